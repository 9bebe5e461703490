//! What "valid" means for the optimizer, and the per-surface gate that rolls back to the
//! last valid state.
//!
//! A quad is **valid** when its four nodes are distinct, every corner turns positively about
//! the reference normal (the plane's normal on planar surfaces, the sum of the nodes'
//! reference normals on curved ones, so a quad turned over scores invalid), no corner is
//! within [`VALID_ETA`] of straight or folded (corner angles strictly inside about
//! (0.06°, 179.94°): the tolerance keeps float-noise-positive straight corners out), no
//! edge is shorter than [`MIN_EDGE_REL`] times the target size at its ends, and, on curved
//! surfaces, every corner is in that range about the reference triangulation's normal at
//! each node of the quad it has too (at input nodes, the normals the gate measures corners
//! about), with [`Local::located_turns`] (the surface named in
//! `OptimizeOptions::located_surfaces`) the corner at a node the reference does not have
//! (split, duplicated and refined nodes) is in that range about the normal of every
//! reference triangle that a point inside the corner (a quarter of the way along its two
//! edges) touches where it now is (the faces the gate measures that corner about: on a
//! coarse curved face such a node can cross onto a face that turns far from the quad's
//! reference normal), and the quad holds to its own geometry: its scaled
//! Jacobian at every corner about its own normal (the cross product of its diagonals) is at
//! least [`MIN_OWN_SJ`] (the gate's rule of `crate::validity`, with a margin). On a planar
//! surface a quad whose corners all turn positively about the plane's normal is convex, so
//! its diagonals cross and its own normal is the plane's: the rule holds there by itself.
//!
//! Every operator accepts a change only if each quad it touches is valid afterwards, or was
//! already invalid before and is not made worse (quads the matching left invalid, e.g. a
//! single triangle pair at a sharp wall corner, which no node move can fix). On top of that,
//! [`Gate`] (`run_surface`) checks whole states: the optimizer may end with no invalid quad
//! other than those it was given; if it does, the surface goes back to its last checked
//! state that passed (the state after a stage), and in the end to the input itself.

use super::local::{same_bits, uniform_normal, Local};
pub(crate) use super::local::{VALID_ETA, VALID_KEY};
use glam::DVec3;
use rayon::prelude::*;

/// Shortest edge of a valid quad, relative to the mean target size of its two ends.
pub(crate) const MIN_EDGE_REL: f64 = 1e-3;

/// Smallest scaled Jacobian of a valid quad at a corner about its own normal (the cross
/// product of its diagonals), on curved surfaces: `sin(VALID_ETA · π/2)`, the sine of the
/// smallest corner angle [`VALID_ETA`] allows.
pub(crate) const MIN_OWN_SJ: f64 = 1.570_795_680_830_879e-3;

/// The reference normal of quad `q` for validity: the plane's on planar surfaces, else the
/// sum of its nodes' reference normals (not the quad's own normal, which turns over with it).
pub(crate) fn reference_normal(l: &Local, q: u32) -> DVec3 {
    let quad = &l.quads[q as usize];
    if l.planar {
        l.nrm[quad[0] as usize]
    } else {
        l.quad_normal(q)
    }
}

/// Largest |cot| of a valid corner: `1 / (1 + cot) >= VALID_KEY` written without a
/// division per corner.
const MAX_COT: f64 = 1.0 / VALID_KEY - 1.0;

/// True when the quad `nodes` at the current positions is valid about `normal` (module
/// docs): per corner, the sine about the unit normal is positive and |cot| at most
/// [`MAX_COT`]; every edge is longer than [`MIN_EDGE_REL`] times its ends' mean size; on a
/// curved surface every corner's scaled Jacobian about the quad's own normal is at least
/// [`MIN_OWN_SJ`]. Written with squared lengths and no division per corner (it runs on
/// every quad at every gate check); NaN anywhere fails.
pub(crate) fn quad_valid(l: &Local, nodes: &[u32; 4], normal: DVec3) -> bool {
    for i in 0..4 {
        for j in i + 1..4 {
            if nodes[i] == nodes[j] {
                return false;
            }
        }
    }
    let n_len = normal.length();
    if !(n_len > 0.0 && n_len.is_finite()) {
        return false;
    }
    let p = nodes.map(|v| l.pos[v as usize]);
    // edge k runs from corner k to corner k + 1
    let e = [p[1] - p[0], p[2] - p[1], p[3] - p[2], p[0] - p[3]];
    for k in 0..4 {
        let h = MIN_EDGE_REL * 0.5 * (l.h[nodes[k] as usize] + l.h[nodes[(k + 1) & 3] as usize]);
        let len2 = e[k].length_squared();
        if !(len2.is_finite() && len2 > h * h) {
            return false;
        }
    }
    for k in 0..4 {
        // corner k between the edge out (a) and the edge back (b)
        let (a, b) = (e[k], -e[(k + 3) & 3]);
        let c = a.cross(b);
        // n_len times the sine about the unit normal (times |a||b|)
        let s = normal.dot(c);
        let cos = a.dot(b).abs();
        // NaN fails too
        if !(s > 0.0 && cos * n_len <= MAX_COT * s) {
            return false;
        }
        // the reference triangulation's normals at the quad's nodes (the gate's at input
        // nodes)
        if !l.gate_nrm.is_empty() && !turns_about_gate_normals(l, nodes, cos, c) {
            return false;
        }
        // at a node the reference does not have, the normals of the reference triangles
        // that a point inside the corner touches (the gate's nearest faces there)
        if located(l, nodes[k]) && !turns_about_located(l, nodes[k], inside(p[k], a, b), cos, c)
        {
            return false;
        }
    }
    l.planar || own_jacobian_ok(&p)
}

/// True when the optimizer holds the corner at node `v` to the reference triangles a point
/// inside it touches ([`Local::located_turns`]): the validity gate measures it about the
/// input faces nearest to that point ([`located_normals`]); a curved surface with reference
/// triangles, and a node the reference does not have (a split node, a duplicated vertex, a
/// node of a fallback split or of a refinement), whose [`Local::gate_nrm`] is zero.
pub(crate) fn located(l: &Local, v: u32) -> bool {
    l.located_turns && l.reference.is_some() && l.gate_nrm.get(v as usize) == Some(&DVec3::ZERO)
}

/// The point inside the corner at `p` with edges `a` and `b` (to its two neighbours), a
/// quarter of the way along both, where the validity gate measures a corner at a node the
/// input does not have (the faces the quad lies on there).
fn inside(p: DVec3, a: DVec3, b: DVec3) -> DVec3 {
    p + 0.25 * (a + b)
}

/// True when the corner `c` = a × b (`cos` = |a · b|) is inside the valid range (sine
/// positive, |cot| at most [`MAX_COT`]) about the unit normal of every reference triangle
/// that point `p` near node `v` touches
/// ([`TriSurface::touching`](crate::quality::locate::TriSurface::touching) within
/// [`Local::tie`], from the triangle a walk from `v`'s finds): the faces the validity gate
/// sums the normal of a node it has no input normal at from. A corner that turns positively
/// about each of them turns positively about any positive sum of them. True without a
/// reference.
pub(crate) fn turns_about_located(l: &Local, v: u32, p: DVec3, cos: f64, c: DVec3) -> bool {
    thread_local! {
        // the touched triangles, kept between calls: this runs for every located corner of
        // every candidate move
        static TOUCHED: std::cell::RefCell<Vec<u32>> = const { std::cell::RefCell::new(Vec::new()) };
    }
    let Some(r) = l.reference.as_deref() else {
        return true;
    };
    let Some(hit) = r.walk(l.tri[v as usize], p) else {
        return true;
    };
    TOUCHED.with_borrow_mut(|tris| {
        tris.clear();
        r.touching(hit.tri, hit.point, l.tie, tris);
        tris.iter().all(|&t| {
            let n = r.normal(t);
            n == DVec3::ZERO || {
                let s = n.dot(c);
                s > 0.0 && cos <= MAX_COT * s
            }
        })
    })
}

/// True when the corners of `quad` at located nodes ([`located`]) turn positively about the
/// faces a point inside each touches ([`turns_about_located`]) with its node `v` at `x`.
/// With `moved_only`, the corner opposite `v` is left out: it does not depend on where `v`
/// is.
fn located_corners_ok(l: &Local, quad: &[u32; 4], v: u32, x: DVec3, moved_only: bool) -> bool {
    let pts = quad.map(|w| if w == v { x } else { l.pos[w as usize] });
    let opposite = quad.iter().position(|&w| w == v).map(|i| (i + 2) & 3);
    (0..4).all(|k| {
        if !located(l, quad[k]) || (moved_only && opposite == Some(k)) {
            return true;
        }
        let (a, b) = (pts[(k + 1) & 3] - pts[k], pts[(k + 3) & 3] - pts[k]);
        turns_about_located(l, quad[k], inside(pts[k], a, b), a.dot(b).abs(), a.cross(b))
    })
}

/// True when the corner between edges `a` and `b` (`cos` = |a · b|, `c` = a × b) is inside
/// the valid range (sine positive, |cot| at most [`MAX_COT`]) about the reference
/// triangulation's normal at every node of `nodes` that has one ([`Local::gate_nrm`]): the validity gate measures
/// each corner about those normals at input nodes, and on a coarse curved face they can
/// turn away from the quad's reference normal.
fn turns_about_gate_normals(l: &Local, nodes: &[u32; 4], cos: f64, c: DVec3) -> bool {
    nodes.iter().all(|&v| {
        let n = l.gate_nrm[v as usize];
        if n == DVec3::ZERO {
            return true;
        }
        let s = n.dot(c);
        s > 0.0 && cos <= MAX_COT * s
    })
}

/// True when the quad `p` has a scaled Jacobian of at least [`MIN_OWN_SJ`] at every corner
/// about its own normal (the cross product of its diagonals). Squared, without a division
/// or a square root; NaN fails.
pub(crate) fn own_jacobian_ok(p: &[DVec3; 4]) -> bool {
    let own = (p[2] - p[0]).cross(p[3] - p[1]);
    let own2 = own.length_squared();
    (0..4).all(|k| {
        let (a, b) = (p[(k + 1) & 3] - p[k], p[(k + 3) & 3] - p[k]);
        let s = own.dot(a.cross(b));
        let floor2 = MIN_OWN_SJ * MIN_OWN_SJ * own2 * a.length_squared() * b.length_squared();
        s > 0.0 && s * s >= floor2
    })
}

/// A rule a move of one node keeps on the quads of its star that pass it at the start
/// position ([`StarHold`]). The smoothing sweeps' keys measure corners about the reference
/// normal only and see neither.
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
pub(crate) enum Rule {
    /// [`own_jacobian_ok`]: no quad folds about its own normal (the cross product of its
    /// diagonals), which would cost the whole stage at the [`Gate`]. Nothing to hold on a
    /// planar surface, where the rule holds by itself.
    OwnJacobian,
    /// The corners at located nodes ([`located`]) turn positively about the faces a point
    /// inside each touches ([`turns_about_located`]): on a coarse curved face such a node
    /// can cross onto a face whose normal turns away from the quad's.
    LocatedTurns,
}

impl Rule {
    /// True when quad `q` passes the rule with its node `v` at `x`; `moved_only` leaves out
    /// what does not depend on where `v` is (for a quad known to pass with `v` elsewhere).
    fn passes(self, l: &Local, q: u32, v: u32, x: DVec3, moved_only: bool) -> bool {
        match self {
            Rule::OwnJacobian => own_jacobian_ok(&moved(l, q, v, x)),
            Rule::LocatedTurns => located_corners_ok(l, &l.quads[q as usize], v, x, moved_only),
        }
    }

    /// False when the rule cannot fail on `v`'s star.
    fn applies(self, l: &Local, v: u32) -> bool {
        match self {
            Rule::OwnJacobian => !l.planar,
            Rule::LocatedTurns => {
                l.located_turns
                    && l.star(v)
                        .iter()
                        .any(|&q| l.quads[q as usize].iter().any(|&w| located(l, w)))
            }
        }
    }
}

/// Which quads of node `v`'s star pass a [`Rule`] with `v` at its start position `x0`, found
/// once for all the candidate positions of one move (the smoothing sweeps try up to 32): a
/// move keeps those passing ([`StarHold::keeps`]) and may leave the others as they are.
pub(crate) struct StarHold {
    rule: Rule,
    /// Bit `i`: star quad `i` passes at `x0` (stars of up to 64 quads).
    held: u64,
    /// The star has more than 64 quads: each candidate checks `x0` again.
    wide: bool,
    v: u32,
    x0: DVec3,
}

impl StarHold {
    /// The star quads of `v` that pass `rule` at `x0` (none held where it cannot fail).
    pub(crate) fn at(l: &Local, v: u32, x0: DVec3, rule: Rule) -> Self {
        let star = l.star(v);
        let applies = rule.applies(l, v);
        let wide = applies && star.len() > 64;
        let mut held = 0u64;
        if applies && !wide {
            for (i, &q) in star.iter().enumerate() {
                if rule.passes(l, q, v, x0, false) {
                    held |= 1 << i;
                }
            }
        }
        StarHold {
            rule,
            held,
            wide,
            v,
            x0,
        }
    }

    /// True when every star quad that passed at the start position passes with the node at
    /// `p`.
    pub(crate) fn keeps(&self, l: &Local, p: DVec3) -> bool {
        let (star, v, rule) = (l.star(self.v), self.v, self.rule);
        if self.wide {
            return star
                .iter()
                .all(|&q| !rule.passes(l, q, v, self.x0, false) || rule.passes(l, q, v, p, true));
        }
        let mut held = self.held;
        while held != 0 {
            let i = held.trailing_zeros() as usize;
            held &= held - 1;
            if !rule.passes(l, star[i], v, p, true) {
                return false;
            }
        }
        true
    }
}

/// The [`Rule`]s a smoothing move of node `v` from `x0` keeps, each found at the start
/// position on first use.
pub(crate) struct Holds<'a> {
    l: &'a Local,
    v: u32,
    x0: DVec3,
    own: std::cell::OnceCell<StarHold>,
    located: std::cell::OnceCell<StarHold>,
}

impl<'a> Holds<'a> {
    pub(crate) fn new(l: &'a Local, v: u32, x0: DVec3) -> Self {
        Holds {
            l,
            v,
            x0,
            own: std::cell::OnceCell::new(),
            located: std::cell::OnceCell::new(),
        }
    }

    /// True when the move to `p` keeps both rules ([`Rule::OwnJacobian`] checked first).
    pub(crate) fn keeps(&self, p: DVec3) -> bool {
        self.hold(&self.own, Rule::OwnJacobian).keeps(self.l, p) && self.keeps_located(p)
    }

    /// True when the move to `p` keeps [`Rule::LocatedTurns`].
    pub(crate) fn keeps_located(&self, p: DVec3) -> bool {
        self.hold(&self.located, Rule::LocatedTurns).keeps(self.l, p)
    }

    fn hold<'c>(&self, cell: &'c std::cell::OnceCell<StarHold>, rule: Rule) -> &'c StarHold {
        cell.get_or_init(|| StarHold::at(self.l, self.v, self.x0, rule))
    }
}

/// The corners of quad `q` with its node `v` at `x`.
fn moved(l: &Local, q: u32, v: u32, x: DVec3) -> [DVec3; 4] {
    l.quads[q as usize].map(|w| if w == v { x } else { l.pos[w as usize] })
}

/// True when alive quad `q` is valid (module docs). It depends only on the quad's nodes and
/// their positions, normals and target sizes, and on whether the surface is planar
/// ([`Gate`] relies on this).
pub(crate) fn valid(l: &Local, q: u32) -> bool {
    quad_valid(l, &l.quads[q as usize], reference_normal(l, q))
}

/// The alive quads that are not valid, by increasing index.
pub(crate) fn invalid_quads(l: &Local) -> Vec<u32> {
    (0..l.quads.len() as u32)
        .into_par_iter()
        .with_min_len(4096)
        .filter(|&q| l.alive[q as usize] && !valid(l, q))
        .collect()
}

/// The alive quads of `l` that are not alive in `base` with the same nodes, or that have a
/// node whose position or normal differs (bit for bit) from `base`'s, by increasing index.
fn changed_quads(l: &Local, base: &State) -> Vec<u32> {
    let moved: Vec<bool> = (0..l.pos.len())
        .into_par_iter()
        .with_min_len(8192)
        .map(|v| {
            base.pos.get(v).is_none_or(|&p| !same_bits(p, l.pos[v]))
                || base.nrm.get(v).is_none_or(|n| !same_bits(n, l.nrm[v]))
        })
        .collect();
    (0..l.quads.len() as u32)
        .into_par_iter()
        .with_min_len(4096)
        .filter(|&q| {
            let i = q as usize;
            l.alive[i]
                && (base.alive.get(i) != Some(&true)
                    || base.quads.get(i) != Some(&l.quads[i])
                    || l.quads[i].iter().any(|&v| moved[v as usize]))
        })
        .collect()
}

/// One surface's nodes and quads at a moment, to roll back to.
#[derive(Clone)]
struct State {
    pos: Vec<DVec3>,
    nrm: Normals,
    tri: Vec<u32>,
    removed: Vec<bool>,
    quads: Vec<[u32; 4]>,
    alive: Vec<bool>,
}

/// A state's node normals. Memory: one vector when every node has the same (bit for bit,
/// as on a planar surface), else one per node.
#[derive(Clone)]
enum Normals {
    /// Every one of `len` nodes has this normal.
    Uniform(DVec3, usize),
    Each(Vec<DVec3>),
}

impl Normals {
    fn of(nrm: &[DVec3]) -> Self {
        match uniform_normal(nrm) {
            Some(n) => Normals::Uniform(n, nrm.len()),
            None => Normals::Each(nrm.to_vec()),
        }
    }

    /// Makes these the normals of `nrm`, reusing the buffer when they are not uniform.
    fn store(&mut self, nrm: &[DVec3]) {
        match (uniform_normal(nrm), &mut *self) {
            (Some(n), _) => *self = Normals::Uniform(n, nrm.len()),
            (None, Normals::Each(v)) => {
                v.clear();
                v.extend_from_slice(nrm);
            }
            (None, Normals::Uniform(..)) => *self = Normals::Each(nrm.to_vec()),
        }
    }

    /// Node `v`'s normal, if the state has node `v`.
    fn get(&self, v: usize) -> Option<DVec3> {
        match self {
            Normals::Uniform(n, len) => (v < *len).then_some(*n),
            Normals::Each(e) => e.get(v).copied(),
        }
    }

    /// Puts these normals into `out`.
    fn restore(&self, out: &mut Vec<DVec3>) {
        match self {
            Normals::Uniform(n, len) => {
                out.clear();
                out.resize(*len, *n);
            }
            Normals::Each(e) => out.clone_from(e),
        }
    }
}

impl State {
    fn of(l: &Local) -> Self {
        State {
            pos: l.pos.clone(),
            nrm: Normals::of(&l.nrm),
            tri: l.tri.clone(),
            removed: l.removed.clone(),
            quads: l.quads.clone(),
            alive: l.alive.clone(),
        }
    }

    /// Makes this state `l`'s, reusing its buffers (no new allocation at a later check).
    fn store(&mut self, l: &Local) {
        self.pos.clone_from(&l.pos);
        self.nrm.store(&l.nrm);
        self.tri.clone_from(&l.tri);
        self.removed.clone_from(&l.removed);
        self.quads.clone_from(&l.quads);
        self.alive.clone_from(&l.alive);
    }

    /// Puts `l` into this state (copied into `l`'s buffers).
    fn restore(&self, l: &mut Local) {
        l.pos.clone_from(&self.pos);
        self.nrm.restore(&mut l.nrm);
        l.tri.clone_from(&self.tri);
        l.removed.clone_from(&self.removed);
        l.quads.clone_from(&self.quads);
        l.alive.clone_from(&self.alive);
        l.build_adjacency();
    }
}

/// The validity gate of one surface (module docs): the quads invalid at the start (sorted
/// node lists: the optimizer may keep them, not create others), the start state and the
/// last state that passed [`Gate::check`].
#[derive(Clone)]
pub(crate) struct Gate {
    inherited: Vec<[u32; 4]>,
    start: Option<State>,
    last: Option<State>,
    /// Checks that failed (states rolled back).
    pub rollbacks: usize,
}

fn sorted(q: [u32; 4]) -> [u32; 4] {
    let mut s = q;
    s.sort_unstable();
    s
}

impl Gate {
    /// Records the start state of `l` and its invalid quads.
    pub fn new(l: &Local) -> Self {
        let mut inherited: Vec<[u32; 4]> = invalid_quads(l)
            .into_iter()
            .map(|q| sorted(l.quads[q as usize]))
            .collect();
        inherited.sort_unstable();
        Gate {
            inherited,
            start: Some(State::of(l)),
            last: None,
            rollbacks: 0,
        }
    }

    /// The invalid quads of `l` that the start did not have (as the same node set).
    ///
    /// Speed: only the quads that differ from the last state that passed (or the start)
    /// are checked. That state had no such quad, and whether a quad is valid depends on its
    /// nodes' positions, normals and sizes alone ([`valid`]; the sizes never change), so a
    /// quad alive there with the same nodes, none of which moved or turned, is not one now.
    pub fn new_invalid(&self, l: &Local) -> Vec<u32> {
        let candidates = match self.last.as_ref().or(self.start.as_ref()) {
            Some(base) => changed_quads(l, base),
            None => (0..l.quads.len() as u32).collect(),
        };
        candidates
            .into_par_iter()
            .with_min_len(4096)
            .filter(|&q| {
                !valid(l, q)
                    && self
                        .inherited
                        .binary_search(&sorted(l.quads[q as usize]))
                        .is_err()
            })
            .collect()
    }

    /// Checks `l` after a stage: a state that passes becomes the one to roll back to
    /// (`keep`: store a copy, else only note it); one that fails is replaced by the last
    /// one that passed (or the start). Returns true when `l` passed.
    /// `stage` names the stage in the [`Rollback`](crate::profile::TraceEvent::Rollback)
    /// event sent to the surface's trace sink, if any.
    pub fn check(&mut self, l: &mut Local, keep: bool, stage: &str) -> bool {
        let bad = self.new_invalid(l);
        if bad.is_empty() {
            if keep {
                // the start is needed only until a later state passed (speed: its buffers
                // hold the later states)
                match (&mut self.last, self.start.take()) {
                    (Some(last), _) => last.store(l),
                    (None, Some(mut start)) => {
                        start.store(l);
                        self.last = Some(start);
                    }
                    (None, None) => self.last = Some(State::of(l)),
                }
            }
            return true;
        }
        if let Some(trace) = &l.trace {
            let quads: Vec<[u64; 4]> = bad
                .iter()
                .take(4)
                .map(|&q| l.quads[q as usize].map(|v| l.tags[v as usize]))
                .collect();
            trace.emit(&crate::profile::TraceEvent::Rollback {
                surface: l.surface,
                stage,
                count: bad.len(),
                quads: &quads,
            });
        }
        self.rollbacks += 1;
        self.roll_back(l);
        false
    }

    /// Puts `l` back into the last state that passed (the start if none).
    pub fn roll_back(&mut self, l: &mut Local) {
        if let Some(s) = self.last.as_ref().or(self.start.as_ref()) {
            s.restore(l);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::optimize::cleanup::tests::local_of;
    use crate::optimize::synth;

    /// A 4 × 4 grid of unit squares and its centre node (free).
    fn grid() -> (Local, u32) {
        let s = synth::quad_grid(4, 4, 4.0, 4.0);
        let (_, l) = local_of(&synth::to_mesh(&s));
        let v = (0..l.pos.len() as u32)
            .find(|&v| l.pos[v as usize].distance(DVec3::new(2.0, 2.0, 0.0)) < 1e-12)
            .expect("centre node");
        assert!(!l.fixed[v as usize]);
        (l, v)
    }

    #[test]
    fn straight_folded_and_collapsed_quads_are_invalid() {
        let (mut l, v) = grid();
        assert!(invalid_quads(&l).is_empty());
        // onto the edge between two neighbours: two quads get a corner of 180° up to
        // float noise, which a bare `η > 0` test lets through
        let c = l.pos[v as usize];
        l.pos[v as usize] = DVec3::new(2.0, 1.0 + 1e-13, 0.0).lerp(c, 1e-9);
        assert!(!invalid_quads(&l).is_empty());
        // past it: folded
        l.pos[v as usize] = DVec3::new(2.0, 0.5, 0.0);
        assert!(!invalid_quads(&l).is_empty());
        // onto a neighbour: an edge of length 0
        l.pos[v as usize] = DVec3::new(2.0, 1.0, 0.0);
        assert!(!invalid_quads(&l).is_empty());
        // a small move keeps every quad valid
        l.pos[v as usize] = c + DVec3::new(0.2, -0.1, 0.0);
        assert!(invalid_quads(&l).is_empty());
    }

    #[test]
    fn a_quad_folded_about_its_own_normal_is_invalid_on_a_curved_surface() {
        // every corner turns positively about the reference normal (+z), but the quad is
        // bent so far that about its own normal (the cross product of its diagonals) one
        // corner folds: invalid on a curved surface, where the rule is checked
        let (mut l, _) = grid();
        let q = 0u32;
        let bent = [
            [-0.08, 0.16, -1.61],
            [0.99, -0.15, 0.18],
            [1.1, 1.17, -1.52],
            [0.09, 0.8, -0.78],
        ];
        let nodes = l.quads[q as usize];
        // the grid's quads may start at any corner: keep the cyclic order
        for (k, &v) in nodes.iter().enumerate() {
            l.pos[v as usize] = DVec3::from_array(bent[k]);
        }
        let p = nodes.map(|v| l.pos[v as usize]);
        assert!(crate::quality::view::quad4_scaled_jacobian(&p) < -0.1);
        l.planar = true;
        assert!(valid(&l, q), "valid about the plane's normal alone");
        l.planar = false;
        assert!(!valid(&l, q));
        // a milder bend of the same quad is valid
        for (k, &v) in nodes.iter().enumerate() {
            let [x, y, z] = bent[k];
            l.pos[v as usize] = DVec3::new(x, y, 0.2 * z);
        }
        assert!(valid(&l, q));
    }

    #[test]
    fn a_corner_must_turn_about_the_input_normal_at_each_node_it_has() {
        // a unit square in z = 0, valid about its reference normal (+z): with the input
        // surface's normal at one of its nodes tilted past 90° from +z about an axis in
        // the plane, every corner turns the wrong way about that normal, so the quad is
        // not valid (the validity gate would refuse it); a normal tilted less, or at a node
        // the input does not have (zero), leaves it valid
        let (mut l, _) = grid();
        l.planar = false;
        let q = 0u32;
        let v = l.quads[q as usize][1] as usize;
        assert!(valid(&l, q));
        l.gate_nrm = vec![DVec3::ZERO; l.pos.len()];
        assert!(valid(&l, q), "no input normal: the reference normal alone");
        let tilted = |deg: f64| {
            let a = deg.to_radians();
            DVec3::new(a.sin(), 0.0, a.cos())
        };
        l.gate_nrm[v] = tilted(60.0);
        assert!(valid(&l, q));
        l.gate_nrm[v] = tilted(100.0);
        assert!(!valid(&l, q));
        // on a planar surface the plane's normal is the input's everywhere: not stored
        l.gate_nrm.clear();
        assert!(valid(&l, q));
    }

    #[test]
    fn a_corner_at_a_node_the_input_lacks_must_turn_about_the_faces_it_touches() {
        // a unit square in z = 0, valid about its reference normal (+z) and the input
        // normals (+z) at three of its nodes; its fourth node is one the input does not
        // have, lying on a reference face tilted from +z about an axis in the plane: the
        // validity gate measures the corner there about that face's normal, so the quad is
        // valid while the face turns less than 90°, and not past it
        let (mut l, _) = grid();
        l.planar = false;
        let q = 0u32;
        let v = l.quads[q as usize][1];
        let up = DVec3::Z;
        l.gate_nrm = vec![up; l.pos.len()];
        l.gate_nrm[v as usize] = DVec3::ZERO;
        let c = l.pos[v as usize];
        let face = |deg: f64| {
            let a = deg.to_radians();
            let (t1, t2) = (DVec3::new(a.cos(), 0.0, -a.sin()), DVec3::Y);
            let pts = vec![c - 100.0 * (t1 + t2), c + 100.0 * (t1 - t2), c + 100.0 * t2];
            std::sync::Arc::new(crate::quality::locate::TriSurface::new(pts, vec![[0, 1, 2]]))
        };
        l.tri[v as usize] = 0;
        l.reference = Some(face(100.0));
        assert!(!located(&l, v) && valid(&l, q), "the rule is off by default");
        l.located_turns = true;
        l.reference = Some(face(60.0));
        assert!(located(&l, v));
        assert!(valid(&l, q));
        l.reference = Some(face(100.0));
        assert!(!valid(&l, q));
        // a move of a neighbouring node keeps a quad that was valid so
        let w = l.quads[q as usize][0];
        let x0 = l.pos[w as usize];
        l.reference = Some(face(60.0));
        let hold = StarHold::at(&l, w, x0, Rule::LocatedTurns);
        assert!(hold.keeps(&l, x0 + DVec3::new(0.05, 0.05, 0.0)));
        // the same node with an input normal: measured about that one alone
        l.reference = Some(face(100.0));
        l.gate_nrm[v as usize] = up;
        assert!(!located(&l, v));
        assert!(valid(&l, q));
    }

    #[test]
    fn the_own_jacobian_floor_is_the_sine_of_the_valid_eta() {
        let s = (VALID_ETA * std::f64::consts::FRAC_PI_2).sin();
        assert!((s - MIN_OWN_SJ).abs() < 1e-15, "{s}");
    }

    #[test]
    fn the_gate_rolls_back_to_the_last_state_that_passed() {
        let (mut l, v) = grid();
        let mut gate = Gate::new(&l);
        let start = l.pos[v as usize];
        // a stage that moves the node a little: passes, and becomes the state to keep
        let moved = start + DVec3::new(0.1, 0.05, 0.0);
        l.pos[v as usize] = moved;
        assert!(gate.check(&mut l, true, "test"));
        // a stage that folds two quads: rolled back to the moved state
        l.pos[v as usize] = DVec3::new(2.0, 0.5, 0.0);
        assert!(!gate.check(&mut l, true, "test"));
        assert_eq!(l.pos[v as usize], moved);
        assert_eq!(gate.rollbacks, 1);
        // a quad removed by a stage that left an invalid one comes back too
        let quads = l.quads.clone();
        l.alive[0] = false;
        l.pos[v as usize] = DVec3::new(2.0, 0.5, 0.0);
        assert!(!gate.check(&mut l, false, "test"));
        assert!(l.alive[0] && l.quads == quads);
    }

    #[test]
    fn the_gate_gives_back_normals_that_differ_from_node_to_node_and_equal_ones() {
        // a state's normals are stored once when all are equal, else one per node: either
        // comes back bit for bit, and a gate can go from one kind to the other
        let (mut l, v) = grid();
        let up = l.nrm[0];
        let mut gate = Gate::new(&l);
        // one node's normal tilted a little: every quad stays valid, the state passes
        let tilted = (up + DVec3::new(0.01, 0.0, 0.0)).normalize();
        l.nrm[v as usize] = tilted;
        assert!(gate.check(&mut l, true, "test"));
        let kept = l.nrm.clone();
        // a stage that folds quads and levels the normals: rolled back to the tilted ones
        l.nrm.fill(up);
        l.pos[v as usize] = DVec3::new(2.0, 0.5, 0.0);
        assert!(!gate.check(&mut l, true, "test"));
        assert_eq!(l.nrm, kept);
        assert_eq!(l.nrm.len(), l.pos.len());
        // level again without folding: passes and becomes the state to keep
        l.nrm.fill(up);
        assert!(gate.check(&mut l, true, "test"));
        l.pos[v as usize] = DVec3::new(2.0, 0.5, 0.0);
        l.nrm[v as usize] = tilted;
        assert!(!gate.check(&mut l, true, "test"));
        assert!(l.nrm.iter().all(|&n| n == up));
        assert_eq!(l.nrm.len(), l.pos.len());
    }

    #[test]
    fn the_gate_sees_quads_turned_over_by_their_normals_alone() {
        // the gate re-checks only quads that changed since the last state that passed: a
        // change of the node normals (no node moved) is a change
        let (mut l, _) = grid();
        let mut gate = Gate::new(&l);
        assert!(gate.check(&mut l, true, "test"));
        let up = l.nrm.clone();
        for n in &mut l.nrm {
            *n = -*n;
        }
        assert!(!gate.new_invalid(&l).is_empty());
        assert!(!gate.check(&mut l, true, "test"));
        assert_eq!(l.nrm, up);
    }

    #[test]
    fn quads_invalid_at_the_start_are_inherited_not_new() {
        let (mut l, v) = grid();
        l.pos[v as usize] = DVec3::new(2.0, 0.5, 0.0);
        let bad = invalid_quads(&l);
        assert!(!bad.is_empty());
        let mut gate = Gate::new(&l);
        assert!(gate.new_invalid(&l).is_empty());
        assert!(gate.check(&mut l, true, "test"));
    }

    #[test]
    fn the_valid_key_is_the_key_of_the_valid_eta() {
        let cot = ((1.0 - VALID_ETA) * std::f64::consts::FRAC_PI_2).tan();
        let key = 1.0 / (1.0 + cot);
        assert!((key - VALID_KEY).abs() < 1e-15, "{key}");
        assert!((super::super::local::key_to_eta(VALID_KEY) - VALID_ETA).abs() < 1e-12);
    }
}
