//! Exact minimum-cost perfect matching on general sparse graphs (Edmonds' primal-dual blossom
//! algorithm), with an optimality certificate and a Tutte witness when no perfect matching
//! exists.
//!
//! **Invariant:** this module knows nothing about meshes: an index graph goes in, a matching
//! and a dual solution come out. It uses nothing else from the crate.
//!
//! # Problem
//! Given `n` vertices and edges `(u, v, cost)`, find a perfect matching `M` minimising
//! `Σ_{e∈M} cost(e)`, or prove that none exists. Costs may be negative. Self-loops are ignored
//! (they can never be in a matching); parallel edges are allowed (the solver treats every edge
//! on its own, so the cheapest copy wins).
//!
//! # Algorithm (see `src/matching/blossom/`)
//! Edmonds' primal-dual algorithm with odd-set (blossom) duals (Edmonds 1965), with ideas from
//! Kolmogorov's Blossom V (Math. Prog. Comp. 2009) and Galil-Micali-Gabow (1986): a greedy
//! and then fractional-matching jump start (single-tree local searches with a small and then
//! a larger grow budget, then a forest), then
//! single-tree searches from the remaining exposed vertices (each tree with its own dual
//! change, abandoned past a budget) and finally one alternating tree per still-exposed
//! vertex, all grown together with lazy O(1) dual changes, each tree with its own dual change
//! (Blossom V's variable δ: per-tree radix heaps of events — `+`→free edges, `+`↔`+` edges
//! inside the tree, `−` blossoms with zero dual — and per-pair-of-trees heaps of the edges
//! between trees, instead of rescans); persistent
//! blossoms expanded only when their dual drops to zero; blossom membership through
//! path-compressed shortcuts (no relabelling). No per-phase `O(n)` reset, no hash maps, `u32`
//! indices, `O(n + m)` memory, vertices renumbered for cache locality.
//!
//! # Certificate
//! [`verify`] checks, with exact integer arithmetic, the LP optimality conditions of the
//! returned [`Duals`] (documented there); a matching that passes is optimal whatever solver
//! produced it. [`verify_witness`] checks a Tutte witness.

// the solver's phases, statistics and invariant check, the brute-force oracle, the radix
// heap: public only with the `testing` feature
internal! {
    mod blossom;
    #[cfg(any(test, feature = "testing"))]
    mod oracle;
    mod radix;
}
mod tuned;
mod verify;

#[cfg(feature = "testing")]
pub use tuned::{solve_owned, solve_with_progress, VertexOrder};
#[cfg(not(feature = "testing"))]
pub(crate) use tuned::{solve_owned, VertexOrder};
pub use verify::{verify, verify_witness, CertificateError};

/// Sentinel for "no vertex / no blossom" in the `u32` arrays of this module: the same value
/// as `mesh::NONE`, defined again so that this module uses nothing else from the
/// crate.
pub const NONE: u32 = u32::MAX;

/// Largest absolute edge cost accepted by [`solve`]. Larger costs are saturated to this value
/// (the solver works with doubled costs and sums of duals in `i64`, and this bound keeps every
/// intermediate value far from overflow for graphs of up to 2^20 vertices per unit of
/// headroom).
pub const MAX_ABS_COST: i64 = 1 << 40;

/// A minimum-cost perfect matching with the dual solution that proves its optimality.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Matching {
    /// `mate[v]` is the vertex matched to `v` (every vertex is matched).
    pub mate: Vec<u32>,
    /// Total cost of the matching: for every matched pair the cost of the cheapest input edge
    /// joining it, summed over the pairs.
    pub cost: i64,
    /// Optimal dual solution (the certificate checked by [`verify`]).
    pub duals: Duals,
}

/// Dual solution of Edmonds' perfect-matching LP, in the "crossing" form.
///
/// All values are integers in units of `1/scale` of the input cost unit (the solver doubles
/// costs, and doubles again whenever a half-integral dual change is needed, so `scale` is a
/// power of two, at least 2). With
/// `y_v = vertex[v]`, `y_B = blossoms[b].dual` and `c'_e = scale · cost(e)`, the reduced cost of
/// an edge `e = (u, v)` is
///
/// `slack(e) = c'_e − y_u − y_v − Σ_{B : exactly one of u, v in B} y_B`.
///
/// The blossoms form a laminar family of odd vertex sets, stored as a forest: each blossom
/// has a `parent` (the smallest blossom strictly containing it, or [`NONE`]), and
/// `vertex_blossom[v]` is the smallest blossom containing `v` (or [`NONE`]). The crossing sum
/// of `(u, v)` is `Y(u) + Y(v) − 2·Y(lca(u, v))` where `Y(x)` sums `y_B` over the blossoms
/// containing `x`.
///
/// Optimality conditions (checked by [`verify`]): every `slack(e) ≥ 0`, `y_B ≥ 0`, matched
/// edges have zero slack, a blossom with `y_B > 0` contains `(|B| − 1) / 2` matched edges, and
/// `scale · cost(M) = Σ y_v + Σ y_B`.
#[derive(Debug, Clone, PartialEq, Eq, Default)]
pub struct Duals {
    /// Duals are in units of `1 / scale` of the input cost unit.
    pub scale: i64,
    /// Vertex duals `y_v` (unrestricted in sign).
    pub vertex: Vec<i64>,
    /// The blossoms (odd sets) with their duals.
    pub blossoms: Vec<BlossomDual>,
    /// Smallest blossom containing each vertex, or [`NONE`].
    pub vertex_blossom: Vec<u32>,
}

/// One odd set of the laminar family in [`Duals`].
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct BlossomDual {
    /// Smallest blossom strictly containing this one, or [`NONE`].
    pub parent: u32,
    /// Its dual `y_B ≥ 0`.
    pub dual: i64,
}

/// Proof that the graph has no perfect matching (Tutte's theorem, paper Section 5): removing
/// the vertex set `witness` (U) leaves more than `|U|` connected components of odd size.
#[derive(Debug, Clone, PartialEq, Eq)]
#[non_exhaustive]
pub struct NoPerfectMatching {
    /// The Tutte set U (may be empty, e.g. when a connected component has an odd number of
    /// vertices).
    pub witness: Vec<u32>,
    /// At least `|U| + 1` odd connected components of `G − U`, each a list of vertices.
    pub odd_components: Vec<Vec<u32>>,
}

impl std::fmt::Display for NoPerfectMatching {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "no perfect matching: removing {} vertices leaves {} odd components",
            self.witness.len(),
            self.odd_components.len()
        )
    }
}

impl std::error::Error for NoPerfectMatching {}

/// Minimum-cost perfect matching of the graph with vertices `0..n` and the given edges.
///
/// Edges with an endpoint `>= n` are ignored, as are self-loops. Costs are saturated to
/// `±`[`MAX_ABS_COST`]. Each connected component is solved on its own; a component with an
/// odd number of vertices fails at once with `U = ∅` as witness.
///
/// Complexity: `O(n + m)` memory. Time: at most `n/2` augmentations with `O(n)` grow /
/// shrink / expand events between two of them, each touching `O(deg)` edges, so
/// `O(n · m · (d + log C))` in the worst case (`d` blossom nesting depth, `C` cost range, for
/// the radix heap); on mesh graphs it grows slightly faster than linearly (cache effects).
pub fn solve(n: usize, edges: &[(u32, u32, i64)]) -> Result<Matching, NoPerfectMatching> {
    prepare(n, edges, None, VertexOrder::BreadthFirst)?.run()
}

/// The solver state for `edges`, or the witness of an odd component.
fn prepare(
    n: usize,
    edges: &[(u32, u32, i64)],
    progress: Option<blossom::ProgressCallback>,
    order: VertexOrder,
) -> Result<blossom::Solver, NoPerfectMatching> {
    if let Some(err) = odd_component_witness(n, edges) {
        return Err(err);
    }
    let mut solver = blossom::Solver::new_in_order(n, edges, order);
    if let Some(p) = progress {
        solver.set_progress(p);
    }
    Ok(solver)
}

/// Scale factor applied by [`solve_f64`]: the power of two `S` such that the largest finite
/// `|cost| · S` is at most 2^31 (or 1 when all costs are 0). Costs are then rounded to the
/// nearest integer, so the optimum is exact for the rounded costs, and within `n/2 · 0.5 / S`
/// of the real optimum for the real costs.
pub fn f64_scale(edges: &[(u32, u32, f64)]) -> f64 {
    let max = edges
        .iter()
        .map(|e| e.2.abs())
        .filter(|c| c.is_finite())
        .fold(0.0f64, f64::max);
    if max == 0.0 {
        return 1.0;
    }
    let exp = (2f64.powi(31) / max).log2().floor() as i32;
    2f64.powi(exp.clamp(-1000, 1000))
}

/// The integer edges [`solve_f64`] solves: each finite cost times [`f64_scale`], rounded;
/// edges with a non-finite cost (NaN, ±∞) are dropped. Returns the edges and the scale.
pub fn scale_costs_f64(edges: &[(u32, u32, f64)]) -> (Vec<(u32, u32, i64)>, f64) {
    let s = f64_scale(edges);
    let scaled = edges
        .iter()
        .filter(|e| e.2.is_finite())
        .map(|&(u, v, c)| (u, v, (c * s).round() as i64))
        .collect();
    (scaled, s)
}

/// [`solve`] for real costs: the costs are scaled by [`f64_scale`] and rounded (see
/// [`scale_costs_f64`]); `Matching::cost` and the duals are in the scaled integer units, so
/// divide `cost` by [`f64_scale`] to get the real cost. Edges with non-finite cost are treated
/// as absent.
pub fn solve_f64(n: usize, edges: &[(u32, u32, f64)]) -> Result<Matching, NoPerfectMatching> {
    let (scaled, _) = scale_costs_f64(edges);
    solve(n, &scaled)
}

/// Connected components of the graph (loops and out-of-range edges ignored): returns the
/// component id of each vertex and the number of components.
pub(crate) fn components(
    n: usize,
    edges: &[(u32, u32, i64)],
    removed: &[bool],
) -> (Vec<u32>, usize) {
    // Union-find with path halving.
    let mut parent: Vec<u32> = (0..n as u32).collect();
    fn find(p: &mut [u32], mut x: u32) -> u32 {
        while p[x as usize] != x {
            let g = p[p[x as usize] as usize];
            p[x as usize] = g;
            x = g;
        }
        x
    }
    for &(u, v, _) in edges {
        if u as usize >= n || v as usize >= n || u == v {
            continue;
        }
        if !removed.is_empty() && (removed[u as usize] || removed[v as usize]) {
            continue;
        }
        let (a, b) = (find(&mut parent, u), find(&mut parent, v));
        if a != b {
            parent[a.max(b) as usize] = a.min(b);
        }
    }
    let mut id = vec![NONE; n];
    let mut count = 0usize;
    for v in 0..n as u32 {
        let r = find(&mut parent, v);
        if id[r as usize] == NONE {
            id[r as usize] = count as u32;
            count += 1;
        }
        id[v as usize] = id[r as usize];
    }
    (id, count)
}

/// If some connected component has an odd number of vertices, the witness `U = ∅` with all
/// odd components.
fn odd_component_witness(n: usize, edges: &[(u32, u32, i64)]) -> Option<NoPerfectMatching> {
    let (id, count) = components(n, edges, &[]);
    let mut size = vec![0u32; count];
    for &c in &id {
        size[c as usize] += 1;
    }
    if size.iter().all(|s| s % 2 == 0) {
        return None;
    }
    let mut slot = vec![NONE; count];
    let mut odd: Vec<Vec<u32>> = Vec::new();
    for (v, &c) in id.iter().enumerate() {
        if size[c as usize] % 2 == 1 {
            if slot[c as usize] == NONE {
                slot[c as usize] = odd.len() as u32;
                odd.push(Vec::new());
            }
            odd[slot[c as usize] as usize].push(v as u32);
        }
    }
    Some(NoPerfectMatching {
        witness: Vec::new(),
        odd_components: odd,
    })
}
