//! Compact lookups by tag: [`TagMap`] (tag → position) and [`TagSet`] (tag exists?).
//! Both are dense arrays when tags are compact (the usual case) and hash-based otherwise.

use std::collections::{HashMap, HashSet};

/// True when `max` tags over `n` items are compact enough for a dense array.
fn dense_ok(max: u64, n: usize) -> bool {
    max <= (4 * n as u64).max(1024)
}

/// Tag → index lookup, dense when tags are compact.
pub(crate) struct TagMap {
    dense: Vec<u32>,
    sparse: HashMap<u64, u32>,
}

impl TagMap {
    /// Maps every tag of `tags` to its position (later duplicates win).
    pub fn new(tags: &[u64]) -> Self {
        let max = tags.iter().copied().max().unwrap_or(0);
        let mut m = TagMap {
            dense: Vec::new(),
            sparse: HashMap::new(),
        };
        if dense_ok(max, tags.len()) {
            m.dense = vec![u32::MAX; max as usize + 1];
            for (i, &t) in tags.iter().enumerate() {
                m.dense[t as usize] = i as u32;
            }
        } else {
            m.sparse.reserve(tags.len());
            for (i, &t) in tags.iter().enumerate() {
                m.sparse.insert(t, i as u32);
            }
        }
        m
    }
    /// Position of `tag`.
    #[inline]
    pub fn get(&self, tag: u64) -> Option<usize> {
        if self.dense.is_empty() {
            self.sparse.get(&tag).map(|&i| i as usize)
        } else {
            match self.dense.get(tag as usize) {
                Some(&i) if i != u32::MAX => Some(i as usize),
                _ => None,
            }
        }
    }
}

/// Set of tags, as a bitset when tags are compact: checking that every element node
/// exists touches 1 bit per tag instead of a full index entry (it stays in cache).
pub(crate) enum TagSet {
    /// Bit `t` set when tag `t` exists.
    Dense(Vec<u64>),
    /// Sparse tags.
    Sparse(HashSet<u64>),
}

impl TagSet {
    /// The set of all node tags of the given tag lists, and the first tag that appears more
    /// than once (if any).
    pub fn new<'a>(tag_lists: impl Iterator<Item = &'a [u64]> + Clone) -> (Self, Option<u64>) {
        let n: usize = tag_lists.clone().map(|t| t.len()).sum();
        let max = tag_lists
            .clone()
            .flat_map(|t| t.iter().copied())
            .max()
            .unwrap_or(0);
        let mut dup = None;
        let set = if dense_ok(max, n) {
            let mut bits = vec![0u64; (max / 64 + 1) as usize];
            for t in tag_lists.flat_map(|t| t.iter().copied()) {
                let (w, b) = ((t / 64) as usize, 1u64 << (t % 64));
                if bits[w] & b != 0 && dup.is_none() {
                    dup = Some(t);
                }
                bits[w] |= b;
            }
            TagSet::Dense(bits)
        } else {
            let mut s = HashSet::with_capacity(n);
            for t in tag_lists.flat_map(|t| t.iter().copied()) {
                if !s.insert(t) && dup.is_none() {
                    dup = Some(t);
                }
            }
            TagSet::Sparse(s)
        };
        (set, dup)
    }

    /// True when node `tag` exists.
    #[inline]
    pub fn contains(&self, tag: u64) -> bool {
        match self {
            TagSet::Dense(bits) => bits
                .get((tag / 64) as usize)
                .is_some_and(|w| w & (1 << (tag % 64)) != 0),
            TagSet::Sparse(s) => s.contains(&tag),
        }
    }
}
