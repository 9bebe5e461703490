//! The half-edges of a triangle list sorted by edge key (a parallel bucketed counting sort,
//! no hash maps) and the runs of equal keys, scanned by pieces in parallel.

use super::*;

/// The half-edges `3t + k` of a triangle list, sorted by (edge key, half-edge).
pub(crate) enum SortedHalves {
    /// Key and half-edge packed in one `u64`: `key_bits << p | half_edge`.
    Packed {
        /// Packed values, sorted.
        v: Vec<u64>,
        /// Bits of the half-edge part.
        p: u32,
    },
    /// `(edge_key, half_edge)` pairs, sorted.
    Pairs(Vec<(u64, u32)>),
}

impl SortedHalves {
    /// Calls `f` with the half-edges of each run of equal keys, in key order.
    #[cfg(test)]
    pub fn runs(&self, f: impl FnMut(&[u32])) {
        match self {
            SortedHalves::Packed { v, p } => packed_runs(v, *p, f),
            SortedHalves::Pairs(v) => pair_runs(v, f),
        }
    }

    /// [`SortedHalves::runs`] on consecutive pieces of the list in parallel, each cut
    /// between two runs: every piece folds its runs, in key order, into a state made by
    /// `init`; the states come back in piece (so key) order. Lists below [`RUN_PIECE`]
    /// half-edges are one piece.
    pub fn par_runs<S: Send>(
        &self,
        init: impl Fn() -> S + Sync,
        f: impl Fn(&mut S, &[u32]) + Sync,
    ) -> Vec<S> {
        match self {
            SortedHalves::Packed { v, p } => {
                let cuts = run_cuts(v.len(), |i| v[i - 1] >> p == v[i] >> p);
                fold_pieces(&cuts, init, |s, (a, b)| {
                    packed_runs(&v[a..b], *p, |run| f(s, run))
                })
            }
            SortedHalves::Pairs(v) => {
                let cuts = run_cuts(v.len(), |i| v[i - 1].0 == v[i].0);
                fold_pieces(&cuts, init, |s, (a, b)| {
                    pair_runs(&v[a..b], |run| f(s, run))
                })
            }
        }
    }
}

/// Half-edges per piece of [`SortedHalves::par_runs`] (about).
pub(super) const RUN_PIECE: usize = 1 << 16;

/// The runs of packed values `v` (key above bit `p`, half-edge below).
pub(super) fn packed_runs(v: &[u64], p: u32, mut f: impl FnMut(&[u32])) {
    let mut buf: Vec<u32> = Vec::with_capacity(4);
    let low = (1u64 << p) - 1;
    for run in v.chunk_by(|x, y| x >> p == y >> p) {
        buf.clear();
        buf.extend(run.iter().map(|x| (x & low) as u32));
        f(&buf);
    }
}

/// The runs of `(key, half-edge)` pairs `v`.
pub(super) fn pair_runs(v: &[(u64, u32)], mut f: impl FnMut(&[u32])) {
    let mut buf: Vec<u32> = Vec::with_capacity(4);
    for run in v.chunk_by(|x, y| x.0 == y.0) {
        buf.clear();
        buf.extend(run.iter().map(|x| x.1));
        f(&buf);
    }
}

/// Boundaries `0 = c_0 < c_1 < … < c_m = len` of pieces of about [`RUN_PIECE`] elements of a
/// list of runs, never inside a run (`same(i)`: elements `i − 1` and `i` are in one run).
pub(super) fn run_cuts(len: usize, same: impl Fn(usize) -> bool) -> Vec<usize> {
    let pieces = len.div_ceil(RUN_PIECE).max(1);
    let mut cuts = vec![0];
    for i in 1..pieces {
        let mut c = (i * len / pieces).max(*cuts.last().unwrap_or(&0));
        while c > 0 && c < len && same(c) {
            c += 1;
        }
        if c > *cuts.last().unwrap_or(&0) && c < len {
            cuts.push(c);
        }
    }
    if len > 0 {
        cuts.push(len);
    }
    cuts
}

/// Folds each piece `(cuts[i], cuts[i + 1])` into a fresh state, in parallel; states in order.
pub(super) fn fold_pieces<S: Send>(
    cuts: &[usize],
    init: impl Fn() -> S + Sync,
    f: impl Fn(&mut S, (usize, usize)) + Sync,
) -> Vec<S> {
    cuts.par_windows(2)
        .map(|w| {
            let mut s = init();
            f(&mut s, (w[0], w[1]));
            s
        })
        .collect()
}

/// Sorts the half-edges of `tris` by [`edge_key`].
///
/// When a key and a half-edge index fit in 64 bits together (node ids below 2^b and
/// half-edges below 2^p with 2b + p ≤ 64: up to about 2^20 nodes and 2^22 half-edges, more
/// when the other is smaller), they are packed in one `u64` and sorted as integers by
/// [`sort_packed`]; otherwise by a parallel comparison sort. Both give the same order.
pub(crate) fn sorted_half_edges(tris: &[[u32; 3]]) -> SortedHalves {
    let halves = 3 * tris.len();
    let (min_id, max_id) = tris
        .par_iter()
        .with_min_len(1 << 14)
        .map(|t| (t[0].min(t[1]).min(t[2]), t[0].max(t[1]).max(t[2])))
        .reduce(|| (u32::MAX, 0), |x, y| (x.0.min(y.0), x.1.max(y.1)));
    let bits = |x: u64| 64 - x.leading_zeros();
    let b = bits(max_id as u64);
    let p = bits(halves.saturating_sub(1) as u64);
    if halves < 1 << 16 || 2 * b + p > 64 {
        let mut keys: Vec<(u64, u32)> = Vec::with_capacity(halves);
        for (t, tri) in tris.iter().enumerate() {
            for k in 0..3 {
                keys.push((edge_key(tri[k], tri[(k + 1) % 3]), (3 * t + k) as u32));
            }
        }
        keys.par_sort_unstable();
        return SortedHalves::Pairs(keys);
    }
    SortedHalves::Packed {
        v: sort_packed(tris, b, p, min_id..=max_id),
        p,
    }
}

/// Triangles per piece of [`sort_packed`]'s first pass.
pub(super) const SORT_PIECE: usize = 1 << 15;

/// The half-edges of `tris` packed as `lo << (b + p) | hi << p | half_edge` (`lo < hi` the
/// node ids of the edge, in `ids`, below 2^b; half-edges below 2^p), sorted ascending. The
/// values are distinct, so this is the one order of (edge key, half-edge).
///
/// Parallel in two passes: pieces of triangles pack their half-edges and group them by the
/// top bits of `lo − min` (buckets of a few thousand values); then each bucket gathers its
/// groups from every piece and sorts itself: by counting on the rest of `lo`, then by
/// comparison inside each `lo` (a few values), or by comparison alone when `lo` spreads
/// much wider than the bucket holds values.
pub(super) fn sort_packed(tris: &[[u32; 3]], b: u32, p: u32, ids: std::ops::RangeInclusive<u32>) -> Vec<u64> {
    let halves = 3 * tris.len();
    let min = *ids.start();
    let span_bits = keysort::bits(ids.end().saturating_sub(min) as u64);
    // top bits of lo − min: about 2048 values per bucket, at most 2^12 buckets
    let top = keysort::bits((halves / 2048) as u64)
        .saturating_sub(1)
        .min(12)
        .min(span_bits);
    let buckets = 1usize << top;
    let lo_shift = b + p;
    let sub_bits = span_bits - top;
    let sub_mask = (1u64 << sub_bits) - 1;
    let rel = |v: u64| (v >> lo_shift) - min as u64;
    let bucket = |v: u64| (rel(v) >> sub_bits) as usize;
    // pass 1: per piece, its values grouped by bucket and where each group starts
    let pieces: Vec<(Vec<u64>, Vec<usize>)> = tris
        .par_chunks(SORT_PIECE)
        .enumerate()
        .map(|(c, chunk)| {
            let first = 3 * c * SORT_PIECE;
            let mut start = vec![0usize; buckets + 1];
            let mut vals: Vec<u64> = Vec::with_capacity(3 * chunk.len());
            for (i, tri) in chunk.iter().enumerate() {
                for k in 0..3 {
                    let (x, y) = (tri[k], tri[(k + 1) % 3]);
                    let (lo, hi) = if x < y { (x, y) } else { (y, x) };
                    let v =
                        ((lo as u64) << lo_shift) | ((hi as u64) << p) | (first + 3 * i + k) as u64;
                    start[bucket(v) + 1] += 1;
                    vals.push(v);
                }
            }
            for j in 1..=buckets {
                start[j] += start[j - 1];
            }
            let mut next = start.clone();
            let mut grouped = vec![0u64; vals.len()];
            for &v in &vals {
                let g = bucket(v);
                grouped[next[g]] = v;
                next[g] += 1;
            }
            (grouped, start)
        })
        .collect();
    // pass 2: each bucket's slice of the output, filled and sorted on its own
    let mut out = vec![0u64; halves];
    let mut slices: Vec<&mut [u64]> = Vec::with_capacity(buckets);
    let mut rest: &mut [u64] = &mut out;
    for g in 0..buckets {
        let size: usize = pieces.iter().map(|(_, s)| s[g + 1] - s[g]).sum();
        let (head, tail) = std::mem::take(&mut rest).split_at_mut(size);
        slices.push(head);
        rest = tail;
    }
    slices.into_par_iter().enumerate().for_each_init(
        Vec::new,
        |count: &mut Vec<usize>, (g, slice)| {
            let parts = || {
                pieces
                    .iter()
                    .map(|(vals, start)| &vals[start[g]..start[g + 1]])
            };
            if 1usize << sub_bits > 4 * slice.len() + 64 {
                // lo spread thin: a comparison sort beats counting over the spread
                let mut at = 0;
                for part in parts() {
                    slice[at..at + part.len()].copy_from_slice(part);
                    at += part.len();
                }
                slice.sort_unstable();
                return;
            }
            // counting sort on the low bits of lo (start of each lo's values, then its end)
            count.clear();
            count.resize((1 << sub_bits) + 1, 0);
            for &v in parts().flatten() {
                count[(rel(v) & sub_mask) as usize + 1] += 1;
            }
            for j in 1..count.len() {
                count[j] += count[j - 1];
            }
            for &v in parts().flatten() {
                let j = (rel(v) & sub_mask) as usize;
                slice[count[j]] = v;
                count[j] += 1;
            }
            // count[j] is now where lo j ends, count[j - 1] where it starts
            let mut from = 0;
            for &to in count.iter().take(1 << sub_bits) {
                if to - from > 1 {
                    slice[from..to].sort_unstable();
                }
                from = to;
            }
        },
    );
    out
}
