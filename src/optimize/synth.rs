//! Synthetic meshes built in memory, for tests, examples and benchmarks of the quality and
//! optimization stages: structured and jittered quad grids, triangle grids, greedy triangle
//! pairing, and maps of a planar grid onto a cylinder or a sphere patch.
//!
//! Everything is deterministic: randomness comes from a seeded xorshift generator.

use crate::mesh::{etype, ElementBlock, Entity, Mesh, NodeBlock};
use crate::quality::eta;
use glam::DVec3;

/// A deterministic xorshift64* generator (no external RNG needed for fixtures).
#[derive(Debug, Clone)]
pub struct Rng(u64);

impl Rng {
    /// A generator from a seed (0 is replaced by a fixed non-zero constant).
    pub fn new(seed: u64) -> Self {
        Rng(if seed == 0 {
            0x9E37_79B9_7F4A_7C15
        } else {
            seed
        })
    }
    /// Uniform in [0, 1).
    pub fn next_f64(&mut self) -> f64 {
        self.0 ^= self.0 >> 12;
        self.0 ^= self.0 << 25;
        self.0 ^= self.0 >> 27;
        let v = self.0.wrapping_mul(0x2545_F491_4F6C_DD1D);
        (v >> 11) as f64 / (1u64 << 53) as f64
    }
    /// Uniform in [-1, 1).
    pub fn sym(&mut self) -> f64 {
        2.0 * self.next_f64() - 1.0
    }
}

/// Points and faces (3 or 4 node indices, counter-clockwise seen from +z before mapping).
#[derive(Debug, Clone, Default)]
pub struct Soup {
    /// Node coordinates.
    pub points: Vec<DVec3>,
    /// Faces: triangles (3 indices) and quads (4 indices).
    pub faces: Vec<Vec<usize>>,
}

/// A structured `nx × ny` quad grid on `[0, lx] × [0, ly]`, counter-clockwise quads.
pub fn quad_grid(nx: usize, ny: usize, lx: f64, ly: f64) -> Soup {
    let mut s = Soup::default();
    for j in 0..=ny {
        for i in 0..=nx {
            s.points.push(DVec3::new(
                lx * i as f64 / nx as f64,
                ly * j as f64 / ny as f64,
                0.0,
            ));
        }
    }
    let id = |i: usize, j: usize| j * (nx + 1) + i;
    for j in 0..ny {
        for i in 0..nx {
            s.faces
                .push(vec![id(i, j), id(i + 1, j), id(i + 1, j + 1), id(i, j + 1)]);
        }
    }
    s
}

/// A structured triangle grid: every cell of an `nx × ny` grid split along a diagonal, the
/// diagonal direction chosen at random (seeded) so greedy pairing is not trivially perfect.
pub fn tri_grid(nx: usize, ny: usize, lx: f64, ly: f64, seed: u64) -> Soup {
    let q = quad_grid(nx, ny, lx, ly);
    let mut rng = Rng::new(seed);
    let mut s = Soup {
        points: q.points,
        faces: Vec::new(),
    };
    for f in q.faces {
        if rng.next_f64() < 0.5 {
            s.faces.push(vec![f[0], f[1], f[2]]);
            s.faces.push(vec![f[0], f[2], f[3]]);
        } else {
            s.faces.push(vec![f[0], f[1], f[3]]);
            s.faces.push(vec![f[1], f[2], f[3]]);
        }
    }
    s
}

/// Nodes on the boundary of the soup (on an edge used by exactly one face).
pub fn boundary_nodes(s: &Soup) -> Vec<bool> {
    let mut edges: Vec<(usize, usize)> = Vec::new();
    for f in &s.faces {
        for k in 0..f.len() {
            let (a, b) = (f[k], f[(k + 1) % f.len()]);
            edges.push((a.min(b), a.max(b)));
        }
    }
    edges.sort_unstable();
    let mut out = vec![false; s.points.len()];
    let mut i = 0;
    while i < edges.len() {
        let mut j = i + 1;
        while j < edges.len() && edges[j] == edges[i] {
            j += 1;
        }
        if j - i == 1 {
            out[edges[i].0] = true;
            out[edges[i].1] = true;
        }
        i = j;
    }
    out
}

/// Moves every non-boundary node by a uniform random offset of at most `amount` in x and y.
pub fn jitter(s: &mut Soup, amount: f64, seed: u64) {
    let fixed = boundary_nodes(s);
    let mut rng = Rng::new(seed);
    for (p, &f) in s.points.iter_mut().zip(&fixed) {
        let (dx, dy) = (rng.sym() * amount, rng.sym() * amount);
        if !f {
            p.x += dx;
            p.y += dy;
        }
    }
}

/// Greedy pairing of adjacent triangles into quads, best η first (the paper's section 3
/// quad-dominant method); unpaired triangles stay. Quads keep the triangles' orientation.
pub fn pair_greedy(s: &Soup) -> Soup {
    // candidate pairs through shared edges
    let mut half: Vec<(usize, usize, usize)> = Vec::new();
    for (t, f) in s.faces.iter().enumerate() {
        if f.len() != 3 {
            continue;
        }
        for k in 0..3 {
            let (a, b) = (f[k], f[(k + 1) % 3]);
            half.push((a.min(b), a.max(b), t));
        }
    }
    half.sort_unstable();
    let mut cands: Vec<(f64, usize, usize, [usize; 4])> = Vec::new();
    for w in half.windows(2) {
        if w[0].0 == w[1].0 && w[0].1 == w[1].1 {
            let (t1, t2) = (w[0].2, w[1].2);
            if let Some(q) = merge_triangles(&s.faces[t1], &s.faces[t2]) {
                let p = q.map(|i| s.points[i]);
                cands.push((eta(&p), t1, t2, q));
            }
        }
    }
    cands.sort_by(|a, b| b.0.total_cmp(&a.0));
    let mut used = vec![false; s.faces.len()];
    let mut out = Soup {
        points: s.points.clone(),
        faces: Vec::new(),
    };
    for (_, t1, t2, q) in cands {
        if !used[t1] && !used[t2] {
            used[t1] = true;
            used[t2] = true;
            out.faces.push(q.to_vec());
        }
    }
    for (t, f) in s.faces.iter().enumerate() {
        if !used[t] {
            out.faces.push(f.clone());
        }
    }
    out
}

/// The quad made of two triangles sharing an edge, in their orientation.
fn merge_triangles(t1: &[usize], t2: &[usize]) -> Option<[usize; 4]> {
    for k in 0..3 {
        let (a, b, c) = (t1[k], t1[(k + 1) % 3], t1[(k + 2) % 3]);
        // t2 must contain the edge b -> a
        for m in 0..3 {
            if t2[m] == b && t2[(m + 1) % 3] == a {
                let d = t2[(m + 2) % 3];
                return Some([a, d, b, c]);
            }
        }
    }
    None
}

/// Maps the plane onto a cylinder of radius `r` around the y axis: x becomes the arc
/// length (angle x/r), y stays, z = r cos − r.
pub fn map_to_cylinder(s: &mut Soup, r: f64) {
    for p in &mut s.points {
        let a = p.x / r;
        *p = DVec3::new(r * a.sin(), p.y, r * a.cos() - r);
    }
}

/// Maps the plane onto the sphere of radius `r` centred at (0, 0, −r) by the inverse
/// gnomonic-like map x, y → r·(x, y, r)/|(x, y, r)| − (0, 0, r): keeps orientation (normals
/// point away from the centre).
pub fn map_to_sphere(s: &mut Soup, r: f64) {
    for p in &mut s.points {
        let v = DVec3::new(p.x, p.y, r).normalize() * r;
        *p = v - DVec3::new(0.0, 0.0, r);
    }
}

/// Builds a [`Mesh`] with one surface entity (tag 1) holding the faces, one curve entity
/// (tag 1) holding the boundary nodes and the boundary edges as line elements. Node tags are
/// `1..=n` (index + 1), element tags follow: lines first, then triangles, then quads.
pub fn to_mesh(s: &Soup) -> Mesh {
    let on_boundary = boundary_nodes(s);
    let mut mesh = Mesh::default();
    let bbox = bbox(&s.points);
    mesh.entities[1].push(Entity {
        dim: 1,
        tag: 1,
        bbox,
        physical_tags: vec![],
        bounding: vec![],
    });
    mesh.entities[2].push(Entity {
        dim: 2,
        tag: 1,
        bbox,
        physical_tags: vec![],
        bounding: vec![1],
    });
    mesh.has_entities_section = true;
    let mut curve = NodeBlock {
        entity_dim: 1,
        entity_tag: 1,
        tags: vec![],
        coords: vec![],
        params: None,
    };
    let mut surf = NodeBlock {
        entity_dim: 2,
        entity_tag: 1,
        ..curve.clone()
    };
    for (i, p) in s.points.iter().enumerate() {
        let b = if on_boundary[i] {
            &mut curve
        } else {
            &mut surf
        };
        b.tags.push(i as u64 + 1);
        b.coords.push(p.to_array());
    }
    mesh.node_blocks = vec![curve, surf];
    let mut tag = 1u64;
    let block = |dim: i32, ty: u32, els: Vec<Vec<usize>>, tag: &mut u64| ElementBlock {
        entity_dim: dim,
        entity_tag: 1,
        element_type: ty,
        tags: els
            .iter()
            .map(|_| {
                *tag += 1;
                *tag - 1
            })
            .collect(),
        nodes: els.iter().flatten().map(|&i| i as u64 + 1).collect(),
        partitions: None,
    };
    // boundary edges in face orientation
    let mut lines = Vec::new();
    let mut edges: Vec<(usize, usize, usize, usize)> = Vec::new();
    for f in &s.faces {
        for k in 0..f.len() {
            let (a, b) = (f[k], f[(k + 1) % f.len()]);
            edges.push((a.min(b), a.max(b), a, b));
        }
    }
    edges.sort_unstable();
    let mut i = 0;
    while i < edges.len() {
        let mut j = i + 1;
        while j < edges.len() && edges[j].0 == edges[i].0 && edges[j].1 == edges[i].1 {
            j += 1;
        }
        if j - i == 1 {
            lines.push(vec![edges[i].2, edges[i].3]);
        }
        i = j;
    }
    let tris: Vec<Vec<usize>> = s.faces.iter().filter(|f| f.len() == 3).cloned().collect();
    let quads: Vec<Vec<usize>> = s.faces.iter().filter(|f| f.len() == 4).cloned().collect();
    let mut blocks = vec![block(1, etype::LINE2, lines, &mut tag)];
    if !tris.is_empty() {
        blocks.push(block(2, etype::TRI3, tris, &mut tag));
    }
    if !quads.is_empty() {
        blocks.push(block(2, etype::QUAD4, quads, &mut tag));
    }
    mesh.element_blocks = blocks;
    mesh
}

fn bbox(points: &[DVec3]) -> [f64; 6] {
    let mut lo = DVec3::splat(f64::INFINITY);
    let mut hi = DVec3::splat(f64::NEG_INFINITY);
    for &p in points {
        lo = lo.min(p);
        hi = hi.max(p);
    }
    [lo.x, lo.y, lo.z, hi.x, hi.y, hi.z]
}

/// A Delaunay triangulation (spade) of the unit square `[0, l]²`: `n` nodes per side on the
/// boundary (an even number of boundary nodes, so the triangle count is even, eq. 5) and a
/// jittered `n × n` lattice inside, like the output of a 2D mesher at uniform size `l / n`.
pub fn delaunay_square(n: usize, l: f64, jitter_amount: f64, seed: u64) -> Soup {
    use spade::{DelaunayTriangulation, Point2, Triangulation};
    let mut rng = Rng::new(seed);
    let h = l / n as f64;
    let mut pts: Vec<DVec3> = Vec::new();
    for i in 0..n {
        let t = i as f64 * h;
        pts.push(DVec3::new(t, 0.0, 0.0));
        pts.push(DVec3::new(l, t, 0.0));
        pts.push(DVec3::new(l - t, l, 0.0));
        pts.push(DVec3::new(0.0, l - t, 0.0));
    }
    for j in 1..n {
        for i in 1..n {
            // shift every other row by half a cell: a triangular lattice, like a frontal mesher
            let shift = if j % 2 == 1 { 0.5 * h } else { 0.0 };
            let x = i as f64 * h + shift + rng.sym() * jitter_amount * h;
            let y = j as f64 * h + rng.sym() * jitter_amount * h;
            if x > 0.5 * h && x < l - 0.5 * h {
                pts.push(DVec3::new(x, y, 0.0));
            }
        }
    }
    let mut dt: DelaunayTriangulation<Point2<f64>> = DelaunayTriangulation::new();
    let mut ids = Vec::new();
    for p in &pts {
        if let Ok(v) = dt.insert(Point2::new(p.x, p.y)) {
            ids.push(v);
        }
    }
    let points: Vec<DVec3> = dt
        .vertices()
        .map(|v| DVec3::new(v.position().x, v.position().y, 0.0))
        .collect();
    let faces = dt
        .inner_faces()
        .map(|f| f.vertices().iter().map(|v| v.fix().index()).collect())
        .collect();
    Soup { points, faces }
}

/// All-quad recombination of a triangle soup by an exact minimum-cost perfect matching
/// (eq. 4, cost 1 − η) over interior edges, without extra edges: `None` when the triangle
/// count is odd or no perfect matching exists. A stand-in for `recombine` in fixtures.
pub fn pair_optimal(s: &Soup) -> Option<Soup> {
    let mut half: Vec<(usize, usize, usize)> = Vec::new();
    for (t, f) in s.faces.iter().enumerate() {
        for k in 0..3 {
            let (a, b) = (f[k], f[(k + 1) % 3]);
            half.push((a.min(b), a.max(b), t));
        }
    }
    half.sort_unstable();
    let mut edges = Vec::new();
    let mut quads = Vec::new();
    for w in half.windows(2) {
        if w[0].0 == w[1].0 && w[0].1 == w[1].1 {
            let q = merge_triangles(&s.faces[w[0].2], &s.faces[w[1].2])?;
            let p = q.map(|i| s.points[i]);
            let n = (p[2] - p[0]).cross(p[3] - p[1]);
            let c = 1.0 - crate::quality::eta_signed(&p, n);
            edges.push((w[0].2 as u32, w[1].2 as u32, c));
            quads.push(((w[0].2, w[1].2), q));
        }
    }
    let m = crate::matching::solve_f64(s.faces.len(), &edges).ok()?;
    let mut out = Soup {
        points: s.points.clone(),
        faces: Vec::new(),
    };
    for ((a, b), q) in quads {
        if m.mate.get(a).copied() == Some(b as u32) {
            out.faces.push(q.to_vec());
        }
    }
    (2 * out.faces.len() == s.faces.len()).then_some(out)
}
