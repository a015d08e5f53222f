//! Light samples of the lights that are not geometry (see [`crate::scene::Light`]):
//! what a point or spot light sends to a receiver, and the directions of a sun.
//!
//! A point light is a delta light: its one direction from a receiver has a
//! probability (that of choosing the light), not a density, and no ray can find it,
//! so its sample takes the weight 1 under MIS. A sun without an angular diameter is a
//! delta light too; with one it is a cone of directions of uniform radiance, drawn
//! uniformly (density `1/Ω`), which rays leaving the scene within it also find: it is
//! weighed against BSDF sampling as the sky is.

use glam::Vec3;

use super::bvh::LightBounds;
use crate::color::luminance;
use crate::sampling::Onb;
use crate::scene::{DirectionalLight, PointLight};

/// What a point light sends to a receiver: the unit direction to the light, the
/// distance, and the light arriving there, `I(−dir) / d²` (an irradiance: the light
/// is a point). `None` where it sends nothing (outside a spot's cone, or at the
/// receiver itself).
#[inline]
pub fn point_towards(light: &PointLight, p: Vec3) -> Option<(Vec3, f32, Vec3)> {
    let to_light = light.position - p;
    let distance_squared = to_light.length_squared();
    let distance = distance_squared.sqrt();
    if distance.is_nan() || distance <= 0.0 || !distance.is_finite() {
        return None;
    }
    let dir = to_light / distance;
    let arriving = light.intensity_towards(-dir) / distance_squared;
    (arriving != Vec3::ZERO && arriving.is_finite()).then_some((dir, distance, arriving))
}

/// A point light's weight in the choice of a light, in the units of an emissive
/// triangle's (`A · lum(L)`, its power over π): `4 · lum(I)` times a spot's share.
pub fn point_weight(light: &PointLight) -> f32 {
    luminance(light.power()) / std::f32::consts::PI
}

/// A point light's bounds in the light BVH: a point, emitting every way, or a spot
/// emitting within 90° of its axis (the BVH's implicit emission angle; a spot's outer
/// angle is at most that).
pub fn point_bounds(light: &PointLight) -> LightBounds {
    let (axis, cos_theta) = match &light.spot {
        None => (Vec3::Z, -1.0),
        Some(cone) => (cone.axis, 1.0),
    };
    LightBounds {
        lo: light.position,
        hi: light.position,
        axis,
        cos_theta,
        power: point_weight(light),
        two_sided: false,
    }
}

/// A sun as light sampling reads it.
#[derive(Clone, Copy, Debug)]
pub struct Sun {
    /// Unit direction towards the sun (against the light's travel).
    pub towards: Vec3,
    /// Irradiance (a delta sun) or radiance (a disc) per channel.
    pub emission: Vec3,
    /// `1 − cos α` and `sin² α` of the disc's angular radius α (0 for a delta sun),
    /// computed without cancellation.
    one_minus_cos: f32,
    sin_squared: f32,
    /// The disc's solid angle's inverse (0 for a delta sun).
    inverse_solid_angle: f32,
    frame: Onb,
}

impl Sun {
    pub fn new(light: &DirectionalLight) -> Self {
        let towards = -light.direction;
        let alpha = light.half_angle;
        let delta = alpha <= 0.0;
        let half_sin = (0.5 * alpha).sin();
        let one_minus_cos = 2.0 * half_sin * half_sin;
        Sun {
            towards,
            emission: if delta {
                light.irradiance
            } else {
                light.radiance()
            },
            one_minus_cos,
            sin_squared: alpha.sin().powi(2),
            inverse_solid_angle: if delta {
                0.0
            } else {
                1.0 / light.solid_angle()
            },
            frame: Onb::from_w(towards),
        }
    }

    /// Whether it is a delta light (no angular diameter).
    #[inline]
    pub fn is_delta(&self) -> bool {
        self.inverse_solid_angle == 0.0
    }

    /// A direction towards the sun from two uniforms, and its density given the sun
    /// (0 for a delta sun, whose one direction has probability 1).
    #[inline]
    pub fn sample(&self, u: [f32; 2]) -> (Vec3, f32) {
        if self.is_delta() {
            return (self.towards, 0.0);
        }
        // `h = 1 − cos θ`, uniform in [0, 1 − cos α]: uniform over the cap's solid angle.
        let h = u[0] * self.one_minus_cos;
        let sin_theta = (h * (2.0 - h)).max(0.0).sqrt();
        let phi = 2.0 * std::f32::consts::PI * u[1];
        let local = Vec3::new(sin_theta * phi.cos(), sin_theta * phi.sin(), 1.0 - h);
        (
            self.frame.to_world(local).normalize(),
            self.inverse_solid_angle,
        )
    }

    /// Whether the unit direction `dir` lies in the sun's disc (never for a delta
    /// sun), by the sine of its angle to the centre, which keeps its precision for a
    /// disc of a fraction of a degree where the cosine would not.
    #[inline]
    pub fn contains(&self, dir: Vec3) -> bool {
        !self.is_delta()
            && self.towards.dot(dir) > 0.0
            && self.towards.cross(dir).length_squared() <= self.sin_squared
    }

    /// The density of [`sample`](Self::sample) along unit `dir` (0 outside the disc).
    #[inline]
    pub fn density(&self, dir: Vec3) -> f32 {
        if self.contains(dir) {
            self.inverse_solid_angle
        } else {
            0.0
        }
    }
}

/// A sun's weight in the choice between the far lights (the sky and the suns): its
/// power through a disc of the scene's bounding radius `r`, `lum(E) · π r²` (how the
/// sky's is estimated).
pub fn sun_power(light: &DirectionalLight, scene_radius: f32) -> f32 {
    luminance(light.irradiance).max(0.0) * std::f32::consts::PI * scene_radius.max(1e-6).powi(2)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sampling::Rng;

    /// A sun's drawn directions all lie in its disc, and the fraction of uniform
    /// directions in the disc is its solid angle over 4π.
    #[test]
    fn sun_draws_lie_in_its_disc() {
        let light = DirectionalLight {
            direction: Vec3::new(0.3, -1.0, 0.2).normalize(),
            irradiance: Vec3::ONE,
            half_angle: 0.3,
        };
        let sun = Sun::new(&light);
        let mut rng = Rng::seeded(5);
        for _ in 0..10_000 {
            let (u1, u2) = rng.pair();
            let (dir, density) = sun.sample([u1, u2]);
            assert!((dir.length() - 1.0).abs() < 1e-5);
            assert!(sun.towards.dot(dir) >= (0.3f32).cos() - 1e-5);
            assert_eq!(density, 1.0 / light.solid_angle());
        }
        let n = 400_000;
        let inside = (0..n)
            .filter(|_| {
                let (u1, u2) = rng.pair();
                sun.contains(crate::sampling::uniform_sphere(u1, u2))
            })
            .count();
        let expected = light.solid_angle() / (4.0 * std::f32::consts::PI);
        let share = inside as f32 / n as f32;
        assert!(
            (share - expected).abs() < 4.0 * (expected / n as f32).sqrt(),
            "{share} {expected}"
        );
    }
}
