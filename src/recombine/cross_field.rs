//! A smooth cross field on the triangles of one surface, for the paper's alignment cost
//! (section 4.3, eq. 7).
//!
//! A cross (four directions 90° apart) at angle θ in a triangle's frame is stored as the
//! unit complex number `z = e^{4iθ}`, which is the same for all four directions. The field
//! minimizes the discrete Dirichlet energy `Σ |z_t − s_tu z_u|²` over the graph edges `(t, u)`
//! (the *connection Laplacian*: `s_tu = (c_t · conj(c_u))⁴` carries a cross from `u`'s frame
//! to `t`'s by unfolding the two triangles about their shared edge, `c_t` being the unit
//! direction of that edge in `t`'s frame), with every triangle that has a wall edge fixed to
//! that wall's direction (several walls are averaged in the `4θ` representation; a triangle
//! whose walls disagree too much, as at a sharp corner, stays free). This is a harmonic
//! interpolation of the walls' directions: unlike the nearest-wall field
//! ([`boundary_cross_field`]), which jumps on the medial axis, it turns
//! gradually between walls, and its magnitude `|z|` drops towards 0 near the field's
//! singularities, where no direction is meaningful.
//!
//! The linear system (Hermitian positive definite when a component has a fixed triangle) is
//! solved by conjugate gradients started from the nearest-wall field, which is exact where
//! all walls agree (an axis-aligned rectangle, whose field is constant): CG then stops at
//! once. The iteration count is capped ([`MAX_ITERATIONS`]), so the cost is linear in the
//! mesh size.

use glam::DVec3;
use rayon::prelude::*;

use super::geometry::NodeSet;
use super::topology::{SurfaceTopo, NONE};

/// Cap on conjugate-gradient iterations. The field only steers a cost; a direction error of
/// a degree is irrelevant, so the solve stops at a relative residual of [`TOLERANCE`] or
/// after this many iterations.
pub const MAX_ITERATIONS: usize = 400;

/// Relative residual (`‖r‖ / ‖b‖`) at which the conjugate-gradient solve stops.
pub const TOLERANCE: f64 = 1e-4;

/// A minimal complex number (re, im).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
struct C(f64, f64);

impl C {
    #[inline]
    fn mul(self, o: C) -> C {
        C(self.0 * o.0 - self.1 * o.1, self.0 * o.1 + self.1 * o.0)
    }
    #[inline]
    fn conj(self) -> C {
        C(self.0, -self.1)
    }
    #[inline]
    fn norm2(self) -> f64 {
        self.0 * self.0 + self.1 * self.1
    }
    #[inline]
    fn pow4(self) -> C {
        let s = self.mul(self);
        s.mul(s)
    }
    #[inline]
    fn unit(self) -> C {
        let r = self.norm2().sqrt();
        if r > 0.0 {
            C(self.0 / r, self.1 / r)
        } else {
            C(0.0, 0.0)
        }
    }
}

/// The smooth cross field of a surface: per triangle a unit tangent `t1` (the cross is
/// `t1, n × t1`) and a confidence in [0, 1] (`|z|`, 1 along walls, dropping towards the
/// field's singularities).
#[derive(Default)]
pub(crate) struct CrossField {
    /// One cross direction per triangle (unit, in the triangle's plane).
    pub t1: Vec<DVec3>,
    /// `|z|` per triangle, clamped to [0, 1].
    pub weight: Vec<f64>,
}

/// Per-triangle orthonormal frame `(e1, e2)` in its plane: `e1` along the first edge.
fn frame(coords: &[DVec3], tri: [u32; 3]) -> (DVec3, DVec3) {
    let (a, b, c) = (
        coords[tri[0] as usize],
        coords[tri[1] as usize],
        coords[tri[2] as usize],
    );
    let e1 = (b - a).normalize_or_zero();
    let n = (b - a).cross(c - a).normalize_or_zero();
    (e1, n.cross(e1))
}

/// Direction `d` as a unit complex number in the frame `f` (0 when `d` is normal or zero).
#[inline]
fn in_frame(f: (DVec3, DVec3), d: DVec3) -> C {
    C(d.dot(f.0), d.dot(f.1)).unit()
}

/// Solves for the smooth cross field (module docs). `coords` are indexed by the global node
/// ids of `topo.tris`; `normals` are the triangles' `geometry::triangle_normals`.
pub(crate) fn smooth_cross_field(
    topo: &SurfaceTopo,
    coords: &[DVec3],
    normals: &[DVec3],
) -> CrossField {
    let n = topo.len();
    let frames: Vec<(DVec3, DVec3)> = topo.tris.iter().map(|&t| frame(coords, t)).collect();
    // transports s_tu per half-edge (3t + k) and the wall constraint per triangle
    let mut s = vec![C::default(); 3 * n];
    let mut fixed = vec![false; n];
    let mut z = vec![C::default(); n];
    for t in 0..n {
        let tri = topo.tris[t];
        let mut wall = C::default();
        let mut walls = 0usize;
        for k in 0..3 {
            let e = coords[tri[(k + 1) % 3] as usize] - coords[tri[k] as usize];
            let ct = in_frame(frames[t], e);
            let u = topo.nbr[3 * t + k];
            if u == NONE {
                let w = ct.pow4();
                wall = C(wall.0 + w.0, wall.1 + w.1);
                walls += 1;
            } else {
                let cu = in_frame(frames[u as usize], e);
                s[3 * t + k] = ct.mul(cu.conj()).pow4();
            }
        }
        if walls > 0 && wall.norm2().sqrt() >= 0.7 * walls as f64 {
            fixed[t] = true;
            z[t] = wall.unit();
        }
    }
    if !fixed.iter().any(|&f| f) {
        // no usable wall: keep the nearest-wall field (a fixed global direction)
        let t1 = boundary_cross_field(topo, coords, normals);
        return CrossField {
            t1,
            weight: vec![1.0; n],
        };
    }
    // initial guess on the free triangles: the nearest-wall field
    let bfs = boundary_cross_field(topo, coords, normals);
    for t in 0..n {
        if !fixed[t] {
            z[t] = in_frame(frames[t], bfs[t]).pow4();
        }
    }
    // (Σ s_tu x_u over t's neighbours u, or only over the fixed ones; number of neighbours)
    let neighbour_sum = |t: usize, x: &[C], only_fixed: bool| -> (C, f64) {
        let mut acc = C::default();
        let mut deg = 0.0;
        for k in 0..3 {
            let u = topo.nbr[3 * t + k];
            if u == NONE {
                continue;
            }
            deg += 1.0;
            if !only_fixed || fixed[u as usize] {
                let v = s[3 * t + k].mul(x[u as usize]);
                acc = C(acc.0 + v.0, acc.1 + v.1);
            }
        }
        (acc, deg)
    };
    // A x on the free triangles: deg_t x_t − Σ_{u free} s_tu x_u (fixed entries of x are 0)
    let apply = |x: &[C], out: &mut [C]| {
        for t in 0..n {
            out[t] = if fixed[t] {
                C::default()
            } else {
                let (acc, deg) = neighbour_sum(t, x, false);
                C(deg * x[t].0 - acc.0, deg * x[t].1 - acc.1)
            };
        }
    };
    // b_t = Σ_{u fixed} s_tu z_u; r = b − A x0 computed as −(full operator applied to z)
    let mut r = vec![C::default(); n];
    let mut bnorm2 = 0.0;
    for t in 0..n {
        if fixed[t] {
            continue;
        }
        let (acc, deg) = neighbour_sum(t, &z, false);
        r[t] = C(acc.0 - deg * z[t].0, acc.1 - deg * z[t].1);
        bnorm2 += neighbour_sum(t, &z, true).0.norm2();
    }
    let dot = |a: &[C], b: &[C]| -> f64 {
        // Re <a, b>; for the Hermitian system the needed products are real
        a.iter().zip(b).map(|(x, y)| x.0 * y.0 + x.1 * y.1).sum()
    };
    let mut p = r.clone();
    let mut ap = vec![C::default(); n];
    let mut rr = dot(&r, &r);
    let stop = TOLERANCE * TOLERANCE * bnorm2.max(f64::MIN_POSITIVE);
    let mut iterations = 0usize;
    while iterations < MAX_ITERATIONS && rr > stop {
        apply(&p, &mut ap);
        let pap = dot(&p, &ap);
        if pap <= 0.0 || !pap.is_finite() {
            break;
        }
        let alpha = rr / pap;
        for t in 0..n {
            if !fixed[t] {
                z[t] = C(z[t].0 + alpha * p[t].0, z[t].1 + alpha * p[t].1);
                r[t] = C(r[t].0 - alpha * ap[t].0, r[t].1 - alpha * ap[t].1);
            }
        }
        let rr_new = dot(&r, &r);
        let beta = rr_new / rr;
        rr = rr_new;
        for t in 0..n {
            p[t] = C(r[t].0 + beta * p[t].0, r[t].1 + beta * p[t].1);
        }
        iterations += 1;
    }
    let mut t1 = vec![DVec3::ZERO; n];
    let mut weight = vec![0.0; n];
    for t in 0..n {
        let m = z[t].norm2().sqrt();
        weight[t] = m.min(1.0);
        let (e1, e2) = frames[t];
        t1[t] = if m > 0.0 {
            let phi = z[t].1.atan2(z[t].0) / 4.0;
            e1 * phi.cos() + e2 * phi.sin()
        } else {
            bfs[t]
        };
    }
    CrossField { t1, weight }
}

/// A cross field on the triangles of a surface (paper section 4.2, eq. 7): per triangle one
/// unit tangent `t1` (with `t2 = n × t1`), the direction of the nearest wall edge in
/// graph steps (multi-source breadth-first search from the triangles with a wall edge),
/// carried from triangle to triangle by projection on each one's plane. Surfaces without
/// walls get the projection of the x axis (or y where x is normal). `normals` are the
/// triangles' [`triangle_normals`](super::geometry::triangle_normals).
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::recombine::geometry::triangle_normals;

    /// A structured triangulation of `[0, 1]²` (`m × m` cells, each split in two) mapped by
    /// `f`, with its adjacency: edges used once are walls.
    fn mesh(m: usize, f: impl Fn(f64, f64) -> DVec3) -> (SurfaceTopo, Vec<DVec3>) {
        let id = |i: usize, j: usize| (j * (m + 1) + i) as u32;
        let mut coords = Vec::new();
        for j in 0..=m {
            for i in 0..=m {
                coords.push(f(i as f64 / m as f64, j as f64 / m as f64));
            }
        }
        let mut tris = Vec::new();
        for j in 0..m {
            for i in 0..m {
                let (a, b, c, d) = (id(i, j), id(i + 1, j), id(i + 1, j + 1), id(i, j + 1));
                if (i + j) % 2 == 0 {
                    tris.push([a, b, c]);
                    tris.push([a, c, d]);
                } else {
                    tris.push([a, b, d]);
                    tris.push([b, c, d]);
                }
            }
        }
        let mut half: std::collections::HashMap<(u32, u32), u32> = Default::default();
        for (t, tri) in tris.iter().enumerate() {
            for k in 0..3 {
                half.insert((tri[k], tri[(k + 1) % 3]), t as u32);
            }
        }
        let mut nbr = vec![NONE; 3 * tris.len()];
        for (t, tri) in tris.iter().enumerate() {
            for k in 0..3 {
                if let Some(&u) = half.get(&(tri[(k + 1) % 3], tri[k])) {
                    nbr[3 * t + k] = u;
                }
            }
        }
        (SurfaceTopo { tris, nbr }, coords)
    }

    /// Angle of the cross of every triangle in `[0, π/2)` (planar meshes in the xy plane).
    fn angles(t1: &[DVec3]) -> Vec<f64> {
        let q = std::f64::consts::FRAC_PI_2;
        t1.iter().map(|d| d.y.atan2(d.x).rem_euclid(q)).collect()
    }

    /// Largest angle between the crosses of two neighbouring triangles with no wall edge
    /// (wall triangles on two walls meeting at a corner differ by the corner's angle).
    fn max_jump(topo: &SurfaceTopo, t1: &[DVec3]) -> f64 {
        let a = angles(t1);
        let q = std::f64::consts::FRAC_PI_2;
        let inner = |t: usize| (0..3).all(|k| topo.nbr[3 * t + k] != NONE);
        let mut worst: f64 = 0.0;
        for t in (0..topo.len()).filter(|&t| inner(t)) {
            for k in 0..3 {
                let u = topo.nbr[3 * t + k] as usize;
                if inner(u) {
                    let d = (a[t] - a[u]).rem_euclid(q);
                    worst = worst.max(d.min(q - d));
                }
            }
        }
        worst
    }

    #[test]
    fn the_field_of_an_axis_aligned_rectangle_is_the_axes() {
        let (topo, coords) = mesh(12, |x, y| DVec3::new(2.0 * x, y, 0.0));
        let f = smooth_cross_field(&topo, &coords, &triangle_normals(&topo, &coords));
        for (t, d) in f.t1.iter().enumerate() {
            assert!((d.length() - 1.0).abs() < 1e-9);
            assert!(d.x.abs().max(d.y.abs()) > 1.0 - 1e-9, "triangle {t}: {d:?}");
            assert!(f.weight[t] > 1.0 - 1e-6, "{}", f.weight[t]);
        }
    }

    #[test]
    fn the_field_follows_the_walls_and_turns_smoothly_between_them() {
        // bottom wall horizontal, top wall rising at atan(0.5) ≈ 26.6°, sides vertical
        let (topo, coords) = mesh(24, |x, y| DVec3::new(x, y * (1.0 + 0.5 * x), 0.0));
        let f = smooth_cross_field(&topo, &coords, &triangle_normals(&topo, &coords));
        let nrm = DVec3::Z;
        for t in 0..topo.len() {
            for k in 0..3 {
                if topo.nbr[3 * t + k] == NONE {
                    let tri = topo.tris[t];
                    let e = coords[tri[(k + 1) % 3] as usize] - coords[tri[k] as usize];
                    let c = cross_cost(e, f.t1[t], nrm);
                    // corner triangles average two walls; the others follow their wall
                    let walls = (0..3).filter(|&j| topo.nbr[3 * t + j] == NONE).count();
                    assert!(walls > 1 || c > 1.0 - 1e-9, "triangle {t}: cost {c}");
                }
            }
        }
        let bfs = boundary_cross_field(&topo, &coords, &triangle_normals(&topo, &coords));
        let (smooth, nearest) = (max_jump(&topo, &f.t1), max_jump(&topo, &bfs));
        // the nearest-wall field jumps by the angle between the walls on the medial axis
        assert!(nearest > 0.3, "{nearest}");
        assert!(smooth < 0.5 * nearest, "{smooth} vs {nearest}");
        // and in the middle the cross lies between the walls' directions
        let a = angles(&f.t1);
        let mid = 2 * (12 * 24 + 12); // a triangle of the centre cell
        assert!(a[mid] > 0.02 && a[mid] < 0.45, "{}", a[mid]);
    }

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
}
