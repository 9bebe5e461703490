//! The stages of one surface and their order (see the module docs of `optimize`): first
//! smoothing, topology rounds with smoothing near their changes, the conformal solve, the
//! polish stages, and on small planar surfaces the choice among three schedules.

use super::local::{grow_rings, Local, Stats};
use super::{conformal, polish, smooth, topo, valid};
use super::{OperationCounts, OptimizeOptions, SurfaceOptimizeReport};
use crate::profile::StageTimer;
use glam::DVec3;

/// Optimizes one surface (see the module docs for the schedule).
pub(super) fn run_surface(
    l: &mut Local,
    opts: &OptimizeOptions,
    tick: &(dyn Fn(usize) + Sync),
) -> SurfaceOptimizeReport {
    let mut tm = StageTimer::new(opts.trace, "optimize", l.surface);
    l.build_adjacency();
    let before = l.stats();
    // validity: the start state and its invalid quads (valid.rs)
    let mut gate = valid::Gate::new(l);
    tm.lap("adj+stats");
    let mut ops = OperationCounts {
        smoothing_moves: smooth::smooth(l, first_sweeps(l, opts), opts.diagonal_weight),
        ..Default::default()
    };
    gate.check(l, true, "smoothing");
    lap_with_quality(&mut tm, l, "smooth");
    // progress: the steps given so far (the last call gives the rest of STEPS)
    let given = std::sync::atomic::AtomicUsize::new(0);
    let tick = |k: usize| {
        given.fetch_add(k, std::sync::atomic::Ordering::Relaxed);
        tick(k);
    };
    let tick = &tick;
    tick(1);
    let polish = opts.angle_sweeps > 0 && opts.smooth_iterations > 0;
    // speed: surfaces already good after the first smoothing skip the alternative schedules
    let small_planar = polish
        && l.planar
        && l.quads.len() < RESMOOTH_ALL_BELOW
        && l.stats().eta_mean < ALTERNATIVES_BELOW;
    // the state before the topology rounds, for the unsheared schedule
    let mut unsheared = (small_planar && opts.topology).then(|| (l.clone(), ops, gate.clone()));
    // quality: small planar surfaces try three schedules and keep the best (see `better` and
    // the module docs): after the topology rounds, finishing with square targets (β = 0)
    // beside the aspect-keeping finish, and topology rounds each followed by a conformal
    // solve. Other surfaces run the aspect-keeping one alone.
    // speed: the schedules are independent, so they run side by side (each is
    // deterministic, so the kept one does not depend on the thread count)
    let mut square: Option<(Local, OperationCounts)> = None;
    rayon::join(
        || {
            if opts.topology {
                topology_rounds(l, opts, &mut ops, &mut tm, tick, false, &mut gate);
            }
            // the square finish starts from the state after the topology rounds
            let fork = small_planar.then(|| (l.clone(), ops, gate.clone()));
            rayon::join(
                || {
                    if let Some((mut plain, mut plain_ops, mut plain_gate)) = fork {
                        let mut tp =
                            StageTimer::new(opts.trace, "optimize (square finish)", plain.surface);
                        finish(
                            &mut plain,
                            opts,
                            &mut plain_ops,
                            &mut tp,
                            0.0,
                            &mut plain_gate,
                        );
                        tp.done();
                        square = Some((plain, plain_ops));
                    }
                },
                || {
                    let keep = conformal::KEEP_ASPECT;
                    finish_ticking(l, opts, &mut ops, &mut tm, keep, &mut gate, tick)
                },
            );
        },
        || {
            if let Some((u, u_ops, u_gate)) = unsheared.as_mut() {
                let mut tu = StageTimer::new(opts.trace, "optimize (conformal rounds)", u.surface);
                topology_rounds(u, opts, u_ops, &mut tu, &|_| {}, true, u_gate);
                finish(u, opts, u_ops, &mut tu, conformal::KEEP_ASPECT, u_gate);
                tu.done();
            }
        },
    );
    if let Some((mut plain, plain_ops)) = square {
        let base = (plain.stats(), plain.tau_estimate());
        let mut best = (l.stats(), l.tau_estimate());
        if !better(&best, &base) {
            std::mem::swap(l, &mut plain);
            ops = plain_ops;
            best = base;
        }
        if let Some((u, u_ops, _)) = unsheared.as_mut() {
            let cand = (u.stats(), u.tau_estimate());
            if better(&cand, &best) && better(&cand, &base) {
                std::mem::swap(l, u);
                ops = *u_ops;
            }
        }
    }
    // validity: every schedule ends in a state its gate passed; check the kept one against
    // the start (rolls back to the start, the matching's quads, if it does not pass)
    gate.check(l, false, "optimization");
    tick(steps(opts).saturating_sub(given.load(std::sync::atomic::Ordering::Relaxed)));
    let after = l.stats();
    tm.lap("stats");
    tm.done();
    SurfaceOptimizeReport {
        surface: l.surface,
        before,
        after,
        operations: ops,
    }
}

/// True when `cand` (stats, τ estimate) should replace `base`: a higher η̄, η_w at most
/// [`ETA_W_SLACK`] lower and τ at most [`TAU_SLACK`] points lower.
fn better(cand: &(Stats, f64), base: &(Stats, f64)) -> bool {
    cand.0.eta_mean > base.0.eta_mean
        && cand.0.eta_worst >= base.0.eta_worst - ETA_W_SLACK
        && cand.1 >= base.1 - TAU_SLACK
}

/// How much lower η_w a schedule may end with than the plain one and still be chosen.
const ETA_W_SLACK: f64 = 0.002;

/// How many points lower τ ([`Local::tau_estimate`]) a schedule may end with than the plain
/// one and still be chosen: above what a schedule worth keeping has cost, below what a
/// harmful one has (the fixtures' figures are in BENCHMARKS.md, "Measurements behind the
/// defaults").
const TAU_SLACK: f64 = 0.7;

/// Tests: `l` in the state the last stages see in the pipeline (the first smoothing and the
/// topology rounds done), with the counts, timer and gate those stages continue with.
#[cfg(test)]
pub(crate) fn after_topology_rounds<'a>(
    l: &mut Local,
    opts: &OptimizeOptions<'a>,
) -> (OperationCounts, StageTimer<'a>, valid::Gate) {
    let mut ops = OperationCounts::default();
    let mut tm = StageTimer::new(opts.trace, "optimize", 0);
    smooth::smooth(l, first_sweeps(l, opts), opts.diagonal_weight);
    let mut gate = valid::Gate::new(l);
    topology_rounds(l, opts, &mut ops, &mut tm, &|_| {}, false, &mut gate);
    (ops, tm, gate)
}

/// Up to `opts.max_rounds` rounds of (topology pass, smoothing near the changes), each
/// followed by the conformal solve when `unshear` (the next pass then judges rotations and
/// merges on squarer quads and finds more).
/// Gives a progress tick per round.
fn topology_rounds(
    l: &mut Local,
    opts: &OptimizeOptions,
    ops: &mut OperationCounts,
    tm: &mut StageTimer<'_>,
    tick: &(dyn Fn(usize) + Sync),
    unshear: bool,
    gate: &mut valid::Gate,
) {
    // speed: around the changes of a topology pass on a large surface, 3/5 of the sweeps
    let near_its = (opts.smooth_iterations * NEAR_SWEEPS_NUM).div_ceil(5);
    // speed: after a pass, smooth only around what it changed (see `near_changes`), and
    // let the next pass's operators search only there (elsewhere they found nothing; see
    // BENCHMARKS.md)
    let mut focus: Option<Vec<bool>> = None;
    for _ in 0..opts.max_rounds {
        // the state before the pass, to find what it changed (a pass never adds quads,
        // so the surface size decides before it)
        let snapshot = (l.quads.len() >= RESMOOTH_ALL_BELOW)
            .then(|| (l.quads.clone(), l.alive.clone(), l.pos.clone()));
        // speed: on a large surface, the pass in two halves side by side (`halves`)
        let changed = if l.quads.len() >= HALVES_FROM {
            super::halves::pass(l, ops, focus.as_deref())
        } else {
            topo::pass(l, ops, focus.as_deref())
        };
        tm.lap("topo");
        if changed == 0 {
            break;
        }
        l.build_adjacency();
        ops.smoothing_moves += match &snapshot {
            None => smooth::smooth(l, opts.smooth_iterations, opts.diagonal_weight),
            Some(snapshot) => {
                let active = near_changes(l, snapshot, RESMOOTH_RINGS);
                focus = Some(active.clone());
                smooth::smooth_near(l, near_its, opts.diagonal_weight, active)
            }
        };
        lap_with_quality(tm, l, "resmooth");
        if unshear {
            ops.smoothing_moves += conformal::unshear(l, conformal::KEEP_ASPECT);
        }
        gate.check(l, true, "topology round");
        tick(1);
        // speed: on a large surface, a pass that changed under 1/ROUNDS_STOP_SHARE of the
        // quads is the last: the next ones find fewer still (see the constant)
        if snapshot.is_some() && changed * ROUNDS_STOP_SHARE < l.quads.len() {
            break;
        }
    }
}

/// Surfaces of this many quads or more run each topology pass in two halves side by side,
/// then along their seam (`halves`): the passes are serial and, at 10^5 quads and beyond,
/// a large share of the optimizer's time; below, the band along the seam is a large part
/// of the surface (figures in BENCHMARKS.md, "Measurements behind the defaults").
const HALVES_FROM: usize = 1 << 15;

/// Surfaces of [`RESMOOTH_ALL_BELOW`] quads or more stop their topology rounds after a pass
/// that changed fewer than one quad in this many: each pass changes about a tenth as much as
/// the one before, and the rounds after such a pass gained under 0.0005 η̄ and 0.1 point of
/// d4 (figures in BENCHMARKS.md, "Measurements behind the defaults").
const ROUNDS_STOP_SHARE: usize = 100;

/// The last stages: conformal solve (keeping `keep_aspect` of the aspect ratios), max-min
/// polish, pattern sweeps, mean-η polish.
pub(super) fn finish(
    l: &mut Local,
    opts: &OptimizeOptions,
    ops: &mut OperationCounts,
    tm: &mut StageTimer<'_>,
    keep_aspect: f64,
    gate: &mut valid::Gate,
) {
    finish_ticking(l, opts, ops, tm, keep_aspect, gate, &|_| {});
}

/// The progress steps of one surface: the first smoothing, each topology round, and the
/// four steps of [`finish`].
pub(super) fn steps(opts: &OptimizeOptions) -> usize {
    1 + opts.max_rounds + 4
}

/// [`finish`], giving a progress tick after each of its four steps.
fn finish_ticking(
    l: &mut Local,
    opts: &OptimizeOptions,
    ops: &mut OperationCounts,
    tm: &mut StageTimer<'_>,
    keep_aspect: f64,
    gate: &mut valid::Gate,
    tick: &(dyn Fn(usize) + Sync),
) {
    // quality: undo global shear the node-by-node smoothers cannot (conformal.rs)
    if opts.angle_sweeps > 0 && opts.smooth_iterations > 0 {
        ops.smoothing_moves += conformal::unshear(l, keep_aspect);
        gate.check(l, true, "conformal solve");
        lap_with_quality(tm, l, "conformal");
    }
    tick(1);
    // quality: lift the worst quads (max-min) first; the pattern search after it keeps
    // every star's worst key, so η_w stays
    if opts.angle_sweeps > 0 {
        let sweeps = by_size(l, WORST_SWEEPS, WORST_SWEEPS_LARGE);
        ops.smoothing_moves += smooth::polish_worst(l, sweeps);
        gate.check(l, true, "max-min polish");
        lap_with_quality(tm, l, "polish_worst");
        tick(1);
        let sweeps = by_size(l, opts.angle_sweeps, opts.angle_sweeps.div_ceil(2));
        ops.smoothing_moves += smooth::optimize_angles(l, sweeps);
        gate.check(l, true, "pattern search");
        lap_with_quality(tm, l, "angles");
        tick(1);
    }
    // then maximize the mean η, the worst of every star kept (polish.rs)
    if opts.smooth_iterations > 0 {
        let sweeps = by_size(l, polish::MEAN_SWEEPS_SMALL, polish::MEAN_SWEEPS);
        ops.smoothing_moves += polish::polish_mean(l, sweeps);
        gate.check(l, true, "mean polish");
        lap_with_quality(tm, l, "polish_mean");
    }
    // quality: on large surfaces, the max-min polish once more (see [`LAST_WORST_SWEEPS`])
    let last_worst = by_size(l, 0, LAST_WORST_SWEEPS);
    if opts.angle_sweeps > 0 && last_worst > 0 {
        ops.smoothing_moves += smooth::polish_worst(l, last_worst);
        gate.check(l, true, "max-min polish");
        lap_with_quality(tm, l, "polish_worst_again");
    }
    tick(1);
}

/// Sweeps of the max-min polish that ends the optimization of surfaces of
/// [`RESMOOTH_ALL_BELOW`] quads or more, after the mean polish (none on smaller ones). Those
/// surfaces also run half of `angle_sweeps` pattern sweeps (rounded up: 1 of the default 2):
/// with both changes they end with the same η̄, d4 and τ and an η_w as high or higher, since
/// the last max-min polish lifts the few quads the mean polish left below η 0.6 and visits
/// only their nodes (figures in BENCHMARKS.md, "Measurements behind the defaults").
const LAST_WORST_SWEEPS: usize = WORST_SWEEPS_LARGE;

/// Sweeps of the max-min polish ([`smooth::polish_worst`]) on surfaces under
/// [`RESMOOTH_ALL_BELOW`] quads.
const WORST_SWEEPS: usize = 4;

/// Sweeps of the max-min polish on surfaces of [`RESMOOTH_ALL_BELOW`] quads or more: after
/// the shorter first smoothing ([`FIRST_SWEEPS_NUM`]) four sweeps left one quad of the 1e5
/// rectangle fixture at η 0.593, eight lift it to 0.600. The sweeps only visit the nodes
/// around quads below η 0.6 and the neighbours of moved nodes, and stop when nothing moves,
/// so the extra ones cost next to nothing.
const WORST_SWEEPS_LARGE: usize = 8;

/// After a topological pass, smoothing starts from the nodes within this many quad rings of
/// the changes: about the quality of smoothing every node, at a fraction of the work
/// (figures in BENCHMARKS.md, "Measurements behind the defaults").
const RESMOOTH_RINGS: usize = 2;

/// Sweeps of the smoothing around a topology pass's changes on surfaces of
/// [`RESMOOTH_ALL_BELOW`] quads or more, in fifths of `smooth_iterations` (rounded up: 3 of
/// the default 5): the fewest that keep the quality of full sweeps (figures in
/// BENCHMARKS.md, "Measurements behind the defaults"; 2 cost η_w with the one-sweep first
/// smoothing of [`FIRST_SWEEPS_NUM`]).
const NEAR_SWEEPS_NUM: usize = 3;

/// Sweeps of the first smoothing on surfaces of [`RESMOOTH_ALL_BELOW`] quads or more, in
/// fifths of `smooth_iterations` (rounded up: 1 of the default 5). The topology rounds
/// re-smooth around every change and the conformal solve removes the low-frequency
/// distortion later, so the further sweeps gain no final quality (figures in
/// BENCHMARKS.md, "Measurements behind the defaults").
const FIRST_SWEEPS_NUM: usize = 1;

/// Sweeps of the first smoothing of `l`: all of `smooth_iterations` on surfaces under
/// [`RESMOOTH_ALL_BELOW`] quads, [`FIRST_SWEEPS_NUM`] fifths of them (rounded up) on larger
/// ones; 0 when smoothing is off.
fn first_sweeps(l: &Local, opts: &OptimizeOptions) -> usize {
    let n = opts.smooth_iterations;
    by_size(l, n, (n * FIRST_SWEEPS_NUM).div_ceil(5))
}

/// `small` on surfaces under [`RESMOOTH_ALL_BELOW`] quads, `large` on the others: the
/// schedule's one size switch for sweep counts.
fn by_size(l: &Local, small: usize, large: usize) -> usize {
    if l.quads.len() < RESMOOTH_ALL_BELOW {
        small
    } else {
        large
    }
}

/// Surfaces with fewer quads re-smooth every node after each topological pass: cheap there,
/// and on small curved surfaces local re-smoothing alone loses mean quality (figures in
/// BENCHMARKS.md, "Measurements behind the defaults").
pub(super) const RESMOOTH_ALL_BELOW: usize = 20_000;

/// Small planar surfaces try the alternative schedules (module docs) only when their mean η
/// after the first smoothing is below this: surfaces already above it gain next to nothing
/// from them, for most of their time (figures in BENCHMARKS.md, "Measurements behind the
/// defaults").
const ALTERNATIVES_BELOW: f64 = 0.84;

/// Nodes within `rings` quad rings of what a topological pass changed, given the quads,
/// liveness and positions before it: nodes of quads that were rewritten, created or removed,
/// and nodes that moved. Needs a current adjacency.
fn near_changes(
    l: &Local,
    (quads, alive, pos): &(Vec<[u32; 4]>, Vec<bool>, Vec<DVec3>),
    rings: usize,
) -> Vec<bool> {
    let n = l.pos.len();
    let mut mark = vec![false; n];
    for (q, quad) in l.quads.iter().enumerate() {
        let same = quads.get(q) == Some(quad) && alive.get(q) == Some(&l.alive[q]);
        if !same {
            for &v in quad.iter().chain(quads.get(q).into_iter().flatten()) {
                mark[v as usize] = true;
            }
        }
    }
    for (v, m) in mark.iter_mut().enumerate() {
        if pos.get(v) != Some(&l.pos[v]) {
            *m = true;
        }
    }
    grow_rings(l, &mut mark, rings);
    mark
}

/// Ends stage `name` of `tm`; with a trace sink, also sends the quads' quality after it
/// ([`TraceEvent::StageQuality`](crate::profile::TraceEvent::StageQuality)), computed off
/// the clock. The adjacency of `l` must be current (its d4 count reads it).
fn lap_with_quality(tm: &mut StageTimer<'_>, l: &Local, name: &'static str) {
    tm.lap(name);
    if let Some(trace) = tm.trace() {
        let s = l.stats();
        let (group, surface) = tm.step();
        trace.emit(&crate::profile::TraceEvent::StageQuality {
            group,
            surface,
            stage: name,
            quads: s.quads,
            eta_worst: s.eta_worst,
            eta_mean: s.eta_mean,
            d4_percent: s.d4_percent,
        });
        tm.restart();
    }
}
