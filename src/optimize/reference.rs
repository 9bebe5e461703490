//! The reference triangulation (the triangle mesh before recombination), prepared per
//! surface ([`PreparedReference`]) and attached to a surface's flat arrays: every node
//! located on it, target sizes from its edge lengths.

use super::local::{Local, NONE};
use super::surface_tags;
use crate::mesh::{etype, Mesh};
use crate::mesh::{NodeIds, NodeTable};
use crate::quality::locate::TriSurface;
use crate::quality::size::mean_incident_edge_length;
use glam::DVec3;
use rayon::prelude::*;

/// The reference triangulation of every surface of a triangle mesh, prepared for
/// [`optimize_prepared`](super::optimize_prepared): per surface its triangles on compact point indices, the nodal
/// sizes (mean incident edge length) and a triangle at each point. It depends on the
/// triangle mesh only, so it can be built while the recombination runs (the CLI does).
/// Memory: of the mesh's node table it keeps only the tag → id lookup (the points'
/// coordinates are in the surfaces' parts).
pub struct PreparedReference {
    pub(super) nodes: NodeIds,
    /// By increasing surface tag.
    pub(super) surfaces: Vec<(i32, SurfaceReference)>,
}

/// One surface's part of a [`PreparedReference`].
pub(super) struct SurfaceReference {
    pts: Vec<DVec3>,
    tris: Vec<[u32; 3]>,
    /// Unscaled mean incident edge length per point.
    nodal: Vec<f64>,
    /// A triangle at each point.
    incident: Vec<u32>,
    /// Flat reference node index -> point index: a dense table when the surface holds a
    /// good share of the mesh's nodes, else a map.
    compact_dense: Vec<u32>,
    compact_sparse: std::collections::HashMap<u32, u32>,
}

impl SurfaceReference {
    /// No triangles.
    pub(super) fn empty() -> Self {
        SurfaceReference {
            pts: Vec::new(),
            tris: Vec::new(),
            nodal: Vec::new(),
            incident: Vec::new(),
            compact_dense: Vec::new(),
            compact_sparse: Default::default(),
        }
    }

    /// Point index of flat reference node `id`.
    fn compact(&self, id: u32) -> Option<u32> {
        if self.compact_dense.is_empty() {
            self.compact_sparse.get(&id).copied()
        } else {
            self.compact_dense
                .get(id as usize)
                .copied()
                .filter(|&c| c != NONE)
        }
    }
}

impl PreparedReference {
    /// Prepares the triangles (3-node) of every surface of `reference` (in parallel).
    pub fn new(reference: &Mesh) -> Self {
        let nodes = NodeTable::new(reference);
        let tags = surface_tags(reference, etype::TRI3);
        let surfaces = tags
            .par_iter()
            .map(|&s| (s, surface_reference(reference, &nodes, s)))
            .collect();
        PreparedReference {
            nodes: nodes.into_ids(),
            surfaces,
        }
    }
}
/// The reference triangles of surface `s` on compact point indices (first use order).
pub(super) fn surface_reference(reference: &Mesh, rnodes: &NodeTable, s: i32) -> SurfaceReference {
    let total = rnodes.coords.len();
    let count: usize = reference
        .element_blocks
        .iter()
        .filter(|b| b.entity_dim == 2 && b.entity_tag == s && b.element_type == etype::TRI3)
        .map(|b| b.len())
        .sum();
    // a dense table when the surface's points (about half its triangles) are a good share
    let dense = total <= 32 * count.max(1);
    let mut compact_dense: Vec<u32> = if dense { vec![NONE; total] } else { Vec::new() };
    let mut compact_sparse: std::collections::HashMap<u32, u32> = Default::default();
    let mut pts: Vec<DVec3> = Vec::new();
    let mut tris: Vec<[u32; 3]> = Vec::with_capacity(count);
    for b in &reference.element_blocks {
        if b.entity_dim != 2 || b.entity_tag != s || b.element_type != etype::TRI3 {
            continue;
        }
        let ids: Vec<[u32; 3]> = (0..b.len())
            .into_par_iter()
            .with_min_len(4096)
            .map(|e| {
                let el = b.element(e);
                [el[0], el[1], el[2]].map(|t| rnodes.id(t).unwrap_or(NONE))
            })
            .collect();
        for t3 in ids {
            if t3.contains(&NONE) {
                continue;
            }
            let mut t = [0u32; 3];
            for (k, &id) in t3.iter().enumerate() {
                let slot = if dense {
                    &mut compact_dense[id as usize]
                } else {
                    compact_sparse.entry(id).or_insert(NONE)
                };
                if *slot == NONE {
                    *slot = pts.len() as u32;
                    pts.push(rnodes.coords[id as usize]);
                }
                t[k] = *slot;
            }
            tris.push(t);
        }
    }
    let nodal = mean_incident_edge_length(&pts, tris.iter().map(|t| &t[..]));
    let mut incident = vec![NONE; pts.len()];
    for (t, tri) in tris.iter().enumerate() {
        for &v in tri {
            incident[v as usize] = t as u32;
        }
    }
    SurfaceReference {
        pts,
        tris,
        nodal,
        incident,
        compact_dense,
        compact_sparse,
    }
}
impl SurfaceReference {
    /// Number of reference triangles.
    pub(super) fn triangles(&self) -> usize {
        self.tris.len()
    }
}

/// Attaches the surface's reference triangulation (`sref`, the prepared triangles of the
/// same surface entity, else the quads split in two), locates every node on it and sets the
/// sizes (those from reference triangles times `size_scale`).
/// Planar surfaces need no projection: their nodes missing from the reference take the mean
/// size of their matched neighbours, and they keep the reference triangles (in a spatial
/// index, with their sizes, for [`Local::tau_estimate`]) only with `keep_planar`.
pub(super) fn attach_reference(
    l: &mut Local,
    sref: Option<SurfaceReference>,
    rnodes: &NodeIds,
    size_scale: f64,
    keep_planar: bool,
) {
    let mut sref = sref.unwrap_or_else(SurfaceReference::empty);
    let mut pts = std::mem::take(&mut sref.pts);
    let mut tris = std::mem::take(&mut sref.tris);
    let incident = std::mem::take(&mut sref.incident);
    let ref_nodal = std::mem::take(&mut sref.nodal);
    let compact = |id: u32| sref.compact(id);
    let own = tris.is_empty();
    if own {
        // quad edges are ~h; the split diagonals (√2 h) would inflate the mean: use the
        // quads' own edges instead.
        let qh = mean_incident_edge_length(&l.pos, l.quads.iter().map(|q| &q[..]));
        l.h = qh.iter().map(|&x| if x > 0.0 { x } else { 1.0 }).collect();
        if l.planar {
            return;
        }
        pts = l.pos.clone();
        tris = Vec::with_capacity(2 * l.quads.len());
        for q in &l.quads {
            tris.push([q[0], q[1], q[2]]);
            tris.push([q[0], q[2], q[3]]);
        }
    }
    let nodal: Vec<f64> = if own {
        mean_incident_edge_length(&pts, tris.iter().map(|t| &t[..]))
    } else {
        let mut h = ref_nodal;
        h.iter_mut().for_each(|h| *h *= size_scale);
        h
    };
    // a node of the reference (same tag, same place) is located without a search
    let mut unmatched = Vec::new();
    if own {
        unmatched.extend(0..l.pos.len());
    } else {
        let found: Vec<Option<u32>> = (0..l.pos.len())
            .into_par_iter()
            .with_min_len(4096)
            .map(|v| {
                // a point of the reference is its node's coordinates, copied
                rnodes
                    .id(l.tags[v])
                    .and_then(|id| compact(id).filter(|&i| pts[i as usize] == l.pos[v]))
                    .filter(|&i| incident[i as usize] != NONE)
            })
            .collect();
        // curved: the input surface's normal at each of its nodes, as the validity gate
        // measures corners about it (area-weighted normal of the triangles around it)
        let point_normals = (!l.planar).then(|| {
            let mut n = vec![DVec3::ZERO; pts.len()];
            for t in &tris {
                let p = t.map(|k| pts[k as usize]);
                let c = (p[1] - p[0]).cross(p[2] - p[0]);
                for &k in t {
                    n[k as usize] += c;
                }
            }
            n
        });
        if point_normals.is_some() {
            l.gate_nrm = vec![DVec3::ZERO; l.pos.len()];
        }
        for (v, hit) in found.into_iter().enumerate() {
            match hit {
                Some(i) => {
                    if let Some(n) = &point_normals {
                        l.gate_nrm[v] = n[i as usize].normalize_or_zero();
                    }
                    l.tri[v] = incident[i as usize];
                    let h = nodal[i as usize];
                    l.h[v] = if h > 0.0 { h } else { 1.0 };
                }
                None => unmatched.push(v),
            }
        }
    }
    if l.planar {
        // nothing to project on: a missing node takes its matched neighbours' mean size,
        // in rounds outward from the matched nodes (after uniform refinement most nodes
        // are new, some several rings away from any reference node)
        let mut matched = vec![true; l.pos.len()];
        for &v in &unmatched {
            matched[v] = false;
        }
        let mut left = unmatched;
        while !left.is_empty() {
            let mut assigned = Vec::new();
            let mut rest = Vec::new();
            for &v in &left {
                let (mut sum, mut cnt) = (0.0, 0);
                for &q in l.star(v as u32) {
                    for &w in &l.quads[q as usize] {
                        if matched[w as usize] {
                            sum += l.h[w as usize];
                            cnt += 1;
                        }
                    }
                }
                if cnt > 0 {
                    l.h[v] = sum / cnt as f64;
                    assigned.push(v);
                } else {
                    rest.push(v);
                }
            }
            if assigned.is_empty() {
                break;
            }
            for v in assigned {
                matched[v] = true;
            }
            left = rest;
        }
        if !own && keep_planar {
            // the surface may choose between schedules by τ (`Local::tau_estimate`)
            l.reference = Some(std::sync::Arc::new(TriSurface::new(pts, tris)));
            l.ref_sizes = nodal;
        }
        return;
    }
    let surface = TriSurface::new(pts, tris);
    for v in unmatched {
        if let Some(hit) = surface.closest(l.pos[v]) {
            l.tri[v] = hit.tri;
            if !own {
                let t = surface.triangle(hit.tri);
                let h: f64 = (0..3).map(|k| hit.bary[k] * nodal[t[k] as usize]).sum();
                l.h[v] = if h > 0.0 { h } else { 1.0 };
            }
        }
    }
    l.reference = Some(std::sync::Arc::new(surface));
    if !own {
        l.ref_sizes = nodal;
    }
}
#[cfg(test)]
mod tests {
    use super::*;
    use crate::optimize::cleanup::tests::local_of;
    use crate::optimize::synth;
    use crate::quality::size::ReferenceSize;

    /// On a graded reference (x squared), after every free node moved, the τ estimate of a
    /// small planar surface uses the reference field at the nodes' new positions: it equals
    /// an independent computation with `ReferenceSize::at`, and differs from the one with
    /// the sizes where the nodes started.
    #[test]
    fn the_tau_estimate_follows_the_reference_field_to_where_nodes_moved() {
        let (tris, quads) = (1u64..40)
            .find_map(|seed| {
                let mut t = synth::delaunay_square(14, 1.0, 0.3, seed);
                for p in t.points.iter_mut() {
                    p.x *= p.x;
                }
                synth::pair_optimal(&t).map(|q| (t, q))
            })
            .expect("a matchable seed");
        let reference = synth::to_mesh(&tris);
        let (_, mut l) = local_of(&synth::to_mesh(&quads));
        let rnodes = NodeTable::new(&reference);
        let sref = surface_reference(&reference, &rnodes, l.surface);
        attach_reference(&mut l, Some(sref), &rnodes.into_ids(), 1.0, true);
        assert!(l.planar && !l.ref_sizes.is_empty() && l.reference.is_some());
        let start_sizes = l.h.clone();
        for v in 0..l.pos.len() {
            if !l.fixed[v] {
                l.pos[v].x += 0.3 * l.h[v];
            }
        }
        let field = ReferenceSize::from_mesh(&reference).expect("triangles");
        let tau = |h: &dyn Fn(usize) -> f64| {
            let (mut sum, mut n) = (0.0, 0);
            for quad in &l.quads {
                for k in 0..4 {
                    let (a, b) = (quad[k] as usize, quad[(k + 1) % 4] as usize);
                    let (ha, hb) = (h(a), h(b));
                    let inv = if (hb - ha).abs() <= 1e-9 * (ha + hb) {
                        2.0 / (ha + hb)
                    } else {
                        (hb / ha).ln() / (hb - ha)
                    };
                    let lh = l.pos[a].distance(l.pos[b]) * inv;
                    sum += lh.min(1.0 / lh) - 1.0;
                    n += 1;
                }
            }
            100.0 * (sum / n as f64).exp()
        };
        let moved = tau(&|v| field.at(l.pos[v]));
        let stale = tau(&|v| start_sizes[v]);
        let est = l.tau_estimate();
        assert!(
            (est - moved).abs() < 1e-6,
            "estimate {est}, field at new positions {moved}"
        );
        assert!(
            (est - stale).abs() > 0.1,
            "estimate {est}, start sizes {stale}"
        );
    }
}
