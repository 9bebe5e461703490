//! Timing of the recombination on large in-memory meshes. Ignored by default (no timed
//! assertions in tests); run with
//! `cargo test --release --test recombine bench -- --ignored --nocapture`.

use crate::recombine_util;

use std::time::Instant;

use blossomquad::recombine::{recombine, RecombineOptions};
use recombine_util::*;

fn run(nx: usize, verify: bool) {
    let t = Instant::now();
    let mesh = grid(&Grid {
        nx,
        ny: nx,
        jitter: 0.7,
        seed: 7,
        ..Default::default()
    });
    let build = t.elapsed();
    let mut m = mesh.clone();
    let t = Instant::now();
    let r = recombine(
        &mut m,
        &RecombineOptions {
            verify,
            ..Default::default()
        },
    )
    .unwrap();
    let total = t.elapsed();
    let s = &r.surfaces[0];
    eprintln!(
        "{} triangles -> {} quads: total {:.3} s (graph {:.3}, matching {:.3}, post {:.3}), verify {verify}, extra used {}, mesh build {:.2} s",
        s.triangles_in,
        s.quads_out,
        total.as_secs_f64(),
        s.time_graph.as_secs_f64(),
        s.time_matching.as_secs_f64(),
        s.time_post.as_secs_f64(),
        s.extra_edges_used,
        build.as_secs_f64()
    );
    assert_eq!(s.quads_out * 2, s.triangles_in);
}

#[test]
#[ignore]
fn bench_grid_100k() {
    run(224, false);
}

#[test]
#[ignore]
fn bench_grid_1m() {
    run(707, false);
}

/// Read → recombine → write of the file named by `BLOSSOMQUAD_BENCH_MSH` (skipped when
/// unset).
#[test]
#[ignore]
fn bench_file_end_to_end() {
    let Some(path) = std::env::var_os("BLOSSOMQUAD_BENCH_MSH") else {
        eprintln!("BLOSSOMQUAD_BENCH_MSH not set; skipping");
        return;
    };
    let path = std::path::PathBuf::from(path);
    let t = Instant::now();
    let mut m = blossomquad::msh::read_file(&path).unwrap();
    let read = t.elapsed();
    eprintln!("read {:.3} s", read.as_secs_f64());
    let t = Instant::now();
    let opts = RecombineOptions {
        extra_edges: std::env::var_os("BLOSSOMQUAD_BENCH_NO_EXTRA").is_none(),
        ..Default::default()
    };
    let r = recombine(&mut m, &opts).unwrap();
    let rec = t.elapsed();
    let out = std::env::temp_dir().join("blossomquad_bench_out.msh");
    let t = Instant::now();
    blossomquad::msh::write_file(&m, &out, blossomquad::msh::default_output_format(&m)).unwrap();
    let write = t.elapsed();
    let tris: usize = r.surfaces.iter().map(|s| s.triangles_in).sum();
    let sum = |f: fn(&blossomquad::recombine::SurfaceReport) -> std::time::Duration| -> f64 {
        r.surfaces.iter().map(|s| f(s).as_secs_f64()).sum()
    };
    let matching = sum(|s| s.time_matching);
    eprintln!(
        "graph {:.3} s, post {:.3} s (summed over surfaces)",
        sum(|s| s.time_graph),
        sum(|s| s.time_post)
    );
    eprintln!(
        "{}: {tris} triangles, {} surfaces, {} parity splits: read {:.3} s, recombine {:.3} s (matching {:.3} s summed over surfaces), write {:.3} s",
        path.display(),
        r.surfaces.len(),
        r.parity_splits.len(),
        read.as_secs_f64(),
        rec.as_secs_f64(),
        matching,
        write.as_secs_f64()
    );
    let _ = std::fs::remove_file(out);
}

/// Recombines (with verification) every .msh file in `BLOSSOMQUAD_STRESS_DIR` (skipped when
/// unset) and reports failures.
#[test]
#[ignore]
fn stress_dir() {
    let Some(dir) = std::env::var_os("BLOSSOMQUAD_STRESS_DIR") else {
        eprintln!("BLOSSOMQUAD_STRESS_DIR not set; skipping");
        return;
    };
    let mut files: Vec<_> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e == "msh"))
        .collect();
    files.sort();
    let mut failed = Vec::new();
    for f in &files {
        let before = blossomquad::msh::read_file(f).unwrap();
        let mut m = before.clone();
        let opts = RecombineOptions {
            verify: true,
            drop_volumes: true,
            ..Default::default()
        };
        match recombine(&mut m, &opts) {
            Ok(r) => eprintln!(
                "{}: {} surfaces, {} triangles, {} splits, {} extra used ({} swaps, {} dups), {} retriangulated",
                f.display(),
                r.surfaces.len(),
                r.surfaces.iter().map(|s| s.triangles_in).sum::<usize>(),
                r.parity_splits.len(),
                r.surfaces.iter().map(|s| s.extra_edges_used).sum::<usize>(),
                r.surfaces.iter().map(|s| s.edge_swaps).sum::<usize>(),
                r.surfaces.iter().map(|s| s.vertex_duplications).sum::<usize>(),
                r.retriangulated.len()
            ),
            Err(e) => {
                eprintln!("{}: FAILED {e}", f.display());
                failed.push(f.clone());
            }
        }
    }
    assert!(failed.is_empty(), "{failed:?}");
}
