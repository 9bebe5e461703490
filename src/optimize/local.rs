//! The optimizer's working copy of one surface's quads: flat arrays indexed by local node and
//! quad numbers, a node → quads CSR rebuilt after each topological pass, and the reference
//! surface nodes are projected on.
//!
//! **Invariant:** a quad's nodes are listed in the orientation of the input; operators keep
//! it. Fixed nodes (on curves, points, the boundary, or used by any element that is not a
//! quad of this surface) never move and are never removed.

use crate::quality::eta::eta_signed_fast;
use crate::quality::locate::TriSurface;
use crate::quality::size::{inverse_linear_integral, tau_deviation};
use glam::DVec3;
use rayon::prelude::*;

/// Sentinel for "no node / no quad / no triangle".
pub(crate) use crate::mesh::NONE;

/// True when `a` and `b` are the same vector bit for bit.
pub(crate) fn same_bits(a: DVec3, b: DVec3) -> bool {
    a.to_array().map(f64::to_bits) == b.to_array().map(f64::to_bits)
}

/// The one normal of every entry of `nrm`, when they are all the same bit for bit (none
/// when `nrm` is empty or they differ).
pub(crate) fn uniform_normal(nrm: &[DVec3]) -> Option<DVec3> {
    let first = *nrm.first()?;
    nrm.par_iter()
        .with_min_len(8192)
        .all(|&n| same_bits(n, first))
        .then_some(first)
}

/// One surface's quads and nodes.
#[derive(Clone)]
pub(crate) struct Local {
    /// Surface entity tag.
    pub surface: i32,
    /// Node positions.
    pub pos: Vec<DVec3>,
    /// Unit reference normal per node (orientation of the input quads).
    pub nrm: Vec<DVec3>,
    /// On curved surfaces, the unit area-weighted normal of the reference triangles around
    /// each node the reference has (at an input node, the normal the validity gate,
    /// `crate::validity`, measures corners about), zero at other nodes; empty on planar
    /// surfaces and without reference triangles.
    pub gate_nrm: Vec<DVec3>,
    /// Distance within which a node touches a reference triangle (an edge or a corner of
    /// it): at a node `gate_nrm` is zero at, the validity gate measures the corner about the
    /// input faces nearest to a point inside it, ties within 1e-9 of the input's extent; this is
    /// 1e-8 of the extent of the mesh optimized, which holds every input node, so every face
    /// the gate counts is one the optimizer measures about.
    pub tie: f64,
    /// Corners at nodes `gate_nrm` is zero at are held to the reference triangles they
    /// touch (the surface is in [`OptimizeOptions::located_surfaces`](super::OptimizeOptions)).
    pub located_turns: bool,
    /// Target size h per node (eq. 1's field at the node).
    pub h: Vec<f64>,
    /// Fixed nodes never move nor disappear.
    pub fixed: Vec<bool>,
    /// Removed by an operator.
    pub removed: Vec<bool>,
    /// Reference triangle each node lies on (projection hint), [`NONE`] if unknown.
    pub tri: Vec<u32>,
    /// Node id in the mesh (see `mesh::NodeTable`).
    pub global: Vec<u32>,
    /// Node tags.
    pub tags: Vec<u64>,
    /// Quads (local node indices).
    pub quads: Vec<[u32; 4]>,
    /// False once an operator removed the quad.
    pub alive: Vec<bool>,
    /// (element block, element index) each quad came from.
    pub origin: Vec<(u32, u32)>,
    /// True when all nodes lie in one plane: moves stay in it, no projection.
    pub planar: bool,
    /// The surface belongs to a mesh of [`LARGE_MESH_FROM`](super::schedule::LARGE_MESH_FROM)
    /// reference triangles or more: it runs the schedule of large surfaces whatever its size.
    pub in_large_mesh: bool,
    /// The surface nodes are projected on (curved surfaces; on small planar surfaces kept
    /// only for [`Local::tau_estimate`]).
    pub reference: Option<std::sync::Arc<TriSurface>>,
    /// Target sizes at the points of `reference` (empty when the surface has no reference
    /// triangles, or is planar and large).
    pub ref_sizes: Vec<f64>,
    /// CSR: quads around node `v` are `adj[start[v]..start[v+1]]`.
    pub start: Vec<u32>,
    /// CSR payload.
    pub adj: Vec<u32>,
    /// Unit reference normal per quad (see [`Local::refresh_quad_normals`]); empty when
    /// `qn_all` holds the one normal of every quad.
    pub qn: Vec<DVec3>,
    /// The unit reference normal of every quad when all nodes have the same normal bit for
    /// bit (planar surfaces; memory: no per-quad copies).
    pub qn_all: Option<DVec3>,
    /// Per quad: a corner whose three nodes are fixed does not turn positively, so no move
    /// can make the quad valid (see [`Local::refresh_quad_normals`]).
    pub hopeless: Vec<bool>,
    /// Free nodes by colour for the sweeps (see [`Local::prepare_sweeps`]).
    pub colours: Vec<Vec<u32>>,
    /// True while `qn`, `hopeless` and `colours` match the quads (cleared by
    /// [`Local::build_adjacency`]).
    pub sweep_ready: bool,
    /// Where stage times and rollbacks go ([`OptimizeOptions::trace`](super::OptimizeOptions)).
    pub trace: Option<crate::profile::Trace>,
}

impl Local {
    /// Rebuilds the node → alive quads CSR.
    pub fn build_adjacency(&mut self) {
        let alive = &self.alive;
        (self.start, self.adj) = csr(self.pos.len(), &self.quads, |q| alive[q]);
        self.sweep_ready = false;
    }

    /// Quad normals, hopeless quads ([`Local::refresh_quad_normals`]) and the colouring of
    /// the free nodes, recomputed only when the quads changed since the last call: they
    /// depend on the topology, the node normals and fixed nodes only, none of which a
    /// smoothing sweep changes. Needs a current adjacency.
    pub fn prepare_sweeps(&mut self) {
        if !self.sweep_ready {
            self.refresh_quad_normals();
            self.colours = colour_free_nodes(self);
            self.sweep_ready = true;
        }
    }

    /// Recomputes the unit reference normal of every quad from its nodes' normals, and
    /// which quads are hopeless for smoothing: those with a fixed corner (the node and both
    /// its quad neighbours fixed) that is straight, reflex or folded. Smoothing leaves such
    /// quads out of its centroids and acceptance tests (otherwise their constant negative
    /// key would let a node's other quads degrade down to it).
    pub fn refresh_quad_normals(&mut self) {
        // with one node normal for all, every quad's sum of four is the same
        self.qn_all = match (uniform_normal(&self.nrm), self.quads.is_empty()) {
            (Some(_), false) => Some(self.quad_normal(0).normalize_or_zero()),
            _ => None,
        };
        self.qn = match self.qn_all {
            Some(_) => Vec::new(),
            None => (0..self.quads.len() as u32)
                .into_par_iter()
                .with_min_len(4096)
                .map(|q| self.quad_normal(q).normalize_or_zero())
                .collect(),
        };
        self.hopeless = (0..self.quads.len())
            .into_par_iter()
            .with_min_len(4096)
            .map(|q| {
                let quad = &self.quads[q];
                self.alive[q]
                    && (0..4).any(|k| {
                        let [a, b, c] = [quad[(k + 3) & 3], quad[k], quad[(k + 1) & 3]];
                        if !(self.fixed[a as usize]
                            && self.fixed[b as usize]
                            && self.fixed[c as usize])
                        {
                            return false;
                        }
                        let pb = self.pos[b as usize];
                        let (x, y) = (self.pos[c as usize] - pb, self.pos[a as usize] - pb);
                        self.qn(q as u32).dot(x.cross(y)) <= 0.0
                    })
            })
            .collect();
    }

    /// Shape key of quad `q` with node `v` at `p` (uses the cached quad normals): a monotone
    /// function of the signed η (eq. 3) that needs no trigonometry, see [`shape_key`].
    pub fn key_with(&self, q: u32, v: u32, p: DVec3) -> f64 {
        let quad = &self.quads[q as usize];
        let mut pts = [DVec3::ZERO; 4];
        for k in 0..4 {
            let w = quad[k];
            pts[k] = if w == v { p } else { self.pos[w as usize] };
        }
        shape_key(&pts, self.qn(q))
    }

    /// The cached unit reference normal of quad `q` ([`Local::refresh_quad_normals`]).
    #[inline]
    pub fn qn(&self, q: u32) -> DVec3 {
        match self.qn_all {
            Some(n) => n,
            None => self.qn[q as usize],
        }
    }

    /// Quads around node `v` (as of the last [`Local::build_adjacency`]).
    pub fn star(&self, v: u32) -> &[u32] {
        &self.adj[self.start[v as usize] as usize..self.start[v as usize + 1] as usize]
    }

    /// Corner positions of quad `q`.
    pub fn corners(&self, q: u32) -> [DVec3; 4] {
        self.quads[q as usize].map(|v| self.pos[v as usize])
    }

    /// Reference normal of quad `q`: the sum of its nodes' normals.
    pub fn quad_normal(&self, q: u32) -> DVec3 {
        self.quads[q as usize]
            .iter()
            .map(|&v| self.nrm[v as usize])
            .sum()
    }

    /// Signed quality of quad `q` (eq. 3, negative when inverted w.r.t. the surface).
    pub fn quality(&self, q: u32) -> f64 {
        eta_signed_fast(&self.corners(q), self.quad_normal(q))
    }

    /// Projects `p` on the reference surface starting from node `v`'s triangle; returns the
    /// point and its triangle. Planar surfaces (or no reference) return `p` unchanged.
    pub fn project(&self, v: u32, p: DVec3) -> (DVec3, u32) {
        match (&self.reference, self.planar) {
            (Some(r), false) => match r.walk(self.tri[v as usize], p) {
                Some(hit) => (hit.point, hit.tri),
                None => (p, self.tri[v as usize]),
            },
            _ => (p, self.tri[v as usize]),
        }
    }

    /// Efficiency index τ (eq. 2, in %) of the live quads' edges (interior edges counted
    /// twice, once per quad), for comparing two states of one surface. With reference sizes
    /// h is the reference field at the nodes' current positions, linear along each edge
    /// (eq. 1 then integrates exactly), as `blossomquad quality --reference` measures it;
    /// else the nodes' own target sizes. Nodes move by up to about h during the
    /// optimization: on a graded field the size where a node started is not the size where
    /// it is (figures in BENCHMARKS.md, "Measurements behind the defaults").
    pub fn tau_estimate(&self) -> f64 {
        let h: std::borrow::Cow<[f64]> = match (&self.reference, self.ref_sizes.is_empty()) {
            (Some(r), false) => (0..self.pos.len())
                .map(|v| {
                    let hit = if self.removed[v] {
                        None
                    } else {
                        r.walk(self.tri[v], self.pos[v])
                    };
                    let h = hit.map_or(0.0, |hit| {
                        let t = r.triangle(hit.tri);
                        (0..3)
                            .map(|k| {
                                hit.bary[k]
                                    * self.ref_sizes.get(t[k] as usize).copied().unwrap_or(0.0)
                            })
                            .sum()
                    });
                    if h > 0.0 && h.is_finite() {
                        h
                    } else {
                        self.h[v]
                    }
                })
                .collect(),
            _ => std::borrow::Cow::Borrowed(&self.h),
        };
        let (mut sum, mut n) = (0.0, 0usize);
        for (quad, _) in self.quads.iter().zip(&self.alive).filter(|(_, &a)| a) {
            for k in 0..4 {
                let (a, b) = (quad[k] as usize, quad[(k + 1) & 3] as usize);
                // eq. 1 with h linear along the edge
                let lh = self.pos[a].distance(self.pos[b]) * inverse_linear_integral(h[a], h[b]);
                if lh.is_finite() && lh > 0.0 {
                    sum += tau_deviation(lh);
                    n += 1;
                }
            }
        }
        100.0 * (sum / n.max(1) as f64).exp()
    }

    /// Unsigned quality statistics: (η_w, η̄, quads, d4 %, interior vertices), with degrees
    /// over free nodes (interior by construction). Needs a current adjacency.
    pub fn stats(&self) -> Stats {
        // η (eq. 3) about each quad's own (Newell) normal, with one atan per quad
        let (n, sum, worst) = self
            .quads
            .par_iter()
            .zip(self.alive.par_iter())
            .with_min_len(4096)
            .filter(|(_, &alive)| alive)
            .map(|(quad, _)| {
                let p = quad.map(|v| self.pos[v as usize]);
                let e = eta_signed_fast(&p, (p[2] - p[0]).cross(p[3] - p[1])).max(0.0);
                (1usize, e, e)
            })
            .reduce(
                || (0, 0.0, f64::INFINITY),
                |a, b| (a.0 + b.0, a.1 + b.1, a.2.min(b.2)),
            );
        let mut interior = 0usize;
        let mut d4 = 0usize;
        for v in 0..self.pos.len() as u32 {
            if self.fixed[v as usize] || self.removed[v as usize] {
                continue;
            }
            interior += 1;
            if self.star(v).len() == 4 {
                d4 += 1;
            }
        }
        Stats {
            quads: n,
            eta_worst: if n > 0 { worst } else { 0.0 },
            eta_mean: if n > 0 { sum / n as f64 } else { 0.0 },
            interior_vertices: interior,
            d4_percent: if interior > 0 {
                100.0 * d4 as f64 / interior as f64
            } else {
                100.0
            },
        }
    }
}

/// Free nodes grouped by colour: no two nodes of a group share a quad.
fn colour_free_nodes(l: &Local) -> Vec<Vec<u32>> {
    let n = l.pos.len();
    let mut colour = vec![u8::MAX; n];
    let mut groups: Vec<Vec<u32>> = Vec::new();
    for v in 0..n as u32 {
        if l.fixed[v as usize] || l.removed[v as usize] || l.star(v).is_empty() {
            continue;
        }
        let mut used: u64 = 0;
        for &q in l.star(v) {
            for &w in &l.quads[q as usize] {
                let c = colour[w as usize];
                if c < 64 {
                    used |= 1 << c;
                }
            }
        }
        let c = (!used).trailing_zeros().min(63) as usize;
        colour[v as usize] = c as u8;
        if groups.len() <= c {
            groups.resize(c + 1, Vec::new());
        }
        groups[c].push(v);
    }
    groups
}

/// Adds to `mark` every node within `rings` quad rings of a marked node. Needs a current
/// adjacency.
pub(crate) fn grow_rings(l: &Local, mark: &mut [bool], rings: usize) {
    let mut frontier: Vec<u32> = (0..l.pos.len() as u32)
        .filter(|&v| mark[v as usize])
        .collect();
    for _ in 0..rings {
        let mut next = Vec::new();
        for &v in &frontier {
            for &q in l.star(v) {
                for &w in &l.quads[q as usize] {
                    if !mark[w as usize] {
                        mark[w as usize] = true;
                        next.push(w);
                    }
                }
            }
        }
        frontier = next;
    }
}

/// Node → quads CSR over `n` nodes of the quads `q` with `keep(q)`: the quads around `v` are
/// `adj[start[v]..start[v + 1]]`; returns `(start, adj)`.
pub(crate) fn csr(
    n: usize,
    quads: &[[u32; 4]],
    keep: impl Fn(usize) -> bool,
) -> (Vec<u32>, Vec<u32>) {
    let mut start = vec![0u32; n + 1];
    for (q, quad) in quads.iter().enumerate() {
        if keep(q) {
            for &v in quad {
                start[v as usize + 1] += 1;
            }
        }
    }
    for i in 0..n {
        start[i + 1] += start[i];
    }
    let mut fill = start.clone();
    let mut adj = vec![0u32; start[n] as usize];
    for (q, quad) in quads.iter().enumerate() {
        if keep(q) {
            for &v in quad {
                adj[fill[v as usize] as usize] = q as u32;
                fill[v as usize] += 1;
            }
        }
    }
    (start, adj)
}

/// Most quads a [`StarEval`] holds; larger stars use [`Local::key_with`].
pub(crate) const STAR_MAX: usize = 12;

/// Node `v`'s star frozen for evaluating many trial positions of `v` (every other node stays
/// put): per quad the three other corners (in the quad's order after `v`), the reference
/// normal, and the cotangent term of the corner opposite `v`, which does not depend on `v`.
/// Gives the same keys as [`Local::key_with`] with a quarter fewer corners and no gathers;
/// stars it cannot hold (see [`StarEval::new`]) are evaluated through [`Local::key_with`].
pub(crate) struct StarEval<'a> {
    l: &'a Local,
    v: u32,
    fast: bool,
    len: usize,
    pts: [[DVec3; 3]; STAR_MAX],
    nrm: [DVec3; STAR_MAX],
    /// |a·b| / (n·(a×b)) at the opposite corner, or −1 when that corner is not valid.
    opp: [f64; STAR_MAX],
    /// The star holds a hopeless quad (left out of the keys, see [`StarEval::keeps_valid`]).
    has_hopeless: bool,
}

impl<'a> StarEval<'a> {
    /// The star of `v` without its hopeless quads; the slow path (every quad) when it has
    /// more than [`STAR_MAX`] quads or `v` appears twice in one of them. Needs current quad
    /// normals.
    pub fn new(l: &'a Local, v: u32) -> Self {
        let star = l.star(v);
        let mut e = StarEval {
            l,
            v,
            fast: false,
            len: star.len(),
            pts: [[DVec3::ZERO; 3]; STAR_MAX],
            nrm: [DVec3::ZERO; STAR_MAX],
            opp: [0.0; STAR_MAX],
            has_hopeless: star
                .iter()
                .any(|&q| l.hopeless.get(q as usize) == Some(&true)),
        };
        if star.len() > STAR_MAX {
            return e;
        }
        let mut i = 0;
        for &q in star {
            if l.hopeless.get(q as usize) == Some(&true) {
                continue;
            }
            let Some(r) = rotate_to(&l.quads[q as usize], v) else {
                return e;
            };
            if r[1..].contains(&v) {
                return e;
            }
            let [b, c, d] = [r[1], r[2], r[3]].map(|w| l.pos[w as usize]);
            let n = l.qn(q);
            let (x, y) = (d - c, b - c);
            let s = n.dot(x.cross(y));
            e.pts[i] = [b, c, d];
            e.nrm[i] = n;
            e.opp[i] = if s > 0.0 { x.dot(y).abs() / s } else { -1.0 };
            i += 1;
        }
        e.len = i;
        e.fast = true;
        e
    }

    /// The largest |cot α| over the corners of star quad `i` with `v` at `p` (the key is
    /// 1 / (1 + that)), or a negative number when some corner does not turn positively (or
    /// on the slow path).
    #[inline]
    pub fn worst_cot(&self, i: usize, p: DVec3) -> f64 {
        if !self.fast {
            return -1.0;
        }
        let [b, c, d] = self.pts[i];
        let n = self.nrm[i];
        let mut worst = self.opp[i];
        if worst >= 0.0 {
            // corners at v, b, d (same edge vectors as `shape_key` on [v, b, c, d])
            for (a, e) in [(b - p, d - p), (c - b, p - b), (p - d, c - d)] {
                let s = n.dot(a.cross(e));
                if s <= 0.0 {
                    return -1.0;
                }
                worst = worst.max(a.dot(e).abs() / s);
            }
        }
        worst
    }

    /// [`StarEval::worst_cot`] of star quad `i` at eight positions of `v` at once
    /// (branch-free, the same arithmetic per position; needs the fast path).
    #[inline]
    pub fn worst_cot8(&self, i: usize, ps: &[DVec3; 8]) -> [f64; 8] {
        let [b, c, d] = self.pts[i];
        let n = self.nrm[i];
        let opp = self.opp[i];
        let mut out = [0.0; 8];
        for (o, &p) in out.iter_mut().zip(ps) {
            let mut worst = opp;
            let mut bad = opp < 0.0;
            for (a, e) in [(b - p, d - p), (c - b, p - b), (p - d, c - d)] {
                let s = n.dot(a.cross(e));
                bad |= s <= 0.0;
                worst = worst.max(a.dot(e).abs() / s);
            }
            *o = if bad { -1.0 } else { worst };
        }
        out
    }

    /// (worst, sum) of the star's keys at each of eight positions of `v` (as
    /// [`StarEval::min_key`] and the sum in [`StarEval::min_sum_above`], same arithmetic):
    /// the eight are evaluated together on the fast path, a position where some quad is
    /// invalid is redone one quad at a time.
    pub fn min_sum8(&self, ps: &[DVec3; 8]) -> [(f64, f64); 8] {
        let mut out = [(f64::INFINITY, 0.0); 8];
        if !self.fast {
            for (o, &p) in out.iter_mut().zip(ps) {
                for i in 0..self.len {
                    let k = self.key(i, p);
                    *o = (o.0.min(k), o.1 + k);
                }
            }
            return out;
        }
        let mut bad = [false; 8];
        for i in 0..self.len {
            let c = self.worst_cot8(i, ps);
            for j in 0..8 {
                bad[j] |= c[j] < 0.0;
                let k = 1.0 / (1.0 + c[j]);
                out[j] = (out[j].0.min(k), out[j].1 + k);
            }
        }
        for j in 0..8 {
            if bad[j] {
                out[j] = (f64::INFINITY, 0.0);
                for i in 0..self.len {
                    let k = self.key(i, ps[j]);
                    out[j] = (out[j].0.min(k), out[j].1 + k);
                }
            }
        }
        out
    }

    /// [`shape_key`] of star quad `i` with `v` at `p`.
    #[inline]
    pub fn key(&self, i: usize, p: DVec3) -> f64 {
        if !self.fast {
            return self.l.key_with(self.l.star(self.v)[i], self.v, p);
        }
        let worst = self.worst_cot(i, p);
        if worst < 0.0 {
            let [b, c, d] = self.pts[i];
            return shape_key(&[p, b, c, d], self.nrm[i]);
        }
        1.0 / (1.0 + worst)
    }

    /// True when a move of `v` whose star's worst key (without hopeless quads) is `min0`
    /// at the current position must also pass [`StarEval::keeps_valid`]: the star holds a
    /// hopeless quad, or a quad below [`VALID_KEY`]. Otherwise a move that keeps every
    /// key at least `min0` keeps every quad valid.
    #[inline]
    pub fn needs_guard(&self, min0: f64) -> bool {
        self.has_hopeless || min0 < VALID_KEY
    }

    /// Validity of a move of `v` from `x0` to `p` quad by quad, hopeless quads included: a
    /// quad valid at `x0` (key at least [`VALID_KEY`]) stays so, any other quad's key does
    /// not drop. (A star-wide worst key that does not drop lets an invalid quad that
    /// improves hide a valid one turned invalid.)
    pub fn keeps_valid(&self, x0: DVec3, p: DVec3) -> bool {
        self.l.star(self.v).iter().all(|&q| {
            let k0 = self.l.key_with(q, self.v, x0);
            let k1 = self.l.key_with(q, self.v, p);
            if k0 >= VALID_KEY {
                k1 >= VALID_KEY
            } else {
                k1 >= k0
            }
        })
    }

    /// True when the star is held (see [`StarEval::new`]): [`StarEval::worst_cot`] works.
    pub fn fast(&self) -> bool {
        self.fast
    }

    /// Number of quads evaluated (the star without its hopeless quads, on the fast path).
    pub fn len(&self) -> usize {
        self.len
    }

    /// The star's worst key with `v` at `p`.
    pub fn min_key(&self, p: DVec3) -> f64 {
        (0..self.len)
            .map(|i| self.key(i, p))
            .fold(f64::INFINITY, f64::min)
    }

    /// True when no quad of the star has a key below `floor` with `v` at `p` (stops at the
    /// first that does).
    pub fn all_at_least(&self, p: DVec3, floor: f64) -> bool {
        (0..self.len).all(|i| self.key(i, p) >= floor)
    }

    /// (worst, sum) of the star's keys with `v` at `p`; `None` as soon as one key is below
    /// `floor`.
    pub fn min_sum_above(&self, p: DVec3, floor: f64) -> Option<(f64, f64)> {
        let mut min = f64::INFINITY;
        let mut sum = 0.0;
        for i in 0..self.len {
            let k = self.key(i, p);
            if k < floor {
                return None;
            }
            min = min.min(k);
            sum += k;
        }
        Some((min, sum))
    }
}

/// Smallest signed η (eq. 3) of a valid quad (the optimizer's rule, `valid`): a corner
/// within 0.09° of 0° or 180° fails.
pub(crate) const VALID_ETA: f64 = 1e-3;

/// [`VALID_ETA`] as a [`shape_key`]: `1 / (1 + cot(VALID_ETA·π/2))`.
pub(crate) const VALID_KEY: f64 = 1.568_334_083_280_948e-3;

/// A key ordered like the signed quality η (eq. 3) of the quad `p` about the unit normal
/// `n`, without trigonometry: for a valid quad (every corner turning positively) it is
/// 1 / (1 + max_k |cot α_k|) in (0, 1] (1 for a rectangle); for an invalid one it is
/// η_signed − 1 in [−2, −1]. Convert with [`key_to_eta`].
pub(crate) fn shape_key(p: &[DVec3; 4], n: DVec3) -> f64 {
    let mut worst = 0.0_f64;
    for k in 0..4 {
        let a = p[(k + 1) & 3] - p[k];
        let b = p[(k + 3) & 3] - p[k];
        let s = n.dot(a.cross(b));
        if s <= 0.0 {
            return crate::quality::eta_signed(p, n) - 1.0;
        }
        worst = worst.max(a.dot(b).abs() / s);
    }
    1.0 / (1.0 + worst)
}

/// The signed η a [`shape_key`] stands for.
#[cfg_attr(not(test), allow(dead_code))]
pub(crate) fn key_to_eta(key: f64) -> f64 {
    if key > 0.0 {
        1.0 - (1.0 / key - 1.0).atan() / std::f64::consts::FRAC_PI_2
    } else {
        key + 1.0
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// With one normal for every node, the quad normals are one cached value, the same bit
    /// for bit as each quad's own; with one node's normal tilted, one per quad again.
    #[test]
    fn quad_normals_are_cached_once_when_every_node_has_the_same() {
        use crate::optimize::cleanup::tests::local_of;
        use crate::optimize::synth;
        let m = synth::to_mesh(&synth::quad_grid(5, 5, 1.0, 1.0));
        let (_, mut l) = local_of(&m);
        let own = |l: &Local, q: u32| l.quad_normal(q).normalize_or_zero();
        l.refresh_quad_normals();
        assert!(l.qn_all.is_some() && l.qn.is_empty());
        for q in 0..l.quads.len() as u32 {
            assert_eq!(l.qn(q).to_array(), own(&l, q).to_array(), "quad {q}");
        }
        let up = l.nrm[0];
        l.nrm[7] = (up + DVec3::new(0.05, 0.0, 0.0)).normalize();
        l.refresh_quad_normals();
        assert!(l.qn_all.is_none() && l.qn.len() == l.quads.len());
        let (with, without): (Vec<u32>, Vec<u32>) =
            (0..l.quads.len() as u32).partition(|&q| l.quads[q as usize].contains(&7));
        assert!(!with.is_empty() && !without.is_empty());
        assert!(with.iter().all(|&q| l.qn(q) != l.qn(without[0])));
        for q in 0..l.quads.len() as u32 {
            assert_eq!(l.qn(q).to_array(), own(&l, q).to_array(), "quad {q}");
        }
    }

    #[test]
    fn batched_star_evaluation_matches_one_position_at_a_time() {
        use crate::optimize::cleanup::tests::local_of;
        use crate::optimize::synth;
        let mut s = synth::quad_grid(7, 7, 1.0, 1.0);
        synth::jitter(&mut s, 0.25 / 7.0, 11);
        let m = synth::to_mesh(&s);
        let (_, mut l) = local_of(&m);
        l.prepare_sweeps();
        let (mut checked, mut invalid) = (0, 0);
        for v in 0..l.pos.len() as u32 {
            if l.fixed[v as usize] {
                continue;
            }
            let star = StarEval::new(&l, v);
            assert!(star.fast());
            // trial positions up to 0.8 h away: some turn a quad over
            let x0 = l.pos[v as usize];
            let ps: [DVec3; 8] = std::array::from_fn(|k| {
                let a = k as f64 * 0.8;
                x0 + DVec3::new(a.cos(), a.sin(), 0.0) * (0.02 + 0.015 * k as f64)
            });
            let batch = star.min_sum8(&ps);
            for (j, &p) in ps.iter().enumerate() {
                let keys: Vec<f64> = (0..star.len()).map(|i| star.key(i, p)).collect();
                let min = keys.iter().copied().fold(f64::INFINITY, f64::min);
                let sum: f64 = keys.iter().sum();
                assert_eq!(batch[j], (min, sum), "node {v} trial {j}");
                assert_eq!(star.min_key(p), min);
                for (i, &k) in keys.iter().enumerate() {
                    let c = star.worst_cot8(i, &ps)[j];
                    assert_eq!(c, star.worst_cot(i, p));
                    if c >= 0.0 {
                        assert_eq!(k, 1.0 / (1.0 + c));
                    } else {
                        invalid += 1;
                        assert!(k < 0.0, "an invalid quad has a negative key");
                    }
                }
                checked += 1;
            }
        }
        assert!(
            checked > 100 && invalid > 0,
            "{checked} trials, {invalid} invalid quads"
        );
    }

    #[test]
    fn shape_key_orders_like_eta_and_converts_back() {
        let q = |pts: [[f64; 2]; 4]| pts.map(|[x, y]| DVec3::new(x, y, 0.0));
        let quads = [
            q([[0., 0.], [1., 0.], [1., 1.], [0., 1.]]),
            q([[0., 0.], [1., 0.2], [1.3, 1.1], [-0.2, 0.7]]),
            q([[0., 0.], [1., 0.], [1.5, 0.8], [0.5, 0.8]]),
            q([[0., 0.], [1., 0.], [0.5, 0.4], [0.5, 1.]]),
        ];
        let mut prev: Option<(f64, f64)> = None;
        for p in &quads {
            let e = crate::quality::eta_signed(p, DVec3::Z);
            let k = shape_key(p, DVec3::Z);
            assert!((key_to_eta(k) - e).abs() < 1e-12, "{e} {k}");
            if let Some((pe, pk)) = prev {
                assert_eq!(pe > e, pk > k);
            }
            prev = Some((e, k));
        }
    }
}

/// Quality of one surface at one moment (η by eq. 3, unsigned).
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct Stats {
    /// Number of quads.
    pub quads: usize,
    /// Worst η.
    pub eta_worst: f64,
    /// Mean η.
    pub eta_mean: f64,
    /// Free (interior) vertices.
    pub interior_vertices: usize,
    /// Percentage of interior vertices with four quads.
    pub d4_percent: f64,
}

/// Index of `v` in `quad`.
pub(crate) fn slot(quad: &[u32; 4], v: u32) -> Option<usize> {
    quad.iter().position(|&w| w == v)
}

/// `quad` rotated so that `v` comes first.
pub(crate) fn rotate_to(quad: &[u32; 4], v: u32) -> Option<[u32; 4]> {
    slot(quad, v).map(|k| {
        [
            quad[k],
            quad[(k + 1) % 4],
            quad[(k + 2) % 4],
            quad[(k + 3) % 4],
        ]
    })
}
