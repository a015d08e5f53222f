//! The same seed gives the same image whatever the thread count, the accelerator's build
//! included: rendered on 1 and on 2 threads (rayon workers, and Embree's build threads),
//! images are equal bit for bit, for both backends and every integrator.
//!
//! The scene is the Cornell box with every wall triangle doubled by a coplanar duplicate
//! of another material, so which of two triangles at the same distance a ray reports shows
//! in the image: a tree that changed with the thread count would change the picture.
//!
//! Only the public rendering API is used, so the test does not follow the integrator's
//! internals.

use std::path::Path;

use ember::accel::{Accel, Bvh, EmbreeAccel};
use ember::embree::{BuildQuality, Device};
use ember::integrator::IntegratorKind;
use ember::render::{render, RenderSettings};
use ember::scene::{load_obj, CameraSettings, Scene};

/// Every integrator. A new variant stops this from compiling until it is listed.
fn integrators() -> [IntegratorKind; 4] {
    let all = [
        IntegratorKind::Bsdf,
        IntegratorKind::Light,
        IntegratorKind::Mixture,
        IntegratorKind::Mis,
    ];
    for kind in all {
        match kind {
            IntegratorKind::Bsdf
            | IntegratorKind::Light
            | IntegratorKind::Mixture
            | IntegratorKind::Mis => {}
        }
    }
    all
}

/// The Cornell box with a coplanar copy of every triangle that does not emit, in
/// another material that does not emit either (the light stays single, so the image is
/// not black).
fn doubled_cornell() -> Scene {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("meshes/CornellBox-Original.obj");
    let (scene, _) = load_obj(&path).expect("the Cornell box ships with ember");
    let mut mesh = scene.mesh.clone();
    let dull: Vec<u32> = (0..scene.materials.len() as u32)
        .filter(|&m| !scene.materials[m as usize].is_emissive())
        .collect();
    for t in 0..scene.mesh.triangles.len() {
        let m = scene.mesh.material[t];
        if let Some(k) = dull.iter().position(|&d| d == m) {
            mesh.triangles.push(scene.mesh.triangles[t]);
            mesh.material.push(dull[(k + 1) % dull.len()]);
        }
    }
    Scene::new(mesh, scene.materials, scene.textures)
}

fn pool(threads: usize) -> rayon::ThreadPool {
    rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .expect("thread pool")
}

/// The image's bits, rendered with `accel` on the pool.
fn image<A: Accel>(
    scene: &Scene,
    accel: &A,
    kind: IntegratorKind,
    pool: &rayon::ThreadPool,
) -> Vec<u32> {
    let (lo, hi) = scene.bounds();
    let camera = CameraSettings::framing(lo, hi, 40.0).camera(40, 40);
    let settings = RenderSettings {
        width: 40,
        height: 40,
        spp: 4,
        max_depth: 5,
        seed: 11,
        integrator: kind,
        light_sampler: Default::default(),
        adaptive: None,
        guiding: None,
        engine: Default::default(),
    };
    let (film, _) = pool.install(|| render(scene, accel, &camera, &settings, &|_| {}));
    film.pixels
        .iter()
        .flat_map(|p| p.to_array())
        .map(f32::to_bits)
        .collect()
}

/// Renders every integrator with the accelerator `build` makes on 1 and on 2 threads.
fn same_images_on_1_and_2_threads<A: Accel>(scene: &Scene, build: impl Fn(usize) -> A) {
    let (one, two) = (pool(1), pool(2));
    let (a1, a2) = (build(1), build(2));
    for kind in integrators() {
        let (i1, i2) = (image(scene, &a1, kind, &one), image(scene, &a2, kind, &two));
        let differ = i1.iter().zip(&i2).filter(|(a, b)| a != b).count();
        assert_eq!(
            differ,
            0,
            "{} {kind:?}: {differ} channels differ",
            a1.name()
        );
        assert!(
            i1.iter().any(|&b| f32::from_bits(b) > 0.0),
            "{kind:?}: black image"
        );
    }
}

#[test]
fn native_bvh_images_do_not_depend_on_the_thread_count() {
    let scene = doubled_cornell();
    let (v, t) = (&scene.mesh.positions, &scene.mesh.triangles);
    same_images_on_1_and_2_threads(&scene, |threads| {
        pool(threads).install(|| Bvh::build(v, t).expect("BVH builds"))
    });
}

#[test]
fn embree_images_do_not_depend_on_the_thread_count() {
    let scene = doubled_cornell();
    let (v, t) = (&scene.mesh.positions, &scene.mesh.triangles);
    same_images_on_1_and_2_threads(&scene, |threads| {
        let device = Device::new(&format!("threads={threads}")).expect("Embree device");
        EmbreeAccel::build(&device, v, t, BuildQuality::High).expect("Embree builds")
    });
}
