//! Second-order meshes (issue 12): 6-node triangles made by `gmsh -2 -order 2` in MSH 4.1
//! and 2.2, ASCII and binary, recombined by the CLI into 9-node quads (8-node with
//! `--incomplete`) and 3-node lines, checked by `tests/check_second_order.py` with Gmsh's
//! own reader and its `minSJ` quality (no triangle left, only second-order quads and
//! lines, `minSJ` > 0 everywhere, curve nodes and kept mid-edge nodes unmoved, new curve
//! nodes on the input's 3-node lines, new tags above the input's, physical groups kept;
//! on the sphere, new and moved nodes on the input's quadratic surface). Needs Gmsh.

use crate::common;
use crate::gmsh_gate;

use std::path::{Path, PathBuf};
use std::process::Command;

use common::{blossomquad_run, gmsh_exe, json_number, repo_dir, run, Variant};

/// Meshes `geo` with `gmsh -2 -order 2` in `variant` at `size`, plus `-setnumber` pairs.
fn mesh_order2(
    geo: &Path,
    dir: &Path,
    variant: Variant,
    size: f64,
    numbers: &[(&str, f64)],
) -> PathBuf {
    let stem = geo
        .file_stem()
        .unwrap_or_default()
        .to_string_lossy()
        .into_owned();
    let out = dir.join(format!("{stem}-{}.msh", variant.name()));
    let mut cmd = Command::new(gmsh_exe());
    cmd.arg("-2")
        .args(["-order", "2"])
        .arg(geo)
        .args(variant.gmsh_args());
    cmd.args(["-setnumber", "size", &size.to_string()]);
    for (name, value) in numbers {
        cmd.args(["-setnumber", name, &value.to_string()]);
    }
    cmd.arg("-o").arg(&out);
    let o = run(&mut cmd);
    let log = String::from_utf8_lossy(&o.stdout).into_owned() + &String::from_utf8_lossy(&o.stderr);
    assert!(
        o.status.success() && !log.contains("Error") && out.is_file(),
        "gmsh failed on {}:\n{log}",
        geo.display()
    );
    out
}

/// Runs the CLI on `input` (with `extra` flags) and the second-order checker on the
/// result; returns the checker's JSON line and the CLI's stderr.
fn recombine_and_check(input: &Path, extra: &[&str], check_flags: &[&str]) -> (String, String) {
    let output = input.with_extension("quads.msh");
    let mut args: Vec<&std::ffi::OsStr> =
        vec![input.as_os_str(), "-o".as_ref(), output.as_os_str()];
    args.extend(extra.iter().map(|s| std::ffi::OsStr::new(*s)));
    let (code, _, err) = blossomquad_run(args);
    assert_eq!(code, Some(0), "{}: {err}", input.display());
    let script = repo_dir().join("tests/check_second_order.py");
    let o = run(Command::new(common::python_exe())
        .arg(script)
        .arg(input)
        .arg(&output)
        .args(check_flags));
    let report =
        String::from_utf8_lossy(&o.stdout).into_owned() + &String::from_utf8_lossy(&o.stderr);
    assert!(
        o.status.success(),
        "{}: checker failed: {report}",
        input.display()
    );
    (report, err)
}

fn number(report: &str, key: &str) -> f64 {
    json_number(report, key).unwrap_or_else(|| panic!("no {key} in {report}"))
}

#[test]
fn sphere_in_every_variant_gives_valid_quad9_on_the_curved_surface() {
    if !gmsh_gate::require_gmsh() {
        return;
    }
    let dir = tempfile::tempdir().expect("temp dir");
    let geo = repo_dir().join("tests/common/sphere_order2.geo");
    for variant in Variant::ALL {
        let input = mesh_order2(&geo, dir.path(), variant, 0.3, &[]);
        let (report, log) = recombine_and_check(&input, &[], &["--sphere", "1"]);
        assert!(
            number(&report, "quads") > 100.0,
            "{}: {report}",
            variant.name()
        );
        // new and moved nodes are on the quadratic sphere (the checker bounds them by the
        // input's own interpolation error); flat placement would be >10x further off
        let new = number(&report, "sphere_new_error");
        let flat = number(&report, "sphere_flat_error");
        assert!(
            new < 0.1 * flat,
            "{}: |r - R| {new} vs flat {flat}",
            variant.name()
        );
        assert!(number(&report, "kept_mid_nodes") > 0.0, "{report}");
        assert!(
            log.contains("second order: "),
            "no second-order log line: {log}"
        );
    }
}

#[test]
fn plate_with_hole_complete_and_incomplete_with_parity_split() {
    if !gmsh_gate::require_gmsh() {
        return;
    }
    let dir = tempfile::tempdir().expect("temp dir");
    let geo = repo_dir().join("tests/common/plate_hole_order2.geo");
    for (variant, flags) in [
        (Variant::Msh41Ascii, vec![]),
        (Variant::Msh22Binary, vec!["--incomplete"]),
        (
            Variant::Msh41Binary,
            vec!["--incomplete", "--format", "msh22"],
        ),
    ] {
        let input = mesh_order2(&geo, dir.path(), variant, 0.35, &[]);
        let check: &[&str] = if flags.contains(&"--incomplete") {
            &["--incomplete"]
        } else {
            &[]
        };
        let (report, log) = recombine_and_check(&input, &flags, check);
        // the surfaces have an odd number of triangles: a curve was split, its new node
        // and the new mid-edge nodes on the split line lie on the input's 3-node line
        assert!(log.contains("parity repair"), "{}: {log}", variant.name());
        assert_eq!(number(&report, "curve_distance"), 0.0, "{report}");
        assert!(number(&report, "lines") > 0.0, "{report}");
    }
}

#[test]
fn msh22_without_line_elements_and_refinement() {
    if !gmsh_gate::require_gmsh() {
        return;
    }
    let dir = tempfile::tempdir().expect("temp dir");
    let geo = repo_dir().join("tests/common/plate_hole_order2.geo");
    let input = mesh_order2(
        &geo,
        dir.path(),
        Variant::Msh22Ascii,
        0.35,
        &[("lines", 0.0)],
    );
    let (report, _) = recombine_and_check(&input, &[], &[]);
    assert_eq!(number(&report, "lines"), 0.0, "{report}");
    // refinement splits every curve segment: the new curve nodes follow the 3-node lines
    let cad = repo_dir().join("geo/cad_solid.geo");
    let input = mesh_order2(&cad, dir.path(), Variant::Msh41Binary, 3.0, &[]);
    let (report, log) = recombine_and_check(&input, &["--refine", "1"], &[]);
    assert!(log.contains("refinement 1"), "{log}");
    assert!(number(&report, "curve_distance") <= 1e-9, "{report}");
}

#[test]
fn third_order_input_is_refused_in_plain_words() {
    if !gmsh_gate::require_gmsh() {
        return;
    }
    let dir = tempfile::tempdir().expect("temp dir");
    let geo = repo_dir().join("tests/common/sphere_order2.geo");
    let input = dir.path().join("order3.msh");
    let o = run(Command::new(gmsh_exe())
        .arg("-2")
        .args(["-order", "3"])
        .arg(&geo)
        .args(["-setnumber", "size", "0.6", "-o"])
        .arg(&input));
    assert!(o.status.success(), "gmsh -order 3 failed");
    let out = dir.path().join("out.msh");
    let (code, _, err) = blossomquad_run([input.as_os_str(), "-o".as_ref(), out.as_os_str()]);
    assert_eq!(code, Some(1), "{err}");
    assert!(
        err.contains("type 21") && err.contains("6-node triangles"),
        "{err}"
    );
    assert!(!out.exists());
}

#[test]
fn quality_view_loads_in_gmsh_with_one_value_per_quad() {
    if !gmsh_gate::require_gmsh() {
        return;
    }
    let dir = tempfile::tempdir().expect("temp dir");
    let geo = repo_dir().join("tests/common/plate_hole_order2.geo");
    let input = mesh_order2(&geo, dir.path(), Variant::Msh41Binary, 0.5, &[]);
    let output = dir.path().join("quads.msh");
    let (code, _, err) = blossomquad_run([input.as_os_str(), "-o".as_ref(), output.as_os_str()]);
    assert_eq!(code, Some(0), "{err}");
    let view = dir.path().join("view.msh");
    let (code, _, err) = blossomquad_run([
        "quality".as_ref(),
        output.as_os_str(),
        "--view".as_ref(),
        view.as_os_str(),
    ]);
    assert_eq!(code, Some(0), "{err}");
    // Gmsh reads the three views: one value per quad for the element views (eta in
    // (0, 1], scaled Jacobian in (0, 1]), one per corner node for the valence (1..=8)
    let script = r#"
import sys, gmsh
gmsh.initialize(); gmsh.option.setNumber("General.Terminal", 0)
gmsh.logger.start(); gmsh.open(sys.argv[1]); log = gmsh.logger.get()
assert not any("Error" in l for l in log), log
quads = [t for ty, tags in zip(*gmsh.model.mesh.getElements(2)[:2]) for t in tags if ty == 10]
names = {}
for v in gmsh.view.getTags():
    kind, tags, data, _, _ = gmsh.view.getModelData(v, 0)
    names[gmsh.view.option.getString(v, "Name")] = (kind, sorted(int(t) for t in tags), [d[0] for d in data])
for n in ("eta", "scaled jacobian"):
    kind, tags, vals = names[n]
    assert kind == "ElementData" and tags == sorted(int(q) for q in quads), n
    assert all(0 < x <= 1 + 1e-12 for x in vals), (n, min(vals))
kind, tags, vals = names["valence"]
assert kind == "NodeData" and all(1 <= x <= 8 for x in vals) and len(tags) > 0
print("ok", len(quads))
"#;
    let o = run(Command::new(common::python_exe())
        .arg("-c")
        .arg(script)
        .arg(&view));
    let text =
        String::from_utf8_lossy(&o.stdout).into_owned() + &String::from_utf8_lossy(&o.stderr);
    assert!(o.status.success() && text.starts_with("ok"), "{text}");
}
