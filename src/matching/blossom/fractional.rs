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
//!
//! Passes: a *local* one grows one tree at a time from each exposed vertex in (locality)
//! order, with the other exposed vertices as plain targets (their duals fixed, which is valid
//! since vertex duals are free in the perfect-matching LP), so consecutive searches touch
//! nearby memory; a search that needs too many grow steps is abandoned (its dual changes are
//! kept). A second local pass retries the abandoned roots with a larger budget for as long
//! as most of its searches end. A *global* pass then grows the remaining trees together, so
//! that they can meet half-way (on near-bipartite lattice meshes the last exposed vertices
//! are far apart), in the `forest` module with `Kind::Frac`: a tight `+`–`+` edge inside a
//! tree closes an odd cycle, and a component that can move without bound is dissolved and
//! left to the main phase.

use super::{Solver, MINUS, NONE, PLUS, PROGRESS_EVERY};

/// Grow steps a local search may take before it is left to the global pass.
pub(super) const LOCAL_GROWS: usize = 64;

/// Grow budget of the second local pass ([`Solver::fractional_local_wide`]): on mesh
/// graphs most of the searches the first pass abandons end within it, and each one ended
/// there is a tree fewer in the global pass, whose dual updates visit every live tree
/// (figures in BENCHMARKS.md, "Measurements behind the defaults").
pub(super) const WIDE_GROWS: usize = 4096;

/// Searches per window of the second local pass.
const WIDE_WINDOW: usize = 64;

/// Windows in a row that end fewer than half their searches after which the second local
/// pass stops. One is too few: on a twice-refined mesh (costs tied in large groups) a
/// single bad window among hundreds of good ones left 115,000 trees to the global pass
/// instead of 10,000 (figures in BENCHMARKS.md, "Measurements behind the defaults").
const WIDE_BAD_WINDOWS: usize = 4;

/// When the second local pass stops (module docs of [`Solver::fractional_local_wide`]):
/// after [`WIDE_BAD_WINDOWS`] windows in a row that ended fewer than half their searches,
/// or at the end of a window once fewer than half of all its searches so far ended.
#[derive(Default)]
struct WidePace {
    /// Searches and ended searches in the current window.
    window: (usize, usize),
    /// Bad windows in a row.
    bad: usize,
    /// Searches and ended searches so far.
    all: (usize, usize),
}

impl WidePace {
    /// Records one search (`ended`: it settled its root); false when the pass should stop.
    fn record(&mut self, ended: bool) -> bool {
        self.window.0 += 1;
        self.window.1 += usize::from(ended);
        self.all.0 += 1;
        self.all.1 += usize::from(ended);
        if self.window.0 < WIDE_WINDOW {
            return true;
        }
        let (tried, done) = std::mem::take(&mut self.window);
        self.bad = if 2 * done < tried { self.bad + 1 } else { 0 };
        self.bad < WIDE_BAD_WINDOWS && 2 * self.all.1 >= self.all.0
    }
}

/// Half-matched odd cycles: `id[v]` is the cycle of vertex `v` (or NONE), `list[c]` the
/// vertices of cycle `c` in order (emptied when the cycle is resolved).
pub(super) struct Cycles {
    pub(super) id: Vec<u32>,
    pub(super) list: Vec<Vec<u32>>,
}

impl Cycles {
    /// No cycle among `n` vertices.
    pub(super) fn none(n: usize) -> Cycles {
        Cycles {
            id: vec![NONE; n],
            list: Vec::new(),
        }
    }
}

impl Solver {
    /// Greedy start followed by the fractional phase (the default start of [`Solver::run`]).
    pub fn init_fractional(&mut self) {
        self.init_fractional_with(LOCAL_GROWS, WIDE_GROWS);
    }

    /// [`Solver::init_fractional`] with given grow budgets for the first local pass
    /// (`budget`; 0 leaves nearly everything to the global pass) and the second (`wide`; 0
    /// skips it); tests use it to exercise every pass.
    pub fn init_fractional_with(&mut self, budget: usize, wide: usize) {
        let t = std::time::Instant::now();
        self.init_greedy();
        self.stats.phase_s[0] = t.elapsed().as_secs_f64();
        self.stats.phase_counts[0] = (self.stats.grows, self.stats.evals, self.stats.pops);
        let mut cy = Cycles::none(self.n);
        self.fractional_passes(&mut cy, budget, wide);
        self.finish_fractional(&cy);
    }

    /// The passes of the fractional start after a start with feasible duals, every matched
    /// edge and every edge of a cycle of `cy` tight (the greedy start, or the blocks joined
    /// by [`Solver::init_fractional_blocks`]): the local pass (grow budget `budget`), the
    /// second local pass (`wide`; 0 skips it) and the global pass. The duals stay feasible,
    /// matched and cycle edges tight; the time and counts go to phases 1 and 2 of the stats.
    pub(super) fn fractional_passes(&mut self, cy: &mut Cycles, budget: usize, wide: usize) {
        let t = std::time::Instant::now();
        self.fractional_local(cy, budget);
        if wide > 0 {
            self.fractional_local_wide(cy, wide);
        }
        self.stats.phase_s[1] += t.elapsed().as_secs_f64();
        self.stats.phase_counts[1] = (self.stats.grows, self.stats.evals, self.stats.pops);
        let t = std::time::Instant::now();
        self.fractional_global_var(cy);
        self.stats.phase_s[2] += t.elapsed().as_secs_f64();
        self.stats.phase_counts[2] = (self.stats.grows, self.stats.evals, self.stats.pops);
    }

    /// Ends the fractional start: each cycle left is matched along its edges but for its
    /// first vertex, which stays exposed, so the main phase starts from a matching on tight
    /// edges with feasible duals and no blossom.
    pub(super) fn finish_fractional(&mut self, cy: &Cycles) {
        for cycle in &cy.list {
            if let Some(&first) = cycle.first() {
                Self::match_cycle_except(&mut self.mate, cycle, first);
            }
        }
        self.stats.cycles = cy.list.iter().filter(|c| !c.is_empty()).count();
        self.tree_lists.clear();
        self.heap.clear();
        self.eps = 0;
    }

    /// Local pass: one tree at a time, roots in (locality) order. The other exposed vertices
    /// keep their duals, so each search is a Dijkstra-like growth around its root that
    /// touches only nearby memory. A search that needs more than `budget` grow steps is
    /// abandoned: its dual changes are kept (they are feasible) and its root stays exposed
    /// for the global pass.
    fn fractional_local(&mut self, cy: &mut Cycles, budget: usize) {
        self.new_trees(1);
        for r in 0..self.n as u32 {
            if r & PROGRESS_EVERY == 0 {
                self.tick(0, r as usize, self.n);
            }
            if !self.settled(cy, r) {
                self.search_from(cy, r, budget);
            }
        }
    }

    /// True when `r` needs no search: matched, or on a half-matched cycle.
    fn settled(&self, cy: &Cycles, r: u32) -> bool {
        self.mate[r as usize] != NONE || cy.id[r as usize] != NONE
    }

    /// One single-tree search from the exposed vertex `r` within `budget` grow steps (its
    /// dual changes kept, whatever the outcome); true when it ended, i.e. `r` is settled.
    fn search_from(&mut self, cy: &mut Cycles, r: u32, budget: usize) -> bool {
        self.start_single_tree(r);
        self.fractional_search(cy, budget);
        self.end_single_tree();
        self.settled(cy, r)
    }

    /// Second local pass over the roots the first left exposed, with the larger budget
    /// `wide` ([`WIDE_GROWS`] by default), while it pays: it stops, leaving the rest to the
    /// global pass, once [`WIDE_BAD_WINDOWS`] windows of [`WIDE_WINDOW`] searches in a row
    /// ended fewer than half of theirs, or fewer than half of all its searches ended
    /// ([`WidePace`]; an abandoned search keeps its dual changes, which are feasible).
    fn fractional_local_wide(&mut self, cy: &mut Cycles, wide: usize) {
        let mut pace = WidePace::default();
        for r in 0..self.n as u32 {
            if r & PROGRESS_EVERY == 0 {
                // progress: the first half of the fractional forest's units
                self.tick(1, r as usize, 2 * self.n);
            }
            if self.settled(cy, r) {
                continue;
            }
            let done = self.search_from(cy, r, wide);
            self.stats.wide_searches[0] += 1;
            self.stats.wide_searches[1] += usize::from(done);
            if !pace.record(done) {
                return;
            }
        }
    }

    /// Grows the single tree 0 until it ends (augmentation, odd cycle), gets stuck or uses
    /// up `budget` grow steps.
    fn fractional_search(&mut self, cy: &mut Cycles, budget: usize) {
        let mut grows = 0;
        while let Some((u, v)) = self.pop_edge_event() {
            let (pu, pv) = (self.in_tree(u, PLUS), self.in_tree(v, PLUS));
            if pu && pv {
                self.close_cycle(cy, u, v);
                return;
            }
            let (x, w) = if pu { (u, v) } else { (v, u) };
            // A vertex on a half-matched cycle has no mate (tested first: `mate` is read
            // by the grow step anyway, `cy.id` would be one more cache miss).
            if self.mate[w as usize] == NONE && cy.id[w as usize] != NONE {
                self.augment_into_cycle(cy, x, w);
                return;
            }
            if self.mate[w as usize] == NONE {
                // Another exposed vertex (not growing now): augment into it.
                self.augment_path(x, w);
                self.mate[w as usize] = x;
                return;
            }
            if grows == budget {
                return;
            }
            grows += 1;
            self.grow(x, w);
        }
    }

    /// Tight `+`–`+` edge `(u, v)` inside one tree: the cycle becomes half-matched.
    pub(super) fn close_cycle(&mut self, cy: &mut Cycles, u: u32, v: u32) {
        let cycle = self.odd_cycle(u, v);
        let c = cy.list.len() as u32;
        for &x in &cycle {
            cy.id[x as usize] = c;
            self.mate[x as usize] = NONE;
        }
        cy.list.push(cycle);
    }

    /// Tight edge from `+` vertex `x` to `w` on a half-matched cycle: augments into `w` and
    /// matches the rest of the cycle along its edges.
    pub(super) fn augment_into_cycle(&mut self, cy: &mut Cycles, x: u32, w: u32) {
        let c = cy.id[w as usize];
        self.augment_path(x, w);
        self.mate[w as usize] = x;
        let cycle = std::mem::take(&mut cy.list[c as usize]);
        Self::match_cycle_except(&mut self.mate, &cycle, w);
        for &y in &cycle {
            cy.id[y as usize] = NONE;
        }
    }

    /// Matches the odd cycle `cycle` (consecutive vertices joined by tight edges) minus vertex
    /// `skip` along the cycle; `skip`'s mate is left untouched.
    pub(super) fn match_cycle_except(mate: &mut [u32], cycle: &[u32], skip: u32) {
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
        let lca = self.lowest_common_plus(u, v);
        // Cycle order: lca, down the u-branch to u, then v, up the v-branch.
        let branch = |s: &Self, from: u32| {
            let mut out = Vec::new();
            let mut p = from;
            while p != lca {
                let m = s.mate[p as usize];
                out.push(p);
                out.push(m);
                p = s.tedge[m as usize].par;
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
            let mp = self.tedge[ext as usize].par;
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

#[cfg(test)]
mod tests {
    use super::*;

    /// Feeds `windows` (searches ended per full window) to a pace; the number of windows
    /// after which it stops, if it does.
    fn stops_after(windows: &[usize]) -> Option<usize> {
        let mut pace = WidePace::default();
        for (w, &ended) in windows.iter().enumerate() {
            for i in 0..WIDE_WINDOW {
                if !pace.record(i < ended) {
                    assert_eq!(i, WIDE_WINDOW - 1, "stops only at the end of a window");
                    return Some(w + 1);
                }
            }
        }
        None
    }

    #[test]
    fn the_second_pass_stops_after_bad_windows_in_a_row_or_when_it_stops_paying() {
        let (good, bad) = (WIDE_WINDOW, WIDE_WINDOW / 4);
        // good windows: never stops
        assert_eq!(stops_after(&[good; 40]), None);
        // a bad window now and then among good ones: keeps going
        let mut mixed = vec![good; 40];
        for w in (5..40).step_by(7) {
            mixed[w] = bad;
        }
        assert_eq!(stops_after(&mixed), None);
        // WIDE_BAD_WINDOWS bad windows in a row after good ones: stops at the last of them
        let mut run = vec![good; 20];
        run.extend([bad; WIDE_BAD_WINDOWS]);
        run.extend([good; 5]);
        assert_eq!(stops_after(&run), Some(20 + WIDE_BAD_WINDOWS));
        // fewer than half of all searches ended: stops, bad windows in a row or not
        let alternating: Vec<usize> = (0..40)
            .map(|w| if w % 2 == 0 { bad } else { good / 2 + 1 })
            .collect();
        assert_eq!(stops_after(&alternating), Some(1));
        let half = WIDE_WINDOW / 2;
        assert_eq!(stops_after(&[half, half, half - 1]), Some(3));
    }
}
