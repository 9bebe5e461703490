//! Optimality certificate and Tutte-witness check.

use super::{components, Matching, NoPerfectMatching, NONE};

/// Why a matching failed its optimality certificate.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[non_exhaustive]
pub enum CertificateError {
    /// Array lengths or indices in the matching or duals are inconsistent.
    #[error("malformed certificate: {0}")]
    Malformed(String),
    /// `mate` is not a perfect matching (vertex unmatched or `mate[mate[v]] != v`).
    #[error("vertex {0} is not perfectly matched")]
    NotPerfect(u32),
    /// A matched pair is not joined by any input edge.
    #[error("matched pair ({0}, {1}) is not an edge of the graph")]
    NotAnEdge(u32, u32),
    /// An edge has negative reduced cost (dual infeasible).
    #[error("edge ({u}, {v}) has negative slack {slack}")]
    NegativeSlack {
        /// First endpoint.
        u: u32,
        /// Second endpoint.
        v: u32,
        /// Reduced cost in dual units.
        slack: i128,
    },
    /// A matched edge is not tight (complementary slackness violated).
    #[error("matched edge ({u}, {v}) has positive slack {slack}")]
    MatchedNotTight {
        /// First endpoint.
        u: u32,
        /// Second endpoint.
        v: u32,
        /// Reduced cost in dual units.
        slack: i128,
    },
    /// A blossom has a negative dual.
    #[error("blossom {0} has negative dual")]
    NegativeBlossomDual(u32),
    /// A blossom with positive dual is not full (or not odd).
    #[error("blossom {0} has positive dual but is not full")]
    BlossomNotFull(u32),
    /// The reported cost is not the cost of the matching.
    #[error("reported cost {reported} but the matching costs {actual}")]
    WrongCost {
        /// `Matching::cost`.
        reported: i64,
        /// Recomputed cost.
        actual: i128,
    },
    /// Primal and dual objectives differ.
    #[error("primal {primal} != dual {dual} (in dual units)")]
    Gap {
        /// `scale · cost(M)`.
        primal: i128,
        /// `Σ y_v + Σ y_B`.
        dual: i128,
    },
}

/// Checks that `m` is an optimal perfect matching of the graph, using only `m` and its duals
/// (definitions in [`super::Duals`]): (a) `mate` is perfect and every pair is an input edge;
/// (b) every edge has `slack ≥ 0` and every blossom `y_B ≥ 0`; (c) the cheapest edge of each
/// matched pair has `slack = 0`; (d) a blossom with `y_B > 0` is odd and holds
/// `(|B| − 1) / 2` matched pairs; (e) `scale · cost(M) = Σ y_v + Σ y_B`, and `m.cost` is the
/// cost of `mate`. Loops and edges with an endpoint `>= n` are ignored, as in
/// [`super::solve`]. Exact (`i128`) arithmetic; `O(m · log depth)` time, `depth` the
/// nesting depth of the blossoms.
#[allow(clippy::needless_range_loop)]
pub fn verify(n: usize, edges: &[(u32, u32, i64)], m: &Matching) -> Result<(), CertificateError> {
    let d = &m.duals;
    let malformed = |s: &str| Err(CertificateError::Malformed(s.to_string()));
    if m.mate.len() != n || d.vertex.len() != n || d.vertex_blossom.len() != n {
        return malformed("array lengths differ from n");
    }
    if d.scale < 1 {
        return malformed("scale < 1");
    }
    let nb = d.blossoms.len();
    if nb >= NONE as usize {
        return malformed("too many blossoms");
    }
    for (v, &b) in d.vertex_blossom.iter().enumerate() {
        if b != NONE && b as usize >= nb {
            return malformed(&format!("vertex {v} in unknown blossom {b}"));
        }
    }
    // Depth of each blossom (roots have depth 1), with cycle detection.
    let mut depth = vec![0u32; nb];
    let mut chain = Vec::new();
    for b0 in 0..nb {
        let mut b = b0;
        chain.clear();
        while depth[b] == 0 {
            if chain.len() > nb {
                return malformed("blossom parents form a cycle");
            }
            chain.push(b);
            let p = d.blossoms[b].parent;
            if p == NONE {
                break;
            }
            if p as usize >= nb {
                return malformed(&format!("blossom {b} has unknown parent {p}"));
            }
            b = p as usize;
        }
        let mut base = if depth[b] == 0 { 0 } else { depth[b] };
        while let Some(x) = chain.pop() {
            base += 1;
            depth[x] = base;
        }
    }
    // Y(b): sum of duals of b and its ancestors.
    let mut order: Vec<usize> = (0..nb).collect();
    order.sort_unstable_by_key(|&b| depth[b]);
    let mut ysum = vec![0i128; nb];
    for &b in &order {
        let bd = &d.blossoms[b];
        if bd.dual < 0 {
            return Err(CertificateError::NegativeBlossomDual(b as u32));
        }
        let up = if bd.parent == NONE {
            0
        } else {
            ysum[bd.parent as usize]
        };
        ysum[b] = up + bd.dual as i128;
    }
    let ybl = |b: u32| if b == NONE { 0 } else { ysum[b as usize] };
    let dep = |b: u32| if b == NONE { 0 } else { depth[b as usize] };
    // Binary lifting: `up[k][b]` is the ancestor 2^k levels above `b` (NONE above a root),
    // so a lowest common ancestor costs O(log depth) however deep the blossoms nest.
    let levels = (u32::BITS - depth.iter().copied().max().unwrap_or(0).leading_zeros()).max(1);
    let mut up: Vec<Vec<u32>> = vec![d.blossoms.iter().map(|b| b.parent).collect()];
    for k in 1..levels as usize {
        let prev = &up[k - 1];
        let next = prev
            .iter()
            .map(|&a| if a == NONE { NONE } else { prev[a as usize] })
            .collect();
        up.push(next);
    }
    let lift = |mut a: u32, mut by: u32| {
        let mut k = 0;
        while by > 0 && a != NONE {
            if by & 1 == 1 {
                a = up[k][a as usize];
            }
            by >>= 1;
            k += 1;
        }
        a
    };
    let lca = |a: u32, b: u32| {
        let (da, db) = (dep(a), dep(b));
        let (mut a, mut b) = if da > db {
            (lift(a, da - db), b)
        } else {
            (a, lift(b, db - da))
        };
        // at equal depths, NONE (depth 0) meets only NONE
        if a == b {
            return a;
        }
        for k in (0..up.len()).rev() {
            let (ua, ub) = (up[k][a as usize], up[k][b as usize]);
            if ua != ub {
                a = ua;
                b = ub;
            }
        }
        up[0][a as usize]
    };
    // (a) perfect.
    for v in 0..n {
        let w = m.mate[v];
        if w as usize >= n || w as usize == v || m.mate[w as usize] as usize != v {
            return Err(CertificateError::NotPerfect(v as u32));
        }
    }
    // (b), (c): slacks; cheapest edge per matched pair.
    let scale = d.scale as i128;
    let mut best = vec![(i64::MAX, 0i128); n];
    for &(u, v, c) in edges {
        let (ui, vi) = (u as usize, v as usize);
        if u == v || ui >= n || vi >= n {
            continue;
        }
        let (bu, bv) = (d.vertex_blossom[ui], d.vertex_blossom[vi]);
        let cross = ybl(bu) + ybl(bv) - 2 * ybl(lca(bu, bv));
        let slack = c as i128 * scale - d.vertex[ui] as i128 - d.vertex[vi] as i128 - cross;
        if slack < 0 {
            return Err(CertificateError::NegativeSlack { u, v, slack });
        }
        if m.mate[ui] == v && c < best[ui].0 {
            best[ui] = (c, slack);
            best[vi] = (c, slack);
        }
    }
    let mut actual: i128 = 0;
    for v in 0..n {
        let w = m.mate[v] as usize;
        if w < v {
            continue;
        }
        let (c, slack) = best[v];
        if c == i64::MAX {
            return Err(CertificateError::NotAnEdge(v as u32, w as u32));
        }
        if slack != 0 {
            return Err(CertificateError::MatchedNotTight {
                u: v as u32,
                v: w as u32,
                slack,
            });
        }
        actual += c as i128;
    }
    if actual != m.cost as i128 {
        return Err(CertificateError::WrongCost {
            reported: m.cost,
            actual,
        });
    }
    // (d) fullness: sizes and inside-pair counts, accumulated bottom-up.
    let mut size = vec![0u64; nb];
    let mut inside = vec![0u64; nb];
    for v in 0..n {
        let b = d.vertex_blossom[v];
        if b != NONE {
            size[b as usize] += 1;
        }
        let w = m.mate[v] as usize;
        if w > v {
            let l = lca(b, d.vertex_blossom[w]);
            if l != NONE {
                inside[l as usize] += 1;
            }
        }
    }
    for &b in order.iter().rev() {
        let p = d.blossoms[b].parent;
        if p != NONE {
            size[p as usize] += size[b];
            inside[p as usize] += inside[b];
        }
    }
    for b in 0..nb {
        if d.blossoms[b].dual > 0 && (size[b].is_multiple_of(2) || inside[b] * 2 + 1 != size[b]) {
            return Err(CertificateError::BlossomNotFull(b as u32));
        }
    }
    // (e) objectives.
    let dual: i128 = d.vertex.iter().map(|&y| y as i128).sum::<i128>()
        + d.blossoms.iter().map(|b| b.dual as i128).sum::<i128>();
    let primal = actual * scale;
    if primal != dual {
        return Err(CertificateError::Gap { primal, dual });
    }
    Ok(())
}

/// Checks a Tutte witness: the vertices of `w.witness` are distinct and in range, and the
/// graph minus them has more than `|U|` connected components of odd size. (The listed
/// `odd_components` are informative; the count is recomputed from the graph.)
pub fn verify_witness(
    n: usize,
    edges: &[(u32, u32, i64)],
    w: &NoPerfectMatching,
) -> Result<(), String> {
    let mut removed = vec![false; n];
    for &u in &w.witness {
        if u as usize >= n {
            return Err(format!("witness vertex {u} out of range (n = {n})"));
        }
        if removed[u as usize] {
            return Err(format!("witness vertex {u} listed twice"));
        }
        removed[u as usize] = true;
    }
    let (id, count) = components(n, edges, &removed);
    let mut size = vec![0u64; count];
    for v in 0..n {
        if !removed[v] {
            size[id[v] as usize] += 1;
        }
    }
    let odd = size.iter().filter(|&&s| s % 2 == 1).count();
    if odd > w.witness.len() {
        Ok(())
    } else {
        Err(format!(
            "G − U has {odd} odd components, not more than |U| = {}",
            w.witness.len()
        ))
    }
}
