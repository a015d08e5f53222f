//! A smooth interface between two dielectrics: exact unpolarised Fresnel reflectance
//! and Snell refraction, and [`Interface`], how much of each channel such an interface
//! reflects and transmits once glTF's specular and transmission parameters shape it.

use glam::Vec3;

use crate::color::luminance;

/// Fresnel reflectance of unpolarised light arriving at cosine `cos_i` (≥ 0) from the
/// side of index `η_i`, onto a medium of relative index `eta = η_t / η_i`:
/// `½ (r_s² + r_p²)` with `r_s = (cos_i − η cos_t)/(cos_i + η cos_t)` and
/// `r_p = (η cos_i − cos_t)/(η cos_i + cos_t)`; 1 under total internal reflection.
#[inline]
pub fn fresnel_dielectric(cos_i: f32, eta: f32) -> f32 {
    let cos_i = cos_i.clamp(0.0, 1.0);
    let sin2_t = (1.0 - cos_i * cos_i) / (eta * eta);
    if sin2_t >= 1.0 {
        return 1.0;
    }
    fresnel_across(cos_i, (1.0 - sin2_t).sqrt(), eta)
}

/// [`fresnel_dielectric`] of light crossing at cosine `cos_i` on its side and `cos_t`
/// (Snell's) on the other: the same from either side (`cos_t`, `1/η` give it too),
/// and well conditioned where `cos_t` is near 0, which recomputing it from `cos_i` is
/// not.
#[inline]
pub fn fresnel_across(cos_i: f32, cos_t: f32, eta: f32) -> f32 {
    let r_s = (cos_i - eta * cos_t) / (cos_i + eta * cos_t);
    let r_p = (eta * cos_i - cos_t) / (eta * cos_i + cos_t);
    0.5 * (r_s * r_s + r_p * r_p)
}

/// `w` (unit, pointing away on the side of `n`, at cosine `cos_i` with it) refracted
/// into the other side of relative index `eta = η_t / η_i`; `None` under total
/// internal reflection.
#[inline]
pub fn refract(w: Vec3, n: Vec3, cos_i: f32, eta: f32) -> Option<Vec3> {
    let sin2_t = (1.0 - cos_i * cos_i).max(0.0) / (eta * eta);
    if sin2_t >= 1.0 {
        return None;
    }
    let cos_t = (1.0 - sin2_t).sqrt();
    Some((-w / eta + (cos_i / eta - cos_t) * n).normalize())
}

/// Whether light arriving at cosine `cos_i` onto relative index `eta` is reflected
/// whole: where [`refract`] finds no direction.
#[inline]
pub fn reflects_totally(cos_i: f32, eta: f32) -> bool {
    (1.0 - cos_i * cos_i).max(0.0) / (eta * eta) >= 1.0
}

/// Fresnel reflectance at normal incidence of an interface of index `ior`: 1 for an
/// infinite index (`KHR_materials_ior`'s 0).
#[inline]
pub fn normal_reflectance(ior: f32) -> f32 {
    if ior.is_infinite() {
        return 1.0;
    }
    let f = (ior - 1.0) / (ior + 1.0);
    f * f
}

/// A dielectric interface of index `ior` behind its normal (1 in front) as glTF's
/// `KHR_materials_transmission` and `KHR_materials_specular` shape it, and as Blender's
/// Principled BSDF renders a glTF's transmission: at a facet seen at cosine `c` it
/// reflects `R = w F(c)` of each channel and transmits `(1 − R) · tint`.
///
/// - `F` is the exact Fresnel reflectance, remapped (as Cycles does) to start from
///   `min(F0 · specular_colour, 1)` instead of `F0` and still reach 1 at grazing
///   angles; a white `specular_colour` keeps it exact.
/// - `w` is `specularFactor`, except under total internal reflection, where no light
///   can leave and all of it is reflected.
/// - `tint` is what a refraction keeps: `√(base colour)` for glTF, so that light
///   crossing a solid's two walls is tinted by the base colour once, as glTF's
///   thin-walled surface tints it (Cycles' choice too).
///
/// Both sides see the same facet the same way (`F(c, η)` equals `F` at the refracted
/// cosine with `1/η`), so the BSDFs made of it are reciprocal.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Interface {
    pub ior: f32,
    pub specular: f32,
    pub specular_colour: Vec3,
    pub tint: Vec3,
}

/// What an [`Interface`] does with light at one facet: each channel's reflectance and
/// transmittance, and the probability with which a sampler chooses reflection.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Split {
    pub reflect: Vec3,
    pub transmit: Vec3,
    pub p_reflect: f32,
}

impl Interface {
    /// Clear glass: exact Fresnel, nothing tinted.
    pub fn clear(ior: f32) -> Interface {
        Interface {
            ior,
            specular: 1.0,
            specular_colour: Vec3::ONE,
            tint: Vec3::ONE,
        }
    }

    /// Whether reflection and transmission are grey: the choice is then made with the
    /// reflectance itself (exact Fresnel for clear glass).
    #[inline]
    fn is_grey(&self) -> bool {
        self.specular_colour == Vec3::ONE && self.tint == Vec3::ONE
    }

    /// The split of light arriving at cosine `cos` (≥ 0) from the side where the
    /// relative index across the interface is `eta`.
    #[inline]
    pub fn split(&self, cos: f32, eta: f32) -> Split {
        self.split_by(fresnel_dielectric(cos, eta))
    }

    /// The split of light crossing at cosine `cos_i` on its side and `cos_t` on the
    /// other (see [`fresnel_across`]).
    #[inline]
    pub fn split_across(&self, cos_i: f32, cos_t: f32, eta: f32) -> Split {
        self.split_by(fresnel_across(cos_i, cos_t, eta))
    }

    /// The split where the exact Fresnel reflectance is `exact`.
    #[inline]
    fn split_by(&self, exact: f32) -> Split {
        if exact >= 1.0 {
            return Split {
                reflect: Vec3::ONE,
                transmit: Vec3::ZERO,
                p_reflect: 1.0,
            };
        }
        let fresnel = if self.specular_colour == Vec3::ONE {
            Vec3::splat(exact)
        } else {
            let f0 = normal_reflectance(self.ior);
            let s = ((exact - f0) / (1.0 - f0)).clamp(0.0, 1.0);
            let tinted = (f0 * self.specular_colour).min(Vec3::ONE);
            tinted + (Vec3::ONE - tinted) * s
        };
        let reflect = self.specular * fresnel;
        let transmit = (Vec3::ONE - reflect) * self.tint;
        let p_reflect = if self.is_grey() {
            reflect.x
        } else {
            let (r, t) = (luminance(reflect), luminance(transmit));
            if r + t > 0.0 {
                r / (r + t)
            } else {
                1.0
            }
        };
        Split {
            reflect,
            transmit,
            p_reflect,
        }
    }
}
