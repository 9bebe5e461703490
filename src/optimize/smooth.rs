//! Vertex smoothing (paper section 6, ref. [20]) that respects the size field's gradation.
//!
//! Each free node is moved towards the *size-weighted centroid* of its star: the minimizer of
//! Σ_j w_j |x − x_j|² with w_j = 1/h_j² for the edge neighbours and `diag`/h_j² for the
//! opposite corners of its quads, h_j being the size at the middle of the segment (mean of the
//! two nodal sizes). With l^h ≈ |x − x_j| / h_j (eq. 1), that is the spring energy Σ (l^h)²,
//! so nodes settle where adimensional lengths balance and gradation is kept; for a constant h
//! it is the plain quad-centroid Laplacian. The move is tried at full length, then at 1/2 and
//! 1/4 (a backtracking line search between the node and the target, cheaper than Gmsh's
//! golden section and measured to reach the same quality), and accepted at the first step
//! where the star's worst signed η (eq. 3 with the surface normal, so inverted quads score
//! below zero) does not drop. On curved surfaces every candidate is projected back onto the
//! reference triangulation by a local walk from the node's current triangle.

use super::local::{rotate_to, Local};

/// Runs `iterations` Gauss-Seidel sweeps over the free nodes; returns the number of accepted
/// moves. Stops early when a sweep moves nothing by more than 1e-4 h. `diag` is the weight of
/// the opposite corners relative to edge neighbours.
pub(crate) fn smooth(l: &mut Local, iterations: usize, diag: f64) -> usize {
    let mut cache: Vec<f64> = (0..l.quads.len() as u32)
        .map(|q| {
            if l.alive[q as usize] {
                l.quality(q)
            } else {
                0.0
            }
        })
        .collect();
    let mut buf: Vec<f64> = Vec::with_capacity(16);
    let mut moves = 0usize;
    for _ in 0..iterations {
        let mut significant = 0usize;
        for v in 0..l.pos.len() as u32 {
            let vi = v as usize;
            if l.fixed[vi] || l.removed[vi] {
                continue;
            }
            let star = l.star(v);
            if star.is_empty() {
                continue;
            }
            let old_min = star
                .iter()
                .map(|&q| cache[q as usize])
                .fold(f64::INFINITY, f64::min);
            let x0 = l.pos[vi];
            let hv = l.h[vi];
            let mut acc = glam::DVec3::ZERO;
            let mut wsum = 0.0;
            for &q in star {
                let Some(r) = rotate_to(&l.quads[q as usize], v) else {
                    continue;
                };
                for (k, w0) in [(1usize, 1.0), (2, diag), (3, 1.0)] {
                    let j = r[k] as usize;
                    let hm = 0.5 * (hv + l.h[j]);
                    let w = w0 / (hm * hm);
                    acc += l.pos[j] * w;
                    wsum += w;
                }
            }
            if wsum <= 0.0 || !wsum.is_finite() {
                continue;
            }
            let target = acc / wsum;
            let step = target - x0;
            if step.length_squared() <= (1e-12 * hv) * (1e-12 * hv) {
                continue;
            }
            for t in [1.0, 0.5, 0.25] {
                let (cand, tri) = l.project(v, x0 + step * t);
                buf.clear();
                let mut new_min = f64::INFINITY;
                for &q in l.star(v) {
                    let e = l.quality_with(q, v, cand);
                    new_min = new_min.min(e);
                    buf.push(e);
                }
                if new_min >= old_min {
                    if cand.distance(x0) > 1e-4 * hv {
                        significant += 1;
                    }
                    l.pos[vi] = cand;
                    l.tri[vi] = tri;
                    for (&q, &e) in l.star(v).iter().zip(&buf) {
                        cache[q as usize] = e;
                    }
                    moves += 1;
                    break;
                }
            }
        }
        if significant == 0 {
            break;
        }
    }
    moves
}

/// Quality-maximizing sweeps: each free node tries small moves (a pattern search in the
/// tangent plane, steps 0.2 h, 0.1 h, 0.05 h along two tangent axes and their diagonals) and
/// keeps the one that most raises the mean signed η of its star without lowering the
/// star's worst η. Returns the number of accepted moves.
pub(crate) fn optimize_angles(l: &mut Local, sweeps: usize) -> usize {
    let mut moves = 0usize;
    let mut buf: Vec<f64> = Vec::with_capacity(16);
    for _ in 0..sweeps {
        for v in 0..l.pos.len() as u32 {
            let vi = v as usize;
            if l.fixed[vi] || l.removed[vi] || l.star(v).is_empty() {
                continue;
            }
            let n = l.nrm[vi];
            let t1 = n.any_orthonormal_vector();
            let t2 = n.cross(t1);
            let eval = |l: &Local, p: glam::DVec3, buf: &mut Vec<f64>| {
                buf.clear();
                for &q in l.star(v) {
                    buf.push(l.quality_with(q, v, p));
                }
                let min = buf.iter().copied().fold(f64::INFINITY, f64::min);
                let mean = buf.iter().sum::<f64>() / buf.len() as f64;
                (min, mean)
            };
            let x0 = l.pos[vi];
            let (min0, mut best_mean) = eval(l, x0, &mut buf);
            let mut best: Option<(glam::DVec3, u32)> = None;
            let h = l.h[vi];
            let dirs = [
                t1,
                -t1,
                t2,
                -t2,
                (t1 + t2) * std::f64::consts::FRAC_1_SQRT_2,
                (t1 - t2) * std::f64::consts::FRAC_1_SQRT_2,
                (-t1 + t2) * std::f64::consts::FRAC_1_SQRT_2,
                (-t1 - t2) * std::f64::consts::FRAC_1_SQRT_2,
            ];
            for s in [0.2, 0.1, 0.05] {
                let base = best.map_or(x0, |b| b.0);
                for d in dirs {
                    let (p, tri) = l.project(v, base + d * (s * h));
                    let (mn, me) = eval(l, p, &mut buf);
                    if mn >= min0 && me > best_mean + 1e-9 {
                        best_mean = me;
                        best = Some((p, tri));
                    }
                }
            }
            if let Some((p, tri)) = best {
                l.pos[vi] = p;
                l.tri[vi] = tri;
                moves += 1;
            }
        }
    }
    moves
}
