//! How a texture lookup finds its texels: each axis's wrap mode outside `[0, 1]`
//! (glTF's `REPEAT`, `CLAMP_TO_EDGE` and `MIRRORED_REPEAT`) and the filter (bilinear
//! between the four nearest texel centres, or the texel the point falls in).
//!
//! A [`Sampler`] is three bytes, copied into each texture: a material's map names a
//! texture, and so its sampler. Wrapping acts on image-space coordinates (`s` rightwards,
//! `t` downwards from the top-left corner), so a mirrored or clamped axis behaves as
//! glTF defines it whatever ember's flip of `v`.

use glam::Vec2;

/// What a lookup reads beyond an edge of the image, on one axis.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum Wrap {
    /// The image repeats (MTL's default, glTF's `REPEAT`).
    #[default]
    Repeat,
    /// The edge texel goes on (glTF's `CLAMP_TO_EDGE`, MTL's `-clamp on`).
    Clamp,
    /// The image repeats, every other copy mirrored (glTF's `MIRRORED_REPEAT`).
    Mirror,
}

/// How the texels about a lookup point make its value.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum Filter {
    /// Bilinear between the four nearest texel centres.
    #[default]
    Bilinear,
    /// The texel the point falls in, exactly.
    Nearest,
}

/// A texture's lookup rule: the wrap modes of its `s` (horizontal) and `t` (vertical)
/// axes and its filter.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct Sampler {
    pub wrap_s: Wrap,
    pub wrap_t: Wrap,
    pub filter: Filter,
}

/// The four texels a bilinear lookup reads, row-major indices `[top-left, top-right,
/// bottom-left, bottom-right]`, and the point's place between them.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Footprint {
    pub index: [usize; 4],
    pub fx: f32,
    pub fy: f32,
}

impl Sampler {
    /// Both axes clamped to the edge, filtered bilinearly (MTL's `-clamp on`).
    pub const CLAMP: Sampler = Sampler {
        wrap_s: Wrap::Clamp,
        wrap_t: Wrap::Clamp,
        filter: Filter::Bilinear,
    };

    /// The texels a bilinear lookup at `uv` reads in an image of `width × height`;
    /// `(0, 0)` is the bottom-left of the image (OBJ convention). `None` when `uv` is
    /// not finite.
    #[inline(always)]
    pub fn footprint(&self, uv: Vec2, width: u32, height: u32) -> Option<Footprint> {
        if !uv.is_finite() {
            return None;
        }
        let x = self.s(uv.x) * width as f32 - 0.5;
        let y = self.t(uv.y) * height as f32 - 0.5;
        let (x0, y0) = (x.floor(), y.floor());
        let (xa, xb) = (
            self.wrap_s.index(x0, width),
            self.wrap_s.index(x0 + 1.0, width),
        );
        let (ya, yb) = (
            self.wrap_t.index(y0, height),
            self.wrap_t.index(y0 + 1.0, height),
        );
        let row = width as usize;
        Some(Footprint {
            index: [ya * row + xa, ya * row + xb, yb * row + xa, yb * row + xb],
            fx: x - x0,
            fy: y - y0,
        })
    }

    /// The texel (row-major index) a nearest lookup at `uv` reads; `None` when `uv`
    /// is not finite.
    #[inline(always)]
    pub fn nearest(&self, uv: Vec2, width: u32, height: u32) -> Option<usize> {
        if !uv.is_finite() {
            return None;
        }
        let x = self.s(uv.x) * width as f32;
        let y = self.t(uv.y) * height as f32;
        let xi = self.wrap_s.index(x.floor(), width);
        let yi = self.wrap_t.index(y.floor(), height);
        Some(yi * width as usize + xi)
    }

    /// The horizontal image coordinate of `u`, reduced to the wrap's period: `[0, 1)`
    /// repeating, `[0, 2)` mirrored, `[0, 1]` clamped.
    #[inline(always)]
    fn s(&self, u: f32) -> f32 {
        match self.wrap_s {
            Wrap::Repeat => u.rem_euclid(1.0),
            Wrap::Clamp => u.clamp(0.0, 1.0),
            Wrap::Mirror => u.rem_euclid(2.0),
        }
    }

    /// The vertical image coordinate (from the top) of `v` (from the bottom), reduced
    /// as [`Sampler::s`] does.
    #[inline(always)]
    fn t(&self, v: f32) -> f32 {
        match self.wrap_t {
            Wrap::Repeat => 1.0 - v.rem_euclid(1.0),
            Wrap::Clamp => (1.0 - v).clamp(0.0, 1.0),
            Wrap::Mirror => (1.0 - v).rem_euclid(2.0),
        }
    }
}

impl Wrap {
    /// The texel of whole position `i` (one period of the wrap at most from the image,
    /// as the reduced coordinates give) on an axis of `n` texels.
    #[inline(always)]
    fn index(self, i: f32, n: u32) -> usize {
        let i = i as i64;
        let n = i64::from(n);
        // Only the texels past the edges need the (slow) integer remainder.
        if (0..n).contains(&i) {
            return i as usize;
        }
        match self {
            Wrap::Repeat => i.rem_euclid(n) as usize,
            Wrap::Clamp => i.clamp(0, n - 1) as usize,
            Wrap::Mirror => {
                let m = i.rem_euclid(2 * n);
                (if m < n { m } else { 2 * n - 1 - m }) as usize
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sampler(wrap: Wrap, filter: Filter) -> Sampler {
        Sampler {
            wrap_s: wrap,
            wrap_t: wrap,
            filter,
        }
    }

    /// The column a nearest lookup at `u` reads in a 4-texel row.
    fn column(wrap: Wrap, u: f32) -> usize {
        sampler(wrap, Filter::Nearest)
            .nearest(Vec2::new(u, 0.5), 4, 1)
            .unwrap()
    }

    #[test]
    fn nearest_columns_follow_each_wrap_mode() {
        // Texel k of 4 covers u in [k/4, (k+1)/4).
        for (u, repeat, clamp, mirror) in [
            (0.1, 0, 0, 0),
            (0.9, 3, 3, 3),
            (-0.1, 3, 0, 0),
            (-0.3, 2, 0, 1),
            (1.1, 0, 3, 3),
            (1.3, 1, 3, 2),
            (2.1, 0, 3, 0),
            (-1.1, 3, 0, 3),
            (7.6, 2, 3, 1),
        ] {
            assert_eq!(column(Wrap::Repeat, u), repeat, "repeat at u = {u}");
            assert_eq!(column(Wrap::Clamp, u), clamp, "clamp at u = {u}");
            assert_eq!(column(Wrap::Mirror, u), mirror, "mirror at u = {u}");
        }
    }

    #[test]
    fn rows_count_from_the_top_and_v_from_the_bottom() {
        let s = sampler(Wrap::Mirror, Filter::Nearest);
        // Row 0 is the top: v just under 1. Below v = 0 the mirrored copy starts with
        // the bottom row again; above v = 1 with the top row.
        assert_eq!(s.nearest(Vec2::new(0.5, 0.9), 1, 4), Some(0));
        assert_eq!(s.nearest(Vec2::new(0.5, 0.1), 1, 4), Some(3));
        assert_eq!(s.nearest(Vec2::new(0.5, -0.1), 1, 4), Some(3));
        assert_eq!(s.nearest(Vec2::new(0.5, 1.1), 1, 4), Some(0));
        assert_eq!(s.nearest(Vec2::new(0.5, 1.3), 1, 4), Some(1));
        let c = sampler(Wrap::Clamp, Filter::Nearest);
        assert_eq!(c.nearest(Vec2::new(0.5, 5.0), 1, 4), Some(0));
        assert_eq!(c.nearest(Vec2::new(0.5, -5.0), 1, 4), Some(3));
    }

    #[test]
    fn bilinear_footprints_at_the_edges() {
        // Halfway between texel centres 3 and 0 of 4 (u = 0 or 1): repeat blends them,
        // clamp and mirror read the edge texel twice.
        let at = |wrap: Wrap, u: f32| {
            let f = sampler(wrap, Filter::Bilinear)
                .footprint(Vec2::new(u, 0.5), 4, 1)
                .unwrap();
            ([f.index[0], f.index[1]], f.fx)
        };
        assert_eq!(at(Wrap::Repeat, 1.0), ([3, 0], 0.5));
        assert_eq!(at(Wrap::Clamp, 1.0), ([3, 3], 0.5));
        assert_eq!(at(Wrap::Clamp, 1.25), ([3, 3], 0.5));
        assert_eq!(at(Wrap::Clamp, -0.25), ([0, 0], 0.5));
        assert_eq!(at(Wrap::Mirror, 1.0), ([3, 3], 0.5));
        assert_eq!(at(Wrap::Mirror, 0.0), ([0, 0], 0.5));
        // u = -0.25 mirrors to 0.25, halfway between texel centres 1 and 0 (the
        // mirrored copy runs right to left).
        assert_eq!(at(Wrap::Mirror, -0.25), ([1, 0], 0.5));
        assert_eq!(at(Wrap::Repeat, -0.25), ([2, 3], 0.5));
    }

    #[test]
    fn non_finite_coordinates_read_nothing() {
        for wrap in [Wrap::Repeat, Wrap::Clamp, Wrap::Mirror] {
            for filter in [Filter::Bilinear, Filter::Nearest] {
                let s = sampler(wrap, filter);
                for uv in [Vec2::new(f32::NAN, 0.5), Vec2::new(0.5, f32::INFINITY)] {
                    assert!(s.footprint(uv, 4, 4).is_none(), "{wrap:?} {filter:?}");
                    assert!(s.nearest(uv, 4, 4).is_none(), "{wrap:?} {filter:?}");
                }
            }
        }
    }
}
