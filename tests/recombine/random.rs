//! Random Delaunay triangulations (fixed seeds): odd and even, with and without curve data,
//! clustered points (slivers, fans) — every one must come out all-quad, conforming and
//! optimal (certificate), with the invariants intact.

use crate::recombine_util;

use blossomquad::mesh::{etype, Mesh};
use blossomquad::recombine::{check_invariants, recombine};
use recombine_util::*;
use spade::{DelaunayTriangulation, Point2, Triangulation};

/// Delaunay triangulation of `n` random points in the unit square, its 4 corners and random
/// points on its sides, as
/// surface 1. With `lines`, the convex hull is curve 1 with line elements and its nodes are
/// classified on it; otherwise every node sits on the surface (no curve data).
fn random_mesh(rng: &mut Rng, n: usize, clustered: bool, lines: bool) -> Mesh {
    let mut t: DelaunayTriangulation<Point2<f64>> = DelaunayTriangulation::new();
    for c in [[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]] {
        t.insert(Point2::new(c[0], c[1])).unwrap();
    }
    // random points on the sides: the boundary node count decides the parity (eq. 5)
    for _ in 0..(n / 8 + 1) {
        let u = rng.next_f64();
        let side = (rng.next_f64() * 4.0) as usize;
        let p = [[u, 0.0], [1.0, u], [u, 1.0], [0.0, u]][side.min(3)];
        t.insert(Point2::new(p[0], p[1])).unwrap();
    }
    for _ in 0..n {
        let (mut x, mut y) = (rng.next_f64(), rng.next_f64());
        if clustered {
            // squeeze towards a corner: strong grading, slivers near the boundary
            x = x * x * x;
            y *= y;
        }
        t.insert(Point2::new(x, y)).unwrap();
    }
    let mut b = Builder::new();
    b.entity(1, 1, &[], &[]);
    b.entity(2, 1, &[1], &[7]);
    let mut on_hull = vec![false; t.num_vertices()];
    let hull: Vec<(usize, usize)> = t
        .convex_hull()
        .map(|e| (e.from().fix().index(), e.to().fix().index()))
        .collect();
    if lines {
        for &(a, _) in &hull {
            on_hull[a] = true;
        }
    }
    let tags: Vec<u64> = t
        .vertices()
        .map(|v| {
            let p = v.position();
            let (dim, ent) = if on_hull[v.fix().index()] {
                (1, 1)
            } else {
                (2, 1)
            };
            b.node(dim, ent, [p.x, p.y, 0.0])
        })
        .collect();
    for f in t.inner_faces() {
        let v = f.vertices().map(|v| tags[v.fix().index()]);
        b.tri(1, v);
    }
    if lines {
        for (a, c) in hull {
            b.line(1, tags[a], tags[c]);
        }
    }
    b.mesh
}

#[test]
fn random_delaunay_meshes() {
    let mut rng = Rng(0xB10550);
    let (mut odd, mut extra, mut swaps, mut dups) = (0, 0, 0, 0);
    for case in 0..160 {
        let n = 5 + (rng.next_f64() * 150.0) as usize;
        let before = random_mesh(&mut rng, n, case % 4 >= 2, case % 2 == 0);
        let mut m = before.clone();
        let r = recombine(&mut m, &verify_opts()).unwrap_or_else(|e| panic!("case {case}: {e}"));
        check_invariants(&before, &m).unwrap_or_else(|e| panic!("case {case}: {e}"));
        assert_eq!(count(&m, etype::TRI3), 0, "case {case}");
        assert!(folded_quads(&m).is_empty(), "case {case}");
        let s = &r.surfaces[0];
        assert_eq!(
            s.quads_out,
            s.triangles_in / 2 + s.vertex_duplications,
            "case {case}"
        );
        odd += usize::from(!r.parity_splits.is_empty());
        extra += s.extra_edges_used;
        swaps += s.edge_swaps;
        dups += s.vertex_duplications;
    }
    eprintln!(
        "{odd} odd meshes repaired, {extra} extra edges used ({swaps} swaps, {dups} duplications)"
    );
    assert!(odd > 20, "the sample must exercise parity repair");
}
