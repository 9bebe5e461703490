//! Every fixture in `geo/`, meshed by Gmsh (coarse; Gmsh is required, see `gmsh_gate`) in
//! the four MSH variants (4.1 and 2.2, ASCII and binary): recombination with verification
//! (certificates + invariants), an independent invariant check, and Gmsh loads the output.

use crate::gmsh_gate;

use std::path::{Path, PathBuf};
use std::process::Command;

use blossomquad::mesh::etype;
use blossomquad::msh;
use blossomquad::recombine::{
    check_invariants, recombine, ParityMode, RecombineError, RecombineOptions,
};
use gmsh_gate::require_gmsh;

fn geo_dir() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("geo")
}

/// Runs `gmsh INPUT ARGS -o OUT`; true when it exits 0 and prints no `Error` line (the
/// Gmsh CLI exits 0 even when it cannot load its input).
fn gmsh(args: &[&str], input: &Path, out: &Path) -> bool {
    Command::new("gmsh")
        .arg(input)
        .args(args)
        .arg("-o")
        .arg(out)
        .output()
        .is_ok_and(|o| {
            o.status.success()
                && !String::from_utf8_lossy(&o.stdout).contains("Error")
                && !String::from_utf8_lossy(&o.stderr).contains("Error")
        })
}

/// Physical groups as sorted (dim, tag, name).
fn groups(m: &blossomquad::mesh::Mesh) -> Vec<(i32, i32, String)> {
    let mut g: Vec<_> = m
        .physical_names
        .iter()
        .map(|p| (p.dim, p.tag, p.name.clone()))
        .collect();
    g.sort();
    g
}

fn quads(m: &blossomquad::mesh::Mesh) -> usize {
    m.count_elements(etype::QUAD4)
}

/// (fixture, size parameter giving a coarse mesh)
const FIXTURES: [(&str, &str); 4] = [
    ("rectangle", "2"),
    ("even_curves", "2"),
    ("square_hole", "8"),
    ("cad_solid", "2.5"),
];

const VARIANTS: [(&str, &[&str]); 4] = [
    ("41a", &["-format", "msh41"]),
    ("41b", &["-format", "msh41", "-bin"]),
    ("22a", &["-format", "msh22"]),
    ("22b", &["-format", "msh22", "-bin"]),
];

#[test]
fn every_fixture_in_every_variant() {
    if !require_gmsh() {
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    for (name, size) in FIXTURES {
        let geo = geo_dir().join(format!("{name}.geo"));
        assert!(geo.is_file(), "{} missing", geo.display());
        for (tag, fmt) in VARIANTS {
            let input = dir.path().join(format!("{name}_{tag}.msh"));
            let mut args = vec!["-2", "-setnumber", "size", size];
            args.extend_from_slice(fmt);
            assert!(gmsh(&args, &geo, &input), "{name} {tag}: gmsh failed");
            let before = msh::read_file(&input).unwrap_or_else(|e| panic!("{name} {tag}: {e}"));
            let mut m = before.clone();
            let r = recombine(
                &mut m,
                &RecombineOptions {
                    verify: true,
                    ..Default::default()
                },
            )
            .unwrap_or_else(|e| panic!("{name} {tag}: {e}"));
            check_invariants(&before, &m).unwrap_or_else(|e| panic!("{name} {tag}: {e}"));
            let tris: usize = m.count_elements(etype::TRI3);
            assert_eq!(tris, 0, "{name} {tag}");
            let out = dir.path().join(format!("{name}_{tag}_quad.msh"));
            msh::write_file(&m, &out, msh::default_output_format(&m)).unwrap();
            let reload = dir.path().join(format!("{name}_{tag}_reload.msh"));
            assert!(
                gmsh(&["-0"], &out, &reload),
                "{name} {tag}: gmsh rejects the output"
            );
            let back = msh::read_file(&reload).unwrap_or_else(|e| panic!("{name} {tag}: {e}"));
            assert_eq!(quads(&back), quads(&m), "{name} {tag}: quads after Gmsh");
            assert_eq!(
                groups(&back),
                groups(&m),
                "{name} {tag}: physical groups after Gmsh"
            );
            eprintln!(
                "{name} {tag}: {} surfaces, {} triangles -> {} quads, {} parity splits, {} extra edges used",
                r.surfaces.len(),
                r.surfaces.iter().map(|s| s.triangles_in).sum::<usize>(),
                r.surfaces.iter().map(|s| s.quads_out).sum::<usize>(),
                r.parity_splits.len(),
                r.surfaces.iter().map(|s| s.extra_edges_used).sum::<usize>()
            );
            if name == "rectangle" {
                assert!(r.parity_splits.is_empty(), "odd curves: no repair needed");
            }
            if name == "even_curves" {
                assert!(!r.parity_splits.is_empty(), "even curves: repair needed");
            }
        }
    }
}

#[test]
fn even_curves_fixture_refused_in_parity_error_mode() {
    if !require_gmsh() {
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let input = dir.path().join("even.msh");
    assert!(gmsh(
        &["-2", "-setnumber", "size", "2"],
        &geo_dir().join("even_curves.geo"),
        &input
    ));
    let mut m = msh::read_file(&input).unwrap();
    let e = recombine(
        &mut m,
        &RecombineOptions {
            parity: ParityMode::Error,
            ..Default::default()
        },
    )
    .unwrap_err();
    let RecombineError::OddParity {
        regions,
        curves,
        message,
    } = e
    else {
        panic!("expected OddParity");
    };
    assert!(!regions.is_empty() && !curves.is_empty());
    assert!(message.contains("Transfinite Curve"), "{message}");
}
