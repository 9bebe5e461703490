//! One surface from its triangles to its quads: the triangles, half-edges and regions of
//! each surface (step 2 of the module docs), then the graph, the matching and the
//! post-processing (steps 4–7).

use std::time::{Duration, Instant};

use rayon::prelude::*;

use super::surface_tags;
use super::topology::{CurveInfo, SurfaceTopo};
use super::{graph, post};
use super::{RecombineError, RecombineOptions, SurfaceReport};
use crate::mesh::{etype, Mesh, NodeTable};
use crate::profile::{StageTimer, Trace, TraceEvent};

/// Triangles of one surface, ready for parity analysis and matching.
pub(crate) struct SurfaceWork {
    pub tag: i32,
    pub topo: SurfaceTopo,
    pub region: Vec<u32>,
    pub n_regions: usize,
    /// Element tag of each triangle.
    pub elem_tags: Vec<u64>,
    /// MSH 2 partition tags of each triangle, when its block had some; empty when no
    /// block of the surface has any.
    pub partitions: Vec<Option<Vec<i32>>>,
    /// Quads already on the surface.
    pub quads_kept: usize,
    pub time: Duration,
}

/// Result of one surface's matching and post-processing.
pub(super) struct SurfaceResult {
    pub faces: post::Faces,
    pub report: SurfaceReport,
}

/// Step 2: every surface's triangles, topology and regions.
pub(super) fn surface_work(
    mesh: &Mesh,
    nodes: &NodeTable,
    curves: &CurveInfo,
    trace: Option<&Trace>,
) -> Result<Vec<SurfaceWork>, RecombineError> {
    surface_tags(mesh)
        .into_par_iter()
        .map(|tag| {
            let t0 = Instant::now();
            let mut tm = StageTimer::new(trace, "topology", tag);
            let blocks = || {
                mesh.element_blocks.iter().filter(|b| {
                    b.element_type == etype::TRI3 && b.entity_dim == 2 && b.entity_tag == tag
                })
            };
            // sized up front (no regrowth copies); partitions only when a block has some
            let count: usize = blocks().map(|b| b.len()).sum();
            let any_parts = blocks().any(|b| b.partitions.is_some());
            let mut tris = Vec::with_capacity(count);
            let mut elem_tags = Vec::with_capacity(count);
            let mut partitions = Vec::with_capacity(if any_parts { count } else { 0 });
            for b in blocks() {
                for i in 0..b.len() {
                    tris.push(nodes.ids::<3>(b.element(i)).map_err(|node| {
                        RecombineError::UnknownNode {
                            dim: 2,
                            entity: tag,
                            element: b.tags[i],
                            node,
                        }
                    })?);
                }
                elem_tags.extend_from_slice(&b.tags);
                if any_parts {
                    partitions.extend(
                        (0..b.len()).map(|i| b.partitions.as_ref().and_then(|p| p.get(i).cloned())),
                    );
                }
            }
            let quads_kept = mesh
                .element_blocks
                .iter()
                .filter(|b| {
                    b.element_type == etype::QUAD4 && b.entity_dim == 2 && b.entity_tag == tag
                })
                .map(|b| b.len())
                .sum();
            tm.lap("ids");
            let topo = SurfaceTopo::new(tris, nodes, curves);
            tm.lap("adjacency");
            let (region, n_regions) = topo.regions();
            tm.lap("regions");
            tm.done();
            Ok(SurfaceWork {
                tag,
                topo,
                region,
                n_regions,
                elem_tags,
                partitions,
                quads_kept,
                time: t0.elapsed(),
            })
        })
        .collect()
}

/// Steps 4–7 for one surface.
pub(super) fn match_surface(
    w: &SurfaceWork,
    coords: &[glam::DVec3],
    split_nodes: &[u32],
    n_global: u32,
    opts: &RecombineOptions,
) -> Result<SurfaceResult, RecombineError> {
    let t0 = Instant::now();
    let cross = opts.cross_field_weight.clamp(0.0, 5.0);
    let g = graph::build(
        &w.topo,
        coords,
        split_nodes,
        cross,
        opts.harmonic_cross_field,
        opts.extra_edges,
        opts.trace.as_ref(),
    );
    let time_graph = w.time + t0.elapsed();
    if let Some(trace) = &opts.trace {
        trace.emit(&TraceEvent::MatchingGraph {
            surface: w.tag,
            vertices: w.topo.len(),
            edges: &g.edges,
        });
    }
    let t1 = Instant::now();
    let n = w.topo.len();
    let m = crate::matching::solve(n, &g.edges).map_err(|e| RecombineError::NoPerfectMatching {
        surface: w.tag,
        triangles: n,
        witness: e.witness.len(),
        odd_components: e.odd_components.len(),
    })?;
    if opts.verify {
        crate::matching::verify(n, &g.edges, &m).map_err(|e| RecombineError::Certificate {
            surface: w.tag,
            detail: e.to_string(),
        })?;
    }
    let time_matching = t1.elapsed();
    let t2 = Instant::now();
    let faces = post::build_faces(&w.topo, &g, &m.mate, coords, n_global).map_err(|detail| {
        RecombineError::PostProcess {
            surface: w.tag,
            detail,
        }
    })?;
    let report = SurfaceReport {
        surface: w.tag,
        triangles_in: n,
        quads_out: faces.quads.len(),
        quads_kept: w.quads_kept,
        parity_splits: 0,
        graph_edges: g.real,
        extra_edges_added: g.edges.len() - g.real,
        extra_edges_used: faces.extra_used,
        edge_swaps: faces.swaps,
        vertex_duplications: faces.duplications,
        matching_cost: m.cost,
        time_graph,
        time_matching,
        time_post: t2.elapsed(),
    };
    Ok(SurfaceResult { faces, report })
}
