//! Parity repair: odd surfaces are made even by splitting boundary segments, consistently
//! across the surfaces sharing a curve.

use crate::recombine_util;

use blossomquad::mesh::etype;
use blossomquad::recombine::{check_invariants, recombine, ParityMode, RecombineOptions};
use recombine_util::*;

#[test]
fn odd_fan_gets_one_boundary_split() {
    let mut b = Builder::new();
    b.entity(2, 1, &[], &[]);
    fan(&mut b, 1, [0.0, 0.0], 5);
    let before = b.mesh;
    let max_node = before.max_node_tag();
    let mut m = before.clone();
    let r = recombine(&mut m, &verify_opts()).unwrap();
    assert_eq!(r.parity_splits.len(), 1);
    let s = &r.parity_splits[0];
    assert_eq!(s.new_node, max_node + 1);
    assert_eq!(s.surfaces, vec![1]);
    // the ring nodes are classified on (bare) curve 101: the new node joins them
    assert_eq!(s.curve, Some(101));
    let blk = m
        .node_blocks
        .iter()
        .find(|b| b.entity_dim == 1 && b.entity_tag == 101)
        .unwrap();
    assert!(blk.tags.contains(&s.new_node));
    assert_eq!(count(&m, etype::QUAD4), 3);
    assert_eq!(count(&m, etype::TRI3), 0);
    assert!(r.log.iter().any(|l| l.contains("parity repair")));
    check_invariants(&before, &m).unwrap();
}

#[test]
fn odd_square_with_lines_splits_the_line_element_too() {
    let mut before = grid(&Grid {
        nx: 3,
        ny: 3,
        ..Default::default()
    });
    // split one segment of curve 4 (left side): 19 triangles, 13 line elements
    let left = line_of(&before, 4, 0);
    let first = split_edge(&mut before, left[0], left[1], 1, 4);
    assert_eq!(count(&before, etype::TRI3), 19);
    let lines_before = count(&before, etype::LINE2);
    let max_elem = before.max_element_tag();
    let mut m = before.clone();
    let r = recombine(&mut m, &verify_opts()).unwrap();
    assert_eq!(r.parity_splits.len(), 1);
    assert_eq!(count(&m, etype::LINE2), lines_before + 1);
    // 20 triangles. Merging the two halves of the repair's split triangle back would make a
    // 180° corner at a node that never moves; keeping them apart costs a vertex duplication
    // (one more quad) on a grid this small, and is worth it. (The input's own split node,
    // `first`, is ordinary input: its halves may merge, at the usual hopeless-quad cost.)
    let dups = r.surfaces[0].vertex_duplications;
    assert_eq!(dups, 1);
    assert_eq!(count(&m, etype::QUAD4), 10 + dups);
    let split = r.parity_splits[0].new_node;
    assert_ne!(split, first);
    let worst = max_angle_at(&m, split);
    assert!(worst < 171.0, "{worst} deg at split node {split}");
    // the new line element has a fresh tag above the maximum
    let line_tags: Vec<u64> = m
        .element_blocks
        .iter()
        .filter(|b| b.element_type == etype::LINE2)
        .flat_map(|b| b.tags.clone())
        .collect();
    assert!(line_tags.iter().any(|&t| t > max_elem));
    check_invariants(&before, &m).unwrap();
}

#[test]
fn two_odd_surfaces_sharing_a_curve_need_one_split() {
    let (mut before, id) = two_squares(3);
    let n = 3;
    // make both odd: split an outer segment of each (curve 1 on the left, curve 3 on the right)
    split_edge(&mut before, id[0][0], id[0][1], 1, 1);
    split_edge(&mut before, id[2 * n][0], id[2 * n][1], 1, 3);
    assert_eq!(count_on(&before, 1, etype::TRI3), 19);
    assert_eq!(count_on(&before, 2, etype::TRI3), 19);
    let mut m = before.clone();
    let r = recombine(&mut m, &verify_opts()).unwrap();
    assert_eq!(r.parity_splits.len(), 1, "{:?}", r.parity_splits);
    assert_eq!(
        r.parity_splits[0].curve,
        Some(2),
        "the shared curve is split"
    );
    assert_eq!(r.parity_splits[0].surfaces, vec![1, 2]);
    // 20 triangles each; a vertex duplication (extra edge around a test split) adds a quad
    let dup = |t: i32| {
        r.surfaces
            .iter()
            .find(|x| x.surface == t)
            .map_or(0, |x| x.vertex_duplications)
    };
    assert_eq!(count_on(&m, 1, etype::QUAD4), 10 + dup(1));
    assert_eq!(count_on(&m, 2, etype::QUAD4), 10 + dup(2));
    check_invariants(&before, &m).unwrap();
    // the split segment is carried by two line elements of curve 2 now
    let c2 = m
        .element_blocks
        .iter()
        .find(|b| b.element_type == etype::LINE2 && b.entity_tag == 2)
        .unwrap();
    assert_eq!(c2.len(), n + 1);
}

#[test]
fn one_odd_surface_next_to_an_even_one_splits_its_outer_boundary() {
    let (mut before, id) = two_squares(2);
    split_edge(&mut before, id[0][0], id[0][1], 1, 1);
    let mut m = before.clone();
    let r = recombine(&mut m, &verify_opts()).unwrap();
    assert_eq!(r.parity_splits.len(), 1);
    assert_eq!(r.parity_splits[0].surfaces, vec![1]);
    assert_eq!(r.parity_splits[0].curve, Some(1));
    check_invariants(&before, &m).unwrap();
}

#[test]
fn closed_shell_adjacent_odd_faces() {
    // cube faces z = 0 (1) and y = 0 (3) share the cube edge y = z = 0; splitting one of its
    // segments makes both odd; the repair must make both even again with one split
    let mut before = cube(2);
    let (a, b) = (
        node_at(&before, [0.0, 0.0, 0.0]),
        node_at(&before, [0.5, 0.0, 0.0]),
    );
    split_edge(&mut before, a, b, 2, 1);
    assert_eq!(count_on(&before, 1, etype::TRI3), 9);
    assert_eq!(count_on(&before, 3, etype::TRI3), 9);
    let mut m = before.clone();
    let r = recombine(&mut m, &verify_opts()).unwrap();
    assert_eq!(r.parity_splits.len(), 1, "{:?}", r.parity_splits);
    assert_eq!(r.parity_splits[0].surfaces, vec![1, 3]);
    assert_eq!(r.parity_splits[0].curve, None, "no curve data in this mesh");
    assert_eq!(count(&m, etype::TRI3), 0);
    check_invariants(&before, &m).unwrap();
}

#[test]
fn closed_shell_opposite_odd_faces() {
    // faces 1 (z = 0) and 2 (z = 1) odd, not adjacent: two splits through a face between
    let mut before = cube(2);
    let (a, b) = (
        node_at(&before, [0.0, 0.0, 0.0]),
        node_at(&before, [0.5, 0.0, 0.0]),
    );
    split_edge(&mut before, a, b, 2, 1); // flips 1 and 3
    let (a, b) = (
        node_at(&before, [0.0, 0.0, 1.0]),
        node_at(&before, [0.5, 0.0, 1.0]),
    );
    split_edge(&mut before, a, b, 2, 2); // flips 3 and 2
    let odd: Vec<i32> = (1..=6)
        .filter(|&s| count_on(&before, s, etype::TRI3) % 2 == 1)
        .collect();
    assert_eq!(odd, vec![1, 2]);
    let mut m = before.clone();
    let r = recombine(&mut m, &verify_opts()).unwrap();
    assert_eq!(r.parity_splits.len(), 2, "{:?}", r.parity_splits);
    assert_eq!(count(&m, etype::TRI3), 0);
    for s in &r.surfaces {
        assert_eq!(s.triangles_in % 2, 0);
    }
    check_invariants(&before, &m).unwrap();
}

#[test]
fn all_six_cube_faces_odd() {
    // splitting one segment on each of three disjoint cube edges makes all six faces odd
    let mut before = cube(2);
    for (p, q) in [
        ([0.0, 0.0, 0.0], [0.5, 0.0, 0.0]), // z=0 / y=0
        ([1.0, 1.0, 0.5], [1.0, 1.0, 1.0]), // x=1 / y=1
        ([0.0, 0.5, 1.0], [0.0, 1.0, 1.0]), // x=0 / z=1
    ] {
        let (a, b) = (node_at(&before, p), node_at(&before, q));
        split_edge(&mut before, a, b, 2, 1);
    }
    assert!((1..=6).all(|s| count_on(&before, s, etype::TRI3) % 2 == 1));
    let mut m = before.clone();
    let r = recombine(&mut m, &verify_opts()).unwrap();
    assert_eq!(r.parity_splits.len(), 3, "{:?}", r.parity_splits);
    assert_eq!(count(&m, etype::TRI3), 0);
    check_invariants(&before, &m).unwrap();
}

#[test]
fn parity_error_mode_names_the_curves() {
    let (mut before, id) = two_squares(2);
    split_edge(&mut before, id[0][0], id[0][1], 1, 1);
    split_edge(&mut before, id[4][0], id[4][1], 1, 3);
    let mut m = before.clone();
    let e = recombine(
        &mut m,
        &RecombineOptions {
            parity: ParityMode::Error,
            ..Default::default()
        },
    )
    .unwrap_err();
    let msg = e.to_string();
    assert!(
        msg.contains("surface 1") && msg.contains("surface 2"),
        "{msg}"
    );
    assert!(msg.contains("curve(s) 2"), "{msg}");
}

#[test]
fn parity_split_interpolates_parametric_coordinates() {
    let mut before = grid(&Grid {
        nx: 5,
        ny: 4,
        ..Default::default()
    });
    let left = line_of(&before, 4, 1);
    split_edge(&mut before, left[0], left[1], 1, 4);
    // parametric blocks: u = x on curves 1 and 3, u = y on curves 2 and 4; (u, v) = (x, y)
    let u_of = |curve: i32, c: &[f64; 3]| if curve % 2 == 1 { c[0] } else { c[1] };
    for b in before.node_blocks.iter_mut() {
        b.params = match b.entity_dim {
            1 => Some(b.coords.iter().map(|c| u_of(b.entity_tag, c)).collect()),
            2 => Some(b.coords.iter().flat_map(|c| [c[0], c[1]]).collect()),
            _ => None,
        };
    }
    let mut m = before.clone();
    let r = recombine(&mut m, &verify_opts()).unwrap();
    assert_eq!(r.parity_splits.len(), 1);
    let s = &r.parity_splits[0];
    let curve = s.curve.expect("split on a curve");
    let blk = m
        .node_blocks
        .iter()
        .find(|b| b.entity_dim == 1 && b.entity_tag == curve)
        .unwrap();
    for b in &m.node_blocks {
        if let Some(p) = &b.params {
            assert_eq!(p.len(), b.tags.len() * b.entity_dim as usize);
        }
    }
    let i = blk.tags.iter().position(|&t| t == s.new_node).unwrap();
    let both_inside = [s.segment.0, s.segment.1].iter().all(|t| {
        before
            .node_blocks
            .iter()
            .any(|b| b.entity_dim == 1 && b.entity_tag == curve && b.tags.contains(t))
    });
    let u = blk.params.as_ref().unwrap()[i];
    if both_inside {
        assert!((u - u_of(curve, &blk.coords[i])).abs() < 1e-12, "u = {u}");
    } else {
        assert!(m.warnings.iter().any(|w| w.contains("parametric")));
    }
    check_invariants(&before, &m).unwrap();
}

/// Two odd fan surfaces bounded only by periodic curves (curve 1 is the periodic image of
/// curve 2, curve 3 of curve 4, a translation by 5 in z): the only repair splits a segment
/// of a periodic curve together with its image, and pairs the two new nodes.
#[test]
fn periodic_curves_are_split_with_their_images() {
    use blossomquad::mesh::PeriodicLink;
    let mut b = Builder::new();
    let ring = |z: f64| -> Vec<[f64; 3]> {
        // curve A: 2 segments from (0,0) to (4,0), bent; curve B: 3 segments back over the
        // top (5 boundary segments: 5 triangles)
        vec![
            [0.0, 0.0, z],
            [2.0, -0.5, z],
            [4.0, 0.0, z],
            [3.0, 2.5, z],
            [0.8, 2.5, z],
        ]
    };
    let mut pairs: Vec<Vec<(u64, u64)>> = vec![Vec::new(), Vec::new()];
    let mut tags_by_z: Vec<Vec<u64>> = Vec::new();
    for (s, z) in [(1, 0.0), (2, 5.0)] {
        let (pa, pb) = (2 * s - 1, 2 * s); // points of this copy
        let (ca, cb) = if s == 1 { (1, 3) } else { (2, 4) };
        b.entity(0, pa, &[], &[]);
        b.entity(0, pb, &[], &[]);
        b.entity(1, ca, &[pa, -pb], &[]);
        b.entity(1, cb, &[pb, -pa], &[]);
        b.entity(2, s, &[ca, cb], &[]);
        let r = ring(z);
        let n: Vec<u64> = r
            .iter()
            .enumerate()
            .map(|(i, p)| match i {
                0 => b.node(0, pa, *p),
                2 => b.node(0, pb, *p),
                1 => b.node(1, ca, *p),
                _ => b.node(1, cb, *p),
            })
            .collect();
        b.line(ca, n[0], n[1]);
        b.line(ca, n[1], n[2]);
        for i in 2..5 {
            b.line(cb, n[i], n[(i + 1) % 5]);
        }
        let c = b.node(2, s, [2.0, 1.0, z]);
        for i in 0..5 {
            b.tri(s, [c, n[i], n[(i + 1) % 5]]);
        }
        tags_by_z.push(n);
    }
    let (lo, hi) = (&tags_by_z[0], &tags_by_z[1]);
    pairs[0].extend([(lo[0], hi[0]), (lo[1], hi[1]), (lo[2], hi[2])]);
    pairs[1].extend([
        (lo[2], hi[2]),
        (lo[3], hi[3]),
        (lo[4], hi[4]),
        (lo[0], hi[0]),
    ]);
    let shift = vec![
        1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0, -5.0, 0.0, 0.0, 0.0, 1.0,
    ];
    for (slave, master, p) in [(1, 2, &pairs[0]), (3, 4, &pairs[1])] {
        b.mesh.periodic.push(PeriodicLink {
            dim: 1,
            tag: slave,
            master_tag: master,
            affine: Some(shift.clone()),
            node_pairs: p.clone(),
        });
    }
    let before = b.mesh;
    // --parity error names a curve pair, and the repair does it
    let mut e = before.clone();
    let err = recombine(
        &mut e,
        &RecombineOptions {
            parity: ParityMode::Error,
            ..Default::default()
        },
    )
    .unwrap_err();
    assert!(err.to_string().contains("by one fixes them"), "{err}");
    let mut m = before.clone();
    let r = recombine(&mut m, &verify_opts()).unwrap();
    assert_eq!(r.parity_splits.len(), 2, "{:?}", r.log);
    let (s0, s1) = (&r.parity_splits[0], &r.parity_splits[1]);
    let curves = [s0.curve.unwrap(), s1.curve.unwrap()];
    assert!(curves == [1, 2] || curves == [2, 1] || curves == [3, 4] || curves == [4, 3]);
    let link = m
        .periodic
        .iter()
        .find(|l| l.tag == curves[0].min(curves[1]))
        .unwrap();
    let new_pair = link
        .node_pairs
        .iter()
        .find(|p| p.0 == s0.new_node || p.0 == s1.new_node)
        .expect("new nodes paired");
    assert!(new_pair.1 == s0.new_node || new_pair.1 == s1.new_node);
    let pos = |t: u64| {
        m.node_blocks
            .iter()
            .find_map(|b| b.tags.iter().position(|&x| x == t).map(|i| b.coords[i]))
            .unwrap()
    };
    let (ps, pm) = (pos(new_pair.0), pos(new_pair.1));
    assert!((ps[0] - pm[0]).abs() < 1e-12 && (ps[1] - pm[1]).abs() < 1e-12);
    assert!((pm[2] - ps[2] - 5.0).abs() < 1e-12);
    assert_eq!(count(&m, etype::TRI3), 0);
    check_invariants(&before, &m).unwrap();
}

/// A segment on `RecombineOptions::parity_avoid` (what the pipeline's fallback sets when a
/// split node ended in a quad that is not valid) is not split when another segment fixes
/// the same odd surface; when it is the only one, it still is.
#[test]
fn an_avoided_segment_gives_way_to_another_of_the_same_surface() {
    let mut before = grid(&Grid {
        nx: 3,
        ny: 3,
        ..Default::default()
    });
    let left = line_of(&before, 4, 0);
    split_edge(&mut before, left[0], left[1], 1, 4);
    let mut first = before.clone();
    let r = recombine(&mut first, &verify_opts()).unwrap();
    assert_eq!(r.parity_splits.len(), 1);
    let chosen = r.parity_splits[0].segment;
    let mut m = before.clone();
    let opts = RecombineOptions {
        parity_avoid: vec![(chosen.1, chosen.0)],
        ..verify_opts()
    };
    let r = recombine(&mut m, &opts).unwrap();
    assert_eq!(r.parity_splits.len(), 1);
    let other = r.parity_splits[0].segment;
    let same = |a: (u64, u64), b: (u64, u64)| a == b || a == (b.1, b.0);
    assert!(!same(other, chosen), "{other:?} was to be avoided");
    assert_eq!(count(&m, etype::TRI3), 0);
    check_invariants(&before, &m).unwrap();

    // a fan of 5 triangles around one node: every boundary segment flips it, so avoiding
    // all but one leaves that one, and avoiding every one still splits one
    let mut b = Builder::new();
    b.entity(2, 1, &[], &[]);
    fan(&mut b, 1, [0.0, 0.0], 5);
    let fan_mesh = b.mesh;
    let mut probe = fan_mesh.clone();
    let r = recombine(&mut probe, &verify_opts()).unwrap();
    let seg = r.parity_splits[0].segment;
    let mut m = fan_mesh.clone();
    let all: Vec<(u64, u64)> = (0..fan_mesh.max_node_tag())
        .flat_map(|a| (0..=fan_mesh.max_node_tag()).map(move |b| (a, b)))
        .collect();
    let opts = RecombineOptions {
        parity_avoid: all,
        ..verify_opts()
    };
    let r = recombine(&mut m, &opts).unwrap();
    assert_eq!(r.parity_splits.len(), 1, "still repaired");
    assert!(
        same(r.parity_splits[0].segment, seg),
        "the usual choice among equals"
    );
    check_invariants(&fan_mesh, &m).unwrap();
}
