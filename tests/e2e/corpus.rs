//! The main job on every core file of the real-world MSH corpus (see
//! `$BLOSSOMQUAD_CORPUS` in tests/common): each recombines and passes the
//! independent checker; files with tetrahedra are refused with a clear reason
//! and accepted with `--drop-volumes`; the broken file is refused. Needs Gmsh.

use crate::common;

use common::{
    blossomquad_run, check_mesh, corpus_dir, file_name, gmsh_loads, gmsh_summary, msh_files,
    recombine,
};
use std::path::Path;

fn has_volume_elements(path: &Path) -> bool {
    gmsh_summary(path, &["--no-element-tags"])
        .lines()
        .any(|l| l.starts_with("elements 3 "))
}

fn is_msh40(path: &Path) -> bool {
    let head = std::fs::read(path).unwrap_or_default();
    let head = String::from_utf8_lossy(&head[..head.len().min(200)]).into_owned();
    head.lines()
        .skip_while(|l| !l.starts_with("$MeshFormat"))
        .nth(1)
        .is_some_and(|l| l.starts_with("4 ") || l.starts_with("4.0 "))
}

#[test]
fn every_core_corpus_file_recombines() {
    let Some(corpus) = corpus_dir() else {
        return;
    };
    let files = msh_files(&corpus);
    assert!(
        files.len() >= 19,
        "corpus {} has {} files",
        corpus.display(),
        files.len()
    );
    let dir = tempfile::tempdir().expect("temp dir");
    let mut failures = Vec::new();
    for input in &files {
        let name = file_name(input);
        let output = dir.path().join(&name);
        let (code, stderr) = recombine(input, &output, &[]);
        if has_volume_elements(input) {
            // Refused with a reason, no output; accepted with --drop-volumes.
            if code != Some(1) || stderr.trim().is_empty() || output.exists() {
                failures.push(format!(
                    "{name}: volume mesh not refused ({code:?}): {stderr}"
                ));
                continue;
            }
            let (code, stderr) = recombine(input, &output, &["--drop-volumes"]);
            if code != Some(0) {
                failures.push(format!(
                    "{name}: --drop-volumes failed ({code:?}): {stderr}"
                ));
                continue;
            }
            let report = check_mesh(input, &output, &["--allow-dropped-volumes"]);
            if !report.ok {
                failures.push(format!("{name}: {}", report.report));
            }
            continue;
        }
        if is_msh40(input) && code == Some(1) {
            // MSH 4.0 may be refused, but then clearly.
            if !stderr.contains("4.0") {
                failures.push(format!(
                    "{name}: MSH 4.0 refused without saying so: {stderr}"
                ));
            }
            continue;
        }
        if code != Some(0) {
            failures.push(format!("{name}: exit {code:?}: {stderr}"));
            continue;
        }
        let report = check_mesh(input, &output, &[]);
        if !report.ok {
            failures.push(format!("{name}: {}", report.report));
        }
    }
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}

#[test]
fn broken_corpus_file_is_refused_with_one_clear_line() {
    let Some(corpus) = corpus_dir() else {
        return;
    };
    let broken = msh_files(&corpus.join("broken"));
    assert!(!broken.is_empty(), "no file in broken/");
    let dir = tempfile::tempdir().expect("temp dir");
    for input in broken {
        let output = dir.path().join("out.msh");
        let (code, stderr) = recombine(&input, &output, &[]);
        assert_eq!(code, Some(1), "{}: {stderr}", input.display());
        assert!(!output.exists(), "partial output written");
        let lines: Vec<&str> = stderr.lines().filter(|l| !l.trim().is_empty()).collect();
        assert_eq!(lines.len(), 1, "one error line expected: {stderr}");
        let name = file_name(&input);
        assert!(
            lines[0].contains(&name),
            "error does not name the file: {stderr}"
        );
    }
}

#[test]
fn every_core_corpus_file_converts_unchanged() {
    let Some(corpus) = corpus_dir() else {
        return;
    };
    let dir = tempfile::tempdir().expect("temp dir");
    let mut failures = Vec::new();
    for input in msh_files(&corpus) {
        let name = file_name(&input);
        let output = dir.path().join(&name);
        let (code, _, stderr) = blossomquad_run([
            "convert".as_ref(),
            input.as_os_str(),
            "-o".as_ref(),
            output.as_os_str(),
        ]);
        if code != Some(0) {
            failures.push(format!("{name}: convert exit {code:?}: {stderr}"));
            continue;
        }
        if let Err(e) = gmsh_loads(&output) {
            failures.push(e);
            continue;
        }
        // Same nodes, faces, boundaries, curves, groups: the checker with
        // triangles allowed is an identity check.
        let report = check_mesh(&input, &output, &["--allow-triangles"]);
        if !report.ok {
            failures.push(format!("{name}: {}", report.report));
        }
    }
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}

/// `--refine 1` on every core file (volumes dropped): the independent checker with
/// `--refined=1` passes. Files with several surfaces and no curve elements (bempp's
/// cube-domains) put the new nodes of a shared edge in one surface's node block; this
/// caught the optimizer renumbering the other surface's nodes after removing some.
#[test]
fn every_core_corpus_file_refines() {
    let Some(corpus) = corpus_dir() else {
        return;
    };
    let files = msh_files(&corpus);
    let dir = tempfile::tempdir().expect("temp dir");
    let mut failures = Vec::new();
    let mut refined = 0;
    for input in &files {
        let name = file_name(input);
        let output = dir.path().join(&name);
        let (code, stderr) = recombine(input, &output, &["--refine", "1", "--drop-volumes"]);
        if is_msh40(input) && code == Some(1) {
            continue;
        }
        if code != Some(0) {
            failures.push(format!("{name}: exit {code:?}: {stderr}"));
            continue;
        }
        let report = check_mesh(input, &output, &["--refined=1", "--allow-dropped-volumes"]);
        if !report.ok {
            failures.push(format!("{name}: {}", report.report));
        }
        refined += 1;
    }
    assert!(failures.is_empty(), "{}", failures.join("\n"));
    assert!(refined >= 18, "only {refined} files refined");
}
