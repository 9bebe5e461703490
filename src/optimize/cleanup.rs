//! Valence cleanup: sequences of edge rotations (the quad *edge swap*) that lower the valence
//! defect of the mesh, found by a bounded depth-first search.
//!
//! The irregular vertices Blossom-Quad leaves on an unstructured triangulation come almost
//! all as *3-5 pairs* (a valence-3 node next to a valence-5 node), the quad analogue of a
//! lattice dislocation. One edge rotation moves such a pair without changing the defect energy
//! E = Σ_v (d_v − d*_v)² (d* = 4 inside, on fixed nodes the boundary angle in right angles,
//! see [`ideal_valence`]); two pairs that meet cancel. A greedy single rotation therefore
//! never removes them, but a short sequence does: [`cleanup`] looks, from every interior edge
//! near a defect, for a sequence of at most `depth` rotations, each one on an edge of the
//! quads the previous one created, whose total lowers E while every prefix keeps it (the
//! intermediate steps are pure moves of a defect: allowing prefixes that raise E by 2 finds
//! no more on the fixtures at 2.5 times the cost), and applies the first it finds
//! (first-improvement local search, in the spirit of the quad cleanup literature: Kinney's
//! edge swaps, the "3-5 pair" moves of Verma & Tautges). E drops by at least 1 per applied
//! sequence, so the search ends.
//!
//! Besides E, a fixed node left with a corner wider than [`MAX_FIXED_CORNER`] (e.g. a
//! boundary node on a straight wall with a single quad, a straight corner no smoothing can
//! open), or given an extra quad with corners narrower than [`MIN_FIXED_CORNER`], costs
//! [`WIDE_CORNER_PENALTY`]: the search removes such corners (they set η_w) and creates one
//! only in a sequence that lowers E by more than the penalty. From a quad with a node whose
//! corners are that wide, the search goes deeper ([`WIDE_DEPTH`] rotations) and its
//! prefixes may raise the energy by up to [`WIDE_FLOOR`] (the whole sequence must still
//! lower it): the first rotations make room for the quad the wide corner needs. A quad with
//! three free corners of valence 3 ([`CROWDED`]) sets η_w too (about 0.57 after every
//! polish) and gets the same depth, with prefixes up to [`CROWDED_FLOOR`] above E.
//!
//! The quads a sequence rewrites must be valid (signed η above [`MIN_ETA`]) at the current
//! node positions; if some are not, the free nodes of those are moved to the centroid of
//! their new ring and every rewritten quad and every quad around a moved node must then
//! reach [`RELOCATED_MIN_ETA`] (else the sequence is undone). The new edge must not join
//! two nodes that already share a quad, and an edge between two fixed nodes (possibly an
//! embedded curve) never rotates. Quads are rewritten from the oriented hexagon of the two
//! quads they replace, so orientation is kept; fixed nodes never move, and no node or quad
//! appears or disappears.
//!
//! Cost: O(1) per candidate sequence (at most (2·7)^depth of them per start edge, depth 3
//! only from the few quads at a wide corner), one sweep over the edges per round, so O(n)
//! per round for a fixed depth.

use super::local::{slot, Local, NONE};
use super::valid;
use glam::DVec3;
use rayon::prelude::*;
use std::f64::consts::FRAC_PI_2;

/// Widest acceptable corner at a fixed node (radians), 150°: wider corners cannot be opened
/// by smoothing since the node never moves.
pub(crate) const MAX_FIXED_CORNER: f64 = 150.0 / 180.0 * std::f64::consts::PI;

/// Narrowest corner at a fixed node a rotation may create by adding a quad there (radians),
/// 65°: a straight wall node with three quads (60° corners) cannot reach η 0.7.
pub(crate) const MIN_FIXED_CORNER: f64 = 65.0 / 180.0 * std::f64::consts::PI;

/// Smallest signed η of the quads a rotation sequence rewrote, after moving the free nodes
/// of invalid ones to their ring's centroid (a worse quad would survive smoothing).
const RELOCATED_MIN_ETA: f64 = 0.2;

/// Quad rings around the focus within which [`Topo::near`] builds the quad neighbours: a
/// search from a focus quad rewrites quads within 3 rings of the focus (depth 2; 4 for the
/// [`WIDE_DEPTH`] searches from a wide corner) and walks the fans of their nodes; one more
/// ring for those fans.
pub(crate) const REACH_RINGS: usize = WIDE_DEPTH + 2;

/// Longest rotation sequence searched from a quad with a node of [`Topo::wide_corner`]: one
/// more than elsewhere, which together with [`WIDE_FLOOR`] lifts the worst quad next to
/// wide corners (figures in BENCHMARKS.md, "Measurements behind the defaults").
const WIDE_DEPTH: usize = 3;

/// How much the prefixes of a sequence searched from a wide corner may raise the energy:
/// one narrow corner ([`WIDE_CORNER_PENALTY`]) and a few valence defects. A straight wall
/// node whose single quad has both its wall edges has neighbours on the wall with two quads
/// each; rotating an edge towards it takes a quad from such a neighbour (a straight corner
/// there), so the sequence must first give that neighbour a third quad (narrow corners).
const WIDE_FLOOR: i32 = WIDE_CORNER_PENALTY + 4;

/// A quad with this many free corners of valence 3 (their corners want 120°, so the fourth
/// is pressed towards 0° or the quad towards a triangle: η about 0.57 at best after
/// smoothing) is searched like a wide corner's: [`WIDE_DEPTH`] rotations, prefixes up to
/// [`CROWDED_FLOOR`] above the energy (figures in BENCHMARKS.md, "Measurements behind the
/// defaults").
const CROWDED: usize = 3;

/// How much the prefixes of a sequence searched from a [`CROWDED`] quad may raise the
/// energy: one defect pair moved next to another before they cancel.
const CROWDED_FLOOR: i32 = 2;

/// Energy of a fixed node whose corners would be wider than [`MAX_FIXED_CORNER`].
const WIDE_CORNER_PENALTY: i32 = 16;

/// Smallest signed η (eq. 3) of a quad created by a rotation, before smoothing (and the
/// quad must be valid, see [`valid`](super::valid): with 0 here, straight corners of
/// float-noise-positive η were kept).
const MIN_ETA: f64 = valid::VALID_ETA;

/// Boundary angle of every node (sum of its quads' corner angles; 2π inside) and its ideal
/// valence: 4 for free nodes; for fixed nodes the angle in right angles, rounded, at least 1.
pub(crate) fn ideal_valence(l: &Local) -> (Vec<i32>, Vec<f64>) {
    let mut angle = vec![0.0; l.pos.len()];
    for (q, quad) in l.quads.iter().enumerate() {
        if !l.alive[q] {
            continue;
        }
        for k in 0..4 {
            let v = quad[k] as usize;
            if !l.fixed[v] {
                continue;
            }
            let p = l.pos[v];
            let a = l.pos[quad[(k + 1) % 4] as usize] - p;
            let b = l.pos[quad[(k + 3) % 4] as usize] - p;
            angle[v] += a.angle_between(b);
        }
    }
    let ideal = (0..l.pos.len())
        .map(|v| {
            if l.fixed[v] {
                ((angle[v] / FRAC_PI_2).round() as i32).max(1)
            } else {
                4
            }
        })
        .collect();
    (ideal, angle)
}

/// One logged change, to undo a tentative rotation.
enum Saved {
    /// A quad's nodes and neighbours before it was rewritten.
    Quad {
        q: u32,
        nodes: [u32; 4],
        nb: [u32; 4],
    },
    /// A node's position and reference triangle before it was moved.
    Node { v: u32, pos: DVec3, tri: u32 },
}

/// Dynamic quad-to-quad adjacency of one surface for the search.
struct Topo<'a> {
    l: &'a mut Local,
    /// `nb[q][k]`: the quad across edge `quads[q][k] → quads[q][k+1]`, or [`NONE`].
    nb: Vec<[u32; 4]>,
    /// Number of alive quads around each node.
    val: Vec<i32>,
    /// Ideal valence per node.
    ideal: Vec<i32>,
    /// Boundary angle per fixed node.
    angle: Vec<f64>,
    /// One quad around each node.
    corner: Vec<u32>,
    /// Nodes around which the quad fan cannot be walked (non-manifold): never touched.
    unsafe_node: Vec<bool>,
    /// Undo log of the current tentative sequence.
    log: Vec<Saved>,
}

impl<'a> Topo<'a> {
    #[cfg(test)]
    fn new(l: &'a mut Local) -> Self {
        Self::near(l, None)
    }

    /// [`Topo::new`] for a search that only starts from quads with a node in `focus`: the
    /// quad neighbours and manifold checks are computed only for the quads with a node
    /// within [`REACH_RINGS`] quad rings of it (all a search of depth ≤ 3 reads), the rest
    /// is left unknown ([`NONE`] neighbours).
    fn near(l: &'a mut Local, focus: Option<&[bool]>) -> Self {
        l.build_adjacency();
        let n = l.pos.len();
        let (ideal, angle) = ideal_valence(l);
        let region = focus.map(|f| {
            let mut mark: Vec<bool> = (0..n).map(|v| f.get(v) == Some(&true)).collect();
            super::local::grow_rings(l, &mut mark, REACH_RINGS);
            mark
        });
        let in_region = |v: u32| region.as_ref().is_none_or(|r| r[v as usize]);
        // per quad (in parallel, read-only): the neighbour across each edge, and which edges
        // are not manifold (a second quad running a -> b, or several running b -> a)
        let lr: &Local = l;
        let rows: Vec<([u32; 4], u8)> = (0..lr.quads.len())
            .into_par_iter()
            .with_min_len(4096)
            .map(|q| {
                let mut nbq = [NONE; 4];
                let mut bad = 0u8;
                let quad = lr.quads[q];
                if !lr.alive[q] || !quad.iter().any(|&w| in_region(w)) {
                    return (nbq, bad);
                }
                for k in 0..4 {
                    let (a, b) = (quad[k], quad[(k + 1) % 4]);
                    let mut found = NONE;
                    let mut count = 0;
                    let mut same_dir = false;
                    for &s in lr.star(a) {
                        if s as usize == q {
                            continue;
                        }
                        let r = &lr.quads[s as usize];
                        for m in 0..4 {
                            if r[m] == b && r[(m + 1) % 4] == a {
                                found = s;
                                count += 1;
                                break;
                            }
                        }
                        same_dir |= (0..4).any(|m| r[m] == a && r[(m + 1) % 4] == b);
                    }
                    if count == 1 && !same_dir {
                        nbq[k] = found;
                    } else if count > 1 || same_dir {
                        bad |= 1 << k;
                    }
                }
                (nbq, bad)
            })
            .collect();
        let mut nb = Vec::with_capacity(rows.len());
        let mut val = vec![0i32; n];
        let mut corner = vec![NONE; n];
        let mut unsafe_node = vec![false; n];
        for (q, (nbq, bad)) in rows.into_iter().enumerate() {
            nb.push(nbq);
            if !l.alive[q] {
                continue;
            }
            let quad = l.quads[q];
            for k in 0..4 {
                let (a, b) = (quad[k], quad[(k + 1) % 4]);
                val[a as usize] += 1;
                corner[a as usize] = q as u32;
                if bad & (1 << k) != 0 {
                    unsafe_node[a as usize] = true;
                    unsafe_node[b as usize] = true;
                }
            }
        }
        let mut t = Topo {
            l,
            nb,
            val,
            ideal,
            angle,
            corner,
            unsafe_node,
            log: Vec::new(),
        };
        // a fan that does not close over all of a node's quads is not manifold either
        let tr = &t;
        let open: Vec<u32> = (0..n as u32)
            .into_par_iter()
            .with_min_len(4096)
            .filter(|&v| {
                let vi = v as usize;
                if tr.val[vi] == 0 || tr.unsafe_node[vi] || !in_region(v) {
                    return false;
                }
                let mut c = 0;
                tr.around(v, |_| c += 1);
                c != tr.val[vi]
            })
            .collect();
        for v in open {
            t.unsafe_node[v as usize] = true;
        }
        t
    }

    /// Calls `f` on every quad of the fan around `v` reachable from `corner[v]`.
    fn around(&self, v: u32, mut f: impl FnMut(u32)) {
        let q0 = self.corner[v as usize];
        if q0 == NONE {
            return;
        }
        // forward: across the edge leaving v
        let mut q = q0;
        loop {
            f(q);
            let Some(k) = slot(&self.l.quads[q as usize], v) else {
                return;
            };
            q = self.nb[q as usize][k];
            if q == NONE || q == q0 {
                break;
            }
        }
        if q == q0 {
            return;
        }
        // backward: across the edge entering v
        let mut q = q0;
        loop {
            let Some(k) = slot(&self.l.quads[q as usize], v) else {
                return;
            };
            q = self.nb[q as usize][(k + 3) % 4];
            if q == NONE || q == q0 {
                break;
            }
            f(q);
        }
    }

    /// True when `v` is a fixed node whose quads' corners are wider than
    /// [`MAX_FIXED_CORNER`] on average.
    fn wide_corner(&self, v: u32) -> bool {
        let vi = v as usize;
        self.l.fixed[vi]
            && self.val[vi] > 0
            && self.angle[vi] / f64::from(self.val[vi]) > MAX_FIXED_CORNER
    }

    /// True when `q` has [`CROWDED`] or more free corners of valence 3.
    fn crowded(&self, q: u32) -> bool {
        let quad = &self.l.quads[q as usize];
        let three = |&&w: &&u32| !self.l.fixed[w as usize] && self.val[w as usize] == 3;
        quad.iter().filter(three).count() >= CROWDED
    }

    /// Energy of node `v` at valence `d`.
    fn energy(&self, v: u32, d: i32) -> i32 {
        let vi = v as usize;
        let e = d - self.ideal[vi];
        let mut c = e * e;
        if self.l.fixed[vi] {
            let corner = if d > 0 {
                self.angle[vi] / f64::from(d)
            } else {
                f64::INFINITY
            };
            if corner > MAX_FIXED_CORNER || (corner < MIN_FIXED_CORNER && d > self.ideal[vi]) {
                c += WIDE_CORNER_PENALTY;
            }
        }
        c
    }

    /// Energy drop of rotating the edge in slot `k` of `q1` to diagonal `s` (1 or 2) of its
    /// hexagon, with the hexagon; `None` when the rotation is not allowed.
    fn candidate(&self, q1: u32, k: usize, s: usize) -> Option<(i32, [u32; 6], u32)> {
        let quad = self.l.quads[q1 as usize];
        let q2 = self.nb[q1 as usize][k];
        if q2 == NONE {
            return None;
        }
        let (u, v) = (quad[k], quad[(k + 1) % 4]);
        let fixed = |w: u32| self.l.fixed[w as usize];
        if fixed(u) && fixed(v) {
            return None;
        }
        let r1 = [
            quad[k],
            quad[(k + 1) % 4],
            quad[(k + 2) % 4],
            quad[(k + 3) % 4],
        ];
        let o = self.l.quads[q2 as usize];
        let m = slot(&o, v)?;
        let r2 = [o[m], o[(m + 1) % 4], o[(m + 2) % 4], o[(m + 3) % 4]];
        if r2[1] != u {
            return None;
        }
        // hexagon in orientation: v p1 p2 u p3 p4
        let hex = [v, r1[2], r1[3], u, r2[2], r2[3]];
        let mut sorted = hex;
        sorted.sort_unstable();
        if sorted.windows(2).any(|w| w[0] == w[1])
            || hex.iter().any(|&w| self.unsafe_node[w as usize])
        {
            return None;
        }
        let (x, y) = (hex[s], hex[s + 3]);
        let val = |w: u32| self.val[w as usize];
        let before = self.energy(u, val(u))
            + self.energy(v, val(v))
            + self.energy(x, val(x))
            + self.energy(y, val(y));
        let after = self.energy(u, val(u) - 1)
            + self.energy(v, val(v) - 1)
            + self.energy(x, val(x) + 1)
            + self.energy(y, val(y) + 1);
        Some((before - after, hex, q2))
    }

    /// True when `x` and `y` already share a quad other than `q1`, `q2`.
    fn share_a_quad(&self, x: u32, y: u32, q1: u32, q2: u32) -> bool {
        let mut hit = false;
        self.around(x, |q| {
            if q != q1 && q != q2 && slot(&self.l.quads[q as usize], y).is_some() {
                hit = true;
            }
        });
        hit
    }

    /// Sets quad `q` to `nodes`, logging its old state.
    fn save(&mut self, q: u32) {
        self.log.push(Saved::Quad {
            q,
            nodes: self.l.quads[q as usize],
            nb: self.nb[q as usize],
        });
    }

    /// Points the neighbour across each edge of `q` back at `q`.
    fn relink(&mut self, q: u32) {
        let quad = self.l.quads[q as usize];
        for k in 0..4 {
            let o = self.nb[q as usize][k];
            if o == NONE {
                continue;
            }
            let (a, b) = (quad[k], quad[(k + 1) % 4]);
            let r = self.l.quads[o as usize];
            if let Some(m) = (0..4).find(|&m| r[m] == b && r[(m + 1) % 4] == a) {
                if self.nb[o as usize][m] != q {
                    self.save(o);
                    self.nb[o as usize][m] = q;
                }
            }
        }
    }

    /// Rotates: `q1`, `q2` become the two quads of `hex` split along diagonal `s`. Returns
    /// false (nothing changed) when the new quads are invalid or the diagonal exists.
    fn rotate(&mut self, q1: u32, q2: u32, hex: [u32; 6], s: usize) -> bool {
        let (x, y) = (hex[s], hex[s + 3]);
        let qa = [hex[s], hex[s + 1], hex[s + 2], hex[s + 3]];
        let qb = [hex[s + 3], hex[(s + 4) % 6], hex[(s + 5) % 6], hex[s]];
        if self.share_a_quad(x, y, q1, q2) {
            return false;
        }
        // outer neighbours of the hexagon, edge hex[i] -> hex[i+1]
        let outer = |t: &Self, a: u32, b: u32| -> u32 {
            for q in [q1, q2] {
                let r = t.l.quads[q as usize];
                if let Some(m) = (0..4).find(|&m| r[m] == a && r[(m + 1) % 4] == b) {
                    return t.nb[q as usize][m];
                }
            }
            NONE
        };
        let mut out = [NONE; 6];
        for i in 0..6 {
            out[i] = outer(self, hex[i], hex[(i + 1) % 6]);
        }
        self.save(q1);
        self.save(q2);
        // qa: hex[s..s+3] edges s, s+1, s+2 outer, then the diagonal
        self.l.quads[q1 as usize] = qa;
        self.nb[q1 as usize] = [out[s], out[s + 1], out[s + 2], q2];
        self.l.quads[q2 as usize] = qb;
        self.nb[q2 as usize] = [out[(s + 3) % 6], out[(s + 4) % 6], out[(s + 5) % 6], q1];
        self.relink(q1);
        self.relink(q2);
        let (u, v) = (hex[3], hex[0]);
        self.val[u as usize] -= 1;
        self.val[v as usize] -= 1;
        self.val[x as usize] += 1;
        self.val[y as usize] += 1;
        self.fix_corners(&hex, q1, q2);
        true
    }

    /// Checks the quads rewritten since the log was cleared: keeps them if all are valid;
    /// else moves the free nodes of the invalid ones to the centroid of their ring and keeps
    /// them if every quad rewritten or around a moved node then has signed η above
    /// [`RELOCATED_MIN_ETA`]. Returns false (positions possibly moved, logged) otherwise.
    fn settle(&mut self) -> bool {
        let mut quads: Vec<u32> = self
            .log
            .iter()
            .filter_map(|s| match s {
                Saved::Quad { q, nodes, .. } if *nodes != self.l.quads[*q as usize] => Some(*q),
                _ => None,
            })
            .collect();
        quads.sort_unstable();
        quads.dedup();
        let invalid: Vec<u32> = quads
            .iter()
            .copied()
            .filter(|&q| self.l.quality(q) <= MIN_ETA || !valid::valid(self.l, q))
            .collect();
        if invalid.is_empty() {
            return true;
        }
        // validity: an invalid quad without a free node cannot be repaired by moving nodes
        // (measured on the island domain: quads of four wall nodes around a sharp island
        // corner were kept, reflex or straight)
        let mut moved: Vec<u32> = invalid
            .iter()
            .flat_map(|&q| self.l.quads[q as usize])
            .filter(|&w| !self.l.fixed[w as usize])
            .collect();
        if moved.is_empty() {
            return false;
        }
        moved.sort_unstable();
        moved.dedup();
        for &w in &moved {
            let mut sum = DVec3::ZERO;
            let mut n = 0.0;
            self.around(w, |q| {
                for &o in &self.l.quads[q as usize] {
                    if o != w {
                        sum += self.l.pos[o as usize];
                        n += 1.0;
                    }
                }
            });
            if n > 0.0 {
                let (p, tri) = self.l.project(w, sum / n);
                self.log.push(Saved::Node {
                    v: w,
                    pos: self.l.pos[w as usize],
                    tri: self.l.tri[w as usize],
                });
                self.l.pos[w as usize] = p;
                self.l.tri[w as usize] = tri;
            }
        }
        let thr = RELOCATED_MIN_ETA;
        let good = |l: &Local, q: u32| l.quality(q) > thr && valid::valid(l, q);
        let mut ok = quads.iter().all(|&q| good(self.l, q));
        for &w in &moved {
            self.around(w, |q| {
                ok = ok && good(self.l, q);
            });
        }
        ok
    }

    fn fix_corners(&mut self, hex: &[u32; 6], q1: u32, q2: u32) {
        for &w in hex {
            self.corner[w as usize] = if slot(&self.l.quads[q1 as usize], w).is_some() {
                q1
            } else {
                q2
            };
        }
    }

    /// Undoes the log back to length `mark` (valences recounted from the restored quads).
    fn undo(&mut self, mark: usize) {
        while self.log.len() > mark {
            match self.log.pop() {
                Some(Saved::Quad { q, nodes, nb }) => {
                    let old = self.l.quads[q as usize];
                    if old != nodes {
                        for &w in &old {
                            self.val[w as usize] -= 1;
                        }
                        for &w in &nodes {
                            self.val[w as usize] += 1;
                            self.corner[w as usize] = q;
                        }
                    }
                    self.l.quads[q as usize] = nodes;
                    self.nb[q as usize] = nb;
                }
                Some(Saved::Node { v, pos, tri }) => {
                    self.l.pos[v as usize] = pos;
                    self.l.tri[v as usize] = tri;
                }
                None => break,
            }
        }
    }

    /// Depth-first search for a rotation sequence with total gain > 0, every prefix's total
    /// at least `floor`, starting at the candidates on the edges of `quads`; applies it and
    /// returns its length when found.
    fn search(&mut self, quads: [u32; 2], gain: i32, depth: usize, floor: i32) -> Option<usize> {
        for q in quads {
            if q == NONE {
                continue;
            }
            for k in 0..4 {
                for s in [1usize, 2] {
                    let Some((g, hex, q2)) = self.candidate(q, k, s) else {
                        continue;
                    };
                    let total = gain + g;
                    if total <= 0 && (depth <= 1 || total < floor) {
                        continue;
                    }
                    let mark = self.log.len();
                    if !self.rotate(q, q2, hex, s) {
                        continue;
                    }
                    if total > 0 {
                        if self.settle() {
                            return Some(1);
                        }
                        self.undo(mark);
                        continue;
                    }
                    if let Some(n) = self.search([q, q2], total, depth - 1, floor) {
                        return Some(n + 1);
                    }
                    self.undo(mark);
                }
            }
        }
        None
    }
}

/// Runs rounds of the rotation search (sequences of at most `depth` rotations) until a round
/// applies nothing or `max_rounds` is reached; returns the number of applied sequences and
/// the number of rotations in them. Leaves the node → quads adjacency stale. With `focus`,
/// only quads with a node marked in it are searched.
pub(crate) fn cleanup(
    l: &mut Local,
    depth: usize,
    max_rounds: usize,
    focus: Option<&[bool]>,
) -> (usize, usize) {
    if depth == 0 {
        return (0, 0);
    }
    let trace = l.trace.clone();
    let mut tm = crate::profile::StageTimer::new(trace.as_ref(), "cleanup", l.surface);
    let mut t = Topo::near(l, focus);
    tm.lap("near");
    let (mut sequences, mut rotations) = (0, 0);
    for _ in 0..max_rounds {
        let mut applied = 0;
        for q in 0..t.l.quads.len() as u32 {
            if !t.l.alive[q as usize] {
                continue;
            }
            let quad = t.l.quads[q as usize];
            if let Some(f) = focus {
                if !quad.iter().any(|&w| f.get(w as usize) == Some(&true)) {
                    continue;
                }
            }
            // only near a defect
            let near = quad.iter().any(|&w| {
                let d = t.val[w as usize];
                t.energy(w, d) > 0
            }) || (0..4).any(|k| {
                let o = t.nb[q as usize][k];
                o != NONE
                    && t.l.quads[o as usize]
                        .iter()
                        .any(|&w| t.energy(w, t.val[w as usize]) > 0)
            });
            if !near {
                continue;
            }
            // quality: around a fixed node whose single quad spans too wide a corner, a
            // longer sequence whose first steps may raise the energy (see WIDE_DEPTH)
            let wide = quad.iter().any(|&w| t.wide_corner(w));
            // quality: a quad with three free corners of valence 3 cannot be smoothed into
            // shape, and no sequence of two rotations that never raises the energy undoes it
            let (d, floor) = if wide {
                (depth.max(WIDE_DEPTH), -WIDE_FLOOR)
            } else if t.crowded(q) {
                (depth.max(WIDE_DEPTH), -CROWDED_FLOOR)
            } else {
                (depth, 0)
            };
            t.log.clear();
            let found = t.search([q, NONE], 0, d, floor);
            if let Some(n) = found {
                applied += 1;
                rotations += n;
            }
        }
        t.log.clear();
        tm.lap("search");
        sequences += applied;
        if applied == 0 {
            break;
        }
    }
    tm.done();
    (sequences, rotations)
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;
    use crate::mesh::Mesh;
    use crate::mesh::NodeTable;
    use crate::optimize::extract::{extract, node_owners, write_back, NodePlaces, PendingNodes};
    use crate::optimize::synth::{self, Soup};
    use crate::optimize::OptimizeReport;

    /// The single surface of `m` as a [`Local`], with its node → quads adjacency.
    pub(crate) fn local_of(m: &Mesh) -> (NodeTable, Local) {
        let flat = NodeTable::new(m);
        let owner = node_owners(m, &flat, &[1]).expect("owners");
        let mut scratch = vec![crate::optimize::local::NONE; flat.coords.len()];
        let mut l = extract(m, &flat, &owner, (0, 1), &mut scratch).expect("extract");
        l.build_adjacency();
        (flat, l)
    }

    /// The Delaunay square `synth::delaunay_square(n, 1.0, 0.3, seed)` optimally paired, as
    /// a [`Local`] whose sizes come from its quads' own edges (as for a surface without
    /// reference triangles); `None` when its triangles have no perfect matching.
    pub(crate) fn square_local(n: usize, seed: u64) -> Option<Local> {
        use crate::optimize::synth;
        let quads = synth::pair_optimal(&synth::delaunay_square(n, 1.0, 0.3, seed))?;
        let (_, mut l) = local_of(&synth::to_mesh(&quads));
        l.h = crate::quality::size::mean_incident_edge_length(
            &l.pos,
            l.quads.iter().map(|q| &q[..]),
        );
        Some(l)
    }

    /// Total defect energy E (see the module docs) of `l`.
    pub(crate) fn energy(l: &mut Local) -> i32 {
        let t = Topo::new(l);
        (0..t.val.len() as u32)
            .filter(|&v| t.val[v as usize] > 0)
            .map(|v| t.energy(v, t.val[v as usize]))
            .sum()
    }

    /// Runs [`cleanup`] and checks what every operator must keep: fixed nodes and their
    /// positions, the quad count, node usage, valid orientation, a conforming mesh.
    fn cleanup_checked(m: &mut Mesh, depth: usize, rounds: usize) -> (i32, i32, usize) {
        let (flat, mut l) = local_of(m);
        let e0 = energy(&mut l);
        let fixed_before: Vec<(u32, DVec3)> = (0..l.pos.len() as u32)
            .filter(|&v| l.fixed[v as usize])
            .map(|v| (v, l.pos[v as usize]))
            .collect();
        let alive = l.alive.iter().filter(|&&a| a).count();
        let quads_before = l.quads.clone();
        let (seqs, rots) = cleanup(&mut l, depth, rounds, None);
        assert!(rots >= seqs);
        for &(v, p) in &fixed_before {
            assert_eq!(l.pos[v as usize], p, "a fixed node moved");
        }
        assert_eq!(l.alive.iter().filter(|&&a| a).count(), alive);
        for (q, quad) in l.quads.iter().enumerate() {
            let e = l.quality(q as u32);
            // rewritten quads are valid (input quads may be flat: the matching is not ours)
            assert!(
                e > 0.0 || *quad == quads_before[q],
                "quad {q} {quad:?} invalid after cleanup: {e}"
            );
        }
        l.build_adjacency();
        let e1 = energy(&mut l);
        write_back_checked(m, flat, &l);
        (e0, e1, seqs)
    }

    /// Writes `l` back into `m` (its mesh, `flat` its node table) and checks the result
    /// with the independent checker: conforming, oriented, its boundary on the curves.
    pub(crate) fn write_back_checked(m: &mut Mesh, flat: NodeTable, l: &Local) {
        let mut rep = OptimizeReport::default();
        let mut pending = PendingNodes::new(m);
        write_back(m, &NodePlaces::new(flat), l, &mut rep, &mut pending);
        pending.apply(m);
        crate::optimize::check::check_surface_mesh(m).expect("conforming, oriented");
    }

    /// Recombined Delaunay squares (the seeds whose triangles have a perfect matching).
    fn matched_squares() -> Vec<(u64, Soup)> {
        let out: Vec<(u64, Soup)> = (1u64..40)
            .filter_map(|seed| {
                synth::pair_optimal(&synth::delaunay_square(14, 1.0, 0.3, seed)).map(|q| (seed, q))
            })
            .take(7)
            .collect();
        assert_eq!(out.len(), 7, "not enough matchable seeds");
        out
    }

    #[test]
    fn rotation_sequences_lower_the_defect_energy_of_recombined_delaunay_squares() {
        let mut total = (0, 0);
        for (seed, quads) in matched_squares().into_iter().take(4) {
            let mut m = synth::to_mesh(&quads);
            let curve = m.node_blocks[0].clone();
            let (e0, e1, seqs) = cleanup_checked(&mut m, 2, 8);
            assert!(e1 <= e0, "seed {seed}: energy rose {e0} -> {e1}");
            assert!(e1 < e0 || seqs == 0);
            assert_eq!(m.node_blocks[0].tags, curve.tags);
            assert_eq!(m.node_blocks[0].coords, curve.coords);
            total.0 += e0;
            total.1 += e1;
        }
        // depth 2 finds sequences a single greedy rotation cannot
        assert!(total.1 < total.0, "{total:?}");
    }

    #[test]
    fn a_focus_over_every_node_finds_the_same_rotations_as_no_focus() {
        // the focused neighbours (built only near the focus) must not miss anything a
        // search from a focus quad reads
        for (seed, quads) in matched_squares().into_iter().take(3) {
            let m = synth::to_mesh(&quads);
            let (_, mut a) = local_of(&m);
            let (_, mut b) = local_of(&m);
            let all = vec![true; b.pos.len()];
            let ra = cleanup(&mut a, 2, 8, None);
            let rb = cleanup(&mut b, 2, 8, Some(&all));
            assert!(ra.0 > 0, "seed {seed}: nothing to do");
            assert_eq!(ra, rb, "seed {seed}");
            assert_eq!(a.quads, b.quads, "seed {seed}");
        }
    }

    #[test]
    fn a_focused_cleanup_only_rewrites_quads_near_the_focus() {
        for (seed, quads) in matched_squares().into_iter().take(3) {
            let m = synth::to_mesh(&quads);
            let (_, mut l) = local_of(&m);
            // focus: the nodes left of the middle
            let mid = l.pos.iter().map(|p| p.x).sum::<f64>() / l.pos.len() as f64;
            let focus: Vec<bool> = l.pos.iter().map(|p| p.x < mid).collect();
            let before = l.quads.clone();
            let (_, mut full) = local_of(&m);
            cleanup(&mut full, 2, 1, None);
            cleanup(&mut l, 2, 1, Some(&focus));
            // within 3 quad rings of the focus (a depth-2 sequence from a focus quad)
            l.build_adjacency();
            let mut near = focus.clone();
            for _ in 0..3 {
                let mut next = near.clone();
                for v in 0..l.pos.len() as u32 {
                    if near[v as usize] {
                        for &q in l.star(v).iter().chain(
                            (0..before.len() as u32)
                                .filter(|&q| before[q as usize].contains(&v))
                                .collect::<Vec<_>>()
                                .iter(),
                        ) {
                            for &w in l.quads[q as usize].iter().chain(&before[q as usize]) {
                                next[w as usize] = true;
                            }
                        }
                    }
                }
                near = next;
            }
            let mut changed = 0;
            for (q, quad) in l.quads.iter().enumerate() {
                if *quad != before[q] {
                    changed += 1;
                    assert!(
                        quad.iter().chain(&before[q]).any(|&w| near[w as usize]),
                        "seed {seed}: quad {q} rewritten far from the focus"
                    );
                }
            }
            // and it did less than the unfocused search
            let changed_full = full
                .quads
                .iter()
                .zip(&before)
                .filter(|(a, b)| a != b)
                .count();
            assert!(
                changed > 0 && changed < changed_full,
                "seed {seed}: {changed} vs {changed_full}"
            );
        }
    }

    #[test]
    fn depth_two_removes_more_defects_than_single_rotations() {
        let (mut one, mut two) = (0, 0);
        for (_, quads) in matched_squares().into_iter().skip(4).take(3) {
            let mut m1 = synth::to_mesh(&quads);
            let mut m2 = m1.clone();
            one += cleanup_checked(&mut m1, 1, 8).1;
            two += cleanup_checked(&mut m2, 2, 8).1;
        }
        assert!(two < one, "depth 2 energy {two}, depth 1 energy {one}");
    }

    /// A 6 × 4 grid whose third and fourth bottom quads had their shared edge rotated: bottom
    /// node 3 (tag 4, pushed slightly down) sits alone in one quad with a 163° corner.
    fn wide_corner_soup() -> Soup {
        let mut s = synth::quad_grid(6, 4, 6.0, 4.0);
        s.points[3].y = -0.15;
        // grid ids: bottom 0..6, row 1: 7..13; quads (2,3,10,9) and (3,4,11,10)
        s.faces[2] = vec![2, 3, 4, 9];
        s.faces[3] = vec![4, 11, 10, 9];
        s
    }

    #[test]
    fn a_fixed_node_alone_in_a_quad_at_a_flat_angle_gets_a_second_quad() {
        let mut m = synth::to_mesh(&wide_corner_soup());
        {
            let (_, mut l) = local_of(&m);
            let t = Topo::new(&mut l);
            let v = (0..t.val.len())
                .find(|&v| l_tag(&t, v) == 4)
                .expect("node 2");
            assert_eq!(t.val[v], 1);
            assert!(t.energy(v as u32, 1) >= WIDE_CORNER_PENALTY);
        }
        let (e0, e1, seqs) = cleanup_checked(&mut m, 1, 8);
        assert!(seqs >= 1 && e1 < e0, "{e0} -> {e1}");
        let (_, mut l) = local_of(&m);
        let t = Topo::new(&mut l);
        let v = (0..t.val.len())
            .find(|&v| l_tag(&t, v) == 4)
            .expect("node 2");
        assert_eq!(t.val[v], 2, "the flat node now has two quads");
        for w in 0..t.val.len() {
            if t.l.fixed[w] && t.val[w] > 0 {
                assert!(
                    t.energy(w as u32, t.val[w]) < WIDE_CORNER_PENALTY,
                    "node {w}"
                );
            }
        }
    }

    /// Tag of local node `v` (synth tags are 1-based point indices).
    fn l_tag(t: &Topo, v: usize) -> u64 {
        t.l.tags[v]
    }

    /// Quads with three free corners of valence 3 in `l` (adjacency current).
    fn crowded_quads(l: &mut Local) -> usize {
        let t = Topo::new(l);
        (0..t.l.quads.len() as u32)
            .filter(|&q| t.l.alive[q as usize] && t.crowded(q))
            .count()
    }

    /// A patch of 135 quads cut around the one quad with three valence-3 corners that the
    /// pipeline left on the 3.6·10^6-triangle rectangle (η_w 0.566 after every polish): the
    /// search from it finds no sequence of two rotations but one of three, and one round of
    /// the cleanup removes it with the mesh kept conforming.
    #[test]
    fn a_quad_with_three_valence_three_corners_is_taken_apart() {
        let text = include_str!("../../tests/data/patches/crowded_quad.txt");
        let mut soup = Soup::default();
        for line in text.lines() {
            let f: Vec<&str> = line.split_whitespace().collect();
            match f.first() {
                Some(&"v") => {
                    let x: Vec<f64> = f[1..].iter().map(|t| t.parse().expect("a float")).collect();
                    soup.points.push(DVec3::new(x[0], x[1], 0.0));
                }
                Some(&"q") => soup.faces.push(
                    f[1..]
                        .iter()
                        .map(|t| t.parse().expect("an index"))
                        .collect(),
                ),
                _ => {}
            }
        }
        // to unit edges (the sizes `local_of` gives): the validity rule compares edge
        // lengths with them
        let c = soup.points.iter().sum::<DVec3>() / soup.points.len() as f64;
        let q0 = &soup.faces[0];
        let scale = soup.points[q0[0]].distance(soup.points[q0[1]]);
        for p in &mut soup.points {
            *p = (*p - c) / scale;
        }
        let mut m = synth::to_mesh(&soup);
        let (_, mut l) = local_of(&m);
        assert_eq!(crowded_quads(&mut l), 1);
        // from the quad itself: nothing within two rotations, a sequence within three
        let mut t = Topo::new(&mut l);
        let q = (0..t.l.quads.len() as u32)
            .find(|&q| t.crowded(q))
            .expect("the crowded quad");
        assert_eq!(t.search([q, NONE], 0, 2, 0), None);
        t.log.clear();
        assert!(t.search([q, NONE], 0, WIDE_DEPTH, -CROWDED_FLOOR).is_some());
        // one round, as a topology pass runs it
        let (e0, e1, seqs) = cleanup_checked(&mut m, 2, 1);
        assert!(seqs > 0 && e1 < e0, "{e0} -> {e1} in {seqs} sequences");
        let (_, mut after) = local_of(&m);
        assert_eq!(crowded_quads(&mut after), 0);
    }

    #[test]
    fn an_edge_between_two_fixed_nodes_never_rotates() {
        // a 1 × 2 strip: its only interior edge joins two boundary nodes; rotating it
        // would lower nothing anyway, but the candidate must be refused outright
        let s = synth::quad_grid(2, 1, 2.0, 1.0);
        let m = synth::to_mesh(&s);
        let (_, mut l) = local_of(&m);
        let t = Topo::new(&mut l);
        for q in 0..2u32 {
            for k in 0..4 {
                for s in [1, 2] {
                    assert!(t.candidate(q, k, s).is_none());
                }
            }
        }
    }
}
