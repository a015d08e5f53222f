//! Instanced scenes against the same meshes baked into world space: images (below)
//! and the accelerators' hits.
//!
//! Two-level acceleration (instances) against the same mesh baked into world space by
//! `scene::compose`: on Embree and on the native BVH, under a rotation, non-uniform
//! scales and two mirrors, with overlapping placements, with and without a cut-out
//! filter, 50 000 random rays give the same hits (triangle, distance, barycentrics) and
//! the same occlusion, except where rounding decides: a ray that meets a triangle
//! within 10⁻³ of its edge, where the baked and the instanced mesh (rounded in
//! different spaces) may pick different neighbours.

mod common;

use std::path::Path;
use std::sync::Arc;

use common::{emitted_power, mean_relative_difference, small_mis_settings};
use ember::accel::{
    instanced_bvh, instanced_embree, instanced_filtered_bvh, Accel, Bvh, EmbreeAccel, Hit,
    HitFilter, Instance, InstancedBvh, Ray,
};
use ember::embree::{BuildQuality, Device};

use ember::render::render;
use ember::sampling::Rng;
use ember::scene::{compose, load_obj, mirrors, place, CameraSettings, Placement, Scene};
use glam::{Affine3A, Quat, Vec3};

/// Rays of the test.
const RAYS: usize = 50_000;
/// Barycentric distance from an edge within which the two structures may disagree.
const EDGE: f32 = 1e-3;

fn sphere_box() -> Scene {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("meshes/CornellBox-Sphere.obj");
    load_obj(&path).expect("bundled sphere box loads").0
}

/// Five placements of mesh 0: a rotation, a non-uniform scale, a mirror in x with a
/// skew rotation, a mirror in z under non-uniform scale (overlapping the second), and
/// the mesh where it is.
fn instances() -> Vec<Instance> {
    let place = |scale: Vec3, axis: Vec3, degrees: f32, at: Vec3| Instance {
        mesh: 0,
        transform: Affine3A::from_scale_rotation_translation(
            scale,
            Quat::from_axis_angle(axis.normalize(), degrees.to_radians()),
            at,
        ),
    };
    vec![
        place(Vec3::ONE, Vec3::Y, 30.0, Vec3::new(-3.1, 0.2, 0.3)),
        place(
            Vec3::new(1.7, 0.6, 1.1),
            Vec3::new(1.0, 2.0, 0.5),
            20.0,
            Vec3::new(2.9, -0.4, 0.1),
        ),
        place(
            Vec3::new(-1.3, 0.9, 1.2),
            Vec3::new(1.0, 2.0, 3.0),
            50.0,
            Vec3::new(0.4, 3.3, -1.7),
        ),
        place(
            Vec3::new(0.8, 1.4, -0.7),
            Vec3::new(-2.0, 1.0, 1.0),
            65.0,
            Vec3::new(3.6, 0.3, 0.9),
        ),
        Instance {
            mesh: 0,
            transform: Affine3A::IDENTITY,
        },
    ]
}

/// The mesh of `scene` baked once per instance.
fn baked(scene: &Scene, instances: &[Instance]) -> Scene {
    let placements: Vec<Placement<'_>> = instances
        .iter()
        .map(|i| Placement {
            scene,
            transform: i.transform,
        })
        .collect();
    compose(&placements)
}

/// Rays from a sphere around the world's box towards points inside it, half of them
/// segments that end at that point.
fn rays(lo: Vec3, hi: Vec3) -> Vec<Ray> {
    let mut rng = Rng::seeded(23);
    let centre = 0.5 * (lo + hi);
    let radius = (hi - lo).length();
    (0..RAYS)
        .map(|i| {
            let target = lo + (hi - lo) * Vec3::new(rng.f32(), rng.f32(), rng.f32());
            let z = 2.0 * rng.f32() - 1.0;
            let phi = std::f32::consts::TAU * rng.f32();
            let r = (1.0 - z * z).max(0.0).sqrt();
            let origin = centre + radius * Vec3::new(r * phi.cos(), r * phi.sin(), z);
            match i % 2 {
                0 => Ray::new(origin, target - origin),
                _ => Ray::segment(origin, target - origin, 1.0),
            }
        })
        .collect()
}

/// Whether a hit lies within [`EDGE`] of its triangle's edge.
fn near_edge(hit: &Hit) -> bool {
    hit.u.min(hit.v).min(1.0 - hit.u - hit.v) < EDGE
}

/// An instanced hit as the baked mesh numbers it: triangle `instance · n + prim`, with
/// `u` and `v` swapped where the instance mirrors (the baked triangle's corners are).
fn as_baked(hit: &Hit, instances: &[Instance], triangles: usize) -> Hit {
    let mirrored = mirrors(&instances[hit.instance as usize].transform);
    let (u, v) = if mirrored {
        (hit.v, hit.u)
    } else {
        (hit.u, hit.v)
    };
    Hit {
        prim: hit.instance * triangles as u32 + hit.prim,
        u,
        v,
        instance: 0,
        ..*hit
    }
}

/// Whether two hits of one ray (both in the baked numbering) are the same.
fn same(a: &Hit, b: &Hit) -> bool {
    a.prim == b.prim
        && (a.t - b.t).abs() <= 1e-4 * a.t.abs().max(b.t.abs())
        && (a.u - b.u).abs() < 1e-3
        && (a.v - b.v).abs() < 1e-3
}

/// Compares every ray's nearest hit and occlusion in `instanced` and `baked`; panics
/// on a disagreement away from an edge or on more edge disagreements than 0.1% of
/// rays. Returns how many rays hit something.
fn agree(
    name: &str,
    instanced: &impl Accel,
    baked: &impl Accel,
    rays: &[Ray],
    instances: &[Instance],
    triangles: usize,
) -> usize {
    let (mut hits, mut at_edges) = (0, 0);
    for (i, ray) in rays.iter().enumerate() {
        let a = instanced
            .intersect(ray)
            .map(|h| as_baked(&h, instances, triangles));
        let b = baked.intersect(ray);
        hits += usize::from(b.is_some());
        let agreed = match (&a, &b) {
            (None, None) => true,
            (Some(a), Some(b)) => same(a, b),
            _ => false,
        };
        let occlusion_agreed = instanced.occluded(ray) == baked.occluded(ray);
        if agreed && occlusion_agreed {
            continue;
        }
        assert!(
            a.iter().chain(&b).all(near_edge),
            "{name}: ray {i} {ray:?}: instanced {a:?}, baked {b:?}"
        );
        at_edges += 1;
    }
    assert!(
        at_edges <= rays.len() / 1000,
        "{name}: {at_edges} rays disagree at edges"
    );
    eprintln!("{name}: {hits} hits, {at_edges} at edges");
    hits
}

/// Rejects every third triangle of the mesh, wherever it is placed.
struct EveryThird {
    triangles: u32,
}

impl HitFilter for EveryThird {
    fn accept(&self, prim: u32, _u: f32, _v: f32) -> bool {
        !(prim % self.triangles).is_multiple_of(3)
    }
}

#[test]
fn instances_are_hit_as_the_baked_mesh_on_both_backends() {
    let scene = sphere_box();
    let instances = instances();
    assert_eq!(
        instances.iter().filter(|i| mirrors(&i.transform)).count(),
        2
    );
    let world = baked(&scene, &instances);
    let (lo, hi) = world.bounds();
    let rays = rays(lo, hi);
    let (v, t) = (&scene.mesh.positions, &scene.mesh.triangles);
    let (wv, wt) = (&world.mesh.positions, &world.mesh.triangles);
    let n = t.len();
    let bounds = {
        let (lo, hi) = scene.bounds();
        [lo, hi]
    };

    let device = Device::new("").unwrap();
    let quality = BuildQuality::Medium;
    let mesh = EmbreeAccel::build(&device, v, t, quality).unwrap();
    let embree = EmbreeAccel::build_instanced(&device, vec![mesh], &instances, quality).unwrap();
    let embree_baked = EmbreeAccel::build(&device, wv, wt, quality).unwrap();
    let hits = agree("embree", &embree, &embree_baked, &rays, &instances, n);
    assert!(
        hits > RAYS / 4,
        "only {hits} rays hit: the test sees too little"
    );

    let bvh = InstancedBvh::build(vec![(Bvh::build(v, t).unwrap(), bounds)], &instances).unwrap();
    let bvh_baked = Bvh::build(wv, wt).unwrap();
    agree("bvh", &bvh, &bvh_baked, &rays, &instances, n);
    // And the two instanced structures against each other (Embree's hits numbered as
    // the baked mesh's, so both sides of the comparison are in one numbering).
    agree("embree/bvh", &bvh, &embree_baked, &rays, &instances, n);

    // Cut-outs: each placed mesh keeps its filter.
    let filter = || {
        Arc::new(EveryThird {
            triangles: n as u32,
        })
    };
    let mesh = EmbreeAccel::build_filtered(&device, v, t, quality, filter()).unwrap();
    let embree = EmbreeAccel::build_instanced(&device, vec![mesh], &instances, quality).unwrap();
    let embree_baked = EmbreeAccel::build_filtered(&device, wv, wt, quality, filter()).unwrap();
    agree(
        "embree cut-outs",
        &embree,
        &embree_baked,
        &rays,
        &instances,
        n,
    );
    let filtered = Bvh::build(v, t).unwrap().with_filter(filter());
    let bvh = InstancedBvh::build(vec![(filtered, bounds)], &instances).unwrap();
    let bvh_baked = Bvh::build(wv, wt).unwrap().with_filter(filter());
    agree("bvh cut-outs", &bvh, &bvh_baked, &rays, &instances, n);
}

#[test]
fn bad_placements_are_refused_on_both_backends() {
    let scene = sphere_box();
    let (v, t) = (&scene.mesh.positions, &scene.mesh.triangles);
    let device = Device::new("").unwrap();
    let quality = BuildQuality::Low;
    let flat = Instance {
        mesh: 0,
        transform: Affine3A::from_scale(Vec3::new(1.0, 1.0, 0.0)),
    };
    let infinite = Instance {
        mesh: 0,
        transform: Affine3A::from_translation(Vec3::new(0.0, f32::INFINITY, 0.0)),
    };
    let unknown = Instance {
        mesh: 1,
        transform: Affine3A::IDENTITY,
    };
    for bad in [flat, infinite, unknown] {
        let mesh = EmbreeAccel::build(&device, v, t, quality).unwrap();
        let built = EmbreeAccel::build_instanced(&device, vec![mesh], &[bad], quality);
        assert!(built.is_err(), "Embree placed {bad:?}");
        let bvh = Bvh::build(v, t).unwrap();
        let bounds = [Vec3::ZERO, Vec3::ONE];
        assert!(InstancedBvh::build(vec![(bvh, bounds)], &[bad]).is_err());
    }
    let other = Device::new("").unwrap();
    let foreign = EmbreeAccel::build(&other, v, t, quality).unwrap();
    let placed = Instance {
        mesh: 0,
        transform: Affine3A::IDENTITY,
    };
    let built = EmbreeAccel::build_instanced(&device, vec![foreign], &[placed], quality);
    let message = built.err().expect("a foreign scene is refused").to_string();
    assert!(message.contains("another device"), "{message}");
}

#[test]
fn an_instanced_scene_renders_as_the_baked_one_on_both_backends() {
    let box_scene = sphere_box();
    assert!(!box_scene.mesh.normals.is_empty());
    let instances = instances();
    let world = baked(&box_scene, &instances);
    let placed = place(&[&box_scene], instances.clone()).unwrap();
    assert_eq!(placed.mesh.triangles.len(), box_scene.mesh.triangles.len());
    // Every instance of the light is an emitter of its own, with the baked power.
    assert_eq!(placed.emitters.len(), world.emitters.len());
    let (p, b) = (emitted_power(&placed), emitted_power(&world));
    assert!((p / b - 1.0).abs() < 1e-5, "placed {p}, baked {b}");

    let (lo, hi) = world.bounds();
    let camera = CameraSettings::framing(lo, hi, 50.0).camera(64, 64);
    let s = small_mis_settings();
    let device = Device::new("").unwrap();
    let quality = BuildQuality::High;
    let instancing = placed.instancing.as_deref().unwrap();
    let embree = instanced_embree(&device, &placed.mesh, instancing, quality, None).unwrap();
    let bvh = instanced_bvh(&placed.mesh, instancing).unwrap();
    let (wv, wt) = (&world.mesh.positions, &world.mesh.triangles);
    let baked_embree = EmbreeAccel::build(&device, wv, wt, quality).unwrap();
    let baked_bvh = Bvh::build(wv, wt).unwrap();
    let placed_embree = render(&placed, &embree, &camera, &s, &|_| {}).0;
    let placed_bvh = render(&placed, &bvh, &camera, &s, &|_| {}).0;
    let world_embree = render(&world, &baked_embree, &camera, &s, &|_| {}).0;
    let world_bvh = render(&world, &baked_bvh, &camera, &s, &|_| {}).0;
    for (name, a, b) in [
        ("embree", &placed_embree, &world_embree),
        ("bvh", &placed_bvh, &world_bvh),
        ("embree against bvh", &placed_embree, &placed_bvh),
    ] {
        let d = mean_relative_difference(a, b);
        eprintln!("{name}: mean relative difference {d:.2e}");
        assert!(d < 1e-3, "{name}: mean relative difference {d:.2e}");
    }
    let mean: f64 = placed_embree
        .pixels
        .iter()
        .map(|p| f64::from(p.element_sum()))
        .sum::<f64>()
        / placed_embree.pixels.len() as f64;
    assert!(mean > 0.01, "mean {mean}: the placed boxes are dark");
}

/// The Cornell box whose tall box is a full cut-out (opacity 0: never hit, a
/// decision with no coin in it, so that the baked and the instanced scene agree
/// point for point).
fn box_without_tall_box() -> Scene {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("meshes/CornellBox-Original.obj");
    let mut scene = load_obj(&path).expect("bundled box loads").0;
    let tall = scene.materials.iter_mut().find(|m| m.name == "tallBox");
    tall.expect("the box has a tall box").opacity = 0.0;
    scene
}

#[test]
fn two_distinct_meshes_with_cut_outs_render_as_the_baked_scene() {
    let (sphere, cut) = (sphere_box(), box_without_tall_box());
    let mut instances = instances();
    for (i, at) in [
        (0, Vec3::new(-4.0, -3.0, 0.5)),
        (1, Vec3::new(1.5, -3.2, -0.4)),
    ] {
        let scale = if i == 0 {
            Vec3::ONE
        } else {
            Vec3::new(1.2, 0.9, -1.1)
        };
        instances.push(Instance {
            mesh: 1,
            transform: Affine3A::from_scale_rotation_translation(
                scale,
                Quat::from_rotation_y(0.4 + i as f32),
                at,
            ),
        });
    }
    let placements: Vec<Placement<'_>> = instances
        .iter()
        .map(|i| Placement {
            scene: [&sphere, &cut][i.mesh as usize],
            transform: i.transform,
        })
        .collect();
    let world = compose(&placements);
    let placed = place(&[&sphere, &cut], instances).unwrap();
    let instancing = placed.instancing.as_deref().unwrap();
    // The cut-out triangles are those of the second mesh, after the first's.
    let (world_cut, placed_cut) = (world.opacity().unwrap(), placed.opacity().unwrap());
    let n = sphere.mesh.triangles.len() as u32;
    assert!((0..n).all(|t| placed_cut.opacity(t, 0.3, 0.3) == 1.0));
    assert!((n..placed.mesh.triangles.len() as u32).any(|t| placed_cut.opacity(t, 0.3, 0.3) == 0.0));

    let (lo, hi) = world.bounds();
    let camera = CameraSettings::framing(lo, hi, 50.0).camera(64, 64);
    let s = small_mis_settings();
    let device = Device::new("").unwrap();
    let quality = BuildQuality::High;
    let (wv, wt) = (&world.mesh.positions, &world.mesh.triangles);
    let embree = instanced_embree(
        &device,
        &placed.mesh,
        instancing,
        quality,
        Some(&placed_cut),
    );
    let baked_embree = EmbreeAccel::build_filtered(&device, wv, wt, quality, world_cut.clone());
    let bvh = instanced_filtered_bvh(&placed.mesh, instancing, &placed_cut).unwrap();
    let baked_bvh = Bvh::build(wv, wt).unwrap().with_filter(world_cut);
    let placed_embree = render(&placed, &embree.unwrap(), &camera, &s, &|_| {}).0;
    let world_embree = render(&world, &baked_embree.unwrap(), &camera, &s, &|_| {}).0;
    let placed_bvh = render(&placed, &bvh, &camera, &s, &|_| {}).0;
    let world_bvh = render(&world, &baked_bvh, &camera, &s, &|_| {}).0;
    for (name, a, b) in [
        ("embree", &placed_embree, &world_embree),
        ("bvh", &placed_bvh, &world_bvh),
    ] {
        let d = mean_relative_difference(a, b);
        eprintln!("{name}, two meshes with cut-outs: mean relative difference {d:.2e}");
        assert!(d < 1e-3, "{name}: mean relative difference {d:.2e}");
    }
}
