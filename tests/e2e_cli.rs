//! `info` and `quality` on the fixtures, and the exit-code contract
//! (0 ok, 1 bad input with one error line naming the file, 2 usage).
//! Needs Gmsh for the generated meshes.

mod common;

use common::{blossomquad, blossomquad_run, generate, geo_dir, json_number, Variant};
use std::path::Path;

fn info(path: &Path) -> String {
    let out = blossomquad().arg("info").arg(path).assert().success();
    String::from_utf8_lossy(&out.get_output().stdout).into_owned()
}

fn quality_json(path: &Path, extra: &[&str]) -> String {
    let out = blossomquad()
        .arg("quality")
        .arg(path)
        .arg("--json")
        .args(extra)
        .assert()
        .success();
    String::from_utf8_lossy(&out.get_output().stdout).into_owned()
}

/// A number of the `"total"` object of `quality --json` (whole-mesh figures;
/// per-surface objects come before it).
fn number(json: &str, key: &str) -> f64 {
    let total = json
        .find("\"total\"")
        .map(|at| &json[at..])
        .unwrap_or_else(|| panic!("no \"total\" in {json}"));
    json_number(total, key).unwrap_or_else(|| panic!("no number {key:?} in {json}"))
}

#[test]
fn info_on_shipped_rectangle() {
    let text = info(&geo_dir().join("rectangle.msh"));
    for word in ["1792", "domain", "bottom", "left"] {
        assert!(text.contains(word), "info lacks {word:?}:\n{text}");
    }
    assert!(
        !text.to_lowercase().contains("odd"),
        "rectangle is even:\n{text}"
    );
}

#[test]
fn info_reports_odd_surfaces_in_every_variant() {
    let dir = tempfile::tempdir().expect("temp dir");
    for variant in Variant::ALL {
        let msh = generate("even_curves", variant, dir.path(), 1.0, &[]);
        let text = info(&msh);
        for word in ["square", "triangle", "pentagon", "940", "333", "1269"] {
            assert!(
                text.contains(word),
                "{}: info lacks {word:?}:\n{text}",
                variant.name()
            );
        }
        assert!(
            text.to_lowercase().contains("odd"),
            "{}:\n{text}",
            variant.name()
        );
    }
}

#[test]
fn quality_of_triangle_input_and_of_our_quads() {
    let dir = tempfile::tempdir().expect("temp dir");
    let input = geo_dir().join("rectangle.msh");
    let tri = quality_json(&input, &[]);
    assert_eq!(number(&tri, "quads"), 0.0, "{tri}");
    assert_eq!(number(&tri, "triangles"), 1792.0, "{tri}");

    let output = dir.path().join("quads.msh");
    blossomquad()
        .arg(&input)
        .args(["-o"])
        .arg(&output)
        .arg("--quiet")
        .assert()
        .success();
    for extra in [&[][..], &["--size", "0.1 + 0.08*sin(3*x)*cos(6*y)"][..]] {
        let q = quality_json(&output, extra);
        let quads = number(&q, "quads");
        assert!(quads > 0.0 && quads <= 1792.0 / 2.0 + 64.0, "{q}");
        assert_eq!(number(&q, "triangles"), 0.0, "{q}");
        let (w, mean) = (number(&q, "eta_worst"), number(&q, "eta_mean"));
        assert!(0.0 < w && w <= mean && mean <= 1.0, "{q}");
        let tau = number(&q, "tau_percent");
        assert!(0.0 < tau && tau <= 100.0, "{q}");
        let d4 = number(&q, "d4_percent");
        assert!((0.0..=100.0).contains(&d4), "{q}");
        let (dmin, dmax) = (number(&q, "d_min"), number(&q, "d_max"));
        assert!((1.0..=4.0).contains(&dmin) && 4.0 <= dmax, "{q}");
    }
}

#[test]
fn quality_of_gmsh_own_quads() {
    let dir = tempfile::tempdir().expect("temp dir");
    let msh = generate(
        "rectangle",
        Variant::Msh41Binary,
        dir.path(),
        1.0,
        &[("Mesh.RecombineAll", 1.0)],
    );
    let q = quality_json(&msh, &[]);
    assert!(number(&q, "quads") > 800.0, "{q}");
    assert!(number(&q, "eta_mean") > 0.5, "{q}");
    let text = blossomquad().arg("quality").arg(&msh).assert().success();
    assert!(!text.get_output().stdout.is_empty());
}

#[test]
fn missing_input_is_exit_1_naming_the_file() {
    let dir = tempfile::tempdir().expect("temp dir");
    let missing = dir.path().join("does-not-exist.msh");
    let out = dir.path().join("out.msh");
    for args in [
        vec![missing.as_os_str(), "-o".as_ref(), out.as_os_str()],
        vec!["info".as_ref(), missing.as_os_str()],
        vec!["quality".as_ref(), missing.as_os_str()],
    ] {
        let (code, _, stderr) = blossomquad_run(args);
        assert_eq!(code, Some(1), "{stderr}");
        assert!(stderr.contains("does-not-exist.msh"), "{stderr}");
        assert_eq!(stderr.trim().lines().count(), 1, "{stderr}");
    }
    assert!(!out.exists());
}

#[test]
fn geo_file_given_by_mistake_is_exit_1() {
    let dir = tempfile::tempdir().expect("temp dir");
    let out = dir.path().join("out.msh");
    let geo = geo_dir().join("rectangle.geo");
    let (code, _, stderr) = blossomquad_run([geo.as_os_str(), "-o".as_ref(), out.as_os_str()]);
    assert_eq!(code, Some(1), "{stderr}");
    assert!(stderr.contains("rectangle.geo"), "{stderr}");
    assert!(!out.exists());
}

#[test]
fn usage_errors_are_exit_2() {
    let shipped = geo_dir().join("rectangle.msh");
    for args in [
        vec!["--no-such-flag".as_ref(), shipped.as_os_str()],
        vec![
            shipped.as_os_str(),
            "-o".as_ref(),
            "x.msh".as_ref(),
            "--format".as_ref(),
            "msh99".as_ref(),
        ],
        vec![
            shipped.as_os_str(),
            "-o".as_ref(),
            "x.msh".as_ref(),
            "--parity".as_ref(),
            "maybe".as_ref(),
        ],
        vec![
            shipped.as_os_str(),
            "-o".as_ref(),
            "x.msh".as_ref(),
            "--cross-field".as_ref(),
            "7".as_ref(),
        ],
        vec![
            shipped.as_os_str(),
            "-o".as_ref(),
            "x.msh".as_ref(),
            "--cross-field".as_ref(),
            "NaN".as_ref(),
        ],
        vec!["quality".as_ref()],
    ] {
        let (code, _, stderr) = blossomquad_run(args);
        assert_eq!(code, Some(2), "{stderr}");
    }
    assert!(!Path::new("x.msh").exists());
}
