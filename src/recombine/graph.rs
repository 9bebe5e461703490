//! The weighted graph of one surface (paper section 4.2): graph edges between adjacent
//! triangles with cost `1 − η` (eq. 4), and the extra edges of section 5.3.

use glam::DVec3;
use rayon::prelude::*;

use super::cross_field::{smooth_cross_field, CrossField};
use super::topology::{SurfaceTopo, NONE};
use crate::quality::eta::{corner_eta, signed_angle};

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
/// ordinary extra edge, more than merged split halves ([`split_halves_cost`]), at most
/// 3.5 · 2³⁸ < 2⁴⁰. Such an edge is still there for graphs that need it.
pub fn bad_extra_edge_cost(n: usize) -> i64 {
    let e = extra_edge_cost(n);
    3 * e + e / 2
}

/// Cost, in a graph of `n` triangles, of merging back the two halves of a triangle split by
/// a parity repair: a "quad" with a 180° corner at the split node, which lies on a wall and
/// never moves. It is `5/2` of an extra edge ([`extra_edge_cost`]), at most
/// 2.5 · 2³⁸ < 2⁴⁰ (the solver's cost limit): an extra edge ends in an edge swap or a vertex
/// duplication (section 5.3) whose quads optimization repairs, while this quad stays
/// invalid for good, so the matching takes up to two more extra edges to avoid it. (This
/// happens when the split falls in a rigid strip of a surface that needs extra edges anyway,
/// e.g. a boundary row of a `gmsh -2` mesh with even curves.) Other hopeless quads keep
/// [`HOPELESS_COST`]: on slivers along a nearly straight boundary a vertex duplication may
/// have no valid position, so trading them for extra edges is not always a gain.
pub fn split_halves_cost(n: usize) -> i64 {
    let e = extra_edge_cost(n);
    2 * e + e / 2
}

/// A cross field on the triangles of a surface (paper section 4.2, eq. 7): per triangle one
/// unit tangent `t1` (with `t2 = n × t1`), the direction of the nearest wall edge in
/// graph steps (multi-source breadth-first search from the triangles with a wall edge),
/// carried from triangle to triangle by projection on each one's plane. Surfaces without
/// walls get the projection of the x axis (or y where x is normal). `normals` are the
/// triangles' [`triangle_normals`].
pub(crate) fn boundary_cross_field(
    topo: &SurfaceTopo,
    coords: &[DVec3],
    normals: &[DVec3],
) -> Vec<DVec3> {
    let n = topo.len();
    let mut t1 = vec![DVec3::ZERO; n];
    let mut queue: std::collections::VecDeque<u32> = std::collections::VecDeque::new();
    // unit normals up front, in parallel (the search below then reads one array)
    let unit: Vec<DVec3> = normals
        .par_iter()
        .with_min_len(4096)
        .map(|nrm| nrm.normalize_or_zero())
        .collect();
    let unit_n = |t: usize| unit[t];
    let project = |d: DVec3, nrm: DVec3| (d - nrm * d.dot(nrm)).normalize_or_zero();
    for (t, dir) in t1.iter_mut().enumerate() {
        for k in 0..3 {
            if topo.nbr[3 * t + k] == NONE {
                let (a, b) = (topo.tris[t][k], topo.tris[t][(k + 1) % 3]);
                let d = project(coords[b as usize] - coords[a as usize], unit_n(t));
                if d != DVec3::ZERO {
                    *dir = d;
                    queue.push_back(t as u32);
                    break;
                }
            }
        }
    }
    if queue.is_empty() && n > 0 {
        let nrm = unit_n(0);
        let d = project(DVec3::X, nrm);
        t1[0] = if d == DVec3::ZERO {
            project(DVec3::Y, nrm)
        } else {
            d
        };
        queue.push_back(0);
    }
    // speed: "t1 is set" (non-zero) as a bitmap, which stays in cache (t1 does not)
    let mut set = NodeSet::with_len(n);
    for (t, d) in t1.iter().enumerate() {
        if *d != DVec3::ZERO {
            set.insert(t as u32);
        }
    }
    while let Some(t) = queue.pop_front() {
        let t = t as usize;
        for k in 0..3 {
            let u = topo.nbr[3 * t + k];
            if u == NONE || set.contains(u) {
                continue;
            }
            let d = project(t1[t], unit_n(u as usize));
            let val = if d == DVec3::ZERO { t1[t] } else { d };
            t1[u as usize] = val;
            if val != DVec3::ZERO {
                set.insert(u);
            }
            queue.push_back(u);
        }
    }
    t1
}

/// Eq. 7: `(max(|e·t1|, |e·t2|) − √2/2) / (1 − √2/2)` for the unit direction `e` of the
/// shared edge (the new quad's diagonal): 0 when the diagonal bisects the cross, so the
/// quad's edges follow it, 1 when it is aligned with it.
pub(crate) fn cross_cost(e: DVec3, t1: DVec3, normal: DVec3) -> f64 {
    let e = e.normalize_or_zero();
    let t2 = normal.normalize_or_zero().cross(t1);
    let m = e.dot(t1).abs().max(e.dot(t2).abs());
    let h = std::f64::consts::FRAC_1_SQRT_2;
    ((m - h) / (1.0 - h)).clamp(0.0, 1.0)
}

/// The quad formed by triangle `t` and its neighbour across local edge `k`, oriented like
/// `t`: `(p[k+1], p[k+2], p[k], s)` with `s` the neighbour's vertex opposite the edge.
pub(crate) fn merged_quad(topo: &SurfaceTopo, t: usize, k: usize) -> [u32; 4] {
    let p = topo.tris[t];
    let u = topo.nbr[3 * t + k] as usize;
    let q = topo.tris[u];
    let s = q
        .iter()
        .copied()
        .find(|&x| x != p[k] && x != p[(k + 1) % 3])
        .unwrap_or(q[0]);
    [p[(k + 1) % 3], p[(k + 2) % 3], p[k], s]
}

/// Area-weighted normal (cross product) of a triangle.
#[inline]
pub(crate) fn tri_normal(c: &[DVec3], t: [u32; 3]) -> DVec3 {
    let (a, b, d) = (c[t[0] as usize], c[t[1] as usize], c[t[2] as usize]);
    (b - a).cross(d - a)
}

/// [`tri_normal`] of every triangle of `topo` (in parallel).
pub(crate) fn triangle_normals(topo: &SurfaceTopo, coords: &[DVec3]) -> Vec<DVec3> {
    topo.tris
        .par_iter()
        .with_min_len(4096)
        .map(|&tri| tri_normal(coords, tri))
        .collect()
}

/// Corner quality below which a corner at a wall node makes a quad as bad as a folded one
/// (see the edge cost): η of the corner alone ≤ 0.25, i.e. an angle above 157.5° or below
/// 22.5°. Measured on the cad_solid fixture at 1e4 triangles: with 0.1 (171°) the matching
/// put three wall nodes of a curved edge into one quad with a 165° corner that no smoothing
/// can open (η_w 0.167 after optimization); with 0.25 η_w is 0.601, and the other fixtures
/// at 1e4 and 1e5 are unchanged.
pub const FIXED_CORNER_MIN_ETA: f64 = 0.25;

/// Cost (eq. 4) of merging `t` with its neighbour across local edge `k`: `1 − η_s` of the
/// merged quad with angles measured in 3D about the sum of the two triangles' normals.
///
/// One refinement of the paper's cost: nodes on walls (curves, the surface boundary) never
/// move during optimization (section 6), so a corner there keeps its angle for good. A quad
/// whose corner at a wall node is (nearly) straight or (nearly) zero — typically the two
/// halves of a triangle split by a parity repair, merged back into a "quad" with a 180°
/// angle — can never become valid, so it costs [`HOPELESS_COST`], far more than a folded
/// quad, and the matching takes it only when avoiding it would cost even more; when the
/// straight corner is at a parity-split node (`split_nodes`, sorted) it costs `split_cost`
/// ([`split_halves_cost`]). `wall_nodes` holds the surface's wall nodes, `normals` the
/// triangles' [`tri_normal`]s.
#[allow(clippy::too_many_arguments)]
pub(crate) fn edge_cost(
    topo: &SurfaceTopo,
    coords: &[DVec3],
    normals: &[DVec3],
    wall_nodes: &NodeSet,
    split_nodes: &[u32],
    split_cost: i64,
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
        let at_split = !split_nodes.is_empty()
            && has_hopeless_corner(&pts, normal, |k| {
                split_nodes.binary_search(&quad[k]).is_ok()
            });
        return if at_split { split_cost } else { HOPELESS_COST };
    }
    cost
}

/// A set of ids (global node ids, or triangles) as a bitmap.
pub(crate) struct NodeSet {
    bits: Vec<u64>,
}

impl NodeSet {
    /// The set of `ids`.
    pub fn new(ids: &[u32]) -> Self {
        let len = ids.iter().map(|&i| i as usize / 64 + 1).max().unwrap_or(0);
        let mut bits = vec![0u64; len];
        for &i in ids {
            bits[i as usize / 64] |= 1 << (i % 64);
        }
        NodeSet { bits }
    }

    /// An empty set for ids below `n`.
    pub fn with_len(n: usize) -> Self {
        NodeSet {
            bits: vec![0; n.div_ceil(64)],
        }
    }

    /// Adds `id` (below the `with_len` bound).
    #[inline]
    pub fn insert(&mut self, id: u32) {
        self.bits[id as usize / 64] |= 1 << (id % 64);
    }

    /// True when `id` is in the set.
    #[inline]
    pub fn contains(&self, id: u32) -> bool {
        self.bits
            .get(id as usize / 64)
            .is_some_and(|w| w >> (id % 64) & 1 == 1)
    }
}

/// True when a corner `k` of the quad with `on_wall(k)` has corner quality ≤
/// [`FIXED_CORNER_MIN_ETA`]. `normal` need not be of unit length. The wall test comes first,
/// so corners off the walls cost no `atan2`.
pub(crate) fn has_hopeless_corner(
    pts: &[DVec3; 4],
    normal: DVec3,
    on_wall: impl Fn(usize) -> bool,
) -> bool {
    // the unit normal only when some corner is on a wall (most quads have none)
    let mut unit = None;
    (0..4).any(|k| {
        on_wall(k) && {
            let unit = *unit.get_or_insert_with(|| normal.normalize_or_zero());
            corner_eta(signed_angle(pts, unit, k)) <= FIXED_CORNER_MIN_ETA
        }
    })
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

/// [`crate::quality::eta_signed`] with one `atan2` instead of four: the corner with the largest deviation
/// `|π/2 − α_k|` is found from the sines of the angles first. With `α ∈ (−π, π]`, corners
/// with `α < −π/2` deviate by more than `π` and more the larger `sin α` is; all others
/// deviate by at most `π` and more the smaller `sin α` is (the deviation is the angle whose
/// cosine is `sin α`). Degenerate corners (a zero edge) count as `α = 0`, as in
/// [`crate::quality::eta::signed_angles`].
pub(crate) fn eta_signed_fast(p: &[DVec3; 4], normal: DVec3) -> f64 {
    let normal = normal.normalize_or_zero();
    // (class, key): larger is worse
    let mut worst = (0u8, f64::NEG_INFINITY, 0.0f64, 0.0f64);
    for k in 0..4 {
        let a = p[(k + 1) % 4] - p[k];
        let b = p[(k + 3) % 4] - p[k];
        let s = normal.dot(a.cross(b));
        let c = a.dot(b);
        let r = (s * s + c * c).sqrt();
        let (class, key) = if r == 0.0 {
            (0, 0.0)
        } else if c < 0.0 && s < 0.0 {
            (1, s / r)
        } else {
            (0, -s / r)
        };
        if (class, key) > (worst.0, worst.1) {
            worst = (class, key, s, c);
        }
    }
    let (_, _, s, c) = worst;
    let alpha = if s == 0.0 && c == 0.0 {
        0.0
    } else {
        s.atan2(c)
    };
    1.0 - (std::f64::consts::FRAC_PI_2 - alpha).abs() / std::f64::consts::FRAC_PI_2
}

/// A fan: the triangles around vertex `v` between two walls, in walking order (each one
/// shares the graph edge `{v, a_i}` with the next).
#[derive(Debug, Clone)]
pub(crate) struct Fan {
    /// The vertex (global id).
    pub v: u32,
    /// The triangles `t1 … tk`.
    pub tris: Vec<u32>,
}

/// Every fan with at least three triangles: starts at each corner whose incoming edge is a
/// wall and walks across graph edges around the corner's vertex until the next wall.
pub(crate) fn fans(topo: &SurfaceTopo) -> Vec<Fan> {
    let mut out = Vec::new();
    let n = topo.len();
    for t in 0..n {
        for c in 0..3 {
            // incoming edge at corner c is local edge (c + 2) % 3
            if topo.nbr[3 * t + (c + 2) % 3] != NONE {
                continue;
            }
            let v = topo.tris[t][c];
            let mut list = vec![t as u32];
            let (mut cur, mut corner) = (t, c);
            while topo.nbr[3 * cur + corner] != NONE && list.len() <= n {
                let next = topo.nbr[3 * cur + corner] as usize;
                let Some(nc) = topo.tris[next].iter().position(|&x| x == v) else {
                    break;
                };
                list.push(next as u32);
                cur = next;
                corner = nc;
            }
            if list.len() >= 3 && list.len() <= n {
                out.push(Fan { v, tris: list });
            }
        }
    }
    out
}

/// The matching graph of one surface.
pub(crate) struct Graph {
    /// `(t, t', cost)`: real graph edges first (`real` of them), then extra edges.
    pub edges: Vec<(u32, u32, i64)>,
    /// Number of real graph edges at the front of `edges`.
    pub real: usize,
    /// For extra edge `real + i`, the fan it joins the ends of.
    pub extra_fans: Vec<Fan>,
}

/// Builds the graph: one edge per graph edge with its cost (eq. 4), plus one extra edge per
/// fan of three or more triangles whose end triangles are not already adjacent (section
/// 5.3; a fan ends at walls: the surface boundary, curves, or orientation changes).
/// `split_nodes` (sorted global ids) are the nodes made by parity repair; `cross_w` > 0
/// adds `cross_w` times the cross-field cost (eq. 7) to every edge that is not hopeless, with
/// the nearest-wall field ([`boundary_cross_field`]) or, when `harmonic`, the smooth field of
/// [`smooth_cross_field`] (its cost scaled by the field's confidence `|z|`).
pub(crate) fn build(
    topo: &SurfaceTopo,
    coords: &[DVec3],
    split_nodes: &[u32],
    cross_w: f64,
    harmonic: bool,
    with_extra: bool,
    trace: Option<&crate::profile::Trace>,
) -> Graph {
    let n = topo.len();
    let mut tm = crate::profile::StageTimer::new(trace, "graph", 0);
    let walls = NodeSet::new(&wall_nodes(topo));
    let walls = &walls;
    let normals = &triangle_normals(topo, coords);
    tm.lap("walls");
    let split_cost = split_halves_cost(n);
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
                        edge_cost(topo, coords, normals, walls, split_nodes, split_cost, t, k);
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
                if super::post::duplication_margin(topo, coords, fan) > 0.0 {
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::quality::eta_signed;

    #[test]
    fn cross_cost_is_zero_on_the_bisector_and_one_along_the_cross() {
        let n = DVec3::new(0.0, 0.0, 2.0);
        let t1 = DVec3::X;
        assert!(cross_cost(DVec3::new(1.0, 1.0, 0.0), t1, n).abs() < 1e-12);
        assert!(cross_cost(DVec3::new(-3.0, 3.0, 0.0), t1, n).abs() < 1e-12);
        assert!((cross_cost(DVec3::new(0.0, -2.0, 0.0), t1, n) - 1.0).abs() < 1e-12);
        assert!((cross_cost(DVec3::new(5.0, 0.0, 0.0), t1, n) - 1.0).abs() < 1e-12);
        let mid = cross_cost(
            DVec3::new(1.0, (std::f64::consts::PI / 8.0).tan(), 0.0),
            t1,
            n,
        );
        assert!(mid > 0.2 && mid < 0.8, "{mid}");
    }

    #[test]
    fn fast_eta_matches_eta_signed() {
        let mut x: u64 = 0x9E37_79B9;
        let mut rnd = || {
            x ^= x << 13;
            x ^= x >> 7;
            x ^= x << 17;
            (x >> 11) as f64 / (1u64 << 53) as f64 * 2.0 - 1.0
        };
        for i in 0..200_000 {
            let mut p = [DVec3::ZERO; 4];
            for q in p.iter_mut() {
                *q = DVec3::new(rnd(), rnd(), 0.3 * rnd());
            }
            if i % 7 == 0 {
                p[2] = p[1]; // degenerate edge
            }
            let n = DVec3::new(0.2 * rnd(), 0.2 * rnd(), 1.0);
            let (a, b) = (eta_signed(&p, n), eta_signed_fast(&p, n));
            assert!((a - b).abs() < 1e-9, "{p:?}: {a} vs {b}");
        }
    }
}
