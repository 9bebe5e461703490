//! The `blossomquad` command line (feature `cli`): a thin driver over the library
//! (`main → run → exit code`), run by `src/main.rs` and by the Python package's
//! `blossomquad` command.
//!
//! Raw flags are parsed by clap into `Cli`; `run` turns them into the library's option
//! structs, calls the stages and maps every error to one line on stderr and exit code 1
//! (usage errors exit with 2, from clap). This module and `msh` are the only places that
//! print, read the environment or touch files.

use std::io::IsTerminal;
use std::path::{Path, PathBuf};
use std::process::ExitCode;
use std::time::Instant;

use crate::mesh::{etype, Mesh, MshFormat, MshVersion};
use crate::{msh, quality, recombine};
use clap::{Args, Parser, Subcommand, ValueEnum};

mod files;
mod job;
mod log;

use files::*;
use job::*;
use log::*;

/// The end of `--help`: what a run prints and the exit codes.
const AFTER_HELP: &str = "\
A run prints one summary line on stderr (surfaces, triangles -> quads, worst and mean
quad quality eta, time) and any warnings; -v adds the per-surface log and stage times,
-q prints nothing but errors.

Exit codes: 0 success (a mesh of quads only goes through, the summary saying there was
nothing to recombine); 1 bad input, a refused mesh (including one with no surface
elements at all, e.g. made by gmsh -1), a bad output path, or a quad still not valid
after the fallback: one error line on stderr, no output written; 2 usage error.";

/// Turn Gmsh triangle surface meshes into all-quadrilateral meshes (Blossom-Quad).
///
/// The main job: `blossomquad INPUT.msh -o OUTPUT.msh` recombines the triangles of every
/// surface entity into quads with an exact minimum-cost perfect matching, then optimizes the
/// quads. Everything else in the file (nodes, curves, physical groups, other elements) is kept.
#[derive(Parser, Debug)]
#[command(
    name = "blossomquad",
    version,
    about,
    args_conflicts_with_subcommands = true,
    subcommand_negates_reqs = true,
    after_help = AFTER_HELP
)]
struct Cli {
    #[command(subcommand)]
    command: Option<Command>,
    #[command(flatten)]
    run: RunArgs,
}

#[derive(Subcommand, Debug)]
enum Command {
    /// Copy a mesh through the reader and writer (format conversion), no recombination.
    Convert {
        /// Input mesh (MSH 2.x or 4.x, ASCII or binary), `-` for stdin.
        input: PathBuf,
        /// Output mesh, `-` for stdout.
        #[arg(short, long)]
        output: PathBuf,
        #[command(flatten)]
        format: FormatArgs,
        /// Allow the output to overwrite the input file.
        #[arg(long)]
        force: bool,
    },
    /// Print the format, entities, element counts per surface, physical groups and parity.
    Info {
        /// Mesh to describe, `-` for stdin.
        input: PathBuf,
    },
    /// Print quad quality η (eq. 3), scaled Jacobian, vertex degrees and efficiency τ
    /// (eq. 1-2) of any mesh.
    Quality {
        /// Mesh to measure, `-` for stdin.
        input: PathBuf,
        /// Size field h(x, y, z) as an expression, e.g. `0.1+0.08*sin(3*x)*cos(6*y)`;
        /// default: estimated from the mesh's own edge lengths.
        #[arg(long, value_name = "EXPR")]
        size: Option<String>,
        /// Triangle mesh the quads came from, to estimate the size field from it.
        #[arg(long, value_name = "MESH")]
        reference: Option<PathBuf>,
        /// Print JSON instead of a table.
        #[arg(long)]
        json: bool,
        /// Also write the mesh with the views "eta" and "scaled jacobian" (per quad,
        /// $ElementData) and "valence" (per node, $NodeData) as MSH 4.1 ASCII, which Gmsh
        /// opens coloured (`gmsh OUT.msh`).
        #[arg(long, value_name = "OUT")]
        view: Option<PathBuf>,
    },
}

#[derive(Args, Debug)]
struct RunArgs {
    /// Input triangle mesh (MSH 2.x or 4.x, ASCII or binary), `-` for stdin.
    #[arg(required = true)]
    input: Option<PathBuf>,
    /// Output quad mesh, a name ending in .msh (checked before any work), `-` for stdout.
    #[arg(short, long, required = true)]
    output: Option<PathBuf>,
    #[command(flatten)]
    format: FormatArgs,
    /// What to do with surfaces that have an odd number of triangles.
    #[arg(long, value_enum, default_value_t = ParityArg::Repair)]
    parity: ParityArg,
    /// Drop volume elements instead of refusing a volume mesh.
    #[arg(long)]
    drop_volumes: bool,
    /// Check the matching's optimality certificate and the mesh invariants; fail if either
    /// does not hold.
    #[arg(long)]
    verify: bool,
    /// Weight W of the cross-field alignment cost (paper eq. 7, cross field following the
    /// nearest boundary) added to the quality cost (eq. 4); 0 = eq. 4 alone. Small weights
    /// raise η̄, the share of regular vertices and τ; weights from 0.1 up lower the worst
    /// quality on strongly graded planar meshes (see the README).
    #[arg(long, value_name = "W", default_value_t = 0.05, value_parser = parse_weight)]
    cross_field: f64,
    /// Uniform refinement after recombination, N times (0..=3): every quad split into four,
    /// every curve segment into two (paper Figure 2, Table I rows 2h and 4h). Mesh the
    /// triangles at 2^N times the wanted size; all new vertices are regular.
    #[arg(long, value_name = "N", default_value_t = 0, value_parser = clap::value_parser!(u8).range(0..=3))]
    refine: u8,
    /// With --cross-field W > 0: use a smooth (harmonic) cross field interpolating the walls'
    /// directions instead of the nearest-wall field.
    #[arg(long)]
    harmonic_cross_field: bool,
    /// Smoothing iterations of the optimization.
    #[arg(long, value_name = "N")]
    smooth: Option<usize>,
    /// Precondition the optimizer's conformal solve on large planar surfaces (4,096 free
    /// nodes or more) with a multigrid: the default (the last of this flag and
    /// --no-conformal-multigrid wins).
    #[arg(long, overrides_with = "no_conformal_multigrid")]
    conformal_multigrid: bool,
    /// Precondition the optimizer's conformal solve with its diagonal instead of the
    /// multigrid (100 iterations: a slower solve that ends further from its minimizer).
    #[arg(long)]
    no_conformal_multigrid: bool,
    /// Skip the topological operators (quad-vertex merge, doublet collapse, ...).
    #[arg(long)]
    no_topology: bool,
    /// Skip the whole optimization (smoothing and topology).
    #[arg(long)]
    no_optimize: bool,
    /// Optimize the surfaces that hold no triangle in the input (all quads already, e.g. a
    /// transfinite or extruded surface with Recombine) like the others. Without it they are
    /// written as read: nodes, coordinates and quads unchanged.
    #[arg(long)]
    smooth_quads: bool,
    /// Write the mesh even when some quads are not valid (a corner not strictly between 0
    /// and 180 degrees, a zero-length edge) after the fallback, listing them as warnings;
    /// without it such a mesh is refused (exit 1) and nothing is written.
    #[arg(long)]
    allow_invalid: bool,
    /// With a second-order input (6-node triangles): write 8-node quads (Gmsh's
    /// Mesh.SecondOrderIncomplete) instead of 9-node quads.
    #[arg(long)]
    incomplete: bool,
    /// Add quality views to the output: "eta" and "scaled jacobian" per quad
    /// ($ElementData) and "valence" per node ($NodeData), shown coloured by `gmsh OUTPUT`.
    #[arg(long)]
    quality_view: bool,
    /// Keep the input's node and element tags exactly, gaps and all. By default the output
    /// is numbered as Gmsh numbers its files: nodes 1..N and elements 1..M without gaps, in
    /// the order of their tags (tags below the first gap and all tags of a mesh with
    /// nothing removed stay as they are).
    #[arg(long, conflicts_with = "tag_map")]
    keep_tags: bool,
    /// Also write the input tag -> output tag map of every input node and element kept in
    /// the output to FILE, as JSON: {"nodes": [[in, out], ...], "elements": [...]}.
    #[arg(long, value_name = "FILE")]
    tag_map: Option<PathBuf>,
    /// Allow the output to overwrite the input file.
    #[arg(long)]
    force: bool,
    /// Print nothing but errors.
    #[arg(short, long, conflicts_with = "verbose")]
    quiet: bool,
    /// Also print the log of every surface (matching, parity repair, fallback, optimization)
    /// and the time of each stage.
    #[arg(short, long)]
    verbose: bool,
}

#[derive(Args, Debug, Default)]
struct FormatArgs {
    /// Output format version (default: the input's).
    #[arg(long, value_enum)]
    format: Option<FormatArg>,
    /// Write binary (default: the input's encoding).
    #[arg(long, conflicts_with = "ascii")]
    binary: bool,
    /// Write ASCII (default: the input's encoding).
    #[arg(long)]
    ascii: bool,
}

#[derive(ValueEnum, Clone, Copy, Debug)]
enum FormatArg {
    /// MSH 4.1.
    Msh41,
    /// MSH 2.2.
    Msh22,
}

#[derive(ValueEnum, Clone, Copy, Debug, PartialEq, Eq)]
enum ParityArg {
    /// Split boundary segments so every surface has an even triangle count.
    Repair,
    /// Refuse odd surfaces with a message saying how to fix the .geo.
    Error,
}

/// Runs the command line on `args` (the first is the program name) and returns the exit
/// code: 0 ok, 1 bad input, refused or invalid mesh (one line on stderr), 2 usage. `--help`
/// and `--version` print and return 0.
pub fn run_args<I, T>(args: I) -> u8
where
    I: IntoIterator<Item = T>,
    T: Into<std::ffi::OsString> + Clone,
{
    let args: Vec<std::ffi::OsString> = args.into_iter().map(Into::into).collect();
    let cli = match Cli::try_parse_from(&args) {
        Ok(cli) => cli,
        Err(e) => {
            if e.exit_code() != 0 {
                if let Some(hint) = second_file_hint(&args) {
                    eprintln!("error: {hint}\n\nUsage: blossomquad [OPTIONS] <INPUT> -o <OUTPUT>\n\nFor more information, try '--help'.");
                    return 2;
                }
            }
            // help and version go to stdout with exit 0, usage errors to stderr with 2
            let _ = e.print();
            return u8::try_from(e.exit_code()).unwrap_or(2);
        }
    };
    match run(cli) {
        Ok(()) => 0,
        Err(msg) => {
            eprintln!("blossomquad: error: {msg}");
            1
        }
    }
}

/// The message for a command line that names a second file where the main job takes one
/// (`blossomquad in.msh out.msh`, which clap reads as an unknown subcommand): `None` when
/// the arguments are not of that shape.
fn second_file_hint(args: &[std::ffi::OsString]) -> Option<String> {
    const WITH_VALUE: &[&str] = &[
        "-o",
        "--output",
        "--format",
        "--parity",
        "--cross-field",
        "--refine",
        "--smooth",
        "--tag-map",
    ];
    let mut files = Vec::new();
    let mut has_output = false;
    let mut it = args.iter().skip(1).map(|a| a.to_string_lossy());
    while let Some(a) = it.next() {
        if a == "-o" || a == "--output" || a.starts_with("--output=") {
            has_output = true;
        } else if a.starts_with("-o") && a.len() > 2 {
            has_output = true;
            continue;
        }
        if WITH_VALUE.contains(&a.as_ref()) {
            it.next();
        } else if a == "-" || !a.starts_with('-') {
            files.push(a.into_owned());
        }
    }
    let first = files.first()?;
    if ["convert", "info", "quality", "help"].contains(&first.as_str()) {
        return None;
    }
    let second = files.get(1)?;
    Some(if has_output {
        format!("unexpected argument '{second}': the main job recombines one INPUT at a time")
    } else {
        format!("unexpected argument '{second}': the output is given with -o; did you mean -o {second}?")
    })
}

/// [`run_args`] on the process's arguments, as an [`ExitCode`].
pub fn main() -> ExitCode {
    ExitCode::from(run_args(std::env::args_os()))
}

fn run(cli: Cli) -> Result<(), String> {
    match cli.command {
        Some(Command::Convert {
            input,
            output,
            format,
            force,
        }) => {
            check_output(&input, &output, force)?;
            let mesh = read(&input)?;
            let log = Log {
                quiet: false,
                bar: None,
            };
            print_warnings(&mesh, &log);
            write(&mesh, &output, &format, &log)
        }
        Some(Command::Info { input }) => {
            let mesh = read(&input)?;
            print_out(&msh::summary(&mesh).to_string())
        }
        Some(Command::Quality {
            input,
            size,
            reference,
            json,
            view,
        }) => {
            if let Some(out) = &view {
                check_output(&input, out, false)?;
            }
            let mesh = read(&input)?;
            if let Some(out) = &view {
                let views = quality::view::view_mesh(&mesh);
                let format = views.format.unwrap_or(crate::MshFormat {
                    version: crate::mesh::MshVersion::V41,
                    binary: false,
                });
                msh::write_file(&views, out, format)
                    .map_err(|e| format!("{}: {e}", out.display()))?;
            }
            let field = match (&size, &reference) {
                (Some(expr), _) => quality::SizeField::Expression(
                    quality::SizeExpr::new(expr).map_err(|e| e.to_string())?,
                ),
                (None, Some(r)) => {
                    let reference = read(r)?;
                    match quality::ReferenceSize::from_mesh(&reference) {
                        Some(f) => quality::SizeField::Reference(f),
                        None => {
                            return Err(format!(
                                "{}: no triangles or quads to estimate sizes from",
                                r.display()
                            ))
                        }
                    }
                }
                (None, None) => quality::SizeField::SelfEstimate,
            };
            let report =
                quality::report(&mesh, &field).map_err(|e| format!("{}: {e}", input.display()))?;
            if json {
                print_out(&format!("{}\n", report.to_json()))
            } else {
                print_out(&report.to_string())
            }
        }
        None => recombine_main(cli.run),
    }
}

/// `--cross-field W`: a finite number in [0, 5].
fn parse_weight(s: &str) -> Result<f64, String> {
    let w: f64 = s
        .parse()
        .map_err(|e| format!("{s:?} is not a number: {e}"))?;
    if (0.0..=5.0).contains(&w) {
        Ok(w)
    } else {
        Err(format!("{w} is outside [0, 5]"))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::{Progress, Stage};

    #[test]
    fn the_progress_line_shows_stage_bar_percent_and_surfaces() {
        let one = Progress::new(Stage::Matching, 48, 100).with_surfaces(0, 1);
        assert_eq!(
            progress_line(&one),
            "matching   [##############                ]  48%  surface 1/1"
        );
        let many = Progress::new(Stage::Optimize, 1, 1).with_surfaces(12, 12);
        assert_eq!(
            progress_line(&many),
            "optimizing [##############################] 100%  12/12 surfaces done"
        );
        let read = Progress::new(Stage::Read, 0, 1);
        assert_eq!(
            progress_line(&read),
            "reading    [                              ]   0%"
        );
    }

    #[test]
    fn the_progress_line_ends_with_the_elapsed_time() {
        let style = indicatif::ProgressStyle::with_template(PROGRESS_TEMPLATE);
        assert!(style.is_ok());
        assert!(PROGRESS_TEMPLATE.ends_with("{elapsed}"));
    }

    #[test]
    fn a_second_file_gets_the_output_hint() {
        let args = |a: &[&str]| -> Vec<std::ffi::OsString> {
            a.iter().map(std::ffi::OsString::from).collect()
        };
        let hint = second_file_hint(&args(&["bq", "hole.msh", "out.msh"]));
        assert!(hint.is_some_and(|h| h.contains("did you mean -o out.msh?")));
        let hint = second_file_hint(&args(&["bq", "--refine", "1", "a.msh", "b.msh"]));
        assert!(hint.is_some_and(|h| h.contains("-o b.msh")));
        // a value of an option is not a file
        assert!(second_file_hint(&args(&["bq", "--smooth", "3", "a.msh"])).is_none());
        // subcommands take their own arguments
        assert!(second_file_hint(&args(&["bq", "info", "a.msh", "b.msh"])).is_none());
        let hint = second_file_hint(&args(&["bq", "a.msh", "b.msh", "-o", "c.msh"]));
        assert!(hint.is_some_and(|h| h.contains("one INPUT at a time")));
    }
}
