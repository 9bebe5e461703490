//! Extra edges (paper 5.3) and their post-processing: edge swap (5.3.1) and vertex
//! duplication (5.3.2), on triangulations built to have no perfect matching.

use crate::recombine_util;

use blossomquad::mesh::{etype, Mesh};
use blossomquad::recombine::{check_invariants, recombine, RecombineError, RecombineOptions};
use recombine_util::*;

/// Moves the edge midpoints of [`subdivided_triangle`]`(2)` outward (1.4× their distance
/// from the centroid): the outline becomes a convex hexagon, so no corner is straight.
fn bulged(mut m: blossomquad::mesh::Mesh) -> blossomquad::mesh::Mesh {
    let all: Vec<[f64; 3]> = m
        .node_blocks
        .iter()
        .flat_map(|b| b.coords.clone())
        .collect();
    let n = all.len() as f64;
    let c = [0, 1, 2].map(|k| all.iter().map(|p| p[k]).sum::<f64>() / n);
    let dist = |p: &[f64; 3]| ((p[0] - c[0]).powi(2) + (p[1] - c[1]).powi(2)).sqrt();
    let far = all.iter().map(dist).fold(0.0, f64::max);
    for b in &mut m.node_blocks {
        for p in &mut b.coords {
            if dist(p) < 0.9 * far {
                p[0] = c[0] + 1.4 * (p[0] - c[0]);
                p[1] = c[1] + 1.4 * (p[1] - c[1]);
            }
        }
    }
    m
}

#[test]
fn figure_6_coarse_needs_an_edge_swap() {
    let before = bulged(subdivided_triangle(2));
    assert_eq!(count(&before, etype::TRI3), 4);
    let mut m = before.clone();
    let r = recombine(&mut m, &verify_opts()).unwrap();
    let s = &r.surfaces[0];
    assert_eq!(s.extra_edges_used, 1);
    assert_eq!(s.edge_swaps, 1);
    assert_eq!(s.vertex_duplications, 0);
    assert_eq!(count(&m, etype::QUAD4), 2);
    assert_eq!(count(&m, etype::TRI3), 0);
    assert_eq!(m.node_count(), before.node_count(), "a swap adds no node");
    assert!(folded_quads(&m).is_empty());
    check_invariants(&before, &m).unwrap();
}

/// With straight sides, the edge swap of Figure 8 would leave a 180° corner at a midpoint
/// on the boundary, which optimization can never move: the vertex duplication is used
/// instead (one new node inside, every corner of the input kept).
#[test]
fn figure_6_coarse_with_straight_sides_duplicates_instead_of_swapping() {
    let before = subdivided_triangle(2);
    let mut m = before.clone();
    let r = recombine(&mut m, &verify_opts()).unwrap();
    let s = &r.surfaces[0];
    assert_eq!(s.extra_edges_used, 1);
    assert_eq!(s.edge_swaps, 0);
    assert_eq!(s.vertex_duplications, 1);
    assert_eq!(count(&m, etype::TRI3), 0);
    assert_eq!(m.node_count(), before.node_count() + 1);
    assert!(folded_quads(&m).is_empty());
    check_invariants(&before, &m).unwrap();
}

#[test]
fn without_extra_edges_figure_6_has_no_perfect_matching() {
    let mut m = subdivided_triangle(2);
    let e = recombine(
        &mut m,
        &RecombineOptions {
            extra_edges: false,
            ..Default::default()
        },
    )
    .unwrap_err();
    match &e {
        RecombineError::NoPerfectMatching {
            surface,
            triangles,
            witness,
            odd_components,
        } => {
            assert_eq!((*surface, *triangles), (1, 4));
            assert!(odd_components > witness);
        }
        other => panic!("expected NoPerfectMatching, got {other:?}"),
    }
    assert!(e.to_string().contains("surface 1"));
}

#[test]
fn figure_6_fine_and_larger_subdivisions() {
    // n(n+1)/2 up and n(n-1)/2 down triangles: every perfect matching needs n/2 extra edges
    for n in [4usize, 6, 8] {
        let before = subdivided_triangle(n);
        let mut m = before.clone();
        let r = recombine(&mut m, &verify_opts()).unwrap();
        let s = &r.surfaces[0];
        assert_eq!(s.extra_edges_used, n / 2, "n = {n}");
        assert_eq!(s.edge_swaps + s.vertex_duplications, n / 2);
        assert_eq!(count(&m, etype::TRI3), 0);
        assert_eq!(
            count(&m, etype::QUAD4),
            n * n / 2 + s.vertex_duplications,
            "n = {n}"
        );
        assert!(folded_quads(&m).is_empty(), "n = {n}");
        check_invariants(&before, &m).unwrap();
    }
}

/// A half-disc fan of 5 triangles around boundary vertex v = (0, 0), with pendant triangles
/// outside t2, t3, t4: the pendants must take t2, t3, t4, so t1 and t5 can only be matched
/// through the extra edge of the fan at v, which has 5 triangles: vertex duplication.
fn pendant_fan() -> Mesh {
    let mut b = Builder::new();
    b.entity(2, 1, &[], &[]);
    let v = b.node(2, 1, [0.0, 0.0, 0.0]);
    let a: Vec<u64> = (0..=5)
        .map(|i| {
            let t = std::f64::consts::PI * i as f64 / 5.0;
            b.node(2, 1, [t.cos(), t.sin(), 0.0])
        })
        .collect();
    for i in 1..=5 {
        b.tri(1, [v, a[i - 1], a[i]]);
    }
    for i in 2..=4 {
        let t = std::f64::consts::PI * (i as f64 - 0.5) / 5.0;
        let x = b.node(2, 1, [1.6 * t.cos(), 1.6 * t.sin(), 0.0]);
        b.tri(1, [a[i - 1], x, a[i]]);
    }
    b.mesh
}

#[test]
fn fan_around_boundary_vertex_needs_vertex_duplication() {
    let before = pendant_fan();
    let mut m = before.clone();
    let r = recombine(&mut m, &verify_opts()).unwrap();
    let s = &r.surfaces[0];
    assert_eq!(s.extra_edges_used, 1);
    assert_eq!(s.vertex_duplications, 1);
    assert_eq!(s.edge_swaps, 0);
    assert_eq!(count(&m, etype::QUAD4), 5);
    assert_eq!(m.node_count(), before.node_count() + 1);
    // the new node is classified on the surface, inside the half disc
    let new_tag = before.max_node_tag() + 1;
    let blk = m
        .node_blocks
        .iter()
        .find(|b| b.tags.contains(&new_tag))
        .unwrap();
    assert_eq!((blk.entity_dim, blk.entity_tag), (2, 1));
    let p = blk.coords[blk.tags.iter().position(|&t| t == new_tag).unwrap()];
    assert!(p[1] > 0.0 && p[0].hypot(p[1]) < 1.0, "{p:?}");
    assert!(folded_quads(&m).is_empty());
    check_invariants(&before, &m).unwrap();
}

#[test]
fn extra_edges_are_unused_when_a_perfect_matching_exists() {
    for seed in 1..6 {
        let before = grid(&Grid {
            nx: 6,
            ny: 5,
            jitter: 0.5,
            seed,
            ..Default::default()
        });
        let mut m = before.clone();
        let r = recombine(&mut m, &verify_opts()).unwrap();
        assert!(r.surfaces[0].extra_edges_added > 0);
        assert_eq!(r.surfaces[0].extra_edges_used, 0);
        assert!(r.surfaces[0].matching_cost < blossomquad::recombine::extra_edge_cost(60));
    }
}

#[test]
fn random_strips_of_pendants_always_recombine() {
    // a strip of triangles with random pendant triangles glued on its outer edges: many
    // have no perfect matching; every one must come out all-quad and conforming
    let mut rng = Rng(0x5eed);
    let (mut swaps, mut dups, mut folded) = (0, 0, 0);
    for case in 0..40 {
        let mut b = Builder::new();
        b.entity(2, 1, &[], &[]);
        let n = 6 + (rng.next_f64() * 6.0) as usize;
        let bottom: Vec<u64> = (0..=n)
            .map(|i| b.node(2, 1, [i as f64, 0.0, 0.0]))
            .collect();
        let top: Vec<u64> = (0..=n)
            .map(|i| b.node(2, 1, [i as f64 + 0.5, 1.0, 0.0]))
            .collect();
        let mut tris = 0;
        for i in 0..n {
            b.tri(1, [bottom[i], bottom[i + 1], top[i]]);
            b.tri(1, [bottom[i + 1], top[i + 1], top[i]]);
            tris += 2;
        }
        for i in 0..n {
            if rng.next_f64() < 0.5 {
                let x = b.node(2, 1, [i as f64 + 0.5, -0.8, 0.0]);
                b.tri(1, [bottom[i + 1], bottom[i], x]);
                tris += 1;
            }
            if rng.next_f64() < 0.5 {
                let x = b.node(2, 1, [i as f64 + 1.0, 1.8, 0.0]);
                b.tri(1, [top[i], top[i + 1], x]);
                tris += 1;
            }
        }
        if tris % 2 == 1 {
            let x = b.node(2, 1, [-0.5, 0.5, 0.0]);
            b.tri(1, [top[0], x, bottom[0]]);
        }
        let before = b.mesh;
        let mut m = before.clone();
        let r = recombine(&mut m, &verify_opts()).unwrap_or_else(|e| panic!("case {case}: {e}"));
        let s = &r.surfaces[0];
        assert_eq!(count(&m, etype::TRI3), 0, "case {case}");
        assert_eq!(s.edge_swaps + s.vertex_duplications, s.extra_edges_used);
        swaps += s.edge_swaps;
        dups += s.vertex_duplications;
        folded += folded_quads(&m).len();
        check_invariants(&before, &m).unwrap_or_else(|e| panic!("case {case}: {e}"));
    }
    eprintln!("{swaps} edge swaps, {dups} vertex duplications, {folded} folded quads");
    // pendants on straight rows: a swap would leave a straight boundary corner, so every
    // extra edge is resolved by vertex duplication (swaps are exercised by Figure 6 bulged)
    assert!(dups > 0, "{swaps} swaps, {dups} duplications");
    assert_eq!(folded, 0);
}
