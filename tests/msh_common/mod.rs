//! Code shared by the `msh_*` integration tests: corpus location, canonical mesh views
//! for comparisons, and Gmsh invocation.
#![allow(dead_code)]

use std::collections::{BTreeMap, BTreeSet};
use std::path::PathBuf;
use std::process::Command;

use blossomquad::mesh::{Mesh, MshFormat, MshVersion};

#[path = "../corpus_gate/mod.rs"]
mod corpus_gate;
/// The real-MSH corpus, `None` (one printed line per test binary) when absent: see
/// `tests/corpus_gate`.
#[allow(unused_imports)] // not every test binary uses it
pub use corpus_gate::corpus_dir;

/// Every readable corpus file (core + extras), sorted.
/// Empty when the corpus is absent (see [`corpus_dir`]).
pub fn corpus_files() -> Vec<PathBuf> {
    let Some(dir) = corpus_dir() else {
        return Vec::new();
    };
    let mut v = Vec::new();
    for d in [dir.clone(), dir.join("extras")] {
        if let Ok(rd) = std::fs::read_dir(&d) {
            for e in rd.flatten() {
                let p = e.path();
                if p.extension().is_some_and(|x| x == "msh") {
                    v.push(p);
                }
            }
        }
    }
    v.sort();
    assert!(
        v.len() >= 21,
        "corpus not found or incomplete at {} ({} files)",
        dir.display(),
        v.len()
    );
    v
}

/// The four written variants.
pub fn variants() -> [(MshFormat, &'static str); 4] {
    [
        (
            MshFormat {
                version: MshVersion::V41,
                binary: false,
            },
            "41a",
        ),
        (
            MshFormat {
                version: MshVersion::V41,
                binary: true,
            },
            "41b",
        ),
        (
            MshFormat {
                version: MshVersion::V2 { minor: 2 },
                binary: false,
            },
            "22a",
        ),
        (
            MshFormat {
                version: MshVersion::V2 { minor: 2 },
                binary: true,
            },
            "22b",
        ),
    ]
}

/// Node tag → coordinate bits.
pub fn nodes(m: &Mesh) -> BTreeMap<u64, [u64; 3]> {
    let mut out = BTreeMap::new();
    for b in &m.node_blocks {
        for (t, c) in b.tags.iter().zip(&b.coords) {
            out.insert(*t, c.map(f64::to_bits));
        }
    }
    out
}

/// Physical tags of entity (`dim`, `tag`), sorted (empty when the entity is unknown).
pub fn sorted_phys(m: &Mesh, dim: i32, tag: i32) -> Vec<i32> {
    let mut phys = m
        .entity(dim, tag)
        .map(|e| e.physical_tags.clone())
        .unwrap_or_default();
    phys.sort_unstable();
    phys
}

/// Element tag → (type, nodes, physical tags of its entity (sorted), entity dim).
pub type ElementView = BTreeMap<u64, (u32, Vec<u64>, Vec<i32>, i32)>;

/// Elements with their physical groups (what both formats can express).
pub fn elements(m: &Mesh) -> ElementView {
    let mut out = BTreeMap::new();
    for b in &m.element_blocks {
        let phys = sorted_phys(m, b.entity_dim, b.entity_tag);
        let k = b.nodes_per_element();
        for (i, t) in b.tags.iter().enumerate() {
            out.insert(
                *t,
                (
                    b.element_type,
                    b.nodes[i * k..(i + 1) * k].to_vec(),
                    phys.clone(),
                    b.entity_dim,
                ),
            );
        }
    }
    out
}

/// Elements keyed by tag with their entity (dim, tag): for same-format round trips.
pub fn element_entities(m: &Mesh) -> BTreeMap<u64, (i32, i32)> {
    let mut out = BTreeMap::new();
    for b in &m.element_blocks {
        for t in &b.tags {
            out.insert(*t, (b.entity_dim, b.entity_tag));
        }
    }
    out
}

/// Entities that hold elements, with sorted physical tags.
pub fn entities_with_elements(m: &Mesh) -> BTreeSet<(i32, i32, Vec<i32>)> {
    let mut out = BTreeSet::new();
    for b in &m.element_blocks {
        let phys = sorted_phys(m, b.entity_dim, b.entity_tag);
        out.insert((b.entity_dim, b.entity_tag, phys));
    }
    out
}

/// Physical names as a set.
pub fn names(m: &Mesh) -> BTreeSet<(i32, i32, String)> {
    m.physical_names
        .iter()
        .map(|p| (p.dim, p.tag, p.name.clone()))
        .collect()
}

/// Physical groups (dim, tag) that hold at least one element.
pub fn groups_with_elements(m: &Mesh) -> BTreeSet<(i32, i32)> {
    entities_with_elements(m)
        .into_iter()
        .flat_map(|(d, _, p)| p.into_iter().map(move |t| (d, t)))
        .collect()
}

/// Runs gmsh with `args`; panics with its output on failure or on an `Error` line.
pub fn gmsh(args: &[&str]) -> String {
    let out = Command::new("gmsh").args(args).output().expect("gmsh runs");
    let text = format!(
        "{}{}",
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(out.status.success(), "gmsh {args:?} failed:\n{text}");
    assert!(
        !text.contains("Error"),
        "gmsh {args:?} reported an error:\n{text}"
    );
    text
}

/// A fresh temporary directory.
pub fn tempdir() -> tempfile::TempDir {
    tempfile::tempdir().expect("temp dir")
}
