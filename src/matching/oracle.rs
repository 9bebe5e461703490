//! Brute-force oracle for tests: exact minimum-cost perfect matching by dynamic programming
//! over vertex subsets, `O(2^n · n)` time and `O(2^n)` memory, for `n ≤ 24`.

/// Minimum cost of a perfect matching (cheapest copy of parallel edges, loops ignored), or
/// `None` if there is none or `n > 24`.
pub fn brute_force_min_cost(n: usize, edges: &[(u32, u32, i64)]) -> Option<i64> {
    if n > 24 {
        return None;
    }
    if n == 0 {
        return Some(0);
    }
    let mut w = vec![None::<i64>; n * n];
    for &(u, v, c) in edges {
        let (u, v) = (u as usize, v as usize);
        if u == v || u >= n || v >= n {
            continue;
        }
        for (a, b) in [(u, v), (v, u)] {
            let slot = &mut w[a * n + b];
            *slot = Some(slot.map_or(c, |old: i64| old.min(c)));
        }
    }
    // dp[mask] = min cost to match exactly the vertices in `mask`; the lowest vertex of the
    // mask is matched first, so each matching is counted once.
    let full = (1usize << n) - 1;
    let mut dp = vec![None::<i64>; full + 1];
    dp[0] = Some(0);
    for mask in 1..=full {
        if mask.count_ones() % 2 == 1 {
            continue;
        }
        let i = mask.trailing_zeros() as usize;
        let rest = mask & !(1 << i);
        let mut best: Option<i64> = None;
        let mut r = rest;
        while r != 0 {
            let j = r.trailing_zeros() as usize;
            r &= r - 1;
            if let (Some(c), Some(sub)) = (w[i * n + j], dp[rest & !(1 << j)]) {
                let t = c + sub;
                best = Some(best.map_or(t, |b| b.min(t)));
            }
        }
        dp[mask] = best;
    }
    dp[full]
}
