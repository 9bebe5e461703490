//! Geometry shared by the graph, the cross field and the post-processing: triangle
//! normals, the quad two triangles make, hopeless corners, and node sets. The edge costs
//! use the crate's one signed-η kernel, [`crate::quality::eta_signed_fast`].

use glam::DVec3;
use rayon::prelude::*;

use super::topology::SurfaceTopo;
use crate::quality::eta::{corner_eta, signed_angle};

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
/// 22.5°. A lower bound lets the matching put consecutive wall nodes of a curved edge into
/// one quad with a corner no smoothing can open (figures in BENCHMARKS.md, "Measurements
/// behind the defaults").
pub const FIXED_CORNER_MIN_ETA: f64 = 0.25;

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
    has_corner_at_most(pts, normal, on_wall, FIXED_CORNER_MIN_ETA)
}

/// Corner quality at most which a corner at a parity-split node counts as flat: the split
/// node lies on the chord of a straight boundary (an angle above about 179°), so the quad
/// of the split triangle's two halves is never valid.
pub(crate) const FLAT_SPLIT_ETA: f64 = 0.01;

/// True when a corner `k` of the quad with `on_wall(k)` has corner quality ≤ `eta`.
/// `normal` need not be of unit length.
pub(crate) fn has_corner_at_most(
    pts: &[DVec3; 4],
    normal: DVec3,
    on_wall: impl Fn(usize) -> bool,
    eta: f64,
) -> bool {
    // the unit normal only when some corner is on a wall (most quads have none)
    let mut unit = None;
    (0..4).any(|k| {
        on_wall(k) && {
            let unit = *unit.get_or_insert_with(|| normal.normalize_or_zero());
            corner_eta(signed_angle(pts, unit, k)) <= eta
        }
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::quality::{eta_signed, eta_signed_fast};

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
