//! Surface extraction and triangle adjacency: which mesh edges lie on
//! model curves (walls), and each surface's triangle-adjacency graph.
//!
//! Hot path: edges are found by sorting `u64` keys `(min << 32) | max` of global `u32` node
//! ids (the ids of [`NodeTable`]), never with hash maps.

use crate::mesh::{etype, Mesh, NodeTable};
use rayon::prelude::*;

use crate::keysort;
use std::sync::atomic::{AtomicU32, Ordering::Relaxed};

use super::RecombineError;

/// Sentinel for "no triangle / no node".
pub(crate) use crate::mesh::NONE;

/// Key of the undirected edge `{a, b}`.
#[inline]
pub(crate) fn edge_key(a: u32, b: u32) -> u64 {
    let (lo, hi) = if a < b { (a, b) } else { (b, a) };
    ((lo as u64) << 32) | hi as u64
}

/// What the whole mesh says about model curves: edges carried by line elements, and for
/// curves without line elements, node classification and bounding points.
pub(crate) struct CurveInfo {
    /// Sorted keys of every 2-node line element's edge.
    pub line_edges: Vec<u64>,
    /// Per global node id: true when some line element uses the node (a cheap filter before
    /// searching `line_edges`).
    pub line_node: Vec<bool>,
    /// For each node block: `Some(curve tag)` when it classifies nodes on a curve that has no
    /// line element anywhere in the mesh (rule (b) applies to it), else `None`.
    pub bare_curve_of_block: Vec<Option<i32>>,
    /// For each node block on a point: the point tag.
    pub point_of_block: Vec<Option<i32>>,
    /// `(curve, |bounding point|)` pairs of bare curves, sorted.
    pub bare_curve_points: Vec<(i32, i32)>,
}

impl CurveInfo {
    /// Collects line edges and bare-curve data.
    pub fn new(mesh: &Mesh, nodes: &NodeTable) -> Result<Self, RecombineError> {
        let mut line_edges = Vec::new();
        let mut line_node = vec![false; nodes.coords.len()];
        let mut curves_with_lines: Vec<i32> = Vec::new();
        for b in &mesh.element_blocks {
            if b.element_type != etype::LINE2 {
                continue;
            }
            curves_with_lines.push(b.entity_tag);
            for i in 0..b.len() {
                let [a, c] =
                    nodes
                        .ids::<2>(b.element(i))
                        .map_err(|node| RecombineError::UnknownNode {
                            dim: b.entity_dim,
                            entity: b.entity_tag,
                            element: b.tags[i],
                            node,
                        })?;
                line_edges.push(edge_key(a, c));
                line_node[a as usize] = true;
                line_node[c as usize] = true;
            }
        }
        line_edges.sort_unstable();
        line_edges.dedup();
        curves_with_lines.sort_unstable();
        curves_with_lines.dedup();
        let bare = |tag: i32| curves_with_lines.binary_search(&tag).is_err();
        let bare_curve_of_block = mesh
            .node_blocks
            .iter()
            .map(|b| (b.entity_dim == 1 && bare(b.entity_tag)).then_some(b.entity_tag))
            .collect();
        let point_of_block = mesh
            .node_blocks
            .iter()
            .map(|b| (b.entity_dim == 0).then_some(b.entity_tag))
            .collect();
        let mut bare_curve_points = Vec::new();
        for c in &mesh.entities[1] {
            if bare(c.tag) {
                for &p in &c.bounding {
                    bare_curve_points.push((c.tag, p.abs()));
                }
            }
        }
        bare_curve_points.sort_unstable();
        Ok(CurveInfo {
            line_edges,
            line_node,
            bare_curve_of_block,
            point_of_block,
            bare_curve_points,
        })
    }

    /// Whether the edge `{a, b}` lies on a model curve: [`OnCurve::Line`] when it is a line
    /// element; for curves without line elements (rule (b)), [`OnCurve::Bare`] when both
    /// nodes are classified on the same bare curve, or one on a bare curve and the other on a
    /// point bounding that curve.
    #[inline]
    pub fn on_curve(&self, nodes: &NodeTable, a: u32, b: u32) -> OnCurve {
        if self.line_node[a as usize]
            && self.line_node[b as usize]
            && self.line_edges.binary_search(&edge_key(a, b)).is_ok()
        {
            return OnCurve::Line;
        }
        let ba = nodes.block[a as usize] as usize;
        let bb = nodes.block[b as usize] as usize;
        let c = match (self.bare_curve_of_block[ba], self.bare_curve_of_block[bb]) {
            (Some(c), Some(d)) => (c == d).then_some(c),
            (Some(c), None) => self.bounds(c, self.point_of_block[bb]).then_some(c),
            (None, Some(d)) => self.bounds(d, self.point_of_block[ba]).then_some(d),
            (None, None) => None,
        };
        c.map_or(OnCurve::No, OnCurve::Bare)
    }

    fn bounds(&self, curve: i32, point: Option<i32>) -> bool {
        point.is_some_and(|p| self.bare_curve_points.binary_search(&(curve, p)).is_ok())
    }
}

/// Result of [`CurveInfo::on_curve`].
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum OnCurve {
    /// Not on a curve.
    No,
    /// A 2-node line element.
    Line,
    /// Possibly a segment of this curve, which has no line elements.
    Bare(i32),
}

/// The half-edges `3t + k` of a triangle list, sorted by (edge key, half-edge).
pub(crate) enum SortedHalves {
    /// Key and half-edge packed in one `u64`: `key_bits << p | half_edge`.
    Packed {
        /// Packed values, sorted.
        v: Vec<u64>,
        /// Bits of the half-edge part.
        p: u32,
    },
    /// `(edge_key, half_edge)` pairs, sorted.
    Pairs(Vec<(u64, u32)>),
}

impl SortedHalves {
    /// Calls `f` with the half-edges of each run of equal keys, in key order.
    #[cfg(test)]
    pub fn runs(&self, f: impl FnMut(&[u32])) {
        match self {
            SortedHalves::Packed { v, p } => packed_runs(v, *p, f),
            SortedHalves::Pairs(v) => pair_runs(v, f),
        }
    }

    /// [`SortedHalves::runs`] on consecutive pieces of the list in parallel, each cut
    /// between two runs: every piece folds its runs, in key order, into a state made by
    /// `init`; the states come back in piece (so key) order. Lists below [`RUN_PIECE`]
    /// half-edges are one piece.
    pub fn par_runs<S: Send>(
        &self,
        init: impl Fn() -> S + Sync,
        f: impl Fn(&mut S, &[u32]) + Sync,
    ) -> Vec<S> {
        match self {
            SortedHalves::Packed { v, p } => {
                let cuts = run_cuts(v.len(), |i| v[i - 1] >> p == v[i] >> p);
                fold_pieces(&cuts, init, |s, (a, b)| {
                    packed_runs(&v[a..b], *p, |run| f(s, run))
                })
            }
            SortedHalves::Pairs(v) => {
                let cuts = run_cuts(v.len(), |i| v[i - 1].0 == v[i].0);
                fold_pieces(&cuts, init, |s, (a, b)| {
                    pair_runs(&v[a..b], |run| f(s, run))
                })
            }
        }
    }
}

/// Half-edges per piece of [`SortedHalves::par_runs`] (about).
const RUN_PIECE: usize = 1 << 16;

/// The runs of packed values `v` (key above bit `p`, half-edge below).
fn packed_runs(v: &[u64], p: u32, mut f: impl FnMut(&[u32])) {
    let mut buf: Vec<u32> = Vec::with_capacity(4);
    let low = (1u64 << p) - 1;
    for run in v.chunk_by(|x, y| x >> p == y >> p) {
        buf.clear();
        buf.extend(run.iter().map(|x| (x & low) as u32));
        f(&buf);
    }
}

/// The runs of `(key, half-edge)` pairs `v`.
fn pair_runs(v: &[(u64, u32)], mut f: impl FnMut(&[u32])) {
    let mut buf: Vec<u32> = Vec::with_capacity(4);
    for run in v.chunk_by(|x, y| x.0 == y.0) {
        buf.clear();
        buf.extend(run.iter().map(|x| x.1));
        f(&buf);
    }
}

/// Boundaries `0 = c_0 < c_1 < … < c_m = len` of pieces of about [`RUN_PIECE`] elements of a
/// list of runs, never inside a run (`same(i)`: elements `i − 1` and `i` are in one run).
fn run_cuts(len: usize, same: impl Fn(usize) -> bool) -> Vec<usize> {
    let pieces = len.div_ceil(RUN_PIECE).max(1);
    let mut cuts = vec![0];
    for i in 1..pieces {
        let mut c = (i * len / pieces).max(*cuts.last().unwrap_or(&0));
        while c > 0 && c < len && same(c) {
            c += 1;
        }
        if c > *cuts.last().unwrap_or(&0) && c < len {
            cuts.push(c);
        }
    }
    if len > 0 {
        cuts.push(len);
    }
    cuts
}

/// Folds each piece `(cuts[i], cuts[i + 1])` into a fresh state, in parallel; states in order.
fn fold_pieces<S: Send>(
    cuts: &[usize],
    init: impl Fn() -> S + Sync,
    f: impl Fn(&mut S, (usize, usize)) + Sync,
) -> Vec<S> {
    cuts.par_windows(2)
        .map(|w| {
            let mut s = init();
            f(&mut s, (w[0], w[1]));
            s
        })
        .collect()
}

/// Sorts the half-edges of `tris` by [`edge_key`].
///
/// When a key and a half-edge index fit in 64 bits together (node ids below 2^b and
/// half-edges below 2^p with 2b + p ≤ 64: up to about 2^20 nodes and 2^22 half-edges, more
/// when the other is smaller), they are packed in one `u64` and sorted as integers by
/// [`sort_packed`]; otherwise by a parallel comparison sort. Both give the same order.
pub(crate) fn sorted_half_edges(tris: &[[u32; 3]]) -> SortedHalves {
    let halves = 3 * tris.len();
    let (min_id, max_id) = tris
        .par_iter()
        .with_min_len(1 << 14)
        .map(|t| (t[0].min(t[1]).min(t[2]), t[0].max(t[1]).max(t[2])))
        .reduce(|| (u32::MAX, 0), |x, y| (x.0.min(y.0), x.1.max(y.1)));
    let bits = |x: u64| 64 - x.leading_zeros();
    let b = bits(max_id as u64);
    let p = bits(halves.saturating_sub(1) as u64);
    if halves < 1 << 16 || 2 * b + p > 64 {
        let mut keys: Vec<(u64, u32)> = Vec::with_capacity(halves);
        for (t, tri) in tris.iter().enumerate() {
            for k in 0..3 {
                keys.push((edge_key(tri[k], tri[(k + 1) % 3]), (3 * t + k) as u32));
            }
        }
        keys.par_sort_unstable();
        return SortedHalves::Pairs(keys);
    }
    SortedHalves::Packed {
        v: sort_packed(tris, b, p, min_id..=max_id),
        p,
    }
}

/// Triangles per piece of [`sort_packed`]'s first pass.
const SORT_PIECE: usize = 1 << 15;

/// The half-edges of `tris` packed as `lo << (b + p) | hi << p | half_edge` (`lo < hi` the
/// node ids of the edge, in `ids`, below 2^b; half-edges below 2^p), sorted ascending. The
/// values are distinct, so this is the one order of (edge key, half-edge).
///
/// Parallel in two passes: pieces of triangles pack their half-edges and group them by the
/// top bits of `lo − min` (buckets of a few thousand values); then each bucket gathers its
/// groups from every piece and sorts itself: by counting on the rest of `lo`, then by
/// comparison inside each `lo` (a few values), or by comparison alone when `lo` spreads
/// much wider than the bucket holds values.
fn sort_packed(tris: &[[u32; 3]], b: u32, p: u32, ids: std::ops::RangeInclusive<u32>) -> Vec<u64> {
    let halves = 3 * tris.len();
    let min = *ids.start();
    let span_bits = keysort::bits(ids.end().saturating_sub(min) as u64);
    // top bits of lo − min: about 2048 values per bucket, at most 2^12 buckets
    let top = keysort::bits((halves / 2048) as u64)
        .saturating_sub(1)
        .min(12)
        .min(span_bits);
    let buckets = 1usize << top;
    let lo_shift = b + p;
    let sub_bits = span_bits - top;
    let sub_mask = (1u64 << sub_bits) - 1;
    let rel = |v: u64| (v >> lo_shift) - min as u64;
    let bucket = |v: u64| (rel(v) >> sub_bits) as usize;
    // pass 1: per piece, its values grouped by bucket and where each group starts
    let pieces: Vec<(Vec<u64>, Vec<usize>)> = tris
        .par_chunks(SORT_PIECE)
        .enumerate()
        .map(|(c, chunk)| {
            let first = 3 * c * SORT_PIECE;
            let mut start = vec![0usize; buckets + 1];
            let mut vals: Vec<u64> = Vec::with_capacity(3 * chunk.len());
            for (i, tri) in chunk.iter().enumerate() {
                for k in 0..3 {
                    let (x, y) = (tri[k], tri[(k + 1) % 3]);
                    let (lo, hi) = if x < y { (x, y) } else { (y, x) };
                    let v =
                        ((lo as u64) << lo_shift) | ((hi as u64) << p) | (first + 3 * i + k) as u64;
                    start[bucket(v) + 1] += 1;
                    vals.push(v);
                }
            }
            for j in 1..=buckets {
                start[j] += start[j - 1];
            }
            let mut next = start.clone();
            let mut grouped = vec![0u64; vals.len()];
            for &v in &vals {
                let g = bucket(v);
                grouped[next[g]] = v;
                next[g] += 1;
            }
            (grouped, start)
        })
        .collect();
    // pass 2: each bucket's slice of the output, filled and sorted on its own
    let mut out = vec![0u64; halves];
    let mut slices: Vec<&mut [u64]> = Vec::with_capacity(buckets);
    let mut rest: &mut [u64] = &mut out;
    for g in 0..buckets {
        let size: usize = pieces.iter().map(|(_, s)| s[g + 1] - s[g]).sum();
        let (head, tail) = std::mem::take(&mut rest).split_at_mut(size);
        slices.push(head);
        rest = tail;
    }
    slices.into_par_iter().enumerate().for_each_init(
        Vec::new,
        |count: &mut Vec<usize>, (g, slice)| {
            let parts = || {
                pieces
                    .iter()
                    .map(|(vals, start)| &vals[start[g]..start[g + 1]])
            };
            if 1usize << sub_bits > 4 * slice.len() + 64 {
                // lo spread thin: a comparison sort beats counting over the spread
                let mut at = 0;
                for part in parts() {
                    slice[at..at + part.len()].copy_from_slice(part);
                    at += part.len();
                }
                slice.sort_unstable();
                return;
            }
            // counting sort on the low bits of lo (start of each lo's values, then its end)
            count.clear();
            count.resize((1 << sub_bits) + 1, 0);
            for &v in parts().flatten() {
                count[(rel(v) & sub_mask) as usize + 1] += 1;
            }
            for j in 1..count.len() {
                count[j] += count[j - 1];
            }
            for &v in parts().flatten() {
                let j = (rel(v) & sub_mask) as usize;
                slice[count[j]] = v;
                count[j] += 1;
            }
            // count[j] is now where lo j ends, count[j - 1] where it starts
            let mut from = 0;
            for &to in count.iter().take(1 << sub_bits) {
                if to - from > 1 {
                    slice[from..to].sort_unstable();
                }
                from = to;
            }
        },
    );
    out
}

/// Two adjacent triangles whose unit normals have a dot product below this are folded
/// onto each other (a turn of more than ~172° across their common edge).
pub(crate) const FOLDED: f64 = -0.99;

/// Why an edge of a surface is refused (see [`SurfaceTopo::new`]); triangles are indices
/// into the surface's triangle list.
pub(crate) enum EdgeProblem {
    /// Three or more triangles, ordered by (first node tag of their half-edge, index).
    NonManifold { tris: Vec<usize> },
    /// Two triangles running the edge `from → to` (node tags) both.
    SameDirection {
        first: usize,
        second: usize,
        from: u64,
        to: u64,
    },
    /// Two consistently oriented triangles with opposite normals; `first` runs the edge
    /// from its lower node tag.
    Folded { first: usize, second: usize },
}

/// The refusal of surface `surface` for `problem` on its edge `lo-hi` (node tags), with
/// `tag` giving the element tag of a triangle index.
pub(crate) fn edge_refusal(
    surface: i32,
    (lo, hi): (u64, u64),
    problem: EdgeProblem,
    tag: impl Fn(usize) -> u64,
) -> RecombineError {
    let (element, problem) = match problem {
        EdgeProblem::NonManifold { tris } => (
            tag(tris[2]),
            format!(
                "its edge {lo}-{hi} is shared by {} triangles of the surface (non-manifold; triangles {}, {}, ...)",
                tris.len(),
                tag(tris[0]),
                tag(tris[1])
            ),
        ),
        EdgeProblem::SameDirection {
            first,
            second,
            from,
            to,
        } => (
            tag(second),
            format!(
                "the triangle runs its edge {from}-{to} in the same direction as triangle {} (inconsistent orientation: one of them is flipped, or they overlap)",
                tag(first)
            ),
        ),
        EdgeProblem::Folded { first, second } => (
            tag(second),
            format!(
                "the triangle is folded over triangle {} across their common edge {lo}-{hi} (their normals point in opposite directions: overlapping or inverted triangles)",
                tag(first)
            ),
        ),
    };
    RecombineError::InvalidElement {
        surface,
        element,
        problem,
    }
}

/// The problem of the edge whose half-edges are `run`: three or more of them, or two
/// running the edge the same way; with the edge's node tags (lower, higher).
fn structural_problem(
    run: &[u32],
    tris: &[[u32; 3]],
    nodes: &NodeTable,
) -> ((u64, u64), EdgeProblem) {
    // (first node, second node) of the half-edge, as tags, and its triangle
    let half = |h: u32| {
        let (t, k) = (h as usize / 3, h as usize % 3);
        let (a, b) = (tris[t][k], tris[t][(k + 1) % 3]);
        (nodes.tags[a as usize], nodes.tags[b as usize], t)
    };
    let (a, b, t0) = half(run[0]);
    let key = (a.min(b), a.max(b));
    if run.len() > 2 {
        let mut ts: Vec<(u64, usize)> = run.iter().map(|&h| half(h)).map(|x| (x.0, x.2)).collect();
        ts.sort_unstable();
        let tris = ts.into_iter().map(|x| x.1).collect();
        return (key, EdgeProblem::NonManifold { tris });
    }
    let t1 = run[1] as usize / 3;
    let (first, second) = (t0.min(t1), t0.max(t1));
    (
        key,
        EdgeProblem::SameDirection {
            first,
            second,
            from: a,
            to: b,
        },
    )
}

/// The fold with the smallest edge (node tags) among the consistently oriented neighbours:
/// the graph edges of `nbr` and the `walled` half-edge pairs (neighbours across a curve).
fn first_fold(
    tris: &[[u32; 3]],
    normals: &[glam::DVec3],
    nbr: &[u32],
    walled: &[(u32, u32)],
    nodes: &NodeTable,
) -> Option<((u64, u64), EdgeProblem)> {
    // the fold of half-edge `h` of triangle t and its neighbour u, with the edge's tags
    let fold = |h: usize, t: usize, u: usize| {
        (normals[t].dot(normals[u]) < FOLDED).then(|| {
            let (a, b) = (tris[t][h % 3], tris[t][(h % 3 + 1) % 3]);
            let (a, b) = (nodes.tags[a as usize], nodes.tags[b as usize]);
            // the triangle running the edge from its lower tag first
            let (first, second) = if a < b { (t, u) } else { (u, t) };
            ((a.min(b), a.max(b)), first, second)
        })
    };
    let graph = (0..tris.len())
        .into_par_iter()
        .with_min_len(4096)
        .filter_map(|t| {
            (3 * t..3 * t + 3)
                .filter(|&h| nbr[h] != NONE && nbr[h] as usize > t)
                .filter_map(|h| fold(h, t, nbr[h] as usize))
                .min()
        })
        .min();
    let curve = walled
        .iter()
        .filter_map(|&(h0, h1)| {
            let (t, u) = (h0 as usize / 3, h1 as usize / 3);
            fold(h0 as usize, t, u)
        })
        .min();
    graph
        .into_iter()
        .chain(curve)
        .min()
        .map(|(key, first, second)| (key, EdgeProblem::Folded { first, second }))
}

/// Makes every graph edge of `nbr` across which two triangles are folded (unit normals'
/// dot product below [`FOLDED`]) a wall: both half-edges get [`NONE`]. Returns the nodes of
/// those edges (sorted global ids).
fn wall_folds(tris: &[[u32; 3]], normals: &[glam::DVec3], nbr: &mut [u32]) -> Vec<u32> {
    let folded: Vec<usize> = (0..nbr.len())
        .into_par_iter()
        .with_min_len(4096)
        .filter(|&h| {
            let u = nbr[h];
            u != NONE && normals[h / 3].dot(normals[u as usize]) < FOLDED
        })
        .collect();
    let mut ends = Vec::with_capacity(2 * folded.len());
    for h in folded {
        nbr[h] = NONE;
        let (t, k) = (h / 3, h % 3);
        ends.push(tris[t][k]);
        ends.push(tris[t][(k + 1) % 3]);
    }
    ends.sort_unstable();
    ends.dedup();
    ends
}

/// A surface's first fold, walled off: the refusal it would have given, and the node tags
/// of every folded edge.
pub(crate) type Fold = (RecombineError, Vec<u64>);

/// One surface's triangles and their adjacency.
pub(crate) struct SurfaceTopo {
    /// Triangles as global node ids, in the order of the surface's element tags (the file's
    /// order, or Morton order on large surfaces: `surface::surface_work`).
    pub tris: Vec<[u32; 3]>,
    /// `nbr[3t + k]`: the triangle across local edge `k` (`tris[t][k] → tris[t][k+1]`) when
    /// that edge is a graph edge, else [`NONE`].
    pub nbr: Vec<u32>,
}

impl SurfaceTopo {
    /// Builds the adjacency of `tris` (the triangles of surface `surface`, element tags
    /// `elem_tags`, unit normals `normals`), refusing what no recombination can turn into valid quads (found while
    /// pairing every edge's triangles, so without a sort of its own):
    ///
    /// - an edge shared by three or more triangles (non-manifold: a parity split of it
    ///   gives edges that no conforming recombination has);
    /// - two triangles running their common edge in the same direction (inconsistent
    ///   orientation: a flipped or overlapping triangle);
    /// - a fold: two consistently oriented triangles sharing an edge whose unit normals
    ///   have a dot product below [`FOLDED`] (one is flipped over the other).
    ///
    /// When a surface has several, the one on the edge with the smallest node tags is
    /// reported, naming its triangles as if the half-edges were sorted by (edge tags, first
    /// node tag, file order).
    ///
    /// A fold (two consistently oriented triangles sharing an edge whose unit normals have
    /// a dot product below [`FOLDED`]: Gmsh's mesh of a thin cylinder meshed coarser than
    /// its radius) is not refused here: every folded edge becomes a wall (no graph edge
    /// across it; parity repair sees it as a wall segment like any other), and the refusal
    /// it would have given (the fold with the smallest edge) comes back beside the
    /// topology with the node tags of the folded edges, for the caller to report if the
    /// quads are not valid.
    pub fn new(
        tris: Vec<[u32; 3]>,
        normals: &[glam::DVec3],
        nodes: &NodeTable,
        curves: &CurveInfo,
        surface: i32,
        elem_tags: &[u64],
    ) -> Result<(Self, Option<Fold>), RecombineError> {
        let n = tris.len();
        let keys = sorted_half_edges(&tris);
        // bare curves that carry a boundary edge of this surface bound it: their segments
        // are boundary edges, so an interior edge between two of their nodes is a chord, not
        // a segment (e.g. a triangle with three nodes on a circle)
        // (runs scanned by pieces in parallel, the pieces' findings merged in key order)
        let mut boundary_curves: Vec<i32> = Vec::new();
        let found = keys.par_runs(Vec::new, |curves_here: &mut Vec<i32>, run| {
            if let [h] = run {
                let (t, k) = (*h as usize / 3, *h as usize % 3);
                let (a, b) = (tris[t][k], tris[t][(k + 1) % 3]);
                if let OnCurve::Bare(c) = curves.on_curve(nodes, a, b) {
                    if !curves_here.contains(&c) {
                        curves_here.push(c);
                    }
                }
            }
        });
        for c in found.into_iter().flatten() {
            if !boundary_curves.contains(&c) {
                boundary_curves.push(c);
            }
        }
        let boundary_curves = &boundary_curves;
        // each half-edge is in one run: the pieces write disjoint entries
        let nbr: Vec<AtomicU32> = (0..3 * n).map(|_| AtomicU32::new(NONE)).collect();
        // per piece: the refused edge with the smallest (lower, higher) node tags, with its
        // problem, and the consistently oriented neighbours across a curve (not graph
        // edges, for the folds)
        type Piece = (Option<((u64, u64), EdgeProblem)>, Vec<(u32, u32)>);
        let keep_first = |refused: &mut Option<((u64, u64), EdgeProblem)>,
                          p: ((u64, u64), EdgeProblem)| {
            if refused.as_ref().is_none_or(|r| p.0 < r.0) {
                *refused = Some(p);
            }
        };
        let pieces: Vec<Piece> = keys.par_runs(
            || (None, Vec::new()),
            |(refused, walled): &mut Piece, run| {
                if run.len() > 2 {
                    // non-manifold: a wall (nbr stays NONE)
                    keep_first(refused, structural_problem(run, &tris, nodes));
                }
                if let [h0, h1] = run {
                    let (h0, h1) = (*h0 as usize, *h1 as usize);
                    let (t0, k0) = (h0 / 3, h0 % 3);
                    let (t1, k1) = (h1 / 3, h1 % 3);
                    let a = tris[t0][k0];
                    let b = tris[t0][(k0 + 1) % 3];
                    // consistent orientation: t1 runs the edge b -> a (else refused)
                    if tris[t1][k1] != b || tris[t1][(k1 + 1) % 3] != a {
                        keep_first(refused, structural_problem(run, &tris, nodes));
                        return;
                    }
                    // an edge on a model curve (embedded curve, seam) is a wall, not a
                    // graph edge
                    let on_curve = match curves.on_curve(nodes, a, b) {
                        OnCurve::Line => true,
                        OnCurve::Bare(c) => !boundary_curves.contains(&c),
                        OnCurve::No => false,
                    };
                    if on_curve {
                        walled.push((h0 as u32, h1 as u32));
                    } else {
                        nbr[h0].store(t1 as u32, Relaxed);
                        nbr[h1].store(t0 as u32, Relaxed);
                    }
                }
            },
        );
        let nbr: Vec<u32> = nbr.into_iter().map(AtomicU32::into_inner).collect();
        let mut refused = None;
        let mut walled: Vec<(u32, u32)> = Vec::new();
        for (r, w) in pieces {
            if let Some(r) = r {
                keep_first(&mut refused, r);
            }
            walled.extend(w);
        }
        let tag = |t: usize| elem_tags.get(t).copied().unwrap_or(0);
        let fold = first_fold(&tris, normals, &nbr, &walled, nodes);
        if let Some(structural) = refused {
            // refused whole: the problem on the smallest edge, the fold included
            let (key, problem) = match fold {
                Some(f) if f.0 < structural.0 => f,
                _ => structural,
            };
            return Err(edge_refusal(surface, key, problem, tag));
        }
        // folds are walled off: no pair across them (a fold across a curve is a wall
        // already); the first one is kept to be reported if the result is not valid
        let mut nbr = nbr;
        let fold = fold.map(|(key, problem)| {
            let ends = wall_folds(&tris, normals, &mut nbr);
            let tags = ends.iter().map(|&v| nodes.tags[v as usize]).collect();
            (edge_refusal(surface, key, problem, tag), tags)
        });
        Ok((SurfaceTopo { tris, nbr }, fold))
    }

    /// Number of triangles.
    pub fn len(&self) -> usize {
        self.tris.len()
    }

    /// Connected components of the graph (graph edges only): component id per triangle and
    /// the number of components.
    ///
    /// Components are numbered in the order of their first triangle. Large surfaces join the
    /// triangles across graph edges in parallel (a union-find whose root is always the
    /// smallest triangle of its tree, so each root is its component's first triangle).
    pub fn regions(&self) -> (Vec<u32>, usize) {
        let n = self.len();
        if n >= PARALLEL_REGIONS {
            return self.regions_parallel();
        }
        self.regions_serial()
    }

    /// [`SurfaceTopo::regions`] by one depth-first search (the numbering the parallel version
    /// reproduces).
    fn regions_serial(&self) -> (Vec<u32>, usize) {
        let n = self.len();
        let mut id = vec![NONE; n];
        let mut count = 0u32;
        let mut stack = Vec::new();
        for s in 0..n {
            if id[s] != NONE {
                continue;
            }
            id[s] = count;
            stack.push(s as u32);
            while let Some(t) = stack.pop() {
                for k in 0..3 {
                    let u = self.nbr[3 * t as usize + k];
                    if u != NONE && id[u as usize] == NONE {
                        id[u as usize] = count;
                        stack.push(u);
                    }
                }
            }
            count += 1;
        }
        (id, count as usize)
    }

    /// [`SurfaceTopo::regions`] by a parallel union-find.
    fn regions_parallel(&self) -> (Vec<u32>, usize) {
        let n = self.len();
        let parent: Vec<AtomicU32> = (0..n as u32).map(AtomicU32::new).collect();
        let find = |mut x: u32| loop {
            let p = parent[x as usize].load(Relaxed);
            if p == x {
                return x;
            }
            // path halving: any ancestor is as good a parent
            let g = parent[p as usize].load(Relaxed);
            let _ = parent[x as usize].compare_exchange(p, g, Relaxed, Relaxed);
            x = g;
        };
        (0..n).into_par_iter().with_min_len(4096).for_each(|t| {
            for k in 0..3 {
                let u = self.nbr[3 * t + k];
                if u == NONE || u < t as u32 {
                    continue;
                }
                let (mut a, mut b) = (t as u32, u);
                loop {
                    a = find(a);
                    b = find(b);
                    if a == b {
                        break;
                    }
                    // link the larger root under the smaller (only if still a root)
                    let (lo, hi) = if a < b { (a, b) } else { (b, a) };
                    if parent[hi as usize]
                        .compare_exchange(hi, lo, Relaxed, Relaxed)
                        .is_ok()
                    {
                        break;
                    }
                }
            }
        });
        let root: Vec<u32> = (0..n as u32)
            .into_par_iter()
            .with_min_len(4096)
            .map(find)
            .collect();
        let mut id = vec![NONE; n];
        let mut count = 0u32;
        for t in 0..n {
            let r = root[t] as usize;
            id[t] = if r == t {
                count += 1;
                count - 1
            } else {
                id[r]
            };
        }
        (id, count as usize)
    }
}

/// Surfaces with at least this many triangles find their regions in parallel.
const PARALLEL_REGIONS: usize = 1 << 15;

#[cfg(test)]
mod tests {
    use super::*;

    impl SortedHalves {
        fn runs_vec(&self) -> Vec<Vec<u32>> {
            let mut out = Vec::new();
            self.runs(|r| out.push(r.to_vec()));
            out
        }
    }

    #[test]
    fn parallel_regions_match_the_search() {
        // a strip of 60 000 triangles cut into components by removing graph edges
        let n = 60_000usize;
        let tris: Vec<[u32; 3]> = (0..n as u32).map(|t| [t, t + 1, t + 2]).collect();
        let mut nbr = vec![NONE; 3 * n];
        let mut x: u64 = 0x9E37;
        for t in 0..n - 1 {
            x ^= x << 13;
            x ^= x >> 7;
            x ^= x << 17;
            if !x.is_multiple_of(50) {
                nbr[3 * t + 1] = t as u32 + 1;
                nbr[3 * (t + 1) + 2] = t as u32;
            }
        }
        // plus a few long-range links, so trees merge out of order
        for t in (0..n / 2).step_by(977) {
            nbr[3 * t] = (n - 1 - t) as u32;
            nbr[3 * (n - 1 - t)] = t as u32;
        }
        let topo = SurfaceTopo { tris, nbr };
        let (par, count) = topo.regions_parallel();
        let (id, c) = topo.regions_serial();
        assert!(count > 100, "{count}");
        assert_eq!(count, c);
        assert_eq!(par, id);
        assert_eq!(topo.regions(), (id, count));
    }

    /// `n` random triangles on nodes `lo..lo + span` (xorshift from `seed`).
    fn random_tris(n: usize, lo: u32, span: u32, seed: u64) -> Vec<[u32; 3]> {
        let mut x = seed;
        let mut next = || {
            x ^= x << 13;
            x ^= x >> 7;
            x ^= x << 17;
            lo + (x % span as u64) as u32
        };
        (0..n).map(|_| [next(), next(), next()]).collect()
    }

    /// The half-edges of `tris` sorted by (edge key, half-edge) by a plain comparison sort.
    fn plain_sort(tris: &[[u32; 3]]) -> Vec<(u64, u32)> {
        let mut v: Vec<(u64, u32)> = Vec::new();
        for (t, tri) in tris.iter().enumerate() {
            for k in 0..3 {
                v.push((edge_key(tri[k], tri[(k + 1) % 3]), (3 * t + k) as u32));
            }
        }
        v.sort_unstable();
        v
    }

    #[test]
    fn the_bucketed_sort_is_a_plain_sort() {
        // sizes around the piece size (SORT_PIECE triangles), dense and sparse node ids, ids
        // far from zero, a single node id span (every edge degenerate)
        let p = SORT_PIECE;
        for (n, lo, span, seed) in [
            (p - 1, 0, 40_000, 1),
            (p, 0, 40_000, 2),
            (p + 1, 0, 40_000, 3),
            (2 * p + 7, 0, 30_000, 4),
            (3 * p - 1, 1_000_000, 50_000, 5),
            (p + 3, 0, 1 << 22, 6),
            (p / 2, 7, 1, 7),
            (p / 2, 0, 3, 8),
        ] {
            let tris = random_tris(n, lo, span, seed);
            let max_id = tris.iter().flatten().copied().max().unwrap_or(0);
            let min_id = tris.iter().flatten().copied().min().unwrap_or(0);
            let b = keysort::bits(max_id as u64);
            let q = keysort::bits(3 * n as u64 - 1);
            assert!(2 * b + q <= 64);
            let sorted = sort_packed(&tris, b, q, min_id..=max_id);
            let low = (1u64 << q) - 1;
            let got: Vec<(u64, u32)> = sorted
                .iter()
                .map(|&v| {
                    let key = ((v >> (b + q)) << 32) | ((v >> q) & ((1 << b) - 1));
                    (key, (v & low) as u32)
                })
                .collect();
            assert_eq!(got, plain_sort(&tris), "n {n}, lo {lo}, span {span}");
        }
    }

    #[test]
    fn runs_by_pieces_are_the_runs() {
        // lists from one piece to several, cut between runs, packed and pairs
        for (n, span) in [
            (100, 50),
            (RUN_PIECE / 3 + 1, 9_000),
            (3 * RUN_PIECE, 60_000),
        ] {
            let tris = random_tris(n, 0, span, n as u64);
            let runs = |k: &SortedHalves| -> Vec<Vec<u32>> {
                let pieces = k.par_runs(Vec::new, |s: &mut Vec<Vec<u32>>, r| s.push(r.to_vec()));
                if n >= RUN_PIECE {
                    assert!(pieces.len() > 1, "n {n}: {} pieces", pieces.len());
                }
                pieces.into_iter().flatten().collect()
            };
            let keys = sorted_half_edges(&tris);
            let plain = SortedHalves::Pairs(plain_sort(&tris));
            assert_eq!(runs(&keys), keys.runs_vec(), "n {n}");
            assert_eq!(runs(&plain), plain.runs_vec(), "n {n}");
            assert_eq!(keys.runs_vec(), plain.runs_vec(), "n {n}");
        }
        // cuts never split a run, even when one run is longer than a piece
        let same = |i: usize| i / (RUN_PIECE + 5) == (i - 1) / (RUN_PIECE + 5);
        let len = 4 * RUN_PIECE + 3;
        let cuts = run_cuts(len, same);
        assert_eq!((cuts[0], cuts[cuts.len() - 1]), (0, len));
        assert!(cuts.windows(2).all(|w| w[0] < w[1]));
        assert!(cuts[1..cuts.len() - 1].iter().all(|&c| !same(c)));
        assert!(cuts.len() > 2);
        assert_eq!(run_cuts(0, same), vec![0]);
    }

    #[test]
    fn radix_and_comparison_sorts_agree() {
        // 30 000 random triangles on 5 000 nodes: the radix path; compare with a plain sort
        let mut x: u64 = 0x1234_5678;
        let mut next = || {
            x ^= x << 13;
            x ^= x >> 7;
            x ^= x << 17;
            (x % 5000) as u32
        };
        let tris: Vec<[u32; 3]> = (0..30_000).map(|_| [next(), next(), next()]).collect();
        let SortedHalves::Packed { .. } = sorted_half_edges(&tris) else {
            panic!("expected the radix path");
        };
        let mut fast: Vec<Vec<u32>> = Vec::new();
        sorted_half_edges(&tris).runs(|r| fast.push(r.to_vec()));
        let mut slow: Vec<(u64, u32)> = Vec::new();
        for (t, tri) in tris.iter().enumerate() {
            for k in 0..3 {
                slow.push((edge_key(tri[k], tri[(k + 1) % 3]), (3 * t + k) as u32));
            }
        }
        slow.sort_unstable();
        let slow: Vec<Vec<u32>> = SortedHalves::Pairs(slow).runs_vec();
        assert_eq!(fast, slow);
    }
}
