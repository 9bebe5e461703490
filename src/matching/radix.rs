//! Monotone radix heap: a priority queue for integer keys that never go below the last
//! extracted minimum (Ahuja, Mehlhorn, Orlin & Tarjan 1990). Each element moves down at most
//! 64 buckets over its life, and every bucket is a plain `Vec`, so it is far more
//! cache-friendly than a binary heap of millions of entries.

/// Min-priority queue of `(key, payload)` with monotone keys.
#[derive(Debug)]
pub struct RadixHeap<T = u32> {
    last: u64,
    len: usize,
    buckets: Vec<Vec<(u64, T)>>,
}

impl<T: Copy> Default for RadixHeap<T> {
    fn default() -> Self {
        Self::new()
    }
}

impl<T: Copy> RadixHeap<T> {
    /// An empty heap whose minimum key so far is 0.
    pub fn new() -> RadixHeap<T> {
        RadixHeap {
            last: 0,
            len: 0,
            buckets: (0..65).map(|_| Vec::new()).collect(),
        }
    }

    #[inline]
    fn bucket(&self, key: u64) -> usize {
        (64 - (key ^ self.last).leading_zeros()) as usize
    }

    /// Number of entries.
    #[cfg(any(test, feature = "testing"))]
    pub fn len(&self) -> usize {
        self.len
    }

    /// True when empty.
    #[cfg(any(test, feature = "testing"))]
    pub fn is_empty(&self) -> bool {
        self.len == 0
    }

    /// Inserts `(key, id)` (`id` any payload); `key` must be at least the last popped key (smaller keys are
    /// clamped to it, which keeps the structure valid).
    #[inline]
    pub fn push(&mut self, key: u64, id: T) {
        let key = key.max(self.last);
        let b = self.bucket(key);
        self.buckets[b].push((key, id));
        self.len += 1;
    }

    /// Removes and returns an entry of minimum key.
    pub fn pop(&mut self) -> Option<(u64, T)> {
        if self.buckets[0].is_empty() {
            let i = self.buckets.iter().position(|b| !b.is_empty())?;
            let moved = std::mem::take(&mut self.buckets[i]);
            self.last = moved.iter().map(|e| e.0).min().unwrap_or(self.last);
            for &(k, id) in &moved {
                let b = self.bucket(k);
                self.buckets[b].push((k, id));
            }
            // Give the (now empty) allocation back to bucket i.
            let mut moved = moved;
            moved.clear();
            self.buckets[i] = moved;
        }
        let e = self.buckets[0].pop();
        if e.is_some() {
            self.len -= 1;
        }
        e
    }

    /// The last extracted minimum (pushed keys are clamped to it).
    pub fn floor(&self) -> u64 {
        self.last
    }

    /// The minimum key, without changing the structure (a scan of the lowest non-empty
    /// bucket).
    pub fn peek_min(&self) -> Option<u64> {
        if !self.buckets[0].is_empty() {
            return Some(self.last);
        }
        let b = self.buckets.iter().find(|b| !b.is_empty())?;
        b.iter().map(|e| e.0).min()
    }

    /// Removes every entry and resets the minimum to 0.
    pub fn clear(&mut self) {
        for b in &mut self.buckets {
            b.clear();
        }
        self.last = 0;
        self.len = 0;
    }

    /// For keys of the form `(time << 1) | flag`: doubles every time (and the running
    /// minimum's), keeping the flags.
    pub fn double_keys_flagged(&mut self) {
        let mut all = Vec::with_capacity(self.len);
        for b in &mut self.buckets {
            all.append(b);
        }
        let dbl = |k: u64| ((k & !1) << 1) | (k & 1);
        self.last = dbl(self.last);
        self.len = 0;
        for (k, id) in all {
            self.push(dbl(k), id);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::RadixHeap;

    #[test]
    fn pops_in_key_order_with_monotone_pushes() {
        let mut h = RadixHeap::<u32>::new();
        let mut x: u64 = 12345;
        let mut popped = Vec::new();
        let mut last = 0;
        for round in 0..2000u32 {
            x = x
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            h.push(last + (x >> 50), round);
            if round % 3 == 0 {
                let min = h.peek_min();
                if let Some((k, _)) = h.pop() {
                    assert_eq!(min, Some(k));
                    assert!(k >= last);
                    last = k;
                    popped.push(k);
                }
            }
        }
        while let Some((k, _)) = h.pop() {
            assert!(k >= last);
            last = k;
            popped.push(k);
        }
        assert_eq!(popped.len(), 2000);
        assert_eq!(h.peek_min(), None);
        assert!(popped.windows(2).all(|w| w[0] <= w[1]));
    }
}
