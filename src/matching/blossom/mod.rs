//! The primal-dual blossom solver behind [`super::solve`].
//!
//! Edmonds' algorithm (1965) with the data-structure ideas of Kolmogorov's Blossom V (2009)
//! and of Galil, Micali & Gabow (1986). One file per concern:
//!
//! - this file: the solver state, its construction ([`Solver::new`]: vertices renumbered in
//!   breadth-first order by `locality_order`, or kept in the caller's order
//!   ([`Solver::new_in_order`] with [`VertexOrder::Given`]), every edge stored twice as half-edges grouped
//!   by their first endpoint, costs doubled), the phase sequence ([`Solver::run`]) and the
//!   result in the caller's numbering;
//! - `start`: the greedy jump start ([`Solver::init_greedy`]: `y_v` = half the cheapest
//!   cost at `v`, each vertex raises its dual to its smallest slack and takes a tight edge to
//!   an exposed neighbour, short tight augmenting paths are flipped);
//! - `fractional`: the fractional jump start ([`Solver::init_fractional`]): the LP without
//!   odd-set constraints solved by the same tree machinery (single-tree searches with a small
//!   and then a larger budget, then a forest), leaving one exposed vertex per odd cycle of
//!   half-edges;
//! - `split`: the fractional start in blocks side by side
//!   ([`Solver::init_fractional_blocks`], off by default, [`Solver::set_split`]): each
//!   block (a contiguous range of the internal numbering) solved alone on its induced
//!   subgraph, the blocks joined by lowering a dual at each infeasible edge between them,
//!   then the passes of `fractional` on the whole graph;
//! - `tree`: alternating trees: single-tree searches ([`Solver::solve_rest_with`]: from each
//!   exposed vertex in locality order one tree grows alone with its own dual change until it
//!   augments, abandoned past a budget of grow steps), growing, dissolving a tree (its lazy
//!   duals committed) and the Tutte witness when a tree can grow without bound;
//! - `events`: lazy duals, slacks and the event queue of a single-tree search (heap keys,
//!   pushing a node's edges, validating popped entries, rescaling);
//! - `forest`: the trees left after the single-tree searches, grown together, each with its
//!   own dual change `ε_T` (Blossom V's variable δ);
//! - `primal`: the primal steps that change the matching or the blossoms: shrink, expand,
//!   augment, rebase;
//! - `shortcut`: the top-level blossom of a vertex through path-compressed shortcuts;
//! - `check`: [`Solver::check_invariants`], what every phase keeps (tests call it).
//!
//! **Lazy duals.** When a node joins a tree its stored dual is offset by `−ε` (`+` node) or
//! `+ε` (`−` node), `ε` being the dual change of its tree so far (`Solver::off`), so a dual
//! change costs O(1); dissolving the tree commits the current values.
//!
//! **Events.** A single-tree search keeps its events in one monotone radix heap
//! ([`super::radix`]) keyed by the `ε` at which they happen:
//! - `+` node to a free node (slack `s`): at `ε + s` → *grow*;
//! - `+` to `+` (slack `s`): at `ε + s/2` → *shrink* into a blossom;
//! - `+` node to an exposed node outside the tree: at `ε + s` → *augment*;
//! - `−` blossom with dual `y`: at `ε + y` → *expand*.
//!
//! Among equal times, tree-ending events come first. Entries are validated when popped
//! (lazy deletion) and re-pushed with the right key when the situation changed.
//!
//! **Blossoms** persist until their dual drops to zero while `−` (Blossom V). The enclosing
//! top-level blossom of a vertex is found through path-compressed shortcuts that stay exact
//! because the duals of non-top blossoms are frozen, so forming a blossom never relabels its
//! vertices.
//!
//! **No perfect matching.** If the events run dry while trees remain, `ε` is unbounded: the
//! `−` vertices of those trees form a Tutte set whose removal isolates the more numerous `+`
//! nodes (each an odd set).
//!
//! **Half-integral steps.** Costs are doubled, and when a `+`↔`+` slack is odd every cost,
//! dual and key is doubled again (`scale` records the factor), so all arithmetic stays exact
//! in `i64`.
//!
//! **Invariants** (checked by [`Solver::check_invariants`]): every reduced cost is `≥ 0`,
//! blossom duals are `≥ 0`, the blossoms form a laminar family whose cycle edges are tight,
//! matched and tree edges are tight, and the shortcuts give the same top blossom and dual
//! sums as walking the parents.

use super::radix::RadixHeap;

#[cfg(any(test, feature = "testing"))]
mod check;
mod events;
mod forest;
mod fractional;
mod primal;
mod shortcut;
mod split;
mod start;
#[cfg(test)]
mod tests;
mod tree;

use super::{BlossomDual, Duals, Matching, NoPerfectMatching, VertexOrder, MAX_ABS_COST, NONE};
#[cfg(any(test, feature = "testing"))]
pub use check::InvariantError;
use std::cell::Cell;

const FREE: u8 = 0;
const PLUS: u8 = 1;
const MINUS: u8 = 2;
const DEAD: u8 = 3;
/// Heap ids with this bit set are "expand blossom" events, the others are edge ids.
const EXPAND: u32 = 1 << 31;
/// Grow steps a single-tree search of the main phase may take before it is left to the
/// forest grown together.
const MAIN_LOCAL_GROWS: usize = 256;

/// One half-edge, stored in the range of its first endpoint (8 bytes): the other endpoint
/// `v`, and the doubled cost of the edge when every doubled cost fits in an `i32` (else the
/// costs are in [`Solver::wide_costs`] and `c` is 0); read through [`Solver::cost`].
#[derive(Clone, Copy, Debug)]
struct Edge {
    v: u32,
    c: i32,
}

/// Hot per-node fields (24 bytes).
#[derive(Clone, Copy, Debug)]
struct Node {
    /// Stored dual: exact for a node outside the trees; for a tree node, its dual minus `ε`
    /// (`+`) or plus `ε` (`−`), so that [`Solver::ycur`] is `y + ε` or `y − ε` and a dual
    /// change costs O(1).
    y: i64,
    /// Enclosing blossom, or NONE for a top-level node.
    parent: u32,
    /// Tree id, or NONE.
    tree: u32,
    /// Base vertex (the vertex whose mate is outside the node).
    base: u32,
    /// FREE, PLUS, MINUS or DEAD.
    label: u8,
}

impl Node {
    fn new(base: u32) -> Node {
        Node {
            y: 0,
            parent: NONE,
            tree: NONE,
            base,
            label: FREE,
        }
    }
}

/// The tree edge of a `−` node: `own` (a vertex in the node) to `par` (a vertex in its
/// parent `+` node).
#[derive(Clone, Copy, Debug)]
struct TreeEdge {
    own: u32,
    par: u32,
}

impl TreeEdge {
    const NO: TreeEdge = TreeEdge {
        own: NONE,
        par: NONE,
    };
}

/// A heap entry: an edge `(u, v)` with its doubled cost `c` (as in [`Solver::ed`], times
/// `Solver::mult` in current units), so that validating a popped event reads no edge array;
/// or an expand event (`u` = blossom `| EXPAND`).
#[derive(Clone, Copy, Debug)]
struct Event {
    c: i64,
    u: u32,
    v: u32,
}

/// A path-compression shortcut of a node: an ancestor `to`, the sum of the duals from the
/// node up to `to` (excluded), and `to`'s generation when the shortcut was set.
#[derive(Clone, Copy, Debug)]
struct Shortcut {
    to: u32,
    gen: u32,
    sum: i64,
}

impl Shortcut {
    const NO: Shortcut = Shortcut {
        to: NONE,
        gen: 0,
        sum: 0,
    };
}

/// A tight edge `{u, v}` popped from the heap: the top blossoms of its ends and whether
/// each is a "+" node of a tree.
struct Tight {
    u: u32,
    v: u32,
    tu: u32,
    tv: u32,
    pu: bool,
    pv: bool,
}

/// Solver state. Nodes `0..n` are vertices, nodes `n..` blossoms.
pub struct Solver {
    n: usize,
    /// Half-edges (far endpoint, doubled cost: units of 1/2, never rescaled), loops removed:
    /// every edge `{a, b}` appears in `a`'s range as `b` and in `b`'s range as `a`.
    ed: Vec<Edge>,
    /// The doubled costs of the half-edges (same index as `ed`) when some does not fit in an
    /// `i32`; empty otherwise (the common case: `ed` then holds them, at half the memory).
    wide_costs: Vec<i64>,
    /// Internal vertex numbering (for memory locality): `order[new] = old`,
    /// `perm[old] = new`.
    order: Vec<u32>,
    perm: Vec<u32>,
    /// CSR adjacency: the half-edges leaving vertex `v` are `adj_start[v]..adj_start[v+1]`.
    adj_start: Vec<u32>,
    /// `mate[v]`: matched vertex or NONE.
    mate: Vec<u32>,
    /// Per node: the hot fields, packed in one cache-line-friendly record.
    nd: Vec<Node>,
    /// For `−` nodes: the tree edge as (vertex in this node, vertex in the parent `+` node).
    tedge: Vec<TreeEdge>,
    /// Per blossom (index `node − n`): children in cycle order starting at the base child, and
    /// the cycle edges: `cyc[i] = (a, b)` with `a` in `children[i]`, `b` in `children[i+1]`.
    children: Vec<Vec<u32>>,
    cyc: Vec<Vec<(u32, u32)>>,
    free_blossoms: Vec<u32>,
    /// Per vertex: top-level node containing it, and the sum of the duals of the nodes
    /// containing it strictly below the top level (its own dual included when not top-level).
    /// Per node: a shortcut to an ancestor (`to`), the sum of the duals from the node up to
    /// that ancestor, excluded (`sum`), and the ancestor's generation when the shortcut was
    /// set (`gen`), in one record (one cache line per lookup). Duals of non-top nodes are fixed, so a shortcut stays exact until its
    /// target is expanded, which bumps `gen[target]`. Path compression with `Cell`s keeps
    /// lookups from `&self`.
    sc: Vec<Cell<Shortcut>>,
    gen: Vec<u32>,
    heap: RadixHeap<Event>,
    /// Dual change `ε` of the single-tree search (zero while the forest runs).
    eps: i64,
    /// Per tree: its own dual change `ε_T` (forest only; zero otherwise).
    teps: Vec<i64>,
    /// True while the forest runs: edges are routed to per-tree heaps and
    /// per-pair-of-trees heaps (`forest`) instead of `heap`.
    var_on: bool,
    /// The forest's queues.
    var: forest::VarQueues,
    /// Nodes that joined each tree (stale entries are filtered by `tree[node]`).
    tree_lists: Vec<Vec<u32>>,
    /// Edges into nodes freed by a dissolve, waiting to be pushed.
    freed: Vec<Event>,
    mark: Vec<u32>,
    mark_stamp: u32,
    /// Costs and duals are in units of `1/scale`.
    scale: i64,
    /// `scale / 2`: the factor from the doubled costs stored in `ed` (units of 1/2) to the
    /// current units.
    mult: i64,
    stack: Vec<(u32, u32)>,
    /// Statistics: number of vertices left exposed by the jump start, re-scalings.
    pub stats: Stats,
    /// Where progress goes (see [`Solver::set_progress`]).
    progress: Option<Ticker>,
    /// Whether [`Solver::run`] may split its fractional start (see [`Solver::set_split`]).
    split: bool,
    /// What hands freed memory back to the system (see [`Solver::set_split`]).
    release: Option<fn()>,
}

/// A progress callback `(done, total)` of the solver (see [`Solver::set_progress`]).
pub type ProgressCallback = Box<dyn Fn(usize, usize) + Send + Sync>;

/// The solver's progress: four phases after the greedy start (fractional local searches,
/// fractional forest with the second local pass before it, main single-tree searches, main
/// forest), `n` units each; a phase's units are the position of its loop over the vertices
/// (the second local pass fills the first half of its phase), or, for a forest, the share
/// of its trees done (reported once past what the phase already reported). Calls the
/// callback when at least [`Ticker::STEP`] of the whole has passed since the last call,
/// never from the inner loops.
struct Ticker {
    f: ProgressCallback,
    /// Units at which the next call is due.
    next: usize,
}

/// The loops over the vertices ask [`Solver::tick`] once per this many + 1 vertices (a
/// power of two minus one, as a mask).
const PROGRESS_EVERY: u32 = (1 << 10) - 1;

impl Ticker {
    /// The smallest share of the whole between two calls.
    const STEP: usize = 64;
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
    /// Augmentations.
    pub augments: usize,
    /// Odd cycles left by the fractional start (one exposed vertex each).
    pub cycles: usize,
    /// Heap pushes and pops.
    pub pushes: usize,
    /// Heap pops.
    pub pops: usize,
    /// Nodes freed by dissolves.
    pub freed: usize,
    /// Edge evaluations when pushing edges (each reads both endpoints' records).
    pub evals: usize,
    /// Events pushed again after a dissolve: the edges from other trees' `+` nodes into the
    /// freed nodes.
    pub cross_pushes: usize,
    /// Wall time (s) of the phases: greedy start, fractional local searches, fractional
    /// forest, main-phase single-tree searches, main-phase forest.
    pub phase_s: [f64; 5],
    /// Searches of the fractional start's second local pass, and how many of them ended
    /// (an augmentation or an odd cycle) within its budget.
    pub wide_searches: [usize; 2],
    /// Trees left to the fractional forest and to the main forest.
    pub forest_trees: [usize; 2],
    /// Cumulative (grows, edge evaluations, heap pops) at the end of each phase.
    pub phase_counts: [(usize, usize, usize); 5],
    /// Variable-δ forest: dual updates, those where trees moved by different amounts,
    /// components joined through a tight `(+, −)` edge between trees, and augmentations
    /// found in a pair-of-trees heap.
    pub var_rounds: usize,
    /// See [`Stats::var_rounds`].
    pub var_split_rounds: usize,
    /// See [`Stats::var_rounds`].
    pub var_joins: usize,
    /// See [`Stats::var_rounds`].
    pub var_pair_augments: usize,
    /// Variable-δ forest: components of trees found free to move without bound (a Tutte
    /// witness in the main phase, trees left to the main phase in the fractional one).
    pub var_stuck: usize,
    /// A fractional start in blocks ([`Solver::init_fractional_blocks`]): the wall time
    /// (s) of the blocks side by side and of their join (the passes on the whole graph
    /// after it count in `phase_s`; the blocks' counters are added to the others), and the
    /// vertices the join released (their duals lowered to make the edges between blocks
    /// feasible).
    pub blocks_s: f64,
    /// See [`Stats::blocks_s`].
    pub released: usize,
}

impl Solver {
    /// Builds the solver state (CSR adjacency, doubled costs). Loops and edges with an
    /// endpoint `>= n` are dropped. Panics when `n >= 2^30` or there are `2^31` edges or more
    /// (u32 indices; such graphs would need tens of gigabytes anyway).
    #[cfg(any(test, feature = "testing"))]
    pub fn new(n: usize, edges: &[(u32, u32, i64)]) -> Solver {
        Solver::new_in_order(n, edges, VertexOrder::BreadthFirst)
    }

    /// [`Solver::new`] with the internal vertex numbering `order` (the result is in the
    /// caller's numbering whatever it is).
    pub fn new_in_order(n: usize, edges: &[(u32, u32, i64)], order: VertexOrder) -> Solver {
        // u32 indices: half-edge ids below 2^32, node ids (vertices and blossoms, < 1.5 n)
        // below the EXPAND flag bit.
        assert!(
            edges.len() < u32::MAX as usize / 2 && n < EXPAND as usize / 2,
            "matching: too many edges or vertices for u32 indices"
        );
        let order = match order {
            VertexOrder::BreadthFirst => locality_order(n, edges),
            VertexOrder::Given => (0..n as u32).collect(),
        };
        let mut perm = vec![0u32; n];
        for (new, &old) in order.iter().enumerate() {
            perm[old as usize] = new as u32;
        }
        // Half-edges in new ids, grouped by their first endpoint (counting sort), so that a
        // vertex's edges sit together in memory and pushing them touches one or two cache
        // lines.
        let mut adj_start = vec![0u32; n + 1];
        for &(u, v, _) in edges {
            if u != v && (u as usize) < n && (v as usize) < n {
                adj_start[perm[u as usize] as usize + 1] += 1;
                adj_start[perm[v as usize] as usize + 1] += 1;
            }
        }
        for v in 0..n {
            adj_start[v + 1] += adj_start[v];
        }
        let mut fill = adj_start.clone();
        let doubled = |c: i64| 2 * c.clamp(-MAX_ABS_COST, MAX_ABS_COST);
        let narrow = edges
            .iter()
            .all(|&(_, _, c)| i32::try_from(doubled(c)).is_ok());
        let mut ed = vec![Edge { v: 0, c: 0 }; adj_start[n] as usize];
        let mut wide_costs = if narrow {
            Vec::new()
        } else {
            vec![0i64; adj_start[n] as usize]
        };
        for &(u, v, c) in edges {
            if u == v || u as usize >= n || v as usize >= n {
                continue;
            }
            let (a, b) = (perm[u as usize], perm[v as usize]);
            let c = doubled(c);
            for (x, w) in [(a, b), (b, a)] {
                let slot = &mut fill[x as usize];
                if narrow {
                    ed[*slot as usize] = Edge { v: w, c: c as i32 };
                } else {
                    ed[*slot as usize] = Edge { v: w, c: 0 };
                    wide_costs[*slot as usize] = c;
                }
                *slot += 1;
            }
        }
        drop(fill);
        Solver::from_csr(n, order, perm, adj_start, ed, wide_costs)
    }

    /// The solver state over the given internal numbering (`order[new] = old`, `perm` its
    /// inverse; both empty for a solver that never builds a result) and half-edges
    /// (`adj_start`, `ed`, `wide_costs` as in [`Solver`]'s fields): all duals 0, nothing
    /// matched, no blossom.
    fn from_csr(
        n: usize,
        order: Vec<u32>,
        perm: Vec<u32>,
        adj_start: Vec<u32>,
        ed: Vec<Edge>,
        wide_costs: Vec<i64>,
    ) -> Solver {
        let mut s = Solver {
            n,
            order,
            perm,
            ed,
            wide_costs,
            adj_start,
            mate: vec![NONE; n],
            nd: Vec::new(),
            tedge: Vec::new(),
            children: Vec::new(),
            cyc: Vec::new(),
            free_blossoms: Vec::new(),
            sc: Vec::new(),
            gen: Vec::new(),
            heap: RadixHeap::new(),
            eps: 0,
            teps: Vec::new(),
            var_on: false,
            var: forest::VarQueues::default(),
            tree_lists: Vec::new(),
            freed: Vec::new(),
            mark: Vec::new(),
            mark_stamp: 0,
            scale: 2,
            mult: 1,
            stack: Vec::new(),
            stats: Stats::default(),
            progress: None,
            split: false,
            release: None,
        };
        s.new_node_arrays();
        s
    }

    /// Fresh per-node arrays (`nd`, `tedge`, `sc`, `gen`, `mark`) for the vertices alone:
    /// duals 0, no blossom, no tree.
    fn new_node_arrays(&mut self) {
        let n = self.n;
        // Room for the vertices and for every blossom that can be alive at once (a laminar
        // family of odd sets of at least 3 vertices has at most `n / 2` members; ids are
        // recycled), so that forming blossoms never reallocates them (a reallocation copies
        // the array while the old one still holds its memory); the room stays untouched,
        // hence not resident, until blossoms use it.
        let cap = n + n / 2;
        self.nd = Vec::with_capacity(cap);
        self.nd.extend((0..n as u32).map(Node::new));
        self.tedge = Vec::with_capacity(cap);
        self.tedge.resize(n, TreeEdge::NO);
        self.sc = Vec::with_capacity(cap);
        self.sc.resize(n, Cell::new(Shortcut::NO));
        self.gen = Vec::with_capacity(cap);
        self.gen.resize(n, 0);
        self.mark = Vec::with_capacity(cap);
        self.mark.resize(n, 0);
    }

    /// Frees the per-node arrays (until [`Solver::new_node_arrays`]).
    fn free_node_arrays(&mut self) {
        self.nd = Vec::new();
        self.tedge = Vec::new();
        self.sc = Vec::new();
        self.gen = Vec::new();
        self.mark = Vec::new();
    }

    /// Doubled cost of half-edge `i` (units of 1/2, as stored: times `mult` for current units).
    #[inline(always)]
    fn cost(&self, i: usize) -> i64 {
        if self.wide_costs.is_empty() {
            self.ed[i].c as i64
        } else {
            self.wide_costs[i]
        }
    }

    /// Reports progress to `f` as `(done, total)` during [`Solver::run`]: `total` is fixed
    /// (four phases of `n` units), `done` only grows, and calls are rare (at most about
    /// 64 per run, each between two searches, never inside one). The last call may stop
    /// short of `total`: the caller knows when the run ends.
    pub fn set_progress(&mut self, f: ProgressCallback) {
        self.progress = Some(Ticker { f, next: 0 });
    }

    /// Progress at `pos` of `of` in phase `phase` (0..4): a call when it is due. Cheap when
    /// not (one comparison), so loops call it once per iteration.
    #[inline]
    pub(super) fn tick(&mut self, phase: usize, pos: usize, of: usize) {
        if let Some(t) = &mut self.progress {
            let n = self.n;
            // units of this phase: `pos / of` of `n` (u128: no overflow for any n)
            let done = phase * n + (pos as u128 * n as u128 / of.max(1) as u128) as usize;
            if done >= t.next {
                let total = 4 * n;
                t.next = done + (total / Ticker::STEP).max(1);
                (t.f)(done.min(total), total);
            }
        }
    }

    /// Runs the jump start and then the tree growth from every exposed vertex.
    pub fn run(mut self) -> Result<Matching, NoPerfectMatching> {
        if self.split && self.n >= split::SPLIT_FROM {
            self.init_fractional_blocks(split::BLOCKS);
        } else {
            self.init_fractional();
        }
        self.grow_rest(MAIN_LOCAL_GROWS)?;
        Ok(self.into_result())
    }

    /// Has [`Solver::run`] run its fractional start in blocks side by side
    /// ([`Solver::init_fractional_blocks`], two blocks) when the graph has 200,000 vertices
    /// or more: the same optimum cost with its certificate (among tied optima maybe another
    /// one), a deterministic result, more memory. Off by default. `release`, called when
    /// the solver has freed its per-node arrays before the blocks allocate theirs, hands
    /// freed heap memory back to the system (the blocks allocate on other threads, whose
    /// allocator arenas would not reuse it).
    pub fn set_split(&mut self, split: bool, release: Option<fn()>) {
        self.split = split;
        self.release = release;
    }

    /// [`Solver::run`] with the fractional start split into `blocks` blocks
    /// ([`Solver::init_fractional_blocks`]) whatever the size (1: the single start); tests
    /// use it to exercise the split on small graphs.
    #[cfg(any(test, feature = "testing"))]
    pub fn run_in_blocks(mut self, blocks: usize) -> Result<Matching, NoPerfectMatching> {
        self.init_fractional_blocks(blocks);
        self.grow_rest(MAIN_LOCAL_GROWS)?;
        Ok(self.into_result())
    }

    /// Runs without jump start (all duals start at 0); used by tests to exercise the tree
    /// growth on its own.
    #[cfg(any(test, feature = "testing"))]
    pub fn run_plain(mut self) -> Result<Matching, NoPerfectMatching> {
        self.init_plain();
        self.solve_rest()
    }

    /// Grows a tree from every exposed vertex (after an init) and returns the result.
    #[cfg(any(test, feature = "testing"))]
    pub fn solve_rest(&mut self) -> Result<Matching, NoPerfectMatching> {
        self.solve_rest_with(MAIN_LOCAL_GROWS)
    }

    /// [`Solver::solve_rest`] with a given grow budget for the single-tree searches (0 leaves
    /// nearly everything to the forest grown together); tests use it to exercise both.
    #[cfg(any(test, feature = "testing"))]
    pub fn solve_rest_with(&mut self, budget: usize) -> Result<Matching, NoPerfectMatching> {
        self.grow_rest(budget)?;
        Ok(self.result())
    }

    /// The phases of [`Solver::solve_rest_with`] without building the result.
    fn grow_rest(&mut self, budget: usize) -> Result<(), NoPerfectMatching> {
        self.stats.exposed_after_init = self.mate.iter().filter(|&&m| m == NONE).count();
        let t = std::time::Instant::now();
        self.run_local(budget)?;
        self.stats.phase_s[3] = t.elapsed().as_secs_f64();
        self.stats.phase_counts[3] = (self.stats.grows, self.stats.evals, self.stats.pops);
        let t = std::time::Instant::now();
        self.run_forest_var()?;
        self.stats.phase_s[4] = t.elapsed().as_secs_f64();
        self.stats.phase_counts[4] = (self.stats.grows, self.stats.evals, self.stats.pops);
        Ok(())
    }

    /// [`Solver::result`] for a solver that is done: the arrays the result does not read
    /// (half-edges, shortcuts, queues, blossom cycles) are freed before it is built, so
    /// that the peak memory of a solve is that of its phases.
    fn into_result(mut self) -> Matching {
        let cost = self.matched_cost();
        self.ed = Vec::new();
        self.wide_costs = Vec::new();
        self.adj_start = Vec::new();
        self.sc = Vec::new();
        self.gen = Vec::new();
        self.mark = Vec::new();
        self.tedge = Vec::new();
        self.children = Vec::new();
        self.cyc = Vec::new();
        self.heap = RadixHeap::new();
        self.tree_lists = Vec::new();
        self.freed = Vec::new();
        self.result_with(cost)
    }

    /// Builds the public result: mates, cost, duals in the laminar-forest form.
    #[cfg(any(test, feature = "testing"))]
    fn result(&self) -> Matching {
        self.result_with(self.matched_cost())
    }

    /// Total input cost of the matching: for each matched pair, its cheapest input edge.
    fn matched_cost(&self) -> i64 {
        let n = self.n;
        // Cost: cheapest input edge for each matched pair (from its lower endpoint's range).
        let unit = 2; // `ed` costs are doubled
        let mut cost: i64 = 0;
        for u in 0..n {
            let m = self.mate[u];
            if (m as usize) <= u || m == NONE {
                continue;
            }
            let best = (self.adj_start[u] as usize..self.adj_start[u + 1] as usize)
                .filter(|&i| self.ed[i].v == m)
                .map(|i| self.cost(i))
                .min();
            if let Some(c) = best {
                cost += c / unit;
            }
        }
        cost
    }

    /// [`Solver::result`] with the matching's cost already known (reads `nd`, `mate`,
    /// `perm`, `order` only).
    #[allow(clippy::needless_range_loop)]
    fn result_with(&self, cost: i64) -> Matching {
        let n = self.n;
        // Blossoms alive: renumber.
        let total = self.nd.len();
        let mut id = vec![NONE; total];
        let mut blossoms = Vec::new();
        for b in n..total {
            if self.nd[b].label != DEAD {
                id[b] = blossoms.len() as u32;
                blossoms.push(BlossomDual {
                    parent: NONE,
                    dual: self.nd[b].y,
                });
            }
        }
        for b in n..total {
            if id[b] != NONE && self.nd[b].parent != NONE {
                blossoms[id[b] as usize].parent = id[self.nd[b].parent as usize];
            }
        }
        let vertex_blossom = (0..n)
            .map(|v| {
                let p = self.nd[self.perm[v] as usize].parent;
                if p == NONE {
                    NONE
                } else {
                    id[p as usize]
                }
            })
            .collect();
        Matching {
            mate: (0..n)
                .map(|v| self.order[self.mate[self.perm[v] as usize] as usize])
                .collect(),
            cost,
            duals: Duals {
                scale: self.scale,
                vertex: (0..n).map(|v| self.nd[self.perm[v] as usize].y).collect(),
                blossoms,
                vertex_blossom,
            },
        }
    }
}

/// A vertex order with good memory locality: breadth-first search, component by component,
/// from the lowest unvisited vertex. Neighbours of a vertex get nearby numbers, which keeps the
/// solver's random accesses inside few cache lines on mesh graphs. Returns `order[new] = old`.
fn locality_order(n: usize, edges: &[(u32, u32, i64)]) -> Vec<u32> {
    let mut start = vec![0u32; n + 1];
    for &(u, v, _) in edges {
        if u != v && (u as usize) < n && (v as usize) < n {
            start[u as usize + 1] += 1;
            start[v as usize + 1] += 1;
        }
    }
    for v in 0..n {
        start[v + 1] += start[v];
    }
    let mut fill = start.clone();
    let mut nb = vec![0u32; start[n] as usize];
    for &(u, v, _) in edges {
        if u != v && (u as usize) < n && (v as usize) < n {
            nb[fill[u as usize] as usize] = v;
            fill[u as usize] += 1;
            nb[fill[v as usize] as usize] = u;
            fill[v as usize] += 1;
        }
    }
    drop(fill);
    let mut seen = vec![false; n];
    let mut order = Vec::with_capacity(n);
    for s in 0..n {
        if seen[s] {
            continue;
        }
        seen[s] = true;
        let mut head = order.len();
        order.push(s as u32);
        while head < order.len() {
            let x = order[head] as usize;
            head += 1;
            for &w in &nb[start[x] as usize..start[x + 1] as usize] {
                if !seen[w as usize] {
                    seen[w as usize] = true;
                    order.push(w);
                }
            }
        }
    }
    order
}
