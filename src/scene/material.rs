//! Materials read from MTL files, and the BSDF each one has at a surface point.
//!
//! How MTL statements map to a material: the first rule that applies, with
//! `α = sqrt(2 / (Ns + 2))` (`Ns` absent counts as 0). The reference images depend on
//! this table; `README.md` repeats it.
//!
//! | rule | material |
//! |---|---|
//! | `illum` 4, 6, 7 or 9 | smooth glass, index `Ni` (1.5 if absent or ≤ 1); `Tf`, `Ns`, `Ks` ignored |
//! | `illum` 3 or 5, or `Ks` > 0 with `Kd` = 0 and no `map_Kd` | GGX conductor, roughness α, Fresnel ≡ `Ks` |
//! | `Kd` (or `map_Kd`) > 0 and `Ks` > 0 | Lambert `Kd·(1−Ks)` + GGX lobe, roughness α, Fresnel ≡ `Ks` |
//! | otherwise | Lambert `Kd` (or `map_Kd`) |
//!
//! `Kd` and `Ks` are clamped to [0, 1] per channel, so no material reflects more light
//! than it receives. Any material with `Ke` > 0 also emits `Ke` from the side its
//! triangles' counter-clockwise winding faces, and still reflects with its BSDF. Every
//! surface but glass is two-sided.

use glam::{Vec2, Vec3};

use crate::bsdf::Bsdf;

/// Which row of the mapping table a material took, with its parameters.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Model {
    /// Lambert `Kd`.
    Lambert,
    /// GGX reflection alone, Fresnel ≡ `Ks`.
    Conductor { alpha: f32 },
    /// Lambert `Kd·(1−Ks)` plus GGX reflection with Fresnel ≡ `Ks`.
    Coated { alpha: f32 },
    /// Smooth glass of index `ior`.
    Glass { ior: f32 },
}

#[derive(Clone, Debug, PartialEq)]
pub struct Material {
    pub name: String,
    /// `Kd`: diffuse reflectance (linear RGB, in [0, 1]).
    pub diffuse: Vec3,
    /// `map_Kd`: index into the scene's textures, replacing `Kd` where present.
    pub diffuse_texture: Option<u32>,
    /// `Ks`: the Fresnel factor of the GGX lobe (linear RGB, in [0, 1]).
    pub specular: Vec3,
    /// `Ke`: emitted radiance.
    pub emission: Vec3,
    pub model: Model,
    /// `d` (or `1 − Tr`): how much of the surface is there, in `[0, 1]`; 1 is opaque.
    /// Multiplies `opacity_map`. See [`super::Opacity`].
    pub opacity: f32,
    /// `map_d` (or the alpha channel of `map_Kd`): index into the scene's alpha maps.
    pub opacity_map: Option<u32>,
}

impl Default for Material {
    /// Matte grey, for triangles without a material.
    fn default() -> Self {
        Material {
            name: "default".into(),
            diffuse: Vec3::splat(0.5),
            diffuse_texture: None,
            specular: Vec3::ZERO,
            emission: Vec3::ZERO,
            model: Model::Lambert,
            opacity: 1.0,
            opacity_map: None,
        }
    }
}

/// The raw MTL values a [`Material`] is made from.
#[derive(Clone, Debug, Default)]
pub struct MtlValues {
    pub kd: Option<Vec3>,
    pub ks: Option<Vec3>,
    pub ke: Option<Vec3>,
    pub ns: Option<f32>,
    pub ni: Option<f32>,
    pub illum: Option<u8>,
}

/// GGX roughness from a Phong exponent: `sqrt(2 / (Ns + 2))`, `Ns` absent or negative
/// counting as 0.
pub fn alpha_from_ns(ns: Option<f32>) -> f32 {
    (2.0 / (ns.unwrap_or(0.0).max(0.0) + 2.0)).sqrt()
}

impl Material {
    /// Applies the mapping table in the module documentation.
    pub fn from_mtl(name: &str, mtl: &MtlValues, diffuse_texture: Option<u32>) -> Material {
        let unit = |c: Option<Vec3>| c.unwrap_or(Vec3::ZERO).clamp(Vec3::ZERO, Vec3::ONE);
        let (kd, ks) = (unit(mtl.kd), unit(mtl.ks));
        let ke = mtl.ke.unwrap_or(Vec3::ZERO).max(Vec3::ZERO);
        let alpha = alpha_from_ns(mtl.ns);
        let illum = mtl.illum.unwrap_or(2);
        let has_diffuse = kd.max_element() > 0.0 || diffuse_texture.is_some();
        let has_specular = ks.max_element() > 0.0;
        let model = if matches!(illum, 4 | 6 | 7 | 9) {
            Model::Glass {
                ior: mtl.ni.filter(|&n| n > 1.0).unwrap_or(1.5),
            }
        } else if matches!(illum, 3 | 5) || (has_specular && !has_diffuse) {
            Model::Conductor { alpha }
        } else if has_diffuse && has_specular {
            Model::Coated { alpha }
        } else {
            Model::Lambert
        };
        Material {
            name: name.to_owned(),
            diffuse: kd,
            diffuse_texture,
            specular: ks,
            emission: ke,
            model,
            opacity: 1.0,
            opacity_map: None,
        }
    }

    /// Whether every point of the surface is there (no cut-outs).
    pub fn is_opaque(&self) -> bool {
        self.opacity >= 1.0 && self.opacity_map.is_none()
    }

    pub fn is_emissive(&self) -> bool {
        self.emission.max_element() > 0.0
    }

    /// The BSDF at a surface point whose diffuse reflectance (`Kd` or its texture) is
    /// `albedo`, with unit shading normal `ns` and geometric normal `ng` on one side.
    #[inline]
    pub fn bsdf(&self, albedo: Vec3, ns: Vec3, ng: Vec3) -> Bsdf {
        match self.model {
            Model::Lambert => Bsdf::lambert(albedo, ns, ng),
            Model::Conductor { alpha } => Bsdf::glossy(Vec3::ZERO, self.specular, alpha, ns, ng),
            Model::Coated { alpha } => {
                Bsdf::glossy(albedo * (1.0 - self.specular), self.specular, alpha, ns, ng)
            }
            Model::Glass { ior } => Bsdf::dielectric(ior, ns, ng),
        }
    }

    /// Whether the diffuse reflectance is read at all (glass and conductors ignore it).
    pub fn uses_albedo(&self) -> bool {
        matches!(self.model, Model::Lambert | Model::Coated { .. })
    }
}

/// An RGB texture in linear colour, looked up with wrapping and bilinear filtering.
#[derive(Clone, Debug)]
pub struct Texture {
    pub width: u32,
    pub height: u32,
    pub texels: Vec<Vec3>,
}

impl Texture {
    /// The colour at `uv`; `(0, 0)` is the bottom-left of the image (OBJ convention).
    pub fn sample(&self, uv: Vec2) -> Vec3 {
        let (w, h) = (self.width as f32, self.height as f32);
        let x = uv.x.rem_euclid(1.0) * w - 0.5;
        let y = (1.0 - uv.y.rem_euclid(1.0)) * h - 0.5;
        if !(x.is_finite() && y.is_finite()) {
            return Vec3::ZERO;
        }
        let (x0, y0) = (x.floor(), y.floor());
        let (fx, fy) = (x - x0, y - y0);
        let texel = |xi: f32, yi: f32| {
            let xi = (xi as i64).rem_euclid(self.width as i64) as usize;
            let yi = (yi as i64).rem_euclid(self.height as i64) as usize;
            self.texels[yi * self.width as usize + xi]
        };
        let top = texel(x0, y0).lerp(texel(x0 + 1.0, y0), fx);
        let bottom = texel(x0, y0 + 1.0).lerp(texel(x0 + 1.0, y0 + 1.0), fx);
        top.lerp(bottom, fy)
    }
}
