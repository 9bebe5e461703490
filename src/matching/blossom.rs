//! The primal-dual blossom solver behind [`super::solve`].
//!
//! Edmonds' algorithm (1965) with the data-structure ideas of Kolmogorov's Blossom V (2009)
//! and of Galil, Micali & Gabow (1986):
//! 0. **Renumbering** (`locality_order`): vertices are renumbered in breadth-first order, so
//!    that neighbours share cache lines, and every edge is stored twice as half-edges grouped
//!    by their first endpoint (CSR), so a vertex's edges with their costs are contiguous. A
//!    heap entry carries its edge's endpoints and cost, so validating a popped event reads
//!    only the two endpoint records. Most time goes to cache misses on those records, so
//!    every per-node structure is kept small (24-byte node records, one 16-byte shortcut
//!    record, one tree-edge pair).
//! 1. **Jump start** ([`Solver::init_greedy`], then [`Solver::init_fractional`]): greedy duals
//!    `y_v` = cheapest cost at `v` (costs are doubled), each vertex raises its dual to its
//!    smallest slack and takes a tight edge to an exposed neighbour, short tight augmenting
//!    paths are flipped; then the fractional phase solves the LP without odd-set constraints
//!    with the same tree machinery (see the `fractional` module: single-tree local searches,
//!    then the rest of the trees grown together as in step 3), which leaves one exposed
//!    vertex per odd cycle of half-edges (e.g. 134 of 10^6 on the lattice family).
//! 2. **Single-tree searches** ([`Solver::solve_rest_with`]): from each exposed vertex in
//!    (locality) order, one alternating tree grows alone with its own dual change until it
//!    reaches another exposed node (augment) — vertex duals are free in the perfect-matching
//!    LP, so the other exposed vertices may keep theirs. Consecutive searches touch nearby
//!    memory. A search that needs more than a budget of grow steps (256) is abandoned; its
//!    dual changes and blossoms are kept (they are feasible), its root goes to step 3. (An
//!    unbounded single tree can wander very far on mesh graphs: on lattice-1e6 the main
//!    phase takes 4.5 s instead of 0.36 s.)
//! 3. **Forest**: every remaining exposed vertex roots an alternating tree and all trees grow
//!    together, so that far-apart trees meet half-way. Two modes ([`ForestMode`]):
//!    - *variable δ* (the default; the `var` module, Kolmogorov's scheme): every tree `T`
//!      has its own dual change `ε_T`; its own events (grow, shrink, expand) sit in a
//!      per-tree radix heap keyed by `ε_T`, the edges between two trees in per-pair heaps;
//!      rounds of primal steps alternate with dual updates that give each connected
//!      component of trees (joined by tight `(+, −)` edges) its own `δ` under the
//!      constraints `δ_T + δ_T' ≤ slack` (`(+, +)` edges) and `δ_T − δ_T' ≤ slack`
//!      (`(+ of T, − of T')` edges). Measured (best of 2-3, interleaved, shared machine):
//!      6-15% less CPU than the global mode at 10^6 and 4-8% at 4·10^6 on the lattice and
//!      random families, ~6% more instructions at 10^5 (where everything fits in cache).
//!      The number of grow steps is nearly the same (−8% in the fractional forest on
//!      lattice-4e6); the gain comes from the per-tree heaps being small and local;
//!    - *global ε*: all trees under one dual change `ε` and one radix heap, described below
//!      (the single-tree searches of step 2 use the same machinery with one tree).
//!
//!    Dual changes are lazy (in all modes): when a node joins a tree its stored dual is
//!    offset by `−ε` (`+` node) or `+ε` (`−` node), so its current dual is the stored value
//!    `+ ε` or `− ε` and a dual change costs O(1) (24-byte node records; in the variable
//!    mode `ε` is the tree's `ε_T`, `Solver::off`). Events live in one
//!    monotone radix heap ([`super::radix`]) keyed by the `ε` at which they happen:
//!    - `+` node to a free node (slack `s`): at `ε + s` → *grow*;
//!    - `+` to `+` (slack `s`): at `ε + s/2` → *shrink* into a blossom (same tree) or
//!      *augment* (different trees);
//!    - `+` node to an exposed node outside the trees (single-tree mode): at `ε + s` →
//!      *augment*;
//!    - `−` blossom with dual `y`: at `ε + y` → *expand*.
//!
//!    Among equal times, tree-ending events come first. Entries are validated when popped
//!    (lazy deletion) and re-pushed with the right key when the situation changed.
//! 4. After an augmentation only the two trees involved are dissolved (their duals committed).
//!    The only edges that become events then are those from `+` nodes of other trees into the
//!    dissolved `−` nodes (`+`→`−` slacks are constant in the global mode, so they had no heap
//!    entry): each tree keeps the list of them met so far (`cross`; in the variable mode they
//!    are the pair heaps), so a dissolve re-evaluates those instead of
//!    every edge of its `−` nodes (half the edge evaluations of the forest phases);
//!    blossoms persist until their dual drops to zero while `−` (Blossom V). The enclosing
//!    top-level blossom of a vertex is found through path-compressed shortcuts (every node
//!    on a walk gets one to the top, so deep nestings are walked once) that stay exact
//!    because the duals of non-top blossoms are frozen, so forming a blossom never relabels
//!    its vertices.
//!
//! If the heap runs dry while trees remain (in either mode), `ε` is unbounded: the `−`
//! vertices of the trees form a Tutte set whose removal isolates the more numerous `+` nodes
//! (each an odd set).
//!
//! Half-integral steps: costs are doubled, and when a `+`↔`+` slack is odd every cost, dual
//! and key is doubled again (`scale` records the factor; in practice it happens once), so all
//! arithmetic stays exact in `i64`.

use super::radix::RadixHeap;

mod fractional;
mod var;
use super::{BlossomDual, Duals, Matching, NoPerfectMatching, MAX_ABS_COST, NONE};
use std::cell::Cell;
pub use var::ForestMode;

const FREE: u8 = 0;
const PLUS: u8 = 1;
const MINUS: u8 = 2;
const DEAD: u8 = 3;
/// Heap ids with this bit set are "expand blossom" events, the others are edge ids.
const EXPAND: u32 = 1 << 31;
/// Grow steps a single-tree search of the main phase may take before it is left to the
/// forest grown together.
const MAIN_LOCAL_GROWS: usize = 256;

/// One half-edge: from `u` to `v`, and the cost (scaled) of the edge.
#[derive(Clone, Copy, Debug)]
struct Edge {
    u: u32,
    v: u32,
    c: i64,
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
    /// Half-edges (endpoints, doubled cost: units of 1/2, never rescaled), loops removed:
    /// every edge `{a, b}` appears as `(a, b)` and `(b, a)`.
    ed: Vec<Edge>,
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
    /// Global dual change `ε` (all trees move together).
    eps: i64,
    /// Per tree: its own dual change `ε_T` (variable-δ forest only; zero otherwise).
    teps: Vec<i64>,
    /// True while the variable-δ forest runs: edges are routed to per-tree heaps and
    /// per-pair-of-trees heaps (`var`) instead of `heap`.
    var_on: bool,
    /// The variable-δ forest's queues.
    var: var::VarQueues,
    /// Which forest the fractional and main phases use.
    forest_mode: ForestMode,
    /// Nodes that joined each tree (stale entries are filtered by `tree[node]`).
    tree_lists: Vec<Vec<u32>>,
    /// Per tree: half-edges from a `+` node of another tree to a `−` node of this tree
    /// (recorded when [`Solver::edge_key`] meets them; stale entries are harmless). They have
    /// no heap entry, and are the only edges that become events when the tree is dissolved.
    cross: Vec<Vec<Event>>,
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
    /// Events pushed from the cross-edge lists of dissolved trees.
    pub cross_pushes: usize,
    /// Wall time (s) of the phases: greedy start, fractional local searches, fractional
    /// forest, main-phase single-tree searches, main-phase forest.
    pub phase_s: [f64; 5],
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
}

impl Solver {
    /// Builds the solver state (CSR adjacency, doubled costs). Loops and edges with an
    /// endpoint `>= n` are dropped. Panics when `n >= 2^30` or there are `2^31` edges or more
    /// (u32 indices; such graphs would need tens of gigabytes anyway).
    pub fn new(n: usize, edges: &[(u32, u32, i64)]) -> Solver {
        // u32 indices: half-edge ids below 2^32, node ids (vertices and blossoms, < 1.5 n)
        // below the EXPAND flag bit.
        assert!(
            edges.len() < u32::MAX as usize / 2 && n < EXPAND as usize / 2,
            "matching: too many edges or vertices for u32 indices"
        );
        let order = locality_order(n, edges);
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
        let mut ed = vec![Edge { u: 0, v: 0, c: 0 }; adj_start[n] as usize];
        for &(u, v, c) in edges {
            if u == v || u as usize >= n || v as usize >= n {
                continue;
            }
            let (a, b) = (perm[u as usize], perm[v as usize]);
            let c = 2 * c.clamp(-MAX_ABS_COST, MAX_ABS_COST);
            for (x, w) in [(a, b), (b, a)] {
                let slot = &mut fill[x as usize];
                ed[*slot as usize] = Edge { u: x, v: w, c };
                *slot += 1;
            }
        }
        drop(fill);
        Solver {
            n,
            order,
            perm,
            ed,
            adj_start,
            mate: vec![NONE; n],
            nd: (0..n as u32).map(Node::new).collect(),
            tedge: vec![TreeEdge::NO; n],
            children: Vec::new(),
            cyc: Vec::new(),
            free_blossoms: Vec::new(),
            sc: vec![Cell::new(Shortcut::NO); n],
            gen: vec![0; n],
            heap: RadixHeap::new(),
            eps: 0,
            teps: Vec::new(),
            var_on: false,
            var: var::VarQueues::default(),
            forest_mode: ForestMode::DEFAULT,
            tree_lists: Vec::new(),
            cross: Vec::new(),
            freed: Vec::new(),
            mark: vec![0; n],
            mark_stamp: 0,
            scale: 2,
            mult: 1,
            stack: Vec::new(),
            stats: Stats::default(),
        }
    }

    /// Runs the jump start and then the tree growth from every exposed vertex.
    pub fn run(mut self) -> Result<Matching, NoPerfectMatching> {
        self.init_fractional();
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
            self.nd[v].y = self.min_incident_half(v);
        }
    }

    /// Grows a tree from every exposed vertex (after an init) and returns the result.
    pub fn solve_rest(&mut self) -> Result<Matching, NoPerfectMatching> {
        self.solve_rest_with(MAIN_LOCAL_GROWS)
    }

    /// [`Solver::solve_rest`] with a given grow budget for the single-tree searches (0 leaves
    /// nearly everything to the forest grown together); tests use it to exercise both.
    pub fn solve_rest_with(&mut self, budget: usize) -> Result<Matching, NoPerfectMatching> {
        self.stats.exposed_after_init = self.mate.iter().filter(|&&m| m == NONE).count();
        let t = std::time::Instant::now();
        self.run_local(budget)?;
        self.stats.phase_s[3] = t.elapsed().as_secs_f64();
        self.stats.phase_counts[3] = (self.stats.grows, self.stats.evals, self.stats.pops);
        let t = std::time::Instant::now();
        match self.forest_mode {
            ForestMode::Global => self.run_forest()?,
            ForestMode::Variable => self.run_forest_var()?,
        }
        self.stats.phase_s[4] = t.elapsed().as_secs_f64();
        self.stats.phase_counts[4] = (self.stats.grows, self.stats.evals, self.stats.pops);
        Ok(self.result())
    }

    /// Single-tree searches from each exposed vertex in (locality) order, the other exposed
    /// vertices being plain targets with fixed duals (vertex duals are free in the
    /// perfect-matching LP, so one tree may move alone). A search that needs more than
    /// `budget` grow steps is abandoned, its dual changes and blossoms kept, and its root left
    /// to [`Solver::run_forest`].
    fn run_local(&mut self, budget: usize) -> Result<(), NoPerfectMatching> {
        self.new_trees(1);
        for r in 0..self.n as u32 {
            if self.mate[r as usize] != NONE {
                continue;
            }
            let root = self.top_of(r);
            if self.mate[self.nd[root as usize].base as usize] != NONE {
                continue; // r is inside a blossom whose base is matched
            }
            self.start_single_tree(root);
            self.local_search(budget)?;
            self.end_single_tree();
        }
        self.tree_lists.clear();
        Ok(())
    }

    /// Empty node and cross-edge lists for trees `0..k`.
    fn new_trees(&mut self, k: usize) {
        self.tree_lists = vec![Vec::new(); k];
        self.cross = vec![Vec::new(); k];
        self.teps = vec![0; k];
    }

    /// Makes top-level node `root` the `+` root of tree `t` (at `ε = 0`); its edges are not
    /// pushed.
    fn make_root(&mut self, root: u32, t: u32) {
        let nd = &mut self.nd[root as usize];
        nd.tree = t;
        nd.label = PLUS;
        nd.y -= self.eps + self.teps[t as usize];
        self.tree_lists[t as usize].push(root);
    }

    /// Starts a single-tree search from top-level node `root`: an empty heap, `ε = 0`, tree 0.
    fn start_single_tree(&mut self, root: u32) {
        self.eps = 0;
        self.heap.clear();
        self.make_root(root, 0);
        self.push_edges_of(root);
    }

    /// Ends a single-tree search: tree 0 is dissolved (its duals committed).
    fn end_single_tree(&mut self) {
        self.dissolve(0);
        self.freed.clear();
    }

    /// Grows the single tree 0 until it augments, or gives up after `budget` grow steps.
    /// Err when it gets stuck (no perfect matching).
    fn local_search(&mut self, budget: usize) -> Result<(), NoPerfectMatching> {
        let mut grows = 0;
        loop {
            let Tight {
                u,
                v,
                tu,
                tv,
                pu,
                pv,
            } = self.next_tight()?;
            if pu && pv {
                self.shrink(u, v);
                continue;
            }
            let (x, w, tw) = if pu { (u, v, tv) } else { (v, u, tu) };
            if self.mate[self.nd[tw as usize].base as usize] == NONE {
                // Another exposed node (not growing now): augment into it.
                self.stats.augments += 1;
                self.augment_path(x, w);
                self.rebase(tw, w);
                self.mate[w as usize] = x;
                return Ok(());
            }
            if grows == budget {
                return Ok(());
            }
            grows += 1;
            self.grow(x, w);
        }
    }

    /// The next edge to become tight ([`Solver::pop_edge_event`]) with its endpoints' top
    /// blossoms and whether each is a "+" node of a tree; the Tutte witness when the heap
    /// runs dry (no perfect matching).
    #[inline]
    fn next_tight(&mut self) -> Result<Tight, NoPerfectMatching> {
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
    fn pop_edge_event(&mut self) -> Option<(u32, u32)> {
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
    fn next_event(&mut self, key: u64, ev: Event) -> Option<(u32, u32)> {
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

    fn min_incident_half(&self, v: usize) -> i64 {
        let (a, b) = (self.adj_start[v] as usize, self.adj_start[v + 1] as usize);
        self.ed[a..b]
            .iter()
            .map(|e| e.c * self.mult / 2)
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
                let s = self.ed[e].c * self.mult - self.nd[v].y - self.nd[w as usize].y;
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
    fn augment_short_paths(&mut self) {
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
    fn tight_other(&self, e: usize, x: u32) -> Option<u32> {
        let ed = self.ed[e];
        debug_assert_eq!(ed.u, x);
        let w = ed.v;
        (ed.c * self.mult - self.nd[x as usize].y - self.nd[w as usize].y == 0).then_some(w)
    }

    /// Current dual of a top-level node (lazy tree correction applied).
    #[inline]
    fn ycur(&self, node: u32) -> i64 {
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

    /// The dual change of tree `t` so far: the global `ε` plus the tree's own `ε_T` (one of
    /// the two is always zero: `ε_T` is used by the variable-δ forest only).
    #[inline]
    fn off(&self, t: u32) -> i64 {
        self.eps + self.teps[t as usize]
    }

    #[inline]
    fn in_tree(&self, node: u32, lab: u8) -> bool {
        self.nd[node as usize].tree != NONE && self.nd[node as usize].label == lab
    }

    /// Top-level node containing vertex `x`, and the sum of the duals of the nodes
    /// containing `x` below it (its own dual included when it is not top-level).
    #[inline(always)]
    fn find(&self, x: u32) -> (u32, i64) {
        if self.nd[x as usize].parent == NONE {
            return (x, 0);
        }
        self.find_inner(x)
    }

    /// [`Solver::find`] for a vertex inside a blossom (shortcut walk, path compression).
    #[inline(never)]
    fn find_inner(&self, x: u32) -> (u32, i64) {
        // One step up from non-top node `ni`: through its shortcut if still valid, else to
        // its parent; returns the next node and the duals summed on the way.
        let step = |ni: usize| -> (u32, i64) {
            let sc = self.sc[ni].get();
            if sc.to != NONE && sc.gen == self.gen[sc.to as usize] {
                (sc.to, sc.sum)
            } else {
                (self.nd[ni].parent, self.nd[ni].y)
            }
        };
        let mut node = x;
        let mut s = 0i64;
        let mut steps = 0u32;
        while self.nd[node as usize].parent != NONE {
            let (next, d) = step(node as usize);
            s += d;
            node = next;
            steps += 1;
        }
        let top = node;
        if steps > 0 {
            // Full path compression: every node on the walk gets a shortcut to `top`, so
            // deep nestings are walked once (the duals below the top level are frozen).
            let gen = self.gen[top as usize];
            let (mut node, mut rem) = (x, s);
            while node != top {
                let (next, d) = step(node as usize);
                self.sc[node as usize].set(Shortcut {
                    to: top,
                    gen,
                    sum: rem,
                });
                rem -= d;
                node = next;
            }
        }
        (top, s)
    }

    /// Top-level node containing vertex `x`.
    #[inline]
    fn top_of(&self, x: u32) -> u32 {
        self.find(x).0
    }

    /// Slack of edge `e` whose endpoints are in different top-level nodes.
    #[inline]
    fn slack(&self, e: Event) -> i64 {
        let (tu, iu) = self.find(e.u);
        let (tv, iv) = self.find(e.v);
        e.c * self.mult - iu - iv - self.ycur(tu) - self.ycur(tv)
    }

    /// Heap key of edge `e`, or None if it is not an event edge: the event time `ε` shifted
    /// left by one, with bit 0 clear for events that end a tree (`+`–`+`, `+` to an exposed
    /// or half-matched vertex) and set for grows, so that among equal times the tree-ending
    /// events come first (ties are the rule on mesh graphs). May rescale.
    fn edge_key(&mut self, e: Event) -> Option<i64> {
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
            let to = self.nd[other as usize].tree;
            if to != NONE {
                // `+`–`−` edge: slack does not change while both stay. Across two trees it
                // becomes an event when the `−` node's tree is dissolved: record it there.
                let plus = if pu { tu } else { tv };
                if to != self.nd[plus as usize].tree {
                    self.cross[to as usize].push(e);
                }
                return None;
            }
            let grow = self.mate[self.nd[other as usize].base as usize] != NONE;
            let t = self.eps + e.c * self.mult - iu - iv - self.ycur(tu) - self.ycur(tv);
            Some((t << 1) | grow as i64)
        } else {
            None
        }
    }

    fn push_edge(&mut self, e: Event) {
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
    fn push_edges_of(&mut self, node: u32) {
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
    fn push_vertex_edges(&mut self, x: u32) {
        let m = self.mate[x as usize];
        let (a, b) = (
            self.adj_start[x as usize] as usize,
            self.adj_start[x as usize + 1] as usize,
        );
        for i in a..b {
            let ed = self.ed[i];
            if ed.v != m {
                self.push_edge(Event {
                    c: ed.c,
                    u: ed.u,
                    v: ed.v,
                });
            }
        }
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

    fn add_to_tree(&mut self, node: u32, lab: u8, t: u32) {
        let i = node as usize;
        self.nd[i].tree = t;
        self.nd[i].label = lab;
        self.tree_lists[t as usize].push(node);
        if lab == PLUS {
            self.nd[i].y -= self.off(t);
            self.push_edges_of(node);
        } else {
            // Stored as `y + ε`: the current dual `y − ε` reaches 0 at `ε` = the stored value.
            self.nd[i].y += self.off(t);
            if i >= self.n {
                let k = self.nd[i].y;
                let ev = Event {
                    c: 0,
                    u: node | EXPAND,
                    v: NONE,
                };
                if self.var_on {
                    self.var_push_tree(t, (k << 1) | 1, ev);
                } else {
                    self.heap.push(((k << 1) | 1) as u64, ev);
                }
            }
        }
    }

    /// Grows one alternating tree per exposed vertex, all with the global `ε`, until every
    /// tree has been consumed by an augmentation.
    fn run_forest(&mut self) -> Result<(), NoPerfectMatching> {
        self.eps = 0;
        self.heap.clear();
        let roots: Vec<u32> = (0..self.n as u32)
            .filter(|&v| self.mate[v as usize] == NONE)
            .collect();
        let mut alive = roots.len();
        self.stats.forest_trees[1] = alive;
        self.new_trees(roots.len());
        for (t, &r) in roots.iter().enumerate() {
            self.make_root(self.top_of(r), t as u32);
        }
        for &r in &roots {
            self.push_edges_of(self.top_of(r));
        }
        while alive > 0 {
            let Tight {
                u,
                v,
                tu,
                tv,
                pu,
                pv,
            } = self.next_tight()?;
            if pu && pv {
                let (ta, tb) = (self.nd[tu as usize].tree, self.nd[tv as usize].tree);
                if ta == tb {
                    self.shrink(u, v);
                } else {
                    self.stats.augments += 1;
                    self.augment_path(u, v);
                    self.augment_path(v, u);
                    self.dissolve(ta);
                    self.dissolve(tb);
                    self.push_freed();
                    alive -= 2;
                }
            } else {
                let (x, w) = if pu { (u, v) } else { (v, u) };
                self.grow(x, w);
            }
        }
        Ok(())
    }

    /// `x` in a `+` node, `w` in a matched node outside the tree.
    fn grow(&mut self, x: u32, w: u32) {
        self.stats.grows += 1;
        let tw = self.top_of(w);
        self.tedge[tw as usize] = TreeEdge { own: w, par: x };
        let mb = self.mate[self.nd[tw as usize].base as usize];
        let tm = self.top_of(mb);
        let t = self.nd[self.top_of(x) as usize].tree;
        self.add_to_tree(tw, MINUS, t);
        self.add_to_tree(tm, PLUS, t);
    }

    /// The `+` node above `+` node `p` (grandparent in the tree), or NONE for the root.
    fn up2(&self, p: u32) -> u32 {
        let m = self.mate[self.nd[p as usize].base as usize];
        if m == NONE {
            return NONE;
        }
        let tm = self.top_of(m);
        self.top_of(self.tedge[tm as usize].par)
    }

    fn new_blossom_id(&mut self) -> u32 {
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
    fn lowest_common_plus(&mut self, tu: u32, tv: u32) -> u32 {
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
    fn tree_path_to(&self, mut p: u32, top: u32) -> Vec<(u32, (u32, u32))> {
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
    fn shrink(&mut self, u: u32, v: u32) {
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
    fn child_index(&self, b: u32, x: u32) -> usize {
        let mut c = x;
        while self.nd[c as usize].parent != b {
            c = self.nd[c as usize].parent;
        }
        let bi = b as usize - self.n;
        self.children[bi].iter().position(|&k| k == c).unwrap_or(0)
    }

    /// Expands `−` blossom `b` whose dual reached zero.
    fn expand(&mut self, b: u32) {
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
    fn augment_path(&mut self, x: u32, partner: u32) {
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
            self.nd[b as usize].base = x;
        }
        self.stack = work;
    }

    /// Commits the lazy duals of tree `t` and frees its nodes (they are queued in `freed`).
    fn dissolve(&mut self, t: u32) {
        let nodes = std::mem::take(&mut self.tree_lists[t as usize]);
        for &p in &nodes {
            let i = p as usize;
            if self.nd[i].parent == NONE && self.nd[i].label != DEAD && self.nd[i].tree == t {
                self.nd[i].y = self.ycur(p);
                self.nd[i].label = FREE;
                self.nd[i].tree = NONE;
                self.stats.freed += 1;
            }
        }
        // Edges from other trees' `+` nodes into a former `+` node already have a heap entry
        // (a `+`–`+` key, earlier than the new `+`–free time, fixed when popped); into a
        // former `−` node they have none: they are in `cross[t]` and must be pushed.
        let cross = std::mem::take(&mut self.cross[t as usize]);
        self.freed.extend_from_slice(&cross);
    }

    /// Pushes the recorded edges from `+` nodes of other trees into freed nodes: they are
    /// grow events now.
    fn push_freed(&mut self) {
        let freed = std::mem::take(&mut self.freed);
        let before = self.stats.pushes;
        for &e in &freed {
            self.push_edge(e);
        }
        self.stats.cross_pushes += self.stats.pushes - before;
        self.freed = freed;
        self.freed.clear();
    }

    /// Tutte witness when no event is left: `U` = vertices of the `−` nodes of all trees
    /// (all single vertices: a `−` blossom always has a pending expand event); every `+` node
    /// has edges only to `U` and is an odd set, and there are more `+` nodes than `−` nodes.
    fn stuck_witness(&mut self) -> NoPerfectMatching {
        self.stuck_witness_in(&|_| true)
    }

    /// [`Solver::stuck_witness`] restricted to the trees `t` with `keep(t)`: valid when the
    /// `+` nodes of those trees have edges only to their `−` vertices.
    fn stuck_witness_in(&mut self, keep: &dyn Fn(u32) -> bool) -> NoPerfectMatching {
        let mut witness = Vec::new();
        let mut slot = vec![NONE; self.nd.len()];
        let mut odd: Vec<Vec<u32>> = Vec::new();
        for v in 0..self.n as u32 {
            let p = self.top_of(v);
            if self.nd[p as usize].tree == NONE || !keep(self.nd[p as usize].tree) {
                continue;
            }
            match self.nd[p as usize].label {
                MINUS => witness.push(self.order[v as usize]),
                PLUS => {
                    if slot[p as usize] == NONE {
                        slot[p as usize] = odd.len() as u32;
                        odd.push(Vec::new());
                    }
                    odd[slot[p as usize] as usize].push(self.order[v as usize]);
                }
                _ => {}
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
        for e in 0..self.ed.len() {
            let (u, v) = (self.ed[e].u as usize, self.ed[e].v as usize);
            if u < v && self.mate[u] == v as u32 {
                let c = self.ed[e].c;
                best[u] = best[u].min(c);
                best[v] = best[v].min(c);
            }
        }
        let unit = 2; // `ed` costs are doubled
        let mut cost: i64 = 0;
        for v in 0..n {
            if (self.mate[v] as usize) > v && best[v] != i64::MAX {
                cost += best[v] / unit;
            }
        }
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
