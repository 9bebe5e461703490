//! Internal renumbering of a big surface's triangles along a Hilbert curve, for memory
//! locality: triangles close on the surface get close numbers, so the topology, the graph
//! costs and the post-processing read neighbouring entries of their arrays instead of
//! jumping through the whole surface (input meshes often number triangles in an order with
//! no locality at all: neighbours a third of the surface apart).
//!
//! The renumbering never shows outside: everything that leaves the surface's work (the
//! matching graph, the quads and their source triangles, the order of extra edges, region
//! numbers) is given in the input numbering and order, so the output is what it was without
//! it.

use glam::DVec3;
use rayon::prelude::*;

/// Surfaces with fewer triangles keep the input numbering (their arrays fit in cache).
pub(crate) const MIN_TRIANGLES: usize = 1 << 14;

/// Bits per axis of the Hilbert key (a 2^16 grid per axis over the bounding box).
const BITS: u32 = 16;

/// A permutation of a surface's triangles: `new → input` and `input → new`, or the identity
/// (both empty).
#[derive(Debug, Clone, Default)]
pub(crate) struct Renumbering {
    /// `orig[t]`: input position of triangle `t`.
    orig: Vec<u32>,
    /// `new_of[i]`: number of the triangle at input position `i`.
    new_of: Vec<u32>,
}

impl Renumbering {
    /// The permutation sorting `order` (`order[t]` = input position of new triangle `t`).
    pub fn from_order(order: Vec<u32>) -> Self {
        let mut new_of = vec![0u32; order.len()];
        for (t, &i) in order.iter().enumerate() {
            new_of[i as usize] = t as u32;
        }
        Renumbering {
            orig: order,
            new_of,
        }
    }

    /// True for the identity.
    #[inline]
    pub fn is_identity(&self) -> bool {
        self.orig.is_empty()
    }

    /// Input position of triangle `t`.
    #[inline]
    pub fn orig(&self, t: u32) -> u32 {
        if self.orig.is_empty() {
            t
        } else {
            self.orig[t as usize]
        }
    }

    /// Triangle at input position `i`.
    #[inline]
    pub fn new_of(&self, i: u32) -> u32 {
        if self.new_of.is_empty() {
            i
        } else {
            self.new_of[i as usize]
        }
    }

    /// Reorders `v` (in input order) into the new order.
    pub fn apply<T: Copy + Send + Sync>(&self, v: Vec<T>) -> Vec<T> {
        if self.is_identity() {
            return v;
        }
        self.orig.par_iter().map(|&i| v[i as usize]).collect()
    }
}

/// The Hilbert order of the triangles' centroids (ties, equal keys, in input order), or
/// the identity for fewer than [`MIN_TRIANGLES`] triangles or a degenerate bounding box.
pub(crate) fn hilbert_order(tris: &[[u32; 3]], coords: &[DVec3]) -> Renumbering {
    if tris.len() < MIN_TRIANGLES {
        return Renumbering::default();
    }
    let centroid = |t: &[u32; 3]| {
        (coords[t[0] as usize] + coords[t[1] as usize] + coords[t[2] as usize]) / 3.0
    };
    let (lo, hi) = tris
        .par_iter()
        .with_min_len(4096)
        .map(|t| {
            let c = centroid(t);
            (c, c)
        })
        .reduce(
            || (DVec3::splat(f64::INFINITY), DVec3::splat(f64::NEG_INFINITY)),
            |a, b| (a.0.min(b.0), a.1.max(b.1)),
        );
    let ext = (hi - lo).max_element();
    if !(ext > 0.0 && ext.is_finite()) {
        return Renumbering::default();
    }
    let scale = ((1u64 << BITS) - 1) as f64 / ext;
    let mut keyed: Vec<(u64, u32)> = tris
        .par_iter()
        .with_min_len(4096)
        .enumerate()
        .map(|(i, t)| {
            let c = (centroid(t) - lo) * scale;
            let q = |x: f64| if x.is_finite() { x.max(0.0) as u32 } else { 0 };
            (hilbert_key([q(c.x), q(c.y), q(c.z)], BITS), i as u32)
        })
        .collect();
    crate::keysort::radix_sort_by_key(&mut keyed, |x| x.0);
    Renumbering::from_order(keyed.into_iter().map(|x| x.1).collect())
}

/// Position of the grid cell `x` (each coordinate below 2^`bits`) along the 3D Hilbert
/// curve through the 2^(3·bits) cells: consecutive positions are cells sharing a face.
/// (Skilling's transposed form: undo the excess work of the axes, Gray-code them, then
/// interleave the bits, most significant first.)
pub(crate) fn hilbert_key(mut x: [u32; 3], bits: u32) -> u64 {
    let top = 1u32 << (bits - 1);
    let mut q = top;
    while q > 1 {
        let p = q - 1;
        for i in 0..3 {
            if x[i] & q != 0 {
                x[0] ^= p;
            } else {
                let t = (x[0] ^ x[i]) & p;
                x[0] ^= t;
                x[i] ^= t;
            }
        }
        q >>= 1;
    }
    x[1] ^= x[0];
    x[2] ^= x[1];
    let mut t = 0;
    let mut q = top;
    while q > 1 {
        if x[2] & q != 0 {
            t ^= q - 1;
        }
        q >>= 1;
    }
    for v in x.iter_mut() {
        *v ^= t;
    }
    let mut key = 0u64;
    for b in (0..bits).rev() {
        for v in x {
            key = (key << 1) | ((v >> b) & 1) as u64;
        }
    }
    key
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_hilbert_curve_walks_from_cell_to_face_neighbour() {
        for bits in [1u32, 2, 3, 4] {
            let side = 1u32 << bits;
            let mut cells: Vec<(u64, [u32; 3])> = Vec::new();
            for x in 0..side {
                for y in 0..side {
                    for z in 0..side {
                        cells.push((hilbert_key([x, y, z], bits), [x, y, z]));
                    }
                }
            }
            cells.sort_unstable();
            // a bijection onto 0..side³
            for (i, c) in cells.iter().enumerate() {
                assert_eq!(c.0, i as u64, "bits {bits}");
            }
            // consecutive cells share a face
            for w in cells.windows(2) {
                let d: u32 = (0..3).map(|i| w[0].1[i].abs_diff(w[1].1[i])).sum();
                assert_eq!(d, 1, "bits {bits}: {:?} -> {:?}", w[0].1, w[1].1);
            }
        }
    }

    #[test]
    fn renumbering_is_a_permutation_with_its_inverse() {
        // a 200 x 100 strip of triangles numbered in a scrambled order
        let (nx, ny) = (200u32, 100u32);
        let mut coords = Vec::new();
        for j in 0..=ny {
            for i in 0..=nx {
                coords.push(DVec3::new(i as f64, j as f64, 0.0));
            }
        }
        let id = |i: u32, j: u32| j * (nx + 1) + i;
        let mut tris = Vec::new();
        for j in 0..ny {
            for i in 0..nx {
                tris.push([id(i, j), id(i + 1, j), id(i + 1, j + 1)]);
                tris.push([id(i, j), id(i + 1, j + 1), id(i, j + 1)]);
            }
        }
        let n = tris.len();
        let scrambled: Vec<[u32; 3]> = (0..n).map(|k| tris[(k * 7919) % n]).collect();
        let r = hilbert_order(&scrambled, &coords);
        assert!(!r.is_identity());
        let mut seen = vec![false; n];
        for t in 0..n as u32 {
            let i = r.orig(t);
            assert!(!seen[i as usize]);
            seen[i as usize] = true;
            assert_eq!(r.new_of(i), t);
        }
        // locality: consecutive triangles in the new order are close (the centroids of the
        // scrambled order are on average a third of the strip apart)
        let c = |t: &[u32; 3]| t.iter().map(|&v| coords[v as usize]).sum::<DVec3>() / 3.0;
        let renum = r.apply(scrambled.clone());
        let mean = |v: &[[u32; 3]]| {
            v.windows(2)
                .map(|w| c(&w[0]).distance(c(&w[1])))
                .sum::<f64>()
                / (n - 1) as f64
        };
        assert!(mean(&renum) < 1.5, "{}", mean(&renum));
        assert!(mean(&scrambled) > 30.0, "{}", mean(&scrambled));
        // small surfaces keep their numbering
        assert!(hilbert_order(&scrambled[..1000], &coords).is_identity());
    }
}
