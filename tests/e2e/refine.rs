//! `--refine N` (uniform refinement after recombination, paper Figure 2 and Table I) on the
//! fixtures: the independent checker (`tests/check_mesh.py --refined=N`) finds every
//! invariant (boundary segments split into 2^N pieces along the curve, shared curves split
//! the same way on both sides, physical groups kept, Gmsh loads the output), the quad
//! count is 4^N times the recombined one, and the checker refuses a refinement level the
//! mesh does not have. Needs Gmsh.

use crate::common;

use common::{blossomquad_run, check_mesh, generate, recombine, test_size, Variant};

/// Recombines `fixture` without optimization, without and with `--refine levels`, and with
/// refinement and optimization; checks the last output independently and returns the quad
/// counts of the first two.
fn refine_fixture(fixture: &str, variant: Variant, levels: u32) -> (f64, f64, bool) {
    let dir = tempfile::tempdir().expect("temp dir");
    let input = generate(fixture, variant, dir.path(), test_size(fixture), &[]);
    let n = levels.to_string();
    let plain = dir.path().join("plain.msh");
    let (code, _, err) = common::blossomquad_run([
        input.as_os_str(),
        "-o".as_ref(),
        plain.as_os_str(),
        "--no-optimize".as_ref(),
        "--verify".as_ref(),
        "-v".as_ref(),
    ]);
    assert_eq!(code, Some(0), "{fixture}: {err}");
    // a surface whose matching leaves folded quads is optimized all the same (the validity
    // guarantee), which may merge quads: the count is then no longer the matching's
    let forced = err.contains("optimized after all");
    let split = dir.path().join("split.msh");
    let (code, err) = recombine(&input, &split, &["--no-optimize", "--refine", &n]);
    assert_eq!(code, Some(0), "{fixture}: {err}");
    let refined = dir.path().join("refined.msh");
    let (code, err) = recombine(&input, &refined, &["--refine", &n]);
    assert_eq!(code, Some(0), "{fixture} --refine {levels}: {err}");
    let report = check_mesh(&input, &refined, &[&format!("--refined={levels}")]);
    assert!(report.ok, "{fixture} --refine {levels}: {}", report.report);
    // one level more than the mesh has must be refused by the checker
    let wrong = check_mesh(&input, &refined, &[&format!("--refined={}", levels + 1)]);
    assert!(
        !wrong.ok,
        "{fixture}: checker accepted --refined={} on a mesh refined {levels} time(s)",
        levels + 1
    );
    let quads = |p: &std::path::Path| common::quality_total(p, "quads");
    (quads(&plain), quads(&split), forced)
}

#[test]
fn refine_once_on_every_fixture() {
    for fixture in common::FIXTURES {
        let (plain, refined, forced) = refine_fixture(fixture, Variant::Msh41Binary, 1);
        if forced {
            println!("{fixture}: some surface was optimized for validity; quad count not compared");
            continue;
        }
        assert_eq!(
            refined,
            4.0 * plain,
            "{fixture}: quads {plain} -> {refined}"
        );
    }
}

#[test]
fn refine_twice_square_hole_msh22() {
    let (plain, refined, forced) = refine_fixture("square_hole", Variant::Msh22Ascii, 2);
    assert!(!forced, "square_hole needed no forced optimization");
    assert_eq!(refined, 16.0 * plain, "quads {plain} -> {refined}");
}

#[test]
fn refine_level_out_of_range_is_a_usage_error() {
    let (code, _, err) = blossomquad_run(["in.msh", "-o", "out.msh", "--refine", "4"]);
    assert_eq!(code, Some(2), "{err}");
    assert!(err.contains("--refine"), "{err}");
}

/// A random boolean part (`tests/data/cad/v41_boolean_embedded_curve.msh`) with a curve
/// embedded in its surface 28, refined once: the embedded curve's segment from node 100 to
/// node 25 (its line element running to the lower tag) is split like every other, and its
/// pieces are edges of two quads each. The checker follows a split chain from the lower
/// tag, whichever way the line element runs (it read that chain backwards and called the
/// segment lost).
#[test]
fn refine_once_a_surface_with_an_embedded_curve() {
    let input = common::repo_dir().join("tests/data/cad/v41_boolean_embedded_curve.msh");
    let dir = tempfile::tempdir().expect("temp dir");
    let refined = dir.path().join("refined.msh");
    let (code, err) = recombine(&input, &refined, &["--refine", "1"]);
    assert_eq!(code, Some(0), "{err}");
    let report = check_mesh(&input, &refined, &["--refined=1"]);
    assert!(report.ok, "{}", report.report);
}
