//! Timing of the recombination on large in-memory meshes. Ignored by default (no timed
//! assertions in tests); run with
//! `cargo test --release --test recombine_bench -- --ignored --nocapture`.

mod recombine_util;

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
