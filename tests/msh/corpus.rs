//! Every real-world corpus file reads, writes in all four variants, and reads back equal.

use crate::msh_common;

use blossomquad::mesh::{Mesh, MshVersion};
use blossomquad::msh;
use msh_common::*;

fn write_bytes(m: &Mesh, f: blossomquad::mesh::MshFormat) -> Vec<u8> {
    let mut v = Vec::new();
    msh::write(m, &mut v, f).expect("write");
    v
}

/// Checks what every variant must keep; returns the re-read mesh.
fn check_round_trip(name: &str, m: &Mesh, f: blossomquad::mesh::MshFormat, label: &str) -> Mesh {
    let bytes = write_bytes(m, f);
    let back = msh::read_bytes(&bytes, &format!("{name}.{label}"))
        .unwrap_or_else(|e| panic!("{name} -> {label}: re-read failed: {e}"));
    assert_eq!(back.format, Some(f), "{name} -> {label}: format");
    assert_eq!(
        nodes(m),
        nodes(&back),
        "{name} -> {label}: nodes (bit-exact coordinates)"
    );
    assert_eq!(
        elements(m),
        elements(&back),
        "{name} -> {label}: elements / physical groups"
    );
    assert_eq!(names(m), names(&back), "{name} -> {label}: physical names");
    assert_eq!(
        entities_with_elements(m),
        entities_with_elements(&back),
        "{name} -> {label}: entities holding elements"
    );
    let same_family = matches!(f.version, MshVersion::V2 { .. })
        == matches!(m.format.map(|x| x.version), Some(MshVersion::V2 { .. }));
    if f.version == MshVersion::V41 || same_family {
        assert_eq!(m.entities, back.entities, "{name} -> {label}: all entities");
        assert_eq!(
            element_entities(m),
            element_entities(&back),
            "{name} -> {label}"
        );
        assert_eq!(
            m.periodic, back.periodic,
            "{name} -> {label}: periodic links"
        );
    }
    if f.version == MshVersion::V41 {
        assert_eq!(
            m.node_blocks, back.node_blocks,
            "{name} -> {label}: node blocks"
        );
    }
    // Writing what we read reproduces the same bytes (a fixed point), except 4.x -> 2.2
    // where node classification is re-derived (node order may change once).
    if f.version == MshVersion::V41 || same_family {
        assert!(
            bytes == write_bytes(&back, f),
            "{name} -> {label}: second write differs"
        );
    }
    back
}

#[test]
fn corpus_files_read_write_all_variants_and_read_back_equal() {
    for path in corpus_files() {
        let name = path.file_name().unwrap().to_string_lossy().into_owned();
        let m = msh::read_file(&path).unwrap_or_else(|e| panic!("{e}"));
        assert!(m.node_count() > 0 && m.element_count() > 0, "{name}: empty");
        for (f, label) in variants() {
            check_round_trip(&name, &m, f, label);
        }
    }
}

#[test]
fn corpus_v41_to_v22_to_v41_keeps_what_v22_expresses() {
    for path in corpus_files() {
        let name = path.file_name().unwrap().to_string_lossy().into_owned();
        let m = msh::read_file(&path).unwrap();
        if m.format.map(|f| f.version) != Some(MshVersion::V41) {
            continue;
        }
        let [a41, _, a22, b22] = variants();
        for f22 in [a22.0, b22.0] {
            let m22 = msh::read_bytes(&write_bytes(&m, f22), "x.msh").unwrap();
            let m41 = msh::read_bytes(&write_bytes(&m22, a41.0), "y.msh").unwrap();
            assert_eq!(nodes(&m), nodes(&m41), "{name}");
            assert_eq!(elements(&m), elements(&m41), "{name}");
            assert_eq!(names(&m), names(&m41), "{name}");
            assert_eq!(
                groups_with_elements(&m),
                groups_with_elements(&m41),
                "{name}"
            );
            assert_eq!(element_entities(&m), element_entities(&m41), "{name}");
        }
    }
}

#[test]
fn corpus_quirks_are_read_as_documented() {
    let Some(dir) = corpus_dir() else {
        return;
    };
    // MSH 4.0 file: sparse node tags, 752 triangles, 5 physical groups.
    let t1 = msh::read_file(&dir.join("mfem__mfem__data__gmsh__v4__t1.msh")).unwrap();
    assert_eq!(t1.format.unwrap().version, MshVersion::V40);
    assert_eq!(t1.node_count(), 417);
    assert_eq!(t1.max_node_tag(), 465);
    let tri: usize = t1.count_elements(2);
    assert_eq!(tri, 752);
    assert_eq!(msh::default_output_format(&t1).version, MshVersion::V41);

    // Comments before $MeshFormat kept and written back first.
    let hole =
        msh::read_file(&dir.join(
            "extras/dealii__dealii__tests__grid__grid_in_msh_version_2__hole81_commented.msh",
        ))
        .unwrap();
    assert!(hole.raw_sections.iter().any(|r| r.name == "Comments"));
    let out = write_bytes(&hole, msh::default_output_format(&hole));
    assert!(
        out.starts_with(b"$Comments"),
        "comments before $MeshFormat stay first"
    );
    assert_eq!(
        msh::default_output_format(&hole).version,
        MshVersion::V2 { minor: 2 }
    );

    // $Periodic with Affine in 2.2, cubic elements kept.
    let per =
        msh::read_file(&dir.join("extras/mfem__mfem__data__periodic-annulus-sector.msh")).unwrap();
    assert!(!per.periodic.is_empty());
    assert!(per
        .periodic
        .iter()
        .any(|l| l.affine.as_ref().is_some_and(|a| a.len() == 16)));
    assert!(per.element_blocks.iter().any(|b| b.element_type == 21));
    assert!(per.element_blocks.iter().any(|b| b.element_type == 26));

    // Unused sphere centre node becomes its own point entity, still written.
    let sph = msh::read_file(&dir.join("bempp__bempp-legacy__examples__sphere-152.msh")).unwrap();
    assert_eq!(sph.node_count(), 79);

    // Several physical tags per curve entity (tagged_gmsh4: tags 6 and 7).
    let tg =
        msh::read_file(&dir.join("kinnala__scikit-fem__docs__examples__meshes__tagged_gmsh4.msh"))
            .unwrap();
    assert!(tg.entities[1].iter().any(|e| e.physical_tags.len() >= 2));
    // Its 2.2 form writes those line elements once per group and merges them back.
    let [_, _, a22, _] = variants();
    let text = String::from_utf8(write_bytes(&tg, a22.0)).unwrap();
    let back = msh::read_bytes(text.as_bytes(), "tg.msh").unwrap();
    assert_eq!(back.element_count(), tg.element_count());
    assert!(back.warnings.iter().any(|w| w.contains("merged")));
}

#[test]
fn summary_reports_formats_counts_and_parity() {
    let Some(dir) = corpus_dir() else {
        return;
    };
    let m = msh::read_file(&dir.join("mfem__mfem__data__compass.msh")).unwrap();
    let s = msh::summary(&m);
    let text = s.to_string();
    assert!(text.starts_with("format: MSH 2.2 ASCII"), "{text}");
    assert_eq!(s.nodes, 13);
    let tris: usize = s.surfaces.iter().map(|x| x.triangles).sum();
    assert_eq!(tris, 8);
    assert_eq!(s.groups.iter().filter(|g| g.name.is_some()).count(), 17);
    assert!(text.contains("is even") || text.contains("is odd"));
}
