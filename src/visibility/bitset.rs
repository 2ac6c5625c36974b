//! A fixed-size bitset over object indices, for visible sets.

/// A set of object indices `0..len`, one bit each.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct ObjectSet {
    words: Vec<u64>,
}

impl ObjectSet {
    /// An empty set able to hold indices `0..len`.
    pub fn new(len: usize) -> Self {
        ObjectSet {
            words: vec![0; len.div_ceil(64)],
        }
    }

    /// How many indices the set can hold (a multiple of 64).
    pub fn capacity(&self) -> usize {
        self.words.len() * 64
    }

    /// Remove every member.
    pub fn clear(&mut self) {
        self.words.fill(0);
    }

    /// Make the members exactly `0..len` (`len` at most the capacity).
    pub fn fill(&mut self, len: usize) {
        self.words.fill(0);
        let (whole, rest) = (len / 64, len % 64);
        self.words[..whole].fill(u64::MAX);
        if rest > 0 {
            self.words[whole] = (1 << rest) - 1;
        }
    }

    pub fn remove(&mut self, i: usize) {
        self.words[i / 64] &= !(1 << (i % 64));
    }

    pub fn insert(&mut self, i: usize) {
        self.words[i / 64] |= 1 << (i % 64);
    }

    pub fn contains(&self, i: usize) -> bool {
        self.words[i / 64] & (1 << (i % 64)) != 0
    }

    /// Add every member of `other`.
    pub fn union_with(&mut self, other: &ObjectSet) {
        for (a, b) in self.words.iter_mut().zip(&other.words) {
            *a |= *b;
        }
    }

    pub fn count(&self) -> usize {
        self.words.iter().map(|w| w.count_ones() as usize).sum()
    }

    /// Members in ascending order.
    pub fn to_vec(&self) -> Vec<u32> {
        let mut out = Vec::with_capacity(self.count());
        for (wi, &w) in self.words.iter().enumerate() {
            let mut w = w;
            while w != 0 {
                let bit = w.trailing_zeros();
                out.push(wi as u32 * 64 + bit);
                w &= w - 1;
            }
        }
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn insert_union_and_list() {
        let mut a = ObjectSet::new(130);
        a.insert(3);
        a.insert(129);
        let mut b = ObjectSet::new(130);
        b.insert(64);
        b.insert(3);
        a.union_with(&b);
        assert_eq!(a.to_vec(), vec![3, 64, 129]);
        assert_eq!(a.count(), 3);
        assert!(a.contains(64) && !a.contains(65));
        a.remove(64);
        assert_eq!(a.to_vec(), vec![3, 129]);
        a.fill(66);
        assert_eq!(a.count(), 66);
        assert!(a.contains(65) && !a.contains(66));
    }
}
