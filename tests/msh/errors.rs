//! One test per class of bad input: each gives one clear error line naming
//! the file, the section and the line (ASCII) or byte offset (binary), and never panics.

use crate::msh_common;

use blossomquad::mesh::{MshFormat, MshVersion};
use blossomquad::msh::{self, ErrorKind, Location, MshError};
use msh_common::*;
use proptest::prelude::*;

/// A valid MSH 4.1 ASCII mesh: one surface, 3 nodes, 1 triangle (22 lines).
const GOOD: &str = "$MeshFormat
4.1 0 8
$EndMeshFormat
$Entities
0 0 1 0
1 0 0 0 1 1 0 0 0
$EndEntities
$Nodes
1 3 1 3
2 1 0 3
1
2
3
0 0 0
1 0 0
0 1 0
$EndNodes
$Elements
1 1 1 1
2 1 2 1
1 1 2 3
$EndElements
";

fn err(text: &str) -> MshError {
    match msh::read_bytes(text.as_bytes(), "mesh.msh") {
        Ok(_) => panic!("accepted bad input:\n{text}"),
        Err(e) => {
            let line = e.to_string();
            assert!(!line.contains('\n'), "error must be one line: {line}");
            assert!(line.starts_with("mesh.msh: "), "{line}");
            e
        }
    }
}

fn replace_line(n: usize, with: &str) -> String {
    GOOD.lines()
        .enumerate()
        .map(|(i, l)| if i + 1 == n { with } else { l })
        .collect::<Vec<_>>()
        .join("\n")
        + "\n"
}

#[test]
fn good_mesh_reads() {
    let m = msh::read_bytes(GOOD.as_bytes(), "mesh.msh").unwrap();
    assert_eq!((m.node_count(), m.element_count()), (3, 1));
}

#[test]
fn missing_coordinate_names_file_section_and_line() {
    let e = err(&replace_line(15, "1 0"));
    assert_eq!(
        e.to_string(),
        "mesh.msh: $Nodes, line 15: expected 3 coordinates, found 2"
    );
}

#[test]
fn truncated_file() {
    let cut = &GOOD[..GOOD.rfind("0 1 0").unwrap()];
    let e = err(cut);
    assert!(
        matches!(
            e.kind,
            ErrorKind::Truncated { .. } | ErrorKind::CountTooLarge { .. }
        ),
        "{e}"
    );
    assert_eq!(e.section.as_deref(), Some("$Nodes"));
    assert!(e.to_string().contains("truncated"), "{e}");
    // Cut inside the section end marker.
    let e = err(&GOOD[..GOOD.len() - 5]);
    assert_eq!(e.section.as_deref(), Some("$Elements"), "{e}");
}

#[test]
fn wrong_counts() {
    // Header announces more nodes than the block holds.
    let e = err(&replace_line(9, "1 4 1 3"));
    assert!(matches!(e.kind, ErrorKind::CountMismatch { .. }), "{e}");
    assert_eq!(e.location, Location::Line(9));
    // Block announces more elements than present: runs into $EndElements.
    let e = err(&replace_line(20, "2 1 2 2"));
    assert!(matches!(e.kind, ErrorKind::EarlyEnd { .. }), "{e}");
    // Absurd counts are refused before any memory is reserved for them.
    let e = err(&replace_line(20, "2 1 98 4000000000"));
    assert!(e.to_string().contains("cannot fit"), "{e}");
    let e = err(&replace_line(5, "0 0 99999999999 0"));
    assert!(e.to_string().contains("cannot fit"), "{e}");
    // Block announces fewer nodes than present: the section does not end where it should.
    let e = err(&replace_line(10, "2 1 0 2"));
    assert_eq!(e.section.as_deref(), Some("$Nodes"), "{e}");
}

#[test]
fn malformed_section() {
    let e = err(&replace_line(17, "$EndNodez"));
    assert_eq!(e.section.as_deref(), Some("$Nodes"), "{e}");
    assert!(e.to_string().contains("expected $EndNodes"), "{e}");
    let e = err(&GOOD.replace("$EndEntities\n", ""));
    assert_eq!(e.section.as_deref(), Some("$Entities"), "{e}");
    let e = err("$MeshFormat\nfour point one\n$EndMeshFormat\n");
    assert_eq!(e.section.as_deref(), Some("$MeshFormat"), "{e}");
    let e = err("$MeshFormat\n4.1 0 8\n$EndMeshFormat\n$Nodes\n");
    assert!(matches!(e.kind, ErrorKind::Truncated { .. }), "{e}");
}

#[test]
fn node_referenced_but_missing() {
    let e = err(&replace_line(21, "1 1 2 99"));
    assert!(
        matches!(
            e.kind,
            ErrorKind::MissingNode {
                element: 1,
                node: 99
            }
        ),
        "{e}"
    );
    assert_eq!(e.location, Location::Line(21));
    // Same in MSH 2.2.
    let v2 = "$MeshFormat\n2.2 0 8\n$EndMeshFormat\n$Nodes\n2\n1 0 0 0\n2 1 0 0\n$EndNodes\n$Elements\n1\n1 1 2 0 1 1 3\n$EndElements\n";
    let e = err(v2);
    assert!(
        matches!(e.kind, ErrorKind::MissingNode { node: 3, .. }),
        "{e}"
    );
    assert_eq!(e.location, Location::Line(11));
}

#[test]
fn duplicate_node_tags_refused_duplicate_element_tags_warned() {
    let e = err(&replace_line(13, "2"));
    assert!(
        e.to_string()
            .contains("node tag 2 is defined more than once"),
        "{e}"
    );
    assert_eq!(e.section.as_deref(), Some("$Nodes"));
    let v2 = "$MeshFormat\n2.2 0 8\n$EndMeshFormat\n$Nodes\n2\n1 0 0 0\n1 1 0 0\n$EndNodes\n";
    assert!(err(v2)
        .to_string()
        .contains("node tag 1 is defined more than once"));
    let twice = GOOD
        .replace("2 1 2 1\n1 1 2 3\n", "2 1 2 2\n1 1 2 3\n1 3 2 1\n")
        .replace("1 1 1 1\n2 1", "1 2 1 1\n2 1");
    let m = msh::read_bytes(twice.as_bytes(), "m.msh").unwrap();
    assert!(m
        .warnings
        .iter()
        .any(|w| w.contains("element tag 1 is used by more than one")));
}

#[test]
fn unknown_element_type_code() {
    let e = err(&replace_line(20, "2 1 77 1"));
    assert!(matches!(e.kind, ErrorKind::UnknownElementType(77)), "{e}");
    assert_eq!(
        e.to_string(),
        "mesh.msh: $Elements, line 20: unknown element type code 77"
    );
    assert_eq!(e.location, Location::Line(20));
}

#[test]
fn non_numeric_fields() {
    let e = err(&replace_line(14, "0 abc 0"));
    assert!(matches!(e.kind, ErrorKind::NotANumber { .. }), "{e}");
    assert_eq!(e.location, Location::Line(14));
    assert!(
        e.to_string().starts_with("mesh.msh: $Nodes, line 14: "),
        "{e}"
    );
    let e = err(&replace_line(21, "1 1 x 3"));
    assert!(matches!(e.kind, ErrorKind::NotANumber { .. }), "{e}");
    assert!(
        e.to_string().starts_with("mesh.msh: $Elements, line 21: "),
        "{e}"
    );
}

#[test]
fn nan_and_inf_coordinates() {
    for bad in ["nan 0 0", "0 inf 0", "0 0 -infinity", "1e999 0 0"] {
        let e = err(&replace_line(16, bad));
        assert!(matches!(e.kind, ErrorKind::NotFinite { .. }), "{bad}: {e}");
        assert_eq!(e.location, Location::Line(16));
        assert!(
            e.to_string().starts_with("mesh.msh: $Nodes, line 16: "),
            "{e}"
        );
    }
    // Binary NaN.
    let m = msh::read_bytes(GOOD.as_bytes(), "g").unwrap();
    let bin41 = MshFormat {
        version: MshVersion::V41,
        binary: true,
    };
    let mut data = Vec::new();
    msh::write(&m, &mut data, bin41).unwrap();
    let one = 1.0f64.to_le_bytes();
    // The first 1.0 after `$Nodes` is a node coordinate (an earlier one would be a
    // bounding box in `$Entities`).
    let nodes = data.windows(7).position(|w| w == b"$Nodes\n").unwrap();
    let at = nodes + data[nodes..].windows(8).position(|w| w == one).unwrap();
    data[at..at + 8].copy_from_slice(&f64::NAN.to_le_bytes());
    let e = msh::read_bytes(&data, "b.msh").unwrap_err();
    assert!(matches!(e.kind, ErrorKind::NotFinite { .. }), "{e}");
    assert_eq!(e.location, Location::Byte(at), "{e}");
    assert!(
        e.to_string()
            .starts_with(&format!("b.msh: $Nodes, byte {at}: ")),
        "{e}"
    );
}

#[test]
fn binary_size_mismatch() {
    let m = msh::read_bytes(GOOD.as_bytes(), "g").unwrap();
    for (f, _) in variants().into_iter().filter(|v| v.0.binary) {
        let mut data = Vec::new();
        msh::write(&m, &mut data, f).unwrap();
        // Cut inside the binary element data.
        let at = data.windows(9).position(|w| w == b"$Elements").unwrap() + 20;
        let e = msh::read_bytes(&data[..at], "b.msh").unwrap_err();
        assert!(matches!(e.kind, ErrorKind::BinarySize { .. }), "{e}");
        assert!(e.to_string().starts_with("b.msh: $Elements, byte "), "{e}");
    }
    // A node count larger than the bytes left.
    let mut data = Vec::new();
    msh::write(&m, &mut data, variants()[1].0).unwrap();
    let at = data.windows(7).position(|w| w == b"$Nodes\n").unwrap() + 7;
    data[at + 8..at + 16].copy_from_slice(&1_000_000u64.to_le_bytes());
    let e = msh::read_bytes(&data, "b.msh").unwrap_err();
    assert_eq!(e.section.as_deref(), Some("$Nodes"), "{e}");
    assert!(
        matches!(e.location, Location::Byte(b) if b < data.len()),
        "{e}"
    );
    assert!(e.to_string().starts_with("b.msh: $Nodes, byte "), "{e}");
}

#[test]
fn empty_file() {
    for d in ["", "\n\n  \r\n"] {
        let e = msh::read_bytes(d.as_bytes(), "e.msh").unwrap_err();
        assert!(matches!(e.kind, ErrorKind::Empty));
        assert_eq!(e.to_string(), "e.msh: file is empty");
    }
}

#[test]
fn geo_or_stl_passed_by_mistake() {
    let geo = "// a square\nSetFactory(\"OpenCASCADE\");\nRectangle(1) = {0,0,0,1,1};\n";
    let e = msh::read_bytes(geo.as_bytes(), "sq.geo").unwrap_err();
    assert_eq!(
        e.to_string(),
        "sq.geo: looks like a Gmsh .geo script, not a mesh; run gmsh -2 first"
    );
    let stl = "solid cube\n facet normal 0 0 1\n  outer loop\n   vertex 0 0 0\n";
    let e = msh::read_bytes(stl.as_bytes(), "c.stl").unwrap_err();
    assert!(e.to_string().contains("ASCII STL"), "{e}");
    let mut bin = vec![0u8; 84 + 50];
    bin[80] = 1;
    let e = msh::read_bytes(&bin, "c.stl").unwrap_err();
    assert!(e.to_string().contains("binary STL"), "{e}");
    let e = msh::read_bytes(b"hello world", "x.txt").unwrap_err();
    assert!(matches!(e.kind, ErrorKind::NotMsh(_)), "{e}");
}

#[test]
fn unreadable_path() {
    let e = msh::read_file(std::path::Path::new("/nonexistent/dir/mesh.msh")).unwrap_err();
    assert!(matches!(e.kind, ErrorKind::Io { .. }));
    assert!(
        e.to_string()
            .starts_with("/nonexistent/dir/mesh.msh: cannot read: "),
        "{e}"
    );
    let dir = tempdir();
    let e = msh::read_file(dir.path()).unwrap_err();
    assert!(matches!(e.kind, ErrorKind::Io { .. }), "{e}");
}

#[test]
fn msh40_binary_refused_clearly() {
    let e = err("$MeshFormat\n4 1 8\n\x01\x00\x00\x00\n$EndMeshFormat\n");
    assert!(matches!(e.kind, ErrorKind::Unsupported(_)));
    assert!(
        e.to_string().contains("MSH 4.0 binary is not supported"),
        "{e}"
    );
    let e = err("$MeshFormat\n3.0 0 8\n$EndMeshFormat\n");
    assert!(matches!(e.kind, ErrorKind::Unsupported(_)), "{e}");
    assert!(
        e.to_string().contains("MSH version 3.0 is not supported")
            && e.to_string().contains("-format msh41")
            && e.to_string().contains("-format msh22"),
        "{e}"
    );
}

/// A complete MSH 1 file (no `$MeshFormat`; `$NOD` ... `$ENDNOD`, `$ELM` ... `$ENDELM`) is
/// named as MSH version 1 with the command that re-saves it, not taken for a truncated
/// section.
#[test]
fn msh1_is_named_with_the_way_out() {
    let msh1 = "$NOD\n3\n1 0 0 0\n2 1 0 0\n3 0 1 0\n$ENDNOD\n$ELM\n1\n1 2 1 1 3 1 2 3\n$ENDELM\n";
    let e = err(msh1);
    assert!(matches!(e.kind, ErrorKind::Unsupported(_)), "{e}");
    assert_eq!(
        e.to_string(),
        "mesh.msh: $NOD, line 1: MSH version 1 ($NOD without $MeshFormat) is not supported \
         (read: 2.0, 2.1, 2.2, 4.0 ASCII, 4.1); re-save it with gmsh IN -0 -format msh41 \
         -o OUT.msh (or -format msh22)"
    );
    // elements first is MSH 1 as well
    let e = err("$ELM\n0\n$ENDELM\n");
    assert!(e.to_string().contains("MSH version 1 ($ELM"), "{e}");
}

#[test]
fn corpus_broken_file_fails_clearly() {
    let Some(dir) = corpus_dir() else {
        return;
    };
    let p = dir.join(
        "broken/ahojukka5__gmshparser__testdata__complex__test_from_internet__physical_v2_1.msh",
    );
    let e = msh::read_file(&p).unwrap_err();
    assert!(matches!(e.kind, ErrorKind::TooManyFields { .. }), "{e}");
    assert_eq!(e.section.as_deref(), Some("$Elements"));
    // Line 27 is `3 1 2 10 2 2 1 2`: a 2-node line with three node tags, the first
    // element line that does not fit its type (see SOURCES.md).
    assert_eq!(e.location, Location::Line(27), "{e}");
    let text = e.to_string();
    assert!(
        text.starts_with(&format!("{}: $Elements, line 27: ", p.display())),
        "{text}"
    );
    assert!(text.contains("too many"), "{text}");
}

#[test]
fn extra_tokens_on_v41_element_line_refused() {
    let e = err(&replace_line(21, "1 1 2 3 4"));
    assert!(matches!(e.kind, ErrorKind::TooManyFields { .. }), "{e}");
    assert_eq!(e.location, Location::Line(21));
}

#[test]
fn write_file_leaves_no_partial_file() {
    let m = msh::read_bytes(GOOD.as_bytes(), "g").unwrap();
    let dir = tempdir();
    let target = dir.path().join("out.msh");
    // Binary 2.2 cannot hold a node tag above i32::MAX: the write fails midway.
    let mut big = m.clone();
    big.node_blocks[0].tags[2] = u64::MAX / 2;
    big.element_blocks[0].nodes[2] = u64::MAX / 2;
    let e = msh::write_file(&big, &target, variants()[3].0).unwrap_err();
    assert!(e.to_string().contains("does not fit"), "{e}");
    assert!(!target.exists());
    assert_eq!(
        std::fs::read_dir(dir.path()).unwrap().count(),
        0,
        "temp file removed"
    );
    // Unwritable directory.
    let e = msh::write_file(
        &m,
        std::path::Path::new("/nonexistent/x.msh"),
        variants()[0].0,
    );
    assert!(e.is_err());
}

/// Mutations of a file: flip, insert or delete bytes, truncate, duplicate a line.
fn mutate(data: &[u8], ops: &[(u8, usize, u8)]) -> Vec<u8> {
    let mut d = data.to_vec();
    for &(op, pos, byte) in ops {
        if d.is_empty() {
            break;
        }
        let p = pos % d.len();
        match op % 5 {
            0 => d[p] = byte,
            1 => d.insert(p, byte),
            2 => {
                d.remove(p);
            }
            3 => d.truncate(p),
            _ => {
                let end = d[p..]
                    .iter()
                    .position(|&b| b == b'\n')
                    .map_or(d.len(), |i| p + i + 1);
                let line = d[p..end].to_vec();
                d.splice(p..p, line);
            }
        }
    }
    d
}

fn fuzz_inputs() -> Vec<Vec<u8>> {
    let mut v: Vec<Vec<u8>> = corpus_files()
        .iter()
        .map(|p| std::fs::read(p).unwrap())
        .collect();
    let m = msh::read_bytes(GOOD.as_bytes(), "g").unwrap();
    let t1 = corpus_files()
        .first()
        .map(|p| msh::read_file(p).unwrap())
        .unwrap_or_else(|| m.clone());
    for mesh in [&m, &t1] {
        for (f, _) in variants() {
            let mut d = Vec::new();
            msh::write(mesh, &mut d, f).unwrap();
            v.push(d);
        }
    }
    v
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 400, failure_persistence: None, rng_seed: proptest::test_runner::RngSeed::Fixed(0x5eed), ..ProptestConfig::default() })]
    #[test]
    fn random_mutations_never_panic(
        which in 0usize..64,
        ops in proptest::collection::vec((any::<u8>(), any::<usize>(), prop_oneof![any::<u8>(), Just(b'\n'), Just(b' '), Just(b'$'), Just(b'9')]), 1..6),
    ) {
        let inputs = fuzz_inputs();
        let data = mutate(&inputs[which % inputs.len()], &ops);
        match msh::read_bytes(&data, "fuzz.msh") {
            Ok(m) => {
                // Whatever was accepted can be written in every variant without panicking.
                for (f, _) in variants() {
                    let _ = msh::write(&m, &mut Vec::new(), f);
                }
            }
            Err(e) => prop_assert!(!e.to_string().contains('\n')),
        }
    }
}
