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
#[cfg(test)]
pub(super) fn run_surface(
    l: &mut Local,
    opts: &OptimizeOptions,
    main: bool,
    tick: &(dyn Fn(usize) + Sync),
) -> SurfaceOptimizeReport {
    run_surface_deferring(l, opts, main, false, tick).0
}

/// [`run_surface`], except that with `defer` a small planar surface that would try the
/// three schedules side by side ([`trial`]), not being the mesh's main surface, runs only
/// the one its mean η chooses and returns, with that result, what the other two need
/// ([`Deferred`]): whether they run depends on the worst quad of the whole mesh
/// ([`finish_deferred`]).
pub(super) fn run_surface_deferring(
    l: &mut Local,
    opts: &OptimizeOptions,
    main: bool,
    defer: bool,
    tick: &(dyn Fn(usize) + Sync),
) -> (SurfaceOptimizeReport, Option<Deferred>) {
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
    let mut deferred = None;
    match plan(l, opts, polish, main) {
        Plan::Trial { unshear } if defer && defers(l, opts, main) => {
            let (ops, tm, gate) = (&mut ops, &mut tm, &mut gate);
            deferred = Some(chosen_keeping_starts(l, opts, unshear, ops, tm, tick, gate));
        }
        Plan::One => {
            if opts.topology {
                topology_rounds(l, opts, &mut ops, &mut tm, tick, false, &mut gate);
            }
            let keep = conformal::KEEP_ASPECT;
            finish_ticking(l, opts, &mut ops, &mut tm, keep, &mut gate, tick);
        }
        Plan::Trial { .. } => trial(l, opts, &mut ops, &mut tm, tick, &mut gate),
        Plan::Single { unshear } => {
            topology_rounds(l, opts, &mut ops, &mut tm, tick, unshear, &mut gate);
            let keep = conformal::KEEP_ASPECT;
            finish_ticking(l, opts, &mut ops, &mut tm, keep, &mut gate, tick);
        }
    }
    // a deferred trial completes from the chosen schedule's state before the last check
    let deferred = deferred.map(|starts| Deferred {
        chosen: (l.clone(), ops, gate.clone()),
        starts,
    });
    // validity: every schedule ends in a state its gate passed; check the kept one against
    // the start (rolls back to the start, the matching's quads, if it does not pass)
    gate.check(l, false, "optimization");
    tick(steps(opts).saturating_sub(given.load(std::sync::atomic::Ordering::Relaxed)));
    let after = l.stats();
    tm.lap("stats");
    tm.done();
    let report = SurfaceOptimizeReport {
        surface: l.surface,
        before,
        after,
        operations: ops,
    };
    (report, deferred)
}

/// A surface's trial put off ([`run_surface_deferring`]): the schedule its mean η chose,
/// before its last validity check, and the states the other two start from.
pub(super) struct Deferred {
    chosen: Branch,
    starts: Starts,
}

/// The states the two schedules a surface did not run start from ([`chosen_keeping_starts`]).
enum Starts {
    /// The chosen schedule is the plain one.
    Plain {
        /// Its state after its first topology pass and smoothing, with its rounds: the
        /// unsheared schedule's start; none when that pass changed nothing (the unsheared
        /// schedule would then be the plain one, and [`trial`] does not run it).
        first: Option<(Branch, Rounds)>,
        /// Its state after its topology rounds: the square finish's start (boxed: a variant
        /// holding two states beside one).
        rounds_done: Box<Branch>,
    },
    /// The chosen schedule is the unsheared one (its first pass changed something).
    Unsheared {
        /// The plain schedule's state after its first topology pass and smoothing, with its
        /// rounds: the plain schedule's start (and through it the square finish's).
        first: (Branch, Rounds),
    },
}

/// Reference triangles from which a mesh puts off the trials of its small planar surfaces
/// ([`run_surface_deferring`]): on smaller meshes every such surface tries the three
/// schedules, which cost little there and each of which moves η̄ (a few surfaces of a few
/// dozen quads each make the whole mesh; figures in BENCHMARKS.md, "Measurements behind
/// the defaults").
pub(super) const TRIAL_BUDGET_FROM: usize = 2000;

/// Extra η over the mesh's worst quad below which a surface's chosen schedule leaves its
/// worst quad for the surface to try the other two ([`finish_deferred`]): where the
/// surface holds the mesh's worst quad or nearly, the trial can raise the mesh's η_w;
/// elsewhere it changes η̄ by little. On the corpus runs of 2,000 triangles or more most
/// trials are skipped, for the same η̄ and η_w within 0.005 (figures in BENCHMARKS.md,
/// "Measurements behind the defaults").
pub(super) const TRIAL_MARGIN: f64 = 0.02;

/// True when the trial of a small planar surface is put off until the mesh's worst quad
/// after every surface's chosen schedule is known: with topology rounds (whose first pass
/// the schedules share), not the mesh's main surface (whose choice is the mesh's), and
/// compared only at the end ([`CUT_TRIAL_FROM`]).
fn defers(l: &Local, opts: &OptimizeOptions, main: bool) -> bool {
    opts.topology && !main && l.quads.len() < CUT_TRIAL_FROM
}

/// The schedule the plan chose for a small planar surface (`unshear`, [`Plan::Trial`]:
/// [`Plan::Single`]'s choice), run on `l` with `ops`, `gate` and progress ticks, keeping
/// the states [`trial`]'s other schedules start from: each schedule is deterministic, so
/// completing the trial from them ([`finish_deferred`]) gives [`trial`]'s result. Where
/// the first topology pass changes nothing, the unsheared schedule is the plain one.
fn chosen_keeping_starts(
    l: &mut Local,
    opts: &OptimizeOptions,
    unshear: bool,
    ops: &mut OperationCounts,
    tm: &mut StageTimer<'_>,
    tick: &(dyn Fn(usize) + Sync),
    gate: &mut valid::Gate,
) -> Starts {
    let mut rounds = Rounds::new(opts);
    let first = rounds
        .pass_and_smooth(l, opts, ops, tm)
        .then(|| ((l.clone(), *ops, gate.clone()), rounds.clone()));
    let starts = match first {
        Some(first) if unshear => {
            rounds.run(l, opts, ops, tm, tick, true, gate);
            Starts::Unsheared { first }
        }
        first => {
            rounds.run(l, opts, ops, tm, tick, false, gate);
            let rounds_done = Box::new((l.clone(), *ops, gate.clone()));
            Starts::Plain { first, rounds_done }
        }
    };
    finish_ticking(l, opts, ops, tm, conformal::KEEP_ASPECT, gate, tick);
    starts
}

/// Completes a deferred trial ([`run_surface_deferring`]) when the chosen schedule left
/// the surface's worst quad within [`TRIAL_MARGIN`] of `worst` (the mesh's worst quad
/// after every surface's chosen schedule): the other two schedules run from their starts
/// and `l` gets [`trial`]'s result, checked against the start; otherwise `l` and `report`
/// stay the chosen schedule's.
pub(super) fn finish_deferred(
    l: &mut Local,
    opts: &OptimizeOptions,
    mut report: SurfaceOptimizeReport,
    d: Deferred,
    worst: f64,
) -> SurfaceOptimizeReport {
    if report.after.eta_worst >= worst + TRIAL_MARGIN {
        return report;
    }
    let mut tm = StageTimer::new(opts.trace, "optimize (deferred trial)", l.surface);
    let Deferred { chosen, starts } = d;
    let keep = conformal::KEEP_ASPECT;
    let ((mut k, mut ops, mut gate), square, unsheared) = match starts {
        // the chosen one is the plain schedule: the square finish from its rounds, the
        // unsheared schedule from its first pass
        Starts::Plain { first, rounds_done } => {
            let (square, unsheared) = rayon::join(
                || square_finish(opts, *rounds_done, false),
                || {
                    first.map(|(mut u, mut r)| {
                        unsheared_schedule(opts, &mut u, &mut r, false);
                        u
                    })
                },
            );
            (chosen, square, unsheared)
        }
        // the chosen one is the unsheared schedule: the plain one from the first pass,
        // and the square finish from its rounds
        Starts::Unsheared { first } => {
            let ((mut p, mut p_ops, mut p_gate), mut rounds) = first;
            rounds.run(&mut p, opts, &mut p_ops, &mut tm, &|_| {}, false, &mut p_gate);
            let fork = (p.clone(), p_ops, p_gate.clone());
            let (square, ()) = rayon::join(
                || square_finish(opts, fork, false),
                || {
                    finish_head(&mut p, opts, &mut p_ops, &mut tm, keep, &mut p_gate, &|_| {});
                    finish_tail(&mut p, opts, &mut p_ops, &mut tm, &mut p_gate, &|_| {});
                },
            );
            ((p, p_ops, p_gate), square, Some(chosen))
        }
    };
    keep_best(&mut k, &mut ops, &mut gate, square, unsheared);
    gate.check(&mut k, false, "optimization");
    *l = k;
    report.after = l.stats();
    report.operations = ops;
    tm.lap("stats");
    tm.done();
    report
}

/// How a surface's optimization goes on after its first smoothing.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Plan {
    /// One schedule: topology rounds, then the aspect-keeping finish.
    One,
    /// The three schedules side by side, the best kept (see [`trial`]); `unshear` is the
    /// one [`Plan::Single`] would run, which a put-off trial runs first
    /// ([`run_surface_deferring`]).
    Trial {
        /// The topology rounds each followed by the conformal solve.
        unshear: bool,
    },
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
    let unshear = mean < UNSHEAR_BELOW;
    if mean >= ALTERNATIVES_BELOW {
        Plan::One
    } else if tries(l, opts, main) {
        Plan::Trial { unshear }
    } else {
        Plan::Single { unshear }
    }
}

/// True when a small planar surface with a low mean η tries the three schedules rather
/// than choosing one from its mean η ([`plan`]).
fn tries(l: &Local, opts: &OptimizeOptions, main: bool) -> bool {
    main || !opts.topology || l.quads.len() < SINGLE_FROM
}

/// True when `l` may try the three schedules ([`Plan::Trial`], depending on its mean η
/// after the first smoothing): the one use of a planar surface's reference triangles, in
/// the τ estimates of [`keep_best`]. Reads what is known before the first smoothing;
/// `main` as for [`run_surface`].
pub(super) fn may_try(l: &Local, opts: &OptimizeOptions, main: bool) -> bool {
    let polish = opts.angle_sweeps > 0 && opts.smooth_iterations > 0;
    polish && l.planar && l.quads.len() < SCHEDULE_CHOICE_BELOW && tries(l, opts, main)
}

/// A schedule's state, with its operation counts and validity gate.
type Branch = (Local, OperationCounts, valid::Gate);

/// The three schedules of a small planar surface, side by side, keeping the best in `l`
/// (see [`keep_best`]): after the topology rounds, finishing with square targets (β = 0)
/// beside the aspect-keeping finish, and (with topology rounds) the rounds each followed by
/// a conformal solve. `l`, `ops` and `gate` run the aspect-keeping one, with progress
/// ticks, and end with the kept schedule's. On surfaces of [`CUT_TRIAL_FROM`] quads or
/// more the schedules stop after the max-min polish ([`finish_head`]), and only the kept
/// one runs the rest of the finish ([`finish_tail`]).
fn trial(
    l: &mut Local,
    opts: &OptimizeOptions,
    ops: &mut OperationCounts,
    tm: &mut StageTimer<'_>,
    tick: &(dyn Fn(usize) + Sync),
    gate: &mut valid::Gate,
) {
    // speed: on larger surfaces the schedules are compared before their last, costliest
    // stages (see the constant)
    let cut = l.quads.len() >= CUT_TRIAL_FROM;
    // speed: the first round's pass and smoothing are the same in the plain and the
    // unsheared schedule (the conformal solve comes after them), so the unsheared one
    // starts from a copy after them. When that pass changed nothing, it would repeat the
    // plain schedule, which it replaces only with a higher η̄, so it does not run.
    let mut rounds = Rounds::new(opts);
    let mut unsheared: Option<(Branch, Rounds)> = None;
    if opts.topology && rounds.pass_and_smooth(l, opts, ops, tm) {
        unsheared = Some(((l.clone(), *ops, gate.clone()), rounds.clone()));
    }
    // speed: the schedules are independent, so they run side by side (each is
    // deterministic, so the kept one does not depend on the thread count)
    let mut square: Option<Branch> = None;
    rayon::join(
        || {
            if opts.topology {
                rounds.run(l, opts, ops, tm, tick, false, gate);
            }
            // the square finish starts from the state after the topology rounds
            let fork = (l.clone(), *ops, gate.clone());
            rayon::join(
                || square = Some(square_finish(opts, fork, cut)),
                || {
                    let keep = conformal::KEEP_ASPECT;
                    finish_head(l, opts, ops, tm, keep, gate, tick);
                    if !cut {
                        finish_tail(l, opts, ops, tm, gate, tick);
                    }
                },
            );
        },
        || {
            if let Some((u, r)) = unsheared.as_mut() {
                unsheared_schedule(opts, u, r, cut);
            }
        },
    );
    if let Some(sq) = square {
        keep_best(l, ops, gate, sq, unsheared.map(|(u, _)| u));
    }
    if cut {
        finish_tail(l, opts, ops, tm, gate, tick);
    }
}

/// Small planar surfaces of this many quads or more that try the three schedules
/// ([`trial`]) compare them after the max-min polish, and only the kept one runs the
/// pattern sweeps and the mean polish, which raise η̄ by about as much in each schedule.
/// On these surfaces (main surfaces, or any without topology rounds) no output of the
/// corpus runs or of Gmsh's example meshes lost 0.005 of η̄ or η_w; choosing that early on
/// smaller ones as well lost up to 0.029 of η_w or 0.012 of η̄ on 9 of those models, for
/// little time (figures in BENCHMARKS.md, "Measurements behind the defaults").
const CUT_TRIAL_FROM: usize = SINGLE_FROM;

/// The square finish (β = 0) of the state after the plain topology rounds; with `cut`,
/// only up to the max-min polish ([`finish_head`]).
fn square_finish(opts: &OptimizeOptions, (mut l, mut ops, mut gate): Branch, cut: bool) -> Branch {
    let mut tp = StageTimer::new(opts.trace, "optimize (square finish)", l.surface);
    finish_head(&mut l, opts, &mut ops, &mut tp, 0.0, &mut gate, &|_| {});
    if !cut {
        finish_tail(&mut l, opts, &mut ops, &mut tp, &mut gate, &|_| {});
    }
    tp.done();
    (l, ops, gate)
}

/// The schedule whose topology rounds are each followed by the conformal solve, run on
/// `u` from the middle of the first round (`rounds`: its pass and smoothing done); with
/// `cut`, only up to the max-min polish ([`finish_head`]).
fn unsheared_schedule(
    opts: &OptimizeOptions,
    (u, u_ops, u_gate): &mut Branch,
    rounds: &mut Rounds,
    cut: bool,
) {
    let mut tu = StageTimer::new(opts.trace, "optimize (conformal rounds)", u.surface);
    rounds.run(u, opts, u_ops, &mut tu, &|_| {}, true, u_gate);
    let keep = conformal::KEEP_ASPECT;
    finish_head(u, opts, u_ops, &mut tu, keep, u_gate, &|_| {});
    if !cut {
        finish_tail(u, opts, u_ops, &mut tu, u_gate, &|_| {});
    }
    tu.done();
}

/// Keeps in `l`, `ops` and `gate` (the aspect-keeping schedule's) the best of it, `square`
/// and `unsheared` by [`better`]: the square finish unless the aspect-keeping one is
/// better, then the unsheared schedule if better than both. A schedule's τ estimate is
/// computed only when a comparison gets to it (the η terms come first).
fn keep_best(
    l: &mut Local,
    ops: &mut OperationCounts,
    gate: &mut valid::Gate,
    (mut square, square_ops, mut square_gate): Branch,
    unsheared: Option<Branch>,
) {
    let (plain_kept, take_unsheared) = {
        let taus: [std::cell::OnceCell<f64>; 3] = Default::default();
        let plain = (l.stats(), || *taus[0].get_or_init(|| l.tau_estimate()));
        let base = (square.stats(), || *taus[1].get_or_init(|| square.tau_estimate()));
        let plain_kept = better(&plain, &base);
        let take_unsheared = unsheared.as_ref().is_some_and(|(u, _, _)| {
            let cand = (u.stats(), || *taus[2].get_or_init(|| u.tau_estimate()));
            let beats_best = if plain_kept {
                better(&cand, &plain)
            } else {
                better(&cand, &base)
            };
            beats_best && better(&cand, &base)
        });
        (plain_kept, take_unsheared)
    };
    if !plain_kept {
        std::mem::swap(l, &mut square);
        std::mem::swap(gate, &mut square_gate);
        *ops = square_ops;
    }
    if let (true, Some((mut u, u_ops, mut u_gate))) = (take_unsheared, unsheared) {
        std::mem::swap(l, &mut u);
        std::mem::swap(gate, &mut u_gate);
        *ops = u_ops;
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
/// [`ETA_W_SLACK`] lower and τ at most [`TAU_SLACK`] points lower. The τ estimates are
/// asked for only when the η terms hold.
fn better(cand: &(Stats, impl Fn() -> f64), base: &(Stats, impl Fn() -> f64)) -> bool {
    cand.0.eta_mean > base.0.eta_mean
        && cand.0.eta_worst >= base.0.eta_worst - ETA_W_SLACK
        && cand.1() >= base.1() - TAU_SLACK
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
    Rounds::new(opts).run(l, opts, ops, tm, tick, unshear, gate);
}

/// Where a surface's topology rounds are ([`topology_rounds`]): a round is its pass and
/// smoothing ([`Rounds::pass_and_smooth`]), then the rest ([`Rounds::close`]), so that two
/// schedules can share a round's first part.
#[derive(Clone)]
struct Rounds {
    /// Rounds not yet started.
    left: usize,
    /// The nodes the next pass searches around (large surfaces, after a pass).
    focus: Option<Vec<bool>>,
    /// The round in the middle: its pass changed this many quads, on a large surface.
    open: Option<(usize, bool)>,
}

impl Rounds {
    /// No round started, up to `opts.max_rounds`.
    fn new(opts: &OptimizeOptions) -> Self {
        Rounds {
            left: opts.max_rounds,
            focus: None,
            open: None,
        }
    }

    /// The remaining rounds (closing the one in the middle first), each followed by the
    /// conformal solve when `unshear`.
    #[allow(clippy::too_many_arguments)]
    fn run(
        &mut self,
        l: &mut Local,
        opts: &OptimizeOptions,
        ops: &mut OperationCounts,
        tm: &mut StageTimer<'_>,
        tick: &(dyn Fn(usize) + Sync),
        unshear: bool,
        gate: &mut valid::Gate,
    ) {
        loop {
            if self.open.is_some() {
                self.close(l, opts, ops, tick, unshear, gate);
            }
            if !self.pass_and_smooth(l, opts, ops, tm) {
                return;
            }
        }
    }

    /// Starts the next round: the topology pass and the smoothing near its changes (of every
    /// node on small surfaces). False, with nothing changed, when no round is left or the
    /// pass changed nothing (the rounds are over).
    fn pass_and_smooth(
        &mut self,
        l: &mut Local,
        opts: &OptimizeOptions,
        ops: &mut OperationCounts,
        tm: &mut StageTimer<'_>,
    ) -> bool {
        if self.left == 0 {
            return false;
        }
        self.left -= 1;
        // speed: around the changes of a topology pass on a large surface, 3/5 of the sweeps
        let near_its = (opts.smooth_iterations * NEAR_SWEEPS_NUM).div_ceil(5);
        // the state before the pass, to find what it changed (a pass never adds quads,
        // so the surface size decides before it)
        let snapshot = large(l).then(|| (l.quads.clone(), l.alive.clone(), l.pos.clone()));
        // speed: on a large surface, the pass in two halves side by side (`halves`); after
        // a pass, the operators search only near its changes (elsewhere they found
        // nothing; see BENCHMARKS.md)
        let changed = if l.quads.len() >= HALVES_FROM {
            super::halves::pass(l, ops, self.focus.as_deref())
        } else {
            topo::pass(l, ops, self.focus.as_deref())
        };
        tm.lap("topo");
        if changed == 0 {
            self.left = 0;
            return false;
        }
        l.build_adjacency();
        // speed: after a pass, smooth only around what it changed (see `near_changes`)
        ops.smoothing_moves += match &snapshot {
            None => smooth::smooth(l, opts.smooth_iterations, opts.diagonal_weight),
            Some(snapshot) => {
                let active = near_changes(l, snapshot, RESMOOTH_RINGS);
                self.focus = Some(active.clone());
                smooth::smooth_near(l, near_its, opts.diagonal_weight, active)
            }
        };
        lap_with_quality(tm, l, "resmooth");
        self.open = Some((changed, snapshot.is_some()));
        true
    }

    /// Ends the round in the middle: the conformal solve when `unshear`, the gate's check,
    /// a progress tick; on a large surface, a pass that changed under 1/ROUNDS_STOP_SHARE
    /// of the quads is the last (the next ones find fewer still; see the constant).
    fn close(
        &mut self,
        l: &mut Local,
        opts: &OptimizeOptions,
        ops: &mut OperationCounts,
        tick: &(dyn Fn(usize) + Sync),
        unshear: bool,
        gate: &mut valid::Gate,
    ) {
        let Some((changed, large)) = self.open.take() else {
            return;
        };
        if unshear {
            let mg = opts.conformal_multigrid;
            ops.smoothing_moves += conformal::unshear(l, conformal::KEEP_ASPECT, mg);
        }
        gate.check(l, true, "topology round");
        tick(1);
        if large && changed * ROUNDS_STOP_SHARE < l.quads.len() {
            self.left = 0;
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
#[cfg(test)]
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
    finish_head(l, opts, ops, tm, keep_aspect, gate, tick);
    finish_tail(l, opts, ops, tm, gate, tick);
}

/// The first two steps of [`finish`]: the conformal solve and the max-min polish, giving a
/// progress tick after each.
fn finish_head(
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
    }
    tick(1);
}

/// The last two steps of [`finish`]: the pattern sweeps, then the mean polish (and on large
/// surfaces the max-min polish again), giving a progress tick after each.
fn finish_tail(
    l: &mut Local,
    opts: &OptimizeOptions,
    ops: &mut OperationCounts,
    tm: &mut StageTimer<'_>,
    gate: &mut valid::Gate,
    tick: &(dyn Fn(usize) + Sync),
) {
    if opts.angle_sweeps > 0 {
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

/// Planar surfaces with fewer quads may choose among three schedules ([`plan`]); those that
/// may try them ([`may_try`]) keep their reference triangles for the τ estimates.
const SCHEDULE_CHOICE_BELOW: usize = 20_000;

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
        assert_eq!(plan(&l, &opts, true, true), Plan::Trial { unshear: mean < UNSHEAR_BELOW });
        assert_eq!(plan(&l, &opts, false, false), Plan::One);
    }

    /// A surface of [`SINGLE_FROM`] quads or more with a low mean η, its sizes from its own
    /// edges (as without reference triangles), after nothing but the extraction.
    fn larger_square() -> Local {
        (1u64..20)
            .find_map(|seed| crate::optimize::cleanup::tests::square_local(36, seed))
            .expect("an even, matchable square")
    }

    /// The unsheared schedule's rounds run from a copy after the first round's pass and
    /// smoothing (as the trial runs them) end exactly where they end run from the start: the
    /// first round's pass and smoothing do not depend on the conformal solve after them.
    #[test]
    fn the_unsheared_rounds_from_the_shared_first_round_end_as_from_the_start() {
        let opts = OptimizeOptions::default();
        let mut l = larger_square();
        let sweeps = first_sweeps(&l, &opts);
        smooth::smooth(&mut l, sweeps, opts.diagonal_weight);
        let gate = valid::Gate::new(&l);
        let mut tm = StageTimer::new(opts.trace, "optimize", 0);
        let (mut a, mut a_ops, mut a_gate) = (l.clone(), OperationCounts::default(), gate.clone());
        topology_rounds(&mut a, &opts, &mut a_ops, &mut tm, &|_| {}, true, &mut a_gate);
        let (mut b, mut b_ops, mut b_gate) = (l, OperationCounts::default(), gate);
        let mut rounds = Rounds::new(&opts);
        assert!(rounds.pass_and_smooth(&mut b, &opts, &mut b_ops, &mut tm));
        // the plain schedule goes on from here with the original
        let (mut u, mut u_ops, mut u_gate, mut u_rounds) = (b.clone(), b_ops, b_gate.clone(), rounds.clone());
        rounds.run(&mut b, &opts, &mut b_ops, &mut tm, &|_| {}, false, &mut b_gate);
        u_rounds.run(&mut u, &opts, &mut u_ops, &mut tm, &|_| {}, true, &mut u_gate);
        use crate::optimize::test_util::bits;
        assert_eq!(bits(&a.pos), bits(&u.pos));
        assert_eq!((&a.quads, &a.alive), (&u.quads, &u.alive));
        assert_eq!(a_ops.smoothing_moves, u_ops.smoothing_moves);
        assert!(a.quads.len() >= CUT_TRIAL_FROM, "{} quads", a.quads.len());
    }

    /// A small planar surface's trial put off ([`run_surface_deferring`]) and completed
    /// near the mesh's worst quad ends exactly as the trial run at once; far above it, the
    /// surface keeps the schedule its mean η chose ([`Plan::Single`]'s). Both choices (the
    /// plain schedule and the unsheared one) occur among the seeds.
    #[test]
    fn a_put_off_trial_ends_as_the_trial_or_as_the_chosen_schedule() {
        let opts = OptimizeOptions::default();
        let mut chosen = [0usize; 2];
        for seed in 1u64..40 {
            let Some(l) = crate::optimize::cleanup::tests::square_local(16, seed) else {
                continue;
            };
            // the plan after the first smoothing must be the trial
            let mut probe = l.clone();
            probe.build_adjacency();
            let sweeps = first_sweeps(&probe, &opts);
            smooth::smooth(&mut probe, sweeps, opts.diagonal_weight);
            if !matches!(plan(&probe, &opts, true, false), Plan::Trial { .. }) {
                continue;
            }
            let state = |m: &Local| {
                use crate::optimize::test_util::bits;
                (bits(&m.pos), m.quads.clone(), m.alive.clone())
            };
            // the trial at once
            let mut a = l.clone();
            let a_rep = run_surface(&mut a, &opts, false, &|_| {});
            // put off, then completed at the surface's own worst quad
            let mut b = l.clone();
            let (b_rep, d) = run_surface_deferring(&mut b, &opts, false, true, &|_| {});
            let d = d.expect("a small planar surface that is not the main one defers");
            chosen[usize::from(matches!(d.starts, Starts::Unsheared { .. }))] += 1;
            let worst = b_rep.after.eta_worst;
            let b_rep = finish_deferred(&mut b, &opts, b_rep, d, worst);
            assert!(state(&a) == state(&b), "seed {seed}: the completed trial differs");
            assert_eq!(a_rep, b_rep, "seed {seed}");
            // far above the mesh's worst quad: the chosen schedule, as Plan::Single runs it
            let mut e = l.clone();
            e.build_adjacency();
            let mut gate = valid::Gate::new(&e);
            let sweeps = first_sweeps(&e, &opts);
            let mut ops = OperationCounts {
                smoothing_moves: smooth::smooth(&mut e, sweeps, opts.diagonal_weight),
                ..Default::default()
            };
            gate.check(&mut e, true, "smoothing");
            let unshear = e.stats().eta_mean < UNSHEAR_BELOW;
            let mut tm = StageTimer::new(None, "optimize", 0);
            topology_rounds(&mut e, &opts, &mut ops, &mut tm, &|_| {}, unshear, &mut gate);
            finish(&mut e, &opts, &mut ops, &mut tm, conformal::KEEP_ASPECT, &mut gate);
            gate.check(&mut e, false, "optimization");
            let mut c = l.clone();
            let (c_rep, d) = run_surface_deferring(&mut c, &opts, false, true, &|_| {});
            let kept = finish_deferred(&mut c, &opts, c_rep, d.expect("deferred"), worst - 1.0);
            assert!(state(&c) == state(&e), "seed {seed}: not the chosen schedule's result");
            assert_eq!(kept.after, e.stats(), "seed {seed}");
        }
        assert!(chosen[0] > 0 && chosen[1] > 0, "plain, unsheared chosen: {chosen:?}");
    }

    /// The trial of a main surface of [`CUT_TRIAL_FROM`] quads or more (the schedules
    /// compared after the max-min polish) ends the same on one thread and on two.
    #[test]
    fn a_cut_trial_does_not_depend_on_the_thread_count() {
        let opts = OptimizeOptions::default();
        let l = larger_square();
        assert!(l.quads.len() >= CUT_TRIAL_FROM && l.stats().eta_mean < ALTERNATIVES_BELOW);
        let run = |threads| {
            crate::optimize::test_util::on_threads(threads, || {
                let mut m = l.clone();
                let rep = run_surface(&mut m, &opts, true, &|_| {});
                let pos = crate::optimize::test_util::bits(&m.pos);
                (pos, m.quads, m.alive, rep.after.eta_mean.to_bits())
            })
        };
        let one = run(1);
        assert_eq!(one, run(2));
    }
}
