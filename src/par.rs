//! Running independent pieces of work (one per surface) on the rayon pool.

use rayon::prelude::*;

/// `f` applied to every item, the largest by `size` first, each item taken by the next idle
/// thread, so that a large item does not start last and run alone; the results come back
/// in the order of `items` (equal sizes start in that order too). Right when each result
/// depends on its item alone, as each surface's does in the recombination and the
/// optimizer.
pub(crate) fn largest_first<T: Send, R: Send>(
    items: Vec<T>,
    size: impl Fn(&T) -> usize,
    f: impl Fn(T) -> R + Sync + Send,
) -> Vec<R> {
    let mut jobs: Vec<(usize, T)> = items.into_iter().enumerate().collect();
    jobs.sort_by_key(|j| std::cmp::Reverse(size(&j.1)));
    let mut results: Vec<(usize, R)> = jobs
        .into_iter()
        .par_bridge()
        .map(|(i, t)| (i, f(t)))
        .collect();
    results.sort_unstable_by_key(|r| r.0);
    results.into_iter().map(|r| r.1).collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn results_come_back_in_the_items_order() {
        let items: Vec<usize> = vec![3, 40, 7, 40, 1, 12];
        let out = largest_first(items.clone(), |&x| x, |x| 2 * x);
        assert_eq!(out, items.iter().map(|x| 2 * x).collect::<Vec<_>>());
    }
}
