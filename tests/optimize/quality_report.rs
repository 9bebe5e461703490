//! Quality report: η, degrees and τ on meshes built in memory.

use blossomquad::mesh::Mesh;
use blossomquad::optimize::synth::{self, Soup};
use blossomquad::quality::{self, eta, ReferenceSize, SizeExpr, SizeField};
use glam::DVec3;

fn report(mesh: &Mesh, size: &SizeField) -> quality::QualityReport {
    quality::report(mesh, size).expect("report")
}

fn constant(h: f64) -> SizeField {
    SizeField::Expression(SizeExpr::new(&format!("{h:?}")).unwrap())
}

#[test]
fn eta_of_known_shapes() {
    let sq = [
        DVec3::new(0., 0., 0.),
        DVec3::new(2., 0., 0.),
        DVec3::new(2., 2., 0.),
        DVec3::new(0., 2., 0.),
    ];
    assert!((eta(&sq) - 1.0).abs() < 1e-12);
    let r = [
        sq[0],
        sq[1],
        DVec3::new(2., 0.5, 0.),
        DVec3::new(0., 0.5, 0.),
    ];
    assert!((eta(&r) - 1.0).abs() < 1e-12);
    // parallelogram with 45 degree angles: worst deviation pi/4 -> 0.5
    let p = [
        DVec3::new(0., 0., 0.),
        DVec3::new(1., 0., 0.),
        DVec3::new(2., 1., 0.),
        DVec3::new(1., 1., 0.),
    ];
    assert!((eta(&p) - 0.5).abs() < 1e-12, "{}", eta(&p));
    // a square with one corner lifted out of plane is no longer perfect
    let bent = [sq[0], sq[1], sq[2], DVec3::new(0., 2., 1.)];
    assert!(eta(&bent) < 1.0 && eta(&bent) > 0.0);
}

#[test]
fn structured_grid_has_degree_four_everywhere_and_eta_one() {
    let m = synth::to_mesh(&synth::quad_grid(6, 5, 6.0, 5.0));
    let r = report(&m, &constant(1.0));
    let s = &r.surfaces[0];
    assert_eq!(s.quads, 30);
    assert_eq!(s.triangles, 0);
    assert_eq!(s.interior_vertices, 5 * 4);
    assert_eq!(s.d4_percent, Some(100.0));
    assert_eq!((s.d_min, s.d_max), (Some(4), Some(4)));
    assert!((s.eta_worst.unwrap() - 1.0).abs() < 1e-12);
    assert!((s.eta_mean.unwrap() - 1.0).abs() < 1e-12);
    // all edges have length 1 under h = 1: tau = 100 %
    assert_eq!(s.edges, 6 * 6 + 5 * 7);
    assert!((s.tau_percent.unwrap() - 100.0).abs() < 1e-9);
    assert_eq!(
        r.total,
        quality::SurfaceQuality {
            surface: None,
            ..s.clone()
        }
    );
}

/// A polygon with `n` corners and `n` points between them around a centre, split into `n`
/// kite-shaped quads: the centre is the only interior vertex, of degree `n`.
fn star(n: usize) -> Soup {
    let mut points = vec![DVec3::ZERO];
    for k in 0..n {
        let a = std::f64::consts::TAU * k as f64 / n as f64;
        let b = std::f64::consts::TAU * (k as f64 + 0.5) / n as f64;
        points.push(DVec3::new(a.cos(), a.sin(), 0.0));
        points.push(DVec3::new(b.cos(), b.sin(), 0.0) * 0.8);
    }
    let faces = (0..n)
        .map(|k| vec![0, 2 + 2 * k, 1 + 2 * ((k + 1) % n), 2 + 2 * ((k + 1) % n)])
        .collect();
    Soup { points, faces }
}

#[test]
fn one_irregular_vertex_is_counted() {
    for n in [3usize, 5, 6] {
        let r = report(&synth::to_mesh(&star(n)), &constant(1.0));
        let s = &r.surfaces[0];
        assert_eq!(s.quads, n);
        assert_eq!(s.interior_vertices, 1, "{r}");
        assert_eq!((s.d_min, s.d_max), (Some(n), Some(n)), "{r}");
        assert_eq!(s.d4_percent, Some(0.0));
        assert!(s.eta_worst.unwrap() > 0.0, "{r}");
    }
}

#[test]
fn tau_of_a_known_edge_length_distribution() {
    // A 2x1 grid of unit squares has 7 edges of length 1. Under h = 2 every l = 0.5:
    // d = -0.5 for each, tau = 100 exp(-0.5).
    let m = synth::to_mesh(&synth::quad_grid(2, 1, 2.0, 1.0));
    let r = report(&m, &constant(2.0));
    assert_eq!(r.total.edges, 7);
    assert!((r.total.tau_percent.unwrap() - 100.0 * (-0.5f64).exp()).abs() < 1e-9);
    // Stretched by 4 in x: 4 horizontal edges of length 4 (l = 4, d = -0.75) and 3 vertical
    // ones of length 1 (d = 0) under h = 1.
    let r = report(
        &synth::to_mesh(&synth::quad_grid(2, 1, 8.0, 1.0)),
        &constant(1.0),
    );
    let expect = 100.0 * ((4.0 * -0.75) / 7.0f64).exp();
    assert!((r.total.tau_percent.unwrap() - expect).abs() < 1e-9);
    assert!((r.total.lh_max.unwrap() - 4.0).abs() < 1e-12);
    assert!((r.total.lh_min.unwrap() - 1.0).abs() < 1e-12);
}

#[test]
fn tau_with_a_linear_size_field_uses_simpson() {
    // Unit square under h = 1 + x: bottom and top edges l = Simpson of 1/(1+x) = 25/36,
    // left edge (x = 0) l = 1, right edge (x = 1) l = 1/2.
    let s = Soup {
        points: vec![
            DVec3::new(0., 0., 0.),
            DVec3::new(1., 0., 0.),
            DVec3::new(1., 1., 0.),
            DVec3::new(0., 1., 0.),
        ],
        faces: vec![vec![0, 1, 2, 3]],
    };
    let r = report(
        &synth::to_mesh(&s),
        &SizeField::Expression(SizeExpr::new("1.0 + x").unwrap()),
    );
    let simpson = (1.0 + 4.0 / 1.5 + 0.5) / 6.0;
    let d: f64 = 2.0 * (simpson - 1.0) + (0.5 - 1.0);
    assert!((r.total.tau_percent.unwrap() - 100.0 * (d / 4.0).exp()).abs() < 1e-9);
}

#[test]
fn reference_size_field_measures_triangles_and_quads_against_the_same_h() {
    let tri_mesh = synth::to_mesh(&synth::tri_grid(8, 8, 8.0, 8.0, 3));
    let reference = SizeField::Reference(ReferenceSize::from_mesh(&tri_mesh).unwrap());
    let tau_tri = report(&tri_mesh, &reference).total.tau_percent.unwrap();
    let quads = synth::to_mesh(&synth::quad_grid(8, 8, 8.0, 8.0));
    let r = report(&quads, &reference);
    let tau_quad = r.total.tau_percent.unwrap();
    // the reference h mixes unit legs and sqrt(2) diagonals: h in (1, 1.2) at every node,
    // so the unit quad edges have l in (1/1.2, 1) and tau in (83, 100)
    assert!(tau_tri > 80.0 && tau_tri < 100.0, "{tau_tri}");
    assert!(tau_quad > 83.0 && tau_quad < 100.0, "{tau_quad}");
    assert!(r.total.lh_max.unwrap() <= 1.0 + 1e-12);
    // self-estimate on a uniform grid: every node sees length 1 -> tau 100
    let r = report(&quads, &SizeField::SelfEstimate);
    assert!((r.total.tau_percent.unwrap() - 100.0).abs() < 1e-9);
}

#[test]
fn mixed_mesh_counts_triangles_and_prints_json_and_table() {
    let s = synth::pair_greedy(&synth::tri_grid(6, 6, 6.0, 6.0, 11));
    let m = synth::to_mesh(&s);
    let r = report(&m, &SizeField::SelfEstimate);
    let t = &r.total;
    assert_eq!(t.quads * 2 + t.triangles, 72);
    assert!(t.quads > 0);
    assert!(t.interior_vertices <= 25);
    let v: serde_json::Value = serde_json::from_str(&r.to_json()).unwrap();
    assert_eq!(v["total"]["quads"].as_u64(), Some(t.quads as u64));
    let table = r.to_string();
    assert!(
        table.contains("tau%") && table.lines().count() >= 4,
        "{table}"
    );
}

#[test]
fn missing_nodes_are_skipped_not_fatal() {
    let mut m = synth::to_mesh(&synth::quad_grid(2, 2, 2.0, 2.0));
    let last = m.element_blocks.len() - 1;
    m.element_blocks[last].nodes[0] = 999_999;
    let r = report(&m, &SizeField::SelfEstimate);
    assert_eq!(r.skipped_elements, 1);
    assert_eq!(r.total.quads, 3);
}
