//! Measures the optimizer on synthetic inputs: a Delaunay triangulation of a square (optionally
//! mapped onto a sphere patch), recombined by an exact matching, then optimized.
//!
//! `cargo run --release --example optimize_bench -- [N] [sphere] [smooth=K] [notopo]`
//! (N nodes per side, default 100: about 2·N² triangles).
//!
//! `... -- quads=Q.msh ref=T.msh [reps=R]`: optimizes the quads of Q.msh (e.g. written by
//! `blossomquad T.msh -o Q.msh --no-optimize`) against the triangles T.msh, best of R runs,
//! and prints time, η_w, η̄, d4 and τ (size field from T.msh).

use blossomquad::optimize::{self, synth, OptimizeOptions};
use blossomquad::quality::{self, ReferenceSize, SizeField};
use std::time::Instant;

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let n: usize = args.first().and_then(|a| a.parse().ok()).unwrap_or(100);
    let sphere = args.iter().any(|a| a == "sphere");
    let mut opts = OptimizeOptions::default();
    for a in &args {
        if let Some(k) = a.strip_prefix("smooth=") {
            opts.smooth_iterations = k.parse().unwrap_or(opts.smooth_iterations);
        }
        if let Some(k) = a.strip_prefix("diag=") {
            opts.diagonal_weight = k.parse().unwrap_or(opts.diagonal_weight);
        }
        if let Some(k) = a.strip_prefix("angles=") {
            opts.angle_sweeps = k.parse().unwrap_or(opts.angle_sweeps);
        }
        if let Some(k) = a.strip_prefix("rounds=") {
            opts.max_rounds = k.parse().unwrap_or(opts.max_rounds);
        }
        if a == "notopo" {
            opts.topology = false;
        }
    }
    if let Some(q) = args.iter().find_map(|a| a.strip_prefix("quads=")) {
        let r = args
            .iter()
            .find_map(|a| a.strip_prefix("ref="))
            .unwrap_or(q);
        let reps: usize = args
            .iter()
            .find_map(|a| a.strip_prefix("reps="))
            .and_then(|k| k.parse().ok())
            .unwrap_or(1);
        files_mode(q, r, reps, &opts);
        return;
    }
    let t0 = Instant::now();
    let from_file = args
        .iter()
        .find_map(|a| a.strip_prefix("file="))
        .map(|path| {
            let m = blossomquad::msh::read_file(std::path::Path::new(path)).expect("read");
            soup_of(&m)
        });
    if let Some(g) = args.iter().find_map(|a| a.strip_prefix("grid=")) {
        // performance mode: a jittered g x g quad grid (g^2 quads), its own reference
        let g: usize = g.parse().unwrap_or(1000);
        let mut s = synth::quad_grid(g, g, 1.0, 1.0);
        synth::jitter(&mut s, 0.3 / g as f64, 3);
        let mut mesh = synth::to_mesh(&s);
        // the triangulation it came from: each quad split along a diagonal
        let split = synth::Soup {
            points: s.points.clone(),
            faces: s
                .faces
                .iter()
                .flat_map(|f| [vec![f[0], f[1], f[2]], vec![f[0], f[2], f[3]]])
                .collect(),
        };
        let reference = synth::to_mesh(&split);
        let t = Instant::now();
        let rep = optimize::optimize(&mut mesh, &reference, &opts).expect("optimize");
        println!("options: {opts:?}");
        println!("optimize time: {:.3?} for {} quads", t.elapsed(), g * g);
        println!("{:?}", rep.surfaces[0]);
        return;
    }
    let Some((mut tris, mut quads)) = from_file
        .and_then(|t| synth::pair_optimal(&t).map(|q| (t, q)))
        .or_else(|| {
            (7..40).find_map(|seed| {
                let tris = synth::delaunay_square(n, 1.0, 0.3, seed);
                synth::pair_optimal(&tris).map(|q| (tris, q))
            })
        })
    else {
        eprintln!("no perfect matching for these inputs");
        return;
    };
    if sphere {
        synth::map_to_sphere(&mut tris, 1.0);
        synth::map_to_sphere(&mut quads, 1.0);
    }
    let tri_mesh = synth::to_mesh(&tris);
    let mut mesh = synth::to_mesh(&quads);
    eprintln!(
        "input built in {:.2?}: {} triangles, {} quads",
        t0.elapsed(),
        tris.faces.len(),
        quads.faces.len()
    );
    let size = SizeField::Reference(ReferenceSize::from_mesh(&tri_mesh).expect("reference"));
    let tri_q = quality::report(&tri_mesh, &size).expect("quality");
    let before = quality::report(&mesh, &size).expect("quality");
    let t = Instant::now();
    let rep = optimize::optimize(&mut mesh, &tri_mesh, &opts).expect("optimize");
    let dt = t.elapsed();
    let after = quality::report(&mesh, &size).expect("quality");
    optimize::check::check_surface_mesh(&mesh).expect("invariants");
    println!("options: {opts:?}");
    println!("optimize time: {dt:.3?} for {} quads", before.total.quads);
    println!("operations: {:?}", rep.surfaces[0].operations);
    let row = |name: &str, s: &quality::SurfaceQuality| {
        println!(
            "{name:<10} quads {:>8} tris {:>8} eta_w {:.3} eta_m {:.3} d4 {:>5.1}% d {}-{} tau {:.1}",
            s.quads,
            s.triangles,
            s.eta_worst.unwrap_or(f64::NAN),
            s.eta_mean.unwrap_or(f64::NAN),
            s.d4_percent.unwrap_or(f64::NAN),
            s.d_min.unwrap_or(0),
            s.d_max.unwrap_or(0),
            s.tau_percent.unwrap_or(f64::NAN)
        );
    };
    row("triangles", &tri_q.total);
    row("before", &before.total);
    row("after", &after.total);
    println!(
        "histogram after: {:?} lh {:?}-{:?}",
        after.total.eta_histogram, after.total.lh_min, after.total.lh_max
    );
    if args.iter().any(|a| a == "worst") {
        let mut etas = quality::quad_etas(&mesh);
        etas.sort_by(|a, b| a.1.total_cmp(&b.1));
        let index = mesh.node_index();
        let quads = mesh
            .element_blocks
            .iter()
            .find(|b| b.element_type == 3)
            .expect("quads");
        for &(tag, e) in etas.iter().take(5) {
            let i = quads.tags.iter().position(|&t| t == tag).unwrap_or(0);
            let pts: Vec<String> = quads
                .element(i)
                .iter()
                .map(|&n| {
                    let r = index.get(n).expect("node");
                    let c = mesh.node_blocks[r.block as usize].coords[r.index as usize];
                    format!(
                        "{}({:.3},{:.3})",
                        if r.block == 0 { "B" } else { "i" },
                        c[0],
                        c[1]
                    )
                })
                .collect();
            println!("worst {tag}: {e:.3} {}", pts.join(" "));
        }
    }
}

/// Optimizes the quads of `quads` against the triangles of `reference` (best of `reps`).
fn files_mode(quads: &str, reference: &str, reps: usize, opts: &OptimizeOptions) {
    let read = |p: &str| blossomquad::msh::read_file(std::path::Path::new(p)).expect("read");
    let tri_mesh = read(reference);
    let input = read(quads);
    let mut best = f64::INFINITY;
    let mut best_cpu = f64::INFINITY;
    let mut mesh = input.clone();
    for _ in 0..reps.max(1) {
        mesh = input.clone();
        let (t, c) = (Instant::now(), blossomquad::profile::cpu_seconds());
        optimize::optimize(&mut mesh, &tri_mesh, opts).expect("optimize");
        best = best.min(t.elapsed().as_secs_f64());
        best_cpu = best_cpu.min(blossomquad::profile::cpu_seconds() - c);
    }
    optimize::check::check_surface_mesh(&mesh).expect("invariants");
    let size = SizeField::Reference(ReferenceSize::from_mesh(&tri_mesh).expect("reference"));
    let q = quality::report(&mesh, &size).expect("quality").total;
    println!(
        "{quads}: optimize {best:.3} s, CPU {best_cpu:.2} s (best of {reps}) quads {} eta_w {:.4} eta_m {:.4} d4 {:.2}% tau {:.2}",
        q.quads,
        q.eta_worst.unwrap_or(f64::NAN),
        q.eta_mean.unwrap_or(f64::NAN),
        q.d4_percent.unwrap_or(f64::NAN),
        q.tau_percent.unwrap_or(f64::NAN)
    );
}

/// All 3-node triangles of a mesh as a soup over its nodes.
fn soup_of(m: &blossomquad::mesh::Mesh) -> synth::Soup {
    let index = m.node_index();
    let mut points = Vec::new();
    let mut id = std::collections::HashMap::new();
    let mut faces = Vec::new();
    for b in m.element_blocks.iter().filter(|b| b.element_type == 2) {
        for e in 0..b.len() {
            let f = b
                .element(e)
                .iter()
                .map(|&t| {
                    *id.entry(t).or_insert_with(|| {
                        let r = index.get(t).expect("node");
                        points.push(glam::DVec3::from_array(
                            m.node_blocks[r.block as usize].coords[r.index as usize],
                        ));
                        points.len() - 1
                    })
                })
                .collect();
            faces.push(f);
        }
    }
    synth::Soup { points, faces }
}
