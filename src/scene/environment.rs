//! Light from infinitely far away: an equirectangular (latitude-longitude) radiance
//! map around the scene, importance-sampled in proportion to luminance × sin θ.
//!
//! Conventions (y is up, as in OBJ scenes):
//! - row 0 of the image is straight up (θ = 0), the last row straight down;
//! - the middle column looks along −z (where the default camera looks), and columns
//!   run towards +x: `φ = atan2(x, −z)`, `u = ½ + φ / 2π`, `v = θ / π`;
//! - `--env-rotate` turns the map about +y by that many degrees (counter-clockwise
//!   seen from above);
//! - Mitsuba's lat-long maps put `u = 0` at −z, half a turn from ours, so its `envmap`
//!   turned R° about +y is ours turned R − 180 (`tests/env_convention.rs`).
//!
//! Radiance is piecewise constant over texels (nearest lookup), so the sampling density
//! can match it exactly: a texel is chosen by two alias tables (a row by its total
//! weight, then a column within it, O(1) each), then a uniform point in it. In solid
//! angle that is `p(ω) = p_row · p_column · W·H / (2π² sin θ)`.
//!
//! Each texel keeps its radiance, its probability and its entry of its row's alias
//! table side by side ([`Texel`]): a map of a few megatexels is far larger than the
//! caches, and a draw or a lookup then costs one or two cache misses instead of four
//! (radiance, coin, alias, probability each in an array of its own took a third of an
//! unguided render of the sky-lit room).

use glam::{Vec2, Vec3};
use std::f32::consts::PI;

use std::path::Path;

use super::SceneError;
use crate::color::luminance;
use crate::image::Image;
use crate::sampling::{alias_bin, alias_draw, AliasEntry, AliasTable};

/// A radiance map at infinity with its sampling distribution.
#[derive(Clone, Debug)]
pub struct Environment {
    width: u32,
    height: u32,
    /// The texels, row 0 at the top.
    texels: Vec<Texel>,
    /// Rotation about +y, radians.
    rotation: f32,
    /// Rows by their total weight; `None` when the map is black everywhere.
    rows: Option<AliasTable>,
    /// `∫ lum(L) dω` over the sphere.
    luminous_intensity: f32,
}

/// One texel of the map: what a lookup or a draw reads of it, in one record (see the
/// module notes).
#[derive(Clone, Copy, Debug)]
struct Texel {
    /// Radiance (scale applied).
    radiance: Vec3,
    /// The probability of drawing this texel: its row's times its own within the row
    /// (0 in a row, or a map, without weight).
    probability: f32,
    /// This texel's entry in its row's alias table over columns (a row without weight
    /// keeps every entry and is never drawn).
    column: AliasEntry,
}

/// A direction drawn towards the environment.
#[derive(Clone, Copy, Debug)]
pub struct SkySample {
    pub dir: Vec3,
    pub radiance: Vec3,
    /// Solid-angle density (> 0).
    pub pdf: f32,
}

impl Environment {
    /// The map `texels` (`width × height`, linear radiance, row 0 up) times `scale`,
    /// turned by `rotate_degrees` about +y.
    pub fn new(
        width: u32,
        height: u32,
        texels: Vec<Vec3>,
        scale: f32,
        rotate_degrees: f32,
    ) -> Self {
        assert_eq!(texels.len(), width as usize * height as usize);
        let radiance: Vec<Vec3> = texels.into_iter().map(|t| t * scale).collect();
        // A texel's weight is its luminance times its row's sin θ (its solid angle).
        let weights = |row: usize, texels: &[Vec3]| -> Vec<f32> {
            let sin_theta = ((row as f32 + 0.5) / height as f32 * PI).sin();
            texels
                .iter()
                .map(|&t| luminance(t).max(0.0) * sin_theta)
                .collect()
        };
        let totals: Vec<f32> = radiance
            .chunks_exact(width.max(1) as usize)
            .enumerate()
            .map(|(row, texels)| weights(row, texels).iter().sum())
            .collect();
        // Each texel spans 2π/W by π/H in (φ, θ), so dω = 2π²/(W·H) · sin θ.
        let texel_solid_angle = 2.0 * PI * PI / (width * height) as f32;
        let luminous_intensity =
            totals.iter().map(|&t| f64::from(t)).sum::<f64>() as f32 * texel_solid_angle;
        let rows = AliasTable::new(&totals);
        let mut texels = Vec::with_capacity(radiance.len());
        for (row, row_radiance) in radiance.chunks_exact(width.max(1) as usize).enumerate() {
            // The row's weights again, rather than all rows' held since the totals:
            // one row at a time is all the map's build needs beside the texels.
            let columns = AliasTable::new(&weights(row, row_radiance));
            let row_probability = rows.as_ref().map_or(0.0, |rows| rows.pmf(row));
            texels.extend(
                row_radiance
                    .iter()
                    .enumerate()
                    .map(|(col, &radiance)| match &columns {
                        Some(columns) => Texel {
                            radiance,
                            probability: row_probability * columns.pmf(col),
                            column: columns.entry(col),
                        },
                        None => Texel {
                            radiance,
                            probability: 0.0,
                            column: AliasEntry {
                                keep: 1.0,
                                alias: col as u32,
                            },
                        },
                    }),
            );
        }
        Environment {
            width,
            height,
            texels,
            rotation: rotate_degrees.to_radians(),
            rows,
            luminous_intensity,
        }
    }

    /// Reads an equirectangular map (EXR or HDR hold linear radiance; any other format
    /// the `image` crate reads is taken as sRGB), refusing texels that are negative or
    /// not finite.
    pub fn load(path: &Path, scale: f32, rotate_degrees: f32) -> Result<Self, SceneError> {
        let fail = |reason: String| SceneError::Environment {
            path: path.to_owned(),
            reason,
        };
        let image = Image::load(path).map_err(|e| fail(e.to_string()))?;
        if let Some((i, t)) = image
            .pixels
            .iter()
            .enumerate()
            .find(|(_, t)| !t.is_finite() || t.min_element() < 0.0)
        {
            let (x, y) = (i as u32 % image.width, i as u32 / image.width);
            return Err(fail(format!(
                "texel ({x}, {y}) is {t}, not a finite radiance ≥ 0"
            )));
        }
        if !(scale.is_finite() && scale >= 0.0 && rotate_degrees.is_finite()) {
            return Err(fail(format!(
                "scale {scale} or rotation {rotate_degrees} is not usable"
            )));
        }
        Ok(Environment::new(
            image.width,
            image.height,
            image.pixels,
            scale,
            rotate_degrees,
        ))
    }

    /// A uniform sky of radiance `radiance`: one column, rows fine enough that the
    /// density is close to uniform on the sphere.
    pub fn constant(radiance: Vec3) -> Self {
        let rows = 64;
        Environment::new(1, rows, vec![radiance; rows as usize], 1.0, 0.0)
    }

    /// Whether any direction carries light (and sampling the sky is worth it).
    pub fn is_black(&self) -> bool {
        self.rows.is_none()
    }

    /// Luminance of the radiance integrated over the sphere, `∫ lum(L) dω`.
    pub fn luminous_intensity(&self) -> f32 {
        self.luminous_intensity
    }

    /// Radiance arriving from the unit direction `dir` (from the sky towards the
    /// scene along `-dir`).
    #[inline]
    pub fn radiance(&self, dir: Vec3) -> Vec3 {
        self.texels[self.texel_index(self.map_coordinates(dir))].radiance
    }

    /// [`radiance`](Self::radiance) and [`pdf`](Self::pdf) along `dir` from one
    /// lookup (both are read where a ray leaves the scene and multiple importance
    /// sampling weighs it).
    #[inline]
    pub fn radiance_and_pdf(&self, dir: Vec3) -> (Vec3, f32) {
        let uv = self.map_coordinates(dir);
        let texel = &self.texels[self.texel_index(uv)];
        (texel.radiance, self.density(texel, uv.y))
    }

    /// Solid-angle density with which [`sample`](Self::sample) draws `dir`.
    #[inline]
    pub fn pdf(&self, dir: Vec3) -> f32 {
        let uv = self.map_coordinates(dir);
        self.density(&self.texels[self.texel_index(uv)], uv.y)
    }

    /// The density in solid angle at map row `v` (in [0, 1]) of `texel`: its
    /// probability spread uniformly over its (u, v) area, `dω = 2π² sin θ du dv`.
    #[inline]
    fn density(&self, texel: &Texel, v: f32) -> f32 {
        let sin_theta = (v * PI).sin();
        if texel.probability == 0.0 || sin_theta <= 0.0 {
            return 0.0;
        }
        texel.probability * (self.width * self.height) as f32 / (2.0 * PI * PI * sin_theta)
    }

    /// A direction towards the sky from a row draw `u_row` (an `f64` with random low
    /// bits, see [`AliasTable::sample`]) and a column draw `u_column`.
    #[inline]
    pub fn sample(&self, u_row: f64, u_column: f64) -> Option<SkySample> {
        let (row, v_in_row) = self.rows.as_ref()?.sample(u_row);
        let width = self.width as usize;
        let row_texels = &self.texels[row * width..(row + 1) * width];
        let (col, u_in_col) = alias_draw(width, u_column, |c| row_texels[c].column);
        let uv = Vec2::new(
            (col as f32 + u_in_col) / self.width as f32,
            (row as f32 + v_in_row) / self.height as f32,
        );
        // The texel is known: no need to find it again from the direction.
        let texel = &row_texels[col];
        let pdf = self.density(texel, uv.y);
        (pdf > 0.0 && pdf.is_finite()).then(|| SkySample {
            dir: self.direction(uv),
            radiance: texel.radiance,
            pdf,
        })
    }

    /// A hint with no effect on any result: starts loading the texel that
    /// [`sample`](Self::sample) reads first for these uniforms (its column's alias
    /// entry), so that the load overlaps other work. The texels of a sky map are tens
    /// of megabytes, and that load was otherwise a miss to memory on nearly every light
    /// sample: 70% of `sample`'s time and a fifth of an unguided room's.
    #[inline]
    pub fn prefetch(&self, u_row: f64, u_column: f64) {
        let Some(rows) = self.rows.as_ref() else {
            return;
        };
        let (row, _) = rows.sample(u_row);
        let width = self.width as usize;
        let (column, _) = alias_bin(width, u_column);
        if let Some(texel) = self.texels.get(row * width + column) {
            prefetch_line(texel);
        }
    }

    /// `(u, v)` in [0, 1]² of a unit world direction.
    #[inline]
    fn map_coordinates(&self, dir: Vec3) -> Vec2 {
        let (s, c) = self.rotation.sin_cos();
        // Undo the map's rotation about +y.
        let x = c * dir.x - s * dir.z;
        let z = s * dir.x + c * dir.z;
        let phi = x.atan2(-z);
        let theta = dir.y.clamp(-1.0, 1.0).acos();
        Vec2::new(0.5 + phi / (2.0 * PI), theta / PI)
    }

    /// The unit world direction at map coordinates `uv`.
    #[inline]
    fn direction(&self, uv: Vec2) -> Vec3 {
        let phi = (uv.x - 0.5) * 2.0 * PI;
        let theta = uv.y * PI;
        let (sin_t, cos_t) = theta.sin_cos();
        let (x, z) = (sin_t * phi.sin(), -sin_t * phi.cos());
        let (s, c) = self.rotation.sin_cos();
        Vec3::new(c * x + s * z, cos_t, -s * x + c * z)
    }

    #[inline]
    fn texel(&self, uv: Vec2) -> (usize, usize) {
        let col = ((uv.x * self.width as f32) as usize).min(self.width as usize - 1);
        let row = ((uv.y * self.height as f32) as usize).min(self.height as usize - 1);
        (col, row)
    }

    #[inline]
    fn texel_index(&self, uv: Vec2) -> usize {
        let (col, row) = self.texel(uv);
        row * self.width as usize + col
    }

    /// The numbers that identify the map (for checkpoint identity): size, rotation and
    /// every texel's radiance bits.
    pub fn identity_words(&self) -> impl Iterator<Item = u32> + '_ {
        [self.width, self.height, self.rotation.to_bits()]
            .into_iter()
            .chain(
                self.texels
                    .iter()
                    .flat_map(|t| t.radiance.to_array().map(f32::to_bits)),
            )
    }
}

/// Asks the caches for the line holding `value` (a hint; nothing on other targets).
#[inline(always)]
fn prefetch_line<T>(value: &T) {
    #[cfg(target_arch = "x86_64")]
    safe_arch::prefetch_t0(value);
    #[cfg(not(target_arch = "x86_64"))]
    let _ = value;
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn directions_and_map_coordinates_round_trip() {
        for rotate in [0.0f32, 37.0, -120.0] {
            let env = Environment::new(4, 2, vec![Vec3::ONE; 8], 1.0, rotate);
            for (u, v) in [(0.1f32, 0.2f32), (0.5, 0.5), (0.9, 0.77), (0.33, 0.05)] {
                let dir = env.direction(Vec2::new(u, v));
                assert!((dir.length() - 1.0).abs() < 1e-5);
                let back = env.map_coordinates(dir);
                assert!(
                    (back - Vec2::new(u, v)).abs().max_element() < 1e-5,
                    "{rotate}: {back}"
                );
            }
        }
        // The middle of the map looks along −z, the top row up.
        let env = Environment::constant(Vec3::ONE);
        assert!((env.direction(Vec2::new(0.5, 0.5)) - Vec3::NEG_Z).length() < 1e-5);
        assert!((env.direction(Vec2::new(0.3, 0.0)) - Vec3::Y).length() < 1e-5);
    }

    #[test]
    fn a_uniform_map_has_its_radiance_times_four_pi() {
        let env = Environment::constant(Vec3::splat(2.0));
        assert!((env.luminous_intensity() - 8.0 * PI).abs() < 0.05);
    }
}
