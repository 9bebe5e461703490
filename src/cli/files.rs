//! Files and streams: reading, the output format and the checks on the output path before
//! any work, writing (with progress), the tag map.

use super::*;

/// Writes `text` to standard output. A reader that stops early (`| head`) is not an error:
/// the rest is dropped, as Unix tools do; other write errors are.
pub(super) fn print_out(text: &str) -> Result<(), String> {
    use std::io::Write;
    let mut out = std::io::stdout().lock();
    match out.write_all(text.as_bytes()).and_then(|()| out.flush()) {
        Err(e) if e.kind() != std::io::ErrorKind::BrokenPipe => {
            Err(format!("cannot write to standard output: {e}"))
        }
        _ => Ok(()),
    }
}

pub(super) fn read(path: &Path) -> Result<Mesh, String> {
    msh::read_file(path).map_err(|e| e.to_string())
}

pub(super) fn print_warnings(mesh: &Mesh, log: &Log) {
    for w in &mesh.warnings {
        log.say(format!("warning: {w}"));
    }
}

pub(super) fn output_format(mesh: &Mesh, args: &FormatArgs) -> MshFormat {
    let default = msh::default_output_format(mesh);
    MshFormat {
        version: match args.format {
            Some(FormatArg::Msh41) => MshVersion::V41,
            Some(FormatArg::Msh22) => MshVersion::V2 { minor: 2 },
            None => default.version,
        },
        binary: if args.binary {
            true
        } else if args.ascii {
            false
        } else {
            default.binary
        },
    }
}

pub(super) fn write(mesh: &Mesh, path: &Path, args: &FormatArgs, log: &Log) -> Result<(), String> {
    write_with_progress(mesh, path, args, log, &mut |_, _| {})
}

pub(super) fn write_with_progress(
    mesh: &Mesh,
    path: &Path,
    args: &FormatArgs,
    log: &Log,
    progress: &mut dyn FnMut(u64, u64),
) -> Result<(), String> {
    let format = output_format(mesh, args);
    for w in msh::write_warnings(mesh, format) {
        log.say(format!("warning: {w}"));
    }
    msh::write_file_with_progress(mesh, path, format, progress).map_err(|e| e.to_string())
}

/// Checks an output path before any work: named `.msh` (the only format written), not a
/// directory, in a directory that exists and takes new files, and not the input file
/// itself unless `force`. `-` (standard output) passes.
pub(super) fn check_output(input: &Path, output: &Path, force: bool) -> Result<(), String> {
    if output.as_os_str() == "-" {
        return Ok(());
    }
    let shown = output.display();
    if output.is_dir() {
        return Err(format!(
            "{shown}: is a directory; give the output file's name, e.g. -o {}",
            output.join("out.msh").display()
        ));
    }
    let msh = output
        .extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("msh"));
    if !msh {
        let other = output
            .extension()
            .map(|e| format!("names a .{} file", e.to_string_lossy()))
            .unwrap_or_else(|| "has no .msh extension".into());
        return Err(format!(
            "{shown}: {other}, but the output is always a Gmsh MSH file; name it .msh (other formats: convert the .msh afterwards, e.g. with meshio)"
        ));
    }
    let dir = match output.parent() {
        Some(p) if !p.as_os_str().is_empty() => p,
        _ => Path::new("."),
    };
    if !dir.exists() {
        return Err(format!(
            "{shown}: the directory {} does not exist",
            dir.display()
        ));
    }
    if !dir.is_dir() {
        return Err(format!("{shown}: {} is not a directory", dir.display()));
    }
    // the only sure test of "can create a file here": create one (removed at once)
    if let Err(e) = tempfile::Builder::new()
        .prefix(".blossomquad-probe-")
        .tempfile_in(dir)
    {
        let why = match e.kind() {
            std::io::ErrorKind::PermissionDenied => "permission denied".to_string(),
            _ => e
                .to_string()
                .split_once(" at path ")
                .map_or_else(|| e.to_string(), |(m, _)| m.to_string()),
        };
        return Err(format!(
            "{shown}: cannot create a file in the directory {}: {why}",
            dir.display()
        ));
    }
    check_not_input(input, output, force)
}

/// Writes the tag map as JSON (atomically: a temporary file beside `path`, then renamed;
/// `-` writes stdout).
pub(super) fn write_tag_map(path: &Path, map: &crate::renumber::TagMap) -> Result<(), String> {
    let json = serde_json::to_string(map).map_err(|e| e.to_string())?;
    if path.as_os_str() == "-" {
        return print_out(&format!("{json}\n"));
    }
    let name = path
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_default();
    let tmp = path.with_file_name(format!(".{name}.{}.tmp", std::process::id()));
    let fail = |e: std::io::Error| format!("{}: cannot write the tag map: {e}", path.display());
    std::fs::write(&tmp, format!("{json}\n")).map_err(fail)?;
    std::fs::rename(&tmp, path).map_err(|e| {
        let _ = std::fs::remove_file(&tmp);
        fail(e)
    })
}

/// Refuses an output path that is the input file itself, unless `force`.
pub(super) fn check_not_input(input: &Path, output: &Path, force: bool) -> Result<(), String> {
    if force || input.as_os_str() == "-" || output.as_os_str() == "-" {
        return Ok(());
    }
    let same = match (std::fs::canonicalize(input), std::fs::canonicalize(output)) {
        (Ok(a), Ok(b)) => a == b,
        _ => false,
    };
    if same {
        return Err(format!(
            "{}: output would overwrite the input; choose another -o or pass --force",
            output.display()
        ));
    }
    Ok(())
}
