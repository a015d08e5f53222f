//! Light sampling checked against mathematics: spherical-triangle sampling and the
//! emitter's strategy rule against their densities (chi-square over cells of the
//! triangle), from in front of an emitter and from behind a two-sided one; the light
//! BVH's choice probabilities (they sum to 1, vanish only where no light can shine, and
//! match the frequencies of its choices), one-sided and two-sided; and direct light
//! from constructed scenes with known answers.

mod common;

use std::f64::consts::PI;

use common::stats::{assert_chi_square, monte_carlo};
use common::{build, diffuse, lambert_irradiance, Built};
use ember::light::bvh::{LightBounds, LightBvh};
use ember::light::spherical_triangle::{
    bilinear_density, sample_bilinear, SphericalTriangle, Warp,
};
use ember::light::{
    LightSampler, LightSamplerKind, LightTarget, Receiver, BVH_MIN_EMITTERS, MAX_SOLID_ANGLE,
    MIN_SOLID_ANGLE,
};
use ember::sampling::{uniform_sphere, Rng};
use ember::scene::Material;
use glam::{DVec3, Vec3};

/// An emitting triangle in the plane y = 0, emitting downwards (−y).
const TRIANGLE: [Vec3; 3] = [
    Vec3::new(-1.0, 0.0, -1.0),
    Vec3::new(1.0, 0.0, -1.0),
    Vec3::new(0.0, 0.0, 1.0),
];

/// Receivers below [`TRIANGLE`]: near and far, face-on and grazing, with and without
/// a normal (the cosine warp), as (name, receiver).
fn receivers() -> Vec<(&'static str, Receiver)> {
    let up = Vec3::new(0.3, 1.0, 0.2).normalize();
    let side = Vec3::new(1.0, 0.1, 0.0).normalize();
    let mut out = Vec::new();
    for (name, p) in [
        ("near face-on", Vec3::new(0.0, -0.3, 0.0)),
        ("touching", Vec3::new(0.1, -0.004, -0.2)),
        ("near grazing", Vec3::new(2.5, -0.15, 0.3)),
        ("middle", Vec3::new(0.5, -20.0, 1.0)),
        ("far face-on", Vec3::new(0.0, -100.0, 0.0)),
        ("far grazing", Vec3::new(30.0, -1.0, 5.0)),
    ] {
        out.push((name, Receiver::at(p)));
        out.push((name, Receiver { p, n: up }));
        out.push((name, Receiver { p, n: side }));
    }
    out
}

/// Where the point `q` of a triangle lies in its parameters: `q = v0 + s·e1 + t·e2`.
fn parameters(v: [Vec3; 3], q: Vec3) -> (f64, f64) {
    let [v0, v1, v2] = v.map(|x| x.as_dvec3());
    let (e1, e2, d) = (v1 - v0, v2 - v0, q.as_dvec3() - v0);
    let (d00, d01, d11) = (e1.dot(e1), e1.dot(e2), e2.dot(e2));
    let (d20, d21) = (d.dot(e1), d.dot(e2));
    let denominator = d00 * d11 - d01 * d01;
    (
        (d11 * d20 - d01 * d21) / denominator,
        (d00 * d21 - d01 * d20) / denominator,
    )
}

/// Which of the `n²` congruent triangles that split the unit triangle `s, t ≥ 0,
/// s + t ≤ 1` holds `(s, t)`: the square cell `(i, j)` of an `n × n` grid, its lower
/// or upper half.
fn sub_triangle(s: f64, t: f64, n: usize) -> usize {
    let (x, y) = (s * n as f64, t * n as f64);
    let (i, j) = (
        (x.max(0.0) as usize).min(n - 1),
        (y.max(0.0) as usize).min(n - 1),
    );
    let upper = x - i as f64 + y - j as f64 >= 1.0;
    2 * (i * n + j) + usize::from(upper)
}

/// Chi-square of points drawn on triangle `v` against a solid-angle density seen from
/// `p`. The bins are 256 congruent sub-triangles; a bin's expected share is
/// `∫ density · cos α / d² dA` over it (midpoint rule over 64 finer triangles each),
/// which also checks that the density integrates to 1 over the triangle.
fn check_on_triangle(
    name: &str,
    p: Vec3,
    v: [Vec3; 3],
    density: &dyn Fn(Vec3, f32) -> f64,
    draw: &dyn Fn(&mut Rng) -> Option<Vec3>,
    seed: u64,
) {
    const CELLS: usize = 16;
    const FINE: usize = CELLS * 8;
    const DRAWS: usize = 200_000;
    let [v0, v1, v2] = v;
    let cross = (v1 - v0).cross(v2 - v0);
    let (normal, double_area) = (cross.normalize(), f64::from(cross.length()));
    let mut expected = vec![0.0; 2 * CELLS * CELLS];
    let h = 1.0 / FINE as f64;
    for i in 0..FINE {
        for j in 0..FINE - i {
            // The lower fine triangle of cell (i, j), and the upper one where it is
            // inside the unit triangle, by their centroids.
            for (ds, dt) in [(1.0 / 3.0, 1.0 / 3.0), (2.0 / 3.0, 2.0 / 3.0)] {
                let (s, t) = ((i as f64 + ds) * h, (j as f64 + dt) * h);
                if s + t >= 1.0 {
                    continue;
                }
                let q =
                    (v0.as_dvec3() + s * (v1 - v0).as_dvec3() + t * (v2 - v0).as_dvec3()).as_vec3();
                let to_q = (q - p).as_dvec3();
                let d2 = to_q.length_squared();
                let dir = (to_q / d2.sqrt()).as_vec3();
                let cos = f64::from(dir.dot(normal).abs());
                let mass = density(dir, d2.sqrt() as f32) * cos / d2 * double_area * h * h / 2.0;
                expected[sub_triangle(s, t, CELLS)] += mass;
            }
        }
    }
    let total: f64 = expected.iter().sum();
    assert!(
        (total - 1.0).abs() < 2e-3,
        "{name}: the density integrates to {total} over the triangle"
    );
    let mut observed = vec![0.0; 2 * CELLS * CELLS];
    let mut rng = Rng::seeded(seed);
    let mut void = 0;
    for _ in 0..DRAWS {
        let Some(q) = draw(&mut rng) else {
            void += 1;
            continue;
        };
        let (s, t) = parameters(v, q);
        observed[sub_triangle(s, t, CELLS)] += 1.0;
    }
    let expected: Vec<f64> = expected.iter().map(|e| e * DRAWS as f64).collect();
    eprintln!("{name}: total {total:.5} void {void}");
    assert_chi_square(name, &observed, &expected);
    assert!(void < DRAWS / 1000, "{name}: {void} void draws");
}

/// Where the ray from `p` along `w` meets the plane of `v`.
fn on_plane(p: Vec3, w: DVec3, v: [Vec3; 3]) -> Vec3 {
    let [v0, v1, v2] = v.map(|x| x.as_dvec3());
    let n = (v1 - v0).cross(v2 - v0);
    let t = (v0 - p.as_dvec3()).dot(n) / w.dot(n);
    (p.as_dvec3() + t * w).as_vec3()
}

#[test]
fn spherical_triangle_draws_follow_their_density() {
    for (k, (name, at)) in receivers().into_iter().enumerate() {
        let triangle = SphericalTriangle::new(at.p, TRIANGLE).expect("a proper triangle");
        // Nearly touching, the projected density peaks far more sharply than the
        // quadrature grid resolves (and the emitter samples by area there).
        if triangle.solid_angle() > MAX_SOLID_ANGLE {
            continue;
        }
        let warp: Option<Warp> = (at.n != Vec3::ZERO).then(|| triangle.cosine_warp(at.n));
        let density = |dir: Vec3, _distance: f32| triangle.density(dir.as_dvec3(), warp.as_ref());
        let draw = |rng: &mut Rng| {
            let u = [rng.f64(), rng.f64()];
            let u = warp.as_ref().map_or(u, |w| sample_bilinear(w, u));
            Some(on_plane(at.p, triangle.sample(u), TRIANGLE))
        };
        let label = format!("spherical {name}, n {:?}", at.n);
        check_on_triangle(&label, at.p, TRIANGLE, &density, &draw, 100 + k as u64);
    }
}

#[test]
fn the_warp_density_is_the_bilinear_density_at_the_inverted_point() {
    let at = Receiver {
        p: Vec3::new(0.4, -0.5, 0.1),
        n: Vec3::new(1.0, 0.2, 0.0).normalize(),
    };
    let triangle = SphericalTriangle::new(at.p, TRIANGLE).unwrap();
    let warp = triangle.cosine_warp(at.n);
    let mut rng = Rng::seeded(5);
    for _ in 0..1000 {
        let u = sample_bilinear(&warp, [rng.f64(), rng.f64()]);
        let w = triangle.sample(u);
        let expected = bilinear_density(&warp, u) / triangle.solid_angle();
        let got = triangle.density(w, Some(&warp));
        assert!(
            (got - expected).abs() < 1e-7 * expected,
            "{got} vs {expected}"
        );
    }
}

fn one_emitter() -> Built {
    build(
        &[(TRIANGLE, 0)],
        vec![diffuse(Vec3::splat(0.5), Vec3::splat(2.0))],
    )
}

/// [`one_emitter`] emitting from both faces.
fn two_sided_emitter() -> Built {
    let mut built = one_emitter();
    built.scene.materials[0].two_sided_emission = true;
    built
}

/// [`receivers`] mirrored through the triangle's plane: behind it, facing it.
fn receivers_behind() -> Vec<(&'static str, Receiver)> {
    let mirror = |v: Vec3| Vec3::new(v.x, -v.y, v.z);
    receivers()
        .into_iter()
        .map(|(name, at)| {
            (
                name,
                Receiver {
                    p: mirror(at.p),
                    n: mirror(at.n),
                },
            )
        })
        .collect()
}

fn sampler(built: &Built, kind: LightSamplerKind) -> LightSampler {
    LightSampler::with_kind(
        &built.scene.mesh,
        &built.scene.materials,
        &built.scene.textures,
        kind,
    )
}

/// The default sampler is area sampling, from every receiver whatever its solid angle:
/// its points are uniform over the triangle (chi-square over 64 congruent
/// sub-triangles) and its density is `d² / (cos α · A)` with `A = 2` here, the one
/// emitter being chosen with probability 1.
#[test]
fn the_default_sampler_draws_uniform_points_on_the_area() {
    const CELLS: usize = 8;
    const DRAWS: usize = 64_000;
    let built = one_emitter();
    let lights = sampler(&built, LightSamplerKind::default());
    assert_eq!(lights.kind(), Some(LightSamplerKind::Alias));
    for (k, (name, at)) in receivers().into_iter().enumerate() {
        assert!(!lights.samples_by_solid_angle(at, 0), "{name}");
        let mut rng = Rng::seeded(90 + k as u64);
        let mut observed = vec![0.0; 2 * CELLS * CELLS];
        for _ in 0..DRAWS {
            let sample = lights.sample(at, &mut rng).expect("the emitter faces it");
            let q = sample.point.unwrap().p;
            let cos = -sample.dir.dot(Vec3::NEG_Y);
            let area_density = sample.distance * sample.distance / (cos * 2.0);
            assert!(
                (sample.pdf - area_density).abs() <= 1e-4 * area_density,
                "{name}: pdf {} vs d²/(cos A) {area_density}",
                sample.pdf
            );
            let (s, t) = parameters(TRIANGLE, q);
            observed[sub_triangle(s, t, CELLS)] += 1.0;
        }
        // The n² sub-triangles inside the unit triangle: lower halves of the cells
        // with i + j < n, upper halves of those with i + j < n − 1.
        let inside = |i: usize, j: usize, upper: bool| i + j + usize::from(upper) < CELLS;
        let mut kept = Vec::new();
        for i in 0..CELLS {
            for j in 0..CELLS {
                for upper in [false, true] {
                    let bin = observed[2 * (i * CELLS + j) + usize::from(upper)];
                    if inside(i, j, upper) {
                        kept.push(bin);
                    } else {
                        assert_eq!(bin, 0.0, "{name}: a point outside the triangle");
                    }
                }
            }
        }
        assert_eq!(kept.len(), CELLS * CELLS);
        let expected = vec![(DRAWS / (CELLS * CELLS)) as f64; CELLS * CELLS];
        assert_chi_square(&format!("area sampling, {name}"), &kept, &expected);
    }
}

/// The emitter's draws follow the density `pdf_hit` reports for them, whichever
/// strategy the rule picks; and the receivers cover solid-angle sampling, area sampling
/// of a huge triangle and area sampling of small or far ones.
#[test]
fn emitter_draws_follow_the_density_of_their_strategy() {
    let built = one_emitter();
    let mut cases = [0; 3];
    for kind in LightSamplerKind::ALL {
        let lights = sampler(&built, kind);
        for (k, (name, at)) in receivers().into_iter().enumerate() {
            let omega = SphericalTriangle::new(at.p, TRIANGLE)
                .unwrap()
                .solid_angle();
            let by_solid_angle = lights.samples_by_solid_angle(at, 0);
            if by_solid_angle {
                assert!((MIN_SOLID_ANGLE..=MAX_SOLID_ANGLE).contains(&omega));
            }
            let case = match () {
                _ if by_solid_angle => 0,
                _ if omega > MAX_SOLID_ANGLE => 1,
                _ => 2,
            };
            cases[case] += 1;
            let density =
                |dir: Vec3, distance: f32| f64::from(lights.pdf_hit(at, 0, dir, distance));
            let draw = |rng: &mut Rng| {
                let sample = lights.sample(at, rng)?;
                assert_eq!(sample.target, LightTarget::Emitter(0));
                let value = lights.pdf_hit(at, 0, sample.dir, sample.distance);
                assert!(
                    (value - sample.pdf).abs() <= 1e-3 * sample.pdf,
                    "{name}: pdf_hit {value} vs the draw's {}",
                    sample.pdf
                );
                Some(sample.point.unwrap().p)
            };
            let label = format!("emitter ({kind:?}) {name}, n {:?}", at.n);
            check_on_triangle(&label, at.p, TRIANGLE, &density, &draw, 200 + k as u64);
        }
    }
    assert!(
        cases.iter().all(|&c| c > 0),
        "rule cases exercised: {cases:?}"
    );
}

/// A two-sided emitter seen from behind is sampled as from in front: its draws follow
/// the density `pdf_hit` reports (which integrates to 1 over the triangle), for every
/// sampler and whichever strategy the rule picks; one-sided, nothing is drawn from
/// behind and `pdf_hit` is 0 there.
#[test]
fn a_two_sided_emitter_is_drawn_from_behind_with_the_density_pdf_hit_reports() {
    let two_sided = two_sided_emitter();
    let one_sided = one_emitter();
    for kind in LightSamplerKind::ALL {
        let lights = sampler(&two_sided, kind);
        let dark = sampler(&one_sided, kind);
        for (k, (name, at)) in receivers_behind().into_iter().enumerate() {
            let density =
                |dir: Vec3, distance: f32| f64::from(lights.pdf_hit(at, 0, dir, distance));
            let draw = |rng: &mut Rng| {
                let sample = lights.sample(at, rng)?;
                let value = lights.pdf_hit(at, 0, sample.dir, sample.distance);
                assert!(
                    (value - sample.pdf).abs() <= 1e-3 * sample.pdf,
                    "{name}: pdf_hit {value} vs the draw's {}",
                    sample.pdf
                );
                assert_eq!(sample.emission, Vec3::splat(2.0), "{name}: its radiance");
                Some(sample.point.unwrap().p)
            };
            let label = format!("two-sided ({kind:?}) behind, {name}, n {:?}", at.n);
            check_on_triangle(&label, at.p, TRIANGLE, &density, &draw, 300 + k as u64);
            let mut rng = Rng::seeded(k as u64);
            let towards = (Vec3::new(0.1, 0.0, -0.2) - at.p).normalize();
            let distance = at.p.y / -towards.y;
            assert!(dark.sample(at, &mut rng).is_none(), "{name}: one-sided");
            assert_eq!(dark.pdf_hit(at, 0, towards, distance), 0.0, "{name}");
        }
    }
}

/// Behind a two-sided triangle, the light-sampling estimate of the irradiance matches
/// Lambert's formula, as it does in front, for every sampler.
#[test]
fn irradiance_behind_a_two_sided_triangle_matches_lamberts_formula() {
    let receivers = [
        Receiver {
            p: Vec3::new(0.0, 0.2, 0.0),
            n: -Vec3::Y,
        },
        Receiver {
            p: Vec3::new(2.0, 0.5, 0.0),
            n: Vec3::new(-1.0, -0.3, 0.0).normalize(),
        },
        Receiver {
            p: Vec3::new(0.0, -0.2, 0.0),
            n: Vec3::Y,
        },
    ];
    irradiance_matches_lamberts_formula(&two_sided_emitter(), &receivers, 60);
}

/// Random emitters: positions in a box, normals anywhere, powers over four decades
/// (some zero); with each one's vertices.
fn random_lights(n: usize, seed: u64) -> (Vec<LightBounds>, Vec<[Vec3; 3]>) {
    let mut rng = Rng::seeded(seed);
    (0..n)
        .map(|i| {
            let center = Vec3::new(rng.f32(), rng.f32(), rng.f32()) * 10.0 - 5.0;
            let (u1, u2) = rng.pair();
            let normal = uniform_sphere(u1, u2);
            let onb = ember::sampling::Onb::from_w(normal);
            let size = 0.05 + 0.3 * rng.f32();
            let vertices =
                [0.0f32, 2.1, 4.2].map(|a| center + size * (a.cos() * onb.u + a.sin() * onb.v));
            let power = if i % 17 == 16 {
                0.0
            } else {
                10f32.powf(4.0 * rng.f32())
            };
            (LightBounds::triangle(vertices, normal, power), vertices)
        })
        .unzip()
}

/// [`random_lights`] with every third light two-sided.
fn random_lights_some_two_sided(n: usize, seed: u64) -> (Vec<LightBounds>, Vec<[Vec3; 3]>) {
    let (lights, vertices) = random_lights(n, seed);
    let lights = lights
        .into_iter()
        .enumerate()
        .map(|(i, l)| if i % 3 == 0 { l.two_sided() } else { l })
        .collect();
    (lights, vertices)
}

fn random_receiver(rng: &mut Rng, with_normal: bool) -> (Vec3, Vec3) {
    let p = Vec3::new(rng.f32(), rng.f32(), rng.f32()) * 14.0 - 7.0;
    let (u1, u2) = rng.pair();
    (
        p,
        if with_normal {
            uniform_sphere(u1, u2)
        } else {
            Vec3::ZERO
        },
    )
}

/// With one-sided lights, and with every third light two-sided.
#[test]
fn bvh_probabilities_sum_to_one_and_vanish_only_where_no_light_shines() {
    for (n, two_sided) in [1, 2, 3, 300]
        .into_iter()
        .flat_map(|n| [(n, false), (n, true)])
    {
        let (lights, vertices) = match two_sided {
            false => random_lights(n, 31 + n as u64),
            true => random_lights_some_two_sided(n, 31 + n as u64),
        };
        let bvh = LightBvh::new(&lights).expect("some power");
        let mut rng = Rng::seeded(7);
        let mut zero = 0;
        for k in 0..400 {
            let (p, normal) = random_receiver(&mut rng, k % 2 == 0);
            let probabilities: Vec<f32> = (0..n).map(|i| bvh.probability(p, normal, i)).collect();
            let sum: f32 = probabilities.iter().sum();
            assert!(
                (sum - 1.0).abs() < 1e-4,
                "{n} lights at {p}: probabilities sum to {sum}"
            );
            for (i, &probability) in probabilities.iter().enumerate() {
                assert!(probability >= 0.0);
                if lights[i].power == 0.0 {
                    assert_eq!(probability, 0.0, "a light without power is chosen");
                }
                if probability == 0.0 && lights[i].power > 0.0 {
                    zero += 1;
                }
            }
            // A light given probability 0 must be unable to shine on p: p is behind
            // its plane, or it is behind p's.
            for (i, light) in lights.iter().enumerate() {
                if probabilities[i] == 0.0 && light.power > 0.0 {
                    assert!(
                        !can_light(vertices[i], light, p, normal),
                        "light {i} can shine on {p} (normal {normal}) but has probability 0"
                    );
                }
            }
        }
        if n == 300 {
            assert!(zero > 0, "the orientation cones never excluded a light");
        }
    }
}

/// Whether the emitting triangle `v` (unit normal `light.axis`) can send light to a
/// receiver at `p` that takes light only from the side of its normal `n` (zero: from
/// everywhere): `p` is in front of the triangle's plane (or off it, for a two-sided
/// light) and some of the triangle is in front of `p`'s (beyond a rounding tolerance).
fn can_light(v: [Vec3; 3], light: &LightBounds, p: Vec3, n: Vec3) -> bool {
    let tolerance = 1e-5 * (1.0 + p.abs().max_element());
    let height = (p - v[0]).dot(light.axis);
    let emits = height > tolerance || (light.two_sided && height < -tolerance);
    let received = n == Vec3::ZERO || v.iter().any(|&q| (q - p).dot(n) > tolerance);
    emits && received
}

/// Lights as a room has them: clusters of small squares (two triangles each, 10 cm)
/// 5 mm in front of walls, a ceiling and desk tops, facing away from them.
fn room_lights(seed: u64) -> (Vec<LightBounds>, Vec<[Vec3; 3]>) {
    let mut rng = Rng::seeded(seed);
    // (normal, a point of the surface the squares sit on)
    let surfaces = [
        (Vec3::Z, Vec3::new(0.0, 0.0, 0.0)),
        (-Vec3::Z, Vec3::new(0.0, 0.0, 8.0)),
        (-Vec3::Y, Vec3::new(0.0, 3.0, 0.0)),
        (Vec3::Y, Vec3::new(0.0, 0.75, 0.0)),
        (-Vec3::X, Vec3::new(4.95, 0.0, 0.0)),
        (Vec3::X, Vec3::new(5.05, 0.0, 0.0)),
    ];
    let mut lights = Vec::new();
    let mut vertices = Vec::new();
    for (k, (normal, on)) in surfaces.into_iter().enumerate() {
        let onb = ember::sampling::Onb::from_w(normal);
        for _ in 0..40 + 10 * k {
            let (s, t) = (rng.f32() * 6.0 - 3.0, rng.f32() * 3.0 - 1.5);
            let middle = Vec3::new(5.0, 1.5, 4.0);
            let center = middle - (middle - on).dot(normal) * normal
                + s * onb.u
                + t * onb.v
                + 0.005 * normal;
            let h = 0.05;
            let corner = |a: f32, b: f32| center + a * h * onb.u + b * h * onb.v;
            let power = 10f32.powf(2.0 * rng.f32());
            // Counter-clockwise seen from the side `normal` points to (u × v = normal).
            for tri in [
                [corner(-1.0, -1.0), corner(1.0, -1.0), corner(1.0, 1.0)],
                [corner(-1.0, -1.0), corner(1.0, 1.0), corner(-1.0, 1.0)],
            ] {
                lights.push(LightBounds::triangle(tri, normal, power));
                vertices.push(tri);
            }
        }
    }
    (lights, vertices)
}

/// Where the plane tests decide (issue 20): receivers on the surfaces behind a room's
/// lamps, level with them, just in front, beside and under them, on either side and
/// with random normals. Every light the BVH gives probability 0 must be unable to
/// light the receiver (the probabilities still sum to 1), and the tests must cull.
#[test]
fn bvh_probabilities_vanish_only_where_no_light_shines_near_lamps() {
    let (lights, vertices) = room_lights(77);
    let bvh = LightBvh::new(&lights).expect("some power");
    let mut rng = Rng::seeded(78);
    let mut culled = 0usize;
    let offsets = [-0.005, -0.001, 0.0, 0.004, 0.005, 0.006, 0.02, 0.5];
    for k in 0..1500 {
        let i = (rng.f32() * lights.len() as f32) as usize % lights.len();
        let m = lights[i].axis;
        let onb = ember::sampling::Onb::from_w(m);
        let center = (vertices[i][0] + vertices[i][1] + vertices[i][2]) / 3.0;
        let (s, t) = (rng.f32() * 0.6 - 0.3, rng.f32() * 0.6 - 0.3);
        let offset = offsets[k % offsets.len()];
        // The squares sit 5 mm off their surface: offset −0.005 is on it.
        let p = center + s * onb.u + t * onb.v + offset * m;
        let normal = match (k / offsets.len()) % 4 {
            0 => m,
            1 => -m,
            2 => Vec3::ZERO,
            _ => {
                let (u1, u2) = rng.pair();
                uniform_sphere(u1, u2)
            }
        };
        let probabilities: Vec<f32> = (0..lights.len())
            .map(|j| bvh.probability(p, normal, j))
            .collect();
        let sum: f32 = probabilities.iter().sum();
        assert!(
            (sum - 1.0).abs() < 1e-4,
            "at {p}: probabilities sum to {sum}"
        );
        for (j, &probability) in probabilities.iter().enumerate() {
            if probability == 0.0 {
                culled += 1;
                assert!(
                    !can_light(vertices[j], &lights[j], p, normal),
                    "light {j} can shine on {p} (normal {normal}) but has probability 0"
                );
            }
            // Behind the plane of a light's own surface, every lamp of that surface
            // has importance 0: the plane test is exact for a plane. (Its probability
            // may still not be 0: below a node that mixes orientations, whose bounds
            // admit p, children that all have importance 0 are chosen by power.)
            let coplanar =
                lights[j].axis == m && (vertices[j][0] - vertices[i][0]).dot(m).abs() < 1e-6;
            if offset < 0.0 && coplanar {
                assert_eq!(
                    lights[j].importance(p, normal),
                    0.0,
                    "light {j} is behind {p} but has importance"
                );
            }
        }
    }
    assert!(culled > 0);
}

/// Over trees of two to five levels of four-wide nodes (60 and 700 lights), and with
/// every third light two-sided.
#[test]
fn bvh_choices_follow_its_probabilities() {
    for (n, receivers) in [(60, 6), (700, 3)] {
        bvh_choices_follow_its_probabilities_with(random_lights(n, 5).0, receivers);
    }
    bvh_choices_follow_its_probabilities_with(random_lights_some_two_sided(60, 6).0, 4);
}

fn bvh_choices_follow_its_probabilities_with(lights: Vec<LightBounds>, receivers: u64) {
    let n = lights.len();
    let bvh = LightBvh::new(&lights).unwrap();
    let mut rng = Rng::seeded(9);
    for k in 0..receivers {
        let (p, normal) = random_receiver(&mut rng, k % 2 == 1);
        let draws = 200_000;
        let mut counts = vec![0.0; n];
        let mut draw_rng = Rng::seeded(1000 + k);
        for _ in 0..draws {
            let (i, probability, rest) = bvh.sample(p, normal, draw_rng.f64());
            assert_eq!(
                probability,
                bvh.probability(p, normal, i),
                "reported probability"
            );
            assert!((0.0..1.0).contains(&rest));
            counts[i] += 1.0;
        }
        let expected: Vec<f64> = (0..n)
            .map(|i| f64::from(bvh.probability(p, normal, i)) * draws as f64)
            .collect();
        assert_chi_square(&format!("bvh choices at {p}"), &counts, &expected);
    }
}

#[test]
fn bvh_build_is_deterministic() {
    let (lights, _) = random_lights(500, 3);
    let a = LightBvh::new(&lights).unwrap();
    let b = LightBvh::new(&lights).unwrap();
    // Four-wide nodes over the 471 lights with power: at least (471 − 1)/3 of them
    // (every node full), fewer than the 470 interior nodes of a binary tree.
    let lights_with_power: usize = 500 - 500 / 17;
    assert_eq!(a.node_count(), b.node_count());
    assert!(
        (lights_with_power - 1).div_ceil(3) <= a.node_count()
            && a.node_count() < lights_with_power - 1,
        "{} nodes",
        a.node_count()
    );
    let p = Vec3::new(0.3, -1.0, 2.0);
    for i in 0..500 {
        assert_eq!(
            a.probability(p, Vec3::Y, i).to_bits(),
            b.probability(p, Vec3::Y, i).to_bits()
        );
    }
}

/// Lambert's formula for the part of triangle `v` in front of the receiver's plane
/// (the polygon clipped by it, Sutherland–Hodgman): `∫ L max(0, n·ω) dω` over it.
fn clipped_lambert_irradiance(p: Vec3, n: Vec3, v: [Vec3; 3], radiance: f64) -> f64 {
    let height = |q: Vec3| f64::from((q - p).dot(n));
    let mut polygon = Vec::new();
    for k in 0..3 {
        let (a, b) = (v[k], v[(k + 1) % 3]);
        let (ha, hb) = (height(a), height(b));
        if ha >= 0.0 {
            polygon.push(a);
        }
        if (ha >= 0.0) != (hb >= 0.0) {
            let t = (ha / (ha - hb)) as f32;
            polygon.push(a + t * (b - a));
        }
    }
    if polygon.len() < 3 {
        return 0.0;
    }
    lambert_irradiance(p, n, &polygon, radiance)
}

/// A receiver above a large emitting triangle, and one beside it at a grazing angle:
/// the light-sampling estimate of the irradiance matches Lambert's formula (the
/// triangle lies wholly above the receivers' tangent planes).
#[test]
fn irradiance_under_a_large_triangle_matches_lamberts_formula() {
    // The receivers face the light: cos > 0 over all of it.
    let receivers = [
        Receiver {
            p: Vec3::new(0.0, -0.2, 0.0),
            n: Vec3::Y,
        },
        Receiver {
            p: Vec3::new(0.3, -0.02, -0.1),
            n: Vec3::Y,
        },
        Receiver {
            p: Vec3::new(2.0, -0.5, 0.0),
            n: Vec3::new(-1.0, 0.3, 0.0).normalize(),
        },
        Receiver {
            p: Vec3::new(0.0, -30.0, 0.0),
            n: Vec3::Y,
        },
    ];
    irradiance_matches_lamberts_formula(&one_emitter(), &receivers, 40);
}

/// The light-sampling estimate of the irradiance from [`TRIANGLE`] (radiance 2) at each
/// of `receivers` is Lambert's formula's, within four standard errors, for every
/// sampler.
fn irradiance_matches_lamberts_formula(built: &Built, receivers: &[Receiver], seed: u64) {
    for kind in LightSamplerKind::ALL {
        let lights = sampler(built, kind);
        for (k, &at) in receivers.iter().enumerate() {
            let expected = lambert_irradiance(at.p, at.n, &TRIANGLE, 2.0);
            let mut rng = Rng::seeded(seed + k as u64);
            let (estimate, sigma) = monte_carlo(200_000, || {
                lights.sample(at, &mut rng).map_or(0.0, |s| {
                    f64::from(s.emission.x * s.dir.dot(at.n).max(0.0) / s.pdf)
                })
            });
            assert!(
                (estimate - expected).abs() < 4.0 * sigma + 1e-4 * expected,
                "{kind:?} at {:?}: {estimate} ± {sigma} vs {expected}",
                at.p
            );
        }
    }
}

/// A sphere of emitters (a latitude-longitude mesh, facing inwards), each with its
/// own radiance: seen from inside, `∫ L dω = Σ L_i Ω_i`, and with one radiance for all
/// the irradiance is `π L` on any receiver.
///
/// Made `inside_out`, the triangles face away from the centre and emit from both
/// faces: seen from inside, the same light from their backs.
fn emitter_sphere(radiance: &dyn Fn(usize) -> f32, inside_out: bool) -> (Built, Vec<[Vec3; 3]>) {
    let (rings, segments) = (12, 24);
    let point = |i: usize, j: usize| {
        let theta = PI * i as f64 / rings as f64;
        let phi = 2.0 * PI * j as f64 / segments as f64;
        Vec3::new(
            (theta.sin() * phi.cos()) as f32,
            theta.cos() as f32,
            (theta.sin() * phi.sin()) as f32,
        )
    };
    let mut triangles = Vec::new();
    for i in 0..rings {
        for j in 0..segments {
            let (a, b, c, d) = (
                point(i, j),
                point(i + 1, j),
                point(i + 1, j + 1),
                point(i, j + 1),
            );
            for t in [[a, b, c], [a, c, d]] {
                let cross = (t[1] - t[0]).cross(t[2] - t[0]);
                if cross.length() < 1e-6 {
                    continue;
                }
                // Wound to face the centre (or away, inside out).
                let centroid = (t[0] + t[1] + t[2]) / 3.0;
                triangles.push(if (cross.dot(centroid) > 0.0) != inside_out {
                    [t[0], t[2], t[1]]
                } else {
                    t
                });
            }
        }
    }
    let materials = (0..triangles.len())
        .map(|i| Material {
            two_sided_emission: inside_out,
            ..diffuse(Vec3::splat(0.5), Vec3::splat(radiance(i)))
        })
        .collect();
    let tris: Vec<([Vec3; 3], u32)> = triangles
        .iter()
        .enumerate()
        .map(|(i, t)| (*t, i as u32))
        .collect();
    (build(&tris, materials), triangles)
}

/// Facing the centre, and inside out with two-sided emitters seen from behind.
#[test]
fn a_sphere_of_emitters_gives_the_known_direct_light() {
    for inside_out in [false, true] {
        a_sphere_of_emitters_gives_the_known_direct_light_with(inside_out);
    }
}

fn a_sphere_of_emitters_gives_the_known_direct_light_with(inside_out: bool) {
    let mixed = |i: usize| 10f32.powf(((i * 37) % 11) as f32 / 5.0 - 1.0);
    let (built, triangles) = emitter_sphere(&mixed, inside_out);
    let (uniform, _) = emitter_sphere(&|_| 1.5, inside_out);
    let receivers = [
        Receiver::at(Vec3::ZERO),
        Receiver {
            p: Vec3::new(0.3, -0.5, 0.2),
            n: Vec3::new(0.2, 1.0, -0.3).normalize(),
        },
        Receiver {
            p: Vec3::new(-0.1, 0.85, 0.0),
            n: Vec3::X,
        },
    ];
    for kind in LightSamplerKind::ALL {
        let lights = sampler(&built, kind);
        let uniform_lights = sampler(&uniform, kind);
        for (k, at) in receivers.into_iter().enumerate() {
            // Without a normal, radiance integrated over the sphere of directions;
            // with one, over the hemisphere the receiver takes light from, weighted
            // by the cosine (the BVH gives lights behind a receiver no chance).
            let expected: f64 = triangles
                .iter()
                .enumerate()
                .map(|(i, t)| {
                    let radiance = f64::from(mixed(i));
                    if at.n == Vec3::ZERO {
                        radiance * SphericalTriangle::new(at.p, *t).unwrap().solid_angle()
                    } else {
                        clipped_lambert_irradiance(at.p, at.n, *t, radiance)
                    }
                })
                .sum();
            let mut rng = Rng::seeded(60 + k as u64);
            let (estimate, sigma) = monte_carlo(200_000, || {
                lights.sample(at, &mut rng).map_or(0.0, |s| {
                    let cosine = if at.n == Vec3::ZERO {
                        1.0
                    } else {
                        s.dir.dot(at.n).max(0.0)
                    };
                    f64::from(s.emission.x * cosine / s.pdf)
                })
            });
            assert!(
                (estimate - expected).abs() < 4.0 * sigma + 1e-3 * expected,
                "{kind:?} at {:?}, inside out {inside_out}: ∫L (cos) dω {estimate} ± {sigma} vs {expected}",
                at.p
            );
            // The choice probabilities sum to 1 here too.
            let sum: f32 = (0..triangles.len() as u32)
                .map(|prim| lights.choice_probability(at, prim))
                .sum();
            assert!(
                (sum - 1.0).abs() < 1e-4,
                "{kind:?}: probabilities sum to {sum}"
            );
            if at.n == Vec3::ZERO {
                continue;
            }
            let mut rng = Rng::seeded(70 + k as u64);
            let (irradiance, sigma) = monte_carlo(200_000, || {
                uniform_lights.sample(at, &mut rng).map_or(0.0, |s| {
                    f64::from(s.emission.x * s.dir.dot(at.n).max(0.0) / s.pdf)
                })
            });
            let expected = PI * 1.5;
            assert!(
                (irradiance - expected).abs() < 4.0 * sigma + 1e-3 * expected,
                "{kind:?} at {:?}: irradiance {irradiance} ± {sigma} vs π L = {expected}",
                at.p
            );
        }
    }
}

/// The default (`auto`) is the alias table below [`BVH_MIN_EMITTERS`] emitters and the
/// light BVH from there on, in the sampler and in the render's identity alike: a
/// default render of a scene with few emitters has the identity of an explicit
/// `alias` render (version 10's, with no `light-sampler` entry), one of a scene with
/// many that of an explicit `bvh` render (`light-sampler bvh4 2`).
#[test]
fn the_default_is_the_bvh_from_a_measured_emitter_count() {
    use ember::render::{identity, RenderSettings};
    assert_eq!(
        LightSamplerKind::Auto.resolve(BVH_MIN_EMITTERS - 1),
        LightSamplerKind::Alias
    );
    assert_eq!(
        LightSamplerKind::Auto.resolve(BVH_MIN_EMITTERS),
        LightSamplerKind::Bvh
    );
    for kind in [
        LightSamplerKind::Alias,
        LightSamplerKind::SolidAngle,
        LightSamplerKind::Bvh,
    ] {
        assert_eq!(kind.resolve(0), kind);
        assert_eq!(kind.resolve(100_000), kind);
    }
    let few = one_emitter();
    let (many, _) = emitter_sphere(&|_| 1.0, false);
    assert!(many.scene.emitters.len() >= BVH_MIN_EMITTERS);
    assert_eq!(LightSamplerKind::default(), LightSamplerKind::Auto);
    assert_eq!(
        sampler(&few, LightSamplerKind::Auto).kind(),
        Some(LightSamplerKind::Alias)
    );
    assert_eq!(
        sampler(&many, LightSamplerKind::Auto).kind(),
        Some(LightSamplerKind::Bvh)
    );
    let camera = ember::scene::CameraSettings {
        eye: Vec3::new(0.0, 0.0, 3.0),
        look_at: Vec3::ZERO,
        up: Vec3::Y,
        projection: ember::scene::Projection::perspective(40.0),
        lens: Default::default(),
    };
    let id = |built: &Built, light_sampler| {
        let settings = RenderSettings {
            width: 8,
            height: 8,
            spp: 1,
            max_depth: 8,
            seed: 0,
            integrator: Default::default(),
            light_sampler,
            adaptive: None,
            guiding: None,
            engine: Default::default(),
        };
        identity(
            &built.scene,
            &camera,
            &settings,
            ember::accel::AccelKind::Embree,
        )
    };
    let auto_few = id(&few, LightSamplerKind::Auto);
    assert_eq!(auto_few, id(&few, LightSamplerKind::Alias));
    assert!(auto_few.iter().all(|(k, _)| k != "light-sampler"));
    let auto_many = id(&many, LightSamplerKind::Auto);
    assert_eq!(auto_many, id(&many, LightSamplerKind::Bvh));
    assert!(auto_many
        .iter()
        .any(|(k, v)| k == "light-sampler" && v == "bvh4 2"));
    assert_ne!(auto_many, id(&many, LightSamplerKind::Alias));
}
