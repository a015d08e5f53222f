//! A scene file's `[[light]]` tables: each places one light, of a `type`, with a
//! transform and one brightness in stated units (see [`super::lights`] and
//! [`super::area_lights`]). Strict as the rest of the file: a key the type does not
//! take, a missing or doubled brightness, a bad value, each is one error at its key.
//!
//! A light's local frame: it shines along −z (a spot's axis, a sun's direction of
//! travel, the side a quad or a disk lights, both sides with `two-sided = true`), from
//! the origin; `direction = [x, y, z]` turns −z there, as `rotate` or `matrix` would.

use std::f32::consts::PI;
use std::ops::Range;

use glam::{Affine3A, Quat, Vec3};
use serde::Deserialize;
use toml::Spanned;

use super::file::{Entry, Rotation, Scale};
use super::{
    intensity_from_candela, intensity_from_power, irradiance_from_lux, AreaEmission, AreaLight,
    AreaShape, DirectionalLight, Light, PointLight, SceneFile, SceneFileError, SpotCone,
    MAX_SPOT_ANGLE,
};
use crate::geometry::{MAX_RAY_COORDINATE, RAY_REACH};

/// A light a scene file places: one the integrator samples itself, or an area light
/// made of emissive triangles.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum PlacedLight {
    Light(Light),
    Area(AreaLight),
}

/// A `[[light]]` of a scene file.
#[derive(Clone, Debug)]
pub struct SceneLight {
    /// Its `name`, if it has one.
    pub name: Option<String>,
    pub light: PlacedLight,
}

/// One `[[light]]` table as written.
#[derive(Deserialize)]
#[serde(deny_unknown_fields, rename_all = "kebab-case")]
pub(super) struct LightEntry {
    #[serde(rename = "type")]
    kind: Option<Spanned<String>>,
    name: Option<Spanned<String>>,
    color: Option<Spanned<[f32; 3]>>,
    intensity: Option<Spanned<f32>>,
    power: Option<Spanned<f32>>,
    candela: Option<Spanned<f32>>,
    irradiance: Option<Spanned<f32>>,
    lux: Option<Spanned<f32>>,
    radiance: Option<Spanned<f32>>,
    inner_angle: Option<Spanned<f32>>,
    outer_angle: Option<Spanned<f32>>,
    angular_diameter: Option<Spanned<f32>>,
    size: Option<Spanned<[f32; 2]>>,
    radius: Option<Spanned<f32>>,
    two_sided: Option<Spanned<bool>>,
    direction: Option<Spanned<[f32; 3]>>,
    translate: Option<Spanned<[f32; 3]>>,
    rotate: Option<Spanned<Rotation>>,
    scale: Option<Spanned<Scale>>,
    matrix: Option<Spanned<[[f32; 4]; 4]>>,
}

/// The light types: each one's name, its own keys, its transform's keys, and the
/// brightness keys of which it needs exactly one (beside `type`, `name` and `color`).
const TYPES: [LightType; 6] = [
    ("point", &[], &["translate", "matrix"], POINT_UNITS),
    ("spot", &["inner-angle", "outer-angle"], AIMED, POINT_UNITS),
    (
        "directional",
        &["angular-diameter"],
        &["rotate", "direction", "matrix"],
        &["irradiance", "lux"],
    ),
    ("quad", &["size", "two-sided"], SURFACE, AREA_UNITS),
    ("disk", &["radius", "two-sided"], SURFACE, AREA_UNITS),
    (
        "sphere",
        &["radius"],
        &["translate", "rotate", "scale", "matrix"],
        AREA_UNITS,
    ),
];

/// A light type: see [`TYPES`].
type LightType = (
    &'static str,
    &'static [&'static str],
    &'static [&'static str],
    &'static [&'static str],
);

const POINT_UNITS: &[&str] = &["intensity", "power", "candela"];
const AREA_UNITS: &[&str] = &["radiance", "power"];
/// The transform of a light with a position and a direction (its −z).
const AIMED: &[&str] = &["translate", "rotate", "direction", "matrix"];
/// The transform of a flat area light, which may be scaled.
const SURFACE: &[&str] = &["translate", "rotate", "direction", "scale", "matrix"];

/// What each brightness key means, for the messages.
fn unit_of(key: &str) -> &'static str {
    match key {
        "intensity" => "W/sr",
        "candela" => "cd, at 683 lm/W",
        "irradiance" => "W/m²",
        "lux" => "lx, at 683 lm/W",
        "radiance" => "W/m²/sr",
        _ => "W",
    }
}

impl LightEntry {
    /// Every key given, with where its value is.
    fn given(&self) -> Vec<(&'static str, Range<usize>)> {
        let span = |s: Option<Range<usize>>, key: &'static str| s.map(|s| (key, s));
        [
            span(self.kind.as_ref().map(Spanned::span), "type"),
            span(self.name.as_ref().map(Spanned::span), "name"),
            span(self.color.as_ref().map(Spanned::span), "color"),
            span(self.intensity.as_ref().map(Spanned::span), "intensity"),
            span(self.power.as_ref().map(Spanned::span), "power"),
            span(self.candela.as_ref().map(Spanned::span), "candela"),
            span(self.irradiance.as_ref().map(Spanned::span), "irradiance"),
            span(self.lux.as_ref().map(Spanned::span), "lux"),
            span(self.radiance.as_ref().map(Spanned::span), "radiance"),
            span(self.inner_angle.as_ref().map(Spanned::span), "inner-angle"),
            span(self.outer_angle.as_ref().map(Spanned::span), "outer-angle"),
            span(
                self.angular_diameter.as_ref().map(Spanned::span),
                "angular-diameter",
            ),
            span(self.size.as_ref().map(Spanned::span), "size"),
            span(self.radius.as_ref().map(Spanned::span), "radius"),
            span(self.two_sided.as_ref().map(Spanned::span), "two-sided"),
            span(self.direction.as_ref().map(Spanned::span), "direction"),
            span(self.translate.as_ref().map(Spanned::span), "translate"),
            span(self.rotate.as_ref().map(Spanned::span), "rotate"),
            span(self.scale.as_ref().map(Spanned::span), "scale"),
            span(self.matrix.as_ref().map(Spanned::span), "matrix"),
        ]
        .into_iter()
        .flatten()
        .collect()
    }

    /// The value of brightness key `key`.
    fn brightness(&self, key: &str) -> Option<&Spanned<f32>> {
        match key {
            "intensity" => self.intensity.as_ref(),
            "power" => self.power.as_ref(),
            "candela" => self.candela.as_ref(),
            "irradiance" => self.irradiance.as_ref(),
            "lux" => self.lux.as_ref(),
            "radiance" => self.radiance.as_ref(),
            _ => None,
        }
    }
}

/// Reads a `[[light]]` table.
pub(super) fn read_light(
    file: &SceneFile,
    entry: Spanned<LightEntry>,
) -> Result<SceneLight, SceneFileError> {
    let table = entry.span();
    let entry = entry.into_inner();
    let fail = |span: Range<usize>, key: &str, message: &str| {
        file.error(span, &format!("light.{key}"), message)
    };
    let (kind, _, _, brightness_keys) = light_type(&entry, table.clone(), &fail)?;
    let brightness = one_brightness(&entry, kind, brightness_keys, table.clone(), &fail)?;
    let colour = match &entry.color {
        None => Vec3::ONE,
        Some(c) => {
            let v = Vec3::from(*c.get_ref());
            if !v.is_finite() || v.min_element() < 0.0 {
                return Err(fail(c.span(), "color", "must be three finite numbers ≥ 0"));
            }
            v
        }
    };
    let transform = light_transform(file, &entry)?;
    let light = match kind {
        "point" | "spot" => PlacedLight::Light(Light::Point(PointLight {
            position: transform.translation.into(),
            intensity: colour * point_intensity(brightness),
            spot: match kind {
                "spot" => Some(spot_cone(&entry, &transform, table.clone(), &fail)?),
                _ => None,
            },
        })),
        "directional" => PlacedLight::Light(Light::Directional(DirectionalLight {
            direction: shining(&transform),
            irradiance: colour
                * match brightness {
                    ("lux", v) => irradiance_from_lux(v),
                    (_, v) => v,
                },
            half_angle: half_angle(&entry, &fail)?,
        })),
        shape => PlacedLight::Area(AreaLight {
            shape: area_shape(&entry, shape, table.clone(), &fail)?,
            transform,
            colour,
            emission: match brightness {
                ("power", v) => AreaEmission::Power(v),
                (_, v) => AreaEmission::Radiance(v),
            },
            two_sided: entry.two_sided.as_ref().is_some_and(|t| *t.get_ref()),
        }),
    };
    check_power(&light, table.clone(), &fail)?;
    check_reach(&light, table, &fail)?;
    let name = entry.name.as_ref().map(|n| n.get_ref().clone());
    Ok(SceneLight { name, light })
}

/// The entry's type, and that it gives no key the type does not take.
fn light_type(
    entry: &LightEntry,
    table: Range<usize>,
    fail: &impl Fn(Range<usize>, &str, &str) -> SceneFileError,
) -> Result<LightType, SceneFileError> {
    let names: Vec<&str> = TYPES.iter().map(|t| t.0).collect();
    let Some(kind) = &entry.kind else {
        let message = format!("a [[light]] needs type = one of {}", names.join(", "));
        return Err(fail(table, "type", &message));
    };
    let Some(&light_type) = TYPES.iter().find(|t| t.0 == kind.get_ref()) else {
        let message = format!(
            "unknown light type {:?}: choose from {}",
            kind.get_ref(),
            names.join(", ")
        );
        return Err(fail(kind.span(), "type", &message));
    };
    let (name, own, transform, brightness) = light_type;
    let takes: Vec<&str> = [own, transform, brightness].concat();
    for (key, span) in entry.given() {
        if !["type", "name", "color"].contains(&key) && !takes.contains(&key) {
            let message = format!(
                "a {name} light takes no {key} (it takes: {}, name, color)",
                takes.join(", ")
            );
            return Err(fail(span, key, &message));
        }
    }
    Ok(light_type)
}

/// Refuses a light that rays cannot reach in `f32` and Embree (as a placement is
/// refused): its farthest coordinate times [`RAY_REACH`] must stay below
/// [`MAX_RAY_COORDINATE`]. A sun, at infinity, is reached by direction.
fn check_reach(
    light: &PlacedLight,
    table: Range<usize>,
    fail: &impl Fn(Range<usize>, &str, &str) -> SceneFileError,
) -> Result<(), SceneFileError> {
    let far = match light {
        PlacedLight::Light(Light::Point(p)) => p.position.abs().max_element(),
        PlacedLight::Light(Light::Directional(_)) => 0.0,
        PlacedLight::Area(a) => a
            .triangles()
            .iter()
            .flatten()
            .fold(0.0f32, |far, v| far.max(v.abs().max_element())),
    };
    if far.is_finite() && far * RAY_REACH < MAX_RAY_COORDINATE {
        return Ok(());
    }
    let message = format!(
        "it places the light {far:.3e} from the origin: rays from within {RAY_REACH} times \
         that would pass the {MAX_RAY_COORDINATE:.3e} that f32 rays in Embree can carry"
    );
    Err(fail(table, "translate", &message))
}

/// Refuses a light whose power is not a finite number (a brightness near `f32`'s
/// largest, an area light of no area in the world).
fn check_power(
    light: &PlacedLight,
    table: Range<usize>,
    fail: &impl Fn(Range<usize>, &str, &str) -> SceneFileError,
) -> Result<(), SceneFileError> {
    let (power, key) = match light {
        PlacedLight::Light(Light::Point(p)) => (p.power(), "power"),
        PlacedLight::Light(Light::Directional(d)) => (d.irradiance, "irradiance"),
        PlacedLight::Area(a) => {
            let area = a.area();
            if !(area > 0.0 && area.is_finite()) {
                let message = "the light's area in the world is not a positive number";
                return Err(fail(table, "scale", message));
            }
            (a.power(), "power")
        }
    };
    match power.is_finite() {
        true => Ok(()),
        false => Err(fail(table, key, "the light's power is not a finite number")),
    }
}

/// The one brightness key of `keys` the entry gives, and its value (finite, ≥ 0).
fn one_brightness(
    entry: &LightEntry,
    kind: &str,
    keys: &[&'static str],
    table: Range<usize>,
    fail: &impl Fn(Range<usize>, &str, &str) -> SceneFileError,
) -> Result<(&'static str, f32), SceneFileError> {
    let given: Vec<(&'static str, &Spanned<f32>)> = keys
        .iter()
        .filter_map(|&k| entry.brightness(k).map(|v| (k, v)))
        .collect();
    let choices: Vec<String> = keys
        .iter()
        .map(|k| format!("{k} ({})", unit_of(k)))
        .collect();
    match given.as_slice() {
        [] => {
            let message = format!("a {kind} light needs one of {}", choices.join(", "));
            Err(fail(table, keys[0], &message))
        }
        [(key, value)] => {
            let v = *value.get_ref();
            if !v.is_finite() || v < 0.0 {
                return Err(fail(value.span(), key, "must be a finite number ≥ 0"));
            }
            Ok((key, v))
        }
        [(first, _), (second, value), ..] => {
            let message = format!("give one of {first} and {second}, not both");
            Err(fail(value.span(), second, &message))
        }
    }
}

/// A point or spot light's intensity from its brightness key, W/sr.
fn point_intensity((key, value): (&str, f32)) -> f32 {
    match key {
        "power" => intensity_from_power(value),
        "candela" => intensity_from_candela(value),
        _ => value,
    }
}

/// The unit direction the light's −z takes in the world.
fn shining(transform: &Affine3A) -> Vec3 {
    transform.transform_vector3(-Vec3::Z).normalize()
}

/// The entry's transform, `direction` standing for the rotation that turns −z there.
fn light_transform(file: &SceneFile, entry: &LightEntry) -> Result<Affine3A, SceneFileError> {
    let rotate = match &entry.direction {
        None => entry.rotate.clone(),
        Some(d) => {
            let fail = |message: &str| file.error(d.span(), "light.direction", message);
            if let Some(other) = entry
                .rotate
                .as_ref()
                .map(|_| "rotate")
                .or(entry.matrix.as_ref().map(|_| "matrix"))
            {
                return Err(fail(&format!("give either direction or {other}, not both")));
            }
            let v = Vec3::from(*d.get_ref());
            let largest = v.abs().max_element();
            if !v.is_finite() || largest == 0.0 {
                return Err(fail("must be three finite numbers, not all 0"));
            }
            let (axis, angle) =
                Quat::from_rotation_arc(-Vec3::Z, (v / largest).normalize()).to_axis_angle();
            let rotation = Rotation {
                axis: axis.normalize_or(Vec3::X).to_array(),
                degrees: angle.to_degrees(),
            };
            Some(Spanned::new(d.span(), rotation))
        }
    };
    let transform = Entry {
        file: None,
        name: None,
        obj: None,
        translate: entry.translate.clone(),
        rotate,
        scale: entry.scale.clone(),
        matrix: entry.matrix.clone(),
        color: None,
    };
    file.transform(&transform, "light")
}

/// A spot's cone from `inner-angle` (default 0) and `outer-angle` (degrees, needed),
/// around the direction the transform turns −z to.
fn spot_cone(
    entry: &LightEntry,
    transform: &Affine3A,
    table: Range<usize>,
    fail: &impl Fn(Range<usize>, &str, &str) -> SceneFileError,
) -> Result<SpotCone, SceneFileError> {
    let Some(outer) = &entry.outer_angle else {
        let message = "a spot light needs outer-angle (degrees from its axis, at most 90)";
        return Err(fail(table, "outer-angle", message));
    };
    let max = MAX_SPOT_ANGLE.to_degrees();
    let outer_degrees = *outer.get_ref();
    if !(outer_degrees > 0.0 && outer_degrees <= max) {
        let message = format!("must be an angle in degrees above 0 and at most {max}");
        return Err(fail(outer.span(), "outer-angle", &message));
    }
    let inner_degrees = match &entry.inner_angle {
        None => 0.0,
        Some(inner) => {
            let v = *inner.get_ref();
            if !(v >= 0.0 && v <= outer_degrees) {
                let message = "must be an angle in degrees from 0 to outer-angle";
                return Err(fail(inner.span(), "inner-angle", message));
            }
            v
        }
    };
    Ok(SpotCone::new(
        shining(transform),
        inner_degrees.to_radians(),
        outer_degrees.to_radians(),
    ))
}

/// Half a sun's `angular-diameter` (degrees, below 180; absent or 0: a delta light),
/// in radians.
fn half_angle(
    entry: &LightEntry,
    fail: &impl Fn(Range<usize>, &str, &str) -> SceneFileError,
) -> Result<f32, SceneFileError> {
    let Some(diameter) = &entry.angular_diameter else {
        return Ok(0.0);
    };
    let d = *diameter.get_ref();
    if !(0.0..180.0).contains(&d) {
        let message = "must be an angle in degrees from 0 (a delta light) to below 180";
        return Err(fail(diameter.span(), "angular-diameter", message));
    }
    Ok(0.5 * d * PI / 180.0)
}

/// An area light's shape from `size` (a quad) or `radius` (a disk, a sphere).
fn area_shape(
    entry: &LightEntry,
    shape: &str,
    table: Range<usize>,
    fail: &impl Fn(Range<usize>, &str, &str) -> SceneFileError,
) -> Result<AreaShape, SceneFileError> {
    let positive = |v: f32| v.is_finite() && v > 0.0;
    if shape == "quad" {
        let Some(size) = &entry.size else {
            return Err(fail(
                table,
                "size",
                "a quad light needs size = [WIDTH, HEIGHT]",
            ));
        };
        let [width, height] = *size.get_ref();
        if !positive(width) || !positive(height) {
            return Err(fail(
                size.span(),
                "size",
                "must be two finite numbers above 0",
            ));
        }
        return Ok(AreaShape::Quad { width, height });
    }
    let Some(radius) = &entry.radius else {
        let message = format!("a {shape} light needs radius");
        return Err(fail(table, "radius", &message));
    };
    let r = *radius.get_ref();
    if !positive(r) {
        return Err(fail(
            radius.span(),
            "radius",
            "must be a finite number above 0",
        ));
    }
    Ok(match shape {
        "disk" => AreaShape::Disk { radius: r },
        _ => AreaShape::Sphere { radius: r },
    })
}

impl SceneLight {
    /// What the file calls the light: its name, or `light N` for the file's `index`-th
    /// (from 0).
    pub fn label(&self, index: usize) -> String {
        match &self.name {
            Some(name) => format!("light {name:?}"),
            None => format!("light {}", index + 1),
        }
    }

    /// One line saying what the light is, where, and how bright, in the units it
    /// renders with (W/sr, W/m², W/m²/sr) and its power in W where it has one.
    pub fn describe(&self) -> String {
        let what = match &self.light {
            PlacedLight::Light(Light::Point(p)) => {
                let power = luminous_sum(p.power());
                match &p.spot {
                    None => format!(
                        "point at {}: intensity {} W/sr (power {} W)",
                        vector(p.position),
                        colour(p.intensity),
                        number(power)
                    ),
                    Some(cone) => format!(
                        "spot at {} shining along {}, cone {}° to {}°: intensity {} W/sr on its axis (power {} W)",
                        vector(p.position),
                        vector(cone.axis),
                        number(cone.cos_inner.clamp(-1.0, 1.0).acos().to_degrees()),
                        number(cone.cos_outer.clamp(-1.0, 1.0).acos().to_degrees()),
                        colour(p.intensity),
                        number(power)
                    ),
                }
            }
            PlacedLight::Light(Light::Directional(d)) => {
                let disc = match d.half_angle {
                    0.0 => "a delta light".to_owned(),
                    a => format!("a disc {}° across", number(2.0 * a.to_degrees())),
                };
                format!(
                    "directional, shining along {}, {disc}: irradiance {} W/m²",
                    vector(d.direction),
                    colour(d.irradiance)
                )
            }
            PlacedLight::Area(a) => {
                let centre = a.transform.transform_point3(Vec3::ZERO);
                let shape = match a.shape {
                    AreaShape::Quad { width, height } => {
                        format!("quad {}×{}", number(width), number(height))
                    }
                    AreaShape::Disk { radius } => format!("disk of radius {}", number(radius)),
                    AreaShape::Sphere { radius } => format!("sphere of radius {}", number(radius)),
                };
                let facing = match (a.shape, a.two_sided) {
                    (AreaShape::Sphere { .. }, _) => String::new(),
                    (_, false) => format!(" lighting along {}", vector(shining(&a.transform))),
                    (_, true) => {
                        format!(" lighting both sides of {}", vector(shining(&a.transform)))
                    }
                };
                format!(
                    "{shape} at {}{facing}: radiance {} W/m²/sr (power {} W over {} m², {} triangles)",
                    vector(centre),
                    colour(a.radiance()),
                    number(luminous_sum(a.power())),
                    number(a.area()),
                    a.triangle_count()
                )
            }
        };
        what
    }
}

/// A per-channel power as one number: its luminance (the power of a grey light).
fn luminous_sum(power: Vec3) -> f32 {
    crate::color::luminance(power)
}

/// `x` with at most four decimals, trailing zeros dropped.
fn number(x: f32) -> String {
    let s = format!("{x:.4}");
    let s = s.trim_end_matches('0').trim_end_matches('.');
    match s {
        "-0" => "0".to_owned(),
        s => s.to_owned(),
    }
}

fn vector(v: Vec3) -> String {
    format!("({}, {}, {})", number(v.x), number(v.y), number(v.z))
}

/// One number for a grey colour, else the three channels.
fn colour(c: Vec3) -> String {
    if c.x == c.y && c.y == c.z {
        number(c.x)
    } else {
        vector(c)
    }
}
