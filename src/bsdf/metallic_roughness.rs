//! The glTF 2.0 metallic-roughness material: the BRDF of the specification's Appendix B
//! ("BRDF implementation"), with `KHR_materials_ior` and `KHR_materials_specular`, plus
//! multiple-scattering energy compensation.
//!
//! In the local shading frame, with `h` the half vector of `wo` and `wi`, `v·h = wo·h`
//! (= `wi·h`, so every term is reciprocal), `s = (1 − v·h)⁵` and `S = D G1(wo) G1(wi) /
//! (4 cos θo cos θi)` ember's GGX reflection ([`Ggx`]) of `α = roughness²`:
//!
//! - metal: `S · (b + (1 − b) s)`, Schlick's Fresnel with `F0 = b` the base colour;
//! - dielectric, the specification's `fresnel_mix` as `KHR_materials_specular` extends
//!   it: `F = f0 + (1 − f0) s` with `f0 = min(((ior − 1)/(ior + 1))² · specular colour, 1)`
//!   (0.04 for the defaults), then `(1 − w · max(F)) · b / π + w · F · S` for the
//!   specular weight `w` (1 by default): the diffuse base keeps what the layer does not
//!   reflect;
//! - the material: `(1 − metallic) · dielectric + metallic · metal`.
//!
//! Single scattering loses the light that bounces more than once between microfacets
//! (a third of it for a white metal at roughness 1). Kulla and Conty's lobe ("Revisiting
//! Physically Based Shading at Imageworks", 2017) adds it back, reciprocally:
//! `f_ms = F_ms (1 − E(μo)) (1 − E(μi)) / (π (1 − E_avg))`, whose albedo is exactly the
//! missing `1 − E(μo)` ([`ggx_albedo`](super::ggx_albedo)), coloured by
//! `F_ms = F_avg² E_avg / (1 − F_avg (1 − E_avg))` for each specular layer's
//! hemispherical mean Fresnel `F_avg` (Schlick's: `f0 + (1 − f0)/21`).
//!
//! Sampling picks GGX's visible normals or a cosine direction (for the diffuse base and
//! the compensation lobe) with a probability from their albedos at `wo`, so the density
//! is the mixture of the two.

use glam::{Vec2, Vec3};
use std::f32::consts::FRAC_1_PI;

use super::ggx_albedo::{average_albedo, directional_albedo};
use super::{reflect, Ggx, DELTA_ALPHA};
use crate::color::luminance;
use crate::sampling::{choose_second, cosine_hemisphere};

/// The parameters of a glTF metallic-roughness material at one surface point, its
/// textures already applied.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MetallicRoughness {
    /// `baseColorFactor` (× texture): the diffuse colour, and the metal's `F0`; in [0, 1].
    pub base_colour: Vec3,
    /// `metallicFactor` (× texture), in [0, 1].
    pub metallic: f32,
    /// GGX roughness: `roughnessFactor² ` (× texture, before squaring).
    pub alpha: f32,
    /// `KHR_materials_ior`'s index of the dielectric (1.5 by default).
    pub ior: f32,
    /// `KHR_materials_specular`'s `specularFactor`: the weight of the dielectric's
    /// specular layer (1 by default).
    pub specular: f32,
    /// `KHR_materials_specular`'s `specularColorFactor` (× texture): scales the
    /// dielectric's `F0` (white by default).
    pub specular_colour: Vec3,
}

impl MetallicRoughness {
    /// The core specification's material: index 1.5, no `KHR_materials_specular`.
    pub fn new(base_colour: Vec3, metallic: f32, alpha: f32) -> MetallicRoughness {
        MetallicRoughness {
            base_colour,
            metallic,
            alpha,
            ior: 1.5,
            specular: 1.0,
            specular_colour: Vec3::ONE,
        }
    }

    /// A smooth pure metal: a mirror, the only case without a GGX lobe.
    pub(super) fn is_mirror(&self) -> bool {
        self.metallic >= 1.0 && self.alpha < DELTA_ALPHA
    }
}

/// Schlick's Fresnel `f0 + (1 − f0) (1 − cos)⁵`.
#[inline]
pub fn schlick(f0: Vec3, cos: f32) -> Vec3 {
    let s = (1.0 - cos.clamp(0.0, 1.0)).powi(5);
    f0 + (Vec3::ONE - f0) * s
}

/// Kulla and Conty's colour of the multiply scattered light, for a layer whose
/// hemispherical mean Fresnel is `f_avg` over GGX of mean albedo `e_avg`.
#[inline]
fn multiple_scattering_fresnel(f_avg: Vec3, e_avg: f32) -> Vec3 {
    f_avg * f_avg * e_avg / (Vec3::ONE - f_avg * (1.0 - e_avg))
}

/// The metallic-roughness lobes in the local frame (z = the shading normal, both
/// directions above the surface).
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) struct Lobe {
    base: Vec3,
    metallic: f32,
    ggx: Ggx,
    /// The dielectric's Schlick `F0`.
    f0: Vec3,
    /// The weight of the dielectric's specular layer.
    specular: f32,
    /// `F_ms / (π (1 − E_avg))`, mixed over dielectric and metal: the compensation lobe
    /// is this times `(1 − E(μo)) (1 − E(μi))`.
    compensation: Vec3,
}

impl Lobe {
    pub(super) fn new(m: &MetallicRoughness) -> Lobe {
        let alpha = m.alpha.max(DELTA_ALPHA);
        let f = (m.ior - 1.0) / (m.ior + 1.0);
        let f0 = (f * f * m.specular_colour).min(Vec3::ONE);
        let e_avg = average_albedo(alpha);
        // Smooth surfaces lose nothing worth a lobe, and 1 − E_avg would be noise.
        let compensation = if 1.0 - e_avg < 1e-4 {
            Vec3::ZERO
        } else {
            let mean_fresnel = |f0: Vec3| f0 + (Vec3::ONE - f0) / 21.0;
            let dielectric = multiple_scattering_fresnel(m.specular * mean_fresnel(f0), e_avg);
            let metal = multiple_scattering_fresnel(mean_fresnel(m.base_colour), e_avg);
            dielectric.lerp(metal, m.metallic) * FRAC_1_PI / (1.0 - e_avg)
        };
        Lobe {
            base: m.base_colour,
            metallic: m.metallic,
            ggx: Ggx::new(alpha),
            f0,
            specular: m.specular,
            compensation,
        }
    }

    /// The reflectance a denoiser is given: the base colour, plus the dielectric's
    /// specular reflection at normal incidence.
    pub(super) fn albedo(&self) -> Vec3 {
        let dielectric =
            self.base * (1.0 - self.specular * self.f0.max_element()) + self.specular * self.f0;
        dielectric.lerp(self.base, self.metallic).min(Vec3::ONE)
    }

    /// The probability of drawing from GGX rather than the cosine lobe, from the
    /// albedos of the specular layers and of what is cosine-shaped (the diffuse base and
    /// the compensation), with Fresnel taken at `wo`.
    #[inline]
    pub(super) fn glossy_probability(&self, wo: Vec3) -> f32 {
        let e = directional_albedo(wo.z, self.ggx.alpha());
        let dielectric = self.specular * schlick(self.f0, wo.z);
        let metal = schlick(self.base, wo.z);
        let glossy = e * luminance(dielectric.lerp(metal, self.metallic));
        let diffuse =
            (1.0 - self.metallic) * luminance(self.base) * (1.0 - dielectric.max_element());
        let compensation_albedo = std::f32::consts::PI * (1.0 - average_albedo(self.ggx.alpha()));
        let compensation = luminance(self.compensation) * compensation_albedo * (1.0 - e);
        let cosine_shaped = diffuse + compensation;
        // A lobe carrying under 1% is drawn by the other alone (GGX covers the
        // hemisphere); otherwise each keeps a tenth of the draws, whatever the estimate.
        if cosine_shaped <= 0.01 * glossy {
            1.0
        } else {
            (glossy / (glossy + cosine_shaped)).clamp(0.1, 0.9)
        }
    }

    /// A direction `wi` for `wo`, given the lobe choice's probability.
    #[inline]
    pub(super) fn sample(&self, wo: Vec3, u: Vec2, glossy_probability: f32) -> Vec3 {
        // One uniform chooses the lobe and, stretched back, draws within it.
        let mut u1 = u.x;
        if choose_second(&mut u1, glossy_probability) {
            cosine_hemisphere(u1, u.y)
        } else {
            reflect(wo, self.ggx.sample_visible_normal(wo, Vec2::new(u1, u.y)))
        }
    }

    /// `f(wo, wi) cos θi` and the density of `wi` for the lobe choice's probability.
    #[inline]
    pub(super) fn eval_pdf(&self, wo: Vec3, wi: Vec3, glossy_probability: f32) -> (Vec3, f32) {
        let h = (wo + wi).normalize();
        let v_h = wo.dot(h);
        let specular = self.ggx.reflectance_cos(wo, wi);
        let cosine = wi.z * FRAC_1_PI;
        let fresnel = schlick(self.f0, v_h);
        let dielectric = self.base * ((1.0 - self.specular * fresnel.max_element()) * cosine)
            + self.specular * specular * fresnel;
        let metal = specular * schlick(self.base, v_h);
        let alpha = self.ggx.alpha();
        let lost =
            (1.0 - directional_albedo(wo.z, alpha)) * (1.0 - directional_albedo(wi.z, alpha));
        let value = dielectric.lerp(metal, self.metallic) + self.compensation * (lost * wi.z);
        let pdf = glossy_probability * self.ggx.pdf(wo, wi) + (1.0 - glossy_probability) * cosine;
        (value, pdf)
    }
}
