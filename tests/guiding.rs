//! Path guiding (`ember::guiding`): the directional quadtree's density against its
//! sampling (normalisation and chi-square, untrained and trained), training on a
//! constructed scene whose light comes in through a small hole, and the same tree at
//! any thread count.

mod common;

use std::f32::consts::PI;
use std::path::Path;
use std::process::{Command, Output};
use std::sync::atomic::AtomicUsize;
use std::sync::Arc;

use common::stats::{check_density, chi_square, furnace_radiance, Binning, Density, SampleSums};
use common::{build, diffuse, inward_cube, quad, render_stopping, Built};
use ember::accel::{AccelKind, Ray};
use ember::film::Film;
use ember::guiding::{
    cosine_mass_in_cone, direction_to_square, mass_in_cone, square_to_direction, Draw, GuidedDraw,
    Guiding, MixtureDraw, PathRecords, QuadTree, Record, SdTree, Shadow, VertexGuide, GUIDED_COST,
    GUIDE_PROBABILITY, MIN_SELECTION_DRAWS, SELECTION_CHOICES, SKY_SHARE_CHOICES,
    SPLIT_REFERENCE_PIXELS,
};
use ember::image::compare;
use ember::integrator::{IntegratorKind, PathTracer, RayCount};
use ember::light::{GuidedLightPdf, LightSampler, LightTarget, Pdf, Receiver};
use ember::render::{
    guide_view, identity, render, train_guide, Adaptive, GuidePicture, GuideView, RenderSettings,
};
use ember::sampling::{uniform_sphere, Rng};
use ember::scene::{Camera, CameraSettings, Environment};
use glam::{Vec2, Vec3};

/// The untrained guide is the uniform density on the sphere, `1/4π`, and its draws
/// follow it.
#[test]
fn untrained_guide_is_uniform_and_follows_its_density() {
    let tree = QuadTree::uniform();
    let d = Vec3::new(0.3, -0.5, 0.8).normalize();
    assert!((tree.pdf(d) - 0.25 / std::f32::consts::PI).abs() < 1e-7);
    check_density(
        "uniform guide",
        &Density {
            value: &|d| tree.pdf(d),
            draw: &|rng| {
                let (u1, u2) = rng.pair();
                Some(tree.sample(Vec2::new(u1, u2)))
            },
        },
        Vec3::new(0.2, 0.9, -0.1).normalize(),
        1.0,
        2e-3,
        Binning::default(),
        11,
    );
}

/// A tree trained over three iterations on deposits of a peaked function of direction
/// (two lobes and a floor, sampled uniformly and deposited as `f / (1/4π)`).
fn trained_tree() -> QuadTree {
    let lobe_a = Vec3::new(0.3, 0.4, 0.866).normalize();
    let lobe_b = Vec3::new(-0.8, 0.1, -0.3).normalize();
    let f = |d: Vec3| {
        20.0 * d.dot(lobe_a).max(0.0).powi(30) + 5.0 * d.dot(lobe_b).max(0.0).powi(8) + 0.05
    };
    let mut tree = QuadTree::uniform();
    let mut rng = Rng::seeded(3);
    for _ in 0..3 {
        let mut filling = tree.cleared();
        for _ in 0..50_000 {
            let (u1, u2) = rng.pair();
            let d = uniform_sphere(u1, u2);
            filling.deposit(d, f64::from(f(d)) * 4.0 * std::f64::consts::PI);
        }
        tree = filling.refined();
    }
    tree
}

/// `∫ p` over each of `bins × bins` squares of the unit square, exactly: by the
/// midpoint rule on points finer than the finest cell (dyadic, so each point's
/// sub-square lies within one cell, where the density is constant).
fn square_bin_masses(tree: &QuadTree, bins: usize) -> Vec<f64> {
    let depth = tree.depth();
    let points = 1usize << depth;
    assert!(
        points.is_multiple_of(bins),
        "{bins} bins align with cells of depth {depth}"
    );
    let per_bin = points / bins;
    let mut masses = vec![0.0; bins * bins];
    let cell = 1.0 / points as f64;
    for i in 0..points {
        for j in 0..points {
            let p = Vec2::new(
                ((i as f64 + 0.5) * cell) as f32,
                ((j as f64 + 0.5) * cell) as f32,
            );
            masses[(j / per_bin) * bins + i / per_bin] +=
                f64::from(tree.square_pdf(p)) * cell * cell;
        }
    }
    masses
}

/// After training, the density integrates to 1 over the square (so to 1 over the
/// sphere: the map has Jacobian 4π), has learnt the peaks, and its draws follow it.
#[test]
fn trained_guide_is_normalised_and_follows_its_density() {
    let tree = trained_tree();
    let depth = tree.depth();
    eprintln!("trained tree: {} nodes, depth {depth}", tree.node_count());
    assert!((4..=11).contains(&depth), "depth {depth}");
    let bins = 32;
    let masses = square_bin_masses(&tree, bins);
    let total: f64 = masses.iter().sum();
    assert!((total - 1.0).abs() < 1e-5, "∫ p = {total}");
    // The peak is learnt: the density towards lobe A is far above uniform.
    let lobe_a = Vec3::new(0.3, 0.4, 0.866).normalize();
    assert!(tree.pdf(lobe_a) > 20.0 / (4.0 * std::f32::consts::PI));
    let n = 400_000;
    let mut rng = Rng::seeded(5);
    let mut counts = vec![0.0; bins * bins];
    for _ in 0..n {
        let (u1, u2) = rng.pair();
        let p = tree.sample_square(Vec2::new(u1, u2));
        let (i, j) = ((p.x * bins as f32) as usize, (p.y * bins as f32) as usize);
        counts[j.min(bins - 1) * bins + i.min(bins - 1)] += 1.0;
    }
    let expected: Vec<f64> = masses.iter().map(|m| m * n as f64).collect();
    let (chi2, dof) = chi_square(&counts, &expected);
    let limit = dof as f64 + 5.0 * (2.0 * dof as f64).sqrt();
    eprintln!("trained guide: chi2 {chi2:.1} over {dof} dof");
    assert!(chi2 < limit, "chi-square {chi2:.1} over {dof} dof");
    // And on the sphere, through the map: sampled directions against `pdf`.
    check_density(
        "trained guide",
        &Density {
            value: &|d| tree.pdf(d),
            draw: &|rng| {
                let (u1, u2) = rng.pair();
                Some(tree.sample(Vec2::new(u1, u2)))
            },
        },
        Vec3::Z,
        1.0,
        2e-2,
        GUIDE_BINNING,
        7,
    );
}

/// Bins and draws of the chi-square checks of a guide's density on the sphere.
const GUIDE_BINNING: Binning = Binning {
    nz: 8,
    nphi: 8,
    sub: 64,
    draws: 100_000,
};

/// The normals the folded guide is checked around: +z, and two around which the
/// trained tree's lobes lie on both sides.
fn fold_normals() -> [Vec3; 3] {
    [
        Vec3::Z,
        Vec3::new(0.6, -0.3, 0.2).normalize(),
        Vec3::new(-0.8, 0.1, -0.3).normalize(),
    ]
}

/// Folded onto a hemisphere (untrained, trained, and around a normal the lobes lie on
/// both sides of), the guide's density is 0 below the surface, integrates to 1, and its
/// draws follow it (chi-square); the mixture's density integrates to 1 as well.
#[test]
fn folded_guide_is_normalised_and_follows_its_density() {
    let trained = trained_tree();
    let uniform = QuadTree::uniform();
    let normals = fold_normals();
    for (tree, name) in [(&uniform, "uniform"), (&trained, "trained")] {
        for (i, &n) in normals.iter().enumerate() {
            let guide = VertexGuide::new(tree, n, 0.5, 0.5);
            assert_eq!(guide.pdf(-n), 0.0);
            check_density(
                &format!("{name} guide folded about normal {i}"),
                &Density {
                    value: &|d| guide.pdf(d),
                    draw: &|rng| {
                        let (u1, u2) = rng.pair();
                        Some(guide.sample(Vec2::new(u1, u2)))
                    },
                },
                n,
                1.0,
                2e-2,
                Binning {
                    nz: 10,
                    nphi: 12,
                    sub: 48,
                    draws: 100_000,
                },
                13 + i as u64,
            );
            // The mixture with a cosine "BSDF" (density cos/π above the surface).
            let cosine = |d: Vec3| n.dot(d).max(0.0) * std::f32::consts::FRAC_1_PI;
            let total = mass_in_cone(&|d| guide.mixture_pdf(cosine(d), d), n, 0.5 * PI);
            assert!(
                (total - 1.0).abs() < 2e-2,
                "{name} {i}: ∫ mixture = {total}"
            );
        }
    }
    // Folding moves the trained tree's mass below the surface onto it: the mass above
    // around lobe B's normal is all of it, against the tree's own share above.
    let n = Vec3::new(-0.8, 0.1, -0.3).normalize();
    let above = mass_in_cone(&|d| trained.pdf(d), n, 0.5 * PI);
    assert!(above < 0.9, "the tree's own mass above: {above}");
}

/// A draw's density as the draw finds it (its own leaf cell standing in for a
/// descent) is the folded density at the direction drawn, to the bit, so the mixture
/// divides by the density that BSDF draws of the same direction get: for the uniform
/// and the trained tree, three normals, uniforms on a 65×65 grid (the square's
/// corners and edges among them) and random ones.
#[test]
fn a_draw_carries_its_own_density() {
    let trained = trained_tree();
    let uniform = QuadTree::uniform();
    let normals = fold_normals();
    let mut rng = Rng::seeded(17);
    for tree in [&uniform, &trained] {
        for &n in &normals {
            let guide = VertexGuide::new(tree, n, 0.5, 0.5);
            let edges = (0..=64).flat_map(|i| (0..=64).map(move |j| (i, j)));
            let on_edges = edges.map(|(i, j)| Vec2::new(i as f32, j as f32) / 64.0);
            let random = (0..20_000).map(|_| {
                let (u1, u2) = rng.pair();
                Vec2::new(u1, u2)
            });
            for u in on_edges.chain(random.collect::<Vec<_>>()) {
                let u = u.min(Vec2::splat(1.0 - f32::EPSILON / 2.0));
                let (d, pdf) = guide.sample_with_pdf(u);
                assert_eq!(d, guide.sample(u));
                assert_eq!(pdf.to_bits(), guide.pdf(d).to_bits(), "at {u}");
            }
        }
    }
}

/// The box-filtered deposit adds exactly the value deposited, spreads it over the
/// neighbouring cells of the cell it falls in, and keeps a direction's energy near it.
#[test]
fn filtered_deposits_keep_their_energy() {
    let mut tree = trained_tree().cleared();
    let d = Vec3::new(0.3, 0.4, 0.866).normalize();
    tree.deposit_filtered(d, 2.5);
    assert!(
        (tree.energy() - 2.5).abs() < 1e-9,
        "energy {}",
        tree.energy()
    );
    let mut plain = tree.cleared();
    plain.deposit(d, 2.5);
    // The plain deposit puts everything in the cell of `d`, the filter only part.
    let refined = tree.refined();
    assert!(refined.pdf(d) < plain.refined().pdf(d));
    assert!(refined.pdf(d) > 0.0);
}

/// A spatial tree of one region over `(-1, 1)³` whose records (at the origin) came
/// from around the direction `lobe` (the region's guide concentrates there), filled
/// but not yet refined.
fn filled_towards(lobe: Vec3) -> SdTree {
    let mut tree = SdTree::new((Vec3::splat(-1.0), Vec3::splat(1.0))).cleared();
    let mut rng = Rng::seeded(12);
    for _ in 0..5000 {
        let (u1, u2) = rng.pair();
        let dir = uniform_sphere(u1, u2);
        let value = 10.0 * dir.dot(lobe).max(0.0).powi(20) + 0.01;
        tree.deposit(&Record {
            p: Vec3::ZERO,
            dir,
            value,
            direct: 0.0,
            sky: 0.0,
            shadow: Shadow::Untested,
        });
    }
    tree
}

/// A region's estimate of the light arriving at it (what adjoint-driven roulette goes
/// by) is its irradiance `∫ L |cos θ| dω`: vertices at random points of the region,
/// of normal `y`, each recording the radiance `L(ω) = 3·max(0, ω_y)` along a uniform
/// direction times its cosine `|ω_y|` over its density `1/4π`, and a light sample
/// that found nothing, give `2π` (`∫ max(0, ω_y)² dω = 2π/3`), in every region the
/// refinement splits it into; an untrained tree knows nothing.
#[test]
fn a_region_learns_the_light_arriving_at_it() {
    let mut tree = SdTree::new((Vec3::splat(-1.0), Vec3::splat(1.0)));
    assert_eq!(tree.incident_at(Vec3::ZERO), 0.0);
    tree = tree.cleared();
    let mut rng = Rng::seeded(4);
    let vertices = 200_000;
    for _ in 0..vertices {
        let p = Vec3::new(rng.f32(), rng.f32(), rng.f32()) * 2.0 - Vec3::ONE;
        let (u1, u2) = rng.pair();
        let dir = uniform_sphere(u1, u2);
        let value = 3.0 * dir.y.max(0.0) * dir.y.abs() * 4.0 * PI;
        tree.deposit(&Record {
            p,
            dir,
            value,
            direct: 0.0,
            sky: 0.0,
            shadow: Shadow::Untested,
        });
        let light = uniform_sphere(rng.f32(), rng.f32());
        tree.deposit(&Record {
            p,
            dir: light,
            value: 0.0,
            direct: 0.0,
            sky: 0.0,
            shadow: Shadow::Untested,
        });
    }
    assert_eq!(ember::guiding::RECORDS_PER_VERTEX, 2.0);
    // At the split threshold of 1 spp over a few pixels, the region splits.
    let refined = tree.refined(1, 16, &[]);
    assert!(refined.leaf_count() > 8, "{} regions", refined.leaf_count());
    for p in [Vec3::ZERO, Vec3::splat(0.7), Vec3::new(-0.9, 0.3, -0.5)] {
        let estimate = refined.incident_at(p);
        assert!(
            (estimate - 2.0 * PI).abs() < 0.02 * 2.0 * PI,
            "at {p}: {estimate}, expected {}",
            2.0 * PI
        );
    }
}

/// A base density that varies at random between draws: 0.1 to 2.1 times the
/// uniform density on the hemisphere, 1 in the mean.
fn random_base(u: f32) -> f32 {
    (0.1 + 2.0 * u) / (2.2 * PI)
}

/// Draws at the origin towards directions on the side of `Vec3::Z`, from a mixture
/// (share ½) of a base density and the uniform guide of an untrained tree;
/// `terms(u, g)` gives a draw's base density and integrand from a uniform `u` and the
/// density `g` of the guide the share will be used with.
fn draws_at_origin(
    rng: &mut Rng,
    n: usize,
    guide: &SdTree,
    terms: impl Fn(f32, f32) -> (f32, f32),
) -> Vec<(Vec3, MixtureDraw)> {
    let normal = Vec3::Z;
    let uniform = 1.0 / (2.0 * PI);
    (0..n)
        .map(|_| {
            let (u1, u2) = rng.pair();
            let dir = uniform_sphere(u1, u2);
            let dir = if dir.z < 0.0 { -dir } else { dir };
            let g = guide.guide_at(Vec3::ZERO, normal).pdf(dir);
            let (b, integrand) = terms(rng.f32(), g);
            let m = MixtureDraw {
                integrand,
                base_pdf: b,
                guide_scale: 1.0,
                pdf: 0.5 * b + 0.5 * uniform,
                normal,
            };
            (dir, m)
        })
        .collect()
}

/// The draws as [`GuidedDraw`]s of `kind`, at the origin.
fn guided(draws: &[(Vec3, MixtureDraw)], kind: fn(MixtureDraw) -> Draw) -> Vec<GuidedDraw> {
    let at = |&(dir, m): &(Vec3, MixtureDraw)| GuidedDraw {
        p: Vec3::ZERO,
        dir,
        draw: kind(m),
    };
    draws.iter().map(at).collect()
}

/// The selection probability learnt per region minimises the estimated second moment
/// times the cost of guiding, with the guide the region will use: the one refined
/// from the iteration's records, not the one the draws were made with (here uniform).
/// Draws whose integrand is the new guide's density pick the largest choice; draws
/// whose integrand is the base density pick none (the BSDF alone), and so do draws
/// where the base density is the guide's (every choice has the same second moment,
/// and the guide costs more); too few draws keep ½, and a share without any draw is
/// none. Likewise the share of guided sky samples, learnt
/// from sky draws (whose base is the sky's own density), between its own choices.
#[test]
fn selection_probability_follows_the_second_moment() {
    let filled = filled_towards(Vec3::new(0.2, 0.1, 1.0).normalize());
    let guide = filled.refined(1, SPLIT_REFERENCE_PIXELS, &[]);
    let mut rng = Rng::seeded(9);
    #[derive(Clone, Copy)]
    enum Integrand {
        Guide,
        Bsdf,
        Agreeing,
    }
    let mut train = |integrand: Integrand, n: usize, kind: fn(MixtureDraw) -> Draw| {
        let f = |u: f32, g: f32| match integrand {
            Integrand::Guide => (random_base(u), g),
            Integrand::Bsdf => (random_base(u), random_base(u)),
            Integrand::Agreeing => (g, g * u),
        };
        let draws = draws_at_origin(&mut rng, n, &guide, f);
        let tree = filled.refined(1, SPLIT_REFERENCE_PIXELS, &guided(&draws, kind));
        let same_guide = tree.guide_at(Vec3::ZERO, Vec3::Z).pdf(Vec3::Z);
        assert_eq!(same_guide, guide.guide_at(Vec3::ZERO, Vec3::Z).pdf(Vec3::Z));
        (
            tree.selection_at(Vec3::ZERO),
            tree.sky_share_at(Vec3::ZERO),
            tree.guided_leaf_count(),
        )
    };
    use Integrand::*;
    let few = MIN_SELECTION_DRAWS as usize - 1;
    let half = GUIDE_PROBABILITY;
    let last = *SELECTION_CHOICES.last().unwrap();
    assert_eq!(SELECTION_CHOICES[0], 0.0);
    assert_eq!(train(Guide, 5000, Draw::Scattered), (last, 0.0, 1));
    assert_eq!(train(Bsdf, 5000, Draw::Scattered), (0.0, 0.0, 0));
    assert_eq!(train(Agreeing, 5000, Draw::Scattered), (0.0, 0.0, 0));
    assert_eq!(train(Guide, few, Draw::Scattered), (half, 0.0, 1));
    let last = *SKY_SHARE_CHOICES.last().unwrap();
    assert_eq!(SKY_SHARE_CHOICES[0], 0.0);
    assert_eq!(train(Guide, 5000, Draw::Sky), (0.0, last, 1));
    assert_eq!(train(Bsdf, 5000, Draw::Sky), (0.0, 0.0, 0));
    assert_eq!(train(Agreeing, 5000, Draw::Sky), (0.0, 0.0, 0));
    assert_eq!(train(Guide, few, Draw::Sky), (0.0, half, 1));
    // No draws at all: neither share draws from the guide.
    let tree = filled.refined(1, SPLIT_REFERENCE_PIXELS, &[]);
    assert_eq!(tree.guided_leaf_count(), 0);
}

/// Guiding must pay for its cost: draws where the guide lowers the second moment, but
/// by less than [`GUIDED_COST`], leave the region unguided, and draws where it lowers
/// it by more guide it (the moments computed here from their definition,
/// `Σ F² / (p_s · p)` with the new guide's density, to check that the draws are such
/// cases).
#[test]
fn a_region_guides_only_where_it_pays() {
    let filled = filled_towards(Vec3::new(-0.3, 0.2, 1.0).normalize());
    let guide = filled.refined(1, SPLIT_REFERENCE_PIXELS, &[]);
    let moments = |draws: &[(Vec3, MixtureDraw)], s: f32| -> f64 {
        let term = |(dir, m): &(Vec3, MixtureDraw)| {
            let g = guide.guide_at(Vec3::ZERO, m.normal).pdf(*dir);
            let ps = f64::from((1.0 - s) * m.base_pdf + s * g);
            f64::from(m.integrand).powi(2) / (ps * f64::from(m.pdf))
        };
        draws.iter().map(term).sum()
    };
    let mut rng = Rng::seeded(4);
    for (guide_weight, guides) in [(0.1f32, false), (0.9, true)] {
        let f = |u: f32, g: f32| {
            let b = random_base(u);
            (b, (1.0 - guide_weight) * b + guide_weight * g)
        };
        let draws = draws_at_origin(&mut rng, 5000, &guide, f);
        let unguided = moments(&draws, 0.0);
        let best = SELECTION_CHOICES[1..]
            .iter()
            .map(|&s| moments(&draws, s))
            .fold(f64::INFINITY, f64::min);
        assert!(best < unguided, "the guide lowers the second moment");
        assert_eq!(unguided > GUIDED_COST * best, guides, "{unguided} {best}");
        let tree = filled.refined(1, SPLIT_REFERENCE_PIXELS, &guided(&draws, Draw::Scattered));
        assert_eq!(tree.selection_at(Vec3::ZERO) > 0.0, guides);
        assert_eq!(tree.guided_leaf_count(), usize::from(guides));
    }
}

/// The square `[-1, 1]²` at `y = 0`, of material 0: the floor under the sky tests.
fn floor_quad() -> [([Vec3; 3], u32); 2] {
    quad(
        Vec3::new(-1.0, 0.0, -1.0),
        Vec3::new(1.0, 0.0, -1.0),
        Vec3::new(1.0, 0.0, 1.0),
        Vec3::new(-1.0, 0.0, 1.0),
        0,
    )
}

/// A sky with a gradient and a bright patch (the sky's own sampling prefers it).
fn patchy_sky() -> Environment {
    let (width, height) = (32, 16);
    let mut texels = Vec::new();
    for y in 0..height {
        for x in 0..width {
            let patch = (y == 5 && (10..13).contains(&x)) as u32 as f32;
            texels.push(
                Vec3::new(0.2, 0.3, 0.5) * (1.0 + y as f32 / 8.0) + Vec3::splat(50.0 * patch),
            );
        }
    }
    Environment::new(width, height, texels, 1.0, 20.0)
}

/// The prefetch of a light sample's sky texel replays the sample's own draw: where
/// `sky_uniforms_ahead` predicts a draw from the sky's own distribution, the light
/// sample (unguided, and guided with a share of 0.5) is that draw's direction, and
/// where it predicts none the sample is an emitter's or the guide's. A prefetch of
/// the wrong texel would change no image, only lose the time it saves, so this is
/// what keeps it from drifting out of step with the samplers unnoticed.
#[test]
fn sky_prefetch_replays_the_light_samples_draw() {
    let floor = floor_quad();
    // Facing down, at the floor.
    let lamp = quad(
        Vec3::new(-0.2, 1.0, -0.2),
        Vec3::new(0.2, 1.0, -0.2),
        Vec3::new(0.2, 1.0, 0.2),
        Vec3::new(-0.2, 1.0, 0.2),
        1,
    );
    let materials = vec![
        diffuse(Vec3::splat(0.5), Vec3::ZERO),
        diffuse(Vec3::ZERO, Vec3::splat(5.0)),
    ];
    let built = build(&[floor, lamp].concat(), materials);
    let scene = &built.scene;
    let sky = Arc::new(patchy_sky());
    let lights = LightSampler::new(&scene.mesh, &scene.materials, &scene.textures)
        .with_sky(Some(sky.clone()), 2.0);
    assert!(lights.sky_probability() > 0.0 && lights.sky_probability() < 1.0);
    let tree = trained_tree();
    let at = Receiver {
        p: Vec3::new(0.1, 0.01, 0.2),
        n: Vec3::Y,
    };
    let guide = VertexGuide::new(&tree, Vec3::Y, 0.5, 0.5);
    let (mut predicted, mut not_predicted) = (0, 0);
    for i in 0..4000 {
        let share = (i % 2 == 1).then_some(guide.sky_share());
        let ahead = lights.sky_uniforms_ahead(Rng::for_sample(7, i, 3), share);
        let mut drawing = Rng::for_sample(7, i, 3);
        let (dir, emitter) = match share {
            None => match lights.sample(at, &mut drawing) {
                Some(light) => (light.dir, light.point.is_some()),
                None => continue,
            },
            Some(share) => match lights.draw_with_sky_guide(at, &mut drawing, share, &guide) {
                Some(drawn) => (drawn.dir(), drawn.point().is_some()),
                None => continue,
            },
        };
        match ahead {
            Some((u_row, u_column)) => {
                predicted += 1;
                let own = sky
                    .sample(u_row, u_column)
                    .expect("a draw of the sky's own");
                assert!(!emitter, "sample {i}: an emitter's, predicted the sky's");
                assert_eq!(dir, own.dir, "sample {i}, share {share:?}");
            }
            None => not_predicted += 1,
        }
    }
    // Both outcomes occur: the test compares draws, and skips none of them.
    assert!(
        predicted > 1000 && not_predicted > 1000,
        "{predicted} / {not_predicted}"
    );
}

/// Where the sky is chosen, a light sample's direction comes from the mixture of the
/// sky's own sampling and a guide (trained and folded onto a hemisphere): for several
/// shares, that density integrates to 1 over the sphere, the draws follow it
/// (chi-square), and each sample carries the density and radiance of its direction
/// and the guide's density along it; so do the draws of the book's mixture's light
/// half at a guided vertex ([`GuidedLightPdf`]).
#[test]
fn sky_samples_mixed_with_a_guide_follow_their_density() {
    let floor = floor_quad();
    let built = build(&floor, vec![diffuse(Vec3::splat(0.5), Vec3::ZERO)]);
    let sky = Arc::new(patchy_sky());
    let scene = &built.scene;
    let lights = LightSampler::new(&scene.mesh, &scene.materials, &scene.textures)
        .with_sky(Some(sky.clone()), 2.0);
    let tree = trained_tree();
    let normal = Vec3::new(0.3, 0.2, 0.9).normalize();
    let at = Receiver {
        p: Vec3::ZERO,
        n: normal,
    };
    for share in [0.0, 0.5, 0.9] {
        let guide = VertexGuide::new(&tree, normal, 0.5, share);
        let name = format!("sky mixed with a guide, share {share}");
        check_density(
            &name,
            &Density {
                value: &|d| lights.pdf_sky_guided(d, share, guide.pdf(d)),
                draw: &|rng| {
                    lights
                        .sample_with_sky_guide(at, rng, share, &guide)
                        .map(|(s, _)| s.dir)
                },
            },
            normal,
            1.0,
            2e-2,
            GUIDE_BINNING,
            13,
        );
        let mut rng = Rng::seeded(14);
        for _ in 0..10_000 {
            let (s, guide_pdf) = lights
                .sample_with_sky_guide(at, &mut rng, share, &guide)
                .expect("the sky has light");
            // The guide's density comes with the sample, to the bit.
            assert_eq!(guide_pdf, Some(guide.pdf(s.dir)), "{name}");
            let pdf = lights.pdf_sky_guided(s.dir, share, guide.pdf(s.dir));
            assert!(
                (s.pdf - pdf).abs() <= 1e-4 * pdf,
                "{name}: {} against {pdf}",
                s.pdf
            );
            assert_eq!(s.emission, sky.radiance(s.dir));
        }
        // The book's mixture draws its light half as the same density
        // (`GuidedLightPdf`): its draws follow its value too, aimed at the sky.
        let pdf = GuidedLightPdf {
            at,
            lights: &lights,
            share,
            guide: &guide,
        };
        let name = format!("GuidedLightPdf, share {share}");
        check_density(
            &name,
            &Density {
                value: &|d| pdf.value(d, None),
                draw: &|rng| {
                    let drawn = pdf.generate(rng)?;
                    assert_eq!(drawn.aimed_at, Some(LightTarget::Sky), "{name}");
                    Some(drawn.dir)
                },
            },
            normal,
            1.0,
            2e-2,
            GUIDE_BINNING,
            15,
        );
    }
}

/// A guided path where nothing is drawn from the guide is the unguided path, number for
/// number, with every integrator, under a lamp (to the bit) and under a sky (to
/// rounding, see below): training measures
/// every region with its guide, and with the untrained tree (both shares 0 everywhere)
/// its paths must read the same random numbers for the same purposes as unguided ones.
/// A pixel's first-vertex numbers are one stratified (Sobol) sequence; `sd-tree 8`'s
/// guided step drew a coin of its own before the direction's pair, which moved the
/// pair off the dimensions stratified together and cost the Cornell Original 12% in
/// relMSE with every region unguided.
#[test]
fn a_guided_path_drawing_nothing_from_the_guide_is_the_unguided_one() {
    let kinds = [
        IntegratorKind::Mis,
        IntegratorKind::Bsdf,
        IntegratorKind::Light,
        IntegratorKind::Mixture,
    ];
    // Few paths find the sky through the hole: those scenes take more samples.
    for (scene, built, spp) in [("lamp", box_with_hole(), 8), ("sky", box_under_sky(), 128)] {
        for kind in kinds {
            let tree = SdTree::new((Vec3::splat(-1.0), Vec3::new(1.0, 1.5, 1.0)));
            let unguided = PathTracer::new(&built.scene, &built.accel, 8, kind);
            let guided =
                PathTracer::new(&built.scene, &built.accel, 8, kind).with_guide(Some(&tree));
            let camera = inside_camera(16);
            let (mut records, mut draws) = (Vec::new(), Vec::new());
            let mut count = RayCount::default();
            let mut lit = 0;
            for pixel in 0..256u64 {
                for s in 0..spp {
                    let (ray, mut rng) = camera_sample(&camera, 7, pixel, s);
                    let plain = unguided.sample(ray, &mut rng, &mut count).radiance;
                    let (ray, mut rng) = camera_sample(&camera, 7, pixel, s);
                    let mut recorder = PathRecords::new(&mut records, &mut draws, 1.0);
                    let measured = guided.sample_recorded(ray, &mut rng, &mut count, &mut recorder);
                    // Under the sky the guided light sample's density is the sky
                    // mixture's with share 0, the same number by other arithmetic:
                    // equal to rounding, where other random numbers would differ
                    // wholly. Under the lamp, to the bit.
                    let tolerance = if scene == "sky" { 1e-5 } else { 0.0 };
                    assert!(
                        (measured.radiance - plain).abs().max_element()
                            <= tolerance * plain.max_element(),
                        "{kind:?} under the {scene}, pixel {pixel}, sample {s}: {} against {plain}",
                        measured.radiance
                    );
                    lit += usize::from(plain != Vec3::ZERO);
                }
            }
            // About half of what each found (of 2048 paths under the lamp, 32768
            // under the sky): `bsdf` finds the lamp through the hole by chance only,
            // and `mixture` ends a path at a void light draw.
            let enough = match (kind, scene) {
                (IntegratorKind::Bsdf, "lamp") => 5,
                (IntegratorKind::Mixture, "lamp") => 100,
                (_, "lamp") => 500,
                (IntegratorKind::Mis, _) => 300,
                (IntegratorKind::Bsdf, _) => 200,
                (IntegratorKind::Light, _) => 70,
                (IntegratorKind::Mixture, _) => 50,
            };
            assert!(
                lit > enough,
                "{kind:?} under the {scene}: the paths find light ({lit} of 2048)"
            );
            assert!(
                !records.is_empty(),
                "{kind:?} under the {scene}: training recorded the paths"
            );
        }
    }
}

/// A closed box `[-1, 1]³` (albedo 0.5) with one cell of its ceiling (side 0.25,
/// centred at x = 0.125, z = 0.125) left open, and an emissive quad above the hole,
/// facing down: all light comes in through the hole.
fn box_with_hole() -> Built {
    with_lamp(box_with_hole_walls(), 1.3)
}

/// `walls` (material 0, albedo 0.5) and a lamp: a quad over `x, z ∈ [−0.2, 0.45]` at
/// height `y`, facing down, of radiance 40.
fn with_lamp(mut tris: Vec<([Vec3; 3], u32)>, y: f32) -> Built {
    tris.extend(quad(
        Vec3::new(-0.2, y, -0.2),
        Vec3::new(0.45, y, -0.2),
        Vec3::new(0.45, y, 0.45),
        Vec3::new(-0.2, y, 0.45),
        1,
    ));
    build(
        &tris,
        vec![
            diffuse(Vec3::splat(0.5), Vec3::ZERO),
            diffuse(Vec3::ZERO, Vec3::splat(40.0)),
        ],
    )
}

/// The walls of [`box_with_hole`], material 0.
fn box_with_hole_walls() -> Vec<([Vec3; 3], u32)> {
    let cells = 8;
    let hole = |t: &[Vec3; 3]| {
        let c = (t[0] + t[1] + t[2]) / 3.0;
        c.y > 0.999 && (0.0..0.25).contains(&c.x) && (0.0..0.25).contains(&c.z)
    };
    let tris: Vec<_> = inward_cube(cells, 0)
        .into_iter()
        .filter(|(t, _)| !hole(t))
        .collect();
    assert_eq!(tris.len(), 12 * 64 - 2);
    tris
}

/// The walls of the box with the hole under [`patchy_sky`], with no lamp: the sky
/// lights the inside only through the hole, like a room through its window.
fn box_under_sky() -> Built {
    let mut built = build(
        &box_with_hole_walls(),
        vec![diffuse(Vec3::splat(0.5), Vec3::ZERO)],
    );
    built.scene.sky = Some(Arc::new(patchy_sky()));
    built
}

/// The centre of the hole in the ceiling of [`box_with_hole`], and points on its floor
/// that the guide is checked at.
const HOLE: Vec3 = Vec3::new(0.125, 1.0, 0.125);
const FLOOR_POINTS: [Vec3; 3] = [
    Vec3::new(0.1, -0.99, 0.2),
    Vec3::new(-0.5, -0.99, -0.4),
    Vec3::new(0.5, -0.99, 0.6),
];

fn inside_camera(size: u32) -> Camera {
    CameraSettings {
        eye: Vec3::new(0.0, 0.2, 0.9),
        look_at: Vec3::new(0.0, -0.4, -1.0),
        up: Vec3::Y,
        projection: ember::scene::Projection::perspective(70.0),
        lens: Default::default(),
    }
    .camera(size, size)
}

fn guided_settings(size: u32, spp: u32, iterations: u32) -> RenderSettings {
    RenderSettings {
        width: size,
        height: size,
        spp,
        max_depth: 6,
        seed: 2,
        integrator: IntegratorKind::Mis,
        adaptive: None,
        light_sampler: Default::default(),
        guiding: Some(Guiding { iterations }),
        engine: Default::default(),
    }
}

fn train(built: &Built, settings: &RenderSettings) -> SdTree {
    let tracer = PathTracer::new(
        &built.scene,
        &built.accel,
        settings.max_depth,
        settings.integrator,
    );
    let camera = inside_camera(settings.width);
    let guiding = settings.guiding.expect("a guided render");
    train_guide(&tracer, &camera, settings, guiding, &AtomicUsize::new(0))
        .expect("not stopped")
        .0
}

/// On the floor of the box with the hole, the trained guide puts far more of its
/// mass in the cone towards the hole than the cosine density of the floor's BSDF.
#[test]
fn guide_learns_the_way_to_the_light_through_a_hole() {
    let built = box_with_hole();
    let tree = train(&built, &guided_settings(128, 1, 6));
    eprintln!(
        "box with a hole: {} leaves, {} nodes, {} bytes",
        tree.leaf_count(),
        tree.node_count(),
        tree.memory_bytes()
    );
    assert!(tree.leaf_count() > 1, "the spatial tree split");
    for p in FLOOR_POINTS {
        let axis = (HOLE - p).normalize();
        // The cone holds the hole (half-diagonal 0.18 at distance ≥ 2) with a margin
        // of a few cells of the guide.
        let half_angle = 12f32.to_radians();
        let guide = tree.at(p);
        let guided = mass_in_cone(&|d| guide.pdf(d), axis, half_angle);
        let cosine = cosine_mass_in_cone(Vec3::Y, axis, half_angle);
        eprintln!("floor at {p}: mass towards the hole {guided:.3} guided, {cosine:.4} cosine");
        assert!(
            guided > 3.0 * cosine,
            "at {p}: guided mass {guided:.4} against the cosine's {cosine:.4}"
        );
    }
}

/// The box of [`box_with_hole`] closed, its lamp hung inside under the ceiling: seen
/// from all of the floor.
fn box_with_lamp_inside() -> Built {
    with_lamp(inward_cube(8, 0), 0.9)
}

/// Where the light samples find the lamp, the guide leaves its direct light to them
/// and learns the light the walls reflect: on the floor of a closed box whose lamp
/// hangs in plain sight (and whose back is black, and the ceiling behind it unlit),
/// it puts no more mass in the cone towards the lamp than the floor's cosine density
/// does, where through the hole above (whose lamp the light samples mostly miss) it
/// put more than three times as much.
#[test]
fn guide_leaves_a_lamp_in_plain_sight_to_the_light_samples() {
    let built = box_with_lamp_inside();
    let tree = train(&built, &guided_settings(128, 1, 6));
    let lamp = Vec3::new(0.125, 0.9, 0.125);
    for p in FLOOR_POINTS {
        let axis = (lamp - p).normalize();
        let half_angle = 12f32.to_radians();
        let guided = mass_in_cone(&|d| tree.at(p).pdf(d), axis, half_angle);
        let cosine = cosine_mass_in_cone(Vec3::Y, axis, half_angle);
        eprintln!("floor at {p}: mass towards the lamp {guided:.3} guided, {cosine:.4} cosine");
        assert!(
            guided < cosine,
            "at {p}: guided mass {guided:.4} against the cosine's {cosine:.4}"
        );
    }
}

/// Under a sky that only the hole lets in, the sky guide learns where the sky is seen
/// from the floor: its mixture with the sky's own sampling puts far more mass through
/// the hole than the sky's own sampling, and the sky guide alone more than the guide
/// of all incident light (which also holds the light the walls reflect). And the guided
/// render (both mixtures) converges to the unguided one: relMSE against an unguided
/// reference falls like 1/spp.
#[test]
fn guided_sky_samples_find_the_hole_and_stay_unbiased() {
    let built = box_under_sky();
    let tree = train(&built, &guided_settings(64, 1, 6));
    let scene = &built.scene;
    let lights = LightSampler::new(&scene.mesh, &scene.materials, &scene.textures)
        .with_sky(scene.sky.clone(), 2.0);
    for p in FLOOR_POINTS {
        let axis = (HOLE - p).normalize();
        let half_angle = 12f32.to_radians();
        let guide = tree.guide_at(p, Vec3::Y);
        let share = guide.sky_share();
        let mixed = |d| lights.pdf_sky_guided(d, share, guide.sky_pdf(d));
        let guided = mass_in_cone(&mixed, axis, half_angle);
        let own = mass_in_cone(&|d| lights.pdf_sky(d), axis, half_angle);
        let sky_alone = mass_in_cone(&|d| guide.sky_pdf(d), axis, half_angle);
        let all_light = mass_in_cone(&|d| guide.pdf(d), axis, half_angle);
        eprintln!("floor at {p}: sky share {share}, mass towards the hole {guided:.3} guided, {own:.4} the sky's own, {sky_alone:.3} the sky guide's, {all_light:.3} the guide of all light");
        assert!(guided > 3.0 * own, "at {p}: {guided:.4} against {own:.4}");
        // The sky guide learnt the sky seen directly, not the light the walls
        // reflect, which the guide of all incident light holds too.
        assert!(
            sky_alone > 1.5 * all_light,
            "at {p}: {sky_alone:.4} against {all_light:.4}"
        );
    }
    let camera = inside_camera(24);
    let image = |spp, guiding| {
        let settings = RenderSettings {
            guiding,
            seed: u64::from(spp),
            ..guided_settings(24, spp, 5)
        };
        render(&built.scene, &built.accel, &camera, &settings, &|_| {}).0
    };
    let reference = image(8192, None);
    let error = |spp| {
        let guided = image(spp, Some(Guiding { iterations: 5 }));
        compare(&guided, &reference).expect("same size").rel_mse
    };
    let (low, high) = (error(64), error(256));
    eprintln!("guided under a sky: relMSE {low:.3e} at 64 spp, {high:.3e} at 256 spp");
    assert!(
        high < low / 2.5,
        "relMSE {low:.3e} at 64 spp, {high:.3e} at 256 spp"
    );
}

/// Training folds its records in tile order: the tree is the same on 1 and 2
/// threads, and so is the guided image.
#[test]
fn guided_render_is_the_same_at_any_thread_count() {
    let built = box_with_hole();
    // 4 iterations: samples 0..15 are training's, 15..20 the passes'.
    let settings = guided_settings(24, 20, 4);
    let on = |threads| {
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .expect("pool");
        pool.install(|| {
            let tree = train(&built, &settings);
            let camera = inside_camera(settings.width);
            let (image, stats) = render(&built.scene, &built.accel, &camera, &settings, &|_| {});
            let bits: Vec<u32> = image
                .pixels
                .iter()
                .flat_map(|p| p.to_array().map(f32::to_bits))
                .collect();
            (tree, bits, stats.guiding.expect("trained"))
        })
    };
    let (one, two) = (on(1), on(2));
    assert!(one.0 == two.0, "the trees differ");
    assert_eq!(one.1, two.1, "the images differ");
    assert_eq!(one.2.nodes, one.0.node_count());
    assert!(one.1.iter().any(|&b| f32::from_bits(b) > 0.0));
    // The mixture: half the directions come from the guide.
    assert_eq!(GUIDE_PROBABILITY, 0.5);
}

fn run_film(built: &Built, settings: &RenderSettings, film: Film, stop: Option<u64>) -> Film {
    let camera = inside_camera(settings.width);
    render_stopping(&built.scene, &built.accel, &camera, settings, film, 1, stop)
}

/// Whether two films of one render hold the same samples: counts exactly, sums up to
/// the regrouping of `f64` additions (shards merged).
fn assert_same_samples(a: &Film, b: &Film) {
    for (a, b) in a.pixels.iter().zip(&b.pixels) {
        assert_eq!((a.done, a.kept, a.converged), (b.done, b.kept, b.converged));
        let (a, b) = (a.radiance, b.radiance);
        assert!((a - b).abs().max_element() <= 1e-14 * b.max_element().max(1e-300));
    }
    assert_eq!(a.training.len(), b.training.len());
    for (a, b) in a.training.iter().zip(&b.training) {
        assert_eq!(a.kept, b.kept);
        let (a, b) = (a.sum, b.sum);
        assert!((a - b).abs().max_element() <= 1e-14 * b.max_element().max(1e-300));
    }
}

/// Every process trains the same guide before rendering, and the training's samples
/// are the film's first: a guided render stopped and resumed (during training or
/// after it) equals the uninterrupted one bit for bit, and shards (sample ranges,
/// one cutting through the training's samples) merge to it up to the regrouping of
/// f64 sums.
#[test]
fn guided_renders_resume_and_merge_to_the_uninterrupted_film() {
    let built = box_with_hole();
    // 5 iterations: samples 0..31 are training's, 31..40 the passes'.
    let settings = guided_settings(20, 40, 5);
    let film = |samples| Film::new(settings.width, settings.height, samples);
    let whole = run_film(&built, &settings, film(0..40), None);
    assert!(whole.pixels.iter().all(|p| p.done == 40));
    // Training's share of the sums, which the image weighs apart, is its 31 samples'
    // (every estimate in this box is finite).
    let kept = |(p, t): (&ember::film::PixelSums, &ember::film::Moments)| (p.kept, t.kept);
    assert!(whole
        .pixels
        .iter()
        .zip(&whole.training)
        .all(|pt| kept(pt) == (40, 31)));
    // Stopped in training's second iteration (400 pixels, 400 + 800 samples), and
    // in the passes: at the first tile done of the pass from 32 to 40 spp (tiles of
    // 16, so 64 to 2048 samples each), whichever worker finishes first.
    for (stop, taken) in [(700, 1..31), (400 * 32 + 100, 31..40)] {
        let part = run_film(&built, &settings, film(0..40), Some(stop));
        assert!(
            taken.contains(&part.min_done()),
            "stopped after {stop} samples at {}",
            part.min_done()
        );
        let resumed = run_film(&built, &settings, part, None);
        assert_eq!(resumed, whole, "resumed after {stop} samples");
    }
    for cut in [12, 31] {
        let mut merged = run_film(&built, &settings, film(0..cut), None);
        let rest = run_film(&built, &settings, film(cut..40), None);
        assert!(rest.pixels.iter().all(|p| p.done == 40 - cut));
        merged.merge(&rest);
        assert_same_samples(&merged, &whole);
    }
    // And the guide matters: the unguided film differs.
    let unguided = RenderSettings {
        guiding: None,
        engine: Default::default(),
        ..settings
    };
    assert_ne!(
        run_film(&built, &unguided, film(0..40), None).pixels,
        whole.pixels
    );
}

/// With fewer samples than training takes (6 of 7), the film is training's samples
/// only: a stop during training resumes to the uninterrupted film, and shards merge
/// to it.
#[test]
fn guided_renders_of_fewer_samples_than_training_resume_and_merge() {
    let built = box_with_hole();
    let settings = guided_settings(20, 6, 3);
    let film = |samples| Film::new(settings.width, settings.height, samples);
    let whole = run_film(&built, &settings, film(0..6), None);
    assert!(whole.pixels.iter().all(|p| p.done == 6));
    let part = run_film(&built, &settings, film(0..6), Some(700));
    assert!(part.min_done() < 6, "stopped early");
    let resumed = run_film(&built, &settings, part, None);
    assert_eq!(resumed, whole);
    let mut merged = run_film(&built, &settings, film(0..2), None);
    merged.merge(&run_film(&built, &settings, film(2..6), None));
    assert_same_samples(&merged, &whole);
}

/// Adaptive sampling sees training's samples as the film's: its first decision is
/// taken where training ends (every pixel at 15), and a guided adaptive render
/// stopped during training or in its passes resumes to the uninterrupted film.
#[test]
fn guided_adaptive_renders_resume_to_the_uninterrupted_film() {
    let built = box_with_hole();
    let settings = RenderSettings {
        adaptive: Some(Adaptive {
            threshold: 0.22,
            min_spp: 8,
        }),
        ..guided_settings(20, 64, 4)
    };
    let film = || Film::new(settings.width, settings.height, 0..64);
    let whole = run_film(&built, &settings, film(), None);
    let at = |spp: u32| whole.pixels.iter().filter(|p| p.done == spp).count();
    let (fifteen, all) = (at(15), at(64));
    eprintln!("guided adaptive: of 400 pixels, {fifteen} stopped at 15 spp, {all} took 64");
    assert!(whole.pixels.iter().all(|p| p.done >= 15));
    assert!(fifteen > 0 && fifteen + all < 400 && all > 0);
    for stop in [500, 400 * 20] {
        let part = run_film(&built, &settings, film(), Some(stop));
        assert!(!part.is_complete(), "stopped after {stop} samples");
        let resumed = run_film(&built, &settings, part, None);
        assert_eq!(resumed, whole, "resumed after {stop} samples");
    }
}

/// Training's samples count in the image: in a closed furnace where every surface
/// emits `Le` and reflects with albedo `a`, the radiance along every camera ray is
/// `Le · Σ_{k<N} a^k` (paths of at most N segments). A guided render of exactly the
/// training's samples (15 spp over 4 iterations: none of the passes') finds it.
#[test]
fn training_samples_in_the_image_find_the_furnace_radiance() {
    let albedo = 0.6f32;
    let le = Vec3::new(1.0, 0.5, 0.25);
    let built = build(&inward_cube(4, 0), vec![diffuse(Vec3::splat(albedo), le)]);
    let settings = guided_settings(24, 15, 4);
    let film = run_film(
        &built,
        &settings,
        Film::new(settings.width, settings.height, 0..15),
        None,
    );
    assert!(film.pixels.iter().all(|p| p.done == 15 && p.kept == 15));
    let sums = SampleSums {
        sum: film.pixels.iter().map(|p| p.radiance).sum(),
        sum_sq: film.pixels.iter().map(|p| p.radiance_sq).sum(),
        n: film.total_done() as f64,
    };
    let truth = furnace_radiance(le, albedo, settings.max_depth);
    sums.assert_mean("guided furnace at 15 training spp", truth);
}

/// Camera sample `s` of `pixel` (row-major) of a 16×16 `camera` under `seed`: its ray,
/// and its stream after the camera's draws.
fn camera_sample(camera: &Camera, seed: u64, pixel: u64, s: u64) -> (Ray, Rng) {
    let (x, y) = ((pixel % 16) as f32, (pixel / 16) as f32);
    let mut rng = Rng::for_pixel_sample(seed, pixel, s);
    let (dx, dy) = rng.pair();
    (camera.ray(x + dx, y + dy), rng)
}

/// Adjoint-driven roulette (`ember::integrator`'s `roulette`) keeps a guided render
/// unbiased and does cut paths: in the closed furnace above (albedo 0.4, so that a
/// path's expectation falls below a sixth of its pixel's after a bounce or two), the
/// paths after training find `Le · Σ_{k<N} a^k`, and trace fewer rays than the
/// unguided paths of the same pixels, which at depth 6 play no roulette at all.
#[test]
fn adjoint_roulette_finds_the_furnace_radiance_with_fewer_rays() {
    let albedo = 0.4f32;
    let le = Vec3::new(1.0, 0.5, 0.25);
    let built = build(&inward_cube(4, 0), vec![diffuse(Vec3::splat(albedo), le)]);
    let settings = guided_settings(16, 15, 4);
    assert!(settings.max_depth <= ember::integrator::ROULETTE_START_VERTEX);
    let tree = train(&built, &settings);
    let new_tracer = || {
        PathTracer::new(
            &built.scene,
            &built.accel,
            settings.max_depth,
            IntegratorKind::Mis,
        )
    };
    let (unguided, guided) = (new_tracer(), new_tracer().with_guide(Some(&tree)));
    let camera = inside_camera(16);
    let (mut unguided_rays, mut guided_rays) = (RayCount::default(), RayCount::default());
    let mut sums = SampleSums::default();
    for pixel in 0..256u64 {
        for s in 0..64 {
            let (ray, mut rng) = camera_sample(&camera, 5, pixel, s);
            unguided.sample(ray, &mut rng, &mut unguided_rays);
            let (ray, mut rng) = camera_sample(&camera, 5, pixel, s);
            sums.add(guided.sample(ray, &mut rng, &mut guided_rays).radiance);
        }
    }
    let truth = furnace_radiance(le, albedo, settings.max_depth);
    sums.assert_mean("furnace with adjoint roulette", truth);
    let (guided_rays, unguided_rays) = (guided_rays.rays, unguided_rays.rays);
    eprintln!("rays: {guided_rays} guided against {unguided_rays} unguided");
    assert!(
        (guided_rays as f64) < 0.9 * unguided_rays as f64,
        "roulette cut no paths: {guided_rays} rays against {unguided_rays}"
    );
}

/// Guiding is part of a render's identity (checkpoints and shards of another setting
/// are refused), and unguided renders keep the identity they had before guiding.
#[test]
fn guiding_is_part_of_the_render_identity() {
    let built = box_with_hole();
    let camera = CameraSettings {
        eye: Vec3::ZERO,
        look_at: -Vec3::Z,
        up: Vec3::Y,
        projection: ember::scene::Projection::perspective(40.0),
        lens: Default::default(),
    };
    let id = |guiding| {
        let settings = RenderSettings {
            guiding,
            ..guided_settings(8, 1, 1)
        };
        identity(&built.scene, &camera, &settings, AccelKind::Embree)
    };
    let (none, three, four) = (
        id(None),
        id(Some(Guiding { iterations: 3 })),
        id(Some(Guiding { iterations: 4 })),
    );
    assert_ne!(none, three);
    assert_ne!(three, four);
    assert!(!none.iter().any(|(k, _)| k == "guiding"));
}

fn ember(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_ember"))
        .args(args)
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .output()
        .expect("ember runs")
}

/// `--guiding` guides every integrator; a bad iteration count is refused by clap
/// (its line naming the flag, then where to read more) before any work; a guided render reports its training and its tree, and trains for
/// an eighth of its samples unless told.
#[test]
fn the_guiding_flag() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("guided.png");
    let out = out.to_str().unwrap();
    let common = [
        "render",
        "meshes/CornellBox-Original.obj",
        "-o",
        out,
        "--width",
        "24",
        "--height",
        "24",
        "--spp",
        "2",
        "--guiding",
    ];
    let refused = ember(&[&common[..], &["--guiding-iterations", "0"]].concat());
    let stderr = String::from_utf8_lossy(&refused.stderr);
    assert_eq!(refused.status.code(), Some(2), "{stderr}");
    let first = stderr.lines().next().unwrap_or_default();
    assert!(
        first.starts_with("error:") && first.contains("--guiding-iterations"),
        "{stderr}"
    );
    assert!(!Path::new(out).exists());
    // Every integrator is guided.
    for integrator in ["bsdf", "light", "mixture"] {
        let args = [
            &common[..],
            &["--integrator", integrator, "--guiding-iterations", "2"],
        ];
        let guided = ember(&args.concat());
        let stderr = String::from_utf8_lossy(&guided.stderr);
        assert!(guided.status.success(), "{integrator}: {stderr}");
        assert!(
            stderr.contains("guiding trained in"),
            "{integrator}: {stderr}"
        );
    }
    let guided = ember(&[&common[..], &["--guiding-iterations", "2"]].concat());
    let stderr = String::from_utf8_lossy(&guided.stderr);
    assert!(guided.status.success(), "{stderr}");
    assert!(stderr.contains("guiding trained in"), "{stderr}");
    assert!(stderr.contains("1728 samples"), "3 spp at 24², {stderr}");
    assert!(Path::new(out).is_file());
    // Without --guiding-iterations, training takes at most an eighth of --spp: 3
    // iterations (7 spp) of 64.
    let default = [&common[..9], &["64", "--guiding"]].concat();
    let guided = ember(&default);
    let stderr = String::from_utf8_lossy(&guided.stderr);
    assert!(guided.status.success(), "{stderr}");
    assert!(stderr.contains("(4032 samples"), "7 spp at 24², {stderr}");
}

/// A guided render resumed to more samples without `--guiding-iterations` trains as its
/// checkpoint did (3 iterations at 64 spp, where 128 spp alone would take 4): it
/// resumes, to the image of one 128-spp render with 3 iterations, bit for bit.
#[test]
fn a_guided_resume_to_more_samples_keeps_its_training() {
    let dir = tempfile::tempdir().unwrap();
    let path = |name: &str| dir.path().join(name).to_str().unwrap().to_owned();
    fn common<'a>(out: &'a str, spp: &'a str) -> Vec<&'a str> {
        let scene = "meshes/CornellBox-Original.obj";
        let size = ["--width", "16", "--height", "16", "--guiding"];
        [&["render", scene, "-o", out, "--spp", spp][..], &size[..]].concat()
    }
    let (resumed, whole) = (path("resumed.exr"), path("whole.exr"));
    let keep = ["--checkpoint-every", "3600"];
    let first = ember(&[&common(&resumed, "64")[..], &keep[..]].concat());
    assert!(
        first.status.success(),
        "{}",
        String::from_utf8_lossy(&first.stderr)
    );
    let more = ember(&[&common(&resumed, "128")[..], &["--resume"][..]].concat());
    let stderr = String::from_utf8_lossy(&more.stderr);
    assert!(more.status.success(), "{stderr}");
    let once = ember(&[&common(&whole, "128")[..], &["--guiding-iterations", "3"]].concat());
    assert!(
        once.status.success(),
        "{}",
        String::from_utf8_lossy(&once.stderr)
    );
    assert_eq!(
        std::fs::read(&resumed).unwrap(),
        std::fs::read(&whole).unwrap()
    );
}

/// `--guide-image`'s picture is the learnt density: each pixel's value times its solid
/// angle is the tree's mass over the pixel (the exact integral over the pixel's square
/// cells), the pixels integrate to 1 over the sphere, and the guide's own draws fall
/// into the pixels as often as the image says (chi-square).
#[test]
fn guide_image_shows_the_learnt_density() {
    let tree = trained_tree();
    let bins = 32;
    let masses = square_bin_masses(&tree, bins);
    let image = tree.density_image(bins as u32, bins as u32);
    let pixel_solid_angle = 4.0 * std::f64::consts::PI / (bins * bins) as f64;
    for row in 0..bins {
        for col in 0..bins {
            // Row 0 is z = +1, the square's u = 1; columns are the azimuth, v.
            let (u_bin, v_bin) = (bins - 1 - row, col);
            let shown = f64::from(image[row * bins + col]) * pixel_solid_angle;
            let mass = masses[v_bin * bins + u_bin];
            assert!(
                (shown - mass).abs() <= 1e-6 + 1e-4 * mass,
                "pixel {col},{row}: {shown} shown, {mass} learnt"
            );
        }
    }
    let (w, h) = (256usize, 128usize);
    for (name, tree) in [("uniform", QuadTree::uniform()), ("trained", tree)] {
        let image = tree.density_image(w as u32, h as u32);
        let solid_angle = 4.0 * std::f64::consts::PI / (w * h) as f64;
        let total: f64 = image.iter().map(|&v| f64::from(v) * solid_angle).sum();
        assert!((total - 1.0).abs() < 1e-5, "{name}: ∫ image = {total}");
        // Draws of the guide, binned by the image's pixels (of 16 × 8 = 128 pixels).
        let (cw, ch) = (16usize, 8usize);
        let coarse = tree.density_image(cw as u32, ch as u32);
        let n = 200_000;
        let mut counts = vec![0.0; cw * ch];
        let mut rng = Rng::seeded(11);
        for _ in 0..n {
            let (u1, u2) = rng.pair();
            let p = direction_to_square(tree.sample(Vec2::new(u1, u2)));
            let row = ch - 1 - ((p.x * ch as f32) as usize).min(ch - 1);
            let col = ((p.y * cw as f32) as usize).min(cw - 1);
            counts[row * cw + col] += 1.0;
        }
        let expected: Vec<f64> = coarse
            .iter()
            .map(|&v| f64::from(v) * 4.0 * std::f64::consts::PI / (cw * ch) as f64 * n as f64)
            .collect();
        let (chi2, dof) = chi_square(&counts, &expected);
        let limit = dof as f64 + 5.0 * (2.0 * dof as f64).sqrt();
        assert!(chi2 < limit, "{name}: chi-square {chi2:.1} over {dof} dof");
    }
}

/// The mass of a guide's picture (of `width × height` pixels) within `half_angle` of
/// the unit `axis`, pixels counted by their centre's direction; and its total.
fn picture_mass(picture: &GuidePicture, axis: Vec3, half_angle: f32) -> (f64, f64) {
    let (w, h) = (picture.width as usize, picture.height as usize);
    let solid_angle = 4.0 * std::f64::consts::PI / (w * h) as f64;
    let (mut within, mut total) = (0.0, 0.0);
    for (i, &v) in picture.density.iter().enumerate() {
        let (row, col) = (i / w, i % w);
        let centre =
            Vec2::new((h - 1 - row) as f32 + 0.5, col as f32 + 0.5) / Vec2::new(h as f32, w as f32);
        let mass = f64::from(v) * solid_angle;
        total += mass;
        if square_to_direction(centre).dot(axis) >= half_angle.cos() {
            within += mass;
        }
    }
    (within, total)
}

/// The guide's picture at the floor pixel `(32, 60)` of the box `built` (trained at
/// 64×64), and the unit direction from its vertex to the hole.
fn floor_view(built: &Built) -> (GuideView, Vec3) {
    let settings = guided_settings(64, 1, 6);
    let tree = train(built, &settings);
    let camera = inside_camera(settings.width);
    // The bottom middle of the image sees the floor.
    let view = guide_view(
        &built.scene,
        &built.accel,
        &camera,
        &tree,
        (32, 60),
        settings.max_depth,
        (128, 64),
    )
    .expect("the pixel sees the floor");
    assert!(view.p.y < -0.99, "the floor, not {}", view.p);
    assert_eq!(view.normal, Vec3::Y);
    let hole = (Vec3::new(0.125, 1.0, 0.125) - view.p).normalize();
    (view, hole)
}

/// Seen from a pixel of the floor of the box with a hole, the guide's picture puts its
/// brightest pixels towards the hole, far above the uniform density, and integrates
/// to 1.
#[test]
fn guide_view_from_a_floor_pixel_looks_at_the_hole() {
    let (view, hole) = floor_view(&box_with_hole());
    // The picture's mass within 12° of the hole, against the cosine density's there,
    // as the test above does with the tree.
    let half_angle = 12f32.to_radians();
    let (towards_hole, total) = picture_mass(&view.all_light, hole, half_angle);
    assert!((total - 1.0).abs() < 1e-5, "∫ view = {total}");
    let cosine = cosine_mass_in_cone(Vec3::Y, hole, half_angle);
    let below = view.all_light.below;
    eprintln!("towards the hole {towards_hole:.4} (cosine {cosine:.4}), below {below:.3}");
    assert!(
        towards_hole > 2.0 * cosine,
        "{towards_hole} towards the hole"
    );
    assert!(below < 0.5, "{below} of the mass below the floor");
}

/// Under a sky that only the hole lets in, the picture of the floor's sky guide
/// (`--guide-sky`) integrates to 1 and puts more of its mass towards the hole than
/// the picture of its guide of all light, which also holds the light the walls
/// reflect.
#[test]
fn guide_sky_view_from_a_floor_pixel_looks_at_the_sky_through_the_hole() {
    let (view, hole) = floor_view(&box_under_sky());
    let half_angle = 12f32.to_radians();
    let (sky, total) = picture_mass(&view.sky, hole, half_angle);
    assert!((total - 1.0).abs() < 1e-5, "∫ sky view = {total}");
    let (all_light, _) = picture_mass(&view.all_light, hole, half_angle);
    eprintln!("towards the hole: sky guide {sky:.3}, guide of all light {all_light:.3}");
    assert!(sky > 1.5 * all_light, "{sky:.4} against {all_light:.4}");
}

/// `--guide-image` writes the picture of the guide at a pixel; a pixel outside the
/// image is refused in one line before any work, and nothing is written.
#[test]
fn the_guide_image_flag() {
    let dir = tempfile::tempdir().unwrap();
    let (out, guide) = (dir.path().join("guided.png"), dir.path().join("guide.exr"));
    let (out, guide) = (out.to_str().unwrap(), guide.to_str().unwrap());
    let common = [
        "render",
        "meshes/CornellBox-Original.obj",
        "-o",
        out,
        "--width",
        "24",
        "--height",
        "24",
        "--spp",
        "2",
        "--guiding",
        "--guiding-iterations",
        "2",
        "--guide-image",
        guide,
    ];
    let refused = ember(&[&common[..], &["--guide-pixel", "24,3"]].concat());
    let stderr = String::from_utf8_lossy(&refused.stderr);
    assert!(!refused.status.success());
    assert_eq!(stderr.trim().lines().count(), 1, "{stderr}");
    assert!(
        stderr.starts_with("error:") && stderr.contains("--guide-pixel"),
        "{stderr}"
    );
    assert!(!Path::new(out).exists() && !Path::new(guide).exists());
    let written = ember(&[&common[..], &["--guide-pixel", "12,20"]].concat());
    let stderr = String::from_utf8_lossy(&written.stderr);
    assert!(written.status.success(), "{stderr}");
    let integral = || {
        let image = ember::image::Image::load(Path::new(guide)).expect("the guide image");
        assert_eq!((image.width, image.height), (256, 128));
        let solid_angle = 4.0 * std::f64::consts::PI / (256.0 * 128.0);
        let pixels = image.pixels.iter();
        pixels.map(|p| f64::from(p.x) * solid_angle).sum::<f64>()
    };
    let total = integral();
    assert!((total - 1.0).abs() < 1e-4, "∫ image = {total}");
    assert!(stderr.contains("the guide at pixel 12,20"), "{stderr}");
    // The sky's guide of a box without a sky is the untrained, uniform one.
    let sky = ember(&[&common[..], &["--guide-pixel", "12,20", "--guide-sky"]].concat());
    let stderr = String::from_utf8_lossy(&sky.stderr);
    assert!(sky.status.success(), "{stderr}");
    assert!(
        stderr.contains("the sky's guide at pixel 12,20"),
        "{stderr}"
    );
    let total = integral();
    assert!((total - 1.0).abs() < 1e-4, "∫ sky image = {total}");
}
