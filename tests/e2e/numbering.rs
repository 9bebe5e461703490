//! The output's numbering: by default nodes 1..N and elements 1..M without gaps, in the
//! order of the tags (what Gmsh writes and DOLFINx's reader needs), with the input → output
//! map from `--tag-map`; `--keep-tags` keeps the input's tags exactly. The map is checked
//! against the `--keep-tags` output (same mesh, tags mapped), on Gmsh's own numbering and
//! on an input with gaps. Needs Gmsh.

use crate::common;

use blossomquad::mesh::Mesh;
use common::{blossomquad_run, check_mesh, generate, recombine, tag_map_path, test_size, Variant};
use std::collections::HashMap;
use std::path::Path;

fn read(path: &Path) -> Mesh {
    blossomquad::msh::read_file(path).unwrap_or_else(|e| panic!("{e}"))
}

/// (input → output node map, same for elements) from the JSON the tool wrote.
fn read_map(path: &Path) -> (HashMap<u64, u64>, HashMap<u64, u64>) {
    let text = std::fs::read_to_string(path).unwrap_or_else(|e| panic!("{e}"));
    let v: serde_json::Value = serde_json::from_str(&text).expect("tag map is JSON");
    let pairs = |key: &str| -> HashMap<u64, u64> {
        v[key]
            .as_array()
            .unwrap_or_else(|| panic!("no {key} in the map"))
            .iter()
            .map(|p| {
                let a = p[0].as_u64().expect("tag");
                let b = p[1].as_u64().expect("tag");
                (a, b)
            })
            .collect()
    };
    (pairs("nodes"), pairs("elements"))
}

fn sorted_tags(m: &Mesh) -> (Vec<u64>, Vec<u64>) {
    let mut n: Vec<u64> = m.node_blocks.iter().flat_map(|b| b.tags.clone()).collect();
    let mut e: Vec<u64> = m
        .element_blocks
        .iter()
        .flat_map(|b| b.tags.clone())
        .collect();
    n.sort_unstable();
    e.sort_unstable();
    e.dedup();
    (n, e)
}

fn is_one_to_n(tags: &[u64]) -> bool {
    tags.iter().enumerate().all(|(i, &t)| t == i as u64 + 1)
}

/// Asserts that `renumbered` is `kept` with every tag mapped: nodes (block by block, same
/// coordinates), element node lists and element tags; input tags through `map`, the new
/// ones (absent from the map) in the order of their tags after the kept ones.
fn assert_same_mesh_renumbered(kept: &Mesh, renumbered: &Mesh, map: &Path) {
    let (nodes, elements) = read_map(map);
    let (kn, ke) = sorted_tags(kept);
    let (rn, re) = sorted_tags(renumbered);
    assert!(is_one_to_n(&rn), "node tags not 1..N");
    assert!(is_one_to_n(&re), "element tags not 1..M");
    assert_eq!(kn.len(), rn.len());
    // new tags: by rank among all tags of the --keep-tags output
    let node_new: HashMap<u64, u64> = kn
        .iter()
        .enumerate()
        .map(|(i, &t)| (t, i as u64 + 1))
        .collect();
    let elem_new: HashMap<u64, u64> = ke
        .iter()
        .enumerate()
        .map(|(i, &t)| (t, i as u64 + 1))
        .collect();
    for (a, b) in &nodes {
        assert_eq!(node_new.get(a), Some(b), "node {a}: the map says {b}");
    }
    for (a, b) in &elements {
        assert_eq!(elem_new.get(a), Some(b), "element {a}: the map says {b}");
    }
    assert_eq!(kept.node_blocks.len(), renumbered.node_blocks.len());
    for (k, r) in kept.node_blocks.iter().zip(&renumbered.node_blocks) {
        assert_eq!(k.coords, r.coords);
        let mapped: Vec<u64> = k.tags.iter().map(|t| node_new[t]).collect();
        assert_eq!(mapped, r.tags);
    }
    assert_eq!(kept.element_blocks.len(), renumbered.element_blocks.len());
    for (k, r) in kept.element_blocks.iter().zip(&renumbered.element_blocks) {
        let mapped: Vec<u64> = k.nodes.iter().map(|t| node_new[t]).collect();
        assert_eq!(mapped, r.nodes);
        let mapped: Vec<u64> = k.tags.iter().map(|t| elem_new[t]).collect();
        assert_eq!(mapped, r.tags);
    }
    assert_eq!(kept.periodic.len(), renumbered.periodic.len());
    for (k, r) in kept.periodic.iter().zip(&renumbered.periodic) {
        let mapped: Vec<(u64, u64)> = k
            .node_pairs
            .iter()
            .map(|(a, b)| (node_new[a], node_new[b]))
            .collect();
        assert_eq!(mapped, r.node_pairs);
    }
}

#[test]
fn default_output_is_numbered_without_gaps_and_keep_tags_keeps_the_input_tags() {
    let dir = tempfile::tempdir().expect("temp dir");
    for variant in [Variant::Msh41Binary, Variant::Msh22Ascii] {
        let fixture = "square_hole";
        let input = generate(fixture, variant, dir.path(), test_size(fixture), &[]);
        let default = dir.path().join(format!("default-{}.msh", variant.name()));
        let kept = dir.path().join(format!("kept-{}.msh", variant.name()));
        let (code, err) = recombine(&input, &default, &[]);
        assert_eq!(code, Some(0), "{err}");
        let (code, err) = recombine(&input, &kept, &["--keep-tags"]);
        assert_eq!(code, Some(0), "{err}");
        assert!(!tag_map_path(&kept).exists());
        let k = read(&kept);
        let (kn, ke) = sorted_tags(&k);
        // nodes were removed and triangles merged: --keep-tags leaves gaps
        assert!(!is_one_to_n(&kn) && !is_one_to_n(&ke), "no gaps to close");
        let inp = read(&input);
        let (inn, ine) = sorted_tags(&inp);
        assert!(
            kn.iter().all(|t| inn.binary_search(t).is_ok()),
            "--keep-tags invented a node tag"
        );
        assert!(
            ke.iter().all(|t| ine.binary_search(t).is_ok()),
            "--keep-tags invented an element tag"
        );
        // the checker compares the --keep-tags output with the input by tag, directly,
        // and the default one through the map (numbering checked)
        let report = check_mesh(&input, &kept, &[]);
        assert!(report.ok, "{}", report.report);
        assert!(!report.report.contains("numbering"), "{}", report.report);
        let report = check_mesh(&input, &default, &[]);
        assert!(report.ok, "{}", report.report);
        assert!(
            report.report.contains("\"numbering\": true"),
            "{}",
            report.report
        );
        assert_same_mesh_renumbered(&k, &read(&default), &tag_map_path(&default));
    }
}

#[test]
fn tags_of_an_input_without_gaps_stay_when_nodes_are_only_added() {
    let dir = tempfile::tempdir().expect("temp dir");
    // refinement adds nodes; without the optimizer none goes
    let input = generate("rectangle", Variant::Msh41Ascii, dir.path(), 1.0, &[]);
    let flags = ["--no-optimize", "--refine", "1"];
    let default = dir.path().join("default.msh");
    let kept = dir.path().join("kept.msh");
    let (code, err) = recombine(&input, &default, &flags);
    assert_eq!(code, Some(0), "{err}");
    let (code, err) = recombine(&input, &kept, &[&flags[..], &["--keep-tags"]].concat());
    assert_eq!(code, Some(0), "{err}");
    let (d, k) = (read(&default), read(&kept));
    let inp = read(&input);
    assert!(d.node_count() > inp.node_count(), "no node added");
    let (dn, _) = sorted_tags(&d);
    assert!(is_one_to_n(&dn));
    assert!(d.node_blocks == k.node_blocks, "node tags changed");
    assert_same_mesh_renumbered(&k, &d, &tag_map_path(&default));
}

/// Writes `input` with every node tag tripled and every element tag doubled (plus 5).
fn spread_tags(input: &Path, output: &Path) {
    let mut m = read(input);
    for b in &mut m.node_blocks {
        b.tags.iter_mut().for_each(|t| *t *= 3);
    }
    for b in &mut m.element_blocks {
        b.nodes.iter_mut().for_each(|t| *t *= 3);
        b.tags.iter_mut().for_each(|t| *t = 2 * *t + 5);
    }
    for l in &mut m.periodic {
        l.node_pairs
            .iter_mut()
            .for_each(|(a, b)| (*a, *b) = (3 * *a, 3 * *b));
    }
    let format = blossomquad::msh::default_output_format(&m);
    blossomquad::msh::write_file(&m, output, format).expect("write");
}

#[test]
fn an_input_with_gaps_comes_out_numbered_1_to_n() {
    let dir = tempfile::tempdir().expect("temp dir");
    for variant in [Variant::Msh41Ascii, Variant::Msh22Binary] {
        let plain = generate(
            "cad_solid",
            variant,
            dir.path(),
            test_size("cad_solid"),
            &[],
        );
        let input = dir.path().join(format!("spread-{}.msh", variant.name()));
        spread_tags(&plain, &input);
        let default = dir.path().join(format!("default-{}.msh", variant.name()));
        let kept = dir.path().join(format!("kept-{}.msh", variant.name()));
        let (code, err) = recombine(&input, &default, &[]);
        assert_eq!(code, Some(0), "{err}");
        let (code, err) = recombine(&input, &kept, &["--keep-tags"]);
        assert_eq!(code, Some(0), "{err}");
        let report = check_mesh(&input, &default, &[]);
        assert!(report.ok, "{}", report.report);
        let report = check_mesh(&input, &kept, &[]);
        assert!(report.ok, "{}", report.report);
        let k = read(&kept);
        // a curve node keeps its (tripled) tag with --keep-tags
        assert!(k
            .node_blocks
            .iter()
            .all(|b| b.tags.iter().all(|t| t % 3 == 0)));
        assert_same_mesh_renumbered(&k, &read(&default), &tag_map_path(&default));
    }
}

#[test]
fn tag_map_refusals() {
    let dir = tempfile::tempdir().expect("temp dir");
    let input = common::geo_dir().join("rectangle.msh");
    let out = dir.path().join("out.msh");
    let (code, _, err) = blossomquad_run([
        input.as_os_str(),
        "-o".as_ref(),
        out.as_os_str(),
        "--keep-tags".as_ref(),
        "--tag-map".as_ref(),
        dir.path().join("m.json").as_os_str(),
    ]);
    assert_eq!(code, Some(2), "{err}");
    assert!(
        err.contains("--keep-tags") && err.contains("--tag-map"),
        "{err}"
    );
    let (code, _, err) = blossomquad_run([
        input.as_os_str(),
        "-o".as_ref(),
        out.as_os_str(),
        "--tag-map".as_ref(),
        out.as_os_str(),
    ]);
    assert_eq!(code, Some(1), "{err}");
    assert!(err.contains("same file"), "{err}");
    assert!(!out.exists(), "nothing written on refusal");
    let (code, _, err) = blossomquad_run([
        input.as_os_str(),
        "-o".as_ref(),
        out.as_os_str(),
        "--tag-map".as_ref(),
        input.as_os_str(),
    ]);
    assert_eq!(code, Some(1), "{err}");
    assert!(err.contains("overwrite the input"), "{err}");
    assert!(!out.exists(), "nothing written on refusal");
}

/// `out.msh` copied to `name` beside it, with `map` (JSON) as its tag map.
fn with_map(out: &Path, name: &str, map: &serde_json::Value) -> std::path::PathBuf {
    let copy = out.with_file_name(name);
    std::fs::copy(out, &copy).expect("copy");
    std::fs::write(tag_map_path(&copy), map.to_string()).expect("write the map");
    copy
}

#[test]
fn the_checker_catches_a_wrong_tag_map() {
    let dir = tempfile::tempdir().expect("temp dir");
    let input = generate("square_hole", Variant::Msh41Ascii, dir.path(), 4.0, &[]);
    let out = dir.path().join("out.msh");
    let (code, err) = recombine(&input, &out, &[]);
    assert_eq!(code, Some(0), "{err}");
    let text = std::fs::read_to_string(tag_map_path(&out)).expect("the map");
    let map: serde_json::Value = serde_json::from_str(&text).expect("JSON");
    assert!(check_mesh(&input, &out, &[]).ok);
    // two curve nodes swapped: the output read back through the map moves them
    let mut swapped = map.clone();
    let nodes = swapped["nodes"].as_array_mut().expect("nodes");
    let (a, b) = (nodes[5][1].clone(), nodes[6][1].clone());
    nodes[5][1] = b;
    nodes[6][1] = a;
    let report = check_mesh(&input, &with_map(&out, "swapped.msh", &swapped), &[]);
    assert!(!report.ok, "{}", report.report);
    assert!(
        report.report.contains("\"numbering\": false"),
        "{}",
        report.report
    );
    assert!(
        report.report.contains("\"fixed_nodes\": false"),
        "{}",
        report.report
    );
    // a kept curve node left out of the map: it reads as a new node, its input tag as lost
    let mut dropped = map.clone();
    dropped["nodes"].as_array_mut().expect("nodes").remove(5);
    let report = check_mesh(&input, &with_map(&out, "dropped.msh", &dropped), &[]);
    assert!(!report.ok, "{}", report.report);
    assert!(
        report.report.contains("\"node_tags\": false"),
        "{}",
        report.report
    );
    // the --keep-tags output is not numbered 1..N: the map cannot make it so
    let kept = dir.path().join("kept.msh");
    let (code, err) = recombine(&input, &kept, &["--keep-tags"]);
    assert_eq!(code, Some(0), "{err}");
    let report = check_mesh(&input, &with_map(&kept, "kept-mapped.msh", &map), &[]);
    assert!(
        report.report.contains("\"numbering\": false"),
        "{}",
        report.report
    );
}
