//! Reference solver kept as a test oracle: the same primal-dual algorithm as [`super::blossom`] but
//! growing one alternating tree at a time (simple and slow). Used by tests on mid-size graphs.
//!
//!
//! Edmonds' algorithm (1965) in the form of Kolmogorov's Blossom V (2009), one alternating tree
//! at a time:
//! 1. **Jump start** ([`Solver::init_greedy`]): `y_v = min cost at v` (costs are doubled, so
//!    this is half of the cheapest doubled cost), then each vertex in turn raises its dual to
//!    its smallest slack and takes the tight edge if both ends are still exposed.
//! 2. For each exposed vertex `r`, grow an alternating tree `T` rooted at `r` with a lazy dual
//!    change `ε_T`: the stored dual of a tree node is corrected by `+(ε_T − join)` for `+`
//!    nodes and `−(ε_T − join)` for `−` nodes. Events live in one binary heap keyed by the
//!    value of `ε_T` at which they happen:
//!    - `+` node to a node outside `T` (slack `s`): at `ε_T + s` → *grow* (outside node is a
//!      matched free node) or *augment* (outside node is another exposed vertex);
//!    - `+` to `+` inside `T` (slack `s`): at `ε_T + s/2` → *shrink* into a new blossom;
//!    - `−` blossom with dual `y`: at `ε_T + y` → *expand*.
//!
//!    Heap entries are validated when popped (lazy deletion), and re-pushed with the right key
//!    when the situation changed.
//! 3. After an augmentation the tree's duals are committed and the tree dissolves; blossoms
//!    stay (Blossom V keeps them until their dual drops to zero while `−`).
//!
//! If a tree's heap runs dry, `ε_T` is unbounded: the `−` vertices of `T` form a Tutte set
//! whose removal isolates the `|−| + 1` `+` nodes of `T` (each an odd set).
//!
//! Half-integral steps: costs are doubled, and when a `+`↔`+` slack is odd every cost, dual
//! and key is doubled again (`scale` records the factor), so all arithmetic stays in `i64`.

use super::{BlossomDual, Duals, Matching, NoPerfectMatching, MAX_ABS_COST, NONE};
use std::cmp::Reverse;
use std::collections::BinaryHeap;

const FREE: u8 = 0;
const PLUS: u8 = 1;
const MINUS: u8 = 2;
const DEAD: u8 = 3;
/// Heap ids with this bit set are "expand blossom" events, the others are edge ids.
const EXPAND: u32 = 1 << 31;

/// Solver state. Nodes `0..n` are vertices, nodes `n..` blossoms.
pub struct Solver {
    n: usize,
    /// Edge endpoints and (scaled) costs, loops removed.
    eu: Vec<u32>,
    ev: Vec<u32>,
    ec: Vec<i64>,
    /// CSR adjacency: edge ids incident to vertex `v` are `adj[adj_start[v]..adj_start[v+1]]`.
    adj_start: Vec<u32>,
    adj: Vec<u32>,
    /// `mate[v]`: matched vertex or NONE.
    mate: Vec<u32>,
    /// Per node: stored dual, blossom parent, base vertex, label, tree stamp, `ε` at join.
    y: Vec<i64>,
    parent: Vec<u32>,
    base: Vec<u32>,
    label: Vec<u8>,
    tree: Vec<u32>,
    join: Vec<i64>,
    /// For `−` nodes: the tree edge as (vertex in this node, vertex in the parent `+` node).
    tself: Vec<u32>,
    tpar: Vec<u32>,
    /// Per blossom (index `node − n`): children in cycle order starting at the base child, and
    /// the cycle edges: `cyc[i] = (a, b)` with `a` in `children[i]`, `b` in `children[i+1]`.
    children: Vec<Vec<u32>>,
    cyc: Vec<Vec<(u32, u32)>>,
    free_blossoms: Vec<u32>,
    /// Per vertex: top-level node containing it, and the sum of the duals of the nodes
    /// containing it strictly below the top level (its own dual included when not top-level).
    top: Vec<u32>,
    inner: Vec<i64>,
    heap: BinaryHeap<Reverse<(i64, u32)>>,
    eps: i64,
    cur: u32,
    tree_nodes: Vec<u32>,
    mark: Vec<u32>,
    mark_stamp: u32,
    /// Costs and duals are in units of `1/scale`.
    scale: i64,
    stack: Vec<(u32, u32)>,
    /// Statistics: number of vertices left exposed by the jump start, re-scalings.
    pub stats: Stats,
}

/// Counters describing one run (for benchmarks).
#[derive(Debug, Clone, Copy, Default)]
pub struct Stats {
    /// Exposed vertices after the jump start.
    pub exposed_after_init: usize,
    /// Number of times every cost and dual was doubled to keep duals integral.
    pub rescales: usize,
    /// Blossoms formed.
    pub shrinks: usize,
    /// Blossoms expanded.
    pub expands: usize,
    /// Grow steps.
    pub grows: usize,
}

impl Solver {
    /// Builds the solver state (CSR adjacency, doubled costs). Loops and edges with an
    /// endpoint `>= n` are dropped.
    pub fn new(n: usize, edges: &[(u32, u32, i64)]) -> Solver {
        let m = edges.len();
        let mut eu = Vec::with_capacity(m);
        let mut ev = Vec::with_capacity(m);
        let mut ec = Vec::with_capacity(m);
        let mut deg = vec![0u32; n + 1];
        for &(u, v, c) in edges {
            if u == v || u as usize >= n || v as usize >= n {
                continue;
            }
            eu.push(u);
            ev.push(v);
            ec.push(2 * c.clamp(-MAX_ABS_COST, MAX_ABS_COST));
            deg[u as usize] += 1;
            deg[v as usize] += 1;
        }
        let mut adj_start = vec![0u32; n + 1];
        for v in 0..n {
            adj_start[v + 1] = adj_start[v] + deg[v];
        }
        let mut fill = adj_start.clone();
        let mut adj = vec![0u32; adj_start[n] as usize];
        for e in 0..eu.len() {
            for x in [eu[e], ev[e]] {
                adj[fill[x as usize] as usize] = e as u32;
                fill[x as usize] += 1;
            }
        }
        Solver {
            n,
            eu,
            ev,
            ec,
            adj_start,
            adj,
            mate: vec![NONE; n],
            y: vec![0; n],
            parent: vec![NONE; n],
            base: (0..n as u32).collect(),
            label: vec![FREE; n],
            tree: vec![NONE; n],
            join: vec![0; n],
            tself: vec![NONE; n],
            tpar: vec![NONE; n],
            children: Vec::new(),
            cyc: Vec::new(),
            free_blossoms: Vec::new(),
            top: (0..n as u32).collect(),
            inner: vec![0; n],
            heap: BinaryHeap::new(),
            eps: 0,
            cur: 0,
            tree_nodes: Vec::new(),
            mark: vec![0; n],
            mark_stamp: 0,
            scale: 2,
            stack: Vec::new(),
            stats: Stats::default(),
        }
    }

    /// Runs the jump start and then the tree growth from every exposed vertex.
    pub fn run(mut self) -> Result<Matching, NoPerfectMatching> {
        self.init_greedy();
        self.solve_rest()
    }

    /// Runs without jump start (all duals start at 0); used by tests to exercise the tree
    /// growth on its own.
    pub fn run_plain(mut self) -> Result<Matching, NoPerfectMatching> {
        self.init_plain();
        self.solve_rest()
    }

    /// Feasible starting duals without any matching: `y_v` = half the cheapest doubled cost
    /// at `v`.
    pub fn init_plain(&mut self) {
        for v in 0..self.n {
            self.y[v] = self.min_incident_half(v);
        }
    }

    /// Grows a tree from every exposed vertex (after an init) and returns the result.
    pub fn solve_rest(&mut self) -> Result<Matching, NoPerfectMatching> {
        self.stats.exposed_after_init = self.mate.iter().filter(|&&m| m == NONE).count();
        for r in 0..self.n as u32 {
            if self.mate[r as usize] == NONE {
                self.grow_tree(r)?;
            }
        }
        Ok(self.result())
    }

    fn min_incident_half(&self, v: usize) -> i64 {
        let (a, b) = (self.adj_start[v] as usize, self.adj_start[v + 1] as usize);
        self.adj[a..b]
            .iter()
            .map(|&e| self.ec[e as usize] / 2)
            .min()
            .unwrap_or(0)
    }

    /// Greedy dual jump start (see module docs, step 1).
    pub fn init_greedy(&mut self) {
        let n = self.n;
        for v in 0..n {
            self.y[v] = self.min_incident_half(v);
        }
        for v in 0..n {
            let (a, b) = (self.adj_start[v] as usize, self.adj_start[v + 1] as usize);
            let mut best = i64::MAX;
            let mut best_free = NONE;
            for &e in &self.adj[a..b] {
                let e = e as usize;
                let w = if self.eu[e] as usize == v {
                    self.ev[e]
                } else {
                    self.eu[e]
                };
                let s = self.ec[e] - self.y[v] - self.y[w as usize];
                if s < best || (s == best && best_free == NONE && self.mate[w as usize] == NONE) {
                    best = s;
                    best_free = if self.mate[w as usize] == NONE {
                        w
                    } else {
                        NONE
                    };
                }
            }
            if best == i64::MAX {
                continue;
            }
            self.y[v] += best;
            if self.mate[v] == NONE && best_free != NONE {
                self.mate[v] = best_free;
                self.mate[best_free as usize] = v as u32;
            }
        }
    }

    /// Current dual of a top-level node (lazy tree correction applied).
    #[inline]
    fn ycur(&self, node: u32) -> i64 {
        let i = node as usize;
        if self.tree[i] == self.cur {
            match self.label[i] {
                PLUS => return self.y[i] + (self.eps - self.join[i]),
                MINUS => return self.y[i] - (self.eps - self.join[i]),
                _ => {}
            }
        }
        self.y[i]
    }

    #[inline]
    fn in_tree(&self, node: u32, lab: u8) -> bool {
        self.tree[node as usize] == self.cur && self.label[node as usize] == lab
    }

    /// Slack of edge `e` whose endpoints are in different top-level nodes.
    #[inline]
    fn slack(&self, e: usize) -> i64 {
        let (u, v) = (self.eu[e] as usize, self.ev[e] as usize);
        self.ec[e] - self.inner[u] - self.inner[v] - self.ycur(self.top[u]) - self.ycur(self.top[v])
    }

    /// Event time of edge `e` for the current tree, or None if it is not an event edge.
    /// May rescale (which invalidates previously computed values).
    fn edge_key(&mut self, e: usize) -> Option<i64> {
        let (tu, tv) = (self.top[self.eu[e] as usize], self.top[self.ev[e] as usize]);
        if tu == tv {
            return None;
        }
        let (pu, pv) = (self.in_tree(tu, PLUS), self.in_tree(tv, PLUS));
        if pu && pv {
            let mut s = self.slack(e);
            if s % 2 != 0 {
                self.rescale();
                s = self.slack(e);
            }
            Some(self.eps + s / 2)
        } else if pu || pv {
            let other = if pu { tv } else { tu };
            if self.tree[other as usize] == self.cur {
                return None; // `+`–`−` edge: slack does not change
            }
            Some(self.eps + self.slack(e))
        } else {
            None
        }
    }

    fn push_edge(&mut self, e: usize) {
        if let Some(k) = self.edge_key(e) {
            debug_assert!(k >= self.eps, "negative slack on edge {e}");
            self.heap.push(Reverse((k, e as u32)));
        }
    }

    /// Pushes every edge incident to a vertex of `node`.
    fn push_edges_of(&mut self, node: u32) {
        let mut verts = std::mem::take(&mut self.stack);
        verts.clear();
        self.collect_vertices(node, &mut verts);
        for &(x, _) in &verts {
            let (a, b) = (
                self.adj_start[x as usize] as usize,
                self.adj_start[x as usize + 1] as usize,
            );
            for i in a..b {
                let e = self.adj[i] as usize;
                self.push_edge(e);
            }
        }
        self.stack = verts;
    }

    /// Appends the vertices of `node` (as `(v, 0)` pairs) to `out`.
    fn collect_vertices(&self, node: u32, out: &mut Vec<(u32, u32)>) {
        let start = out.len();
        out.push((node, 0));
        let mut i = start;
        // Expand blossoms in place until only vertices remain.
        while i < out.len() {
            let x = out[i].0;
            if (x as usize) < self.n {
                i += 1;
            } else {
                let b = x as usize - self.n;
                out.swap_remove(i);
                out.extend(self.children[b].iter().map(|&c| (c, 0)));
            }
        }
    }

    /// Doubles every cost, dual and key so that a half-integral step becomes integral.
    fn rescale(&mut self) {
        self.stats.rescales += 1;
        self.scale *= 2;
        for c in &mut self.ec {
            *c *= 2;
        }
        for y in &mut self.y {
            *y *= 2;
        }
        for j in &mut self.join {
            *j *= 2;
        }
        for y in &mut self.inner {
            *y *= 2;
        }
        self.eps *= 2;
        let old = std::mem::take(&mut self.heap).into_vec();
        self.heap = old
            .into_iter()
            .map(|Reverse((k, id))| Reverse((k * 2, id)))
            .collect();
    }

    fn add_to_tree(&mut self, node: u32, lab: u8) {
        let i = node as usize;
        self.tree[i] = self.cur;
        self.label[i] = lab;
        self.join[i] = self.eps;
        self.tree_nodes.push(node);
        if lab == PLUS {
            self.push_edges_of(node);
        } else if i >= self.n {
            let k = self.eps + self.y[i];
            self.heap.push(Reverse((k, node | EXPAND)));
        }
    }

    /// Grows the tree rooted at exposed vertex `r` until an augmentation.
    fn grow_tree(&mut self, r: u32) -> Result<(), NoPerfectMatching> {
        self.cur += 1;
        self.eps = 0;
        self.heap.clear();
        self.tree_nodes.clear();
        let root = self.top[r as usize];
        self.add_to_tree(root, PLUS);
        loop {
            let Some(Reverse((key, id))) = self.heap.pop() else {
                return Err(self.stuck_witness());
            };
            if id & EXPAND != 0 {
                let b = id & !EXPAND;
                let bi = b as usize;
                if self.label[bi] == DEAD
                    || self.parent[bi] != NONE
                    || !self.in_tree(b, MINUS)
                    || self.join[bi] + self.y[bi] != key
                {
                    continue;
                }
                self.eps = key;
                self.expand(b);
                continue;
            }
            let e = id as usize;
            let Some(k2) = self.edge_key(e) else { continue };
            if k2 != key {
                // Keys were rescaled or the situation changed since the push.
                self.heap.push(Reverse((k2, id)));
                continue;
            }
            debug_assert!(key >= self.eps);
            self.eps = key;
            let (u, v) = (self.eu[e], self.ev[e]);
            let (tu, tv) = (self.top[u as usize], self.top[v as usize]);
            let (pu, pv) = (self.in_tree(tu, PLUS), self.in_tree(tv, PLUS));
            if pu && pv {
                self.shrink(u, v);
            } else {
                let (x, w) = if pu { (u, v) } else { (v, u) };
                let tw = self.top[w as usize];
                if self.mate[self.base[tw as usize] as usize] == NONE {
                    self.augment(x, w);
                    self.finish_tree();
                    return Ok(());
                }
                self.grow(x, w);
            }
        }
    }

    /// `x` in a `+` node, `w` in a matched node outside the tree.
    fn grow(&mut self, x: u32, w: u32) {
        self.stats.grows += 1;
        let tw = self.top[w as usize];
        self.tself[tw as usize] = w;
        self.tpar[tw as usize] = x;
        let mb = self.mate[self.base[tw as usize] as usize];
        let tm = self.top[mb as usize];
        self.add_to_tree(tw, MINUS);
        self.add_to_tree(tm, PLUS);
    }

    /// The `+` node above `+` node `p` (grandparent in the tree), or NONE for the root.
    fn up2(&self, p: u32) -> u32 {
        let m = self.mate[self.base[p as usize] as usize];
        if m == NONE {
            return NONE;
        }
        let tm = self.top[m as usize];
        self.top[self.tpar[tm as usize] as usize]
    }

    fn new_blossom_id(&mut self) -> u32 {
        if let Some(b) = self.free_blossoms.pop() {
            return b;
        }
        let b = self.y.len() as u32;
        self.y.push(0);
        self.parent.push(NONE);
        self.base.push(NONE);
        self.label.push(FREE);
        self.tree.push(NONE);
        self.join.push(0);
        self.tself.push(NONE);
        self.tpar.push(NONE);
        self.mark.push(0);
        self.children.push(Vec::new());
        self.cyc.push(Vec::new());
        b
    }

    /// Forms a blossom from tight `+`–`+` edge `(u, v)`.
    fn shrink(&mut self, u: u32, v: u32) {
        self.stats.shrinks += 1;
        let (tu, tv) = (self.top[u as usize], self.top[v as usize]);
        // Find the lowest common `+` ancestor by walking up alternately.
        self.mark_stamp = self.mark_stamp.wrapping_add(1);
        if self.mark_stamp == 0 {
            self.mark.iter_mut().for_each(|m| *m = 0);
            self.mark_stamp = 1;
        }
        let st = self.mark_stamp;
        self.mark[tu as usize] = st;
        self.mark[tv as usize] = st;
        let (mut a, mut b) = (tu, tv);
        let lca = loop {
            if a != NONE {
                a = self.up2(a);
                if a != NONE {
                    if self.mark[a as usize] == st {
                        break a;
                    }
                    self.mark[a as usize] = st;
                }
            }
            if b != NONE {
                b = self.up2(b);
                if b != NONE {
                    if self.mark[b as usize] == st {
                        break b;
                    }
                    self.mark[b as usize] = st;
                }
            }
        };
        // Cycle: lca, (down to tu), tu, tv, (up to lca).
        let mut path_u: Vec<(u32, (u32, u32))> = Vec::new(); // (node, edge to next node up)
        let mut p = tu;
        while p != lca {
            let m = self.mate[self.base[p as usize] as usize];
            let tm = self.top[m as usize];
            path_u.push((p, (self.base[p as usize], m)));
            let (ms, mp) = (self.tself[tm as usize], self.tpar[tm as usize]);
            path_u.push((tm, (ms, mp)));
            p = self.top[mp as usize];
        }
        let mut path_v: Vec<(u32, (u32, u32))> = Vec::new();
        let mut p = tv;
        while p != lca {
            let m = self.mate[self.base[p as usize] as usize];
            let tm = self.top[m as usize];
            path_v.push((p, (self.base[p as usize], m)));
            let (ms, mp) = (self.tself[tm as usize], self.tpar[tm as usize]);
            path_v.push((tm, (ms, mp)));
            p = self.top[mp as usize];
        }
        let b = self.new_blossom_id();
        let bi = b as usize - self.n;
        let mut ch = std::mem::take(&mut self.children[bi]);
        let mut cy = std::mem::take(&mut self.cyc[bi]);
        ch.clear();
        cy.clear();
        ch.push(lca);
        // Going down path_u in reverse: edge from the node above to this node is the
        // reversed "edge to next node up" of this node.
        for &(node, (a_in, b_up)) in path_u.iter().rev() {
            cy.push((b_up, a_in));
            ch.push(node);
        }
        cy.push((u, v));
        for &(node, (a_in, b_up)) in path_v.iter() {
            ch.push(node);
            cy.push((a_in, b_up));
        }
        let _ = path_u;
        debug_assert_eq!(ch.len(), cy.len());
        debug_assert!(ch.len() % 2 == 1);
        // Commit children duals, update top/inner.
        let mut verts = std::mem::take(&mut self.stack);
        let mut was_minus: Vec<u32> = Vec::new();
        for &c in &ch {
            let yc = self.ycur(c);
            if self.label[c as usize] == MINUS {
                was_minus.push(c);
            }
            self.y[c as usize] = yc;
            self.parent[c as usize] = b;
            verts.clear();
            self.collect_vertices(c, &mut verts);
            for &(x, _) in &verts {
                self.inner[x as usize] += yc;
                self.top[x as usize] = b;
            }
        }
        self.stack = verts;
        let bn = b as usize;
        self.y[bn] = 0;
        self.parent[bn] = NONE;
        self.base[bn] = self.base[lca as usize];
        self.label[bn] = PLUS;
        self.tree[bn] = self.cur;
        self.join[bn] = self.eps;
        self.tree_nodes.push(b);
        self.children[bi] = ch;
        self.cyc[bi] = cy;
        for c in was_minus {
            self.push_edges_of(c);
        }
    }

    /// Index of the child of blossom `b` that contains vertex `x`.
    fn child_index(&self, b: u32, x: u32) -> usize {
        let mut c = x;
        while self.parent[c as usize] != b {
            c = self.parent[c as usize];
        }
        let bi = b as usize - self.n;
        self.children[bi].iter().position(|&k| k == c).unwrap_or(0)
    }

    /// Expands `−` blossom `b` whose dual reached zero.
    fn expand(&mut self, b: u32) {
        self.stats.expands += 1;
        let bi = b as usize - self.n;
        let bn = b as usize;
        let (ts, tp) = (self.tself[bn], self.tpar[bn]);
        let j = self.child_index(b, ts);
        let ch = std::mem::take(&mut self.children[bi]);
        let cy = std::mem::take(&mut self.cyc[bi]);
        let k = ch.len();
        let mut verts = std::mem::take(&mut self.stack);
        for &c in &ch {
            self.parent[c as usize] = NONE;
            self.tree[c as usize] = NONE;
            self.label[c as usize] = FREE;
            let yc = self.y[c as usize];
            verts.clear();
            self.collect_vertices(c, &mut verts);
            for &(x, _) in &verts {
                self.inner[x as usize] -= yc;
                self.top[x as usize] = c;
            }
        }
        self.stack = verts;
        self.label[bn] = DEAD;
        self.tree[bn] = NONE;
        self.free_blossoms.push(b);
        // Path from ch[j] to ch[0] of even length; its nodes go to the tree.
        let mut path: Vec<(u32, u8, u32, u32)> = Vec::new(); // node, label, tself, tpar
        path.push((ch[j], MINUS, ts, tp));
        if j.is_multiple_of(2) {
            let mut i = j;
            while i > 0 {
                // ch[i-1] is `+` (matched to ch[i]), ch[i-2] is `−` with tree edge cyc[i-2].
                path.push((ch[i - 1], PLUS, NONE, NONE));
                let (a, bb) = cy[i - 2];
                path.push((ch[i - 2], MINUS, a, bb));
                i -= 2;
            }
        } else {
            let mut i = j;
            while i != 0 {
                path.push((ch[(i + 1) % k], PLUS, NONE, NONE));
                let (a, bb) = cy[(i + 1) % k];
                path.push((ch[(i + 2) % k], MINUS, bb, a));
                i = (i + 2) % k;
            }
        }
        let mut on_path = vec![false; k];
        if j.is_multiple_of(2) {
            for flag in on_path.iter_mut().take(j + 1) {
                *flag = true;
            }
        } else {
            for (i, flag) in on_path.iter_mut().enumerate() {
                *flag = i >= j || i == 0;
            }
        }
        for &(node, lab, s, p) in &path {
            if lab == MINUS {
                self.tself[node as usize] = s;
                self.tpar[node as usize] = p;
            }
        }
        for &(node, lab, _, _) in &path {
            self.add_to_tree(node, lab);
        }
        // Off-path children become free: edges from tree `+` nodes into them are events now.
        for (i, &c) in ch.iter().enumerate() {
            if !on_path[i] {
                self.push_edges_of(c);
            }
        }
        // Recycle vectors.
        let mut ch = ch;
        let mut cy = cy;
        ch.clear();
        cy.clear();
        self.children[bi] = ch;
        self.cyc[bi] = cy;
    }

    /// Augments along the tree path from `+` vertex `x` to the root and the edge `x`–`w`,
    /// `w` in an exposed node outside the tree.
    fn augment(&mut self, x: u32, w: u32) {
        let tw = self.top[w as usize];
        self.rebase(tw, w);
        self.mate[w as usize] = x;
        let (mut node, mut xv, mut partner) = (self.top[x as usize], x, w);
        loop {
            let ext = self.mate[self.base[node as usize] as usize];
            self.rebase(node, xv);
            self.mate[xv as usize] = partner;
            if ext == NONE {
                break;
            }
            let m = self.top[ext as usize];
            let (ms, mp) = (self.tself[m as usize], self.tpar[m as usize]);
            self.rebase(m, ms);
            self.mate[ms as usize] = mp;
            node = self.top[mp as usize];
            xv = mp;
            partner = ms;
        }
    }

    /// Makes vertex `x` the base of `node` (and of every blossom inside it that contains
    /// `x`), re-matching the cycles; the caller sets `mate[x]`.
    fn rebase(&mut self, node: u32, x: u32) {
        let mut work = std::mem::take(&mut self.stack);
        work.clear();
        work.push((node, x));
        while let Some((b, x)) = work.pop() {
            if (b as usize) < self.n {
                continue;
            }
            let bi = b as usize - self.n;
            let j = self.child_index(b, x);
            let cj = self.children[bi][j];
            work.push((cj, x));
            let k = self.children[bi].len();
            if j.is_multiple_of(2) {
                // Pairs (ch[i-1], ch[i-2]) via cyc[i-2] for i = j, j-2, ..., 2.
                let mut i = j;
                while i > 0 {
                    let (a, bb) = self.cyc[bi][i - 2];
                    self.mate[a as usize] = bb;
                    self.mate[bb as usize] = a;
                    let (ca, cb) = (self.children[bi][i - 2], self.children[bi][i - 1]);
                    work.push((ca, a));
                    work.push((cb, bb));
                    i -= 2;
                }
            } else {
                // Pairs via cyc[i+1] for i = j, j+2, ..., k-2.
                let mut i = j;
                while i != 0 {
                    let (a, bb) = self.cyc[bi][(i + 1) % k];
                    self.mate[a as usize] = bb;
                    self.mate[bb as usize] = a;
                    let (ca, cb) = (
                        self.children[bi][(i + 1) % k],
                        self.children[bi][(i + 2) % k],
                    );
                    work.push((ca, a));
                    work.push((cb, bb));
                    i = (i + 2) % k;
                }
            }
            self.children[bi].rotate_left(j);
            self.cyc[bi].rotate_left(j);
            self.base[b as usize] = x;
        }
        self.stack = work;
    }

    /// Commits the lazy duals of the finished tree.
    fn finish_tree(&mut self) {
        let nodes = std::mem::take(&mut self.tree_nodes);
        for &p in &nodes {
            let i = p as usize;
            if self.parent[i] == NONE && self.label[i] != DEAD && self.tree[i] == self.cur {
                self.y[i] = self.ycur(p);
                self.label[i] = FREE;
            }
        }
        self.tree_nodes = nodes;
        self.tree_nodes.clear();
    }

    /// Tutte witness of a stuck tree: `U` = vertices of the `−` nodes (all single vertices:
    /// a `−` blossom always has a pending expand event), odd components = the `+` nodes.
    fn stuck_witness(&mut self) -> NoPerfectMatching {
        let mut witness = Vec::new();
        let mut odd = Vec::new();
        let nodes = std::mem::take(&mut self.tree_nodes);
        let mut verts = Vec::new();
        for &p in &nodes {
            let i = p as usize;
            if self.parent[i] != NONE || self.label[i] == DEAD || self.tree[i] != self.cur {
                continue;
            }
            verts.clear();
            self.collect_vertices(p, &mut verts);
            let vs: Vec<u32> = verts.iter().map(|&(x, _)| x).collect();
            if self.label[i] == MINUS {
                witness.extend(vs);
            } else if self.label[i] == PLUS {
                odd.push(vs);
            }
        }
        NoPerfectMatching {
            witness,
            odd_components: odd,
        }
    }

    /// Builds the public result: mates, cost, duals in the laminar-forest form.
    #[allow(clippy::needless_range_loop)]
    fn result(&self) -> Matching {
        let n = self.n;
        // Cost: cheapest input edge for each matched pair.
        let mut best = vec![i64::MAX; n];
        for e in 0..self.eu.len() {
            let (u, v) = (self.eu[e] as usize, self.ev[e] as usize);
            if self.mate[u] == v as u32 {
                let c = self.ec[e];
                best[u] = best[u].min(c);
                best[v] = best[v].min(c);
            }
        }
        let unit = self.scale;
        let mut cost: i64 = 0;
        for v in 0..n {
            if (self.mate[v] as usize) > v && best[v] != i64::MAX {
                cost += best[v] / unit;
            }
        }
        // Blossoms alive: renumber.
        let total = self.y.len();
        let mut id = vec![NONE; total];
        let mut blossoms = Vec::new();
        for b in n..total {
            if self.label[b] != DEAD {
                id[b] = blossoms.len() as u32;
                blossoms.push(BlossomDual {
                    parent: NONE,
                    dual: self.y[b],
                });
            }
        }
        for b in n..total {
            if id[b] != NONE && self.parent[b] != NONE {
                blossoms[id[b] as usize].parent = id[self.parent[b] as usize];
            }
        }
        let vertex_blossom = (0..n)
            .map(|v| {
                let p = self.parent[v];
                if p == NONE {
                    NONE
                } else {
                    id[p as usize]
                }
            })
            .collect();
        Matching {
            mate: self.mate.clone(),
            cost,
            duals: Duals {
                scale: self.scale,
                vertex: self.y[..n].to_vec(),
                blossoms,
                vertex_blossom,
            },
        }
    }
}
