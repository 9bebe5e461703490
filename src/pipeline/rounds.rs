//! The rounds of one job (the fallback) and the worst-quad tries after it (see the module
//! doc of [`super`]).

use super::*;
use std::collections::HashMap;

/// True when a node of `tags` is not where `input` has it in `output` (or is gone).
pub(super) fn moved_any(input: &Mesh, output: &Mesh, tags: &[u64]) -> bool {
    if tags.is_empty() {
        return false;
    }
    let (a, b) = (TagCoords::new(input), TagCoords::new(output));
    tags.iter().any(|&t| a.get(t) != b.get(t))
}

/// The rounds of one job on `input` (see the module doc), starting from `start`'s priced-out
/// quads and split triangles; returns the result with the fallback's state at its end.
/// With `cap`, the job stops before a round whose split triangles alone put its result
/// above `cap` new quads per input triangle ([`splits_exceed`]), which its caller would not
/// keep: an [`Error::FallbackExhausted`] with [`JobNotes::over_count`] set.
pub(super) fn run_rounds<'a>(
    input: &'a Mesh,
    opts: &Options,
    start: FallbackStart,
    cap: Option<f64>,
    cache: &mut Shared<'a>,
    notes: &mut JobNotes,
) -> Result<(Mesh, Report, FallbackStart), Error> {
    let mut times = Times::default();
    let mut log = Vec::new();
    // the first round of a job from nothing priced, avoided, split or located is the same
    // in every job of the run (the start's other settings decide only the rounds after it)
    let from_nothing = start.priced.is_empty()
        && start.avoid.is_empty()
        && !start.flat_halves_out
        && start.hopeless_out.is_empty()
        && start.segments.is_empty()
        && start.peels.is_empty()
        && start.located.is_empty()
        && start.chosen.is_empty()
        && start.pairs.is_empty()
        && start.bent == crate::validity::Bent::Refused;
    let mut start = start;
    let mut chosen: HashSet<u64> = std::mem::take(&mut start.chosen);
    let splits_only = start.splits_only;
    let mut local = LocalFallback {
        pricing_rounds: if splits_only { PRICING_ROUNDS } else { 0 },
        segment_rounds: if splits_only || start.no_segments {
            SEGMENT_ROUNDS
        } else {
            0
        },
        state: start,
        ..Default::default()
    };
    let mut fallback = None;
    let mut folds: Vec<recombine::WalledFold> = Vec::new();
    // without optimization: surfaces optimized all the same because their matching left
    // quads that are not valid (vertex duplications fold quads until smoothed)
    let mut force: HashSet<i32> = HashSet::new();
    // without optimization: the last round's mesh before optimization, when the next round
    // only optimizes more surfaces of the same recombination
    let mut carried: Option<Recombined> = None;
    // speed: the input's triangles, for the cap on the job's splits
    let triangles = cap.map(|_| surface_elements(input, etype::TRI3));
    for round in 0..=FALLBACK_ROUNDS {
        if let (Some(cap), Some(t)) = (cap, triangles) {
            if splits_exceed(t, chosen.len(), cap) {
                notes.over_count = true;
                return Err(Error::FallbackExhausted);
            }
        }
        let optimizing = opts.optimize || !force.is_empty();
        // speed: a first round from nothing is the one an earlier job of the run had
        let replay = (round == 0 && from_nothing)
            .then(|| cache.first_round.clone())
            .flatten();
        let outcome = match replay {
            Some(o) => o,
            None => one_round(
                input,
                opts,
                round,
                optimizing,
                &chosen,
                &local,
                &force,
                &mut carried,
                &mut fallback,
                &mut log,
                &mut times,
                cache,
            )?,
        };
        // a first round that needs the fallback may come again in the run's other jobs
        if round == 0 && from_nothing && !outcome.bad.is_empty() && cache.first_round.is_none() {
            cache.first_round = Some(outcome.clone());
        }
        let Outcome {
            mesh,
            report: run,
            bad,
            turned_bad,
            recombined: recombine_report,
            refined,
            unoptimized,
        } = outcome;
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
        report.priced_out = local.state.priced.len();
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
        if !turned_bad.is_empty() {
            let count = turned_bad.len();
            local.state.located.extend(turned_bad);
            local.state.located.sort_unstable();
            local.state.located.dedup();
            log.push(format!(
                "fallback round {}: the optimizer turned {count} quad(s) at new nodes bad: it now holds their corners to the faces they lie on (surface(s) {})",
                round + 1,
                sorted_list(&local.state.located)
            ));
        }
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
        let pairs_before = local.state.pairs.len();
        let next = if round == FALLBACK_ROUNDS {
            Next::GiveUp
        } else {
            // a refined round's bad quads as the recombination's quads they came from
            let traced = refined.as_ref().filter(|_| local.state.traced);
            let recombination = traced.map(Refinement::recombination);
            let parents = traced.map(|r| parents_of(r, &bad));
            local.next(
                input,
                recombination.as_ref().unwrap_or(&mesh),
                parents.as_deref().unwrap_or(&bad),
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
                if !local.state.hopeless_out.is_empty() {
                    line += &format!(
                        ", and every pair with a corner near 180 or 0 degrees at a wall node on surface(s) {}",
                        sorted_list(&local.state.hopeless_out)
                    );
                }
                log.push(line);
                continue;
            }
            Next::Segments(count) => {
                notes.segments_used = true;
                log.push(format!(
                    "fallback round {}: {count} boundary segment(s) under fan quads or flat wall corners to split",
                    round + 1
                ));
                continue;
            }
            Next::Peel(count) => {
                log.push(format!(
                    "fallback round {}: {count} radial edge(s) of boundary fans to peel",
                    round + 1
                ));
                continue;
            }
            Next::HalvesOut(count) => {
                log.push(format!(
                    "fallback round {}: {count} quad(s) with a bad corner at a split node: the merged halves of split triangles priced out",
                    round + 1
                ));
                continue;
            }
            Next::Split(more) => {
                notes.rings_diverged |= local.diverged;
                if more.is_empty() && local.state.pairs.len() > pairs_before {
                    continue;
                }
                more
            }
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
            // a surface of the bad quads that wraps round a node: named in the refusal
            let wrapped = cache.checks.as_ref().and_then(|c| {
                bad.iter().find_map(|b| {
                    c.validity
                        .wrapped_node(b.surface, &b.nodes)
                        .map(|n| (b.surface, n))
                })
            });
            return Err(Error::Invalid {
                bad,
                log: lines,
                wrapped,
            });
        }
        chosen.extend(more);
    }
    // every path of the last round returns; this is only a guard
    Err(Error::FallbackExhausted)
}

/// One round of a job (see [`run_rounds`]): the input with the fallback's splits
/// recombined (or the `carried` recombination), optimized (the surfaces of an earlier job
/// put back) and checked, with what a surface the optimizer left invalid gets back.
#[allow(clippy::too_many_arguments)]
fn one_round<'a>(
    input: &'a Mesh,
    opts: &Options,
    round: usize,
    optimizing: bool,
    chosen: &HashSet<u64>,
    local: &LocalFallback,
    force: &HashSet<i32>,
    carried: &mut Option<Recombined>,
    fallback: &mut Option<recombine::FallbackSplit>,
    log: &mut Vec<String>,
    times: &mut Times,
    cache: &mut Shared<'a>,
) -> Result<Outcome, Error> {
    // the input's largest tags: a job's own nodes and elements are above them
    let input_tags = (input.max_node_tag(), input.max_element_tag());
    let recombined = match carried.take() {
        Some(c) => c,
        None => {
            let mut mesh = input.clone();
            let mut movable = Vec::new();
            if !chosen.is_empty()
                || !local.state.segments.is_empty()
                || !local.state.pairs.is_empty()
                || !local.state.peels.is_empty()
            {
                let t = Instant::now();
                let pairs: Vec<recombine::FlatPair> = local.state.pairs.iter().map(|p| p.1).collect();
                let split =
                    recombine::split_triangles(&mut mesh, chosen, &pairs, &local.state.segments, &local.state.peels);
                let mut line = format!("fallback round {round}: ");
                if split.segments_split > 0 {
                    line += &format!(
                        "{} boundary segment(s) split at their midpoints, ",
                        split.segments_split
                    );
                }
                if split.triangles_peeled > 0 {
                    line += &format!(
                        "{} triangle(s) of boundary fans peeled (a quad on the boundary and a triangle at the apex each), ",
                        split.triangles_peeled
                    );
                }
                if split.pairs_split > 0 {
                    line += &format!(
                        "{} flat pair(s) of triangles split into three quads each, ",
                        split.pairs_split
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
                movable.clone_from(&split.peel_nodes);
                *fallback = Some(split);
                times.recombine += t.elapsed();
            }
            // speed: the matchings of the run's earlier recombinations (none are kept from
            // the first: most runs need no other, and its keys would be work for nothing)
            let memo = (cache.recombinations > 0).then_some(&cache.matchings);
            cache.recombinations += 1;
            recombine_once(
                input,
                mesh,
                opts,
                &local.state.priced.iter().map(|p| p.1).collect::<Vec<_>>(),
                &local.state.avoid,
                local.state.flat_halves_out,
                &local.state.hopeless_out,
                &movable,
                optimizing,
                &mut cache.checks,
                memo,
                times,
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
        && (round > 0 || !cache.surfaces.is_empty() || mesh.element_count() <= REUSE_UP_TO))
        .then(|| {
            Fingerprints::of(&mesh, input_tags.0, input_tags.1)
                .with_variant(1, |s| local.state.located.binary_search(&s).is_ok())
        });
    let reused = match &fingerprints {
        Some(fp) => cache.surfaces.put_back(&mut mesh, fp),
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
        force,
        &reused,
        &local.state.located,
        prepared,
        (&mut cache.checks, &mut cache.trial_worst),
        times,
        &mut run,
    )?;
    // memory: the optimizer's arrays are freed; the checks allocate next
    release_memory();
    let t = Instant::now();
    progress(opts, Stage::Check, 0, 1);
    // the input side of the checks, when no round before prepared it
    let checks = cache
        .checks
        .get_or_insert_with(|| Checks::new(input, opts.refine == 0));
    // after a refinement the refined mesh is the baseline of the invariants
    let refined_before = refined.as_ref().map(|r| recombine::Before::new(&r.mesh));
    let before = refined_before.as_ref().or(checks.invariants.as_ref());
    let invariants_of = |m: &Mesh, coords: &TagCoords| match before {
        Some(b) => b.check_at(m, coords),
        None => recombine::check_invariants(input, m),
    };
    // memory: one table of the output's coordinates for both checks
    let coords = TagCoords::new(&mesh);
    // speed: a surface given back as an earlier job left it, where it passed the validity
    // check in an output of the same check key, passes it again (`SurfaceCache::passed`)
    let bent = local.state.bent;
    let key = crate::validity::check_key(&mesh, bent);
    let passed = match &fingerprints {
        Some(fp) => cache.surfaces.passed(fp, &reused, key),
        None => Vec::new(),
    };
    // speed: the two checks are independent, so they run side by side (an invariant
    // failure still comes first)
    let (invariants, mut bad) = rayon::join(
        || invariants_of(&mesh, &coords),
        || checks.validity.invalid_quads_except(&mesh, &coords, &passed, bent),
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
    // quads the optimizer left bad at a new node it moved, or turned bad (not bad before
    // it), on surfaces where it does not hold them yet: from the next round on it holds
    // the corners at the job's new nodes there to the faces the gate measures them about
    let mut turned_bad: Vec<i32> = Vec::new();
    if let (false, Some(pre)) = (bad.is_empty(), unoptimized.as_ref()) {
        // speed: only the surfaces with bad quads are checked again (the others are
        // valid)
        let mut bad_surfaces: Vec<i32> = bad.iter().map(|b| b.surface).collect();
        bad_surfaces.sort_unstable();
        bad_surfaces.dedup();
        let was = TagCoords::new(pre);
        let before: HashSet<[u64; 4]> = checks
            .validity
            .invalid_quads_on(pre, &was, |s| bad_surfaces.binary_search(&s).is_ok(), bent)
            .into_iter()
            .map(|b| sorted4(b.nodes))
            .collect();
        let is = TagCoords::new(&mesh);
        turned_bad = bad
            .iter()
            .filter(|b| local.state.located.binary_search(&b.surface).is_err())
            .filter(|b| {
                let n = b.node();
                (n > input_tags.0 && was.get(n) != is.get(n))
                    || (b.nodes.iter().any(|&n| n > input_tags.0)
                        && !before.contains(&sorted4(b.nodes)))
            })
            .map(|b| b.surface)
            .collect();
        drop((was, is));
        // the surfaces with bad quads as they were before optimization, when that is
        // valid (with their periodic partners: a slave is the image of its master before
        // optimization as after)
        let surfaces = recombine::with_periodic_partners(&mesh, bad_surfaces.iter().copied().collect());
        let back = revert_surfaces(&mesh, pre, &surfaces);
        let coords = TagCoords::new(&back);
        if checks
            .validity
            .invalid_quads_on(&back, &coords, |s| surfaces.contains(&s), bent)
            .is_empty()
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
        // what passed the check: the surfaces without a bad quad, in the mesh checked (not
        // when undoing an optimization changed its check key)
        let bad_on: HashSet<i32> = bad.iter().map(|b| b.surface).collect();
        let ok = |s: i32| !bad_on.contains(&s);
        let checked = crate::validity::check_key(&mesh, bent) == key;
        cache
            .surfaces
            .record(&mesh, fp, checked.then_some((key, &ok as &dyn Fn(i32) -> bool)));
    }
    Ok(Outcome {
        mesh,
        report: run,
        bad,
        turned_bad,
        recombined: recombine_report,
        refined,
        unoptimized,
    })
}

/// The bad quads `bad` of a refined round as quads of its recombination, each the quad
/// whose refinement made the bad one, so that the fallback prices, peels and splits the
/// recombination's pairs as on a round without refinement.
/// The defect's corner becomes the parent's corner at the same node, or else the corner
/// whose child holds the bad quad. A quad the optimizer's topology passes made (not a quad
/// of the refined mesh) stays as it is; each parent once, in the order of `bad`.
fn parents_of(refinement: &Refinement, bad: &[BadQuad]) -> Vec<BadQuad> {
    let sorted = |mut q: [u64; 4]| {
        q.sort_unstable();
        q
    };
    let surfaces: HashSet<i32> = bad.iter().map(|b| b.surface).collect();
    // the refined mesh's quads on those surfaces: block and index by sorted nodes
    let mut at: HashMap<(i32, [u64; 4]), (usize, usize)> = HashMap::new();
    for (k, b) in refinement.mesh.element_blocks.iter().enumerate() {
        if b.entity_dim != 2 || b.element_type != etype::QUAD4 || !surfaces.contains(&b.entity_tag) {
            continue;
        }
        for i in 0..b.len() {
            if let Ok(q) = <[u64; 4]>::try_from(b.element(i)) {
                at.insert((b.entity_tag, sorted(q)), (k, i));
            }
        }
    }
    let parent = |q: &BadQuad| -> Option<BadQuad> {
        let &(block, mut i) = at.get(&(q.surface, sorted(q.nodes)))?;
        let mut corner = 0;
        for level in refinement.shapes.iter().rev() {
            (i, corner) = crate::refine::parent_of(*level.get(block)?, i)?;
        }
        let first = refinement.recombined.get(block)?;
        let nodes = <[u64; 4]>::try_from(first.element(i)).ok()?;
        let c = nodes.iter().position(|&n| n == q.node()).unwrap_or(corner);
        Some(BadQuad {
            surface: q.surface,
            element: first.tags[i],
            nodes,
            defect: q.defect.clone().at_corner(c),
        })
    };
    let mut seen = HashSet::new();
    bad.iter()
        .map(|q| parent(q).unwrap_or_else(|| q.clone()))
        .filter(|q| seen.insert((q.surface, sorted(q.nodes))))
        .collect()
}

/// `mesh` with the quads and the surface-classified nodes of `surfaces` taken from `pre`
/// (the same mesh before optimization: the optimizer moves and removes only nodes inside a
/// surface, and changes only its quads).
pub(super) fn revert_surfaces(mesh: &Mesh, pre: &Mesh, surfaces: &HashSet<i32>) -> Mesh {
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

/// The node tags of a quad, sorted.
fn sorted4(mut q: [u64; 4]) -> [u64; 4] {
    q.sort_unstable();
    q
}

/// Surface tags in increasing order, without repeats, as "1, 4, 7".
pub(super) fn sorted_list<'a>(tags: impl IntoIterator<Item = &'a i32>) -> String {
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
/// already, or a mesh of fewer than [`COUNT_RULE_FROM`](crate::recombine::COUNT_RULE_FROM)
/// triangles: at most a quarter more than the larger of the two):
/// 1. when the fallback priced quads out, the fallback with splits only (triangles split
///    into quads around a bad quad may give better quads than the matching's way around
///    it);
/// 2. quads with η below [`ETA_FLOOR`] priced out, or where there is none, those below
///    [`PRICE_FLOOR`] where their surfaces hold [`PRICE_TRY_UP_TO`] input triangles at
///    most (this try adds no quad);
/// 3. the boundary segments under flat wall corners of those quads split
///    ([`low_quad_segments`]): a pair whose only partners give a corner near 180° at a wall
///    node gets its halves paired with one neighbour each;
/// 4. up to [`SPLIT_TRIES`] times, the input triangles around the quads still below
///    [`ETA_FLOOR`] split: one ring, or two where the first is all split already; a ring
///    try after the first runs only when the one before it was kept;
/// 5. where a ring try raised the worst quad but broke the element-count rule (or was
///    stopped where its split triangles alone broke it, as every try is: it may have raised
///    the worst quad), the input triangles inside the quads still below [`ETA_FLOOR`]
///    split ([`triangles_inside`]: a parity split's node stands for its segment's ends, so
///    the triangle it halved counts), fewer new quads than a ring. It comes after them: a result it raises just
///    above the floor would end the ring tries, which may raise the worst quad further;
/// 6. last, the boundary fans of the quads still below [`ETA_FLOOR`] whose widest corner
///    is near flat at a fan node peeled ([`low_quad_fans`]): a boundary node with two
///    triangles at one apex, on a curve that is nearly straight there, pairs them with a
///    corner of the curve's angle, valid but near 180°; peeled, each is a quad on the curve
///    and a triangle at the apex, about 1.5 quads a triangle where a ring costs 3. It
///    comes after the rings, whose result where kept is often the better one.
///
/// No try runs once the worst quad is within [`RAISE_MIN`] of the input's wall-corner
/// bound ([`wall_corner_bound`]): no result could be kept.
pub(super) fn raise_worst_quad<'a>(
    input: &'a Mesh,
    opts: &Options,
    first: (Mesh, Report, FallbackStart),
    cache: &mut Shared<'a>,
) -> Result<(Mesh, Report, FallbackStart), Error> {
    let mut best = first;
    // without optimization the quads are the matching's as they are (low by design); a
    // large mesh that needed no fallback is not run again for its worst quad (a try costs
    // a whole job)
    let large = best.1.rounds == 1 && input.element_count() > TRIES_UP_TO;
    if !opts.optimize || !best.1.invalid.is_empty() || large {
        return Ok(best);
    }
    let skip = unmeasured_surfaces(input, opts);
    let (mut low, mut worst) = low_quads(&best.0, &skip);
    let triangles = surface_elements(input, etype::TRI3);
    // the new quads per input triangle a try may end with, against the kept result's
    // `before`: the element-count rule (a quarter more on a small mesh), or a quarter more
    // than a result above the rule already
    let count_limit = |before: f64| {
        if before > MAX_QUADS_PER_TRIANGLE {
            1.25 * before
        } else {
            count_rule_limit(triangles)
        }
    };
    // whether the last ring try was kept, and whether one raised the worst quad but broke
    // the element-count rule
    let mut split_kept = false;
    let mut ring_over_count = false;
    // speed: an acute corner of a planar surface may bound the worst quad of every result
    // (measured once, when a try would run): the tries cannot raise it past that bound
    // (refinement moves the new curve nodes off the walls' lines)
    let mut bound: Option<f64> = None;
    for step in 0..5 + SPLIT_TRIES {
        let ring_try = (3..3 + SPLIT_TRIES).contains(&step);
        let mut start = best.2.clone();
        let what = match step {
            0 => {
                if start.priced.is_empty() {
                    continue;
                }
                start = FallbackStart {
                    splits_only: true,
                    global_rings: start.global_rings,
                    flat_pairs: start.flat_pairs,
                    bent: start.bent,
                    ..FallbackStart::default()
                };
                "the fallback with splits only".to_string()
            }
            1 => {
                // where no quad is under ETA_FLOOR, those under PRICE_FLOOR, on surfaces
                // small enough that solving them again costs little
                let (floor, under) = if low.is_empty() {
                    let (under, _) = quads_under(&best.0, &skip, PRICE_FLOOR);
                    let surfaces: HashSet<i32> = under.iter().map(|q| q.0).collect();
                    let on = |s| surfaces.contains(&s);
                    if surface_elements_where(input, etype::TRI3, on) > PRICE_TRY_UP_TO {
                        continue;
                    }
                    (PRICE_FLOOR, under)
                } else {
                    (ETA_FLOOR, low.clone())
                };
                let new = pairs_of(input, &under, &start.priced);
                if new.is_empty() {
                    continue;
                }
                let n = new.len();
                start.priced.extend(new);
                format!("{n} quad(s) under eta {floor} priced out")
            }
            2 => {
                let new = low_quad_segments(input, &best.0, &low, &start.segments);
                if new.is_empty() || start.no_segments {
                    continue;
                }
                let n = new.len();
                start.segments.extend(new);
                format!("{n} boundary segment(s) under flat wall corners of quads under eta {ETA_FLOOR} split")
            }
            // the try before the last: the triangles inside the quads still low
            _ if step == 3 + SPLIT_TRIES => {
                if !ring_over_count {
                    continue;
                }
                let splits = &best.1.recombine.parity_splits;
                let more = triangles_inside(input, &low, splits, &start.chosen);
                if more.is_empty() {
                    continue;
                }
                let n = more.len();
                start.chosen.extend(more);
                format!("{n} triangle(s) inside quads under eta {ETA_FLOOR} split")
            }
            // the last try: the boundary fans under the quads still low peeled
            _ if step == 4 + SPLIT_TRIES => {
                let new = low_quad_fans(input, &best.0, &low, &start.peels);
                if new.is_empty() {
                    continue;
                }
                let n = new.len();
                start.peels.extend(new);
                format!("{n} radial edge(s) of boundary fans under flat wall corners of quads under eta {ETA_FLOOR} peeled")
            }
            _ => {
                // a ring try after the first only when the one before it was kept
                if low.is_empty() || (step > 3 && !split_kept) {
                    continue;
                }
                let around = |ring| fallback_triangles(input, &best.0, &low, &start.chosen, ring, false);
                let (mut ring, mut more) = (1, around(1));
                if more.is_empty() {
                    (ring, more) = (2, around(2));
                }
                if more.is_empty() {
                    continue;
                }
                let n = more.len();
                start.chosen.extend(more);
                format!("{n} triangle(s) in {ring} ring(s) around quads under eta {ETA_FLOOR} split")
            }
        };
        let b = *bound.get_or_insert_with(|| match opts.refine {
            0 => wall_corner_bound(input),
            _ => 1.0,
        });
        if !raisable(worst, b) {
            best.1.log.push(format!(
                "worst quad: eta_w {worst:.3} is at the input's wall-corner bound {b:.3}: no try can raise it"
            ));
            break;
        }
        split_kept = false;
        let limit = count_limit(quads_per_triangle(input, &best.0, opts.refine));
        // speed: a try stops as soon as its splits alone break the rule it must keep; a
        // ring try stopped there counts as one that raised the worst quad and broke the
        // rule (it may have), so the triangles inside the quads still low get their try
        let mut notes = JobNotes::default();
        let Ok(candidate) = run_rounds(input, opts, start, Some(limit), cache, &mut notes) else {
            ring_over_count |= ring_try && notes.over_count;
            let why = if notes.over_count {
                "its splits alone break the element-count rule"
            } else {
                "refused"
            };
            best.1.log.push(format!("worst quad: {what}: not kept ({why})"));
            continue;
        };
        if !candidate.1.invalid.is_empty() {
            best.1.log.push(format!("worst quad: {what}: not kept (not valid)"));
            best.1.times = add_times(&best.1.times, &candidate.1.times);
            continue;
        }
        let (_, new_worst) = low_quads(&candidate.0, &skip);
        let raised = new_worst > worst + RAISE_MIN;
        let within = quads_per_triangle(input, &candidate.0, opts.refine) <= limit;
        ring_over_count |= raised && !within && ring_try;
        if raised && within {
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
            split_kept = ring_try;
        } else {
            best.1.log.push(format!(
                "worst quad: {what}: not kept (eta_w {new_worst:.3}, {:.3} new quads per input triangle)",
                quads_per_triangle(input, &candidate.0, opts.refine)
            ));
            best.1.times = add_times(&best.1.times, &candidate.1.times);
        }
    }
    Ok(best)
}

/// The stage times of two jobs added.
pub(super) fn add_times(a: &Times, b: &Times) -> Times {
    Times {
        recombine: a.recombine + b.recombine,
        refine: a.refine + b.refine,
        optimize: a.optimize + b.optimize,
        check: a.check + b.check,
        second_order: a.second_order + b.second_order,
    }
}
