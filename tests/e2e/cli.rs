//! `info` and `quality` on the fixtures, and the exit-code contract
//! (0 ok, 1 bad input with one error line naming the file, 2 usage).
//! Needs Gmsh for the generated meshes.

use crate::common;

use common::{blossomquad, blossomquad_run, generate, geo_dir, total_number, Variant};
use std::path::Path;

fn info(path: &Path) -> String {
    let out = blossomquad().arg("info").arg(path).assert().success();
    String::from_utf8_lossy(&out.get_output().stdout).into_owned()
}

fn quality_json(path: &Path, extra: &[&str]) -> String {
    let out = blossomquad()
        .arg("quality")
        .arg(path)
        .arg("--json")
        .args(extra)
        .assert()
        .success();
    String::from_utf8_lossy(&out.get_output().stdout).into_owned()
}

/// The stderr of a successful main job `blossomquad INPUT -o OUT` with the developer hooks'
/// variables unset.
fn stderr_without_hooks(input: &Path, out: &Path) -> String {
    let run = blossomquad()
        .arg(input)
        .arg("-o")
        .arg(out)
        .env_remove("BLOSSOMQUAD_STAGE_TIMES")
        .env_remove("BLOSSOMQUAD_DUMP_GRAPHS")
        .assert()
        .success();
    String::from_utf8_lossy(&run.get_output().stderr).into_owned()
}

#[test]
fn info_on_shipped_rectangle() {
    let text = info(&geo_dir().join("rectangle.msh"));
    for word in ["1792", "domain", "bottom", "left"] {
        assert!(text.contains(word), "info lacks {word:?}:\n{text}");
    }
    assert!(
        !text.to_lowercase().contains("odd"),
        "rectangle is even:\n{text}"
    );
}

/// `info` and `quality` piped into a reader that stops at once (`| head -0`): no panic, exit
/// 0 (the rest of the output is dropped, as Unix tools do).
#[test]
fn info_and_quality_into_a_closed_pipe_exit_quietly() {
    use std::process::{Command, Stdio};
    let mesh = geo_dir().join("rectangle.msh");
    for args in [&["info"][..], &["quality"], &["quality", "--json"]] {
        let mut child = Command::new(env!("CARGO_BIN_EXE_blossomquad"))
            .args(args)
            .arg(&mesh)
            .stdout(Stdio::piped())
            .stderr(Stdio::piped())
            .spawn()
            .expect("start blossomquad");
        // the reader goes away before the mesh is read and anything is written
        drop(child.stdout.take());
        let out = child.wait_with_output().expect("wait for blossomquad");
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert!(!stderr.contains("panicked"), "{args:?}: {stderr}");
        assert_eq!(out.status.code(), Some(0), "{args:?}: {stderr}");
    }
}

#[test]
fn info_reports_odd_surfaces_in_every_variant() {
    let dir = tempfile::tempdir().expect("temp dir");
    for variant in Variant::ALL {
        let msh = generate("even_curves", variant, dir.path(), 1.0, &[]);
        let text = info(&msh);
        for word in ["square", "triangle", "pentagon", "940", "333", "1269"] {
            assert!(
                text.contains(word),
                "{}: info lacks {word:?}:\n{text}",
                variant.name()
            );
        }
        assert!(
            text.to_lowercase().contains("odd"),
            "{}:\n{text}",
            variant.name()
        );
    }
}

/// The summary counts the input's triangles, the count `info` gives, also when parity
/// repair splits boundary segments (which add triangles); the splits are reported apart.
#[test]
fn the_summary_counts_the_triangles_info_counts() {
    let dir = tempfile::tempdir().expect("temp dir");
    let msh = generate("even_curves", Variant::Msh41Ascii, dir.path(), 1.0, &[]);
    let counts: Vec<u64> = info(&msh)
        .lines()
        .filter_map(|l| l.split("triangle count ").nth(1))
        .filter_map(|rest| rest.split_whitespace().next()?.parse().ok())
        .collect();
    assert_eq!(counts.len(), 3, "{}", info(&msh));
    assert!(
        counts.iter().any(|n| n % 2 == 1),
        "{counts:?}: no odd surface"
    );
    let total: u64 = counts.iter().sum();
    let out = dir.path().join("out.msh");
    let err = main_job_stderr(&[msh.as_os_str(), "-o".as_ref(), out.as_os_str()]);
    assert!(
        err.starts_with(&format!("3 surfaces, {total} triangles -> ")),
        "info counts {total}: {err}"
    );
    assert!(
        err.contains("; parity repair split 2 boundary segment(s)"),
        "{err}"
    );
}

#[test]
fn quality_of_triangle_input_and_of_our_quads() {
    let dir = tempfile::tempdir().expect("temp dir");
    let input = geo_dir().join("rectangle.msh");
    let tri = quality_json(&input, &[]);
    assert_eq!(total_number(&tri, "quads"), 0.0, "{tri}");
    assert_eq!(total_number(&tri, "triangles"), 1792.0, "{tri}");

    let output = dir.path().join("quads.msh");
    blossomquad()
        .arg(&input)
        .args(["-o"])
        .arg(&output)
        .arg("--quiet")
        .assert()
        .success();
    for extra in [&[][..], &["--size", "0.1 + 0.08*sin(3*x)*cos(6*y)"][..]] {
        let q = quality_json(&output, extra);
        let quads = total_number(&q, "quads");
        assert!(quads > 0.0 && quads <= 1792.0 / 2.0 + 64.0, "{q}");
        assert_eq!(total_number(&q, "triangles"), 0.0, "{q}");
        let (w, mean) = (total_number(&q, "eta_worst"), total_number(&q, "eta_mean"));
        assert!(0.0 < w && w <= mean && mean <= 1.0, "{q}");
        let tau = total_number(&q, "tau_percent");
        assert!(0.0 < tau && tau <= 100.0, "{q}");
        let d4 = total_number(&q, "d4_percent");
        assert!((0.0..=100.0).contains(&d4), "{q}");
        let (dmin, dmax) = (total_number(&q, "d_min"), total_number(&q, "d_max"));
        assert!((1.0..=4.0).contains(&dmin) && 4.0 <= dmax, "{q}");
    }
}

#[test]
fn quality_of_gmsh_own_quads() {
    let dir = tempfile::tempdir().expect("temp dir");
    let msh = generate(
        "rectangle",
        Variant::Msh41Binary,
        dir.path(),
        1.0,
        &[("Mesh.RecombineAll", 1.0)],
    );
    let q = quality_json(&msh, &[]);
    assert!(total_number(&q, "quads") > 800.0, "{q}");
    assert!(total_number(&q, "eta_mean") > 0.5, "{q}");
    let text = blossomquad().arg("quality").arg(&msh).assert().success();
    assert!(!text.get_output().stdout.is_empty());
}

#[test]
fn missing_input_is_exit_1_naming_the_file() {
    let dir = tempfile::tempdir().expect("temp dir");
    let missing = dir.path().join("does-not-exist.msh");
    let out = dir.path().join("out.msh");
    for args in [
        vec![missing.as_os_str(), "-o".as_ref(), out.as_os_str()],
        vec!["info".as_ref(), missing.as_os_str()],
        vec!["quality".as_ref(), missing.as_os_str()],
    ] {
        let (code, _, stderr) = blossomquad_run(args);
        assert_eq!(code, Some(1), "{stderr}");
        assert!(stderr.contains("does-not-exist.msh"), "{stderr}");
        assert_eq!(stderr.trim().lines().count(), 1, "{stderr}");
    }
    assert!(!out.exists());
}

#[test]
fn geo_file_given_by_mistake_is_exit_1() {
    let dir = tempfile::tempdir().expect("temp dir");
    let out = dir.path().join("out.msh");
    let geo = geo_dir().join("rectangle.geo");
    let (code, _, stderr) = blossomquad_run([geo.as_os_str(), "-o".as_ref(), out.as_os_str()]);
    assert_eq!(code, Some(1), "{stderr}");
    assert!(stderr.contains("rectangle.geo"), "{stderr}");
    assert!(!out.exists());
}

/// An MSH 1 file (and one of a version the reader does not know) is refused with exit 1 in
/// one line naming the version and the Gmsh command that re-saves it, for the main job and
/// for `info`; nothing is written.
#[test]
fn an_msh1_file_is_named_with_the_way_out() {
    let dir = tempfile::tempdir().expect("temp dir");
    let old = dir.path().join("old.msh");
    std::fs::write(
        &old,
        "$NOD\n4\n1 0 0 0\n2 1 0 0\n3 1 1 0\n4 0 1 0\n$ENDNOD\n\
         $ELM\n2\n1 2 1 1 3 1 2 3\n2 2 1 1 3 1 3 4\n$ENDELM\n",
    )
    .expect("write input");
    let v3 = dir.path().join("v3.msh");
    std::fs::write(&v3, "$MeshFormat\n3.0 0 8\n$EndMeshFormat\n").expect("write input");
    let out = dir.path().join("out.msh");
    for (input, version) in [(&old, "MSH version 1 "), (&v3, "MSH version 3.0 ")] {
        for args in [
            vec![input.as_os_str(), "-o".as_ref(), out.as_os_str()],
            vec!["info".as_ref(), input.as_os_str()],
        ] {
            let (code, _, stderr) = blossomquad_run(args);
            assert_eq!(code, Some(1), "{stderr}");
            assert_eq!(stderr.trim().lines().count(), 1, "{stderr}");
            assert!(
                stderr.contains(version)
                    && stderr.contains("is not supported")
                    && stderr.contains("gmsh IN -0 -format msh41 -o OUT.msh (or -format msh22)"),
                "{stderr}"
            );
            assert!(!stderr.contains("truncated"), "{stderr}");
        }
    }
    assert!(!out.exists());
}

#[test]
fn usage_errors_are_exit_2() {
    let shipped = geo_dir().join("rectangle.msh");
    for args in [
        vec!["--no-such-flag".as_ref(), shipped.as_os_str()],
        vec![
            shipped.as_os_str(),
            "-o".as_ref(),
            "x.msh".as_ref(),
            "--format".as_ref(),
            "msh99".as_ref(),
        ],
        vec![
            shipped.as_os_str(),
            "-o".as_ref(),
            "x.msh".as_ref(),
            "--parity".as_ref(),
            "maybe".as_ref(),
        ],
        vec![
            shipped.as_os_str(),
            "-o".as_ref(),
            "x.msh".as_ref(),
            "--cross-field".as_ref(),
            "7".as_ref(),
        ],
        vec![
            shipped.as_os_str(),
            "-o".as_ref(),
            "x.msh".as_ref(),
            "--cross-field".as_ref(),
            "NaN".as_ref(),
        ],
        vec!["quality".as_ref()],
    ] {
        let (code, _, stderr) = blossomquad_run(args);
        assert_eq!(code, Some(2), "{stderr}");
    }
    assert!(!Path::new("x.msh").exists());
}

/// The developer hooks reach the caller's `Trace` sink and change nothing: the shipped
/// rectangle traced gives the same mesh as untraced, one matching graph with a vertex per
/// triangle, and stage times of the graph and optimizer steps. The CLI turns them into
/// `DIR/surface-TAG.txt` (`BLOSSOMQUAD_DUMP_GRAPHS`) and stderr lines
/// (`BLOSSOMQUAD_STAGE_TIMES`), and prints neither without those variables.
#[test]
fn trace_hooks_reach_the_sink_and_change_nothing() {
    use blossomquad::profile::{Trace, TraceEvent};
    use std::sync::{Arc, Mutex};
    let path = geo_dir().join("rectangle.msh");
    let input = blossomquad::read(&path).expect("read");
    let triangles: usize = input.count_elements(2);
    let mut plain = input.clone();
    let plain_report =
        blossomquad::quadrangulate(&mut plain, &blossomquad::Options::default()).expect("plain");
    let seen: Arc<Mutex<Vec<String>>> = Arc::default();
    let sink = seen.clone();
    let mut opts = blossomquad::Options::default();
    opts.trace = Some(Trace::new(move |e: &TraceEvent<'_>| {
        let line = match e {
            TraceEvent::MatchingGraph {
                vertices, edges, ..
            } => format!("graph {vertices} {}", edges.len()),
            TraceEvent::StageTimes { group, laps, .. } => format!("times {group} {}", laps.len()),
            TraceEvent::StageQuality {
                stage,
                quads,
                eta_worst,
                eta_mean,
                ..
            } => format!("quality {stage} {quads} {eta_worst} {eta_mean}"),
            _ => "other".to_string(),
        };
        sink.lock().expect("sink").push(line);
    }));
    let mut traced = input.clone();
    blossomquad::quadrangulate(&mut traced, &opts).expect("traced");
    let mut a = Vec::new();
    let mut b = Vec::new();
    let format = blossomquad::MshFormat {
        version: blossomquad::mesh::MshVersion::V41,
        binary: false,
    };
    blossomquad::msh::write(&plain, &mut a, format).expect("write");
    blossomquad::msh::write(&traced, &mut b, format).expect("write");
    assert!(a == b, "tracing changed the output");
    let seen = seen.lock().expect("seen").clone();
    let graphs: Vec<&String> = seen.iter().filter(|l| l.starts_with("graph ")).collect();
    assert_eq!(graphs.len(), 1, "one surface, one graph: {seen:?}");
    let parts: Vec<usize> = graphs[0][6..]
        .split(' ')
        .map(|x| x.parse().expect("number"))
        .collect();
    assert_eq!(parts[0], triangles, "a graph vertex per triangle");
    assert!(
        parts[1] >= triangles,
        "fewer edges than triangles: {seen:?}"
    );
    for group in ["times graph ", "times optimize "] {
        assert!(
            seen.iter()
                .any(|l| l.starts_with(group) && !l.ends_with(" 0")),
            "no {group:?} laps: {seen:?}"
        );
    }

    // the quality after each optimizer stage: every stage of the schedule reported, with
    // η in [0, 1]; the schedule kept ends where the report's figures are
    let quality: Vec<(String, usize, f64, f64)> = seen
        .iter()
        .filter_map(|l| l.strip_prefix("quality "))
        .map(|l| {
            let f: Vec<&str> = l.split(' ').collect();
            let num = |i: usize| f[i].parse::<f64>().expect("number");
            (f[0].to_string(), num(1) as usize, num(2), num(3))
        })
        .collect();
    for stage in [
        "smooth",
        "resmooth",
        "conformal",
        "polish_worst",
        "angles",
        "polish_mean",
    ] {
        assert!(
            quality.iter().any(|q| q.0 == stage),
            "no quality after {stage}: {seen:?}"
        );
    }
    assert!(quality
        .iter()
        .all(|q| q.1 > 0 && (0.0..=1.0).contains(&q.2) && q.2 <= q.3 && q.3 <= 1.0));
    let after = &plain_report.optimize.as_ref().expect("optimized").surfaces[0].after;
    assert!(
        quality
            .iter()
            .any(|q| q.0 == "polish_mean" && q.1 == after.quads && q.3 == after.eta_mean),
        "no polish_mean quality equal to the report's {after:?}: {quality:?}"
    );

    let dir = tempfile::tempdir().expect("temp dir");
    let out = dir.path().join("out.msh");
    let err = stderr_without_hooks(&path, &out);
    assert!(
        !err.contains("cpu/wall"),
        "stage times without the variable:\n{err}"
    );
    let graphs = dir.path().join("graphs");
    std::fs::create_dir(&graphs).expect("mkdir");
    let loud = blossomquad()
        .arg(&path)
        .arg("-o")
        .arg(&out)
        .env("BLOSSOMQUAD_STAGE_TIMES", "1")
        .env("BLOSSOMQUAD_DUMP_GRAPHS", &graphs)
        .assert()
        .success();
    let err = String::from_utf8_lossy(&loud.get_output().stderr).into_owned();
    assert!(
        err.contains("optimize surface 1 cpu/wall"),
        "no stage times:\n{err}"
    );
    let dump = std::fs::read_to_string(graphs.join("surface-1.txt")).expect("graph file");
    let first = dump.lines().next().expect("header");
    assert_eq!(
        first.split(' ').next(),
        Some(triangles.to_string().as_str()),
        "header {first:?}"
    );
}

/// With stderr not a terminal (captured here), the main job prints its log lines and no
/// progress line: no carriage return, no escape sequence, no bar; with `--quiet`, nothing.
#[test]
fn no_progress_line_when_stderr_is_not_a_terminal() {
    let dir = tempfile::tempdir().expect("temp dir");
    let out = dir.path().join("out.msh");
    let input = geo_dir().join("rectangle.msh");
    let verbose = blossomquad()
        .arg(&input)
        .arg("-o")
        .arg(&out)
        .arg("-v")
        .env_remove("BLOSSOMQUAD_STAGE_TIMES")
        .env_remove("BLOSSOMQUAD_DUMP_GRAPHS")
        .assert()
        .success();
    let err = String::from_utf8_lossy(&verbose.get_output().stderr).into_owned();
    assert!(
        !err.contains('\r') && !err.contains('\u{1b}') && !err.contains("[#") && !err.contains('%'),
        "progress output on a pipe:\n{err:?}"
    );
    let lines: Vec<&str> = err.lines().collect();
    assert!(lines.len() >= 4, "{err}");
    let (summary, log) = lines.split_last().expect("lines");
    assert!(
        summary.starts_with("1 surface, 1792 triangles -> "),
        "{err}"
    );
    for line in log {
        assert!(
            line.starts_with("surface ") || line.starts_with("time"),
            "unexpected line {line:?} in:\n{err}"
        );
    }
    let quiet = blossomquad()
        .arg(&input)
        .arg("-o")
        .arg(&out)
        .arg("--quiet")
        .assert()
        .success();
    assert!(quiet.get_output().stderr.is_empty());
}

/// The main job's stderr for `args` (hooks unset), asserting exit 0.
fn main_job_stderr(args: &[&std::ffi::OsStr]) -> String {
    let run = blossomquad()
        .args(args)
        .env_remove("BLOSSOMQUAD_STAGE_TIMES")
        .env_remove("BLOSSOMQUAD_DUMP_GRAPHS")
        .assert()
        .success();
    String::from_utf8_lossy(&run.get_output().stderr).into_owned()
}

/// By default a run prints one line: surfaces, triangles -> quads, the worst and mean η of
/// the quads written (the same figures `quality` measures on the output), where it went and
/// the time. `-v` adds the per-surface log and the stage times before it; `--verify` says
/// it passed.
#[test]
fn the_default_output_is_one_summary_line() {
    let dir = tempfile::tempdir().expect("temp dir");
    let out = dir.path().join("out.msh");
    let input = geo_dir().join("rectangle.msh");
    let err = main_job_stderr(&[input.as_os_str(), "-o".as_ref(), out.as_os_str()]);
    let lines: Vec<&str> = err.lines().collect();
    assert_eq!(lines.len(), 1, "one line expected:\n{err}");
    let line = lines[0];
    let q = quality_json(&out, &[]);
    let quads = total_number(&q, "quads");
    let expected = format!(
        "1 surface, 1792 triangles -> {quads} quads (quality eta: worst {:.3}, mean {:.3}); written to {} in ",
        total_number(&q, "eta_worst"),
        total_number(&q, "eta_mean"),
        out.display()
    );
    assert!(
        line.starts_with(&expected),
        "{line:?}\nexpected {expected:?}"
    );
    let seconds = line[expected.len()..]
        .strip_suffix(" s")
        .and_then(|t| t.parse::<f64>().ok());
    assert!(seconds.is_some_and(|t| t > 0.0), "{line:?}");
    assert!(!err.contains("cost ") && !err.contains("time:"), "{err}");

    let verbose = main_job_stderr(&[
        input.as_os_str(),
        "-o".as_ref(),
        out.as_os_str(),
        "-v".as_ref(),
    ]);
    assert!(
        verbose.contains("surface 1: 1792 triangles -> 896 quads (cost "),
        "{verbose}"
    );
    assert!(
        verbose.contains("surface 1: optimized, eta_w "),
        "{verbose}"
    );
    assert!(verbose.contains("\ntime: read "), "{verbose}");
    assert!(
        verbose.trim_end().ends_with(" s") && verbose.lines().count() >= 5,
        "{verbose}"
    );

    let verified = main_job_stderr(&[
        input.as_os_str(),
        "-o".as_ref(),
        out.as_os_str(),
        "--verify".as_ref(),
    ]);
    let lines: Vec<&str> = verified.lines().collect();
    assert_eq!(lines.len(), 2, "{verified}");
    assert!(lines[0].starts_with("verify: passed"), "{verified}");
    assert!(
        lines[1].starts_with("1 surface, 1792 triangles -> "),
        "{verified}"
    );

    let both = blossomquad()
        .arg(&input)
        .args(["-o", "x.msh", "-q", "-v"])
        .assert()
        .code(2);
    assert!(!both.get_output().stderr.is_empty());
}

/// Warnings stay in the default output: a mesh whose triangles repeat is recombined with a
/// warning line before the summary.
#[test]
fn warnings_stay_in_the_default_output() {
    let dir = tempfile::tempdir().expect("temp dir");
    let input = dir.path().join("repeated.msh");
    // two triangles of a unit square, the second written twice
    std::fs::write(
        &input,
        "$MeshFormat\n2.2 0 8\n$EndMeshFormat\n$Nodes\n4\n1 0 0 0\n2 1 0 0\n3 1 1 0\n4 0 1 0\n$EndNodes\n\
         $Elements\n3\n1 2 2 1 1 1 2 3\n2 2 2 1 1 1 3 4\n3 2 2 1 1 1 3 4\n$EndElements\n",
    )
    .expect("write input");
    let out = dir.path().join("out.msh");
    let err = main_job_stderr(&[input.as_os_str(), "-o".as_ref(), out.as_os_str()]);
    let lines: Vec<&str> = err.lines().collect();
    assert!(lines.len() >= 2, "{err}");
    let (summary, rest) = lines.split_last().expect("lines");
    assert!(summary.starts_with("1 surface, "), "{err}");
    assert!(rest.iter().all(|l| l.starts_with("warning: ")), "{err}");
    assert!(out.exists());
}

/// Outputs get the permissions a new file gets (0666 less the umask), and a replaced file
/// keeps its own.
#[cfg(unix)]
#[test]
fn outputs_get_the_permissions_of_a_new_file() {
    use std::os::unix::fs::PermissionsExt;
    let dir = tempfile::tempdir().expect("temp dir");
    let input = geo_dir().join("rectangle.msh");
    let mode = |p: &Path| std::fs::metadata(p).expect("metadata").permissions().mode() & 0o777;
    for (umask, expected) in [("022", 0o644), ("027", 0o640), ("002", 0o664)] {
        let out = dir.path().join(format!("out-{umask}.msh"));
        assert_cmd::Command::new("sh")
            .arg("-c")
            .arg(format!("umask {umask} && exec \"$0\" \"$@\""))
            .arg(env!("CARGO_BIN_EXE_blossomquad"))
            .arg(&input)
            .arg("-o")
            .arg(&out)
            .arg("-q")
            .assert()
            .success();
        assert_eq!(mode(&out), expected, "umask {umask}: {:o}", mode(&out));
        let converted = dir.path().join(format!("convert-{umask}.msh"));
        assert_cmd::Command::new("sh")
            .arg("-c")
            .arg(format!("umask {umask} && exec \"$0\" \"$@\""))
            .arg(env!("CARGO_BIN_EXE_blossomquad"))
            .arg("convert")
            .arg(&input)
            .arg("-o")
            .arg(&converted)
            .assert()
            .success();
        assert_eq!(mode(&converted), expected, "convert, umask {umask}");
    }
    let kept = dir.path().join("kept.msh");
    std::fs::write(&kept, "old").expect("write");
    std::fs::set_permissions(&kept, std::fs::Permissions::from_mode(0o604)).expect("chmod");
    blossomquad()
        .arg(&input)
        .arg("-o")
        .arg(&kept)
        .arg("-q")
        .assert()
        .success();
    assert_eq!(mode(&kept), 0o604);
    assert!(std::fs::read(&kept)
        .expect("read")
        .starts_with(b"$MeshFormat"));
}

/// The output path is checked before the input is even read: a missing directory, a
/// directory, another extension than `.msh`, the input itself; each refused with exit 1
/// in one line naming the path in plain words (no temporary file's name), nothing written.
#[test]
fn a_bad_output_path_is_refused_before_any_work() {
    let dir = tempfile::tempdir().expect("temp dir");
    let input = geo_dir().join("rectangle.msh");
    // the input does not exist: the output's error comes first, so no work was done
    let missing = dir.path().join("missing.msh");
    let nodir = dir.path().join("nodir").join("out.msh");
    let vtk = dir.path().join("out.vtk");
    let cases: Vec<(&Path, std::ffi::OsString, &str)> = vec![
        (&missing, nodir.clone().into(), "does not exist"),
        (&input, nodir.clone().into(), "does not exist"),
        (&missing, dir.path().into(), "is a directory"),
        (&input, vtk.clone().into(), "names a .vtk file"),
        (
            &input,
            dir.path().join("noext").into(),
            "has no .msh extension",
        ),
        (&input, input.clone().into(), "would overwrite the input"),
    ];
    for (inp, out, words) in cases {
        let (code, _, stderr) = blossomquad_run([inp.as_os_str(), "-o".as_ref(), out.as_os_str()]);
        assert_eq!(code, Some(1), "{stderr}");
        assert_eq!(stderr.trim().lines().count(), 1, "{stderr}");
        assert!(stderr.contains(words), "{out:?}: {stderr}");
        assert!(stderr.contains(&*out.to_string_lossy()), "{stderr}");
        assert!(
            !stderr.contains(".blossomquad-") && !stderr.contains("os error"),
            "{stderr}"
        );
    }
    assert!(!vtk.exists() && !nodir.exists());
    // the extension check is case-blind, and convert and quality --view check too
    let upper = dir.path().join("OUT.MSH");
    blossomquad()
        .arg(&input)
        .arg("-o")
        .arg(&upper)
        .arg("-q")
        .assert()
        .success();
    blossomquad()
        .arg("convert")
        .arg(&input)
        .arg("-o")
        .arg(&vtk)
        .assert()
        .code(1);
    blossomquad()
        .arg("quality")
        .arg(&input)
        .arg("--view")
        .arg(&nodir)
        .assert()
        .code(1);
    // a directory that takes no new file (not testable as root, who writes anywhere)
    #[cfg(unix)]
    {
        use std::os::unix::fs::PermissionsExt;
        let locked = dir.path().join("locked");
        std::fs::create_dir(&locked).expect("mkdir");
        std::fs::set_permissions(&locked, std::fs::Permissions::from_mode(0o555)).expect("chmod");
        if std::fs::write(locked.join("probe"), "").is_err() {
            let out = locked.join("out.msh");
            let (code, _, stderr) =
                blossomquad_run([input.as_os_str(), "-o".as_ref(), out.as_os_str()]);
            assert_eq!(code, Some(1), "{stderr}");
            assert!(
                stderr.contains("cannot create a file in the directory"),
                "{stderr}"
            );
            assert!(stderr.contains("permission denied"), "{stderr}");
        }
        std::fs::set_permissions(&locked, std::fs::Permissions::from_mode(0o755)).expect("chmod");
    }
}

/// A second file where `-o` was meant is a usage error (exit 2) with the fix spelled out.
#[test]
fn a_second_file_gets_a_hint_to_use_dash_o() {
    let dir = tempfile::tempdir().expect("temp dir");
    let input = geo_dir().join("rectangle.msh");
    let out = dir.path().join("out.msh");
    let (code, _, stderr) = blossomquad_run([input.as_os_str(), out.as_os_str()]);
    assert_eq!(code, Some(2), "{stderr}");
    let hint = format!("did you mean -o {}?", out.display());
    assert!(stderr.contains(&hint), "{stderr}");
    assert!(!stderr.contains("subcommand"), "{stderr}");
    assert!(!out.exists());
}

/// A mesh without surface elements (curves only, as `gmsh -1` writes; no element at all,
/// as `gmsh -2` saves a model whose physical groups are all volumes) is refused with exit
/// 1 saying there is nothing to recombine and why, and nothing is written; a mesh of quads only goes
/// through (exit 0) and the summary says there was nothing to recombine; the help documents
/// the exit codes.
#[test]
fn a_mesh_with_nothing_to_recombine_says_so() {
    let dir = tempfile::tempdir().expect("temp dir");
    let curves = dir.path().join("curves.msh");
    std::fs::write(
        &curves,
        "$MeshFormat\n2.2 0 8\n$EndMeshFormat\n$Nodes\n3\n1 0 0 0\n2 1 0 0\n3 1 1 0\n$EndNodes\n\
         $Elements\n2\n1 1 2 1 1 1 2\n2 1 2 1 1 2 3\n$EndElements\n",
    )
    .expect("write input");
    let out = dir.path().join("out.msh");
    let (code, _, stderr) = blossomquad_run([curves.as_os_str(), "-o".as_ref(), out.as_os_str()]);
    assert_eq!(code, Some(1), "{stderr}");
    assert_eq!(stderr.trim().lines().count(), 1, "{stderr}");
    assert!(
        stderr.contains("curves.msh: nothing to recombine"),
        "{stderr}"
    );
    assert!(
        stderr.contains("2 line element(s)") && stderr.contains("gmsh -2"),
        "{stderr}"
    );
    assert!(!out.exists());
    // no element at all, as `gmsh -2` saves a model whose physical groups are all volumes
    // (Gmsh saves only the elements of physical groups): the words name the groups and the
    // cure; the same file without the group is a file with no mesh
    for (groups, expected) in [
        (
            "$PhysicalNames\n1\n3 1 \"solid\"\n$EndPhysicalNames\n",
            &[
                "no elements; Gmsh saves only the elements of physical groups",
                "groups are all on volumes, none on a surface",
                "gmsh -save_all",
            ][..],
        ),
        ("", &["the mesh has no elements", "gmsh -2"][..]),
    ] {
        let empty = dir.path().join("empty.msh");
        std::fs::write(
            &empty,
            format!(
                "$MeshFormat\n2.2 0 8\n$EndMeshFormat\n{groups}$Nodes\n0\n$EndNodes\n\
                 $Elements\n0\n$EndElements\n"
            ),
        )
        .expect("write input");
        let (code, _, stderr) =
            blossomquad_run([empty.as_os_str(), "-o".as_ref(), out.as_os_str()]);
        assert_eq!(code, Some(1), "{stderr}");
        assert_eq!(stderr.trim().lines().count(), 1, "{stderr}");
        assert!(
            stderr.contains("empty.msh: nothing to recombine"),
            "{stderr}"
        );
        for words in expected {
            assert!(stderr.contains(words), "{words}: {stderr}");
        }
        assert!(!stderr.contains("gmsh -1"), "{stderr}");
        assert!(!out.exists());
    }
    // quads only: the output of a first run goes through unchanged in its elements
    let quads = dir.path().join("quads.msh");
    blossomquad()
        .arg(geo_dir().join("rectangle.msh"))
        .arg("-o")
        .arg(&quads)
        .arg("-q")
        .assert()
        .success();
    let err = main_job_stderr(&[quads.as_os_str(), "-o".as_ref(), out.as_os_str()]);
    let n = total_number(&quality_json(&quads, &[]), "quads");
    let expected = format!("nothing to recombine: no triangle, the surfaces hold {n} quads already (quality eta: worst ");
    assert!(
        err.starts_with(&expected) && err.lines().count() == 1,
        "{err}"
    );
    assert_eq!(total_number(&quality_json(&out, &[]), "quads"), n);
    let help = blossomquad().arg("--help").assert().success();
    let help = String::from_utf8_lossy(&help.get_output().stdout).into_owned();
    assert!(
        help.contains("Exit codes: 0 success") && help.contains("; 1 bad input"),
        "{help}"
    );
    assert!(
        help.contains("no surface") && help.contains("gmsh -1"),
        "{help}"
    );
    assert!(help.contains("-v, --verbose"), "{help}");
}

/// Reading and writing report progress as they go on a big file (several megabytes):
/// values that grow from 0, some strictly between start and end, the last one complete.
#[test]
fn reading_and_writing_report_progress_on_big_files() {
    let dir = tempfile::tempdir().expect("temp dir");
    let mut mesh = blossomquad::read(geo_dir().join("rectangle.msh")).expect("read");
    let mut opts = blossomquad::Options::default();
    opts.refine = 3;
    blossomquad::quadrangulate(&mut mesh, &opts).expect("refined");
    let big = dir.path().join("big.msh");
    let format = blossomquad::MshFormat {
        version: blossomquad::mesh::MshVersion::V41,
        binary: false,
    };
    let mut writes = Vec::new();
    blossomquad::msh::write_file_with_progress(&mesh, &big, format, &mut |d, t| {
        writes.push((d, t))
    })
    .expect("write");
    let size = std::fs::metadata(&big).expect("metadata").len();
    assert!(
        size > 3 << 20,
        "{size} bytes: not big enough to show progress"
    );
    let mut reads = Vec::new();
    let back = blossomquad::msh::read_file_with_progress(&big, &mut |d, t| reads.push((d, t)))
        .expect("read back");
    assert_eq!(back.count_elements(2), mesh.count_elements(2));
    for (what, calls) in [("write", &writes), ("read", &reads)] {
        assert!(
            calls.windows(2).all(|w| w[0].0 <= w[1].0),
            "{what}: {calls:?}"
        );
        assert!(calls.iter().all(|&(d, t)| d <= t), "{what}: {calls:?}");
        assert_eq!(calls.first().map(|c| c.0), Some(0), "{what}: {calls:?}");
        assert_eq!(calls.last(), Some(&(size, size)), "{what}: {calls:?}");
        let inside = calls.iter().filter(|&&(d, t)| d > 0 && d < t).count();
        assert!(inside >= 3, "{what}: too few steps: {calls:?}");
    }
}

/// The output the README shows for its first command is what the command prints (but the
/// time).
#[test]
fn the_readme_shows_what_the_first_command_prints() {
    let readme = std::fs::read_to_string(common::repo_dir().join("README.md")).expect("README");
    let command = "$ cargo run --release -- geo/rectangle.msh -o rectangle-quads.msh\n";
    let at = readme
        .find(command)
        .expect("the first command in the README")
        + command.len();
    let shown = readme[at..]
        .lines()
        .next()
        .expect("a line after the command");
    let dir = tempfile::tempdir().expect("temp dir");
    let run = blossomquad()
        .current_dir(dir.path())
        .arg(geo_dir().join("rectangle.msh"))
        .args(["-o", "rectangle-quads.msh"])
        .env_remove("BLOSSOMQUAD_STAGE_TIMES")
        .env_remove("BLOSSOMQUAD_DUMP_GRAPHS")
        .assert()
        .success();
    let printed = String::from_utf8_lossy(&run.get_output().stderr).into_owned();
    let without_time = |l: &str| l.rsplit_once(" in ").map(|(a, _)| a.to_string());
    assert_eq!(
        without_time(printed.trim_end()),
        without_time(shown),
        "README shows {shown:?}, the command prints {printed:?}"
    );
    assert!(without_time(shown).is_some(), "{shown:?}");
}
