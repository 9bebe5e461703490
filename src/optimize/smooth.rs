//! Vertex smoothing (paper section 6, ref. [20]) that respects the size field's gradation.
//!
//! Each free node is moved towards the *size-weighted centroid* of its star: the minimizer of
//! Σ_j w_j |x − x_j|² with w_j = 1/h_j² for the edge neighbours and `diag`/h_j² for the
//! opposite corners of its quads, h_j being the size at the middle of the segment (mean of the
//! two nodal sizes). With l^h ≈ |x − x_j| / h_j (eq. 1), that is the spring energy Σ (l^h)²,
//! so nodes settle where adimensional lengths balance and gradation is kept; for a constant h
//! it is the plain quad-centroid Laplacian. The move is tried at full length, then at 1/2 and
//! 1/4 (a backtracking line search between the node and the target, in place of Gmsh's
//! golden-section search on the same segment), and accepted at the first step
//! where the star's worst signed η (eq. 3 with the surface normal, so inverted quads score
//! below zero) does not drop. On curved surfaces every candidate is projected back onto the
//! reference triangulation by a local walk from the node's current triangle, and a move
//! is refused when it would fold a quad of the star about its own normal (the cross product
//! of its diagonals, `valid::Rule::OwnJacobian`) or (on `OptimizeOptions::located_surfaces`)
//! turn a corner at a node the reference does not have away from the reference triangles
//! that node touches (`valid::Rule::LocatedTurns`), which the keys do not see.
//!
//! Sweeps are Gauss-Seidel by colour: nodes are greedily coloured so that two nodes of one
//! colour never share a quad, the moves of one colour are computed in parallel (rayon) from
//! the same state, then applied. After the first sweep only nodes near a move larger than
//! `MOVE_TOL` · h are tried again. Quality comparisons use a trigonometry-free key ordered
//! like η ([`shape_key`](super::local)), evaluated on a [`StarEval`] (the node's star copied
//! once per proposal, the corner opposite the node computed once). Hopeless quads (a fixed
//! corner that is straight or worse, see [`Local::refresh_quad_normals`]) take no part.
//!
//! [`polish_worst`] lifts the quads with η < 0.6 by a max-min pattern search, and
//! [`optimize_angles`] then polishes nodes around poor quads by a pattern search on the
//! star's mean η that keeps every star's worst. η (eq. 3) sees angles only and accepts
//! elongated rectangles, so these raise η̄ and η_w at some cost in τ (figures in
//! BENCHMARKS.md, "Measurements behind the defaults").

use super::local::{rotate_to, Local, StarEval};
use super::valid::Holds;
use glam::DVec3;
use rayon::prelude::*;

/// A move proposal for one node: its new position and reference triangle, or none.
type Propose<'a> = dyn Fn(&Local, u32) -> Option<(DVec3, u32)> + Sync + 'a;

/// Runs the `active` nodes of `groups` (independent nodes) through `propose` (in parallel)
/// and applies the accepted moves. Returns the number of moves; nodes that moved by more than
/// `MOVE_TOL` · h make their neighbours (and themselves) active in `next`.
fn sweep(
    l: &mut Local,
    groups: &[Vec<u32>],
    active: &[bool],
    next: &mut [bool],
    propose: &Propose<'_>,
) -> usize {
    let mut moves = 0;
    for g in groups {
        let lr: &Local = l;
        let found: Vec<(u32, DVec3, u32)> = g
            .par_iter()
            .with_min_len(512)
            .filter(|&&v| active[v as usize])
            .filter_map(|&v| propose(lr, v).map(|(p, t)| (v, p, t)))
            .collect();
        for (v, p, t) in found {
            let vi = v as usize;
            if p.distance(l.pos[vi]) > MOVE_TOL * l.h[vi] {
                for &q in l.star(v) {
                    for &w in &l.quads[q as usize] {
                        next[w as usize] = true;
                    }
                }
            }
            l.pos[vi] = p;
            l.tri[vi] = t;
            moves += 1;
        }
    }
    moves
}

/// A node whose move exceeds `MOVE_TOL` · h makes its neighbours active for the next sweep:
/// small enough to cost no mean quality, large enough to cut the work of later sweeps
/// (figures in BENCHMARKS.md, "Measurements behind the defaults").
const MOVE_TOL: f64 = 1e-3;

/// Sweeps `propose` over the free nodes up to `sweeps` times, each sweep only over the nodes
/// near a significant move of the previous one; the first sweep over the nodes flagged in
/// `active` (all nodes when `None`).
fn sweeps(l: &mut Local, sweeps: usize, propose: &Propose, active: Option<Vec<bool>>) -> usize {
    l.prepare_sweeps();
    let groups = std::mem::take(&mut l.colours);
    let mut active = active.unwrap_or_else(|| vec![true; l.pos.len()]);
    let mut next = vec![false; l.pos.len()];
    let mut moves = 0;
    for _ in 0..sweeps {
        moves += sweep(l, &groups, &active, &mut next, propose);
        if !next.iter().any(|&a| a) {
            break;
        }
        std::mem::swap(&mut active, &mut next);
        next.fill(false);
    }
    l.colours = groups;
    moves
}

/// Size-weighted centroid move with backtracking (see the module docs).
fn propose_centroid(l: &Local, v: u32, diag: f64) -> Option<(DVec3, u32)> {
    let vi = v as usize;
    let x0 = l.pos[vi];
    let hv = l.h[vi];
    let mut acc = DVec3::ZERO;
    let mut wsum = 0.0;
    for &q in l.star(v) {
        if l.hopeless[q as usize] {
            continue;
        }
        let r = rotate_to(&l.quads[q as usize], v)?;
        for (k, w0) in [(1usize, 1.0), (2, diag), (3, 1.0)] {
            let j = r[k] as usize;
            let hm = 0.5 * (hv + l.h[j]);
            let w = w0 / (hm * hm);
            acc += l.pos[j] * w;
            wsum += w;
        }
    }
    if wsum <= 0.0 || !wsum.is_finite() {
        return None;
    }
    let step = acc / wsum - x0;
    if step.length_squared() <= (1e-9 * hv) * (1e-9 * hv) {
        return None;
    }
    let star = StarEval::new(l, v);
    let old = star.min_key(x0);
    let guard = star.needs_guard(old);
    let holds = Holds::new(l, v, x0);
    for t in [1.0, 0.5, 0.25] {
        let (cand, tri) = l.project(v, x0 + step * t);
        if star.all_at_least(cand, old)
            && (!guard || star.keeps_valid(x0, cand))
            && holds.keeps(cand)
        {
            return Some((cand, tri));
        }
    }
    None
}

/// Runs up to `iterations` sweeps of [`propose_centroid`] over the free nodes (after the
/// first, only near nodes that moved by more than `MOVE_TOL` · h); returns the number of accepted
/// moves. `diag` is the weight of the opposite corners relative to edge neighbours.
pub(crate) fn smooth(l: &mut Local, iterations: usize, diag: f64) -> usize {
    sweeps(l, iterations, &|l, v| propose_centroid(l, v, diag), None)
}

/// [`smooth`] starting from the nodes flagged in `active` only (e.g. around the elements a
/// topological pass changed).
pub(crate) fn smooth_near(l: &mut Local, iterations: usize, diag: f64, active: Vec<bool>) -> usize {
    sweeps(
        l,
        iterations,
        &|l, v| propose_centroid(l, v, diag),
        Some(active),
    )
}

/// Pattern search on the star's mean shape key, the worst kept (see [`optimize_angles`]).
/// Only nodes whose star holds a quad with key below 0.7 (η ≈ 0.8) are tried.
fn propose_pattern(l: &Local, v: u32) -> Option<(DVec3, u32)> {
    let vi = v as usize;
    let x0 = l.pos[vi];
    let star = StarEval::new(l, v);
    let (min0, best_sum) = star.min_sum_above(x0, f64::NEG_INFINITY)?;
    if min0 >= 0.7 {
        return None;
    }
    let guard = star.needs_guard(min0);
    let holds = Holds::new(l, v, x0);
    pattern_search8(l, v, &[0.15, 0.05, 0.015], best_sum, |ps, floor| {
        let r = star.min_sum8(ps);
        std::array::from_fn(|j| {
            let (min, sum) = r[j];
            (min >= min0
                && sum > floor
                && (!guard || star.keeps_valid(x0, ps[j]))
                && holds.keeps(ps[j]))
            .then_some(sum)
        })
    })
}

/// Pattern search for node `v` in its tangent plane: for each step `s·h` in `steps`, the 8
/// compass moves from the best point so far (projected on the reference surface) are
/// scored together (`score` gets the eight projected points in compass order and the score
/// a trial must exceed to be taken, and returns their scores, `None` meaning not allowed or
/// not taken: the checks of a move that cannot win are skipped); the best score above
/// `start` (the score of the current position) wins. Returns the best position and its
/// reference triangle, if any.
pub(crate) fn pattern_search8(
    l: &Local,
    v: u32,
    steps: &[f64],
    start: f64,
    score: impl Fn(&[DVec3; 8], f64) -> [Option<f64>; 8],
) -> Option<(DVec3, u32)> {
    let vi = v as usize;
    let (t1, t2) = tangents(l.nrm[vi]);
    let h = l.h[vi];
    let dirs = compass(t1, t2);
    let mut best_score = start;
    let mut best: Option<(DVec3, u32)> = None;
    for &s in steps {
        let base = best.map_or(l.pos[vi], |b| b.0);
        let trials: [(DVec3, u32); 8] =
            std::array::from_fn(|k| l.project(v, base + dirs[k] * (s * h)));
        let scores = score(&trials.map(|t| t.0), best_score + 1e-12);
        for (k, sc) in scores.into_iter().enumerate() {
            match sc {
                Some(x) if x > best_score + 1e-12 => {
                    best_score = x;
                    best = Some(trials[k]);
                }
                _ => {}
            }
        }
    }
    best
}

/// Two unit tangents orthogonal to the unit normal `n` and to each other.
pub(crate) fn tangents(n: DVec3) -> (DVec3, DVec3) {
    let t1 = n.any_orthonormal_vector();
    (t1, n.cross(t1))
}

/// The eight compass directions of the tangent plane spanned by `t1`, `t2`.
pub(crate) fn compass(t1: DVec3, t2: DVec3) -> [DVec3; 8] {
    let r = std::f64::consts::FRAC_1_SQRT_2;
    [
        t1,
        -t1,
        t2,
        -t2,
        (t1 + t2) * r,
        (t1 - t2) * r,
        (t2 - t1) * r,
        -(t1 + t2) * r,
    ]
}

/// Quality-maximizing sweeps: each free node whose star holds a poor quad tries small moves
/// (a pattern search in the tangent plane, steps 0.15 h, 0.05 h, 0.015 h along two tangent
/// axes and their diagonals) and keeps the one that most raises the mean shape key of its
/// star without lowering its worst. Returns the number of accepted moves.
pub(crate) fn optimize_angles(l: &mut Local, n: usize) -> usize {
    sweeps(l, n, &propose_pattern, None)
}

/// Key of a quad whose η (eq. 3) is 0.6: tan(0.2π) = 0.7265 is the worst |cot α| there.
const POLISH_BELOW: f64 = 1.0 / (1.0 + 0.726_542_528_005_360_9);

/// Pattern search on the star's worst shape key (max-min): moves a node of a poor quad
/// (key below [`POLISH_BELOW`]) to the trial position that most raises its star's worst key.
fn propose_worst(l: &Local, v: u32) -> Option<(DVec3, u32)> {
    let star = StarEval::new(l, v);
    let x0 = l.pos[v as usize];
    let min0 = star.min_key(x0);
    if min0 >= POLISH_BELOW {
        return None;
    }
    let guard = star.needs_guard(min0);
    let holds = Holds::new(l, v, x0);
    pattern_search8(l, v, &[0.1, 0.03, 0.01, 0.003], min0, |ps, floor| {
        let r = star.min_sum8(ps);
        std::array::from_fn(|j| {
            (r[j].0 > floor
                && (!guard || star.keeps_valid(x0, ps[j]))
                && holds.keeps(ps[j]))
                .then_some(r[j].0)
        })
    })
}

/// Max-min polish of the worst quads: [`propose_worst`] on the nodes of quads with η below
/// 0.6 and, over `n` sweeps, around the nodes that moved. Returns the number of moves.
pub(crate) fn polish_worst(l: &mut Local, n: usize) -> usize {
    l.prepare_sweeps();
    let mut active = vec![false; l.pos.len()];
    let mut any = false;
    for (q, quad) in l.quads.iter().enumerate() {
        if l.alive[q] && l.key_with(q as u32, quad[0], l.pos[quad[0] as usize]) < POLISH_BELOW {
            for &v in quad {
                active[v as usize] = true;
            }
            any = true;
        }
    }
    if !any {
        return 0;
    }
    sweeps(l, n, &propose_worst, Some(active))
}
