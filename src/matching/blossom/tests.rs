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
