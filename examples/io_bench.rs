//! MSH read/write throughput next to Gmsh on the same files (a benchmark, not a test).
//!
//! Usage: `cargo run --release --example io_bench -- MESH.msh [MESH2.msh ...]`
//! (scripts/bench_io.sh generates ~1e6-triangle meshes and runs this).
//!
//! For each file: best of 3 runs of our read (file → Mesh), our write (Mesh → file, same
//! version and encoding, atomic write_file), and one run of `gmsh IN -0 -o OUT` (with `-bin`
//! for binary input so both write the same encoding), then MB/s and the time ratio.

use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::{Duration, Instant};

use blossomquad::msh;

fn best_of<T>(n: usize, mut f: impl FnMut() -> T) -> (Duration, T) {
    let mut best = Duration::MAX;
    let mut last = None;
    for _ in 0..n {
        let t = Instant::now();
        let v = f();
        best = best.min(t.elapsed());
        last = Some(v);
    }
    (best, last.expect("n > 0"))
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
        let (t_read, mesh) = best_of(3, || msh::read_file(f));
        let mesh = match mesh {
            Ok(m) => m,
            Err(e) => {
                eprintln!("{e}");
                std::process::exit(1);
            }
        };
        let format = msh::default_output_format(&mesh);
        let out = tmp.path().join("ours.msh");
        let (t_write, r) = best_of(3, || msh::write_file(&mesh, &out, format));
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
        let t = Instant::now();
        let status = cmd.output().map(|o| o.status.success());
        let t_gmsh = t.elapsed();

        let tris: usize = mesh
            .element_blocks
            .iter()
            .filter(|b| b.element_type == 2)
            .map(|b| b.len())
            .sum();
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
    }
    let _ = Path::new(".");
}
