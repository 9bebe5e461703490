//! Lazy duals, slacks and the event queue of a single-tree search: heap keys, pushing a
//! node's edges, validating popped entries, and rescaling to keep every step integral.

use super::{Event, NoPerfectMatching, Solver, Tight, DEAD, EXPAND, MINUS, NONE, PLUS};

impl Solver {
    /// The next edge to become tight ([`Solver::pop_edge_event`]) with its endpoints' top
    /// blossoms and whether each is a "+" node of a tree; the Tutte witness when the heap
    /// runs dry (no perfect matching).
    #[inline]
    pub(super) fn next_tight(&mut self) -> Result<Tight, NoPerfectMatching> {
        let Some((u, v)) = self.pop_edge_event() else {
            return Err(self.stuck_witness());
        };
        let (tu, tv) = (self.top_of(u), self.top_of(v));
        Ok(Tight {
            u,
            v,
            tu,
            tv,
            pu: self.in_tree(tu, PLUS),
            pv: self.in_tree(tv, PLUS),
        })
    }

    /// Pops heap entries until an edge event happens now (see [`Solver::next_event`]) and
    /// returns its endpoints; None when the heap runs dry.
    pub(super) fn pop_edge_event(&mut self) -> Option<(u32, u32)> {
        loop {
            let (key, id) = self.heap.pop()?;
            if let Some(e) = self.next_event(key, id) {
                return Some(e);
            }
        }
    }

    /// Handles a popped heap entry common to both growth modes: expands a `−` blossom whose
    /// dual reached zero, re-pushes an edge whose event time moved, drops stale entries.
    /// Returns the edge's endpoints when an edge event happens now (`ε` advanced to it).
    pub(super) fn next_event(&mut self, key: u64, ev: Event) -> Option<(u32, u32)> {
        self.stats.pops += 1;
        if ev.u & EXPAND != 0 {
            let b = ev.u & !EXPAND;
            let bi = b as usize;
            if self.nd[bi].label == DEAD
                || self.nd[bi].parent != NONE
                || !self.in_tree(b, MINUS)
                || ((self.nd[bi].y << 1) | 1) as u64 != key
            {
                return None;
            }
            self.eps = (key >> 1) as i64;
            self.expand(b);
            return None;
        }
        let key = key as i64;
        let k2 = self.edge_key(ev)?;
        debug_assert!(k2 >> 1 >= key >> 1, "missed event on edge {ev:?}");
        if k2 >> 1 > key >> 1 {
            // Keys were rescaled or the situation changed since the push.
            self.heap.push(k2 as u64, ev);
            return None;
        }
        debug_assert!(key >> 1 >= self.eps);
        self.eps = key >> 1;
        Some((ev.u, ev.v))
    }

    /// Current dual of a top-level node (lazy tree correction applied).
    #[inline]
    pub(super) fn ycur(&self, node: u32) -> i64 {
        let i = node as usize;
        if self.nd[i].tree != NONE {
            match self.nd[i].label {
                PLUS => return self.nd[i].y + self.off(self.nd[i].tree),
                MINUS => return self.nd[i].y - self.off(self.nd[i].tree),
                _ => {}
            }
        }
        self.nd[i].y
    }

    /// The dual change of tree `t` so far: the single-tree `ε` plus the tree's own `ε_T` (one of
    /// the two is always zero: `ε_T` is used by the variable-δ forest only).
    #[inline]
    pub(super) fn off(&self, t: u32) -> i64 {
        self.eps + self.teps[t as usize]
    }

    #[inline]
    pub(super) fn in_tree(&self, node: u32, lab: u8) -> bool {
        self.nd[node as usize].tree != NONE && self.nd[node as usize].label == lab
    }

    /// Slack of edge `e` whose endpoints are in different top-level nodes.
    #[inline]
    pub(super) fn slack(&self, e: Event) -> i64 {
        let (tu, iu) = self.find(e.u);
        let (tv, iv) = self.find(e.v);
        e.c * self.mult - iu - iv - self.ycur(tu) - self.ycur(tv)
    }

    /// Heap key of edge `e`, or None if it is not an event edge: the event time `ε` shifted
    /// left by one, with bit 0 clear for events that end a tree (`+`–`+`, `+` to an exposed
    /// or half-matched vertex) and set for grows, so that among equal times the tree-ending
    /// events come first (ties are the rule on mesh graphs). May rescale.
    pub(super) fn edge_key(&mut self, e: Event) -> Option<i64> {
        let (tu, iu) = self.find(e.u);
        let (tv, iv) = self.find(e.v);
        if tu == tv {
            return None;
        }
        let (pu, pv) = (self.in_tree(tu, PLUS), self.in_tree(tv, PLUS));
        if pu && pv {
            let s = e.c * self.mult - iu - iv - self.ycur(tu) - self.ycur(tv);
            if s % 2 != 0 {
                self.rescale();
                return Some((self.eps + self.slack(e) / 2) << 1);
            }
            Some((self.eps + s / 2) << 1)
        } else if pu || pv {
            let other = if pu { tv } else { tu };
            if self.nd[other as usize].tree != NONE {
                // `+`–`−` edge of the one tree: its slack does not change while both stay.
                return None;
            }
            let grow = self.mate[self.nd[other as usize].base as usize] != NONE;
            let t = self.eps + e.c * self.mult - iu - iv - self.ycur(tu) - self.ycur(tv);
            Some((t << 1) | grow as i64)
        } else {
            None
        }
    }

    pub(super) fn push_edge(&mut self, e: Event) {
        self.stats.evals += 1;
        if self.var_on {
            self.var_push_edge(e);
            return;
        }
        if let Some(k) = self.edge_key(e) {
            debug_assert!(k >> 1 >= self.eps, "negative slack on edge {e:?}");
            self.stats.pushes += 1;
            self.heap.push(k as u64, e);
        }
    }

    /// Pushes every edge incident to a vertex of `node`.
    pub(super) fn push_edges_of(&mut self, node: u32) {
        if (node as usize) < self.n {
            self.push_vertex_edges(node);
            return;
        }
        let mut verts = std::mem::take(&mut self.stack);
        verts.clear();
        self.collect_vertices(node, &mut verts);
        for &(x, _) in &verts {
            self.push_vertex_edges(x);
        }
        self.stack = verts;
    }

    /// Pushes the edges of vertex `x` except those to its mate: whenever edges are pushed
    /// (a node becomes `+`, a `−` node joins a `+` blossom, a blossom child becomes free) the
    /// mate is in the same node, the `−` parent or an equally free node, so such an edge is
    /// never an event.
    pub(super) fn push_vertex_edges(&mut self, x: u32) {
        let m = self.mate[x as usize];
        let (a, b) = (
            self.adj_start[x as usize] as usize,
            self.adj_start[x as usize + 1] as usize,
        );
        let nx = self.nd[x as usize];
        if nx.parent == NONE && nx.tree != NONE && nx.label == PLUS {
            if self.var_on {
                self.var_push_plus_vertex_edges(x, m, a..b);
            } else {
                self.push_plus_vertex_edges(x, m, a..b);
            }
            return;
        }
        for i in a..b {
            let w = self.ed[i].v;
            if w != m {
                self.push_edge(Event {
                    c: self.cost(i),
                    u: x,
                    v: w,
                });
            }
        }
    }

    /// [`Solver::push_vertex_edges`] in a single-tree search for a top-level `+` vertex `x`
    /// (mate `m`, half-edges `range`): the keys of [`Solver::edge_key`] with `x`'s side
    /// computed once and, for a top-level far end, no blossom lookup; an edge into a blossom
    /// or needing a rescale takes the general path. Same keys, same order.
    fn push_plus_vertex_edges(&mut self, x: u32, m: u32, range: std::ops::Range<usize>) {
        let yx = self.ycur(x);
        let (eps, mult) = (self.eps, self.mult);
        for i in range {
            let w = self.ed[i].v;
            if w == m {
                continue;
            }
            let c = self.cost(i);
            let ev = Event { c, u: x, v: w };
            let nw = self.nd[w as usize];
            if nw.parent != NONE {
                self.push_edge(ev);
                continue;
            }
            let key = if nw.tree == NONE {
                // `+` to a free node: grow, or augment into an exposed one (flag clear).
                let t = eps + c * mult - yx - nw.y;
                (t << 1) | (self.mate[nw.base as usize] != NONE) as i64
            } else if nw.label == PLUS {
                // `+`–`+` inside the one tree (both lazy offsets are `ε`).
                let s = c * mult - yx - (nw.y + eps + self.teps[nw.tree as usize]);
                if s % 2 != 0 {
                    self.push_edge(ev); // rescales
                    continue;
                }
                (eps + s / 2) << 1
            } else {
                // `+`–`−` edge of the one tree: never an event.
                self.stats.evals += 1;
                continue;
            };
            debug_assert_eq!(Some(key), self.edge_key(ev), "fast key of {ev:?}");
            self.stats.evals += 1;
            self.stats.pushes += 1;
            self.heap.push(key as u64, ev);
        }
    }

    /// [`Solver::push_vertex_edges`] in the forest for a top-level `+` vertex `x` of tree
    /// `T`: an edge to a free top-level node goes to `T`'s heap as [`Solver::var_push_edge`]
    /// would put it (key `2 (ε_T + slack) + 1`), with `x`'s side computed once; the other
    /// edges take the general path.
    fn var_push_plus_vertex_edges(&mut self, x: u32, m: u32, range: std::ops::Range<usize>) {
        let yx = self.ycur(x);
        let t = self.nd[x as usize].tree;
        let et = self.teps[t as usize];
        let mult = self.mult;
        for i in range {
            let w = self.ed[i].v;
            if w == m {
                continue;
            }
            let c = self.cost(i);
            let ev = Event { c, u: x, v: w };
            let nw = self.nd[w as usize];
            if nw.parent != NONE || nw.tree != NONE {
                self.push_edge(ev);
                continue;
            }
            let s = c * mult - yx - nw.y;
            debug_assert!(s >= 0, "negative slack on edge {ev:?}");
            self.stats.evals += 1;
            self.stats.pushes += 1;
            self.var_push_tree(t, ((et + s) << 1) | 1, ev);
        }
    }

    /// Appends the vertices of `node` (as `(v, 0)` pairs) to `out`.
    pub(super) fn collect_vertices(&self, node: u32, out: &mut Vec<(u32, u32)>) {
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
    pub(super) fn rescale(&mut self) {
        self.stats.rescales += 1;
        self.scale *= 2;
        self.mult *= 2;
        for nd in &mut self.nd {
            nd.y *= 2;
        }
        for sc in &mut self.sc {
            sc.get_mut().sum *= 2;
        }
        self.eps *= 2;
        self.heap.double_keys_flagged();
        for e in &mut self.teps {
            *e *= 2;
        }
        if self.var_on {
            self.var_rescale();
        }
    }
}
