//! The glTF 2.0 metallic-roughness material: the BRDF of the specification's Appendix B
//! ("BRDF implementation"), with `KHR_materials_ior`, `KHR_materials_specular` and
//! `KHR_materials_transmission`, made energy-conserving.
//!
//! In the local shading frame, with `h` the half vector of `wo` and `wi`, `v·h = wo·h`
//! (= `wi·h`), `s = (1 − v·h)⁵` and `S = D G1(wo) G1(wi) / (4 cos θo cos θi)` ember's
//! GGX reflection ([`Ggx`]) of `α = roughness²`:
//!
//! - metal: `S · (b + (1 − b) s)`, Schlick's Fresnel with `F0 = b` the base colour;
//! - dielectric: a specular layer `w · F · S` with `F = f0 + (1 − f0) s`,
//!   `f0 = min(((ior − 1)/(ior + 1))² · specular colour, 1)` (0.04 for the defaults) and
//!   `w` the specular weight (1 by default), over a Lambert base `b / π`;
//! - glass, for the transmission `t`: a rough dielectric interface of index `ior`
//!   behind the surface ([`Interface`]), GGX reflection and Walter et al.'s refraction
//!   through the same facets, refraction tinted by `√b`;
//! - the material: `(1 − metallic) · ((1 − t) · dielectric + t · glass) + metallic · metal`.
//!
//! The glass is what glTF's transmission asks (its BTDF "replaces the diffuse base" in
//! proportion `t`, with the specular layer's roughness, tinted by the base colour), as
//! Blender's importer and Cycles' Principled BSDF make it: a solid of index `ior`, where
//! light refracts on the way in and out and is reflected whole beyond the critical
//! angle inside, rather than the specification's thin wall that only lets light
//! through (`KHR_materials_volume`, which tells the two apart, is not read). Its
//! Fresnel factor is exact, not Schlick's, so that a smooth glass is ember's smooth
//! glass (below [`DELTA_ALPHA`] a pure glass is that delta lobe).
//!
//! The base is where ember departs from the letter of Appendix B (which is
//! non-normative). Its `fresnel_mix` weighs the base by `1 − w max F(v·h)`, but `v·h`
//! stays near 1 for most `wi` while the layer reflects up to all of grazing light: a
//! white dielectric of roughness 0.3 would reflect 22% more than it receives at 80°.
//! ember weighs the base instead by what the layer lets through on the way in and out,
//! `(1 − E_l(μo)) (1 − E_l(μi)) / (1 − E_l,avg)`, with `E_l` the layer's directional
//! albedo (largest channel, as `max F` is) and `E_l,avg` its mean: reciprocal, and the
//! base's albedo is exactly `1 − E_l(μo)`, so a white dielectric keeps all the light.
//! The base's albedo `1 − E_l(μo)` is the specification's at normal incidence (about
//! 0.96 for the defaults) and falls where the layer takes more, at grazing angles; a
//! smooth base lit and seen along the normal is 5% brighter than the specification's.
//!
//! Single scattering also loses the light that bounces more than once between
//! microfacets (nearly two thirds for a white metal at roughness 1). Kulla and Conty's lobe
//! ("Revisiting Physically Based Shading at Imageworks", 2017) adds it back,
//! reciprocally: `f_ms = F_ms (1 − E(μo)) (1 − E(μi)) / (π (1 − E_avg))`, whose albedo is
//! exactly the missing `1 − E(μo)`, coloured by `F_ms = F_avg² E_avg / (1 − F_avg (1 −
//! E_avg))` for each layer's hemispherical mean Fresnel `F_avg` (Schlick's: `f0 + (1 −
//! f0)/21`). The albedos `E` come from a table ([`ggx_albedo`](super::ggx_albedo)). The
//! glass is compensated instead as Cycles' Principled BSDF compensates it, by Turquin's
//! energy scaling: its reflection and refraction are divided by the single-scattering
//! albedo `E(μo, α, η)` of the clear glass ([`glass_albedo`](super::glass_albedo), for
//! the side `wo` is on), so that a clear glass keeps all the light from either side and
//! its density stays single scattering's. The scale depends on `wo` alone, so the glass
//! is reciprocal only up to `E(μi)/E(μo)` (as Cycles' is).
//!
//! Sampling picks GGX's visible normals or a cosine direction (for the base and the
//! compensation lobe) with a probability from their albedos at `wo`, so the density is
//! the mixture of the two; through a visible normal it refracts rather than reflects
//! with a probability from the glass's Fresnel split at `wo` (`sample` has two
//! uniforms, so the choice is made before the normal is drawn, not per facet).

use glam::{Vec2, Vec3};
use std::f32::consts::FRAC_1_PI;

use super::dielectric::{normal_reflectance, reflects_totally, refract, Interface};
use super::ggx_albedo::{average_albedo, directional_albedo, Albedo};
use super::glass_albedo::glass_albedo;
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
    /// GGX's α: `(roughnessFactor × texture)²`.
    pub alpha: f32,
    /// `KHR_materials_ior`'s index of the dielectric (1.5 by default).
    pub ior: f32,
    /// `KHR_materials_specular`'s `specularFactor`: the weight of the dielectric's
    /// specular layer (1 by default).
    pub specular: f32,
    /// `KHR_materials_specular`'s `specularColorFactor` (× texture): scales the
    /// dielectric's `F0` (white by default).
    pub specular_colour: Vec3,
    /// `KHR_materials_transmission`'s `transmissionFactor` (× texture), in [0, 1]: the
    /// share of the dielectric that is glass rather than the diffuse base (0 by default).
    pub transmission: f32,
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
            transmission: 0.0,
        }
    }

    /// A smooth pure metal: a mirror, one of the two cases without a GGX lobe.
    pub(super) fn is_mirror(&self) -> bool {
        self.metallic >= 1.0 && self.alpha < DELTA_ALPHA
    }

    /// A smooth pure glass: ember's smooth dielectric, the other case without a GGX
    /// lobe.
    pub(super) fn is_smooth_glass(&self) -> bool {
        self.transmission >= 1.0
            && self.metallic <= 0.0
            && self.alpha < DELTA_ALPHA
            && self.ior.is_finite()
    }

    /// The glass's interface: index `ior`, refraction tinted by `√(base colour)`.
    pub(super) fn interface(&self) -> Interface {
        Interface {
            ior: self.ior,
            specular: self.specular,
            specular_colour: self.specular_colour,
            tint: self.base_colour.max(Vec3::ZERO).map(f32::sqrt),
        }
    }
}

/// The least index the rough glass refracts with: nearer 1 its BTDF narrows to a
/// straight pass-through (at 1, a delta), which no density could follow.
const MIN_ROUGH_IOR: f32 = 1.01;

/// The least single-scattering albedo the glass is scaled up from: keeps the scale
/// finite where a table cell at grazing incidence is near 0.
const MIN_GLASS_ALBEDO: f32 = 0.05;

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

/// Schlick's mean over the hemisphere, `2 ∫ F(μ) μ dμ`.
#[inline]
fn mean_fresnel(f0: Vec3) -> Vec3 {
    f0 + (Vec3::ONE - f0) / 21.0
}

/// The probabilities with which [`Lobe::sample`] draws through GGX's visible normals
/// rather than from the cosine lobe, and refracts rather than reflects through the
/// normal drawn.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) struct Choice {
    glossy: f32,
    refract: f32,
}

/// The metallic-roughness lobes in the local frame (z = the shading normal, `wo` above
/// the surface; `wi` above it, or below it when the glass refracts).
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) struct Lobe {
    base: Vec3,
    metallic: f32,
    ggx: Ggx,
    /// The dielectric's Schlick `F0`, and its largest channel.
    f0: Vec3,
    f0_max: f32,
    /// The weight of the dielectric's specular layer.
    specular: f32,
    /// `1 − t`: the share of the dielectric that is opaque (layer over diffuse base).
    opaque: f32,
    /// `(1 − metallic) (1 − t)`: the diffuse base's weight in the material.
    diffuse_weight: f32,
    /// `(1 − metallic) t`: the glass's weight in the material (0: none).
    glass: f32,
    interface: Interface,
    /// Kulla–Conty's `F_ms`, mixed over the opaque dielectric and the metal, and
    /// `1 / (π (1 − E_avg))`: the compensation lobe is their product times
    /// `(1 − E(μo)) (1 − E(μi))`.
    multiple: Vec3,
    multiple_norm: f32,
    /// The dielectric layer's `F_ms` in its largest channel.
    multiple_dielectric: f32,
    /// `1 / (π (1 − E_layer,avg))`, the diffuse base's normalisation (0 when the layer
    /// reflects everything).
    diffuse_norm: f32,
}

impl Lobe {
    pub(super) fn new(m: &MetallicRoughness) -> Lobe {
        let alpha = m.alpha.max(DELTA_ALPHA);
        let f0 = (normal_reflectance(m.ior) * m.specular_colour).min(Vec3::ONE);
        let mean = average_albedo(alpha);
        // Smooth surfaces lose nothing worth a lobe, and 1 − E_avg would be noise.
        let (multiple_norm, dielectric, metal) = if 1.0 - mean.one < 1e-4 {
            (0.0, Vec3::ZERO, Vec3::ZERO)
        } else {
            let ms = |f_avg: Vec3| multiple_scattering_fresnel(f_avg, mean.one);
            let dielectric = ms(m.specular * mean_fresnel(f0));
            let metal = ms(mean_fresnel(m.base_colour));
            (FRAC_1_PI / (1.0 - mean.one), dielectric, metal)
        };
        // Nothing refracts into an infinite index.
        let transmission = if m.ior.is_finite() {
            m.transmission.clamp(0.0, 1.0)
        } else {
            0.0
        };
        let opaque = 1.0 - transmission;
        let interface = Interface {
            ior: m.ior.max(MIN_ROUGH_IOR),
            ..m.interface()
        };
        let mut lobe = Lobe {
            base: m.base_colour,
            metallic: m.metallic,
            ggx: Ggx::new(alpha),
            f0,
            f0_max: f0.max_element(),
            specular: m.specular,
            opaque,
            diffuse_weight: (1.0 - m.metallic) * opaque,
            glass: (1.0 - m.metallic) * transmission,
            interface,
            multiple: (dielectric * opaque).lerp(metal, m.metallic),
            multiple_norm,
            multiple_dielectric: dielectric.max_element(),
            diffuse_norm: 0.0,
        };
        let kept = 1.0 - lobe.layer_albedo(mean);
        lobe.diffuse_norm = if kept > 1e-4 { FRAC_1_PI / kept } else { 0.0 };
        lobe
    }

    /// Whether any light is refracted.
    #[inline]
    pub(super) fn transmits(&self) -> bool {
        self.glass > 0.0
    }

    /// The relative index light crosses from the side of `wo` into the glass: `ior` from
    /// the front (the side of the normal), `1/ior` from behind.
    #[inline]
    pub(super) fn eta(&self, behind: bool) -> f32 {
        if behind {
            1.0 / self.interface.ior
        } else {
            self.interface.ior
        }
    }

    /// Turquin's energy scaling of the glass for `wo` at `cos θo = mu` (`eta` as for
    /// [`choice`](Self::choice)): `1/E` of the clear glass of the same roughness and
    /// index, whatever its tint, so that a clear glass keeps all the light and a tinted
    /// one loses only what its tint absorbs.
    #[inline]
    fn glass_compensation(&self, mu: f32, eta: f32) -> f32 {
        1.0 / glass_albedo(mu, self.ggx.alpha(), eta).max(MIN_GLASS_ALBEDO)
    }

    /// What the dielectric's specular layer (compensation included) reflects of light
    /// arriving where GGX's albedos are `a`, in its largest channel.
    #[inline]
    fn layer_albedo(&self, a: Albedo) -> f32 {
        let single = self.f0_max * a.one + (1.0 - self.f0_max) * a.edge;
        (self.specular * single + self.multiple_dielectric * (1.0 - a.one)).min(1.0)
    }

    /// The reflectance a denoiser is given: the base colour, plus the dielectric's
    /// specular reflection at normal incidence (the glass: the base colour).
    pub(super) fn albedo(&self) -> Vec3 {
        let mut dielectric =
            self.base * (1.0 - self.specular * self.f0_max) + self.specular * self.f0;
        if self.glass > 0.0 {
            dielectric = dielectric * self.opaque + self.base * (1.0 - self.opaque);
        }
        dielectric.lerp(self.base, self.metallic).min(Vec3::ONE)
    }

    /// The lobe choice for `wo`, light crossing the relative index `eta` into the
    /// glass. GGX is drawn with the share of the specular layers and the glass in the
    /// albedo at `wo`, the rest being cosine-shaped (the diffuse base and the
    /// compensation); it refracts with the glass's transmitted share.
    #[inline]
    pub(super) fn choice(&self, wo: Vec3, eta: f32) -> Choice {
        let a = directional_albedo(wo.z, self.ggx.alpha());
        let dielectric = self.specular * a.schlick(self.f0) * self.opaque;
        let reflected = luminance(dielectric.lerp(a.schlick(self.base), self.metallic));
        let diffuse = self.diffuse_weight * luminance(self.base) * (1.0 - self.layer_albedo(a));
        let cosine_shaped = diffuse + luminance(self.multiple) * (1.0 - a.one);
        let (glossy, refract) = if self.glass > 0.0 {
            let split = self.interface.split(wo.z, eta);
            let weight = self.glass * a.one;
            let refracted = weight * luminance(split.transmit);
            let glossy = reflected + weight * luminance(split.reflect) + refracted;
            // Facets refract where the mean surface reflects all (and the reverse): each
            // keeps a twentieth of the draws, so the density covers both.
            let share = if glossy > 0.0 {
                refracted / glossy
            } else {
                0.5
            };
            (glossy, share.clamp(0.05, 0.95))
        } else {
            (reflected, 0.0)
        };
        // A lobe carrying under 1% is drawn by the other alone (GGX covers the
        // hemisphere); otherwise each keeps a tenth of the draws, whatever the estimate.
        let glossy = if cosine_shaped <= 0.01 * glossy {
            1.0
        } else {
            (glossy / (glossy + cosine_shaped)).clamp(0.1, 0.9)
        };
        Choice { glossy, refract }
    }

    /// A direction `wi` for `wo` with the lobe choice `c` (`eta` as for
    /// [`choice`](Self::choice)), with `wi.z` of the sign its lobe scatters to (a
    /// reflection above, a refraction below); `None` where it has not (the draw is void).
    /// A refraction through a facet that reflects all the light is that reflection.
    #[inline]
    pub(super) fn sample(&self, wo: Vec3, u: Vec2, c: Choice, eta: f32) -> Option<Vec3> {
        // One uniform chooses the lobe and, stretched back, draws within it.
        let mut u1 = u.x;
        if choose_second(&mut u1, c.glossy) {
            return Some(cosine_hemisphere(u1, u.y));
        }
        let refracts = c.refract > 0.0 && choose_second(&mut u1, 1.0 - c.refract);
        let h = self.ggx.sample_visible_normal(wo, Vec2::new(u1, u.y));
        let refracted = match refracts {
            true => refract(wo, h, wo.dot(h).max(0.0), eta),
            false => None,
        };
        match refracted {
            Some(wi) => (wi.z < 0.0).then_some(wi),
            None if c.refract > 0.0 => Some(reflect(wo, h)).filter(|wi| wi.z > 0.0),
            // Reflection alone, as before transmission existed (`eval` voids `wi.z ≤ 0`).
            None => Some(reflect(wo, h)),
        }
    }

    /// `f(wo, wi) |cos θi|` and the density of `wi` for the lobe choice `c` (`eta` as
    /// for [`choice`](Self::choice)).
    #[inline]
    pub(super) fn eval_pdf(&self, wo: Vec3, wi: Vec3, c: Choice, eta: f32) -> (Vec3, f32) {
        if wi.z < 0.0 {
            return self.eval_pdf_refracted(wo, wi, c, eta);
        }
        let alpha = self.ggx.alpha();
        let (a_o, a_i) = (
            directional_albedo(wo.z, alpha),
            directional_albedo(wi.z, alpha),
        );
        let v_h = wo.dot((wo + wi).normalize());
        let specular = self.ggx.reflectance_cos(wo, wi);
        let kept = (1.0 - self.layer_albedo(a_o)) * (1.0 - self.layer_albedo(a_i));
        let dielectric = self.base * (kept * self.diffuse_norm * wi.z)
            + self.specular * specular * schlick(self.f0, v_h);
        let metal = specular * schlick(self.base, v_h);
        let lost = (1.0 - a_o.one) * (1.0 - a_i.one);
        let mut value = (dielectric * self.opaque).lerp(metal, self.metallic)
            + self.multiple * (lost * self.multiple_norm * wi.z);
        if self.glass > 0.0 {
            let glass = self.glass * self.glass_compensation(wo.z, eta);
            value += glass * specular * self.interface.split(v_h, eta).reflect;
        }
        // Refractions through facets that reflect whole are reflections too.
        let reflecting = match c.refract > 0.0 && reflects_totally(v_h, eta) {
            true => 1.0,
            false => 1.0 - c.refract,
        };
        let pdf =
            c.glossy * reflecting * self.ggx.pdf(wo, wi) + (1.0 - c.glossy) * wi.z * FRAC_1_PI;
        (value, pdf)
    }

    /// [`eval_pdf`](Self::eval_pdf) of a `wi` below the surface: the glass's refraction.
    #[inline]
    fn eval_pdf_refracted(&self, wo: Vec3, wi: Vec3, c: Choice, eta: f32) -> (Vec3, f32) {
        if self.glass <= 0.0 {
            return (Vec3::ZERO, 0.0);
        }
        let Some(r) = self.ggx.refraction(wo, wi, eta) else {
            return (Vec3::ZERO, 0.0);
        };
        let transmit = self.interface.split_across(r.cos_o, r.cos_i, eta).transmit;
        let glass = self.glass * self.glass_compensation(wo.z, eta);
        (glass * r.value * transmit, c.glossy * c.refract * r.pdf)
    }
}
