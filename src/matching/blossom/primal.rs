//! The primal steps that change the matching or the blossoms: shrink a tight `+`–`+` edge
//! of one tree into a blossom, expand a `−` blossom whose dual reached zero, augment along a
//! tree path, and rebase a blossom on a new base vertex.

use super::{Node, Shortcut, Solver, TreeEdge, DEAD, FREE, MINUS, NONE, PLUS};
use std::cell::Cell;

impl Solver {
    pub(super) fn new_blossom_id(&mut self) -> u32 {
        if let Some(b) = self.free_blossoms.pop() {
            return b;
        }
        let b = self.nd.len() as u32;
        self.nd.push(Node::new(NONE));
        self.tedge.push(TreeEdge::NO);
        self.mark.push(0);
        self.sc.push(Cell::new(Shortcut::NO));
        self.gen.push(0);
        self.children.push(Vec::new());
        self.cyc.push(Vec::new());
        b
    }

    /// Lowest common `+` ancestor of `+` nodes `tu` and `tv` of one tree, found by walking up
    /// from both alternately (cost proportional to the cycle, not the tree).
    pub(super) fn lowest_common_plus(&mut self, tu: u32, tv: u32) -> u32 {
        self.mark_stamp = self.mark_stamp.wrapping_add(1);
        if self.mark_stamp == 0 {
            self.mark.iter_mut().for_each(|m| *m = 0);
            self.mark_stamp = 1;
        }
        let st = self.mark_stamp;
        self.mark[tu as usize] = st;
        self.mark[tv as usize] = st;
        let mut side = [tu, tv];
        loop {
            for x in &mut side {
                if *x == NONE {
                    continue;
                }
                *x = self.up2(*x);
                if *x != NONE {
                    if self.mark[*x as usize] == st {
                        return *x;
                    }
                    self.mark[*x as usize] = st;
                }
            }
            if side == [NONE, NONE] {
                return NONE; // not in one tree (cannot happen for a `+`–`+` edge of a tree)
            }
        }
    }

    /// The tree path from `+` node `p` up to its `+` ancestor `top` (excluded): each node with
    /// the edge `(vertex in it, vertex in the next node up)`.
    pub(super) fn tree_path_to(&self, mut p: u32, top: u32) -> Vec<(u32, (u32, u32))> {
        let mut path = Vec::new();
        while p != top {
            let base = self.nd[p as usize].base;
            let m = self.mate[base as usize];
            let tm = self.top_of(m);
            path.push((p, (base, m)));
            let (ms, mp) = {
                let t = self.tedge[tm as usize];
                (t.own, t.par)
            };
            path.push((tm, (ms, mp)));
            p = self.top_of(mp);
        }
        path
    }

    /// Forms a blossom from tight `+`–`+` edge `(u, v)`.
    pub(super) fn shrink(&mut self, u: u32, v: u32) {
        self.stats.shrinks += 1;
        let (tu, tv) = (self.top_of(u), self.top_of(v));
        let t = self.nd[tu as usize].tree;
        let lca = self.lowest_common_plus(tu, tv);
        // Cycle: lca, (down to tu), tu, tv, (up to lca).
        let path_u = self.tree_path_to(tu, lca);
        let path_v = self.tree_path_to(tv, lca);
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
        debug_assert_eq!(ch.len(), cy.len());
        debug_assert!(ch.len() % 2 == 1);
        // Commit children duals, update top/inner.
        let mut was_minus: Vec<u32> = Vec::new();
        for &c in &ch {
            let yc = self.ycur(c);
            if self.nd[c as usize].label == MINUS {
                was_minus.push(c);
            }
            self.nd[c as usize].y = yc;
            self.nd[c as usize].parent = b;
        }
        let bn = b as usize;
        self.nd[bn].y = -self.off(t); // dual 0 now (stored as `y − ε` for a `+` node)
        self.nd[bn].parent = NONE;
        self.nd[bn].base = self.nd[lca as usize].base;
        self.nd[bn].label = PLUS;
        self.nd[bn].tree = t;
        self.tree_lists[t as usize].push(b);
        self.children[bi] = ch;
        self.cyc[bi] = cy;
        for c in was_minus {
            self.push_edges_of(c);
        }
    }

    /// Index of the child of blossom `b` that contains vertex `x`.
    pub(super) fn child_index(&self, b: u32, x: u32) -> usize {
        let mut c = x;
        while self.nd[c as usize].parent != b {
            c = self.nd[c as usize].parent;
        }
        let bi = b as usize - self.n;
        self.children[bi].iter().position(|&k| k == c).unwrap_or(0)
    }

    /// Expands `−` blossom `b` whose dual reached zero.
    pub(super) fn expand(&mut self, b: u32) {
        self.stats.expands += 1;
        let bi = b as usize - self.n;
        let bn = b as usize;
        let (ts, tp) = (self.tedge[bn].own, self.tedge[bn].par);
        let t = self.nd[bn].tree;
        let j = self.child_index(b, ts);
        let ch = std::mem::take(&mut self.children[bi]);
        let cy = std::mem::take(&mut self.cyc[bi]);
        let k = ch.len();
        for &c in &ch {
            self.nd[c as usize].parent = NONE;
            self.nd[c as usize].tree = NONE;
            self.nd[c as usize].label = FREE;
        }
        // Shortcuts through `b` are stale from now on.
        self.gen[bn] = self.gen[bn].wrapping_add(1);
        self.nd[bn].label = DEAD;
        self.nd[bn].tree = NONE;
        self.free_blossoms.push(b);
        // Path from ch[j] to ch[0] of even length; its nodes go to the tree.
        let mut path: Vec<(u32, u8, u32, u32)> = Vec::new(); // node, label, tree edge (own, par)
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
                self.tedge[node as usize] = TreeEdge { own: s, par: p };
            }
        }
        for &(node, lab, _, _) in &path {
            self.add_to_tree(node, lab, t);
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

    /// Flips the tree path from `+` vertex `x` to its root and matches `x` to `partner`
    /// (a vertex of another tree; the caller flips that side too).
    pub(super) fn augment_path(&mut self, x: u32, partner: u32) {
        let (mut node, mut xv, mut partner) = (self.top_of(x), x, partner);
        loop {
            let ext = self.mate[self.nd[node as usize].base as usize];
            self.rebase(node, xv);
            self.mate[xv as usize] = partner;
            if ext == NONE {
                break;
            }
            let m = self.top_of(ext);
            let (ms, mp) = {
                let t = self.tedge[m as usize];
                (t.own, t.par)
            };
            self.rebase(m, ms);
            self.mate[ms as usize] = mp;
            node = self.top_of(mp);
            xv = mp;
            partner = ms;
        }
    }

    /// Makes vertex `x` the base of `node` (and of every blossom inside it that contains
    /// `x`), re-matching the cycles; the caller sets `mate[x]`.
    pub(super) fn rebase(&mut self, node: u32, x: u32) {
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
            self.nd[b as usize].base = x;
        }
        self.stack = work;
    }
}
