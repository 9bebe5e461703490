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

/// Log sink: prints to stderr unless quiet (above the progress line when there is one).
struct Log {
    quiet: bool,
    bar: Option<indicatif::ProgressBar>,
}

impl Log {
    fn say(&self, msg: impl AsRef<str>) {
        if self.quiet {
            return;
        }
        match &self.bar {
            Some(b) => b.suspend(|| eprintln!("{}", msg.as_ref())),
            None => eprintln!("{}", msg.as_ref()),
        }
    }

    /// Prints every line, the progress line hidden once for all of them.
    fn say_all(&self, lines: &[String]) {
        if self.quiet {
            return;
        }
        let print = || {
            for line in lines {
                eprintln!("{line}");
            }
        };
        match &self.bar {
            Some(b) => b.suspend(print),
            None => print(),
        }
    }
}

/// The progress line of the main job on stderr, rewritten in place (at most 20 times a
/// second): the stage, a bar and its percentage, the surfaces when the stage goes surface by
/// surface, and the time since the start, e.g.
/// `matching   [##############                ]  48%  surface 1/1  3s`. Only on a terminal
/// and without `--quiet` (`None` otherwise: nothing is drawn, no callback is installed).
fn progress_bar(quiet: bool) -> Option<indicatif::ProgressBar> {
    if quiet || !std::io::stderr().is_terminal() {
        return None;
    }
    let b = indicatif::ProgressBar::new(1);
    // one message holds the line but the clock, so a report is one redraw; the clock is
    // redrawn by the ticker when no report comes
    b.set_style(
        indicatif::ProgressStyle::with_template(PROGRESS_TEMPLATE)
            .unwrap_or_else(|_| indicatif::ProgressStyle::default_spinner()),
    );
    b.enable_steady_tick(std::time::Duration::from_millis(500));
    Some(b)
}

/// The progress line's template: [`progress_line`], then the elapsed time.
const PROGRESS_TEMPLATE: &str = "{msg}  {elapsed}";

/// Shows `p` on the progress line. The reports that start or end a stage are drawn at
/// once, so every stage shows 0% and 100% (the others are drawn at most 20 times a second,
/// and one that comes too soon after the last drawn is left to the next).
fn show_progress(b: &indicatif::ProgressBar, p: &crate::Progress) {
    b.set_message(progress_line(p));
    if p.done == 0 || p.done == p.total {
        b.force_draw();
    }
}

/// The progress line of `p` (see [`progress_bar`]).
fn progress_line(p: &crate::Progress) -> String {
    const WIDTH: usize = 30;
    let label = match p.stage {
        crate::Stage::Read => "reading",
        crate::Stage::Topology => "topology",
        crate::Stage::Graph => "graph",
        crate::Stage::Matching => "matching",
        crate::Stage::Refine => "refining",
        crate::Stage::Optimize => "optimizing",
        crate::Stage::Check => "checking",
        crate::Stage::Write => "writing",
    };
    let f = p.fraction();
    let filled = ((f * WIDTH as f64) as usize).min(WIDTH);
    let surfaces = match p.surfaces {
        0 => String::new(),
        1 => "  surface 1/1".to_string(),
        n => format!("  {}/{n} surfaces done", p.surfaces_done),
    };
    format!(
        "{label:<10} [{}{}] {:>3}%{surfaces}",
        "#".repeat(filled),
        " ".repeat(WIDTH - filled),
        (f * 100.0) as u32
    )
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

/// The developer hooks the environment asks for: `BLOSSOMQUAD_STAGE_TIMES` (set: stage
/// times, the optimizer's quality after each stage and its rollbacks on stderr, one line
/// each) and `BLOSSOMQUAD_DUMP_GRAPHS=DIR`
/// (each surface's matching graph as `DIR/surface-TAG.txt`: a line `n m`, then `u v cost`
/// per edge, the input format of `examples/solve_matching`).
fn trace_from_env() -> Option<crate::profile::Trace> {
    use crate::profile::{Trace, TraceEvent};
    let times = std::env::var_os("BLOSSOMQUAD_STAGE_TIMES").is_some();
    let graphs = std::env::var_os("BLOSSOMQUAD_DUMP_GRAPHS").map(PathBuf::from);
    if !times && graphs.is_none() {
        return None;
    }
    Some(Trace::new(move |e: &TraceEvent<'_>| match e {
        TraceEvent::StageTimes {
            group,
            surface,
            laps,
        } if times => {
            let cpu: f64 = laps.iter().map(|x| x.1).sum();
            let wall: f64 = laps.iter().map(|x| x.2).sum();
            let s: Vec<String> = laps
                .iter()
                .map(|(n, c, w)| format!("{n} {c:.2}/{w:.2}"))
                .collect();
            eprintln!(
                "{group} surface {surface} cpu/wall ({cpu:.2}/{wall:.2} s): {}",
                s.join(", ")
            );
        }
        TraceEvent::Rollback {
            surface,
            stage,
            count,
            quads,
        } if times => {
            let q: Vec<String> = quads
                .iter()
                .map(|q| format!("{} {} {} {}", q[0], q[1], q[2], q[3]))
                .collect();
            eprintln!(
                "surface {surface}: the {stage} left {count} invalid quad(s) (nodes {}); rolled back",
                q.join(", ")
            );
        }
        TraceEvent::StageQuality {
            group,
            surface,
            stage,
            quads,
            eta_worst,
            eta_mean,
            d4_percent,
        } if times => {
            eprintln!(
                "{group} surface {surface} after {stage}: {quads} quads, eta_w {eta_worst:.4}, mean eta {eta_mean:.4}, d4 {d4_percent:.2} %"
            );
        }
        TraceEvent::MatchingGraph {
            surface,
            vertices,
            edges,
        } => {
            if let Some(dir) = &graphs {
                let path = dir.join(format!("surface-{surface}.txt"));
                if let Err(err) = dump_graph(&path, *vertices, edges) {
                    eprintln!("warning: cannot write {}: {err}", path.display());
                }
            }
        }
        _ => {}
    }))
}

/// Writes one matching graph (see [`trace_from_env`]).
fn dump_graph(path: &Path, n: usize, edges: &[(u32, u32, i64)]) -> std::io::Result<()> {
    use std::io::Write;
    let mut f = std::io::BufWriter::new(std::fs::File::create(path)?);
    writeln!(f, "{n} {}", edges.len())?;
    for (u, v, c) in edges {
        writeln!(f, "{u} {v} {c}")?;
    }
    f.flush()
}

fn recombine_main(args: RunArgs) -> Result<(), String> {
    let (Some(input), Some(output)) = (args.input, args.output) else {
        return Err("missing INPUT or -o OUTPUT (see --help)".into());
    };
    check_output(&input, &output, args.force)?;
    if let Some(map) = &args.tag_map {
        check_not_input(&input, map, args.force)?;
        if map == &output {
            return Err(format!(
                "{}: --tag-map and -o name the same file",
                map.display()
            ));
        }
    }
    let quiet = args.quiet;
    let bar = progress_bar(quiet);
    let log = Log {
        quiet,
        bar: bar.clone(),
    };
    let finish = || {
        if let Some(b) = &bar {
            b.finish_and_clear();
        }
    };
    let t0 = Instant::now();
    let read_result = match &bar {
        Some(b) => msh::read_file_with_progress(&input, &mut |done, total| {
            show_progress(b, &crate::Progress::new(crate::Stage::Read, done, total))
        }),
        None => msh::read_file(&input),
    };
    let mut mesh = read_result
        .map_err(|e| e.to_string())
        .inspect_err(|_| finish())?;
    let t_read = t0.elapsed().as_secs_f64();
    print_warnings(&mesh, &log);
    nothing_to_recombine(&mesh)
        .map(|why| format!("{}: {why}", input.display()))
        .map_or(Ok(()), Err)
        .inspect_err(|_| finish())?;

    // the summary counts the input's triangles, as `info` does (parity repair adds some)
    let triangles = input_triangles(&mesh);
    let mut opts = crate::Options {
        parity: match args.parity {
            ParityArg::Repair => recombine::ParityMode::Repair,
            ParityArg::Error => recombine::ParityMode::Error,
        },
        drop_volumes: args.drop_volumes,
        verify: args.verify,
        cross_field_weight: args.cross_field,
        harmonic_cross_field: args.harmonic_cross_field,
        refine: args.refine,
        smooth: args.smooth,
        topology: !args.no_topology,
        optimize: !args.no_optimize,
        smooth_quads: args.smooth_quads,
        allow_invalid: args.allow_invalid,
        incomplete: args.incomplete,
        keep_tags: args.keep_tags,
        tag_map: args.tag_map.is_some(),
        trace: trace_from_env(),
        ..Default::default()
    };
    if let Some(b) = bar.clone() {
        opts.progress = Some(crate::ProgressFn::new(move |p: crate::Progress| {
            show_progress(&b, &p)
        }));
    }
    let result = crate::quadrangulate(&mut mesh, &opts);
    let report = result.inspect_err(|_| finish()).map_err(|e| {
        if let (true, crate::Error::Invalid { log: lines, .. }) = (args.verbose, &e) {
            log.say_all(lines);
        }
        format!("{}: {e}{}", input.display(), error_hint(&e))
    })?;
    if args.verbose {
        log.say_all(&report.log);
    }
    let warnings: Vec<String> = report
        .warnings
        .iter()
        .map(|w| {
            let flag = if w.is_invalid_written() {
                " (--allow-invalid)"
            } else {
                ""
            };
            format!("warning: {w}{flag}")
        })
        .collect();
    log.say_all(&warnings);
    if args.quality_view {
        // encoded for the format written (the library option encodes for the default one)
        let binary = output_format(&mesh, &args.format).binary;
        quality::view::add_views(&mut mesh, binary);
    }
    let t3 = Instant::now();
    let written = match &bar {
        Some(b) => write_with_progress(&mesh, &output, &args.format, &log, &mut |done, total| {
            show_progress(b, &crate::Progress::new(crate::Stage::Write, done, total))
        }),
        None => write(&mesh, &output, &args.format, &log),
    };
    finish();
    written?;
    if let (Some(path), Some(map)) = (&args.tag_map, &report.renumber.map) {
        write_tag_map(path, map)?;
    }
    let t_write = t3.elapsed().as_secs_f64();
    if args.verbose {
        log.say_all(&time_lines(&report, t_read, t_write));
    }
    if args.verify {
        log.say("verify: passed (every surface's matching is optimal by its dual certificate, and the output keeps the input's invariants)");
    }
    if !quiet {
        let seconds = t0.elapsed().as_secs_f64();
        log.say(summary_line(&report, triangles, &mesh, &output, seconds));
    }
    Ok(())
}

/// The command-line flag that is the way past error `e`, as text to append to its message
/// (empty when there is none).
fn error_hint(e: &crate::Error) -> &'static str {
    use crate::high_order::HighOrderError;
    use crate::recombine::RecombineError;
    match e {
        crate::Error::Invalid { .. }
        | crate::Error::SecondOrder(HighOrderError::Invalid { .. }) => {
            " (rerun with --allow-invalid to write the mesh anyway)"
        }
        crate::Error::Recombine(RecombineError::VolumeElements { .. }) => " (--drop-volumes)",
        _ => "",
    }
}

/// Why `mesh` gives the main job nothing to work on (no surface element at all, as
/// `gmsh -1` writes), in words; `None` when some surface has elements (a mesh of quads
/// only goes through and is reported as such).
fn nothing_to_recombine(mesh: &Mesh) -> Option<String> {
    let count = |dim: i32| -> usize {
        mesh.element_blocks
            .iter()
            .filter(|b| b.entity_dim == dim)
            .map(|b| b.len())
            .sum()
    };
    if count(2) > 0 {
        return None;
    }
    let volumes = count(3);
    Some(if volumes > 0 {
        format!("nothing to recombine: no surface elements, only {volumes} volume element(s); nothing written")
    } else {
        format!(
            "nothing to recombine: the mesh has no surface elements ({} line element(s); made by gmsh -1? mesh the surfaces with gmsh -2); nothing written",
            count(1)
        )
    })
}

/// The triangles (3- or 6-node) on the surfaces of `mesh`: the count `info` reports for
/// the input, before parity repair or the fallback split any.
fn input_triangles(mesh: &Mesh) -> usize {
    mesh.element_blocks
        .iter()
        .filter(|b| b.entity_dim == 2 && matches!(b.element_type, etype::TRI3 | etype::TRI6))
        .map(|b| b.len())
        .sum()
}

/// The line a run ends with: surfaces, the input's `triangles` -> quads, the quads' worst
/// and mean η (eq. 3), what changed besides the pairing (parity repair, fallback,
/// refinement), where the mesh went and the whole run's time.
fn summary_line(
    report: &crate::Report,
    triangles: usize,
    mesh: &Mesh,
    output: &Path,
    seconds: f64,
) -> String {
    let surfaces = report.recombine.surfaces.len();
    let etas = quality::quad_etas(mesh);
    let quads = etas.len();
    let quality = if quads > 0 {
        let worst = etas.iter().map(|e| e.1).fold(f64::INFINITY, f64::min);
        let mean = etas.iter().map(|e| e.1).sum::<f64>() / quads as f64;
        format!(" (quality eta: worst {worst:.3}, mean {mean:.3})")
    } else {
        String::new()
    };
    let mut notes = Vec::new();
    let splits = report.recombine.parity_splits.len();
    if splits > 0 {
        notes.push(format!("parity repair split {splits} boundary segment(s)"));
    }
    if report.priced_out > 0 {
        notes.push(format!(
            "the fallback paired the triangles of {} invalid or poor quad(s) otherwise",
            report.priced_out
        ));
    }
    if let Some(f) = &report.fallback {
        notes.push(format!(
            "the fallback split {} triangle(s) into three quads each",
            f.triangles_to_quads
        ));
    }
    if !report.refine.is_empty() {
        notes.push(format!("refined {} time(s)", report.refine.len()));
    }
    if !report.invalid.is_empty() {
        notes.push(format!("{} quad(s) not valid", report.invalid.len()));
    }
    let notes = if notes.is_empty() {
        String::new()
    } else {
        format!("; {}", notes.join(", "))
    };
    let target = if output.as_os_str() == "-" {
        "standard output".to_string()
    } else {
        output.display().to_string()
    };
    if triangles == 0 {
        return format!(
            "nothing to recombine: no triangle, the surfaces hold {quads} quads already{quality}; written to {target} in {seconds:.2} s"
        );
    }
    format!(
        "{surfaces} surface{}, {triangles} triangles -> {quads} quads{quality}{notes}; written to {target} in {seconds:.2} s",
        if surfaces == 1 { "" } else { "s" },
    )
}

/// The stage times `--verbose` prints.
fn time_lines(report: &crate::Report, t_read: f64, t_write: f64) -> Vec<String> {
    let times = &report.times;
    let refine_time = if !report.refine.is_empty() {
        format!(", refine {:.3} s", times.refine.as_secs_f64())
    } else {
        String::new()
    };
    let second_order_time = if report.second_order.is_some() {
        format!(", second order {:.3} s", times.second_order.as_secs_f64())
    } else {
        String::new()
    };
    let sum = |f: fn(&recombine::SurfaceReport) -> std::time::Duration| {
        report
            .recombine
            .surfaces
            .iter()
            .map(f)
            .sum::<std::time::Duration>()
            .as_secs_f64()
    };
    vec![
        format!(
            "time: read {t_read:.3} s, recombine {:.3} s{refine_time}, optimize {:.3} s, check {:.3} s{second_order_time}, write {t_write:.3} s",
            times.recombine.as_secs_f64(),
            times.optimize.as_secs_f64(),
            times.check.as_secs_f64(),
        ),
        format!(
            "time in recombine, summed over surfaces: topology and graph {:.3} s, matching {:.3} s, quads {:.3} s",
            sum(|s| s.time_graph),
            sum(|s| s.time_matching),
            sum(|s| s.time_post)
        ),
    ]
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

/// Writes `text` to standard output. A reader that stops early (`| head`) is not an error:
/// the rest is dropped, as Unix tools do; other write errors are.
fn print_out(text: &str) -> Result<(), String> {
    use std::io::Write;
    let mut out = std::io::stdout().lock();
    match out.write_all(text.as_bytes()).and_then(|()| out.flush()) {
        Err(e) if e.kind() != std::io::ErrorKind::BrokenPipe => {
            Err(format!("cannot write to standard output: {e}"))
        }
        _ => Ok(()),
    }
}

fn read(path: &Path) -> Result<Mesh, String> {
    msh::read_file(path).map_err(|e| e.to_string())
}

fn print_warnings(mesh: &Mesh, log: &Log) {
    for w in &mesh.warnings {
        log.say(format!("warning: {w}"));
    }
}

fn output_format(mesh: &Mesh, args: &FormatArgs) -> MshFormat {
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

fn write(mesh: &Mesh, path: &Path, args: &FormatArgs, log: &Log) -> Result<(), String> {
    write_with_progress(mesh, path, args, log, &mut |_, _| {})
}

fn write_with_progress(
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
fn check_output(input: &Path, output: &Path, force: bool) -> Result<(), String> {
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
fn write_tag_map(path: &Path, map: &crate::renumber::TagMap) -> Result<(), String> {
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
fn check_not_input(input: &Path, output: &Path, force: bool) -> Result<(), String> {
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
