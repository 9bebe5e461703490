//! Quad mesh optimization, the paper's section 6: vertex smoothing that respects the size
//! field ([`smooth`](self) module docs), then the topological operators quad-vertex merge
//! (Figure 10), doublet collapse (Figure 11) and edge rotation, iterated with smoothing until
//! nothing improves.
//!
//! Every surface entity is optimized independently (in parallel): its 4-node quads are copied
//! into flat arrays (`extract`, into a [`local`](self) `Local`), optimized (`schedule`), and
//! written back (`extract`). Curved surfaces are smoothed in 3D and projected back onto the
//! *reference triangulation* (the triangle mesh before recombination), so no CAD kernel is
//! needed; planar surfaces move in their plane. That triangulation depends on the triangles
//! alone ([`PreparedReference`], `reference`): the pipeline builds it while the recombination
//! runs and passes it to [`optimize_prepared`].
//!
//! Files: this one holds the options, reports and entry points; `schedule` the stages of
//! one surface; `extract` the copy into flat arrays and the write-back; `reference` the
//! prepared reference triangulation and its attachment to a surface; `local` the flat
//! arrays and star evaluation; `smooth`, `topo`, `cleanup`, `conformal`, `polish` the stages
//! (`halves` runs a topology pass of a large surface on its two halves side by side);
//! `valid` the optimizer's validity rule and the per-surface gate; `check` and `synth` serve
//! the tests.
//!
//! Schedule per surface (`schedule::run_surface`): smoothing sweeps; up to
//! `max_rounds` rounds of (topology pass, smoothing near what the pass changed, or of every
//! node on small surfaces); on planar surfaces one global conformal solve that removes shear
//! no node-by-node move can undo, keeping part of each corner's aspect ratio
//! ([`conformal`](self)); a max-min polish of the quads with η < 0.6; pattern-search sweeps;
//! mean-η polish sweeps, whose objective has a small size term for τ ([`polish`](self));
//! on surfaces of 10^4 quads or more (and every surface of a mesh of 2^19 triangles or
//! more), a share of the sweeps in the first smoothing and near the changes, half the
//! pattern sweeps, one mean polish and the max-min polish once more at the end.
//! Small planar surfaces with a low mean η after the first smoothing choose among three
//! schedules (square-target finish, the one above, topology rounds each followed by the
//! conformal solve): under 1,000 quads, or when the surface holds half of the reference's
//! triangles or more, the three run side by side and the best by η̄, η_w and estimated τ
//! is kept (`schedule::better`; from 1,000 quads they are compared after the max-min polish
//! and only the kept one runs the pattern and mean-η sweeps; the one with the conformal
//! solve after each round starts from the plain one's first pass and smoothing, which are
//! the same); other such surfaces run one of them, chosen by their mean η after the first
//! smoothing. On a mesh of 2,000 reference triangles or more, a surface under 1,000 quads
//! that is not the main one first runs only the schedule its mean η chooses, keeping the
//! states the other two start from; once every surface has run, those whose worst quad is
//! within 0.02 of the mesh's worst (over the surfaces left with no invalid quad) run the
//! other two and keep the best of three, exactly as side by side
//! (`schedule::finish_deferred`); the others keep the chosen one. That worst quad comes
//! with the options when an earlier call measured it ([`OptimizeOptions::trial_worst`]).
//! Only the surfaces that may try the three keep a planar reference (for the τ
//! estimates), and a τ is estimated only when the η terms of a comparison hold. The
//! choices read the surface, the reference and that worst quad, and each schedule is
//! deterministic, so the result does not depend on the thread count. Surfaces are started
//! largest first, each on the next idle thread. On large surfaces the topology passes after the first only look near what the previous pass
//! changed, and the rounds stop after a pass that changed under 1 % of the quads; from 2^15
//! quads each pass runs on the two halves of the quads side by side, then on a band along
//! their seam (deterministic, but not the serial pass's result). Quads are
//! numbered in Morton order of their centroids and nodes by first use.
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
mod extract;
mod halves;
mod local;
mod multigrid;
mod polish;
mod reference;
mod schedule;
mod smooth;
mod topo;
mod valid;

internal! {
    // synthetic test meshes (the only user of spade), for the tests and examples
    #[cfg(any(test, feature = "testing"))]
    mod synth;
    // an independent quad-mesh checker, for the tests
    #[cfg(any(test, feature = "testing"))]
    mod check;
}

/// Code shared by the optimizer's unit tests.
#[cfg(test)]
pub(crate) mod test_util {
    use glam::DVec3;

    /// `f` run in a pool of `threads` threads.
    pub(crate) fn on_threads<T: Send>(threads: usize, f: impl FnOnce() -> T + Send) -> T {
        rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .expect("a thread pool")
            .install(f)
    }

    /// The bits of every coordinate of `pos`, to compare positions exactly.
    pub(crate) fn bits(pos: &[DVec3]) -> Vec<[u64; 3]> {
        pos.iter().map(|p| p.to_array().map(f64::to_bits)).collect()
    }
}

pub(crate) use extract::on_one_plane;
pub use local::Stats;
pub use reference::PreparedReference;

use crate::mesh::NodeTable;
use crate::mesh::{etype, DataKind, Mesh};
use crate::profile::StageTimer;
use extract::{extract, node_owners, write_back, NodePlaces, PendingNodes};
use local::{Local, NONE};
use reference::{attach_reference, SurfaceReference};
use rayon::prelude::*;
#[cfg(test)]
use schedule::run_surface;
use schedule::{finish_deferred, run_surface_deferring};

use std::sync::atomic::{AtomicU64, AtomicUsize, Ordering};

/// Options of [`optimize`].
#[derive(Clone, Copy)]
pub struct OptimizeOptions<'a> {
    /// Smoothing sweeps per smoothing phase (`--smooth N`); 0 disables smoothing. Surfaces
    /// of 10,000 quads or more, and every surface of a mesh of 2^19 triangles or more, run
    /// a share of them in the first smoothing and after each topology pass (`schedule.rs`).
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
    /// Called with the [`crate::progress::Stage::Optimize`] progress as surfaces progress (units:
    /// each surface's quads times the steps of its schedule), from any thread, a few times
    /// per surface; `done` may arrive out of order from several threads.
    pub progress: Option<&'a (dyn Fn(crate::progress::Progress) + Sync)>,
    /// Surfaces left as they are (their nodes count as shared, so neighbours keep them).
    pub skip: &'a [i32],
    /// Where stage times and rollbacks go (see [`crate::profile`]); `None`: nowhere.
    pub trace: Option<&'a crate::profile::Trace>,
    /// Precondition the conformal solve of surfaces of 4,096 free nodes or more by an
    /// aggregation multigrid (on by default) instead of the diagonal, which ends further
    /// from the solve's minimizer in more time.
    pub conformal_multigrid: bool,
    /// The surfaces (sorted tags) where, if curved, the corner at a node the reference does
    /// not have (split, duplicated and refined nodes) is held to turn positively about the
    /// reference triangles that node touches where it is, as the validity gate measures it
    /// (none by default; the pipeline's fallback names a surface once the optimizer turned
    /// a quad there that the validity gate refuses: see `valid`).
    pub located_surfaces: &'a [i32],
    /// The mesh's worst quad η after every surface's first schedule, as an earlier call
    /// for the same input reported it ([`OptimizeReport::trial_worst`]); `None`: measured
    /// in this call. Small planar surfaces that may try three schedules run the one their
    /// mean η chooses, and the other two only where it leaves a worst quad within 0.02
    /// (`schedule::TRIAL_MARGIN`) of this (`schedule::finish_deferred`). A
    /// run passes every call after its first the first one's, so that a surface
    /// optimized from the same quads in two calls ends the same.
    pub trial_worst: Option<f64>,
}

impl Default for OptimizeOptions<'_> {
    /// Defaults: 5 smoothing sweeps, topology on for at most 4 rounds, diagonal
    /// weight 0.5, 2 final pattern-search sweeps, no size scale. They were chosen by
    /// measurement with `examples/optimize_bench` (figures in BENCHMARKS.md, "Measurements
    /// behind the defaults").
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
            conformal_multigrid: true,
            located_surfaces: &[],
            trial_worst: None,
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
            .field("trial_worst", &self.trial_worst)
            .finish()
    }
}

/// Errors of the quad optimization.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
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

/// What the quad optimization returns: one entry per surface with quads, by increasing tag.
#[derive(Debug, Clone, Default, PartialEq, serde::Serialize)]
pub struct OptimizeReport {
    /// Per surface.
    pub surfaces: Vec<SurfaceOptimizeReport>,
    /// Nodes removed from the mesh.
    pub nodes_removed: usize,
    /// Quads removed from the mesh.
    pub quads_removed: usize,
    /// The worst quad η after every optimized surface's first schedule, over the surfaces
    /// with no invalid quad (infinite when there is none), with which this call chose the
    /// surfaces that try three schedules (the options' `trial_worst`, or measured here
    /// when that was `None`); `None` on a mesh of under 2,000 reference triangles
    /// (`schedule::TRIAL_BUDGET_FROM`), where every such surface tries them.
    pub trial_worst: Option<f64>,
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
#[cfg(any(test, feature = "testing"))]
pub fn optimize(
    mesh: &mut Mesh,
    reference: &Mesh,
    opts: &OptimizeOptions,
) -> Result<OptimizeReport, OptimizeError> {
    optimize_prepared(mesh, PreparedReference::new(reference), opts)
}
/// The surfaces of `mesh` with elements of type `element_type`, in increasing tag order.
///
/// Sorted because surfaces are found by binary search: a node's owning surface
/// (`extract::node_owners`) and each quad surface's reference triangles (the prepared
/// reference is listed by the same order). The order does not reach the output: every
/// surface writes back into its own blocks, whatever the order. (Recombination's list keeps
/// file order instead, see `recombine`.)
pub(super) fn surface_tags(mesh: &Mesh, element_type: u32) -> Vec<i32> {
    mesh.sorted_surfaces(|b| b.element_type == element_type && !b.is_empty())
}
/// The diagonal of the bounding box of `coords` (1 when empty or flat to a point), as the
/// validity gate measures a mesh's extent.
fn extent(coords: &[glam::DVec3]) -> f64 {
    use glam::DVec3;
    let (lo, hi) = coords.iter().fold(
        (DVec3::splat(f64::INFINITY), DVec3::splat(f64::NEG_INFINITY)),
        |(lo, hi), &c| (lo.min(c), hi.max(c)),
    );
    let d = (hi - lo).length();
    if d.is_finite() && d > 0.0 {
        d
    } else {
        1.0
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
    let flat = NodeTable::new(mesh);
    tm.lap("flat");
    let surfaces = surface_tags(mesh, etype::QUAD4);
    let owner = node_owners(mesh, &flat, &surfaces)?;
    tm.lap("owners");
    let mut locals = Vec::with_capacity(surfaces.len());
    let mut scratch = vec![NONE; flat.coords.len()];
    let tie = 1e-8 * extent(&flat.coords);
    for (si, &s) in surfaces.iter().enumerate() {
        if opts.skip.contains(&s) {
            continue;
        }
        let mut l = extract(mesh, &flat, &owner, (si as u32, s), &mut scratch)?;
        l.trace = opts.trace.cloned();
        l.tie = tie;
        l.located_turns = opts.located_surfaces.binary_search(&s).is_ok();
        locals.push(l);
    }
    // memory: through the surfaces' optimization, only where each node lives
    drop((owner, scratch));
    let places = NodePlaces::new(flat);
    tm.lap("extract");
    // progress: a surface's steps weigh its quads
    let weight = |l: &Local| l.quads.len().max(1) as u64;
    let steps = schedule::steps(opts) as u64;
    let total: u64 = locals.iter().map(|l| weight(l) * steps).sum();
    let surfaces = locals.len();
    let done = AtomicU64::new(0);
    let finished = AtomicUsize::new(0);
    let tick = |units: u64, surface_done: bool| {
        let d = done.fetch_add(units, Ordering::Relaxed) + units;
        let f = finished.fetch_add(usize::from(surface_done), Ordering::Relaxed)
            + usize::from(surface_done);
        if let Some(p) = opts.progress {
            p(crate::progress::Progress::new(
                crate::progress::Stage::Optimize,
                d.min(total),
                total,
            )
            .with_surfaces(f, surfaces));
        }
    };
    if let Some(p) = opts.progress {
        p(
            crate::progress::Progress::new(crate::progress::Stage::Optimize, 0, total)
                .with_surfaces(0, surfaces),
        );
    }
    let PreparedReference {
        nodes: refnodes,
        surfaces: mut prepared,
    } = prepared;
    // the reference's triangles (the input's, the same in every job of a run): a surface
    // holding half of them or more is the mesh's main surface (`schedule::plan`)
    let triangles: usize = prepared.iter().map(|p| p.1.triangles()).sum();
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
    // the trials of small planar surfaces wait for the mesh's worst quad
    // (`schedule::finish_deferred`) on meshes large enough for them to cost
    let budget = triangles >= schedule::TRIAL_BUDGET_FROM;
    // speed: the largest surfaces first (each surface's result does not depend on the
    // order; the results come back in tag order)
    let jobs: Vec<(Local, Option<SurfaceReference>)> = locals.into_iter().zip(refs).collect();
    // the surfaces that put off their trial, until the mesh's worst quad after the first
    // schedules is known (`schedule::finish_deferred`)
    type Done = (Local, SurfaceOptimizeReport, Option<schedule::Deferred>);
    let results: Vec<Done> = crate::par::largest_first(
        jobs,
        |j| j.0.quads.len(),
        |(mut l, sref)| {
            let main = sref
                .as_ref()
                .map_or(triangles == 0, |r| 2 * r.triangles() >= triangles);
            l.in_large_mesh = triangles >= schedule::LARGE_MESH_FROM;
            let mut tr = StageTimer::new(opts.trace, "attach", l.surface);
            // planar surfaces keep their reference triangles only for the τ estimates
            let keep_planar = schedule::may_try(&l, opts, main);
            let scale = opts.reference_size_scale;
            attach_reference(&mut l, sref, refnodes, scale, keep_planar);
            tr.lap("attach_reference");
            tr.done();
            let w = weight(&l);
            let steps = |k: usize| tick(k as u64 * w, false);
            let (rep, deferred) = run_surface_deferring(&mut l, opts, main, budget, &steps);
            tick(0, true);
            (l, rep, deferred)
        },
    );
    tm.lap("surfaces");
    // the mesh's worst quad after the first schedules, as an earlier call measured it or
    // over the surfaces left with no invalid quad (in a fallback's first round, those the
    // fallback will rework are not the mesh's last word); with none such, every put-off
    // trial runs
    let trial_worst = opts.trial_worst.or_else(|| {
        budget.then(|| {
            results
                .iter()
                .map(|r| r.1.after.eta_worst)
                .filter(|&w| w >= local::VALID_ETA)
                .fold(f64::INFINITY, f64::min)
        })
    });
    // the put-off trials of the surfaces near the mesh's worst quad, side by side
    let results: Vec<(Local, SurfaceOptimizeReport)> = results
        .into_par_iter()
        .map(|(mut l, rep, d)| match (d, trial_worst) {
            (Some(d), Some(worst)) => {
                let rep = finish_deferred(&mut l, opts, rep, d, worst);
                (l, rep)
            }
            _ => (l, rep),
        })
        .collect();
    tm.lap("deferred trials");
    let mut report = OptimizeReport {
        trial_worst,
        ..OptimizeReport::default()
    };
    let mut pending = PendingNodes::new(mesh);
    for (l, rep) in results {
        write_back(mesh, &places, &l, &mut report, &mut pending);
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

#[cfg(test)]
mod tests {
    use super::*;

    /// `k` disjoint recombined Delaunay squares side by side, surface (and boundary curve)
    /// `i + 1` each: the quads and the triangles they came from.
    fn squares(k: usize) -> (Mesh, Mesh) {
        const OFFSET: u64 = 1_000_000;
        let mut pairs = Vec::new();
        let mut seed = 1u64;
        while pairs.len() < k {
            let tris = synth::delaunay_square(16, 1.0, 0.3, seed);
            if let Some(quads) = synth::pair_optimal(&tris) {
                pairs.push((synth::to_mesh(&quads), synth::to_mesh(&tris)));
            }
            seed += 1;
        }
        let merge = |meshes: Vec<&Mesh>| {
            let mut out = Mesh {
                has_entities_section: true,
                ..Mesh::default()
            };
            for (i, m) in meshes.into_iter().enumerate() {
                let (tag, shift) = (i as i32 + 1, i as u64 * OFFSET);
                for (dim, entities) in m.entities.iter().enumerate() {
                    for e in entities {
                        let mut e = e.clone();
                        e.tag = tag;
                        e.bounding = e.bounding.iter().map(|_| tag).collect();
                        out.entities[dim].push(e);
                    }
                }
                for b in &m.node_blocks {
                    let mut b = b.clone();
                    b.entity_tag = tag;
                    b.tags.iter_mut().for_each(|t| *t += shift);
                    b.coords.iter_mut().for_each(|c| c[0] += 2.0 * i as f64);
                    out.node_blocks.push(b);
                }
                for b in &m.element_blocks {
                    let mut b = b.clone();
                    b.entity_tag = tag;
                    b.tags.iter_mut().for_each(|t| *t += shift);
                    b.nodes.iter_mut().for_each(|t| *t += shift);
                    out.element_blocks.push(b);
                }
            }
            out
        };
        (
            merge(pairs.iter().map(|p| &p.0).collect()),
            merge(pairs.iter().map(|p| &p.1).collect()),
        )
    }

    /// The optimization of a mesh large enough for the trials to wait for its worst quad
    /// reports that worst quad, and a second call given it ends with the same mesh (as the
    /// pipeline's later calls, and `reuse`, rely on).
    #[test]
    fn a_call_given_the_reported_worst_quad_ends_as_the_call_that_measured_it() {
        let (quads, tris) = squares(6);
        let triangles: usize = tris
            .element_blocks
            .iter()
            .filter(|b| b.element_type == etype::TRI3)
            .map(|b| b.len())
            .sum();
        assert!(triangles >= schedule::TRIAL_BUDGET_FROM, "{triangles} triangles");
        let opts = OptimizeOptions::default();
        let mut a = quads.clone();
        let ra = optimize(&mut a, &tris, &opts).expect("optimized");
        let worst = ra.trial_worst.expect("measured");
        assert!(worst.is_finite() && worst > 0.0, "{worst}");
        let given = OptimizeOptions {
            trial_worst: Some(worst),
            ..opts
        };
        let mut b = quads.clone();
        let rb = optimize(&mut b, &tris, &given).expect("optimized");
        assert!(a == b, "the meshes differ");
        assert_eq!(ra, rb);
        // below the budget's size, no worst quad is measured
        let (small, small_tris) = squares(1);
        let mut c = small.clone();
        let rc = optimize(&mut c, &small_tris, &opts).expect("optimized");
        assert_eq!(rc.trial_worst, None);
    }
}
