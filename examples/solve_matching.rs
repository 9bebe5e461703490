//! Benchmark driver: reads a graph file (first line `n m`, then `m` lines `u v cost`,
//! 0-based), solves the minimum-cost perfect matching, checks the optimality certificate and
//! prints one line `n=… m=… cost=… time_s=… verified=true`.
//!
//! Usage: `solve_matching <file> [--stats] [--given-order] [--blocks K]` (`--given-order`:
//! the solver keeps the file's vertex numbering, [`matching::VertexOrder::Given`];
//! `--blocks K`: the fractional start in `K` blocks side by side, whatever the size, 1 for
//! the single start). `time_s` covers the solver only (not parsing
//! nor verification, reported separately as `parse_s` and `verify_s`); `solve_peak_mb` is the
//! peak resident memory during the solve (the parsed edge list included; Linux only, `?`
//! elsewhere).

use blossomquad::matching;
use std::time::Instant;

/// A graph: vertex count and edges `(u, v, cost)`.
type Graph = (usize, Vec<(u32, u32, i64)>);

fn parse(text: &str) -> Result<Graph, String> {
    let mut it = text.split_ascii_whitespace();
    // `what` is only formatted on error (a `format!` per field would dominate the parse).
    let mut next = |what: &dyn Fn() -> String| -> Result<i64, String> {
        it.next()
            .ok_or_else(|| format!("unexpected end of file reading {}", what()))?
            .parse::<i64>()
            .map_err(|e| format!("bad {}: {e}", what()))
    };
    let n = next(&|| "n".to_string())?;
    let m = next(&|| "m".to_string())?;
    if n < 0 || n > u32::MAX as i64 || m < 0 {
        return Err(format!("bad header n={n} m={m}"));
    }
    let mut edges = Vec::with_capacity(m as usize);
    for i in 0..m {
        let u = next(&|| format!("u of edge {i}"))?;
        let v = next(&|| format!("v of edge {i}"))?;
        let c = next(&|| format!("cost of edge {i}"))?;
        if u < 0 || v < 0 || u >= n || v >= n {
            return Err(format!("edge {i} ({u}, {v}) out of range"));
        }
        edges.push((u as u32, v as u32, c));
    }
    Ok((n as usize, edges))
}

/// The process's peak resident memory in MB (`VmHWM` of `/proc/self/status`), if known.
fn peak_mb() -> Option<f64> {
    let status = std::fs::read_to_string("/proc/self/status").ok()?;
    let line = status.lines().find(|l| l.starts_with("VmHWM:"))?;
    let kb: f64 = line.split_whitespace().nth(1)?.parse().ok()?;
    Some(kb / 1024.0)
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().collect();
    let path = args
        .get(1)
        .ok_or("usage: solve_matching <file> [--stats] [--given-order] [--blocks K]")?;
    let stats = args.iter().any(|a| a == "--stats");
    let order = if args.iter().any(|a| a == "--given-order") {
        matching::VertexOrder::Given
    } else {
        matching::VertexOrder::BreadthFirst
    };
    // `--blocks K`: the fractional start in K blocks side by side, whatever the size
    let blocks = args
        .iter()
        .position(|a| a == "--blocks")
        .map(|i| {
            args.get(i + 1)
                .and_then(|k| k.parse::<usize>().ok())
                .ok_or("--blocks needs a block count")
        })
        .transpose()?;
    let t0 = Instant::now();
    let text = std::fs::read_to_string(path).map_err(|e| format!("{path}: {e}"))?;
    let (n, edges) = parse(&text).map_err(|e| format!("{path}: {e}"))?;
    drop(text);
    let parse_s = t0.elapsed().as_secs_f64();
    // Peak resident memory of the solve alone: reset the high-water mark (Linux), read it
    // after the solve (the parsed edge list, alive throughout, is included).
    let _ = std::fs::write("/proc/self/clear_refs", "5");
    let t1 = Instant::now();
    let c1 = blossomquad::profile::cpu_seconds();
    let result = if stats {
        let mut solver = matching::blossom::Solver::new_in_order(n, &edges, order);
        if std::env::var("GREEDY").is_ok() {
            solver.init_greedy();
        } else if let Some(k) = blocks {
            solver.init_fractional_blocks(k);
        } else {
            solver.init_fractional();
        }
        let init_stats = solver.stats;
        let init_s = t1.elapsed().as_secs_f64();
        let r = solver.solve_rest();
        eprintln!("init {init_s:.3}s {init_stats:?}\ntotal {:?}", solver.stats);
        r
    } else if let Some(k) = blocks {
        matching::blossom::Solver::new_in_order(n, &edges, order).run_in_blocks(k)
    } else if order == matching::VertexOrder::Given {
        matching::blossom::Solver::new_in_order(n, &edges, order).run()
    } else {
        matching::solve(n, &edges)
    };
    let time_s = t1.elapsed().as_secs_f64();
    let cpu_s = blossomquad::profile::cpu_seconds() - c1;
    let peak = peak_mb().map_or_else(|| "?".to_string(), |p| format!("{p:.1}"));
    match result {
        Ok(m) => {
            let t2 = Instant::now();
            let ok = matching::verify(n, &edges, &m);
            let verify_s = t2.elapsed().as_secs_f64();
            if let Err(e) = &ok {
                eprintln!("certificate failed: {e}");
            }
            println!(
                "n={n} m={} cost={} time_s={time_s:.3} cpu_s={cpu_s:.2} verified={} parse_s={parse_s:.3} verify_s={verify_s:.3} solve_peak_mb={peak}",
                edges.len(),
                m.cost,
                ok.is_ok()
            );
            if ok.is_err() {
                std::process::exit(1);
            }
        }
        Err(w) => {
            let ok = matching::verify_witness(n, &edges, &w).is_ok();
            println!(
                "n={n} m={} no_perfect_matching witness={} odd_components={} time_s={time_s:.3} witness_verified={ok}",
                edges.len(),
                w.witness.len(),
                w.odd_components.len()
            );
        }
    }
    Ok(())
}
