//! The flattened wide node: the bounds of its children as struct-of-arrays, so their
//! slab tests run four lanes at a time in SIMD.

/// How many children an inner node has: a multiple of 4, the SIMD width of the slab
/// test.
pub const WIDTH: usize = 8;
const _: () = assert!(WIDTH.is_multiple_of(4));

/// Most references a leaf holds: two blocks of four triangles, each tested at once.
/// (The leaf code could count up to 16 blocks; leaves of up to two measured best.)
pub const MAX_LEAF: usize = 8;

/// Most triangle blocks a BVH can address: a leaf names its first block with 27 bits.
/// The builder never makes more references than this (presplits and spatial splits
/// included), and there are never more blocks than references, so it also bounds the
/// triangles a BVH can index. (Not `scene::MAX_BLOCKS`, ember's limit for a scene.)
pub const MAX_BLOCKS: usize = 1 << 27;

const LEAF_BIT: u32 = 1 << 31;

/// A reference to a child: an inner node's index, or a leaf's run of triangle blocks
/// (bit 31 set, count - 1 in bits 27..31, first block in bits 0..27).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Child(pub u32);

impl Child {
    pub fn inner(index: u32) -> Self {
        debug_assert!(index < LEAF_BIT);
        Child(index)
    }

    pub fn leaf(first: usize, count: usize) -> Self {
        debug_assert!((1..=16).contains(&count) && first < MAX_BLOCKS);
        Child(LEAF_BIT | ((count as u32 - 1) << 27) | first as u32)
    }

    #[inline(always)]
    pub fn is_leaf(self) -> bool {
        self.0 & LEAF_BIT != 0
    }

    /// The block range of a leaf.
    #[inline(always)]
    pub fn range(self) -> std::ops::Range<usize> {
        let first = (self.0 & (MAX_BLOCKS as u32 - 1)) as usize;
        let count = ((self.0 >> 27) & 15) as usize + 1;
        first..first + count
    }

    #[inline(always)]
    pub fn index(self) -> usize {
        self.0 as usize
    }
}

/// The children's boxes, `lo[axis][lane]` / `hi[axis][lane]`, and their references.
/// Unused lanes have an empty box (`lo = +inf`, `hi = -inf`) that no ray can hit.
/// Aligned to a cache line: traversal is bound by the lines it waits for, and at
/// 16-byte alignment a 4-wide node's 112 bytes straddled three lines in half of the
/// nodes (bvh_ab: 1-3% faster on every diffuse and shadow set at 64).
#[derive(Clone, Copy, Debug)]
#[repr(C, align(64))]
pub struct Node {
    pub lo: [[f32; WIDTH]; 3],
    pub hi: [[f32; WIDTH]; 3],
    pub child: [Child; WIDTH],
}

impl Node {
    pub const EMPTY: Node = Node {
        lo: [[f32::INFINITY; WIDTH]; 3],
        hi: [[f32::NEG_INFINITY; WIDTH]; 3],
        child: [Child(0); WIDTH],
    };

    pub fn set(&mut self, lane: usize, lo: [f32; 3], hi: [f32; 3], child: Child) {
        for axis in 0..3 {
            self.lo[axis][lane] = lo[axis];
            self.hi[axis][lane] = hi[axis];
        }
        self.child[lane] = child;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn leaf_codes_round_trip() {
        for (first, count) in [(0, 1), (5, 8), (MAX_BLOCKS - 16, 16), (123_456, 3)] {
            let c = Child::leaf(first, count);
            assert!(c.is_leaf());
            assert_eq!(c.range(), first..first + count);
        }
        assert!(!Child::inner(42).is_leaf());
        assert_eq!(Child::inner(42).index(), 42);
    }
}
