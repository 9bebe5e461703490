//! One surface from its triangles to its quads: the triangles, half-edges and regions of
//! each surface (step 2 of the module docs), then the graph, the matching and the
//! post-processing (steps 4–7).

use std::sync::atomic::{AtomicU64, AtomicUsize, Ordering};
use std::sync::Arc;
use std::time::{Duration, Instant};

use rayon::prelude::*;

use super::surface_tags;
use super::topology::{CurveInfo, SurfaceTopo};
use super::memo::{self, MatchMemo};
use super::{graph, post};
use super::{RecombineError, RecombineOptions, SurfaceReport};
use crate::mesh::{etype, Mesh, NodeTable};
use crate::profile::{StageTimer, Trace, TraceEvent};

/// Triangles of one surface, ready for parity analysis and matching.
pub(crate) struct SurfaceWork {
    pub tag: i32,
    pub topo: SurfaceTopo,
    /// The refusal of the surface's first fold, when it has folds (walled off in `topo`),
    /// and the node tags of the folded edges.
    pub fold: Option<super::topology::Fold>,
    pub region: Vec<u32>,
    pub n_regions: usize,
    /// The regions that are strips (filled once the regions are final, before they are
    /// freed; see [`super::strip`]).
    pub strips: Vec<super::strip::Strip>,
    /// Element tag of each triangle.
    pub elem_tags: Vec<u64>,
    /// MSH 2 partition tags of each triangle, when its block had some; empty when no
    /// block of the surface has any.
    pub partitions: Vec<Option<Vec<i32>>>,
    /// Quads already on the surface.
    pub quads_kept: usize,
    /// True when `topo.tris` are in Morton order (from [`MORTON_FROM`] triangles): the
    /// matching then keeps that numbering ([`crate::matching::VertexOrder::Given`]).
    pub morton: bool,
    pub time: Duration,
}

/// Triangles from which a surface's triangles are put in Morton order (`surface_work`):
/// below, the surface's arrays stay in cache in the file's order.
const MORTON_FROM: usize = 1 << 16;

/// Result of one surface's matching and post-processing.
pub(super) struct SurfaceResult {
    pub faces: post::Faces,
    pub report: SurfaceReport,
    /// The surface's strips that may be meshed again ([`super::strip`]), for the
    /// recombination to choose from within the element count.
    pub strip_plans: Vec<super::strip::StripPlan>,
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
            // speed: a large surface's triangles in the Morton order of their centroids, so
            // that the topology, the graph and the matching touch nearby memory (the file's
            // order is not local enough; figures in BENCHMARKS.md, "Measurements behind the
            // defaults")
            let morton = tris.len() >= MORTON_FROM;
            if morton {
                let order = crate::keysort::morton_order(&tris, &nodes.coords);
                tris = order.iter().map(|&t| tris[t as usize]).collect();
                elem_tags = order.iter().map(|&t| elem_tags[t as usize]).collect();
                if any_parts {
                    partitions = order
                        .iter()
                        .map(|&t| std::mem::take(&mut partitions[t as usize]))
                        .collect();
                }
            }
            tm.lap("ids");
            let normals = super::input::triangle_normals(tag, &tris, &elem_tags, nodes)?;
            tm.lap("checks");
            let (topo, fold) = SurfaceTopo::new(tris, &normals, nodes, curves, tag, &elem_tags)?;
            drop(normals);
            tm.lap("adjacency");
            let (region, n_regions) = topo.regions();
            tm.lap("regions");
            tm.done();
            Ok(SurfaceWork {
                tag,
                topo,
                fold,
                region,
                n_regions,
                strips: Vec::new(),
                elem_tags,
                partitions,
                quads_kept,
                morton,
                time: t0.elapsed(),
            })
        })
        .collect()
}

/// Triangles from which a surface hands the memory freed by its graph's construction back
/// to the system before its solver allocates ([`crate::set_memory_release`]):
/// below, the solver's arrays are small and the call would cost more than it frees.
const RELEASE_BEFORE_SOLVE: usize = 100_000;

/// What every surface's matching reads of the whole mesh.
#[derive(Clone, Copy)]
pub(super) struct MeshSide<'a> {
    /// Node coordinates by global id.
    pub coords: &'a [glam::DVec3],
    /// The split nodes (parity and fallback splits), sorted global ids.
    pub split_nodes: &'a [u32],
    /// The nodes a corner at which is no wall's
    /// ([`RecombineOptions::movable_nodes`]), sorted global ids.
    pub movable: &'a [u32],
    /// The priced-out quads as sorted global ids, sorted.
    pub priced: &'a [[u32; 4]],
    /// The number of global ids (a surface's new nodes are numbered from it).
    pub n_global: u32,
}

/// Steps 4–7 for one surface.
pub(super) fn match_surface(
    w: &SurfaceWork,
    mesh: &MeshSide,
    opts: &RecombineOptions,
    tracker: Option<&Arc<Tracker>>,
    memo: Option<&MatchMemo>,
) -> Result<SurfaceResult, RecombineError> {
    let MeshSide {
        coords,
        split_nodes,
        movable,
        priced,
        n_global,
    } = *mesh;
    let t0 = Instant::now();
    let n = w.topo.len();
    // speed: a surface recombined before in the run, the same but for its global node ids,
    // gets that matching's quads back (not with the certificate check or a trace, which
    // want the graph and the solver)
    let local = memo.filter(|_| !opts.verify && opts.trace.is_none()).map(|m| {
        let l = memo::Local::new(w.tag, w.morton, &w.topo, coords, [split_nodes, movable], priced, opts);
        (m, l)
    });
    if let Some((m, l)) = &local {
        if let Some((faces, strip_plans, f)) = l.find(m, n_global) {
            if let Some(t) = tracker {
                t.graph_built(n);
                t.matched(n as u64, true);
            }
            let times = [w.time + t0.elapsed(), Duration::ZERO, Duration::ZERO];
            let report = surface_report(w, &faces, f, times);
            return Ok(SurfaceResult {
                faces,
                report,
                strip_plans,
            });
        }
    }
    let cross = opts.cross_field_weight.clamp(0.0, 5.0);
    let mut g = graph::build(
        &w.topo,
        coords,
        graph::Pricing {
            split_nodes,
            movable,
            flat_halves_out: opts.flat_halves_out,
            hopeless_out: opts.hopeless_out.binary_search(&w.tag).is_ok(),
        },
        cross,
        opts.harmonic_cross_field,
        opts.extra_edges,
        opts.trace.as_ref(),
    );
    let priced_edges = price_out(&w.topo, &mut g, priced);
    let time_graph = w.time + t0.elapsed();
    if let Some(trace) = &opts.trace {
        trace.emit(&TraceEvent::MatchingGraph {
            surface: w.tag,
            vertices: w.topo.len(),
            edges: &g.edges,
        });
    }
    let t1 = Instant::now();
    if n >= RELEASE_BEFORE_SOLVE {
        // memory: the graph's temporaries (normals, cross field, walls) are freed, maybe
        // on other threads' arenas; the solver allocates next
        crate::memory::release_memory();
    }
    let sent = Arc::new(AtomicU64::new(0));
    let progress = tracker.map(|t| {
        t.graph_built(n);
        let (t, sent) = (Arc::clone(t), Arc::clone(&sent));
        // the solver's (done, total) as this surface's share of the triangles
        let f = move |done: usize, total: usize| {
            let units = (n as u128 * done as u128 / total.max(1) as u128) as u64;
            let before = sent.fetch_max(units, Ordering::Relaxed);
            t.matched(units.saturating_sub(before), false);
        };
        Box::new(f) as crate::matching::blossom::ProgressCallback
    });
    let edge_count = g.edges.len();
    // memory: the solver frees the edge list once its own arrays are built, unless the
    // certificate check below reads it again
    let edges = if opts.verify {
        g.edges.clone()
    } else {
        std::mem::take(&mut g.edges)
    };
    // speed: a surface in Morton order is more local in that order than in the solver's
    // breadth-first one (BENCHMARKS.md, "Measurements behind the defaults")
    let order = if w.morton {
        crate::matching::VertexOrder::Given
    } else {
        crate::matching::VertexOrder::BreadthFirst
    };
    let split = opts
        .split_matching
        .then_some(crate::memory::release_memory as fn());
    let solved = crate::matching::solve_owned(n, edges, progress, order, split);
    let m = solved.map_err(|e| RecombineError::NoPerfectMatching {
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
    let strip_plans = if opts.two_row_strips {
        super::strip::plans(&w.topo, &w.strips, coords, &faces, n_global)
    } else {
        Vec::new()
    };
    if let Some(t) = tracker {
        let before = sent.swap(n as u64, Ordering::Relaxed);
        t.matched((n as u64).saturating_sub(before), true);
    }
    let figures = memo::Figures {
        graph_edges: g.real,
        extra_edges_added: edge_count - g.real,
        matching_cost: m.cost,
        pairs_priced_out: priced_edges.len(),
        priced_out_used: priced_edges
            .iter()
            .filter(|&&(t, u)| m.mate[t as usize] == u)
            .count(),
    };
    let report = surface_report(w, &faces, figures, [time_graph, time_matching, t2.elapsed()]);
    if let Some((m, l)) = &local {
        // a result naming a node neither the surface's nor new is not stored (none does)
        let _ = l.store(m, &faces, &strip_plans, n_global, figures);
    }
    Ok(SurfaceResult {
        faces,
        report,
        strip_plans,
    })
}

/// The report of surface `w` recombined into `faces`, with its graph's and matching's
/// `figures` and the times of its graph, matching and quads.
fn surface_report(
    w: &SurfaceWork,
    faces: &post::Faces,
    figures: memo::Figures,
    [time_graph, time_matching, time_post]: [Duration; 3],
) -> SurfaceReport {
    SurfaceReport {
        surface: w.tag,
        triangles_in: w.topo.len(),
        quads_out: faces.quads.len(),
        quads_kept: w.quads_kept,
        parity_splits: 0,
        graph_edges: figures.graph_edges,
        extra_edges_added: figures.extra_edges_added,
        extra_edges_used: faces.extra_used,
        edge_swaps: faces.swaps,
        vertex_duplications: faces.duplications,
        strips_remeshed: 0,
        matching_cost: figures.matching_cost,
        pairs_priced_out: figures.pairs_priced_out,
        priced_out_used: figures.priced_out_used,
        time_graph,
        time_matching,
        time_post,
    }
}

/// Gives every real graph edge of `g` whose quad (the union of its two triangles, as
/// sorted node ids) is in `priced` (sorted) the cost [`graph::priced_out_cost`]; returns
/// those edges' triangles.
fn price_out(topo: &SurfaceTopo, g: &mut graph::Graph, priced: &[[u32; 4]]) -> Vec<(u32, u32)> {
    let mut out = Vec::new();
    if priced.is_empty() {
        return out;
    }
    let cost = graph::priced_out_cost(topo.len());
    for e in &mut g.edges[..g.real] {
        let (a, b) = (topo.tris[e.0 as usize], topo.tris[e.1 as usize]);
        let Some(&far) = b.iter().find(|v| !a.contains(v)) else {
            continue;
        };
        let mut q = [a[0], a[1], a[2], far];
        q.sort_unstable();
        if priced.binary_search(&q).is_ok() {
            e.2 = e.2.max(cost);
            out.push((e.0, e.1));
        }
    }
    out
}

/// The progress of the graphs and matchings of all surfaces, which run side by side (see
/// [`crate::progress::Stage::Graph`] and [`crate::progress::Stage::Matching`]): the graph stage until every
/// surface has its graph, then the matching stage, both counted in triangles.
pub(super) struct Tracker {
    f: crate::progress::ProgressFn,
    /// Triangles of all surfaces.
    triangles: u64,
    surfaces: usize,
    /// Triangles of the surfaces whose graph is built, and those surfaces.
    graph_triangles: AtomicU64,
    graphs: AtomicUsize,
    /// Triangles matched (each surface's share of its solver's progress), and the surfaces
    /// with their quads made.
    matched: AtomicU64,
    finished: AtomicUsize,
}

impl Tracker {
    pub(super) fn new(f: crate::progress::ProgressFn, work: &[SurfaceWork]) -> Self {
        Tracker {
            f,
            triangles: work.iter().map(|w| w.topo.len() as u64).sum(),
            surfaces: work.len(),
            graph_triangles: AtomicU64::new(0),
            graphs: AtomicUsize::new(0),
            matched: AtomicU64::new(0),
            finished: AtomicUsize::new(0),
        }
    }

    /// A surface of `n` triangles has its graph.
    fn graph_built(&self, n: usize) {
        self.graph_triangles.fetch_add(n as u64, Ordering::Relaxed);
        self.graphs.fetch_add(1, Ordering::Relaxed);
        self.emit();
    }

    /// `units` more triangles matched; `finished`: a surface has its quads.
    fn matched(&self, units: u64, finished: bool) {
        self.matched.fetch_add(units, Ordering::Relaxed);
        if finished {
            self.finished.fetch_add(1, Ordering::Relaxed);
        }
        self.emit();
    }

    /// Reports the current state (the pipeline's reporter drops what is not due).
    pub(super) fn emit(&self) {
        let graphs = self.graphs.load(Ordering::Relaxed);
        let p = if graphs < self.surfaces {
            crate::progress::Progress::new(
                crate::progress::Stage::Graph,
                self.graph_triangles.load(Ordering::Relaxed),
                self.triangles,
            )
            .with_surfaces(graphs, self.surfaces)
        } else {
            crate::progress::Progress::new(
                crate::progress::Stage::Matching,
                self.matched.load(Ordering::Relaxed),
                self.triangles,
            )
            .with_surfaces(self.finished.load(Ordering::Relaxed), self.surfaces)
        };
        self.f.report(p);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::optimize::synth;

    /// A large surface in a file order without locality (its faces shuffled).
    fn shuffled_square() -> Mesh {
        let mut soup = synth::delaunay_square(190, 1.0, 0.3, 3);
        let mut rng = synth::Rng::new(11);
        for i in (1..soup.faces.len()).rev() {
            let j = (rng.next_f64() * (i + 1) as f64) as usize % (i + 1);
            soup.faces.swap(i, j);
        }
        assert!(soup.faces.len() >= MORTON_FROM, "{}", soup.faces.len());
        synth::to_mesh(&soup)
    }

    /// The whole job on such a surface: every triangle recombined, the matching solved in
    /// the Morton order with its optimality certificate checked, the checks of
    /// `quadrangulate` (conformity, orientation, validity) passed.
    #[test]
    fn a_large_shuffled_surface_is_recombined_and_optimized() {
        let mut mesh = shuffled_square();
        let opts = crate::Options {
            verify: true,
            ..crate::Options::default()
        };
        let report = crate::quadrangulate(&mut mesh, &opts).expect("quadrangulate");
        assert!(report
            .recombine
            .surfaces
            .iter()
            .all(|s| s.quads_out > 30_000));
        let tris: usize = mesh.count_elements(etype::TRI3);
        assert_eq!(tris, 0);
    }

    /// With the matching's fractional start in blocks asked for, a surface above the
    /// solver's threshold for it (200,000 vertices) gets the default run's matching cost,
    /// its certificate checked, and passes the checks of `quadrangulate`.
    #[test]
    #[cfg_attr(
        debug_assertions,
        ignore = "2·10^5 triangles: run with cargo test --release"
    )]
    fn a_split_matching_reaches_the_default_cost() {
        let mesh = synth::to_mesh(&synth::delaunay_square(330, 1.0, 0.3, 5));
        assert!(mesh.count_elements(etype::TRI3) > 200_000);
        let costs = |split_matching| {
            let mut m = mesh.clone();
            let opts = crate::Options {
                verify: true,
                optimize: false,
                split_matching,
                ..crate::Options::default()
            };
            let report = crate::quadrangulate(&mut m, &opts).expect("quadrangulate");
            let s = &report.recombine.surfaces;
            s.iter().map(|s| s.matching_cost).collect::<Vec<_>>()
        };
        assert_eq!(costs(true), costs(false));
    }

    /// A surface of [`MORTON_FROM`] triangles or more is taken in Morton order: each
    /// triangle keeps its own element tag, every triangle is there once, and consecutive
    /// triangles are close (their centroids a few cells apart on average, against a
    /// large share of the square in the generator's order after a shuffle).
    #[test]
    fn a_large_surface_takes_its_triangles_in_morton_order_with_their_tags() {
        let mesh = shuffled_square();
        let nodes = NodeTable::new(&mesh);
        let curves = CurveInfo::new(&mesh, &nodes).expect("curves");
        let work = surface_work(&mesh, &nodes, &curves, None).expect("the surface");
        assert_eq!(work.len(), 1);
        let w = &work[0];
        // so the matching keeps that numbering (`VertexOrder::Given`); a small surface
        // keeps the file's order and the solver's breadth-first one
        assert!(w.morton);
        let small = synth::to_mesh(&synth::delaunay_square(20, 1.0, 0.3, 3));
        let nodes_s = NodeTable::new(&small);
        let curves_s = CurveInfo::new(&small, &nodes_s).expect("curves");
        let small_work = surface_work(&small, &nodes_s, &curves_s, None).expect("the surface");
        assert!(small_work.iter().all(|w| !w.morton));
        // the element of each tag, as node ids
        let mut by_tag = std::collections::HashMap::new();
        for b in mesh
            .element_blocks
            .iter()
            .filter(|b| b.element_type == etype::TRI3)
        {
            for i in 0..b.len() {
                by_tag.insert(b.tags[i], nodes.ids::<3>(b.element(i)).expect("nodes"));
            }
        }
        assert_eq!(w.elem_tags.len(), by_tag.len());
        let mut seen = std::collections::HashSet::new();
        for (t, tag) in w.elem_tags.iter().enumerate() {
            assert!(seen.insert(*tag), "tag {tag} twice");
            let mut a = w.topo.tris[t];
            let mut b = by_tag[tag];
            a.sort_unstable();
            b.sort_unstable();
            assert_eq!(a, b, "triangle {t} is not element {tag}");
        }
        let centroid = |t: &[u32; 3]| {
            t.iter()
                .map(|&v| nodes.coords[v as usize])
                .sum::<glam::DVec3>()
                / 3.0
        };
        let mean_step = w
            .topo
            .tris
            .windows(2)
            .map(|p| centroid(&p[0]).distance(centroid(&p[1])))
            .sum::<f64>()
            / (w.topo.tris.len() - 1) as f64;
        // cells of 1/190: consecutive triangles within a few cells of each other
        assert!(mean_step < 5.0 / 190.0, "mean step {mean_step}");
    }
}
