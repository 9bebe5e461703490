//! Surface extraction and triangle adjacency: which mesh edges lie on
//! model curves (walls), and each surface's triangle-adjacency graph.
//!
//! Hot path: edges are found by sorting `u64` keys `(min << 32) | max` of global `u32` node
//! ids (the ids of [`NodeTable`]), never with hash maps.

use crate::mesh::{etype, Mesh, NodeTable};
use rayon::prelude::*;

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

/// Whether an edge shared by two triangles of a surface is a graph edge, and if not why.
/// (An edge with one triangle of the surface is always a wall: the surface boundary.)
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Wall {
    /// Graph edge (not a wall).
    Open,
    /// Two triangles of the surface share it but it lies on a model curve (embedded curve,
    /// seam).
    Curve,
    /// Two triangles share it with opposite orientations (their merge could not keep both
    /// orientations), or three or more triangles share it.
    Inconsistent,
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
    pub fn runs(&self, mut f: impl FnMut(&[u32])) {
        let mut buf: Vec<u32> = Vec::with_capacity(4);
        match self {
            SortedHalves::Packed { v, p } => {
                let low = (1u64 << p) - 1;
                for run in v.chunk_by(|x, y| x >> p == y >> p) {
                    buf.clear();
                    buf.extend(run.iter().map(|x| (x & low) as u32));
                    f(&buf);
                }
            }
            SortedHalves::Pairs(v) => {
                for run in v.chunk_by(|x, y| x.0 == y.0) {
                    buf.clear();
                    buf.extend(run.iter().map(|x| x.1));
                    f(&buf);
                }
            }
        }
    }
}

/// Sorts the half-edges of `tris` by [`edge_key`].
///
/// When a key and a half-edge index fit in 64 bits together (node ids below 2^b and
/// half-edges below 2^p with 2b + p ≤ 64: up to about 2^20 nodes and 2^22 half-edges, more
/// when the other is smaller), they are packed in one `u64` and sorted by an LSD radix sort
/// on the key bits (stable, so equal keys keep half-edge order); otherwise by a parallel
/// comparison sort. Both give the same order.
pub(crate) fn sorted_half_edges(tris: &[[u32; 3]]) -> SortedHalves {
    let halves = 3 * tris.len();
    let max_id = tris
        .iter()
        .map(|t| t[0].max(t[1]).max(t[2]))
        .max()
        .unwrap_or(0);
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
    let mut a: Vec<u64> = Vec::with_capacity(halves);
    for (t, tri) in tris.iter().enumerate() {
        for k in 0..3 {
            let (x, y) = (tri[k], tri[(k + 1) % 3]);
            let (lo, hi) = if x < y { (x, y) } else { (y, x) };
            a.push(((lo as u64) << (b + p)) | ((hi as u64) << p) | (3 * t + k) as u64);
        }
    }
    // LSD radix sort over the 2b key bits, 11 bits per pass
    const DIGIT: u32 = 11;
    let mut buf = vec![0u64; halves];
    let mut shift = p;
    while shift < p + 2 * b {
        let mask = (1u64 << DIGIT) - 1;
        let mut count = vec![0usize; 1 << DIGIT];
        for &v in &a {
            count[((v >> shift) & mask) as usize] += 1;
        }
        let mut sum = 0;
        for c in count.iter_mut() {
            let x = *c;
            *c = sum;
            sum += x;
        }
        for &v in &a {
            let d = ((v >> shift) & mask) as usize;
            buf[count[d]] = v;
            count[d] += 1;
        }
        std::mem::swap(&mut a, &mut buf);
        shift += DIGIT;
    }
    SortedHalves::Packed { v: a, p }
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

/// One surface's triangles and their adjacency.
pub(crate) struct SurfaceTopo {
    /// Triangles as global node ids, in input order.
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
    pub fn new(
        tris: Vec<[u32; 3]>,
        normals: &[glam::DVec3],
        nodes: &NodeTable,
        curves: &CurveInfo,
        surface: i32,
        elem_tags: &[u64],
    ) -> Result<Self, RecombineError> {
        let n = tris.len();
        let keys = sorted_half_edges(&tris);
        // bare curves that carry a boundary edge of this surface bound it: their segments
        // are boundary edges, so an interior edge between two of their nodes is a chord, not
        // a segment (e.g. a triangle with three nodes on a circle)
        let mut boundary_curves: Vec<i32> = Vec::new();
        keys.runs(|run| {
            if let [h] = run {
                let (t, k) = (*h as usize / 3, *h as usize % 3);
                let (a, b) = (tris[t][k], tris[t][(k + 1) % 3]);
                if let OnCurve::Bare(c) = curves.on_curve(nodes, a, b) {
                    if !boundary_curves.contains(&c) {
                        boundary_curves.push(c);
                    }
                }
            }
        });
        let mut nbr = vec![NONE; 3 * n];
        // the refused edge with the smallest (lower, higher) node tags, with its problem
        let mut refused: Option<((u64, u64), EdgeProblem)> = None;
        let mut keep_first = |p: ((u64, u64), EdgeProblem)| {
            if refused.as_ref().is_none_or(|r| p.0 < r.0) {
                refused = Some(p);
            }
        };
        // consistently oriented neighbours across a curve (not graph edges), for the folds
        let mut walled: Vec<(u32, u32)> = Vec::new();
        keys.runs(|run| {
            if run.len() > 2 {
                // non-manifold: a wall (nbr stays NONE)
                keep_first(structural_problem(run, &tris, nodes));
            }
            if let [h0, h1] = run {
                let (h0, h1) = (*h0 as usize, *h1 as usize);
                let (t0, k0) = (h0 / 3, h0 % 3);
                let (t1, k1) = (h1 / 3, h1 % 3);
                let a = tris[t0][k0];
                let b = tris[t0][(k0 + 1) % 3];
                // consistent orientation: t1 runs the edge b -> a
                let consistent = tris[t1][k1] == b && tris[t1][(k1 + 1) % 3] == a;
                let w = if !consistent {
                    keep_first(structural_problem(run, &tris, nodes));
                    Wall::Inconsistent
                } else {
                    match curves.on_curve(nodes, a, b) {
                        OnCurve::Line => Wall::Curve,
                        OnCurve::Bare(c) if !boundary_curves.contains(&c) => Wall::Curve,
                        _ => Wall::Open,
                    }
                };
                match w {
                    Wall::Open => {
                        nbr[h0] = t1 as u32;
                        nbr[h1] = t0 as u32;
                    }
                    Wall::Curve => walled.push((h0 as u32, h1 as u32)),
                    Wall::Inconsistent => {}
                }
            }
        });
        let refused = refused
            .into_iter()
            .chain(first_fold(&tris, normals, &nbr, &walled, nodes))
            .min_by_key(|p| p.0);
        if let Some((key, problem)) = refused {
            return Err(edge_refusal(surface, key, problem, |t| {
                elem_tags.get(t).copied().unwrap_or(0)
            }));
        }
        Ok(SurfaceTopo { tris, nbr })
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
        use std::sync::atomic::{AtomicU32, Ordering::Relaxed};
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
