//! The forest: the trees left after the single-tree searches (of the fractional start and
//! of the main phase) grow together, so that far-apart trees meet half-way; every tree `T`
//! has its own dual change `ε_T` (Kolmogorov 2009, Sec. 4, "variable δ", connected-components
//! rule).
//!
//! Lazy duals as in a single-tree search, but per tree: a `+` node of `T` stores `y − ε_T`, a
//! `−` node `y + ε_T` ([`Solver::off`]). Queues:
//! - per tree, a monotone radix heap of the events that involve `T` alone, keyed by the
//!   value of `ε_T` at which they happen (`(time << 1) | flag`; the flag is clear only for
//!   `+`–`+` edges, so that at equal times they come first): `+` node to a free node (grow,
//!   or augment into an exposed/half-matched node), `+`–`+` inside `T` (shrink, or close an
//!   odd cycle in the fractional phase), `−` blossom whose dual reaches zero (expand);
//! - per pair of trees `{A, B}` that have met (found through a short per-tree list), three
//!   binary heaps keyed by the part of the slack that does not move: `(+A, +B)` edges (slack `k − ε_A − ε_B`; zero slack is an
//!   augmentation), `(+A, −B)` edges (slack `k − ε_A + ε_B`) and `(+B, −A)` edges.
//!
//! Entries are validated when their time comes and re-routed when the situation of the edge
//! changed (lazy deletion). An edge to a node that has since become `−` of another tree stays
//! in its tree heap as a grow event until it surfaces; the bound it gives (`δ_A ≤ slack`) is
//! stricter than the true one (`δ_A − δ_B ≤ slack`), so it only delays `A`, and it is moved
//! to its pair heap when it surfaces. The dual updates therefore read the raw heap minima
//! (a stale entry only restricts): `(+, +)` pair entries are never stale while both trees
//! live, and a `(+, −)` minimum is validated only when it is tight (it would join two
//! trees); if that re-routes an entry, the bounds are gathered again.
//!
//! Rounds: first every tree with a tight event (a worklist filled by the dual update and by
//! pushes whose time is now) acts on all of them (primal steps); then one dual update picks
//! every tree's `δ_T ≥ 0`:
//! 1. trees joined by a tight `(+, −)` edge form components that share one `δ` (then a
//!    tight `(+A, −B)` edge stays tight);
//! 2. components are processed in turn, trees not processed yet counting as `δ = 0`; a
//!    component takes the largest `δ` allowed by its trees' own events, by `(+, +)` edges
//!    inside it (`2δ ≤ slack`), by `(+, +)` edges to processed components
//!    (`δ ≤ slack − δ'`) or unprocessed ones (`δ ≤ slack`), and by `(+ of it, −)` edges
//!    (`δ ≤ slack + δ'`). An edge from a `+` node of a processed component into a `−` node
//!    of this one is satisfied whatever `δ ≥ 0` is, since that component assumed `δ = 0`
//!    here. The first component always gets `δ > 0`, so every round makes progress;
//! 3. a component with no bound at all is stuck: its `−` vertices are a Tutte set (main
//!    phase: no perfect matching), or it is dissolved and left to the main phase
//!    (fractional phase).
//!
//! An augmentation dissolves its two trees: their pair heaps die, and the edges from the
//! other trees' `+` nodes into the freed nodes (the `(+, +)` and `(+, −)` entries of those
//! pairs) are pushed again as grow events.

use super::fractional::Cycles;
use super::{Event, NoPerfectMatching, RadixHeap, Solver, EXPAND, MINUS, NONE, PLUS};
use std::cmp::Reverse;
use std::collections::BinaryHeap;

/// A heap entry: key, then the edge (or an expand event: `u` = blossom `| EXPAND`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord)]
struct Entry {
    key: i64,
    u: u32,
    v: u32,
    c: i64,
}

impl Entry {
    fn event(self) -> Event {
        Event {
            c: self.c,
            u: self.u,
            v: self.v,
        }
    }
}

type Heap = BinaryHeap<Reverse<Entry>>;

/// A tree's own events: a monotone radix heap (keys never go below `2 ε_T`, and an entry is
/// popped only when its time has come, so the last popped key never exceeds later pushes
/// except for the flag bit of a tie) with a cached minimum key for the dual updates.
#[derive(Default)]
struct TreeHeap {
    h: RadixHeap<Event>,
    /// The minimum key when `known` (None: empty).
    min: Option<u64>,
    known: bool,
}

impl TreeHeap {
    fn push(&mut self, key: i64, e: Event) {
        let key = (key as u64).max(self.h.floor());
        self.h.push(key, e);
        if self.known {
            self.min = Some(self.min.map_or(key, |m| m.min(key)));
        }
    }

    fn min_key(&mut self) -> Option<i64> {
        if !self.known {
            self.min = self.h.peek_min();
            self.known = true;
        }
        self.min.map(|m| m as i64)
    }

    /// Pops an entry of minimum key if that key is at most `limit`.
    fn pop_le(&mut self, limit: i64) -> Option<(i64, Event)> {
        if self.min_key()? > limit {
            return None;
        }
        self.known = false;
        self.h.pop().map(|(k, e)| (k as i64, e))
    }
}

/// Pair heap of `(+a, +b)` edges.
const PP: usize = 0;

/// Two trees that have met: heaps of `(+a, +b)`, `(+a, −b)` and `(+b, −a)` edges, keyed by
/// the constant part of the slack; `min` holds their current minimum slacks during a dual
/// update.
#[derive(Default)]
struct Pair {
    a: u32,
    b: u32,
    h: [Heap; 3],
    min: [i64; 3],
}

/// Queues and scratch arrays of the variable-δ forest.
#[derive(Default)]
pub struct VarQueues {
    tree: Vec<TreeHeap>,
    pairs: Vec<Pair>,
    /// Per tree: `(other tree, pair)` for every live pair it belongs to.
    tpairs: Vec<Vec<(u32, u32)>>,
    alive: Vec<u32>,
    dead: Vec<bool>,
    /// Dual-update scratch, per tree: union-find parent, own bound, component list link,
    /// component head, component processed and its `δ`.
    uf: Vec<u32>,
    own: Vec<i64>,
    next: Vec<u32>,
    head: Vec<u32>,
    cdone: Vec<bool>,
    cdelta: Vec<i64>,
    /// Trees that may have a tight event (a stack, and membership flags).
    dirty: Vec<u32>,
    is_dirty: Vec<bool>,
}

/// Where an edge belongs now.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Dest {
    Drop,
    Tree(u32, i64),
    Pair(u32, usize, i64),
}

/// Which phase runs the forest: the main phase (blossoms), or the fractional jump start
/// (odd cycles of half-edges instead of blossoms).
pub(super) enum Kind<'a> {
    Main,
    Frac(&'a mut Cycles),
}

/// Outcome of a dual update.
enum DualStep {
    /// Some trees moved.
    Moved,
    /// A tight event was found (or everything was rescaled): back to the primal steps.
    Retry,
    /// These trees can move without bound.
    Stuck(Vec<u32>),
}

impl Solver {
    /// Main phase, variable δ: a tree per exposed vertex.
    pub(super) fn run_forest_var(&mut self) -> Result<(), NoPerfectMatching> {
        let roots: Vec<u32> = (0..self.n as u32)
            .filter(|&v| self.mate[v as usize] == NONE)
            .map(|v| self.top_of(v))
            .collect();
        self.stats.forest_trees[1] = roots.len();
        self.var_forest(&roots, &mut Kind::Main)
    }

    /// Fractional phase, variable δ: a tree per exposed vertex not on a half-matched cycle.
    pub(super) fn fractional_global_var(&mut self, cy: &mut Cycles) {
        let roots: Vec<u32> = (0..self.n as u32)
            .filter(|&v| self.mate[v as usize] == NONE && cy.id[v as usize] == NONE)
            .collect();
        self.stats.forest_trees[0] = roots.len();
        // Stuck trees are dissolved inside and left to the main phase: never an error.
        let _ = self.var_forest(&roots, &mut Kind::Frac(cy));
    }

    fn var_forest(&mut self, roots: &[u32], kind: &mut Kind) -> Result<(), NoPerfectMatching> {
        self.eps = 0;
        self.heap.clear();
        let k = roots.len();
        self.new_trees(k);
        let q = &mut self.var;
        q.tree = (0..k).map(|_| TreeHeap::default()).collect();
        q.pairs.clear();
        q.tpairs = vec![Vec::new(); k];
        q.alive = (0..k as u32).collect();
        q.dead = vec![false; k];
        q.uf = vec![NONE; k];
        q.own = vec![0; k];
        q.next = vec![NONE; k];
        q.head = vec![NONE; k];
        q.cdone = vec![false; k];
        q.cdelta = vec![0; k];
        q.dirty = (0..k as u32).rev().collect();
        q.is_dirty = vec![true; k];
        self.var_on = true;
        for (t, &r) in roots.iter().enumerate() {
            self.make_root(r, t as u32);
        }
        for &r in roots {
            self.push_edges_of(r);
        }
        let res = loop {
            while let Some(t) = self.var.dirty.pop() {
                self.var.is_dirty[t as usize] = false;
                if !self.var.dead[t as usize] {
                    self.var_primal_tree(t, kind);
                }
            }
            let dead = std::mem::take(&mut self.var.dead);
            self.var.alive.retain(|&t| !dead[t as usize]);
            self.var.dead = dead;
            let phase = if matches!(kind, Kind::Main) { 3 } else { 1 };
            self.tick(phase, k - self.var.alive.len(), k);
            if self.var.alive.is_empty() {
                break Ok(());
            }
            match self.var_dual() {
                DualStep::Moved | DualStep::Retry => {}
                DualStep::Stuck(trees) => {
                    self.stats.var_stuck += 1;
                    match kind {
                        Kind::Main => {
                            let mut inside = vec![false; k];
                            for &t in &trees {
                                inside[t as usize] = true;
                            }
                            break Err(self.stuck_witness_in(&|t| inside[t as usize]));
                        }
                        Kind::Frac(_) => {
                            // Left to the main phase; their alternating structure is a matching.
                            for &t in &trees {
                                self.var_dissolve(t);
                            }
                            self.push_freed();
                        }
                    }
                }
            }
        };
        self.var_on = false;
        self.freed.clear();
        let q = &mut self.var;
        q.tree = Vec::new();
        q.pairs = Vec::new();
        q.tpairs = Vec::new();
        res
    }

    /// Acts on every tight event of tree `t` (its own heap, then its `(+, +)` pair heaps).
    fn var_primal_tree(&mut self, t: u32, kind: &mut Kind) {
        let ti = t as usize;
        while let Some((key, ev)) = self.var.tree[ti].pop_le((self.teps[ti] << 1) | 1) {
            // Its time has come: validate (it may be stale), then act.
            self.stats.pops += 1;
            if ev.u & EXPAND != 0 {
                let b = (ev.u & !EXPAND) as usize;
                let nd = &self.nd[b];
                if nd.label == MINUS && nd.parent == NONE && nd.tree == t && nd.y == key >> 1 {
                    self.expand(ev.u & !EXPAND);
                }
                continue;
            }
            let d = self.route(ev);
            match d {
                Dest::Tree(t2, k2) if t2 == t && k2 >> 1 == self.teps[ti] => {}
                _ => {
                    self.place(ev, d);
                    continue;
                }
            }
            if self.tree_event(t, ev.u, ev.v, kind) {
                self.push_freed();
                return;
            }
        }
        // `(+, +)` entries never go stale while both trees live (a `+` node stays `+` in
        // its tree), so the raw minimum is exact.
        let et = self.teps[ti];
        let found = self.var.tpairs[ti].iter().find_map(|&(o, p)| {
            let &Reverse(en) = self.var.pairs[p as usize].h[PP].peek()?;
            (en.key - et - self.teps[o as usize] == 0).then_some(en)
        });
        if let Some(en) = found {
            let (a, b) = (self.tree_of(en.u), self.tree_of(en.v));
            debug_assert!(a != b && a != NONE && b != NONE);
            self.stats.augments += matches!(kind, Kind::Main) as usize;
            self.stats.var_pair_augments += 1;
            self.augment_path(en.u, en.v);
            self.augment_path(en.v, en.u);
            self.var_dissolve(a);
            self.var_dissolve(b);
            self.push_freed();
        }
    }

    /// Queues tree `t` for the primal steps.
    fn mark_dirty(&mut self, t: u32) {
        if !self.var.is_dirty[t as usize] {
            self.var.is_dirty[t as usize] = true;
            self.var.dirty.push(t);
        }
    }

    fn tree_of(&self, x: u32) -> u32 {
        self.nd[self.top_of(x) as usize].tree
    }

    /// A tight event of tree `t`'s own heap; true if `t` was dissolved.
    fn tree_event(&mut self, t: u32, u: u32, v: u32, kind: &mut Kind) -> bool {
        let (tu, tv) = (self.top_of(u), self.top_of(v));
        let (pu, pv) = (self.in_tree(tu, PLUS), self.in_tree(tv, PLUS));
        if pu && pv {
            match kind {
                Kind::Main => {
                    self.shrink(u, v);
                    return false;
                }
                Kind::Frac(cy) => {
                    self.close_cycle(cy, u, v);
                    self.var_dissolve(t);
                    return true;
                }
            }
        }
        let (x, w, tw) = if pu { (u, v, tv) } else { (v, u, tu) };
        if let Kind::Frac(cy) = kind {
            // On a half-matched cycle (no mate; `mate` first, it is read anyway).
            if self.mate[w as usize] == NONE && cy.id[w as usize] != NONE {
                self.augment_into_cycle(cy, x, w);
                self.var_dissolve(t);
                return true;
            }
        }
        if self.mate[self.nd[tw as usize].base as usize] == NONE {
            // An exposed node outside the trees.
            self.augment_path(x, w);
            self.rebase(tw, w);
            self.mate[w as usize] = x;
            self.var_dissolve(t);
            return true;
        }
        self.grow(x, w);
        false
    }

    /// Puts edge `e` where it belongs now.
    pub(super) fn var_push_edge(&mut self, e: Event) {
        let d = self.route(e);
        self.place(e, d);
    }

    /// Where edge `e` belongs now (may rescale).
    fn route(&mut self, e: Event) -> Dest {
        let (tu, iu) = self.find(e.u);
        let (tv, iv) = self.find(e.v);
        if tu == tv {
            return Dest::Drop;
        }
        let (pu, pv) = (self.in_tree(tu, PLUS), self.in_tree(tv, PLUS));
        if !pu && !pv {
            return Dest::Drop;
        }
        let s = e.c * self.mult - iu - iv - self.ycur(tu) - self.ycur(tv);
        debug_assert!(s >= 0, "negative slack on edge {e:?}");
        let (ta, tb) = (self.nd[tu as usize].tree, self.nd[tv as usize].tree);
        if pu && pv {
            if ta == tb {
                if s % 2 != 0 {
                    self.rescale();
                    return self.route(e);
                }
                return Dest::Tree(ta, (self.teps[ta as usize] + s / 2) << 1);
            }
            let p = self.pair_of(ta, tb);
            return Dest::Pair(p, PP, s + self.teps[ta as usize] + self.teps[tb as usize]);
        }
        let (tp, to) = if pu { (ta, tb) } else { (tb, ta) };
        if to != NONE {
            if to == tp {
                return Dest::Drop;
            }
            let p = self.pair_of(tp, to);
            let which = if self.var.pairs[p as usize].a == tp {
                1
            } else {
                2
            };
            return Dest::Pair(
                p,
                which,
                s + self.teps[tp as usize] - self.teps[to as usize],
            );
        }
        // Flag bit set whether the free node is matched (grow) or not (augment): unlike the
        // single-tree heap, no tie-break for tree-ending events here, which saves reading
        // `mate` of the far node for every edge (a cache miss).
        Dest::Tree(tp, ((self.teps[tp as usize] + s) << 1) | 1)
    }

    fn place(&mut self, e: Event, d: Dest) {
        let en = |key| {
            Reverse(Entry {
                key,
                u: e.u,
                v: e.v,
                c: e.c,
            })
        };
        match d {
            Dest::Drop => {}
            Dest::Tree(t, key) => {
                debug_assert!(key >> 1 >= self.teps[t as usize]);
                self.stats.pushes += 1;
                self.var_push_tree(t, key, e);
            }
            Dest::Pair(p, w, k) => {
                self.stats.pushes += 1;
                self.var.pairs[p as usize].h[w].push(en(k));
                if w == PP && self.pair_slack(p, PP, k) == 0 {
                    self.mark_dirty(self.var.pairs[p as usize].a);
                }
            }
        }
    }

    /// Pushes an event into tree `t`'s heap (marking the tree when it is due now).
    pub(super) fn var_push_tree(&mut self, t: u32, key: i64, ev: Event) {
        self.var.tree[t as usize].push(key, ev);
        if key >> 1 == self.teps[t as usize] {
            self.mark_dirty(t);
        }
    }

    /// The pair of trees `{a, b}`, created if they had not met.
    fn pair_of(&mut self, a: u32, b: u32) -> u32 {
        if let Some(&(_, p)) = self.var.tpairs[a as usize].iter().find(|&&(o, _)| o == b) {
            return p;
        }
        let q = &mut self.var;
        let p = q.pairs.len() as u32;
        q.pairs.push(Pair {
            a,
            b,
            ..Pair::default()
        });
        q.tpairs[a as usize].push((b, p));
        q.tpairs[b as usize].push((a, p));
        p
    }

    /// Current slack of a pair-heap entry of key `k` in heap `w` of pair `p`.
    fn pair_slack(&self, p: u32, w: usize, k: i64) -> i64 {
        let (a, b) = (self.var.pairs[p as usize].a, self.var.pairs[p as usize].b);
        let (ea, eb) = (self.teps[a as usize], self.teps[b as usize]);
        match w {
            PP => k - ea - eb,
            1 => k - ea + eb,
            _ => k - eb + ea,
        }
    }

    /// Validates the top of heap `w` of pair `p` (re-routing stale entries) and returns its
    /// current slack.
    fn clean_pair(&mut self, p: u32, w: usize) -> Option<i64> {
        loop {
            let &Reverse(en) = self.var.pairs[p as usize].h[w].peek()?;
            let r0 = self.stats.rescales;
            let d = self.route(en.event());
            if self.stats.rescales != r0 {
                continue; // keys were doubled: look again
            }
            if let Dest::Pair(p2, w2, k) = d {
                if p2 == p && w2 == w && k == en.key {
                    return Some(self.pair_slack(p, w, k));
                }
            }
            self.var.pairs[p as usize].h[w].pop();
            self.place(en.event(), d);
        }
    }

    /// Dissolves tree `t` (duals committed, nodes freed); the edges of its pairs from other
    /// trees' `+` nodes into its nodes are queued in `freed`.
    fn var_dissolve(&mut self, t: u32) {
        self.dissolve(t);
        self.var.dead[t as usize] = true;
        self.var.tree[t as usize] = TreeHeap::default();
        let pl = std::mem::take(&mut self.var.tpairs[t as usize]);
        for (o, p) in pl {
            let lst = &mut self.var.tpairs[o as usize];
            if let Some(i) = lst.iter().position(|&(_, q)| q == p) {
                lst.swap_remove(i);
            }
            let pair = &mut self.var.pairs[p as usize];
            // (+o, −t): heap 1 when o is `a`, else heap 2.
            let into_t = if pair.a == o { 1 } else { 2 };
            let hs = std::mem::take(&mut pair.h);
            for (w, h) in hs.into_iter().enumerate() {
                if w == PP || w == into_t {
                    self.freed
                        .extend(h.into_vec().into_iter().map(|Reverse(en)| en.event()));
                }
            }
        }
    }

    /// Doubles every key of the variable-δ queues (with [`Solver::rescale`]).
    pub(super) fn var_rescale(&mut self) {
        let dbl = |h: &mut Heap| {
            let mut v = std::mem::take(h).into_vec();
            for Reverse(en) in &mut v {
                en.key *= 2;
            }
            *h = BinaryHeap::from(v);
        };
        for h in &mut self.var.tree {
            h.h.double_keys_flagged();
            h.known = false;
        }
        for pair in &mut self.var.pairs {
            for h in &mut pair.h {
                dbl(h);
            }
        }
    }

    fn uf_find(&mut self, mut t: u32) -> u32 {
        while self.var.uf[t as usize] != t {
            let g = self.var.uf[self.var.uf[t as usize] as usize];
            self.var.uf[t as usize] = g;
            t = g;
        }
        t
    }

    /// One dual update (see the module doc).
    fn var_dual(&mut self) -> DualStep {
        let r0 = self.stats.rescales;
        let alive = std::mem::take(&mut self.var.alive);
        let res = self.var_dual_in(&alive, r0);
        self.var.alive = alive;
        res
    }

    fn var_dual_in(&mut self, alive: &[u32], r0: usize) -> DualStep {
        let mut retry = false;
        let pushes = self.stats.pushes;
        for &t in alive {
            let ti = t as usize;
            self.var.uf[ti] = t;
            self.var.head[ti] = NONE;
            self.var.cdone[ti] = false;
            // The raw top: a stale entry only delays this tree (its key is not later than
            // the event it stood for, and the real event has its own entry).
            self.var.own[ti] = match self.var.tree[ti].min_key() {
                Some(key) => (key >> 1) - self.teps[ti],
                None => i64::MAX,
            };
            if self.var.own[ti] <= 0 {
                retry = true;
                self.mark_dirty(t);
            }
        }
        for &t in alive {
            let ti = t as usize;
            let mut i = 0;
            while i < self.var.tpairs[ti].len() {
                let (o, p) = self.var.tpairs[ti][i];
                i += 1;
                if self.var.pairs[p as usize].a != t {
                    continue;
                }
                // Raw minima: `(+, +)` entries are never stale; a stale `(+, −)` entry only
                // restricts, and is validated when it would join two trees.
                let mut m = [i64::MAX; 3];
                for (w, mw) in m.iter_mut().enumerate() {
                    if let Some(&Reverse(en)) = self.var.pairs[p as usize].h[w].peek() {
                        *mw = self.pair_slack(p, w, en.key);
                    }
                    if w != PP && *mw == 0 {
                        *mw = self.clean_pair(p, w).unwrap_or(i64::MAX);
                    }
                }
                self.var.pairs[p as usize].min = m;
                if m[PP] == 0 {
                    retry = true;
                    self.mark_dirty(t);
                }
                if m[1] == 0 || m[2] == 0 {
                    let (ra, rb) = (self.uf_find(t), self.uf_find(o));
                    if ra != rb {
                        self.stats.var_joins += 1;
                        self.var.uf[ra as usize] = rb;
                    }
                }
            }
        }
        // A stale entry re-routed while the bounds were gathered may have landed in a heap
        // already read (or a new pair): gather again.
        if retry || self.stats.rescales != r0 || self.stats.pushes != pushes {
            return DualStep::Retry;
        }
        for &t in alive {
            let r = self.uf_find(t);
            self.var.next[t as usize] = self.var.head[r as usize];
            self.var.head[r as usize] = t;
        }
        for &t0 in alive {
            let r = self.uf_find(t0);
            if self.var.cdone[r as usize] {
                continue;
            }
            let mut d = i64::MAX;
            let mut odd = false;
            let mut x = self.var.head[r as usize];
            while x != NONE {
                d = d.min(self.var.own[x as usize]);
                for &(o, p) in &self.var.tpairs[x as usize] {
                    let ro = uf_root(&self.var.uf, o);
                    let pr = &self.var.pairs[p as usize];
                    let s_pp = pr.min[PP];
                    let s_out = if pr.a == x { pr.min[1] } else { pr.min[2] };
                    let (done, dd) = (self.var.cdone[ro as usize], self.var.cdelta[ro as usize]);
                    if s_pp != i64::MAX {
                        if ro == r {
                            odd |= s_pp % 2 != 0;
                            d = d.min(s_pp / 2);
                        } else if done {
                            d = d.min(s_pp - dd);
                        } else {
                            d = d.min(s_pp);
                        }
                    }
                    if s_out != i64::MAX && ro != r {
                        d = d.min(if done { s_out + dd } else { s_out });
                    }
                }
                x = self.var.next[x as usize];
            }
            if odd {
                // A half-integral step inside the component: double everything first.
                self.rescale();
                return DualStep::Retry;
            }
            if d == i64::MAX {
                let mut trees = Vec::new();
                let mut x = self.var.head[r as usize];
                while x != NONE {
                    trees.push(x);
                    x = self.var.next[x as usize];
                }
                return DualStep::Stuck(trees);
            }
            debug_assert!(d >= 0);
            self.var.cdone[r as usize] = true;
            self.var.cdelta[r as usize] = d;
        }
        self.stats.var_rounds += 1;
        let mut seen = None;
        let mut split = false;
        for &t in alive {
            let r = self.uf_find(t);
            let d = self.var.cdelta[r as usize];
            split |= seen.is_some_and(|s| s != d);
            seen = Some(d);
            self.teps[t as usize] += d;
            // Trees whose own next event is now, or with a `(+, +)` edge that is now tight.
            let mut tight = self.var.own[t as usize] == d;
            for &(_, p) in &self.var.tpairs[t as usize] {
                let pr = &self.var.pairs[p as usize];
                if pr.a == t && pr.min[PP] != i64::MAX {
                    let rb = uf_root(&self.var.uf, pr.b);
                    tight |= pr.min[PP] == d + self.var.cdelta[rb as usize];
                }
            }
            if tight {
                self.mark_dirty(t);
            }
        }
        self.stats.var_split_rounds += split as usize;
        DualStep::Moved
    }
}

/// Root of `t` in the union-find forest `uf` (no compression: for loops that hold other
/// borrows of the solver; [`Solver::uf_find`] compresses).
fn uf_root(uf: &[u32], mut t: u32) -> u32 {
    while uf[t as usize] != t {
        t = uf[t as usize];
    }
    t
}
