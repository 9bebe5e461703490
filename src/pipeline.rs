//! The whole main job in one call: [`quadrangulate`] recombines every surface (with parity
//! repair), optionally refines, optimizes, and checks every quad before it returns. This is
//! what the `blossomquad IN -o OUT` command does between reading and writing.
//!
//! # The validity guarantee
//! When [`quadrangulate`] returns `Ok`, every 4-node quad of every surface is valid in the
//! sense of [`crate::validity`] (corners strictly between 0° and 180° about the input
//! surface's normal, oriented like the input, no zero-length edge, no repeated node) and
//! [`crate::recombine::check_invariants`] holds between the input and the result
//! (conformity, no triangle left, curve nodes unmoved, planar areas, physical groups) —
//! unless [`Options::allow_invalid`] is set, in which case the bad quads are listed in
//! [`Report::invalid`] instead of failing.
//!
//! # The fallback
//! When quads are not valid after a run, the job runs again from the input, locally:
//! 1. **Pricing.** A bad quad that two adjacent input triangles form is priced out: the
//!    matching gives that pair the cost of three extra edges
//!    ([`crate::recombine::RecombineOptions::priced_out`]) and solves the surface again, so
//!    it pairs those triangles otherwise unless nothing else works. A bad quad at the node
//!    of a parity repair's split puts that boundary segment on the parity repair's list of
//!    segments to avoid ([`crate::recombine::RecombineOptions::parity_avoid`]), so the
//!    repair splits another segment that fixes the same odd regions where there is one. At
//!    most [`PRICING_ROUNDS`] rounds price new quads or avoid new segments.
//! 2. **Segments under fans.** A bad quad that pricing could not avoid and that is a fan
//!    of two triangles with their bases on one side of a strip or band (flat at a
//!    boundary node, its diagonal's other end on the other side) gets a boundary segment
//!    at that other end split at its midpoint, with every triangle on it
//!    ([`crate::recombine::split_triangles`]), so the fan's triangles find partners on
//!    that side; at most [`SEGMENT_ROUNDS`] rounds, before any triangle is split. A job
//!    that still fails with such splits runs again without them.
//! 3. **Splits.** When no bad quad is left to price, the input triangles around each bad
//!    quad (those holding one of its input nodes, or the nearest one to a quad of new
//!    nodes) are split into three quads each before the matching
//!    ([`crate::recombine::split_triangles`]); a second split round adds one more ring (the
//!    triangles touching those), up to [`SPLIT_RINGS`] rings.
//! 4. **Last resort.** Quads still bad after that get every triangle of their surface split
//!    (the splits' halved neighbours along shared curves may bring another surface there in
//!    the next round; segment splits are dropped then), up to [`FALLBACK_ROUNDS`] rounds in
//!    all.
//! 5. **The worst quad.** A valid optimized result gets up to three more tries: where the
//!    fallback priced quads out, the fallback with splits only; quads under η
//!    [`ETA_FLOOR`] priced out; one ring around those still under it split. Each is kept
//!    only when it raises the worst quad without breaking the element-count rule. (A mesh
//!    of more than [`TRIES_UP_TO`] elements gets them only after a fallback.)
//!
//! Quads still bad after the fallback are refused (or listed with
//! [`Options::allow_invalid`]). A run whose quads are all valid the first time, with no
//! quad under η [`ETA_FLOOR`], pays only for the check.

use std::collections::HashSet;
use std::sync::Arc;
use std::time::{Duration, Instant};

use serde::{Deserialize, Serialize};

use crate::memory::release_memory;
pub use crate::memory::set_memory_release;
use crate::mesh::{etype, Mesh, TagCoords};
pub use crate::progress::{Progress, ProgressFn, Stage};
use crate::reuse::{Fingerprints, SurfaceCache};
use crate::validity::BadQuad;
use crate::warning::Warning;
use crate::{optimize, recombine, refine, validity};

mod fallback;

use fallback::{
    fallback_triangles, low_quads, pairs_of, quads_per_triangle, surface_elements, FallbackStart,
    LocalFallback, Next, COUNT_RULE_FROM, MAX_QUADS_PER_TRIANGLE,
};
pub use fallback::{ETA_FLOOR, PRICING_ROUNDS, SEGMENT_ROUNDS, SPLIT_RINGS};

/// Rounds after the first run at most: the fallback's pricing and split rounds, and (without
/// optimization) the rounds that optimize the surfaces whose matching left bad quads.
pub const FALLBACK_ROUNDS: usize = 10;

/// Elements up to which a valid result that needed no fallback still gets the tries that
/// may raise its worst quad (see the module doc); larger meshes get them only after a
/// fallback.
pub const TRIES_UP_TO: usize = 1 << 18;

/// Elements up to which a job keeps its optimized surfaces for the next job from its first
/// round on ([`crate::reuse`]): the meshes whose valid first round may still get the
/// worst-quad tries ([`TRIES_UP_TO`]), each a whole job in which the surfaces a try leaves
/// as they were are put back instead of optimized again; larger meshes from their second
/// round on (a first round that is valid, the usual case for them, then pays nothing for
/// it).
const REUSE_UP_TO: usize = TRIES_UP_TO;

/// Where the stages send their progress: forwards to a [`ProgressFn`] only what keeps the
/// promises of [`Progress`] (stage order, `done` not decreasing, a stage's reports from 0 to
/// `total`) and what moved by at least 1/[`Reporter::STEPS`] of the stage since the last
/// report, or ends it; one call at a time,
/// so reports from several threads arrive in order. A report of [`Stage::Topology`] at 0,
/// or of any stage at 0 after a finished [`Stage::Check`], starts a new round.
struct Reporter {
    f: ProgressFn,
    /// The last report forwarded.
    last: std::sync::Mutex<Option<Progress>>,
}

impl Reporter {
    /// Reports per stage at most (plus the one that ends it).
    const STEPS: u64 = 200;

    /// A callback forwarding to `f` what is due.
    pub(crate) fn wrap(f: &ProgressFn) -> ProgressFn {
        let r = Reporter {
            f: f.clone(),
            last: std::sync::Mutex::new(None),
        };
        ProgressFn::new(move |p| r.report(p))
    }

    /// Forwards `p` if it is due (see the type's docs).
    fn report(&self, p: Progress) {
        // a poisoned lock means a callback panicked: report nothing more
        let Ok(mut last) = self.last.lock() else {
            return;
        };
        // a stage's first report forwarded: preceded by one at 0 when it is past 0
        let mut starts = true;
        if let Some(l) = *last {
            // a fallback round starts again from the first stage, and a round that only
            // optimizes more surfaces (without `optimize`) from the optimizer, once the
            // checks that end a round are done
            let round_over = l.stage == Stage::Check && l.done == l.total;
            let restart = p.done == 0 && (p.stage == Stage::Topology || round_over);
            if p.stage < l.stage && !restart {
                return;
            }
            starts = p.stage != l.stage;
            if p.stage == l.stage {
                let ended = p.done == p.total && l.done < l.total;
                let moved = (p.fraction() - l.fraction()) * Self::STEPS as f64 >= 1.0;
                // the last surfaces may finish after the units are all done
                let last_surfaces = p.done == p.total && p.surfaces_done > l.surfaces_done;
                if p.fraction() < l.fraction() || !(ended || moved || last_surfaces) {
                    return;
                }
            } else if l.done < l.total && p.stage > l.stage {
                // a later stage started, so this one ended (its last report may have
                // been overtaken by another thread's)
                (self.f.0)(Progress {
                    done: l.total,
                    surfaces_done: l.surfaces,
                    ..l
                });
            }
        }
        if starts && p.done > 0 {
            // a stage starts at 0 (its first units may have been done before it is
            // reported, such as surfaces matched while another's graph was built)
            (self.f.0)(Progress {
                done: 0,
                surfaces_done: 0,
                ..p
            });
        }
        *last = Some(p);
        (self.f.0)(p);
    }
}

/// Options of [`quadrangulate`]; the defaults are the command line's.
#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(default)]
#[non_exhaustive]
pub struct Options {
    /// What to do with surfaces that have an odd number of triangles.
    pub parity: recombine::ParityMode,
    /// Drop volume elements instead of refusing a volume mesh.
    pub drop_volumes: bool,
    /// Check the matching's optimality certificate too (the invariants and the validity of
    /// every quad are always checked).
    pub verify: bool,
    /// Weight of the cross-field alignment cost (eq. 7), in [0, 5]; 0.05 by default.
    pub cross_field_weight: f64,
    /// Use the harmonic cross field instead of the nearest-wall one.
    pub harmonic_cross_field: bool,
    /// Uniform refinement levels after recombination (0–3).
    pub refine: u8,
    /// Smoothing sweeps per smoothing phase; `None`: 5 · 2^refine.
    pub smooth: Option<usize>,
    /// Apply the topological operators.
    pub topology: bool,
    /// Optimize at all (smoothing and topology).
    pub optimize: bool,
    /// Return `Ok` with the invalid quads listed in [`Report::invalid`] instead of failing.
    pub allow_invalid: bool,
    /// With second-order (6-node triangle) input: write 8-node quads (Gmsh's
    /// `Mesh.SecondOrderIncomplete`) instead of 9-node quads.
    pub incomplete: bool,
    /// Append the quality views "eta", "scaled jacobian" (`$ElementData`) and "valence"
    /// (`$NodeData`) to the result ([`crate::quality::view`]), encoded for
    /// [`crate::msh::default_output_format`] of the mesh (written in another encoding,
    /// they are dropped with a warning; the CLI's `--quality-view` encodes them for the
    /// format it writes).
    pub quality_view: bool,
    /// Optimize the surfaces that hold no triangle in the input (already all quads, as Gmsh's
    /// recombination, a transfinite or an extruded surface with `Recombine` leave them)
    /// like the others. By default they are written as read: their nodes (coordinates and
    /// parametric coordinates) and quads, in their order, unless parity repair or the
    /// fallback splits a curve segment they share with a triangle surface (their quads
    /// along it are then split too, to stay conforming).
    pub smooth_quads: bool,
    /// Keep the input's node and element tags exactly, gaps and all; by default the result
    /// is numbered 1..N without gaps, as Gmsh numbers its files ([`crate::renumber`]).
    pub keep_tags: bool,
    /// Give the input tag → output tag map of the kept nodes and elements in
    /// [`Report::renumber`] (`map`); ignored with [`Options::keep_tags`].
    pub tag_map: bool,
    /// Progress callback.
    #[serde(skip)]
    pub progress: Option<ProgressFn>,
    /// Developer hooks: stage times, optimizer rollbacks and matching graphs (see
    /// [`crate::profile`]).
    #[serde(skip)]
    pub trace: Option<crate::profile::Trace>,
}

impl Default for Options {
    fn default() -> Self {
        Options {
            parity: recombine::ParityMode::Repair,
            drop_volumes: false,
            verify: false,
            cross_field_weight: 0.05,
            harmonic_cross_field: false,
            refine: 0,
            smooth: None,
            topology: true,
            optimize: true,
            allow_invalid: false,
            incomplete: false,
            quality_view: false,
            smooth_quads: false,
            keep_tags: false,
            tag_map: false,
            progress: None,
            trace: None,
        }
    }
}

/// Wall time of each stage, summed over fallback rounds.
#[derive(Debug, Clone, Default, PartialEq, Serialize)]
pub struct Times {
    /// Recombination (parity, graph, matching, quads, fallback splits).
    pub recombine: Duration,
    /// Refinement.
    pub refine: Duration,
    /// Optimization.
    pub optimize: Duration,
    /// Invariant and validity checks.
    pub check: Duration,
    /// Second-order nodes and their Jacobian check (second-order input only).
    pub second_order: Duration,
}

/// What [`quadrangulate`] did.
#[derive(Debug, Clone, Default, Serialize)]
pub struct Report {
    /// The recombination of the final round.
    pub recombine: recombine::RecombineReport,
    /// One entry per refinement level.
    pub refine: Vec<refine::RefineReport>,
    /// The optimization of the final round (`None` without optimization).
    pub optimize: Option<optimize::OptimizeReport>,
    /// Fallback splits done before the final round's recombination (empty when the first
    /// run was valid).
    pub fallback: Option<recombine::FallbackSplit>,
    /// Quads the fallback priced out of the final round's matching (their triangles were
    /// paired otherwise where the matching could).
    pub priced_out: usize,
    /// Runs done (1 + fallback rounds).
    pub rounds: usize,
    /// Quads still invalid (only with [`Options::allow_invalid`]; empty otherwise).
    pub invalid: Vec<BadQuad>,
    /// The second-order step (second-order input only, see [`crate::high_order`]).
    pub second_order: Option<crate::high_order::SecondOrderReport>,
    /// The renumbering of nodes and elements to 1..N (all zero with
    /// [`Options::keep_tags`]).
    pub renumber: crate::renumber::RenumberReport,
    /// What the job did, in order, as lines in plain words (what `--verbose` prints).
    pub log: Vec<String>,
    /// What the caller may not expect (every warning is also worth showing without
    /// `--verbose`).
    pub warnings: Vec<Warning>,
    /// Wall times.
    pub times: Times,
}

/// Why [`quadrangulate`] failed.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum Error {
    /// Reading or writing an MSH file.
    #[error(transparent)]
    Msh(#[from] crate::msh::MshError),
    /// Recombination refused or failed.
    #[error(transparent)]
    Recombine(#[from] recombine::RecombineError),
    /// Refinement refused.
    #[error(transparent)]
    Refine(#[from] refine::RefineError),
    /// Optimization failed.
    #[error(transparent)]
    Optimize(#[from] optimize::OptimizeError),
    /// The result broke an invariant (a bug: please report it with the input).
    #[error("internal check failed after {stage}: {violation}")]
    Invariant {
        /// The stage after which the check failed.
        stage: &'static str,
        /// What failed.
        #[source]
        violation: recombine::InvariantViolation,
    },
    /// The fallback ran out of rounds without a verdict (a bug: please report it with the
    /// input).
    #[error("internal error: the fallback ended without a result")]
    FallbackExhausted,
    /// Some quads are not valid even after the fallback.
    #[error("{}", invalid_message(bad))]
    Invalid {
        /// The quads still bad after the last round.
        bad: Vec<BadQuad>,
        /// The rounds' log up to the refusal (what [`Report::log`] would have held).
        log: Vec<String>,
    },
    /// Second-order input refused, or second-order elements not valid.
    #[error(transparent)]
    SecondOrder(crate::high_order::HighOrderError),
}

/// A refusal of the linear copy is the linear job's refusal ([`Error::Recombine`]).
impl From<crate::high_order::HighOrderError> for Error {
    fn from(e: crate::high_order::HighOrderError) -> Self {
        match e {
            crate::high_order::HighOrderError::Recombine(e) => Error::Recombine(e),
            e => Error::SecondOrder(e),
        }
    }
}

fn invalid_message(bad: &[BadQuad]) -> String {
    format!(
        "{} quad(s) on surface(s) {} are not valid even after splitting their triangles into quads; first: {}",
        bad.len(),
        sorted_list(bad.iter().map(|b| &b.surface)),
        bad.first().map(|b| b.to_string()).unwrap_or_default()
    )
}

/// Turns every surface's triangles into valid quads (see the module doc): recombination
/// with parity repair, refinement, optimization, then the invariant and validity checks,
/// with the fallback when quads are not valid. A mesh with 6-node triangles is recombined
/// on its corners and written back as 9-node (or, with [`Options::incomplete`], 8-node)
/// quads on its curved geometry ([`crate::high_order`]). On error `mesh` is unchanged.
pub fn quadrangulate(mesh: &mut Mesh, opts: &Options) -> Result<Report, Error> {
    let input_tags =
        (opts.tag_map && !opts.keep_tags).then(|| crate::renumber::InputTags::of(mesh));
    let mut report = if crate::high_order::is_second_order(mesh) {
        // the linear job on the corners, then second-order nodes on the input's geometry
        quadrangulate_second_order(mesh, opts)?
    } else {
        quadrangulate_linear(mesh, opts)?
    };
    if !opts.keep_tags {
        report.renumber = crate::renumber::renumber(mesh, input_tags);
        let warnings = std::mem::take(&mut report.renumber.warnings);
        report.warnings.extend(
            warnings
                .into_iter()
                .map(|text| Warning::Renumbering { text }),
        );
    }
    if opts.quality_view {
        let binary = crate::msh::default_output_format(mesh).binary;
        crate::quality::view::add_views(mesh, binary);
    }
    Ok(report)
}

/// [`quadrangulate`] of a second-order mesh ([`crate::high_order`]'s module doc): its
/// linear copy, the linear job on it, then the second-order elements on the input's
/// geometry. On error `mesh` is unchanged.
fn quadrangulate_second_order(mesh: &mut Mesh, opts: &Options) -> Result<Report, Error> {
    use crate::high_order::{elevate, linearize, ElevateOptions};
    let (mut linear, dropped) = linearize(mesh, opts.drop_volumes)?;
    let linear_max = linear.max_node_tag();
    // the views are measured on the second-order result, not on the linear copy, and
    // `elevate` finds the input's nodes by tag: the renumbering comes after it
    let linear_opts = Options {
        quality_view: false,
        keep_tags: true,
        tag_map: false,
        ..opts.clone()
    };
    let mut report = quadrangulate_linear(&mut linear, &linear_opts)?;
    let t = Instant::now();
    if dropped > 0 {
        report.recombine.dropped_volume_elements = dropped;
        report
            .log
            .insert(0, format!("dropped {dropped} volume elements"));
    }
    let elevation = ElevateOptions {
        incomplete: opts.incomplete,
        allow_invalid: opts.allow_invalid,
    };
    let (out, so) = elevate(mesh, linear, linear_max, elevation)?;
    report.log.push(format!(
        "second order: {} {}-node quads, {} 3-node lines; mid-edge nodes: {} kept from the input, {} new on curves, {} new on surfaces; face nodes: {} kept, {} new; {} moved corner(s) placed on the curved geometry; min scaled Jacobian {:.3}, mean {:.3}",
        so.quads,
        if so.quad_type == etype::QUAD9 { 9 } else { 8 },
        so.lines,
        so.kept_mid_nodes,
        so.curve_mid_nodes,
        so.surface_mid_nodes,
        so.kept_face_nodes,
        so.face_nodes,
        so.corners_placed,
        so.min_scaled_jacobian,
        so.mean_scaled_jacobian,
    ));
    if !so.straight.is_empty() {
        report.log.push(format!(
            "second order: {} element(s) got straight-sided nodes because the curved placement made their Jacobian not positive ({} corner(s) put back at the linear position): {}",
            so.straight.len(),
            so.corners_reverted,
            short_list(&so.straight)
        ));
    }
    if !so.invalid.is_empty() {
        report.warnings.push(Warning::InvalidSecondOrder {
            count: so.invalid.len(),
            list: short_list(&so.invalid),
        });
    }
    report.second_order = Some(so);
    report.times.second_order += t.elapsed();
    *mesh = out;
    Ok(report)
}

fn short_list(tags: &[u64]) -> String {
    let mut s = tags
        .iter()
        .take(20)
        .map(|t| t.to_string())
        .collect::<Vec<_>>()
        .join(", ");
    if tags.len() > 20 {
        s.push_str(&format!(", ... ({} in all)", tags.len()));
    }
    s
}

/// [`quadrangulate`] of a linear mesh.
fn quadrangulate_linear(mesh: &mut Mesh, opts: &Options) -> Result<Report, Error> {
    // every stage reports through one reporter (order, throttling)
    let wrapped;
    let opts = match &opts.progress {
        Some(p) => {
            wrapped = Options {
                progress: Some(Reporter::wrap(p)),
                ..opts.clone()
            };
            &wrapped
        }
        None => opts,
    };
    let input = std::mem::take(mesh);
    // triangles repeating another's nodes (zero-area pockets) are removed once, up front:
    // every check below compares with the input without them
    let cleaned = recombine::drop_repeated_triangles(&input);
    let (base, dropped) = match &cleaned {
        Some((m, lines)) => (m, lines.clone()),
        None => (&input, Vec::new()),
    };
    let mut cache = SurfaceCache::default();
    let mut segments_used = false;
    let result = run_rounds(
        base,
        opts,
        FallbackStart::default(),
        &mut cache,
        &mut segments_used,
    )
    .or_else(|e| match e {
        // a fallback that split boundary segments under fans and still failed runs again
        // without them (on strips that share curves, a segment split moves one strip's
        // imbalance to the next)
        Error::Invalid { .. } | Error::FallbackExhausted if segments_used => {
            let start = FallbackStart {
                no_segments: true,
                ..FallbackStart::default()
            };
            run_rounds(base, opts, start, &mut cache, &mut false)
        }
        e => Err(e),
    })
    .and_then(|first| raise_worst_quad(base, opts, first, &mut cache));
    match result {
        Ok((out, mut report, _)) => {
            *mesh = out;
            report.warnings.splice(
                0..0,
                dropped
                    .into_iter()
                    .map(|text| Warning::RepeatedTriangles { text }),
            );
            Ok(report)
        }
        Err(e) => {
            *mesh = input;
            Err(e)
        }
    }
}

fn progress(opts: &Options, stage: Stage, done: usize, total: usize) {
    if let Some(p) = &opts.progress {
        p.report(Progress::new(stage, done as u64, total as u64));
    }
}

/// True when a node of `tags` is not where `input` has it in `output` (or is gone).
fn moved_any(input: &Mesh, output: &Mesh, tags: &[u64]) -> bool {
    if tags.is_empty() {
        return false;
    }
    let (a, b) = (TagCoords::new(input), TagCoords::new(output));
    tags.iter().any(|&t| a.get(t) != b.get(t))
}

/// The rounds of one job on `input` (see the module doc), starting from `start`'s priced-out
/// quads and split triangles; returns the result with the fallback's state at its end.
fn run_rounds(
    input: &Mesh,
    opts: &Options,
    start: FallbackStart,
    cache: &mut SurfaceCache,
    segments_used: &mut bool,
) -> Result<(Mesh, Report, FallbackStart), Error> {
    let mut times = Times::default();
    let mut log = Vec::new();
    let mut chosen: HashSet<u64> = start.chosen;
    let splits_only = start.splits_only;
    let mut local = LocalFallback {
        priced: start.priced,
        avoid: start.avoid,
        flat_halves_out: start.flat_halves_out,
        segments: start.segments,
        pricing_rounds: if splits_only { PRICING_ROUNDS } else { 0 },
        segment_rounds: if splits_only || start.no_segments {
            SEGMENT_ROUNDS
        } else {
            0
        },
        no_segments: start.no_segments,
        ..Default::default()
    };
    let mut fallback = None;
    // the input's largest tags: a job's own nodes and elements are above them
    let input_tags = (input.max_node_tag(), input.max_element_tag());
    let mut folds: Vec<recombine::WalledFold> = Vec::new();
    // without optimization: surfaces optimized all the same because their matching left
    // quads that are not valid (vertex duplications fold quads until smoothed)
    let mut force: HashSet<i32> = HashSet::new();
    // the input side of the checks, prepared once (during the first round's matching)
    let mut checks: Option<Checks> = None;
    // without optimization: the last round's mesh before optimization, when the next round
    // only optimizes more surfaces of the same recombination
    let mut carried: Option<Recombined> = None;
    for round in 0..=FALLBACK_ROUNDS {
        let optimizing = opts.optimize || !force.is_empty();
        let recombined = match carried.take() {
            Some(c) => c,
            None => {
                let mut mesh = input.clone();
                if !chosen.is_empty() || !local.segments.is_empty() {
                    let t = Instant::now();
                    let split = recombine::split_triangles(&mut mesh, &chosen, &local.segments);
                    let mut line = format!("fallback round {round}: ");
                    if split.segments_split > 0 {
                        line += &format!(
                            "{} boundary segment(s) under fans split at their midpoints, ",
                            split.segments_split
                        );
                    }
                    line += &format!(
                        "{} triangle(s) split into three quads each on surface(s) {}, {} neighbouring triangle(s) and {} line(s) split in two",
                        split.triangles_to_quads,
                        sorted_list(&split.surfaces),
                        split.triangles_halved,
                        split.lines_split
                    );
                    log.push(line);
                    fallback = Some(split);
                    times.recombine += t.elapsed();
                }
                recombine_once(
                    input,
                    mesh,
                    opts,
                    &local.priced.iter().map(|p| p.1).collect::<Vec<_>>(),
                    &local.avoid,
                    local.flat_halves_out,
                    optimizing,
                    &mut checks,
                    &mut times,
                )?
            }
        };
        let Recombined {
            mut mesh,
            report: recombine_report,
            refined,
            prepared,
        } = recombined;
        // after a first invalid run, keep the mesh before optimization: a surface the
        // optimizer leaves invalid gets it back (and without optimization, the next round
        // may start from it)
        let keep = round > 0 && optimizing;
        let unoptimized = keep.then(|| mesh.clone());
        // speed: the surfaces an earlier job optimized from the same recombination get
        // that job's result back instead of being optimized again (exact: `crate::reuse`)
        let fingerprints = (opts.optimize
            && (round > 0 || !cache.is_empty() || mesh.element_count() <= REUSE_UP_TO))
            .then(|| Fingerprints::of(&mesh, input_tags.0, input_tags.1));
        let reused = match &fingerprints {
            Some(fp) => cache.put_back(&mut mesh, fp),
            None => Vec::new(),
        };
        let mut run = recombine_report.clone();
        if !reused.is_empty() {
            run.log.push(format!(
                "{} surface(s) optimized as in an earlier round: {}",
                reused.len(),
                sorted_list(&reused)
            ));
        }
        optimize_once(
            input,
            &mut mesh,
            opts,
            &force,
            &reused,
            prepared,
            &mut checks,
            &mut times,
            &mut run,
        )?;
        // memory: the optimizer's arrays are freed; the checks allocate next
        release_memory();
        let t = Instant::now();
        progress(opts, Stage::Check, 0, 1);
        // the input side of the checks, when the first round's matching did not prepare it
        let checks = checks.get_or_insert_with(|| Checks::new(input, opts.refine == 0));
        // after a refinement the refined mesh is the baseline of the invariants
        let refined_before = refined.as_ref().map(recombine::Before::new);
        let before = refined_before.as_ref().or(checks.invariants.as_ref());
        let invariants_of = |m: &Mesh, coords: &TagCoords| match before {
            Some(b) => b.check_at(m, coords),
            None => recombine::check_invariants(input, m),
        };
        // memory: one table of the output's coordinates for both checks
        let coords = TagCoords::new(&mesh);
        // speed: the two checks are independent, so they run side by side (an invariant
        // failure still comes first)
        let (invariants, mut bad) = rayon::join(
            || invariants_of(&mesh, &coords),
            || checks.validity.invalid_quads_at(&mesh, &coords),
        );
        drop(coords);
        invariants.map_err(|violation| Error::Invariant {
            stage: if opts.optimize {
                "optimization"
            } else {
                "recombination"
            },
            violation,
        })?;
        if let (false, Some(pre)) = (bad.is_empty(), unoptimized.as_ref()) {
            let surfaces: HashSet<i32> = bad.iter().map(|b| b.surface).collect();
            let back = revert_surfaces(&mesh, pre, &surfaces);
            let coords = TagCoords::new(&back);
            if checks.validity.invalid_quads_at(&back, &coords).is_empty()
                && invariants_of(&back, &coords).is_ok()
            {
                run.log.push(format!(
                    "surface(s) {}: optimization undone (it left a quad that is not valid)",
                    sorted_list(&surfaces)
                ));
                mesh = back;
                bad.clear();
            }
        }
        progress(opts, Stage::Check, 1, 1);
        times.check += t.elapsed();
        if let Some(fp) = &fingerprints {
            cache.record(&mesh, fp);
        }
        let mut report = run;
        // the folds walled off in any round (a fallback split can take a fold's triangles
        // out of later rounds' topology)
        for f in &report.recombine.walled_folds {
            if !folds.iter().any(|g| g.surface == f.surface) {
                folds.push(f.clone());
            }
        }
        report.log.splice(0..0, log.iter().cloned());
        report.fallback = fallback.clone();
        report.priced_out = local.priced.len();
        report.rounds = round + 1;
        if bad.is_empty() {
            // the nodes of walled-off folds bound walls: a result that moved one (the
            // optimizer does not know them as walls) is refused naming the fold
            if let Some(fold) = folds.iter().find(|f| moved_any(input, &mesh, &f.nodes)) {
                return Err(Error::Recombine(fold.refusal()));
            }
            report.times = times;
            return Ok((mesh, report, local.finish(chosen, splits_only)));
        }
        let surfaces: HashSet<i32> = bad.iter().map(|b| b.surface).collect();
        log.push(format!(
            "round {}: {} quad(s) not valid on surface(s) {}: {}",
            round + 1,
            bad.len(),
            sorted_list(&surfaces),
            bad.iter()
                .take(3)
                .map(|b| b.to_string())
                .collect::<Vec<_>>()
                .join("; ")
        ));
        if !opts.optimize && round < FALLBACK_ROUNDS {
            let new: Vec<i32> = surfaces.difference(&force).copied().collect();
            if !new.is_empty() {
                log.push(format!(
                    "surface(s) {}: optimized after all, to make the matching's quads valid",
                    sorted_list(&new)
                ));
                force.extend(new);
                // the recombination would be the same: only the optimizer runs again
                // (nothing was optimized when no mesh was kept before optimization)
                carried = Some(Recombined {
                    mesh: unoptimized.unwrap_or(mesh),
                    report: recombine_report,
                    refined,
                    prepared: None,
                });
                continue;
            }
        }
        let next = if round == FALLBACK_ROUNDS {
            Next::GiveUp
        } else {
            local.next(
                input,
                &mesh,
                &bad,
                &chosen,
                &recombine_report.recombine.parity_splits,
            )
        };
        let more = match next {
            Next::Price(quads, segments) => {
                let mut line = format!(
                    "fallback round {}: {} quad(s) priced out of the matching",
                    round + 1,
                    quads
                );
                if segments > 0 {
                    line += &format!(", {segments} parity split segment(s) avoided");
                }
                log.push(line);
                continue;
            }
            Next::Segments(count) => {
                *segments_used = true;
                log.push(format!(
                    "fallback round {}: {count} boundary segment(s) under fan quads to split",
                    round + 1
                ));
                continue;
            }
            Next::Split(more) => more,
            Next::GiveUp => HashSet::new(),
        };
        if more.is_empty() {
            if opts.allow_invalid {
                report.warnings.push(Warning::InvalidQuads {
                    count: bad.len(),
                    list: bad
                        .iter()
                        .map(|b| b.to_string())
                        .collect::<Vec<_>>()
                        .join("; "),
                });
                report.invalid = bad;
                report.times = times;
                return Ok((mesh, report, local.finish(chosen, splits_only)));
            }
            // a surface whose folds were walled off and whose quads are still not valid
            // is refused naming its fold
            if let Some(fold) = folds.iter().find(|f| surfaces.contains(&f.surface)) {
                return Err(Error::Recombine(fold.refusal()));
            }
            let mut lines = std::mem::take(&mut report.log);
            lines.extend(log.last().cloned());
            return Err(Error::Invalid { bad, log: lines });
        }
        chosen.extend(more);
    }
    // every path of the last round returns; this is only a guard
    Err(Error::FallbackExhausted)
}

/// `mesh` with the quads and the surface-classified nodes of `surfaces` taken from `pre`
/// (the same mesh before optimization: the optimizer moves and removes only nodes inside a
/// surface, and changes only its quads).
fn revert_surfaces(mesh: &Mesh, pre: &Mesh, surfaces: &HashSet<i32>) -> Mesh {
    let mut out = mesh.clone();
    let ours = |dim: i32, tag: i32| dim == 2 && surfaces.contains(&tag);
    out.node_blocks
        .retain(|b| !ours(b.entity_dim, b.entity_tag));
    out.node_blocks.extend(
        pre.node_blocks
            .iter()
            .filter(|b| ours(b.entity_dim, b.entity_tag))
            .cloned(),
    );
    out.element_blocks
        .retain(|b| !(ours(b.entity_dim, b.entity_tag) && b.element_type == etype::QUAD4));
    out.element_blocks.extend(
        pre.element_blocks
            .iter()
            .filter(|b| ours(b.entity_dim, b.entity_tag) && b.element_type == etype::QUAD4)
            .cloned(),
    );
    out
}

/// Surface tags in increasing order, without repeats, as "1, 4, 7".
fn sorted_list<'a>(tags: impl IntoIterator<Item = &'a i32>) -> String {
    let mut v: Vec<i32> = tags.into_iter().copied().collect();
    v.sort_unstable();
    v.dedup();
    v.iter()
        .map(|x| x.to_string())
        .collect::<Vec<_>>()
        .join(", ")
}

/// After the fallback, with optimization, other results that may have a better worst
/// quad, each a new job kept only when it is valid, raises the worst quad's η and keeps the
/// new quads per input triangle at most [`MAX_QUADS_PER_TRIANGLE`] (a result above it
/// already, or a mesh of fewer than [`COUNT_RULE_FROM`] triangles: at most a quarter more
/// than the larger of the two):
/// 1. when the fallback priced quads out, the fallback with splits only (triangles split
///    into quads around a bad quad may give better quads than the matching's way around
///    it);
/// 2. quads with η below [`ETA_FLOOR`] priced out;
/// 3. one ring of input triangles around the quads still below [`ETA_FLOOR`] split.
fn raise_worst_quad(
    input: &Mesh,
    opts: &Options,
    first: (Mesh, Report, FallbackStart),
    cache: &mut SurfaceCache,
) -> Result<(Mesh, Report, FallbackStart), Error> {
    let mut best = first;
    // without optimization the quads are the matching's as they are (low by design); a
    // large mesh that needed no fallback is not run again for its worst quad (a try costs
    // a whole job)
    let large = best.1.rounds == 1 && input.element_count() > TRIES_UP_TO;
    if !opts.optimize || !best.1.invalid.is_empty() || large {
        return Ok(best);
    }
    let skip = if opts.smooth_quads {
        Vec::new()
    } else {
        quad_only_surfaces(input)
    };
    let (mut low, mut worst) = low_quads(&best.0, &skip);
    let triangles = surface_elements(input, etype::TRI3);
    for step in 0..3 {
        let mut start = best.2.clone();
        let what = match step {
            0 => {
                if start.priced.is_empty() {
                    continue;
                }
                start = FallbackStart {
                    splits_only: true,
                    ..FallbackStart::default()
                };
                "the fallback with splits only".to_string()
            }
            1 => {
                let new = pairs_of(input, &low, &start.priced);
                if new.is_empty() {
                    continue;
                }
                let n = new.len();
                start.priced.extend(new);
                format!("{n} quad(s) under eta {ETA_FLOOR} priced out")
            }
            _ => {
                let more = fallback_triangles(input, &best.0, &low, &start.chosen, 1);
                if low.is_empty() || more.is_empty() {
                    continue;
                }
                let n = more.len();
                start.chosen.extend(more);
                format!("{n} triangle(s) around quads under eta {ETA_FLOOR} split")
            }
        };
        let Ok(candidate) = run_rounds(input, opts, start, cache, &mut false) else {
            continue;
        };
        if !candidate.1.invalid.is_empty() {
            continue;
        }
        let (_, new_worst) = low_quads(&candidate.0, &skip);
        // a result above the element-count rule already, or of a small mesh (where the
        // rule does not apply), may grow by a quarter
        let before = quads_per_triangle(input, &best.0);
        let limit = if before > MAX_QUADS_PER_TRIANGLE || triangles < COUNT_RULE_FROM {
            1.25 * before.max(MAX_QUADS_PER_TRIANGLE)
        } else {
            MAX_QUADS_PER_TRIANGLE
        };
        if new_worst > worst + 1e-3 && quads_per_triangle(input, &candidate.0) <= limit {
            let mut kept = candidate;
            kept.1.log.splice(
                0..0,
                best.1.log.iter().cloned().chain(std::iter::once(format!(
                    "worst quad: {what}: eta_w {worst:.3} -> {new_worst:.3}"
                ))),
            );
            kept.1.times = add_times(&best.1.times, &kept.1.times);
            best = kept;
            (low, worst) = low_quads(&best.0, &skip);
        } else {
            best.1.times = add_times(&best.1.times, &candidate.1.times);
        }
    }
    Ok(best)
}

/// The stage times of two jobs added.
fn add_times(a: &Times, b: &Times) -> Times {
    Times {
        recombine: a.recombine + b.recombine,
        refine: a.refine + b.refine,
        optimize: a.optimize + b.optimize,
        check: a.check + b.check,
        second_order: a.second_order + b.second_order,
    }
}

/// The input side of the final checks: the validity reference, and the invariants'
/// baseline when it is the input (no refinement).
struct Checks<'a> {
    validity: validity::Reference<'a>,
    invariants: Option<recombine::Before<'a>>,
}

impl<'a> Checks<'a> {
    fn new(input: &'a Mesh, invariants: bool) -> Self {
        // memory: one table of the input's coordinates for both
        let coords = Arc::new(TagCoords::new(input));
        let (validity, invariants) = rayon::join(
            || validity::Reference::with_coords(input, Arc::clone(&coords)),
            || invariants.then(|| recombine::Before::with_coords(input, Arc::clone(&coords))),
        );
        Checks {
            validity,
            invariants,
        }
    }
}

/// A round's mesh before optimization, with what the recombination and refinement of that
/// round reported. Without [`Options::optimize`], a round that only adds surfaces to the
/// optimized set starts again from it instead of recombining the input again (the
/// recombination is a function of the input and the fallback's splits, which have not
/// changed).
struct Recombined {
    /// The mesh after recombination and refinement.
    mesh: Mesh,
    /// The recombination and refinement reports (no optimization yet).
    report: Report,
    /// After a refinement, the refined mesh (the invariants' baseline).
    refined: Option<Mesh>,
    /// The optimizer's reference, when it was prepared beside the recombination.
    prepared: Option<optimize::PreparedReference>,
}

/// The first half of a run: recombine `mesh` (the input, with the fallback's splits) and
/// refine it, the optimizer's reference prepared on its own thread meanwhile when
/// `optimizing`, and the input side of the checks too when they are missing and the
/// optimizer will not run.
#[allow(clippy::too_many_arguments)]
fn recombine_once<'a>(
    input: &'a Mesh,
    mut mesh: Mesh,
    opts: &Options,
    priced_out: &[[u64; 4]],
    parity_avoid: &[(u64, u64)],
    flat_halves_out: bool,
    optimizing: bool,
    checks: &mut Option<Checks<'a>>,
    times: &mut Times,
) -> Result<Recombined, Error> {
    let ropts = recombine::RecombineOptions {
        parity: opts.parity,
        drop_volumes: opts.drop_volumes,
        verify: opts.verify,
        cross_field_weight: opts.cross_field_weight,
        harmonic_cross_field: opts.harmonic_cross_field,
        // the fallback's edge-split nodes (tags above the input's) are split nodes too
        split_nodes_from: Some(input.max_node_tag() + 1),
        priced_out: priced_out.to_vec(),
        parity_avoid: parity_avoid.to_vec(),
        flat_halves_out,
        trace: opts.trace.clone(),
        progress: opts.progress.clone(),
        // `quadrangulate` removed them from `input` (the fallback's splits add none)
        repeated_dropped: true,
        ..Default::default()
    };
    let t = Instant::now();
    // the optimizer's reference and the input side of the final checks depend on the input
    // only: the reference is prepared on its own thread while the recombination runs (its
    // matching is serial per surface), and so is the checks' input side without the
    // optimizer
    let want_checks = checks.is_none();
    // memory: with the optimizer, the input side of the final checks is prepared while the
    // optimizer runs (its arrays are then live anyway), not during the matching
    let checks_with_recombination = want_checks && !optimizing;
    let (recombined, prep) = std::thread::scope(|sc| {
        let prep = (optimizing || checks_with_recombination).then(|| {
            sc.spawn(|| {
                let reference = optimizing.then(|| optimize::PreparedReference::new(input));
                let ready = checks_with_recombination.then(|| Checks::new(input, opts.refine == 0));
                (reference, ready)
            })
        });
        let r = recombine::recombine(&mut mesh, &ropts);
        (r, prep.map(|h| h.join()))
    });
    let (prepared, ready) = match prep {
        Some(Ok(p)) => p,
        Some(Err(panic)) => std::panic::resume_unwind(panic),
        None => (None, None),
    };
    if ready.is_some() {
        *checks = ready;
    }
    // memory: the recombination's arrays are freed; the optimizer allocates next
    release_memory();
    let rreport = recombined?;
    times.recombine += t.elapsed();
    let mut report = Report {
        log: rreport.log.clone(),
        warnings: rreport.warnings.clone(),
        recombine: rreport,
        ..Default::default()
    };

    let t = Instant::now();
    for level in 1..=opts.refine {
        progress(
            opts,
            Stage::Refine,
            usize::from(level - 1),
            usize::from(opts.refine),
        );
        let r = refine::refine(&mut mesh)?;
        report.log.push(format!(
            "refinement {level}: {} quads, {} line elements, {} new nodes",
            r.quads, r.lines, r.nodes_added
        ));
        report.refine.push(r);
    }
    if opts.refine > 0 {
        progress(
            opts,
            Stage::Refine,
            usize::from(opts.refine),
            usize::from(opts.refine),
        );
    }
    times.refine += t.elapsed();
    let refined = (opts.refine > 0).then(|| mesh.clone());
    Ok(Recombined {
        mesh,
        report,
        refined,
        prepared,
    })
}

/// The second half of a run: optimize `mesh` (all surfaces, or without
/// [`Options::optimize`] those in `force`; none when neither), the input side of the
/// checks prepared on its own thread meanwhile when it is missing. Adds the optimizer's
/// report and log lines to `report`.
#[allow(clippy::too_many_arguments)]
fn optimize_once<'a>(
    input: &'a Mesh,
    mesh: &mut Mesh,
    opts: &Options,
    force: &HashSet<i32>,
    reused: &[i32],
    prepared: Option<optimize::PreparedReference>,
    checks: &mut Option<Checks<'a>>,
    times: &mut Times,
    report: &mut Report,
) -> Result<(), Error> {
    if !opts.optimize && force.is_empty() {
        return Ok(());
    }
    let t = Instant::now();
    let mut oopts = optimize::OptimizeOptions::default();
    // a refined mesh has 2^N times more nodes across: smoothing needs as many more
    // sweeps to carry a move as far
    oopts.smooth_iterations = opts
        .smooth
        .unwrap_or(oopts.smooth_iterations << opts.refine);
    oopts.topology = opts.topology;
    oopts.reference_size_scale = 0.5f64.powi(i32::from(opts.refine));
    let cb = |p: Progress| {
        if let Some(f) = &opts.progress {
            f.report(p);
        }
    };
    if opts.progress.is_some() {
        oopts.progress = Some(&cb);
    }
    oopts.trace = opts.trace.as_ref();
    let prepared = prepared.unwrap_or_else(|| optimize::PreparedReference::new(input));
    // periodic surfaces keep the matching's quads (master and slave stay images of
    // each other, node for node)
    let mut skip: Vec<i32> = mesh
        .periodic
        .iter()
        .filter(|p| p.dim == 2)
        .flat_map(|p| [p.tag, p.master_tag])
        .collect();
    if !opts.optimize {
        // only the surfaces in `force`
        skip.extend(
            mesh.element_blocks
                .iter()
                .filter(|b| b.entity_dim == 2 && !force.contains(&b.entity_tag))
                .map(|b| b.entity_tag),
        );
    }
    if !opts.smooth_quads {
        // the surfaces the user meshed with quads alone stay as read (those in `force`
        // excepted: without `optimize`, the ones the checks found not valid)
        skip.extend(
            quad_only_surfaces(input)
                .into_iter()
                .filter(|s| !force.contains(s)),
        );
    }
    // the surfaces whose optimized state an earlier job gave back
    skip.extend_from_slice(reused);
    skip.sort_unstable();
    skip.dedup();
    oopts.skip = &skip;
    // memory: the input side of the final checks is prepared while the optimizer runs
    // (its arrays are then live anyway), not during the matching
    let want_checks = checks.is_none();
    let (orep, ready) = std::thread::scope(|sc| {
        let ready = want_checks.then(|| sc.spawn(|| Checks::new(input, opts.refine == 0)));
        let orep = optimize::optimize_prepared(mesh, prepared, &oopts);
        (orep, ready.map(|h| h.join()))
    });
    match ready {
        Some(Ok(ready)) => *checks = Some(ready),
        Some(Err(panic)) => std::panic::resume_unwind(panic),
        None => {}
    }
    let orep = orep?;
    for s in &orep.surfaces {
        report.log.push(format!(
            "surface {}: optimized, eta_w {:.3} -> {:.3}, mean eta {:.3} -> {:.3}, {} quads",
            s.surface,
            s.before.eta_worst,
            s.after.eta_worst,
            s.before.eta_mean,
            s.after.eta_mean,
            s.after.quads
        ));
    }
    report.optimize = Some(orep);
    times.optimize += t.elapsed();
    Ok(())
}

/// The surfaces of `mesh` with 4-node quads and no 3-node triangle: meshed with quads
/// alone, they have nothing to recombine.
fn quad_only_surfaces(mesh: &Mesh) -> Vec<i32> {
    let with = |t: u32| mesh.sorted_surfaces(|b| b.element_type == t && !b.is_empty());
    let triangles = with(etype::TRI3);
    let mut quads = with(etype::QUAD4);
    quads.retain(|s| triangles.binary_search(s).is_err());
    quads
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::sync::Mutex;

    /// Every report of one `quadrangulate` of the repository's rectangle (1792 triangles,
    /// one surface).
    fn reports(opts: Options) -> (Vec<Progress>, Report) {
        reports_of("geo/rectangle.msh", opts)
    }

    /// Every report of one `quadrangulate` of the repository's file `path`.
    fn reports_of(path: &str, opts: Options) -> (Vec<Progress>, Report) {
        let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join(path);
        let mut mesh = crate::msh::read_file(&path).expect("a mesh of the repository");
        let seen = Arc::new(Mutex::new(Vec::new()));
        let sink = Arc::clone(&seen);
        let opts = Options {
            progress: Some(ProgressFn::new(move |p| {
                sink.lock().expect("lock").push(p);
            })),
            ..opts
        };
        let report = quadrangulate(&mut mesh, &opts).expect("quadrangulate");
        let seen = seen.lock().expect("lock").clone();
        (seen, report)
    }

    /// The stages of `seen`, each once per stretch of reports.
    fn stage_order(seen: &[Progress]) -> Vec<Stage> {
        let mut order: Vec<Stage> = seen.iter().map(|p| p.stage).collect();
        order.dedup();
        order
    }

    #[test]
    fn progress_comes_in_stage_order_and_ends_every_stage() {
        let (seen, report) = reports(Options::default());
        assert_eq!(report.rounds, 1);
        let order = stage_order(&seen);
        assert_eq!(
            order,
            [
                Stage::Topology,
                Stage::Graph,
                Stage::Matching,
                Stage::Optimize,
                Stage::Check
            ]
        );
        for stage in &order {
            let of: Vec<&Progress> = seen.iter().filter(|p| p.stage == *stage).collect();
            for w in of.windows(2) {
                assert!(w[0].fraction() <= w[1].fraction(), "{stage:?}: {w:?}");
            }
            for p in &of {
                assert!(p.total > 0 && p.done <= p.total, "{p:?}");
                assert!((0.0..=1.0).contains(&p.fraction()));
            }
            let last = of.last().expect("a report");
            assert_eq!(last.done, last.total, "{stage:?} does not end complete");
        }
        // the solver's progress shows inside the matching stage, not only its ends
        assert!(
            seen.iter()
                .any(|p| p.stage == Stage::Matching && p.done > 0 && p.done < p.total),
            "{seen:?}"
        );
        let matching = seen.iter().find(|p| p.stage == Stage::Matching);
        assert_eq!(matching.map(|p| (p.surfaces, p.total)), Some((1, 1792)));
        // the stages that go surface by surface end with every surface done
        for stage in [Stage::Graph, Stage::Matching, Stage::Optimize] {
            let last = seen.iter().rfind(|p| p.stage == stage);
            assert_eq!(last.map(|p| (p.surfaces_done, p.surfaces)), Some((1, 1)));
        }
        // optimizer steps, not one jump
        let optimize = seen.iter().filter(|p| p.stage == Stage::Optimize).count();
        assert!(optimize >= 4, "{seen:?}");
        // throttled: far fewer reports than triangles
        assert!(seen.len() < 400, "{} reports", seen.len());
    }

    /// `seen` cut where the stage changes: each stretch is one stage of one round.
    fn stretches(seen: &[Progress]) -> Vec<&[Progress]> {
        seen.chunk_by(|a, b| a.stage == b.stage).collect()
    }

    #[test]
    fn every_stage_moves_from_0_to_1() {
        // one surface; twelve surfaces matched side by side (a surface's matching may be
        // done before the last graph is, so the matching stage starts past 0 unless the
        // reporter says 0 first); refinement and a fallback round
        for (path, opts) in [
            ("geo/rectangle.msh", Options::default()),
            (
                "geo/rectangle.msh",
                Options {
                    refine: 1,
                    ..Options::default()
                },
            ),
            (
                "tests/data/cad/v22_fillet_box_own_jacobian.msh",
                Options::default(),
            ),
        ] {
            let (seen, _) = reports_of(path, opts);
            let runs = stretches(&seen);
            assert!(runs.len() >= 5, "{path}: {seen:?}");
            for run in runs {
                let stage = run[0].stage;
                assert_eq!(run[0].done, 0, "{path}: {stage:?} starts past 0: {run:?}");
                for w in run.windows(2) {
                    assert!(w[0].fraction() <= w[1].fraction(), "{path}: {w:?}");
                }
                let last = run[run.len() - 1];
                assert_eq!(
                    last.done, last.total,
                    "{path}: {stage:?} ends short: {run:?}"
                );
            }
        }
    }

    #[test]
    fn the_memory_release_runs_between_stages() {
        use std::sync::atomic::{AtomicUsize, Ordering};
        static CALLS: AtomicUsize = AtomicUsize::new(0);
        fn count() {
            CALLS.fetch_add(1, Ordering::Relaxed);
        }
        // the first setting in this test binary (no other test sets one)
        set_memory_release(count);
        let before = CALLS.load(Ordering::Relaxed);
        let (_, report) = reports(Options::default());
        assert_eq!(report.rounds, 1);
        // after the topology, before the optimizer, before the checks (the surface is too
        // small for the one before its solver)
        assert!(CALLS.load(Ordering::Relaxed) - before >= 3);
    }

    #[test]
    fn progress_reports_refinement_levels_in_order() {
        let (seen, _) = reports(Options {
            refine: 1,
            optimize: false,
            ..Options::default()
        });
        let order = stage_order(&seen);
        assert_eq!(
            order,
            [
                Stage::Topology,
                Stage::Graph,
                Stage::Matching,
                Stage::Refine,
                Stage::Check
            ]
        );
        let refine = seen.iter().rfind(|p| p.stage == Stage::Refine);
        assert_eq!(refine.map(|p| (p.done, p.total)), Some((1, 1)));
    }

    #[test]
    fn the_reporter_drops_late_and_small_steps_and_ends_a_stage_overtaken() {
        let seen = Arc::new(Mutex::new(Vec::new()));
        let sink = Arc::clone(&seen);
        let r = Reporter::wrap(&ProgressFn::new(move |p| {
            sink.lock().expect("lock").push((p.stage, p.done))
        }));
        for (stage, done) in [
            (Stage::Graph, 0),
            (Stage::Graph, 1), // less than 1/200 more: dropped
            (Stage::Graph, 500),
            (Stage::Graph, 400),   // went back: dropped
            (Stage::Matching, 10), // Graph ends first
            (Stage::Graph, 1000),  // an earlier stage: dropped
            (Stage::Matching, 1000),
            (Stage::Matching, 1000), // already ended: dropped
            (Stage::Topology, 0),    // a new round
            (Stage::Check, 0),
            (Stage::Optimize, 0), // an earlier stage before the checks end: dropped
            (Stage::Check, 1000),
            (Stage::Optimize, 0), // a round that only optimizes
        ] {
            r.report(Progress::new(stage, done, 1000));
        }
        assert_eq!(
            *seen.lock().expect("lock"),
            [
                (Stage::Graph, 0),
                (Stage::Graph, 500),
                (Stage::Graph, 1000),
                (Stage::Matching, 0), // a stage starts at 0
                (Stage::Matching, 10),
                (Stage::Matching, 1000),
                (Stage::Topology, 0),
                (Stage::Topology, 1000), // ended when the checks overtook it
                (Stage::Check, 0),
                (Stage::Check, 1000),
                (Stage::Optimize, 0),
            ]
        );
    }
}
