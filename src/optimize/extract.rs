//! A surface's quads copied out of the [`Mesh`] into flat arrays (a `Local`: quads in
//! Morton order, nodes numbered by first use, fixed nodes marked), and written back.

use super::local::{csr, Local, NONE};
use super::{OptimizeError, OptimizeReport};
use crate::mesh::NodeTable;
use crate::mesh::{etype, Mesh};
use glam::DVec3;
use rayon::prelude::*;

const UNSET: u32 = u32::MAX;
const SHARED: u32 = u32::MAX - 1;

/// For every flat node: the index (in `surfaces`) of the only surface whose quads use it, or
/// `SHARED` when anything else uses it (other elements, other surfaces, a point/curve node
/// block), or `UNSET` when unused.
pub(crate) fn node_owners(
    mesh: &Mesh,
    flat: &NodeTable,
    surfaces: &[i32],
) -> Result<Vec<u32>, OptimizeError> {
    let mut owner = vec![UNSET; flat.coords.len()];
    for (bi, b) in mesh.node_blocks.iter().enumerate() {
        if b.entity_dim != 2 {
            let start = flat.block_start[bi] as usize;
            owner[start..start + b.tags.len()].fill(SHARED);
        }
    }
    for b in &mesh.element_blocks {
        let key = if b.entity_dim == 2 && b.element_type == etype::QUAD4 {
            surfaces
                .binary_search(&b.entity_tag)
                .map_or(SHARED, |i| i as u32)
        } else {
            SHARED
        };
        for (k, &t) in b.nodes.iter().enumerate() {
            let Some(i) = flat.id(t) else {
                let per = b.nodes_per_element().max(1);
                return Err(OptimizeError::MissingNode {
                    surface: b.entity_tag,
                    element: b.tags.get(k / per).copied().unwrap_or(0),
                    node: t,
                });
            };
            let o = &mut owner[i as usize];
            *o = match *o {
                UNSET => key,
                x if x == key => key,
                _ => SHARED,
            };
        }
    }
    Ok(owner)
}

/// Copies surface `s`'s quads into a [`Local`] (with its adjacency built). `scratch` has one
/// entry per flat node, all [`NONE`], and is left so.
pub(crate) fn extract(
    mesh: &Mesh,
    flat: &NodeTable,
    owner: &[u32],
    (sid, s): (u32, i32),
    scratch: &mut [u32],
) -> Result<Local, OptimizeError> {
    let mut quads = Vec::new();
    let mut origin = Vec::new();
    for (bi, b) in mesh.element_blocks.iter().enumerate() {
        if b.entity_dim != 2 || b.entity_tag != s || b.element_type != etype::QUAD4 {
            continue;
        }
        for e in 0..b.len() {
            let mut q = [0u32; 4];
            for (k, &t) in b.element(e).iter().enumerate() {
                q[k] = flat.id(t).ok_or(OptimizeError::MissingNode {
                    surface: s,
                    element: b.tags[e],
                    node: t,
                })?;
            }
            quads.push(q);
            origin.push((bi as u32, e as u32));
        }
    }
    // Memory locality (measured: 2-3x faster sweeps at 1e6 triangles): quads in Morton order
    // of their centroids, nodes numbered by first use in that order.
    let order = crate::keysort::morton_order(&quads, &flat.coords);
    let origin: Vec<(u32, u32)> = order.iter().map(|&q| origin[q as usize]).collect();
    let mut global: Vec<u32> = Vec::new();
    let quads: Vec<[u32; 4]> = order
        .iter()
        .map(|&q| {
            quads[q as usize].map(|g| {
                let slot = &mut scratch[g as usize];
                if *slot == NONE {
                    *slot = global.len() as u32;
                    global.push(g);
                }
                *slot
            })
        })
        .collect();
    for &g in &global {
        scratch[g as usize] = NONE;
    }
    let node_tags: Vec<u64> = global.iter().map(|&g| flat.tags[g as usize]).collect();
    let n = global.len();
    let pos: Vec<DVec3> = global.iter().map(|&g| flat.coords[g as usize]).collect();
    let mut fixed: Vec<bool> = global.iter().map(|&g| owner[g as usize] != sid).collect();
    let (start, adj) = csr(n, &quads, |_| true);
    // boundary of the quad set (edges not shared by exactly two quads), and degenerate quads;
    // an edge's count is the same seen from both ends, so each node only marks itself
    let on_boundary: Vec<bool> = (0..n)
        .into_par_iter()
        .with_min_len(4096)
        .map_init(Vec::new, |around: &mut Vec<u32>, v| {
            around.clear();
            for &q in &adj[start[v] as usize..start[v + 1] as usize] {
                let quad = &quads[q as usize];
                for k in 0..4 {
                    if quad[k] == v as u32 {
                        around.push(quad[(k + 1) % 4]);
                        around.push(quad[(k + 3) % 4]);
                    }
                }
            }
            around.sort_unstable();
            let mut i = 0;
            while i < around.len() {
                let mut j = i + 1;
                while j < around.len() && around[j] == around[i] {
                    j += 1;
                }
                if j - i != 2 || around[i] == v as u32 {
                    return true;
                }
                i = j;
            }
            false
        })
        .collect();
    for (f, b) in fixed.iter_mut().zip(on_boundary) {
        *f |= b;
    }
    for q in &quads {
        let mut sorted = *q;
        sorted.sort_unstable();
        if sorted.windows(2).any(|w| w[0] == w[1]) {
            for &v in q {
                fixed[v as usize] = true;
            }
        }
    }
    // normals: sum of incident quad (Newell) normals; a plane if every node is on it
    let mut nrm = vec![DVec3::ZERO; n];
    let mut total = DVec3::ZERO;
    for q in &quads {
        let p = q.map(|v| pos[v as usize]);
        let qn = (p[2] - p[0]).cross(p[3] - p[1]);
        total += qn;
        for &v in q {
            nrm[v as usize] += qn;
        }
    }
    let plane = total.normalize_or_zero();
    let planar = on_one_plane(&pos, plane);
    for v in nrm.iter_mut() {
        *v = if planar { plane } else { v.normalize_or_zero() };
    }
    Ok(Local {
        surface: s,
        h: vec![1.0; n],
        tri: vec![NONE; n],
        removed: vec![false; n],
        alive: vec![true; quads.len()],
        pos,
        nrm,
        gate_nrm: Vec::new(),
        tie: 0.0,
        located_turns: false,
        fixed,
        global,
        tags: node_tags,
        quads,
        origin,
        planar,
        in_large_mesh: false,
        reference: None,
        ref_sizes: Vec::new(),
        start,
        adj,
        qn: Vec::new(),
        qn_all: None,
        hopeless: Vec::new(),
        colours: Vec::new(),
        sweep_ready: false,
        trace: None,
    })
}

/// Removes the entries at the (sorted, distinct) positions `rm` from `v`, keeping order.
fn remove_sorted<T>(v: &mut Vec<T>, rm: &[usize]) {
    let mut k = 0;
    let mut idx = 0;
    v.retain(|_| {
        let keep = rm.get(k) != Some(&idx);
        if !keep {
            k += 1;
        }
        idx += 1;
        keep
    });
}

/// Node changes of all surfaces, applied after every surface has been written back: a node
/// block can hold nodes of several surfaces (e.g. new nodes on a curve-less edge shared by
/// two surfaces), and removing nodes shifts the flat indices the other surfaces use.
pub(crate) struct PendingNodes {
    removed_by_block: Vec<Vec<usize>>,
    moved_blocks: Vec<bool>,
}

impl PendingNodes {
    pub(crate) fn new(mesh: &Mesh) -> Self {
        PendingNodes {
            removed_by_block: vec![Vec::new(); mesh.node_blocks.len()],
            moved_blocks: vec![false; mesh.node_blocks.len()],
        }
    }

    /// Removes the nodes marked removed; drops the parametric coordinates of blocks whose
    /// nodes moved (they no longer match the coordinates).
    pub(crate) fn apply(self, mesh: &mut Mesh) {
        for (b, mut rm) in self.removed_by_block.into_iter().enumerate() {
            if rm.is_empty() && !self.moved_blocks[b] {
                continue;
            }
            let block = &mut mesh.node_blocks[b];
            if block.params.is_some() {
                block.params = None;
                mesh.warnings.push(format!(
                    "parametric coordinates of node block ({}, {}) dropped: nodes moved",
                    block.entity_dim, block.entity_tag
                ));
            }
            if rm.is_empty() {
                continue;
            }
            rm.sort_unstable();
            remove_sorted(&mut block.tags, &rm);
            remove_sorted(&mut block.coords, &rm);
        }
    }
}

/// Where each node id of a [`NodeTable`] lives in its mesh: what the write back needs of
/// the table (memory: the coordinates, tags and tag lookup are freed once the surfaces are
/// extracted).
pub(crate) struct NodePlaces {
    /// Node block of each id.
    block: Vec<u32>,
    /// First id of each node block.
    block_start: Vec<u32>,
}

impl NodePlaces {
    pub(crate) fn new(table: NodeTable) -> Self {
        let NodeTable {
            block, block_start, ..
        } = table;
        NodePlaces { block, block_start }
    }

    /// Node block and index in it of node id `g`.
    fn place(&self, g: usize) -> (usize, usize) {
        let b = self.block[g] as usize;
        (b, g - self.block_start[b] as usize)
    }
}

/// Writes surface `l` back: moved coordinates and the quads in place, dead quads removed;
/// removed nodes go to `pending` (see [`PendingNodes`]).
pub(crate) fn write_back(
    mesh: &mut Mesh,
    places: &NodePlaces,
    l: &Local,
    report: &mut OptimizeReport,
    pending: &mut PendingNodes,
) {
    let block_of = |g: usize| places.place(g);
    let tag_of = |g: u32| {
        let (b, i) = block_of(g as usize);
        mesh.node_blocks[b].tags[i]
    };
    let tags: Vec<u64> = l.global.iter().map(|&g| tag_of(g)).collect();
    for v in 0..l.pos.len() {
        if l.fixed[v] {
            continue;
        }
        let (b, i) = block_of(l.global[v] as usize);
        if l.removed[v] {
            pending.removed_by_block[b].push(i);
            report.nodes_removed += 1;
        } else if mesh.node_blocks[b].coords[i] != l.pos[v].to_array() {
            mesh.node_blocks[b].coords[i] = l.pos[v].to_array();
            pending.moved_blocks[b] = true;
        }
    }
    // quads
    let mut dead_by_block: Vec<Vec<u32>> = vec![Vec::new(); mesh.element_blocks.len()];
    for (q, quad) in l.quads.iter().enumerate() {
        let (b, e) = l.origin[q];
        if !l.alive[q] {
            dead_by_block[b as usize].push(e);
            report.quads_removed += 1;
            continue;
        }
        let block = &mut mesh.element_blocks[b as usize];
        let base = e as usize * 4;
        for k in 0..4 {
            block.nodes[base + k] = tags[quad[k] as usize];
        }
    }
    for (b, mut dead) in dead_by_block.into_iter().enumerate() {
        if dead.is_empty() {
            continue;
        }
        dead.sort_unstable();
        let block = &mut mesh.element_blocks[b];
        let n = block.len();
        let mut tags_out = Vec::with_capacity(n - dead.len());
        let mut nodes_out = Vec::with_capacity(4 * (n - dead.len()));
        let mut parts_out = block.partitions.as_ref().map(|_| Vec::new());
        let mut k = 0;
        for e in 0..n {
            if dead.get(k) == Some(&(e as u32)) {
                k += 1;
                continue;
            }
            tags_out.push(block.tags[e]);
            nodes_out.extend_from_slice(block.element(e));
            if let (Some(out), Some(p)) = (parts_out.as_mut(), block.partitions.as_ref()) {
                out.push(p.get(e).cloned().unwrap_or_default());
            }
        }
        block.tags = tags_out;
        block.nodes = nodes_out;
        block.partitions = parts_out;
    }
}

/// True when every point of `points` lies on the plane through their mean with the unit
/// normal `normal` (not zero), to 1e-9 of the diagonal of their bounding box: what makes a
/// surface planar for the optimizer (and for the worst-quad tries' wall-corner bound).
pub(crate) fn on_one_plane(points: &[DVec3], normal: DVec3) -> bool {
    let centre = points.iter().copied().sum::<DVec3>() / points.len().max(1) as f64;
    let (lo, hi) = points.iter().fold(
        (DVec3::splat(f64::INFINITY), DVec3::splat(f64::NEG_INFINITY)),
        |(lo, hi), &p| (lo.min(p), hi.max(p)),
    );
    let diag = (hi - lo).length();
    normal != DVec3::ZERO
        && points
            .iter()
            .all(|&p| (p - centre).dot(normal).abs() <= 1e-9 * diag)
}
