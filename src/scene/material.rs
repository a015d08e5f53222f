//! Materials read from MTL files, and the BSDF each one has at a surface point.
//!
//! How MTL statements map to a material: the first rule that applies, with
//! `α = sqrt(2 / (Ns + 2))` (`Ns` absent counts as 0). The reference images depend on
//! this table; docs/guide.md repeats it.
//!
//! | rule | material |
//! |---|---|
//! | `illum` 4, 6, 7 or 9 | smooth glass, index `Ni` (1.5 if absent or ≤ 1); `Tf`, `Ns`, `Ks` ignored |
//! | `illum` 3 or 5, or `Ks` > 0 with `Kd` = 0 and no `map_Kd` | GGX conductor, roughness α, Fresnel ≡ `Ks` |
//! | `Kd` (or `map_Kd`) > 0 and (`Ks` > 0, `map_Ks` or `Pm`/`map_Pm`) | Lambert `Kd·(1−Ks)` + GGX lobe, roughness α, Fresnel ≡ `Ks` |
//! | otherwise | Lambert `Kd` (or `map_Kd`) |
//!
//! `Pr` (the PBR extension's roughness), when given, sets `α = Pr²` instead of `Ns`
//! (the perceptual-roughness convention of glTF and Disney: α grows as the square).
//! `Pm` (metallic, `m`) blends the last two rows toward a conductor whose Fresnel is
//! the diffuse colour: Lambert `Kd·(1−Ks)·(1−m)` + GGX with Fresnel `Ks·(1−m) + Kd·m`,
//! exactly `(1−m)·dielectric + m·metal` since both share α. It leaves glass and the
//! conductor row alone: their `Kd` is not a metal's colour (converters write `Kd 0`,
//! `Ks` = F0, `illum 3` for metals).
//!
//! Texture maps replace or multiply their constants at each point: `map_Kd` and
//! `map_Ks` replace `Kd` and `Ks`; `map_Ke`, `map_Pr`, `map_Pm` and `map_Ns` multiply
//! `Ke`, `Pr`, `Pm` and `Ns` (each taken as 1 when only its map is given, except `Ns`).
//!
//! `Kd` and `Ks` are clamped to [0, 1] per channel, so no material reflects more light
//! than it receives. Any material with `Ke` > 0 (or `map_Ke`) also emits from the side
//! its triangles' counter-clockwise winding faces (from both faces where
//! [`Material::two_sided_emission`] is set), and still reflects with its BSDF.
//! Every surface but glass is two-sided.
//!
//! A glTF material is not read from MTL: its loader makes a [`Model::MetallicRoughness`]
//! with [`Material::metallic_roughness`] and sets the maps. Its factors *multiply* their
//! textures (`baseColorFactor` in `Kd` × `map_Kd`, `specularColorFactor` in `Ks` ×
//! `map_Ks`, `transmissionFactor` in the model × `maps.transmission`), and one
//! metallic-roughness texture feeds both scalars through [`Channel`]s: roughness from
//! green, metallic from blue.

use glam::Vec3;

use crate::bsdf::{Bsdf, MetallicRoughness};

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
    /// The glTF 2.0 metallic-roughness BSDF ([`MetallicRoughness`]): base colour `Kd`,
    /// metallic `Pm`, roughness `Pr` (`alpha` = `Pr²`); `ior` is `KHR_materials_ior`'s
    /// (infinite for its 0), `specular` `KHR_materials_specular`'s `specularFactor`,
    /// whose `specularColorFactor` is `Ks`, and `transmission`
    /// `KHR_materials_transmission`'s `transmissionFactor`.
    MetallicRoughness {
        alpha: f32,
        ior: f32,
        specular: f32,
        transmission: f32,
    },
}

/// Which channel of its texture a scalar map reads. A single-channel texture (what
/// MTL's scalar maps load as: the image's luminance) holds its value in all three.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub enum Channel {
    #[default]
    Red,
    Green,
    Blue,
}

impl Channel {
    /// This channel of a texture's value.
    #[inline]
    pub fn of(self, value: Vec3) -> f32 {
        match self {
            Channel::Red => value.x,
            Channel::Green => value.y,
            Channel::Blue => value.z,
        }
    }
}

/// The texture maps of a material: indices into the scene's textures.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct MaterialMaps {
    /// `map_Ks` (colour): replaces `Ks`.
    pub specular: Option<u32>,
    /// `map_Ns` (scalar): multiplies `Ns`.
    pub shininess: Option<u32>,
    /// `map_Ke` (colour): multiplies `Ke`.
    pub emission: Option<u32>,
    /// `map_Pr` (scalar): multiplies `Pr`.
    pub roughness: Option<u32>,
    /// The channel `roughness` reads (glTF's metallic-roughness texture: green).
    pub roughness_channel: Channel,
    /// `map_Pm` (scalar): multiplies `Pm`.
    pub metallic: Option<u32>,
    /// The channel `metallic` reads (glTF's metallic-roughness texture: blue).
    pub metallic_channel: Channel,
    /// glTF's `transmissionTexture` (scalar, its red channel): multiplies the model's
    /// `transmission`.
    pub transmission: Option<u32>,
    /// `bump` / `map_Bump` (scalar height map) and its `-bm` multiplier.
    pub bump: Option<u32>,
    pub bump_scale: f32,
    /// `norm` (tangent-space normal map, RGB data).
    pub normal: Option<u32>,
}

impl MaterialMaps {
    /// Whether the shading normal is perturbed by a map.
    pub fn perturbs_normal(&self) -> bool {
        self.bump.is_some() || self.normal.is_some()
    }
}

#[derive(Clone, Debug, PartialEq)]
pub struct Material {
    pub name: String,
    /// `Kd`: diffuse reflectance (linear RGB, in [0, 1]); glTF's `baseColorFactor`.
    pub diffuse: Vec3,
    /// `map_Kd`: index into the scene's textures, replacing `Kd` where present (glTF's
    /// `baseColorTexture`, which multiplies it).
    pub diffuse_texture: Option<u32>,
    /// `Ks`: the Fresnel factor of the GGX lobe (linear RGB, in [0, 1]); glTF's
    /// `specularColorFactor` (≥ 0), which scales the dielectric's `F0`.
    pub specular: Vec3,
    /// `Ke`: emitted radiance (1 where only `map_Ke` is given).
    pub emission: Vec3,
    pub model: Model,
    /// `Pr`: the roughness the model's α comes from, when given (α = `Pr²`).
    pub roughness: Option<f32>,
    /// `Ns`, when `map_Ns` needs it (α is computed per point from `Ns × map`).
    pub shininess: Option<f32>,
    /// `Pm`: metallic, in [0, 1].
    pub metallic: f32,
    pub maps: MaterialMaps,
    /// `d` (or `1 − Tr`): how much of the surface is there, in `[0, 1]`; 1 is opaque.
    /// Multiplies `opacity_map`. See [`super::Opacity`].
    pub opacity: f32,
    /// `map_d` (or the alpha channel of `map_Kd`): index into the scene's alpha maps.
    pub opacity_map: Option<u32>,
    /// Whether the emission leaves both faces (glTF's `doubleSided`, a scene file's
    /// `two-sided` light) rather than the counter-clockwise side alone.
    pub two_sided_emission: bool,
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
            roughness: None,
            shininess: None,
            metallic: 0.0,
            maps: MaterialMaps::default(),
            opacity: 1.0,
            opacity_map: None,
            two_sided_emission: false,
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
    /// `Pr`: roughness in [0, 1].
    pub pr: Option<f32>,
    /// `Pm`: metallic in [0, 1].
    pub pm: Option<f32>,
    /// The texture maps other than `map_Kd`.
    pub maps: MaterialMaps,
}

/// What a material is at one surface point, once its textures are read.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SurfaceParams {
    /// Diffuse colour (`Kd` or `map_Kd`), in [0, 1].
    pub albedo: Vec3,
    /// `Ks` or `map_Ks`, in [0, 1].
    pub specular: Vec3,
    /// GGX roughness.
    pub alpha: f32,
    /// Metallic, in [0, 1].
    pub metallic: f32,
    /// The glTF transmission (factor × map), in [0, 1]; 0 for the other models.
    pub transmission: f32,
}

/// GGX roughness from a Phong exponent: `sqrt(2 / (Ns + 2))`, `Ns` absent or negative
/// counting as 0.
pub fn alpha_from_ns(ns: Option<f32>) -> f32 {
    (2.0 / (ns.unwrap_or(0.0).max(0.0) + 2.0)).sqrt()
}

/// GGX roughness from the PBR extension's `Pr`: `α = Pr²`, `Pr` clamped to [0, 1].
pub fn alpha_from_pr(pr: f32) -> f32 {
    let pr = pr.clamp(0.0, 1.0);
    pr * pr
}

impl Material {
    /// Applies the mapping table in the module documentation.
    pub fn from_mtl(name: &str, mtl: &MtlValues, diffuse_texture: Option<u32>) -> Material {
        let unit = |c: Option<Vec3>| c.unwrap_or(Vec3::ZERO).clamp(Vec3::ZERO, Vec3::ONE);
        let (kd, ks) = (unit(mtl.kd), unit(mtl.ks));
        let maps = mtl.maps;
        let ke = match (mtl.ke, maps.emission) {
            (None, Some(_)) => Vec3::ONE,
            (ke, _) => ke.unwrap_or(Vec3::ZERO).max(Vec3::ZERO),
        };
        let alpha = mtl.pr.map_or_else(|| alpha_from_ns(mtl.ns), alpha_from_pr);
        // With only `map_Pm`, the map is the metallic value (it multiplies a `Pm` of 1).
        let metallic = match (mtl.pm, maps.metallic) {
            (None, Some(_)) => 1.0,
            (pm, _) => pm.unwrap_or(0.0).clamp(0.0, 1.0),
        };
        let illum = mtl.illum.unwrap_or(2);
        let has_diffuse = kd.max_element() > 0.0 || diffuse_texture.is_some();
        let has_specular = ks.max_element() > 0.0 || maps.specular.is_some();
        let has_metal = metallic > 0.0;
        let model = if matches!(illum, 4 | 6 | 7 | 9) {
            Model::Glass {
                ior: mtl.ni.filter(|&n| n > 1.0).unwrap_or(1.5),
            }
        } else if matches!(illum, 3 | 5) || (has_specular && !has_diffuse) {
            Model::Conductor { alpha }
        } else if has_diffuse && (has_specular || has_metal) {
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
            roughness: mtl.pr.map(|pr| pr.clamp(0.0, 1.0)),
            shininess: mtl.ns,
            metallic,
            maps,
            opacity: 1.0,
            opacity_map: None,
            two_sided_emission: false,
        }
    }

    /// The glTF metallic-roughness material of the core specification: base colour
    /// `base_colour` (linear), `metallic` and perceptual `roughness` in [0, 1], index
    /// 1.5, no emission and no maps.
    pub fn metallic_roughness(
        name: &str,
        base_colour: Vec3,
        metallic: f32,
        roughness: f32,
    ) -> Material {
        let roughness = roughness.clamp(0.0, 1.0);
        Material {
            name: name.to_owned(),
            diffuse: base_colour.clamp(Vec3::ZERO, Vec3::ONE),
            specular: Vec3::ONE,
            model: Model::MetallicRoughness {
                alpha: alpha_from_pr(roughness),
                ior: 1.5,
                specular: 1.0,
                transmission: 0.0,
            },
            roughness: Some(roughness),
            metallic: metallic.clamp(0.0, 1.0),
            ..Material::default()
        }
    }

    /// Whether a colour factor multiplies its texture (glTF) rather than being replaced
    /// by it (MTL).
    pub fn factors_multiply_maps(&self) -> bool {
        matches!(self.model, Model::MetallicRoughness { .. })
    }

    /// Whether every point of the surface is there (no cut-outs).
    pub fn is_opaque(&self) -> bool {
        self.opacity >= 1.0 && self.opacity_map.is_none()
    }

    pub fn is_emissive(&self) -> bool {
        self.emission.max_element() > 0.0
    }

    /// Whether the emission reaches a ray travelling along `dir` that meets the
    /// surface of geometric normal `ng` (counter-clockwise): from the front, or from
    /// either face when two-sided (grazing rays meet nothing).
    #[inline]
    pub fn emits_along(&self, dir: Vec3, ng: Vec3) -> bool {
        let cos = dir.dot(ng);
        cos < 0.0 || (self.two_sided_emission && cos > 0.0)
    }

    /// How many faces emit: the factor of the power `π A L` of a triangle of area `A`.
    #[inline]
    pub fn emitting_faces(&self) -> f32 {
        if self.two_sided_emission {
            2.0
        } else {
            1.0
        }
    }

    /// The GGX roughness of the model, before any map.
    pub fn alpha(&self) -> f32 {
        match self.model {
            Model::Conductor { alpha }
            | Model::Coated { alpha }
            | Model::MetallicRoughness { alpha, .. } => alpha,
            Model::Lambert | Model::Glass { .. } => 1.0,
        }
    }

    /// GGX roughness at a point where `map_Pr` reads `roughness_map` and `map_Ns`
    /// reads `shininess_map` (each `None` when the material has no such map).
    pub fn alpha_at(&self, roughness_map: Option<f32>, shininess_map: Option<f32>) -> f32 {
        match (roughness_map, self.roughness, shininess_map) {
            (Some(t), pr, _) => alpha_from_pr(pr.unwrap_or(1.0) * t),
            (None, None, Some(t)) => alpha_from_ns(Some(self.shininess.unwrap_or(0.0) * t)),
            _ => self.alpha(),
        }
    }

    /// The BSDF at a surface point with parameters `p`, with unit shading normal `ns`
    /// and geometric normal `ng` on one side.
    #[inline]
    pub fn bsdf(&self, p: &SurfaceParams, ns: Vec3, ng: Vec3) -> Bsdf {
        match self.model {
            Model::Lambert | Model::Coated { .. } => {
                let m = p.metallic;
                let diffuse = p.albedo * (1.0 - p.specular) * (1.0 - m);
                let specular = p.specular * (1.0 - m) + p.albedo * m;
                Bsdf::glossy(diffuse, specular, p.alpha, ns, ng)
            }
            Model::Conductor { .. } => Bsdf::glossy(Vec3::ZERO, p.specular, p.alpha, ns, ng),
            Model::Glass { ior } => Bsdf::dielectric(ior, ns, ng),
            Model::MetallicRoughness { ior, specular, .. } => {
                let m = MetallicRoughness {
                    base_colour: p.albedo,
                    metallic: p.metallic,
                    alpha: p.alpha,
                    ior,
                    specular,
                    specular_colour: p.specular,
                    transmission: p.transmission,
                };
                Bsdf::metallic_roughness(&m, ns, ng)
            }
        }
    }

    /// Whether the diffuse reflectance is read at all (glass and conductors ignore it).
    pub fn uses_albedo(&self) -> bool {
        matches!(
            self.model,
            Model::Lambert | Model::Coated { .. } | Model::MetallicRoughness { .. }
        )
    }
}
