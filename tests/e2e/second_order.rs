//! Second-order meshes: 6-node triangles made by `gmsh -2 -order 2` in MSH 4.1
//! and 2.2, ASCII and binary, recombined by the CLI into 9-node quads (8-node with
//! `--incomplete`) and 3-node lines, checked by `tests/check_second_order.py` with Gmsh's
//! own reader and its `minSJ` quality (no triangle left, only second-order quads and
//! lines, `minSJ` > 0 everywhere, curve nodes and kept mid-edge nodes unmoved, new curve
//! nodes on the input's 3-node lines, new tags above the input's, physical groups kept;
//! on the sphere, new and moved nodes on the input's quadratic surface; 9- and 8-node
//! quads of the input kept as they are). Needs Gmsh.

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

/// Runs the CLI on `input` (with `-v`, the `extra` flags, and `--tag-map` unless they have
/// `--keep-tags`) and the second-order checker on the result (with the tag map: it checks
/// the numbering 1..N and compares tags through it); returns the checker's JSON line and
/// the CLI's stderr.
fn recombine_and_check(input: &Path, extra: &[&str], check_flags: &[&str]) -> (String, String) {
    let output = input.with_extension("quads.msh");
    let map = common::tag_map_path(&output);
    let keep = extra.contains(&"--keep-tags");
    let mut args: Vec<std::ffi::OsString> = vec![
        input.into(),
        "-o".into(),
        output.clone().into(),
        "-v".into(),
    ];
    args.extend(extra.iter().map(std::ffi::OsString::from));
    if !keep {
        args.extend(common::tag_map_args(&output));
    }
    let (code, _, err) = blossomquad_run(args);
    assert_eq!(code, Some(0), "{}: {err}", input.display());
    let script = repo_dir().join("tests/check_second_order.py");
    let mut map_flag = std::ffi::OsString::from("--tag-map=");
    map_flag.push(&map);
    let o = run(Command::new(common::python_exe())
        .arg(script)
        .arg(input)
        .arg(&output)
        .args(check_flags)
        .args((!keep).then_some(map_flag)));
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
        // the input's tags as they are: the checker compares them directly
        (Variant::Msh22Ascii, vec!["--keep-tags"]),
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

/// Surface-only physical groups (Gmsh writes no line elements then, in 4.1 as in 2.2): the
/// only record of a curve segment's mid-edge node is the 6-node triangle's. Parity repair
/// splits a boundary segment at its midpoint; the input's mid-edge node of that segment
/// must become the new corner (same tag, same coordinates) instead of a new tag at about
/// the same place. The checker's `boundary_mid_nodes` holds every boundary mid-edge node
/// of the input to that, through the tag map by default and as is with `--keep-tags`.
#[test]
fn a_parity_split_segment_keeps_its_mid_edge_node_as_the_new_corner() {
    if !gmsh_gate::require_gmsh() {
        return;
    }
    let dir = tempfile::tempdir().expect("temp dir");
    let geo = repo_dir().join("tests/common/plate_hole_order2.geo");
    for (variant, extra) in [
        (Variant::Msh41Ascii, &[][..]),
        (Variant::Msh22Binary, &[][..]),
        (Variant::Msh41Ascii, &["--keep-tags"][..]),
    ] {
        let input = mesh_order2(&geo, dir.path(), variant, 0.35, &[("lines", 0.0)]);
        let (report, log) = recombine_and_check(&input, extra, &[]);
        assert!(log.contains("parity repair: split segment"), "{log}");
        assert!(report.contains("\"boundary_mid_nodes\": true"), "{report}");
        assert_eq!(number(&report, "lines"), 0.0, "{report}");
    }
}

#[test]
fn a_thin_wire_keeps_every_mid_edge_node_of_its_curves_without_turning_its_faces_ends() {
    // the linear run turns the ends of a thin wire's quarter faces across their side curves
    // (a node on a side segment near its end); on a second-order input every curve node
    // stays where it is instead
    if !gmsh_gate::require_gmsh() {
        return;
    }
    let dir = tempfile::tempdir().expect("temp dir");
    let geo = repo_dir().join("corpus/thin_wires.geo");
    let input = mesh_order2(&geo, dir.path(), Variant::Msh41Ascii, 0.25, &[]);
    let (report, log) = recombine_and_check(&input, &[], &[]);
    assert!(!log.contains("turned across"), "{log}");
    assert!(report.contains("\"boundary_mid_nodes\": true"), "{report}");
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

/// Runs `tests/check_views.py` on `mesh` (and on `blossomquad quality MESH --json`):
/// the views load in Gmsh with one value per quad, the scaled Jacobian equals Gmsh's
/// `minSIGE` per element and the report's per-surface `sj_min`/`sj_mean` its minimum
/// and mean. Returns the number of quads.
fn check_views(mesh: &Path) -> usize {
    let (code, json, err) =
        blossomquad_run(["quality".as_ref(), mesh.as_os_str(), "--json".as_ref()]);
    assert_eq!(code, Some(0), "{err}");
    let report = mesh.with_extension("quality.json");
    std::fs::write(&report, json).expect("write the report");
    let o = run(Command::new(common::python_exe())
        .arg(repo_dir().join("tests/check_views.py"))
        .arg(mesh)
        .arg(&report));
    let text =
        String::from_utf8_lossy(&o.stdout).into_owned() + &String::from_utf8_lossy(&o.stderr);
    assert!(o.status.success(), "{}: {text}", mesh.display());
    text.trim()
        .strip_prefix("ok ")
        .and_then(|n| n.parse().ok())
        .unwrap_or_else(|| panic!("{text}"))
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
    assert!(check_views(&view) > 20);
}

#[test]
fn quality_view_on_the_main_command_in_every_variant_linear_and_second_order() {
    if !gmsh_gate::require_gmsh() {
        return;
    }
    let dir = tempfile::tempdir().expect("temp dir");
    let geo = repo_dir().join("tests/common/plate_hole_order2.geo");
    // (input variant, order, flags choosing the output's variant): the views are encoded
    // for the variant written, also when it is not the input's
    let cases: [(Variant, u8, &[&str]); 6] = [
        (Variant::Msh41Ascii, 1, &[]),
        (Variant::Msh41Binary, 2, &[]),
        (Variant::Msh22Ascii, 2, &["--incomplete"]),
        (Variant::Msh22Binary, 1, &[]),
        (Variant::Msh41Ascii, 2, &["--binary", "--format", "msh22"]),
        (Variant::Msh22Binary, 1, &["--ascii", "--format", "msh41"]),
    ];
    for (i, (variant, order, flags)) in cases.into_iter().enumerate() {
        let input = if order == 2 {
            mesh_order2(&geo, dir.path(), variant, 0.5, &[])
        } else {
            let p = dir.path().join(format!("linear-{}.msh", variant.name()));
            common::generate_geo(&geo, &p, variant, 0.5, &[]);
            p
        };
        let output = dir.path().join(format!("out-{i}.msh"));
        let mut args: Vec<&std::ffi::OsStr> = vec![
            input.as_os_str(),
            "-o".as_ref(),
            output.as_os_str(),
            "--quality-view".as_ref(),
        ];
        args.extend(flags.iter().map(std::ffi::OsStr::new));
        let (code, _, err) = blossomquad_run(args);
        assert_eq!(code, Some(0), "case {i}: {err}");
        assert!(!err.contains("dropped"), "case {i}: {err}");
        assert!(check_views(&output) > 20, "case {i}");
    }
}

#[test]
fn quads_already_in_the_input_are_kept_beside_recombined_triangles() {
    if !gmsh_gate::require_gmsh() {
        return;
    }
    let dir = tempfile::tempdir().expect("temp dir");
    // a transfinite recombined square (Gmsh writes 9-node quads, 8-node ones with
    // Mesh.SecondOrderIncomplete) beside a triangle face bounded by an arc
    let geo = repo_dir().join("tests/common/mixed_order2.geo");
    for (variant, incomplete_in, flags) in [
        (Variant::Msh41Ascii, 0.0, vec![]),
        (Variant::Msh22Binary, 1.0, vec!["--incomplete"]),
        (Variant::Msh41Binary, 0.0, vec!["--incomplete"]),
        (Variant::Msh22Ascii, 1.0, vec![]),
    ] {
        let input = mesh_order2(
            &geo,
            dir.path(),
            variant,
            0.3,
            &[("Mesh.SecondOrderIncomplete", incomplete_in)],
        );
        let check: &[&str] = if flags.contains(&"--incomplete") {
            &["--incomplete"]
        } else {
            &[]
        };
        let (report, log) = recombine_and_check(&input, &flags, check);
        let name = variant.name();
        // every input quad is in the output with its tag and nodes (the checker's
        // input_quads check), and there are 7 x 7 of them
        assert_eq!(
            number(&report, "input_quad_count"),
            49.0,
            "{name}: {report}"
        );
        assert_eq!(
            number(&report, "input_quads_kept"),
            49.0,
            "{name}: {report}"
        );
        assert!(number(&report, "quads") > 49.0, "{name}: {report}");
        if incomplete_in == 0.0 && flags.is_empty() {
            assert!(log.contains("face nodes: 49 kept"), "{name}: {log}");
        }
    }
}
