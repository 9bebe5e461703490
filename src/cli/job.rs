//! The main job: flags to options, the run, and what is printed of its report (the
//! summary line, the stage times, the way past a refusal).

use super::*;

/// The developer hooks the environment asks for: `BLOSSOMQUAD_STAGE_TIMES` (set: stage
/// times, the optimizer's quality after each stage and its rollbacks on stderr, one line
/// each) and `BLOSSOMQUAD_DUMP_GRAPHS=DIR`
/// (each surface's matching graph as `DIR/surface-TAG.txt`: a line `n m`, then `u v cost`
/// per edge, the input format of `examples/solve_matching`).
pub(super) fn trace_from_env() -> Option<crate::profile::Trace> {
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
pub(super) fn dump_graph(path: &Path, n: usize, edges: &[(u32, u32, i64)]) -> std::io::Result<()> {
    use std::io::Write;
    let mut f = std::io::BufWriter::new(std::fs::File::create(path)?);
    writeln!(f, "{n} {}", edges.len())?;
    for (u, v, c) in edges {
        writeln!(f, "{u} {v} {c}")?;
    }
    f.flush()
}

pub(super) fn recombine_main(args: RunArgs) -> Result<(), String> {
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

    // the summary counts the input's triangles, as `info` does (parity repair adds some)
    let triangles = input_triangles(&mesh);
    let surfaces = input_surfaces(&mesh);
    let mut opts = crate::Options {
        parity: match args.parity {
            ParityArg::Repair => recombine::ParityMode::Repair,
            ParityArg::Error => recombine::ParityMode::Error,
        },
        drop_volumes: args.drop_volumes,
        verify: args.verify,
        cross_field_weight: args.cross_field,
        harmonic_cross_field: args.harmonic_cross_field,
        conformal_multigrid: args.conformal_multigrid || !args.no_conformal_multigrid,
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
        // developer hook: the matching's fractional start in blocks side by side (GUIDE.md)
        split_matching: std::env::var_os("BLOSSOMQUAD_SPLIT_MATCHING").is_some(),
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
        // a mesh with no surface element is refused before any work
        let written = match e {
            crate::Error::NothingToRecombine(_) => "; nothing written",
            _ => "",
        };
        format!("{}: {e}{written}{}", input.display(), error_hint(&e))
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
        log.say(summary_line(
            &report,
            (surfaces, triangles),
            &mesh,
            &output,
            seconds,
        ));
    }
    Ok(())
}

/// The command-line flag that is the way past error `e` ([`crate::Error::option_past`]), as
/// text to append to its message (empty when there is none).
pub(super) fn error_hint(e: &crate::Error) -> &'static str {
    match e.option_past() {
        Some("allow_invalid") => " (rerun with --allow-invalid to write the mesh anyway)",
        Some("drop_volumes") => " (--drop-volumes)",
        _ => "",
    }
}

/// The triangles (3- or 6-node) on the surfaces of `mesh`: the count `info` reports for
/// the input, before parity repair or the fallback split any.
pub(super) fn input_triangles(mesh: &Mesh) -> usize {
    mesh.element_blocks
        .iter()
        .filter(|b| b.entity_dim == 2 && matches!(b.element_type, etype::TRI3 | etype::TRI6))
        .map(|b| b.len())
        .sum()
}

/// The surfaces of `mesh` that hold triangles (3- or 6-node): those a run recombines.
pub(super) fn input_surfaces(mesh: &Mesh) -> usize {
    mesh.sorted_surfaces(|b| matches!(b.element_type, etype::TRI3 | etype::TRI6) && !b.is_empty())
        .len()
}

/// The line a run ends with: the input's surfaces with triangles and its triangles ->
/// quads, the quads' worst and mean η (eq. 3), what changed besides the pairing (parity
/// repair, fallback, refinement), where the mesh went and the whole run's time.
pub(super) fn summary_line(
    report: &crate::Report,
    (surfaces, triangles): (usize, usize),
    mesh: &Mesh,
    output: &Path,
    seconds: f64,
) -> String {
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
    let turns = report
        .recombine
        .parity_splits
        .iter()
        .filter(|s| s.turn)
        .count();
    let splits = report.recombine.parity_splits.len() - turns;
    if splits > 0 {
        notes.push(format!("parity repair split {splits} boundary segment(s)"));
    }
    if turns > 0 {
        notes.push(format!(
            "{} narrow face end(s) turned across {turns} shared curve segment(s)",
            2 * turns
        ));
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
        if f.pairs_split > 0 {
            notes.push(format!(
                "{} flat pair(s) of triangles into three quads each",
                f.pairs_split
            ));
        }
        if f.triangles_peeled > 0 {
            notes.push(format!(
                "peeled {} boundary fan triangle(s) into a quad on the curve and a triangle at the apex each",
                f.triangles_peeled
            ));
        }
        if f.segments_split > 0 {
            notes.push(format!(
                "split {} boundary segment(s) under bad quads",
                f.segments_split
            ));
        }
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
pub(super) fn time_lines(report: &crate::Report, t_read: f64, t_write: f64) -> Vec<String> {
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
