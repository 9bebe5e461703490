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

/// True when the triangles `tris` (unit normals `normals`) lie in one plane: every normal
/// parallel to the first non-zero one, either way, and every node within 1e-9 of the
/// triangles' extent of the plane through that triangle.
fn flat(tris: &[[u32; 3]], normals: &[glam::DVec3], nodes: &NodeTable) -> bool {
    let Some(i) = normals.iter().position(|n| *n != glam::DVec3::ZERO) else {
        return true;
    };
    let (n0, p0) = (normals[i], nodes.coords[tris[i][0] as usize]);
    let (mut lo, mut hi) = (p0, p0);
    for t in tris {
        for &v in t {
            let p = nodes.coords[v as usize];
            lo = lo.min(p);
            hi = hi.max(p);
        }
    }
    let tol = 1e-9 * (hi - lo).length();
    normals
        .iter()
        .all(|n| *n == glam::DVec3::ZERO || n.dot(n0).abs() >= 1.0 - 1e-9)
        && tris
            .iter()
            .flatten()
            .all(|&v| (nodes.coords[v as usize] - p0).dot(n0).abs() <= tol)
}

/// The first triangle of a flat surface (see [`flat`]) whose normal points opposite to the
/// area-weighted sum of all the triangles' normals, if any.
fn turned_over(tris: &[[u32; 3]], normals: &[glam::DVec3], nodes: &NodeTable) -> Option<usize> {
    let area = |t: &[u32; 3]| {
        let p = t.map(|v| nodes.coords[v as usize]);
        (p[1] - p[0]).cross(p[2] - p[0]).length()
    };
    let sum: glam::DVec3 = tris.iter().zip(normals).map(|(t, n)| area(t) * *n).sum();
    normals.iter().position(|n| n.dot(sum) < 0.0)
}

mod checks;
mod halves;

pub(crate) use checks::*;
pub(crate) use halves::*;

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
    ///   orientation: a flipped or overlapping triangle).
    ///
    /// When a surface has several, the one on the edge with the smallest node tags is
    /// reported, naming its triangles as if the half-edges were sorted by (edge tags, first
    /// node tag, file order); a fold is not among them, even on a smaller edge (it is not
    /// the reason of the refusal).
    ///
    /// A fold (two consistently oriented triangles sharing an edge whose unit normals have
    /// a dot product below [`FOLDED`]: Gmsh's mesh of a thin cylinder meshed coarser than
    /// its radius) is not refused here: every folded edge becomes a wall (no graph edge
    /// across it; parity repair sees it as a wall segment like any other), and the refusal
    /// it would have given (the fold with the smallest edge) comes back beside the
    /// topology with the node tags of the folded edges, for the caller to report if the
    /// quads are not valid. On a flat surface (every triangle in one plane) a fold is
    /// triangles lying over each other, with no side of the surface for a quad to stand
    /// on: that surface is refused, naming the fold.
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
                    keep_first(refused, structural_problem(run, &tris, normals, nodes));
                }
                if let [h0, h1] = run {
                    let (h0, h1) = (*h0 as usize, *h1 as usize);
                    let (t0, k0) = (h0 / 3, h0 % 3);
                    let (t1, k1) = (h1 / 3, h1 % 3);
                    let a = tris[t0][k0];
                    let b = tris[t0][(k0 + 1) % 3];
                    // consistent orientation: t1 runs the edge b -> a (else refused)
                    if tris[t1][k1] != b || tris[t1][(k1 + 1) % 3] != a {
                        keep_first(refused, structural_problem(run, &tris, normals, nodes));
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
        if let Some((key, problem)) = refused {
            // refused whole, naming the problem on the smallest such edge: a fold alone is
            // walled off, not refused, so a fold elsewhere is not the reason
            return Err(edge_refusal(surface, key, problem, tag));
        }
        let fold = first_fold(&tris, normals, &nbr, &walled, nodes);
        // on a flat surface a fold is triangles lying over each other (overlapping or
        // inverted), with no side of the surface for a quad there: refused whole; so is a
        // triangle turned the other way from the rest that shares no edge with them (a flap
        // joined to them at its nodes only, which no edge check sees)
        // (speed: the plane is only looked for where a fold or a normal turned more than
        // 90 degrees from the first says it may matter)
        let n0 = normals.iter().find(|n| **n != glam::DVec3::ZERO).copied();
        let mixed = n0.is_some_and(|n0| {
            normals
                .par_iter()
                .with_min_len(4096)
                .any(|n| n.dot(n0) < 0.0)
        });
        let planar = (fold.is_some() || mixed) && flat(&tris, normals, nodes);
        let fold = match fold {
            Some((key, problem)) if planar => {
                return Err(edge_refusal(surface, key, problem, tag));
            }
            fold => fold,
        };
        if planar && mixed {
            if let Some(t) = turned_over(&tris, normals, nodes) {
                return Err(RecombineError::InvalidElement {
                    surface,
                    element: tag(t),
                    problem: "the triangle is turned over: the surface is flat and its normal points opposite to the rest of the surface's (it lies over other triangles, or its nodes run the wrong way round)".into(),
                });
            }
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
