//! Code shared by the end-to-end tests: where the fixtures and the corpus
//! are, generating fixture meshes with Gmsh in each MSH variant, asking Gmsh
//! what it reads from a file, the independent checker (`tests/check_mesh.py`)
//! and the `blossomquad` binary.
//!
//! Gmsh (`gmsh` on PATH, and the `gmsh` Python module) is required: the tests
//! fail with a message saying how to install it when it is missing
//! (`scripts/test.sh` installs it).

// Each test binary uses a different subset of these functions.
#![allow(dead_code)]

use std::ffi::OsStr;
use std::path::{Path, PathBuf};
use std::process::{Command, Output};
use std::sync::OnceLock;

/// The crate's root directory.
pub fn repo_dir() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

/// `geo/`, the .geo fixtures and the shipped mesh.
pub fn geo_dir() -> PathBuf {
    repo_dir().join("geo")
}

/// The four .geo fixtures of `geo/`, by stem.
pub const FIXTURES: [&str; 4] = ["rectangle", "square_hole", "cad_solid", "even_curves"];

/// Fixture sizes used by the tests (the `size` parameter of each .geo), chosen
/// for about 1e3 to 1e4 triangles so the whole suite stays fast.
pub fn test_size(fixture: &str) -> f64 {
    match fixture {
        "rectangle" => 1.0,   // 1792 triangles
        "square_hole" => 4.0, // ~4.5e3 triangles
        "cad_solid" => 1.5,   // ~3e3 triangles on 14 faces
        _ => 1.0,             // even_curves: ~2.5e3 triangles
    }
}

#[path = "../corpus_gate/mod.rs"]
mod corpus_gate;
/// The real-world MSH corpus, `None` (one printed line per test binary) when absent: see
/// `tests/corpus_gate`.
#[allow(unused_imports)] // not every test binary uses it
pub use corpus_gate::corpus_dir;

/// The `.msh` files directly inside `dir`, sorted.
pub fn msh_files(dir: &Path) -> Vec<PathBuf> {
    let mut files: Vec<PathBuf> = std::fs::read_dir(dir)
        .unwrap_or_else(|e| panic!("cannot list {}: {e}", dir.display()))
        .filter_map(|entry| entry.ok().map(|e| e.path()))
        .filter(|p| p.extension() == Some(OsStr::new("msh")))
        .collect();
    files.sort();
    files
}

/// One of the four MSH encodings Gmsh and blossomquad write.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Variant {
    /// MSH 4.1, ASCII.
    Msh41Ascii,
    /// MSH 4.1, binary.
    Msh41Binary,
    /// MSH 2.2, ASCII.
    Msh22Ascii,
    /// MSH 2.2, binary.
    Msh22Binary,
}

impl Variant {
    /// All four variants.
    pub const ALL: [Variant; 4] = [
        Variant::Msh41Ascii,
        Variant::Msh41Binary,
        Variant::Msh22Ascii,
        Variant::Msh22Binary,
    ];

    /// Short name used in file names and messages.
    pub fn name(self) -> &'static str {
        match self {
            Variant::Msh41Ascii => "msh41-ascii",
            Variant::Msh41Binary => "msh41-bin",
            Variant::Msh22Ascii => "msh22-ascii",
            Variant::Msh22Binary => "msh22-bin",
        }
    }

    /// The format name (`msh41` or `msh22`), as Gmsh's `-format` and our `--format` take it.
    pub fn format(self) -> &'static str {
        match self {
            Variant::Msh41Ascii | Variant::Msh41Binary => "msh41",
            Variant::Msh22Ascii | Variant::Msh22Binary => "msh22",
        }
    }

    /// True for the binary encodings.
    pub fn binary(self) -> bool {
        matches!(self, Variant::Msh41Binary | Variant::Msh22Binary)
    }

    /// True for MSH 2.2.
    pub fn is_msh22(self) -> bool {
        self.format() == "msh22"
    }

    /// Gmsh command-line arguments selecting this variant.
    pub fn gmsh_args(self) -> Vec<&'static str> {
        let mut args = vec!["-format", self.format()];
        if self.binary() {
            args.push("-bin");
        }
        args
    }

    /// blossomquad arguments selecting this variant.
    pub fn cli_args(self) -> Vec<&'static str> {
        vec![
            "--format",
            self.format(),
            if self.binary() { "--binary" } else { "--ascii" },
        ]
    }
}

fn tool(env_var: &str, default: &str) -> String {
    std::env::var(env_var).unwrap_or_else(|_| default.to_string())
}

/// The Gmsh executable (`$GMSH`, else `gmsh` on PATH). Panics with a clear
/// message when Gmsh or its Python module is missing.
pub fn gmsh_exe() -> String {
    static CHECKED: OnceLock<Result<String, String>> = OnceLock::new();
    let checked = CHECKED.get_or_init(|| {
        let exe = tool("GMSH", "gmsh");
        let version = Command::new(&exe).arg("--version").output();
        let module = Command::new(python_exe())
            .args(["-c", "import gmsh"])
            .output();
        match (version, module) {
            (Ok(v), Ok(m)) if v.status.success() && m.status.success() => Ok(exe),
            _ => Err(format!(
                "Gmsh is required by the end-to-end tests but `{exe} --version` or \
                 `{} -c 'import gmsh'` failed: run scripts/test.sh (it installs it) or \
                 `python3 -m pip install gmsh==4.15.2` and put its `gmsh` on PATH",
                python_exe()
            )),
        }
    });
    match checked {
        Ok(exe) => exe.clone(),
        Err(message) => panic!("{message}"),
    }
}

/// The Python interpreter (`$PYTHON`, else `python3`).
pub fn python_exe() -> String {
    tool("PYTHON", "python3")
}

/// Runs a command to completion, panicking if it cannot be started.
pub fn run(cmd: &mut Command) -> Output {
    cmd.output()
        .unwrap_or_else(|e| panic!("cannot run {cmd:?}: {e}"))
}

fn text(bytes: &[u8]) -> String {
    String::from_utf8_lossy(bytes).into_owned()
}

/// Meshes `geo/<fixture>.geo` with `gmsh -2` at the given `size` parameter in
/// `variant`, into `dir/<fixture>-<variant>.msh`; `numbers` are more
/// `-setnumber` pairs. Panics if Gmsh fails or reports an error.
pub fn generate(
    fixture: &str,
    variant: Variant,
    dir: &Path,
    size: f64,
    numbers: &[(&str, f64)],
) -> PathBuf {
    let geo = geo_dir().join(format!("{fixture}.geo"));
    let out = dir.join(format!("{fixture}-{}.msh", variant.name()));
    generate_geo(&geo, &out, variant, size, numbers);
    out
}

/// Meshes any .geo file with `gmsh -2` into `out` (see [`generate`]).
pub fn generate_geo(geo: &Path, out: &Path, variant: Variant, size: f64, numbers: &[(&str, f64)]) {
    let mut cmd = Command::new(gmsh_exe());
    cmd.arg("-2").arg(geo).args(variant.gmsh_args());
    cmd.args(["-setnumber", "size", &size.to_string()]);
    for (name, value) in numbers {
        cmd.args(["-setnumber", name, &value.to_string()]);
    }
    cmd.arg("-o").arg(out);
    let output = run(&mut cmd);
    let log = text(&output.stdout) + &text(&output.stderr);
    assert!(
        output.status.success() && !log.contains("Error") && out.is_file(),
        "gmsh failed on {}:\n{log}",
        geo.display()
    );
}

/// "Gmsh loads the file": `gmsh FILE -0 -o CHECK.msh` exits 0 and prints no
/// `Error` line (it exits 0 even after some errors). Returns the log on failure.
pub fn gmsh_loads(path: &Path) -> Result<(), String> {
    let dir = tempfile::tempdir().map_err(|e| e.to_string())?;
    let check = dir.path().join("check.msh");
    let output = run(Command::new(gmsh_exe())
        .arg(path)
        .arg("-0")
        .arg("-o")
        .arg(&check));
    let log = text(&output.stdout) + &text(&output.stderr);
    if output.status.success() && !log.contains("Error") && check.is_file() {
        Ok(())
    } else {
        Err(format!("gmsh cannot load {}:\n{log}", path.display()))
    }
}

/// What Gmsh reads from `path`, as canonical text (see
/// `tests/common/gmsh_summary.py`); `flags` are `--no-element-tags`,
/// `--no-classification`. Panics when Gmsh reports an error.
pub fn gmsh_summary(path: &Path, flags: &[&str]) -> String {
    let script = repo_dir().join("tests/common/gmsh_summary.py");
    let output = run(Command::new(python_exe()).arg(script).arg(path).args(flags));
    assert!(
        output.status.success(),
        "gmsh cannot read {}: {}",
        path.display(),
        text(&output.stderr)
    );
    text(&output.stdout)
}

/// Result of `tests/check_mesh.py`.
#[derive(Debug)]
pub struct CheckReport {
    /// True when the checker exited 0 (every invariant holds).
    pub ok: bool,
    /// The checker's exit code.
    pub code: Option<i32>,
    /// Its JSON line (and stderr, if any).
    pub report: String,
}

/// Where the tests have the tool write the tag map of `output` (`--tag-map`):
/// `OUTPUT.tags.json` beside it.
pub fn tag_map_path(output: &Path) -> PathBuf {
    let mut name = output.as_os_str().to_owned();
    name.push(".tags.json");
    PathBuf::from(name)
}

/// `--tag-map OUTPUT.tags.json`, for a main-job command line whose output the checker
/// reads (it then compares node and element tags through the map).
pub fn tag_map_args(output: &Path) -> [std::ffi::OsString; 2] {
    ["--tag-map".into(), tag_map_path(output).into_os_string()]
}

/// Runs the independent checker on (input, output) with extra `flags`
/// (`--allow-dropped-volumes`, `--allow-triangles`); when the tool wrote the tag map
/// `OUTPUT.tags.json` ([`tag_map_path`]), the checker gets it (`--tag-map=`): it checks
/// the output's numbering 1..N and compares tags with the input through it.
pub fn check_mesh(input: &Path, output: &Path, flags: &[&str]) -> CheckReport {
    let script = repo_dir().join("tests/check_mesh.py");
    let map = tag_map_path(output);
    let mut map_flag = std::ffi::OsString::from("--tag-map=");
    map_flag.push(&map);
    let out = run(Command::new(python_exe())
        .arg(script)
        .arg(input)
        .arg(output)
        .args(flags)
        .args(map.exists().then_some(map_flag)));
    CheckReport {
        ok: out.status.success(),
        code: out.status.code(),
        report: text(&out.stdout) + &text(&out.stderr),
    }
}

/// Breaks a valid quad mesh on purpose with `tests/common/mutate.py`.
pub fn mutate(src: &Path, dst: &Path, what: &str) {
    let script = repo_dir().join("tests/common/mutate.py");
    let out = run(Command::new(python_exe())
        .arg(script)
        .arg(src)
        .arg(dst)
        .arg(what));
    assert!(
        out.status.success(),
        "mutate.py {what} failed: {}",
        text(&out.stderr)
    );
}

/// The `blossomquad` binary under test, as an assert_cmd command.
pub fn blossomquad() -> assert_cmd::Command {
    assert_cmd::Command::new(env!("CARGO_BIN_EXE_blossomquad"))
}

/// Runs `blossomquad args...` and returns (exit code, stdout, stderr).
pub fn blossomquad_run<I, S>(args: I) -> (Option<i32>, String, String)
where
    I: IntoIterator<Item = S>,
    S: AsRef<OsStr>,
{
    let output = blossomquad().args(args).output();
    match output {
        Ok(o) => (o.status.code(), text(&o.stdout), text(&o.stderr)),
        Err(e) => panic!("cannot run blossomquad: {e}"),
    }
}

/// The number after `"key":` in a flat JSON object (enough for the
/// `quality --json` and checker reports).
pub fn json_number(json: &str, key: &str) -> Option<f64> {
    let pattern = format!("\"{key}\"");
    let start = json.find(&pattern)? + pattern.len();
    let rest = json[start..].trim_start().strip_prefix(':')?.trim_start();
    let end = rest
        .find(|c: char| !(c.is_ascii_digit() || "+-.eE".contains(c)))
        .unwrap_or(rest.len());
    rest[..end].parse().ok()
}

/// A number of the `"total"` object of a `quality --json` report (whole-mesh figures;
/// per-surface objects come before it).
pub fn total_number(json: &str, key: &str) -> f64 {
    let total = json
        .find("\"total\"")
        .map(|at| &json[at..])
        .unwrap_or_else(|| panic!("no \"total\" in {json}"));
    json_number(total, key).unwrap_or_else(|| panic!("no number {key:?} in {json}"))
}

/// [`total_number`] of `blossomquad quality PATH --json`, which must succeed.
pub fn quality_total(path: &Path, key: &str) -> f64 {
    let (code, json, stderr) =
        blossomquad_run(["quality".as_ref(), path.as_os_str(), "--json".as_ref()]);
    assert_eq!(code, Some(0), "quality {} failed: {stderr}", path.display());
    total_number(&json, key)
}

/// Asserts that `path` starts with the `$MeshFormat` header of `variant`.
pub fn assert_variant(path: &Path, variant: Variant) {
    let bytes = std::fs::read(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    let version = if variant.is_msh22() { "2.2" } else { "4.1" };
    let header = format!(
        "$MeshFormat\n{version} {} 8",
        if variant.binary() { 1 } else { 0 }
    );
    assert!(
        bytes.starts_with(header.as_bytes()),
        "{}: expected {} header, file starts with {:?}",
        path.display(),
        variant.name(),
        String::from_utf8_lossy(&bytes[..bytes.len().min(40)])
    );
}

/// The main job as the tests run it: `blossomquad INPUT -o OUTPUT --verify
/// --quiet EXTRA...`, with `--tag-map OUTPUT.tags.json` (read by [`check_mesh`]) unless
/// EXTRA has `--keep-tags`; returns (exit code, stderr).
pub fn recombine(input: &Path, output: &Path, extra: &[&str]) -> (Option<i32>, String) {
    let map = tag_map_path(output);
    let _ = std::fs::remove_file(&map);
    let keep = extra.contains(&"--keep-tags");
    let (code, _, stderr) = blossomquad_run(
        [
            input.as_os_str(),
            "-o".as_ref(),
            output.as_os_str(),
            "--verify".as_ref(),
            "--quiet".as_ref(),
        ]
        .into_iter()
        .chain(extra.iter().map(|s| s.as_ref()))
        .chain(
            (!keep)
                .then(|| ["--tag-map".as_ref(), map.as_os_str()])
                .into_iter()
                .flatten(),
        ),
    );
    (code, stderr)
}

/// The last component of `path`, as text.
pub fn file_name(path: &Path) -> String {
    path.file_name()
        .unwrap_or_default()
        .to_string_lossy()
        .into_owned()
}
