//! Gmsh agrees with our files: every corpus file written in all four variants loads in Gmsh
//! (`gmsh OUT -0 -o CHECK.msh`, and the gmsh Python module sees the same numbers of nodes,
//! elements per type, entities and physical groups), and meshes Gmsh writes in all four
//! variants (binary included) read consistently. Gmsh is required (see `gmsh_gate`).

use crate::gmsh_gate;
use crate::msh_common;

use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};
use std::process::Command;

use blossomquad::mesh::{Mesh, MshFormat, MshVersion};
use blossomquad::msh;
use gmsh_gate::require_gmsh;
use msh_common::*;

#[derive(Debug, PartialEq)]
struct Seen {
    nodes: usize,
    types: BTreeMap<u32, usize>,
    entities: [usize; 4],
    groups: BTreeSet<(i32, i32)>,
}

/// Runs tests/gmsh_counts.py on `files`; one `Seen` per file.
fn gmsh_python_counts(files: &[PathBuf]) -> Vec<Seen> {
    let script = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/gmsh_counts.py");
    let out = Command::new("python3")
        .arg(script)
        .args(files)
        .output()
        .expect("python3 runs");
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let text = String::from_utf8(out.stdout).unwrap();
    text.lines()
        .map(|l| {
            assert!(l.contains("\"error\": null"), "gmsh python: {l}");
            parse_seen(l)
        })
        .collect()
}

/// Minimal parse of the script's JSON line (fixed layout written by json.dumps).
fn parse_seen(l: &str) -> Seen {
    let field = |k: &str| -> &str {
        let i = l
            .find(&format!("\"{k}\": "))
            .unwrap_or_else(|| panic!("{k} in {l}"))
            + k.len()
            + 4;
        &l[i..]
    };
    let nodes: usize = field("nodes")
        .split([',', '}'])
        .next()
        .unwrap()
        .trim()
        .parse()
        .unwrap();
    let t = field("types");
    let t = &t[1..t.find('}').unwrap()];
    let mut types = BTreeMap::new();
    for kv in t.split(", ").filter(|s| !s.is_empty()) {
        let (k, v) = kv.split_once(": ").unwrap();
        types.insert(k.trim_matches('"').parse().unwrap(), v.parse().unwrap());
    }
    let e = field("entities");
    let e: Vec<usize> = e[1..e.find(']').unwrap()]
        .split(", ")
        .map(|x| x.parse().unwrap())
        .collect();
    let g = field("groups");
    let g = &g[1..g.find("]]").map_or(1, |i| i + 1)];
    let mut groups = BTreeSet::new();
    for pair in g.split("], [") {
        let pair = pair.trim_matches(['[', ']']);
        if let Some((a, b)) = pair.split_once(", ") {
            groups.insert((a.parse().unwrap(), b.parse().unwrap()));
        }
    }
    Seen {
        nodes,
        types,
        entities: [e[0], e[1], e[2], e[3]],
        groups,
    }
}

/// What Gmsh should see in `m` written as 4.1 (`v41`) or 2.2 (elements once per group).
fn expected(m: &Mesh, v41: bool) -> Seen {
    let mut types = BTreeMap::new();
    for b in &m.element_blocks {
        let copies = if v41 {
            1
        } else {
            m.entity(b.entity_dim, b.entity_tag)
                .map_or(1, |e| e.physical_tags.len().max(1))
        };
        *types.entry(b.element_type).or_insert(0) += b.len() * copies;
    }
    let groups = if v41 {
        m.entities
            .iter()
            .flatten()
            .flat_map(|e| e.physical_tags.iter().map(move |&p| (e.dim, p)))
            .collect()
    } else {
        groups_with_elements(m)
    };
    Seen {
        nodes: m.node_count(),
        types,
        // MSH 2.2 has no entity section: Gmsh creates one per elementary tag of the elements.
        entities: if v41 {
            [0, 1, 2, 3].map(|d| m.entities[d].len())
        } else {
            let with: BTreeSet<(i32, i32)> = m
                .element_blocks
                .iter()
                .map(|b| (b.entity_dim, b.entity_tag))
                .collect();
            [0, 1, 2, 3].map(|d| with.iter().filter(|e| e.0 == d).count())
        },
        groups,
    }
}

#[test]
fn corpus_outputs_load_in_gmsh_with_same_counts() {
    if !require_gmsh() {
        return;
    }
    let dir = tempdir();
    let mut outs = Vec::new();
    let mut exp = Vec::new();
    for (i, path) in corpus_files().iter().enumerate() {
        let m = msh::read_file(path).unwrap();
        for (f, label) in variants() {
            let out = dir.path().join(format!("c{i}_{label}.msh"));
            msh::write_file(&m, &out, f).unwrap();
            let check = dir.path().join(format!("c{i}_{label}_check.msh"));
            gmsh(&[out.to_str().unwrap(), "-0", "-o", check.to_str().unwrap()]);
            let c = msh::read_file(&check).unwrap_or_else(|e| panic!("{e}"));
            assert!(
                c.node_count() > 0 && c.element_count() > 0,
                "{}",
                out.display()
            );
            outs.push(out);
            exp.push(expected(&m, f.version == MshVersion::V41));
        }
    }
    let seen = gmsh_python_counts(&outs);
    assert_eq!(seen.len(), outs.len());
    for ((s, e), o) in seen.into_iter().zip(exp).zip(&outs) {
        assert_eq!(s, e, "{}", o.display());
    }
}

/// Meshes `geo_text` with `gmsh -2` in variant `f`; returns the file path.
fn gmsh_mesh(dir: &Path, stem: &str, geo_text: &str, f: MshFormat, label: &str) -> PathBuf {
    let geo = dir.join(format!("{stem}.geo"));
    std::fs::write(&geo, geo_text).unwrap();
    let out = dir.join(format!("{stem}_{label}.msh"));
    let fmt = if f.version == MshVersion::V41 {
        "msh41"
    } else {
        "msh22"
    };
    let mut args = vec![
        geo.to_str().unwrap(),
        "-2",
        "-format",
        fmt,
        "-o",
        out.to_str().unwrap(),
    ];
    if f.binary {
        args.push("-bin");
    }
    gmsh(&args);
    out
}

const GEO: &str = r#"SetFactory("OpenCASCADE");
Rectangle(1) = {0, 0, 0, 1, 1};
Rectangle(2) = {1, 0, 0, 1, 1};
BooleanFragments{ Surface{1}; Delete; }{ Surface{2}; Delete; }
Physical Surface("left") = {1};
Physical Surface("all") = {1, 2};
Physical Surface(7) = {1};
Physical Curve("bottom") = {1, 5};
Mesh.MeshSizeMax = 0.2;
"#;

#[test]
fn gmsh_written_meshes_read_in_all_four_variants() {
    if !require_gmsh() {
        return;
    }
    let dir = tempdir();
    let mut meshes = Vec::new();
    for (f, label) in variants() {
        let out = gmsh_mesh(dir.path(), "two", GEO, f, label);
        let m = msh::read_file(&out).unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(m.format.unwrap().binary, f.binary, "{label}");
        meshes.push((label, m));
    }
    let (_, base) = &meshes[0];
    let tri = |m: &Mesh| -> usize { m.count_elements(2) };
    assert!(tri(base) > 20);
    for (label, m) in &meshes[1..] {
        assert_eq!(m.node_count(), base.node_count(), "{label}");
        assert_eq!(
            tri(m),
            tri(base),
            "{label}: duplicated per-group triangles merged"
        );
        assert_eq!(
            groups_with_elements(m),
            groups_with_elements(base),
            "{label}"
        );
        assert_eq!(names(m), names(base), "{label}");
    }
    // Binary and ASCII of the same version: identical elements; coordinates equal to
    // Gmsh's ASCII precision.
    for (a, b) in [(0, 1), (2, 3)] {
        assert_eq!(elements(&meshes[a].1), elements(&meshes[b].1));
        let (na, nb) = (nodes(&meshes[a].1), nodes(&meshes[b].1));
        for (t, c) in &na {
            let d = nb[t];
            for k in 0..3 {
                assert!((f64::from_bits(c[k]) - f64::from_bits(d[k])).abs() < 1e-14);
            }
        }
    }
    // Entities derived from the 2.2 files: each surface is bounded by the curve of the
    // "bottom" group that carries line elements along its edge.
    for (label, m) in &meshes[2..] {
        for (s, c) in [(1, 1), (2, 5)] {
            let e = m.entity(2, s).unwrap();
            assert!(e.bounding.iter().any(|b| b.abs() == c), "{label}: {e:?}");
        }
    }
    // The 2.2 binary file holds surface 1's triangles three times (groups left, all, 7).
    let m22b = &meshes[3].1;
    assert!(m22b.warnings.iter().any(|w| w.contains("merged")));
    let s1 = m22b.entities[2].iter().find(|e| e.tag == 1).unwrap();
    let mut p = s1.physical_tags.clone();
    p.sort_unstable();
    assert_eq!(p.len(), 3);
    // Written back as binary 2.2 the copies come back, and Gmsh sees as many as it wrote.
    let back = dir.path().join("back22b.msh");
    msh::write_file(m22b, &back, variants()[3].0).unwrap();
    let orig = gmsh_python_counts(&[dir.path().join("two_22b.msh"), back.clone()]);
    assert_eq!(orig[0].types, orig[1].types);
    assert_eq!(orig[0].groups, orig[1].groups);
}

const PERIODIC_GEO: &str =
    "Point(1) = {0, 0, 0}; Point(2) = {1, 0, 0}; Point(3) = {1, 1, 0}; Point(4) = {0, 1, 0};
Line(1) = {1, 2}; Line(2) = {2, 3}; Line(3) = {4, 3}; Line(4) = {1, 4};
Curve Loop(1) = {1, 2, -3, -4}; Plane Surface(1) = {1};
Periodic Curve{3} = {1} Translate{0, 1, 0};
Mesh.MeshSizeMax = 0.25;
";

#[test]
fn periodic_links_survive_every_variant() {
    if !require_gmsh() {
        return;
    }
    let dir = tempdir();
    let mut ours = Vec::new();
    for (f, label) in variants() {
        let src = gmsh_mesh(dir.path(), "per", PERIODIC_GEO, f, label);
        let m = msh::read_file(&src).unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(m.periodic.len(), 3, "{label}");
        let curve = m.periodic.iter().find(|l| l.dim == 1).unwrap();
        assert_eq!((curve.tag, curve.master_tag), (3, 1));
        assert!(curve.node_pairs.len() >= 3);
        assert_eq!(curve.affine.as_ref().map(Vec::len), Some(16), "{label}");
        for (g, l2) in variants() {
            let out = dir.path().join(format!("per_{label}_to_{l2}.msh"));
            msh::write_file(&m, &out, g).unwrap();
            let back = msh::read_file(&out).unwrap();
            assert_eq!(back.periodic, m.periodic, "{label} -> {l2}");
            ours.push(out);
        }
    }
    // Gmsh loads every one of them.
    let seen = gmsh_python_counts(&ours);
    assert_eq!(seen.len(), 16);
}

#[test]
fn partitioned_meshes_are_read_and_written_unpartitioned() {
    if !require_gmsh() {
        return;
    }
    let dir = tempdir();
    let geo = dir.path().join("two.geo");
    std::fs::write(&geo, GEO).unwrap();
    let g = geo.to_str().unwrap();
    let mut sources = Vec::new();
    for (label, extra) in [
        ("p41a", vec!["-format", "msh41"]),
        (
            "p41b",
            vec![
                "-format",
                "msh41",
                "-bin",
                "-setnumber",
                "Mesh.PartitionCreateGhostCells",
                "1",
            ],
        ),
        ("p22a", vec!["-format", "msh22"]),
    ] {
        let out = dir.path().join(format!("{label}.msh"));
        let mut args = vec![g, "-2", "-part", "2", "-o", out.to_str().unwrap()];
        args.extend(extra);
        gmsh(&args);
        sources.push(out);
    }
    let mut outs = Vec::new();
    let mut exp = Vec::new();
    for src in &sources {
        let m = msh::read_file(src).unwrap_or_else(|e| panic!("{e}"));
        if m.format.unwrap().version == MshVersion::V41 {
            assert!(
                m.warnings.iter().any(|w| w.contains("partitioned mesh")),
                "{:?}",
                m.warnings
            );
        } else {
            assert!(
                m.element_blocks.iter().all(|b| b.partitions.is_some()),
                "2.2 partition tags kept"
            );
        }
        for (f, label) in variants() {
            let out = dir.path().join(format!(
                "{}_{label}.msh",
                src.file_stem().unwrap().to_string_lossy()
            ));
            msh::write_file(&m, &out, f).unwrap();
            let check = dir.path().join("check.msh");
            gmsh(&[out.to_str().unwrap(), "-0", "-o", check.to_str().unwrap()]);
            outs.push(out);
            exp.push(expected(&m, f.version == MshVersion::V41));
        }
    }
    let seen = gmsh_python_counts(&outs);
    let orig = gmsh_python_counts(&sources);
    for ((s, e), o) in seen.iter().zip(&exp).zip(&outs) {
        assert_eq!(s.nodes, e.nodes, "{}", o.display());
        assert_eq!(
            s.groups,
            orig[0].groups,
            "{}: physical groups survive",
            o.display()
        );
        if o.to_string_lossy().contains("_41") {
            assert_eq!(s.types, e.types, "{}", o.display());
        }
    }
}
