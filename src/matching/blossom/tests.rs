//! The solver's invariants after each phase ([`Solver::check_invariants`]), on small random
//! graphs, against the brute-force oracle and the optimality certificate.

use super::{Solver, NONE};
use crate::matching::{oracle::brute_force_min_cost, verify, verify_witness};

/// A small deterministic generator (64-bit LCG, high bits).
struct Rng(u64);

impl Rng {
    fn below(&mut self, k: u64) -> u64 {
        self.0 = self
            .0
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        (self.0 >> 33) % k
    }
}

fn random_graph(rng: &mut Rng, n: usize, p_percent: u64, range: i64) -> Vec<(u32, u32, i64)> {
    let mut edges = Vec::new();
    for u in 0..n as u32 {
        for v in u + 1..n as u32 {
            if rng.below(100) < p_percent {
                edges.push((u, v, rng.below(range as u64) as i64 - range / 3));
            }
        }
    }
    edges
}

fn check(s: &Solver, what: &str) {
    if let Err(e) = s.check_invariants() {
        panic!("after {what}: {e}");
    }
}

/// Counters over all runs, to show the checks met blossoms, expansions and graphs without a
/// perfect matching.
#[derive(Default)]
struct Seen {
    shrinks: usize,
    expands: usize,
    no_matching: usize,
}

/// Runs the phases of five start sequences, checking the invariants after each, and the
/// result against the oracle (`expect`) and the certificate.
fn run_all(n: usize, edges: &[(u32, u32, i64)], expect: Option<i64>, seen: &mut Seen) {
    for start in 0..5 {
        let mut s = Solver::new(n, edges);
        let main_budget = match start {
            0 => {
                s.init_greedy();
                check(&s, "greedy start");
                256
            }
            1 => {
                s.init_fractional();
                check(&s, "fractional start");
                256
            }
            2 => {
                s.init_plain();
                check(&s, "plain start");
                0
            }
            3 => {
                s.init_fractional_with(0, 0);
                check(&s, "fractional start, budget 0");
                0
            }
            _ => {
                s.init_greedy();
                check(&s, "greedy start");
                1
            }
        };
        let res = s.solve_rest_with(main_budget);
        check(&s, "main phase");
        seen.shrinks += s.stats.shrinks;
        seen.expands += s.stats.expands;
        match (expect, res) {
            (Some(c), Ok(m)) => {
                assert_eq!(m.cost, c, "start {start}: n={n} {edges:?}");
                if let Err(e) = verify(n, edges, &m) {
                    panic!("start {start}: certificate: {e}: n={n} {edges:?}");
                }
            }
            (None, Err(w)) => {
                seen.no_matching += 1;
                if let Err(e) = verify_witness(n, edges, &w) {
                    panic!("start {start}: witness: {e}: n={n} {edges:?}");
                }
            }
            (e, r) => panic!("start {start}: oracle {e:?}, solver {r:?}: n={n} {edges:?}"),
        }
    }
}

#[test]
fn every_phase_keeps_the_invariants_on_small_random_graphs() {
    let mut rng = Rng(7);
    let mut seen = Seen::default();
    for iter in 0..1500 {
        let n = 2 + rng.below(13) as usize; // 2..14, odd ones included
        let p = [20, 35, 60, 100][iter % 4];
        let range = [1, 3, 10, 1000][(iter / 4) % 4];
        let edges = random_graph(&mut rng, n, p, range);
        let expect = brute_force_min_cost(n, &edges);
        run_all(n, &edges, expect, &mut seen);
    }
    assert!(seen.shrinks > 100, "few blossoms formed: {}", seen.shrinks);
    assert!(seen.expands > 10, "few blossoms expanded: {}", seen.expands);
    assert!(
        seen.no_matching > 100,
        "few graphs without a perfect matching"
    );
}

#[test]
fn every_phase_keeps_the_invariants_on_mid_size_sparse_graphs() {
    // Sparse graphs of 60-200 vertices, costs with many ties: nested blossoms. The optimum
    // comes from the default run (certified), the other starts must reach the same cost.
    let mut rng = Rng(11);
    let mut seen = Seen::default();
    for iter in 0..40 {
        let n = 60 + 2 * rng.below(71) as usize;
        let mut edges = Vec::new();
        for u in 0..n as u32 {
            for _ in 0..3 {
                let v = rng.below(n as u64) as u32;
                edges.push((u, v, rng.below([4, 50][iter % 2]) as i64));
            }
            // A ring keeps the graph connected.
            edges.push((u, (u + 1) % n as u32, 40));
        }
        let reference = Solver::new(n, &edges).run();
        let expect = reference.as_ref().ok().map(|m| m.cost);
        if let Ok(m) = &reference {
            assert!(verify(n, &edges, m).is_ok());
        }
        run_all(n, &edges, expect, &mut seen);
    }
    assert!(seen.shrinks > 100, "few blossoms formed: {}", seen.shrinks);
}

#[test]
fn check_invariants_rejects_broken_states() {
    // A 6-cycle with a chord, solved: then break one thing at a time.
    let edges = [
        (0, 1, 2),
        (1, 2, 3),
        (2, 3, 1),
        (3, 4, 5),
        (4, 5, 2),
        (5, 0, 4),
        (0, 3, 1),
    ];
    let solved = || {
        let mut s = Solver::new(6, &edges);
        s.init_plain();
        s.solve_rest_with(0).expect("perfect matching");
        s
    };
    assert_eq!(solved().check_invariants(), Ok(()));
    let rule = |s: &Solver| s.check_invariants().map_err(|e| e.rule);

    let mut s = solved();
    s.nd[0].y += 1_000; // an edge at vertex 0 gets negative slack
    assert_eq!(rule(&s), Err("dual feasibility"));

    let mut s = solved();
    let m = s.mate[0] as usize;
    s.mate[m] = NONE; // one-sided match
    assert_eq!(rule(&s), Err("matching"));

    let mut s = solved();
    s.nd[0].y -= 1_000; // every edge at 0 loose: its matched edge is no longer tight
    assert_eq!(rule(&s), Err("tight edges"));

    let mut s = solved();
    s.nd[0].label = super::PLUS; // a `+` label outside any tree
    assert_eq!(rule(&s), Err("trees"));
}

#[test]
fn check_invariants_rejects_a_broken_blossom() {
    // The first random graph whose solved state keeps a blossom.
    let mut rng = Rng(3);
    let (mut s, b) = (0..200)
        .find_map(|_| {
            let edges = random_graph(&mut rng, 12, 40, 3);
            let mut s = Solver::new(12, &edges);
            s.init_plain();
            s.solve_rest_with(0).ok()?;
            let b = (s.n..s.nd.len()).find(|&b| s.nd[b].label != super::DEAD)?;
            Some((s, b))
        })
        .expect("some solved state keeps a blossom");
    assert_eq!(s.check_invariants(), Ok(()));
    s.children[b - s.n].pop(); // an even number of children
    assert_eq!(
        s.check_invariants().map_err(|e| e.rule),
        Err("laminar blossoms")
    );
}

/// Solves with the fractional start in `blocks` blocks, checking the invariants after the
/// start and after the main phase; returns the result and the vertices the join released.
fn run_blocks(
    n: usize,
    edges: &[(u32, u32, i64)],
    blocks: usize,
) -> (Result<crate::matching::Matching, crate::matching::NoPerfectMatching>, usize) {
    let mut s = Solver::new(n, edges);
    s.init_fractional_blocks(blocks);
    check(&s, &format!("fractional start in {blocks} blocks"));
    let res = s.solve_rest_with(super::MAIN_LOCAL_GROWS);
    check(&s, &format!("main phase after {blocks} blocks"));
    (res, s.stats.released)
}

#[test]
fn a_start_in_blocks_keeps_the_invariants_and_the_optimum_on_small_random_graphs() {
    // Odd blocks, blocks without a perfect matching of their own (odd, or a vertex whose
    // edges all cross a seam), graphs without any, empty blocks (more blocks than
    // vertices): the optimum and its certificate, or a witness, every time.
    let mut rng = Rng(41);
    let (mut released, mut no_matching) = (0, 0);
    for iter in 0..1200 {
        let n = 2 + rng.below(13) as usize; // 2..14, odd ones included
        let p = [20, 35, 60, 100][iter % 4];
        let range = [1, 3, 10, 1000][(iter / 4) % 4];
        let mut edges = random_graph(&mut rng, n, p, range);
        if iter % 7 == 0 {
            // doubled costs beyond `i32`: the blocks copy the wide cost array
            for e in &mut edges {
                e.2 <<= 28;
            }
        }
        let expect = brute_force_min_cost(n, &edges);
        for blocks in 2..=5 {
            let (res, r) = run_blocks(n, &edges, blocks);
            released += r;
            match (expect, res) {
                (Some(c), Ok(m)) => {
                    assert_eq!(m.cost, c, "{blocks} blocks: n={n} {edges:?}");
                    if let Err(e) = verify(n, &edges, &m) {
                        panic!("{blocks} blocks: certificate: {e}: n={n} {edges:?}");
                    }
                }
                (None, Err(w)) => {
                    no_matching += 1;
                    if let Err(e) = verify_witness(n, &edges, &w) {
                        panic!("{blocks} blocks: witness: {e}: n={n} {edges:?}");
                    }
                }
                (e, r) => panic!("{blocks} blocks: oracle {e:?}, solver {r:?}: n={n} {edges:?}"),
            }
        }
    }
    assert!(released > 500, "few vertices released at seams: {released}");
    assert!(no_matching > 100, "few graphs without a perfect matching");
}

#[test]
fn a_start_in_blocks_reaches_the_single_start_optimum_on_mid_size_sparse_graphs() {
    // Sparse graphs of 60-400 vertices with tied costs: half-matched cycles in the blocks,
    // some broken at a seam; the same cost as the single start, certified, and the same
    // result on a second run.
    let mut rng = Rng(43);
    let mut released = 0;
    for iter in 0..40 {
        let n = 60 + 2 * rng.below(171) as usize;
        let mut edges = Vec::new();
        for u in 0..n as u32 {
            for _ in 0..2 {
                let v = rng.below(n as u64) as u32;
                edges.push((u, v, rng.below([4, 50][iter % 2]) as i64));
            }
            edges.push((u, (u + 1) % n as u32, 40));
        }
        let single = Solver::new(n, &edges).run_in_blocks(1);
        let reference = Solver::new(n, &edges).run();
        assert_eq!(single, reference, "one block: the single start");
        let mut asked = Solver::new(n, &edges);
        asked.set_split(true, None);
        assert_eq!(asked.run(), reference, "below the size threshold: the single start");
        let single = single.expect("a ring of even length has a perfect matching");
        for blocks in [2, 3, 7] {
            let (res, r) = run_blocks(n, &edges, blocks);
            released += r;
            let m = res.expect("perfect matching");
            assert_eq!(m.cost, single.cost, "{blocks} blocks, iteration {iter}");
            assert!(verify(n, &edges, &m).is_ok(), "{blocks} blocks");
            let again = Solver::new(n, &edges).run_in_blocks(blocks);
            assert_eq!(again.as_ref(), Ok(&m), "{blocks} blocks: another result");
        }
    }
    assert!(released > 100, "few vertices released at seams: {released}");
}

#[test]
fn joining_blocks_lowers_a_seam_dual_and_breaks_the_cycle_through_it() {
    // Internal order = breadth-first from 0: triangle 0-1-2 (cost 2 each: a half-matched
    // cycle in block 0 = {0, 1, 2}), then 3, 4, 5 (block 1, a tight pair 4-5 and 3 alone).
    // The seam edge 2-3 of cost 0 is violated once each block has raised its duals: the
    // join lowers the dual of 2, the cycle is matched along 0-1, 2 stays exposed.
    let edges = [
        (0, 1, 2),
        (1, 2, 2),
        (2, 0, 2),
        (2, 3, 0),
        (3, 4, 6),
        (4, 5, 2),
        (3, 5, 6),
    ];
    let (res, released) = run_blocks(6, &edges, 2);
    let m = res.expect("perfect matching");
    assert_eq!(Some(m.cost), brute_force_min_cost(6, &edges));
    assert!(verify(6, &edges, &m).is_ok());
    // vertex 2 alone: the seam's only violated edge, seen from its lower endpoint
    assert_eq!(released, 1);
}
