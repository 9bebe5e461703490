//! The fractional start in blocks, side by side ([`Solver::init_fractional_blocks`]).
//!
//! The fractional start leaves no blossom: only vertex duals, matched edges (tight) and
//! half-matched odd cycles (tight). So it can run on the subgraphs induced by contiguous
//! ranges of the internal numbering (spatially compact: the numbering is local), one
//! per thread, and the pieces join into a state of the whole graph that keeps its
//! invariants:
//! - each block's duals, in the finest units among the blocks (a block that rescaled has
//!   doubled its duals; the others are doubled as many times), are feasible on its edges
//!   and its matched and cycle edges are tight;
//! - an edge between two blocks (a seam edge) whose reduced cost is negative gets feasible
//!   by lowering the dual of its lower-numbered endpoint; lowering a dual keeps every other
//!   edge at that vertex feasible, and the vertex is released: its mate is unmatched, or its
//!   half-matched cycle is matched along the cycle's other (still tight) edges, the vertex
//!   staying exposed.
//!
//! The passes of the fractional start then run on the whole graph from that state (the
//! released vertices and what the blocks left exposed are their roots), and the main phase
//! follows as after the single start. The result is an optimum with its certificate either
//! way; among tied optima it may be another one than the single start's. It depends on the
//! block count and the input only, never on the threads' timing: each block runs alone and
//! the join is sequential.

use super::fractional::{Cycles, LOCAL_GROWS, WIDE_GROWS};
use super::{Edge, Solver, Stats, NONE};
use rayon::prelude::*;

/// Vertices from which [`Solver::run`] splits the fractional start into blocks when asked
/// ([`Solver::set_split`]); below, the single start: its greedy and local passes take a few
/// hundredths of a second (0.036 s on r1e5's graph, 91,298 vertices), too little to share.
pub(super) const SPLIT_FROM: usize = 200_000;

/// Blocks of a split start: fixed, so that the result does not depend on the machine's
/// thread count.
pub(super) const BLOCKS: usize = 2;

/// What the fractional start of one block leaves besides its duals and mates: its
/// half-matched cycles (in the whole graph's numbering), the units of its duals (`1/scale`)
/// and its counters.
struct BlockStart {
    cycles: Vec<Vec<u32>>,
    scale: i64,
    stats: Stats,
}

/// The solver of the subgraph induced by the vertices `lo..hi` of a solver's half-edges
/// (`adj_start`, `ed`, `wide_costs` as in [`Solver`]), numbered from `lo`.
fn block_solver(
    adj_start: &[u32],
    ed: &[Edge],
    wide_costs: &[i64],
    lo: usize,
    hi: usize,
) -> Solver {
    let n = hi - lo;
    // room for every half-edge of the range: the unused tail is never touched
    let room = (adj_start[lo] as usize..adj_start[hi] as usize).len();
    let mut start = Vec::with_capacity(n + 1);
    let mut sub = Vec::with_capacity(room);
    let mut sub_wide = Vec::with_capacity(if wide_costs.is_empty() { 0 } else { room });
    start.push(0u32);
    for v in lo..hi {
        for i in adj_start[v] as usize..adj_start[v + 1] as usize {
            let w = ed[i].v as usize;
            if (lo..hi).contains(&w) {
                sub.push(Edge {
                    v: (w - lo) as u32,
                    c: ed[i].c,
                });
                if !wide_costs.is_empty() {
                    sub_wide.push(wide_costs[i]);
                }
            }
        }
        start.push(sub.len() as u32);
    }
    Solver::from_csr(n, Vec::new(), Vec::new(), start, sub, sub_wide)
}

/// The fractional start of the block `lo..hi`, alone: its duals go to `y` and its mates
/// (in the whole graph's numbering) to `mate`, both indexed from `lo`; its cycles stay
/// half-matched.
fn block_start(
    (adj_start, ed, wide_costs): (&[u32], &[Edge], &[i64]),
    lo: usize,
    y: &mut [i64],
    mate: &mut [u32],
) -> BlockStart {
    let mut s = block_solver(adj_start, ed, wide_costs, lo, lo + y.len());
    s.init_greedy();
    let mut cy = Cycles::none(s.n);
    s.fractional_passes(&mut cy, LOCAL_GROWS, WIDE_GROWS);
    let lo = lo as u32;
    for (v, (y, mate)) in y.iter_mut().zip(mate.iter_mut()).enumerate() {
        *y = s.nd[v].y;
        *mate = match s.mate[v] {
            NONE => NONE,
            m => m + lo,
        };
    }
    let cycles = cy
        .list
        .into_iter()
        .filter(|c| !c.is_empty())
        .map(|c| c.into_iter().map(|x| x + lo).collect())
        .collect();
    BlockStart {
        cycles,
        scale: s.scale,
        stats: s.stats,
    }
}

impl Solver {
    /// The fractional start ([`Solver::init_fractional`]) with its greedy start and passes
    /// run on `blocks` contiguous ranges of the internal numbering side by side, the
    /// blocks joined (module docs) and the passes run again on the whole graph. Leaves what
    /// the single start leaves: feasible duals, matched edges tight, no blossom, no tree.
    /// One block (or none): the single start.
    pub fn init_fractional_blocks(&mut self, blocks: usize) {
        if blocks <= 1 {
            self.init_fractional();
            return;
        }
        let n = self.n;
        let t = std::time::Instant::now();
        let bounds: Vec<usize> = (0..=blocks).map(|i| i * n / blocks).collect();
        // memory: the blocks hold their own per-node arrays; the whole graph's are freed
        // (handed back to the system: the blocks allocate on other threads' arenas) and
        // built again after them
        self.free_node_arrays();
        if let Some(release) = self.release {
            release();
        }
        let mut y = vec![0i64; n];
        let mut pieces = Vec::with_capacity(blocks);
        let (mut y_rest, mut mate_rest) = (&mut y[..], &mut self.mate[..]);
        for b in bounds.windows(2) {
            let (y_b, y_r) = y_rest.split_at_mut(b[1] - b[0]);
            let (m_b, m_r) = mate_rest.split_at_mut(b[1] - b[0]);
            pieces.push((b[0], y_b, m_b));
            (y_rest, mate_rest) = (y_r, m_r);
        }
        let graph = (&self.adj_start[..], &self.ed[..], &self.wide_costs[..]);
        let parts: Vec<BlockStart> = pieces
            .into_par_iter()
            .map(|(lo, y, mate)| block_start(graph, lo, y, mate))
            .collect();
        self.new_node_arrays();
        let scale = parts.iter().map(|p| p.scale).max().unwrap_or(self.scale);
        self.scale = scale;
        self.mult = scale / 2;
        let mut cy = Cycles::none(n);
        let mut rescales = 0;
        for (part, b) in parts.into_iter().zip(bounds.windows(2)) {
            let f = scale / part.scale;
            for (nd, &y) in self.nd[b[0]..b[1]].iter_mut().zip(&y[b[0]..b[1]]) {
                nd.y = y * f;
            }
            for cycle in part.cycles {
                let c = cy.list.len() as u32;
                for &x in &cycle {
                    cy.id[x as usize] = c;
                }
                cy.list.push(cycle);
            }
            rescales = rescales.max(part.stats.rescales);
            self.stats.add_block(&part.stats);
        }
        drop(y);
        self.stats.rescales += rescales;
        self.stats.released = self.join_seams(&bounds, &mut cy);
        self.stats.blocks_s = t.elapsed().as_secs_f64();
        self.fractional_passes(&mut cy, LOCAL_GROWS, WIDE_GROWS);
        self.finish_fractional(&cy);
    }

    /// Makes every seam edge (between blocks `bounds[i]..bounds[i + 1]`) feasible by
    /// lowering the dual of its lower-numbered endpoint by the edge's deficit, and releases
    /// each vertex lowered (module docs); returns how many. Before: the duals are feasible
    /// on the edges inside the blocks, matched and cycle edges tight (all inside blocks).
    /// After: the duals are feasible on every edge, matched and cycle edges still tight.
    fn join_seams(&mut self, bounds: &[usize], cy: &mut Cycles) -> usize {
        let mut released = 0;
        for b in bounds.windows(2) {
            let hi = b[1];
            for v in b[0]..hi {
                // the seam edges to later blocks (those to earlier blocks were seen from
                // their other endpoint)
                let yv = self.nd[v].y;
                let mut deficit = 0;
                for i in self.adj_start[v] as usize..self.adj_start[v + 1] as usize {
                    let w = self.ed[i].v as usize;
                    if w >= hi {
                        let slack = self.cost(i) * self.mult - yv - self.nd[w].y;
                        deficit = deficit.max(-slack);
                    }
                }
                if deficit > 0 {
                    self.nd[v].y -= deficit;
                    self.release(v as u32, cy);
                    released += 1;
                }
            }
        }
        released
    }

    /// Leaves `v` exposed: its mate unmatched, or its half-matched cycle matched along its
    /// other edges (an even path once `v` is out), so that no matched or cycle edge at `v`
    /// needs to be tight.
    fn release(&mut self, v: u32, cy: &mut Cycles) {
        let m = self.mate[v as usize];
        if m != NONE {
            self.mate[m as usize] = NONE;
            self.mate[v as usize] = NONE;
        } else if cy.id[v as usize] != NONE {
            let cycle = std::mem::take(&mut cy.list[cy.id[v as usize] as usize]);
            Self::match_cycle_except(&mut self.mate, &cycle, v);
            for &x in &cycle {
                cy.id[x as usize] = NONE;
            }
        }
    }
}

impl Stats {
    /// Adds the counters of a block's fractional start (not its times, nor its rescales:
    /// the join counts those).
    fn add_block(&mut self, b: &Stats) {
        self.grows += b.grows;
        self.evals += b.evals;
        self.pops += b.pops;
        self.pushes += b.pushes;
        self.augments += b.augments;
        self.freed += b.freed;
        self.cross_pushes += b.cross_pushes;
        self.wide_searches[0] += b.wide_searches[0];
        self.wide_searches[1] += b.wide_searches[1];
        self.var_rounds += b.var_rounds;
        self.var_split_rounds += b.var_split_rounds;
        self.var_joins += b.var_joins;
        self.var_pair_augments += b.var_pair_augments;
        self.var_stuck += b.var_stuck;
    }
}
