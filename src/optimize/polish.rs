//! Polish: the last steps of the optimization, aimed at η̄ and η_w (eq. 3) directly.
//!
//! [`polish_mean`] moves every free node by a pattern search (8 tangent directions, steps
//! h/10, h/25, h/67) to the place that maximizes the *sum of η* over its star, its worst
//! kept. The centroid smoothing balances lengths (eq. 1), which is what τ measures, while
//! η sees only angles: this trades a little τ for η̄. To take back part of that τ, the
//! objective adds [`SIZE_WEIGHT`] times `Σ d_i` over the node's edges, `d_i` the summand
//! of eq. 2 (`l − 1` below 1, `1/l − 1` above, with l^h ≈ |edge| times the mean of 1/h at
//! its ends): where η is flat (moves that keep angles but change lengths, common since η
//! is a max over corners), the node goes where the edges fit the size field.
//!
//! The worst quads are lifted before this by [`super::smooth::polish_worst`] (max-min
//! pattern search); only surfaces of 10^4 quads or more run that again after the mean
//! polish (`schedule`).
//!
//! Cost: 1 colour-parallel sweep over the free nodes (4 on surfaces under 10^4 quads).

use super::local::{Local, StarEval, STAR_MAX};
use super::smooth::pattern_search8;
use glam::DVec3;

/// Sweeps of [`polish_mean`] on surfaces of 10^4 quads or more: the second sweep gains about
/// a third as much η̄ as the first at the same cost (figures in BENCHMARKS.md,
/// "Measurements behind the defaults").
pub(crate) const MEAN_SWEEPS: usize = 1;

/// Weight of the size term (module docs) against the star's summed η: it trades a little
/// mean η for τ; [`SIZE_TERM_MAX_COT`] keeps it off the stars whose worst quad the polish
/// must still lift (figures in BENCHMARKS.md, "Measurements behind the defaults").
const SIZE_WEIGHT: f64 = 0.3;

/// The size term applies only to stars whose worst |cot α| is at most this (worst corner
/// within 34° of a right angle, η ≥ 0.62).
const SIZE_TERM_MAX_COT: f64 = 0.68;

/// Stars with more edges than this get no size term (valence above 8 is rare).
const MAX_SIZE_EDGES: usize = 8;

/// Sweeps of [`polish_mean`] on surfaces under 10^4 quads, where they are cheap (figures in
/// BENCHMARKS.md, "Measurements behind the defaults").
pub(crate) const MEAN_SWEEPS_SMALL: usize = 4;

/// `atan(t)` for `t ≥ 0` within about 1e-5 rad (a minimax polynomial on [0, 1] and
/// `atan t = π/2 − atan(1/t)` above): the polish compares sums of η over a star, so a
/// consistent approximation is enough, and the library `atan` was a large share of the
/// polish's time (BENCHMARKS.md, "Measurements behind the defaults").
fn atan_fast(t: f64) -> f64 {
    let (x, flip) = if t > 1.0 { (1.0 / t, true) } else { (t, false) };
    let x2 = x * x;
    let a = x
        * (0.999_866_0
            + x2 * (-0.330_299_5 + x2 * (0.180_141_0 + x2 * (-0.085_133_0 + x2 * 0.020_835_1))));
    if flip {
        std::f64::consts::FRAC_PI_2 - a
    } else {
        a
    }
}

/// η (eq. 3) of a valid quad whose worst |cot α| is `c` (see [`StarEval::worst_cot`];
/// its [`shape_key`](super::local) is 1 / (1 + c)), through [`atan_fast`] (the exact form
/// is [`key_to_eta`](super::local::key_to_eta)).
fn eta_of_cot(c: f64) -> f64 {
    1.0 - atan_fast(c) / std::f64::consts::FRAC_PI_2
}

/// Pattern search maximizing the star's summed η, its worst kept: the new position and
/// reference triangle of `v`, if better. Stars holding an invalid quad are left alone (e.g.
/// the two quads of a doublet): raising such a quad's key can still turn it over (measured:
/// a doublet node pushed out of its star); so are trial positions that make one invalid.
#[inline]
fn mean_node(l: &Local, v: u32, size_weight: f64) -> Option<(DVec3, u32)> {
    let vi = v as usize;
    let x0 = l.pos[vi];
    if l.star(v)
        .iter()
        .any(|&q| l.hopeless.get(q as usize) == Some(&true))
    {
        return None;
    }
    let star = StarEval::new(l, v);
    // (worst |cot|, summed η): the worst cot stands for the worst key (the key is
    // 1 / (1 + cot)), so no key is computed
    let eval = |p: DVec3| -> Option<(f64, f64)> {
        let mut max = 0.0_f64;
        let mut sum = 0.0;
        for i in 0..star.len() {
            let c = if star.fast() {
                star.worst_cot(i, p)
            } else {
                let k = star.key(i, p);
                if k > 0.0 {
                    1.0 / k - 1.0
                } else {
                    -1.0
                }
            };
            if c.is_nan() || c < 0.0 {
                return None;
            }
            max = max.max(c);
            sum += eta_of_cot(c);
        }
        Some((max, sum))
    };
    let (max0, sum0) = eval(x0)?;
    // validity: a star whose worst quad is below the valid key is left to the max-min
    // polish (keeping the worst cotangent would not keep its other quads valid)
    if max0 > 1.0 / super::valid::VALID_KEY - 1.0 {
        return None;
    }
    // the size term (module docs), on stars whose worst quad is not poor
    let mut edges = [(DVec3::ZERO, 0.0); MAX_SIZE_EDGES];
    let mut ne = 0;
    if size_weight > 0.0 && max0 <= SIZE_TERM_MAX_COT && star.len() <= MAX_SIZE_EDGES {
        for &q in l.star(v) {
            let quad = &l.quads[q as usize];
            if let Some(k) = quad.iter().position(|&w| w == v) {
                let w = quad[(k + 1) & 3] as usize;
                edges[ne] = (l.pos[w], 0.5 * (1.0 / l.h[vi] + 1.0 / l.h[w]));
                ne += 1;
            }
        }
    }
    let edges = &edges[..ne];
    let size_term = |p: DVec3| -> f64 {
        let mut t = 0.0;
        for &(x, inv_h) in edges {
            // eq. 2's summand: l − 1 below 1, 1/l − 1 above
            let lh = p.distance(x) * inv_h;
            t += lh.min(1.0 / lh);
        }
        size_weight * (t - edges.len() as f64)
    };
    let sum0 = sum0 + size_term(x0);
    let eval = |p: DVec3| eval(p).map(|(m, s)| (m, s + size_term(p)));
    // a trial must also keep the corners at located nodes turning about the faces there
    let holds = super::valid::Holds::new(l, v, x0);
    let keeps = |p: DVec3| holds.keeps_located(p);
    let score = |p: DVec3, floor: f64| {
        eval(p).and_then(|(mx, sum)| (mx <= max0 && sum > floor && keeps(p)).then_some(sum))
    };
    if star.fast() {
        // the eight compass trials of a step scored together (same sums as `eval`)
        // speed: the η sums (an atan each) only for the trials that keep the worst
        return pattern_search8(l, v, &[0.1, 0.04, 0.015], sum0, |ps, floor| {
            let mut max = [0.0_f64; 8];
            let mut ok = [true; 8];
            let mut cots = [[0.0_f64; 8]; STAR_MAX];
            for (i, cot) in cots.iter_mut().enumerate().take(star.len()) {
                *cot = star.worst_cot8(i, ps);
                for j in 0..8 {
                    ok[j] &= cot[j] >= 0.0;
                    max[j] = max[j].max(cot[j]);
                }
            }
            std::array::from_fn(|j| {
                if !(ok[j] && max[j] <= max0) {
                    return None;
                }
                let sum = cots[..star.len()]
                    .iter()
                    .fold(0.0, |sum, cot| sum + eta_of_cot(cot[j].max(0.0)))
                    + size_term(ps[j]);
                (sum > floor && keeps(ps[j])).then_some(sum)
            })
        });
    }
    pattern_search8(l, v, &[0.1, 0.04, 0.015], sum0, |ps, floor| {
        ps.map(|p| score(p, floor))
    })
}

/// Up to `sweeps` sweeps of [`mean_node`] over all free nodes, Gauss-Seidel by colour (the
/// nodes of one colour share no quad: their moves are computed in parallel), with the size
/// term weighted by [`SIZE_WEIGHT`].
pub(crate) fn polish_mean(l: &mut Local, sweeps: usize) -> usize {
    polish_mean_weighted(l, sweeps, SIZE_WEIGHT)
}

/// [`polish_mean`] with the size term weighted by `size_weight` (0: η alone).
fn polish_mean_weighted(l: &mut Local, sweeps: usize, size_weight: f64) -> usize {
    use rayon::prelude::*;
    l.prepare_sweeps();
    let groups = std::mem::take(&mut l.colours);
    let mut moves = 0;
    // after the first sweep, only nodes sharing a quad with a node that moved
    let mut active = vec![true; l.pos.len()];
    let mut next = vec![false; l.pos.len()];
    for _ in 0..sweeps {
        let mut moved = 0;
        for g in &groups {
            let lr: &Local = l;
            let act = &active;
            let found: Vec<(u32, DVec3, u32)> = g
                .par_iter()
                .with_min_len(512)
                .filter(|&&v| act[v as usize])
                .filter_map(|&v| mean_node(lr, v, size_weight).map(|(p, t)| (v, p, t)))
                .collect();
            moved += found.len();
            for (v, p, t) in found {
                l.pos[v as usize] = p;
                l.tri[v as usize] = t;
                for &q in l.star(v) {
                    for &w in &l.quads[q as usize] {
                        next[w as usize] = true;
                    }
                }
            }
        }
        moves += moved;
        if moved == 0 {
            break;
        }
        std::mem::swap(&mut active, &mut next);
        next.fill(false);
    }
    l.colours = groups;
    moves
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn atan_fast_is_close_to_atan() {
        for i in 0..20_000 {
            let t = i as f64 / 1000.0;
            assert!((atan_fast(t) - t.atan()).abs() < 2e-5, "{t}");
        }
    }
    use crate::optimize::cleanup::tests::local_of;
    use crate::optimize::synth;

    fn worst(l: &Local) -> f64 {
        (0..l.quads.len() as u32)
            .map(|q| l.quality(q))
            .fold(f64::INFINITY, f64::min)
    }

    #[test]
    fn polish_raises_the_worst_quad_and_keeps_fixed_nodes() {
        for seed in [1u64, 2, 3] {
            let mut s = synth::quad_grid(8, 8, 1.0, 1.0);
            synth::jitter(&mut s, 0.2 / 8.0, seed);
            // squeeze one interior node towards a neighbour: a poor but valid quad
            let v = 4 * 9 + 4;
            s.points[v] = s.points[v].lerp(s.points[v + 1], 0.75);
            let m = synth::to_mesh(&s);
            let (_, mut l) = local_of(&m);
            let fixed: Vec<DVec3> = (0..l.pos.len())
                .filter(|&w| l.fixed[w])
                .map(|w| l.pos[w])
                .collect();
            let before = worst(&l);
            assert!(
                before > 0.0 && before < 0.55,
                "seed {seed}: the fixture needs a poor valid quad ({before})"
            );
            l.build_adjacency();
            let moves = super::super::smooth::polish_worst(&mut l, 3);
            let after = worst(&l);
            assert!(moves > 0);
            assert!(
                after > before + 0.1,
                "seed {seed}: worst {before} -> {after}"
            );
            let fixed_after: Vec<DVec3> = (0..l.pos.len())
                .filter(|&w| l.fixed[w])
                .map(|w| l.pos[w])
                .collect();
            assert_eq!(fixed, fixed_after, "a fixed node moved");
        }
    }

    #[test]
    fn mean_polish_raises_mean_eta_and_never_lowers_a_stars_worst() {
        for seed in [4u64, 5] {
            let mut s = synth::quad_grid(10, 10, 1.0, 1.0);
            synth::jitter(&mut s, 0.3 / 10.0, seed);
            let m = synth::to_mesh(&s);
            let (_, mut l) = local_of(&m);
            let mean = |l: &Local| {
                (0..l.quads.len() as u32).map(|q| l.quality(q)).sum::<f64>() / l.quads.len() as f64
            };
            let (m0, w0) = (mean(&l), worst(&l));
            let fixed: Vec<DVec3> = (0..l.pos.len())
                .filter(|&w| l.fixed[w])
                .map(|w| l.pos[w])
                .collect();
            assert!(polish_mean(&mut l, 3) > 0);
            let (m1, w1) = (mean(&l), worst(&l));
            assert!(m1 > m0 + 0.02, "seed {seed}: mean {m0} -> {m1}");
            assert!(w1 >= w0 - 1e-12, "seed {seed}: worst {w0} -> {w1}");
            let fixed_after: Vec<DVec3> = (0..l.pos.len())
                .filter(|&w| l.fixed[w])
                .map(|w| l.pos[w])
                .collect();
            assert_eq!(fixed, fixed_after);
        }
    }

    /// Recombined Delaunay squares after smoothing and the topology rounds (the state the
    /// polish sees in the pipeline): with the size term the polish ends with a higher
    /// estimated τ than without it, summed over seeds, at a small cost in η̄.
    #[test]
    fn the_size_term_raises_tau_at_a_small_cost_in_mean_eta() {
        let (mut tau, mut eta, mut runs) = ([0.0; 2], [0.0; 2], 0);
        for seed in 1u64..40 {
            let Some(mut l) = crate::optimize::cleanup::tests::square_local(14, seed) else {
                continue;
            };
            let opts = crate::optimize::OptimizeOptions::default();
            crate::optimize::schedule::after_topology_rounds(&mut l, &opts);
            for (k, w) in [0.0, SIZE_WEIGHT].into_iter().enumerate() {
                let mut p = l.clone();
                p.build_adjacency();
                polish_mean_weighted(&mut p, MEAN_SWEEPS_SMALL, w);
                let st = p.stats();
                tau[k] += p.tau_estimate();
                eta[k] += st.eta_mean;
            }
            runs += 1;
        }
        assert!(runs >= 5, "not enough matchable seeds");
        let n = runs as f64;
        assert!(tau[1] > tau[0] + 0.1 * n, "tau {:?} over {runs}", tau);
        assert!(eta[1] > eta[0] - 0.005 * n, "eta {:?} over {runs}", eta);
    }

    #[test]
    fn stars_holding_an_invalid_quad_are_left_alone() {
        // push an interior node across its neighbour's diagonal: two quads turn non-convex
        let mut s = synth::quad_grid(6, 6, 1.0, 1.0);
        let v = 3 * 7 + 3;
        s.points[v] = s.points[v].lerp(s.points[v + 8], 1.3);
        let m = synth::to_mesh(&s);
        let (_, mut l) = local_of(&m);
        l.refresh_quad_normals();
        let invalid = |l: &Local| -> Vec<usize> {
            (0..l.quads.len())
                .filter(|&q| l.quality(q as u32) <= 0.0)
                .collect()
        };
        let bad = invalid(&l);
        assert!(!bad.is_empty());
        let around: Vec<u32> = bad.iter().flat_map(|&q| l.quads[q]).collect();
        let before: Vec<DVec3> = around.iter().map(|&w| l.pos[w as usize]).collect();
        polish_mean(&mut l, 3);
        let after: Vec<DVec3> = around.iter().map(|&w| l.pos[w as usize]).collect();
        assert_eq!(before, after, "a node of an invalid quad moved");
        assert_eq!(invalid(&l), bad);
    }
}
