//! Tests of the independent checker `tests/check_mesh.py` itself: it accepts
//! known perfect recombinations (structured meshes Gmsh writes both as
//! triangles and as the quads made of those triangle pairs, same node tags),
//! and it rejects each kind of broken output. Needs Gmsh.

mod common;

use common::{check_mesh, generate_geo, mutate, repo_dir, Variant};
use std::path::{Path, PathBuf};

/// Triangle and quad versions of a structured reference mesh in `variant`.
fn reference(dir: &Path, name: &str, variant: Variant) -> (PathBuf, PathBuf) {
    let geo = repo_dir().join(format!("tests/common/{name}.geo"));
    let tri = dir.join(format!("{name}-tri-{}.msh", variant.name()));
    let quad = dir.join(format!("{name}-quad-{}.msh", variant.name()));
    generate_geo(&geo, &tri, variant, 1.0, &[]);
    generate_geo(&geo, &quad, variant, 1.0, &[("quads", 1.0)]);
    (tri, quad)
}

#[test]
fn checker_accepts_exact_recombination_in_every_variant() {
    let dir = tempfile::tempdir().expect("temp dir");
    for name in ["structured_plate", "structured_shell"] {
        for variant in Variant::ALL {
            let (tri, quad) = reference(dir.path(), name, variant);
            let report = check_mesh(&tri, &quad, &[]);
            assert!(report.ok, "{name} {}: {}", variant.name(), report.report);
            assert!(report.report.contains("\"quads\": "), "{}", report.report);
        }
    }
}

#[test]
fn checker_rejects_the_triangle_mesh_itself() {
    let dir = tempfile::tempdir().expect("temp dir");
    let (tri, _) = reference(dir.path(), "structured_plate", Variant::Msh41Ascii);
    let report = check_mesh(&tri, &tri, &[]);
    assert_eq!(report.code, Some(1), "{}", report.report);
    assert!(report.report.contains("no_triangles"), "{}", report.report);
    // ... and accepts it when triangles are explicitly allowed.
    assert!(check_mesh(&tri, &tri, &["--allow-triangles"]).ok);
}

/// Mutates the plate's (or shell's) valid quad mesh and returns the report.
fn broken(name: &str, what: &str) -> common::CheckReport {
    let dir = tempfile::tempdir().expect("temp dir");
    let (tri, quad) = reference(dir.path(), name, Variant::Msh41Ascii);
    let bad = dir.path().join(format!("{what}.msh"));
    mutate(&quad, &bad, what);
    check_mesh(&tri, &bad, &[])
}

/// Asserts the checker failed (exit 1) and reported `check` as violated.
fn assert_violation(report: &common::CheckReport, check: &str) {
    assert_eq!(report.code, Some(1), "{}", report.report);
    assert!(
        report.report.contains(&format!("\"{check}\": false")),
        "expected a {check} violation: {}",
        report.report
    );
}

#[test]
fn checker_accepts_an_unchanged_rewrite() {
    let report = broken("structured_plate", "identity");
    assert!(report.ok, "{}", report.report);
}

#[test]
fn checker_rejects_a_triangle_left() {
    assert_violation(&broken("structured_plate", "triangle-left"), "no_triangles");
}

#[test]
fn checker_rejects_a_flipped_quad_on_a_planar_surface() {
    assert_violation(&broken("structured_plate", "flipped-quad"), "orientation");
}

#[test]
fn checker_rejects_a_flipped_quad_on_a_curved_surface() {
    assert_violation(&broken("structured_shell", "flipped-quad"), "orientation");
}

#[test]
fn checker_rejects_a_duplicated_quad() {
    assert_violation(&broken("structured_plate", "duplicate-quad"), "conformity");
}

#[test]
fn checker_rejects_a_moved_boundary_node() {
    let report = broken("structured_plate", "moved-node");
    assert_violation(&report, "fixed_nodes");
    assert_violation(&report, "area");
}

#[test]
fn checker_rejects_a_lost_line_element() {
    assert_violation(&broken("structured_plate", "lost-segment"), "curve_edges");
}

#[test]
fn checker_rejects_a_renamed_physical_group() {
    assert_violation(
        &broken("structured_plate", "renamed-group"),
        "physical_groups",
    );
}

#[test]
fn checker_rejects_an_output_gmsh_cannot_load() {
    let dir = tempfile::tempdir().expect("temp dir");
    let (tri, quad) = reference(dir.path(), "structured_plate", Variant::Msh41Ascii);
    let bytes = std::fs::read(&quad).expect("read quad mesh");
    let text = String::from_utf8_lossy(&bytes);
    // Reference a node that does not exist in the first quad element line.
    let at = text.find("$Elements").expect("elements section");
    let elements = &text[at..];
    let quad_block = elements.find("\n2 1 3 ").expect("quad block header");
    let line_start = at + quad_block + 1;
    let first_elem = text[line_start..].find('\n').expect("block header end") + line_start + 1;
    let end = text[first_elem..].find('\n').expect("element line end") + first_elem;
    let tag = text[first_elem..end]
        .split_whitespace()
        .next()
        .expect("element tag");
    let corrupted = format!("{}{tag} 1 2 3 999999{}", &text[..first_elem], &text[end..]);
    let bad = dir.path().join("bad.msh");
    std::fs::write(&bad, corrupted).expect("write");
    let report = check_mesh(&tri, &bad, &[]);
    assert_violation(&report, "loads");
}

#[test]
fn checker_reports_an_unreadable_input_as_usage_error() {
    let dir = tempfile::tempdir().expect("temp dir");
    let missing = dir.path().join("missing.msh");
    let report = check_mesh(&missing, &missing, &[]);
    assert_eq!(report.code, Some(2), "{}", report.report);
}
