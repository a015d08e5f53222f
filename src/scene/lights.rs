//! Lights that are not geometry: a point (a spot when it has a cone) and a direction
//! (the sun). They are what a scene file's `[[light]]` tables and glTF's
//! `KHR_lights_punctual` place; area lights are made of emissive triangles instead
//! ([`super::area_lights`]).
//!
//! Units are radiometric: a point's intensity in W/sr, a direction's irradiance in
//! W/m² (per colour channel; scene units are taken as metres). Photometric values
//! convert at [`LUMENS_PER_WATT`] (683 lm/W), as Blender's glTF importer reads them,
//! so that ember and Cycles render one file equally bright: a point or spot of `I` cd
//! has `I/683` W/sr (its power `I·4π/683` W), a sun of `E` lux gives `E/683` W/m².

use glam::{Affine3A, Vec3};
use std::f32::consts::PI;

/// The luminous efficacy at which candela and lux become W/sr and W/m²: 683 lm/W,
/// the definition of the candela at 540 THz, and Blender's glTF importer's factor.
pub const LUMENS_PER_WATT: f32 = 683.0;

/// The widest spot cone (half-angle, radians): `KHR_lights_punctual`'s limit of π/2.
pub const MAX_SPOT_ANGLE: f32 = std::f32::consts::FRAC_PI_2;

/// A light of the scene that is not geometry.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Light {
    Point(PointLight),
    Directional(DirectionalLight),
}

/// Light leaving one point: the same intensity in every direction, or within a spot
/// cone. A delta light: no ray can hit it, so only light samples reach it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PointLight {
    pub position: Vec3,
    /// Radiant intensity along the axis (in every direction without a cone), W/sr.
    pub intensity: Vec3,
    pub spot: Option<SpotCone>,
}

/// A spot light's cone with `KHR_lights_punctual`'s smooth falloff: full intensity
/// within the inner angle, none beyond the outer, and between them the square of a
/// ramp that is linear in the cosine.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SpotCone {
    /// Unit direction the light shines along.
    pub axis: Vec3,
    pub cos_inner: f32,
    pub cos_outer: f32,
}

/// Light arriving from one direction, as from the sun: a delta light, or with an
/// angular diameter a small disc of directions of uniform radiance.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DirectionalLight {
    /// Unit direction the light travels (from the sun towards the scene).
    pub direction: Vec3,
    /// Irradiance on a surface facing the light, W/m².
    pub irradiance: Vec3,
    /// Half the angular diameter, radians; 0 for a delta light.
    pub half_angle: f32,
}

impl Light {
    /// The light placed by `transform` (an instance's): its position and direction
    /// moved with it, its intensity left as it is (as glTF's node scale leaves it).
    pub fn transformed(&self, transform: &Affine3A) -> Light {
        let turn = |v: Vec3| transform.transform_vector3(v).normalize_or(v);
        match *self {
            Light::Point(p) => Light::Point(PointLight {
                position: transform.transform_point3(p.position),
                spot: p.spot.map(|cone| SpotCone {
                    axis: turn(cone.axis),
                    ..cone
                }),
                ..p
            }),
            Light::Directional(d) => Light::Directional(DirectionalLight {
                direction: turn(d.direction),
                ..d
            }),
        }
    }
}

impl SpotCone {
    /// The cone around unit `axis` with inner and outer half-angles in radians
    /// (`0 ≤ inner ≤ outer ≤ π/2`, checked by the caller).
    pub fn new(axis: Vec3, inner: f32, outer: f32) -> Self {
        SpotCone {
            axis,
            cos_inner: inner.cos(),
            cos_outer: outer.cos(),
        }
    }

    /// The width of the ramp in cosine, as `KHR_lights_punctual` bounds it (so that
    /// equal angles still give a finite slope).
    #[inline]
    fn ramp(&self) -> f32 {
        (self.cos_inner - self.cos_outer).max(0.001)
    }

    /// The share of the axis's intensity sent along unit `dir` (away from the light):
    /// the extension's `saturate(cd · scale + offset)²` with `cd = axis · dir`,
    /// `scale = 1 / max(0.001, cos inner − cos outer)` and `offset = −cos outer · scale`.
    #[inline]
    pub fn falloff(&self, dir: Vec3) -> f32 {
        let scale = 1.0 / self.ramp();
        let offset = -self.cos_outer * scale;
        let t = (self.axis.dot(dir) * scale + offset).clamp(0.0, 1.0);
        t * t
    }

    /// `∫ falloff dω / 4π`: the share of a point light's power the cone keeps. In the
    /// cosine `c` of the angle to the axis the falloff is `((c − cos o)/w)²` over the
    /// ramp of width `w`, and 1 above it: `2π ((1 − cos o − w) + w/3)` over the sphere,
    /// or `2π (1 − cos o)³/3w²` where the ramp reaches past the axis (tiny cones).
    pub fn power_share(&self) -> f32 {
        let w = self.ramp();
        let open = 1.0 - self.cos_outer;
        if w <= open {
            0.5 * ((open - w) + w / 3.0)
        } else {
            0.5 * open * open * open / (3.0 * w * w)
        }
    }
}

impl PointLight {
    /// The intensity sent along unit `dir` (away from the light), W/sr.
    #[inline]
    pub fn intensity_towards(&self, dir: Vec3) -> Vec3 {
        match &self.spot {
            None => self.intensity,
            Some(cone) => self.intensity * cone.falloff(dir),
        }
    }

    /// Power sent out, W per channel: `4π I` times the cone's share.
    pub fn power(&self) -> Vec3 {
        let share = self.spot.map_or(1.0, |cone| cone.power_share());
        4.0 * PI * share * self.intensity
    }
}

impl DirectionalLight {
    /// The solid angle of its disc of directions, `2π (1 − cos α)` (0 for a delta).
    pub fn solid_angle(&self) -> f32 {
        let s = (0.5 * self.half_angle).sin();
        4.0 * PI * s * s
    }

    /// The radiance of its disc, `E / (π sin²α)`, so that a surface facing it receives
    /// `E` (the disc's cosine-weighted solid angle is `π sin²α`).
    pub fn radiance(&self) -> Vec3 {
        let s = self.half_angle.sin();
        self.irradiance / (PI * s * s)
    }
}

/// `I` cd as W/sr.
pub fn intensity_from_candela(candela: f32) -> f32 {
    candela / LUMENS_PER_WATT
}

/// A point or spot light of `power` W as its intensity, W/sr: `P / 4π`. A spot's power
/// is that of the point light it is cut from (Blender's and pbrt's convention, and
/// what a glTF's candela give), so narrowing the cone does not brighten it.
pub fn intensity_from_power(power: f32) -> f32 {
    power / (4.0 * PI)
}

/// `E` lux as W/m².
pub fn irradiance_from_lux(lux: f32) -> f32 {
    lux / LUMENS_PER_WATT
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The cone's share of power is the falloff integrated over the sphere, here by
    /// the midpoint rule in the cosine.
    #[test]
    fn power_share_integrates_the_falloff() {
        for (inner, outer) in [
            (0.0f32, 30.0f32),
            (20.0, 30.0),
            (45.0, 45.0),
            (0.0, 90.0),
            (2.0, 2.0),
        ] {
            let cone = SpotCone::new(Vec3::Z, inner.to_radians(), outer.to_radians());
            let n = 2_000_000;
            let sum: f64 = (0..n)
                .map(|i| {
                    let c = -1.0 + 2.0 * (i as f64 + 0.5) / n as f64;
                    let s = (1.0 - c * c).sqrt();
                    f64::from(cone.falloff(Vec3::new(s as f32, 0.0, c as f32)))
                })
                .sum();
            // ∫ f dω / 4π = ∫ f dc / 2: the mean over c in [−1, 1].
            let share = sum / n as f64;
            let expected = f64::from(cone.power_share());
            assert!(
                (share - expected).abs() < 5e-4 * expected,
                "{inner}°..{outer}°: {share} against {expected}"
            );
        }
    }

    /// A disc of the radiance given receives the irradiance given, facing it.
    #[test]
    fn a_sun_disc_gives_its_irradiance() {
        let sun = DirectionalLight {
            direction: -Vec3::Z,
            irradiance: Vec3::splat(3.0),
            half_angle: 0.2,
        };
        let n = 100_000;
        // ∫ L cos θ dω over the cap, by the midpoint rule in cos θ.
        let cos_a = f64::from(sun.half_angle).cos();
        let sum: f64 = (0..n)
            .map(|i| cos_a + (1.0 - cos_a) * (i as f64 + 0.5) / n as f64)
            .sum();
        let e = f64::from(sun.radiance().x) * 2.0 * std::f64::consts::PI * sum / n as f64
            * (1.0 - cos_a);
        assert!((e - 3.0).abs() < 1e-4, "{e}");
        let omega = 2.0 * std::f64::consts::PI * (1.0 - cos_a);
        assert!((f64::from(sun.solid_angle()) - omega).abs() < 1e-6 * omega.max(1.0));
    }
}
