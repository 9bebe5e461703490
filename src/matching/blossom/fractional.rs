//! Fractional jump start: the LP relaxation without odd-set constraints, solved by the same
//! tree machinery (Kolmogorov 2009, Sec. 5, "fractional matching initialization").
//!
//! Half-integral solutions of that LP are a matching plus vertex-disjoint odd cycles of
//! half-edges. Trees grow exactly as in the main phase, but a tight `+`–`+` edge inside a tree
//! closes an odd cycle instead of a blossom: the path from the root to the cycle is flipped
//! (the root gets matched) and the cycle's vertices become "half-matched", with frozen duals.
//! A tree that reaches a half-matched vertex augments into it and the rest of that cycle is
//! matched along its (tight) edges. At the end each remaining cycle leaves one vertex exposed.
//! Duals stay feasible and every matched edge tight, so the main phase starts from there with
//! near-optimal duals and few exposed vertices.

use super::{Solver, EXPAND, MINUS, NONE, PLUS};

impl Solver {
    /// Greedy start followed by the fractional phase (the default start of [`Solver::run`]).
    pub fn init_fractional(&mut self) {
        self.init_greedy();
        let n = self.n;
        let mut cyc_id = vec![NONE; n];
        let mut cycles: Vec<Vec<u32>> = Vec::new();
        self.eps = 0;
        self.heap.clear();
        let roots: Vec<u32> = (0..n as u32)
            .filter(|&v| self.mate[v as usize] == NONE)
            .collect();
        self.tree_lists = vec![Vec::new(); roots.len()];
        for (t, &r) in roots.iter().enumerate() {
            let nd = &mut self.nd[r as usize];
            nd.tree = t as u32;
            nd.label = PLUS;
            nd.join = 0;
            self.tree_lists[t].push(r);
        }
        for &r in &roots {
            self.push_edges_of(r);
        }
        let mut alive = roots.len();
        while alive > 0 {
            let Some((key, id)) = self.heap.pop() else {
                break; // some tree is stuck: leave it to the main phase
            };
            if id & EXPAND != 0 {
                continue; // no blossoms in this phase
            }
            let e = id as usize;
            let key = key as i64;
            let Some(k2) = self.edge_key(e) else { continue };
            if k2 != key {
                self.heap.push(k2 as u64, id);
                continue;
            }
            self.eps = key;
            let (u, v) = (self.ed[e].u, self.ed[e].v);
            let (pu, pv) = (self.in_tree(u, PLUS), self.in_tree(v, PLUS));
            if pu && pv {
                let (ta, tb) = (self.nd[u as usize].tree, self.nd[v as usize].tree);
                if ta == tb {
                    let cycle = self.odd_cycle(u, v);
                    let c = cycles.len() as u32;
                    for &x in &cycle {
                        cyc_id[x as usize] = c;
                        self.mate[x as usize] = NONE;
                    }
                    cycles.push(cycle);
                    self.dissolve(ta);
                    alive -= 1;
                } else {
                    self.augment_path(u, v);
                    self.augment_path(v, u);
                    self.dissolve(ta);
                    self.dissolve(tb);
                    alive -= 2;
                }
            } else {
                let (x, w) = if pu { (u, v) } else { (v, u) };
                let c = cyc_id[w as usize];
                if c != NONE {
                    let ta = self.nd[x as usize].tree;
                    self.augment_path(x, w);
                    self.mate[w as usize] = x;
                    let cycle = std::mem::take(&mut cycles[c as usize]);
                    Self::match_cycle_except(&mut self.mate, &cycle, w);
                    for &y in &cycle {
                        cyc_id[y as usize] = NONE;
                    }
                    self.dissolve(ta);
                    alive -= 1;
                } else {
                    self.grow(x, w);
                }
            }
            self.push_freed();
        }
        // Stuck trees (if any) are dissolved; their alternating structure is a valid matching.
        for t in 0..self.tree_lists.len() {
            self.dissolve(t as u32);
        }
        self.freed.clear();
        for cycle in &cycles {
            if let Some(&first) = cycle.first() {
                Self::match_cycle_except(&mut self.mate, cycle, first);
            }
        }
        self.stats.cycles = cycles.iter().filter(|c| !c.is_empty()).count();
        self.tree_lists.clear();
        self.heap.clear();
        self.eps = 0;
    }

    /// Matches the odd cycle `cycle` (consecutive vertices joined by tight edges) minus vertex
    /// `skip` along the cycle; `skip`'s mate is left untouched.
    fn match_cycle_except(mate: &mut [u32], cycle: &[u32], skip: u32) {
        let k = cycle.len();
        let j = cycle.iter().position(|&x| x == skip).unwrap_or(0);
        let mut i = 1;
        while i + 1 < k {
            let (a, b) = (cycle[(j + i) % k], cycle[(j + i + 1) % k]);
            mate[a as usize] = b;
            mate[b as usize] = a;
            i += 2;
        }
    }

    /// Closes the odd cycle made by tight edge `u`–`v` inside one tree (all nodes are single
    /// vertices in this phase): flips the path from the cycle's top vertex to the root and
    /// returns the cycle's vertices in order.
    fn odd_cycle(&mut self, u: u32, v: u32) -> Vec<u32> {
        self.mark_stamp = self.mark_stamp.wrapping_add(1);
        if self.mark_stamp == 0 {
            self.mark.iter_mut().for_each(|m| *m = 0);
            self.mark_stamp = 1;
        }
        let st = self.mark_stamp;
        self.mark[u as usize] = st;
        self.mark[v as usize] = st;
        let (mut a, mut b) = (u, v);
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
        // Cycle order: lca, down the u-branch to u, then v, up the v-branch.
        let branch = |s: &Self, from: u32| {
            let mut out = Vec::new();
            let mut p = from;
            while p != lca {
                let m = s.mate[p as usize];
                out.push(p);
                out.push(m);
                p = s.tpar[m as usize];
            }
            out
        };
        let bu = branch(self, u);
        let bv = branch(self, v);
        // Flip the root path above lca: lca's mate chain up to the root.
        let mut node = lca;
        let mut partner = NONE;
        loop {
            let ext = self.mate[node as usize];
            self.mate[node as usize] = partner;
            if ext == NONE {
                break;
            }
            debug_assert_eq!(self.nd[ext as usize].label, MINUS);
            let mp = self.tpar[ext as usize];
            self.mate[ext as usize] = mp;
            partner = ext;
            node = mp;
        }
        let mut cycle = Vec::with_capacity(bu.len() + bv.len() + 1);
        cycle.push(lca);
        cycle.extend(bu.iter().rev());
        cycle.extend(bv.iter());
        cycle
    }
}
