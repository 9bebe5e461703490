//! Writes a matching benchmark graph: the triangle-adjacency graph of a planar Delaunay mesh
//! (spade), with the Blossom-Quad cost of each graph edge.
//!
//! Usage: `gen_matching_graph <lattice|random> <triangles> <out-file> [seed]`
//! - `lattice`: jittered equilateral lattice (near-equilateral triangles, like a frontal
//!   mesher; many near-ties);
//! - `random`: uniform random points in the unit square (many poor quads).
//!
//! Output format: first line `n m`, then `m` lines `u v cost` (0-based). The cost of the edge
//! between triangles `t_i`, `t_j` is `round(1000 · (1 − η(q_ij)))` with `q_ij` the quad made
//! by merging them and `η` the quality of paper eq. (3). If the mesh has an odd number of
//! triangles, one boundary triangle is dropped so that a perfect matching can exist.

use spade::{DelaunayTriangulation, Point2, Triangulation};
use std::f64::consts::PI;
use std::io::Write;

/// SplitMix64.
struct Rng(u64);
impl Rng {
    fn next_f64(&mut self) -> f64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        ((z ^ (z >> 31)) >> 11) as f64 / (1u64 << 53) as f64
    }
}

/// Quad quality η of paper eq. (3): `max(1 − (2/π)·max_k |π/2 − α_k|, 0)` for the corners
/// `p[0..4]` in order.
fn eta(p: [[f64; 2]; 4]) -> f64 {
    let mut worst: f64 = 0.0;
    for k in 0..4 {
        let (a, b, c) = (p[(k + 3) % 4], p[k], p[(k + 1) % 4]);
        let (u, v) = ([a[0] - b[0], a[1] - b[1]], [c[0] - b[0], c[1] - b[1]]);
        let cross = v[0] * u[1] - v[1] * u[0];
        let dot = u[0] * v[0] + u[1] * v[1];
        // Interior angle of a counter-clockwise polygon, in (0, 2π).
        let mut ang = cross.atan2(dot);
        if ang < 0.0 {
            ang += 2.0 * PI;
        }
        worst = worst.max((PI / 2.0 - ang).abs());
    }
    (1.0 - 2.0 / PI * worst).max(0.0)
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().collect();
    if args.len() < 4 {
        return Err(
            "usage: gen_matching_graph <lattice|random> <triangles> <out-file> [seed]".into(),
        );
    }
    let kind = args[1].as_str();
    let target: usize = args[2].parse()?;
    let seed: u64 = args.get(4).map(|s| s.parse()).transpose()?.unwrap_or(1);
    let mut rng = Rng(seed);
    let mut pts = Vec::new();
    match kind {
        "lattice" => {
            // A W×H point lattice has about 2·W·H triangles.
            let w = ((target as f64 / 2.0 / 0.866).sqrt()).ceil() as usize + 1;
            let h = ((target as f64 / 2.0) / w as f64).ceil() as usize + 1;
            let dy = 3f64.sqrt() / 2.0;
            for j in 0..h {
                for i in 0..w {
                    let jx = (rng.next_f64() - 0.5) * 0.2;
                    let jy = (rng.next_f64() - 0.5) * 0.2;
                    let x = i as f64 + 0.5 * (j % 2) as f64 + jx;
                    pts.push(Point2::new(x, j as f64 * dy + jy));
                }
            }
        }
        "random" => {
            for _ in 0..target / 2 + 2 {
                pts.push(Point2::new(rng.next_f64(), rng.next_f64()));
            }
        }
        _ => return Err(format!("unknown family {kind}").into()),
    }
    let t: DelaunayTriangulation<Point2<f64>> = DelaunayTriangulation::bulk_load(pts)?;
    let nf = t.num_inner_faces();
    let mut edges: Vec<(u32, u32, i64)> = Vec::with_capacity(nf * 3 / 2);
    let pos = |p: Point2<f64>| [p.x, p.y];
    for f in t.inner_faces() {
        let fi = f.fix().index() - 1;
        for e in f.adjacent_edges() {
            let Some(g) = e.rev().face().as_inner() else {
                continue;
            };
            let gi = g.fix().index() - 1;
            if fi >= gi {
                continue;
            }
            let (Some(c), Some(d)) = (e.opposite_vertex(), e.rev().opposite_vertex()) else {
                continue;
            };
            let (a, b) = (e.from().position(), e.to().position());
            let q = [pos(a), pos(d.position()), pos(b), pos(c.position())];
            let cost = (1000.0 * (1.0 - eta(q))).round() as i64;
            edges.push((fi as u32, gi as u32, cost));
        }
    }
    let mut n = nf;
    if n % 2 == 1 {
        // Drop a triangle of smallest degree (a corner), renumbering the last one into its slot.
        let mut deg = vec![0u32; n];
        for &(u, v, _) in &edges {
            deg[u as usize] += 1;
            deg[v as usize] += 1;
        }
        let drop = (0..n).min_by_key(|&v| deg[v]).unwrap_or(0) as u32;
        let last = (n - 1) as u32;
        edges.retain(|&(u, v, _)| u != drop && v != drop);
        for e in &mut edges {
            if e.0 == last {
                e.0 = drop;
            }
            if e.1 == last {
                e.1 = drop;
            }
        }
        n -= 1;
    }
    let mut out = std::io::BufWriter::new(std::fs::File::create(&args[3])?);
    writeln!(out, "{} {}", n, edges.len())?;
    for (u, v, c) in &edges {
        writeln!(out, "{u} {v} {c}")?;
    }
    out.flush()?;
    eprintln!("{kind}: n={n} m={}", edges.len());
    Ok(())
}
