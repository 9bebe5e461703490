//! Greedy jump start: feasible duals and a first matching on tight edges.

use super::{Solver, NONE};

impl Solver {
    /// Feasible starting duals without any matching: `y_v` = half the cheapest doubled cost
    /// at `v`.
    #[cfg(any(test, feature = "testing"))]
    pub fn init_plain(&mut self) {
        for v in 0..self.n {
            self.nd[v].y = self.min_incident_half(v);
        }
    }

    pub(super) fn min_incident_half(&self, v: usize) -> i64 {
        let (a, b) = (self.adj_start[v] as usize, self.adj_start[v + 1] as usize);
        (a..b)
            .map(|i| self.cost(i) * self.mult / 2)
            .min()
            .unwrap_or(0)
    }

    /// Greedy dual jump start (see module docs, step 1).
    pub fn init_greedy(&mut self) {
        let n = self.n;
        for v in 0..n {
            self.nd[v].y = self.min_incident_half(v);
        }
        for v in 0..n {
            let (a, b) = (self.adj_start[v] as usize, self.adj_start[v + 1] as usize);
            let mut best = i64::MAX;
            let mut best_free = NONE;
            for e in a..b {
                let w = self.ed[e].v;
                let s = self.cost(e) * self.mult - self.nd[v].y - self.nd[w as usize].y;
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
            self.nd[v].y += best;
            if self.mate[v] == NONE && best_free != NONE {
                self.mate[v] = best_free;
                self.mate[best_free as usize] = v as u32;
            }
        }
        self.augment_short_paths();
    }

    /// Second part of the jump start: for each exposed vertex `v`, looks for an augmenting
    /// path `v – w = w' – x` of three tight edges (`x` exposed) and flips it. Cheap and local;
    /// it removes many of the exposed vertices the greedy pass leaves.
    pub(super) fn augment_short_paths(&mut self) {
        for v in 0..self.n as u32 {
            if self.mate[v as usize] != NONE {
                continue;
            }
            let (a, b) = (
                self.adj_start[v as usize] as usize,
                self.adj_start[v as usize + 1] as usize,
            );
            'outer: for i in a..b {
                let Some(w) = self.tight_other(i, v) else {
                    continue;
                };
                let w2 = self.mate[w as usize];
                if w2 == NONE {
                    // Tight edge to an exposed vertex (possible after dual raises).
                    self.mate[v as usize] = w;
                    self.mate[w as usize] = v;
                    break;
                }
                let (c, d) = (
                    self.adj_start[w2 as usize] as usize,
                    self.adj_start[w2 as usize + 1] as usize,
                );
                for j in c..d {
                    let Some(x) = self.tight_other(j, w2) else {
                        continue;
                    };
                    if x != v && self.mate[x as usize] == NONE {
                        self.mate[v as usize] = w;
                        self.mate[w as usize] = v;
                        self.mate[w2 as usize] = x;
                        self.mate[x as usize] = w2;
                        break 'outer;
                    }
                }
            }
        }
    }

    /// The other endpoint of edge `e` seen from `x`, if the edge is tight (jump start only:
    /// no blossoms yet).
    #[inline]
    pub(super) fn tight_other(&self, e: usize, x: u32) -> Option<u32> {
        let w = self.ed[e].v;
        (self.cost(e) * self.mult - self.nd[x as usize].y - self.nd[w as usize].y == 0).then_some(w)
    }
}
