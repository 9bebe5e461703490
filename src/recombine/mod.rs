//! Blossom-Quad recombination (Remacle et al. 2012, sections 4, 5 and 7 steps 1–5): every
//! surface's 3-node triangles become 4-node quads through an exact minimum-cost perfect
//! matching of the triangle-adjacency graph.
//!
//! # Pipeline ([`recombine`])
//! 1. **Checks.** Volume elements → [`RecombineError::VolumeElements`] unless
//!    [`RecombineOptions::drop_volumes`] (then they are dropped with a warning; volume entities
//!    are kept). Surface elements other than tri3/quad4 (tri6, quad9 …) →
//!    [`RecombineError::UnsupportedSurfaceElements`]. A periodic slave surface (`$Periodic`
//!    link of dimension 2) is not recombined: after step 9 it gets the image of its master's
//!    quads (`periodic.rs`); it is refused ([`RecombineError::PeriodicSurface`]) only when
//!    its triangles are not the image of its master's.
//! 2. **Topology** (per surface, in parallel). Nodes get dense global `u32` ids; each
//!    surface's half-edges are sorted by `u64` edge key (an LSD radix sort of key and
//!    half-edge packed in one `u64`; no hash maps). An edge shared by two triangles of the
//!    surface is a *graph edge* unless it is a *wall*: it lies on a model curve, or the two
//!    triangles are oriented inconsistently, or three or more triangles share it. "On a
//!    curve" means: a 2-node line element; or, for curves without any line element (rule
//!    (b)), both nodes classified on the same curve, or on a curve and a point bounding it —
//!    unless that curve also carries boundary edges of this surface, in which case its
//!    segments are boundary edges and the interior edge is a chord (a triangle with three
//!    nodes on a circle). An edge with one triangle of the surface is a wall too: this is how
//!    surfaces without any line element (MSH 2.2 files, `gmsh -2` with physical surfaces only)
//!    are bounded — where the surface's triangle set ends or meets another surface. (A seam
//!    curve in a file with neither line elements nor curve node classification cannot be
//!    seen; the graph then crosses it, which keeps the mesh valid.) The connected components
//!    of the graph are the surface's *regions*.
//! 3. **Parity** (eq. 5–6). Every region needs an even number of triangles: odd regions are
//!    made even by splitting wall segments (a T-join over the groups of segments that flip
//!    the same regions, splits placed where thin strips still pair soundly, periodic images
//!    and quad chords split along); the design is in the documentation of `parity`. Before
//!    the plan, the ends of narrow faces one row of two triangles wide whose end curve has a
//!    node in its middle (a thin wire's quarter faces meshed with three nodes per arc) are
//!    *turned* (`parity::turn`, with [`RecombineOptions::turn_strip_ends`] and
//!    [`RecombineOptions::two_row_strips`], not on a periodic mesh nor with
//!    `ParityMode::Error`): two faces that share a side segment at the same
//!    end node get a node on it near the end row's far node (recorded as a parity split,
//!    [`ParitySplit::turn`]) and a node inside each, and each end row's three triangles
//!    become the six of three sound quads, both ends of a face or neither (parity kept).
//! 4. **Graph** (section 4.2). Cost of a graph edge = `1 − η_s` of the quad formed by its two
//!    triangles (eq. 4), η_s the signed quality of [`crate::quality::eta_signed`] with angles
//!    measured in 3D about the sum of the two triangles' normals, so a non-convex or folded
//!    quad (η_s ≤ 0) costs more than any valid one. Integer costs: `round(10⁴ · (1 − η_s))`
//!    ∈ [0, 2·10⁴] ([`COST_SCALE`]). A *hopeless* quad, with a (nearly) straight or zero
//!    corner at a wall node ([`FIXED_CORNER_MIN_ETA`]) — which optimization can never move —
//!    costs [`HOPELESS_COST`] = 10⁵ (three extra edges, [`priced_out_cost`], on the
//!    surfaces of [`RecombineOptions::hopeless_out`]); the two halves of a parity-split
//!    triangle (a 180° corner at the split node) cost 5/2 of an extra edge
//!    ([`curved_split_halves_cost`]): the matching takes up to two more extra edges (whose quads optimization repairs) to
//!    avoid them; with [`RecombineOptions::flat_halves_out`] (set by the pipeline's
//!    fallback once such a quad was not valid), halves at a flat split node cost 15/4
//!    ([`split_halves_cost`]), above three extra edges, a priced-out pair or an extra edge
//!    without a valid vertex duplication.
//!    With [`RecombineOptions::cross_field_weight`] `w` > 0, the paper's alternative cost
//!    (eq. 7) is added to ordinary edges: `10⁴ · w · c₇`, c₇ = 0 when the shared edge (the
//!    quad's diagonal) bisects a cross field that follows the nearest wall, or, with
//!    [`RecombineOptions::harmonic_cross_field`], the smooth field of `cross_field.rs`
//!    (the walls' directions interpolated harmonically in the 4θ representation; its cost
//!    is scaled by the field's confidence `|z|`, which drops near singularities). The CLI
//!    uses w = 0.05 by default (measured in BENCHMARKS.md, "Cross-field weight"); the
//!    recombination's own default is 0.
//! 5. **Extra edges** (section 5.3). Around every vertex, the triangles between two walls
//!    form a *fan* `t1 … tk` (each sharing a graph edge `{v, a_i}` with the next). The paper
//!    joins the triangles of two successive boundary edges; here every fan with k ≥ 3 whose
//!    ends are not already adjacent gets an extra edge `t1–tk` (walls from curves and
//!    orientation changes count as boundary, so post-processing never crosses a curve). Its
//!    cost, `10⁵ · (n/2 + 1) + 1` ([`extra_edge_cost`]), exceeds the cost of any
//!    perfect matching's other edges, so the optimum uses the fewest extra edges possible
//!    (counting merged split halves as 5/2 or 15/4) — none when the original graph has a perfect
//!    matching that keeps split halves apart. A fan where no position of a duplicated
//!    vertex leaves its triangles unfolded prices its extra edge at 7/2
//!    ([`bad_extra_edge_cost`]).
//! 6. **Matching.** [`crate::matching::solve`]; with [`RecombineOptions::verify`] its
//!    optimality certificate is checked ([`crate::matching::verify`]). No perfect matching
//!    even with extra edges → [`RecombineError::NoPerfectMatching`] naming the surface and the
//!    Tutte witness size; no triangle is ever left silently.
//! 7. **Quads.** Two triangles matched through a graph edge become the quad
//!    `(p[k+1], p[k+2], p[k], s)` (oriented like the first triangle; graph edges only join
//!    consistently oriented triangles, so like both). For each extra edge in the matching:
//!    - **Edge swap** (5.3.1) when the fan is `t1 t2 t3`, `t2` is matched across the edge
//!      opposite `v` to `t4`, none of the four triangles is in another used extra edge's fan,
//!      and the new diagonal from `v` to `t4`'s far vertex `x` lies inside the quad `t2 ∪ t4`:
//!      the hexagon `t1 ∪ t2 ∪ t4 ∪ t3` is cut into two quads by `v x` (the quad `t2 ∪ t4`
//!      has its diagonal swapped). Both are simple polygons, possibly non-convex;
//!      optimization (section 6) is expected to improve them. Unlike the paper, the swap is
//!      skipped when a corner of a new quad would be (nearly) straight or zero — e.g. two
//!      successive segments of a straight curve in one quad — since a wall node never moves
//!      and that corner would stay; the fan then gets a vertex duplication.
//!    - **Vertex duplication** (5.3.2) otherwise: a new node `v'` is placed halfway between
//!      `v` and the mean of the fan's inner vertices `a_1 … a_{k−1}` (classified on the
//!      surface, parametric coordinates averaged from those of the `a_i` when the surface
//!      block is parametric); the faces of the middle triangles `t2 … t(k−1)` get `v'` instead
//!      of `v`, and `v'` is inserted into the edge `{v, a_1}` of `t1` and `{v, a_(k−1)}` of
//!      `tk`, which become quads sharing the new edge `v v'`. The boundary and the curves are
//!      untouched, the mesh stays conforming, orientations are kept.
//! 8. **Strips** (`strip.rs`; not in the paper). A region whose triangles lie in one row
//!    between its walls (a path or a cycle of *units*: a triangle with the triangles that
//!    touch nothing else, such as the two outer triangles of a fan of three at a strip's
//!    end) has one or two perfect matchings and no node that optimization may move, so a
//!    poor pair stays poor: a narrow chamfer or fillet face ending in such a fan pairs two
//!    of its triangles into a quad with a straight corner at the end's middle node. When the
//!    worst quad of a strip is under η 0.3, a dynamic programme over the strip cuts it into
//!    cells of one to four consecutive units, each made one quad or two (a hexagon cut
//!    between opposite vertices), with a *midline*, a new node on each interior edge,
//!    between two cells of odd triangle counts; it keeps the best worst η, then the fewest
//!    quads. A plan at least 0.05 better replaces the matching's quads of the strip; the
//!    plans of all surfaces are taken worst strip first while the quads stay within
//!    `MAX_QUADS_PER_TRIANGLE` of the triangles (a quarter more under
//!    `COUNT_RULE_FROM`). Midline nodes are surface nodes, which optimization moves;
//!    walls, curves and the other surfaces are untouched.
//! 9. **Write back.** Each surface's tri3 blocks are replaced by one quad4 block (appended to
//!    an existing quad4 block of that surface: quads already present are kept). **A quad
//!    reuses the element tag of one of its triangles** (the first in input order for a plain
//!    merge; `t1` and `tk` for the two quads of an edge swap or a vertex duplication; a
//!    triangle of its cell that no other quad takes for a strip's quad), so no element tag
//!    is invented. New nodes get tags above the maximum. Element data sections
//!    are invalidated. Then every periodic slave surface's elements are replaced by the image
//!    of its master's through the `$Periodic` node pairs (`periodic.rs`; each slave quad
//!    keeps the tag of the slave image of its master quad's triangle; master nodes without a
//!    counterpart, e.g. from vertex duplication, get a slave node at their image through the
//!    link's affine transform, and the pair is added). [`map_periodic_slaves`] does the same after
//!    optimization (the pipeline runs it), moving the slave's interior nodes to the images of the
//!    optimized master's, so the output stays periodic.
//!
//! **Invariant** (checked by [`check_invariants`], which shares no code with the above): no
//! triangle is left on a surface, the mesh is conforming, boundaries and curve nodes are
//! unchanged (up to parity splits), planar areas are unchanged, orientations are kept,
//! physical groups are identical.

mod cross_field;
mod error;
mod fallback;
mod fan;
mod geometry;
mod graph;
mod input;
mod invariants;
mod memo;
mod options;
mod parity;
mod periodic;
mod post;
mod report;
mod strip;
mod surface;
mod topology;
mod write_back;

use std::sync::Arc;
use std::time::{Duration, Instant};


use crate::mesh::{element_dim, etype, ElementBlock, Mesh, NodeTable};
use crate::profile::StageTimer;
pub(crate) use memo::MatchMemo;
pub(crate) use surface::SurfaceWork;
use surface::{match_surface, surface_work, SurfaceResult};
use topology::CurveInfo;
use write_back::write_back;

pub use fallback::{split_triangles, FallbackSplit, FlatPair};
pub(crate) use error::list_tags;
use error::odd_parity_error;
pub use error::RecombineError;
// the cost model's constants, for the tests
#[cfg(feature = "testing")]
pub use geometry::FIXED_CORNER_MIN_ETA;
#[cfg(feature = "testing")]
pub use graph::{
    bad_extra_edge_cost, curved_split_halves_cost, extra_edge_cost, priced_out_cost,
    split_halves_cost, COST_SCALE, HOPELESS_COST, MAX_REAL_COST,
};
pub use invariants::{check_invariants, Before, EdgeSet, InvariantViolation};
pub use options::{ParityMode, RecombineOptions};
use report::note_folds;
pub use report::{ParitySplit, RecombineReport, SurfaceReport, WalledFold};

/// A copy of `mesh` without the triangles that repeat another triangle's three nodes on
/// the same surface (a triangle and its reverse cancel: a zero-area pocket such as Gmsh
/// writes at a degenerate apex; a copy is kept where it fills the hole the removal leaves;
/// copies in the same orientation keep one), with one line per surface saying what went;
/// `None` when there are none. [`recombine`] runs it first; [`crate::quadrangulate`] runs
/// it on its input, so every later check compares with the surface without them.
pub fn drop_repeated_triangles(mesh: &Mesh) -> Option<(Mesh, Vec<String>)> {
    input::drop_repeated_triangles(mesh)
}
pub use parity::OddRegion;

/// Turns every surface's tri3 triangles into quad4 quads (see the module documentation).
///
/// Everything else is kept: node tags, curve and point elements, physical groups, entities,
/// quads already present, other element types. On error the mesh may be partly changed
/// (parity splits, dropped volumes, and the recombined surfaces' triangle blocks emptied
/// once their topology is built); callers that need the input should clone it first.
#[cfg(any(test, feature = "testing"))]
pub fn recombine(
    mesh: &mut Mesh,
    opts: &RecombineOptions,
) -> Result<RecombineReport, RecombineError> {
    recombine_with(mesh, opts, None)
}

/// [`recombine`] with the matchings of earlier recombinations of the run in `memo` (a
/// surface equal to one of them but for its global node ids gets its quads back; see
/// `memo.rs`), where each new one is stored.
pub(crate) fn recombine_with(
    mesh: &mut Mesh,
    opts: &RecombineOptions,
    memo: Option<&MatchMemo>,
) -> Result<RecombineReport, RecombineError> {
    let start = Instant::now();
    let hits_before = memo.map_or(0, MatchMemo::hits);
    let mut tm = StageTimer::new(opts.trace.as_ref(), "recombine", 0);
    let mut report = RecombineReport::default();
    // repeated triangles (zero-area pockets) go first: the checks below compare with the
    // mesh without them
    let cleaned = (!opts.repeated_dropped)
        .then(|| input::drop_repeated_triangles(mesh))
        .flatten();
    if let Some((cleaned, lines)) = cleaned {
        *mesh = cleaned;
        report.warnings.extend(
            lines
                .into_iter()
                .map(|text| crate::Warning::RepeatedTriangles { text }),
        );
    }
    tm.lap("repeated triangles");
    topology_progress(opts, 0);
    let before = opts.verify.then(|| mesh.clone());
    check_input(mesh, opts, &mut report)?;
    tm.lap("input checks");
    topology_progress(opts, 1);

    // Topology, parity, matching. A surface whose triangles are enclosed by quads so that
    // they cannot be made even or matched (isolated triangles left by a partial
    // recombination) has its quads split into triangles and is recombined whole; this
    // happens at most once per surface, so the loop ends.
    let mut retriangulated: Vec<i32> = Vec::new();
    let (work, mut results) = loop {
        let staged = parity_stage(mesh, opts, &mut report).and_then(|(nodes, mut work)| {
            // memory: what only the topology and parity read goes before the graphs and
            // the solvers allocate: the regions, and the surfaces' triangle blocks when
            // nothing can read them again before the write back replaces them
            for w in &mut work {
                w.strips = strip::strips(w);
                w.region = Vec::new();
            }
            if !may_reread_triangles(mesh, &work) {
                clear_triangle_blocks(mesh, &work);
            }
            let n_global = nodes.coords.len() as u32;
            let mut split_nodes: Vec<u32> = report
                .parity_splits
                .iter()
                .filter_map(|s| nodes.id(s.new_node))
                .collect();
            if let Some(from) = opts.split_nodes_from {
                split_nodes.extend((0..n_global).filter(|&i| nodes.tags[i as usize] >= from));
                split_nodes.dedup();
            }
            split_nodes.sort_unstable();
            let split_nodes = &split_nodes;
            let mut movable: Vec<u32> = opts
                .movable_nodes
                .iter()
                .filter_map(|&t| nodes.id(t))
                .collect();
            movable.sort_unstable();
            movable.dedup();
            let movable = &movable;
            // the priced-out quads as sorted node ids (quads naming an unknown node are
            // no pair's)
            let mut priced: Vec<[u32; 4]> = opts
                .priced_out
                .iter()
                .filter_map(|q| {
                    let mut ids = [0u32; 4];
                    for (id, &t) in ids.iter_mut().zip(q) {
                        *id = nodes.id(t)?;
                    }
                    ids.sort_unstable();
                    Some(ids)
                })
                .collect();
            priced.sort_unstable();
            priced.dedup();
            let priced = &priced;
            // memory: the graphs and the matchings read only the coordinates; the rest of
            // the node table (tags, blocks, tag index) is built again for the write back
            // (the nodes do not change in between)
            let coords = nodes.into_coords();
            // memory: the topology's temporaries are freed; the graphs and the solvers
            // allocate next, maybe on other threads (other arenas)
            crate::memory::release_memory();
            let coords = &coords;
            let tracker = opts.progress.as_ref().map(|p| {
                let end = TOPOLOGY_UNITS[4];
                p.report(crate::progress::Progress::new(
                    crate::progress::Stage::Topology,
                    end,
                    end,
                ));
                let t = Arc::new(surface::Tracker::new(p.clone(), &work));
                t.emit();
                t
            });
            let side = surface::MeshSide {
                coords,
                split_nodes,
                movable,
                priced,
                n_global,
            };
            // speed: the largest surfaces first (each surface's result does not depend on
            // the order; the results come back in surface order, and of several errors the
            // first surface's is returned)
            let results: Result<Vec<SurfaceResult>, RecombineError> =
                crate::par::largest_first(work.iter().collect(), |w| w.topo.len(), |w| {
                    match_surface(w, &side, opts, tracker.as_ref(), memo)
                })
                .into_iter()
                .collect();
            if let Some(t) = &tracker {
                t.emit();
            }
            results.map(|r| (work, r))
        });
        match staged {
            Ok(done) => break done,
            Err(RecombineError::NoPerfectMatching { surface, .. })
                if has_quads(mesh, surface) && !retriangulated.contains(&surface) =>
            {
                retriangulate(mesh, &[surface], &mut report);
                retriangulated.push(surface);
            }
            Err(RecombineError::ParityUnsolvable { regions, message }) => {
                let fix: Vec<i32> = regions
                    .iter()
                    .map(|r| r.surface)
                    .filter(|&s| has_quads(mesh, s) && !retriangulated.contains(&s))
                    .collect();
                if fix.is_empty() {
                    return Err(RecombineError::ParityUnsolvable { regions, message });
                }
                retriangulate(mesh, &fix, &mut report);
                retriangulated.extend(fix);
            }
            Err(e) => return Err(e),
        }
    };
    tm.lap("surfaces");
    for (r, w) in results.iter_mut().zip(&work) {
        r.report.parity_splits = report
            .parity_splits
            .iter()
            .filter(|s| s.surfaces.contains(&w.tag))
            .count();
    }
    let periodic_corr = periodic::correspondence(mesh)?;
    let nodes = NodeTable::new(mesh);
    choose_strips(&work, &mut results, nodes.coords.len() as u32, &mut report.log);
    write_back(mesh, &nodes, &work, &results);
    drop(nodes);
    let mapped = periodic::map_slaves(mesh, Some(&periodic_corr))?;
    if mapped > 0 {
        report.log.push(format!(
            "{mapped} periodic surface(s) got the image of their master's quads"
        ));
    }
    if let Some(k) = memo.map(|m| m.hits() - hits_before).filter(|&k| k > 0) {
        report.log.push(format!(
            "{k} surface(s) matched as in an earlier recombination of the run (the same triangles, costs and options)"
        ));
    }
    mesh.invalidate_element_data();
    tm.lap("write back");
    for r in &results {
        let s = &r.report;
        let after_splits = match s.parity_splits {
            0 => String::new(),
            k => format!(" (after {k} parity split(s))"),
        };
        let strips = match s.strips_remeshed {
            0 => String::new(),
            k => format!(", {k} strip(s) meshed again with a midline"),
        };
        report.log.push(format!(
            "surface {}: {} triangles{after_splits} -> {} quads (cost {}, {} extra edges used, {} edge swaps, {} vertex duplications{strips})",
            s.surface, s.triangles_in, s.quads_out, s.matching_cost, s.extra_edges_used, s.edge_swaps, s.vertex_duplications
        ));
    }
    report.surfaces = results.into_iter().map(|r| r.report).collect();
    if let Some(before) = before {
        check_invariants(&before, mesh).map_err(RecombineError::Invariant)?;
    }
    tm.lap("verify");
    tm.done();
    report.time_total = start.elapsed();
    Ok(report)
}

/// New quads per input triangle that the recombination's strips meshed again, and the
/// fallback's worst-quad repairs, may not take a mesh above (unless it was above already):
/// 0.5 when every triangle pairs with a neighbour.
pub(crate) const MAX_QUADS_PER_TRIANGLE: f64 = 0.6;

/// Input triangles from which [`MAX_QUADS_PER_TRIANGLE`] binds: a smaller mesh may take up
/// to a quarter more quads than that for a better worst quad.
pub(crate) const COUNT_RULE_FROM: usize = 500;

/// The most new quads per input triangle the element-count rule allows a mesh of
/// `triangles` input triangles: [`MAX_QUADS_PER_TRIANGLE`], a quarter more under
/// [`COUNT_RULE_FROM`] triangles.
pub(crate) fn count_rule_limit(triangles: usize) -> f64 {
    if triangles < COUNT_RULE_FROM {
        1.25 * MAX_QUADS_PER_TRIANGLE
    } else {
        MAX_QUADS_PER_TRIANGLE
    }
}

/// Meshes again the strips planned in `results` (see [`strip`]) whose quads were worst
/// first, as long as the new quads keep the mesh within [`MAX_QUADS_PER_TRIANGLE`] of its
/// triangles (a quarter more under [`COUNT_RULE_FROM`] triangles); ties in surface order.
fn choose_strips(
    work: &[SurfaceWork],
    results: &mut [SurfaceResult],
    n_global: u32,
    log: &mut Vec<String>,
) {
    let triangles: usize = results.iter().map(|r| r.report.triangles_in).sum();
    let quads: usize = results.iter().map(|r| r.faces.quads.len()).sum();
    let rate = count_rule_limit(triangles);
    let mut budget = ((rate * triangles as f64).floor() as usize).saturating_sub(quads);
    let mut all: Vec<(usize, usize)> = results
        .iter()
        .enumerate()
        .flat_map(|(s, r)| (0..r.strip_plans.len()).map(move |p| (s, p)))
        .collect();
    all.sort_by(|a, b| {
        let w = |&(s, p): &(usize, usize)| results[s].strip_plans[p].worst_before;
        w(a).total_cmp(&w(b)).then(a.cmp(b))
    });
    let mut chosen: Vec<Vec<usize>> = vec![Vec::new(); results.len()];
    for (s, p) in all {
        let extra = results[s].strip_plans[p].extra_quads;
        if extra <= budget {
            budget -= extra;
            chosen[s].push(p);
        }
    }
    for ((r, w), chosen) in results.iter_mut().zip(work).zip(chosen) {
        let plans = std::mem::take(&mut r.strip_plans);
        let picked: Vec<&strip::StripPlan> = chosen.iter().map(|&p| &plans[p]).collect();
        for p in &picked {
            log.push(format!(
                "surface {}: a strip of {} triangles meshed again with a midline (worst quad eta {:.3} -> {:.3})",
                w.tag,
                w.strips[p.strip].units.iter().map(Vec::len).sum::<usize>(),
                p.worst_before.max(0.0),
                p.worst_after
            ));
        }
        strip::apply(&mut r.faces, w.topo.len(), &w.strips, &picked, n_global);
        r.report.strips_remeshed = picked.len();
        r.report.quads_out = r.faces.quads.len();
    }
}

/// Makes every periodic slave surface the image of its master again (elements and interior
/// node positions, through the `$Periodic` node pairs and affine transform): run it after
/// anything that changed the master surfaces (the optimizer). Returns the number of slave
/// surfaces mapped.
pub(crate) fn map_periodic_slaves(mesh: &mut Mesh) -> Result<usize, RecombineError> {
    periodic::map_slaves(mesh, None)
}

/// The slave surfaces of the mesh's `$Periodic` surface links that have faces: the
/// optimizer leaves them out and [`map_periodic_slaves`] makes each the image of its
/// optimized master.
pub(crate) fn periodic_slaves(mesh: &Mesh) -> Vec<i32> {
    periodic::slave_surfaces(mesh)
}

/// `surfaces` with every surface linked to one of them by `$Periodic` surface links
/// ([`periodic_slaves`]' links; master or slave, through chains of links).
pub(crate) fn with_periodic_partners(
    mesh: &Mesh,
    surfaces: std::collections::HashSet<i32>,
) -> std::collections::HashSet<i32> {
    periodic::with_partners(mesh, surfaces)
}

/// Steps 2–3: topology of every surface, then parity repair (one round, checked).
/// [`crate::progress::Stage::Topology`] progress: `step` of its four steps (input checks, node table,
/// surface topology, parity repair) done, each weighted by its usual share of the time
/// ([`TOPOLOGY_UNITS`]).
fn topology_progress(opts: &RecombineOptions, step: usize) {
    if let Some(p) = &opts.progress {
        let units = TOPOLOGY_UNITS[step.min(4)];
        p.report(crate::progress::Progress::new(
            crate::progress::Stage::Topology,
            units,
            TOPOLOGY_UNITS[4],
        ));
    }
}

/// The [`crate::progress::Stage::Topology`] units done after each of its four steps: the input checks
/// and the node table take one unit each, each surface's triangles, half-edges and regions
/// twelve (most of the stage's time), the parity repair two.
const TOPOLOGY_UNITS: [u64; 5] = [0, 1, 2, 14, 16];

fn parity_stage(
    mesh: &mut Mesh,
    opts: &RecombineOptions,
    report: &mut RecombineReport,
) -> Result<(NodeTable, Vec<SurfaceWork>), RecombineError> {
    let mut tm = StageTimer::new(opts.trace.as_ref(), "parity stage", 0);
    let mut nodes = NodeTable::new(mesh);
    tm.lap("node table");
    topology_progress(opts, 2);
    let curves = CurveInfo::new(mesh, &nodes)?;
    tm.lap("curves");
    let mut work = surface_work(mesh, &nodes, &curves, opts.trace.as_ref())?;
    tm.lap("surface work");
    // strip ends turned across the curves they share (before the parity plan, which sees
    // their triangles)
    if opts.turn_strip_ends
        && opts.two_row_strips
        && opts.parity != ParityMode::Error
        && mesh.periodic.is_empty()
    {
        let turns = parity::turns(mesh, &nodes, &work);
        if !turns.is_empty() {
            let splits = parity::apply_turns(mesh, &nodes, &work, &turns);
            for s in &splits {
                let place = match s.curve {
                    Some(c) => format!("curve {c}"),
                    None => "their shared boundary".into(),
                };
                report.log.push(format!(
                    "the ends of surfaces {} turned across {place}: segment {}-{} split near node {} (new node {})",
                    list_tags(&s.surfaces),
                    s.segment.0,
                    s.segment.1,
                    s.segment.1,
                    s.new_node
                ));
            }
            report.parity_splits.extend(splits);
            mesh.invalidate_element_data();
            nodes = NodeTable::new(mesh);
            let curves = CurveInfo::new(mesh, &nodes)?;
            work = surface_work(mesh, &nodes, &curves, opts.trace.as_ref())?;
            tm.lap("strip end turns");
        }
    }
    topology_progress(opts, 3);
    // the segments to avoid, as edge keys of node ids (sorted)
    let mut avoid: Vec<u64> = opts
        .parity_avoid
        .iter()
        .filter_map(|&(a, b)| Some(topology::edge_key(nodes.id(a)?, nodes.id(b)?)))
        .collect();
    avoid.sort_unstable();
    let plan = parity::plan(mesh, &nodes, &work, &avoid);
    tm.lap("plan");
    tm.done();
    note_folds(&work, report);
    if plan.odd.is_empty() {
        return Ok((nodes, work));
    }
    if opts.parity == ParityMode::Error {
        return Err(odd_parity_error(&plan));
    }
    // with folds walled off, a parity repair that fails is the folds' doing: the first
    // fold is the refusal
    let first_fold = report.walled_folds.first().map(WalledFold::refusal);
    let or_fold = |e: RecombineError| first_fold.clone().unwrap_or(e);
    if !plan.unsolved.is_empty() {
        return Err(or_fold(parity::unsolvable_error(&plan)));
    }
    let splits = parity::apply(mesh, &nodes, &plan.choices, &plan.columns).map_err(or_fold)?;
    for o in &plan.odd {
        report.log.push(format!(
            "surface {}: region {} of {} has {} triangles (odd)",
            o.surface,
            o.region.0 + 1,
            o.region.1,
            o.triangles
        ));
    }
    for s in &splits {
        let place = match s.curve {
            Some(c) => format!("curve {c}"),
            None => "a boundary without curve data".into(),
        };
        report.log.push(if s.surfaces.is_empty() {
            format!(
                "parity repair: split segment {}-{}{} at its midpoint (new node {}) with the split above (its periodic image or the quad strip it runs through)",
                s.segment.0,
                s.segment.1,
                s.curve.map(|c| format!(" of curve {c}")).unwrap_or_default(),
                s.new_node
            )
        } else {
            format!(
                "parity repair: split segment {}-{} of {place} at its midpoint (new node {}), flipping surface(s) {}",
                s.segment.0,
                s.segment.1,
                s.new_node,
                list_tags(&s.surfaces)
            )
        });
    }
    for c in &plan.columns {
        let tag = |n: u32| nodes.tags[n as usize];
        report.log.push(format!(
            "parity repair: the splits of segments {}-{} and {}-{} face each other across strip \
             surface {}, joined by an edge between their new nodes",
            tag(c.first.0),
            tag(c.first.1),
            tag(c.second.0),
            tag(c.second.1),
            c.surface
        ));
    }
    report.parity_splits.extend(splits);
    mesh.invalidate_element_data();
    let nodes = NodeTable::new(mesh);
    let curves = CurveInfo::new(mesh, &nodes)?;
    let work = surface_work(mesh, &nodes, &curves, opts.trace.as_ref()).map_err(or_fold)?;
    let again = parity::plan(mesh, &nodes, &work, &[]);
    if !again.odd.is_empty() {
        return Err(or_fold(parity::still_odd_error(&again.odd)));
    }
    note_folds(&work, report);
    Ok((nodes, work))
}

/// True when the triangle blocks of the surfaces in `work` may be read again before the
/// write back replaces them: when one of those surfaces has quads (a failed matching
/// retriangulates it and runs the topology of every surface again), or when the mesh has
/// periodic surface links (the slaves' correspondence reads their masters' triangles).
fn may_reread_triangles(mesh: &Mesh, work: &[SurfaceWork]) -> bool {
    mesh.periodic.iter().any(|p| p.dim == 2) || work.iter().any(|w| has_quads(mesh, w.tag))
}

/// Empties (keeping the blocks, which the write back finds and replaces) the triangle
/// blocks of the surfaces in `work`: their triangles, element tags and partitions are in
/// `work` already.
fn clear_triangle_blocks(mesh: &mut Mesh, work: &[SurfaceWork]) {
    for b in &mut mesh.element_blocks {
        if b.element_type == etype::TRI3
            && b.entity_dim == 2
            && work.iter().any(|w| w.tag == b.entity_tag)
        {
            b.nodes = Vec::new();
            b.tags = Vec::new();
            b.partitions = None;
        }
    }
}

/// True when surface `s` has 4-node quads.
fn has_quads(mesh: &Mesh, s: i32) -> bool {
    mesh.element_blocks.iter().any(|b| {
        b.element_type == etype::QUAD4 && b.entity_dim == 2 && b.entity_tag == s && !b.is_empty()
    })
}

/// Splits every quad of the given surfaces into two triangles along its shorter diagonal
/// (orientation kept; the first triangle keeps the quad's tag, the second gets a fresh tag),
/// so that the whole surface is recombined.
fn retriangulate(mesh: &mut Mesh, surfaces: &[i32], report: &mut RecombineReport) {
    let idx = mesh.node_index();
    let pos = |t: u64| -> Option<glam::DVec3> {
        idx.get(t).map(|r| {
            glam::DVec3::from_array(mesh.node_blocks[r.block as usize].coords[r.index as usize])
        })
    };
    let mut next = mesh.max_element_tag() + 1;
    let mut new_blocks = Vec::new();
    for b in &mesh.element_blocks {
        if !(b.element_type == etype::QUAD4
            && b.entity_dim == 2
            && surfaces.contains(&b.entity_tag))
        {
            continue;
        }
        let mut tri = ElementBlock {
            entity_dim: 2,
            entity_tag: b.entity_tag,
            element_type: etype::TRI3,
            tags: Vec::with_capacity(2 * b.len()),
            nodes: Vec::with_capacity(6 * b.len()),
            partitions: b.partitions.as_ref().map(|_| Vec::new()),
        };
        for i in 0..b.len() {
            let q = b.element(i);
            let d02 = pos(q[0]).zip(pos(q[2])).map(|(a, c)| a.distance(c));
            let d13 = pos(q[1]).zip(pos(q[3])).map(|(a, c)| a.distance(c));
            let halves = if d13 < d02 {
                [[q[0], q[1], q[3]], [q[1], q[2], q[3]]]
            } else {
                [[q[0], q[1], q[2]], [q[0], q[2], q[3]]]
            };
            for (h, t) in halves.iter().zip([b.tags[i], next]) {
                tri.tags.push(t);
                tri.nodes.extend_from_slice(h);
                if let (Some(dst), Some(src)) = (tri.partitions.as_mut(), b.partitions.as_ref()) {
                    dst.push(src.get(i).cloned().unwrap_or_default());
                }
            }
            next += 1;
        }
        report.retriangulated.push(b.entity_tag);
        report.log.push(format!(
            "surface {}: its triangles are enclosed by quads and cannot be paired; its {} quads were split into triangles and the whole surface recombined",
            b.entity_tag,
            b.len()
        ));
        new_blocks.push(tri);
    }
    mesh.element_blocks.retain(|b| {
        !(b.element_type == etype::QUAD4 && b.entity_dim == 2 && surfaces.contains(&b.entity_tag))
    });
    mesh.element_blocks.extend(new_blocks);
    mesh.invalidate_element_data();
}

/// Refuses a block whose node or partition lists do not fit its element count
/// ([`ElementBlock::is_well_formed`]); `high_order` uses it too.
pub(crate) fn check_block(b: &ElementBlock) -> Result<(), RecombineError> {
    if b.is_well_formed() {
        return Ok(());
    }
    Err(RecombineError::MalformedBlock {
        dim: b.entity_dim,
        entity: b.entity_tag,
        element_type: b.element_type,
        nodes: b.nodes.len(),
        elements: b.len(),
    })
}

/// Step 1 of the pipeline: refuses what cannot be recombined, drops volumes when asked.
fn check_input(
    mesh: &mut Mesh,
    opts: &RecombineOptions,
    report: &mut RecombineReport,
) -> Result<(), RecombineError> {
    for b in &mesh.element_blocks {
        check_block(b)?;
    }
    let mut volumes: Vec<i32> = Vec::new();
    let mut count = 0;
    for b in &mesh.element_blocks {
        if element_dim(b.element_type) == Some(3) && !b.is_empty() {
            count += b.len();
            volumes.push(b.entity_tag);
        }
    }
    volumes.sort_unstable();
    volumes.dedup();
    if count > 0 {
        if !opts.drop_volumes {
            return Err(RecombineError::VolumeElements { count, volumes });
        }
        mesh.element_blocks
            .retain(|b| element_dim(b.element_type) != Some(3));
        mesh.warnings.push(format!(
            "dropped {count} volume elements (volumes {}); the volume entities are kept",
            list_tags(&volumes)
        ));
        report.dropped_volume_elements = count;
        report.log.push(format!("dropped {count} volume elements"));
    }
    for b in &mesh.element_blocks {
        if element_dim(b.element_type) != Some(2) || b.is_empty() {
            continue;
        }
        if b.element_type != etype::TRI3 && b.element_type != etype::QUAD4 {
            return Err(RecombineError::UnsupportedSurfaceElements {
                surface: b.entity_tag,
                element_type: b.element_type,
                count: b.len(),
            });
        }
    }
    input::check_tag_room(mesh)?;
    input::check_surface_elements(mesh)?;
    // periodic slave surfaces get their master's quads (periodic.rs); the check that each
    // is the image of its master runs after parity repair
    Ok(())
}

/// Surface tags with 3-node triangles, in first-appearance order (the order of the element
/// blocks in the file), periodic slaves left out.
///
/// The order is part of the output: `write_back` gives the surfaces' new nodes (vertex
/// duplications) their tags in this order, so sorting it (as `optimize` does) would
/// renumber nodes of the written mesh. Periodic slaves are not recombined: they get the
/// image of their master's quads (`periodic`).
fn surface_tags(mesh: &Mesh) -> Vec<i32> {
    // periodic slaves are not recombined: they get the image of their master
    let slaves = periodic::slave_surfaces(mesh);
    let mut tags: Vec<i32> = Vec::new();
    for b in &mesh.element_blocks {
        if b.element_type == etype::TRI3
            && b.entity_dim == 2
            && !b.is_empty()
            && !tags.contains(&b.entity_tag)
            && !slaves.contains(&b.entity_tag)
        {
            tags.push(b.entity_tag);
        }
    }
    tags
}
