//! The validity of second-order elements (module doc, "Validity"): the Bézier
//! coefficients of a quad's Jacobian determinant, and a line3's direction.

use super::*;

/// True when the 9-node quad `x` (an 8-node quad with its serendipity centre as node 8)
/// is valid as Gmsh measures it, and its straight-sided normal agrees with `reference`
/// (the linear quad's): every Bézier coefficient of its Jacobian determinant, measured
/// about that normal, is strictly positive. This implies a positive determinant over the
/// whole element, and it is what makes Gmsh's `minSJ` positive: Gmsh bounds the scaled
/// Jacobian from below by ratios of Bézier coefficients (degree-raised and subdivided,
/// which keeps positive coefficients positive) and reports a negative bound for valid
/// elements whose coefficients are not all positive at the depth it stops at. A
/// straight-sided quad passes exactly when its corners turn positively.
pub fn quad_valid(x: &[DVec3; 9], reference: DVec3) -> bool {
    let n = straight_normal(x);
    if n.dot(reference).partial_cmp(&0.0) != Some(std::cmp::Ordering::Greater)
        || x.iter().any(|p| !p.is_finite())
    {
        return false;
    }
    let n = n.normalize_or_zero();
    jacobian_positive(
        &|u, v| {
            let (xu, xv) = quad9_derivatives(x, u, v);
            xu.cross(xv).dot(n)
        },
        0,
    )
}

/// Inverse of the cubic Bernstein collocation matrix at 0, 1/3, 2/3, 1.
pub(super) fn bernstein_inverse() -> [[f64; 4]; 4] {
    // M[i][j] = C(3, j) s_i^j (1 - s_i)^(3 - j)
    let binom = [1.0, 3.0, 3.0, 1.0];
    let mut m = [[0.0f64; 8]; 4];
    for (i, row) in m.iter_mut().enumerate() {
        let s = i as f64 / 3.0;
        for j in 0..4 {
            row[j] = binom[j] * s.powi(j as i32) * (1.0 - s).powi(3 - j as i32);
        }
        row[4 + i] = 1.0;
    }
    // Gauss-Jordan with partial pivoting (the matrix is well conditioned)
    for c in 0..4 {
        let p = (c..4)
            .max_by(|&a, &b| m[a][c].abs().total_cmp(&m[b][c].abs()))
            .unwrap_or(c);
        m.swap(c, p);
        let d = m[c][c];
        for v in m[c].iter_mut() {
            *v /= d;
        }
        for r in 0..4 {
            if r != c {
                let f = m[r][c];
                let pivot = m[c];
                for (v, pv) in m[r].iter_mut().zip(pivot) {
                    *v -= f * pv;
                }
            }
        }
    }
    let mut inv = [[0.0; 4]; 4];
    for i in 0..4 {
        inv[i].copy_from_slice(&m[i][4..]);
    }
    inv
}

/// True when the polynomial `f` of degree at most 3 in each of ξ, η is certified strictly
/// positive on [-1, 1]²: its Bézier coefficients on a box bound it; boxes whose
/// coefficients are not all positive are split in four, up to `max_depth` levels (then the
/// answer is `false`). With `max_depth` 0 this is the whole element's coefficients alone.
pub fn jacobian_positive(f: &dyn Fn(f64, f64) -> f64, max_depth: u32) -> bool {
    let inv = bernstein_inverse();
    let mut stack = vec![(-1.0f64, -1.0f64, 2.0f64, 0u32)];
    let mut boxes = 0;
    while let Some((u0, v0, w, depth)) = stack.pop() {
        boxes += 1;
        if boxes > 4096 {
            return false;
        }
        let mut s = [[0.0f64; 4]; 4];
        for (i, row) in s.iter_mut().enumerate() {
            for (j, v) in row.iter_mut().enumerate() {
                *v = f(u0 + w * i as f64 / 3.0, v0 + w * j as f64 / 3.0);
                if (*v).partial_cmp(&0.0) != Some(std::cmp::Ordering::Greater) {
                    return false;
                }
            }
        }
        // C = inv · S · invᵀ
        let mut t = [[0.0f64; 4]; 4];
        for i in 0..4 {
            for j in 0..4 {
                t[i][j] = (0..4).map(|k| inv[i][k] * s[k][j]).sum();
            }
        }
        let mut min_c = f64::INFINITY;
        for row in &t {
            for inv_j in &inv {
                let c: f64 = row.iter().zip(inv_j).map(|(a, b)| a * b).sum();
                min_c = min_c.min(c);
            }
        }
        if min_c > 0.0 {
            continue;
        }
        if depth >= max_depth {
            return false;
        }
        let h = w * 0.5;
        for (du, dv) in [(0.0, 0.0), (h, 0.0), (0.0, h), (h, h)] {
            stack.push((u0 + du, v0 + dv, h, depth + 1));
        }
    }
    true
}

/// True when the line3 `(a, b, m)` runs forward along its chord at both ends (its tangent
/// is linear in ξ, so then everywhere).
pub(super) fn line_valid(a: DVec3, b: DVec3, m: DVec3) -> bool {
    let chord = b - a;
    let tangent = |xi: f64| a * (xi - 0.5) + b * (xi + 0.5) - m * (2.0 * xi);
    tangent(-1.0).dot(chord) > 0.0 && tangent(1.0).dot(chord) > 0.0
}
