//! The main job on every fixture in all four MSH variants: the output keeps
//! the input's format, Gmsh loads it, `--verify` passes and the independent
//! checker (`tests/check_mesh.py`) finds every invariant; parity repair and
//! `--parity error` on the odd fixture; stdin/stdout; the README's first
//! command on the shipped mesh. Needs Gmsh.

use crate::common;

use common::{
    assert_variant, blossomquad, blossomquad_run, check_mesh, generate, geo_dir, gmsh_loads,
    recombine, test_size, Variant,
};
use std::path::Path;

/// Recombines `input` into `output` with `--verify` and checks it independently.
fn recombine_and_check(input: &Path, output: &Path, variant: Variant, extra: &[&str]) {
    let (code, stderr) = recombine(input, output, extra);
    assert_eq!(
        code,
        Some(0),
        "blossomquad {} failed: {stderr}",
        input.display()
    );
    assert_variant(output, variant);
    gmsh_loads(output).unwrap_or_else(|e| panic!("{e}"));
    let report = check_mesh(input, output, &[]);
    assert!(report.ok, "{}: {}", input.display(), report.report);
}

fn recombine_fixture(fixture: &str) {
    let dir = tempfile::tempdir().expect("temp dir");
    for variant in Variant::ALL {
        let input = generate(fixture, variant, dir.path(), test_size(fixture), &[]);
        let output = dir
            .path()
            .join(format!("{fixture}-{}-quads.msh", variant.name()));
        recombine_and_check(&input, &output, variant, &[]);
    }
}

#[test]
fn recombine_rectangle_all_variants() {
    recombine_fixture("rectangle");
}

#[test]
fn recombine_square_hole_all_variants() {
    recombine_fixture("square_hole");
}

#[test]
fn recombine_cad_solid_all_variants() {
    recombine_fixture("cad_solid");
}

#[test]
fn recombine_even_curves_repairs_parity_all_variants() {
    recombine_fixture("even_curves");
}

#[test]
fn recombine_without_optimization_keeps_invariants() {
    let dir = tempfile::tempdir().expect("temp dir");
    for fixture in ["square_hole", "cad_solid"] {
        let variant = Variant::Msh41Binary;
        let input = generate(fixture, variant, dir.path(), test_size(fixture), &[]);
        for (name, args) in [
            ("no-optimize", vec!["--no-optimize"]),
            ("no-topology", vec!["--no-topology"]),
            ("smooth-0", vec!["--smooth", "0"]),
        ] {
            let output = dir.path().join(format!("{fixture}-{name}.msh"));
            recombine_and_check(&input, &output, variant, &args);
        }
    }
}

#[test]
fn recombine_cad_solid_with_odd_faces() {
    // At this size Gmsh's plain curve counts leave some faces of the closed
    // shell odd: parity repair must split shared curves consistently.
    let dir = tempfile::tempdir().expect("temp dir");
    let variant = Variant::Msh41Ascii;
    let input = generate("cad_solid", variant, dir.path(), 0.25, &[]);
    let output = dir.path().join("cad_solid-fine-quads.msh");
    recombine_and_check(&input, &output, variant, &[]);
}

#[test]
fn parity_error_names_the_odd_surfaces() {
    let dir = tempfile::tempdir().expect("temp dir");
    let input = generate("even_curves", Variant::Msh41Ascii, dir.path(), 1.0, &[]);
    let output = dir.path().join("refused.msh");
    let (code, _, stderr) = blossomquad_run([
        input.as_os_str(),
        "-o".as_ref(),
        output.as_os_str(),
        "--parity".as_ref(),
        "error".as_ref(),
    ]);
    assert_eq!(code, Some(1), "stderr: {stderr}");
    assert!(!output.exists(), "no output on refusal");
    let lower = stderr.to_lowercase();
    assert!(lower.contains("odd"), "{stderr}");
    // Surfaces 2 (the triangle) and 3 (the pentagon) are odd, 1 (the square) even.
    for tag in ["2", "3"] {
        assert!(
            stderr
                .split(|c: char| !c.is_ascii_digit())
                .any(|w| w == tag),
            "surface {tag} not named: {stderr}"
        );
    }
}

#[test]
fn parity_error_accepts_even_input() {
    let dir = tempfile::tempdir().expect("temp dir");
    let input = generate("rectangle", Variant::Msh41Ascii, dir.path(), 1.0, &[]);
    let output = dir.path().join("even.msh");
    recombine_and_check(
        &input,
        &output,
        Variant::Msh41Ascii,
        &["--parity", "repair"],
    );
    let output2 = dir.path().join("even2.msh");
    recombine_and_check(
        &input,
        &output2,
        Variant::Msh41Ascii,
        &["--parity", "error"],
    );
}

#[test]
fn readme_first_command_on_shipped_mesh() {
    let dir = tempfile::tempdir().expect("temp dir");
    let input = geo_dir().join("rectangle.msh");
    let output = dir.path().join("rectangle-quads.msh");
    blossomquad()
        .arg(&input)
        .arg("-o")
        .arg(&output)
        .assert()
        .success();
    assert_variant(&output, Variant::Msh41Ascii);
    let report = check_mesh(&input, &output, &[]);
    assert!(report.ok, "{}", report.report);
}

#[test]
fn stdin_to_stdout() {
    let dir = tempfile::tempdir().expect("temp dir");
    let input = geo_dir().join("rectangle.msh");
    let bytes = std::fs::read(&input).expect("read shipped mesh");
    let out = blossomquad()
        .args(["-", "-o", "-", "--quiet"])
        .write_stdin(bytes)
        .assert()
        .success();
    let output = dir.path().join("stdout.msh");
    std::fs::write(&output, &out.get_output().stdout).expect("write");
    assert_variant(&output, Variant::Msh41Ascii);
    let report = check_mesh(&input, &output, &[]);
    assert!(report.ok, "{}", report.report);
}

#[test]
fn format_override_on_recombination() {
    let dir = tempfile::tempdir().expect("temp dir");
    let input = geo_dir().join("rectangle.msh");
    for target in Variant::ALL {
        let output = dir.path().join(format!("quads-{}.msh", target.name()));
        recombine_and_check(&input, &output, target, &target.cli_args());
    }
}

/// The eq. 7 cost option on a curved multi-face solid and on the odd-surface fixture: the
/// output passes the same independent checks (`recombine` runs with `--verify`).
#[test]
fn cross_field_cost_output_is_valid() {
    let dir = tempfile::tempdir().expect("temp dir");
    for fixture in ["cad_solid", "even_curves"] {
        let input = generate(
            fixture,
            Variant::Msh41Binary,
            dir.path(),
            test_size(fixture),
            &[],
        );
        let output = dir.path().join(format!("{fixture}-cross.msh"));
        recombine_and_check(
            &input,
            &output,
            Variant::Msh41Binary,
            &["--cross-field", "0.3"],
        );
    }
}

/// The conformal solve's multigrid (the default) against its diagonal
/// (`--no-conformal-multigrid`) on a one-surface rectangle large enough for the multigrid:
/// both outputs pass the checks, they differ, the multigrid's mean η is at least the
/// diagonal's, and the last of `--conformal-multigrid` and `--no-conformal-multigrid` wins.
#[test]
fn the_conformal_multigrid_is_the_default_and_can_be_turned_off() {
    let dir = tempfile::tempdir().expect("temp dir");
    let variant = Variant::Msh41Binary;
    let input = generate("rectangle", variant, dir.path(), 0.35, &[]);
    let run = |name: &str, extra: &[&str]| {
        let output = dir.path().join(format!("{name}.msh"));
        let (code, stderr) = recombine(&input, &output, extra);
        assert_eq!(code, Some(0), "{name}: {stderr}");
        output
    };
    let eta_mean = |output: &Path| common::quality_total(output, "eta_mean");
    let multigrid = run("multigrid", &[]);
    let diagonal = run("diagonal", &["--no-conformal-multigrid"]);
    for output in [&multigrid, &diagonal] {
        assert_variant(output, variant);
        let report = check_mesh(&input, output, &[]);
        assert!(report.ok, "{}: {}", output.display(), report.report);
    }
    let read = |p: &Path| std::fs::read(p).expect("output");
    assert_ne!(read(&multigrid), read(&diagonal));
    let (m, d) = (eta_mean(&multigrid), eta_mean(&diagonal));
    assert!(
        m >= d,
        "mean eta {m} with the multigrid, {d} with the diagonal"
    );
    let on = run("on", &["--no-conformal-multigrid", "--conformal-multigrid"]);
    let off = run(
        "off",
        &["--conformal-multigrid", "--no-conformal-multigrid"],
    );
    assert_eq!(read(&on), read(&multigrid));
    assert_eq!(read(&off), read(&diagonal));
}
