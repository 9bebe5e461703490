//! The stages of one surface and their order (see the module docs of `optimize`): first
//! smoothing, topology rounds with smoothing near their changes, the conformal solve, the
//! polish stages, and on small planar surfaces the choice among three schedules.

use super::local::{grow_rings, Local, Stats};
use super::{conformal, polish, smooth, topo, valid};
use super::{OperationCounts, OptimizeOptions, SurfaceOptimizeReport};
use crate::profile::StageTimer;
use glam::DVec3;

/// Optimizes one surface (see the module docs for the schedule).
/// `main`: the surface holds half of the reference's triangles or more (see [`plan`]).
pub(super) fn run_surface(
    l: &mut Local,
    opts: &OptimizeOptions,
    main: bool,
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
    match plan(l, opts, polish, main) {
        Plan::One => {
            if opts.topology {
                topology_rounds(l, opts, &mut ops, &mut tm, tick, false, &mut gate);
            }
            let keep = conformal::KEEP_ASPECT;
            finish_ticking(l, opts, &mut ops, &mut tm, keep, &mut gate, tick);
        }
        Plan::Trial => {
            let start = opts.topology.then(|| (l.clone(), ops, gate.clone()));
            trial(l, opts, &mut ops, &mut tm, tick, &mut gate, start);
        }
        Plan::Single { unshear } => {
            topology_rounds(l, opts, &mut ops, &mut tm, tick, unshear, &mut gate);
            let keep = conformal::KEEP_ASPECT;
            finish_ticking(l, opts, &mut ops, &mut tm, keep, &mut gate, tick);
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

/// How a surface's optimization goes on after its first smoothing.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Plan {
    /// One schedule: topology rounds, then the aspect-keeping finish.
    One,
    /// The three schedules side by side, the best kept (see [`trial`]).
    Trial,
    /// One of the trial's schedules, chosen from the first smoothing: the topology rounds
    /// each followed by the conformal solve (`unshear`), or the plain one.
    Single {
        /// The topology rounds each followed by the conformal solve.
        unshear: bool,
    },
}

/// The plan of `l` after its first smoothing: small planar surfaces with a low mean η
/// ([`ALTERNATIVES_BELOW`]) choose among three schedules, by trying them all when they have
/// fewer than [`SINGLE_FROM`] quads, when they are the mesh's `main` surface (half of the
/// reference's triangles or more: its choice is the mesh's) or without topology rounds,
/// and otherwise from the mean η ([`UNSHEAR_BELOW`]); other surfaces run one schedule.
fn plan(l: &Local, opts: &OptimizeOptions, polish: bool, main: bool) -> Plan {
    if !(polish && l.planar && l.quads.len() < SCHEDULE_CHOICE_BELOW) {
        return Plan::One;
    }
    let mean = l.stats().eta_mean;
    if mean >= ALTERNATIVES_BELOW {
        Plan::One
    } else if main || !opts.topology || l.quads.len() < SINGLE_FROM {
        Plan::Trial
    } else {
        Plan::Single {
            unshear: mean < UNSHEAR_BELOW,
        }
    }
}

/// A schedule's state, with its operation counts and validity gate.
type Branch = (Local, OperationCounts, valid::Gate);

/// The three schedules of a small planar surface, side by side, keeping the best in `l`
/// (see [`keep_best`]): after the topology rounds, finishing with square targets (β = 0)
/// beside the aspect-keeping finish, and (from `start`, the state after the first
/// smoothing, when given) topology rounds each followed by a conformal solve. `l`, `ops`
/// and `gate` run the aspect-keeping one, with progress ticks.
fn trial(
    l: &mut Local,
    opts: &OptimizeOptions,
    ops: &mut OperationCounts,
    tm: &mut StageTimer<'_>,
    tick: &(dyn Fn(usize) + Sync),
    gate: &mut valid::Gate,
    mut start: Option<Branch>,
) {
    // speed: the schedules are independent, so they run side by side (each is
    // deterministic, so the kept one does not depend on the thread count)
    let mut square: Option<Branch> = None;
    rayon::join(
        || {
            if opts.topology {
                topology_rounds(l, opts, ops, tm, tick, false, gate);
            }
            // the square finish starts from the state after the topology rounds
            let fork = (l.clone(), *ops, gate.clone());
            rayon::join(
                || square = Some(square_finish(opts, fork)),
                || {
                    let keep = conformal::KEEP_ASPECT;
                    finish_ticking(l, opts, ops, tm, keep, gate, tick)
                },
            );
        },
        || {
            if let Some(u) = start.as_mut() {
                unsheared_schedule(opts, u);
            }
        },
    );
    if let Some(sq) = square {
        keep_best(l, ops, sq, start);
    }
}

/// The square finish (β = 0) of the state after the plain topology rounds.
fn square_finish(opts: &OptimizeOptions, (mut l, mut ops, mut gate): Branch) -> Branch {
    let mut tp = StageTimer::new(opts.trace, "optimize (square finish)", l.surface);
    finish(&mut l, opts, &mut ops, &mut tp, 0.0, &mut gate);
    tp.done();
    (l, ops, gate)
}

/// The schedule whose topology rounds are each followed by the conformal solve, run on
/// `u` (the state after the first smoothing).
fn unsheared_schedule(opts: &OptimizeOptions, (u, u_ops, u_gate): &mut Branch) {
    let mut tu = StageTimer::new(opts.trace, "optimize (conformal rounds)", u.surface);
    topology_rounds(u, opts, u_ops, &mut tu, &|_| {}, true, u_gate);
    finish(u, opts, u_ops, &mut tu, conformal::KEEP_ASPECT, u_gate);
    tu.done();
}

/// Keeps in `l` (the aspect-keeping schedule's result) the best of it, `square` and
/// `unsheared` by [`better`]: the square finish unless the aspect-keeping one is better,
/// then the unsheared schedule if better than both.
fn keep_best(
    l: &mut Local,
    ops: &mut OperationCounts,
    (mut square, square_ops, _): Branch,
    unsheared: Option<Branch>,
) {
    let base = (square.stats(), square.tau_estimate());
    let mut best = (l.stats(), l.tau_estimate());
    if !better(&best, &base) {
        std::mem::swap(l, &mut square);
        *ops = square_ops;
        best = base;
    }
    if let Some((mut u, u_ops, _)) = unsheared {
        let cand = (u.stats(), u.tau_estimate());
        if better(&cand, &best) && better(&cand, &base) {
            std::mem::swap(l, &mut u);
            *ops = u_ops;
        }
    }
}

/// Small planar surfaces of this many quads or more ([`Plan::Single`]) run one schedule
/// chosen from their first smoothing instead of the three side by side (figures in
/// BENCHMARKS.md, "Measurements behind the defaults").
const SINGLE_FROM: usize = 1000;

/// Small planar surfaces of [`SINGLE_FROM`] quads or more whose mean η after the first
/// smoothing is below this run the topology rounds each followed by the conformal solve;
/// above it, the plain schedule (figures in BENCHMARKS.md, "Measurements behind the
/// defaults").
const UNSHEAR_BELOW: f64 = 0.81;

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
        let snapshot = large(l).then(|| (l.quads.clone(), l.alive.clone(), l.pos.clone()));
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
            let mg = opts.conformal_multigrid;
            ops.smoothing_moves += conformal::unshear(l, conformal::KEEP_ASPECT, mg);
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

/// Surfaces of [`LARGE_SURFACE_FROM`] quads or more stop their topology rounds after a pass
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
        ops.smoothing_moves += conformal::unshear(l, keep_aspect, opts.conformal_multigrid);
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
/// [`LARGE_SURFACE_FROM`] quads or more, after the mean polish (none on smaller ones). Those
/// surfaces also run half of `angle_sweeps` pattern sweeps (rounded up: 1 of the default 2):
/// with both changes they end with the same η̄, d4 and τ and an η_w as high or higher, since
/// the last max-min polish lifts the few quads the mean polish left below η 0.6 and visits
/// only their nodes (figures in BENCHMARKS.md, "Measurements behind the defaults").
const LAST_WORST_SWEEPS: usize = WORST_SWEEPS_LARGE;

/// Sweeps of the max-min polish ([`smooth::polish_worst`]) on surfaces under
/// [`LARGE_SURFACE_FROM`] quads.
const WORST_SWEEPS: usize = 4;

/// Sweeps of the max-min polish on surfaces of [`LARGE_SURFACE_FROM`] quads or more: after
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
/// [`LARGE_SURFACE_FROM`] quads or more, in fifths of `smooth_iterations` (rounded up: 3 of
/// the default 5): the fewest that keep the quality of full sweeps (figures in
/// BENCHMARKS.md, "Measurements behind the defaults"; 2 cost η_w with the one-sweep first
/// smoothing of [`FIRST_SWEEPS_NUM`]).
const NEAR_SWEEPS_NUM: usize = 3;

/// Sweeps of the first smoothing on surfaces of [`LARGE_SURFACE_FROM`] quads or more, in
/// fifths of `smooth_iterations` (rounded up: 1 of the default 5). The topology rounds
/// re-smooth around every change and the conformal solve removes the low-frequency
/// distortion later, so the further sweeps gain no final quality (figures in
/// BENCHMARKS.md, "Measurements behind the defaults").
const FIRST_SWEEPS_NUM: usize = 1;

/// Sweeps of the first smoothing of `l`: all of `smooth_iterations` on surfaces under
/// [`LARGE_SURFACE_FROM`] quads, [`FIRST_SWEEPS_NUM`] fifths of them (rounded up) on larger
/// ones; 0 when smoothing is off.
fn first_sweeps(l: &Local, opts: &OptimizeOptions) -> usize {
    let n = opts.smooth_iterations;
    by_size(l, n, (n * FIRST_SWEEPS_NUM).div_ceil(5))
}

/// `small` on small surfaces, `big` on large ones ([`large`]): the schedule's one size
/// switch for sweep counts.
fn by_size(l: &Local, small: usize, big: usize) -> usize {
    if large(l) {
        big
    } else {
        small
    }
}

/// True when `l` runs the sweeps of large surfaces: it has [`LARGE_SURFACE_FROM`] quads or
/// more, or its mesh has [`LARGE_MESH_FROM`] reference triangles or more.
fn large(l: &Local) -> bool {
    l.quads.len() >= LARGE_SURFACE_FROM || l.in_large_mesh
}

/// Reference triangles from which every surface of a mesh runs the sweeps of large surfaces
/// (a share of the sweeps in the first smoothing and near the changes, the rounds stopped
/// after a pass that changed little, half the pattern sweeps, one mean polish, the max-min
/// polish again at the end); the choice among schedules stays the surface's own. On a mesh
/// of many smaller surfaces the full sweeps of each cost about twice the time for 0.003 of
/// η̄ (figures in BENCHMARKS.md, "Measurements behind the defaults").
pub(crate) const LARGE_MESH_FROM: usize = 1 << 19;

/// Surfaces with fewer quads run the sweeps of small surfaces ([`large`]): every node
/// re-smoothed after each topological pass, full sweep counts. Cheap there, and on small
/// curved surfaces local re-smoothing alone loses mean quality; from 10^4 quads on, the
/// light sweeps end within 0.003 of η̄ at about half the optimizer's time (figures in
/// BENCHMARKS.md, "Measurements behind the defaults").
pub(super) const LARGE_SURFACE_FROM: usize = 10_000;

/// Planar surfaces with fewer quads may choose among three schedules ([`plan`]) and keep
/// their reference triangles for the τ estimates that choice needs.
pub(super) const SCHEDULE_CHOICE_BELOW: usize = 20_000;

/// Small planar surfaces choose among the three schedules ([`plan`]) only when their mean η
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::optimize::cleanup::tests::local_of;
    use crate::optimize::synth;

    /// The plan of a small planar surface with a low mean η: the trial under
    /// [`SINGLE_FROM`] quads or as the mesh's main surface, one schedule otherwise.
    #[test]
    fn larger_surfaces_that_are_not_the_mesh_run_one_schedule() {
        let opts = OptimizeOptions::default();
        let quads = (1u64..20)
            .find_map(|seed| synth::pair_optimal(&synth::delaunay_square(36, 1.0, 0.3, seed)))
            .expect("an even, matchable square");
        let (_, l) = local_of(&synth::to_mesh(&quads));
        assert!(
            l.quads.len() >= SINGLE_FROM && l.planar,
            "{} quads",
            l.quads.len()
        );
        let mean = l.stats().eta_mean;
        assert!(mean < ALTERNATIVES_BELOW, "mean η {mean}");
        let single = Plan::Single {
            unshear: mean < UNSHEAR_BELOW,
        };
        assert_eq!(plan(&l, &opts, true, false), single);
        assert_eq!(plan(&l, &opts, true, true), Plan::Trial);
        assert_eq!(plan(&l, &opts, false, false), Plan::One);
    }
}
