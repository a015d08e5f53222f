//! What a surface does with light: the BSDF at one surface point, which can be sampled
//! *and* evaluated, so that light sampling, the book's mixture and MIS work at every
//! vertex that is not a perfect mirror or smooth glass.
//!
//! One interface for every material ([`Bsdf`]):
//! - [`sample`](Bsdf::sample)`(wo, u)`: a direction `wi`, its value, its density and
//!   whether the lobe is a delta;
//! - [`eval`](Bsdf::eval)`(wo, wi)`: the value;
//! - [`pdf`](Bsdf::pdf)`(wo, wi)`: the density per steradian with which `sample`
//!   draws `wi`.
//!
//! The *value* is `f(wo, wi) · |cos θi|` (shading normal): the factor by which radiance
//! arriving along `-wi` is scattered towards `wo`. Integrators multiply by it and
//! divide by a density; they know nothing else of a material. Directions are unit
//! world vectors pointing away from the surface.
//!
//! A delta lobe (a mirror, smooth glass) reflects or refracts into one direction: its
//! `eval` and `pdf` are 0 for any given pair of directions, and `sample` returns the
//! weight as `value / pdf`, where `pdf` is the probability of the discrete choice.
//! A BSDF is either wholly delta or has no delta part (see [`Bsdf::glossy`]).
//!
//! Light that crosses the surface (glass, smooth or rough) is radiance squeezed into a
//! denser medium or spread out of it: refraction carries a factor `1/η²` for the
//! relative index `η` crossed, and [`BsdfSample::eta`] says which, so that the
//! integrator can take it out again where only the path's weight matters (Russian
//! roulette). So `f(wo, wi) / η_o² = f(wi, wo) / η_i²` with `η_o`, `η_i` the indices on
//! the sides of `wo` and `wi`.

mod dielectric;
mod ggx_albedo;
mod ggx_albedo_table;
mod glass_albedo;
mod glass_albedo_table;
mod metallic_roughness;
mod microfacet;

pub use dielectric::{fresnel_dielectric, refract, Interface, Split};
pub use ggx_albedo::{average_albedo, directional_albedo, Albedo};
pub use glass_albedo::glass_albedo;
pub use metallic_roughness::{schlick, MetallicRoughness};
pub use microfacet::{reflect, Ggx, Refraction};

use glam::{Vec2, Vec3};
use std::f32::consts::FRAC_1_PI;

use crate::color::luminance;
use crate::sampling::{choose_second, cosine_hemisphere, Onb};

/// Below this roughness a GGX conductor is treated as a perfect mirror, and a pure glass
/// as smooth glass (delta lobes): their lobes are narrower than anything sampling
/// could resolve.
pub const DELTA_ALPHA: f32 = 1e-3;

/// A direction drawn from a [`Bsdf`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BsdfSample {
    /// Unit direction the light comes from (pointing away from the surface).
    pub wi: Vec3,
    /// `f · |cos θi|` (for a delta lobe, the lobe's weight times the choice's
    /// probability, so that `value / pdf` is the path weight).
    pub value: Vec3,
    /// Density per steradian of `wi` (for a delta lobe, the probability of choosing it).
    pub pdf: f32,
    /// Whether the direction came from a delta lobe.
    pub delta: bool,
    /// Relative index of refraction `η_t / η_i` crossed by a refraction, 1 otherwise.
    pub eta: f32,
}

impl BsdfSample {
    /// `value / pdf`: what a path's throughput is multiplied by.
    #[inline]
    pub fn weight(&self) -> Vec3 {
        self.value / self.pdf
    }
}

/// The scattering functions a BSDF combines.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Lobes {
    /// Lambert with albedo `diffuse` plus GGX reflection with constant Fresnel
    /// `specular` (either may be black). Two-sided. `sample` draws the GGX lobe with
    /// probability `glossy_probability`, the cosine lobe otherwise.
    Reflective {
        diffuse: Vec3,
        specular: Vec3,
        ggx: Ggx,
        glossy_probability: f32,
    },
    /// A perfect mirror whose reflectance goes, by Schlick's Fresnel, from `normal` at
    /// normal incidence to `grazing` (equal for a constant reflectance). Two-sided.
    Mirror { normal: Vec3, grazing: Vec3 },
    /// The glTF metallic-roughness material, never a delta (see
    /// [`MetallicRoughness`]). Two-sided for reflection; where it transmits, its glass
    /// has index `ior` on the side opposite the geometric normal.
    MetallicRoughness(metallic_roughness::Lobe),
    /// Smooth glass: the interface's index inside (the side opposite the normal), 1
    /// outside.
    Dielectric(Interface),
}

/// The BSDF at one surface point: its lobes in the frame of the shading normal.
#[derive(Clone, Copy, Debug)]
pub struct Bsdf {
    /// Around the unit shading normal, which lies on the side of `ng`.
    frame: Onb,
    /// Unit geometric normal: decides which side of a two-sided surface light is on,
    /// so that shading normals never let light through a reflective surface.
    ng: Vec3,
    lobes: Lobes,
}

impl Bsdf {
    /// A Lambertian surface of albedo `albedo`.
    pub fn lambert(albedo: Vec3, ns: Vec3, ng: Vec3) -> Bsdf {
        Bsdf::glossy(albedo, Vec3::ZERO, 1.0, ns, ng)
    }

    /// Lambert `diffuse` plus a GGX lobe of roughness `alpha` with Fresnel ≡
    /// `specular`. A GGX lobe alone (a conductor) narrower than [`DELTA_ALPHA`] is a
    /// mirror. Beside a diffuse lobe it stays GGX at α = [`DELTA_ALPHA`] instead, so
    /// that a BSDF is never part delta: light sampling and the mixture density then
    /// apply to all of it.
    pub fn glossy(diffuse: Vec3, specular: Vec3, alpha: f32, ns: Vec3, ng: Vec3) -> Bsdf {
        let has_diffuse = diffuse.max_element() > 0.0;
        let has_specular = specular.max_element() > 0.0;
        let lobes = if has_specular && !has_diffuse && alpha < DELTA_ALPHA {
            Lobes::Mirror {
                normal: specular,
                grazing: specular,
            }
        } else {
            let glossy_probability = match (has_diffuse, has_specular) {
                (_, false) => 0.0,
                (false, true) => 1.0,
                (true, true) => {
                    let (s, d) = (luminance(specular), luminance(diffuse));
                    (s / (s + d)).clamp(0.1, 0.9)
                }
            };
            Lobes::Reflective {
                diffuse,
                specular,
                ggx: Ggx::new(alpha.max(DELTA_ALPHA)),
                glossy_probability,
            }
        };
        Bsdf::with_lobes(lobes, ns, ng)
    }

    /// Smooth glass of index `ior` on the side opposite the normals.
    pub fn dielectric(ior: f32, ns: Vec3, ng: Vec3) -> Bsdf {
        Bsdf::with_lobes(Lobes::Dielectric(Interface::clear(ior)), ns, ng)
    }

    /// The glTF metallic-roughness material `m`. A pure metal narrower than
    /// [`DELTA_ALPHA`] is a mirror with Schlick's Fresnel, a pure glass that narrow is
    /// smooth glass; any other stays GGX at α ≥ [`DELTA_ALPHA`], for the reason
    /// [`glossy`](Self::glossy) gives.
    pub fn metallic_roughness(m: &MetallicRoughness, ns: Vec3, ng: Vec3) -> Bsdf {
        let lobes = if m.is_mirror() {
            Lobes::Mirror {
                normal: m.base_colour,
                grazing: Vec3::ONE,
            }
        } else if m.is_smooth_glass() {
            Lobes::Dielectric(m.interface())
        } else {
            Lobes::MetallicRoughness(metallic_roughness::Lobe::new(m))
        };
        Bsdf::with_lobes(lobes, ns, ng)
    }

    fn with_lobes(lobes: Lobes, ns: Vec3, ng: Vec3) -> Bsdf {
        Bsdf {
            frame: Onb::from_w(ns),
            ng,
            lobes,
        }
    }

    /// Whether every direction `sample` returns comes from a delta lobe (then `eval`
    /// and `pdf` are 0 everywhere and light sampling is pointless).
    #[inline]
    pub fn is_delta(&self) -> bool {
        !matches!(
            self.lobes,
            Lobes::Reflective { .. } | Lobes::MetallicRoughness(_)
        )
    }

    /// Whether some light crosses the surface (the side opposite `wo` then receives
    /// light too, which light sampling must not cull).
    #[inline]
    pub fn transmits(&self) -> bool {
        match self.lobes {
            Lobes::Dielectric(_) => true,
            Lobes::MetallicRoughness(lobe) => lobe.transmits(),
            Lobes::Reflective { .. } | Lobes::Mirror { .. } => false,
        }
    }

    /// The relative index `η_t / η_i` crossed from `wo` to `wi`: 1 unless they are on
    /// opposite sides of a surface that transmits (what [`BsdfSample::eta`] says of a
    /// sample).
    #[inline]
    pub fn eta(&self, wo: Vec3, wi: Vec3) -> f32 {
        if self.same_side(wo, wi) {
            return 1.0;
        }
        match self.lobes {
            Lobes::MetallicRoughness(lobe) if lobe.transmits() => lobe.eta(wo.dot(self.ng) < 0.0),
            Lobes::Dielectric(glass) if wo.dot(self.frame.w) > 0.0 => glass.ior,
            Lobes::Dielectric(glass) => 1.0 / glass.ior,
            _ => 1.0,
        }
    }

    /// The reflectance a denoiser is given as albedo: diffuse plus specular colour,
    /// at most 1 (a delta lobe reflects or transmits everything: 1, or its tint).
    pub fn albedo(&self) -> Vec3 {
        match self.lobes {
            Lobes::Reflective {
                diffuse, specular, ..
            } => (diffuse + specular).min(Vec3::ONE),
            Lobes::Mirror { normal, .. } => normal,
            Lobes::Dielectric(glass) => glass.tint * glass.tint,
            Lobes::MetallicRoughness(lobe) => lobe.albedo(),
        }
    }

    /// A direction for light arriving towards `wo`, drawn from two uniforms in
    /// `[0, 1)`; `None` when the draw yields nothing (a direction below the surface).
    #[inline]
    pub fn sample(&self, wo: Vec3, u: Vec2) -> Option<BsdfSample> {
        match self.lobes {
            Lobes::Reflective {
                ggx,
                glossy_probability,
                ..
            } => {
                let (flip, wo_local) = self.reflective_frame(wo)?;
                // One uniform chooses the lobe and, stretched back, draws within it.
                let mut u1 = u.x;
                let wi_local = if choose_second(&mut u1, glossy_probability) {
                    cosine_hemisphere(u1, u.y)
                } else {
                    let normal = ggx.sample_visible_normal(wo_local, Vec2::new(u1, u.y));
                    reflect(wo_local, normal)
                };
                self.non_delta_sample(wo, self.world(wi_local, flip))
            }
            Lobes::MetallicRoughness(lobe) => {
                let (flip, wo_local) = self.reflective_frame(wo)?;
                let eta = lobe.eta(flip);
                let wi_local = lobe.sample(wo_local, u, lobe.choice(wo_local, eta), eta)?;
                let wi = self.world(wi_local, flip);
                let sample = self.non_delta_sample(wo, wi)?;
                Some(BsdfSample {
                    eta: self.eta(wo, wi),
                    ..sample
                })
            }
            Lobes::Mirror { normal, grazing } => {
                let (flip, wo_local) = self.reflective_frame(wo)?;
                let wi = self.world(Vec3::new(-wo_local.x, -wo_local.y, wo_local.z), flip);
                let edge = (1.0 - wo_local.z.min(1.0)).powi(5);
                self.same_side(wo, wi).then_some(BsdfSample {
                    wi,
                    value: normal + (grazing - normal) * edge,
                    pdf: 1.0,
                    delta: true,
                    eta: 1.0,
                })
            }
            Lobes::Dielectric(glass) => self.sample_dielectric(&glass, wo, u.x),
        }
    }

    /// The sample of direction `wi`, drawn for `wo` by a lobe that is not a delta: its
    /// value and density are what `eval` and `pdf` say of it (`None` where 0).
    #[inline]
    fn non_delta_sample(&self, wo: Vec3, wi: Vec3) -> Option<BsdfSample> {
        let (value, pdf) = self.eval_pdf(wo, wi);
        (pdf > 0.0).then_some(BsdfSample {
            wi,
            value,
            pdf,
            delta: false,
            eta: 1.0,
        })
    }

    /// `f(wo, wi) · |cos θi|` (0 for delta lobes).
    #[inline]
    pub fn eval(&self, wo: Vec3, wi: Vec3) -> Vec3 {
        self.eval_pdf(wo, wi).0
    }

    /// Density per steradian with which [`sample`](Self::sample) draws `wi` for `wo`
    /// (0 for delta lobes).
    #[inline]
    pub fn pdf(&self, wo: Vec3, wi: Vec3) -> f32 {
        self.eval_pdf(wo, wi).1
    }

    /// [`eval`](Self::eval) and [`pdf`](Self::pdf) at once, sharing the frame change.
    #[inline]
    pub fn eval_pdf(&self, wo: Vec3, wi: Vec3) -> (Vec3, f32) {
        if self.is_delta() {
            return (Vec3::ZERO, 0.0);
        }
        let Some((flip, wo_local)) = self.reflective_frame(wo) else {
            return (Vec3::ZERO, 0.0);
        };
        let wi_local = self.local(wi, flip);
        if let Lobes::MetallicRoughness(lobe) = self.lobes {
            // Reflected on wo's side, or refracted to the other (a transmitting lobe's
            // `eval_pdf` is 0 below where it does not).
            let sides = wo.dot(self.ng) * wi.dot(self.ng);
            let reflected = wi_local.z > 0.0 && sides > 0.0;
            let refracted = wi_local.z < 0.0 && sides < 0.0;
            if !(reflected || refracted) {
                return (Vec3::ZERO, 0.0);
            }
            let eta = lobe.eta(flip);
            return lobe.eval_pdf(wo_local, wi_local, lobe.choice(wo_local, eta), eta);
        }
        if wi_local.z <= 0.0 || !self.same_side(wo, wi) {
            return (Vec3::ZERO, 0.0);
        }
        match self.lobes {
            Lobes::Reflective {
                diffuse,
                specular,
                ggx,
                glossy_probability,
            } => {
                let cosine = wi_local.z * FRAC_1_PI;
                let mut value = diffuse * cosine;
                let mut pdf = (1.0 - glossy_probability) * cosine;
                if glossy_probability > 0.0 {
                    value += specular * ggx.reflectance_cos(wo_local, wi_local);
                    pdf += glossy_probability * ggx.pdf(wo_local, wi_local);
                }
                (value, pdf)
            }
            Lobes::MetallicRoughness(_) | Lobes::Mirror { .. } | Lobes::Dielectric(_) => {
                (Vec3::ZERO, 0.0)
            }
        }
    }

    /// For a two-sided reflective surface: whether `wo` is behind the geometric normal
    /// (the lobes then mirror to that side), and `wo` in that side's local frame.
    /// `None` when `wo` is on one side of the geometric surface and the other of the
    /// shading normal: no reflection is defined there.
    #[inline]
    fn reflective_frame(&self, wo: Vec3) -> Option<(bool, Vec3)> {
        let flip = wo.dot(self.ng) < 0.0;
        let local = self.local(wo, flip);
        (local.z > 0.0).then_some((flip, local))
    }

    #[inline]
    fn local(&self, w: Vec3, flip: bool) -> Vec3 {
        let l = self.frame.to_local(w);
        if flip {
            Vec3::new(l.x, l.y, -l.z)
        } else {
            l
        }
    }

    #[inline]
    fn world(&self, l: Vec3, flip: bool) -> Vec3 {
        let z = if flip { -l.z } else { l.z };
        self.frame.to_world(Vec3::new(l.x, l.y, z))
    }

    #[inline]
    fn same_side(&self, wo: Vec3, wi: Vec3) -> bool {
        wo.dot(self.ng) * wi.dot(self.ng) > 0.0
    }

    /// Reflection with probability `F` (exact Fresnel), refraction otherwise, each with
    /// weight 1 on the path (clear glass), times `(η_i/η_t)²` on refraction: radiance is
    /// compressed into a smaller solid angle on entering a denser medium. A tinted
    /// interface chooses by its split's luminances (see [`Interface::split`]).
    fn sample_dielectric(&self, glass: &Interface, wo: Vec3, coin: f32) -> Option<BsdfSample> {
        let ns = self.frame.w;
        let cos_o = wo.dot(ns);
        if cos_o == 0.0 || !cos_o.is_finite() {
            return None;
        }
        // Arriving from the side the normal points to means entering the glass.
        let (n, eta) = if cos_o > 0.0 {
            (ns, glass.ior)
        } else {
            (-ns, 1.0 / glass.ior)
        };
        let cos_i = cos_o.abs();
        let split = glass.split(cos_i, eta);
        let p = split.p_reflect;
        let refracted = if coin < p {
            None
        } else {
            refract(wo, n, cos_i, eta)
        };
        Some(match refracted {
            None => BsdfSample {
                wi: reflect(wo, n),
                value: split.reflect,
                pdf: p,
                delta: true,
                eta: 1.0,
            },
            Some(wi) => BsdfSample {
                wi,
                value: split.transmit / (eta * eta),
                pdf: 1.0 - p,
                delta: true,
                eta,
            },
        })
    }
}
