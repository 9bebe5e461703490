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
//!    that side. When no fan is left to split under (nor, in a job that peels fans, to
//!    peel), a bad quad flat at a boundary node where its diagonal ends gets the boundary
//!    segment opposite that node split, the longer of its triangles' two, when the
//!    triangle over it is wide there (120° or more): two curves side by side a fraction of
//!    a segment apart, the triangle between a node of one and a segment of the other makes
//!    a flat corner with either neighbour, and its halves pair with one neighbour each.
//!    At most [`SEGMENT_ROUNDS`] rounds split segments, before any triangle is split. A job
//!    that still fails with such splits runs again without them.
//! 3. **Splits.** When no bad quad is left to price, the input triangles around each bad
//!    quad (those holding one of its input nodes, or the nearest one to a quad of new
//!    nodes) are split into three quads each before the matching
//!    ([`crate::recombine::split_triangles`]); a second split round adds one more ring (the
//!    triangles touching those), up to [`SPLIT_RINGS`] rings. When that first ring would
//!    break the element-count rule (0.6 new quads per input triangle, a quarter more under
//!    500 triangles), the splits are **tight**: the first ring of a bad pair is its own two
//!    triangles, and a bad quad after a split round whose bad corner is at a node the input
//!    does not have (the matching merged the two halves of a triangle halved beside split
//!    ones: a flat corner at the split edge's midpoint) first gets the same splits again
//!    with such halves priced out
//!    ([`crate::recombine::RecombineOptions::flat_halves_out`]), once, before another ring.
//!    When a round's bad quad has its bad corner at a node of the job that the optimizer
//!    moved (or the optimizer turned bad a quad holding such a node), the optimizer holds
//!    the corners at those nodes on that quad's surface to the faces the validity gate
//!    measures them about from the next round on
//!    ([`crate::optimize::OptimizeOptions::located_surfaces`]; the other surfaces keep the
//!    optimization, and the reuse, of the rounds before): on a coarse curved face it
//!    otherwise moves a split triangle's centroid or midpoint onto a face turned far from
//!    the quad.
//! 4. **Last resort.** Quads still bad after that get every triangle of their surface split
//!    (the splits' halved neighbours along shared curves may bring another surface there in
//!    the next round; segment splits are dropped then), up to [`FALLBACK_ROUNDS`] rounds in
//!    all. Each surface counts its own split rounds, so a surface that first has a bad quad
//!    after splits elsewhere starts from its first ring. Where that differs from counting
//!    the rounds over the job (the n-th split round splits the n-th ring around every bad
//!    quad, then whole surfaces), the job runs again that way too and the better result is
//!    kept: a valid one, then one within the element-count rule, then the higher worst
//!    quad, then fewer quads (the local rings can end valid where the cascade of whole
//!    surfaces does not, or the other way round). Where the kept job split triangles and
//!    its result breaks the element-count rule (the splits cascaded), or no job was valid,
//!    the job runs again pricing out, in its pricing rounds, every pair with a hopeless
//!    corner at a wall node (near 180° or 0°, which optimization never changes) on the
//!    surfaces of the bad quads, not only the bad pairs
//!    ([`crate::recombine::RecombineOptions::hopeless_out`]): where the surface's structure
//!    forces such a pair (along a curve meshed much finer than the face, boundary nodes
//!    with the two triangles of one fan), pricing the bad pairs one by one moves the flat
//!    corner to the next fan, and the matching now takes extra edges instead. The better
//!    of the two is kept, by the same order, and only it gets the worst-quad tries of
//!    step 5, after one more job, where the fallback split triangles and broke the
//!    element-count rule and the better result still misses a goal (the element-count rule,
//!    or a quad under η [`ETA_FLOOR`]), that **peels boundary fans** before any split: after its pricing
//!    rounds, the fans on the surfaces of the bad quads (runs of boundary nodes each with
//!    exactly two triangles at one apex: a curve meshed finer than its face, where every
//!    perfect matching has a pair flat at a boundary node) and the fan of each bad quad's
//!    corner at such a node get their radial edges split (`fallback::fan_radials`, at
//!    most `PEEL_ROUNDS` rounds), each fan triangle then a quad on the boundary and a
//!    triangle at the apex ([`crate::recombine::split_triangles`]); the matching pairs
//!    those triangles with each other at the radial midpoints, which it does not take for
//!    walls ([`crate::recombine::RecombineOptions::movable_nodes`]) and the optimizer
//!    moves. The better of the two is kept by the same order, except that of two valid
//!    results that both break the element-count rule, one with at most `SMALLER_SHARE`
//!    of the other's new quads per input triangle is better unless its worst quad is under
//!    both [`ETA_FLOOR`] and the other's by more than `SMALLER_ETA_MARGIN`. Where the
//!    fallback split triangles and the result (after
//!    those tries) breaks the element-count rule or has a quad under η [`ETA_FLOOR`], or
//!    where no job was valid, the job runs once more with **flat pairs**: at a surface's
//!    first ring, a bad pair flat or reflex at an end of its diagonal is split into three
//!    quads that leave the edges at that node whole ([`crate::recombine::FlatPair`]; the
//!    two triangles are split as chosen ones from the surface's second ring on), so a
//!    boundary fan's split does not halve the triangles of the face beyond the curve; with
//!    its own worst-quad tries, the better of the two results is kept, by the same order
//!    (where neither is valid, the refusal is the first job's). Where the fallback split
//!    triangles and the kept result still breaks the element-count rule, or no job was
//!    valid, the job runs once more accepting **quads bent across sharp turns**
//!    ([`crate::validity::Bent`]): every other job's rounds also refuse a quad with a
//!    corner that turns positively about its own node's normal but not about the normal at
//!    another node of the quad, which on a surface meshed coarser than its curvature (a
//!    pair across a turn of 90° or more) leaves no valid pair and cascades into splits;
//!    with its own worst-quad tries, the better of the two is kept, by the same order.
//!    Every count of new quads per input triangle is taken before refinement
//!    (`--refine`): a refined result's quads divided by 4 per level. On a refined run the
//!    fallback works on the recombination's quads (each bad quad traced back through the
//!    levels to the quad whose refinement made it, `refine::parent_of`), and the jobs
//!    that price out hopeless pairs and that split flat pairs run wherever the fallback
//!    ran, whatever the count and the worst quad: the quads judged there are those
//!    refinement made, whose corners at curved walls turn bad after the matching, and a
//!    first result within the goals may still be the worse one. Where the fallback ran and
//!    the kept result still misses a goal, the jobs run once more handing the fallback the
//!    refined quads and mesh themselves, and the better result is kept.
//! 5. **The worst quad.** A valid optimized result gets more tries: where the fallback
//!    priced quads out, the fallback with splits only; quads under η [`ETA_FLOOR`] priced
//!    out, or where there is none, those under η [`PRICE_FLOOR`] on surfaces of at most
//!    [`PRICE_TRY_UP_TO`] triangles in all (this try adds no quad); the boundary segments
//!    under the quads under η [`ETA_FLOOR`] with a flat wall corner split (the segment of
//!    the quad's two input triangles that does not end at that corner's node, so the
//!    triangles pair otherwise); up to [`SPLIT_TRIES`] times, the input triangles around
//!    those still under it split (one ring, or two where the first is split already),
//!    each ring try after the first only when the one before was kept; last, where a ring
//!    try raised the worst quad but broke the element-count rule (or was stopped by it, as
//!    below), only the input triangles inside those still under it split (a parity split's
//!    node standing for its segment's ends); and last, the boundary fans of those still
//!    under it whose widest corner is near flat at a fan node peeled (a curve nearly
//!    straight there: the two triangles at the node pair with a valid corner near 180°).
//!    Each is kept only when it raises the worst quad without breaking the element-count
//!    rule. (A mesh of more than [`TRIES_UP_TO`] elements gets them only after a fallback.) A result whose worst quad is at the input's wall-corner
//!    bound (an acute corner of a planar surface, which bounds the worst quad of every
//!    result) gets no more tries.
//!
//! A job that could only be kept within a count of new quads per input triangle (a
//! worst-quad try, against the count it must keep; any job after the first, where the
//! result it competes with is valid: against the element-count rule where that result is
//! within it, and against 1/`SMALLER_SHARE` of that result's count where it breaks the rule
//! with no quad under η [`ETA_FLOOR`], since a valid result with more is then never the
//! better one) stops before a round whose split triangles alone would put it above that
//! count (`fallback::splits_exceed`), and counts as refused: it could not have been kept
//! (the log says so).
//!
//! Quads still bad after the fallback are refused (or listed with
//! [`Options::allow_invalid`]). A run whose quads are all valid the first time, with no
//! quad under η [`PRICE_FLOOR`], pays only for the check.

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
mod options;
mod report;
mod reporter;
mod rounds;

pub use options::Options;
pub use report::{Error, Report, Times};
use reporter::Reporter;
use rounds::*;

use fallback::{
    corner_bounds, count_rule_limit, fallback_triangles, low_quad_fans, low_quad_segments, low_quads, low_quads_eta, pairs_of, quads_per_triangle, quads_under, raisable,
    splits_exceed, surface_elements, surface_elements_where, triangles_inside, wall_corner_bound, FallbackStart, JobNotes,
    LocalFallback, Next, MAX_QUADS_PER_TRIANGLE, PRICE_FLOOR, PRICE_TRY_UP_TO, RAISE_MIN,
};
pub use fallback::{ETA_FLOOR, PRICING_ROUNDS, SEGMENT_ROUNDS, SPLIT_TRIES};
#[cfg(feature = "testing")]
pub use fallback::SPLIT_RINGS;

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

/// Turns every surface's triangles into valid quads: recombination with parity repair,
/// refinement, optimization, then the invariant and validity checks, with the fallback when
/// quads are not valid. A mesh with 6-node triangles is recombined on its corners and
/// written back as 9-node (or, with [`Options::incomplete`], 8-node) quads on its curved
/// geometry. On error `mesh` is unchanged.
///
/// # The validity guarantee
/// When it returns `Ok`, every 4-node quad of every surface is valid (corners strictly
/// between 0° and 180° about the input surface's normal, oriented like the input, no
/// zero-length edge, no repeated node) and the recombination's invariants hold between the
/// input and the result (conformity, no triangle left, curve nodes unmoved, planar areas,
/// physical groups), unless [`Options::allow_invalid`] is set: the bad quads are then
/// listed in [`Report::invalid`] instead.
///
/// # The fallback
/// When quads are not valid after a run, the job runs again from the input, locally: the
/// bad quads priced out of the matching, boundary segments under fans split, then the input
/// triangles around the bad quads split into three quads each (one ring, then two), and as
/// a last resort every triangle of their surface (where that cascaded, other jobs price
/// out every hopeless pair, peel boundary fans, split flat pairs, accept quads bent across
/// sharp turns); up to 10 rounds after the first run
/// ([`Report::rounds`]). Quads still bad then are refused ([`Error::Invalid`]).
pub fn quadrangulate(mesh: &mut Mesh, opts: &Options) -> Result<Report, Error> {
    if let Some(why) = nothing_to_recombine(mesh) {
        return Err(Error::NothingToRecombine(why));
    }
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

/// Why `mesh` gives [`quadrangulate`] nothing to work on: no surface element at all (as
/// `gmsh -1` writes), in words; `None` when some surface has elements (a mesh of quads only
/// goes through). Where a mesh read from a file has physical groups but none on a surface,
/// the words say so: Gmsh then saves only the elements of those groups, so a surface mesh
/// of a model whose groups are all volumes holds no element at all.
pub(crate) fn nothing_to_recombine(mesh: &Mesh) -> Option<String> {
    let count = |dim: i32| -> usize {
        mesh.element_blocks
            .iter()
            .filter(|b| b.entity_dim == dim)
            .map(|b| b.len())
            .sum()
    };
    if count(2) > 0 {
        return None;
    }
    let grouped = |dim: usize| {
        mesh.physical_names.iter().any(|p| p.dim == dim as i32)
            || mesh.entities[dim]
                .iter()
                .any(|e| !e.physical_tags.is_empty())
    };
    let kinds: Vec<&str> = [(0, "points"), (1, "curves"), (3, "volumes")]
        .into_iter()
        .filter(|&(dim, _)| grouped(dim))
        .map(|(_, kind)| kind)
        .collect();
    let groups_only = if kinds.is_empty() || grouped(2) || mesh.format.is_none() {
        String::new()
    } else {
        format!(
            "; Gmsh saves only the elements of physical groups, and this model's groups are all on {}, \
             none on a surface: add a physical surface group, or save every element (gmsh -save_all, \
             Mesh.SaveAll = 1)",
            kinds.join(" and ")
        )
    };
    let (lines, volumes) = (count(1), count(3));
    Some(if volumes > 0 {
        format!("nothing to recombine: no surface elements, only {volumes} volume element(s){groups_only}")
    } else if lines > 0 {
        format!(
            "nothing to recombine: the mesh has no surface elements ({lines} line element(s); made by gmsh -1? mesh the surfaces with gmsh -2){groups_only}"
        )
    } else if !groups_only.is_empty() {
        format!("nothing to recombine: the file holds no elements{groups_only}")
    } else {
        "nothing to recombine: the mesh has no elements (mesh the surfaces first, e.g. with gmsh -2)".to_string()
    })
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
        keep_curve_nodes: true,
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
    let mut cache = Shared::default();
    // on a refined run, the fallback works on the recombination's quads (each bad quad
    // traced back to the quad whose refinement made it)
    let refined = opts.refine > 0;
    let result = jobs(base, opts, refined, &mut cache);
    // where the fallback ran and that misses a goal: the jobs again with the refined quads
    // themselves, and the better of the two
    let missed = fallback_ran(&result)
        && result
            .as_ref()
            .map_or(true, |r| !meets_goals(base, opts, r));
    let result = if refined && missed {
        let other = jobs(base, opts, false, &mut cache);
        keep_better(base, opts, result, other)
    } else {
        result
    };
    match result {
        Ok((out, mut report, end)) => {
            *mesh = out;
            report.warnings.splice(
                0..0,
                dropped
                    .into_iter()
                    .map(|text| Warning::RepeatedTriangles { text }),
            );
            if let Some(checks) = &cache.checks {
                report
                    .warnings
                    .extend(coarse_surfaces(base, &checks.validity, &end.chosen));
            }
            let poor = poor_quads(base, opts, mesh, &report);
            report.warnings.extend(poor);
            report.warnings.extend(fine_curves(base, opts, mesh, &report));
            Ok(report)
        }
        Err(e) => {
            *mesh = input;
            Err(e)
        }
    }
}

/// Where the fallback peeled boundary fans and the result has more new quads per input
/// triangle than the element-count rule ([`count_rule_limit`]): a warning naming the
/// surfaces with peeled triangles.
fn fine_curves(input: &Mesh, opts: &Options, out: &Mesh, report: &Report) -> Option<Warning> {
    let split = report.fallback.as_ref().filter(|f| f.triangles_peeled > 0)?;
    let per_triangle = quads_per_triangle(input, out, opts.refine);
    let limit = count_rule_limit(surface_elements(input, etype::TRI3));
    (per_triangle > limit).then(|| Warning::FineCurves {
        surfaces: split.peeled_surfaces.clone(),
        peeled: split.triangles_peeled,
        quads_per_triangle: per_triangle,
    })
}

/// True when the fallback did anything for `r`: more than one round, triangles split or
/// pairs priced out (by the rounds or the worst-quad tries), or nothing was valid.
fn fallback_ran(r: &JobResult) -> bool {
    match r {
        Ok(r) => r.1.rounds > 1 || !r.2.chosen.is_empty() || !r.2.priced.is_empty(),
        Err(e) => matches!(e, Error::Invalid { .. } | Error::FallbackExhausted),
    }
}

/// The jobs of a run, in order (see the module doc): the first one, and the others where
/// it split triangles and misses a goal, each kept where better; `traced`: on a refined run,
/// the fallback works on the recombination's quads, each bad quad traced back to the quad
/// whose refinement made it ([`FallbackStart::traced`]).
fn jobs<'a>(base: &'a Mesh, opts: &Options, traced: bool, cache: &mut Shared<'a>) -> JobResult {
    let from = FallbackStart {
        traced,
        ..FallbackStart::default()
    };
    // the rings counted per surface first; where that made a difference, the rings
    // counted over the job too, and the better of the two
    let (local, diverged, _) = run_job(base, opts, from.clone(), None, cache);
    let result = if diverged {
        let start = FallbackStart {
            global_rings: true,
            ..from.clone()
        };
        let cap = count_cap(base, opts, &local);
        let name = job_name(&start);
        let (global, _, stopped) = run_job(base, opts, start, cap, cache);
        match (local, global) {
            (Ok(a), Ok(b)) => Ok(better_job(base, opts, a, b)),
            (Ok(a), Err(_)) => Ok(note_stopped(a, &name, stopped)),
            (Err(_), global) => global,
        }
    } else {
        // the same job either way: the worst-quad tries count their rings over the job
        local.map(|mut r| {
            r.2.global_rings = true;
            r
        })
    };
    // whether the fallback split triangles (or nothing was valid), before the worst-quad
    // tries
    let split = match &result {
        Ok(r) => !r.2.chosen.is_empty(),
        Err(e) => matches!(e, Error::Invalid { .. } | Error::FallbackExhausted),
    };
    // where the fallback split triangles and the result breaks the element-count rule (the
    // splits cascaded), or nothing was valid: the job that prices out every pair with a
    // hopeless corner at a wall node on the surfaces of the bad quads, and the better of the
    // two (before the worst-quad tries, which only the kept one gets). On a refined run,
    // wherever the fallback ran: the quads it judges there are those refinement made,
    // whose corners at curved walls turn bad after the matching, and a first result within
    // the goals may still be the worse one
    let breaks_count_rule =
        |r: &JobResult| r.as_ref().map_or(true, |r| !job_measures(base, opts, r).1);
    let refined_fallback = opts.refine > 0 && fallback_ran(&result);
    let result = if refined_fallback || (split && breaks_count_rule(&result)) {
        let start = FallbackStart {
            hopeless: true,
            ..from.clone()
        };
        let result = with_job(base, opts, result, start, false, cache);
        // where that still misses a goal: the job that peels boundary fans
        if result.as_ref().map_or(true, |r| !meets_goals(base, opts, r)) {
            let start = FallbackStart {
                peel_fans: true,
                ..from.clone()
            };
            with_job(base, opts, result, start, false, cache)
        } else {
            result
        }
    } else {
        result
    };
    let result = result.and_then(|first| raise_worst_quad(base, opts, first, cache));
    // where the fallback split triangles and the result misses a goal (above the
    // element-count rule, or a quad under η ETA_FLOOR), or where nothing was valid (and on
    // a refined run wherever the fallback ran): the same with flat pairs, with its
    // worst-quad tries, and the better of the two
    let missed = result
        .as_ref()
        .map_or(true, |r| !meets_goals(base, opts, r));
    let result = if refined_fallback || (split && missed) {
        let start = FallbackStart {
            flat_pairs: true,
            ..from.clone()
        };
        with_job(base, opts, result, start, true, cache)
    } else {
        result
    };
    // where the fallback split triangles and the result still breaks the element-count
    // rule (on a surface meshed coarser than its curvature, pairs across its sharp turns
    // fail at the other nodes' normals, and the splits cascade), or nothing was valid: the
    // job that accepts quads bent across a sharp turn (`validity::Bent`), with its
    // worst-quad tries, and the better of the two
    if split && breaks_count_rule(&result) {
        let start = FallbackStart {
            bent: crate::validity::Bent::Accepted,
            ..from
        };
        with_job(base, opts, result, start, true, cache)
    } else {
        result
    }
}

/// The surfaces where the fallback split triangles (`chosen`, tags of `input`'s) at a node
/// the surface wraps round ([`validity::Reference::wrapped_among`]): meshed coarser than
/// their curvature, so no pair of triangles there made a valid quad: a warning each, in
/// surface order, naming such a node.
fn coarse_surfaces(
    input: &Mesh,
    reference: &validity::Reference,
    chosen: &HashSet<u64>,
) -> Vec<Warning> {
    if chosen.is_empty() {
        return Vec::new();
    }
    // the nodes of each surface's split triangles
    let mut split: std::collections::BTreeMap<i32, Vec<u64>> = Default::default();
    for b in input
        .element_blocks
        .iter()
        .filter(|b| b.entity_dim == 2 && b.element_type == etype::TRI3)
    {
        for (i, tag) in b.tags.iter().enumerate() {
            if chosen.contains(tag) {
                split
                    .entry(b.entity_tag)
                    .or_default()
                    .extend_from_slice(b.element(i));
            }
        }
    }
    split
        .into_iter()
        .filter_map(|(surface, mut nodes)| {
            nodes.sort_unstable();
            nodes.dedup();
            let node = reference.wrapped_among(surface, &nodes)?;
            Some(Warning::CoarseSurface { surface, node })
        })
        .collect()
}

/// The quads of `mesh` (the job's result, `report` its report) under η [`ETA_FLOOR`] on
/// surfaces without a [`Warning::CoarseSurface`] where the input's corners allow better
/// (below the surface's corner bound, [`corner_bounds`], by more than [`RAISE_MIN`]; an
/// estimate on a curved surface): one warning naming them. None without optimization (the
/// matching's quads as they are) or with quads listed as invalid.
fn poor_quads(input: &Mesh, opts: &Options, mesh: &Mesh, report: &Report) -> Option<Warning> {
    if !opts.optimize || !report.invalid.is_empty() {
        return None;
    }
    let skip = unmeasured_surfaces(input, opts);
    // speed: a one-round result whose every measured surface was optimized in it and
    // ended at η ETA_FLOOR or more has no such quad (the optimizer's own figures)
    let surfaces = report.optimize.as_ref().map_or(&[][..], |o| &o.surfaces[..]);
    let optimized: HashSet<i32> = surfaces.iter().map(|s| s.surface).collect();
    let all_optimized = mesh
        .sorted_surfaces(|b| b.element_type == etype::QUAD4 && !b.is_empty())
        .iter()
        .all(|s| optimized.contains(s) || skip.binary_search(s).is_ok());
    let low_after = surfaces.iter().any(|s| s.after.eta_worst < ETA_FLOOR);
    if report.rounds <= 1 && all_optimized && !low_after {
        return None;
    }
    let (low, _) = low_quads_eta(mesh, &skip, ETA_FLOOR);
    if low.is_empty() {
        return None;
    }
    let coarse: Vec<i32> = report
        .warnings
        .iter()
        .filter_map(|w| match w {
            Warning::CoarseSurface { surface, .. } => Some(*surface),
            _ => None,
        })
        .collect();
    // refinement moves the new curve nodes off the walls' lines: no bound then
    let bounds: std::collections::HashMap<i32, f64> = match opts.refine {
        0 => corner_bounds(input)
            .into_iter()
            .map(|c| (c.surface, c.bound))
            .collect(),
        _ => Default::default(),
    };
    let etas: Vec<(i32, f64)> = low
        .iter()
        .map(|&((s, _), eta)| (s, eta))
        .filter(|(s, eta)| {
            !coarse.contains(s) && raisable(*eta, bounds.get(s).copied().unwrap_or(1.0))
        })
        .collect();
    if etas.is_empty() {
        return None;
    }
    let mut surfaces: Vec<i32> = etas.iter().map(|e| e.0).collect();
    surfaces.sort_unstable();
    surfaces.dedup();
    Some(Warning::PoorQuads {
        count: etas.len(),
        surfaces,
        eta_w: etas.iter().map(|e| e.1).fold(f64::INFINITY, f64::min),
    })
}

/// A job's result: the output, its report and the fallback's state at its end.
type JobResult = Result<(Mesh, Report, FallbackStart), Error>;

/// The better of `result` and another job from `start` (its split rings counted as
/// `result`'s), that job with its worst-quad tries when `tries` ([`keep_better`]).
fn with_job<'a>(
    base: &'a Mesh,
    opts: &Options,
    result: JobResult,
    start: FallbackStart,
    tries: bool,
    cache: &mut Shared<'a>,
) -> JobResult {
    let start = FallbackStart {
        global_rings: result.as_ref().is_ok_and(|r| r.2.global_rings),
        ..start
    };
    let cap = count_cap(base, opts, &result);
    let name = job_name(&start);
    let (other, _, stopped) = run_job(base, opts, start, cap, cache);
    let other = match tries {
        true => other.and_then(|first| raise_worst_quad(base, opts, first, cache)),
        false => other,
    };
    keep_better(base, opts, result, other).map(|kept| note_stopped(kept, &name, stopped))
}

/// `kept` with a log line saying that the job `name` stopped, where `stopped` is the count
/// its split triangles alone went beyond (a result above it could not have been kept).
fn note_stopped(
    mut kept: (Mesh, Report, FallbackStart),
    name: &str,
    stopped: Option<f64>,
) -> (Mesh, Report, FallbackStart) {
    if let Some(cap) = stopped {
        kept.1.log.push(format!(
            "fallback: {name} stopped: its split triangles alone put it above {cap:.3} new quads \
             per input triangle, where it could not have been kept"
        ));
    }
    kept
}

/// The most new quads per input triangle another job's result may have and still be the
/// better one against `result` ([`better_job`]): where `result` is valid and within the
/// element-count rule, the rule's limit; where it is valid, breaks the rule and has no quad
/// under η [`ETA_FLOOR`], its own count over [`SMALLER_SHARE`] (against a valid result with
/// more, `result` is the much smaller one, whatever that result's worst quad; an invalid
/// one is never better); otherwise none.
fn count_cap(base: &Mesh, opts: &Options, result: &JobResult) -> Option<f64> {
    let r = result.as_ref().ok()?;
    let (valid, within, per_triangle) = count_measures(base, opts, r);
    if !valid {
        return None;
    }
    if within {
        return Some(count_rule_limit(surface_elements(base, etype::TRI3)));
    }
    let worst = low_quads(&r.0, &unmeasured_surfaces(base, opts)).1;
    (worst >= ETA_FLOOR).then(|| per_triangle / SMALLER_SHARE)
}

/// One job's rounds from `start`; a job that split boundary segments under fans and still
/// failed runs again without them (on strips that share curves, a segment split moves one
/// strip's imbalance to the next). Returns the result and whether per-surface rings made a
/// difference in either run ([`FallbackStart::global_rings`]), and `cap` where the job was
/// refused because its split triangles alone put it above `cap` new quads per input
/// triangle, where it stopped ([`run_rounds`]).
fn run_job<'a>(
    base: &'a Mesh,
    opts: &Options,
    start: FallbackStart,
    cap: Option<f64>,
    cache: &mut Shared<'a>,
) -> (JobResult, bool, Option<f64>) {
    let mut notes = JobNotes::default();
    let again = FallbackStart {
        no_segments: true,
        global_rings: start.global_rings,
        traced: start.traced,
        ..FallbackStart::default()
    };
    let result = run_rounds(base, opts, start, cap, cache, &mut notes).or_else(|e| match e {
        Error::Invalid { .. } | Error::FallbackExhausted
            if notes.segments_used && !notes.over_count =>
        {
            run_rounds(base, opts, again, cap, cache, &mut notes)
        }
        e => Err(e),
    });
    let stopped = cap.filter(|_| notes.over_count && result.is_err());
    (result, notes.rings_diverged, stopped)
}

/// The better of two jobs' outcomes ([`better_job`] when both are valid); where both were
/// refused, the first refusal.
fn keep_better(
    base: &Mesh,
    opts: &Options,
    a: JobResult,
    b: JobResult,
) -> JobResult {
    match (a, b) {
        (Ok(a), Ok(b)) => Ok(better_job(base, opts, a, b)),
        (Ok(a), Err(_)) => Ok(a),
        (Err(_), Ok(b)) => Ok(b),
        (Err(e), Err(_)) => Err(e),
    }
}

/// True when `r` keeps the element-count rule ([`count_rule_limit`]), lists no invalid
/// quad and has no quad under η [`ETA_FLOOR`] (quad-only input surfaces left aside unless
/// they are smoothed).
fn meets_goals(input: &Mesh, opts: &Options, r: &(Mesh, Report, FallbackStart)) -> bool {
    let (valid, within, worst, _) = job_measures(input, opts, r);
    valid && within && worst >= ETA_FLOOR
}

/// A result's measures for [`better_job`], each better when larger except the last: no
/// quad listed as invalid, within the element-count rule, worst quad η, new quads per
/// input triangle.
fn job_measures(
    input: &Mesh,
    opts: &Options,
    r: &(Mesh, Report, FallbackStart),
) -> (bool, bool, f64, f64) {
    let (valid, within, per_triangle) = count_measures(input, opts, r);
    (
        valid,
        within,
        low_quads(&r.0, &unmeasured_surfaces(input, opts)).1,
        per_triangle,
    )
}

/// The measures of [`job_measures`] that need no quality pass: no quad listed as invalid,
/// within the element-count rule, and the new quads per input triangle.
fn count_measures(
    input: &Mesh,
    opts: &Options,
    r: &(Mesh, Report, FallbackStart),
) -> (bool, bool, f64) {
    let limit = count_rule_limit(surface_elements(input, etype::TRI3));
    let per_triangle = quads_per_triangle(input, &r.0, opts.refine);
    (r.1.invalid.is_empty(), per_triangle <= limit, per_triangle)
}

/// New quads per input triangle, as a share of the other result's, at or below which a
/// valid result that breaks the element-count rule is better than another that breaks it
/// too, unless its worst quad is under both [`ETA_FLOOR`] and the other's by more than
/// [`SMALLER_ETA_MARGIN`] (see [`better_job`]).
const SMALLER_SHARE: f64 = 0.8;

/// How much lower than the other's a much smaller result's worst quad η may be (see
/// [`SMALLER_SHARE`]).
const SMALLER_ETA_MARGIN: f64 = 0.05;

/// The better of two valid results of the same input: one with no quad listed as invalid
/// ([`Options::allow_invalid`]), then one within the element-count rule
/// ([`count_rule_limit`]); of two that both break it, one with at most [`SMALLER_SHARE`]
/// of the other's new quads per input triangle whose worst quad η is at least [`ETA_FLOOR`]
/// or the other's, or at most [`SMALLER_ETA_MARGIN`] below the other's (a cascade of splits
/// gives sound quads, but three per triangle); then the
/// higher worst quad η (by more than [`RAISE_MIN`]), then fewer quads; `a` on a tie.
fn better_job(
    input: &Mesh,
    opts: &Options,
    a: (Mesh, Report, FallbackStart),
    b: (Mesh, Report, FallbackStart),
) -> (Mesh, Report, FallbackStart) {
    let measure = |r: &(Mesh, Report, FallbackStart)| job_measures(input, opts, r);
    let (x, y) = (measure(&a), measure(&b));
    // of two valid results that both break the element-count rule, a much smaller one
    // whose worst quad is not below both the floor and the other's, or not much below
    let smaller = |a: &(bool, bool, f64, f64), b: &(bool, bool, f64, f64)| {
        a.0 && !a.1
            && a.3 <= SMALLER_SHARE * b.3
            && (a.2 >= ETA_FLOOR.min(b.2) || b.2 - a.2 <= SMALLER_ETA_MARGIN)
    };
    let b_better = if (x.0, x.1) != (y.0, y.1) {
        (y.0, y.1) > (x.0, x.1)
    } else if smaller(&x, &y) || smaller(&y, &x) {
        smaller(&y, &x)
    } else if (x.2 - y.2).abs() > RAISE_MIN {
        y.2 > x.2
    } else {
        y.3 < x.3
    };
    let (mut kept, other) = if b_better { (b, a) } else { (a, b) };
    let variant = |r: &(Mesh, Report, FallbackStart)| job_name(&r.2);
    let (k, o) = if b_better { (y, x) } else { (x, y) };
    kept.1.log.push(format!(
        "fallback: {} kept (quads per triangle {:.3}, eta_w {:.3}), not {} ({:.3}, {:.3})",
        variant(&kept),
        k.3,
        k.2,
        variant(&other),
        o.3,
        o.2,
    ));
    kept.1.times = add_times(&other.1.times, &kept.1.times);
    kept
}

/// The job a start describes, in the log's words ("split rings counted per surface, boundary
/// fans peeled").
fn job_name(start: &FallbackStart) -> String {
    let rings = match start.global_rings {
        true => "split rings counted over the job",
        false => "split rings counted per surface",
    };
    let pairs = match start.flat_pairs {
        true => format!("{rings}, flat pairs"),
        false => rings.to_string(),
    };
    let hopeless = match start.hopeless {
        true => format!("{pairs}, every pair with a corner near 180 or 0 degrees at a wall node priced out"),
        false => pairs,
    };
    let peeled = match start.peel_fans {
        true => format!("{hopeless}, boundary fans peeled"),
        false => hopeless,
    };
    let bent = match start.bent {
        crate::validity::Bent::Accepted => format!("{peeled}, quads bent across sharp turns accepted"),
        crate::validity::Bent::Refused => peeled,
    };
    match start.traced {
        true => format!("{bent}, bad quads traced back to the recombination's"),
        false => bent,
    }
}

fn progress(opts: &Options, stage: Stage, done: usize, total: usize) {
    if let Some(p) = &opts.progress {
        p.report(Progress::new(stage, done as u64, total as u64));
    }
}

/// What the jobs of one run share: the surfaces they recombined and optimized
/// ([`recombine::MatchMemo`], [`crate::reuse`]) and the input side of the final checks,
/// prepared once (all depend on the input alone).
#[derive(Default)]
struct Shared<'a> {
    /// The matchings of the run's recombinations from its second one.
    matchings: recombine::MatchMemo,
    /// Recombinations done in the run.
    recombinations: usize,
    surfaces: SurfaceCache,
    /// Prepared during the first round's optimization (or its matching, without the
    /// optimizer).
    checks: Option<Checks<'a>>,
    /// The first round of a job from the input alone (nothing priced, avoided, split or
    /// located), once one ended with quads that are not valid: every such round of the run
    /// has this outcome.
    first_round: Option<Outcome>,
    /// The worst quad η after the first schedules of the run's first optimization
    /// ([`optimize::OptimizeReport::trial_worst`]), which every later one is given: a
    /// surface optimized from the same quads ends the same in every job.
    trial_worst: Option<f64>,
}

/// A round's outcome, as the rest of its job reads it.
#[derive(Clone)]
struct Outcome {
    /// The checked mesh (a surface the optimizer left invalid given its quads from before
    /// optimization back, when that is valid).
    mesh: Mesh,
    /// The round's recombination, refinement and optimization reports.
    report: Report,
    /// The quads of `mesh` that are not valid.
    bad: Vec<BadQuad>,
    /// Surfaces where the optimizer left a quad bad at a new node it moved, or turned one
    /// bad, and does not hold their corners yet.
    turned_bad: Vec<i32>,
    /// The recombination and refinement reports alone.
    recombined: Report,
    /// After a refinement, its meshes.
    refined: Option<Refinement>,
    /// After a first invalid round, the mesh before optimization.
    unoptimized: Option<Mesh>,
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
    /// After a refinement, its meshes.
    refined: Option<Refinement>,
    /// The optimizer's reference, when it was prepared beside the recombination.
    prepared: Option<optimize::PreparedReference>,
}

/// A refined round before optimization: the refined mesh, and what traces its elements
/// back to the recombination's.
#[derive(Clone)]
struct Refinement {
    /// The recombination's element blocks (its nodes are all in `mesh`, where refinement
    /// left them).
    recombined: Vec<crate::mesh::ElementBlock>,
    /// The element type and length of each block each level refined, the recombination's
    /// first (element `i` of a block is the parent of elements `k·i .. k·i + k` of the same
    /// block one level on, [`refine::parent_of`]).
    shapes: Vec<Vec<(u32, usize)>>,
    /// The refined mesh (the invariants' baseline).
    mesh: Mesh,
}

impl Refinement {
    /// The recombination as a mesh: its elements on the refined mesh's nodes.
    fn recombination(&self) -> Mesh {
        Mesh {
            element_blocks: self.recombined.clone(),
            ..self.mesh.clone()
        }
    }
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
    hopeless_out: &[i32],
    movable: &[u64],
    optimizing: bool,
    checks: &mut Option<Checks<'a>>,
    matchings: Option<&recombine::MatchMemo>,
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
        hopeless_out: hopeless_out.to_vec(),
        movable_nodes: movable.to_vec(),
        trace: opts.trace.clone(),
        progress: opts.progress.clone(),
        // `quadrangulate` removed them from `input` (the fallback's splits add none)
        repeated_dropped: true,
        split_matching: opts.split_matching,
        turn_strip_ends: !opts.keep_curve_nodes,
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
        let r = recombine::recombine_with(&mut mesh, &ropts, matchings);
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
    let recombined = (opts.refine > 0).then(|| mesh.element_blocks.clone());
    let mut shapes = Vec::with_capacity(usize::from(opts.refine));
    for level in 1..=opts.refine {
        shapes.push(
            mesh.element_blocks
                .iter()
                .map(|b| (b.element_type, b.len()))
                .collect(),
        );
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
    let refined = recombined.map(|recombined| Refinement {
        recombined,
        shapes,
        mesh: mesh.clone(),
    });
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
    located: &[i32],
    prepared: Option<optimize::PreparedReference>,
    (checks, trial_worst): (&mut Option<Checks<'a>>, &mut Option<f64>),
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
    oopts.conformal_multigrid = opts.conformal_multigrid;
    oopts.located_surfaces = located;
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
    oopts.trial_worst = *trial_worst;
    let prepared = prepared.unwrap_or_else(|| optimize::PreparedReference::new(input));
    // periodic slaves are not optimized: each becomes the image of its optimized master
    // below
    let mut skip: Vec<i32> = recombine::periodic_slaves(mesh);
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
    if trial_worst.is_none() {
        *trial_worst = orep.trial_worst;
    }
    recombine::map_periodic_slaves(mesh)?;
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

/// The surfaces whose quads the worst quad leaves aside (sorted): those `input` meshed with
/// quads alone, which stay as read unless [`Options::smooth_quads`].
fn unmeasured_surfaces(input: &Mesh, opts: &Options) -> Vec<i32> {
    if opts.smooth_quads {
        Vec::new()
    } else {
        quad_only_surfaces(input)
    }
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

    /// The least count of [`splits_exceed`] holds on every result of the fallback: a job
    /// that ends with `c` triangles split into three quads has at least three quarters of
    /// `3 c + (t - c) / 2` new quads from 500 triangles on, half below (the optimizer
    /// removes far fewer), so a job stopped for its splits could not have ended within the
    /// cap it broke; three of these meshes have 500 triangles or more.
    #[test]
    fn no_result_of_the_fallback_has_fewer_quads_than_its_splits_make_at_least() {
        for path in [
            "tests/data/cad/v41_coarse_torus.msh",
            "tests/data/cad/v41_thin_pin_own_side.msh",
            "tests/data/cad/v41_boolean_embedded_curve.msh",
            "tests/data/cad/v22_boolean_close_curves.msh",
        ] {
            let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join(path);
            let input = crate::msh::read_file(&path).expect("a mesh of the repository");
            let mut mesh = input.clone();
            let report = quadrangulate(&mut mesh, &Options::default()).expect("quadrangulate");
            let split = report.fallback.as_ref().map_or(0, |f| f.triangles_to_quads);
            assert!(split > 0, "{}: the fallback splits triangles", path.display());
            let triangles = surface_elements(&input, etype::TRI3);
            let per_triangle = quads_per_triangle(&input, &mesh, 0);
            assert!(
                !splits_exceed(triangles, split, per_triangle),
                "{}: {split} of {triangles} triangles split, {per_triangle:.3} new quads per triangle",
                path.display()
            );
        }
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

    /// A unit square of four triangles around its centre (node 5) as the input, and a
    /// result of `quads` (node tags, with nodes 6-9 at the edge midpoints).
    fn square_with(quads: &[[u64; 4]]) -> (Mesh, Mesh) {
        use crate::mesh::testing::{node_block, one_surface};
        let coords = vec![
            [0.0, 0.0, 0.0],
            [1.0, 0.0, 0.0],
            [1.0, 1.0, 0.0],
            [0.0, 1.0, 0.0],
            [0.5, 0.5, 0.0],
        ];
        let input = one_surface(
            vec![node_block(2, (1..=5).collect(), coords.clone())],
            etype::TRI3,
            &[&[1, 2, 5], &[2, 3, 5], &[3, 4, 5], &[4, 1, 5]],
        );
        let mut all = coords;
        all.extend([[0.5, 0.0, 0.0], [1.0, 0.5, 0.0], [0.5, 1.0, 0.0], [0.0, 0.5, 0.0]]);
        let elems: Vec<&[u64]> = quads.iter().map(|q| &q[..]).collect();
        let out = one_surface(vec![node_block(2, (1..=9).collect(), all)], etype::QUAD4, &elems);
        (input, out)
    }

    #[test]
    fn a_first_round_replayed_gives_the_job_that_runs_it_again() {
        let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("tests/data/cad/v41_cylinders_coarse.msh");
        let input = crate::msh::read_file(&path).expect("a mesh of the repository");
        let opts = Options::default();
        let mut notes = JobNotes::default();
        // a job whose first round has quads that are not valid keeps that round
        let mut shared = Shared::default();
        let first = run_rounds(&input, &opts, FallbackStart::default(), None, &mut shared, &mut notes)
            .expect("a valid result");
        assert!(first.1.rounds > 1, "{} round(s)", first.1.rounds);
        assert!(shared.first_round.is_some());
        // the fallback with splits only starts from the same first round: replayed, and
        // run again in a run of its own, the same result
        let start = FallbackStart {
            splits_only: true,
            ..FallbackStart::default()
        };
        let replayed = run_rounds(&input, &opts, start.clone(), None, &mut shared, &mut notes)
            .expect("a valid result");
        let mut alone = Shared::default();
        let again =
            run_rounds(&input, &opts, start, None, &mut alone, &mut notes).expect("a valid result");
        assert_eq!(replayed.0, again.0);
        assert_eq!(replayed.1.rounds, again.1.rounds);
        assert_eq!(replayed.2.chosen, again.2.chosen);
    }

    #[test]
    fn the_better_job_keeps_the_count_rule_then_the_worst_quad_then_fewer_quads() {
        let job = |m: &Mesh| (m.clone(), Report::default(), FallbackStart::default());
        let opts = Options::default();
        // under 500 triangles the rule allows 0.75 new quads per triangle: 3 quads here
        // two quads flat at node 5 (eta 0)
        let (input, flat) = square_with(&[[1, 2, 3, 5], [3, 4, 1, 5]]);
        // four squares around the centre: a better worst quad, but above the rule
        let (_, four) = square_with(&[[1, 6, 5, 9], [6, 2, 7, 5], [5, 7, 3, 8], [9, 5, 8, 4]]);
        // two half-square rectangles, and the same left one with the right one as two
        // squares: the same worst quad
        let (_, two) = square_with(&[[1, 6, 8, 4], [6, 2, 3, 8]]);
        let (_, three) = square_with(&[[1, 6, 8, 4], [6, 2, 7, 5], [5, 7, 3, 8]]);
        let kept = |a: &Mesh, b: &Mesh| {
            better_job(&input, &opts, job(a), job(b))
                .0
                .element_count()
        };
        // within the rule first
        assert_eq!(kept(&flat, &four), 2);
        assert_eq!(kept(&four, &flat), 2);
        // then the higher worst quad
        assert_eq!(kept(&flat, &three), 3);
        assert_eq!(kept(&three, &flat), 3);
        // then fewer quads
        assert_eq!(kept(&three, &two), 2);
        assert_eq!(kept(&two, &three), 2);
        // a result with quads listed as invalid loses to one without
        let mut listed = job(&flat);
        listed.1.invalid.push(crate::validity::BadQuad {
            surface: 1,
            element: 1,
            nodes: [1, 2, 3, 5],
            defect: crate::validity::Defect::Corner {
                corner: 3,
                degrees: 180.0,
            },
        });
        let r = better_job(&input, &opts, listed, job(&four));
        assert_eq!(r.0.element_count(), 4);
    }
}
