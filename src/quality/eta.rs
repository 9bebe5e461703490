//! Quad quality η, eq. (3) of Remacle et al. (2012):
//! η(q) = max(1 − (2/π)·max_k |π/2 − α_k|, 0), with α_k the four interior angles.

use glam::DVec3;
use std::f64::consts::FRAC_PI_2;

/// Interior angles of the quad `p[0] p[1] p[2] p[3]`, signed with respect to `normal`.
///
/// The angle at vertex k is the rotation about `normal` that takes the edge towards
/// `p[k+1]` onto the edge towards `p[k-1]`, in (−π, π]. For a convex quad whose vertices turn
/// counter-clockwise seen from `normal`, every angle lies in (0, π); a reflex corner
/// (non-convex quad) or a folded corner gives an angle ≤ 0. Degenerate edges give 0. Only
/// the direction of `normal` matters; a zero normal gives all angles 0.
pub fn signed_angles(p: &[DVec3; 4], normal: DVec3) -> [f64; 4] {
    let normal = normal.normalize_or_zero();
    [0, 1, 2, 3].map(|k| signed_angle(p, normal, k))
}

/// The signed interior angle at corner `k` (see [`signed_angles`]); `unit_normal` must be
/// of unit length (or zero).
pub fn signed_angle(p: &[DVec3; 4], unit_normal: DVec3, k: usize) -> f64 {
    let a = p[(k + 1) % 4] - p[k];
    let b = p[(k + 3) % 4] - p[k];
    let s = unit_normal.dot(a.cross(b));
    let c = a.dot(b);
    if s == 0.0 && c == 0.0 {
        0.0
    } else {
        s.atan2(c)
    }
}

/// Quality of one corner alone: 1 − (2/π)·|π/2 − α| (the term of eq. 3 for angle α).
pub fn corner_eta(alpha: f64) -> f64 {
    1.0 - (FRAC_PI_2 - alpha).abs() / FRAC_PI_2
}

/// Signed quad quality: 1 − (2/π)·max_k |π/2 − α_k| with the corners' angles signed about
/// `normal` (`signed_angles`). Equals η (eq. 3) for valid convex quads, is ≤ 0 for degenerate,
/// non-convex or folded quads (down to −1 for a corner turned the wrong way), so it orders
/// invalid quads below every valid one. Used for matching costs (eq. 4).
pub fn eta_signed(p: &[DVec3; 4], normal: DVec3) -> f64 {
    let worst = signed_angles(p, normal)
        .iter()
        .map(|a| (FRAC_PI_2 - a).abs())
        .fold(0.0_f64, f64::max);
    1.0 - worst / FRAC_PI_2
}

/// Quad quality η, eq. (3): 1 for a perfect square, 0 when an angle is ≤ 0 or ≥ π.
///
/// The reference normal is the quad's own average normal (sum of the cross products of its
/// diagonals' halves, i.e. the Newell normal), so this works for any quad in 3D, planar or
/// not. A quad whose orientation is known (e.g. from the surface it lies on) should use
/// [`eta_signed`] with that normal to detect folding.
pub fn eta(p: &[DVec3; 4]) -> f64 {
    let normal = (p[2] - p[0]).cross(p[3] - p[1]);
    eta_signed(p, normal).max(0.0)
}

/// Same value as [`eta_signed`] (up to rounding), computed with one `atan` instead of four
/// `atan2` when the quad is valid (every corner turns positively about `normal`): the worst
/// deviation |π/2 − α| is atan(|cos α| / sin α) at the corner maximizing |a·b| / (n·(a×b)).
/// Falls back to [`eta_signed`] for invalid quads. Used on the optimizer's hot paths.
pub fn eta_signed_fast(p: &[DVec3; 4], normal: DVec3) -> f64 {
    let n = normal.normalize_or_zero();
    let mut worst = 0.0_f64;
    for k in 0..4 {
        let a = p[(k + 1) % 4] - p[k];
        let b = p[(k + 3) % 4] - p[k];
        let s = n.dot(a.cross(b));
        if s <= 0.0 {
            return eta_signed(p, normal);
        }
        worst = worst.max(a.dot(b).abs() / s);
    }
    1.0 - worst.atan() / FRAC_PI_2
}

#[cfg(test)]
mod tests {
    use super::*;

    fn q(pts: [[f64; 2]; 4]) -> [DVec3; 4] {
        pts.map(|[x, y]| DVec3::new(x, y, 0.0))
    }

    #[test]
    fn square_is_one_in_either_orientation() {
        let s = q([[0., 0.], [1., 0.], [1., 1.], [0., 1.]]);
        assert!((eta(&s) - 1.0).abs() < 1e-12);
        let r = [s[3], s[2], s[1], s[0]];
        assert!((eta(&r) - 1.0).abs() < 1e-12);
        assert!((eta_signed(&s, DVec3::Z) - 1.0).abs() < 1e-12);
        assert!(eta_signed(&r, DVec3::Z) < -0.99);
    }

    #[test]
    fn rhombus_60_degrees() {
        let h = 3f64.sqrt() / 2.0;
        let r = q([[0., 0.], [1., 0.], [1.5, h], [0.5, h]]);
        // angles 60/120: worst deviation 30 degrees -> 1 - 1/3.
        assert!((eta(&r) - 2.0 / 3.0).abs() < 1e-12, "{}", eta(&r));
    }

    #[test]
    fn non_convex_quad_is_zero_and_signed_negative() {
        // reflex corner at (0.5, 0.4)
        let d = q([[0., 0.], [1., 0.], [0.5, 0.4], [0.5, 1.]]);
        assert_eq!(eta(&d), 0.0);
        assert!(eta_signed(&d, DVec3::Z) < 0.0);
    }

    #[test]
    fn fast_signed_eta_matches_the_reference() {
        let quads = [
            q([[0., 0.], [1., 0.], [1., 1.], [0., 1.]]),
            q([[0., 0.], [1., 0.2], [1.3, 1.1], [-0.2, 0.7]]),
            q([[0., 0.], [1., 0.], [0.5, 0.4], [0.5, 1.]]),
            q([[0., 0.], [0., 1.], [1., 1.], [1., 0.]]),
        ];
        for p in &quads {
            let (a, b) = (
                eta_signed(p, DVec3::Z * 3.0),
                eta_signed_fast(p, DVec3::Z * 3.0),
            );
            assert!((a - b).abs() < 1e-12, "{a} vs {b}");
        }
    }

    #[test]
    fn triangle_shaped_quad_is_zero() {
        // a straight angle at vertex 1
        let t = q([[0., 0.], [1., 0.], [2., 0.], [1., 1.]]);
        assert!(eta(&t).abs() < 1e-12);
    }
}
