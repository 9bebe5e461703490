//! In-memory test meshes for the recombination tests.
#![allow(dead_code)]

use blossomquad::mesh::{etype, ElementBlock, Entity, Mesh, NodeBlock, PhysicalName};
use std::collections::HashMap;

/// Small deterministic generator (xorshift64*).
pub struct Rng(pub u64);
impl Rng {
    pub fn next_f64(&mut self) -> f64 {
        self.0 ^= self.0 >> 12;
        self.0 ^= self.0 << 25;
        self.0 ^= self.0 >> 27;
        (self.0.wrapping_mul(0x2545F4914F6CDD1D) >> 11) as f64 / (1u64 << 53) as f64
    }
}

/// Incremental mesh builder.
#[derive(Default)]
pub struct Builder {
    pub mesh: Mesh,
    next_elem: u64,
    next_node: u64,
}

impl Builder {
    pub fn new() -> Self {
        Builder {
            next_elem: 1,
            next_node: 1,
            ..Default::default()
        }
    }

    pub fn entity(&mut self, dim: i32, tag: i32, bounding: &[i32], phys: &[i32]) {
        self.mesh.entities[dim as usize].push(Entity {
            dim,
            tag,
            bbox: [0.0; 6],
            physical_tags: phys.to_vec(),
            bounding: bounding.to_vec(),
        });
    }

    /// Adds a node classified on (dim, ent); returns its tag.
    pub fn node(&mut self, dim: i32, ent: i32, p: [f64; 3]) -> u64 {
        let tag = self.next_node;
        self.next_node += 1;
        let blocks = &mut self.mesh.node_blocks;
        let b = match blocks
            .iter()
            .position(|b| b.entity_dim == dim && b.entity_tag == ent)
        {
            Some(i) => &mut blocks[i],
            None => {
                blocks.push(NodeBlock {
                    entity_dim: dim,
                    entity_tag: ent,
                    tags: Vec::new(),
                    coords: Vec::new(),
                    params: None,
                });
                blocks.last_mut().unwrap()
            }
        };
        b.tags.push(tag);
        b.coords.push(p);
        tag
    }

    /// Adds an element of type `ty` on (dim, ent); returns its tag.
    pub fn elem(&mut self, dim: i32, ent: i32, ty: u32, nodes: &[u64]) -> u64 {
        let tag = self.next_elem;
        self.next_elem += 1;
        let blocks = &mut self.mesh.element_blocks;
        let b = match blocks
            .iter()
            .position(|b| b.entity_dim == dim && b.entity_tag == ent && b.element_type == ty)
        {
            Some(i) => &mut blocks[i],
            None => {
                blocks.push(ElementBlock {
                    entity_dim: dim,
                    entity_tag: ent,
                    element_type: ty,
                    tags: Vec::new(),
                    nodes: Vec::new(),
                    partitions: None,
                });
                blocks.last_mut().unwrap()
            }
        };
        b.tags.push(tag);
        b.nodes.extend_from_slice(nodes);
        tag
    }

    pub fn tri(&mut self, ent: i32, n: [u64; 3]) -> u64 {
        self.elem(2, ent, etype::TRI3, &n)
    }

    pub fn line(&mut self, ent: i32, a: u64, b: u64) -> u64 {
        self.elem(1, ent, etype::LINE2, &[a, b])
    }
}

/// Options for [`grid`].
pub struct Grid {
    pub nx: usize,
    pub ny: usize,
    pub x0: f64,
    pub jitter: f64,
    pub seed: u64,
    /// Write the 4 boundary curves as line elements.
    pub lines: bool,
    /// Clockwise triangles.
    pub clockwise: bool,
}

impl Default for Grid {
    fn default() -> Self {
        Grid {
            nx: 4,
            ny: 4,
            x0: 0.0,
            jitter: 0.0,
            seed: 1,
            lines: true,
            clockwise: false,
        }
    }
}

/// A unit square `[x0, x0+1] × [0, 1]` as surface 1 bounded by curves 1..4 (bottom, right,
/// top, left) and points 1..4, an nx × ny grid with seeded random diagonals and interior
/// jitter. Physical group 10 on the surface ("plate"), 20 on curve 1.
// nodes are created row by row (j outer) but indexed id[i][j]: the index loop is clearer
#[allow(clippy::needless_range_loop)]
pub fn grid(g: &Grid) -> Mesh {
    let mut b = Builder::new();
    for p in 1..=4 {
        b.entity(0, p, &[], &[]);
    }
    b.entity(1, 1, &[1, -2], &[20]);
    b.entity(1, 2, &[2, -3], &[]);
    b.entity(1, 3, &[3, -4], &[]);
    b.entity(1, 4, &[4, -1], &[]);
    b.entity(2, 1, &[1, 2, 3, 4], &[10]);
    b.mesh.physical_names.push(PhysicalName {
        dim: 2,
        tag: 10,
        name: "plate".into(),
    });
    let mut rng = Rng(g.seed.wrapping_mul(0x9E3779B97F4A7C15) | 1);
    let mut id = vec![vec![0u64; g.ny + 1]; g.nx + 1];
    for j in 0..=g.ny {
        for i in 0..=g.nx {
            let (bx, by) = (i == 0 || i == g.nx, j == 0 || j == g.ny);
            let mut x = i as f64 / g.nx as f64;
            let mut y = j as f64 / g.ny as f64;
            let (dim, ent) = match (i, j) {
                (0, 0) => (0, 1),
                (i, 0) if i == g.nx => (0, 2),
                (i, j) if i == g.nx && j == g.ny => (0, 3),
                (0, j) if j == g.ny => (0, 4),
                (_, 0) => (1, 1),
                (i, _) if i == g.nx => (1, 2),
                (_, j) if j == g.ny => (1, 3),
                (0, _) => (1, 4),
                _ => (2, 1),
            };
            if !bx && !by {
                x += g.jitter * (rng.next_f64() - 0.5) / g.nx as f64;
                y += g.jitter * (rng.next_f64() - 0.5) / g.ny as f64;
            }
            id[i][j] = b.node(dim, ent, [g.x0 + x, y, 0.0]);
        }
    }
    for j in 0..g.ny {
        for i in 0..g.nx {
            let (a, bb, c, d) = (id[i][j], id[i + 1][j], id[i + 1][j + 1], id[i][j + 1]);
            let tris = if rng.next_f64() < 0.5 {
                [[a, bb, c], [a, c, d]]
            } else {
                [[a, bb, d], [bb, c, d]]
            };
            for t in tris {
                let t = if g.clockwise { [t[0], t[2], t[1]] } else { t };
                b.tri(1, t);
            }
        }
    }
    if g.lines {
        for i in 0..g.nx {
            b.line(1, id[i][0], id[i + 1][0]);
            b.line(3, id[i + 1][g.ny], id[i][g.ny]);
        }
        for j in 0..g.ny {
            b.line(2, id[g.nx][j], id[g.nx][j + 1]);
            b.line(4, id[0][j + 1], id[0][j]);
        }
    }
    b.mesh
}

/// Count of elements of type `ty` in the mesh.
pub fn count(m: &Mesh, ty: u32) -> usize {
    m.count_elements(ty)
}

/// Count of elements of type `ty` on surface `s`.
pub fn count_on(m: &Mesh, s: i32, ty: u32) -> usize {
    m.element_blocks
        .iter()
        .filter(|b| b.element_type == ty && b.entity_dim == 2 && b.entity_tag == s)
        .map(|b| b.len())
        .sum()
}

/// A regular polygon fan: `k` triangles around a centre node, on surface `ent`, boundary
/// without line elements unless `line_curve` is given.
pub fn fan(b: &mut Builder, ent: i32, centre: [f64; 2], k: usize) -> Vec<u64> {
    let c = b.node(2, ent, [centre[0], centre[1], 0.0]);
    let ring: Vec<u64> = (0..k)
        .map(|i| {
            let a = std::f64::consts::TAU * i as f64 / k as f64;
            b.node(
                1,
                100 + ent,
                [centre[0] + a.cos(), centre[1] + a.sin(), 0.0],
            )
        })
        .collect();
    for i in 0..k {
        b.tri(ent, [c, ring[i], ring[(i + 1) % k]]);
    }
    ring
}

/// Closed cube surface `[0,1]^3`, 6 surfaces (tags 1..6), each face an n × n grid split
/// into triangles with alternating diagonals, outward oriented, nodes shared along the
/// cube edges. No line elements and no curve classification: every node sits on its first
/// face, as in an MSH 2.2 file without curve data.
pub fn cube(n: usize) -> Mesh {
    cuboid(|_| n, 1.0, true)
}

/// A box `[0,1] × [0,1] × [0,h]` as surfaces 1..6 (faces z = 0, z = h, y = 0, y = 1,
/// x = 0, x = 1, each with its outward normal), nodes classified on the first face that
/// has them, no line elements. `cells(axis)` gives the number of cells along a face's axis
/// (`axis` the unit vector of the unit cube); each cell is split by a diagonal, alternating
/// between the two when `alternate`.
pub fn cuboid(cells: impl Fn(&[f64; 3]) -> usize, h: f64, alternate: bool) -> Mesh {
    let mut b = Builder::new();
    for s in 1..=6 {
        b.entity(2, s, &[], &[s]);
    }
    let mut ids: HashMap<[i64; 3], u64> = HashMap::new();
    // each face: origin, u axis, v axis (u × v = outward normal)
    let faces: [([f64; 3], [f64; 3], [f64; 3]); 6] = [
        ([0., 0., 0.], [0., 1., 0.], [1., 0., 0.]), // z = 0, normal -z
        ([0., 0., 1.], [1., 0., 0.], [0., 1., 0.]), // z = 1, +z
        ([0., 0., 0.], [1., 0., 0.], [0., 0., 1.]), // y = 0, -y
        ([0., 1., 0.], [0., 0., 1.], [1., 0., 0.]), // y = 1, +y
        ([0., 0., 0.], [0., 0., 1.], [0., 1., 0.]), // x = 0, -x
        ([1., 0., 0.], [0., 1., 0.], [0., 0., 1.]), // x = 1, +x
    ];
    for (f, (o, u, v)) in faces.iter().enumerate() {
        let s = f as i32 + 1;
        let (nu, nv) = (cells(u), cells(v));
        let mut grid = vec![vec![0u64; nv + 1]; nu + 1];
        for (i, row) in grid.iter_mut().enumerate() {
            for (j, cell) in row.iter_mut().enumerate() {
                let mut p = [0, 1, 2]
                    .map(|k| o[k] + u[k] * i as f64 / nu as f64 + v[k] * j as f64 / nv as f64);
                p[2] *= h;
                let key = p.map(|x| (x * 1e6).round() as i64);
                *cell = *ids.entry(key).or_insert_with(|| b.node(2, s, p));
            }
        }
        for i in 0..nu {
            for j in 0..nv {
                let (a, bb, c, d) = (
                    grid[i][j],
                    grid[i + 1][j],
                    grid[i + 1][j + 1],
                    grid[i][j + 1],
                );
                if !alternate || (i + j) % 2 == 0 {
                    b.tri(s, [a, bb, c]);
                    b.tri(s, [a, c, d]);
                } else {
                    b.tri(s, [a, bb, d]);
                    b.tri(s, [bb, c, d]);
                }
            }
        }
    }
    b.mesh
}

/// Splits every triangle and 2-node line holding the edge {a, b} at a new midpoint node
/// classified on (dim, ent); returns the new node's tag. (Test-side construction of odd
/// meshes, independent of the library's parity repair.)
pub fn split_edge(m: &mut Mesh, a: u64, b: u64, dim: i32, ent: i32) -> u64 {
    let idx = m.node_index();
    let pos = |t: u64| {
        let r = idx.get(t).unwrap();
        m.node_blocks[r.block as usize].coords[r.index as usize]
    };
    let (pa, pb) = (pos(a), pos(b));
    let mid = [0, 1, 2].map(|k| 0.5 * (pa[k] + pb[k]));
    let tag = m.max_node_tag() + 1;
    let mut next_elem = m.max_element_tag() + 1;
    match m
        .node_blocks
        .iter_mut()
        .find(|bl| bl.entity_dim == dim && bl.entity_tag == ent)
    {
        Some(bl) => {
            bl.tags.push(tag);
            bl.coords.push(mid);
        }
        None => m.node_blocks.push(NodeBlock {
            entity_dim: dim,
            entity_tag: ent,
            tags: vec![tag],
            coords: vec![mid],
            params: None,
        }),
    }
    for bl in m.element_blocks.iter_mut() {
        let k = match bl.element_type {
            etype::TRI3 => 3,
            etype::LINE2 => 2,
            _ => continue,
        };
        for i in 0..bl.len() {
            let e = bl.element(i).to_vec();
            let Some(j) = (0..k).find(|&j| {
                let (x, y) = (e[j], e[(j + 1) % k]);
                (x == a && y == b) || (x == b && y == a)
            }) else {
                continue;
            };
            let (first, second) = if k == 3 {
                let (x, y, z) = (e[j], e[(j + 1) % 3], e[(j + 2) % 3]);
                (vec![x, tag, z], vec![tag, y, z])
            } else {
                (vec![e[0], tag], vec![tag, e[1]])
            };
            bl.nodes[i * k..(i + 1) * k].copy_from_slice(&first);
            bl.tags.push(next_elem);
            next_elem += 1;
            bl.nodes.extend_from_slice(&second);
        }
    }
    tag
}

/// Two unit squares side by side, surfaces 1 (x ≤ 1) and 2 (x ≥ 1), n × n cells each,
/// sharing curve 2 (x = 1, line elements). Outer boundary: curve 1 (around surface 1) and
/// curve 3 (around surface 2), also with line elements. Returns the mesh and the node grid.
pub fn two_squares(n: usize) -> (Mesh, Vec<Vec<u64>>) {
    let mut b = Builder::new();
    b.entity(1, 1, &[], &[]);
    b.entity(1, 2, &[], &[5]);
    b.entity(1, 3, &[], &[]);
    b.entity(2, 1, &[1, 2], &[1]);
    b.entity(2, 2, &[-2, 3], &[2]);
    let mut id = vec![vec![0u64; n + 1]; 2 * n + 1];
    for (i, col) in id.iter_mut().enumerate() {
        for (j, cell) in col.iter_mut().enumerate() {
            let (dim, ent) = if i == n {
                (1, 2)
            } else if i == 0 || j == 0 || j == n {
                (1, if i < n { 1 } else { 3 })
            } else if i == 2 * n {
                (1, 3)
            } else {
                (2, if i < n { 1 } else { 2 })
            };
            *cell = b.node(dim, ent, [i as f64 / n as f64, j as f64 / n as f64, 0.0]);
        }
    }
    for i in 0..2 * n {
        let s = if i < n { 1 } else { 2 };
        for j in 0..n {
            let (a, bb, c, d) = (id[i][j], id[i + 1][j], id[i + 1][j + 1], id[i][j + 1]);
            b.tri(s, [a, bb, c]);
            b.tri(s, [a, c, d]);
        }
    }
    for i in 0..2 * n {
        let c = if i < n { 1 } else { 3 };
        b.line(c, id[i][0], id[i + 1][0]);
        b.line(c, id[i + 1][n], id[i][n]);
    }
    for j in 0..n {
        b.line(1, id[0][j + 1], id[0][j]);
        b.line(2, id[n][j], id[n][j + 1]);
        b.line(3, id[2 * n][j], id[2 * n][j + 1]);
    }
    (b.mesh, id)
}

/// An equilateral triangle cut into n² triangles (Figure 6 of the paper for n = 2 and 4):
/// n(n+1)/2 "up" and n(n−1)/2 "down" triangles; every adjacency joins an up and a down
/// triangle, so there is no perfect matching without extra edges. Surface 1, no lines.
pub fn subdivided_triangle(n: usize) -> Mesh {
    let mut b = Builder::new();
    b.entity(2, 1, &[], &[]);
    let h = 3f64.sqrt() / 2.0;
    // row r (0 at the bottom) has n + 1 - r nodes
    let mut id: Vec<Vec<u64>> = Vec::new();
    for r in 0..=n {
        let row = (0..=n - r)
            .map(|i| {
                let on_boundary = r == 0 || i == 0 || i == n - r;
                let (dim, ent) = if on_boundary { (1, 1) } else { (2, 1) };
                b.node(dim, ent, [i as f64 + 0.5 * r as f64, r as f64 * h, 0.0])
            })
            .collect();
        id.push(row);
    }
    for r in 0..n {
        for i in 0..n - r {
            b.tri(1, [id[r][i], id[r][i + 1], id[r + 1][i]]);
            if i + 1 < n - r {
                b.tri(1, [id[r][i + 1], id[r + 1][i + 1], id[r + 1][i]]);
            }
        }
    }
    b.mesh
}

/// Recombination options with the certificate and invariant checks on.
pub fn verify_opts() -> blossomquad::recombine::RecombineOptions {
    blossomquad::recombine::RecombineOptions {
        verify: true,
        ..Default::default()
    }
}

/// Node grid `(nx + 1) × (ny + 1)` on surface 1 at integer coordinates; each cell is handed
/// to `cell(builder, i, j, [a, b, c, d])` (counter-clockwise corners) to fill.
pub fn cell_grid(
    nx: usize,
    ny: usize,
    mut cell: impl FnMut(&mut Builder, usize, usize, [u64; 4]),
) -> Mesh {
    let mut b = Builder::new();
    b.entity(2, 1, &[], &[]);
    let mut id = vec![vec![0u64; ny + 1]; nx + 1];
    for (i, col) in id.iter_mut().enumerate() {
        for (j, c) in col.iter_mut().enumerate() {
            *c = b.node(2, 1, [i as f64, j as f64, 0.0]);
        }
    }
    for i in 0..nx {
        for j in 0..ny {
            let q = [id[i][j], id[i + 1][j], id[i + 1][j + 1], id[i][j + 1]];
            cell(&mut b, i, j, q);
        }
    }
    b.mesh
}

/// Nodes of line element `i` of curve `curve`.
pub fn line_of(m: &Mesh, curve: i32, i: usize) -> Vec<u64> {
    m.element_blocks
        .iter()
        .find(|b| b.element_type == etype::LINE2 && b.entity_tag == curve)
        .map(|b| b.element(i).to_vec())
        .unwrap()
}

/// Tag of the node at `p`.
pub fn node_at(m: &Mesh, p: [f64; 3]) -> u64 {
    m.node_blocks
        .iter()
        .flat_map(|b| b.tags.iter().zip(&b.coords))
        .find(|(_, c)| (0..3).all(|k| (c[k] - p[k]).abs() < 1e-9))
        .map(|(t, _)| *t)
        .unwrap()
}

/// Corner coordinates of every quad, with its tag.
/// The corner coordinates of every quad of surface `s`.
pub fn quad_coords_on(m: &Mesh, s: i32) -> Vec<Vec<[f64; 3]>> {
    let idx = m.node_index();
    let at = |t: u64| {
        let r = idx.get(t).unwrap();
        m.node_blocks[r.block as usize].coords[r.index as usize]
    };
    m.element_blocks
        .iter()
        .filter(|b| b.element_type == etype::QUAD4 && b.entity_tag == s)
        .flat_map(|b| (0..b.len()).map(move |i| b.element(i)))
        .map(|e| e.iter().map(|&t| at(t)).collect())
        .collect()
}

pub fn quad_coords(m: &Mesh) -> Vec<(u64, Vec<[f64; 3]>)> {
    let idx = m.node_index();
    let mut out = Vec::new();
    for blk in m
        .element_blocks
        .iter()
        .filter(|b| b.element_type == etype::QUAD4)
    {
        for i in 0..blk.len() {
            let p = blk
                .element(i)
                .iter()
                .map(|&n| {
                    let r = idx.get(n).unwrap();
                    m.node_blocks[r.block as usize].coords[r.index as usize]
                })
                .collect();
            out.push((blk.tags[i], p));
        }
    }
    out
}

/// Quads (with their tag) whose signed area in the xy plane is not positive, or that are
/// self-intersecting (two signed triangle areas of opposite sign around both diagonals):
/// folded quads in a counter-clockwise planar mesh.
pub fn folded_quads(m: &Mesh) -> Vec<u64> {
    let tri = |a: &[f64; 3], b: &[f64; 3], c: &[f64; 3]| {
        (b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0])
    };
    quad_coords(m)
        .into_iter()
        .filter(|(_, p)| {
            // a simple quad (convex or not) has one diagonal splitting it into two
            // positive triangles
            let d02 = tri(&p[0], &p[1], &p[2]) > 0.0 && tri(&p[0], &p[2], &p[3]) > 0.0;
            let d13 = tri(&p[1], &p[2], &p[3]) > 0.0 && tri(&p[1], &p[3], &p[0]) > 0.0;
            !(d02 || d13)
        })
        .map(|(t, _)| t)
        .collect()
}

/// Largest interior angle (degrees) at node `v` over the quads that use it.
pub fn max_angle_at(m: &blossomquad::mesh::Mesh, v: u64) -> f64 {
    let mut worst: f64 = 0.0;
    for (_, pts, nodes) in quads_with_nodes(m) {
        if let Some(k) = nodes.iter().position(|&n| n == v) {
            let p = |i: usize| pts[i % 4];
            let (c, a, b) = (p(k), p(k + 1), p(k + 3));
            let u = [a[0] - c[0], a[1] - c[1]];
            let w = [b[0] - c[0], b[1] - c[1]];
            let ang = (u[0] * w[1] - u[1] * w[0]).atan2(u[0] * w[0] + u[1] * w[1]);
            worst = worst.max(ang.to_degrees());
        }
    }
    worst
}

/// Every quad as (tag, coordinates, node tags).
pub fn quads_with_nodes(m: &blossomquad::mesh::Mesh) -> Vec<(u64, Vec<[f64; 3]>, Vec<u64>)> {
    let idx = m.node_index();
    let mut out = Vec::new();
    for b in m
        .element_blocks
        .iter()
        .filter(|b| b.element_type == blossomquad::mesh::etype::QUAD4)
    {
        for i in 0..b.len() {
            let nodes = b.element(i).to_vec();
            let pts = nodes
                .iter()
                .map(|&t| {
                    let r = idx.get(t).unwrap();
                    m.node_blocks[r.block as usize].coords[r.index as usize]
                })
                .collect();
            out.push((b.tags[i], pts, nodes));
        }
    }
    out
}

/// A planar annulus as surface 1: `outer` segments on curve 1 (radius 1), `inner` on
/// curve 2 (radius `r`), with line elements, triangulated by advancing round both circles:
/// every triangle has an edge on a circle and the triangles form a closed band.
pub fn annulus(outer: usize, inner: usize, r: f64) -> Mesh {
    let mut b = Builder::new();
    b.entity(1, 1, &[], &[]);
    b.entity(1, 2, &[], &[]);
    b.entity(2, 1, &[1, 2], &[]);
    let at = |k: usize, n: usize, rad: f64| {
        let a = std::f64::consts::TAU * k as f64 / n as f64;
        [rad * a.cos(), rad * a.sin(), 0.0]
    };
    let out: Vec<u64> = (0..outer)
        .map(|k| b.node(1, 1, at(k, outer, 1.0)))
        .collect();
    let inn: Vec<u64> = (0..inner).map(|k| b.node(1, 2, at(k, inner, r))).collect();
    let (mut i, mut j) = (0, 0);
    while i < outer || j < inner {
        let next_out = (i + 1) as f64 / outer as f64;
        let next_in = (j + 1) as f64 / inner as f64;
        if j == inner || (i < outer && next_out <= next_in) {
            b.tri(1, [inn[j % inner], out[i], out[(i + 1) % outer]]);
            i += 1;
        } else {
            b.tri(1, [inn[j], out[i % outer], inn[(j + 1) % inner]]);
            j += 1;
        }
    }
    for k in 0..outer {
        b.line(1, out[k], out[(k + 1) % outer]);
    }
    for k in 0..inner {
        b.line(2, inn[k], inn[(k + 1) % inner]);
    }
    b.mesh
}
