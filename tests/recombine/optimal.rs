//! End-to-end optimality of the recombination's *cost*, not just of the matching: on small
//! random Delaunay meshes every perfect matching of the triangle-adjacency graph is
//! enumerated and priced with this file's own η (eq. 3, signed angles in the plane) and the
//! hopeless-corner rule, and the quads `recombine` writes must cost the minimum. A matching
//! certificate alone cannot catch a cost that ignores η (the matching would be optimal for
//! the wrong costs); this test does.

use crate::recombine_util;

use blossomquad::mesh::Mesh;
use blossomquad::recombine::{
    recombine, RecombineOptions, COST_SCALE, FIXED_CORNER_MIN_ETA, HOPELESS_COST,
};
use recombine_util::*;
use spade::{DelaunayTriangulation, Point2, Triangulation};
use std::f64::consts::FRAC_PI_2;

/// Interior angles of a counter-clockwise polygon in the xy plane, signed (negative where it
/// turns the wrong way).
fn signed_angles(p: &[[f64; 2]; 4]) -> [f64; 4] {
    std::array::from_fn(|k| {
        let (c, n, b) = (p[k], p[(k + 1) % 4], p[(k + 3) % 4]);
        let a = [n[0] - c[0], n[1] - c[1]];
        let w = [b[0] - c[0], b[1] - c[1]];
        (a[0] * w[1] - a[1] * w[0]).atan2(a[0] * w[0] + a[1] * w[1])
    })
}

/// The recombination's edge cost, written independently: `round(10⁴ (1 − η))` with
/// η = 1 − max|π/2 − α|/(π/2) (eq. 3), or `HOPELESS_COST` when a corner at a boundary node has
/// corner quality `1 − |π/2 − α|/(π/2)` at most `FIXED_CORNER_MIN_ETA`.
fn cost(p: &[[f64; 2]; 4], on_wall: [bool; 4]) -> i64 {
    let ang = signed_angles(p);
    let dev = |a: f64| (FRAC_PI_2 - a).abs() / FRAC_PI_2;
    if (0..4).any(|k| on_wall[k] && 1.0 - dev(ang[k]) <= FIXED_CORNER_MIN_ETA) {
        return HOPELESS_COST;
    }
    let eta = 1.0 - ang.iter().map(|&a| dev(a)).fold(0.0, f64::max);
    (COST_SCALE as f64 * (1.0 - eta)).round() as i64
}

/// Minimum total cost over all perfect matchings of `tris` (CCW), pairing triangles that
/// share an edge into the quad (a, s, b, c); `None` when there is no perfect matching.
fn brute_force(pts: &[[f64; 2]], wall: &[bool], tris: &[[usize; 3]]) -> Option<i64> {
    let n = tris.len();
    let mut pair = vec![vec![None; n]; n];
    for (i, t) in tris.iter().enumerate() {
        for k in 0..3 {
            let (a, b, c) = (t[k], t[(k + 1) % 3], t[(k + 2) % 3]);
            for (j, u) in tris.iter().enumerate() {
                if j == i || !(u.contains(&a) && u.contains(&b)) {
                    continue;
                }
                let s = *u.iter().find(|&&x| x != a && x != b).unwrap();
                let q = [a, s, b, c];
                pair[i][j] = Some(cost(&q.map(|v| pts[v]), q.map(|v| wall[v])));
            }
        }
    }
    fn go(pair: &[Vec<Option<i64>>], used: &mut [bool]) -> Option<i64> {
        let Some(i) = used.iter().position(|&u| !u) else {
            return Some(0);
        };
        used[i] = true;
        let mut best: Option<i64> = None;
        for j in 0..used.len() {
            if let (false, Some(c)) = (used[j], pair[i][j]) {
                used[j] = true;
                if let Some(rest) = go(pair, used) {
                    best = Some(best.map_or(c + rest, |b: i64| b.min(c + rest)));
                }
                used[j] = false;
            }
        }
        used[i] = false;
        best
    }
    go(&pair, &mut vec![false; n])
}

/// Surface 1 made of `tris` over the points `pts` (z = 0, no curve data), and the node tags.
fn planar_mesh(pts: &[[f64; 2]], tris: &[[usize; 3]]) -> (Mesh, Vec<u64>) {
    let mut b = Builder::new();
    b.entity(2, 1, &[], &[]);
    let tags: Vec<u64> = pts
        .iter()
        .map(|p| b.node(2, 1, [p[0], p[1], 0.0]))
        .collect();
    for tri in tris {
        b.tri(1, tri.map(|v| tags[v]));
    }
    (b.mesh, tags)
}

/// Total cost of the quads of `m`, priced like [`brute_force`] does.
fn output_cost(m: &Mesh, wall_tags: &[u64]) -> i64 {
    quads_with_nodes(m)
        .iter()
        .map(|(_, p, nodes)| {
            let q: [[f64; 2]; 4] = std::array::from_fn(|k| [p[k][0], p[k][1]]);
            cost(&q, std::array::from_fn(|k| wall_tags.contains(&nodes[k])))
        })
        .sum()
}

#[test]
fn recombined_quads_cost_the_brute_force_minimum() {
    let mut rng = Rng(0x0E7A_C057);
    let (mut checked, mut hopeless_seen) = (0, 0);
    for case in 0..600 {
        let npts = 6 + (rng.next_f64() * 5.0) as usize;
        let mut t: DelaunayTriangulation<Point2<f64>> = DelaunayTriangulation::new();
        for _ in 0..npts {
            let _ = t.insert(Point2::new(rng.next_f64(), rng.next_f64()));
        }
        let pts: Vec<[f64; 2]> = t
            .vertices()
            .map(|v| [v.position().x, v.position().y])
            .collect();
        let mut wall = vec![false; pts.len()];
        for e in t.convex_hull() {
            wall[e.from().fix().index()] = true;
        }
        let tris: Vec<[usize; 3]> = t
            .inner_faces()
            .map(|f| f.vertices().map(|v| v.fix().index()))
            .collect();
        if tris.len() % 2 == 1 || tris.len() > 16 {
            continue;
        }
        let Some(best) = brute_force(&pts, &wall, &tris) else {
            continue; // no perfect matching: extra edges, another test's business
        };
        let (mut m, tags) = planar_mesh(&pts, &tris);
        // the matching's own quads: a strip meshed again is not a matching's
        let opts = RecombineOptions {
            two_row_strips: false,
            ..verify_opts()
        };
        let r = recombine(&mut m, &opts).unwrap_or_else(|e| panic!("case {case}: {e}"));
        assert!(r.parity_splits.is_empty(), "case {case}");
        assert_eq!(r.surfaces[0].extra_edges_used, 0, "case {case}");
        let wall_tags: Vec<u64> = (0..pts.len())
            .filter(|&i| wall[i])
            .map(|i| tags[i])
            .collect();
        let got = output_cost(&m, &wall_tags);
        // each quad's cost is rounded from a float computed two ways: allow 1 per quad
        let slack = (tris.len() / 2) as i64;
        assert!(
            (got - best).abs() <= slack,
            "case {case}: recombined quads cost {got}, the best perfect matching {best}"
        );
        checked += 1;
        hopeless_seen += usize::from(best >= HOPELESS_COST);
    }
    eprintln!("{checked} meshes checked against brute force, {hopeless_seen} with a hopeless quad");
    assert!(
        checked >= 150,
        "only {checked} meshes were even with a perfect matching"
    );
}

/// The cross-field cost (eq. 7) turns quads towards the cross field, here the axes of a unit
/// square (its walls): the share of quad edges within 15° of an axis must grow (measured:
/// 0.369 -> 0.426 at weight 2 on random points), and the matching stays certified.
#[test]
fn cross_field_weight_aligns_quads_with_the_boundary() {
    let mut rng = Rng(0xC705_5F1E);
    let mut t: DelaunayTriangulation<Point2<f64>> = DelaunayTriangulation::new();
    let k = 20;
    for i in 0..k {
        let u = i as f64 / k as f64;
        for p in [[u, 0.0], [1.0, u], [1.0 - u, 1.0], [0.0, 1.0 - u]] {
            let _ = t.insert(Point2::new(p[0], p[1]));
        }
    }
    for _ in 0..600 {
        let (x, y) = (0.02 + 0.96 * rng.next_f64(), 0.02 + 0.96 * rng.next_f64());
        let _ = t.insert(Point2::new(x, y));
    }
    let pts: Vec<[f64; 2]> = t
        .vertices()
        .map(|v| [v.position().x, v.position().y])
        .collect();
    let tris: Vec<[usize; 3]> = t
        .inner_faces()
        .map(|f| f.vertices().map(|v| v.fix().index()))
        .collect();
    let aligned_share = |w: f64| -> f64 {
        let (mut m, _) = planar_mesh(&pts, &tris);
        let opts = RecombineOptions {
            verify: true,
            cross_field_weight: w,
            ..Default::default()
        };
        recombine(&mut m, &opts).unwrap();
        let (mut aligned, mut all) = (0usize, 0usize);
        for (_, p, _) in quads_with_nodes(&m) {
            for i in 0..4 {
                let (a, c) = (p[i], p[(i + 1) % 4]);
                let ang = (c[1] - a[1])
                    .atan2(c[0] - a[0])
                    .to_degrees()
                    .rem_euclid(90.0);
                aligned += usize::from(!(15.0..=75.0).contains(&ang));
                all += 1;
            }
        }
        aligned as f64 / all as f64
    };
    let (plain, crossed) = (aligned_share(0.0), aligned_share(2.0));
    eprintln!(
        "edges within 15 deg of an axis: {plain:.3} with eq. 4, {crossed:.3} with eq. 7 added"
    );
    assert!(crossed > plain + 0.03, "{plain} -> {crossed}");
}
