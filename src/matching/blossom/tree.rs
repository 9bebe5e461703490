//! Alternating trees: the single-tree searches of the main phase, growing a tree by one
//! `−` and one `+` node, dissolving a tree (its lazy duals committed), and the Tutte witness
//! when trees can grow without bound.

use super::{
    Event, NoPerfectMatching, Solver, Tight, TreeEdge, DEAD, EXPAND, FREE, MINUS, NONE, PLUS,
    PROGRESS_EVERY,
};

impl Solver {
    /// Single-tree searches from each exposed vertex in (locality) order, the other exposed
    /// vertices being plain targets with fixed duals (vertex duals are free in the
    /// perfect-matching LP, so one tree may move alone). A search that needs more than
    /// `budget` grow steps is abandoned, its dual changes and blossoms kept, and its root left
    /// to [`Solver::run_forest`].
    pub(super) fn run_local(&mut self, budget: usize) -> Result<(), NoPerfectMatching> {
        self.new_trees(1);
        for r in 0..self.n as u32 {
            if r & PROGRESS_EVERY == 0 {
                self.tick(2, r as usize, self.n);
            }
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

    /// Empty node lists and zero dual changes for trees `0..k`.
    pub(super) fn new_trees(&mut self, k: usize) {
        self.tree_lists = vec![Vec::new(); k];
        self.teps = vec![0; k];
    }

    /// Makes top-level node `root` the `+` root of tree `t` (at `ε = 0`); its edges are not
    /// pushed.
    pub(super) fn make_root(&mut self, root: u32, t: u32) {
        let nd = &mut self.nd[root as usize];
        nd.tree = t;
        nd.label = PLUS;
        nd.y -= self.eps + self.teps[t as usize];
        self.tree_lists[t as usize].push(root);
    }

    /// Starts a single-tree search from top-level node `root`: an empty heap, `ε = 0`, tree 0.
    pub(super) fn start_single_tree(&mut self, root: u32) {
        self.eps = 0;
        self.heap.clear();
        self.make_root(root, 0);
        self.push_edges_of(root);
    }

    /// Ends a single-tree search: tree 0 is dissolved (its duals committed).
    pub(super) fn end_single_tree(&mut self) {
        self.dissolve(0);
        self.freed.clear();
    }

    /// Grows the single tree 0 until it augments, or gives up after `budget` grow steps.
    /// Err when it gets stuck (no perfect matching).
    pub(super) fn local_search(&mut self, budget: usize) -> Result<(), NoPerfectMatching> {
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

    pub(super) fn add_to_tree(&mut self, node: u32, lab: u8, t: u32) {
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

    /// `x` in a `+` node, `w` in a matched node outside the tree.
    pub(super) fn grow(&mut self, x: u32, w: u32) {
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
    pub(super) fn up2(&self, p: u32) -> u32 {
        let m = self.mate[self.nd[p as usize].base as usize];
        if m == NONE {
            return NONE;
        }
        let tm = self.top_of(m);
        self.top_of(self.tedge[tm as usize].par)
    }

    /// Commits the lazy duals of tree `t` and frees its nodes.
    pub(super) fn dissolve(&mut self, t: u32) {
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
    }

    /// Pushes the recorded edges from `+` nodes of other trees into freed nodes: they are
    /// grow events now.
    pub(super) fn push_freed(&mut self) {
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
    pub(super) fn stuck_witness(&mut self) -> NoPerfectMatching {
        self.stuck_witness_in(&|_| true)
    }

    /// [`Solver::stuck_witness`] restricted to the trees `t` with `keep(t)`: valid when the
    /// `+` nodes of those trees have edges only to their `−` vertices.
    pub(super) fn stuck_witness_in(&mut self, keep: &dyn Fn(u32) -> bool) -> NoPerfectMatching {
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
}
