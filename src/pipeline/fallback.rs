//! The fallback's decisions between the rounds of a job (see the module doc of
//! [`crate::pipeline`]): which quads to price out of the matching and which parity split
//! segments to avoid, which input triangles to split, and the measures the worst-quad tries
//! are judged by. The rounds themselves (the jobs) run in the pipeline; nothing here runs
//! one.

use std::collections::{BTreeMap, HashSet};

use crate::mesh::{etype, Mesh, TagCoords};
use crate::recombine;
use crate::validity::BadQuad;

/// Quads whose η (eq. 3) is below this are repaired after the fallback when that raises the
/// worst quad (up to 3 + [`SPLIT_TRIES`] more jobs after the fallback, see the module doc).
pub const ETA_FLOOR: f64 = 0.2;

/// Quads whose η is below this are priced out of the matching in the worst-quad try that
/// adds no quad (the surface solved again without their pairs, kept only when that raises
/// the worst quad) where no quad is under [`ETA_FLOOR`] (those are priced out then): above
/// [`ETA_FLOOR`], where the tries that split triangles do not go.
pub(crate) const PRICE_FLOOR: f64 = 0.35;

/// Input triangles on the surfaces of the quads under [`PRICE_FLOOR`] up to which they are
/// priced out (the try solves and optimizes those surfaces again: a few hundredths of a
/// second at this size).
pub(crate) const PRICE_TRY_UP_TO: usize = 5000;

/// Tries at most that split the input triangles around the quads under [`ETA_FLOOR`] after
/// the fallback, each after the one before it raised the worst quad.
pub const SPLIT_TRIES: usize = 3;

/// Fallback rounds that price out new bad quads at most (see the module doc).
pub const PRICING_ROUNDS: usize = 2;

/// Rings of input triangles around a bad quad that the fallback splits at most.
pub const SPLIT_RINGS: usize = 2;

/// Fallback rounds that split new boundary segments under fans or flat wall corners at most
/// (see the module doc).
pub const SEGMENT_ROUNDS: usize = 2;

/// Fallback rounds that peel new boundary fans at most (see the module doc).
pub const PEEL_ROUNDS: usize = 2;

/// What the fallback does after a round with bad quads.
pub(super) enum Next {
    /// Solve again with this many more quads priced out and parity split segments
    /// avoided.
    Price(usize, usize),
    /// Solve again with this many more boundary segments split under fans or flat wall
    /// corners.
    Segments(usize),
    /// Solve again with this many more radial edges of boundary fans peeled.
    Peel(usize),
    /// Solve again with the merged halves of split triangles priced out
    /// ([`LocalFallback::flat_halves_out`]): this many bad quads had their bad corner at a
    /// node the input does not have.
    HalvesOut(usize),
    /// Split these input triangles too (empty: nothing more to split).
    Split(HashSet<u64>),
    /// Nothing more to try.
    GiveUp,
}

/// The fallback's state over the rounds (see the module doc): the quads priced out of the
/// matching and the rounds spent.
#[derive(Default)]
pub(super) struct LocalFallback {
    /// What the job started from, with what its rounds have added since (quads priced out,
    /// segments avoided and split, fans peeled, flat pairs, surfaces located); the rounds keep
    /// its split triangles (`chosen`) and `splits_only` themselves.
    pub(super) state: FallbackStart,
    /// Rounds spent peeling fans, pricing, splitting segments and splitting triangles.
    pub(super) peel_rounds: usize,
    pub(super) pricing_rounds: usize,
    pub(super) segment_rounds: usize,
    pub(super) split_rounds: usize,
    /// Rings split so far around the bad quads of each surface.
    pub(super) rings: BTreeMap<i32, usize>,
    /// A split round's rings differed from the job's count on some surface (per-surface
    /// rings only).
    pub(super) diverged: bool,
    /// The splits keep to the element-count rule: the first ring around the bad quads
    /// would break it, so it holds only the triangles of the bad pairs, and a bad corner
    /// at a split node gets merged halves priced out before another ring.
    pub(super) tight: bool,
}

impl LocalFallback {
    /// The state at the end of a job (`chosen` the triangles split, `splits_only` as the
    /// job started): what another job of the same input starts from.
    pub(super) fn finish(self, chosen: HashSet<u64>, splits_only: bool) -> FallbackStart {
        FallbackStart {
            chosen,
            splits_only,
            ..self.state
        }
    }

    /// A segment round that splits `new` boundary segments, when there are any.
    fn split_segments(&mut self, new: Vec<(u64, u64)>) -> Option<Next> {
        if new.is_empty() {
            return None;
        }
        self.segment_rounds += 1;
        let count = new.len();
        self.state.segments.extend(new);
        Some(Next::Segments(count))
    }

    /// The next step after a round whose quads `bad` are not valid (`mesh` the round's
    /// result, or on a refined round its recombination, with `bad` the quads refinement
    /// made them of; `chosen` the triangles split so far).
    pub(super) fn next(
        &mut self,
        input: &Mesh,
        mesh: &Mesh,
        bad: &[BadQuad],
        chosen: &HashSet<u64>,
        splits: &[recombine::ParitySplit],
    ) -> Next {
        let spots: Vec<(i32, [u64; 4])> = bad.iter().map(|b| (b.surface, b.nodes)).collect();
        if self.pricing_rounds < PRICING_ROUNDS {
            let new = pairs_of(input, &spots, &self.state.priced);
            // the parity splits whose node is a corner of a bad quad
            let mut segments: Vec<(u64, u64)> = splits
                .iter()
                .filter(|s| bad.iter().any(|b| b.nodes.contains(&s.new_node)))
                .map(|s| s.segment)
                .filter(|s| !self.state.avoid.contains(s))
                .collect();
            segments.sort_unstable();
            segments.dedup();
            if !segments.is_empty() {
                self.state.flat_halves_out = true;
            }
            // the surfaces of the bad quads: every pair with a hopeless corner at a wall
            // node priced out there too (pricing the bad pairs alone moves a flat corner
            // that the surface's structure forces to the next such pair)
            let before = self.state.hopeless_out.len();
            if self.state.hopeless {
                self.state.hopeless_out.extend(spots.iter().map(|s| s.0));
            }
            self.state.hopeless_out.sort_unstable();
            self.state.hopeless_out.dedup();
            let surfaces = self.state.hopeless_out.len() - before;
            if !new.is_empty() || !segments.is_empty() || surfaces > 0 {
                self.pricing_rounds += 1;
                let count = (new.len(), segments.len());
                self.state.priced.extend(new);
                self.state.avoid.extend(segments);
                return Next::Price(count.0, count.1);
            }
        }
        if self.segment_rounds < SEGMENT_ROUNDS && self.split_rounds == 0 {
            if let Some(next) = self.split_segments(fan_segments(input, bad, &self.state.segments)) {
                return next;
            }
        }
        if self.state.peel_fans && self.peel_rounds < PEEL_ROUNDS && self.split_rounds == 0 {
            let new = fan_radials(input, bad, &self.state.peels);
            if !new.is_empty() {
                self.peel_rounds += 1;
                let count = new.len();
                self.state.peels.extend(new);
                return Next::Peel(count);
            }
        }
        // no fan left to split under or peel: the segments opposite flat wall corners
        if self.segment_rounds < SEGMENT_ROUNDS && self.split_rounds == 0 {
            let new = wall_corner_segments(input, bad, &self.state.segments);
            if let Some(next) = self.split_segments(new) {
                return next;
            }
        }
        // tight splits with a bad corner at a node of a split (the matching merged the two
        // halves of a triangle halved next to split ones, a flat corner at the split edge's
        // midpoint): the same splits again with such halves priced out before another ring
        let at_split = bad
            .iter()
            .filter(|b| b.node() > input.max_node_tag())
            .count();
        if self.tight && !self.state.flat_halves_out && at_split > 0 {
            self.state.flat_halves_out = true;
            return Next::HalvesOut(at_split);
        }
        self.split_rounds += 1;
        let pairs_before = self.state.pairs.len();
        // each surface's ring: one more than it had
        let mut surfaces: Vec<i32> = spots.iter().map(|s| s.0).collect();
        surfaces.sort_unstable();
        surfaces.dedup();
        for &s in &surfaces {
            *self.rings.entry(s).or_default() += 1;
        }
        let rounds = self.split_rounds;
        if !self.state.global_rings && surfaces.iter().any(|s| self.rings.get(s) != Some(&rounds)) {
            self.diverged = true;
        }
        let ring_of = |s: i32| match self.state.global_rings {
            true => rounds,
            false => self.rings.get(&s).copied().unwrap_or(1),
        };
        let at_ring = |r: usize| -> Vec<(i32, [u64; 4])> {
            spots.iter().filter(|s| ring_of(s.0) == r).copied().collect()
        };
        // the last resort, after the local rounds: every triangle of the surfaces that still
        // have a bad quad (the splits' halved neighbours along shared curves may bring
        // another surface here in the next round), without the segment splits (a split on
        // a curve between two strips moves the strips' imbalance to the other strip)
        let last: Vec<(i32, [u64; 4])> = spots
            .iter()
            .filter(|s| ring_of(s.0) > SPLIT_RINGS)
            .copied()
            .collect();
        let mut out = HashSet::new();
        if !last.is_empty() {
            self.state.segments.clear();
            out.extend(surface_triangles(input, &last, chosen));
        }
        let mut first = at_ring(1);
        // a bad pair flat or reflex at an end of its diagonal: split as a flat pair, which
        // leaves the edges at that node whole
        if self.state.flat_pairs && !first.is_empty() {
            let on: HashSet<i32> = first.iter().map(|s| s.0).collect();
            let triangles = SurfaceTriangles::of(input, &on);
            for b in bad.iter().filter(|b| {
                on.contains(&b.surface) && matches!(b.defect, crate::validity::Defect::Corner { .. })
            }) {
                let Some((t, u)) = triangles.pair_at(b.surface, b.nodes, b.node()) else {
                    continue;
                };
                if chosen.contains(&t) || chosen.contains(&u) {
                    continue;
                }
                if self.state.pairs.iter().any(|(_, p)| p.triangles.contains(&t) || p.triangles.contains(&u)) {
                    continue;
                }
                let pair = recombine::FlatPair {
                    triangles: [t, u],
                    node: b.node(),
                };
                self.state.pairs.push((b.surface, pair));
                first.retain(|s| s != &(b.surface, b.nodes));
            }
        }
        // from the second ring on, a surface's flat pairs are split as chosen triangles
        let later: HashSet<i32> = spots
            .iter()
            .filter(|s| ring_of(s.0) >= 2)
            .map(|s| s.0)
            .collect();
        self.state.pairs.retain(|(s, p)| {
            let ours = later.contains(s);
            if ours {
                out.extend(p.triangles);
            }
            !ours
        });
        if !first.is_empty() {
            let ring = fallback_triangles(input, mesh, &first, chosen, 1, self.tight);
            if !self.tight && breaks_count_rule(input, mesh, ring.len()) {
                self.tight = true;
                out.extend(fallback_triangles(input, mesh, &first, chosen, 1, true));
            } else {
                out.extend(ring);
            }
        }
        for r in 2..=SPLIT_RINGS {
            let spots = at_ring(r);
            if !spots.is_empty() {
                out.extend(fallback_triangles(input, mesh, &spots, chosen, r, self.tight));
            }
        }
        if out.is_empty() && self.state.pairs.len() == pairs_before && last.len() < spots.len() {
            // nothing new within the rings: the last resort at once
            self.state.segments.clear();
            out = surface_triangles(input, &spots, chosen);
        }
        Next::Split(out)
    }
}

/// True when splitting `more` input triangles of `input` into three quads each, on top of
/// `mesh` (a round's recombination), would take the new quads per input triangle above the
/// element-count rule: [`MAX_QUADS_PER_TRIANGLE`] from
/// [`COUNT_RULE_FROM`](crate::recombine::COUNT_RULE_FROM) triangles, a quarter more below
/// (a split triangle makes three quads where a pair made one between two triangles: 2.5
/// more quads each, its halved neighbours not counted).
pub(super) fn breaks_count_rule(input: &Mesh, mesh: &Mesh, more: usize) -> bool {
    let triangles = surface_elements(input, etype::TRI3);
    let limit = count_rule_limit(triangles);
    let quads = quads_per_triangle(input, mesh, 0) * triangles as f64;
    quads + 2.5 * more as f64 > limit * triangles as f64
}

/// The fallback's state at the start (and the end) of a job's rounds: the quads priced out
/// of the matching (sorted node tags, sorted) and the input triangles split into quads.
#[derive(Debug, Clone, Default)]
pub(super) struct FallbackStart {
    /// Quads priced out of the matching: surface and sorted node tags.
    pub(super) priced: Vec<(i32, [u64; 4])>,
    /// Boundary segments the parity repair avoids (node tags).
    pub(super) avoid: Vec<(u64, u64)>,
    /// Merged halves of split triangles priced out.
    pub(super) flat_halves_out: bool,
    /// Surfaces whose pairs with a hopeless corner at a wall node are priced out.
    pub(super) hopeless_out: Vec<i32>,
    /// A pricing round prices out every pair with a hopeless corner at a wall node on the
    /// surfaces of the bad quads (the job the pipeline runs where the others broke the
    /// element-count rule or were refused).
    pub(super) hopeless: bool,
    /// Boundary segments split at their midpoints (node tags).
    pub(super) segments: Vec<(u64, u64)>,
    /// No segment splits (after a job with them failed).
    pub(super) no_segments: bool,
    /// Radial edges of boundary fans peeled.
    pub(super) peels: Vec<(u64, u64)>,
    /// Peel the boundary fans of bad quads before any split ([`fan_radials`]).
    pub(super) peel_fans: bool,
    /// Surfaces where the optimizer's corners at new nodes are held to the faces they lie
    /// on.
    pub(super) located: Vec<i32>,
    /// Input triangles split into three quads each (element tags).
    pub(super) chosen: HashSet<u64>,
    /// Split only, never price (the fallback of the other result that
    /// [`super::raise_worst_quad`] tries).
    pub(super) splits_only: bool,
    /// Split rings counted over the job: the n-th split round splits the n-th ring around
    /// every bad quad, and the last resort takes every surface with a bad quad after
    /// [`SPLIT_RINGS`] rounds. Otherwise each surface counts its own rings, so a surface
    /// that first has a bad quad after splits elsewhere (their halved neighbours on a
    /// shared curve) starts from its first ring.
    pub(super) global_rings: bool,
    /// Flat pairs split into three quads, with their surfaces.
    pub(super) pairs: Vec<(i32, recombine::FlatPair)>,
    /// At the first ring, a bad pair whose bad corner is at an end of its diagonal is split
    /// as a flat pair ([`recombine::FlatPair`]) instead of as two chosen triangles.
    pub(super) flat_pairs: bool,
    /// How the rounds judge quads bent across a sharp turn of a curved surface: refused,
    /// except in the job the pipeline runs last where the others broke the element-count
    /// rule or were refused ([`crate::validity::Bent::Accepted`]).
    pub(super) bent: crate::validity::Bent,
    /// On a refined run, the rounds hand the fallback the bad quads traced back to the
    /// recombination's quads whose refinement made them, and the recombination
    /// ([`crate::refine::parent_of`]); otherwise the refined quads and mesh themselves.
    pub(super) traced: bool,
}

/// What a job's rounds did that decides whether another job runs (see the module doc of
/// [`super`]).
#[derive(Debug, Default)]
pub(super) struct JobNotes {
    /// Boundary segments under fans were split.
    pub(super) segments_used: bool,
    /// Per-surface rings differed from the job's count (see [`FallbackStart::global_rings`]).
    pub(super) rings_diverged: bool,
    /// The job stopped before a round whose split triangles alone put every result above
    /// the count its caller can use ([`splits_exceed`]).
    pub(super) over_count: bool,
}

/// Share of a job's quads that the optimizer's topological operations (doublet collapses,
/// quad-vertex merges) are taken to remove at most, in [`splits_exceed`], on a mesh of
/// [`COUNT_RULE_FROM`](crate::recombine::COUNT_RULE_FROM) triangles or more: a few percent
/// on most meshes, under a twentieth on every one measured (BENCHMARKS.md, "Measurements
/// behind the defaults").
const REMOVED_SHARE_MAX: f64 = 0.25;

/// [`REMOVED_SHARE_MAX`] on a mesh of fewer triangles: there the optimizer removed up to
/// about a fifth.
const SMALL_REMOVED_SHARE_MAX: f64 = 0.5;

/// True when splitting `chosen` input triangles into three quads each puts every result of
/// a job above `cap` new quads per input triangle (the count [`quads_per_triangle`] takes):
/// each split triangle gives three quads and each other triangle of the input's
/// `triangles` lies in a quad of at most two triangles (its halves, where a neighbour's
/// split halves it, in two such quads), so a result holds at least `3 c + (t - c) / 2` new
/// quads before optimization, of which the optimizer removes at most
/// [`REMOVED_SHARE_MAX`] ([`SMALL_REMOVED_SHARE_MAX`] under
/// [`COUNT_RULE_FROM`](crate::recombine::COUNT_RULE_FROM) triangles).
pub(super) fn splits_exceed(triangles: usize, chosen: usize, cap: f64) -> bool {
    let (t, c) = (triangles.max(1) as f64, chosen.min(triangles) as f64);
    let least = 3.0 * c + 0.5 * (t - c);
    let removed = match triangles < crate::recombine::COUNT_RULE_FROM {
        true => SMALL_REMOVED_SHARE_MAX,
        false => REMOVED_SHARE_MAX,
    };
    (1.0 - removed) * least > cap * t
}

/// The element-count rule that the repair of the worst quad keeps, as the recombination's
/// strips do.
pub(super) use crate::recombine::{count_rule_limit, MAX_QUADS_PER_TRIANGLE};

/// The quads of `mesh`'s surfaces with η below [`ETA_FLOOR`], as (surface, node tags), and
/// the worst η of those quads; surfaces in `skip` (sorted: those the input meshed with quads
/// alone, which no job changes) are left out.
pub(super) fn low_quads(mesh: &Mesh, skip: &[i32]) -> (Vec<(i32, [u64; 4])>, f64) {
    quads_under(mesh, skip, ETA_FLOOR)
}

/// [`low_quads`] with η below `floor` instead of [`ETA_FLOOR`].
pub(super) fn quads_under(mesh: &Mesh, skip: &[i32], floor: f64) -> (Vec<Spot>, f64) {
    let (low, worst) = low_quads_eta(mesh, skip, floor);
    (low.into_iter().map(|(q, _)| q).collect(), worst)
}

/// A quad of a result: its surface and node tags.
pub(super) type Spot = (i32, [u64; 4]);

/// [`quads_under`] with the η of each quad.
pub(super) fn low_quads_eta(mesh: &Mesh, skip: &[i32], floor: f64) -> (Vec<(Spot, f64)>, f64) {
    let coords = TagCoords::new(mesh);
    let mut low = Vec::new();
    let mut worst = f64::INFINITY;
    for b in mesh.element_blocks.iter().filter(|b| {
        b.entity_dim == 2
            && b.element_type == etype::QUAD4
            && skip.binary_search(&b.entity_tag).is_err()
    }) {
        for i in 0..b.len() {
            let e = b.element(i);
            let q = [e[0], e[1], e[2], e[3]];
            let Some(p) = q
                .iter()
                .map(|&t| coords.get(t).map(glam::DVec3::from_array))
                .collect::<Option<Vec<_>>>()
            else {
                continue;
            };
            let eta = crate::quality::eta(&[p[0], p[1], p[2], p[3]]);
            worst = worst.min(eta);
            if eta < floor {
                low.push(((b.entity_tag, q), eta));
            }
        }
    }
    (low, worst)
}

/// How much a worst-quad try must raise the worst quad's η to be kept.
pub(super) const RAISE_MIN: f64 = 1e-3;

/// The input's wall-corner bound: no valid result of `input` without refinement has a
/// worst quad η above it (1 when nothing bounds it below). At a boundary node of a planar
/// surface, the quads of any valid result partition the angle the surface's triangles make
/// there (the node never moves, the walls at it keep their directions: their splits are at
/// midpoints, and every node stays in the plane), so the quad holding the smallest share
/// has a corner no larger than that angle; at an angle θ up to 90° its η is at most
/// θ / 90° (eq. 3). Curved surfaces, which can fold the angle, and surfaces with quads or
/// other faces in the input are left out.
pub(super) fn wall_corner_bound(input: &Mesh) -> f64 {
    corner_bounds(input)
        .into_iter()
        .filter(|c| c.planar)
        .fold(1.0, |b, c| b.min(c.bound))
}

/// One surface's corner bound ([`corner_bounds`]).
pub(super) struct CornerBound {
    pub(super) surface: i32,
    /// The smallest angle its triangles make at a boundary node, / 90°, capped at 1.
    pub(super) bound: f64,
    /// Its nodes lie on one plane (where the bound holds for every valid result, see
    /// [`wall_corner_bound`]; on a curved surface it is an estimate).
    pub(super) planar: bool,
}

/// For each surface of `input` with triangles alone (no quad or other face): the
/// smallest sum of its triangles' angles at one of its boundary nodes (ends of the edges
/// that one of its triangles alone has), / 90°, capped at 1, by increasing tag.
pub(super) fn corner_bounds(input: &Mesh) -> Vec<CornerBound> {
    use glam::DVec3;
    let coords = TagCoords::new(input);
    let at = |t: u64| coords.get(t).map(DVec3::from_array);
    let other_faces: HashSet<i32> = input
        .element_blocks
        .iter()
        .filter(|b| b.entity_dim == 2 && b.element_type != etype::TRI3 && !b.is_empty())
        .map(|b| b.entity_tag)
        .collect();
    let mut out = Vec::new();
    for s in input.sorted_surfaces(|b| b.element_type == etype::TRI3 && !b.is_empty()) {
        if other_faces.contains(&s) {
            continue;
        }
        let mut tris: Vec<([u64; 3], [DVec3; 3])> = Vec::new();
        for b in input.element_blocks.iter().filter(|b| {
            b.entity_dim == 2 && b.entity_tag == s && b.element_type == etype::TRI3
        }) {
            for i in 0..b.len() {
                let e = b.element(i);
                let n = [e[0], e[1], e[2]];
                if let (Some(a), Some(b), Some(c)) = (at(n[0]), at(n[1]), at(n[2])) {
                    tris.push((n, [a, b, c]));
                }
            }
        }
        if tris.is_empty() {
            continue;
        }
        // boundary nodes: ends of the edges that one triangle alone has
        let mut edges: Vec<(u64, u64)> = tris
            .iter()
            .flat_map(|(n, _)| (0..3).map(move |k| (n[k].min(n[(k + 1) % 3]), n[k].max(n[(k + 1) % 3]))))
            .collect();
        edges.sort_unstable();
        let mut boundary: HashSet<u64> = HashSet::new();
        for run in edges.chunk_by(|a, b| a == b) {
            if run.len() != 2 {
                boundary.extend([run[0].0, run[0].1]);
            }
        }
        let mut angle: std::collections::HashMap<u64, f64> = std::collections::HashMap::new();
        for (n, p) in &tris {
            for k in 0..3 {
                if boundary.contains(&n[k]) {
                    let (u, v) = (p[(k + 1) % 3] - p[k], p[(k + 2) % 3] - p[k]);
                    *angle.entry(n[k]).or_default() += u.cross(v).length().atan2(u.dot(v));
                }
            }
        }
        let bound = angle
            .into_values()
            .fold(1.0_f64, |b, a| b.min(a / std::f64::consts::FRAC_PI_2));
        out.push(CornerBound {
            surface: s,
            bound,
            planar: planar(&tris),
        });
    }
    out
}

/// True when every node of `tris` lies on one plane ([`crate::optimize::on_one_plane`],
/// about the sum of their normals: the optimizer's planar test).
fn planar(tris: &[([u64; 3], [glam::DVec3; 3])]) -> bool {
    let normal = tris
        .iter()
        .map(|(_, p)| (p[1] - p[0]).cross(p[2] - p[0]))
        .sum::<glam::DVec3>()
        .normalize_or_zero();
    let points: Vec<glam::DVec3> = tris.iter().flat_map(|(_, p)| *p).collect();
    crate::optimize::on_one_plane(&points, normal)
}

/// True when a result of worst quad η `worst` may still be raised by [`RAISE_MIN`] under
/// the wall-corner bound `bound` ([`wall_corner_bound`]; a margin of 1e-6 for rounding).
pub(super) fn raisable(worst: f64, bound: f64) -> bool {
    bound > worst + RAISE_MIN - 1e-6
}

/// New quads per input triangle of `out` against `input` (quads already in the input do
/// not count), `out` refined `refine` times: each refinement makes four quads of one, so
/// the count is taken before refinement, the one the element-count rule bounds.
pub(super) fn quads_per_triangle(input: &Mesh, out: &Mesh, refine: u8) -> f64 {
    let triangles = surface_elements(input, etype::TRI3).max(1);
    let quads = surface_elements(out, etype::QUAD4) as f64 / 4f64.powi(i32::from(refine));
    (quads - surface_elements(input, etype::QUAD4) as f64) / triangles as f64
}

/// Elements of type `t` on the surfaces of `m`.
pub(super) fn surface_elements(m: &Mesh, t: u32) -> usize {
    surface_elements_where(m, t, |_| true)
}

/// [`surface_elements`] on the surfaces for which `keep` (of the surface tag) is true.
pub(super) fn surface_elements_where(m: &Mesh, t: u32, keep: impl Fn(i32) -> bool) -> usize {
    m.element_blocks
        .iter()
        .filter(|b| b.entity_dim == 2 && b.element_type == t && keep(b.entity_tag))
        .map(|b| b.len())
        .sum()
}

/// Every triangle of `input` on the surfaces of `spots`, without those already `chosen`.
pub(super) fn surface_triangles(
    input: &Mesh,
    spots: &[(i32, [u64; 4])],
    chosen: &HashSet<u64>,
) -> HashSet<u64> {
    let surfaces: HashSet<i32> = spots.iter().map(|s| s.0).collect();
    input
        .element_blocks
        .iter()
        .filter(|b| {
            b.element_type == etype::TRI3 && b.entity_dim == 2 && surfaces.contains(&b.entity_tag)
        })
        .flat_map(|b| b.tags.iter().copied())
        .filter(|t| !chosen.contains(t))
        .collect()
}

/// The triangles of some surfaces of an input, by surface and sorted node tags, with their
/// element tags.
struct SurfaceTriangles(std::collections::HashMap<(i32, [u64; 3]), u64>);

impl SurfaceTriangles {
    /// The triangles of `input` on `surfaces`.
    fn of(input: &Mesh, surfaces: &HashSet<i32>) -> Self {
        let mut map = std::collections::HashMap::new();
        for b in input.element_blocks.iter().filter(|b| {
            b.element_type == etype::TRI3 && b.entity_dim == 2 && surfaces.contains(&b.entity_tag)
        }) {
            for i in 0..b.len() {
                let e = b.element(i);
                let mut t = [e[0], e[1], e[2]];
                t.sort_unstable();
                map.insert((b.entity_tag, t), b.tags[i]);
            }
        }
        SurfaceTriangles(map)
    }

    /// The element tag of surface `s`'s triangle of nodes `t` (any order).
    fn tag(&self, s: i32, mut t: [u64; 3]) -> Option<u64> {
        t.sort_unstable();
        self.0.get(&(s, t)).copied()
    }

    /// True when surface `s` has the triangle of nodes `a`, `b`, `c` (any order).
    fn has(&self, s: i32, a: u64, b: u64, c: u64) -> bool {
        self.tag(s, [a, b, c]).is_some()
    }

    /// The element tags of the two triangles of surface `s` that form the quad `q` split
    /// along a diagonal with an end at `node`, when there are such.
    fn pair_at(&self, s: i32, [a, b, c, d]: [u64; 4], node: u64) -> Option<(u64, u64)> {
        let diagonal_ac = node == a || node == c;
        let diagonal_bd = node == b || node == d;
        [
            (diagonal_ac, [a, b, c], [a, c, d]),
            (diagonal_bd, [b, c, d], [b, d, a]),
        ]
        .into_iter()
        .filter(|x| x.0)
        .find_map(|(_, x, y)| Some((self.tag(s, x)?, self.tag(s, y)?)))
    }

    /// The element tags of the two triangles of surface `s` that form the quad `q` (split
    /// along either diagonal), when there are such.
    fn pair(&self, s: i32, [a, b, c, d]: [u64; 4]) -> Option<(u64, u64)> {
        [([a, b, c], [a, c, d]), ([b, c, d], [b, d, a])]
            .into_iter()
            .find_map(|(x, y)| Some((self.tag(s, x)?, self.tag(s, y)?)))
    }
}

/// The quads of `spots` (surface, node tags), as (surface, sorted node tags), that two
/// adjacent triangles of `input` on the same surface form, and that `priced` does not hold
/// yet.
pub(super) fn pairs_of(
    input: &Mesh,
    spots: &[(i32, [u64; 4])],
    priced: &[(i32, [u64; 4])],
) -> Vec<(i32, [u64; 4])> {
    let surfaces: HashSet<i32> = spots.iter().map(|s| s.0).collect();
    let triangles = SurfaceTriangles::of(input, &surfaces);
    let mut out = Vec::new();
    for &(surface, n) in spots {
        let mut sorted = n;
        sorted.sort_unstable();
        if priced.contains(&(surface, sorted)) || out.contains(&(surface, sorted)) {
            continue;
        }
        if triangles.pair(surface, n).is_some() {
            out.push((surface, sorted));
        }
    }
    out
}

/// The radial edges of the boundary fans on the surfaces of bad quads, to peel
/// ([`recombine::split_triangles`]), that `done` does not hold yet. A fan node is a
/// boundary node `b` of a surface with exactly two triangles, `(p, b, x)` and `(b, n, x)`
/// (`p-b` and `b-n` its boundary segments): pairing them gives a corner of the
/// boundary's angle at `b`, flat on a straight or smooth curve, whatever the optimizer
/// does. Consecutive fan nodes with the same apex `x` (a curve meshed finer than the face)
/// make a fan whose middle triangles have no other neighbour, so every perfect matching has
/// such a flat pair. Taken are the fans of two fan nodes or more, and the fan of the bad
/// corner of each bad quad of two triangles at a fan node; a fan's radial edges are `x` to
/// each of its fan nodes and, where they are inside the surface, to its two ends. Peeled,
/// each triangle of the fan is a quad on the boundary and a triangle at `x`, and the
/// triangles at `x` pair with each other at the radial edges' midpoints, which the
/// optimizer moves.
pub(super) fn fan_radials(input: &Mesh, bad: &[BadQuad], done: &[(u64, u64)]) -> Vec<(u64, u64)> {
    let corners: Vec<(i32, [u64; 4], u64)> = bad.iter().map(|q| (q.surface, q.nodes, q.node())).collect();
    fans_at(input, &corners, done)
}

/// [`fan_radials`] of the quads `corners` (surface, node tags, the node of the corner that
/// may be a fan node's).
fn fans_at(input: &Mesh, corners: &[(i32, [u64; 4], u64)], done: &[(u64, u64)]) -> Vec<(u64, u64)> {
    let surfaces: HashSet<i32> = corners.iter().map(|c| c.0).collect();
    let triangles = SurfaceTriangles::of(input, &surfaces);
    let boundary = Boundary::of(&triangles);
    // the third nodes of the triangles at each edge of a surface
    let mut third: std::collections::HashMap<(i32, u64, u64), Vec<u64>> = Default::default();
    for &(s, t) in triangles.0.keys() {
        for j in 0..3 {
            let (a, c) = key(t[j], t[(j + 1) % 3]);
            third.entry((s, a, c)).or_default().push(t[(j + 2) % 3]);
        }
    }
    let inside = |s: i32, a: u64, c: u64| {
        let (a, c) = key(a, c);
        boundary.count.get(&(s, a, c)) == Some(&2)
    };
    let single = |s: i32, a: u64, c: u64| {
        let (a, c) = key(a, c);
        match third.get(&(s, a, c)).map(Vec::as_slice) {
            Some(&[x]) => Some(x),
            _ => None,
        }
    };
    // a fan node's apex and its two boundary neighbours
    let fan = |s: i32, b: u64| -> Option<(u64, [u64; 2])> {
        let &[p, n] = boundary.at.get(&(s, b))?.as_slice() else {
            return None;
        };
        let x = single(s, p, b)?;
        (single(s, b, n)? == x && x != p && x != n && inside(s, b, x)).then_some((x, [p, n]))
    };
    let mut starts: Vec<(i32, u64)> = Vec::new();
    for &(s, nodes, node) in corners {
        if fan(s, node).is_some() && triangles.pair(s, nodes).is_some() {
            starts.push((s, node));
        }
    }
    let mut nodes: Vec<(i32, u64)> = boundary.at.keys().copied().collect();
    nodes.sort_unstable();
    for (s, b) in nodes {
        if let Some((x, ends)) = fan(s, b) {
            if ends.iter().any(|&e| fan(s, e).is_some_and(|f| f.0 == x)) {
                starts.push((s, b));
            }
        }
    }
    let mut seen: HashSet<(i32, u64)> = HashSet::new();
    let mut out: std::collections::BTreeSet<(u64, u64)> = Default::default();
    for (s, v) in starts {
        let Some((x, ends)) = fan(s, v) else { continue };
        if !seen.insert((s, v)) {
            continue;
        }
        out.insert(key(v, x));
        // along the boundary from v both ways while the nodes are fan nodes at x
        for first in ends {
            let (mut prev, mut cur) = (v, first);
            loop {
                match fan(s, cur) {
                    Some((y, [p, n])) if y == x && cur != v && seen.insert((s, cur)) => {
                        out.insert(key(cur, x));
                        let next = if p == prev { n } else { p };
                        (prev, cur) = (cur, next);
                    }
                    _ => {
                        // the fan's end: its radial edge where it is inside the surface
                        if cur != x && inside(s, cur, x) && fan(s, cur).is_none_or(|f| f.0 != x) {
                            out.insert(key(cur, x));
                        }
                        break;
                    }
                }
            }
        }
    }
    out.into_iter().filter(|r| !done.contains(r)).collect()
}

/// Boundary segments whose split lets the triangles of a bad fan quad pair otherwise, and
/// that `done` does not hold yet. A fan quad is two input triangles `(u, v, x)` and
/// `(v, w, x)` of one surface whose bad corner is at `v`, a boundary node of the surface
/// (on a strip or a band between two curves, a run of triangles with their bases on the
/// same side: the corner at `v` is flat). When `x` is a boundary node too, the longer
/// boundary segment `(x, y)` of a triangle `(x, y, w)` or `(x, y, u)` is split: its two
/// halves give `(v, w, x)` (or `(u, v, x)`) a partner with a base on `x`'s side, as a
/// parity repair's split would.
pub(super) fn fan_segments(input: &Mesh, bad: &[BadQuad], done: &[(u64, u64)]) -> Vec<(u64, u64)> {
    let surfaces: HashSet<i32> = bad.iter().map(|b| b.surface).collect();
    let coords = TagCoords::new(input);
    let at = |t: u64| coords.get(t).map(glam::DVec3::from_array);
    let triangles = SurfaceTriangles::of(input, &surfaces);
    let boundary = Boundary::of(&triangles);
    let on_boundary = |s: i32, a: u64, b: u64| boundary.is_segment(s, a, b);
    let segments_at = &boundary.at;
    let mut out: Vec<(u64, u64)> = Vec::new();
    for q in bad {
        let s = q.surface;
        let n = q.nodes;
        let Some(k) = n.iter().position(|&t| t == q.node()) else {
            continue;
        };
        // the quad as (u, v, w, x) with the bad corner at v and the diagonal v-x
        let (u, v, w, x) = (n[(k + 3) % 4], n[k], n[(k + 1) % 4], n[(k + 2) % 4]);
        if !triangles.has(s, u, v, x) || !triangles.has(s, v, w, x) {
            continue;
        }
        if !on_boundary(s, u, v) || !on_boundary(s, v, w) {
            continue;
        }
        let Some(ys) = segments_at.get(&(s, x)) else {
            continue;
        };
        let mut ys = ys.clone();
        ys.sort_unstable();
        let candidates = ys
            .into_iter()
            .filter(|&y| y != u && y != w)
            .filter(|&y| triangles.has(s, x, y, w) || triangles.has(s, x, y, u))
            .map(|y| key(x, y))
            .filter(|seg| !done.contains(seg) && !out.contains(seg));
        if let Some(seg) = longest(candidates, &at) {
            out.push(seg);
        }
    }
    out.sort_unstable();
    out
}

/// The longest of `segments` (node pairs) by the positions `at` gives, the first of equal
/// ones; segments with an end `at` does not know are skipped.
fn longest(
    segments: impl Iterator<Item = (u64, u64)>,
    at: &impl Fn(u64) -> Option<glam::DVec3>,
) -> Option<(u64, u64)> {
    let mut best: Option<(f64, (u64, u64))> = None;
    for seg in segments {
        let (Some(pa), Some(pb)) = (at(seg.0), at(seg.1)) else {
            continue;
        };
        let len = pa.distance(pb);
        if best.is_none_or(|(l, _)| len > l) {
            best = Some((len, seg));
        }
    }
    best.map(|b| b.1)
}

/// The boundary segments of a set of surfaces' triangles: the edges that one triangle of
/// the surface holds.
struct Boundary {
    /// How many of a surface's triangles hold each edge (surface, smaller tag, larger tag).
    count: std::collections::HashMap<(i32, u64, u64), u32>,
    /// The other ends of a surface's boundary segments at each node.
    at: std::collections::HashMap<(i32, u64), Vec<u64>>,
}

impl Boundary {
    fn of(triangles: &SurfaceTriangles) -> Self {
        let mut count: std::collections::HashMap<(i32, u64, u64), u32> =
            std::collections::HashMap::new();
        for &(s, t) in triangles.0.keys() {
            for j in 0..3 {
                let (a, c) = key(t[j], t[(j + 1) % 3]);
                *count.entry((s, a, c)).or_default() += 1;
            }
        }
        let mut at: std::collections::HashMap<(i32, u64), Vec<u64>> =
            std::collections::HashMap::new();
        for (&(s, a, b), &c) in &count {
            if c == 1 {
                at.entry((s, a)).or_default().push(b);
                at.entry((s, b)).or_default().push(a);
            }
        }
        Boundary { count, at }
    }

    /// True when `(a, b)` is a boundary segment of surface `s`.
    fn is_segment(&self, s: i32, a: u64, b: u64) -> bool {
        let (a, b) = key(a, b);
        self.count.get(&(s, a, b)) == Some(&1)
    }
}

/// The node pair `(a, b)` in increasing order.
fn key(a: u64, b: u64) -> (u64, u64) {
    (a.min(b), a.max(b))
}

/// Smallest angle of a quad's corner at a wall node, in degrees, from which
/// [`low_quad_segments`] splits a segment under it: a corner whose η (eq. 3) is at most
/// [`crate::recombine::FIXED_CORNER_MIN_ETA`], which no smoothing opens or closes.
const FLAT_WALL_CORNER_DEG: f64 = 157.5;

/// Boundary segments whose split lets the triangles of a poor quad pair otherwise, and
/// that `done` does not hold yet. A poor quad (`low`: surface and node tags of `result`) is
/// two input triangles `(u, v, x)` and `(v, w, x)` of one surface whose widest corner, at
/// least [`FLAT_WALL_CORNER_DEG`], is at `v`, a boundary node of the surface: a wall corner
/// no smoothing changes. The longer boundary segment of the two triangles that does not
/// end at `v` is split. Typically `v` is a reflex wall corner whose middle triangle has its
/// third side on a curve: that triangle's only neighbours are the two beside it, and its
/// wide angle at `v` makes a flat or reflex corner with either; its halves pair with one
/// each, and the corner at `v` is parted between two quads.
pub(super) fn low_quad_segments(
    input: &Mesh,
    result: &Mesh,
    low: &[(i32, [u64; 4])],
    done: &[(u64, u64)],
) -> Vec<(u64, u64)> {
    let corners = widest_corners(result, low, FLAT_WALL_CORNER_DEG);
    segments_opposite(input, &corners, done, None)
}

/// The radial edges of boundary fans to peel ([`fan_radials`]) for the poor quads `low`
/// (surface and node tags of `result`) whose widest corner, at least
/// [`FLAT_WALL_CORNER_DEG`], is at a fan node: a boundary node with exactly two triangles,
/// at one apex, which every pairing of those two makes a corner of the boundary's angle
/// there, near 180° on a smooth curve, whatever the optimizer does. Peeled, each of the
/// fan's triangles is a quad on the boundary and a triangle at the apex.
pub(super) fn low_quad_fans(
    input: &Mesh,
    result: &Mesh,
    low: &[(i32, [u64; 4])],
    done: &[(u64, u64)],
) -> Vec<(u64, u64)> {
    let corners: Vec<(i32, [u64; 4], u64)> = widest_corners(result, low, FLAT_WALL_CORNER_DEG)
        .into_iter()
        .map(|(s, n, k)| (s, n, n[k]))
        .collect();
    if corners.is_empty() {
        return Vec::new();
    }
    fans_at(input, &corners, done)
}

/// The quads of `low` (surface and node tags of `result`) whose widest corner is at least
/// `min_deg` degrees, with that corner's index.
fn widest_corners(result: &Mesh, low: &[(i32, [u64; 4])], min_deg: f64) -> Vec<(i32, [u64; 4], usize)> {
    let results = TagCoords::new(result);
    let mut out = Vec::new();
    for &(s, n) in low {
        let Some(p) = n
            .iter()
            .map(|&t| results.get(t).map(glam::DVec3::from_array))
            .collect::<Option<Vec<_>>>()
        else {
            continue;
        };
        let angle = |k: usize| (p[(k + 1) % 4] - p[k]).angle_between(p[(k + 3) % 4] - p[k]);
        let Some(k) = (0..4).max_by(|&a, &b| angle(a).total_cmp(&angle(b))) else {
            continue;
        };
        if angle(k).to_degrees() >= min_deg {
            out.push((s, n, k));
        }
    }
    out
}

/// Boundary segments whose split lets the triangles of a bad quad pair otherwise, and
/// that `done` does not hold yet: as [`low_quad_segments`], for the quads of `bad` whose
/// corner is flat, reflex or turned over about the input surface's normal at a boundary
/// node, that corner taken as `v` whatever its angle in space (on a curved face a corner
/// the gate finds flat can measure well under [`FLAT_WALL_CORNER_DEG`] between its edges),
/// where the triangle over the segment has an angle of at least [`WIDE_AT_WALL_DEG`] at `v`.
/// Typically two curves of a face run side by side a fraction of a segment apart, and the
/// triangle between a node of one and a segment of the other has a wide angle at the node:
/// with either neighbour it makes a corner near 180° there.
pub(super) fn wall_corner_segments(
    input: &Mesh,
    bad: &[BadQuad],
    done: &[(u64, u64)],
) -> Vec<(u64, u64)> {
    let corners: Vec<(i32, [u64; 4], usize)> = bad
        .iter()
        .filter_map(|b| match b.defect {
            crate::validity::Defect::Corner { corner, .. } => Some((b.surface, b.nodes, corner)),
            _ => None,
        })
        .collect();
    segments_opposite(input, &corners, done, Some(WIDE_AT_WALL_DEG))
}

/// The segments [`segment_under`] gives for the quads `corners` (surface, node tags, the
/// corner `v`), each not in `done` nor given for an earlier quad, sorted; with `wide`, only
/// those whose triangle has an angle of at least `wide` degrees at `v`.
fn segments_opposite(
    input: &Mesh,
    corners: &[(i32, [u64; 4], usize)],
    done: &[(u64, u64)],
    wide: Option<f64>,
) -> Vec<(u64, u64)> {
    if corners.is_empty() {
        return Vec::new();
    }
    let surfaces: HashSet<i32> = corners.iter().map(|c| c.0).collect();
    let triangles = SurfaceTriangles::of(input, &surfaces);
    let boundary = Boundary::of(&triangles);
    let coords = TagCoords::new(input);
    let at = |t: u64| coords.get(t).map(glam::DVec3::from_array);
    let mut out: Vec<(u64, u64)> = Vec::new();
    for &(s, n, k) in corners {
        let Some(seg) = segment_under(&triangles, &boundary, &at, s, n, k, done, &out) else {
            continue;
        };
        if let Some(wide) = wide {
            // the angle its triangle has at the corner's node
            let (Some(v), Some(a), Some(b)) = (at(n[k]), at(seg.0), at(seg.1)) else {
                continue;
            };
            if (a - v).angle_between(b - v).to_degrees() < wide {
                continue;
            }
        }
        out.push(seg);
    }
    out.sort_unstable();
    out
}

/// Smallest angle, in degrees, of the input triangle at a bad quad's wall corner for which
/// [`wall_corner_segments`] splits the boundary segment opposite it: halved, that angle
/// leaves each half's partner room for a corner under 180° there; a narrower one is not
/// what made the corner flat.
const WIDE_AT_WALL_DEG: f64 = 120.0;

/// The longer boundary segment, not in `done` or `taken`, of the two input triangles
/// `(u, v, x)` and `(v, w, x)` of surface `s` that quad `n` is made of, with `v` its corner
/// `k`, a boundary node of `s`: a side of a triangle opposite `v`.
#[allow(clippy::too_many_arguments)]
fn segment_under(
    triangles: &SurfaceTriangles,
    boundary: &Boundary,
    at: &impl Fn(u64) -> Option<glam::DVec3>,
    s: i32,
    n: [u64; 4],
    k: usize,
    done: &[(u64, u64)],
    taken: &[(u64, u64)],
) -> Option<(u64, u64)> {
    let (u, v, w, x) = (n[(k + 3) % 4], n[k], n[(k + 1) % 4], n[(k + 2) % 4]);
    if !boundary.at.contains_key(&(s, v)) {
        return None;
    }
    if !triangles.has(s, u, v, x) || !triangles.has(s, v, w, x) {
        return None;
    }
    let candidates = [(u, x), (w, x)]
        .into_iter()
        .filter(|&(a, b)| boundary.is_segment(s, a, b))
        .map(|(a, b)| key(a, b))
        .filter(|seg| !done.contains(seg) && !taken.contains(seg));
    longest(candidates, at)
}

/// The input triangles of `input` that lie inside the quads `spots` (surface, node tags),
/// without those already `chosen`: on a quad's surface, those whose three nodes are among
/// the quad's, the node of a parity split (`splits`) standing for both ends of its segment
/// (so the triangle it halved counts, as well as a pair's two triangles). Splitting these
/// alone, rather than the ring around the quad, leaves the faces beyond the quad's curves
/// as they are where the quad is on a wall.
pub(super) fn triangles_inside(
    input: &Mesh,
    spots: &[(i32, [u64; 4])],
    splits: &[recombine::ParitySplit],
    chosen: &HashSet<u64>,
) -> HashSet<u64> {
    let surfaces: HashSet<i32> = spots.iter().map(|s| s.0).collect();
    let triangles = SurfaceTriangles::of(input, &surfaces);
    let ends: std::collections::HashMap<u64, (u64, u64)> =
        splits.iter().map(|s| (s.new_node, s.segment)).collect();
    let mut out = HashSet::new();
    for &(surface, quad) in spots {
        let mut nodes: Vec<u64> = Vec::with_capacity(8);
        for n in quad {
            match ends.get(&n) {
                Some(&(a, b)) => nodes.extend([a, b]),
                None => nodes.push(n),
            }
        }
        nodes.sort_unstable();
        nodes.dedup();
        for i in 0..nodes.len() {
            for j in i + 1..nodes.len() {
                for k in j + 1..nodes.len() {
                    if let Some(t) = triangles.tag(surface, [nodes[i], nodes[j], nodes[k]]) {
                        if !chosen.contains(&t) {
                            out.insert(t);
                        }
                    }
                }
            }
        }
    }
    out
}

/// The input triangles to split after a round with bad quads `spots` (surface, node tags;
/// `mesh` the round's result): on each bad quad's surface, the triangles holding one of
/// its nodes (or, for a quad none of whose nodes an input triangle holds, the input
/// triangle nearest to its centre), and from the second ring on also those touching a
/// triangle split before; without those already `chosen`. With `tight`, the first ring of
/// a bad quad that two input triangles form is those two.
pub(super) fn fallback_triangles(
    input: &Mesh,
    mesh: &Mesh,
    spots: &[(i32, [u64; 4])],
    chosen: &HashSet<u64>,
    ring: usize,
    tight: bool,
) -> HashSet<u64> {
    let surfaces: HashSet<i32> = spots.iter().map(|s| s.0).collect();
    let tri_blocks = || {
        input.element_blocks.iter().filter(|b| {
            b.element_type == etype::TRI3 && b.entity_dim == 2 && surfaces.contains(&b.entity_tag)
        })
    };
    let mut out = HashSet::new();
    // the first ring of a bad quad that two input triangles form is those two
    let mut spots = spots.to_vec();
    if ring == 1 && tight {
        let triangles = SurfaceTriangles::of(input, &surfaces);
        spots.retain(|&(s, q)| {
            match triangles.pair(s, q) {
                Some((x, y)) => {
                    out.extend([x, y].into_iter().filter(|t| !chosen.contains(t)));
                    false
                }
                None => true,
            }
        });
    }
    let spots = &spots[..];
    let mut near: HashSet<(i32, u64)> = spots
        .iter()
        .flat_map(|&(s, q)| q.into_iter().map(move |n| (s, n)))
        .collect();
    // quads none of whose nodes an input triangle of their surface holds (made of new
    // nodes): the nearest input triangle to their centre stands for them
    let held: HashSet<(i32, u64)> = tri_blocks()
        .flat_map(|b| {
            b.nodes
                .iter()
                .filter(|&&n| near.contains(&(b.entity_tag, n)))
                .map(move |&n| (b.entity_tag, n))
        })
        .collect();
    let orphans: Vec<&(i32, [u64; 4])> = spots
        .iter()
        .filter(|(s, q)| !q.iter().any(|&n| held.contains(&(*s, n))))
        .collect();
    if !orphans.is_empty() {
        let out_index = mesh.node_index();
        let in_index = input.node_index();
        let at = |m: &Mesh, index: &crate::mesh::NodeIndex, t: u64| {
            index
                .get(t)
                .map(|r| m.node_blocks[r.block as usize].coords[r.index as usize])
        };
        for &(surface, q) in orphans {
            let pts: Vec<[f64; 3]> = q.iter().filter_map(|&t| at(mesh, &out_index, t)).collect();
            if pts.is_empty() {
                continue;
            }
            let c = centre(&pts);
            let mut best: Option<(f64, [u64; 3])> = None;
            for b in tri_blocks().filter(|b| b.entity_tag == surface) {
                for i in 0..b.len() {
                    let e = b.element(i);
                    let corners: Vec<[f64; 3]> =
                        e.iter().filter_map(|&t| at(input, &in_index, t)).collect();
                    if corners.len() != 3 {
                        continue;
                    }
                    let m = centre(&corners);
                    let d = (0..3).map(|k| (m[k] - c[k]).powi(2)).sum::<f64>();
                    if best.is_none_or(|(bd, _)| d < bd) {
                        best = Some((d, [e[0], e[1], e[2]]));
                    }
                }
            }
            if let Some((_, t)) = best {
                near.extend(t.iter().map(|&n| (surface, n)));
            }
        }
    }
    if ring >= 2 {
        for b in tri_blocks() {
            for i in 0..b.len() {
                if chosen.contains(&b.tags[i]) {
                    near.extend(b.element(i).iter().map(|&n| (b.entity_tag, n)));
                }
            }
        }
    }
    for b in tri_blocks() {
        for i in 0..b.len() {
            let t = b.tags[i];
            if !chosen.contains(&t)
                && b.element(i)
                    .iter()
                    .any(|&n| near.contains(&(b.entity_tag, n)))
            {
                out.insert(t);
            }
        }
    }
    out
}

/// The mean of `points`.
pub(super) fn centre(points: &[[f64; 3]]) -> [f64; 3] {
    let n = points.len().max(1) as f64;
    let mut c = [0.0; 3];
    for p in points {
        for k in 0..3 {
            c[k] += p[k] / n;
        }
    }
    c
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::testing::{node_block, one_surface};
    use crate::validity::Defect;

    /// A strip between two straight curves, bottom nodes 1-3 and top nodes 4-8, whose
    /// triangles 3 and 4 form a fan at node 2: their bases are both on the top.
    fn strip() -> Mesh {
        let coords = vec![
            [0.0, 0.0, 0.0],
            [2.0, 0.0, 0.0],
            [5.0, 0.0, 0.0],
            [0.0, 1.0, 0.0],
            [1.0, 1.0, 0.0],
            [2.0, 1.0, 0.0],
            [3.0, 1.0, 0.0],
            [5.0, 1.0, 0.0],
        ];
        one_surface(
            vec![node_block(2, (1..=8).collect(), coords)],
            etype::TRI3,
            &[
                &[1, 5, 4],
                &[1, 2, 5],
                &[2, 6, 5],
                &[2, 7, 6],
                &[2, 3, 7],
                &[3, 8, 7],
            ],
        )
    }

    fn bad(nodes: [u64; 4], corner: usize) -> BadQuad {
        BadQuad {
            surface: 1,
            element: 1,
            nodes,
            defect: Defect::Corner {
                corner,
                degrees: 180.0,
            },
        }
    }

    /// A planar fan of triangles around node 1 at the origin, spanning `degrees` in the
    /// plane z = 0 turned by `tilt` radians about the x axis (one node per 10 degrees,
    /// nodes 2, 3, … at distance 1), with node 1 lifted by `lift` out of that plane.
    fn wedge(degrees: u32, tilt: f64, lift: f64) -> Mesh {
        let steps = degrees.div_ceil(10);
        let mut coords = vec![[0.0, 0.0, lift]];
        for k in 0..=steps {
            let a = f64::from(degrees) * f64::from(k) / f64::from(steps);
            let (y, x) = a.to_radians().sin_cos();
            coords.push([x, y * tilt.cos(), y * tilt.sin()]);
        }
        let tris: Vec<[u64; 3]> = (0..u64::from(steps)).map(|k| [1, k + 2, k + 3]).collect();
        let elems: Vec<&[u64]> = tris.iter().map(|t| &t[..]).collect();
        let tags = (1..=coords.len() as u64).collect();
        one_surface(vec![node_block(2, tags, coords)], etype::TRI3, &elems)
    }

    #[test]
    fn the_wall_corner_bound_is_the_acute_angle_of_a_planar_surface() {
        // a 20-degree corner at node 1 bounds η by 20/90; the other corners (85 degrees
        // at the arc's ends, 170 between them) do not go lower
        let bound = wall_corner_bound(&wedge(20, 0.0, 0.0));
        assert!((bound - 20.0 / 90.0).abs() < 1e-9, "{bound}");
        // the same in a tilted plane
        let bound = wall_corner_bound(&wedge(20, 0.5, 0.0));
        assert!((bound - 20.0 / 90.0).abs() < 1e-9, "{bound}");
        // a wide fan: its corners are all above 90 degrees but the ends of the arc, which
        // have 85
        let bound = wall_corner_bound(&wedge(300, 0.0, 0.0));
        assert!((bound - 85.0 / 90.0).abs() < 1e-9, "{bound}");
        // a curved surface (the centre lifted out of the plane) is left out
        assert_eq!(wall_corner_bound(&wedge(20, 0.0, 0.1)), 1.0);
        // so is a surface with a quad in the input
        let mut with_quad = wedge(20, 0.0, 0.0);
        let mut quads = with_quad.element_blocks[0].clone();
        quads.element_type = etype::QUAD4;
        quads.tags = vec![100];
        quads.nodes = vec![1, 2, 3, 3];
        with_quad.element_blocks.push(quads);
        assert_eq!(wall_corner_bound(&with_quad), 1.0);
    }

    #[test]
    fn a_worst_quad_at_the_wall_corner_bound_cannot_be_raised() {
        let bound = 20.0 / 90.0;
        assert!(!raisable(bound, bound));
        assert!(!raisable(bound - 0.5 * RAISE_MIN, bound));
        assert!(raisable(bound - 2.0 * RAISE_MIN, bound));
        assert!(raisable(0.1, 1.0));
        assert!(!raisable(1.0, 1.0));
    }

    #[test]
    fn a_fan_quad_gets_the_longer_segment_under_its_apex_split() {
        let m = strip();
        // the quad 5-6-7-2 of the fan at node 2 is flat at node 6
        let got = fan_segments(&m, &[bad([5, 6, 7, 2], 1)], &[]);
        // segments 1-2 (length 2, its triangle holds node 5) and 2-3 (length 3, its
        // triangle holds node 7): the longer one
        assert_eq!(got, vec![(2, 3)]);
        // the same quad named from another corner, with the same bad node
        assert_eq!(fan_segments(&m, &[bad([7, 2, 5, 6], 3)], &[]), vec![(2, 3)]);
        // a segment split already is not split again: the other one is
        assert_eq!(
            fan_segments(&m, &[bad([5, 6, 7, 2], 1)], &[(2, 3)]),
            vec![(1, 2)]
        );
    }

    #[test]
    fn splits_exceed_a_cap_only_past_the_least_count_the_optimizer_may_lower() {
        // 100 triangles, cap 0.6: at least 3 c + (100 - c) / 2 new quads, of which the
        // optimizer may remove half: past the cap from 29 split triangles on
        assert!(!splits_exceed(100, 0, 0.6));
        assert!(!splits_exceed(100, 28, 0.6));
        assert!(splits_exceed(100, 29, 0.6));
        assert!(splits_exceed(100, 100, 0.6));
        // a larger cap takes more splits; more split triangles than the input has count
        // as all of them
        assert!(!splits_exceed(100, 29, 0.75));
        assert!(splits_exceed(100, 500, 1.4));
        assert!(!splits_exceed(100, 500, 1.5));
        // no triangle: no split exceeds anything
        assert!(!splits_exceed(0, 0, 0.6));
        // 1000 triangles, where the optimizer may remove a quarter: past the cap 0.6 from
        // 121 split triangles on (3 c + (1000 - c) / 2 times 3/4 above 600)
        assert!(!splits_exceed(1000, 120, 0.6));
        assert!(splits_exceed(1000, 121, 0.6));
    }

    #[test]
    fn a_quad_flat_at_a_wall_node_gets_the_segment_across_the_neck_split() {
        // two curves 0.15 apart: nodes 1-2-3 on y = 0, nodes 4 and 5 on y = 0.15; the
        // middle triangle 2-5-4 has a 163 degree angle at node 2, so either pair it makes
        // is flat there, and neither of its sides at node 2 is a boundary segment (no fan)
        let coords = vec![
            [0.0, 0.0, 0.0],
            [1.0, 0.0, 0.0],
            [2.0, 0.0, 0.0],
            [0.0, 0.15, 0.0],
            [2.0, 0.15, 0.0],
        ];
        let m = one_surface(
            vec![node_block(2, (1..=5).collect(), coords)],
            etype::TRI3,
            &[&[1, 2, 4], &[2, 5, 4], &[2, 3, 5]],
        );
        let flat = bad([1, 2, 5, 4], 1);
        assert!(fan_segments(&m, std::slice::from_ref(&flat), &[]).is_empty());
        // of the pair's boundary segments opposite node 2 (1-4 and 4-5), the longer, whose
        // triangle is wide at node 2
        assert_eq!(wall_corner_segments(&m, std::slice::from_ref(&flat), &[]), vec![(4, 5)]);
        // with 4-5 split already, not 1-4: its triangle has 8.5 degrees at node 2
        assert!(wall_corner_segments(&m, std::slice::from_ref(&flat), &[(4, 5)]).is_empty());
        // the same quad bad at node 5, off the pair's diagonal 2-4: not two triangles
        // meeting there
        assert!(wall_corner_segments(&m, &[bad([1, 2, 5, 4], 2)], &[]).is_empty());
        // a quad folded about its own normal names no flat wall corner
        let folded = BadQuad {
            defect: Defect::OwnJacobian {
                corner: 1,
                scaled: -0.5,
            },
            ..flat
        };
        assert!(wall_corner_segments(&m, &[folded], &[]).is_empty());
    }

    #[test]
    fn a_fan_quad_gets_the_radial_edges_of_its_whole_fan_to_peel() {
        // boundary nodes 1-5 on y = 0 under apex 6, nodes 7 and 8 beyond the fan's ends:
        // nodes 1 to 5 each have two triangles at 6; 6-7 and 6-8 are boundary segments
        let coords = vec![
            [0.0, 0.0, 0.0],
            [1.0, 0.0, 0.0],
            [2.0, 0.0, 0.0],
            [3.0, 0.0, 0.0],
            [4.0, 0.0, 0.0],
            [2.0, 2.0, 0.0],
            [-1.0, 1.0, 0.0],
            [5.0, 1.0, 0.0],
        ];
        let m = one_surface(
            vec![node_block(2, (1..=8).collect(), coords)],
            etype::TRI3,
            &[&[1, 2, 6], &[2, 3, 6], &[3, 4, 6], &[4, 5, 6], &[7, 1, 6], &[5, 8, 6]],
        );
        let all = vec![(1, 6), (2, 6), (3, 6), (4, 6), (5, 6)];
        assert_eq!(fan_radials(&m, &[bad([2, 3, 4, 6], 1)], &[]), all);
        // the fan is found from any bad quad of its surface, and radials done are left out
        assert_eq!(
            fan_radials(&m, &[bad([7, 1, 2, 6], 0)], &[(3, 6)]),
            vec![(1, 6), (2, 6), (4, 6), (5, 6)]
        );
        // a fan of one node: its radial edge and, inside the surface, those of its ends
        let strip = strip();
        assert_eq!(
            fan_radials(&strip, &[bad([5, 6, 7, 2], 1)], &[]),
            vec![(2, 5), (2, 6), (2, 7)]
        );
        // no fan node at the bad corner, and no fan of two nodes on the surface
        assert!(fan_radials(&strip, &[bad([1, 2, 6, 5], 1)], &[]).is_empty());
    }

    #[test]
    fn a_poor_quad_nearly_flat_at_a_fan_node_gets_its_fan_to_peel() {
        let input = strip();
        // in the result, node 6 lifted off the line 5-7: the corner of 5-6-7-2 at 6 is
        // about 179.4 degrees, valid but poor
        let mut result = strip();
        result.node_blocks[0].coords[5] = [2.0, 1.01, 0.0];
        let fan = vec![(2, 5), (2, 6), (2, 7)];
        assert_eq!(low_quad_fans(&input, &result, &[(1, [5, 6, 7, 2])], &[]), fan);
        // radials done are left out
        assert_eq!(
            low_quad_fans(&input, &result, &[(1, [5, 6, 7, 2])], &[(2, 6)]),
            vec![(2, 5), (2, 7)]
        );
        // a poor quad with no corner near flat, and a flat one at no fan node
        assert!(low_quad_fans(&input, &result, &[(1, [1, 2, 6, 5])], &[]).is_empty());
        assert!(low_quad_fans(&input, &result, &[(1, [4, 5, 6, 1])], &[]).is_empty());
    }

    #[test]
    fn tight_splits_take_a_bad_pairs_own_triangles_first() {
        let m = strip();
        // the quad 5-6-7-2 is the pair of triangles 3 (2, 6, 5) and 4 (2, 7, 6)
        let spots = [(1, [5, 6, 7, 2])];
        let none = HashSet::new();
        let tight = fallback_triangles(&m, &m, &spots, &none, 1, true);
        assert_eq!(tight, HashSet::from([3, 4]));
        // the usual first ring: every triangle holding one of its nodes
        let ring = fallback_triangles(&m, &m, &spots, &none, 1, false);
        assert_eq!(ring, (1..=6).collect::<HashSet<u64>>());
        // the second ring is the usual one either way
        let chosen = HashSet::from([3, 4]);
        let second = fallback_triangles(&m, &m, &spots, &chosen, 2, true);
        assert_eq!(second, HashSet::from([1, 2, 5, 6]));
        // 6 triangles, no quad yet: under 500 triangles the rule allows 0.75 new quads
        // per triangle (4.5 here), and a split triangle adds 2.5
        assert!(!breaks_count_rule(&m, &m, 1));
        assert!(breaks_count_rule(&m, &m, 2));
    }

    #[test]
    fn the_triangles_inside_a_quad_count_the_one_a_parity_split_halved() {
        let m = strip();
        let none = HashSet::new();
        // a pair's two triangles
        let pair = [(1, [5, 6, 7, 2])];
        assert_eq!(triangles_inside(&m, &pair, &[], &none), HashSet::from([3, 4]));
        // segment 2-3 split at node 9: the quad 9-3-8-7 is the half (9, 3, 7) of triangle 5
        // (2, 3, 7) and triangle 6 (3, 8, 7); the split's node stands for 2 and 3
        let split = recombine::ParitySplit {
            curve: None,
            surfaces: vec![1],
            segment: (2, 3),
            new_node: 9,
            turn: false,
        };
        let half = [(1, [9, 3, 8, 7])];
        assert_eq!(
            triangles_inside(&m, &half, std::slice::from_ref(&split), &none),
            HashSet::from([5, 6])
        );
        // without the split known, only the whole triangle
        assert_eq!(triangles_inside(&m, &half, &[], &none), HashSet::from([6]));
        // nor those chosen already, nor a triangle of another surface
        assert_eq!(
            triangles_inside(&m, &half, &[split], &HashSet::from([6])),
            HashSet::from([5])
        );
        assert!(triangles_inside(&m, &[(2, [5, 6, 7, 2])], &[], &none).is_empty());
    }

    /// The strip as surface 1 and its mirror image above the top curve (nodes 4-8) as
    /// surface 2: bottom nodes 9-11, triangles 7-12 in the same order.
    fn two_strips() -> Mesh {
        let mut m = strip();
        let b = &mut m.node_blocks[0];
        for (t, x) in [(9, 0.0), (10, 2.0), (11, 5.0)] {
            b.tags.push(t);
            b.coords.push([x, 2.0, 0.0]);
        }
        let mirror = |n: u64| match n {
            1 => 9,
            2 => 10,
            3 => 11,
            n => n,
        };
        let mut upper = m.element_blocks[0].clone();
        upper.entity_tag = 2;
        upper.tags = (7..=12).collect();
        upper.nodes = upper.nodes.iter().map(|&n| mirror(n)).collect();
        m.element_blocks.push(upper);
        m
    }

    #[test]
    fn a_surface_first_bad_after_splits_elsewhere_starts_from_its_first_ring() {
        let m = two_strips();
        // two split rounds on surface 1 (triangles 3 and 4, then their neighbours), pricing
        // and segment rounds spent, tight splits; then a bad pair on surface 2: 10-6-5
        // (triangle 9) and 10-7-6 (triangle 10), flat at node 6
        let chosen: HashSet<u64> = (1..=6).collect();
        let state = |global_rings| LocalFallback {
            pricing_rounds: PRICING_ROUNDS,
            segment_rounds: SEGMENT_ROUNDS,
            split_rounds: SPLIT_RINGS,
            rings: BTreeMap::from([(1, SPLIT_RINGS)]),
            tight: true,
            state: FallbackStart {
                flat_halves_out: true,
                global_rings,
                ..Default::default()
            },
            ..Default::default()
        };
        let mut quad = bad([5, 6, 7, 10], 1);
        quad.surface = 2;
        let split = |f: &mut LocalFallback, chosen: &HashSet<u64>| {
            match f.next(&m, &m, std::slice::from_ref(&quad), chosen, &[]) {
                Next::Split(t) => t,
                _ => panic!("a split round expected"),
            }
        };
        // per surface: the first (tight) ring of surface 2, the pair's own triangles
        let mut local = state(false);
        assert_eq!(split(&mut local, &chosen), HashSet::from([9, 10]));
        assert!(local.diverged);
        assert_eq!(local.rings, BTreeMap::from([(1, SPLIT_RINGS), (2, 1)]));
        // over the job: the third split round is the last resort, all of surface 2
        let mut global = state(true);
        assert_eq!(split(&mut global, &chosen), (7..=12).collect::<HashSet<u64>>());
        assert!(!global.diverged);
        // per surface, surface 2's own rings run out too: its second ring (the triangles
        // touching 9 and 10), then the rest of the surface
        let mut chosen = chosen.clone();
        chosen.extend([9, 10]);
        assert_eq!(split(&mut local, &chosen), HashSet::from([7, 8, 11, 12]));
        chosen.extend([7, 8]);
        assert_eq!(split(&mut local, &chosen), HashSet::from([11, 12]));
    }

    #[test]
    fn a_pair_flat_at_its_diagonal_is_split_as_a_flat_pair_then_as_chosen_triangles() {
        let m = strip();
        let state = LocalFallback {
            pricing_rounds: PRICING_ROUNDS,
            segment_rounds: SEGMENT_ROUNDS,
            state: FallbackStart {
                flat_pairs: true,
                ..Default::default()
            },
            ..Default::default()
        };
        let mut f = state;
        let none = HashSet::new();
        // the quad 5-6-7-2 (triangles 3 and 4, diagonal 2-6) is flat at node 6: a flat pair
        let quad = bad([5, 6, 7, 2], 1);
        match f.next(&m, &m, std::slice::from_ref(&quad), &none, &[]) {
            Next::Split(t) => assert!(t.is_empty(), "{t:?}"),
            _ => panic!("a split round expected"),
        }
        assert_eq!(
            f.state.pairs,
            vec![(
                1,
                recombine::FlatPair {
                    triangles: [4, 3],
                    node: 6
                }
            )]
        );
        // bad again there: the second ring splits the pair's triangles as chosen ones and
        // the ring around the quad
        match f.next(&m, &m, std::slice::from_ref(&quad), &none, &[]) {
            Next::Split(t) => assert_eq!(t, (1..=6).collect::<HashSet<u64>>()),
            _ => panic!("a split round expected"),
        }
        assert!(f.state.pairs.is_empty());
        // flat at node 5, not an end of the diagonal 2-6: the pair's own triangles (tight)
        let mut f = LocalFallback {
            pricing_rounds: PRICING_ROUNDS,
            segment_rounds: SEGMENT_ROUNDS,
            tight: true,
            state: FallbackStart {
                flat_pairs: true,
                ..Default::default()
            },
            ..Default::default()
        };
        match f.next(&m, &m, &[bad([5, 6, 7, 2], 0)], &none, &[]) {
            Next::Split(t) => assert_eq!(t, HashSet::from([3, 4])),
            _ => panic!("a split round expected"),
        }
        assert!(f.state.pairs.is_empty());
    }

    #[test]
    fn a_bad_corner_that_is_not_a_fan_on_a_boundary_gets_no_segment() {
        let m = strip();
        // bad at the apex (node 2), not at the flat top node: no segment
        assert!(fan_segments(&m, &[bad([5, 6, 7, 2], 3)], &[]).is_empty());
        // not two triangles of the input (5-6-7-8 is no pair)
        assert!(fan_segments(&m, &[bad([5, 6, 7, 8], 1)], &[]).is_empty());
        // a pair of triangles, but not a fan: 1-2-5 and 2-6-5 (the corner at node 2
        // joins a bottom and a cross edge)
        assert!(fan_segments(&m, &[bad([1, 2, 6, 5], 1)], &[]).is_empty());
    }
}
