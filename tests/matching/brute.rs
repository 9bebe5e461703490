//! Matching solver against the brute-force oracle on many small random graphs.

use blossomquad::matching::{
    self,
    blossom::{Solver, Stats},
    oracle::brute_force_min_cost,
};
use std::cell::RefCell;

use crate::matching_common;
use matching_common::Rng;

fn random_graph(rng: &mut Rng, n: usize, p_percent: u64, cost_range: i64) -> Vec<(u32, u32, i64)> {
    let mut edges = Vec::new();
    for u in 0..n as u32 {
        for v in u + 1..n as u32 {
            if rng.below(100) < p_percent {
                let c = rng.below(cost_range as u64) as i64 - cost_range / 3;
                edges.push((u, v, c));
            }
        }
    }
    edges
}

thread_local! {
    /// Forest counters summed over the checks of this thread:
    /// (dual updates, split updates, joins, pair augmentations).
    static VAR: RefCell<[usize; 4]> = const { RefCell::new([0; 4]) };
}

fn add_var(st: &Stats) {
    VAR.with(|v| {
        let mut v = v.borrow_mut();
        v[0] += st.var_rounds;
        v[1] += st.var_split_rounds;
        v[2] += st.var_joins;
        v[3] += st.var_pair_augments;
    });
}

/// Solves with both entry points and checks them against the oracle and the certificate.
/// Returns how many events the starts pushed from dissolved trees' cross-edge lists.
fn check(n: usize, edges: &[(u32, u32, i64)]) -> usize {
    let mut cross = 0;
    let expect = brute_force_min_cost(n, edges);
    // Ten starts: fractional (the path of `Solver::run`, which `matching::solve` below
    // takes), then none, greedy only, fractional with local-search budgets 0 and 1 (work left
    // to the forest), main phase with single-tree budgets 0 and 1 (work left to the forest);
    // then plain start with main budget 0 (every tree in the forest, blossoms from scratch),
    // greedy with main budget 0, fractional with both budgets 0.
    for start in 0..10 {
        let mut s = Solver::new(n, edges);
        let res = match start {
            0 => {
                s.init_fractional();
                let r = s.solve_rest();
                add_var(&s.stats);
                r
            }
            1 => s.run_plain(),
            2 => {
                s.init_greedy();
                let r = s.solve_rest();
                cross += s.stats.cross_pushes;
                r
            }
            3 | 4 => {
                s.init_fractional_with(start - 3, 0);
                let r = s.solve_rest();
                cross += s.stats.cross_pushes;
                r
            }
            5 | 6 => {
                s.init_fractional();
                let r = s.solve_rest_with(start - 5);
                cross += s.stats.cross_pushes;
                r
            }
            _ => {
                match start {
                    7 => s.init_plain(),
                    8 => s.init_greedy(),
                    _ => s.init_fractional_with(0, 0),
                }
                let r = s.solve_rest_with(0);
                add_var(&s.stats);
                r
            }
        };
        match (expect, res) {
            (Some(c), Ok(m)) => {
                assert_eq!(m.cost, c, "n={n} edges={edges:?} start={start}");
                if let Err(e) = matching::verify(n, edges, &m) {
                    panic!("certificate failed: {e} n={n} edges={edges:?} start={start}");
                }
            }
            (None, Err(w)) => {
                if let Err(e) = matching::verify_witness(n, edges, &w) {
                    panic!("witness failed: {e} n={n} edges={edges:?} w={w:?}");
                }
            }
            (Some(c), Err(w)) => panic!("solver failed {w:?}, optimum {c}: n={n} {edges:?}"),
            (None, Ok(m)) => panic!("solver found {m:?} but none exists: n={n} {edges:?}"),
        }
    }
    // The public entry (component split) must agree too.
    match (expect, matching::solve(n, edges)) {
        (Some(c), Ok(m)) => {
            assert_eq!(m.cost, c);
            if let Err(e) = matching::verify(n, edges, &m) {
                panic!("certificate failed (solve): {e} n={n} edges={edges:?}");
            }
        }
        (None, Err(w)) => assert!(matching::verify_witness(n, edges, &w).is_ok()),
        _ => panic!("solve disagrees with oracle: n={n} {edges:?}"),
    }
    cross
}

#[test]
fn random_dense_and_sparse_graphs() {
    let mut rng = Rng(12345);
    let mut cross = 0;
    for iter in 0..3000 {
        let n = 2 + 2 * rng.below(7) as usize; // 2..14 even
        let p = [15, 30, 50, 80, 100][iter % 5];
        let range = [1, 2, 3, 10, 1000][(iter / 5) % 5];
        let edges = random_graph(&mut rng, n, p, range.max(1));
        cross += check(n, &edges);
    }
    // The forest starts must reach the dissolve path that re-pushes the edges other trees
    // had into a dissolved tree's nodes.
    assert!(cross > 0, "no cross-edge event was ever pushed");
    // The forest starts must really give trees different dual changes, join trees
    // through tight `(+, −)` edges and augment between trees.
    let [rounds, split, joins, pair_aug] = VAR.with(|v| *v.borrow());
    eprintln!("variable δ: rounds {rounds} split {split} joins {joins} pair augments {pair_aug}");
    assert!(split > 100, "split rounds {split} of {rounds}");
    assert!(joins > 100, "joins {joins}");
    assert!(pair_aug > 1000, "pair augmentations {pair_aug}");
}

#[test]
fn random_odd_sizes_and_multigraphs() {
    let mut rng = Rng(777);
    for _ in 0..1500 {
        let n = 1 + rng.below(12) as usize;
        let mut edges = random_graph(&mut rng, n, 40, 5);
        // Parallel edges and loops.
        for _ in 0..rng.below(6) {
            let u = rng.below(n as u64) as u32;
            let v = rng.below(n as u64) as u32;
            edges.push((u, v, rng.below(7) as i64 - 2));
        }
        check(n, &edges);
    }
}

#[test]
fn costs_beyond_i32() {
    // Doubled costs that do not fit in an `i32` (the solver then keeps its costs in a
    // separate `i64` array): all of them large, or one large edge among small ones, and
    // costs saturated at `MAX_ABS_COST`.
    let mut rng = Rng(31337);
    for iter in 0..600 {
        let n = 2 + 2 * rng.below(6) as usize;
        let mut edges = random_graph(&mut rng, n, 50, 1000);
        match iter % 3 {
            0 => edges.iter_mut().for_each(|e| e.2 *= 1 << 28),
            1 => {
                if let Some(e) = edges.first_mut() {
                    e.2 = (1 << 31) + rng.below(3) as i64;
                }
            }
            _ => {
                if let Some(e) = edges.last_mut() {
                    e.2 = -matching::MAX_ABS_COST;
                }
            }
        }
        check(n, &edges);
    }
}

#[test]
fn all_equal_costs() {
    let mut rng = Rng(4242);
    for _ in 0..800 {
        let n = 2 + 2 * rng.below(7) as usize;
        let mut edges = random_graph(&mut rng, n, 45, 1);
        for e in &mut edges {
            e.2 = 7;
        }
        check(n, &edges);
    }
}

#[test]
fn random_graphs_exercise_blossoms() {
    // Guards the value of the tests above: the random families do create and expand blossoms
    // and do rescale duals.
    let mut rng = Rng(99);
    let (mut shrinks, mut expands, mut rescales) = (0, 0, 0);
    for _ in 0..500 {
        let n = 2 + 2 * rng.below(7) as usize;
        let edges = random_graph(&mut rng, n, 50, 1000);
        let mut s = Solver::new(n, &edges);
        s.init_plain();
        let _ = s.solve_rest();
        shrinks += s.stats.shrinks;
        expands += s.stats.expands;
        rescales += s.stats.rescales;
    }
    assert!(shrinks > 50, "shrinks {shrinks}");
    assert!(expands > 5, "expands {expands}");
    eprintln!("shrinks {shrinks} expands {expands} rescales {rescales}");
}

mod properties {
    use super::check;
    use proptest::prelude::*;

    fn graph() -> impl Strategy<Value = (usize, Vec<(u32, u32, i64)>)> {
        (1usize..=12).prop_flat_map(|n| {
            let e = (0..n as u32, 0..n as u32, -20i64..40);
            (Just(n), proptest::collection::vec(e, 0..40))
        })
    }

    proptest! {
        #![proptest_config(ProptestConfig { cases: 400, ..ProptestConfig::default() })]

        /// Optimal cost equals brute force, certificate or witness verifies, for both
        /// starts and the public entry point.
        #[test]
        fn agrees_with_brute_force((n, edges) in graph()) {
            check(n, &edges);
        }

        /// Relabelling the vertices does not change the optimum.
        #[test]
        fn invariant_under_relabelling((n, edges) in graph(), seed in any::<u64>()) {
            let mut perm: Vec<u32> = (0..n as u32).collect();
            let mut s = seed | 1;
            for i in (1..n).rev() {
                s ^= s << 13; s ^= s >> 7; s ^= s << 17;
                perm.swap(i, (s % (i as u64 + 1)) as usize);
            }
            let relabelled: Vec<_> = edges.iter().map(|&(u, v, c)| (perm[u as usize], perm[v as usize], c)).collect();
            let a = blossomquad::matching::solve(n, &edges).map(|m| m.cost).ok();
            let b = blossomquad::matching::solve(n, &relabelled).map(|m| m.cost).ok();
            prop_assert_eq!(a, b);
        }
    }
}
