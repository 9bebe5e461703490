//! The Jacobian of a 9-node (or 8-node, with its serendipity centre) quadrangle: its
//! derivatives and the scaled Jacobian at the nodes, measured about the straight-sided
//! normal as Gmsh measures it.

use glam::DVec3;

/// 1D quadratic Lagrange basis on nodes -1, 0, 1 at `t`, and its derivative.
fn lagrange(t: f64) -> ([f64; 3], [f64; 3]) {
    (
        [0.5 * t * (t - 1.0), 1.0 - t * t, 0.5 * t * (t + 1.0)],
        [t - 0.5, -2.0 * t, t + 0.5],
    )
}

/// The node of a 9-node quad (Gmsh order) at grid position (i, j), i, j in {0: -1, 1: 0, 2: 1}.
const GRID: [[usize; 3]; 3] = [
    // j = 0 (η = -1), 1 (η = 0), 2 (η = 1), for i = 0 (ξ = -1)
    [0, 7, 3],
    [4, 8, 6],
    [1, 5, 2],
];

/// ∂x/∂ξ and ∂x/∂η of the 9-node quad `x` at (ξ, η).
pub(crate) fn quad9_derivatives(x: &[DVec3; 9], xi: f64, eta: f64) -> (DVec3, DVec3) {
    let (lu, du) = lagrange(xi);
    let (lv, dv) = lagrange(eta);
    let mut xu = DVec3::ZERO;
    let mut xv = DVec3::ZERO;
    for (i, row) in GRID.iter().enumerate() {
        for (j, &n) in row.iter().enumerate() {
            xu += x[n] * (du[i] * lv[j]);
            xv += x[n] * (lu[i] * dv[j]);
        }
    }
    (xu, xv)
}

/// The normal Gmsh measures a surface element's Jacobian about: that of its straight-sided
/// (bilinear) quad at the centre, `(x2 − x0) × (x3 − x1)` up to a positive factor.
pub(crate) fn straight_normal(x: &[DVec3; 9]) -> DVec3 {
    (x[2] - x[0]).cross(x[3] - x[1])
}

/// Smallest scaled Jacobian (`det J / (|∂x/∂ξ| |∂x/∂η|)`, about the straight-sided normal)
/// at the 9 nodes of a quad (for an 8-node quad, pass its serendipity centre as node 8).
pub fn min_scaled_jacobian_at_nodes(x: &[DVec3; 9]) -> f64 {
    let n = straight_normal(x).normalize_or_zero();
    let mut worst = f64::INFINITY;
    for xi in [-1.0, 0.0, 1.0] {
        for eta in [-1.0, 0.0, 1.0] {
            let (xu, xv) = quad9_derivatives(x, xi, eta);
            let d = xu.length() * xv.length();
            let s = if d > 0.0 {
                xu.cross(xv).dot(n) / d
            } else {
                0.0
            };
            worst = worst.min(s);
        }
    }
    worst
}
