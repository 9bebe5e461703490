//! Tests of the independent checker `tests/check_mesh.py` itself: it accepts
//! known perfect recombinations (structured meshes Gmsh writes both as
//! triangles and as the quads made of those triangle pairs, same node tags),
//! and it rejects each kind of broken output. Needs Gmsh.

use crate::common;

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

/// A triangle ABC with centre node p (three triangles: an odd surface) and
/// its three curves carrying line elements, in MSH 4.1 ASCII.
const ODD_TRIANGLE: &str = "$MeshFormat\n4.1 0 8\n$EndMeshFormat\n\
$PhysicalNames\n1\n2 1 \"tri\"\n$EndPhysicalNames\n\
$Entities\n3 3 1 0\n1 0 0 0 0\n2 1 0 0 0\n3 0.5 0.866 0 0\n\
1 0 0 0 1 0 0 0 2 1 -2\n2 0.5 0 0 1 0.866 0 0 2 2 -3\n3 0 0 0 0.5 0.866 0 0 2 3 -1\n\
1 0 0 0 1 0.866 0 1 1 3 1 2 3\n$EndEntities\n\
$Nodes\n4 4 1 4\n0 1 0 1\n1\n0 0 0\n0 2 0 1\n2\n1 0 0\n0 3 0 1\n3\n0.5 0.866 0\n\
2 1 0 1\n4\n0.45 0.3 0\n$EndNodes\n\
$Elements\n4 6 1 6\n1 1 1 1\n1 1 2\n1 2 1 1\n2 2 3\n1 3 1 1\n3 3 1\n\
2 1 2 3\n4 1 2 4\n5 2 3 4\n6 3 1 4\n$EndElements\n";

/// ODD_TRIANGLE after a parity repair that put node 5 at `m` on curve 1 (the
/// segment AB) and recombined the four triangles into two quads; with
/// `split_line` false the curve's line element is (wrongly) left whole.
fn repaired_triangle(m: &str, split_line: bool) -> String {
    let lines = if split_line {
        "1 1 1 2\n1 1 5\n7 5 2\n"
    } else {
        "1 1 1 1\n1 1 2\n"
    };
    let count = if split_line { 6 } else { 5 };
    format!(
        "$MeshFormat\n4.1 0 8\n$EndMeshFormat\n\
$PhysicalNames\n1\n2 1 \"tri\"\n$EndPhysicalNames\n\
$Entities\n3 3 1 0\n1 0 0 0 0\n2 1 0 0 0\n3 0.5 0.866 0 0\n\
1 0 0 0 1 0 0 0 2 1 -2\n2 0.5 0 0 1 0.866 0 0 2 2 -3\n3 0 0 0 0.5 0.866 0 0 2 3 -1\n\
1 0 0 0 1 0.866 0 1 1 3 1 2 3\n$EndEntities\n\
$Nodes\n5 5 1 5\n0 1 0 1\n1\n0 0 0\n0 2 0 1\n2\n1 0 0\n0 3 0 1\n3\n0.5 0.866 0\n\
1 1 0 1\n5\n{m}\n2 1 0 1\n4\n0.45 0.3 0\n$EndNodes\n\
$Elements\n4 {count} 1 11\n{lines}1 2 1 1\n2 2 3\n1 3 1 1\n3 3 1\n\
2 1 3 2\n10 1 5 4 3\n11 5 2 3 4\n$EndElements\n"
    )
}

fn check_texts(input: &str, output: &str) -> common::CheckReport {
    let dir = tempfile::tempdir().expect("temp dir");
    let (a, b) = (dir.path().join("in.msh"), dir.path().join("out.msh"));
    std::fs::write(&a, input).expect("write input");
    std::fs::write(&b, output).expect("write output");
    check_mesh(&a, &b, &[])
}

/// The split itself is accepted (boundary and line elements agree), but the two quads
/// around centre node 4, the only interior node, share it with valence 2: their corners
/// there add up to 360 degrees, so one is reflex and quad_valid rejects it.
#[test]
fn checker_accepts_a_parity_split_on_the_segment() {
    let report = check_texts(ODD_TRIANGLE, &repaired_triangle("0.5 0 0", true));
    for check in [
        "boundary",
        "curve_edges",
        "fixed_nodes",
        "area",
        "orientation",
    ] {
        assert!(
            report.report.contains(&format!("\"{check}\": true")),
            "{check}: {}",
            report.report
        );
    }
    assert_bad_quad(&report, "reflex corner at node 4");
}

#[test]
fn checker_rejects_a_split_node_off_the_segment() {
    let report = check_texts(ODD_TRIANGLE, &repaired_triangle("0.5 0.05 0", true));
    assert_violation(&report, "boundary");
    assert_violation(&report, "curve_edges");
}

#[test]
fn checker_rejects_a_split_missing_from_the_line_elements() {
    let report = check_texts(ODD_TRIANGLE, &repaired_triangle("0.5 0 0", false));
    assert_violation(&report, "boundary");
}

/// Asserts a `quad_valid` violation whose message names the element and `what`.
fn assert_bad_quad(report: &common::CheckReport, what: &str) {
    assert_violation(report, "quad_valid");
    assert!(
        report.report.contains("element ") && report.report.contains(what),
        "expected a bad quad ({what}) named by element and nodes: {}",
        report.report
    );
}

#[test]
fn checker_rejects_a_flat_corner_on_a_planar_surface() {
    let report = broken("structured_plate", "flat-corner");
    assert_bad_quad(&report, "flat corner at node");
    // The quad keeps its orientation and the surface its area: only quad_valid sees it.
    assert!(
        report.report.contains("\"orientation\": true"),
        "{}",
        report.report
    );
}

#[test]
fn checker_rejects_a_flat_corner_on_a_curved_surface() {
    assert_bad_quad(
        &broken("structured_shell", "flat-corner"),
        "flat corner at node",
    );
}

#[test]
fn checker_rejects_a_reflex_corner() {
    for name in ["structured_plate", "structured_shell"] {
        assert_bad_quad(&broken(name, "reflex-corner"), "reflex corner at node");
    }
}

#[test]
fn checker_rejects_a_zero_length_edge() {
    assert_bad_quad(&broken("structured_plate", "zero-edge"), "zero-length edge");
}

/// The triangle mesh of `corpus/periodic_curves.geo` (curves periodic in x and y), and
/// a mutated copy of it; both checked with triangles allowed.
fn periodic_reports(what: &str) -> (common::CheckReport, common::CheckReport) {
    let dir = tempfile::tempdir().expect("temp dir");
    let geo = repo_dir().join("corpus/periodic_curves.geo");
    let tri = dir.path().join("periodic.msh");
    generate_geo(&geo, &tri, Variant::Msh41Ascii, 0.2, &[]);
    let bad = dir.path().join("bad.msh");
    mutate(&tri, &bad, what);
    (
        check_mesh(&tri, &tri, &["--allow-triangles"]),
        check_mesh(&tri, &bad, &["--allow-triangles"]),
    )
}

#[test]
fn checker_rejects_lost_periodic_links() {
    let (same, report) = periodic_reports("periodic-dropped");
    assert!(same.ok, "{}", same.report);
    assert!(
        same.report.contains("\"periodic\": true"),
        "{}",
        same.report
    );
    assert_violation(&report, "periodic");
    assert!(report.report.contains("link to"), "{}", report.report);
}

#[test]
fn checker_rejects_a_slave_node_without_its_master() {
    let (_, report) = periodic_reports("periodic-unpaired");
    assert_violation(&report, "periodic");
    assert!(
        report.report.contains("without a master node"),
        "{}",
        report.report
    );
}

/// Two one-triangle surfaces sharing the edge 2-3, no curve entity nor line element
/// (as MSH 2.2 written with `Mesh.SaveAll = 0` has none), and outputs where the edge
/// is split by node 5 in surface 1 only, or in both.
const TWO_SURFACES: &str = "$MeshFormat\n4.1 0 8\n$EndMeshFormat\n\
$Entities\n0 0 2 0\n1 0 0 0 1 1 0 0 0\n2 1 0 0 2 1 0 0 0\n$EndEntities\n\
$Nodes\n2 4 1 4\n2 1 0 3\n1\n2\n3\n0 0 0\n1 0 0\n1 1 0\n2 2 0 1\n4\n2 0.5 0\n$EndNodes\n\
$Elements\n2 2 1 2\n2 1 2 1\n1 1 2 3\n2 2 2 1\n2 2 4 3\n$EndElements\n";

fn two_surfaces_split(both: bool) -> String {
    let second = if both {
        "2 2 3 1\n2 2 4 3 5\n"
    } else {
        "2 2 2 1\n2 2 4 3\n"
    };
    format!(
        "$MeshFormat\n4.1 0 8\n$EndMeshFormat\n\
$Entities\n0 0 2 0\n1 0 0 0 1 1 0 0 0\n2 1 0 0 2 1 0 0 0\n$EndEntities\n\
$Nodes\n2 5 1 5\n2 1 0 4\n1\n2\n3\n5\n0 0 0\n1 0 0\n1 1 0\n1 0.5 0\n2 2 0 1\n4\n2 0.5 0\n$EndNodes\n\
$Elements\n2 2 1 2\n2 1 3 1\n1 1 2 5 3\n{second}$EndElements\n"
    )
}

#[test]
fn checker_rejects_a_shared_edge_split_on_one_side_only() {
    let report = check_texts(TWO_SURFACES, &two_surfaces_split(false));
    assert_violation(&report, "shared_edges");
    assert!(
        report.report.contains("surface 1: [5], surface 2: kept"),
        "{}",
        report.report
    );
    // Split alike on both sides: the surfaces still conform (the quads themselves have
    // a flat corner at node 5, which quad_valid reports).
    let report = check_texts(TWO_SURFACES, &two_surfaces_split(true));
    assert!(
        report.report.contains("\"shared_edges\": true"),
        "{}",
        report.report
    );
    assert_bad_quad(&report, "flat corner at node 5");
}
