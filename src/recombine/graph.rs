//! The weighted graph of one surface (paper section 4.2): graph edges between adjacent
//! triangles with cost `1 − η` (eq. 4), and the extra edges of section 5.3.

use glam::DVec3;
use rayon::prelude::*;

use super::cross_field::{boundary_cross_field, cross_cost, smooth_cross_field, CrossField};
use super::fan::{duplication_margin, fans, Fan};
use super::geometry::{
    has_corner_at_most, has_hopeless_corner, merged_quad, triangle_normals, NodeSet,
    FIXED_CORNER_MIN_ETA, FLAT_SPLIT_ETA,
};
use super::topology::{SurfaceTopo, NONE};
use crate::quality::eta_signed_fast;

/// Integer cost of one unit of `1 − η`: a graph edge costs `round(COST_SCALE · (1 − η_s))`
/// with η_s the signed quality ([`crate::quality::eta_signed`]), so a perfect square costs 0, a quad with a
/// zero angle `COST_SCALE`, and non-convex or folded quads up to `2 · COST_SCALE`: always more
/// than any valid quad. 10⁴ resolves η to 10⁻⁴, far below any meaningful quality difference,
/// and keeps the costs below within the solver's cost range.
pub const COST_SCALE: i64 = 10_000;

/// Cost of a quad that optimization can never make valid: a (nearly) straight or zero corner
/// at a wall node (see the edge cost). Ten times the cost of a degenerate quad, so the
/// matching rearranges up to about twenty ordinary quads to avoid one of these. (At a
/// parity-split node the cost is higher still: [`split_halves_cost`].)
pub const HOPELESS_COST: i64 = 10 * COST_SCALE;

/// Largest cost of a real graph edge other than the two halves of a parity-split triangle.
pub const MAX_REAL_COST: i64 = HOPELESS_COST;

/// Cost of an extra edge in a graph of `n` triangles: `MAX_REAL_COST · (n/2 + 1) + 1`, capped
/// at 2³⁸ (reached beyond 5·10⁶ triangles). Any perfect matching with fewer extra edges
/// (and no more merged split halves, see [`split_halves_cost`]) is then cheaper than every
/// matching with more (a perfect matching has `n/2` edges, each other one costing at most
/// `MAX_REAL_COST`), so the optimum uses the fewest extra edges possible, and none when the
/// original graph has a perfect matching (the paper's "very high value", made exact).
pub fn extra_edge_cost(n: usize) -> i64 {
    let c = (MAX_REAL_COST as i128) * (n as i128 / 2 + 1) + 1;
    c.min(1i128 << 38) as i64
}

/// Cost of an extra edge whose fan has no valid vertex duplication (every candidate position
/// of the new vertex folds a face: slivers along a nearly straight boundary), `7/2` of an
/// ordinary extra edge, less than merged split halves ([`split_halves_cost`]), at most
/// 3.5 · 2³⁸ < 2⁴⁰. Such an edge is still there for graphs that need it.
pub fn bad_extra_edge_cost(n: usize) -> i64 {
    let e = extra_edge_cost(n);
    3 * e + e / 2
}

/// Cost, in a graph of `n` triangles, of merging back the two halves of a triangle split by
/// a parity repair or by the fallback's edge splits on a straight boundary: a "quad" with a
/// flat corner at the split node (above about 179°), which lies on a wall and never moves,
/// so it is not valid unless the optimizer's topology passes rebuild the quads around it.
/// Where merged halves were not valid after a run
/// ([`super::RecombineOptions::flat_halves_out`], which the pipeline's fallback sets), it
/// is `15/4` of an extra edge ([`extra_edge_cost`]), at most 3.75 · 2³⁸ < 2⁴⁰ (the solver's
/// cost limit): above three extra edges, a pair the fallback priced out
/// ([`priced_out_cost`]) and an extra edge with no valid vertex duplication
/// ([`bad_extra_edge_cost`]), whose quads optimization or the fallback's pricing can still
/// repair, so the matching merges split halves only when nothing else gives a perfect
/// matching; otherwise it is [`curved_split_halves_cost`]. (Merged halves sent the fallback
/// after a parity split in a rigid strip of a surface that needs extra edges anyway, e.g. a
/// boundary row of a `gmsh -2` mesh with even curves or a fillet's strip, and each split
/// round's new parity split made another.) Other hopeless quads keep [`HOPELESS_COST`]: on
/// slivers along a nearly straight boundary a vertex duplication may have no valid
/// position, so trading them for extra edges is not always a gain.
pub fn split_halves_cost(n: usize) -> i64 {
    let e = extra_edge_cost(n);
    3 * e + 3 * (e / 4)
}

/// Cost, in a graph of `n` triangles, of merging back the two halves of a split triangle
/// whose split node lies on a curved boundary (placed on the curve, off the chord): a quad
/// with a corner near 180° that stays valid. It is `5/2` of an extra edge, at most
/// 2.5 · 2³⁸ < 2⁴⁰: below a priced-out pair ([`priced_out_cost`]), so the matching keeps
/// such a quad rather than three extra edges or a pair the fallback priced out.
pub fn curved_split_halves_cost(n: usize) -> i64 {
    let e = extra_edge_cost(n);
    2 * e + e / 2
}

/// Cost, in a graph of `n` triangles, of a pair priced out by the fallback
/// ([`super::RecombineOptions::priced_out`]: its quad was not valid after optimization):
/// three extra edges ([`extra_edge_cost`]), at most 3 · 2³⁸ < 2⁴⁰. The matching takes up to
/// two more extra edges (whose quads optimization repairs) to avoid it, but not merged split
/// halves ([`split_halves_cost`]), which are never valid, and still has a perfect matching
/// when nothing else works.
pub fn priced_out_cost(n: usize) -> i64 {
    3 * extra_edge_cost(n)
}

/// Cost (eq. 4) of merging `t` with its neighbour across local edge `k`: `1 − η_s` of the
/// merged quad with angles measured in 3D about the sum of the two triangles' normals.
///
/// One refinement of the paper's cost: nodes on walls (curves, the surface boundary) never
/// move during optimization (section 6), so a corner there keeps its angle for good. A quad
/// whose corner at a wall node is (nearly) straight or (nearly) zero — typically the two
/// halves of a triangle split by a parity repair, merged back into a "quad" with a 180°
/// angle — can never become valid, so it costs `wall_costs[2]` ([`HOPELESS_COST`], far more
/// than a folded quad, or [`priced_out_cost`] where the fallback priced such pairs out), and
/// the matching takes it only when avoiding it would cost even more; when the straight
/// corner is at a parity-split node (`split_nodes`, sorted) it costs `wall_costs[0]` when
/// that corner is flat ([`FLAT_SPLIT_ETA`], a straight boundary), else `wall_costs[1]` (a
/// curved one; see [`split_halves_cost`]). `wall_nodes` holds the surface's wall nodes,
/// `normals` the triangles' [`tri_normal`](super::geometry::tri_normal)s.
#[allow(clippy::too_many_arguments)]
pub(crate) fn edge_cost(
    topo: &SurfaceTopo,
    coords: &[DVec3],
    normals: &[DVec3],
    wall_nodes: &NodeSet,
    split_nodes: &[u32],
    wall_costs: [i64; 3],
    t: usize,
    k: usize,
) -> i64 {
    let quad = merged_quad(topo, t, k);
    let u = topo.nbr[3 * t + k] as usize;
    let normal = normals[t] + normals[u];
    let pts = quad.map(|i| coords[i as usize]);
    let eta = eta_signed_fast(&pts, normal);
    let eta = if eta.is_finite() { eta } else { -1.0 };
    let cost = (COST_SCALE as f64 * (1.0 - eta)).round() as i64;
    if has_hopeless_corner(&pts, normal, |k| wall_nodes.contains(quad[k])) {
        let at_split = |eta: f64| {
            !split_nodes.is_empty()
                && has_corner_at_most(
                    &pts,
                    normal,
                    |k| split_nodes.binary_search(&quad[k]).is_ok(),
                    eta,
                )
        };
        return if at_split(FLAT_SPLIT_ETA) {
            wall_costs[0]
        } else if at_split(FIXED_CORNER_MIN_ETA) {
            wall_costs[1]
        } else {
            wall_costs[2]
        };
    }
    cost
}

/// Sorted, deduplicated nodes that lie on a wall edge of the surface (an edge with no
/// graph neighbour: boundary, curve, orientation change, non-manifold).
pub(crate) fn wall_nodes(topo: &SurfaceTopo) -> Vec<u32> {
    let mut out: Vec<u32> = Vec::new();
    for (t, tri) in topo.tris.iter().enumerate() {
        for k in 0..3 {
            if topo.nbr[3 * t + k] == NONE {
                out.push(tri[k]);
                out.push(tri[(k + 1) % 3]);
            }
        }
    }
    out.sort_unstable();
    out.dedup();
    out
}

/// What the pipeline's fallback prices out of a surface's matching beyond single pairs: the
/// split nodes of the surface (sorted ids: parity and fallback splits) and whether the
/// merged halves at a flat one are priced out ([`split_halves_cost`]), and whether every
/// pair with a hopeless corner at a wall node costs [`priced_out_cost`] instead of
/// [`HOPELESS_COST`].
pub(crate) struct Pricing<'a> {
    pub split_nodes: &'a [u32],
    /// Nodes that are no wall's though an edge at them has no graph neighbour (sorted ids:
    /// the midpoints of a peeled fan, which the optimizer places).
    pub movable: &'a [u32],
    pub flat_halves_out: bool,
    pub hopeless_out: bool,
}

/// The matching graph of one surface.
pub(crate) struct Graph {
    /// `(t, t', cost)`: real graph edges first (`real` of them), then extra edges (empty
    /// once moved to the solver).
    pub edges: Vec<(u32, u32, i64)>,
    /// Number of real graph edges at the front of `edges`.
    pub real: usize,
    /// For extra edge `real + i`, the fan it joins the ends of.
    pub extra_fans: Vec<Fan>,
}

/// Builds the graph: one edge per graph edge with its cost (eq. 4), plus one extra edge per
/// fan of three or more triangles whose end triangles are not already adjacent (section
/// 5.3; a fan ends at walls: the surface boundary, curves, or orientation changes).
/// `pricing` says what the fallback priced out (see [`Pricing`]); `cross_w` > 0
/// adds `cross_w` times the cross-field cost (eq. 7) to every edge that is not hopeless, with
/// the nearest-wall field ([`boundary_cross_field`]) or, when `harmonic`, the smooth field of
/// [`smooth_cross_field`] (its cost scaled by the field's confidence `|z|`).
pub(crate) fn build(
    topo: &SurfaceTopo,
    coords: &[DVec3],
    pricing: Pricing,
    cross_w: f64,
    harmonic: bool,
    with_extra: bool,
    trace: Option<&crate::profile::Trace>,
) -> Graph {
    let n = topo.len();
    let mut tm = crate::profile::StageTimer::new(trace, "graph", 0);
    let mut walls = wall_nodes(topo);
    if !pricing.movable.is_empty() {
        walls.retain(|v| pricing.movable.binary_search(v).is_err());
    }
    let walls = NodeSet::new(&walls);
    let walls = &walls;
    let normals = &triangle_normals(topo, coords);
    tm.lap("walls");
    // merged halves at a flat split node: priced out once they were not valid, else at
    // the cost of a curved boundary's (the optimizer's topology passes may still repair
    // them); other hopeless pairs priced out where the fallback said so
    let split_nodes = pricing.split_nodes;
    let curved = curved_split_halves_cost(n);
    let wall_costs = [
        if pricing.flat_halves_out {
            split_halves_cost(n)
        } else {
            curved
        },
        curved,
        if pricing.hopeless_out {
            priced_out_cost(n)
        } else {
            HOPELESS_COST
        },
    ];
    let field = match (cross_w > 0.0, harmonic) {
        (false, _) => CrossField::default(),
        (true, false) => {
            let t1 = boundary_cross_field(topo, coords, normals);
            let weight = vec![1.0; t1.len()];
            CrossField { t1, weight }
        }
        (true, true) => smooth_cross_field(topo, coords, normals),
    };
    let field = &field;
    tm.lap("cross field");
    let mut edges: Vec<(u32, u32, i64)> = (0..n)
        .into_par_iter()
        .with_min_len(4096)
        .flat_map_iter(|t| {
            (0..3).filter_map(move |k| {
                let u = topo.nbr[3 * t + k];
                (u != NONE && (t as u32) < u).then(|| {
                    let mut c =
                        edge_cost(topo, coords, normals, walls, split_nodes, wall_costs, t, k);
                    if cross_w > 0.0 && c <= 2 * COST_SCALE {
                        let tri = topo.tris[t];
                        let e = coords[tri[(k + 1) % 3] as usize] - coords[tri[k] as usize];
                        let nrm = normals[t];
                        let wt = field.weight[t];
                        c += (COST_SCALE as f64 * cross_w * wt * cross_cost(e, field.t1[t], nrm))
                            .round() as i64;
                    }
                    (t as u32, u, c)
                })
            })
        })
        .collect();
    let real = edges.len();
    tm.lap("edges");
    let mut extra_fans = Vec::new();
    if with_extra {
        let cost = extra_edge_cost(n);
        let mut ends: Vec<((u32, u32), Fan)> = fans(topo)
            .into_iter()
            .filter_map(|fan| {
                let (a, b) = (fan.tris[0], fan.tris[fan.tris.len() - 1]);
                let adjacent = (0..3).any(|k| topo.nbr[3 * a as usize + k] == b);
                (a != b && !adjacent).then_some(((a.min(b), a.max(b)), fan))
            })
            .collect();
        // one extra edge per pair of end triangles (stable: the first fan found is kept)
        ends.sort_by_key(|e| e.0);
        ends.dedup_by_key(|e| e.0);
        let costs: Vec<i64> = ends
            .par_iter()
            .map(|(_, fan)| {
                if duplication_margin(topo, coords, fan) > 0.0 {
                    cost
                } else {
                    bad_extra_edge_cost(n)
                }
            })
            .collect();
        for (((a, b), fan), c) in ends.into_iter().zip(costs) {
            edges.push((a, b, c));
            extra_fans.push(fan);
        }
    }
    tm.lap("extra");
    tm.done();
    Graph {
        edges,
        real,
        extra_fans,
    }
}
