//! Recombination on in-memory meshes: all-quad output, invariants, optimality certificate,
//! tags, orientation, what is kept and what is refused.

use crate::recombine_util;

use blossomquad::mesh::{etype, ElementBlock, PeriodicLink};
use blossomquad::recombine::{
    check_invariants, recombine, ParityMode, RecombineError, RecombineOptions,
};
use recombine_util::*;

#[test]
fn structured_grid_becomes_all_quads() {
    let before = grid(&Grid::default());
    let mut m = before.clone();
    let r = recombine(&mut m, &verify_opts()).unwrap();
    assert_eq!(count(&m, etype::TRI3), 0);
    assert_eq!(count(&m, etype::QUAD4), 16);
    assert_eq!(r.surfaces.len(), 1);
    assert_eq!(r.surfaces[0].triangles_in, 32);
    assert_eq!(r.surfaces[0].quads_out, 16);
    assert_eq!(r.surfaces[0].extra_edges_used, 0);
    assert!(r.parity_splits.is_empty());
    check_invariants(&before, &m).unwrap();
    // lines, nodes, entities untouched
    assert_eq!(count(&m, etype::LINE2), count(&before, etype::LINE2));
    assert_eq!(m.node_blocks, before.node_blocks);
}

#[test]
fn jittered_grids_with_random_diagonals() {
    for seed in 1..8 {
        let before = grid(&Grid {
            nx: 9,
            ny: 7,
            jitter: 0.6,
            seed,
            ..Default::default()
        });
        let mut m = before.clone();
        let r = recombine(&mut m, &verify_opts()).unwrap();
        assert_eq!(count(&m, etype::TRI3), 0, "seed {seed}");
        assert_eq!(
            count(&m, etype::QUAD4),
            63 + r.surfaces[0].vertex_duplications,
            "seed {seed}"
        );
        check_invariants(&before, &m).unwrap();
    }
}

#[test]
fn regular_grid_matching_is_perfect_squares() {
    // any diagonals in a regular grid: the optimum merges every cell back into its square
    let before = grid(&Grid {
        nx: 6,
        ny: 6,
        ..Default::default()
    });
    let mut m = before.clone();
    let r = recombine(&mut m, &verify_opts()).unwrap();
    assert_eq!(
        r.surfaces[0].matching_cost, 0,
        "every cell is a perfect square"
    );
    check_invariants(&before, &m).unwrap();
}

#[test]
fn quads_reuse_triangle_tags_and_keep_orientation() {
    for clockwise in [false, true] {
        let before = grid(&Grid {
            nx: 5,
            ny: 4,
            jitter: 0.3,
            clockwise,
            ..Default::default()
        });
        let tri_tags: Vec<u64> = before
            .element_blocks
            .iter()
            .filter(|b| b.element_type == etype::TRI3)
            .flat_map(|b| b.tags.clone())
            .collect();
        let mut m = before.clone();
        recombine(&mut m, &verify_opts()).unwrap();
        let mut seen = std::collections::HashSet::new();
        for (t, p) in quad_coords(&m) {
            assert!(tri_tags.contains(&t), "quad tag {t} is not a triangle tag");
            assert!(seen.insert(t), "quad tag {t} used twice");
            // the signed area's sign follows the triangles' orientation
            let area: f64 = (0..4)
                .map(|k| p[k][0] * p[(k + 1) % 4][1] - p[(k + 1) % 4][0] * p[k][1])
                .sum();
            assert_eq!(area < 0.0, clockwise, "quad {t} orientation");
        }
        check_invariants(&before, &m).unwrap();
    }
}

#[test]
fn physical_groups_and_other_elements_are_kept() {
    let mut before = grid(&Grid::default());
    // a point element on point 1 and a second surface with only quads
    let mut b = Builder::new();
    b.mesh = before.clone();
    b.elem(0, 1, etype::POINT, &[1]);
    before = b.mesh;
    let mut m = before.clone();
    recombine(&mut m, &verify_opts()).unwrap();
    assert_eq!(m.entities, before.entities);
    assert_eq!(m.physical_names, before.physical_names);
    assert_eq!(count(&m, etype::POINT), 1);
    assert_eq!(count(&m, etype::LINE2), 16);
}

#[test]
fn mixed_surface_keeps_its_quads() {
    // left half quads, right half triangles, same surface
    let mut quads = 0;
    let before = cell_grid(6, 4, |b, i, _, [a, bb, c, d]| {
        if i < 3 {
            b.elem(2, 1, etype::QUAD4, &[a, bb, c, d]);
            quads += 1;
        } else {
            b.tri(1, [a, bb, c]);
            b.tri(1, [a, c, d]);
        }
    });
    let mut m = before.clone();
    let r = recombine(&mut m, &verify_opts()).unwrap();
    assert_eq!(count(&m, etype::TRI3), 0);
    assert_eq!(count_on(&m, 1, etype::QUAD4), quads + 12);
    assert_eq!(r.surfaces[0].quads_out, 12);
    assert_eq!(r.surfaces[0].quads_kept, quads);
    check_invariants(&before, &m).unwrap();
}

#[test]
fn embedded_curve_is_never_crossed() {
    // a 4x4 grid with an embedded line element curve along x = 0.5
    let before = grid(&Grid {
        nx: 4,
        ny: 4,
        jitter: 0.0,
        ..Default::default()
    });
    let mut on_mid: Vec<(f64, u64)> = Vec::new();
    for b in &before.node_blocks {
        for (t, c) in b.tags.iter().zip(&b.coords) {
            if (c[0] - 0.5).abs() < 1e-12 {
                on_mid.push((c[1], *t));
            }
        }
    }
    on_mid.sort_by(|a, b| a.0.partial_cmp(&b.0).unwrap());
    let mut b = Builder::new();
    b.mesh = before;
    b.mesh.entities[1].push(blossomquad::mesh::Entity {
        dim: 1,
        tag: 9,
        bbox: [0.0; 6],
        physical_tags: vec![],
        bounding: vec![],
    });
    for w in on_mid.windows(2) {
        b.line(9, w[0].1, w[1].1);
    }
    let before = b.mesh;
    let mut m = before.clone();
    recombine(&mut m, &verify_opts()).unwrap();
    check_invariants(&before, &m).unwrap();
    // every quad lies on one side of x = 0.5
    for (tag, p) in quad_coords(&m) {
        let xs: Vec<f64> = p.iter().map(|c| c[0]).collect();
        let left = xs.iter().all(|&x| x <= 0.5 + 1e-12);
        let right = xs.iter().all(|&x| x >= 0.5 - 1e-12);
        assert!(
            left || right,
            "quad {tag} crosses the embedded curve: {xs:?}"
        );
    }
}

#[test]
fn embedded_curve_from_node_classification_only() {
    // same as above but the curve has no line elements: its nodes are classified on it and
    // it is bounded by two points
    let mut b = Builder::new();
    b.entity(0, 1, &[], &[]);
    b.entity(0, 2, &[], &[]);
    b.entity(1, 9, &[1, -2], &[]);
    b.entity(2, 1, &[], &[]);
    let n = 4;
    let mut id = vec![vec![0u64; n + 1]; n + 1];
    for (i, col) in id.iter_mut().enumerate() {
        for (j, cell) in col.iter_mut().enumerate() {
            let p = [i as f64 / n as f64, j as f64 / n as f64, 0.0];
            let (dim, ent) = if i == 2 && j == 0 {
                (0, 1)
            } else if i == 2 && j == n {
                (0, 2)
            } else if i == 2 {
                (1, 9)
            } else {
                (2, 1)
            };
            *cell = b.node(dim, ent, p);
        }
    }
    for i in 0..n {
        for j in 0..n {
            let (a, bb, c, d) = (id[i][j], id[i + 1][j], id[i + 1][j + 1], id[i][j + 1]);
            // diagonals chosen so that a cross-curve pairing would be attractive
            b.tri(1, [a, bb, d]);
            b.tri(1, [bb, c, d]);
        }
    }
    let before = b.mesh;
    let mut m = before.clone();
    recombine(&mut m, &verify_opts()).unwrap();
    for (tag, p) in quad_coords(&m) {
        let xs: Vec<f64> = p.iter().map(|c| c[0]).collect();
        assert!(
            xs.iter().all(|&x| x <= 0.5 + 1e-12) || xs.iter().all(|&x| x >= 0.5 - 1e-12),
            "quad {tag} crosses the bare curve: {xs:?}"
        );
    }
}

#[test]
fn closed_cube_without_lines_recombines_per_face() {
    let before = cube(3);
    let mut m = before.clone();
    let r = recombine(&mut m, &verify_opts()).unwrap();
    assert_eq!(r.surfaces.len(), 6);
    for s in 1..=6 {
        assert_eq!(count_on(&m, s, etype::QUAD4), 9, "face {s}");
    }
    check_invariants(&before, &m).unwrap();
}

#[test]
fn volume_elements_are_refused_or_dropped() {
    let mut b = Builder::new();
    b.mesh = grid(&Grid::default());
    b.entity(3, 1, &[1], &[]);
    b.elem(3, 1, etype::TRI3 + 2, &[1, 2, 3, 7]); // a tet4 (type 4)
    let mut m = b.mesh.clone();
    match recombine(&mut m, &RecombineOptions::default()) {
        Err(RecombineError::VolumeElements { count, volumes }) => {
            assert_eq!(count, 1);
            assert_eq!(volumes, vec![1]);
        }
        other => panic!("expected a volume error, got {other:?}"),
    }
    let mut m = b.mesh.clone();
    let r = recombine(
        &mut m,
        &RecombineOptions {
            drop_volumes: true,
            ..verify_opts()
        },
    )
    .unwrap();
    assert_eq!(r.dropped_volume_elements, 1);
    assert_eq!(count(&m, 4), 0);
    assert_eq!(m.entities[3].len(), 1, "volume entity kept");
    assert!(m.warnings.iter().any(|w| w.contains("volume")));
}

/// `m` with surface 1 made a periodic slave of surface 5 (which has no faces), without node
/// pairs.
fn slave_of_5(mut m: blossomquad::mesh::Mesh) -> blossomquad::mesh::Mesh {
    m.periodic.push(PeriodicLink {
        dim: 2,
        tag: 1,
        master_tag: 5,
        affine: None,
        node_pairs: vec![],
    });
    m
}

#[test]
fn high_order_and_periodic_surfaces_are_refused() {
    let mut m = grid(&Grid::default());
    m.element_blocks.push(ElementBlock {
        entity_dim: 2,
        entity_tag: 7,
        element_type: etype::TRI6,
        tags: vec![1000],
        nodes: vec![1, 2, 3, 4, 5, 6],
        partitions: None,
    });
    let e = recombine(&mut m, &RecombineOptions::default()).unwrap_err();
    assert!(matches!(
        e,
        RecombineError::UnsupportedSurfaceElements {
            surface: 7,
            element_type: 9,
            ..
        }
    ));
    assert!(e.to_string().contains("surface 7"));

    let mut m = slave_of_5(grid(&Grid::default()));
    let e = recombine(&mut m, &RecombineOptions::default()).unwrap_err();
    assert!(matches!(
        e,
        RecombineError::PeriodicSurface {
            surface: 1,
            master: 5,
            ..
        }
    ));
    // a slave that is not the image of its master is refused, in plain words
    let msg = e.to_string();
    assert!(
        msg.contains("surface 1 is periodic") && msg.contains("its master 0"),
        "{msg}"
    );
    assert!(!msg.contains('{'), "{msg}");
}

#[test]
fn unknown_node_is_an_error_not_a_panic() {
    let mut m = grid(&Grid::default());
    m.element_blocks
        .iter_mut()
        .find(|b| b.element_type == etype::TRI3)
        .unwrap()
        .nodes[0] = 99999;
    let e = recombine(&mut m, &RecombineOptions::default()).unwrap_err();
    assert!(
        matches!(e, RecombineError::UnknownNode { node: 99999, .. }),
        "{e}"
    );
}

#[test]
fn parity_error_mode_explains_the_fix() {
    let mut b = Builder::new();
    b.entity(2, 1, &[], &[]);
    fan(&mut b, 1, [0.0, 0.0], 5);
    let mut m = b.mesh.clone();
    let opts = RecombineOptions {
        parity: ParityMode::Error,
        ..Default::default()
    };
    let e = recombine(&mut m, &opts).unwrap_err();
    let msg = e.to_string();
    assert!(matches!(e, RecombineError::OddParity { .. }));
    assert!(msg.contains("surface 1"), "{msg}");
    assert!(msg.contains("5 triangles"), "{msg}");
    assert!(msg.contains("Transfinite Curve"), "{msg}");
    assert!(msg.contains("Mesh.RecombineAll"), "{msg}");
    assert_eq!(m, b.mesh, "error mode changes nothing");
}

#[test]
fn chords_of_a_bare_boundary_curve_are_graph_edges() {
    // a hexagon triangulated from one corner (no interior node): every interior edge joins
    // two nodes of the same curve (classified on bare curve 5, no line elements), but the
    // curve bounds the surface, so they are chords, not curve segments
    let mut b = Builder::new();
    b.entity(1, 5, &[], &[]);
    b.entity(2, 1, &[5], &[]);
    let ring: Vec<u64> = (0..6)
        .map(|i| {
            let a = std::f64::consts::TAU * i as f64 / 6.0;
            b.node(1, 5, [a.cos(), a.sin(), 0.0])
        })
        .collect();
    for i in 1..5 {
        b.tri(1, [ring[0], ring[i], ring[i + 1]]);
    }
    let before = b.mesh;
    let mut m = before.clone();
    let r = recombine(&mut m, &verify_opts()).unwrap();
    assert_eq!(r.surfaces[0].graph_edges, 3);
    assert_eq!(r.surfaces[0].extra_edges_used, 0);
    assert_eq!(count(&m, etype::QUAD4), 2);
    check_invariants(&before, &m).unwrap();
}

#[test]
fn isolated_triangles_among_quads_retriangulate_the_surface() {
    // first: a 3 x 3 quad grid whose cells (1,1) (4 triangles around a centre node) and
    // (2,1) (2 triangles) are triangulated: 6 triangles in one region, recombined among
    // themselves, the quads untouched
    let mut quads = 0;
    let before = cell_grid(3, 3, |b, i, j, [a, bb, c, d]| {
        if (i, j) == (1, 1) {
            let x = b.node(2, 1, [i as f64 + 0.5, j as f64 + 0.5, 0.0]);
            b.tri(1, [a, bb, x]);
            b.tri(1, [bb, c, x]);
            b.tri(1, [c, d, x]);
            b.tri(1, [d, a, x]);
        } else if (i, j) == (2, 1) {
            b.tri(1, [a, bb, c]);
            b.tri(1, [a, c, d]);
        } else {
            b.elem(2, 1, etype::QUAD4, &[a, bb, c, d]);
            quads += 1;
        }
    });
    let mut m = before.clone();
    let r = recombine(&mut m, &verify_opts()).unwrap();
    assert!(r.retriangulated.is_empty());
    assert_eq!(count(&m, etype::QUAD4), quads + 3);
    check_invariants(&before, &m).unwrap();

    // a triangle whose three edges all border quads: it can neither be made even (no
    // splittable segment) nor matched; the surface is retriangulated and recombined whole
    let mut b2 = Builder::new();
    b2.entity(2, 1, &[], &[]);
    let pts = [
        [0.0, 0.0],  // 0 a
        [2.0, 0.0],  // 1 b
        [1.0, 1.7],  // 2 c
        [0.0, -1.0], // 3 below a
        [2.0, -1.0], // 4 below b
        [3.0, 0.5],  // 5 right of b
        [2.2, 2.2],  // 6 right of c
        [-0.2, 2.2], // 7 left of c
        [-1.0, 0.5], // 8 left of a
    ];
    let p: Vec<u64> = pts
        .iter()
        .map(|q| b2.node(2, 1, [q[0], q[1], 0.0]))
        .collect();
    b2.tri(1, [p[0], p[1], p[2]]);
    b2.elem(2, 1, etype::QUAD4, &[p[0], p[3], p[4], p[1]]);
    b2.elem(2, 1, etype::QUAD4, &[p[1], p[5], p[6], p[2]]);
    b2.elem(2, 1, etype::QUAD4, &[p[2], p[7], p[8], p[0]]);
    let before = b2.mesh;
    let mut m = before.clone();
    let r = recombine(&mut m, &verify_opts()).unwrap();
    assert_eq!(r.retriangulated, vec![1]);
    assert_eq!(count(&m, etype::TRI3), 0);
    check_invariants(&before, &m).unwrap();
}

#[test]
fn malformed_block_is_an_error_not_a_panic() {
    let mut m = grid(&Grid::default());
    m.element_blocks
        .iter_mut()
        .find(|b| b.element_type == etype::TRI3)
        .unwrap()
        .nodes
        .pop();
    let e = recombine(&mut m, &RecombineOptions::default()).unwrap_err();
    assert!(matches!(e, RecombineError::MalformedBlock { .. }), "{e}");
}

#[test]
fn large_grid_takes_the_radix_path_and_stays_valid() {
    // 2 * 130 * 130 = 33 800 triangles: more than 2^16 half-edges, so the packed radix sort
    // builds the adjacency
    let before = grid(&Grid {
        nx: 130,
        ny: 130,
        jitter: 0.5,
        seed: 3,
        ..Default::default()
    });
    let mut m = before.clone();
    let r = recombine(&mut m, &verify_opts()).unwrap();
    assert_eq!(r.surfaces[0].quads_out, 130 * 130);
    check_invariants(&before, &m).unwrap();
}

/// The edge checks (non-manifold, same direction, fold) run in the topology for recombined
/// surfaces and in the input checks for periodic slaves, which get no topology: both
/// name the same element and edge. A slave is refused; a recombined surface has its folds
/// walled off instead, and the report names the first (what `quadrangulate` refuses with
/// when the quads are not valid), unless the walls leave parity repair nothing to do, in
/// which case the fold is the refusal.
#[test]
fn edge_checks_agree_on_recombined_and_periodic_slave_surfaces() {
    let flipped = || {
        let mut m = grid(&Grid::default());
        let b = m
            .element_blocks
            .iter_mut()
            .find(|b| b.element_type == etype::TRI3)
            .unwrap();
        b.nodes.swap(13, 14); // triangle 5 (0-based 4) runs its nodes the other way
        m
    };
    let folded = || {
        let mut m = grid(&Grid::default());
        // the interior node at (0.5, 0.5) moved outside the square: some of its triangles
        // turn over, and fold over their neighbours
        let v = node_at(&m, [0.5, 0.5, 0.0]);
        for nb in &mut m.node_blocks {
            if let Some(i) = nb.tags.iter().position(|&t| t == v) {
                nb.coords[i] = [1.9, 1.3, 0.0];
            }
        }
        m
    };
    for (what, make, words) in [
        (
            "flipped",
            &flipped as &dyn Fn() -> _,
            "same direction as triangle",
        ),
        ("folded", &folded, "folded over triangle"),
    ] {
        let refuse = |mut m, walled: bool| {
            let e = match recombine(&mut m, &RecombineOptions::default()) {
                Err(e) => e,
                Ok(r) => {
                    assert!(walled, "{what}: recombined");
                    assert_eq!(r.walled_folds.len(), 1, "{what}");
                    r.walled_folds[0].refusal()
                }
            };
            assert!(
                matches!(e, RecombineError::InvalidElement { surface: 1, .. }),
                "{what}: {e}"
            );
            e.to_string()
        };
        let walled = what == "folded";
        let (own, as_slave) = (refuse(make(), walled), refuse(slave_of_5(make()), false));
        assert!(own.contains(words), "{what}: {own}");
        assert_eq!(own, as_slave, "{what}");
    }
}

/// A surface with a fold (walled off, not a refusal on its own) and a non-manifold edge
/// further on in edge order is refused naming the non-manifold edge, the reason of the
/// refusal, not the fold on its smaller edge.
#[test]
fn a_non_manifold_edge_is_named_even_after_a_fold_on_a_smaller_edge() {
    let mut m = grid(&Grid::default());
    let v = node_at(&m, [0.5, 0.5, 0.0]);
    for nb in &mut m.node_blocks {
        if let Some(i) = nb.tags.iter().position(|&t| t == v) {
            nb.coords[i] = [1.9, 1.3, 0.0];
        }
    }
    // the fold alone: walled off, its edge named by the report
    let fold = match recombine(&mut m.clone(), &RecombineOptions::default()) {
        Ok(r) => r.walled_folds[0].refusal().to_string(),
        Err(e) => e.to_string(),
    };
    let edge = |s: &str, after: &str| -> (u64, u64) {
        let rest = &s[s.find(after).unwrap() + after.len()..];
        let word = rest.split_whitespace().next().unwrap();
        let (a, b) = word.split_once('-').unwrap();
        (a.parse().unwrap(), b.parse().unwrap())
    };
    let fold_edge = edge(&fold, "common edge ");
    // an edge of two triangles after the fold's, away from the moved node, gets a third
    // triangle (to a node above the plate)
    let tris = m
        .element_blocks
        .iter()
        .find(|b| b.element_type == etype::TRI3)
        .unwrap();
    let mut count = std::collections::HashMap::new();
    for i in 0..tris.len() {
        let e = tris.element(i);
        for k in 0..3 {
            let (a, b) = (e[k], e[(k + 1) % 3]);
            *count.entry((a.min(b), a.max(b))).or_insert(0) += 1;
        }
    }
    let (a, b) = count
        .iter()
        .filter(|&(&(a, b), &n)| n == 2 && a != v && b != v && (a, b) > fold_edge)
        .map(|(&e, _)| e)
        .max()
        .expect("an interior edge after the fold's");
    let top = m.max_node_tag() + 1;
    let block = m
        .node_blocks
        .iter_mut()
        .find(|b| b.entity_dim == 2)
        .unwrap();
    block.tags.push(top);
    block.coords.push([0.5, 0.5, 0.3]);
    let tag = m.max_element_tag() + 1;
    let tris = m
        .element_blocks
        .iter_mut()
        .find(|b| b.element_type == etype::TRI3)
        .unwrap();
    tris.tags.push(tag);
    tris.nodes.extend([a, b, top]);
    let e = recombine(&mut m, &RecombineOptions::default()).expect_err("refused");
    let msg = e.to_string();
    assert!(msg.contains("shared by 3 triangles"), "{msg}");
    assert_eq!(edge(&msg, "its edge "), (a, b), "{msg}");
    assert!(!msg.contains("folded"), "{msg}");
}
