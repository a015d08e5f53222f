//! Lights a scene places, against mathematics: a point light's inverse-square law (in
//! W/sr and in candela at 683 lm/W), a spot's cut-off and its `KHR_lights_punctual`
//! falloff, a sun's `E cos θ` (a delta light, and a disc of the same mean), area lights'
//! inverse-square irradiance from their power and their radiance seen directly, a
//! two-sided quad lighting two parallel planes by the rectangle's form factor and
//! splitting its power over both faces, the tessellation's error, every integrator agreeing on scenes of every kind of light,
//! a closed room lit by a point light that conserves energy, and guiding staying
//! unbiased (with a point light and a two-sided panel seen from behind); then scene files with every light type on both backends, their errors,
//! and `ember info`'s list.

mod common;

use std::f64::consts::PI;
use std::path::Path;
use std::sync::Arc;

use common::stats::SampleSums;
use common::{build, diffuse, ember_in, inward_cube, quad, with_embree, Built};
use ember::accel::Ray;
use ember::guiding::Guiding;
use ember::image::{compare, Image};
use ember::integrator::{IntegratorKind, PathTracer, RayCount};
use ember::light::{LightSampler, LightSamplerKind, LightTarget, Receiver};
use ember::render::{render, scene_hash, train_guide, RenderSettings};
use ember::sampling::{uniform_sphere, Rng};
use ember::scene::{
    area_light_scene, compose, intensity_from_candela, irradiance_from_lux, AreaEmission,
    AreaLight, AreaShape, Camera, CameraSettings, DirectionalLight, Environment, Light, Material,
    Placement, PointLight, Scene, SpotCone,
};
use glam::{Affine3A, DVec3, Quat, Vec3};

const ALL: [IntegratorKind; 4] = [
    IntegratorKind::Bsdf,
    IntegratorKind::Light,
    IntegratorKind::Mixture,
    IntegratorKind::Mis,
];

/// The albedo of the floors below.
const ALBEDO: f32 = 0.8;

/// A floor at y = 0 over x, z in [−50, 50], facing up, of material 0.
fn floor() -> [([Vec3; 3], u32); 2] {
    let s = 50.0;
    quad(
        Vec3::new(-s, 0.0, -s),
        Vec3::new(-s, 0.0, s),
        Vec3::new(s, 0.0, s),
        Vec3::new(s, 0.0, -s),
        0,
    )
}

/// The white floor of [`ALBEDO`] lit by `lights`.
fn lit_floor(lights: Vec<Light>) -> Built {
    let mut built = build(&floor(), vec![diffuse(Vec3::splat(ALBEDO), Vec3::ZERO)]);
    built.scene.lights = lights;
    built
}

/// The radiance leaving the floor at `(x, 0, z)` towards the sky, each of `n` samples.
fn floor_radiance(built: &Built, kind: IntegratorKind, x: f32, z: f32, n: u64) -> Vec<Vec3> {
    let tracer = PathTracer::new(&built.scene, &built.accel, 4, kind);
    let mut count = RayCount::default();
    (0..n)
        .map(|i| {
            let mut rng = Rng::for_sample(7, 0, i);
            let ray = Ray::new(Vec3::new(x, 3.0, z), -Vec3::Y);
            tracer.radiance(ray, &mut rng, &mut count)
        })
        .collect()
}

/// Lambert's radiance off the floor under irradiance `e`: `ρ/π · E`.
fn lambert(e: DVec3) -> DVec3 {
    f64::from(ALBEDO) / PI * e
}

fn assert_close(label: &str, got: Vec3, expected: DVec3, relative: f64, absolute: f64) {
    for c in 0..3 {
        let (g, e) = (f64::from(got[c]), expected[c]);
        assert!(
            (g - e).abs() <= relative * e.abs() + absolute,
            "{label}, channel {c}: {g} against {e}"
        );
    }
}

/// A point light of intensity `I` at height `h` over a white Lambertian floor gives the
/// floor at distance `r` from it the irradiance `I cos θ / r²` (`cos θ = h / r`), and
/// so the radiance `ρ/π · I cos θ / r²`, under it and at an angle. A delta light with
/// one light sample is exact: every sample of every integrator is that value.
#[test]
fn a_point_light_lights_a_floor_by_the_inverse_square_law() {
    let position = Vec3::new(0.2, 1.5, -0.1);
    let intensity = Vec3::new(2.0, 1.0, 0.5);
    let built = lit_floor(vec![Light::Point(PointLight {
        position,
        intensity,
        spot: None,
    })]);
    for (x, z) in [(0.2, -0.1), (0.9, 0.3), (-2.5, 1.0)] {
        let p = Vec3::new(x, 0.0, z).as_dvec3();
        let to_light = position.as_dvec3() - p;
        let r = to_light.length();
        let irradiance = intensity.as_dvec3() * (to_light.y / r) / (r * r);
        for kind in ALL {
            for got in floor_radiance(&built, kind, x, z, 16) {
                let label = format!("{kind:?} at ({x}, {z})");
                assert_close(&label, got, lambert(irradiance), 1e-5, 0.0);
            }
        }
    }
}

/// The same in candela: `683π` cd one metre over a floor of albedo 0.8 is `π` W/sr,
/// and the floor under it has the radiance 0.8 (Cycles, through Blender's glTF
/// importer, gave 0.792 for the same file). A sun of `E` lux is `E / 683` W/m².
#[test]
fn candela_and_lux_convert_at_683_lumens_per_watt() {
    assert_eq!(intensity_from_candela(683.0), 1.0);
    assert_eq!(irradiance_from_lux(683.0), 1.0);
    let intensity = intensity_from_candela((683.0 * PI) as f32);
    let built = lit_floor(vec![Light::Point(PointLight {
        position: Vec3::Y,
        intensity: Vec3::splat(intensity),
        spot: None,
    })]);
    for got in floor_radiance(&built, IntegratorKind::Mis, 0.0, 0.0, 4) {
        assert_close("683π cd at 1 m", got, DVec3::splat(0.8), 1e-5, 0.0);
    }
}

/// `KHR_lights_punctual`'s spot falloff, written out from the extension's text in
/// `f64`: `saturate(cd · scale + offset)²` with `cd` the cosine to the axis.
fn khr_falloff(cos_to_axis: f64, inner: f64, outer: f64) -> f64 {
    let scale = 1.0 / (inner.cos() - outer.cos()).max(0.001);
    let offset = -outer.cos() * scale;
    (cos_to_axis * scale + offset).clamp(0.0, 1.0).powi(2)
}

/// A spot light over the floor, its axis tilted: at points whose direction from the
/// light makes the angle θ with the axis, the floor's radiance is `ρ/π · I f(θ) cos θ_r
/// / r²`, `f` the extension's falloff (full within the inner cone, the squared ramp
/// between, none beyond the outer cone), for every integrator.
#[test]
fn a_spot_light_cuts_off_at_its_outer_cone_and_falls_off_smoothly() {
    let position = Vec3::new(0.0, 2.0, 0.0);
    let axis = Vec3::new(0.2, -1.0, 0.1).normalize();
    let (inner, outer) = (15f64.to_radians(), 25f64.to_radians());
    let intensity = Vec3::new(5.0, 4.0, 3.0);
    let built = lit_floor(vec![Light::Point(PointLight {
        position,
        intensity,
        spot: Some(SpotCone::new(axis, inner as f32, outer as f32)),
    })]);
    let a = axis.as_dvec3();
    let u = a.cross(DVec3::Z).normalize();
    let v = a.cross(u);
    for degrees in [
        0.0, 5.0, 14.5, 15.5, 18.0, 20.0, 22.5, 24.5, 25.5, 30.0, 45.0,
    ] {
        for phi in [0.3f64, 2.0, 4.1] {
            let theta = f64::to_radians(degrees);
            let w = theta.cos() * a + theta.sin() * (phi.cos() * u + phi.sin() * v);
            // Where the ray from the light along `w` meets the floor.
            let t = -f64::from(position.y) / w.y;
            let p = position.as_dvec3() + t * w;
            let falloff = khr_falloff(theta.cos(), inner, outer);
            let expected = lambert(intensity.as_dvec3() * falloff * (-w.y) / (t * t));
            for kind in ALL {
                for got in floor_radiance(&built, kind, p.x as f32, p.z as f32, 4) {
                    let label = format!("{kind:?} at {degrees}° from the axis");
                    if degrees > 25.0 {
                        assert_eq!(got, Vec3::ZERO, "{label}: outside the outer cone");
                    } else {
                        // The ramp's cosines in f32 near the outer cone, relatively.
                        assert_close(&label, got, expected, 2e-3, 1e-6);
                    }
                }
            }
        }
    }
}

/// A sun of irradiance `E` whose light falls at the angle θ to the floor's normal gives
/// it `E cos θ`: exactly, as a delta light; and with an angular diameter (20°, a disc
/// wholly above the horizon), the same in the mean, for every integrator (`bsdf`
/// finds the disc by chance, the others also by their light samples), and the disc
/// seen directly has the radiance `E / (π sin² α)`.
#[test]
fn a_sun_gives_e_cos_theta_as_a_delta_light_and_as_a_disc() {
    let direction = Vec3::new(0.4, -1.0, 0.3).normalize();
    let irradiance = Vec3::new(3.0, 2.0, 1.0);
    let expected = lambert(irradiance.as_dvec3() * f64::from(-direction.y));
    let sun = |half_angle| {
        lit_floor(vec![Light::Directional(DirectionalLight {
            direction,
            irradiance,
            half_angle,
        })])
    };
    let delta = sun(0.0);
    for kind in ALL {
        for got in floor_radiance(&delta, kind, 0.3, -0.2, 8) {
            assert_close(&format!("{kind:?}, a delta sun"), got, expected, 1e-5, 0.0);
        }
    }
    let half_angle = 10f32.to_radians();
    let disc = sun(half_angle);
    for kind in ALL {
        let mut sums = SampleSums::default();
        for got in floor_radiance(&disc, kind, 0.3, -0.2, 200_000) {
            sums.add(got);
        }
        sums.assert_mean(&format!("{kind:?}, a sun 20° across"), expected);
    }
    let radiance = irradiance.as_dvec3() / (PI * f64::from(half_angle).sin().powi(2));
    for kind in ALL {
        let tracer = PathTracer::new(&disc.scene, &disc.accel, 1, kind);
        let mut rng = Rng::seeded(3);
        let mut count = RayCount::default();
        let towards = -direction;
        let seen = tracer.radiance(Ray::new(Vec3::Y, towards), &mut rng, &mut count);
        assert_close(&format!("{kind:?}: the disc"), seen, radiance, 1e-4, 0.0);
        let beside = (towards + 0.3 * Vec3::X).normalize();
        let dark = tracer.radiance(Ray::new(Vec3::Y, beside), &mut rng, &mut count);
        assert_eq!(dark, Vec3::ZERO, "{kind:?}: beside the disc");
    }
}

/// Point lights are chosen with the emitters in proportion to power: by the alias
/// table, each light sample of a point light has the probability of its power's
/// share (a spot's power counting only its cone), and the emissive triangle its own.
/// With every sampler (the alias table, the solid-angle rule, the light BVH), light
/// samples at a receiver estimate the irradiance all the lights send it: the points'
/// and spots' `I f cos θ / d²`, the suns' `E cos θ`, and the emitter's (a small
/// triangle far away: `L A cos θ cos θ_e / d²` to 0.1%).
#[test]
fn light_samples_choose_points_by_power_and_estimate_their_irradiance() {
    let spot_cone = SpotCone::new(Vec3::new(0.3, -1.0, 0.0).normalize(), 0.2, 0.6);
    let points = [
        (Vec3::new(0.5, 2.0, 0.0), 1.0, None),
        (Vec3::new(-1.0, 1.0, 2.0), 3.0, None),
        (Vec3::new(0.0, 3.0, -1.0), 20.0, Some(spot_cone)),
    ];
    let mut lights: Vec<Light> = points
        .iter()
        .map(|&(position, i, spot)| {
            Light::Point(PointLight {
                position,
                intensity: Vec3::splat(i),
                spot,
            })
        })
        .collect();
    let sun = DirectionalLight {
        direction: Vec3::new(0.2, -1.0, 0.4).normalize(),
        irradiance: Vec3::splat(0.7),
        half_angle: 0.0,
    };
    lights.push(Light::Directional(sun));
    // An emissive triangle of area 0.02 and radiance 50, far above, facing down.
    let lamp = [
        Vec3::new(0.0, 6.0, 0.0),
        Vec3::new(0.2, 6.0, 0.0),
        Vec3::new(0.0, 6.0, 0.2),
    ];
    let mut triangles = floor().to_vec();
    triangles.push((lamp, 1));
    let mut built = build(
        &triangles,
        vec![
            diffuse(Vec3::splat(ALBEDO), Vec3::ZERO),
            diffuse(Vec3::ZERO, Vec3::splat(50.0)),
        ],
    );
    built.scene.lights = lights;
    let receiver = Receiver {
        p: Vec3::new(0.1, 0.0, 0.2),
        n: Vec3::Y,
    };
    let mut expected = 0.0f64;
    let mut weights = Vec::new();
    for (position, i, spot) in points {
        let light = PointLight {
            position,
            intensity: Vec3::splat(i),
            spot,
        };
        let to = (position - receiver.p).as_dvec3();
        let d = to.length();
        let falloff = spot.map_or(1.0, |c| f64::from(c.falloff(-(to / d).as_vec3())));
        expected += f64::from(i) * falloff * (to.y / d) / (d * d);
        weights.push(f64::from(light.power().x) / PI);
    }
    expected += 0.7 * f64::from(-sun.direction.y);
    let lamp_centre = (lamp[0] + lamp[1] + lamp[2]).as_dvec3() / 3.0;
    let to = lamp_centre - receiver.p.as_dvec3();
    let d = to.length();
    expected += 50.0 * 0.02 * (to.y / d) * (to.y / d) / (d * d);
    weights.push(0.02 * 50.0);
    for kind in LightSamplerKind::ALL {
        let lights = LightSampler::for_scene(&built.scene, kind);
        let mut rng = Rng::seeded(31);
        let mut sums = SampleSums::default();
        // The probability with which each point light was chosen.
        let mut chosen = [None; 3];
        for _ in 0..2_000_000 {
            let Some(s) = lights.sample(receiver, &mut rng) else {
                sums.add(Vec3::ZERO);
                continue;
            };
            sums.add(s.emission * s.dir.dot(receiver.n).max(0.0) / s.pdf);
            if let LightTarget::Delta(k @ 0..=2) = s.target {
                assert!(s.is_delta());
                chosen[k as usize] = Some(f64::from(s.pdf));
            }
        }
        if kind == LightSamplerKind::Alias {
            let chosen = chosen.map(|p| p.expect("every point light chosen"));
            for k in 1..3 {
                let (ratio, expected) = (chosen[k] / chosen[0], weights[k] / weights[0]);
                assert!(
                    (ratio / expected - 1.0).abs() < 1e-5,
                    "point {k} chosen {ratio} times as often as point 0, not {expected}"
                );
            }
        }
        sums.assert_mean(&format!("{kind:?}: irradiance"), DVec3::splat(expected));
    }
}

/// `lights` as emissive triangles beside the floor, in one scene.
fn floor_with(lights: &[AreaLight]) -> Built {
    let floor = build(&floor(), vec![diffuse(Vec3::splat(ALBEDO), Vec3::ZERO)]);
    let names: Vec<String> = (0..lights.len()).map(|i| format!("light {i}")).collect();
    let lights = area_light_scene(lights, &names);
    let placements = [&floor.scene, &lights].map(|scene| Placement {
        scene,
        transform: Affine3A::IDENTITY,
    });
    with_embree(compose(&placements))
}

/// The area light `shape` of power `power` (grey), its centre at `centre`, facing
/// (lighting the side of) `facing`.
fn area_light(shape: AreaShape, emission: AreaEmission, centre: Vec3, facing: Vec3) -> AreaLight {
    AreaLight {
        shape,
        transform: Affine3A::from_rotation_translation(
            Quat::from_rotation_arc(-Vec3::Z, facing),
            centre,
        ),
        colour: Vec3::ONE,
        emission,
        two_sided: false,
    }
}

const SHAPES: [(&str, AreaShape); 3] = [
    (
        "quad",
        AreaShape::Quad {
            width: 0.5,
            height: 0.3,
        },
    ),
    ("disk", AreaShape::Disk { radius: 0.3 }),
    ("sphere", AreaShape::Sphere { radius: 0.3 }),
];

/// An area light of power `P` seen from afar (distance `D` = 8, 27 times its size) is
/// a point of the intensity its power gives: a one-sided quad or disk facing the
/// receiver gives the irradiance `P / (π D²)` (its intensity `L A` along its normal,
/// `P = π A L`), a sphere `P / (4π D²)`, within the far-field error (`~(s/D)²`, below
/// 0.2%) and the tessellation's.
#[test]
fn area_lights_of_a_power_give_its_inverse_square_irradiance_from_afar() {
    let power = 40.0f32;
    let distance = 8.0f32;
    for (name, shape) in SHAPES {
        let centre = Vec3::new(0.1, distance, -0.2);
        let light = area_light(shape, AreaEmission::Power(power), centre, -Vec3::Y);
        let emitted = light.power();
        assert!(
            (emitted.x / power - 1.0).abs() < 1e-5,
            "{name}: π A L = {emitted}, not {power}"
        );
        let built = floor_with(&[light]);
        let share = match shape {
            AreaShape::Sphere { .. } => 4.0,
            _ => 1.0,
        };
        let irradiance = f64::from(power) / (share * PI * f64::from(distance).powi(2));
        let mut sums = SampleSums::default();
        for got in floor_radiance(&built, IntegratorKind::Mis, 0.1, -0.2, 20_000) {
            sums.add(got);
        }
        let (mean, sigma) = sums.mean_and_error();
        let expected = lambert(DVec3::splat(irradiance));
        eprintln!("{name}: {mean} ± {sigma}, expected {expected}");
        assert!(
            (mean.x - expected.x).abs() < 4.0 * sigma.x + 5e-3 * expected.x,
            "{name}: {mean} ± {sigma}, expected {expected}"
        );
    }
}

/// Seen directly, an area light has the radiance it was given, exactly (its
/// triangles carry it as their `Ke`), from its lit side, and nothing from behind a
/// quad or disk.
#[test]
fn an_area_light_seen_directly_has_its_stated_radiance() {
    let radiance = AreaEmission::Radiance(7.0);
    for (name, shape) in SHAPES {
        let centre = Vec3::new(0.0, 2.0, 0.0);
        let light = AreaLight {
            colour: Vec3::new(1.0, 0.5, 0.25),
            ..area_light(shape, radiance, centre, -Vec3::Y)
        };
        let built = floor_with(&[light]);
        for kind in ALL {
            let tracer = PathTracer::new(&built.scene, &built.accel, 1, kind);
            let mut rng = Rng::seeded(1);
            let mut count = RayCount::default();
            let up = Ray::new(Vec3::new(0.02, 0.5, 0.01), Vec3::Y);
            let seen = tracer.radiance(up, &mut rng, &mut count);
            assert_eq!(seen, Vec3::new(7.0, 3.5, 1.75), "{name}, {kind:?}");
            let down = Ray::new(Vec3::new(0.02, 3.5, 0.01), -Vec3::Y);
            let back = tracer.radiance(down, &mut rng, &mut count);
            let expected = match shape {
                AreaShape::Sphere { .. } => Vec3::new(7.0, 3.5, 1.75),
                _ => Vec3::ZERO,
            };
            assert_eq!(back, expected, "{name} from above, {kind:?}");
        }
    }
}

/// The irradiance at distance `h` under a corner of an `a × b` rectangle of radiance
/// `L` parallel to the receiver: `π L` times the form factor from a differential area to
/// a parallel rectangle (Howell's catalogue, B-3),
/// `L/2 [X/√(1+X²) atan(Y/√(1+X²)) + Y/√(1+Y²) atan(X/√(1+Y²))]`, `X = a/h`, `Y = b/h`.
fn corner_irradiance(a: f64, b: f64, h: f64, radiance: f64) -> f64 {
    let (x, y) = (a / h, b / h);
    let (sx, sy) = ((1.0 + x * x).sqrt(), (1.0 + y * y).sqrt());
    0.5 * radiance * (x / sx * (y / sx).atan() + y / sy * (x / sy).atan())
}

/// A floor at y = 0 facing up and a ceiling at y = 2h facing down (albedo
/// [`ALBEDO`]), with a `width × depth` quad light of radiance `radiance` half-way,
/// lighting the floor from its front (and the ceiling from its back when `two_sided`).
fn between_planes(width: f32, depth: f32, h: f32, radiance: f32, two_sided: bool) -> Built {
    let s = 50.0;
    let y = 2.0 * h;
    let mut planes = floor().to_vec();
    planes.extend(quad(
        Vec3::new(-s, y, -s),
        Vec3::new(s, y, -s),
        Vec3::new(s, y, s),
        Vec3::new(-s, y, s),
        0,
    ));
    let room = build(&planes, vec![diffuse(Vec3::splat(ALBEDO), Vec3::ZERO)]);
    let light = AreaLight {
        two_sided,
        ..area_light(
            AreaShape::Quad {
                width,
                height: depth,
            },
            AreaEmission::Radiance(radiance),
            Vec3::new(0.0, h, 0.0),
            -Vec3::Y,
        )
    };
    let lights = area_light_scene(&[light], &["panel".to_owned()]);
    let placements = [&room.scene, &lights].map(|scene| Placement {
        scene,
        transform: Affine3A::IDENTITY,
    });
    with_embree(compose(&placements))
}

/// A two-sided quad light of radiance `L` half-way between two parallel planes gives
/// each, at points under it, the irradiance of the rectangle's form factor (the sum
/// over the four rectangles the point's foot cuts it into), the ceiling from the
/// light's back as the floor from its front: direct light only (depth 2), every
/// integrator and light sampler. One-sided, the ceiling gets nothing.
#[test]
fn a_two_sided_quad_lights_both_parallel_planes_by_the_form_factor() {
    let (width, depth, h, radiance) = (1.2f32, 0.8f32, 0.5f32, 3.0f32);
    let two_sided = between_planes(width, depth, h, radiance, true);
    let one_sided = between_planes(width, depth, h, radiance, false);
    let runs = ALL
        .iter()
        .map(|&kind| (kind, LightSamplerKind::default()))
        .chain([
            (IntegratorKind::Mis, LightSamplerKind::SolidAngle),
            (IntegratorKind::Mis, LightSamplerKind::Bvh),
        ]);
    for (kind, sampler) in runs {
        for (x, z) in [(0.0f32, 0.0f32), (0.35, -0.2)] {
            let (a, b) = (f64::from(width) / 2.0, f64::from(depth) / 2.0);
            let (x64, z64) = (f64::from(x), f64::from(z));
            let irradiance: f64 = [(a - x64, b - z64), (a + x64, b - z64)]
                .into_iter()
                .flat_map(|(w, d)| [(w, d), (w, 2.0 * b - d)])
                .map(|(w, d)| corner_irradiance(w, d, f64::from(h), f64::from(radiance)))
                .sum();
            let expected = lambert(DVec3::splat(irradiance));
            for (name, y, dir) in [("floor", 0.5 * h, -Vec3::Y), ("ceiling", 1.5 * h, Vec3::Y)] {
                let label = format!("{kind:?}, {sampler:?}, {name} at ({x}, {z})");
                let ray = Ray::new(Vec3::new(x, y, z), dir);
                let tracer = |built: &Built| {
                    let tracer = PathTracer::with_light_sampler(
                        &built.scene,
                        &built.accel,
                        2,
                        kind,
                        sampler,
                    );
                    let mut count = RayCount::default();
                    let mut sums = SampleSums::default();
                    for i in 0..20_000 {
                        let mut rng = Rng::for_sample(11, 0, i);
                        sums.add(tracer.radiance(ray, &mut rng, &mut count));
                    }
                    sums
                };
                tracer(&two_sided).assert_mean(&label, expected);
                let dark = tracer(&one_sided).mean_and_error().0;
                match name {
                    "ceiling" => assert_eq!(dark, DVec3::ZERO, "{label}, one-sided"),
                    _ => assert!(dark.x > 0.0, "{label}, one-sided"),
                }
            }
        }
    }
}

/// A two-sided area light of power `P` splits it over both faces (`P = 2π A L`): from
/// afar each side gets half the irradiance a one-sided light of that power gives its
/// lit side, `P / (2π D²)`.
#[test]
fn a_two_sided_area_light_splits_its_power_over_both_faces() {
    let (power, distance) = (40.0f32, 8.0f32);
    for (name, shape) in &SHAPES[..2] {
        for facing in [-Vec3::Y, Vec3::Y] {
            let centre = Vec3::new(0.1, distance, -0.2);
            let light = AreaLight {
                two_sided: true,
                ..area_light(*shape, AreaEmission::Power(power), centre, facing)
            };
            let emitted = light.power().x;
            assert!((emitted / power - 1.0).abs() < 1e-5, "{name}: {emitted}");
            let expected_radiance = power / (2.0 * std::f32::consts::PI * light.area());
            assert!((light.radiance().x / expected_radiance - 1.0).abs() < 1e-5);
            let built = floor_with(&[light]);
            let irradiance = f64::from(power) / (2.0 * PI * f64::from(distance).powi(2));
            let mut sums = SampleSums::default();
            for got in floor_radiance(&built, IntegratorKind::Mis, 0.1, -0.2, 20_000) {
                sums.add(got);
            }
            let (mean, sigma) = sums.mean_and_error();
            let expected = lambert(DVec3::splat(irradiance));
            assert!(
                (mean.x - expected.x).abs() < 4.0 * sigma.x + 5e-3 * expected.x,
                "{name} facing {facing}: {mean} ± {sigma}, expected {expected}"
            );
        }
    }
}

/// The tessellation's error is bounded: a disk's fan and a sphere's icosahedron fall
/// short of `πr²` and `4πr²` by at most 0.05% and 0.5%; a sphere's outline (its
/// projected area, which sets its irradiance from afar) is within 0.5% of a quarter of
/// its area from every direction tried, so that a sphere of power `P` gives
/// `P / (4π D²)` that closely; and a quad is exact.
#[test]
fn tessellation_error_is_bounded() {
    let r = 0.7f32;
    let light = |shape| area_light(shape, AreaEmission::Radiance(1.0), Vec3::ONE, Vec3::X);
    let quad = light(AreaShape::Quad {
        width: 2.0,
        height: 0.5,
    });
    assert!((quad.area() - 1.0).abs() < 1e-6);
    let disk = light(AreaShape::Disk { radius: r }).area() / (std::f32::consts::PI * r * r);
    assert!((0.9995..=1.0).contains(&disk), "disk: {disk} of πr²");
    let sphere = light(AreaShape::Sphere { radius: r });
    let area = sphere.area();
    let ratio = area / (4.0 * std::f32::consts::PI * r * r);
    assert!((0.995..=1.0).contains(&ratio), "sphere: {ratio} of 4πr²");
    let triangles = sphere.triangles();
    let mut rng = Rng::seeded(9);
    for _ in 0..200 {
        let u = uniform_sphere(rng.f32(), rng.f32()).as_dvec3();
        let projected: f64 = triangles
            .iter()
            .map(|[a, b, c]| 0.5 * (*b - *a).cross(*c - *a).as_dvec3().dot(u).abs())
            .sum::<f64>()
            / 2.0;
        let quarter = f64::from(area) / 4.0;
        assert!(
            (projected / quarter - 1.0).abs() < 5e-3,
            "outline along {u}: {projected} against A/4 = {quarter}"
        );
    }
}

/// The radiance along `n` rays from `origin` in uniform directions, each ray's
/// direction the same whatever the integrator.
fn radiance_from(scene: &Built, kind: IntegratorKind, origin: Vec3, n: u64) -> Vec<Vec3> {
    let tracer = PathTracer::new(&scene.scene, &scene.accel, 5, kind);
    let mut count = RayCount::default();
    (0..n)
        .map(|i| {
            let mut rng = Rng::for_sample(21, 1, i);
            let dir = uniform_sphere(rng.f32(), rng.f32());
            tracer.radiance(Ray::new(origin, dir), &mut rng, &mut count)
        })
        .collect()
}

/// A corner of floor and wall, lit by `area` lights and the placed `lights` (and a
/// sky when given): every integrator estimates the same radiance along random rays
/// from a point above the floor, `mis` and `light` among them, `mixture` and `bsdf`
/// taking the delta lights by their own light samples: the mean of each pair's
/// difference along the same rays is 0 within four standard errors.
fn integrators_agree(label: &str, area: &[AreaLight], lights: Vec<Light>, sky: Option<Vec3>) {
    let wall = quad(
        Vec3::new(-1.0, 0.0, -3.0),
        Vec3::new(-1.0, 3.0, -3.0),
        Vec3::new(-1.0, 3.0, 3.0),
        Vec3::new(-1.0, 0.0, 3.0),
        1,
    );
    let mut triangles = floor().to_vec();
    triangles.extend(wall);
    let room = build(
        &triangles,
        vec![
            diffuse(Vec3::splat(0.6), Vec3::ZERO),
            diffuse(Vec3::new(0.7, 0.4, 0.2), Vec3::ZERO),
        ],
    );
    let names: Vec<String> = (0..area.len()).map(|i| format!("area {i}")).collect();
    let emitters = area_light_scene(area, &names);
    let placements = [&room.scene, &emitters].map(|scene| Placement {
        scene,
        transform: Affine3A::IDENTITY,
    });
    let mut scene: Scene = compose(&placements);
    scene.lights = lights;
    scene.sky = sky.map(|s| Arc::new(Environment::constant(s)));
    let built = with_embree(scene);
    let origin = Vec3::new(0.4, 0.7, 0.3);
    let estimates: Vec<Vec<Vec3>> = ALL
        .into_iter()
        .map(|kind| radiance_from(&built, kind, origin, 400_000))
        .collect();
    // Paired along the same directions: what varies with the direction cancels.
    for (i, a) in ALL.iter().enumerate() {
        let mut sums = SampleSums::default();
        estimates[i].iter().for_each(|&l| sums.add(l));
        let (mean, sigma) = sums.mean_and_error();
        eprintln!("{label}, {a:?}: {mean} ± {sigma}");
        assert!(mean.x > 0.0, "{label}: lit");
        for (j, b) in ALL.iter().enumerate().skip(i + 1) {
            let mut difference = SampleSums::default();
            for (x, y) in estimates[i].iter().zip(&estimates[j]) {
                difference.add(*x - *y);
            }
            difference.assert_mean(&format!("{label}: {a:?} − {b:?}"), DVec3::ZERO);
        }
    }
}

#[test]
fn every_integrator_agrees_with_a_point_light_and_an_area_light() {
    let panel = area_light(
        AreaShape::Quad {
            width: 0.6,
            height: 0.4,
        },
        AreaEmission::Power(12.0),
        Vec3::new(0.5, 1.8, -0.6),
        Vec3::new(-0.3, -1.0, 0.2).normalize(),
    );
    let point = Light::Point(PointLight {
        position: Vec3::new(0.0, 1.2, 0.8),
        intensity: Vec3::new(1.5, 1.0, 0.8),
        spot: None,
    });
    integrators_agree("point and quad", &[panel], vec![point], None);
}

/// Lit only by a two-sided panel that faces away (up, to an empty sky), the room and
/// the point the rays leave from see its back: every integrator agrees there too.
#[test]
fn every_integrator_agrees_with_a_two_sided_light_seen_from_behind() {
    let panel = AreaLight {
        two_sided: true,
        ..area_light(
            AreaShape::Quad {
                width: 0.6,
                height: 0.4,
            },
            AreaEmission::Power(12.0),
            Vec3::new(0.5, 1.8, -0.6),
            Vec3::new(0.3, 1.0, -0.2).normalize(),
        )
    };
    integrators_agree("two-sided panel from behind", &[panel], vec![], None);
}

#[test]
fn every_integrator_agrees_with_spots_suns_disks_spheres_and_a_sky() {
    let disk = area_light(
        AreaShape::Disk { radius: 0.2 },
        AreaEmission::Radiance(6.0),
        Vec3::new(-0.5, 1.5, 0.2),
        -Vec3::Y,
    );
    let ball = area_light(
        AreaShape::Sphere { radius: 0.1 },
        AreaEmission::Power(3.0),
        Vec3::new(1.0, 0.4, -0.5),
        Vec3::Y,
    );
    let spot = Light::Point(PointLight {
        position: Vec3::new(0.8, 2.0, 0.6),
        intensity: Vec3::splat(4.0),
        spot: Some(SpotCone::new(
            Vec3::new(-0.3, -1.0, -0.2).normalize(),
            0.3,
            0.5,
        )),
    });
    let sun = |half_angle, irradiance| {
        Light::Directional(DirectionalLight {
            direction: Vec3::new(0.5, -1.0, 0.2).normalize(),
            irradiance: Vec3::splat(irradiance),
            half_angle,
        })
    };
    let lights = vec![spot, sun(0.0, 0.5), sun(0.3, 0.8)];
    integrators_agree(
        "spot, suns, disk, sphere, sky",
        &[disk, ball],
        lights,
        Some(Vec3::new(0.1, 0.15, 0.3)),
    );
}

/// A point light of power `P` inside a closed room whose walls all have albedo ρ: all
/// of `P` is absorbed in the end, so the walls receive `P / (1 − ρ)` and send out
/// `ρ P / (1 − ρ)`, and their radiance, averaged over their area, is
/// `ρ P / (π (1 − ρ) A)`. Rays from the light to uniform points of the walls see that
/// average, whatever the integrator.
#[test]
fn a_point_light_in_a_closed_room_conserves_energy() {
    let albedo = 0.5f32;
    let mut built = build(
        &inward_cube(2, 0),
        vec![diffuse(Vec3::splat(albedo), Vec3::ZERO)],
    );
    let intensity = Vec3::new(1.0, 2.0, 3.0);
    let centre = Vec3::new(0.2, -0.1, 0.3);
    built.scene.lights = vec![Light::Point(PointLight {
        position: centre,
        intensity,
        spot: None,
    })];
    let power = 4.0 * PI * intensity.as_dvec3();
    let area = 24.0;
    let a = f64::from(albedo);
    let expected = a * power / (PI * (1.0 - a) * area);
    for kind in ALL {
        let tracer = PathTracer::new(&built.scene, &built.accel, 60, kind);
        let mut sums = SampleSums::default();
        let mut count = RayCount::default();
        for i in 0..60_000u64 {
            let mut rng = Rng::for_sample(5, 2, i);
            // A uniform point of the cube's surface: a face, then a point on it.
            let face = rng.below(6) as usize;
            let axis = face / 2;
            let mut q = [0.0f32; 3];
            q[axis] = if face.is_multiple_of(2) { 1.0 } else { -1.0 };
            q[(axis + 1) % 3] = 2.0 * rng.f32() - 1.0;
            q[(axis + 2) % 3] = 2.0 * rng.f32() - 1.0;
            let dir = (Vec3::from(q) - centre).normalize();
            sums.add(tracer.radiance(Ray::new(centre, dir), &mut rng, &mut count));
        }
        sums.assert_mean(&format!("{kind:?}: the room's mean radiance"), expected);
    }
}

/// The walls of the box `[-1, 1]³` facing inwards, of material 0, with a hole in the
/// ceiling over x, z ∈ [0, 0.25).
fn box_with_a_hole() -> Vec<([Vec3; 3], u32)> {
    let hole = |t: &[Vec3; 3]| {
        let c = (t[0] + t[1] + t[2]) / 3.0;
        c.y > 0.999 && (0.0..0.25).contains(&c.x) && (0.0..0.25).contains(&c.z)
    };
    inward_cube(8, 0)
        .into_iter()
        .filter(|(t, _)| !hole(t))
        .collect()
}

/// A box lit only through a hole in its ceiling by a point light above the hole: the
/// guide learns the way in (where light samples from inside are blocked), and the
/// guided image converges to the unguided one (relMSE against an unguided reference
/// falls like 1/spp), with the same mean.
#[test]
fn guiding_with_a_point_light_renders_the_unguided_image() {
    let mut built = build(
        &box_with_a_hole(),
        vec![diffuse(Vec3::splat(0.5), Vec3::ZERO)],
    );
    built.scene.lights = vec![Light::Point(PointLight {
        position: Vec3::new(0.125, 1.4, 0.125),
        intensity: Vec3::splat(3.0),
        spot: None,
    })];
    guiding_renders_the_unguided_image("a point light", &built);
}

/// The same box lit through the hole by a two-sided panel above it that faces up, away
/// from it: the light the guide learns comes from the panel's back.
#[test]
fn guiding_with_a_two_sided_light_seen_from_behind_renders_the_unguided_image() {
    let y = 1.4;
    let mut triangles = box_with_a_hole();
    // Counter-clockwise seen from above: its front faces up, away from the box.
    triangles.extend(quad(
        Vec3::new(0.0, y, 0.0),
        Vec3::new(0.0, y, 0.25),
        Vec3::new(0.25, y, 0.25),
        Vec3::new(0.25, y, 0.0),
        1,
    ));
    let panel = Material {
        two_sided_emission: true,
        ..diffuse(Vec3::ZERO, Vec3::splat(48.0))
    };
    let built = build(
        &triangles,
        vec![diffuse(Vec3::splat(0.5), Vec3::ZERO), panel],
    );
    guiding_renders_the_unguided_image("a two-sided panel", &built);
}

/// Renders of the box of `built` from inside, guided at 64 and 256 spp, against an
/// unguided one of 8192: see the tests above.
fn guiding_renders_the_unguided_image(label: &str, built: &Built) {
    let size = 24;
    let camera: Camera = CameraSettings {
        eye: Vec3::new(0.0, 0.2, 0.9),
        look_at: Vec3::new(0.0, -0.4, -1.0),
        up: Vec3::Y,
        projection: ember::scene::Projection::perspective(70.0),
        lens: Default::default(),
    }
    .camera(size, size);
    let settings = |spp: u32, guiding| RenderSettings {
        width: size,
        height: size,
        spp,
        max_depth: 6,
        seed: u64::from(spp),
        integrator: IntegratorKind::Mis,
        light_sampler: Default::default(),
        adaptive: None,
        guiding,
        engine: Default::default(),
    };
    let guiding = Guiding { iterations: 5 };
    let guided = Some(guiding);
    let tracer = PathTracer::new(&built.scene, &built.accel, 6, IntegratorKind::Mis);
    let tree = train_guide(
        &tracer,
        &camera,
        &settings(64, guided),
        guiding,
        &std::sync::atomic::AtomicUsize::new(0),
    )
    .expect("not stopped")
    .0;
    assert!(tree.leaf_count() > 1, "the guide learnt regions");
    let image = |spp, guiding| {
        render(
            &built.scene,
            &built.accel,
            &camera,
            &settings(spp, guiding),
            &|_| {},
        )
        .0
    };
    let reference = image(8192, None);
    let mean = |image: &Image| {
        image
            .pixels
            .iter()
            .map(|p| f64::from(p.element_sum()))
            .sum::<f64>()
            / image.pixels.len() as f64
    };
    let error = |spp| {
        let image = image(spp, guided);
        (
            compare(&image, &reference).expect("same size").rel_mse,
            mean(&image),
        )
    };
    let ((low, _), (high, high_mean)) = (error(64), error(256));
    let reference_mean = mean(&reference);
    eprintln!(
        "guided with {label}: relMSE {low:.3e} at 64 spp, {high:.3e} at 256; mean {high_mean} against {reference_mean}"
    );
    assert!(reference_mean > 0.0);
    assert!(
        high < low / 2.5,
        "{label}: relMSE {low:.3e} at 64 spp, {high:.3e} at 256"
    );
    assert!(
        (high_mean / reference_mean - 1.0).abs() < 0.02,
        "{label}: mean {high_mean} against {reference_mean}"
    );
}

/// A scene placed by instances places its lights with it: each placement moves a point
/// light's position and turns a spot's axis and a sun's direction, and leaves their
/// brightness as it is.
#[test]
fn instances_place_a_scenes_lights_with_it() {
    let spot = SpotCone::new(-Vec3::Y, 0.1, 0.3);
    let lamp = lit_floor(vec![
        Light::Point(PointLight {
            position: Vec3::new(1.0, 2.0, 0.0),
            intensity: Vec3::splat(3.0),
            spot: Some(spot),
        }),
        Light::Directional(DirectionalLight {
            direction: -Vec3::Y,
            irradiance: Vec3::ONE,
            half_angle: 0.0,
        }),
    ])
    .scene;
    let turn = Affine3A::from_rotation_translation(
        Quat::from_rotation_z(std::f32::consts::FRAC_PI_2),
        Vec3::new(0.0, 0.0, 5.0),
    );
    let instances = [Affine3A::IDENTITY, turn]
        .map(|transform| ember::geometry::Instance { mesh: 0, transform });
    let placed = ember::scene::place(&[&lamp], instances.to_vec()).unwrap();
    assert_eq!(placed.lights.len(), 4);
    assert_eq!(placed.lights[..2], lamp.lights[..]);
    let Light::Point(moved) = placed.lights[2] else {
        panic!("a point light: {:?}", placed.lights[2]);
    };
    assert!((moved.position - Vec3::new(-2.0, 1.0, 5.0)).length() < 1e-5);
    assert_eq!(moved.intensity, Vec3::splat(3.0));
    let axis = moved.spot.expect("a spot").axis;
    assert!((axis - Vec3::X).length() < 1e-6, "{axis}");
    let Light::Directional(sun) = placed.lights[3] else {
        panic!("a sun: {:?}", placed.lights[3]);
    };
    assert!((sun.direction - Vec3::X).length() < 1e-6);
}

/// A scene's fingerprint (which checkpoints and shards carry) changes with its placed
/// lights, and a scene without any keeps the fingerprint it had before lights existed.
#[test]
fn the_scene_fingerprint_holds_the_lights() {
    let plain = lit_floor(Vec::new());
    let before = scene_hash(&plain.scene);
    let point = |x| {
        Light::Point(PointLight {
            position: Vec3::new(x, 1.0, 0.0),
            intensity: Vec3::ONE,
            spot: None,
        })
    };
    let one = lit_floor(vec![point(0.0)]);
    let moved = lit_floor(vec![point(0.5)]);
    assert_ne!(scene_hash(&one.scene), before);
    assert_ne!(scene_hash(&one.scene), scene_hash(&moved.scene));
    assert_eq!(scene_hash(&lit_floor(Vec::new()).scene), before);
}

/// A folder holding a floor OBJ (albedo 0.8, its MTL beside it) and the scene file
/// `scene` (which names it `floor.obj`) as `scene.toml`.
fn scene_folder(scene: &str) -> tempfile::TempDir {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(
        dir.path().join("floor.obj"),
        "mtllib floor.mtl\nv -50 0 -50\nv -50 0 50\nv 50 0 50\nv 50 0 -50\nusemtl white\nf 1 2 3\nf 1 3 4\n",
    )
    .unwrap();
    std::fs::write(
        dir.path().join("floor.mtl"),
        "newmtl white\nKd 0.8 0.8 0.8\n",
    )
    .unwrap();
    std::fs::write(dir.path().join("scene.toml"), scene).unwrap();
    dir
}

/// A camera straight down onto the floor's origin from 5 above, a tenth of a degree
/// wide.
const DOWN: &str = "[camera.down]\neye = [0, 5, 0]\nlook-at = [0, 0, 0]\nup = [0, 0, -1]\nfov = 0.1\n\n[[obj]]\nfile = \"floor.obj\"\n";

fn render_in(dir: &Path, args: &[&str]) -> Image {
    let mut all = vec!["render", "scene.toml", "-o", "out.exr"];
    all.extend(args);
    let out = ember_in(&all, dir);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "ember {all:?}: {stderr}");
    assert!(
        !stderr.contains("white sky"),
        "placed lights light the scene: {stderr}"
    );
    Image::load(&dir.join("out.exr")).unwrap()
}

/// Through a scene file: `683π` cd one metre over the floor (albedo 0.8) renders it
/// with the radiance 0.8, on both backends.
#[test]
fn a_scene_files_point_light_in_candela_renders_on_both_backends() {
    let scene = format!(
        "{DOWN}\n[[light]]\ntype = \"point\"\ntranslate = [0, 1, 0]\ncandela = {}\n",
        683.0 * PI
    );
    let dir = scene_folder(&scene);
    for accel in ["embree", "bvh"] {
        let image = render_in(
            dir.path(),
            &[
                "--width", "8", "--height", "8", "--spp", "2", "--accel", accel,
            ],
        );
        for p in &image.pixels {
            // Within the tenth of a degree the camera sees, `cos³` of the angle to
            // the light is above 0.9999.
            assert_close(accel, *p, DVec3::splat(0.8), 1e-3, 0.0);
        }
    }
}

/// One light of every type in a scene file: each renders on both backends, the two
/// images agree, and the floor is lit where each light shines.
#[test]
fn a_scene_file_with_every_light_type_renders_on_both_backends() {
    let scene = r#"
[camera.top]
eye = [0, 6, 0.001]
look-at = [0, 0, 0]
fov = 70

[[obj]]
file = "floor.obj"

[[light]]
type = "point"
translate = [0, 1, 0]
intensity = 1

[[light]]
name = "key"
type = "spot"
translate = [2, 2, 0]
direction = [0, -1, 0]
inner-angle = 10
outer-angle = 20
power = 100

[[light]]
type = "directional"
direction = [1, -2, 0]
irradiance = 0.05
angular-diameter = 0.53

[[light]]
type = "directional"
rotate = { axis = [1, 0, 0], degrees = -60 }
lux = 20

[[light]]
type = "quad"
size = [1, 0.5]
translate = [-2, 1, 0]
direction = [0, -1, 0]
power = 5

[[light]]
type = "disk"
radius = 0.3
translate = [-2, 1, 2]
direction = [0, -1, 0]
radiance = 2

[[light]]
type = "quad"
size = [0.4, 0.4]
translate = [2, 1, -2]
direction = [0, 1, 0]
two-sided = true
power = 4

[[light]]
type = "sphere"
radius = 0.2
translate = [0, 0.5, 2]
power = 3
color = [1, 0.5, 0.2]
"#;
    let dir = scene_folder(scene);
    let args = ["--width", "32", "--height", "32", "--spp", "16"];
    let with = |accel| {
        let mut all = args.to_vec();
        all.extend(["--accel", accel]);
        render_in(dir.path(), &all)
    };
    let (embree, bvh) = (with("embree"), with("bvh"));
    let error = compare(&bvh, &embree).unwrap();
    assert!(
        error.rel_mse < 1e-6,
        "the backends differ: relMSE {}",
        error.rel_mse
    );
    // The suns light all of the floor; only the backs of the one-sided quad and the
    // disk, which reflect nothing, are black (the two-sided quad has none).
    let dark = embree
        .pixels
        .iter()
        .filter(|p| p.max_element() <= 0.0)
        .count();
    assert!(dark < embree.pixels.len() / 50, "{dark} black pixels");
    let info = ember_in(&["info", "scene.toml"], dir.path());
    let stdout = String::from_utf8_lossy(&info.stdout);
    assert!(info.status.success(), "{stdout}");
    for line in [
        "8 placed lights",
        "light 1: point at (0, 1, 0): intensity 1 W/sr (power 12.5664 W)",
        "light \"key\": spot at (2, 2, 0) shining along (0, -1, 0), cone 10° to 20°",
        "light 3: directional, shining along (0.4472, -0.8944, 0), a disc 0.53° across: irradiance 0.05 W/m²",
        "light 4: directional, shining along (0, -0.866, -0.5), a delta light: irradiance 0.0293 W/m²",
        "light 5: quad 1×0.5 at (-2, 1, 0) lighting along (0, -1, 0): radiance 3.1831 W/m²/sr (power 5 W",
        "light 6: disk of radius 0.3 at (-2, 1, 2) lighting along (0, -1, 0): radiance 2 W/m²/sr",
        "light 7: quad 0.4×0.4 at (2, 1, -2) lighting both sides of (0, 1, 0): radiance 3.9789 W/m²/sr (power 4 W",
        "light 8: sphere of radius 0.2 at (0, 0.5, 2): radiance",
    ] {
        assert!(stdout.contains(line), "`ember info` lacks {line:?}:\n{stdout}");
    }
}

/// A `[[light]]` that is wrong is one error naming the file, line, column and key.
#[test]
fn scene_file_light_errors_name_the_key() {
    let cases = [
        ("[[light]]\ntype = \"point\"\nintensity = 1\nfoo = 2\n", "13:1: foo: unknown field `foo`"),
        ("[[light]]\ntype = \"point\"\nintensity = \"bright\"\n", "12:13: intensity: invalid type: string \"bright\", expected f32"),
        ("[[light]]\ntype = \"lamp\"\nintensity = 1\n", "11:8: light.type: unknown light type \"lamp\": choose from point, spot, directional, quad, disk, sphere"),
        ("[[light]]\nintensity = 1\n", "10:1: light.type: a [[light]] needs type"),
        ("[[light]]\ntype = \"point\"\n", "10:1: light.intensity: a point light needs one of intensity (W/sr), power (W), candela (cd, at 683 lm/W)"),
        ("[[light]]\ntype = \"point\"\nintensity = 1\npower = 2\n", "13:9: light.power: give one of intensity and power, not both"),
        ("[[light]]\ntype = \"spot\"\nintensity = 1\n", "10:1: light.outer-angle: a spot light needs outer-angle"),
        ("[[light]]\ntype = \"spot\"\nintensity = 1\nouter-angle = 120\n", "13:15: light.outer-angle: must be an angle in degrees above 0 and at most 90"),
        ("[[light]]\ntype = \"spot\"\nintensity = 1\nouter-angle = 20\ninner-angle = 30\n", "14:15: light.inner-angle: must be an angle in degrees from 0 to outer-angle"),
        ("[[light]]\ntype = \"point\"\nintensity = 1\nradius = 2\n", "13:10: light.radius: a point light takes no radius"),
        ("[[light]]\ntype = \"sphere\"\nradius = 1\npower = 1\ntwo-sided = true\n", "14:13: light.two-sided: a sphere light takes no two-sided"),
        ("[[light]]\ntype = \"directional\"\nirradiance = 1\ntranslate = [0, 1, 0]\n", "13:13: light.translate: a directional light takes no translate"),
        ("[[light]]\ntype = \"spot\"\nintensity = 1\nouter-angle = 20\ndirection = [0, -1, 0]\nrotate = { axis = [1, 0, 0], degrees = 3 }\n", "14:13: light.direction: give either direction or rotate, not both"),
        ("[[light]]\ntype = \"quad\"\nradiance = 1\n", "10:1: light.size: a quad light needs size"),
        ("[[light]]\ntype = \"sphere\"\npower = 1\nradius = -1\n", "13:10: light.radius: must be a finite number above 0"),
        ("[[light]]\ntype = \"disk\"\npower = -1\nradius = 1\n", "12:9: light.power: must be a finite number ≥ 0"),
        ("[[light]]\ntype = \"point\"\nintensity = 1\ncolor = [1, -1, 0]\n", "13:9: light.color: must be three finite numbers ≥ 0"),
        ("[[light]]\ntype = \"directional\"\nlux = 1\nangular-diameter = 180\n", "13:20: light.angular-diameter: must be an angle"),
        ("[[light]]\ntype = \"quad\"\nradiance = 1\nsize = [1, 1]\nscale = 0\n", "14:9: light.scale: must be finite and non-zero"),
        ("[[light]]\ntype = \"point\"\nintensity = 3e38\n", "10:1: light.power: the light's power is not a finite number"),
        ("[[light]]\ntype = \"sphere\"\nradius = 1\npower = 1\ntranslate = [0, 1e16, 0]\n", "10:1: light.translate: it places the light 1.000e16 from the origin"),
    ];
    for (light, expected) in cases {
        let dir = scene_folder(&format!("{DOWN}\n{light}"));
        let out = ember_in(&["render", "scene.toml", "-o", "out.png"], dir.path());
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert!(!out.status.success(), "{light}: accepted");
        assert_eq!(stderr.lines().count(), 1, "{light}: {stderr}");
        assert!(
            stderr.starts_with("error: ")
                && stderr.contains("scene.toml:")
                && stderr.contains(expected),
            "{light}: {stderr} lacks {expected:?}"
        );
        assert!(!dir.path().join("out.png").exists());
    }
}
