//! Format quirks the reader must survive and the model must keep, each pinned by a small
//! hand-written file: CRLF, trailing spaces, 3-digit exponents, missing final newline,
//! unknown and data sections, 2.x tag conventions, parametric nodes, periodic links.

use crate::msh_common;

use blossomquad::mesh::{Mesh, MshFormat, MshVersion, SectionPosition};
use blossomquad::msh;
use msh_common::*;

fn read(text: &str) -> Mesh {
    msh::read_bytes(text.as_bytes(), "q.msh").unwrap_or_else(|e| panic!("{e}"))
}

fn write_as(m: &Mesh, f: MshFormat) -> Vec<u8> {
    let mut v = Vec::new();
    msh::write(m, &mut v, f).unwrap();
    v
}

const V41: &str = "$MeshFormat
4.1 0 8
$EndMeshFormat
$Entities
0 0 1 0
1 0 0 0 1 1 0 1 5 0
$EndEntities
$Nodes
1 4 10 40
2 1 0 4
40
10
30
20
0 0 0
1 0 0
1 1 0
0 1 0
$EndNodes
$Elements
1 2 7 9
2 1 2 2
9 40 10 30
7 40 30 20
$EndElements
";

#[test]
fn crlf_trailing_spaces_exponents_and_no_final_newline() {
    let base = read(V41);
    let crlf = V41.replace('\n', "\r\n");
    assert_eq!(nodes(&read(&crlf)), nodes(&base));
    let spaced = V41
        .replace("9 40 10 30", "9 40 10 30   \t")
        .replace("1 1 0\n", "1 1 0  \n");
    assert_eq!(elements(&read(&spaced)), elements(&base));
    let exp = V41.replace("1 1 0\n", "1.000e+000 10E-001 0.0e-007\n");
    assert_eq!(nodes(&read(&exp)), nodes(&base));
    let trimmed = V41.trim_end();
    assert_eq!(elements(&read(trimmed)), elements(&base));
    let crlf_trimmed = crlf.trim_end();
    assert_eq!(elements(&read(crlf_trimmed)), elements(&base));
}

#[test]
fn sparse_unordered_tags_kept_as_written() {
    let m = read(V41);
    assert_eq!(m.node_blocks[0].tags, vec![40, 10, 30, 20]);
    assert_eq!(m.element_blocks[0].tags, vec![9, 7]);
    assert_eq!(m.entities[2][0].physical_tags, vec![5]);
    for (f, label) in variants() {
        let back = msh::read_bytes(&write_as(&m, f), label).unwrap();
        assert_eq!(nodes(&back), nodes(&m), "{label}");
        assert_eq!(elements(&back), elements(&m), "{label}");
    }
}

#[test]
fn unknown_and_data_sections_kept_and_written_back() {
    let text = format!(
        "$Comments\nbefore the format\n$EndComments\n{V41}$Fancy\n1 2 3\n$EndFancy\n$NodeData\n1\n\"t\"\n1\n0.0\n3\n0\n1\n4\n40 1\n10 2\n30 3\n20 4\n$EndNodeData\n"
    );
    let m = read(&text);
    assert_eq!(m.raw_sections.len(), 2);
    assert_eq!(m.raw_sections[0].position, SectionPosition::BeforeFormat);
    assert_eq!(m.raw_sections[1].name, "Fancy");
    assert_eq!(m.raw_sections[1].body, b"1 2 3\n");
    assert_eq!(m.data_sections.len(), 1);
    let ascii = variants()[0].0;
    let out = String::from_utf8(write_as(&m, ascii)).unwrap();
    assert!(out.starts_with("$Comments\nbefore the format\n$EndComments\n$MeshFormat"));
    assert!(out.contains("$Fancy\n1 2 3\n$EndFancy\n"));
    assert!(out.contains("$NodeData\n1\n\"t\"\n"));
    assert!(msh::write_warnings(&m, ascii).is_empty());
    // Binary output cannot carry ASCII data sections: dropped, and the warning says so.
    let bin = variants()[1].0;
    let out = write_as(&m, bin);
    assert!(!out.windows(9).any(|w| w == b"$NodeData"));
    assert!(msh::write_warnings(&m, bin)[0].contains("dropped 1"));
    // A section Gmsh decodes in the file's encoding ($Parametrizations) follows the data
    // sections' rule.
    let para = read(&format!(
        "{V41}$Parametrizations\n0 0\n$EndParametrizations\n"
    ));
    let out = String::from_utf8_lossy(&write_as(&para, bin)).into_owned();
    assert!(!out.contains("$Parametrizations"));
    assert!(msh::write_warnings(&para, bin)[0].contains("$Parametrizations dropped"));
    let out = String::from_utf8(write_as(&para, ascii)).unwrap();
    assert!(out.contains("$Parametrizations\n0 0\n$EndParametrizations\n"));
    // An unclosed unknown section is an error, not a silent skip.
    let e = msh::read_bytes(format!("{V41}$Fancy\n1 2 3\n").as_bytes(), "q.msh").unwrap_err();
    assert!(e.to_string().contains("$EndFancy"), "{e}");
}

const V2_TAGS: &str = "$MeshFormat
2.2 0 8
$EndMeshFormat
$PhysicalNames
2
2 5 \"five\"
2 6 \"six\"
$EndPhysicalNames
$Nodes
5
1 0 0 0
2 1 0 0
3 1 1 0
4 0 1 0
9 5 5 5
$EndNodes
$Elements
7
1 2 2 5 3 1 2 3
2 2 2 5 3 1 3 4
3 2 2 6 3 1 2 3
4 2 2 6 3 1 3 4
5 1 4 7 2 1 3 1 2
6 1 2 -8 2 2 3
7 1 2 9 2 3 4
$EndElements
";

#[test]
fn v2_copies_merged_partitions_negative_tags_and_splits() {
    let m = read(V2_TAGS);
    // Triangles written once per group (5 and 6) are one element each, in both groups.
    let tri: Vec<_> = m
        .element_blocks
        .iter()
        .filter(|b| b.element_type == 2)
        .collect();
    assert_eq!(tri.len(), 1);
    assert_eq!(tri[0].tags, vec![1, 2]);
    let mut p = m.entity(2, 3).unwrap().physical_tags.clone();
    p.sort_unstable();
    assert_eq!(p, vec![5, 6]);
    // Curve 2 holds elements of groups 7, 8 (negative tag) and 9: split into three entities.
    let lines: Vec<_> = m
        .element_blocks
        .iter()
        .filter(|b| b.element_type == 1)
        .collect();
    assert_eq!(lines.len(), 3);
    assert!(m
        .warnings
        .iter()
        .any(|w| w.contains("negative physical tag")));
    assert!(m.warnings.iter().any(|w| w.contains("split")));
    let with_part = lines.iter().find(|b| b.tags == vec![5]).unwrap();
    assert_eq!(with_part.partitions, Some(vec![vec![1, 3]]));
    assert_eq!(
        with_part.entity_tag, 2,
        "first physical set keeps the elementary tag"
    );
    let g8 = lines.iter().find(|b| b.tags == vec![6]).unwrap();
    assert_eq!(m.entity(1, g8.entity_tag).unwrap().physical_tags, vec![8]);
    // Node 9 is used by no element: its own point entity.
    let nb = m.node_blocks.iter().find(|b| b.tags.contains(&9)).unwrap();
    assert_eq!(nb.entity_dim, 0);
    // Triangle nodes on the curve are classified on the curve (lowest dimension).
    let nb1 = m.node_blocks.iter().find(|b| b.tags.contains(&1)).unwrap();
    assert_eq!(nb1.entity_dim, 1);
    // Written back as 2.2: copies again, partitions kept, same model when re-read.
    let out = String::from_utf8(write_as(&m, variants()[2].0)).unwrap();
    assert!(out.contains("\n5 1 4 7 2 1 3 1 2\n"), "{out}");
    assert_eq!(
        out.matches(" 2 2 5 3 ").count() + out.matches(" 2 2 6 3 ").count(),
        4
    );
    let back = read(&out);
    assert_eq!(elements(&back), elements(&m));
    assert_eq!(m.entities, back.entities);
    // 4.1 output: derived entities with bounding boxes, surface bounded by a curve.
    let m41 = msh::read_bytes(&write_as(&m, variants()[0].0), "x").unwrap();
    let s = m41.entity(2, 3).unwrap();
    assert_eq!(s.bbox, [0.0, 0.0, 0.0, 1.0, 1.0, 0.0]);
    assert!(
        !s.bounding.is_empty(),
        "surface 3 bounded by curve elements on its edges"
    );
    assert_eq!(names(&m41), names(&m));
}

#[test]
fn v2_parametric_nodes_read_and_written() {
    let text = "$MeshFormat\n2.2 0 8\n$EndMeshFormat\n$ParametricNodes\n3\n1 0 0 0 0 1\n2 1 0 0 1 4 0.5\n3 0 1 0 2 1 0.25 0.75\n$EndParametricNodes\n$Elements\n1\n1 2 2 0 1 1 2 3\n$EndElements\n";
    let m = read(text);
    let b = m.node_blocks.iter().find(|b| b.entity_dim == 1).unwrap();
    assert_eq!((b.entity_tag, b.params.clone()), (4, Some(vec![0.5])));
    let s = m.node_blocks.iter().find(|b| b.entity_dim == 2).unwrap();
    assert_eq!(s.params, Some(vec![0.25, 0.75]));
    let out = String::from_utf8(write_as(&m, variants()[2].0)).unwrap();
    assert!(out.contains("$ParametricNodes\n3\n"), "{out}");
    assert!(out.contains("\n2 1 0 0 1 4 0.5\n"), "{out}");
    let back = read(&out);
    assert_eq!(back.node_blocks, m.node_blocks);
    assert!(msh::write_warnings(&m, variants()[2].0).is_empty());
    assert!(
        !msh::write_warnings(&m, variants()[3].0).is_empty(),
        "binary 2.2 drops them"
    );
    // Without values for every curve and surface node, 2.2 writes plain $Nodes and says so.
    let mut partial = m.clone();
    for b in partial.node_blocks.iter_mut().filter(|b| b.entity_dim == 2) {
        b.params = None;
    }
    let out = String::from_utf8(write_as(&partial, variants()[2].0)).unwrap();
    assert!(out.contains("$Nodes\n3\n") && !out.contains("$ParametricNodes"));
    assert!(msh::write_warnings(&partial, variants()[2].0)[0].contains("parametric"));
    // 4.1 keeps them as parametric node blocks.
    let m41 = msh::read_bytes(&write_as(&m, variants()[1].0), "x").unwrap();
    assert_eq!(m41.node_blocks, m.node_blocks);
}

#[test]
fn big_endian_binary_is_read() {
    // A big-endian MSH 4.1 binary file, built field by field.
    let mut d: Vec<u8> = b"$MeshFormat\n4.1 1 8\n".to_vec();
    d.extend(1i32.to_be_bytes());
    d.extend(b"\n$EndMeshFormat\n$Entities\n");
    let u = |d: &mut Vec<u8>, v: u64| d.extend(v.to_be_bytes());
    let i = |d: &mut Vec<u8>, v: i32| d.extend(v.to_be_bytes());
    let f = |d: &mut Vec<u8>, v: f64| d.extend(v.to_be_bytes());
    for c in [0, 0, 1, 0] {
        u(&mut d, c);
    }
    i(&mut d, 1);
    for v in [0.0, 0.0, 0.0, 1.0, 1.0, 0.0] {
        f(&mut d, v);
    }
    u(&mut d, 0);
    u(&mut d, 0);
    d.extend(b"\n$EndEntities\n$Nodes\n");
    for v in [1, 3, 1, 3] {
        u(&mut d, v);
    }
    for v in [2, 1, 0] {
        i(&mut d, v);
    }
    u(&mut d, 3);
    for v in [1, 2, 3] {
        u(&mut d, v);
    }
    for v in [0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0] {
        f(&mut d, v);
    }
    d.extend(b"\n$EndNodes\n$Elements\n");
    for v in [1, 1, 1, 1] {
        u(&mut d, v);
    }
    for v in [2, 1, 2] {
        i(&mut d, v);
    }
    for v in [1, 1, 1, 2, 3] {
        u(&mut d, v);
    }
    d.extend(b"\n$EndElements\n");
    let m = msh::read_bytes(&d, "be.msh").unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(m.node_blocks[0].coords[1], [1.0, 0.0, 0.0]);
    assert_eq!(m.element_blocks[0].nodes, vec![1, 2, 3]);
    assert_eq!(m.entities[2][0].bbox[3], 1.0);
    // A probe that is neither 1 nor byte-swapped 1 is refused.
    let at = "$MeshFormat\n4.1 1 8\n".len();
    d[at..at + 4].copy_from_slice(&7i32.to_le_bytes());
    let e = msh::read_bytes(&d, "bad.msh").unwrap_err();
    assert!(e.to_string().contains("endianness probe"), "{e}");
}

#[test]
fn default_formats_and_version_mapping() {
    let m = read(V41);
    assert_eq!(
        msh::default_output_format(&m),
        MshFormat {
            version: MshVersion::V41,
            binary: false
        }
    );
    let old = read(&V2_TAGS.replace("2.2 0 8", "2 0 8"));
    assert_eq!(old.format.unwrap().version, MshVersion::V2 { minor: 0 });
    assert_eq!(
        msh::default_output_format(&old).version,
        MshVersion::V2 { minor: 2 }
    );
    assert_eq!(
        msh::default_output_format(&Mesh::default()).version,
        MshVersion::V41
    );
}

#[test]
fn v41_without_entities_section_gets_entities() {
    let text = V41.replace(
        "$Entities\n0 0 1 0\n1 0 0 0 1 1 0 1 5 0\n$EndEntities\n",
        "",
    );
    let m = read(&text);
    assert!(!m.has_entities_section);
    let e = m.entity(2, 1).expect("entity derived from the blocks");
    assert_eq!(e.bbox, [0.0, 0.0, 0.0, 1.0, 1.0, 0.0]);
    assert!(m.warnings.is_empty());
    // A mesh built in memory with a block on an unknown entity is written with that entity.
    let mut mem = read(V41);
    mem.entities = Default::default();
    mem.format = None;
    let back = msh::read_bytes(&write_as(&mem, variants()[1].0), "x").unwrap();
    assert!(back.has_entities_section);
    assert_eq!(
        back.entity(2, 1).unwrap().bbox,
        [0.0, 0.0, 0.0, 1.0, 1.0, 0.0]
    );
    // $Entities present but incomplete: completed, with a warning.
    let partial = V41.replace("0 0 1 0\n1 0 0 0 1 1 0 1 5 0\n", "0 0 0 0\n");
    assert!(read(&partial)
        .warnings
        .iter()
        .any(|w| w.contains("missing from $Entities")));
}

#[test]
fn periodic_forms_without_affine_transform() {
    // 4.1 form with numAffine = 0, then the old form (no affine line) of 2.2.
    let v41 =
        format!("{V41}$Periodic\n2\n1 5 6\n0\n2\n10 20\n30 40\n0 1 2\n0\n1\n40 10\n$EndPeriodic\n");
    let m = read(&v41);
    assert_eq!(m.periodic.len(), 2);
    assert_eq!(m.periodic[0].affine, None);
    assert_eq!(m.periodic[0].node_pairs, vec![(10, 20), (30, 40)]);
    assert_eq!(m.periodic[1].node_pairs, vec![(40, 10)]);
    let v22 = V2_TAGS.to_string() + "$Periodic\n2\n1 2 4\n2\n1 2\n3 4\n0 3 4\n0\n$EndPeriodic\n";
    let m2 = read(&v22);
    assert_eq!(m2.periodic[0].node_pairs, vec![(1, 2), (3, 4)]);
    assert_eq!(m2.periodic[0].affine, None);
    assert!(
        m2.periodic[1].node_pairs.is_empty(),
        "a last link without nodes"
    );
    for (f, label) in variants() {
        for m in [&m, &m2] {
            let back = msh::read_bytes(&write_as(m, f), label).unwrap();
            assert_eq!(back.periodic, m.periodic, "{label}");
        }
    }
}

#[test]
fn inconsistent_in_memory_blocks_are_written_consistently() {
    // A stage that left a block with a tag but no node list (or a node list shorter than its
    // tags) must not make the writers announce more records than they write.
    let mut m = read(V41);
    m.element_blocks[0].tags.push(99);
    m.node_blocks[0].tags.push(77);
    for (f, label) in variants() {
        let back = msh::read_bytes(&write_as(&m, f), label).unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(back.element_count(), 2, "{label}");
        assert_eq!(back.node_count(), 4, "{label}");
    }
}
