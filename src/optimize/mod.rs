//! Quad mesh optimization, the paper's section 6: vertex smoothing that respects the size
//! field ([`smooth`](self) module docs), then the topological operators quad-vertex merge
//! (Figure 10), doublet collapse (Figure 11) and edge rotation, iterated with smoothing until
//! nothing improves.
//!
//! Every surface entity is optimized independently (in parallel): its 4-node quads are copied
//! into flat arrays ([`local`](self)), optimized, and written back. Curved surfaces are
//! smoothed in 3D and projected back onto the *reference triangulation* (the triangle mesh
//! before recombination), so no CAD kernel is needed; planar surfaces move in their plane.
//! That triangulation depends on the triangles alone ([`PreparedReference`]): the CLI builds
//! it while the recombination runs and passes it to [`optimize_prepared`].
//!
//! Schedule per surface (`run_surface`): 5 smoothing sweeps; up to 4 rounds of (topology
//! pass, 3 sweeps starting from the nodes within 2 quad rings of what the pass changed, or
//! 5 from every node on surfaces under 20k quads); on planar surfaces one global conformal
//! solve that removes shear no node-by-node move can undo, keeping part of each corner's
//! aspect ratio ([`conformal`](self)); a max-min polish of the quads with η < 0.6; 2
//! pattern-search sweeps; 2 mean-η polish sweeps (4 under 20k quads), whose objective has a
//! small size term for τ ([`polish`](self)).
//!
//! Planar surfaces under 20k quads (cheap) whose mean η after the first smoothing is below
//! `ALTERNATIVES_BELOW` (0.84) run three schedules side by side and keep the best: the same
//! with a square-target last conformal solve (β = 0), the plain one; the one above; and
//! topology rounds each followed by the conformal solve, whose squarer quads let the next
//! topology pass find more rotations and merges (measured on the 1e4 square with a hole:
//! d4 83.5 -> 85.0 %, η̄ +0.005). The second, then the third, replaces the kept one only
//! with a higher η̄, η_w at most 0.002 lower and τ (`Local::tau_estimate`, against the
//! reference size field at the nodes' current positions) at most 0.7 point lower than both
//! the kept one and the plain one. More regular vertices follow a graded size field less
//! well: the conformal rounds cost the 1e4 rectangle 1.5 points of τ (rejected) and the
//! square with a hole 0.6 (kept: the polish's size term gained it 0.8 before); the
//! aspect-keeping solve costs even_curves 1e4 0.012 of η_w. On
//! surfaces of 20k quads or more, the topology passes after the first only look at the quads
//! within 2 rings of what the previous pass changed (elsewhere the same searches already
//! failed). For speed the quads are numbered in Morton order of their centroids and the
//! nodes by first use (memory locality), and planar surfaces of 20k quads or more build no
//! spatial index.
//! Measured on a 1e6-triangle rectangle (2 cores, shared machine): CPU time
//! about 3x lower than the schedule that re-smoothed every node in every round.
//!
//! **Validity** ([`valid`](self)): every operator accepts a change only if each quad it
//! touches stays valid (corners strictly inside (0°, 180°) about the reference normal, with
//! a small tolerance, no collapsed edge), or, if the matching left it invalid, gets no
//! worse: doublet collapse, quad-vertex merge, edge rotation and the cleanup's sequences
//! check the quads they write; the smoothing, pattern-search and polish moves check quad by
//! quad when the star holds an invalid or hopeless quad (else keeping the star's worst key
//! is enough); the conformal solve puts back the nodes of the quads its step spoilt. After
//! every stage a gate compares the surface with its start: a quad invalid that was not
//! invalid (as the same nodes) at the start sends the surface back to the last state that
//! passed (the start, the matching's quads, at worst).
//!
//! **Invariant:** nodes classified on points and curves, nodes on the boundary of a
//! surface's quads and nodes used by any element that is not a quad of the surface being
//! optimized never move and are never removed. Quads keep their orientation and the mesh
//! stays conforming; removed quads and nodes disappear from their blocks, every other tag is
//! kept.

// optquality hook: the valence cleanup (rotation sequences) called from `topo::pass`.
mod cleanup;
mod conformal;
mod local;
mod polish;
mod smooth;
// synthetic test meshes (the only user of spade): for tests and examples, not the API
#[doc(hidden)]
pub mod synth;
mod topo;
mod valid;

// an independent mesh checker for the tests (not the API)
#[doc(hidden)]
pub mod check;

pub use local::Stats;

use crate::mesh::{etype, DataKind, Mesh};
use crate::profile::StageTimer;
use crate::quality::locate::TriSurface;
use crate::quality::size::mean_incident_edge_length;
use crate::quality::FlatNodes;
use glam::DVec3;
use local::{csr, Local, NONE};

use rayon::prelude::*;
use std::sync::atomic::{AtomicUsize, Ordering};

/// Options of [`optimize`].
#[derive(Clone, Copy)]
pub struct OptimizeOptions<'a> {
    /// Smoothing sweeps per smoothing phase (`--smooth N`); 0 disables smoothing.
    pub smooth_iterations: usize,
    /// Apply the topological operators (`--no-topology` turns them off).
    pub topology: bool,
    /// Rounds of (topology pass, smoothing) at most; stops earlier when a pass changes
    /// nothing.
    pub max_rounds: usize,
    /// Weight of a quad's opposite corner relative to an edge neighbour in the smoothing
    /// centroid.
    pub diagonal_weight: f64,
    /// Final quality-maximizing sweeps (pattern search on the star's mean η, worst η kept),
    /// preceded by a max-min polish of the quads with η < 0.6; 0 disables both.
    pub angle_sweeps: usize,
    /// Factor applied to the target sizes taken from the reference triangulation: `0.5^N`
    /// after N uniform refinements ([`crate::refine`]), whose quads are 2^N times smaller
    /// than the triangles they came from.
    pub reference_size_scale: f64,
    /// Called with (steps done, total steps) as surfaces progress, from any thread.
    pub progress: Option<&'a (dyn Fn(usize, usize) + Sync)>,
    /// Surfaces left as they are (their nodes count as shared, so neighbours keep them).
    pub skip: &'a [i32],
    /// Where stage times and rollbacks go (see [`crate::profile`]); `None`: nowhere.
    pub trace: Option<&'a crate::profile::Trace>,
}

impl Default for OptimizeOptions<'_> {
    /// Defaults chosen by measurement (`examples/optimize_bench`, a 15k-triangle Gmsh
    /// rectangle and 10k-triangle Delaunay squares): 5 smoothing sweeps give the same η̄ as
    /// 10, 20 or 40; topology rounds converge within 4; 2 final pattern-search sweeps add
    /// about 0.015 to η̄ (4 add 0.004 more at twice the cost).
    fn default() -> Self {
        OptimizeOptions {
            smooth_iterations: 5,
            topology: true,
            max_rounds: 4,
            diagonal_weight: 0.5,
            angle_sweeps: 2,
            reference_size_scale: 1.0,
            progress: None,
            skip: &[],
            trace: None,
        }
    }
}

impl std::fmt::Debug for OptimizeOptions<'_> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("OptimizeOptions")
            .field("smooth_iterations", &self.smooth_iterations)
            .field("topology", &self.topology)
            .field("max_rounds", &self.max_rounds)
            .field("diagonal_weight", &self.diagonal_weight)
            .field("angle_sweeps", &self.angle_sweeps)
            .field("reference_size_scale", &self.reference_size_scale)
            .field("progress", &self.progress.is_some())
            .field("skip", &self.skip)
            .finish()
    }
}

/// Errors of [`optimize`].
#[derive(Debug, thiserror::Error)]
pub enum OptimizeError {
    /// A quad names a node tag that no node block holds.
    #[error("surface {surface}: element {element} names node {node}, which does not exist")]
    MissingNode {
        /// Surface entity tag.
        surface: i32,
        /// Element tag.
        element: u64,
        /// The missing node tag.
        node: u64,
    },
}

/// Counts of what the optimizer did on one surface.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, serde::Serialize)]
pub struct OperationCounts {
    /// Accepted node moves (all smoothing sweeps).
    pub smoothing_moves: usize,
    /// Doublet collapses (Figure 11).
    pub doublet_collapses: usize,
    /// Quad-vertex merges (Figure 10).
    pub quad_vertex_merges: usize,
    /// Edge rotations (the shared edge of two quads turned to another diagonal of their
    /// hexagon).
    pub edge_rotations: usize,
}

/// Before/after figures for one surface.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct SurfaceOptimizeReport {
    /// Surface entity tag.
    pub surface: i32,
    /// Before optimization.
    pub before: Stats,
    /// After optimization.
    pub after: Stats,
    /// What was done.
    pub operations: OperationCounts,
}

/// What [`optimize`] returns: one entry per surface with quads, by increasing tag.
#[derive(Debug, Clone, Default, PartialEq, serde::Serialize)]
pub struct OptimizeReport {
    /// Per surface.
    pub surfaces: Vec<SurfaceOptimizeReport>,
    /// Nodes removed from the mesh.
    pub nodes_removed: usize,
    /// Quads removed from the mesh.
    pub quads_removed: usize,
}

/// Optimizes the 4-node quads of every surface of `mesh` in place (paper section 6).
///
/// `reference` is the triangle mesh before recombination (same surfaces, same entity tags):
/// curved surfaces are projected onto its triangles and the target sizes h come from its
/// edge lengths (mean incident edge length per node, interpolated). A surface without
/// reference triangles uses its own quads, split in two, as the reference.
///
/// Complexity: O(n) per smoothing sweep and per topological pass (flat arrays, CSR
/// adjacency). Fails only when an element names a missing node.
pub fn optimize(
    mesh: &mut Mesh,
    reference: &Mesh,
    opts: &OptimizeOptions,
) -> Result<OptimizeReport, OptimizeError> {
    optimize_prepared(mesh, PreparedReference::new(reference), opts)
}

/// The reference triangulation of every surface of a triangle mesh, prepared for
/// [`optimize_prepared`]: per surface its triangles on compact point indices, the nodal
/// sizes (mean incident edge length) and a triangle at each point. It depends on the
/// triangle mesh only, so it can be built while the recombination runs (the CLI does).
pub struct PreparedReference {
    nodes: FlatNodes,
    /// By increasing surface tag.
    surfaces: Vec<(i32, SurfaceReference)>,
}

/// One surface's part of a [`PreparedReference`].
struct SurfaceReference {
    pts: Vec<DVec3>,
    tris: Vec<[u32; 3]>,
    /// Unscaled mean incident edge length per point.
    nodal: Vec<f64>,
    /// A triangle at each point.
    incident: Vec<u32>,
    /// Flat reference node index -> point index: a dense table when the surface holds a
    /// good share of the mesh's nodes, else a map.
    compact_dense: Vec<u32>,
    compact_sparse: std::collections::HashMap<u32, u32>,
}

impl SurfaceReference {
    /// No triangles.
    fn empty() -> Self {
        SurfaceReference {
            pts: Vec::new(),
            tris: Vec::new(),
            nodal: Vec::new(),
            incident: Vec::new(),
            compact_dense: Vec::new(),
            compact_sparse: Default::default(),
        }
    }

    /// Point index of flat reference node `id`.
    fn compact(&self, id: u32) -> Option<u32> {
        if self.compact_dense.is_empty() {
            self.compact_sparse.get(&id).copied()
        } else {
            self.compact_dense
                .get(id as usize)
                .copied()
                .filter(|&c| c != NONE)
        }
    }
}

impl PreparedReference {
    /// Prepares the triangles (3-node) of every surface of `reference` (in parallel).
    pub fn new(reference: &Mesh) -> Self {
        let nodes = FlatNodes::new(reference);
        let tags = surface_tags(reference, etype::TRI3);
        let surfaces = tags
            .par_iter()
            .map(|&s| (s, surface_reference(reference, &nodes, s)))
            .collect();
        PreparedReference { nodes, surfaces }
    }
}

/// The surfaces of `mesh` with elements of type `element_type`, in increasing tag order.
fn surface_tags(mesh: &Mesh, element_type: u32) -> Vec<i32> {
    let mut tags: Vec<i32> = mesh
        .element_blocks
        .iter()
        .filter(|b| b.entity_dim == 2 && b.element_type == element_type && !b.is_empty())
        .map(|b| b.entity_tag)
        .collect();
    tags.sort_unstable();
    tags.dedup();
    tags
}

/// The reference triangles of surface `s` on compact point indices (first use order).
fn surface_reference(reference: &Mesh, rnodes: &FlatNodes, s: i32) -> SurfaceReference {
    let total = rnodes.coords.len();
    let count: usize = reference
        .element_blocks
        .iter()
        .filter(|b| b.entity_dim == 2 && b.entity_tag == s && b.element_type == etype::TRI3)
        .map(|b| b.len())
        .sum();
    // a dense table when the surface's points (about half its triangles) are a good share
    let dense = total <= 32 * count.max(1);
    let mut compact_dense: Vec<u32> = if dense { vec![NONE; total] } else { Vec::new() };
    let mut compact_sparse: std::collections::HashMap<u32, u32> = Default::default();
    let mut pts: Vec<DVec3> = Vec::new();
    let mut tris: Vec<[u32; 3]> = Vec::with_capacity(count);
    for b in &reference.element_blocks {
        if b.entity_dim != 2 || b.entity_tag != s || b.element_type != etype::TRI3 {
            continue;
        }
        let ids: Vec<[u32; 3]> = (0..b.len())
            .into_par_iter()
            .with_min_len(4096)
            .map(|e| {
                let el = b.element(e);
                [el[0], el[1], el[2]].map(|t| rnodes.get(t).unwrap_or(NONE))
            })
            .collect();
        for t3 in ids {
            if t3.contains(&NONE) {
                continue;
            }
            let mut t = [0u32; 3];
            for (k, &id) in t3.iter().enumerate() {
                let slot = if dense {
                    &mut compact_dense[id as usize]
                } else {
                    compact_sparse.entry(id).or_insert(NONE)
                };
                if *slot == NONE {
                    *slot = pts.len() as u32;
                    pts.push(rnodes.coords[id as usize]);
                }
                t[k] = *slot;
            }
            tris.push(t);
        }
    }
    let nodal = mean_incident_edge_length(&pts, tris.iter().map(|t| &t[..]));
    let mut incident = vec![NONE; pts.len()];
    for (t, tri) in tris.iter().enumerate() {
        for &v in tri {
            incident[v as usize] = t as u32;
        }
    }
    SurfaceReference {
        pts,
        tris,
        nodal,
        incident,
        compact_dense,
        compact_sparse,
    }
}

/// [`optimize`] with the reference triangulation already prepared (from the triangle mesh
/// before recombination).
pub fn optimize_prepared(
    mesh: &mut Mesh,
    prepared: PreparedReference,
    opts: &OptimizeOptions,
) -> Result<OptimizeReport, OptimizeError> {
    let mut tm = StageTimer::new(opts.trace, "optimize setup", 0);
    let flat = FlatNodes::new(mesh);
    tm.lap("flat");
    let surfaces = surface_tags(mesh, etype::QUAD4);
    let owner = node_owners(mesh, &flat, &surfaces)?;
    tm.lap("owners");
    let mut locals = Vec::with_capacity(surfaces.len());
    let mut scratch = vec![NONE; flat.coords.len()];
    for (si, &s) in surfaces.iter().enumerate() {
        if opts.skip.contains(&s) {
            continue;
        }
        let mut l = extract(mesh, &flat, &owner, (si as u32, s), &mut scratch)?;
        l.trace = opts.trace.cloned();
        locals.push(l);
    }
    tm.lap("extract");
    let total = locals.len() * (1 + opts.max_rounds);
    let done = AtomicUsize::new(0);
    let tick = |n: usize| {
        let d = done.fetch_add(n, Ordering::Relaxed) + n;
        if let Some(p) = opts.progress {
            p(d.min(total), total);
        }
    };
    let PreparedReference {
        nodes: refnodes,
        surfaces: mut prepared,
    } = prepared;
    // each surface takes its reference (the quad surfaces are sorted by tag, as are these)
    let refs: Vec<Option<SurfaceReference>> = locals
        .iter()
        .map(|l| {
            prepared
                .binary_search_by_key(&l.surface, |p| p.0)
                .ok()
                .map(|i| std::mem::replace(&mut prepared[i].1, SurfaceReference::empty()))
        })
        .collect();
    let refnodes = &refnodes;
    let results: Vec<(Local, SurfaceOptimizeReport)> = locals
        .into_par_iter()
        .zip(refs)
        .map(|(mut l, sref)| {
            let mut tr = StageTimer::new(opts.trace, "attach", l.surface);
            attach_reference(&mut l, sref, refnodes, opts.reference_size_scale);
            tr.lap("attach_reference");
            tr.done();
            let rep = run_surface(&mut l, opts, &tick);
            (l, rep)
        })
        .collect();
    tm.lap("surfaces");
    let mut report = OptimizeReport::default();
    let mut pending = PendingNodes::new(mesh);
    for (l, rep) in results {
        write_back(mesh, &flat, &l, &mut report, &mut pending);
        report.surfaces.push(rep);
    }
    pending.apply(mesh);
    tm.lap("write back");
    tm.done();
    if report.quads_removed > 0
        || report
            .surfaces
            .iter()
            .any(|s| s.operations.edge_rotations > 0)
    {
        mesh.invalidate_element_data();
    }
    if report.nodes_removed > 0 {
        let before = mesh.data_sections.len();
        mesh.data_sections.retain(|d| d.kind != DataKind::Node);
        if mesh.data_sections.len() < before {
            mesh.warnings
                .push("dropped $NodeData section(s): the optimizer removed nodes".to_string());
        }
    }
    Ok(report)
}

/// Optimizes one surface (see the module docs for the schedule).
fn run_surface(
    l: &mut Local,
    opts: &OptimizeOptions,
    tick: &(dyn Fn(usize) + Sync),
) -> SurfaceOptimizeReport {
    let mut tm = StageTimer::new(opts.trace, "optimize", l.surface);
    l.build_adjacency();
    let before = l.stats();
    // validity: the start state and its invalid quads (valid.rs)
    let mut gate = valid::Gate::new(l);
    tm.lap("adj+stats");
    let mut ops = OperationCounts {
        smoothing_moves: smooth::smooth(l, opts.smooth_iterations, opts.diagonal_weight),
        ..Default::default()
    };
    gate.check(l, true, "smoothing");
    tm.lap("smooth");
    tick(1);
    let polish = opts.angle_sweeps > 0 && opts.smooth_iterations > 0;
    // speed: surfaces already good after the first smoothing skip the alternative schedules
    let small_planar = polish
        && l.planar
        && l.quads.len() < RESMOOTH_ALL_BELOW
        && l.stats().eta_mean < ALTERNATIVES_BELOW;
    // the state before the topology rounds, for the unsheared schedule
    let mut unsheared = (small_planar && opts.topology).then(|| (l.clone(), ops, gate.clone()));
    let mut ticks = 1;
    if small_planar {
        // quality: small planar surfaces try three schedules and keep the best (see
        // `better` and the module docs): finishing with square targets (β = 0), with the
        // aspect-keeping solve, and topology rounds each followed by a conformal solve.
        // speed: the schedules are independent, so they run side by side (each is
        // deterministic, so the kept one does not depend on the thread count)
        let mut plain_ops = ops;
        let (mut plain, ()) = rayon::join(
            || {
                if opts.topology {
                    ticks = topology_rounds(l, opts, &mut ops, &mut tm, tick, false, &mut gate);
                }
                // the square finish starts from the state after the topology rounds
                plain_ops = ops;
                let mut plain = l.clone();
                let mut plain_gate = gate.clone();
                let mut tp = StageTimer::new(opts.trace, "optimize (square finish)", l.surface);
                rayon::join(
                    || {
                        finish(
                            &mut plain,
                            opts,
                            &mut plain_ops,
                            &mut tp,
                            0.0,
                            &mut plain_gate,
                        )
                    },
                    || {
                        finish(
                            l,
                            opts,
                            &mut ops,
                            &mut tm,
                            conformal::KEEP_ASPECT,
                            &mut gate,
                        )
                    },
                );
                tp.done();
                plain
            },
            || {
                if let Some((u, u_ops, u_gate)) = unsheared.as_mut() {
                    let mut tu =
                        StageTimer::new(opts.trace, "optimize (conformal rounds)", u.surface);
                    topology_rounds(u, opts, u_ops, &mut tu, &|_| {}, true, u_gate);
                    finish(u, opts, u_ops, &mut tu, conformal::KEEP_ASPECT, u_gate);
                    tu.done();
                }
            },
        );
        let base = (plain.stats(), plain.tau_estimate());
        let mut best = (l.stats(), l.tau_estimate());
        if !better(&best, &base) {
            std::mem::swap(l, &mut plain);
            ops = plain_ops;
            best = base;
        }
        if let Some((u, u_ops, _)) = unsheared.as_mut() {
            let cand = (u.stats(), u.tau_estimate());
            if better(&cand, &best) && better(&cand, &base) {
                std::mem::swap(l, u);
                ops = *u_ops;
            }
        }
    } else {
        if opts.topology {
            ticks = topology_rounds(l, opts, &mut ops, &mut tm, tick, false, &mut gate);
        }
        finish(
            l,
            opts,
            &mut ops,
            &mut tm,
            conformal::KEEP_ASPECT,
            &mut gate,
        );
    }
    // validity: every schedule ends in a state its gate passed; check the kept one against
    // the start (rolls back to the start, the matching's quads, if it does not pass)
    gate.check(l, false, "optimization");
    tick(1 + opts.max_rounds - ticks);
    let after = l.stats();
    tm.lap("stats");
    tm.done();
    SurfaceOptimizeReport {
        surface: l.surface,
        before,
        after,
        operations: ops,
    }
}

/// True when `cand` (stats, τ estimate) should replace `base`: a higher η̄, η_w at most
/// [`ETA_W_SLACK`] lower and τ at most [`TAU_SLACK`] points lower.
fn better(cand: &(Stats, f64), base: &(Stats, f64)) -> bool {
    cand.0.eta_mean > base.0.eta_mean
        && cand.0.eta_worst >= base.0.eta_worst - ETA_W_SLACK
        && cand.1 >= base.1 - TAU_SLACK
}

/// How much lower η_w a schedule may end with than the plain one and still be chosen.
const ETA_W_SLACK: f64 = 0.002;

/// How many points lower τ ([`Local::tau_estimate`]) a schedule may end with than the plain
/// one and still be chosen (module docs: the 1e4 square with a hole needs 0.6 for its
/// conformal-rounds schedule, the 1e4 rectangle's costs 1.5).
const TAU_SLACK: f64 = 0.7;

/// Tests: `l` in the state the last stages see in the pipeline (the first smoothing and the
/// topology rounds done), with the counts, timer and gate those stages continue with.
#[cfg(test)]
pub(crate) fn after_topology_rounds<'a>(
    l: &mut Local,
    opts: &OptimizeOptions<'a>,
) -> (OperationCounts, StageTimer<'a>, valid::Gate) {
    let mut ops = OperationCounts::default();
    let mut tm = StageTimer::new(opts.trace, "optimize", 0);
    smooth::smooth(l, opts.smooth_iterations, opts.diagonal_weight);
    let mut gate = valid::Gate::new(l);
    topology_rounds(l, opts, &mut ops, &mut tm, &|_| {}, false, &mut gate);
    (ops, tm, gate)
}

/// Up to `opts.max_rounds` rounds of (topology pass, smoothing near the changes), each
/// followed by the conformal solve when `unshear` (the next pass then judges rotations and
/// merges on squarer quads and finds more: d4 +1.5 point on the 1e4 square with a hole).
/// Returns the progress ticks given.
fn topology_rounds(
    l: &mut Local,
    opts: &OptimizeOptions,
    ops: &mut OperationCounts,
    tm: &mut StageTimer<'_>,
    tick: &(dyn Fn(usize) + Sync),
    unshear: bool,
    gate: &mut valid::Gate,
) -> usize {
    let mut ticks = 1;
    // speed: around the changes of a topology pass on a large surface, 3/5 of the sweeps
    let near_its = (opts.smooth_iterations * NEAR_SWEEPS_NUM).div_ceil(5);
    // speed: after a pass, smooth only around what it changed (see `near_changes`), and
    // let the next pass's operators search only there (elsewhere they found nothing;
    // measured on the 1e5 fixtures: d4 within 0.02 point, same η)
    let mut focus: Option<Vec<bool>> = None;
    for _ in 0..opts.max_rounds {
        // the state before the pass, to find what it changed (a pass never adds quads,
        // so the surface size decides before it)
        let snapshot = (l.quads.len() >= RESMOOTH_ALL_BELOW)
            .then(|| (l.quads.clone(), l.alive.clone(), l.pos.clone()));
        let changed = topo::pass(l, ops, focus.as_deref());
        tm.lap("topo");
        if changed == 0 {
            break;
        }
        l.build_adjacency();
        ops.smoothing_moves += match &snapshot {
            None => smooth::smooth(l, opts.smooth_iterations, opts.diagonal_weight),
            Some(snapshot) => {
                let active = near_changes(l, snapshot, RESMOOTH_RINGS);
                focus = Some(active.clone());
                smooth::smooth_near(l, near_its, opts.diagonal_weight, active)
            }
        };
        tm.lap("resmooth");
        if unshear {
            ops.smoothing_moves += conformal::unshear(l, conformal::KEEP_ASPECT);
        }
        gate.check(l, true, "topology round");
        tick(1);
        ticks += 1;
    }
    ticks
}

/// The last stages: conformal solve (keeping `keep_aspect` of the aspect ratios), max-min
/// polish, pattern sweeps, mean-η polish.
fn finish(
    l: &mut Local,
    opts: &OptimizeOptions,
    ops: &mut OperationCounts,
    tm: &mut StageTimer<'_>,
    keep_aspect: f64,
    gate: &mut valid::Gate,
) {
    // quality: undo global shear the node-by-node smoothers cannot (conformal.rs)
    if opts.angle_sweeps > 0 && opts.smooth_iterations > 0 {
        ops.smoothing_moves += conformal::unshear(l, keep_aspect);
        gate.check(l, true, "conformal solve");
        tm.lap("conformal");
    }
    // quality: lift the worst quads (max-min) first; the pattern search after it keeps
    // every star's worst key, so η_w stays
    if opts.angle_sweeps > 0 {
        ops.smoothing_moves += smooth::polish_worst(l, 4);
        gate.check(l, true, "max-min polish");
        tm.lap("polish_worst");
        ops.smoothing_moves += smooth::optimize_angles(l, opts.angle_sweeps);
        gate.check(l, true, "pattern search");
        tm.lap("angles");
    }
    // then maximize the mean η, the worst of every star kept (polish.rs)
    if opts.smooth_iterations > 0 {
        let sweeps = if l.quads.len() < RESMOOTH_ALL_BELOW {
            polish::MEAN_SWEEPS_SMALL
        } else {
            polish::MEAN_SWEEPS
        };
        ops.smoothing_moves += polish::polish_mean(l, sweeps);
        gate.check(l, true, "mean polish");
        tm.lap("polish_mean");
    }
}

/// After a topological pass, smoothing starts from the nodes within this many quad rings of
/// the changes (measured on 1.6e5 and 1e6-triangle rectangles: η̄ within 0.001 of smoothing
/// every node, at a fraction of the work).
const RESMOOTH_RINGS: usize = 2;

/// Sweeps of the smoothing around a topology pass's changes on surfaces of
/// [`RESMOOTH_ALL_BELOW`] quads or more, in fifths of `smooth_iterations` (rounded up: 3 of
/// the default 5). Measured on the 1e5 fixtures: 3 keep η_w, η̄, τ and d4 within 0.001 /
/// 0.1 point; 2 or 1 lose up to 0.017 of η_w or 0.003 of η̄ on some.
const NEAR_SWEEPS_NUM: usize = 3;

/// Surfaces with fewer quads re-smooth every node after each topological pass: cheap there,
/// and measured on the 1e5-triangle cad_solid fixture (14 curved surfaces of 500 to 5,000
/// quads) local re-smoothing alone loses 0.008 of η̄ (0.840 -> 0.831).
const RESMOOTH_ALL_BELOW: usize = 20_000;

/// Small planar surfaces try the alternative schedules (module docs) only when their mean η
/// after the first smoothing is below this. Measured on the 1e4/1e5 fixtures: surfaces at
/// 0.84 or more there (cad_solid 1e5's largest faces at 0.844-0.862, even_curves 1e5's
/// 18k-quad face at 0.915) gained at most 0.0015 of η̄ from them, for most of their time;
/// the surfaces that need them start at 0.70-0.84 (square_hole 1e4: 0.72, +0.007).
const ALTERNATIVES_BELOW: f64 = 0.84;

/// Nodes within `rings` quad rings of what a topological pass changed, given the quads,
/// liveness and positions before it: nodes of quads that were rewritten, created or removed,
/// and nodes that moved. Needs a current adjacency.
fn near_changes(
    l: &Local,
    (quads, alive, pos): &(Vec<[u32; 4]>, Vec<bool>, Vec<DVec3>),
    rings: usize,
) -> Vec<bool> {
    let n = l.pos.len();
    let mut mark = vec![false; n];
    for (q, quad) in l.quads.iter().enumerate() {
        let same = quads.get(q) == Some(quad) && alive.get(q) == Some(&l.alive[q]);
        if !same {
            for &v in quad.iter().chain(quads.get(q).into_iter().flatten()) {
                mark[v as usize] = true;
            }
        }
    }
    for (v, m) in mark.iter_mut().enumerate() {
        if pos.get(v) != Some(&l.pos[v]) {
            *m = true;
        }
    }
    grow_rings(l, &mut mark, rings);
    mark
}

/// Adds to `mark` every node within `rings` quad rings of a marked node. Needs a current
/// adjacency.
pub(crate) fn grow_rings(l: &Local, mark: &mut [bool], rings: usize) {
    let mut frontier: Vec<u32> = (0..l.pos.len() as u32)
        .filter(|&v| mark[v as usize])
        .collect();
    for _ in 0..rings {
        let mut next = Vec::new();
        for &v in &frontier {
            for &q in l.star(v) {
                for &w in &l.quads[q as usize] {
                    if !mark[w as usize] {
                        mark[w as usize] = true;
                        next.push(w);
                    }
                }
            }
        }
        frontier = next;
    }
}

const UNSET: u32 = u32::MAX;
const SHARED: u32 = u32::MAX - 1;

/// For every flat node: the index (in `surfaces`) of the only surface whose quads use it, or
/// `SHARED` when anything else uses it (other elements, other surfaces, a point/curve node
/// block), or `UNSET` when unused.
fn node_owners(mesh: &Mesh, flat: &FlatNodes, surfaces: &[i32]) -> Result<Vec<u32>, OptimizeError> {
    let mut owner = vec![UNSET; flat.coords.len()];
    for (bi, b) in mesh.node_blocks.iter().enumerate() {
        if b.entity_dim != 2 {
            owner[flat.offsets[bi]..flat.offsets[bi] + b.tags.len()].fill(SHARED);
        }
    }
    for b in &mesh.element_blocks {
        let key = if b.entity_dim == 2 && b.element_type == etype::QUAD4 {
            surfaces
                .binary_search(&b.entity_tag)
                .map_or(SHARED, |i| i as u32)
        } else {
            SHARED
        };
        for (k, &t) in b.nodes.iter().enumerate() {
            let Some(i) = flat.get(t) else {
                let per = b.nodes_per_element().max(1);
                return Err(OptimizeError::MissingNode {
                    surface: b.entity_tag,
                    element: b.tags.get(k / per).copied().unwrap_or(0),
                    node: t,
                });
            };
            let o = &mut owner[i as usize];
            *o = match *o {
                UNSET => key,
                x if x == key => key,
                _ => SHARED,
            };
        }
    }
    Ok(owner)
}

/// Copies surface `s`'s quads into a [`Local`] (with its adjacency built). `scratch` has one
/// entry per flat node, all [`NONE`], and is left so.
fn extract(
    mesh: &Mesh,
    flat: &FlatNodes,
    owner: &[u32],
    (sid, s): (u32, i32),
    scratch: &mut [u32],
) -> Result<Local, OptimizeError> {
    let mut quads = Vec::new();
    let mut origin = Vec::new();
    for (bi, b) in mesh.element_blocks.iter().enumerate() {
        if b.entity_dim != 2 || b.entity_tag != s || b.element_type != etype::QUAD4 {
            continue;
        }
        for e in 0..b.len() {
            let mut q = [0u32; 4];
            for (k, &t) in b.element(e).iter().enumerate() {
                q[k] = flat.get(t).ok_or(OptimizeError::MissingNode {
                    surface: s,
                    element: b.tags[e],
                    node: t,
                })?;
            }
            quads.push(q);
            origin.push((bi as u32, e as u32));
        }
    }
    // Memory locality (measured: 2-3x faster sweeps at 1e6 triangles): quads in Morton order
    // of their centroids, nodes numbered by first use in that order.
    let order = morton_order(&quads, &flat.coords);
    let origin: Vec<(u32, u32)> = order.iter().map(|&q| origin[q as usize]).collect();
    let mut global: Vec<u32> = Vec::new();
    let quads: Vec<[u32; 4]> = order
        .iter()
        .map(|&q| {
            quads[q as usize].map(|g| {
                let slot = &mut scratch[g as usize];
                if *slot == NONE {
                    *slot = global.len() as u32;
                    global.push(g);
                }
                *slot
            })
        })
        .collect();
    for &g in &global {
        scratch[g as usize] = NONE;
    }
    let node_tags: Vec<u64> = global
        .iter()
        .map(|&g| {
            let b = flat.offsets.partition_point(|&o| o <= g as usize) - 1;
            mesh.node_blocks[b].tags[g as usize - flat.offsets[b]]
        })
        .collect();
    let n = global.len();
    let pos: Vec<DVec3> = global.iter().map(|&g| flat.coords[g as usize]).collect();
    let mut fixed: Vec<bool> = global.iter().map(|&g| owner[g as usize] != sid).collect();
    let (start, adj) = csr(n, &quads, |_| true);
    // boundary of the quad set (edges not shared by exactly two quads), and degenerate quads;
    // an edge's count is the same seen from both ends, so each node only marks itself
    let on_boundary: Vec<bool> = (0..n)
        .into_par_iter()
        .with_min_len(4096)
        .map_init(Vec::new, |around: &mut Vec<u32>, v| {
            around.clear();
            for &q in &adj[start[v] as usize..start[v + 1] as usize] {
                let quad = &quads[q as usize];
                for k in 0..4 {
                    if quad[k] == v as u32 {
                        around.push(quad[(k + 1) % 4]);
                        around.push(quad[(k + 3) % 4]);
                    }
                }
            }
            around.sort_unstable();
            let mut i = 0;
            while i < around.len() {
                let mut j = i + 1;
                while j < around.len() && around[j] == around[i] {
                    j += 1;
                }
                if j - i != 2 || around[i] == v as u32 {
                    return true;
                }
                i = j;
            }
            false
        })
        .collect();
    for (f, b) in fixed.iter_mut().zip(on_boundary) {
        *f |= b;
    }
    for q in &quads {
        let mut sorted = *q;
        sorted.sort_unstable();
        if sorted.windows(2).any(|w| w[0] == w[1]) {
            for &v in q {
                fixed[v as usize] = true;
            }
        }
    }
    // normals: sum of incident quad (Newell) normals; a plane if every node is on it
    let mut nrm = vec![DVec3::ZERO; n];
    let mut total = DVec3::ZERO;
    for q in &quads {
        let p = q.map(|v| pos[v as usize]);
        let qn = (p[2] - p[0]).cross(p[3] - p[1]);
        total += qn;
        for &v in q {
            nrm[v as usize] += qn;
        }
    }
    let centre = pos.iter().copied().sum::<DVec3>() / n.max(1) as f64;
    let (lo, hi) = pos.iter().fold(
        (DVec3::splat(f64::INFINITY), DVec3::splat(f64::NEG_INFINITY)),
        |(lo, hi), &p| (lo.min(p), hi.max(p)),
    );
    let diag = (hi - lo).length();
    let plane = total.normalize_or_zero();
    let planar = plane != DVec3::ZERO
        && pos
            .iter()
            .all(|&p| (p - centre).dot(plane).abs() <= 1e-9 * diag);
    for v in nrm.iter_mut() {
        *v = if planar { plane } else { v.normalize_or_zero() };
    }
    Ok(Local {
        surface: s,
        h: vec![1.0; n],
        tri: vec![NONE; n],
        removed: vec![false; n],
        alive: vec![true; quads.len()],
        pos,
        nrm,
        fixed,
        global,
        tags: node_tags,
        quads,
        origin,
        planar,
        reference: None,
        ref_sizes: Vec::new(),
        start,
        adj,
        qn: Vec::new(),
        hopeless: Vec::new(),
        colours: Vec::new(),
        sweep_ready: false,
        trace: None,
    })
}

/// Quad indices sorted by the Morton (Z-order) code of their centroids (flat node indices in
/// `quads`), for memory locality of the sweeps.
fn morton_order(quads: &[[u32; 4]], coords: &[DVec3]) -> Vec<u32> {
    let centroid = |q: &[u32; 4]| q.iter().map(|&v| coords[v as usize]).sum::<DVec3>() * 0.25;
    let (lo, hi) = quads.iter().fold(
        (DVec3::splat(f64::INFINITY), DVec3::splat(f64::NEG_INFINITY)),
        |(lo, hi), q| {
            let c = centroid(q);
            (lo.min(c), hi.max(c))
        },
    );
    let ext = (hi - lo).max_element();
    let scale = if ext > 0.0 && ext.is_finite() {
        ((1u64 << 21) - 1) as f64 / ext
    } else {
        0.0
    };
    // spreads the low 21 bits of x to every third bit
    let spread = |x: u64| {
        let mut x = x & 0x1f_ffff;
        x = (x | x << 32) & 0x1f_0000_0000_ffff;
        x = (x | x << 16) & 0x1f_0000_ff00_00ff;
        x = (x | x << 8) & 0x100f_00f0_0f00_f00f;
        x = (x | x << 4) & 0x10c3_0c30_c30c_30c3;
        x = (x | x << 2) & 0x1249_2492_4924_9249;
        x
    };
    let mut keyed: Vec<(u64, u32)> = quads
        .iter()
        .enumerate()
        .map(|(i, q)| {
            let c = (centroid(q) - lo) * scale;
            let k = |x: f64| if x.is_finite() { x.max(0.0) as u64 } else { 0 };
            let code = spread(k(c.x)) | spread(k(c.y)) << 1 | spread(k(c.z)) << 2;
            (code, i as u32)
        })
        .collect();
    keyed.par_sort_unstable();
    keyed.into_iter().map(|(_, i)| i).collect()
}

/// Attaches the surface's reference triangulation (`sref`, the prepared triangles of the
/// same surface entity, else the quads split in two), locates every node on it and sets the
/// sizes (those from reference triangles times `size_scale`).
/// Planar surfaces need no projection: their nodes missing from the reference take the mean
/// size of their matched neighbours and no spatial index is built.
fn attach_reference(
    l: &mut Local,
    sref: Option<SurfaceReference>,
    rnodes: &FlatNodes,
    size_scale: f64,
) {
    let mut sref = sref.unwrap_or_else(SurfaceReference::empty);
    let mut pts = std::mem::take(&mut sref.pts);
    let mut tris = std::mem::take(&mut sref.tris);
    let incident = std::mem::take(&mut sref.incident);
    let ref_nodal = std::mem::take(&mut sref.nodal);
    let compact = |id: u32| sref.compact(id);
    let own = tris.is_empty();
    if own {
        // quad edges are ~h; the split diagonals (√2 h) would inflate the mean: use the
        // quads' own edges instead.
        let qh = mean_incident_edge_length(&l.pos, l.quads.iter().map(|q| &q[..]));
        l.h = qh.iter().map(|&x| if x > 0.0 { x } else { 1.0 }).collect();
        if l.planar {
            return;
        }
        pts = l.pos.clone();
        tris = Vec::with_capacity(2 * l.quads.len());
        for q in &l.quads {
            tris.push([q[0], q[1], q[2]]);
            tris.push([q[0], q[2], q[3]]);
        }
    }
    let nodal: Vec<f64> = if own {
        mean_incident_edge_length(&pts, tris.iter().map(|t| &t[..]))
    } else {
        let mut h = ref_nodal;
        h.iter_mut().for_each(|h| *h *= size_scale);
        h
    };
    // a node of the reference (same tag, same place) is located without a search
    let mut unmatched = Vec::new();
    if own {
        unmatched.extend(0..l.pos.len());
    } else {
        let found: Vec<Option<u32>> = (0..l.pos.len())
            .into_par_iter()
            .with_min_len(4096)
            .map(|v| {
                rnodes
                    .get(l.tags[v])
                    .and_then(|id| compact(id).filter(|_| rnodes.coords[id as usize] == l.pos[v]))
                    .filter(|&i| incident[i as usize] != NONE)
            })
            .collect();
        for (v, hit) in found.into_iter().enumerate() {
            match hit {
                Some(i) => {
                    l.tri[v] = incident[i as usize];
                    let h = nodal[i as usize];
                    l.h[v] = if h > 0.0 { h } else { 1.0 };
                }
                None => unmatched.push(v),
            }
        }
    }
    if l.planar {
        // nothing to project on: a missing node takes its matched neighbours' mean size,
        // in rounds outward from the matched nodes (after uniform refinement most nodes
        // are new, some several rings away from any reference node)
        let mut matched = vec![true; l.pos.len()];
        for &v in &unmatched {
            matched[v] = false;
        }
        let mut left = unmatched;
        while !left.is_empty() {
            let mut assigned = Vec::new();
            let mut rest = Vec::new();
            for &v in &left {
                let (mut sum, mut cnt) = (0.0, 0);
                for &q in l.star(v as u32) {
                    for &w in &l.quads[q as usize] {
                        if matched[w as usize] {
                            sum += l.h[w as usize];
                            cnt += 1;
                        }
                    }
                }
                if cnt > 0 {
                    l.h[v] = sum / cnt as f64;
                    assigned.push(v);
                } else {
                    rest.push(v);
                }
            }
            if assigned.is_empty() {
                break;
            }
            for v in assigned {
                matched[v] = true;
            }
            left = rest;
        }
        if !own && l.quads.len() < RESMOOTH_ALL_BELOW {
            // small surfaces choose between schedules by τ (`Local::tau_estimate`)
            l.reference = Some(TriSurface::new(pts, tris));
            l.ref_sizes = nodal;
        }
        return;
    }
    let surface = TriSurface::new(pts, tris);
    for v in unmatched {
        if let Some(hit) = surface.closest(l.pos[v]) {
            l.tri[v] = hit.tri;
            if !own {
                let t = surface.triangle(hit.tri);
                let h: f64 = (0..3).map(|k| hit.bary[k] * nodal[t[k] as usize]).sum();
                l.h[v] = if h > 0.0 { h } else { 1.0 };
            }
        }
    }
    l.reference = Some(surface);
    if !own {
        l.ref_sizes = nodal;
    }
}

/// Removes the entries at the (sorted, distinct) positions `rm` from `v`, keeping order.
fn remove_sorted<T>(v: &mut Vec<T>, rm: &[usize]) {
    let mut k = 0;
    let mut idx = 0;
    v.retain(|_| {
        let keep = rm.get(k) != Some(&idx);
        if !keep {
            k += 1;
        }
        idx += 1;
        keep
    });
}

/// Writes node positions, removed nodes and changed/removed quads back into `mesh`.
/// Node changes of all surfaces, applied after every surface has been written back: a node
/// block can hold nodes of several surfaces (e.g. new nodes on a curve-less edge shared by
/// two surfaces), and removing nodes shifts the flat indices the other surfaces use.
pub(crate) struct PendingNodes {
    removed_by_block: Vec<Vec<usize>>,
    moved_blocks: Vec<bool>,
}

impl PendingNodes {
    pub(crate) fn new(mesh: &Mesh) -> Self {
        PendingNodes {
            removed_by_block: vec![Vec::new(); mesh.node_blocks.len()],
            moved_blocks: vec![false; mesh.node_blocks.len()],
        }
    }

    /// Removes the nodes marked removed; drops the parametric coordinates of blocks whose
    /// nodes moved (they no longer match the coordinates).
    pub(crate) fn apply(self, mesh: &mut Mesh) {
        for (b, mut rm) in self.removed_by_block.into_iter().enumerate() {
            if rm.is_empty() && !self.moved_blocks[b] {
                continue;
            }
            let block = &mut mesh.node_blocks[b];
            if block.params.is_some() {
                block.params = None;
                mesh.warnings.push(format!(
                    "parametric coordinates of node block ({}, {}) dropped: nodes moved",
                    block.entity_dim, block.entity_tag
                ));
            }
            if rm.is_empty() {
                continue;
            }
            rm.sort_unstable();
            remove_sorted(&mut block.tags, &rm);
            remove_sorted(&mut block.coords, &rm);
        }
    }
}

/// Writes surface `l` back: moved coordinates and the quads in place, dead quads removed;
/// removed nodes go to `pending` (see [`PendingNodes`]).
pub(crate) fn write_back(
    mesh: &mut Mesh,
    flat: &FlatNodes,
    l: &Local,
    report: &mut OptimizeReport,
    pending: &mut PendingNodes,
) {
    // nodes: flat index -> (block, index)
    let block_of = |g: usize| {
        let b = flat.offsets.partition_point(|&o| o <= g) - 1;
        (b, g - flat.offsets[b])
    };
    let tag_of = |g: u32| {
        let (b, i) = block_of(g as usize);
        mesh.node_blocks[b].tags[i]
    };
    let tags: Vec<u64> = l.global.iter().map(|&g| tag_of(g)).collect();
    for v in 0..l.pos.len() {
        if l.fixed[v] {
            continue;
        }
        let (b, i) = block_of(l.global[v] as usize);
        if l.removed[v] {
            pending.removed_by_block[b].push(i);
            report.nodes_removed += 1;
        } else if mesh.node_blocks[b].coords[i] != l.pos[v].to_array() {
            mesh.node_blocks[b].coords[i] = l.pos[v].to_array();
            pending.moved_blocks[b] = true;
        }
    }
    // quads
    let mut dead_by_block: Vec<Vec<u32>> = vec![Vec::new(); mesh.element_blocks.len()];
    for (q, quad) in l.quads.iter().enumerate() {
        let (b, e) = l.origin[q];
        if !l.alive[q] {
            dead_by_block[b as usize].push(e);
            report.quads_removed += 1;
            continue;
        }
        let block = &mut mesh.element_blocks[b as usize];
        let base = e as usize * 4;
        for k in 0..4 {
            block.nodes[base + k] = tags[quad[k] as usize];
        }
    }
    for (b, mut dead) in dead_by_block.into_iter().enumerate() {
        if dead.is_empty() {
            continue;
        }
        dead.sort_unstable();
        let block = &mut mesh.element_blocks[b];
        let n = block.len();
        let mut tags_out = Vec::with_capacity(n - dead.len());
        let mut nodes_out = Vec::with_capacity(4 * (n - dead.len()));
        let mut parts_out = block.partitions.as_ref().map(|_| Vec::new());
        let mut k = 0;
        for e in 0..n {
            if dead.get(k) == Some(&(e as u32)) {
                k += 1;
                continue;
            }
            tags_out.push(block.tags[e]);
            nodes_out.extend_from_slice(block.element(e));
            if let (Some(out), Some(p)) = (parts_out.as_mut(), block.partitions.as_ref()) {
                out.push(p.get(e).cloned().unwrap_or_default());
            }
        }
        block.tags = tags_out;
        block.nodes = nodes_out;
        block.partitions = parts_out;
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::optimize::cleanup::tests::local_of;
    use crate::optimize::synth;
    use crate::quality::size::ReferenceSize;

    /// On a graded reference (x squared), after every free node moved, the τ estimate of a
    /// small planar surface uses the reference field at the nodes' new positions: it equals
    /// an independent computation with `ReferenceSize::at`, and differs from the one with
    /// the sizes where the nodes started.
    #[test]
    fn the_tau_estimate_follows_the_reference_field_to_where_nodes_moved() {
        let (tris, quads) = (1u64..40)
            .find_map(|seed| {
                let mut t = synth::delaunay_square(14, 1.0, 0.3, seed);
                for p in t.points.iter_mut() {
                    p.x *= p.x;
                }
                synth::pair_optimal(&t).map(|q| (t, q))
            })
            .expect("a matchable seed");
        let reference = synth::to_mesh(&tris);
        let (_, mut l) = local_of(&synth::to_mesh(&quads));
        let rnodes = FlatNodes::new(&reference);
        let sref = surface_reference(&reference, &rnodes, l.surface);
        attach_reference(&mut l, Some(sref), &rnodes, 1.0);
        assert!(l.planar && !l.ref_sizes.is_empty() && l.reference.is_some());
        let start_sizes = l.h.clone();
        for v in 0..l.pos.len() {
            if !l.fixed[v] {
                l.pos[v].x += 0.3 * l.h[v];
            }
        }
        let field = ReferenceSize::from_mesh(&reference).expect("triangles");
        let tau = |h: &dyn Fn(usize) -> f64| {
            let (mut sum, mut n) = (0.0, 0);
            for quad in &l.quads {
                for k in 0..4 {
                    let (a, b) = (quad[k] as usize, quad[(k + 1) % 4] as usize);
                    let (ha, hb) = (h(a), h(b));
                    let inv = if (hb - ha).abs() <= 1e-9 * (ha + hb) {
                        2.0 / (ha + hb)
                    } else {
                        (hb / ha).ln() / (hb - ha)
                    };
                    let lh = l.pos[a].distance(l.pos[b]) * inv;
                    sum += lh.min(1.0 / lh) - 1.0;
                    n += 1;
                }
            }
            100.0 * (sum / n as f64).exp()
        };
        let moved = tau(&|v| field.at(l.pos[v]));
        let stale = tau(&|v| start_sizes[v]);
        let est = l.tau_estimate();
        assert!(
            (est - moved).abs() < 1e-6,
            "estimate {est}, field at new positions {moved}"
        );
        assert!(
            (est - stale).abs() > 0.1,
            "estimate {est}, start sizes {stale}"
        );
    }
}
