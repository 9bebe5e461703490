//! [`Solver::check_invariants`]: what the solver keeps true between any two of its steps,
//! checked from its raw state (slow: for tests on small graphs).

use super::{Solver, DEAD, FREE, MINUS, NONE, PLUS};

/// An invariant of the solver's state that does not hold: which rule, and where (vertex and
/// blossom ids in the solver's internal numbering).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct InvariantError {
    /// The rule broken, e.g. `"dual feasibility"`.
    pub rule: &'static str,
    /// The nodes or edge concerned.
    pub detail: String,
}

impl std::fmt::Display for InvariantError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{}: {}", self.rule, self.detail)
    }
}

impl std::error::Error for InvariantError {}

fn broken(rule: &'static str, detail: String) -> Result<(), InvariantError> {
    Err(InvariantError { rule, detail })
}

impl Solver {
    /// Checks the solver's state:
    /// - **matching**: `mate` is symmetric and never maps a vertex to itself;
    /// - **laminar blossoms**: every live blossom has an odd number (≥ 3) of children whose
    ///   parent it is, the parent links form a forest, and its base is its first child's base;
    /// - **blossom cycles**: consecutive children are joined by the recorded cycle edge, which
    ///   is tight, and every vertex of a blossom but its base is matched inside it;
    /// - **dual feasibility**: every edge has reduced cost `≥ 0` (current duals, lazy tree
    ///   offsets applied) and every blossom dual is `≥ 0`;
    /// - **tight edges**: matched edges and the tree edges of `−` nodes have reduced cost 0;
    /// - **trees**: a top-level node outside the trees is free; a `+` node is a root with an
    ///   exposed base or is matched into a `−` node of its tree; a `−` node is matched into a
    ///   `+` node of its tree and hangs from a `+` node of its tree;
    /// - **shortcuts**: the path-compressed lookup gives the same top blossom and dual sum as
    ///   walking the parent links.
    ///
    /// Holds after any start ([`Solver::init_plain`], [`Solver::init_greedy`],
    /// [`Solver::init_fractional`]; [`Solver::new`] alone has all duals 0, infeasible for
    /// negative costs) and after every later phase, including one that found no perfect
    /// matching. Cost `O(m · d)` for blossom nesting depth `d`; meant for tests.
    pub fn check_invariants(&self) -> Result<(), InvariantError> {
        let n = self.n;
        let total = self.nd.len();
        if self.mate.len() != n || self.children.len() != total - n || self.cyc.len() != total - n {
            return broken("shape", format!("{n} vertices, {total} nodes"));
        }
        for v in 0..n {
            let m = self.mate[v];
            if m != NONE
                && (m as usize >= n || m as usize == v || self.mate[m as usize] != v as u32)
            {
                return broken("matching", format!("mate[{v}] = {m}"));
            }
        }
        // Parent links: from a live node to a live blossom listing it, without cycles.
        for x in 0..total {
            if self.nd[x].label == DEAD {
                continue;
            }
            let p = self.nd[x].parent;
            if p == NONE {
                continue;
            }
            let pi = p as usize;
            if pi < n || pi >= total || self.nd[pi].label == DEAD {
                return broken("laminar blossoms", format!("node {x} has parent {p}"));
            }
            if !self.children[pi - n].contains(&(x as u32)) {
                return broken("laminar blossoms", format!("{p} does not list child {x}"));
            }
            let mut y = p;
            let mut steps = 0;
            while y != NONE {
                steps += 1;
                if steps > total {
                    return broken("laminar blossoms", format!("parent cycle above {x}"));
                }
                y = self.nd[y as usize].parent;
            }
        }
        for b in n..total {
            if self.nd[b].label == DEAD {
                continue;
            }
            let (ch, cy) = (&self.children[b - n], &self.cyc[b - n]);
            if ch.len() < 3 || ch.len() % 2 == 0 || cy.len() != ch.len() {
                return broken(
                    "laminar blossoms",
                    format!(
                        "blossom {b}: {} children, {} cycle edges",
                        ch.len(),
                        cy.len()
                    ),
                );
            }
            if let Some(&c) = ch.iter().find(|&&c| self.nd[c as usize].parent != b as u32) {
                return broken(
                    "laminar blossoms",
                    format!("child {c} of {b} has another parent"),
                );
            }
            if self.nd[b].base != self.nd[ch[0] as usize].base {
                return broken(
                    "laminar blossoms",
                    format!("blossom {b}: base not its first child's"),
                );
            }
            let k = ch.len();
            for (i, &(a, c)) in cy.iter().enumerate() {
                if !self.contains(ch[i], a) || !self.contains(ch[(i + 1) % k], c) {
                    return broken(
                        "blossom cycles",
                        format!(
                            "blossom {b}: edge ({a}, {c}) does not join children {i}, {}",
                            i + 1
                        ),
                    );
                }
                if self.min_slack(a, c) != Some(0) {
                    return broken(
                        "blossom cycles",
                        format!("blossom {b}: cycle edge ({a}, {c}) not tight"),
                    );
                }
            }
            let dual = if self.nd[b].parent == NONE {
                self.ycur(b as u32)
            } else {
                self.nd[b].y
            };
            if dual < 0 {
                return broken("dual feasibility", format!("blossom {b} has dual {dual}"));
            }
        }
        // Inside a blossom every vertex but the base is matched inside it.
        for v in 0..n as u32 {
            let mut b = self.nd[v as usize].parent;
            while b != NONE {
                let m = self.mate[v as usize];
                let inside = m != NONE && self.contains(b, m);
                if inside == (self.nd[b as usize].base == v) {
                    return broken(
                        "blossom cycles",
                        format!(
                            "vertex {v} (mate {m}) in blossom {b} with base {}",
                            self.nd[b as usize].base
                        ),
                    );
                }
                b = self.nd[b as usize].parent;
            }
        }
        // Reduced costs.
        for u in 0..n as u32 {
            for i in self.adj_start[u as usize] as usize..self.adj_start[u as usize + 1] as usize {
                let v = self.ed[i].v;
                if u < v {
                    let s = self.reduced_cost(u, v, self.cost(i));
                    if s < 0 {
                        return broken(
                            "dual feasibility",
                            format!("edge ({u}, {v}) has slack {s}"),
                        );
                    }
                }
            }
        }
        for v in 0..n as u32 {
            let m = self.mate[v as usize];
            if m != NONE && v < m && self.min_slack(v, m) != Some(0) {
                return broken("tight edges", format!("matched edge ({v}, {m}) not tight"));
            }
        }
        // Trees.
        for x in 0..total as u32 {
            let nd = self.nd[x as usize];
            if nd.label == DEAD || nd.parent != NONE {
                continue;
            }
            if nd.tree == NONE {
                if nd.label != FREE {
                    return broken("trees", format!("node {x} outside the trees is not free"));
                }
                continue;
            }
            let in_tree = |v: u32, lab: u8| {
                let t = self.top_of(v);
                self.nd[t as usize].tree == nd.tree && self.nd[t as usize].label == lab
            };
            let m = self.mate[nd.base as usize];
            match nd.label {
                PLUS => {
                    if m != NONE && !in_tree(m, MINUS) {
                        return broken("trees", format!("+ node {x} matched outside a − node"));
                    }
                }
                MINUS => {
                    let te = self.tedge[x as usize];
                    if m == NONE || !in_tree(m, PLUS) {
                        return broken("trees", format!("− node {x} not matched into a + node"));
                    }
                    if te.own == NONE || !self.contains(x, te.own) || !in_tree(te.par, PLUS) {
                        return broken("trees", format!("− node {x}: bad tree edge {te:?}"));
                    }
                    if self.min_slack(te.own, te.par) != Some(0) {
                        return broken("tight edges", format!("tree edge of − node {x} not tight"));
                    }
                }
                _ => return broken("trees", format!("tree node {x} has label {}", nd.label)),
            }
        }
        // Shortcuts.
        for v in 0..n as u32 {
            let (mut node, mut sum) = (v, 0i64);
            while self.nd[node as usize].parent != NONE {
                sum += self.nd[node as usize].y;
                node = self.nd[node as usize].parent;
            }
            if self.find(v) != (node, sum) {
                return broken(
                    "shortcuts",
                    format!(
                        "vertex {v}: lookup {:?}, walk {:?}",
                        self.find(v),
                        (node, sum)
                    ),
                );
            }
        }
        Ok(())
    }

    /// Whether node `node` contains vertex `v` (walking `v`'s parent links).
    fn contains(&self, node: u32, v: u32) -> bool {
        let mut x = v;
        loop {
            if x == node {
                return true;
            }
            x = self.nd[x as usize].parent;
            if x == NONE {
                return false;
            }
        }
    }

    /// The nodes containing vertex `v`, innermost first, with their current duals.
    fn chain(&self, v: u32) -> Vec<(u32, i64)> {
        let mut out = Vec::new();
        let mut x = v;
        while x != NONE {
            let p = self.nd[x as usize].parent;
            let y = if p == NONE {
                self.ycur(x)
            } else {
                self.nd[x as usize].y
            };
            out.push((x, y));
            x = p;
        }
        out
    }

    /// Reduced cost (current units) of an edge `(u, v)` of doubled cost `c`: the cost minus
    /// the duals of the nodes containing exactly one of `u`, `v`.
    fn reduced_cost(&self, u: u32, v: u32, c: i64) -> i64 {
        let (cu, cv) = (self.chain(u), self.chain(v));
        let crossing = |a: &[(u32, i64)], b: &[(u32, i64)]| -> i64 {
            a.iter()
                .filter(|(x, _)| !b.iter().any(|(y, _)| y == x))
                .map(|&(_, y)| y)
                .sum()
        };
        c * self.mult - crossing(&cu, &cv) - crossing(&cv, &cu)
    }

    /// The smallest reduced cost of the edges joining vertices `u` and `v`, if any.
    fn min_slack(&self, u: u32, v: u32) -> Option<i64> {
        let (a, b) = (
            self.adj_start[u as usize] as usize,
            self.adj_start[u as usize + 1] as usize,
        );
        (a..b)
            .filter(|&i| self.ed[i].v == v)
            .map(|i| self.reduced_cost(u, v, self.cost(i)))
            .min()
    }
}
