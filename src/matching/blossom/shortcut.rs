//! The top-level blossom of a vertex and the duals of the blossoms below it, through
//! path-compressed shortcuts (exact because the duals of non-top blossoms are frozen; a
//! shortcut dies when its target is expanded, which bumps the target's generation).

use super::{Shortcut, Solver, NONE};

impl Solver {
    /// Top-level node containing vertex `x`, and the sum of the duals of the nodes
    /// containing `x` below it (its own dual included when it is not top-level).
    #[inline(always)]
    pub(super) fn find(&self, x: u32) -> (u32, i64) {
        if self.nd[x as usize].parent == NONE {
            return (x, 0);
        }
        self.find_inner(x)
    }

    /// [`Solver::find`] for a vertex inside a blossom (shortcut walk, path compression).
    #[inline(never)]
    pub(super) fn find_inner(&self, x: u32) -> (u32, i64) {
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
    pub(super) fn top_of(&self, x: u32) -> u32 {
        self.find(x).0
    }
}
