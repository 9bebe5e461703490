//! Quad mesh optimization, the paper's section 6: vertex smoothing that respects the size
//! field ([`smooth`](self) module docs), then the topological operators quad-vertex merge
//! (Figure 10), doublet collapse (Figure 11) and edge rotation, iterated with smoothing until
//! nothing improves.
//!
//! Every surface entity is optimized independently (in parallel): its 4-node quads are copied
//! into flat arrays ([`local`](self)), optimized, and written back. Curved surfaces are
//! smoothed in 3D and projected back onto the *reference triangulation* (the triangle mesh
//! before recombination), so no CAD kernel is needed; planar surfaces move in their plane.
//!
//! **Invariant:** nodes classified on points and curves, nodes on the boundary of a
//! surface's quads and nodes used by any element that is not a quad of the surface being
//! optimized never move and are never removed. Quads keep their orientation and the mesh
//! stays conforming; removed quads and nodes disappear from their blocks, every other tag is
//! kept.

// optquality hook: the valence cleanup (rotation sequences) called from `topo::pass`.
mod cleanup;
mod local;
mod polish;
mod smooth;
pub mod synth;
mod topo;

pub mod check;

pub use local::Stats;

use crate::mesh::{etype, DataKind, Mesh};
use crate::quality::locate::TriSurface;
use crate::quality::size::mean_incident_edge_length;
use crate::quality::FlatNodes;
use glam::DVec3;
use local::{Local, NONE};
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
    /// Final quality-maximizing sweeps (pattern search on the star's mean η, worst η kept).
    pub angle_sweeps: usize,
    /// Called with (steps done, total steps) as surfaces progress, from any thread.
    pub progress: Option<&'a (dyn Fn(usize, usize) + Sync)>,
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
            progress: None,
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
            .field("progress", &self.progress.is_some())
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
    let flat = FlatNodes::new(mesh);
    let mut surfaces: Vec<i32> = mesh
        .element_blocks
        .iter()
        .filter(|b| b.entity_dim == 2 && b.element_type == etype::QUAD4 && !b.is_empty())
        .map(|b| b.entity_tag)
        .collect();
    surfaces.sort_unstable();
    surfaces.dedup();
    let owner = node_owners(mesh, &flat, &surfaces)?;
    let mut locals = Vec::with_capacity(surfaces.len());
    for (si, &s) in surfaces.iter().enumerate() {
        locals.push(extract(mesh, &flat, &owner, si as u32, s)?);
    }
    let total = locals.len() * (1 + opts.max_rounds);
    let done = AtomicUsize::new(0);
    let tick = |n: usize| {
        let d = done.fetch_add(n, Ordering::Relaxed) + n;
        if let Some(p) = opts.progress {
            p(d.min(total), total);
        }
    };
    let results: Vec<(Local, SurfaceOptimizeReport)> = locals
        .into_par_iter()
        .map(|mut l| {
            attach_reference(&mut l, reference);
            let rep = run_surface(&mut l, opts, &tick);
            (l, rep)
        })
        .collect();
    let mut report = OptimizeReport::default();
    for (l, rep) in results {
        write_back(mesh, &flat, &l, &mut report);
        report.surfaces.push(rep);
    }
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

fn run_surface(
    l: &mut Local,
    opts: &OptimizeOptions,
    tick: &(dyn Fn(usize) + Sync),
) -> SurfaceOptimizeReport {
    l.build_adjacency();
    let before = l.stats();
    let mut ops = OperationCounts {
        smoothing_moves: smooth::smooth(l, opts.smooth_iterations, opts.diagonal_weight),
        ..Default::default()
    };
    tick(1);
    let mut ticks = 1;
    if opts.topology {
        for _ in 0..opts.max_rounds {
            let changed = topo::pass(l, &mut ops);
            if changed == 0 {
                break;
            }
            l.build_adjacency();
            ops.smoothing_moves += smooth::smooth(l, opts.smooth_iterations, opts.diagonal_weight);
            tick(1);
            ticks += 1;
        }
    }
    if opts.angle_sweeps > 0 {
        ops.smoothing_moves += smooth::optimize_angles(l, opts.angle_sweeps);
    }
    // optquality hook: maximize the mean η, then raise the worst quads (polish.rs)
    if opts.smooth_iterations > 0 {
        ops.smoothing_moves += polish::polish_mean(l, polish::MEAN_SWEEPS);
        ops.smoothing_moves += polish::polish_worst(l, polish::POLISH_BELOW, 3);
    }
    tick(1 + opts.max_rounds - ticks);
    let after = l.stats();
    SurfaceOptimizeReport {
        surface: l.surface,
        before,
        after,
        operations: ops,
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

/// Copies surface `s`'s quads into a [`Local`].
fn extract(
    mesh: &Mesh,
    flat: &FlatNodes,
    owner: &[u32],
    sid: u32,
    s: i32,
) -> Result<Local, OptimizeError> {
    let mut local_of: Vec<u32> = Vec::new();
    let mut global = Vec::new();
    let mut quads = Vec::new();
    let mut origin = Vec::new();
    // map flat -> local lazily through a sorted list to avoid a full-size array per surface
    let mut used: Vec<(u32, u64)> = Vec::new();
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
                used.push((q[k], t));
            }
            quads.push(q);
            origin.push((bi as u32, e as u32));
        }
    }
    used.sort_unstable();
    used.dedup();
    local_of.extend(used.iter().map(|u| u.0));
    global.extend(used.iter().map(|u| u.0));
    let node_tags: Vec<u64> = used.iter().map(|u| u.1).collect();
    let lid = |g: u32| local_of.binary_search(&g).map_or(0, |i| i as u32);
    let quads: Vec<[u32; 4]> = quads.iter().map(|q| q.map(lid)).collect();
    let n = global.len();
    let pos: Vec<DVec3> = global.iter().map(|&g| flat.coords[g as usize]).collect();
    let mut fixed: Vec<bool> = global.iter().map(|&g| owner[g as usize] != sid).collect();
    // boundary of the quad set (edges not shared by exactly two quads), and degenerate quads
    let mut edges: Vec<(u32, u32)> = Vec::with_capacity(quads.len() * 4);
    for q in &quads {
        for k in 0..4 {
            let (a, b) = (q[k], q[(k + 1) % 4]);
            edges.push((a.min(b), a.max(b)));
        }
        let mut sorted = *q;
        sorted.sort_unstable();
        if sorted.windows(2).any(|w| w[0] == w[1]) {
            for &v in q {
                fixed[v as usize] = true;
            }
        }
    }
    edges.sort_unstable();
    let mut i = 0;
    while i < edges.len() {
        let mut j = i + 1;
        while j < edges.len() && edges[j] == edges[i] {
            j += 1;
        }
        if j - i != 2 {
            fixed[edges[i].0 as usize] = true;
            fixed[edges[i].1 as usize] = true;
        }
        i = j;
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
        start: Vec::new(),
        adj: Vec::new(),
        qn: Vec::new(),
    })
}

/// Builds the surface's reference triangulation (triangles of the same surface entity in
/// `reference`, else the quads split in two), locates every node on it and sets the sizes.
fn attach_reference(l: &mut Local, reference: &Mesh) {
    let rindex = reference.node_index();
    let mut tri_tags: Vec<[u64; 3]> = Vec::new();
    for b in &reference.element_blocks {
        if b.entity_dim != 2 || b.entity_tag != l.surface || b.element_type != etype::TRI3 {
            continue;
        }
        for e in 0..b.len() {
            let el = b.element(e);
            if el.iter().all(|&t| rindex.get(t).is_some()) {
                tri_tags.push([el[0], el[1], el[2]]);
            }
        }
    }
    // Compact indices for the reference nodes.
    let mut tags: Vec<u64> = tri_tags.iter().flatten().copied().collect();
    tags.sort_unstable();
    tags.dedup();
    let mut pts: Vec<DVec3> = Vec::with_capacity(tags.len());
    let mut tris_ok = Vec::with_capacity(tri_tags.len());
    for t in &tri_tags {
        tris_ok.push(t.map(|x| tags.binary_search(&x).map_or(0, |i| i as u32)));
    }
    for &t in &tags {
        if let Some(r) = rindex.get(t) {
            pts.push(DVec3::from_array(
                reference.node_blocks[r.block as usize].coords[r.index as usize],
            ));
        }
    }
    let own = tris_ok.is_empty() || pts.len() != tags.len();
    let (pts, tris_ok) = if own {
        let mut t = Vec::with_capacity(2 * l.quads.len());
        for q in &l.quads {
            t.push([q[0], q[1], q[2]]);
            t.push([q[0], q[2], q[3]]);
        }
        (l.pos.clone(), t)
    } else {
        (pts, tris_ok)
    };
    let nodal = mean_incident_edge_length(&pts, tris_ok.iter().map(|t| &t[..]));
    if own {
        // quad edges are ~h; the split diagonals (√2 h) would inflate the mean: use the
        // quads' own edges instead.
        let qh = mean_incident_edge_length(&l.pos, l.quads.iter().map(|q| &q[..]));
        l.h = qh.iter().map(|&x| if x > 0.0 { x } else { 1.0 }).collect();
    }
    // a node of the reference (same tag, same place) is located without a search
    let mut unmatched = Vec::new();
    if own {
        unmatched.extend(0..l.pos.len());
    } else {
        let mut incident = vec![NONE; pts.len()];
        for (t, tri) in tris_ok.iter().enumerate() {
            for &v in tri {
                incident[v as usize] = t as u32;
            }
        }
        for v in 0..l.pos.len() {
            match tags.binary_search(&l.tags[v]) {
                Ok(i) if incident[i] != NONE && pts[i] == l.pos[v] => {
                    l.tri[v] = incident[i];
                    l.h[v] = if nodal[i] > 0.0 { nodal[i] } else { 1.0 };
                }
                _ => unmatched.push(v),
            }
        }
    }
    if l.planar && !own && unmatched.is_empty() {
        return; // sizes known, nothing to project on
    }
    let surface = TriSurface::new(pts, tris_ok);
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
    if !l.planar {
        l.reference = Some(surface);
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
fn write_back(mesh: &mut Mesh, flat: &FlatNodes, l: &Local, report: &mut OptimizeReport) {
    // nodes: flat index -> (block, index)
    let block_of = |g: usize| {
        let b = flat.offsets.partition_point(|&o| o <= g) - 1;
        (b, g - flat.offsets[b])
    };
    let mut removed_by_block: Vec<Vec<usize>> = vec![Vec::new(); mesh.node_blocks.len()];
    let mut moved_blocks = vec![false; mesh.node_blocks.len()];
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
            removed_by_block[b].push(i);
            report.nodes_removed += 1;
        } else if mesh.node_blocks[b].coords[i] != l.pos[v].to_array() {
            mesh.node_blocks[b].coords[i] = l.pos[v].to_array();
            moved_blocks[b] = true;
        }
    }
    for (b, mut rm) in removed_by_block.into_iter().enumerate() {
        if rm.is_empty() && !moved_blocks[b] {
            continue;
        }
        let block = &mut mesh.node_blocks[b];
        if block.params.is_some() {
            block.params = None;
            mesh.warnings.push(format!(
                "surface {}: parametric coordinates of node block ({}, {}) dropped: nodes moved",
                l.surface, block.entity_dim, block.entity_tag
            ));
        }
        if rm.is_empty() {
            continue;
        }
        rm.sort_unstable();
        remove_sorted(&mut block.tags, &rm);
        remove_sorted(&mut block.coords, &rm);
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
