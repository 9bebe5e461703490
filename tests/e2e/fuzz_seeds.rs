//! The fuzz targets' own checks (`fuzz/check/`), run by the ordinary test suite over their
//! seed corpora (`fuzz/corpus/TARGET/seed-*`) and the recorded findings
//! (`tests/data/fuzz/`), so that a harness that breaks (a false finding on a seed) or a
//! finding that comes back is caught without a nightly toolchain.

use std::path::{Path, PathBuf};

#[path = "../../fuzz/check/pipeline.rs"]
mod pipeline_check;

#[path = "../../fuzz/check/read.rs"]
mod read_check;

fn root() -> &'static Path {
    Path::new(env!("CARGO_MANIFEST_DIR"))
}

/// The files of `dir` whose names start with `prefix`, sorted.
fn files(dir: &str, prefix: &str) -> Vec<PathBuf> {
    let mut v: Vec<PathBuf> = std::fs::read_dir(root().join(dir))
        .unwrap_or_else(|e| panic!("read {dir}: {e}"))
        .map(|e| e.expect("directory entry").path())
        .filter(|p| {
            p.file_name()
                .and_then(|n| n.to_str())
                .is_some_and(|n| n.starts_with(prefix))
        })
        .collect();
    v.sort();
    v
}

/// Runs `check` on every file; a panic inside it is a finding too. Returns the findings.
fn findings(paths: &[PathBuf], check: fn(&[u8]) -> Result<(), String>) -> Vec<String> {
    let mut out = Vec::new();
    for p in paths {
        let data = std::fs::read(p).unwrap_or_else(|e| panic!("read {}: {e}", p.display()));
        match std::panic::catch_unwind(|| check(&data)) {
            Ok(Ok(())) => {}
            Ok(Err(e)) => out.push(format!("{}: {e}", p.display())),
            Err(_) => out.push(format!("{}: panicked", p.display())),
        }
    }
    out
}

#[test]
fn the_pipeline_check_passes_on_its_seeds() {
    let seeds = files("fuzz/corpus/pipeline", "seed-");
    assert!(seeds.len() >= 9, "the seed corpus is there: {seeds:?}");
    let f = findings(&seeds, pipeline_check::check);
    assert!(f.is_empty(), "findings on the seeds:\n{}", f.join("\n"));
}

#[test]
fn the_pipeline_check_passes_on_the_recorded_findings() {
    let recorded = files("tests/data/fuzz", "");
    assert!(recorded.len() >= 5, "the findings are there: {recorded:?}");
    let f = findings(&recorded, pipeline_check::check);
    assert!(f.is_empty(), "findings come back:\n{}", f.join("\n"));
}

#[test]
fn the_read_check_passes_on_its_seeds_and_the_recorded_findings() {
    let mut paths = files("fuzz/corpus/read", "seed-");
    assert!(paths.len() >= 10, "the seed corpus is there: {paths:?}");
    paths.extend(files("fuzz/corpus/pipeline", "seed-"));
    paths.extend(files("tests/data/fuzz", ""));
    let f = findings(&paths, read_check::check);
    assert!(f.is_empty(), "findings:\n{}", f.join("\n"));
}

/// The check can fail: a seed whose output is compared by the output's own tags (the
/// harness's old mistake, after the output is numbered 1..N) is caught, so the mapping
/// through the tag map is what makes the seeds pass.
#[test]
fn the_pipeline_check_catches_a_mesh_compared_by_the_wrong_tags() {
    let path = root().join("fuzz/corpus/pipeline/seed-sphere22.msh");
    let data = std::fs::read(&path).expect("read the seed");
    let before = blossomquad::msh::read_bytes(&data, "seed.msh").expect("the seed reads");
    let mut after = before.clone();
    blossomquad::quadrangulate(&mut after, &blossomquad::Options::default()).expect("Ok");
    // compared by the output's own tags, the renumbered sphere looks broken...
    assert!(
        pipeline_check::check_quads(&before, &after).is_err(),
        "comparing by the output's own tags should fail on the renumbered sphere"
    );
    // ...and the check through the tag map passes
    assert_eq!(pipeline_check::check(&data), Ok(()));
}

/// An MSH 2.2 mesh of `nodes` (tags 1, 2, ...) and `elements` (type, node tags) on surface 1.
fn msh22(nodes: &[[f64; 3]], elements: &[(u32, &[u64])]) -> blossomquad::Mesh {
    let mut text = format!(
        "$MeshFormat\n2.2 0 8\n$EndMeshFormat\n$Nodes\n{}\n",
        nodes.len()
    );
    for (i, p) in nodes.iter().enumerate() {
        text += &format!("{} {} {} {}\n", i + 1, p[0], p[1], p[2]);
    }
    text += &format!("$EndNodes\n$Elements\n{}\n", elements.len());
    for (i, (t, e)) in elements.iter().enumerate() {
        let tags: Vec<String> = e.iter().map(|n| n.to_string()).collect();
        text += &format!("{} {t} 2 0 1 {}\n", i + 1, tags.join(" "));
    }
    text += "$EndElements\n";
    blossomquad::msh::read_bytes(text.as_bytes(), "test.msh").unwrap_or_else(|e| panic!("{e}"))
}

#[test]
fn the_pipeline_check_passes_a_bent_quad_and_catches_one_facing_away_from_the_input() {
    // two triangles hinged along 1-3, the second turned 120 degrees out of the first's
    // plane: the quad 1 2 3 4 is valid (each corner about its own node's normal, facing
    // the input's way, no fold about its own normal), though bent
    let hinged = [
        [0., 0., 0.],
        [1., 0., 0.],
        [1., 1., 0.],
        [0.75, 0.25, 0.612],
    ];
    let before = msh22(&hinged, &[(2, &[1, 2, 3]), (2, &[1, 3, 4])]);
    let after = msh22(&hinged, &[(3, &[1, 2, 3, 4])]);
    assert_eq!(pipeline_check::check_quads(&before, &after), Ok(()));
    // a saddle quad (its own normal +z) whose nodes each have a small input triangle of
    // their own, normal pointing into the saddle and down: every corner turns positively
    // about its own node's normal and about the quad's own normal, but the quad faces
    // away from the sum of its corners' normals
    let nodes = [
        [1., 0., 1.],
        [0., 1., -1.],
        [-1., 0., 1.],
        [0., -1., -1.],
        [1., 0.1, 1.],
        [1.02, 0., 0.9],
        [0., 1.02, -0.9],
        [0.1, 1., -1.],
        [-1.02, 0., 0.9],
        [-1., 0.1, 1.],
        [0.1, -1., -1.],
        [0., -1.02, -0.9],
    ];
    let tris: [(u32, &[u64]); 4] = [
        (2, &[1, 5, 6]),
        (2, &[2, 7, 8]),
        (2, &[3, 9, 10]),
        (2, &[4, 11, 12]),
    ];
    let before = msh22(&nodes, &tris);
    let after = msh22(&nodes, &[(3, &[1, 2, 3, 4])]);
    let finding = pipeline_check::check_quads(&before, &after).expect_err("a finding");
    assert!(
        finding.contains("faces away from the input surface"),
        "{finding}"
    );
}
