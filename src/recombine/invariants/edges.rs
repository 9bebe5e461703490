//! Edges and the faces that use them: sorted edge lists with their use counts, and the
//! edge table the conformity checks look edges up in.

use super::*;

pub(super) type Edge = (u64, u64);

/// Faces per parallel task within one surface.
pub(super) const CHUNK: usize = 8192;

pub(super) fn undirected(a: u64, b: u64) -> Edge {
    (a.min(b), a.max(b))
}

pub(super) fn has(sorted: &[Edge], e: &Edge) -> bool {
    sorted.binary_search(e).is_ok()
}

/// Corner nodes of the 2D elements (tri3, quad4) of one surface.
pub(super) fn faces_of(mesh: &Mesh, surface: i32) -> Vec<&[u64]> {
    let mut out = Vec::new();
    for b in &mesh.element_blocks {
        if b.entity_dim != 2 || b.entity_tag != surface || element_dim(b.element_type) != Some(2) {
            continue;
        }
        if b.element_type != etype::TRI3 && b.element_type != etype::QUAD4 {
            continue;
        }
        for i in 0..b.len() {
            out.push(b.element(i));
        }
    }
    out
}

/// Every undirected edge of `faces` with the number of faces using it, sorted.
pub(super) fn edge_counts(faces: &[&[u64]]) -> Vec<(Edge, u32)> {
    let mut all: Vec<Edge> = Vec::with_capacity(faces.iter().map(|f| f.len()).sum());
    for f in faces {
        for i in 0..f.len() {
            all.push(undirected(f[i], f[(i + 1) % f.len()]));
        }
    }
    sort_pairs(&mut all);
    // memory: sized exactly (see `EdgeTable::new`)
    let distinct = 1 + all.windows(2).filter(|w| w[0] != w[1]).count();
    let mut out: Vec<(Edge, u32)> = Vec::with_capacity(distinct);
    for e in all {
        match out.last_mut() {
            Some((last, c)) if *last == e => *c += 1,
            _ => out.push((e, 1)),
        }
    }
    out
}

pub(super) fn count_of(counts: &[(Edge, u32)], e: &Edge) -> u32 {
    counts
        .binary_search_by_key(e, |x| x.0)
        .map_or(0, |i| counts[i].1)
}

/// The uses of face `f`'s edges as (smaller node, larger node · 2 + 1 when the face runs
/// the edge from the larger).
pub(super) fn edge_uses(f: &[u64]) -> impl Iterator<Item = Edge> + '_ {
    (0..f.len()).map(move |i| {
        let (a, b) = (f[i], f[(i + 1) % f.len()]);
        let (lo, hi) = undirected(a, b);
        (lo, (hi << 1) | u64::from(a > b))
    })
}

/// The edges of `faces` with how many faces use each and in which directions, sorted by
/// edge, with (when node tags are compact) the start of each first node's run, so that a
/// lookup is two nearby reads instead of a binary search over the whole list.
///
/// Memory (it is held through the whole run): the fields are parallel arrays, and with the
/// runs the first node of an entry is its run's, not stored: 12 bytes an edge instead of a
/// tuple's 24.
pub(super) struct EdgeTable {
    /// Smaller node of each edge; empty when `start` is not (the entry's run tells it).
    lo: Vec<u64>,
    /// Larger node of each edge.
    hi: Vec<u64>,
    /// Faces using the edge (saturating) · 4, plus bit 0: some face runs it from its
    /// smaller node, bit 1: some face runs it from its larger node.
    uses: Vec<u32>,
    /// Entries of first node `a`: `start[a]..start[a + 1]`; empty when tags are not
    /// compact.
    pub(super) start: Vec<u32>,
}

impl EdgeTable {
    /// Largest face count stored (a count only ever compared with 1 and 2).
    const MAX_COUNT: u32 = u32::MAX >> 2;

    pub(super) fn new(faces: &[&[u64]]) -> Self {
        let n_uses: usize = faces.iter().map(|f| f.len()).sum();
        let max = faces.iter().flat_map(|f| f.iter()).copied().max();
        match max {
            Some(max) if max <= 4 * n_uses as u64 + 1024 => Self::with_runs(faces, max, n_uses),
            _ => Self::sorted(faces, n_uses),
        }
    }

    /// The table of `faces` whose node tags are at most `max`, compact enough for runs.
    ///
    /// Memory (this is built beside the optimizer): each use goes straight into its smaller
    /// node's run (a counting sort, one `u64` a use), each run is sorted on its own and its
    /// repeated edges merged, so the construction needs about a quarter of the memory of a
    /// sort of `(smaller, larger)` pairs with its scratch.
    pub(super) fn with_runs(faces: &[&[u64]], max: u64, n_uses: usize) -> Self {
        let mut start = vec![0u32; max as usize + 2];
        for f in faces {
            for (lo, _) in edge_uses(f) {
                start[lo as usize + 1] += 1;
            }
        }
        for i in 1..start.len() {
            start[i] += start[i - 1];
        }
        // filling moves each run's start to the next run's; shifted back below
        let mut x = vec![0u64; n_uses];
        for f in faces {
            for (lo, key) in edge_uses(f) {
                let lo = lo as usize;
                x[start[lo] as usize] = key;
                start[lo] += 1;
            }
        }
        let len = start.len();
        start.copy_within(0..len - 1, 1);
        start[0] = 0;
        let run = |a: usize| start[a] as usize..start[a + 1] as usize;
        for a in 0..start.len() - 1 {
            x[run(a)].sort_unstable();
        }
        // memory: sized exactly
        let distinct = (0..start.len() - 1)
            .map(|a| {
                let r = &x[run(a)];
                usize::from(!r.is_empty()) + r.windows(2).filter(|w| w[0] >> 1 != w[1] >> 1).count()
            })
            .sum();
        let mut hi: Vec<u64> = Vec::with_capacity(distinct);
        let mut uses: Vec<u32> = Vec::with_capacity(distinct);
        // each run's start becomes its first distinct edge's (read before it is rewritten)
        let mut begin = 0usize;
        for a in 0..start.len() - 1 {
            let end = start[a + 1] as usize;
            start[a] = hi.len() as u32;
            let mut open = false;
            for &k in &x[begin..end] {
                Self::add_use(&mut hi, &mut uses, &mut open, k);
            }
            begin = end;
        }
        let last = start.len() - 1;
        start[last] = hi.len() as u32;
        EdgeTable {
            lo: Vec::new(),
            hi,
            uses,
            start,
        }
    }

    /// Adds use `key` (larger node · 2 + runs from the larger) of the current first node:
    /// to the last edge when `open` and it is the same edge, else as a new edge.
    pub(super) fn add_use(hi: &mut Vec<u64>, uses: &mut Vec<u32>, open: &mut bool, key: u64) {
        let b = key >> 1;
        let dir = 1u32 << (key & 1);
        match (hi.last(), uses.last_mut()) {
            (Some(&lb), Some(u)) if *open && lb == b => {
                let count = (*u >> 2).saturating_add(1).min(Self::MAX_COUNT);
                *u = (count << 2) | (*u & 3) | dir;
            }
            _ => {
                hi.push(b);
                uses.push((1 << 2) | dir);
                *open = true;
            }
        }
    }

    /// The table of `faces` with sparse node tags: one sort of the uses, lookups by binary
    /// search.
    pub(super) fn sorted(faces: &[&[u64]], n_uses: usize) -> Self {
        // each use as (smaller node, larger node · 2 + runs from the larger): one sort gives
        // the counts and the directions
        let mut all: Vec<Edge> = Vec::with_capacity(n_uses);
        for f in faces {
            all.extend(edge_uses(f));
        }
        sort_pairs(&mut all);
        // memory: sized exactly (a guess of half the uses is one short on any surface with
        // a boundary, and the growth doubles it)
        let distinct = 1 + all
            .windows(2)
            .filter(|w| (w[0].0, w[0].1 >> 1) != (w[1].0, w[1].1 >> 1))
            .count();
        let mut lo: Vec<u64> = Vec::with_capacity(distinct);
        let mut hi: Vec<u64> = Vec::with_capacity(distinct);
        let mut uses: Vec<u32> = Vec::with_capacity(distinct);
        for (a, key) in all {
            // the same edge as the last one only within the same first node
            let mut open = lo.last() == Some(&a);
            let before = hi.len();
            Self::add_use(&mut hi, &mut uses, &mut open, key);
            if hi.len() > before {
                lo.push(a);
            }
        }
        EdgeTable {
            lo,
            hi,
            uses,
            start: Vec::new(),
        }
    }

    /// The `uses` entry of undirected edge `e`.
    pub(super) fn find(&self, e: &Edge) -> Option<u32> {
        let (a, b) = *e;
        if self.start.is_empty() {
            // sorted by (lo, hi): the run of `a` by binary search, then `b` inside it
            let from = self.lo.partition_point(|&x| x < a);
            let to = from + self.lo[from..].partition_point(|&x| x == a);
            return self.hi[from..to]
                .binary_search(&b)
                .ok()
                .map(|i| self.uses[from + i]);
        }
        match (self.start.get(a as usize), self.start.get(a as usize + 1)) {
            (Some(&from), Some(&to)) => {
                let (from, to) = (from as usize, to as usize);
                self.hi[from..to]
                    .iter()
                    .position(|&x| x == b)
                    .map(|i| self.uses[from + i])
            }
            _ => None,
        }
    }

    /// Faces using undirected edge `e`.
    pub(super) fn count(&self, e: &Edge) -> u32 {
        self.find(e).map_or(0, |u| u >> 2)
    }

    /// Some face runs the edge from `p` to `q`.
    pub(super) fn runs(&self, p: u64, q: u64) -> bool {
        let bit = if p < q { 1 } else { 2 };
        self.find(&undirected(p, q)).is_some_and(|u| u & bit != 0)
    }

    /// The edges used by one face, sorted.
    pub(super) fn boundary(&self) -> Vec<Edge> {
        let once = |i: usize| self.uses[i] >> 2 == 1;
        if self.start.is_empty() {
            return (0..self.hi.len())
                .filter(|&i| once(i))
                .map(|i| (self.lo[i], self.hi[i]))
                .collect();
        }
        let mut out = Vec::new();
        for (a, w) in self.start.windows(2).enumerate() {
            out.extend(
                (w[0] as usize..w[1] as usize)
                    .filter(|&i| once(i))
                    .map(|i| (a as u64, self.hi[i])),
            );
        }
        out
    }
}
