//! `KHR_lights_punctual` lights as ember's [`Light`]s, placed by their nodes. Units as
//! Blender's glTF importer reads them, at 683 lm/W: a point or spot light's intensity
//! in candela becomes `I/683` W/sr, a directional light's illuminance in lux `E/683`
//! W/m². Lights shine along their node's −Z. `range` is ignored: ember's lights fall
//! off as 1/d², as the extension's physically based limit does.

use glam::{Affine3A, Vec3};
use gltf::khr_lights_punctual::Kind;

use crate::scene::{
    intensity_from_candela, irradiance_from_lux, DirectionalLight, Light, PointLight, SpotCone,
    MAX_SPOT_ANGLE,
};

/// A light of the file, at its node's place.
pub fn light(
    light: &gltf::khr_lights_punctual::Light<'_>,
    world: &Affine3A,
) -> Result<Light, String> {
    let what = format!("light {}", light.index());
    let colour = Vec3::from(light.color());
    let intensity = light.intensity();
    if !colour.is_finite() || colour.min_element() < 0.0 {
        return Err(format!("{what}: its color must be finite and not negative"));
    }
    if !intensity.is_finite() || intensity < 0.0 {
        return Err(format!(
            "{what}: its intensity {intensity} must be finite and not negative"
        ));
    }
    let local = match light.kind() {
        Kind::Directional => Light::Directional(DirectionalLight {
            direction: -Vec3::Z,
            irradiance: colour * irradiance_from_lux(intensity),
            half_angle: 0.0,
        }),
        Kind::Point => Light::Point(PointLight {
            position: Vec3::ZERO,
            intensity: colour * intensity_from_candela(intensity),
            spot: None,
        }),
        Kind::Spot {
            inner_cone_angle,
            outer_cone_angle,
        } => {
            let (inner, outer) = (inner_cone_angle, outer_cone_angle);
            if !(0.0 <= inner && inner <= outer && outer <= MAX_SPOT_ANGLE) {
                return Err(format!(
                    "{what}: its cone angles (inner {inner}, outer {outer}) must satisfy \
                     0 <= inner <= outer <= pi/2"
                ));
            }
            Light::Point(PointLight {
                position: Vec3::ZERO,
                intensity: colour * intensity_from_candela(intensity),
                spot: Some(SpotCone::new(-Vec3::Z, inner, outer)),
            })
        }
    };
    Ok(local.transformed(world))
}

/// `point light 2 "Lamp"`: the kind, the index and the name, for `ember info`.
pub fn label(light: &gltf::khr_lights_punctual::Light<'_>) -> String {
    let kind = match light.kind() {
        Kind::Directional => "directional light",
        Kind::Point => "point light",
        Kind::Spot { .. } => "spot light",
    };
    let unit = match light.kind() {
        Kind::Directional => "lx",
        _ => "cd",
    };
    let name = light.name().map_or(String::new(), |n| format!(" {n:?}"));
    format!(
        "{kind} {}{name}, {} {unit}",
        light.index(),
        light.intensity()
    )
}
