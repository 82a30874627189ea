//! Small geometry types: `Vec3` for computation, `[f32; 3]` at API boundaries, [`Aabb`]; and the
//! one [`UnionFind`] (cell corners in MC33, mesh vertices in `topo`).

pub use glam::{DVec3, Vec3};

/// An axis-aligned box, `min` and `max` inclusive; empty when `min > max` on any axis.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Aabb {
    /// Lower corner.
    pub min: [f64; 3],
    /// Upper corner.
    pub max: [f64; 3],
}

impl Aabb {
    /// The empty box: grows to the first point added.
    pub const EMPTY: Aabb = Aabb { min: [f64::INFINITY; 3], max: [f64::NEG_INFINITY; 3] };

    /// Grows the box to contain `p`.
    #[inline]
    pub fn add(&mut self, p: [f64; 3]) {
        for a in 0..3 {
            self.min[a] = self.min[a].min(p[a]);
            self.max[a] = self.max[a].max(p[a]);
        }
    }

    /// True when no point was added.
    pub fn is_empty(&self) -> bool {
        (0..3).any(|a| self.min[a] > self.max[a])
    }

    /// `max - min` per axis (zero for an empty box).
    pub fn size(&self) -> [f64; 3] {
        if self.is_empty() {
            return [0.0; 3];
        }
        [self.max[0] - self.min[0], self.max[1] - self.min[1], self.max[2] - self.min[2]]
    }
}

/// Converts a `[f32; 3]` to `Vec3`.
#[inline]
pub fn v3(p: [f32; 3]) -> Vec3 {
    Vec3::from_array(p)
}

/// Disjoint sets of `0..n` with path halving. The smallest element of a set is its root, so
/// numbering sets by their roots is deterministic. `S` holds the parents: an array for small
/// fixed sets kept on the stack (`UnionFind::<[u32; 8]>::fixed()`: a cell's corners), a `Vec` for
/// sets that grow (`UnionFind::new(n)`: a mesh's vertices).
#[derive(Debug, Clone, Copy)]
pub struct UnionFind<S = Vec<u32>> {
    parent: S,
}

impl<const N: usize> UnionFind<[u32; N]> {
    /// `N` elements, each in a set of its own.
    pub fn fixed() -> Self {
        UnionFind { parent: std::array::from_fn(|i| i as u32) }
    }
}

impl UnionFind<Vec<u32>> {
    /// `n` elements, each in a set of its own.
    pub fn new(n: usize) -> Self {
        UnionFind { parent: (0..n as u32).collect() }
    }
    /// Adds elements up to `n` (exclusive), each in a set of its own.
    pub fn grow(&mut self, n: usize) {
        let from = self.parent.len() as u32;
        self.parent.extend(from..n as u32);
    }
}

impl<S: AsRef<[u32]> + AsMut<[u32]>> UnionFind<S> {
    /// Elements held.
    pub fn len(&self) -> usize {
        self.parent.as_ref().len()
    }
    /// Whether no element is held.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }
    /// The root (smallest element) of `x`'s set.
    #[inline]
    pub fn find<I: SetIndex>(&mut self, x: I) -> I {
        let parent = self.parent.as_mut();
        let mut x = x.index() as u32;
        while parent[x as usize] != x {
            let p = parent[parent[x as usize] as usize];
            parent[x as usize] = p;
            x = p;
        }
        I::from_index(x as usize)
    }
    /// Joins the sets of `a` and `b`; returns `(kept root, absorbed root)` when they differed.
    #[inline]
    pub fn union<I: SetIndex>(&mut self, a: I, b: I) -> Option<(I, I)> {
        let (ra, rb) = (self.find(a), self.find(b));
        if ra == rb {
            return None;
        }
        let (lo, hi) = if ra < rb { (ra, rb) } else { (rb, ra) };
        self.parent.as_mut()[hi.index()] = lo.index() as u32;
        Some((lo, hi))
    }
}

/// [`UnionFind`] of `0..n` shared by threads: unions from any thread, lock-free (a root is linked
/// under the smaller root by compare-and-swap, finds halve paths). The smallest element of a set
/// is its root, as in [`UnionFind`], so the sets and their roots do not depend on the threads.
#[derive(Debug)]
pub struct AtomicUnionFind {
    parent: Vec<std::sync::atomic::AtomicU32>,
}

impl AtomicUnionFind {
    /// `n` elements, each in a set of its own.
    pub fn new(n: usize) -> Self {
        AtomicUnionFind { parent: (0..n as u32).map(std::sync::atomic::AtomicU32::new).collect() }
    }
    /// Elements held.
    pub fn len(&self) -> usize {
        self.parent.len()
    }
    /// Whether no element is held.
    pub fn is_empty(&self) -> bool {
        self.parent.is_empty()
    }
    /// The root of `x`'s set now (its smallest element once no union is under way).
    #[inline]
    pub fn find(&self, x: u32) -> u32 {
        use std::sync::atomic::Ordering::Relaxed;
        let mut x = x;
        loop {
            let p = self.parent[x as usize].load(Relaxed);
            if p == x {
                return x;
            }
            let g = self.parent[p as usize].load(Relaxed);
            if g != p {
                // Path halving; losing the race only leaves a longer path. Parents only ever
                // decrease, so `g` is still an ancestor of `x`.
                let _ = self.parent[x as usize].compare_exchange_weak(p, g, Relaxed, Relaxed);
            }
            x = p;
        }
    }
    /// Joins the sets of `a` and `b`.
    #[inline]
    pub fn union(&self, a: u32, b: u32) {
        use std::sync::atomic::Ordering::Relaxed;
        let (mut a, mut b) = (a, b);
        loop {
            a = self.find(a);
            b = self.find(b);
            if a == b {
                return;
            }
            let (lo, hi) = if a < b { (a, b) } else { (b, a) };
            // Link only if `hi` is still a root; otherwise another thread moved it: retry.
            if self.parent[hi as usize].compare_exchange(hi, lo, Relaxed, Relaxed).is_ok() {
                return;
            }
        }
    }
}

/// The element types [`UnionFind`] takes: vertex ids (`u32`) and small indices (`usize`).
pub trait SetIndex: Copy + Ord {
    /// As an index.
    fn index(self) -> usize;
    /// From an index known to fit.
    fn from_index(i: usize) -> Self;
}

impl SetIndex for u32 {
    #[inline]
    fn index(self) -> usize {
        self as usize
    }
    #[inline]
    fn from_index(i: usize) -> Self {
        i as u32
    }
}

impl SetIndex for usize {
    #[inline]
    fn index(self) -> usize {
        self
    }
    #[inline]
    fn from_index(i: usize) -> Self {
        i
    }
}

#[cfg(test)]
mod union_find_tests {
    use super::{AtomicUnionFind, UnionFind};

    proptest::proptest! {
        #![proptest_config(proptest::prelude::ProptestConfig::with_cases(64))]
        /// Unions spread over four threads give the serial structure's sets and roots.
        #[test]
        fn atomic_union_find_from_threads_equals_the_serial_one(
            n in 1u32..400,
            pairs in proptest::collection::vec((0u32..400, 0u32..400), 0..800),
        ) {
            let pairs: Vec<(u32, u32)> = pairs.into_iter().map(|(a, b)| (a % n, b % n)).collect();
            let mut serial = UnionFind::new(n as usize);
            for &(a, b) in &pairs {
                serial.union(a, b);
            }
            let shared = AtomicUnionFind::new(n as usize);
            std::thread::scope(|s| {
                for part in pairs.chunks(pairs.len().div_ceil(4).max(1)) {
                    let shared = &shared;
                    s.spawn(move || part.iter().for_each(|&(a, b)| shared.union(a, b)));
                }
            });
            for x in 0..n {
                proptest::prop_assert_eq!(shared.find(x), serial.find(x), "element {}", x);
            }
        }
    }

    #[test]
    fn roots_are_the_smallest_members_for_both_storages() {
        let mut a = UnionFind::<[u32; 6]>::fixed();
        let mut v = UnionFind::new(4);
        v.grow(6);
        for (x, y) in [(5u32, 3), (3, 4), (1, 2)] {
            assert_eq!(a.union(x as usize, y as usize).map(|(p, q)| (p as u32, q as u32)), v.union(x, y));
        }
        assert_eq!(a.union(4usize, 5), None);
        assert_eq!([0usize, 1, 2, 3, 4, 5].map(|x| a.find(x)), [0, 1, 1, 3, 3, 3]);
        assert_eq!([0u32, 1, 2, 3, 4, 5].map(|x| v.find(x)), [0, 1, 1, 3, 3, 3]);
        assert_eq!(v.union(2u32, 5), Some((1, 3)));
        assert_eq!(v.find(4u32), 1);
        assert_eq!((a.len(), v.len()), (6, 6));
    }
}

/// A multiplicative hasher for small integer keys (the default SipHash is several times slower
/// and DoS resistance is not needed for lattice coordinates).
#[derive(Debug, Default, Clone, Copy)]
pub(crate) struct KeyHasher(u64);

impl std::hash::Hasher for KeyHasher {
    #[inline]
    fn finish(&self) -> u64 {
        self.0
    }
    /// Eight bytes a round (arrays of integers hash as one byte string: `[u32; 3]` is two
    /// rounds, not twelve).
    #[inline]
    fn write(&mut self, bytes: &[u8]) {
        let mut words = bytes.chunks_exact(8);
        for w in &mut words {
            self.write_u64(u64::from_le_bytes(w.try_into().expect("8 bytes")));
        }
        let rest = words.remainder();
        if !rest.is_empty() {
            let mut w = [0u8; 8];
            w[..rest.len()].copy_from_slice(rest);
            self.write_u64(u64::from_le_bytes(w));
        }
    }
    #[inline]
    fn write_u32(&mut self, x: u32) {
        self.write_u64(x as u64);
    }
    #[inline]
    fn write_u64(&mut self, x: u64) {
        self.0 = (self.0.rotate_left(5) ^ x).wrapping_mul(0x51_7c_c1_b7_27_22_0a_95);
    }
    #[inline]
    fn write_usize(&mut self, x: usize) {
        self.write_u64(x as u64);
    }
}
