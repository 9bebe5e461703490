//! Every quirk of the real MSH corpus (listed in `SOURCES.md` of the corpus beside the
//! repository) on a small hand-written file of `tests/data/quirks/` (table in its
//! `README.md`), so a clone with nothing beside it tests them all: each file is read as its
//! quirk means, and the whole tool (`blossomquad IN -o OUT`) either writes a valid all-quad
//! mesh keeping the physical groups, their names, the entities, every node tag and the curve
//! and point elements, or refuses the file in one plain line and writes nothing.
//! Gmsh is needed only by the last test (Gmsh loads every output).

use crate::common;
use crate::gmsh_gate;

use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};

use blossomquad::mesh::{element_dim, etype, Mesh, MshVersion, SectionPosition};
use blossomquad::msh;
use blossomquad::recombine::check_invariants;
use blossomquad::validity::invalid_quads;
use common::{blossomquad_run, repo_dir};

fn quirk(name: &str) -> PathBuf {
    repo_dir().join("tests/data/quirks").join(name)
}

fn read(path: &Path) -> Mesh {
    msh::read_file(path).unwrap_or_else(|e| panic!("{e}"))
}

/// Element tag -> (entity dim, entity tag, type, nodes).
fn elements(m: &Mesh) -> BTreeMap<u64, (i32, i32, u32, Vec<u64>)> {
    let mut out = BTreeMap::new();
    for b in &m.element_blocks {
        for (i, t) in b.tags.iter().enumerate() {
            let e = (
                b.entity_dim,
                b.entity_tag,
                b.element_type,
                b.element(i).to_vec(),
            );
            assert!(out.insert(*t, e).is_none(), "element tag {t} twice");
        }
    }
    out
}

fn count(m: &Mesh, element_type: u32) -> usize {
    m.count_elements(element_type)
}

/// Node tag -> coordinates.
fn coords(m: &Mesh) -> BTreeMap<u64, [f64; 3]> {
    let mut out = BTreeMap::new();
    for b in &m.node_blocks {
        out.extend(b.tags.iter().copied().zip(b.coords.iter().copied()));
    }
    out
}

/// Node tags of each node block, in file order.
fn node_tags_in_file_order(m: &Mesh) -> Vec<u64> {
    m.node_blocks.iter().flat_map(|b| b.tags.clone()).collect()
}

/// The faces (triangles and quads) of dimension-2 entities, as node lists.
fn faces(m: &Mesh) -> Vec<Vec<u64>> {
    m.element_blocks
        .iter()
        .filter(|b| b.entity_dim == 2 && element_dim(b.element_type) == Some(2))
        .flat_map(|b| (0..b.len()).map(move |i| b.element(i).to_vec()))
        .collect()
}

/// Directed edges of the faces with their multiplicity.
fn directed_edges(faces: &[Vec<u64>]) -> BTreeMap<(u64, u64), usize> {
    let mut out = BTreeMap::new();
    for f in faces {
        for i in 0..f.len() {
            *out.entry((f[i], f[(i + 1) % f.len()])).or_default() += 1;
        }
    }
    out
}

/// Euler characteristic V - E + F of the faces.
fn euler(faces: &[Vec<u64>]) -> i64 {
    let nodes: BTreeSet<u64> = faces.iter().flatten().copied().collect();
    let edges: BTreeSet<(u64, u64)> = directed_edges(faces)
        .keys()
        .map(|&(a, b)| (a.min(b), a.max(b)))
        .collect();
    nodes.len() as i64 - edges.len() as i64 + faces.len() as i64
}

/// True when every edge is used once in each direction: a closed surface, consistently
/// oriented.
fn closed_and_oriented(faces: &[Vec<u64>]) -> bool {
    let d = directed_edges(faces);
    d.iter()
        .all(|(&(a, b), &n)| n == 1 && d.get(&(b, a)) == Some(&1))
}

/// z component of twice the vector area of a face.
fn area_z(c: &BTreeMap<u64, [f64; 3]>, f: &[u64]) -> f64 {
    let p: Vec<[f64; 3]> = f.iter().map(|t| c[t]).collect();
    (0..p.len())
        .map(|i| {
            let (a, b) = (p[i], p[(i + 1) % p.len()]);
            (a[0] - p[0][0]) * (b[1] - p[0][1]) - (b[0] - p[0][0]) * (a[1] - p[0][1])
        })
        .sum()
}

/// Sorted physical tags of every entity.
fn physicals(m: &Mesh) -> BTreeSet<(i32, i32, Vec<i32>)> {
    m.entities
        .iter()
        .flatten()
        .map(|e| {
            let mut p = e.physical_tags.clone();
            p.sort_unstable();
            (e.dim, e.tag, p)
        })
        .collect()
}

fn names(m: &Mesh) -> BTreeSet<(i32, i32, String)> {
    m.physical_names
        .iter()
        .map(|p| (p.dim, p.tag, p.name.clone()))
        .collect()
}

/// A fixture recombined by the CLI, the input as read (volume elements removed when they
/// were dropped) and the output as read back.
struct Run {
    input: Mesh,
    output: Mesh,
    out_path: PathBuf,
}

/// `blossomquad FIXTURE -o OUT --quiet EXTRA...` in `dir`: exits 0 and the output, read back
/// with the library, is in `version` and keeps what every run promises (see the module doc).
fn recombine_ok(dir: &Path, name: &str, extra: &[&str], version: MshVersion) -> Run {
    let input_path = quirk(name);
    let out_path = dir.join(name);
    let (code, _, stderr) = blossomquad_run(
        [
            input_path.as_os_str(),
            "-o".as_ref(),
            out_path.as_os_str(),
            "--quiet".as_ref(),
            // the checks below compare the input and the output by tag
            "--keep-tags".as_ref(),
        ]
        .into_iter()
        .chain(extra.iter().map(|s| s.as_ref())),
    );
    assert_eq!(code, Some(0), "{name}: {stderr}");
    let mut input = read(&input_path);
    if extra.contains(&"--drop-volumes") {
        input
            .element_blocks
            .retain(|b| element_dim(b.element_type) != Some(3));
    }
    let output = read(&out_path);
    if extra.contains(&"--drop-volumes") && matches!(version, MshVersion::V2 { .. }) {
        // MSH 2.x has no entity section: the volume without elements is not written, and a
        // node only the volume elements used is read back on a point entity of its own.
        let used: BTreeSet<u64> = elements(&input)
            .values()
            .flat_map(|e| e.3.clone())
            .collect();
        input.entities[3].clear();
        for e in &output.entities[0] {
            if input.entity(0, e.tag).is_none() {
                let own = output
                    .node_blocks
                    .iter()
                    .filter(|b| (b.entity_dim, b.entity_tag) == (0, e.tag))
                    .flat_map(|b| b.tags.iter());
                assert!(e.physical_tags.is_empty(), "{name}: new point {}", e.tag);
                assert!(
                    own.clone().all(|t| !used.contains(t)),
                    "{name}: point {}",
                    e.tag
                );
                input.entities[0].push(e.clone());
            }
        }
    }
    assert_eq!(
        output.format.map(|f| (f.version, f.binary)),
        Some((version, false)),
        "{name}: output format"
    );
    // No triangle left, every quad valid, invariants of recombination.
    assert_eq!(count(&output, etype::TRI3), 0, "{name}: triangles left");
    let surfaces_in: BTreeSet<i32> = faces_by_surface(&input).keys().copied().collect();
    let surfaces_out: BTreeSet<i32> = faces_by_surface(&output).keys().copied().collect();
    assert_eq!(surfaces_in, surfaces_out, "{name}: surfaces holding faces");
    for b in &output.element_blocks {
        if b.entity_dim == 2 && !b.is_empty() {
            assert_eq!(
                b.element_type,
                etype::QUAD4,
                "{name}: surface {}",
                b.entity_tag
            );
        }
    }
    let bad = invalid_quads(&input, &output);
    assert!(bad.is_empty(), "{name}: invalid quads {bad:?}");
    check_invariants(&input, &output).unwrap_or_else(|e| panic!("{name}: {e}"));
    // Physical groups, names and entities kept.
    assert_eq!(physicals(&input), physicals(&output), "{name}: entities");
    assert_eq!(names(&input), names(&output), "{name}: physical names");
    // Every node tag kept; nodes of curves and points (and unused ones) not moved.
    let (ci, co) = (coords(&input), coords(&output));
    let used: BTreeSet<u64> = faces(&input).into_iter().flatten().collect();
    for b in &input.node_blocks {
        for (t, c) in b.tags.iter().zip(&b.coords) {
            let o = co.get(t).unwrap_or_else(|| panic!("{name}: node {t} lost"));
            if b.entity_dim <= 1 || !used.contains(t) {
                assert_eq!(o, c, "{name}: node {t} moved");
            }
        }
    }
    assert!(ci.len() <= co.len());
    // Point and curve elements kept with their tags, nodes and entities; a line the fallback
    // split at a new node M keeps its tag for the half (A, M) and has a half (M, B) beside it.
    let (ei, eo) = (elements(&input), elements(&output));
    for (t, e) in ei.iter().filter(|(_, e)| e.0 < 2) {
        let o = eo
            .get(t)
            .unwrap_or_else(|| panic!("{name}: element {t} lost"));
        if o == e {
            continue;
        }
        let (a, b, m) = (e.3[0], e.3[1], o.3[1]);
        let split = e.2 == etype::LINE2
            && (o.0, o.1, o.2, o.3[0]) == (e.0, e.1, e.2, a)
            && !ci.contains_key(&m)
            && eo
                .values()
                .any(|x| (x.0, x.1, x.2) == (e.0, e.1, e.2) && x.3 == [m, b]);
        assert!(split, "{name}: element {t} was {e:?}, is {o:?}");
    }
    Run {
        input,
        output,
        out_path,
    }
}

/// Faces per surface entity tag.
fn faces_by_surface(m: &Mesh) -> BTreeMap<i32, Vec<Vec<u64>>> {
    let mut out: BTreeMap<i32, Vec<Vec<u64>>> = BTreeMap::new();
    for b in &m.element_blocks {
        if b.entity_dim == 2 && element_dim(b.element_type) == Some(2) && !b.is_empty() {
            let v = out.entry(b.entity_tag).or_default();
            v.extend((0..b.len()).map(|i| b.element(i).to_vec()));
        }
    }
    out
}

/// `blossomquad FIXTURE -o OUT EXTRA...`: exits 1 with exactly one non-empty stderr line,
/// which names the file and contains every one of `words`; writes nothing.
fn refused(dir: &Path, name: &str, extra: &[&str], words: &[&str]) -> String {
    let out = dir.join(format!("refused-{name}"));
    let input = quirk(name);
    let (code, _, stderr) = blossomquad_run(
        [input.as_os_str(), "-o".as_ref(), out.as_os_str()]
            .into_iter()
            .chain(extra.iter().map(|s| s.as_ref())),
    );
    assert_eq!(code, Some(1), "{name}: {stderr}");
    assert!(!out.exists(), "{name}: output written");
    let lines: Vec<&str> = stderr.lines().filter(|l| !l.trim().is_empty()).collect();
    assert_eq!(lines.len(), 1, "{name}: one error line expected: {stderr}");
    assert!(lines[0].contains(name), "{name}: file not named: {stderr}");
    for w in words {
        assert!(lines[0].contains(w), "{name}: no {w:?} in {stderr}");
    }
    lines[0].to_string()
}

/// Gmsh's 4-node tetrahedron.
const TET4: u32 = 4;

const V22: MshVersion = MshVersion::V2 { minor: 2 };

#[test]
fn msh_2_0_8_closed_sphere_with_three_tags_and_an_unused_centre_node() {
    let name = "v20_sphere_three_tags.msh";
    let bytes = std::fs::read(quirk(name)).unwrap_or_else(|e| panic!("{e}"));
    assert!(bytes.starts_with(b"$MeshFormat\n2 0 8\n"));
    let m = read(&quirk(name));
    assert_eq!(
        m.format.map(|f| f.version),
        Some(MshVersion::V2 { minor: 0 })
    );
    assert_eq!(count(&m, etype::TRI3), 32);
    assert_eq!(faces_by_surface(&m).len(), 8);
    assert!(
        physicals(&m).iter().all(|(_, _, p)| p.is_empty()),
        "phys 0 = none"
    );
    // Node 1, the centre, is in no element.
    assert!(!elements(&m).values().any(|e| e.3.contains(&1)));
    assert_eq!(coords(&m)[&1], [0.0; 3]);
    let f = faces(&m);
    assert!(closed_and_oriented(&f) && euler(&f) == 2);

    let dir = tempfile::tempdir().expect("temp dir");
    let run = recombine_ok(dir.path(), name, &[], V22);
    assert_eq!(count(&run.output, etype::QUAD4), 16);
    assert_eq!(coords(&run.output)[&1], [0.0; 3], "unused centre node kept");
    let f = faces(&run.output);
    assert!(closed_and_oriented(&f), "the quads still close the sphere");
    assert_eq!(euler(&f), 2);
}

#[test]
fn msh_2_0_comments_one_tag_descending_ids_quads_only() {
    let name = "v20_comments_one_tag_quads.msh";
    let m = read(&quirk(name));
    assert_eq!(
        m.format.map(|f| f.version),
        Some(MshVersion::V2 { minor: 0 })
    );
    let comments: Vec<_> = m
        .raw_sections
        .iter()
        .filter(|r| r.name == "Comments")
        .collect();
    assert_eq!(comments.len(), 2);
    assert_eq!(comments[0].position, SectionPosition::BeforeFormat);
    let b = &m.element_blocks[0];
    assert_eq!(
        b.tags,
        vec![6, 5, 4, 3, 2, 1],
        "descending ids kept in order"
    );
    assert_eq!(
        m.entity(2, b.entity_tag).map(|e| e.physical_tags.clone()),
        Some(vec![7])
    );
    assert_eq!(count(&m, etype::QUAD4), 6);

    let dir = tempfile::tempdir().expect("temp dir");
    let run = recombine_ok(dir.path(), name, &[], V22);
    let quads = |m: &Mesh| elements(m);
    assert_eq!(
        quads(&run.output),
        quads(&run.input),
        "quads kept as they were"
    );
    let text = std::fs::read(&run.out_path).unwrap_or_else(|e| panic!("{e}"));
    assert!(
        text.starts_with(b"$Comments\n"),
        "comments before $MeshFormat stay first"
    );
}

#[test]
fn msh_2_1_broken_file_is_refused_in_one_line() {
    let name = "v21_extra_node_broken.msh";
    // Read alone: the first element line (line 20) has one field too many.
    let e = msh::read_file(&quirk(name)).unwrap_err();
    assert_eq!(e.location, msh::Location::Line(20), "{e}");
    let dir = tempfile::tempdir().expect("temp dir");
    let line = refused(dir.path(), name, &[], &["$Elements", "line 20", "too many"]);
    assert!(line.starts_with("blossomquad: error: "), "{line}");
}

#[test]
fn crlf_trailing_spaces_three_digit_exponents_no_final_newline() {
    let name = "v41_crlf_trailing_spaces.msh";
    let bytes = std::fs::read(quirk(name)).unwrap_or_else(|e| panic!("{e}"));
    let text = String::from_utf8(bytes).unwrap_or_else(|e| panic!("{e}"));
    // The file is what it claims (a checkout that rewrote line endings would break it).
    assert_eq!(text.matches('\n').count(), text.matches("\r\n").count());
    assert!(text.contains(" \r\n") && text.contains("1.000e+000 0.0e-007 0 \r\n"));
    assert!(text.ends_with("$EndElements"), "no final newline");
    let m = read(&quirk(name));
    let lf = msh::read_bytes(
        text.replace("\r\n", "\n").replace(" \n", "\n").as_bytes(),
        "lf",
    )
    .unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(coords(&m), coords(&lf));
    assert_eq!(elements(&m), elements(&lf));
    assert_eq!(coords(&m)[&2], [1.0, 0.0, 0.0]);
    assert_eq!(coords(&m)[&8], [3.0, 1.0, 0.0]);

    let dir = tempfile::tempdir().expect("temp dir");
    let run = recombine_ok(dir.path(), name, &[], MshVersion::V41);
    assert_eq!(count(&run.output, etype::QUAD4), 6);
}

#[test]
fn msh_4_0_layout_sparse_node_tags_random_element_tags_unnamed_groups() {
    let name = "v40_sparse_tags.msh";
    let m = read(&quirk(name));
    assert_eq!(m.format.map(|f| f.version), Some(MshVersion::V40));
    assert_eq!(m.node_count(), 15);
    assert_eq!(m.max_node_tag(), 49, "tags with gaps");
    let e = elements(&m);
    let tri_tags: Vec<u64> = m
        .element_blocks
        .iter()
        .filter(|b| b.element_type == etype::TRI3)
        .flat_map(|b| b.tags.clone())
        .collect();
    assert_eq!(tri_tags.len(), 16);
    assert!(
        tri_tags.windows(2).any(|w| w[0] > w[1]),
        "triangle tags unsorted"
    );
    assert_eq!(e.len(), 32);
    // Points 1-2 in group 1 and curves 1-2 in group 2: no names; names with spaces kept.
    assert_eq!(
        m.entity(0, 1).map(|e| e.physical_tags.clone()),
        Some(vec![1])
    );
    assert_eq!(
        m.entity(1, 2).map(|e| e.physical_tags.clone()),
        Some(vec![2])
    );
    assert_eq!(m.physical_name(1, 2), None);
    assert_eq!(m.physical_name(1, 5), Some("left edge (inlet)"));
    assert_eq!(
        m.entity(2, 1).map(|e| e.bbox),
        Some([0.0, 0.0, 0.0, 2.0, 0.8, 0.0])
    );

    let dir = tempfile::tempdir().expect("temp dir");
    let run = recombine_ok(dir.path(), name, &[], MshVersion::V41);
    assert_eq!(count(&run.output, etype::QUAD4), 8);
    assert_eq!(run.output.physical_name(2, 6), Some("the plate"));
}

#[test]
fn only_physical_entities_saved_curve_in_two_groups_unordered_tags() {
    let name = "v41_partial_boundary.msh";
    let m = read(&quirk(name));
    let with_lines: BTreeSet<i32> = m
        .element_blocks
        .iter()
        .filter(|b| b.element_type == etype::LINE2)
        .map(|b| b.entity_tag)
        .collect();
    assert_eq!(
        with_lines,
        BTreeSet::from([3]),
        "only curve 3 has line elements"
    );
    assert_eq!(m.entities[1].len(), 4);
    assert_eq!(
        m.entity(1, 3).map(|e| e.physical_tags.clone()),
        Some(vec![6, 7])
    );
    let order = node_tags_in_file_order(&m);
    let mut sorted = order.clone();
    sorted.sort_unstable();
    assert_ne!(order, sorted, "node tags not in file order");
    assert_eq!(sorted, (1..=16).collect::<Vec<u64>>(), "but contiguous");
    let tags: Vec<u64> = elements(&m).keys().copied().collect();
    assert_eq!(&tags[..4], &[1, 2, 3, 40], "element tags jump");

    let dir = tempfile::tempdir().expect("temp dir");
    let run = recombine_ok(dir.path(), name, &[], MshVersion::V41);
    assert_eq!(count(&run.output, etype::QUAD4), 9);
    assert_eq!(count(&run.output, etype::LINE2), 3);
    // The boundary edges without line elements are still the boundary.
    let boundary = |m: &Mesh| -> BTreeSet<(u64, u64)> {
        let d = directed_edges(&faces(m));
        d.keys()
            .filter(|&&(a, b)| !d.contains_key(&(b, a)))
            .copied()
            .collect()
    };
    assert_eq!(boundary(&run.input), boundary(&run.output));
}

#[test]
fn mixed_triangles_and_quads_with_one_physical_tag_in_two_dimensions() {
    let name = "v22_mixed_same_phys_tag.msh";
    let bytes = std::fs::read(quirk(name)).unwrap_or_else(|e| panic!("{e}"));
    assert!(bytes.ends_with(b"$EndElements"), "no final newline");
    let m = read(&quirk(name));
    assert_eq!(m.physical_name(1, 1), Some("no slip wall"));
    assert_eq!(m.physical_name(2, 1), Some("fluid domain"));
    assert_eq!((count(&m, etype::TRI3), count(&m, etype::QUAD4)), (8, 4));
    assert_eq!(
        m.entity(2, 25).map(|e| e.physical_tags.clone()),
        Some(vec![1])
    );

    let dir = tempfile::tempdir().expect("temp dir");
    let run = recombine_ok(dir.path(), name, &[], V22);
    assert_eq!(count(&run.output, etype::QUAD4), 8);
    // The input's quads are kept (tags and nodes); the triangles became the other four.
    let eo = elements(&run.output);
    for (t, e) in elements(&run.input)
        .iter()
        .filter(|e| e.1 .2 == etype::QUAD4)
    {
        assert_eq!(eo.get(t), Some(e), "quad {t}");
    }
}

#[test]
fn clockwise_triangles_large_coordinates_noise_around_zero_no_names() {
    let name = "v22_clockwise_channel.msh";
    let m = read(&quirk(name));
    let c = coords(&m);
    assert!(
        faces(&m).iter().all(|f| area_z(&c, f) < 0.0),
        "all clockwise"
    );
    assert_eq!(c[&2], [20000.0, 6.6e-10, 0.0]);
    assert!(m.physical_names.is_empty());
    assert_eq!(
        m.entity(2, 1).map(|e| e.physical_tags.clone()),
        Some(vec![11])
    );

    let dir = tempfile::tempdir().expect("temp dir");
    let run = recombine_ok(dir.path(), name, &[], V22);
    let c = coords(&run.output);
    let f = faces(&run.output);
    assert_eq!(f.len(), 10);
    assert!(f.iter().all(|q| area_z(&c, q) < 0.0), "quads clockwise too");
    assert!(run.output.physical_names.is_empty(), "no names invented");
}

#[test]
fn no_physical_groups_hole_utm_coordinates_trailing_spaces() {
    let name = "v41_no_physicals_hole.msh";
    let text = std::fs::read_to_string(quirk(name)).unwrap_or_else(|e| panic!("{e}"));
    assert!(text.contains(" \n"));
    let m = read(&quirk(name));
    assert!(physicals(&m).iter().all(|(_, _, p)| p.is_empty()));
    assert_eq!(euler(&faces(&m)), 0, "one hole");
    assert!(coords(&m).values().all(|p| p[0] > 3.5e5 && p[1] > 9.8e4));

    let dir = tempfile::tempdir().expect("temp dir");
    let run = recombine_ok(dir.path(), name, &[], MshVersion::V41);
    let f = faces(&run.output);
    assert_eq!(f.len(), 12);
    assert_eq!(euler(&f), 0);
    let c = coords(&run.output);
    assert!(f.iter().all(|q| area_z(&c, q) < 0.0), "clockwise kept");
    assert!(physicals(&run.output).iter().all(|(_, _, p)| p.is_empty()));
}

#[test]
fn closed_cube_of_six_faces_without_feature_lines() {
    let name = "v22_cube_faces_no_lines.msh";
    let m = read(&quirk(name));
    assert_eq!(count(&m, etype::LINE2), 0);
    let phys: Vec<Vec<i32>> = (1..=6)
        .map(|s| {
            m.entity(2, s)
                .map(|e| e.physical_tags.clone())
                .unwrap_or_default()
        })
        .collect();
    assert_eq!(phys, (1..=6).map(|p| vec![p]).collect::<Vec<_>>());

    let dir = tempfile::tempdir().expect("temp dir");
    let run = recombine_ok(dir.path(), name, &[], V22);
    let f = faces(&run.output);
    assert_eq!(f.len(), 24);
    assert!(
        closed_and_oriented(&f) && euler(&f) == 2,
        "still a closed cube"
    );
    // No quad is folded over an edge of the cube: each lies in its face's plane.
    let c = coords(&run.output);
    for (s, quads) in faces_by_surface(&run.output) {
        for q in quads {
            let flat = (0..3).any(|k| {
                let v: Vec<f64> = q.iter().map(|t| c[t][k]).collect();
                v.iter().all(|x| *x == v[0] && (*x == 0.0 || *x == 1.0))
            });
            assert!(flat, "surface {s}: quad {q:?} leaves its face");
        }
    }
}

#[test]
fn tets_are_refused_plainly_and_dropped_on_request() {
    let dir = tempfile::tempdir().expect("temp dir");
    for (name, version) in [
        ("v41_tets_closed_surface.msh", MshVersion::V41),
        ("v20_tets_mixed_orientation.msh", V22),
    ] {
        let m = read(&quirk(name));
        assert_eq!(count(&m, TET4), 48, "{name}");
        assert_eq!(count(&m, etype::TRI3), 48, "{name}");
        refused(dir.path(), name, &[], &["48 volume elements", "drop"]);
        let run = recombine_ok(dir.path(), name, &["--drop-volumes"], version);
        assert_eq!(count(&run.output, TET4), 0, "{name}");
        assert_eq!(count(&run.output, etype::QUAD4), 24, "{name}");
        assert_eq!(euler(&faces(&run.output)), 2, "{name}");
    }
    // The 4.1 file saved only its physical entities, with tags not starting at 1.
    let m = read(&quirk("v41_tets_closed_surface.msh"));
    let tags = |d: usize| m.entities[d].iter().map(|e| e.tag).min();
    assert_eq!(
        [tags(0), tags(1), tags(2), tags(3)],
        [Some(9), Some(13), Some(7), Some(3)]
    );
    assert_eq!(count(&m, etype::LINE2) + count(&m, etype::POINT), 0);
    assert!(closed_and_oriented(&faces(&m)));
    // The FreeFem-like file: face z = 0 points out of the cube, the other five in; each
    // surface keeps its own orientation.
    let run = recombine_ok(
        dir.path(),
        "v20_tets_mixed_orientation.msh",
        &["--drop-volumes"],
        V22,
    );
    let c = coords(&run.output);
    for (s, quads) in faces_by_surface(&run.output) {
        for q in quads {
            let centre: Vec<f64> = (0..3)
                .map(|k| q.iter().map(|t| c[t][k]).sum::<f64>() / 4.0)
                .collect();
            // Normal by Newell's method, dotted with the direction away from the cube centre.
            let mut n = [0.0; 3];
            for i in 0..4 {
                let (a, b) = (c[&q[i]], c[&q[(i + 1) % 4]]);
                n[0] += (a[1] - b[1]) * (a[2] + b[2]);
                n[1] += (a[2] - b[2]) * (a[0] + b[0]);
                n[2] += (a[0] - b[0]) * (a[1] + b[1]);
            }
            let out: f64 = (0..3).map(|k| n[k] * (centre[k] - 0.5)).sum();
            let z0 = centre[2] == 0.0;
            assert!(
                (out > 0.0) == z0,
                "surface {s}: quad {q:?} orientation changed"
            );
        }
    }
}

#[test]
fn l_shape_with_surface_tag_6_in_two_groups_and_point_tags_from_2() {
    let name = "v41_lshape_surface_tag_6.msh";
    let m = read(&quirk(name));
    assert_eq!(m.entities[2].len(), 1);
    assert_eq!(m.entities[2][0].tag, 6);
    assert_eq!(m.entities[2][0].physical_tags, vec![111, 112]);
    assert_eq!(m.entities[0].iter().map(|e| e.tag).min(), Some(2));
    assert!(m.physical_names.is_empty());

    let dir = tempfile::tempdir().expect("temp dir");
    let run = recombine_ok(dir.path(), name, &[], MshVersion::V41);
    let by = faces_by_surface(&run.output);
    assert_eq!(by.keys().copied().collect::<Vec<_>>(), vec![6]);
    assert_eq!(by[&6].len(), 12);
    // The quads cover the L (area 3 x 0.25 x 4 = 3), not its convex hull: nothing spans the
    // re-entrant corner, which is still a node of the mesh.
    let c = coords(&run.output);
    let area: f64 = by[&6].iter().map(|q| area_z(&c, q).abs() / 2.0).sum();
    assert!((area - 3.0).abs() < 1e-12, "area {area}");
    assert!(
        c.values().any(|p| *p == [1.0, 1.0, 0.0]),
        "re-entrant corner lost"
    );
}

#[test]
fn square_in_square_interface_curve_large_tags_tiny_coordinates() {
    let name = "v22_square_in_square.msh";
    let m = read(&quirk(name));
    let c = coords(&m);
    assert!(c.values().any(|p| p[0] == 2.5e-12) && c.values().any(|p| p[1] == -2.5e-12));
    assert_eq!(
        m.entity(1, 5).map(|e| e.physical_tags.clone()),
        Some(vec![10000])
    );
    assert!(m.physical_names.is_empty());

    let dir = tempfile::tempdir().expect("temp dir");
    let run = recombine_ok(dir.path(), name, &[], V22);
    let by = faces_by_surface(&run.output);
    assert_eq!((by[&1].len(), by[&2].len()), (12, 4));
    // Inner quads stay inside the interface square, outer ones outside it.
    let c = coords(&run.output);
    let inside = |q: &Vec<u64>| {
        q.iter()
            .all(|t| c[t][0].abs() <= 0.5 && c[t][1].abs() <= 0.5)
    };
    assert!(by[&2].iter().all(inside));
    assert!(!by[&1].iter().any(inside));
}

#[test]
fn thin_spikes_each_its_own_surface_and_named_group() {
    let name = "v22_compass_thin_spikes.msh";
    let m = read(&quirk(name));
    assert_eq!(m.physical_names.len(), 17);
    assert_eq!(m.physical_name(2, 9), Some("north first half"));
    // Curves: elementary tags 17..24, physical 1..8.
    let curves: Vec<(i32, Vec<i32>)> = m.entities[1]
        .iter()
        .map(|e| (e.tag, e.physical_tags.clone()))
        .collect();
    assert_eq!(
        curves,
        (1..=8).map(|p| (16 + p, vec![p])).collect::<Vec<_>>()
    );
    // Eight one-triangle surfaces with a corner under 10 degrees, one surface of 4 quads.
    let by = faces_by_surface(&m);
    assert_eq!(by.len(), 9);
    assert_eq!(by.values().filter(|f| f.len() == 1).count(), 8);
    let c = coords(&m);
    let min_angle = by
        .values()
        .flatten()
        .filter(|f| f.len() == 3)
        .flat_map(|f| {
            (0..3).map(|i| {
                let (a, b, d) = (c[&f[i]], c[&f[(i + 1) % 3]], c[&f[(i + 2) % 3]]);
                let (u, v) = ([b[0] - a[0], b[1] - a[1]], [d[0] - a[0], d[1] - a[1]]);
                let cos = (u[0] * v[0] + u[1] * v[1]) / (u[0].hypot(u[1]) * v[0].hypot(v[1]));
                cos.acos().to_degrees()
            })
        })
        .fold(f64::INFINITY, f64::min);
    assert!(min_angle < 10.0, "{min_angle}");

    let dir = tempfile::tempdir().expect("temp dir");
    let run = recombine_ok(dir.path(), name, &[], V22);
    let by = faces_by_surface(&run.output);
    assert_eq!(by.len(), 9, "every surface still has its quads");
    assert_eq!(names(&run.output).len(), 17);
    // the summary counts the eight surfaces with triangles, though the fallback split
    // every one of their triangles (no surface is matched in the last round)
    let out = dir.path().join("summary.msh");
    let (code, _, stderr) =
        blossomquad_run([quirk(name).as_os_str(), "-o".as_ref(), out.as_os_str()]);
    assert_eq!(code, Some(0), "{stderr}");
    assert!(
        stderr.starts_with("8 surfaces, 8 triangles -> "),
        "{stderr}"
    );
}

/// Gmsh's mesh of a very sharp OpenCASCADE cone (apex half-angle 2.9 degrees, meshed by
/// the old `corpus/cone_sharp.geo`): along the cone's seam it repeats triangles (a triangle
/// and its reverse: dropped with a warning) and folds triangles over their neighbours, so
/// no quad there could be oriented like the surface. The folds are walled off first (no
/// quad across them); that cannot give valid quads here, so the file is refused in one line
/// naming the surface, the element and the first fold, as the topology names it.
#[test]
fn sharp_occ_cone_folded_along_its_seam_is_refused_naming_the_fold() {
    let name = "v41_occ_sharp_cone_folded.msh";
    let m = read(&quirk(name));
    let by = faces_by_surface(&m);
    let cone = &by[&1];
    // The quirk: repeated triangles (same three nodes) and a fold (two triangles across an
    // edge, consistently oriented, with opposite normals).
    let mut seen = BTreeMap::new();
    for f in cone {
        let mut k = f.clone();
        k.sort_unstable();
        *seen.entry(k).or_insert(0) += 1;
    }
    assert!(seen.values().filter(|&&n| n > 1).count() >= 10);
    let c = coords(&m);
    let normal = |f: &[u64]| {
        let (a, b, d) = (c[&f[0]], c[&f[1]], c[&f[2]]);
        let (u, v) = (
            [b[0] - a[0], b[1] - a[1], b[2] - a[2]],
            [d[0] - a[0], d[1] - a[1], d[2] - a[2]],
        );
        let n = [
            u[1] * v[2] - u[2] * v[1],
            u[2] * v[0] - u[0] * v[2],
            u[0] * v[1] - u[1] * v[0],
        ];
        let l = (n[0] * n[0] + n[1] * n[1] + n[2] * n[2]).sqrt();
        n.map(|x| x / l)
    };
    let elements = elements(&m);
    let tri = |tag: u64| elements[&tag].3.clone();
    let (t61, t286) = (tri(61), tri(286));
    assert!(t61.contains(&23) && t61.contains(&91) && t286.contains(&23) && t286.contains(&91));
    let (n61, n286) = (normal(&t61), normal(&t286));
    assert!(n61[0] * n286[0] + n61[1] * n286[1] + n61[2] * n286[2] < -0.99);

    let dir = tempfile::tempdir().expect("temp dir");
    refused(
        dir.path(),
        name,
        &[],
        &[
            "surface 1",
            "element 61",
            "folded over triangle 286",
            "23-91",
        ],
    );
}

#[test]
fn cubic_elements_and_affine_periodic_refused_clearly_converted_intact() {
    let name = "v22_cubic_periodic_affine.msh";
    let m = read(&quirk(name));
    assert_eq!(count(&m, 21), 1);
    assert_eq!(count(&m, 26), 3);
    assert_eq!(m.periodic.len(), 1);
    assert_eq!(m.periodic[0].affine.as_ref().map(Vec::len), Some(16));
    assert_eq!(m.periodic[0].node_pairs, vec![(3, 1), (8, 5)]);
    let dir = tempfile::tempdir().expect("temp dir");
    refused(dir.path(), name, &[], &["type 21"]);
    // `convert` keeps what it cannot recombine.
    let out = dir.path().join("converted.msh");
    let input = quirk(name);
    let (code, _, stderr) = blossomquad_run([
        "convert".as_ref(),
        input.as_os_str(),
        "-o".as_ref(),
        out.as_os_str(),
    ]);
    assert_eq!(code, Some(0), "{stderr}");
    let back = read(&out);
    assert_eq!(elements(&back), elements(&m));
    assert_eq!(back.periodic, m.periodic);
}

/// Gmsh loads what the tool wrote from every fixture it recombines.
#[test]
fn gmsh_loads_every_output() {
    if !gmsh_gate::require_gmsh() {
        return;
    }
    let dir = tempfile::tempdir().expect("temp dir");
    let ok = [
        ("v20_sphere_three_tags.msh", &[][..], V22),
        ("v20_comments_one_tag_quads.msh", &[][..], V22),
        ("v41_crlf_trailing_spaces.msh", &[][..], MshVersion::V41),
        ("v40_sparse_tags.msh", &[][..], MshVersion::V41),
        ("v41_partial_boundary.msh", &[][..], MshVersion::V41),
        ("v22_mixed_same_phys_tag.msh", &[][..], V22),
        ("v22_clockwise_channel.msh", &[][..], V22),
        ("v41_no_physicals_hole.msh", &[][..], MshVersion::V41),
        ("v22_cube_faces_no_lines.msh", &[][..], V22),
        (
            "v41_tets_closed_surface.msh",
            &["--drop-volumes"][..],
            MshVersion::V41,
        ),
        (
            "v20_tets_mixed_orientation.msh",
            &["--drop-volumes"][..],
            V22,
        ),
        ("v41_lshape_surface_tag_6.msh", &[][..], MshVersion::V41),
        ("v22_square_in_square.msh", &[][..], V22),
        ("v22_compass_thin_spikes.msh", &[][..], V22),
    ];
    for (name, extra, version) in ok {
        let run = recombine_ok(dir.path(), name, extra, version);
        common::gmsh_loads(&run.out_path).unwrap_or_else(|e| panic!("{name}: {e}"));
    }
}

/// Every fixture of the folder has a test above and a row in its README.
#[test]
fn every_fixture_is_tested_and_listed() {
    let dir = repo_dir().join("tests/data/quirks");
    let readme = std::fs::read_to_string(dir.join("README.md")).unwrap_or_else(|e| panic!("{e}"));
    let this = std::fs::read_to_string(repo_dir().join("tests/e2e/quirks.rs"))
        .unwrap_or_else(|e| panic!("{e}"));
    let files = common::msh_files(&dir);
    assert_eq!(files.len(), 17, "{files:?}");
    for f in files {
        let name = common::file_name(&f);
        assert!(
            readme.contains(&format!("`{name}`")),
            "{name} not in README.md"
        );
        assert!(
            this.matches(&format!("\"{name}\"")).count() >= 1,
            "{name} not tested"
        );
    }
}
