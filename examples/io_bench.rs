//! MSH read/write throughput next to Gmsh on the same files (a benchmark, not a test).
//!
//! Usage: `cargo run --release --example io_bench -- MESH.msh [MESH2.msh ...]`
//! (scripts/bench_io.sh generates ~1e6-triangle meshes and runs this).
//!
//! Wall times are shown, and (Linux) CPU times, which stay meaningful on a loaded machine:
//! ours from `/proc/thread-self/schedstat`, Gmsh's from the children CPU ticks of
//! `/proc/self/stat`.
//!
//! For each file: best of 3 runs of our read (file → Mesh), our write (Mesh → file, same
//! version and encoding, atomic write_file), and one run of `gmsh IN -0 -o OUT` (with `-bin`
//! for binary input so both write the same encoding), then MB/s and the time ratio.

use std::path::PathBuf;
use std::process::Command;
use std::time::{Duration, Instant};

use blossomquad::msh;

/// CPU time this thread has run, from the scheduler (nanoseconds), if available.
fn thread_cpu() -> Option<Duration> {
    let s = std::fs::read_to_string("/proc/thread-self/schedstat").ok()?;
    let ns: u64 = s.split_whitespace().next()?.parse().ok()?;
    Some(Duration::from_nanos(ns))
}

/// CPU time (user + system) of the children waited for, from `/proc/self/stat`.
fn children_cpu() -> Option<Duration> {
    let s = std::fs::read_to_string("/proc/self/stat").ok()?;
    // Fields after the command name (which may hold spaces) start at state (field 3);
    // cutime and cstime are fields 16 and 17, in clock ticks (100 per second on Linux).
    let rest = &s[s.rfind(')')? + 2..];
    let f: Vec<&str> = rest.split_whitespace().collect();
    let ticks: u64 = f.get(13)?.parse::<u64>().ok()? + f.get(14)?.parse::<u64>().ok()?;
    Some(Duration::from_millis(ticks * 10))
}

/// Best wall time and best CPU time of `n` runs, and the last result.
fn best_of<T>(n: usize, mut f: impl FnMut() -> T) -> (Duration, Option<Duration>, T) {
    let mut best = Duration::MAX;
    let mut best_cpu: Option<Duration> = None;
    let mut last = None;
    for _ in 0..n {
        let c = thread_cpu();
        let t = Instant::now();
        let v = f();
        best = best.min(t.elapsed());
        if let (Some(a), Some(b)) = (c, thread_cpu()) {
            let d = b.saturating_sub(a);
            best_cpu = Some(best_cpu.map_or(d, |x| x.min(d)));
        }
        last = Some(v);
    }
    (best, best_cpu, last.expect("n > 0"))
}

fn secs(d: Option<Duration>) -> String {
    d.map_or("n/a".into(), |d| format!("{:.3} s", d.as_secs_f64()))
}

fn mbps(bytes: u64, d: Duration) -> f64 {
    bytes as f64 / 1e6 / d.as_secs_f64()
}

fn main() {
    let files: Vec<PathBuf> = std::env::args().skip(1).map(PathBuf::from).collect();
    if files.is_empty() {
        eprintln!("usage: io_bench MESH.msh [MESH2.msh ...]");
        std::process::exit(2);
    }
    let tmp = tempfile::tempdir().expect("temp dir");
    for f in &files {
        let size = std::fs::metadata(f).map(|m| m.len()).unwrap_or(0);
        let (t_read, c_read, mesh) = best_of(3, || msh::read_file(f));
        let mesh = match mesh {
            Ok(m) => m,
            Err(e) => {
                eprintln!("{e}");
                std::process::exit(1);
            }
        };
        let format = msh::default_output_format(&mesh);
        let out = tmp.path().join("ours.msh");
        let (t_write, c_write, r) = best_of(3, || msh::write_file(&mesh, &out, format));
        if let Err(e) = r {
            eprintln!("{e}");
            std::process::exit(1);
        }
        let out_size = std::fs::metadata(&out).map(|m| m.len()).unwrap_or(0);
        let ours = t_read + t_write;

        let gout = tmp.path().join("gmsh.msh");
        let mut cmd = Command::new("gmsh");
        cmd.arg(f).arg("-0").arg("-o").arg(&gout);
        if format.binary {
            cmd.arg("-bin");
        }
        let c0 = children_cpu();
        let t = Instant::now();
        let status = cmd.output().map(|o| o.status.success());
        let t_gmsh = t.elapsed();
        let c_gmsh = c0.zip(children_cpu()).map(|(a, b)| b.saturating_sub(a));
        let c_ours = c_read.zip(c_write).map(|(a, b)| a + b);

        let tris: usize = mesh.count_elements(2);
        println!(
            "{} ({:.1} MB, {} nodes, {} triangles, {})",
            f.display(),
            size as f64 / 1e6,
            mesh.node_count(),
            tris,
            if format.binary { "binary" } else { "ASCII" }
        );
        println!(
            "  ours : read {:8.3} s ({:7.1} MB/s)  write {:8.3} s ({:7.1} MB/s)  total {:8.3} s",
            t_read.as_secs_f64(),
            mbps(size, t_read),
            t_write.as_secs_f64(),
            mbps(out_size, t_write),
            ours.as_secs_f64()
        );
        match status {
            Ok(true) => println!(
                "  gmsh : IN -0 -o OUT{}  total {:8.3} s ({:7.1} MB/s)   gmsh/ours = {:.2}x",
                if format.binary { " -bin" } else { "" },
                t_gmsh.as_secs_f64(),
                mbps(size, t_gmsh),
                t_gmsh.as_secs_f64() / ours.as_secs_f64()
            ),
            _ => println!("  gmsh : not run (gmsh missing or failed)"),
        }
        println!(
            "  cpu  : ours read {} + write {} = {}; gmsh {}{}",
            secs(c_read),
            secs(c_write),
            secs(c_ours),
            secs(c_gmsh),
            match (c_ours, c_gmsh) {
                (Some(o), Some(g)) if o > Duration::ZERO => format!(
                    "; gmsh/ours = {:.2}x; our read {:.1} MB/s of CPU",
                    g.as_secs_f64() / o.as_secs_f64(),
                    mbps(size, c_read.unwrap_or(o))
                ),
                _ => String::new(),
            }
        );
    }
}
