//! Parity repair and periodic surfaces on real Gmsh models (`tests/parity_models/`):
//! revolved multi-volume parts (curves shared by three surfaces), revolutions with
//! `Layers`/`Recombine` (odd triangle faces bordered only by quads), an OCC boolean, a STEP
//! import, and periodic models (an RVE cube with 3 periodic face pairs, a square with
//! periodic curves). The revolved models at these sizes were refused before ("cannot make
//! these triangle regions even"). Each run is checked by `tests/check_mesh.py`, and
//! periodic outputs by `tests/check_periodic.py` (Gmsh reloads them with complete periodic
//! links, every slave element the image of a master element).

use crate::common;

use common::*;
use std::path::{Path, PathBuf};
use std::process::Command;

fn models() -> PathBuf {
    repo_dir().join("tests/parity_models")
}

fn check(input: &Path, dir: &Path, periodic: bool) {
    let out = dir.join(format!("{}-quads.msh", file_name(input)));
    let (code, stderr) = recombine(input, &out, &[]);
    assert_eq!(code, Some(0), "{}: {stderr}", file_name(input));
    let r = check_mesh(input, &out, &[]);
    assert!(r.ok, "{}: {}", file_name(input), r.report);
    if periodic {
        let o = run(Command::new(python_exe())
            .arg(repo_dir().join("tests/check_periodic.py"))
            .arg(&out));
        let report = String::from_utf8_lossy(&o.stdout);
        assert!(o.status.success(), "{}: {report}", file_name(input));
        let links = json_number(&report, "links").unwrap_or(0.0);
        assert!(links >= 2.0, "{report}");
    }
}

#[test]
fn previously_refused_revolutions_are_repaired() {
    let dir = tempfile::tempdir().expect("temp dir");
    for (geo, sizes) in [
        ("revolved_3x120", &[0.41, 0.3, 0.19][..]),
        ("revolved_layers", &[0.37, 0.29][..]),
    ] {
        for &s in sizes {
            let msh = dir.path().join(format!("{geo}-{s}.msh"));
            generate_geo(
                &models().join(format!("{geo}.geo")),
                &msh,
                Variant::Msh41Ascii,
                s,
                &[],
            );
            let (code, stderr) =
                recombine(&msh, &dir.path().join("err.msh"), &["--parity", "error"]);
            assert_eq!(code, Some(1), "{geo} at {s} should have odd surfaces");
            assert!(stderr.contains("by one fixes them"), "{stderr}");
            check(&msh, dir.path(), false);
        }
    }
}

#[test]
fn boolean_and_step_import_recombine() {
    let dir = tempfile::tempdir().expect("temp dir");
    for s in [0.37, 0.23] {
        let msh = dir.path().join(format!("bool-{s}.msh"));
        generate_geo(
            &models().join("occ_box_minus_cylinder.geo"),
            &msh,
            Variant::Msh22Ascii,
            s,
            &[],
        );
        check(&msh, dir.path(), false);
        let step = dir.path().join(format!("step-{s}.msh"));
        let o = run(Command::new(python_exe())
            .arg(models().join("step_import.py"))
            .arg(s.to_string())
            .arg(&step));
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        check(&step, dir.path(), false);
    }
}

#[test]
fn periodic_surfaces_and_curves_stay_periodic() {
    let dir = tempfile::tempdir().expect("temp dir");
    for (kind, s) in [
        ("rve", 0.3),
        ("rve", 0.17),
        ("square", 0.17),
        ("square", 0.11),
    ] {
        let msh = dir.path().join(format!("{kind}-{s}.msh"));
        let o = run(Command::new(python_exe())
            .arg(models().join("periodic.py"))
            .arg(kind)
            .arg(s.to_string())
            .arg(&msh));
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        check(&msh, dir.path(), true);
    }
}

/// `--refine 1` and `2` on the RVE cube (3 periodic face pairs): every new node of a slave
/// face is paired with its image on the master, so the refined output is as periodic as
/// the recombined one (`tests/check_periodic.py`: complete links, every slave element the
/// image of a master element), and the checker finds it refined that many times.
#[test]
fn periodic_surfaces_stay_periodic_when_refined() {
    let dir = tempfile::tempdir().expect("temp dir");
    let msh = dir.path().join("rve.msh");
    let o = run(Command::new(python_exe())
        .arg(models().join("periodic.py"))
        .arg("rve")
        .arg("0.3")
        .arg(&msh));
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    for levels in ["1", "2"] {
        let out = dir.path().join(format!("rve-refined-{levels}.msh"));
        let (code, stderr) = recombine(&msh, &out, &["--refine", levels]);
        assert_eq!(code, Some(0), "--refine {levels}: {stderr}");
        let r = check_mesh(&msh, &out, &[&format!("--refined={levels}")]);
        assert!(r.ok, "--refine {levels}: {}", r.report);
        let o = run(Command::new(python_exe())
            .arg(repo_dir().join("tests/check_periodic.py"))
            .arg(&out));
        let report = String::from_utf8_lossy(&o.stdout);
        assert!(o.status.success(), "--refine {levels}: {report}");
        let links = json_number(&report, "links").unwrap_or(0.0);
        assert!(links >= 3.0, "{report}");
    }
}

/// A periodic box meshed far coarser than its faces (`corpus/periodic_surface.geo` at
/// sizes 1.2 and 2: four triangles around a centre node per face, so every pair of them
/// has a flat corner and the fallback splits them): the splits on a master face are
/// mirrored on its slave and their new nodes paired in `$Periodic`, so the output stays
/// periodic instead of being refused ("node ... has no periodic counterpart").
#[test]
fn fallback_splits_on_a_periodic_master_are_mirrored_on_its_slave() {
    let dir = tempfile::tempdir().expect("temp dir");
    for s in [1.2, 2.0] {
        let msh = dir.path().join(format!("box-{s}.msh"));
        generate_geo(
            &repo_dir().join("corpus/periodic_surface.geo"),
            &msh,
            Variant::Msh41Ascii,
            s,
            &[],
        );
        let out = dir.path().join(format!("box-{s}-quads.msh"));
        let (code, stdout, stderr) =
            blossomquad_run([msh.as_os_str(), "-o".as_ref(), out.as_os_str()]);
        let said = stdout + &stderr;
        assert_eq!(code, Some(0), "{said}");
        assert!(
            said.contains("the fallback split"),
            "the fallback ran: {said}"
        );
        check(&msh, dir.path(), true);
    }
}
