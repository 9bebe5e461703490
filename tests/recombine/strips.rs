//! Strips meshed again with a midline: a narrow face whose triangles lie in one row between
//! its two long curves, ending in a fan of three triangles round a node in the middle of
//! each short end (as Gmsh meshes a small chamfer or fillet), has one way to pair its
//! triangles, which makes a quad with a straight corner at that node.

use crate::recombine_util;

use blossomquad::mesh::{etype, Mesh};
use blossomquad::recombine::{check_invariants, recombine, RecombineOptions};
use recombine_util::*;

/// How the ends of [`add_strip`] are meshed.
#[derive(Clone, Copy, PartialEq)]
enum Ends {
    /// Three triangles round the bottom curve's second node, as on a chamfer.
    Fan,
    /// Three triangles round the end's middle node, the middle one with no wall edge, as on
    /// a small fillet.
    Y,
}

/// Adds a planar strip `[0, 1] × [y0, y0 + h]` as surface `s` (curves `4s + 1 … 4s + 4`:
/// bottom, top, left, right, with line elements): `n` segments on each long side, the top
/// nodes shifted by `shift` in x (but the corners), one node in the middle of each short
/// end, and one row of triangles between the sides, the ends meshed as `ends` says.
/// Returns the surface's triangles.
fn add_strip(b: &mut Builder, s: i32, y0: f64, n: usize, h: f64, shift: f64, ends: Ends) -> usize {
    let c = 4 * s;
    for k in 1..=4 {
        b.entity(1, c + k, &[], &[]);
    }
    b.entity(2, s, &[c + 1, c + 2, c + 3, c + 4], &[]);
    let lo: Vec<u64> = (0..=n)
        .map(|i| b.node(1, c + 1, [i as f64 / n as f64, y0, 0.0]))
        .collect();
    let hi: Vec<u64> = (0..=n)
        .map(|i| {
            let x = i as f64 / n as f64 + if i == 0 || i == n { 0.0 } else { shift };
            b.node(1, c + 2, [x, y0 + h, 0.0])
        })
        .collect();
    let left = b.node(1, c + 3, [0.0, y0 + 0.5 * h, 0.0]);
    let right = b.node(1, c + 4, [1.0, y0 + 0.5 * h, 0.0]);
    let mut tris = Vec::new();
    match ends {
        Ends::Fan => tris.extend([
            [lo[0], lo[1], left],
            [left, lo[1], hi[0]],
            [hi[0], lo[1], hi[1]],
        ]),
        Ends::Y => tris.extend([
            [lo[0], lo[1], left],
            [left, lo[1], hi[1]],
            [left, hi[1], hi[0]],
        ]),
    }
    for i in 1..n - 1 {
        tris.push([lo[i], lo[i + 1], hi[i]]);
        tris.push([hi[i], lo[i + 1], hi[i + 1]]);
    }
    let (a, z) = (n - 1, n);
    match ends {
        Ends::Fan => tris.extend([
            [lo[a], lo[z], hi[a]],
            [hi[a], lo[z], right],
            [hi[a], right, hi[z]],
        ]),
        Ends::Y => tris.extend([
            [lo[a], lo[z], right],
            [lo[a], right, hi[a]],
            [right, hi[z], hi[a]],
        ]),
    }
    for t in &tris {
        b.tri(s, *t);
    }
    for i in 0..n {
        b.line(c + 1, lo[i], lo[i + 1]);
        b.line(c + 2, hi[i], hi[i + 1]);
    }
    b.line(c + 3, lo[0], left);
    b.line(c + 3, left, hi[0]);
    b.line(c + 4, lo[n], right);
    b.line(c + 4, right, hi[n]);
    tris.len()
}

/// A square of 200 triangles as surface `s`, away from the strips: room in the element
/// count for a strip to gain quads.
fn add_square(b: &mut Builder, s: i32) {
    let c = 4 * s;
    b.entity(1, c + 1, &[], &[]);
    b.entity(2, s, &[c + 1], &[]);
    let k = 10;
    let id: Vec<Vec<u64>> = (0..=k)
        .map(|j| {
            (0..=k)
                .map(|i| {
                    let p = [i as f64 / k as f64, 5.0 + j as f64 / k as f64, 0.0];
                    let edge = i == 0 || j == 0 || i == k || j == k;
                    b.node(if edge { 1 } else { 2 }, if edge { c + 1 } else { s }, p)
                })
                .collect()
        })
        .collect();
    for j in 0..k {
        for i in 0..k {
            b.tri(s, [id[j][i], id[j][i + 1], id[j + 1][i + 1]]);
            b.tri(s, [id[j][i], id[j + 1][i + 1], id[j + 1][i]]);
        }
    }
}

/// Smallest corner angle (degrees) of the quads of surface `s`, and the largest.
fn corner_range(m: &Mesh, s: i32) -> (f64, f64) {
    let (mut lo, mut hi) = (180.0f64, 0.0f64);
    for p in quad_coords_on(m, s) {
        for k in 0..4 {
            let (c, a, d) = (p[k], p[(k + 1) % 4], p[(k + 3) % 4]);
            let u = [a[0] - c[0], a[1] - c[1]];
            let w = [d[0] - c[0], d[1] - c[1]];
            // signed angle from u to w, counter-clockwise (the strips are counter-clockwise
            // in the xy-plane)
            let angle = (u[0] * w[1] - u[1] * w[0])
                .atan2(u[0] * w[0] + u[1] * w[1])
                .to_degrees();
            lo = lo.min(angle);
            hi = hi.max(angle);
        }
    }
    (lo, hi)
}

#[test]
fn a_strip_whose_ends_are_fans_of_three_gets_a_midline() {
    for ends in [Ends::Fan, Ends::Y] {
        for n in [4, 6, 7] {
            let mut b = Builder::new();
            let tris = add_strip(&mut b, 1, 0.0, n, 0.05, 0.3 / n as f64, ends);
            add_square(&mut b, 2);
            let before = b.mesh;
            let mut m = before.clone();
            let r = recombine(&mut m, &verify_opts()).unwrap();
            check_invariants(&before, &m).unwrap();
            assert_eq!(count_on(&m, 1, etype::TRI3), 0);
            let s1 = r.surfaces.iter().find(|s| s.surface == 1).unwrap();
            assert_eq!(s1.strips_remeshed, 1, "n = {n}: {:?}", r.log);
            // two rows of quads, the midline's nodes inside the strip
            assert_eq!(count_on(&m, 1, etype::QUAD4), 2 * n, "n = {n}");
            let inner = m
                .node_blocks
                .iter()
                .filter(|nb| nb.entity_dim == 2 && nb.entity_tag == 1)
                .flat_map(|nb| &nb.coords)
                .collect::<Vec<_>>();
            assert_eq!(inner.len(), n - 1, "n = {n}");
            assert!(inner.iter().all(|p| p[1] > 0.0 && p[1] < 0.05));
            let (lo, hi) = corner_range(&m, 1);
            assert!(lo > 30.0 && hi < 150.0, "n = {n}: corners {lo:.1}..{hi:.1}");
            assert_eq!(
                count(&m, etype::QUAD4),
                2 * n + 100,
                "{tris} strip triangles"
            );

            // without the midline, the strip's pairs (one way to pair a path, extra
            // edges at a Y) leave a corner far from square
            let mut off = before.clone();
            let opts = RecombineOptions {
                two_row_strips: false,
                ..verify_opts()
            };
            let _ = recombine(&mut off, &opts);
            let (off_lo, off_hi) = corner_range(&off, 1);
            let spread = |lo: f64, hi: f64| (90.0 - lo).max(hi - 90.0);
            assert!(
                spread(off_lo, off_hi) > spread(lo, hi) + 10.0,
                "n = {n}: corners {off_lo:.1}..{off_hi:.1} without, {lo:.1}..{hi:.1} with"
            );
        }
    }
}

#[test]
fn strips_gain_quads_only_within_the_element_count_worst_first() {
    // three strips alone: 0.75 quads per triangle (the small-mesh allowance) leaves room
    // for the midlines of two of them; the worst ones (the fan ends pair into a straight
    // corner, the Y ends into a quad the vertex duplication turns) go first
    let mut b = Builder::new();
    let mut tris = 0;
    for (s, shift) in [(1, 0.02), (2, 0.05), (3, 0.08)] {
        tris += add_strip(&mut b, s, 2.0 * s as f64, 6, 0.05, shift, Ends::Fan);
    }
    let before = b.mesh;
    let mut m = before.clone();
    let r = recombine(&mut m, &verify_opts()).unwrap();
    check_invariants(&before, &m).unwrap();
    let remeshed: usize = r.surfaces.iter().map(|s| s.strips_remeshed).sum();
    let quads = count(&m, etype::QUAD4);
    assert!(
        quads as f64 <= 0.75 * tris as f64,
        "{quads} quads from {tris} triangles"
    );
    assert_eq!(remeshed, 2, "{:?}", r.log);
    assert_eq!(quads, tris / 2 + 2 * (12 - 7));
}

/// The smallest corner quality (eq. 3, one corner) of the quads of surface 1 of a planar
/// counter-clockwise mesh, from [`corner_range`].
fn worst_corner_eta(m: &Mesh) -> f64 {
    let (lo, hi) = corner_range(m, 1);
    1.0 - (90.0 - lo).max(hi - 90.0) / 90.0
}

#[test]
fn a_band_whose_circles_differ_in_segments_gets_a_midline_where_its_pairs_shear() {
    // a ring of 9 outer and 7 inner segments (a pipe's end cap meshed coarsely): each of
    // its two pairings leaves a quad sheared by two segments' offset; cells of the band
    // with a midline between the two odd ones do better
    let mut gained = 0;
    for (outer, inner) in [(9, 7), (11, 9), (12, 8)] {
        let before = annulus(outer, inner, 0.67);
        let mut m = before.clone();
        let r = recombine(&mut m, &verify_opts()).unwrap();
        check_invariants(&before, &m).unwrap();
        assert_eq!(count(&m, etype::TRI3), 0);
        let mut off = before.clone();
        let opts = RecombineOptions {
            two_row_strips: false,
            ..verify_opts()
        };
        recombine(&mut off, &opts).unwrap();
        let (with, without) = (worst_corner_eta(&m), worst_corner_eta(&off));
        println!("{outer}/{inner}: worst corner eta {without:.3} -> {with:.3}");
        if r.surfaces[0].strips_remeshed == 1 {
            assert!(
                with >= without + 0.05,
                "{outer}/{inner}: {without:.3} -> {with:.3}"
            );
            assert!(with > 0.0);
            gained += 1;
        } else {
            assert!(without >= 0.3 || with == without);
        }
    }
    assert!(gained >= 2, "{gained} bands remeshed");
}

/// A thin wire along z: a cylinder of radius `r` made of four quarter faces (surfaces
/// 1 … 4, quarter `k` between the side lines `10 + k` and `11 + k`, bottom and top arcs
/// `20 + k` and `30 + k`), each with three nodes on its end arcs and `n` segments of
/// length `h` on its sides: one row of two triangles per segment, the first and last rows
/// three triangles round the arc's middle node, as Gmsh meshes a wire coarser than its
/// radius.
fn wire(r: f64, n: usize, h: f64) -> Mesh {
    let mut b = Builder::new();
    for k in 0..4 {
        for c in [10 + k, 20 + k, 30 + k] {
            b.entity(1, c, &[], &[]);
        }
    }
    for k in 0..4 {
        b.entity(2, 1 + k, &[10 + k, 20 + k, 10 + (k + 1) % 4, 30 + k], &[]);
    }
    let at = |deg: f64, z: f64| {
        let t = deg.to_radians();
        [r * t.cos(), r * t.sin(), z]
    };
    let sides: Vec<Vec<u64>> = (0..4)
        .map(|k| {
            (0..=n)
                .map(|i| b.node(1, 10 + k, at(90.0 * k as f64, i as f64 * h)))
                .collect()
        })
        .collect();
    for k in 0..4 {
        let (a, c) = (&sides[k as usize], &sides[(k as usize + 1) % 4]);
        let mid = 90.0 * k as f64 + 45.0;
        let m = b.node(1, 20 + k, at(mid, 0.0));
        let t = b.node(1, 30 + k, at(mid, n as f64 * h));
        // counter-clockwise in (angle, z): the normals point outwards
        for tri in [[a[0], m, a[1]], [m, c[1], a[1]], [m, c[0], c[1]]] {
            b.tri(1 + k, tri);
        }
        for i in 1..n - 1 {
            b.tri(1 + k, [a[i], c[i], c[i + 1]]);
            b.tri(1 + k, [a[i], c[i + 1], a[i + 1]]);
        }
        let (a1, c1, an, cn) = (a[n - 1], c[n - 1], a[n], c[n]);
        for tri in [[t, an, a1], [t, a1, c1], [t, c1, cn]] {
            b.tri(1 + k, tri);
        }
        b.line(20 + k, a[0], m);
        b.line(20 + k, m, c[0]);
        b.line(30 + k, an, t);
        b.line(30 + k, t, cn);
        for i in 0..n {
            b.line(10 + k, a[i], a[i + 1]);
        }
    }
    b.mesh
}

#[test]
fn the_quarter_faces_of_a_thin_wire_turn_their_ends_across_the_side_lines_they_share() {
    // without the turns each quarter pairs every row across its long diagonal (a quad as
    // thin as the quarter is narrow) or needs a midline from end to end
    let (r, n, h) = (0.03, 12, 0.25);
    let before = wire(r, n, h);
    let mut m = before.clone();
    let report = recombine(&mut m, &verify_opts()).unwrap();
    check_invariants(&before, &m).unwrap();
    assert_eq!(count(&m, etype::TRI3), 0);
    let turns: Vec<_> = report.parity_splits.iter().filter(|s| s.turn).collect();
    // two turns at each end, across two opposite side lines
    assert_eq!(turns.len(), 4, "{:?}", report.log);
    for s in &turns {
        assert_eq!(s.surfaces.len(), 2);
        assert!((10..14).contains(&s.curve.unwrap_or(0)));
    }
    // each quarter: its 2n + 2 triangles, three more at each end, one quad per two
    assert_eq!(count(&m, etype::QUAD4), 4 * (n + 4));
    let worst = quad_coords(&m)
        .iter()
        .map(|(_, q)| {
            let q: [glam::DVec3; 4] = std::array::from_fn(|k| glam::DVec3::from_array(q[k]));
            blossomquad::quality::eta(&q)
        })
        .fold(f64::INFINITY, f64::min);
    assert!(worst >= 0.3, "worst quad eta {worst:.3}");
    // with the turns off (or the strips' plans), every curve node stays where it is
    for opts in [
        RecombineOptions {
            turn_strip_ends: false,
            ..verify_opts()
        },
        RecombineOptions {
            two_row_strips: false,
            ..verify_opts()
        },
    ] {
        let mut off = before.clone();
        let r_off = recombine(&mut off, &opts).unwrap();
        assert!(r_off.parity_splits.is_empty());
        assert_eq!(count(&off, etype::TRI3), 0);
    }
}
