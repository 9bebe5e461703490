//! Fans (the triangles around a node between two walls, paper section 5.3) and the
//! geometry of a vertex duplication in one: where the new node goes and how far the faces
//! around it are from folding.

use glam::DVec3;

use super::geometry::tri_normal;
use super::topology::{SurfaceTopo, NONE};

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

/// The vertex `t` and `u` share besides `v` (original topology).
fn shared_other(topo: &SurfaceTopo, t: u32, u: u32, v: u32) -> u32 {
    let a = topo.tris[t as usize];
    let b = topo.tris[u as usize];
    a.iter()
        .copied()
        .find(|&x| x != v && b.contains(&x))
        .unwrap_or(NONE)
}

/// Position of a duplicated vertex `v'` on the segment from `v` to the mean of the fan's
/// inner neighbours, with its margin: half way when that leaves every face around it
/// unfolded (`margin` > 0), else the candidate (1/2, 1/3, 2/3, 1/5, 4/5 of the way) with the
/// largest margin — near a nearly straight boundary the midpoint can fall across an end
/// face's edge, and along slivers no candidate may be valid (margin ≤ 0).
pub(super) fn place_duplicate(
    v: DVec3,
    mean: DVec3,
    margin: impl Fn(DVec3) -> f64,
) -> (DVec3, f64) {
    let mut best = (0.5 * (v + mean), f64::NEG_INFINITY);
    for t in [0.5, 1.0 / 3.0, 2.0 / 3.0, 0.2, 0.8] {
        let cand = v + t * (mean - v);
        let m = margin(cand);
        if m > 0.0 {
            return (cand, m);
        }
        if m > best.1 {
            best = (cand, m);
        }
    }
    best
}

/// Whether a vertex duplication of `fan` can leave its faces unfolded, judged on the
/// triangles alone (before the matching): the margin ([`place_duplicate`]) of the end
/// triangles with `v'` inserted and the middle triangles with `v` replaced by `v'`. Used to
/// price the fan's extra edge ([`super::graph::build`]).
pub(crate) fn duplication_margin(topo: &SurfaceTopo, coords: &[DVec3], fan: &Fan) -> f64 {
    const VP: u32 = u32::MAX;
    let v = fan.v;
    let k = fan.tris.len();
    let frame = (k >= 2).then(|| fan_frame(topo, coords, fan)).flatten();
    let Some(FanFrame { near, mean, normal }) = frame else {
        return f64::NEG_INFINITY;
    };
    let mut polys: Vec<Vec<u32>> = Vec::with_capacity(k);
    for (end, a) in [(fan.tris[0], near[0]), (fan.tris[k - 1], near[k - 2])] {
        let tri = topo.tris[end as usize];
        let Some(iv) = tri.iter().position(|&p| p == v) else {
            return f64::NEG_INFINITY;
        };
        let mut poly = tri.to_vec();
        if tri[(iv + 1) % 3] == a {
            poly.insert(iv + 1, VP);
        } else {
            poly.insert(iv, VP);
        }
        polys.push(poly);
    }
    for &t in &fan.tris[1..k - 1] {
        polys.push(
            topo.tris[t as usize]
                .iter()
                .map(|&p| if p == v { VP } else { p })
                .collect(),
        );
    }
    place_duplicate(coords[v as usize], mean, |cand| {
        worst_margin(
            polys.iter().map(|p| &p[..]),
            |i| if i == VP { cand } else { coords[i as usize] },
            normal,
        )
    })
    .1
}

/// What a vertex duplication of a fan at `v` needs: `near[i]`, the node shared by fan
/// triangles `i` and `i + 1` besides `v`; their mean; and the fan's normal (sum of its
/// triangles' normals).
pub(super) struct FanFrame {
    pub near: Vec<u32>,
    pub mean: DVec3,
    pub normal: DVec3,
}

/// The [`FanFrame`] of `fan`; `None` when two successive triangles share no edge at `v`.
pub(super) fn fan_frame(topo: &SurfaceTopo, coords: &[DVec3], fan: &Fan) -> Option<FanFrame> {
    let near: Vec<u32> = fan
        .tris
        .windows(2)
        .map(|w| shared_other(topo, w[0], w[1], fan.v))
        .collect();
    if near.contains(&NONE) {
        return None;
    }
    let mean = near.iter().map(|&a| coords[a as usize]).sum::<DVec3>() / near.len() as f64;
    let normal = fan
        .tris
        .iter()
        .map(|&t| tri_normal(coords, topo.tris[t as usize]))
        .sum();
    Some(FanFrame { near, mean, normal })
}

/// The smallest [`unfolded_margin`] over `polys` (node ids placed by `at`).
pub(super) fn worst_margin<'p>(
    polys: impl Iterator<Item = &'p [u32]>,
    at: impl Fn(u32) -> DVec3,
    normal: DVec3,
) -> f64 {
    polys
        .map(|poly| {
            let pts: Vec<DVec3> = poly.iter().map(|&i| at(i)).collect();
            unfolded_margin(&pts, normal)
        })
        .fold(f64::INFINITY, f64::min)
}

/// How far polygon `pts` is from folded, seen along `normal`: for a quad, the larger over its
/// two diagonals of the smaller signed area of the two triangles the diagonal cuts it into
/// (positive iff the quad is a simple polygon oriented like `normal`); for a triangle its
/// signed area; other polygons count as unfolded.
fn unfolded_margin(pts: &[DVec3], normal: DVec3) -> f64 {
    let area = |a: DVec3, b: DVec3, c: DVec3| (b - a).cross(c - a).dot(normal);
    match pts {
        [a, b, c] => area(*a, *b, *c),
        [a, b, c, d] => {
            let d02 = area(*a, *b, *c).min(area(*a, *c, *d));
            let d13 = area(*b, *c, *d).min(area(*b, *d, *a));
            d02.max(d13)
        }
        _ => f64::INFINITY,
    }
}
