//! Linear-time sorts of integer keys, for the checkers that run on every
//! [`crate::quadrangulate`] call (`recombine::check_invariants`, `validity`, the input
//! checks): an LSD radix sort over the bits the largest key uses, so sorting the edge lists
//! of a surface costs a few passes over them instead of a comparison sort's log n.

/// Lists shorter than this are sorted by comparison (the radix sort's histograms cost more).
const SMALL: usize = 256;

/// Sorts `v` by `key`, stably (equal keys keep their order): the same order as
/// `v.sort_by_key(key)`.
pub(crate) fn radix_sort_by_key<T: Copy>(v: &mut Vec<T>, key: impl Fn(&T) -> u64) {
    if v.len() < SMALL {
        v.sort_by_key(|x| key(x));
        return;
    }
    let max = v.iter().map(&key).max().unwrap_or(0);
    let bits = u64::BITS - max.leading_zeros();
    if bits == 0 {
        return;
    }
    let passes = bits.div_ceil(11);
    let digit = bits.div_ceil(passes);
    let buckets = 1usize << digit;
    let mask = (buckets - 1) as u64;
    // all histograms in one read
    let mut counts = vec![0usize; buckets * passes as usize];
    for x in v.iter() {
        let k = key(x);
        for p in 0..passes as usize {
            counts[p * buckets + ((k >> (p as u32 * digit)) & mask) as usize] += 1;
        }
    }
    let mut src = std::mem::take(v);
    let mut dst = src.clone();
    for p in 0..passes as usize {
        let count = &mut counts[p * buckets..(p + 1) * buckets];
        // one bucket holds every key: this digit does not reorder
        if count.contains(&src.len()) {
            continue;
        }
        let mut sum = 0;
        for c in count.iter_mut() {
            let n = *c;
            *c = sum;
            sum += n;
        }
        let shift = p as u32 * digit;
        for x in &src {
            let b = ((key(x) >> shift) & mask) as usize;
            dst[count[b]] = *x;
            count[b] += 1;
        }
        std::mem::swap(&mut src, &mut dst);
    }
    *v = src;
}

/// Bits the value `x` uses (0 for 0).
pub(crate) fn bits(x: u64) -> u32 {
    u64::BITS - x.leading_zeros()
}

/// Sorts `v` into the order of `v.sort_unstable()`, given an order-keeping `key`
/// (`x < y` implies `key(x) <= key(y)`): radix sorted by `key`, then each run of equal keys
/// sorted by comparison (short runs: a key that packs most of the element).
pub(crate) fn sort_by_prefix<T: Copy + Ord>(v: &mut Vec<T>, key: impl Fn(&T) -> u64) {
    radix_sort_by_key(v, &key);
    let mut i = 0;
    while i < v.len() {
        let k = key(&v[i]);
        let mut j = i + 1;
        while j < v.len() && key(&v[j]) == k {
            j += 1;
        }
        if j - i > 1 {
            v[i..j].sort_unstable();
        }
        i = j;
    }
}

/// Sorts `v` into the order of `v.sort_unstable()`, given an order-keeping `first`
/// (`x < y` implies `first(x) <= first(y)`), when the values of `first` span at most a few
/// times the list's length (node tags of a mesh surface): a counting sort by `first`, then
/// each bucket (a few elements) by comparison. Returns false, `v` unchanged, when they span
/// more.
pub(crate) fn bucket_sort<T: Copy + Ord + Default>(
    v: &mut Vec<T>,
    first: impl Fn(&T) -> u64,
) -> bool {
    let (mut lo, mut hi) = (u64::MAX, 0u64);
    for x in v.iter() {
        let k = first(x);
        lo = lo.min(k);
        hi = hi.max(k);
    }
    if v.is_empty() {
        return true;
    }
    if hi - lo > 4 * v.len() as u64 {
        return false;
    }
    let range = (hi - lo) as usize + 1;
    // start[k]: where the elements whose `first` is lo + k begin
    let mut start = vec![0usize; range + 1];
    for x in v.iter() {
        start[(first(x) - lo) as usize + 1] += 1;
    }
    for k in 1..=range {
        start[k] += start[k - 1];
    }
    let mut next = start.clone();
    let mut out = vec![T::default(); v.len()];
    for x in v.iter() {
        let k = (first(x) - lo) as usize;
        out[next[k]] = *x;
        next[k] += 1;
    }
    for w in start.windows(2) {
        if w[1] - w[0] > 1 {
            out[w[0]..w[1]].sort_unstable();
        }
    }
    *v = out;
    true
}

/// Sorts pairs of tags lexicographically (the order of `v.sort_unstable()`): a
/// [`bucket_sort`] by the first tag when it applies; else radix sorted on both packed in
/// one `u64` key when they fit; else by comparison.
pub(crate) fn sort_pairs(v: &mut Vec<(u64, u64)>) {
    if v.len() < SMALL {
        v.sort_unstable();
        return;
    }
    if bucket_sort(v, |x| x.0) {
        return;
    }
    let m1 = v.iter().map(|x| x.1).max().unwrap_or(0);
    let m0 = v.iter().map(|x| x.0).max().unwrap_or(0);
    let shift = bits(m1);
    if bits(m0) + shift >= u64::BITS {
        v.sort_unstable();
        return;
    }
    // the key is the pair itself: equal keys are equal pairs
    radix_sort_by_key(v, |&(a, b)| (a << shift) | b);
}

/// Cell indices (cells of `N` node indices into `coords`: triangles, quads) sorted by the
/// Morton (Z-order) code of their centroids, cells with the same code in their order, for
/// memory locality: consecutive cells are mostly neighbours. The centroids are computed once
/// (in parallel, in single precision: they only order), the codes quantize the centroids'
/// box to [`morton_bits`] bits per axis and are sorted by [`radix_sort_by_key`].
pub(crate) fn morton_order<const N: usize>(cells: &[[u32; N]], coords: &[glam::DVec3]) -> Vec<u32> {
    use glam::Vec3;
    use rayon::prelude::*;
    // the one pass that reads `coords` in the cells' (random) order
    let centroids: Vec<Vec3> = cells
        .par_iter()
        .with_min_len(4096)
        .map(|c| (c.iter().map(|&v| coords[v as usize]).sum::<glam::DVec3>() / N as f64).as_vec3())
        .collect();
    // min and max are exact, so the box does not depend on how the reduction splits
    let (lo, hi) = centroids
        .par_iter()
        .with_min_len(4096)
        .map(|&p| (p, p))
        .reduce(
            || (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY)),
            |a, b| (a.0.min(b.0), a.1.max(b.1)),
        );
    let per_axis = morton_bits(cells.len());
    let top = (1u64 << per_axis) - 1;
    let ext = (hi - lo).max_element();
    let scale = if ext > 0.0 && ext.is_finite() {
        top as f32 / ext
    } else {
        0.0
    };
    // spreads the low 21 bits of x to every third bit
    let spread = |x: u64| {
        let mut x = x & 0x1f_ffff;
        x = (x | x << 32) & 0x1f_0000_0000_ffff;
        x = (x | x << 16) & 0x1f_0000_ff00_00ff;
        x = (x | x << 8) & 0x100f_00f0_0f00_f00f;
        x = (x | x << 4) & 0x10c3_0c30_c30c_30c3;
        x = (x | x << 2) & 0x1249_2492_4924_9249;
        x
    };
    let mut keyed: Vec<(u64, u32)> = centroids
        .par_iter()
        .with_min_len(4096)
        .enumerate()
        .map(|(i, &c)| {
            let p = (c - lo) * scale;
            let k = |x: f32| {
                if x.is_finite() {
                    (x.max(0.0) as u64).min(top)
                } else {
                    0
                }
            };
            (
                spread(k(p.x)) | spread(k(p.y)) << 1 | spread(k(p.z)) << 2,
                i as u32,
            )
        })
        .collect();
    drop(centroids);
    radix_sort_by_key(&mut keyed, |&(code, _)| code);
    keyed.into_iter().map(|(_, i)| i).collect()
}

/// Bits per axis of the Morton codes of `n` cells: enough for a few grid cells per mesh
/// cell on a surface (about 4n cells of a 2D grid), no more, so the radix sort of the codes
/// takes 3 passes up to about 4·10^6 cells; at most 21 (a 63-bit code).
fn morton_bits(n: usize) -> u32 {
    (bits(n as u64).div_ceil(2) + 1).clamp(2, 21)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A deterministic pseudo-random sequence (xorshift).
    fn numbers(n: usize, seed: u64) -> Vec<u64> {
        let mut s = seed;
        (0..n)
            .map(|_| {
                s ^= s << 13;
                s ^= s >> 7;
                s ^= s << 17;
                s
            })
            .collect()
    }

    /// The cells of a 64 × 64 grid of unit squares, listed in a shuffled order, come out
    /// as a permutation in Z-order: the first four are the 2 × 2 block at the lowest corner,
    /// consecutive cells are on average under two cells apart (a shuffled list: about 40),
    /// and two cells with the same centroid keep their input order.
    #[test]
    fn the_morton_order_is_a_local_permutation() {
        let k = 64u32;
        let coords: Vec<glam::DVec3> = (0..=k)
            .flat_map(|j| (0..=k).map(move |i| glam::DVec3::new(f64::from(i), f64::from(j), 0.0)))
            .collect();
        let node = |i: u32, j: u32| j * (k + 1) + i;
        let mut cells: Vec<[u32; 4]> = (0..k)
            .flat_map(|j| {
                (0..k).map(move |i| {
                    [
                        node(i, j),
                        node(i + 1, j),
                        node(i + 1, j + 1),
                        node(i, j + 1),
                    ]
                })
            })
            .collect();
        let shuffle = numbers(cells.len(), 5);
        for i in (1..cells.len()).rev() {
            cells.swap(i, (shuffle[i] % (i as u64 + 1)) as usize);
        }
        // a copy of the last cell after it: the same code, so input order
        cells.push(cells[cells.len() - 1]);
        let order = morton_order(&cells, &coords);
        let mut sorted = order.clone();
        sorted.sort_unstable();
        assert!(sorted.iter().enumerate().all(|(i, &c)| c as usize == i));
        let centroid = |c: u32| {
            cells[c as usize]
                .iter()
                .map(|&v| coords[v as usize])
                .sum::<glam::DVec3>()
                / 4.0
        };
        let mut first: Vec<(i64, i64)> = order[..4]
            .iter()
            .map(|&c| {
                let p = centroid(c);
                (p.x.floor() as i64, p.y.floor() as i64)
            })
            .collect();
        first.sort_unstable();
        assert_eq!(first, [(0, 0), (0, 1), (1, 0), (1, 1)]);
        let mean_step = order
            .windows(2)
            .map(|w| centroid(w[0]).distance(centroid(w[1])))
            .sum::<f64>()
            / (order.len() - 1) as f64;
        assert!(mean_step < 2.0, "{mean_step}");
        let last = (cells.len() - 1) as u32;
        let at = |c: u32| order.iter().position(|&o| o == c);
        assert_eq!(at(last), at(last - 1).map(|p| p + 1));
    }

    #[test]
    fn the_radix_sort_is_a_stable_sort_by_key() {
        for (n, range) in [(10, 100), (5000, 1 << 17), (5000, 7), (3000, u64::MAX)] {
            let v: Vec<(u64, usize)> = numbers(n, 42)
                .into_iter()
                .enumerate()
                .map(|(i, x)| (if range == u64::MAX { x } else { x % range }, i))
                .collect();
            let mut a = v.clone();
            radix_sort_by_key(&mut a, |x| x.0);
            let mut b = v;
            b.sort_by_key(|x| x.0);
            assert_eq!(a, b, "n {n}, range {range}");
        }
    }

    #[test]
    fn pairs_sort_like_a_comparison_sort() {
        for (n, range) in [
            (100, 50),
            (20_000, 1 << 20),
            (20_000, 30_000),
            (20_000, 3),
            (20_000, 1 << 40),
            (2_000, u64::MAX),
        ] {
            let x = numbers(2 * n, 7);
            let v: Vec<(u64, u64)> = (0..n)
                .map(|i| {
                    let f = |y: u64| if range == u64::MAX { y } else { y % range };
                    (f(x[2 * i]), f(x[2 * i + 1]))
                })
                .collect();
            let mut a = v.clone();
            sort_pairs(&mut a);
            let mut b = v;
            b.sort_unstable();
            assert_eq!(a, b, "n {n}, range {range}");
        }
        // a key that packs only part of the element: runs sorted by comparison
        let x = numbers(3 * 5000, 9);
        let v: Vec<(u64, u64, u32)> = (0..5000)
            .map(|i| (x[3 * i] % 300, x[3 * i + 1] % 3, (x[3 * i + 2] % 5) as u32))
            .collect();
        let mut a = v.clone();
        sort_by_prefix(&mut a, |e| e.0 << 2 | e.1);
        let mut c = v.clone();
        assert!(bucket_sort(&mut c, |e| e.0));
        let mut b = v;
        b.sort_unstable();
        assert_eq!(a, b);
        assert_eq!(c, b);
        // first values spread too far for buckets: nothing done
        let mut far = vec![(0u64, 1u64), (1 << 40, 0)];
        assert!(!bucket_sort(&mut far, |e| e.0));
        assert_eq!(far, [(0, 1), (1 << 40, 0)]);
        // zeros in the second place (a shift of 0)
        let mut z: Vec<(u64, u64)> = (0..1000u64).rev().map(|i| (i, 0)).collect();
        sort_pairs(&mut z);
        assert!(z.windows(2).all(|w| w[0] < w[1]));
    }
}
