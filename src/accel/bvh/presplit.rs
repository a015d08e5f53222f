//! Early split clipping (Ernst and Greiner 2007): a triangle much larger than the
//! average (a floor, a wall) gets a box far bigger than the geometry in most of it, and
//! every ray near that box pays for it. Such triangles are cut at the middle of their
//! box's longest axis, recursively, and each piece becomes a reference with the box of
//! the triangle's part inside it ([`split_box`], which spatial splits use too). Leaves
//! then hold some triangles more than once, which costs nothing in correctness: the
//! nearest hit is the nearest hit.

use glam::Vec3A;

use super::aabb::{Aabb, PrimRef};
use super::clip::split_box;
use super::node::MAX_BLOCKS;

/// Triangles whose box has more than this many times the average surface area are
/// split into several references with tighter boxes.
const PRESPLIT_AREA: f32 = 8.0;
/// At most this many halvings per triangle (up to 2^depth references).
const PRESPLIT_DEPTH: u32 = 6;
/// At most this many extra references, as a fraction of the triangle count.
const PRESPLIT_BUDGET: f32 = 0.5;

/// Splits the references of large triangles into pieces with tighter boxes (the first
/// piece replaces the reference, the others are appended). `corners(id)` gives a
/// triangle's corners.
pub fn presplit(refs: &mut Vec<PrimRef>, corners: impl Fn(u32) -> [Vec3A; 3]) {
    if refs.is_empty() {
        return;
    }
    let mean = refs.iter().map(|r| r.aabb().half_area()).sum::<f32>() / refs.len() as f32;
    let threshold = PRESPLIT_AREA * mean;
    let mut budget =
        ((refs.len() as f32 * PRESPLIT_BUDGET) as usize).min(MAX_BLOCKS.saturating_sub(refs.len()));
    let large: Vec<usize> = (0..refs.len())
        .filter(|&i| refs[i].aabb().half_area() > threshold)
        .collect();
    for i in large {
        let id = refs[i].id();
        let pieces = pieces(&corners(id), refs[i].aabb(), threshold, &mut budget);
        for (k, piece) in pieces.iter().enumerate() {
            let r = PrimRef::new(piece.lo, piece.hi, id);
            if k == 0 {
                refs[i] = r;
            } else {
                refs.push(r);
            }
        }
    }
}

/// The boxes of the pieces of triangle `tri` (whose box is `whole`): halved until
/// smaller than `threshold`, [`PRESPLIT_DEPTH`] deep, or out of `budget` (one per
/// halving). Never empty.
fn pieces(tri: &[Vec3A; 3], whole: Aabb, threshold: f32, budget: &mut usize) -> Vec<Aabb> {
    let mut pieces = Vec::new();
    let mut todo = vec![(whole, 0u32)];
    while let Some((bounds, depth)) = todo.pop() {
        if depth >= PRESPLIT_DEPTH || bounds.half_area() <= threshold || *budget == 0 {
            pieces.push(bounds);
            continue;
        }
        let axis = (bounds.hi - bounds.lo).max_position();
        let at = 0.5 * (bounds.lo[axis] + bounds.hi[axis]);
        let (lo, hi) = split_box(tri, bounds, axis, at);
        *budget -= 1;
        match (lo.is_empty(), hi.is_empty()) {
            // Rounding lost both parts: keep the piece whole.
            (true, true) => pieces.push(bounds),
            _ => todo.extend(
                [lo, hi]
                    .into_iter()
                    .filter(|b| !b.is_empty())
                    .map(|b| (b, depth + 1)),
            ),
        }
    }
    pieces
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_large_triangle_becomes_pieces_that_cover_it() {
        // One floor-sized triangle among small ones.
        let small = |i: u32| {
            let p = Vec3A::new(i as f32, 0.0, 0.0);
            [
                p,
                p + Vec3A::new(0.1, 0.0, 0.0),
                p + Vec3A::new(0.0, 0.1, 0.0),
            ]
        };
        let mut tris: Vec<[Vec3A; 3]> = (0..100).map(small).collect();
        tris.push([
            Vec3A::ZERO,
            Vec3A::new(100.0, 0.0, 0.0),
            Vec3A::new(0.0, 0.0, 100.0),
        ]);
        let mut refs: Vec<PrimRef> = (tris.iter().enumerate())
            .map(|(id, [a, b, c])| PrimRef::new(a.min(*b).min(*c), a.max(*b).max(*c), id as u32))
            .collect();
        presplit(&mut refs, |id| tris[id as usize]);
        let big: Vec<Aabb> = (refs.iter().filter(|r| r.id() == 100))
            .map(PrimRef::aabb)
            .collect();
        assert!(big.len() > 1 && refs.len() == 100 + big.len());
        // Pieces are smaller than the triangle's box and together hold every point.
        let mut rng = crate::sampling::Rng::seeded(5);
        let [a, b, c] = tris[100];
        for _ in 0..10_000 {
            let (u, v) = crate::sampling::uniform_triangle(rng.f32(), rng.f32());
            let p = (1.0 - u - v) * a + u * b + v * c;
            assert!(
                big.iter()
                    .any(|bx| p.cmpge(bx.lo).all() && p.cmple(bx.hi).all()),
                "{p}"
            );
        }
        // The triangle's box has a half area of 100²; the pieces follow its diagonal.
        let area: f32 = big.iter().map(|b| b.half_area()).sum();
        assert!(area < 0.75 * 100.0 * 100.0, "{area}");
    }
}
