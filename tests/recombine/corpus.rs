//! Recombination of every core file of the real MSH corpus: each one recombines (or is refused
//! with a clear reason: volume meshes without `drop_volumes`), passes the invariant check and
//! the matching certificates, and survives a write/read round trip.

use crate::corpus_gate;
use crate::gmsh_gate;

use std::path::PathBuf;

use blossomquad::mesh::etype;
use blossomquad::msh;
use blossomquad::recombine::{check_invariants, recombine, RecombineError, RecombineOptions};
use corpus_gate::corpus_dir;

/// Number of `.msh` files at the top level of the corpus (SOURCES.md lists them).
const CORE_FILES: usize = 19;

/// Empty when the corpus is absent.
fn core_files() -> Vec<PathBuf> {
    let Some(dir) = corpus_dir() else {
        return Vec::new();
    };
    let mut files: Vec<PathBuf> = std::fs::read_dir(&dir)
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e == "msh"))
        .collect();
    files.sort();
    assert_eq!(
        files.len(),
        CORE_FILES,
        "corpus at {} incomplete: {files:?}",
        dir.display()
    );
    files
}

/// Gmsh loads the output without errors (Gmsh is required, see `gmsh_gate`).
fn gmsh_loads(path: &std::path::Path, name: &str) {
    if !gmsh_gate::require_gmsh() {
        return;
    }
    let out = path.with_extension("gmsh.msh");
    let run = std::process::Command::new("gmsh")
        .arg(path)
        .args(["-0", "-o"])
        .arg(&out)
        .output()
        .unwrap_or_else(|e| panic!("{name}: cannot run gmsh: {e}"));
    let text =
        String::from_utf8_lossy(&run.stdout).to_string() + &String::from_utf8_lossy(&run.stderr);
    assert!(
        run.status.success() && !text.contains("Error"),
        "{name}: gmsh could not load the output:\n{text}"
    );
}

fn has_volumes(m: &blossomquad::mesh::Mesh) -> bool {
    m.element_blocks
        .iter()
        .any(|b| blossomquad::mesh::element_dim(b.element_type) == Some(3))
}

#[test]
fn every_core_file_recombines_and_keeps_its_invariants() {
    let files = core_files();
    let verify = RecombineOptions {
        verify: true,
        ..Default::default()
    };
    let mut done = 0;
    for f in &files {
        let name = f.file_name().unwrap().to_string_lossy().to_string();
        let before = msh::read_file(f).unwrap_or_else(|e| panic!("{name}: {e}"));
        let mut m = before.clone();
        let opts = if has_volumes(&before) {
            match recombine(&mut m, &verify) {
                Err(RecombineError::VolumeElements { count, .. }) => assert!(count > 0),
                other => panic!("{name}: volumes must be refused, got {other:?}"),
            }
            m = before.clone();
            RecombineOptions {
                drop_volumes: true,
                ..verify.clone()
            }
        } else {
            verify.clone()
        };
        let r = recombine(&mut m, &opts).unwrap_or_else(|e| panic!("{name}: {e}"));
        let tris_before: usize = before
            .element_blocks
            .iter()
            .map(|b| match b.element_type {
                etype::TRI3 => b.len(),
                etype::QUAD4 if r.retriangulated.contains(&b.entity_tag) => 2 * b.len(),
                _ => 0,
            })
            .sum();
        let tris_in: usize = r.surfaces.iter().map(|s| s.triangles_in).sum();
        assert_eq!(
            tris_in,
            tris_before
                + r.parity_splits
                    .iter()
                    .map(|s| s.surfaces.len())
                    .sum::<usize>(),
            "{name}"
        );
        let mut reference = before.clone();
        if opts.drop_volumes {
            reference
                .element_blocks
                .retain(|b| blossomquad::mesh::element_dim(b.element_type) != Some(3));
        }
        check_invariants(&reference, &m).unwrap_or_else(|e| panic!("{name}: {e}"));
        // round trip through the writer in the input's format
        let fmt = msh::default_output_format(&m);
        let dir = tempfile::tempdir().unwrap();
        let out = dir.path().join("out.msh");
        msh::write_file(&m, &out, fmt).unwrap_or_else(|e| panic!("{name}: {e}"));
        let back = msh::read_file(&out).unwrap_or_else(|e| panic!("{name}: {e}"));
        let quads = |m: &blossomquad::mesh::Mesh| -> usize { m.count_elements(etype::QUAD4) };
        assert_eq!(quads(&back), quads(&m), "{name}");
        gmsh_loads(&out, &name);
        eprintln!(
            "{name}: {} surfaces, {} triangles -> {} quads, {} parity splits, {} extra edges used",
            r.surfaces.len(),
            tris_in,
            r.surfaces.iter().map(|s| s.quads_out).sum::<usize>(),
            r.parity_splits.len(),
            r.surfaces.iter().map(|s| s.extra_edges_used).sum::<usize>()
        );
        done += 1;
    }
    assert_eq!(done, files.len());
}
