//! A smooth interface between two dielectrics: exact unpolarised Fresnel reflectance
//! and Snell refraction.

use glam::Vec3;

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
    let cos_t = (1.0 - sin2_t).sqrt();
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
