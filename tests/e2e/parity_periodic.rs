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
        assert_periodic(&out, 2.0);
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
        let msh = periodic_model(dir.path(), kind, s);
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
    let msh = periodic_model(dir.path(), "rve", 0.3);
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
/// has a flat corner; without the topological operators, which would merge the centre
/// node away, the fallback splits them): the splits on a master face are mirrored on its
/// slave and their new nodes paired in `$Periodic`, so the output stays periodic instead
/// of being refused ("node ... has no periodic counterpart").
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
        let [map_flag, map] = tag_map_args(&out);
        let (code, stdout, stderr) = blossomquad_run([
            msh.as_os_str(),
            "-o".as_ref(),
            out.as_os_str(),
            "--no-topology".as_ref(),
            &map_flag,
            &map,
        ]);
        let said = stdout + &stderr;
        assert_eq!(code, Some(0), "{said}");
        assert!(
            said.contains("the fallback split"),
            "the fallback ran: {said}"
        );
        let r = check_mesh(&msh, &out, &[]);
        assert!(r.ok, "{}", r.report);
        assert_periodic(&out, 2.0);
    }
}

/// Periodic masters are optimized like every other surface, and each slave is then made
/// the image of its optimized master: on the RVE cube (3 periodic face pairs) every
/// periodic surface ends with a higher mean η than the matching's quads alone
/// (`--no-optimize`), and the output stays valid and periodic.
#[test]
fn periodic_masters_are_optimized_and_their_slaves_follow() {
    let dir = tempfile::tempdir().expect("temp dir");
    let msh = periodic_model(dir.path(), "rve", 0.17);
    let input = blossomquad::msh::read_file(&msh).expect("the model reads");
    let mut periodic: Vec<i32> = input
        .periodic
        .iter()
        .filter(|p| p.dim == 2 && p.tag != p.master_tag)
        .flat_map(|p| [p.tag, p.master_tag])
        .collect();
    periodic.sort_unstable();
    periodic.dedup();
    assert_eq!(periodic.len(), 6, "three periodic face pairs: {periodic:?}");
    let optimized = dir.path().join("rve-optimized.msh");
    let (code, stderr) = recombine(&msh, &optimized, &[]);
    assert_eq!(code, Some(0), "{stderr}");
    let r = check_mesh(&msh, &optimized, &[]);
    assert!(r.ok, "{}", r.report);
    assert_periodic(&optimized, 3.0);
    let plain = dir.path().join("rve-plain.msh");
    let (code, stderr) = recombine(&msh, &plain, &["--no-optimize"]);
    assert_eq!(code, Some(0), "{stderr}");
    let (optimized, plain) = (surface_means(&optimized), surface_means(&plain));
    for s in periodic {
        assert!(
            optimized[&s] > plain[&s] + 0.02,
            "surface {s}: mean eta {} optimized, {} as matched",
            optimized[&s],
            plain[&s]
        );
    }
}

/// The corpus's RVE (`corpus/periodic_rve.py` at its coarse size) with `--keep-tags`: where
/// the optimizer removes a master node (a surface put back as an earlier fallback job left
/// it included), its slave node leaves the link too, so no `$Periodic` pair names a node
/// the output does not have (the renumbering drops such pairs; with the tags kept,
/// nothing else would).
#[test]
fn no_periodic_pair_names_a_node_the_optimizer_removed() {
    let dir = tempfile::tempdir().expect("temp dir");
    let msh = dir.path().join("rve.msh");
    let o = run(Command::new(python_exe())
        .arg(repo_dir().join("corpus/periodic_rve.py"))
        .arg("0.25")
        .arg(&msh));
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let out = dir.path().join("rve-kept.msh");
    let (code, stderr) = recombine(&msh, &out, &["--keep-tags"]);
    assert_eq!(code, Some(0), "{stderr}");
    let r = check_mesh(&msh, &out, &[]);
    assert!(r.ok, "{}", r.report);
    assert_periodic(&out, 3.0);
}

/// `tests/parity_models/periodic.py`'s model `kind` (`rve` or `square`) meshed at `size`
/// in `dir`.
fn periodic_model(dir: &Path, kind: &str, size: f64) -> PathBuf {
    let msh = dir.join(format!("{kind}-{size}.msh"));
    let o = run(Command::new(python_exe())
        .arg(models().join("periodic.py"))
        .arg(kind)
        .arg(size.to_string())
        .arg(&msh));
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    msh
}

/// The mean η of each surface's quads in the mesh at `path`.
fn surface_means(path: &Path) -> std::collections::HashMap<i32, f64> {
    let mesh = blossomquad::msh::read_file(path).expect("the output reads");
    let surface: std::collections::HashMap<u64, i32> = mesh
        .element_blocks
        .iter()
        .filter(|b| b.entity_dim == 2)
        .flat_map(|b| b.tags.iter().map(move |&t| (t, b.entity_tag)))
        .collect();
    let mut sums: std::collections::HashMap<i32, (f64, usize)> = Default::default();
    for (tag, eta) in blossomquad::quality::quad_etas(&mesh) {
        let e = sums.entry(surface[&tag]).or_default();
        e.0 += eta;
        e.1 += 1;
    }
    sums.into_iter()
        .map(|(s, (sum, n))| (s, sum / n as f64))
        .collect()
}

/// Asserts that `tests/check_periodic.py` passes on `out` with at least `links` links.
fn assert_periodic(out: &Path, links: f64) {
    let o = run(Command::new(python_exe())
        .arg(repo_dir().join("tests/check_periodic.py"))
        .arg(out));
    let report = String::from_utf8_lossy(&o.stdout);
    assert!(o.status.success(), "{}: {report}", out.display());
    let found = json_number(&report, "links").unwrap_or(0.0);
    assert!(found >= links, "{report}");
}
