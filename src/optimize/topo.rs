//! Topological operators of the paper's section 6, plus edge rotation.
//!
//! One [`pass`] applies, in this order and each only where its whole neighbourhood is still
//! untouched in the pass (so the node → quads adjacency it reads is current):
//!
//! 1. **Doublet collapse** (Figure 11): a free node with exactly two quads around it is
//!    removed and its two quads become one.
//! 2. **Quad-vertex merge** (Figure 10, Gmsh's "diamond"): a quad is removed by merging two
//!    opposite free corners into one node, when that lowers the valence defect (the paper's
//!    case: two corners with three quads each, becoming one node with four). Accepted when
//!    the merged star's worst signed η is not below the worst of the two old stars.
//! 3. **Edge rotation**: the edge shared by two quads is replaced by another diagonal of the
//!    hexagon they form, when that lowers the valence defect Σ (d − d*)² (d* = 4 inside; on
//!    the boundary the number of right angles in the boundary angle, at least 1) and the two
//!    new quads are valid (they need not be as good as the old pair: judged before
//!    smoothing, that would block most useful rotations); or, whatever the
//!    valences (defect up by 2 at most), when it lifts a bad pair (worst η < 0.2) by more
//!    than 0.2 (e.g. a quad with two boundary edges in line, a straight angle).
//! 4. **Valence cleanup** ([`cleanup`](super::cleanup)): sequences of up to
//!    [`CLEANUP_DEPTH`] edge rotations (three from a fixed node's too-wide corner) that
//!    together lower the valence defect (moving 3-5 pairs until they cancel) or open a fixed
//!    node's flat corner.
//!
//! Quad-vertex merge never leaves a fixed node with a corner wider than
//! [`MAX_FIXED_CORNER`] (a fixed node cannot move to open it).
//!
//! Every operator keeps the orientation (quads are rewritten from the oriented boundary of the
//! region they replace) and never moves or removes a fixed node.

use super::cleanup::{ideal_valence, MAX_FIXED_CORNER};
use super::local::{rotate_to, slot, Local};
use super::valid::{self, quad_valid};
use super::OperationCounts;
use glam::DVec3;

/// Longest rotation sequence [`cleanup`](super::cleanup) searches: deeper searches find
/// more regular nodes at a growing cost (figures in BENCHMARKS.md, "Measurements behind the
/// defaults").
const CLEANUP_DEPTH: usize = 2;

/// One pass of the operators; returns how many were applied. Leaves the adjacency stale:
/// the caller rebuilds it. With `focus`, every operator only looks at the nodes (doublets)
/// and quads (merges, rotations, cleanup) with a node in it: the region a previous pass
/// and its smoothing changed (elsewhere the same searches already failed).
pub(crate) fn pass(l: &mut Local, ops: &mut OperationCounts, focus: Option<&[bool]>) -> usize {
    l.sweep_ready = false;
    let trace = l.trace.clone();
    let mut tm = crate::profile::StageTimer::new(trace.as_ref(), "topo pass", l.surface);
    let mut dirty = vec![false; l.pos.len()];
    let (ideal, angle) = ideal_valence(l);
    let before = ops.doublet_collapses + ops.quad_vertex_merges + ops.edge_rotations;
    let in_focus = |v: u32| focus.is_none_or(|f| f.get(v as usize) == Some(&true));
    let quad_in_focus =
        |l: &Local, q: u32| focus.is_none() || l.quads[q as usize].iter().any(|&w| in_focus(w));
    for v in 0..l.pos.len() as u32 {
        if in_focus(v) && doublet_collapse(l, v, &mut dirty) {
            ops.doublet_collapses += 1;
        }
    }
    tm.lap("doublets");
    for q in 0..l.quads.len() as u32 {
        if quad_in_focus(l, q) && quad_vertex_merge(l, q, &ideal, &angle, &mut dirty) {
            ops.quad_vertex_merges += 1;
        }
    }
    tm.lap("merges");
    // quality of each quad when first needed (a quad is only read while none of its nodes is
    // dirty, i.e. as it was when the rotations started)
    let mut qual = vec![f64::NAN; l.quads.len()];
    let mut valence: Vec<i32> = (0..l.pos.len() as u32)
        .map(|v| l.star(v).len() as i32)
        .collect();
    for q in 0..l.quads.len() as u32 {
        if !quad_in_focus(l, q) {
            continue;
        }
        for k in 0..4 {
            if edge_rotation(l, q, k, &ideal, &mut valence, &mut qual, &mut dirty) {
                ops.edge_rotations += 1;
                break;
            }
        }
    }
    tm.lap("rotations");
    let (_, rot) = super::cleanup::cleanup(l, CLEANUP_DEPTH, 1, focus);
    ops.edge_rotations += rot;
    tm.lap("cleanup");
    tm.done();
    ops.doublet_collapses + ops.quad_vertex_merges + ops.edge_rotations - before
}

fn any_dirty(dirty: &[bool], nodes: &[u32]) -> bool {
    nodes.iter().any(|&v| dirty[v as usize])
}

fn mark(dirty: &mut [bool], nodes: &[u32]) {
    for &v in nodes {
        dirty[v as usize] = true;
    }
}

/// Worst signed η of the quads around `v`.
fn star_min(l: &Local, v: u32) -> f64 {
    l.star(v)
        .iter()
        .filter(|&&q| l.alive[q as usize])
        .map(|&q| l.quality(q))
        .fold(f64::INFINITY, f64::min)
}

/// True when some alive quad other than those in `except` contains both `a` and `b`.
fn share_a_quad(l: &Local, a: u32, b: u32, except: &[u32]) -> bool {
    l.star(a).iter().any(|&q| {
        l.alive[q as usize] && !except.contains(&q) && slot(&l.quads[q as usize], b).is_some()
    })
}

/// Figure 11: removes free node `v` when exactly two quads surround it.
fn doublet_collapse(l: &mut Local, v: u32, dirty: &mut [bool]) -> bool {
    let vi = v as usize;
    if l.fixed[vi] || l.removed[vi] || dirty[vi] || l.star(v).len() != 2 {
        return false;
    }
    let (q1, q2) = (l.star(v)[0], l.star(v)[1]);
    let (Some(r1), Some(r2)) = (
        rotate_to(&l.quads[q1 as usize], v),
        rotate_to(&l.quads[q2 as usize], v),
    ) else {
        return false;
    };
    // r1 = v a b c ; r2 = v c d a (the star closes around v)
    let [_, a, b, c] = r1;
    let [_, c2, d, a2] = r2;
    if c2 != c || a2 != a || b == d || any_dirty(dirty, &[a, b, c, d]) {
        return false;
    }
    // the merged quad must not duplicate an existing one
    if l.star(b).iter().any(|&q| {
        q != q1
            && l.alive[q as usize]
            && [a, c, d]
                .iter()
                .all(|&w| slot(&l.quads[q as usize], w).is_some())
    }) {
        return false;
    }
    let merged = [a, b, c, d];
    let n = l.quad_normal(q1) + l.quad_normal(q2);
    // validity: the merged quad must be valid (no corner within VALID_ETA of straight, no
    // collapsed edge), not only of positive η
    if !quad_valid(l, &merged, n) {
        return false;
    }
    l.quads[q1 as usize] = merged;
    l.alive[q2 as usize] = false;
    l.removed[vi] = true;
    mark(dirty, &[v, a, b, c, d]);
    true
}

/// Figure 10: removes quad `q` by merging two opposite free corners when that lowers the
/// valence defect: the paper's diamond (two corners of valence 3 whose other two corners
/// have 5 or more) and its generalizations. A 3-3 diamond whose other corners have valence
/// 4 is left alone: merging it would only turn those two into valence 3.
fn quad_vertex_merge(
    l: &mut Local,
    q: u32,
    ideal: &[i32],
    angle: &[f64],
    dirty: &mut [bool],
) -> bool {
    if !l.alive[q as usize] {
        return false;
    }
    let quad = l.quads[q as usize];
    for k in 0..2 {
        let (a, b, c, d) = (quad[k], quad[k + 1], quad[(k + 2) % 4], quad[(k + 3) % 4]);
        if try_merge(l, q, [a, b, c, d], ideal, angle, dirty) {
            return true;
        }
    }
    false
}

fn try_merge(
    l: &mut Local,
    q: u32,
    [a, b, c, d]: [u32; 4],
    ideal: &[i32],
    angle: &[f64],
    dirty: &mut [bool],
) -> bool {
    let free = |v: u32| !l.fixed[v as usize] && !l.removed[v as usize];
    if !free(a) || !free(c) {
        return false;
    }
    let val = |v: u32| l.star(v).len() as i32;
    // b and d lose a quad: keep free ones at 3 or more, fixed ones at 1 or more and without a
    // corner wider than MAX_FIXED_CORNER (a fixed node cannot move to open it)
    let keeps = |v: u32| {
        if l.fixed[v as usize] {
            val(v) >= 2 && angle[v as usize] / f64::from(val(v) - 1) <= MAX_FIXED_CORNER
        } else {
            val(v) >= 4
        }
    };
    if !keeps(b) || !keeps(d) {
        return false;
    }
    let def = |v: u32, n: i32| (n - ideal[v as usize]) * (n - ideal[v as usize]);
    let before = def(a, val(a)) + def(c, val(c)) + def(b, val(b)) + def(d, val(d));
    let after = def(a, val(a) + val(c) - 2) + def(b, val(b) - 1) + def(d, val(d) - 1);
    if after >= before {
        return false;
    }
    // the two stars must only meet along q (else the merge pinches the surface)
    let ring = |v: u32| -> Vec<u32> {
        let mut r: Vec<u32> = l
            .star(v)
            .iter()
            .filter(|&&s| s != q)
            .flat_map(|&s| l.quads[s as usize])
            .filter(|&w| w != v && w != b && w != d)
            .collect();
        r.sort_unstable();
        r.dedup();
        r
    };
    let (ra, rc) = (ring(a), ring(c));
    if ra.iter().any(|w| rc.binary_search(w).is_ok()) || ra.contains(&c) {
        return false;
    }
    let mut nodes: Vec<u32> = vec![a, b, c, d];
    nodes.extend(&ra);
    nodes.extend(&rc);
    if any_dirty(dirty, &nodes) {
        return false;
    }
    let old_min = star_min(l, a).min(star_min(l, c));
    let others: Vec<u32> = l
        .star(a)
        .iter()
        .chain(l.star(c))
        .copied()
        .filter(|&s| s != q)
        .collect();
    // candidate positions: midpoint, then the centroid of the merged star's ring
    let mid = 0.5 * (l.pos[a as usize] + l.pos[c as usize]);
    let centroid = {
        let mut s = DVec3::ZERO;
        let mut n = 0.0;
        for &o in &others {
            for &w in &l.quads[o as usize] {
                if w != a && w != c {
                    s += l.pos[w as usize];
                    n += 1.0;
                }
            }
        }
        if n > 0.0 {
            s / n
        } else {
            mid
        }
    };
    let saved_c: Vec<(u32, [u32; 4])> = others.iter().map(|&o| (o, l.quads[o as usize])).collect();
    let (pa, na, ta) = (l.pos[a as usize], l.nrm[a as usize], l.tri[a as usize]);
    // rewrite: c -> a in c's quads
    for &o in &others {
        for w in l.quads[o as usize].iter_mut() {
            if *w == c {
                *w = a;
            }
        }
    }
    // a planar surface's nodes keep the plane's normal bit for bit (the validity gate then
    // stores one normal for all of them)
    if !l.planar {
        l.nrm[a as usize] = (na + l.nrm[c as usize]).normalize_or(na);
    }
    for cand in [mid, centroid] {
        let (p, tri) = l.project(a, cand);
        l.pos[a as usize] = p;
        let new_min = others
            .iter()
            .map(|&o| l.quality(o))
            .fold(f64::INFINITY, f64::min);
        if new_min > 0.0 && new_min >= old_min && others.iter().all(|&o| valid::valid(l, o)) {
            l.tri[a as usize] = tri;
            l.alive[q as usize] = false;
            l.removed[c as usize] = true;
            mark(dirty, &nodes);
            return true;
        }
    }
    // undo
    for (o, quad) in saved_c {
        l.quads[o as usize] = quad;
    }
    l.pos[a as usize] = pa;
    l.nrm[a as usize] = na;
    l.tri[a as usize] = ta;
    false
}

/// Rotates the edge `quads[q][k] → quads[q][k+1]` if that helps (see module docs).
fn edge_rotation(
    l: &mut Local,
    q1: u32,
    k: usize,
    ideal: &[i32],
    valence: &mut [i32],
    qual: &mut [f64],
    dirty: &mut [bool],
) -> bool {
    if !l.alive[q1 as usize] {
        return false;
    }
    let quad = l.quads[q1 as usize];
    let (u, v) = (quad[k], quad[(k + 1) % 4]);
    // each interior edge once (from the quad running through it from the smaller node)
    if u > v || l.fixed[u as usize] && l.fixed[v as usize] || any_dirty(dirty, &[u, v]) {
        return false;
    }
    // the other quad through v -> u
    let Some(&q2) = l.star(u).iter().find(|&&s| {
        s != q1 && l.alive[s as usize] && {
            let r = l.quads[s as usize];
            (0..4).any(|m| r[m] == v && r[(m + 1) % 4] == u)
        }
    }) else {
        return false;
    };
    let r1 = rotate_to(&quad, u).unwrap_or(quad); // u v p1 p2
    let r2 = rotate_to(&l.quads[q2 as usize], v).unwrap_or(quad); // v u p3 p4
                                                                  // hexagon in orientation: v p1 p2 u p3 p4
    let hex = [v, r1[2], r1[3], u, r2[2], r2[3]];
    let mut sorted = hex;
    sorted.sort_unstable();
    if sorted.windows(2).any(|w| w[0] == w[1]) || any_dirty(dirty, &hex) {
        return false;
    }
    let defect = |w: u32, val: i32| {
        let d = val - ideal[w as usize];
        d * d
    };
    // qualities as at the start of the rotations (quads touched since have dirty nodes)
    let mut cached = |q: u32| {
        let c = &mut qual[q as usize];
        if c.is_nan() {
            *c = l.quality(q);
        }
        *c
    };
    let old_min = cached(q1).min(cached(q2));
    let gains = [1usize, 2].map(|s| {
        let (x, y) = (hex[s], hex[s + 3]);
        let before: i32 = [u, v, x, y]
            .iter()
            .map(|&w| defect(w, valence[w as usize]))
            .sum();
        before
            - (defect(u, valence[u as usize] - 1)
                + defect(v, valence[v as usize] - 1)
                + defect(x, valence[x as usize] + 1)
                + defect(y, valence[y as usize] + 1))
    });
    if gains.iter().all(|&g| g <= 0) && old_min >= 0.2 {
        return false;
    }
    let n = l.quad_normal(q1) + l.quad_normal(q2);
    let mut best: Option<(i32, f64, [[u32; 4]; 2])> = None;
    for (s, gain) in [1usize, 2].into_iter().zip(gains) {
        // new diagonal hex[s] - hex[s+3]
        let (x, y) = (hex[s], hex[s + 3]);
        if gain < -2 || share_a_quad(l, x, y, &[q1, q2]) {
            continue;
        }
        let qa = [hex[s], hex[s + 1], hex[s + 2], hex[s + 3]];
        let qb = [hex[s + 3], hex[(s + 4) % 6], hex[(s + 5) % 6], hex[s]];
        let ea = crate::quality::eta_signed_fast(&qa.map(|w| l.pos[w as usize]), n);
        let eb = crate::quality::eta_signed_fast(&qb.map(|w| l.pos[w as usize]), n);
        let new_min = ea.min(eb);
        // fewer irregular vertices (smoothing follows), or a much better quad pair
        let topological = gain > 0;
        let geometric = old_min < 0.2 && new_min > old_min + 0.2;
        if new_min <= 0.0 || !(topological || geometric) {
            continue;
        }
        // validity: both new quads valid (a float-noise-positive straight corner at a
        // wall node is not)
        if !quad_valid(l, &qa, n) || !quad_valid(l, &qb, n) {
            continue;
        }
        if best.is_none_or(|(g, m, _)| (gain, new_min) > (g, m)) {
            best = Some((gain, new_min, [qa, qb]));
        }
    }
    let Some((_, _, [qa, qb])) = best else {
        return false;
    };
    let (x, y) = (qa[0], qa[3]);
    l.quads[q1 as usize] = qa;
    l.quads[q2 as usize] = qb;
    valence[u as usize] -= 1;
    valence[v as usize] -= 1;
    valence[x as usize] += 1;
    valence[y as usize] += 1;
    mark(dirty, &hex);
    true
}
