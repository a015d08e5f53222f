//! The densities of `ember::sampling` checked against mathematics: the book's worked
//! Monte Carlo examples, normalisation over the sphere, and histograms of `generate`
//! against `value` (chi-square).

mod common;

use std::f64::consts::PI;

use common::stats::{bin_integrals, check_density, monte_carlo, Binning, Density};
use common::{build, diffuse, quad, Built};
use ember::accel::{Accel, Ray};
use ember::bsdf::Bsdf;
use ember::light::{
    BsdfPdf, LightPdf, LightSampler, LightSamplerKind, LightTarget, MixturePdf, Pdf, Receiver,
};
use ember::sampling::{uniform_sphere, Rng};
use glam::Vec3;

#[test]
fn book_x_squared_with_linear_density() {
    // ∫₀² x² dx = 8/3, sampling p(r) = r/2 by inverting its CDF: r = sqrt(4u).
    let mut rng = Rng::seeded(1);
    let (estimate, sigma) = monte_carlo(200_000, || {
        let r = (4.0 * f64::from(rng.f32())).sqrt();
        if r == 0.0 {
            return 0.0;
        }
        r * r / (r / 2.0)
    });
    assert!(
        (estimate - 8.0 / 3.0).abs() < 4.0 * sigma,
        "{estimate} ± {sigma} vs 8/3"
    );
    assert!(sigma < 0.01);
}

#[test]
fn book_cos_squared_over_the_sphere() {
    // ∫ cos²θ dω = 4π/3 with directions uniform on the sphere, density 1/4π.
    let mut rng = Rng::seeded(2);
    let (estimate, sigma) = monte_carlo(200_000, || {
        let (u1, u2) = rng.pair();
        let d = uniform_sphere(u1, u2);
        f64::from(d.z * d.z) * 4.0 * PI
    });
    assert!(
        (estimate - 4.0 * PI / 3.0).abs() < 4.0 * sigma,
        "{estimate} ± {sigma} vs 4π/3"
    );
}

/// A shading point at the origin under a big emissive quad (facing down, Ke 1) and
/// beside a brighter emissive triangle (facing −x, Ke 4); optionally an occluder
/// between the point and the quad and a light that faces away.
fn light_scene(occluded: bool) -> Built {
    let y = 0.6;
    let mut tris: Vec<([Vec3; 3], u32)> = quad(
        Vec3::new(-1.0, y, -1.0),
        Vec3::new(1.0, y, -1.0),
        Vec3::new(1.0, y, 1.0),
        Vec3::new(-1.0, y, 1.0),
        0,
    )
    .to_vec();
    tris.push((
        [
            Vec3::new(0.8, -0.5, -0.5),
            Vec3::new(0.8, -0.5, 0.5),
            Vec3::new(0.8, 0.5, 0.0),
        ],
        1,
    ));
    if occluded {
        // A grey square half way to the quad, and a light below facing away.
        tris.extend(quad(
            Vec3::new(-0.2, 0.3, -0.2),
            Vec3::new(-0.2, 0.3, 0.2),
            Vec3::new(0.2, 0.3, 0.2),
            Vec3::new(0.2, 0.3, -0.2),
            2,
        ));
        tris.push((
            [
                Vec3::new(-0.5, -0.7, -0.5),
                Vec3::new(0.5, -0.7, -0.5),
                Vec3::new(0.0, -0.7, 0.5),
            ],
            1,
        ));
    }
    build(
        &tris,
        vec![
            diffuse(Vec3::splat(0.5), Vec3::ONE),
            diffuse(Vec3::splat(0.5), Vec3::splat(4.0)),
            diffuse(Vec3::splat(0.5), Vec3::ZERO),
        ],
    )
}

fn lights_of(built: &Built) -> LightSampler {
    LightSampler::new(
        &built.scene.mesh,
        &built.scene.materials,
        &built.scene.textures,
    )
}

fn lights_with(built: &Built, kind: LightSamplerKind) -> LightSampler {
    LightSampler::with_kind(
        &built.scene.mesh,
        &built.scene.materials,
        &built.scene.textures,
        kind,
    )
}

/// The receivers the light densities are checked from: the origin without a normal,
/// and with normals that make the cosine warp matter.
fn receivers() -> [Receiver; 3] {
    [
        Receiver::at(Vec3::ZERO),
        Receiver {
            p: Vec3::ZERO,
            n: Vec3::new(0.2, 1.0, 0.1).normalize(),
        },
        Receiver {
            p: Vec3::ZERO,
            n: Vec3::new(1.0, 0.3, -0.4).normalize(),
        },
    ]
}

/// Checks a [`Pdf`] at the origin of `built`'s scene: its value for a direction is
/// told that direction's first hit, traced here.
fn check_pdf(name: &str, built: &Built, pdf: &impl Pdf, total: f64, seed: u64) {
    let value = |dir: Vec3| {
        let hit = built.accel.intersect(&Ray::new(Vec3::ZERO, dir));
        pdf.value(dir, hit.as_ref())
    };
    let draw = |rng: &mut Rng| {
        let drawn = pdf.generate(rng)?;
        let hit = built.accel.intersect(&Ray::new(Vec3::ZERO, drawn.dir));
        drawn.reached(hit.as_ref()).then_some(drawn.dir)
    };
    let density = Density {
        value: &value,
        draw: &draw,
    };
    check_density(
        name,
        &density,
        Vec3::Y,
        total,
        0.01,
        Binning::default(),
        seed,
    );
}

fn lambert_pdf(bsdf: &Bsdf, normal: Vec3) -> BsdfPdf<'_> {
    BsdfPdf { bsdf, wo: normal }
}

#[test]
fn cosine_density_is_normalised_and_matches_its_draws() {
    let built = light_scene(false);
    let normal = Vec3::new(0.3, 0.5, -0.8).normalize();
    let lambert = Bsdf::lambert(Vec3::ONE, normal, normal);
    check_pdf("cosine", &built, &lambert_pdf(&lambert, normal), 1.0, 10);
}

#[test]
fn light_density_is_normalised_and_matches_its_draws() {
    let built = light_scene(false);
    for kind in LightSamplerKind::ALL {
        let lights = lights_with(&built, kind);
        assert_eq!(lights.len(), 3);
        for (i, at) in receivers().into_iter().enumerate() {
            let pdf = LightPdf {
                at,
                lights: &lights,
            };
            check_pdf(
                &format!("light ({kind:?}, {at:?})"),
                &built,
                &pdf,
                1.0,
                13 + i as u64,
            );
        }
    }
}

#[test]
fn mixture_density_is_normalised_and_matches_its_draws() {
    let built = light_scene(false);
    for kind in LightSamplerKind::ALL {
        let lights = lights_with(&built, kind);
        let normal = Vec3::new(0.2, 1.0, 0.1).normalize();
        let light = LightPdf {
            at: Receiver {
                p: Vec3::ZERO,
                n: normal,
            },
            lights: &lights,
        };
        let lambert = Bsdf::lambert(Vec3::ONE, normal, normal);
        let mixture = MixturePdf::even(lambert_pdf(&lambert, normal), light);
        check_pdf(&format!("mixture ({kind:?})"), &built, &mixture, 1.0, 14);
        let sideways = Bsdf::lambert(Vec3::ONE, -Vec3::X, -Vec3::X);
        let uneven = MixturePdf {
            first: lambert_pdf(&sideways, -Vec3::X),
            second: light,
            weight: 0.2,
        };
        check_pdf(
            &format!("mixture 0.2/0.8 ({kind:?})"),
            &built,
            &uneven,
            1.0,
            15,
        );
    }
}

#[test]
fn light_power_weighting_is_area_times_luminance() {
    let built = light_scene(false);
    for kind in [LightSamplerKind::Alias, LightSamplerKind::SolidAngle] {
        let lights = lights_with(&built, kind);
        // Quad: area 4, Ke 1 → 4 (2 per half); triangle: area 0.5, Ke 4 → 2. The alias
        // table's probabilities are 2/6 for each half of the quad, 2/6 for the triangle,
        // wherever the receiver is.
        for p in [Vec3::ZERO, Vec3::new(5.0, -3.0, 2.0)] {
            let at = Receiver::at(p);
            for prim in 0..3 {
                let chosen = lights.choice_probability(at, prim);
                assert!((chosen - 1.0 / 3.0).abs() < 1e-6, "{prim}: {chosen}");
            }
            assert_eq!(lights.choice_probability(at, 7), 0.0);
        }
    }
}

#[test]
fn hidden_lights_make_void_draws_and_value_still_matches() {
    let built = light_scene(true);
    for kind in LightSamplerKind::ALL {
        let lights = lights_with(&built, kind);
        let pdf = LightPdf {
            at: Receiver::at(Vec3::ZERO),
            lights: &lights,
        };
        // Integral = 1 − P(void); estimate it by quadrature, then check draws against it.
        let value = |dir: Vec3| {
            let hit = built.accel.intersect(&Ray::new(Vec3::ZERO, dir));
            pdf.value(dir, hit.as_ref())
        };
        let integral: f64 = bin_integrals(&value, Vec3::Y, 20, 24, 12).iter().sum();
        assert!(
            integral < 0.95,
            "occluder and back-facing light should hide mass"
        );
        check_pdf(
            &format!("light (occluded, {kind:?})"),
            &built,
            &pdf,
            integral,
            16,
        );
    }
}

#[test]
fn light_value_equals_the_density_of_the_draw() {
    for (occluded, kind) in [false, true]
        .into_iter()
        .flat_map(|o| LightSamplerKind::ALL.map(|k| (o, k)))
    {
        let built = light_scene(occluded);
        let lights = lights_with(&built, kind);
        let at = receivers()[1];
        let pdf = LightPdf {
            at,
            lights: &lights,
        };
        let mut rng = Rng::seeded(17);
        let mut produced = 0;
        for _ in 0..20_000 {
            let Some(sample) = lights.sample(at, &mut rng) else {
                continue;
            };
            let hit = built.accel.intersect(&Ray::new(Vec3::ZERO, sample.dir));
            if hit.is_some_and(|h| LightTarget::Emitter(h.prim) == sample.target) {
                let v = pdf.value(sample.dir, hit.as_ref());
                assert!(
                    (v - sample.pdf).abs() <= 1e-3 * sample.pdf,
                    "value {v} vs generator density {}",
                    sample.pdf
                );
                produced += 1;
            }
        }
        assert!(produced > 10_000);
    }
}

/// `may_light` may only say "no" for points behind every emitter: for random emitters
/// whose normals lie in a cone, and random points, a point it culls has
/// `(p − q) · n ≤ 0` for every vertex `q` of every emitter (and so, by linearity, for
/// every point of every emitter).
#[test]
fn light_culling_never_skips_a_lit_point() {
    let mut rng = Rng::seeded(77);
    for spread in [0.0f32, 0.3, 0.9] {
        let mut triangles = Vec::new();
        for _ in 0..6 {
            let center = Vec3::new(rng.f32(), 2.0 + rng.f32(), rng.f32());
            // A normal near -y, tilted by up to `spread` radians.
            let tilt = Vec3::new(rng.f32() - 0.5, 0.0, rng.f32() - 0.5) * 2.0 * spread.tan();
            let n = (-Vec3::Y + tilt).normalize();
            let onb = ember::sampling::Onb::from_w(n);
            // Counter-clockwise around n.
            let verts =
                [0.0f32, 2.1, 4.2].map(|a| center + 0.2 * (a.cos() * onb.u + a.sin() * onb.v));
            triangles.push((verts, 0));
        }
        let built = build(&triangles, vec![diffuse(Vec3::splat(0.5), Vec3::ONE)]);
        let lights = lights_of(&built);
        let mut culled = 0;
        for _ in 0..20_000 {
            let p = Vec3::new(
                rng.f32() * 6.0 - 3.0,
                rng.f32() * 6.0 - 1.0,
                rng.f32() * 6.0 - 3.0,
            );
            if lights.may_light(p) {
                continue;
            }
            culled += 1;
            for (verts, _) in &triangles {
                let n = (verts[1] - verts[0]).cross(verts[2] - verts[0]).normalize();
                for q in verts {
                    assert!(
                        (p - *q).dot(n) <= 1e-5,
                        "culled {p} is in front of an emitter"
                    );
                }
            }
        }
        // The test is not vacuous: points above the lights are culled (fewer as the
        // normals spread and the cone widens).
        let expected = if spread < 0.5 { 1000 } else { 1 };
        assert!(
            culled >= expected,
            "only {culled} points culled with spread {spread}"
        );
        assert!(!lights.may_light(Vec3::new(0.5, 10.0, 0.5)));
        assert!(lights.may_light(Vec3::new(0.5, -1.0, 0.5)));
    }
}
