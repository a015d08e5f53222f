//! Scenes built in code for the sampling and integrator tests.
#![allow(dead_code)]

pub mod bsdf;
pub mod exr;
pub mod fuzz;
pub mod gltf;
pub mod ply;
pub mod stats;

use std::path::Path;
use std::process::{Command, Output};

use ember::accel::EmbreeAccel;
use ember::embree::{BuildQuality, Device};
use ember::image::Image;
use ember::scene::{Material, Scene, TriangleMesh};
use glam::{DVec3, Vec3};

/// The camera of the Cornell references (Mitsuba's), as `ember render` flags.
pub const CORNELL_CAMERA: [&str; 6] = ["--eye", "0,1,3.9", "--look-at", "0,1,0", "--fov", "40"];

/// Runs this build's `ember` with `args` in the directory `dir`.
pub fn ember_in(args: &[&str], dir: &Path) -> Output {
    Command::new(env!("CARGO_BIN_EXE_ember"))
        .args(args)
        .current_dir(dir)
        .output()
        .expect("ember runs")
}

/// A scene and the Embree structure over it.
pub struct Built {
    pub scene: Scene,
    pub accel: EmbreeAccel,
    // Declared last: dropped after the accelerator that uses it.
    _device: Device,
}

/// Triangles as (vertices, material index), with their materials.
pub fn build(triangles: &[([Vec3; 3], u32)], materials: Vec<Material>) -> Built {
    let mut positions = Vec::new();
    let mut tris = Vec::new();
    let mut material = Vec::new();
    for (verts, m) in triangles {
        let base = positions.len() as u32;
        positions.extend_from_slice(verts);
        tris.push([base, base + 1, base + 2]);
        material.push(*m);
    }
    let mesh = TriangleMesh {
        positions,
        normals: Vec::new(),
        uvs: Vec::new(),
        triangles: tris,
        material,
        colours: Vec::new(),
    };
    with_embree(Scene::new(mesh, materials, Vec::new()))
}

/// `scene` with an Embree structure built over it.
pub fn with_embree(scene: Scene) -> Built {
    let device = Device::new("").expect("Embree device");
    let accel = EmbreeAccel::build(
        &device,
        &scene.mesh.positions,
        &scene.mesh.triangles,
        BuildQuality::High,
    )
    .expect("Embree scene");
    Built {
        scene,
        accel,
        _device: device,
    }
}

pub fn diffuse(albedo: Vec3, emission: Vec3) -> Material {
    Material {
        diffuse: albedo,
        emission,
        ..Material::default()
    }
}

/// An emitter of radiance 1, a square of side `side` centred on the z axis in the
/// plane at `z`, facing +z; nothing else.
pub fn emitting_square(z: f32, side: f32) -> Built {
    let h = 0.5 * side;
    let tris = quad(
        Vec3::new(-h, -h, z),
        Vec3::new(h, -h, z),
        Vec3::new(h, h, z),
        Vec3::new(-h, h, z),
        0,
    );
    build(&tris, vec![diffuse(Vec3::ZERO, Vec3::ONE)])
}

/// The two triangles of the quad `a b c d` (counter-clockwise seen from the side its
/// normal points to).
pub fn quad(a: Vec3, b: Vec3, c: Vec3, d: Vec3, material: u32) -> [([Vec3; 3], u32); 2] {
    [([a, b, c], material), ([a, c, d], material)]
}

/// The cube `[-1, 1]³` with each face cut into `cells × cells` quads (2 triangles
/// each), wound so that all normals point inwards: `12 · cells²` triangles.
pub fn inward_cube(cells: u32, material: u32) -> Vec<([Vec3; 3], u32)> {
    let mut tris = Vec::new();
    let step = 2.0 / cells as f32;
    for axis in 0..3 {
        for sign in [-1.0f32, 1.0] {
            // Face at coordinate `axis` = sign; u, v span the other two axes.
            let (u, v) = ((axis + 1) % 3, (axis + 2) % 3);
            let corner = |a: f32, b: f32| {
                let mut p = [0.0f32; 3];
                p[axis] = sign;
                p[u] = a;
                p[v] = b;
                Vec3::from_array(p)
            };
            let mut inward = [0.0f32; 3];
            inward[axis] = -sign;
            let inward = Vec3::from_array(inward);
            for i in 0..cells {
                for j in 0..cells {
                    let (a0, b0) = (-1.0 + i as f32 * step, -1.0 + j as f32 * step);
                    let (a1, b1) = (a0 + step, b0 + step);
                    let (p00, p10, p11, p01) = (
                        corner(a0, b0),
                        corner(a1, b0),
                        corner(a1, b1),
                        corner(a0, b1),
                    );
                    // u × v points along +axis; inwards is -sign along the axis.
                    let cell = if sign > 0.0 {
                        quad(p00, p01, p11, p10, material)
                    } else {
                        quad(p00, p10, p11, p01, material)
                    };
                    for t in cell {
                        let n = (t.0[1] - t.0[0]).cross(t.0[2] - t.0[0]);
                        assert!(n.dot(inward) > 0.0, "cube triangle faces outwards");
                        tris.push(t);
                    }
                }
            }
        }
    }
    tris
}

/// Renders `film` on with `render_progressive` on the current rayon pool, stopping once
/// `stop_after` more samples were taken (the stop flag is checked before each sample, so
/// this lands inside tiles and pixels). Checks the reported sample count.
#[allow(clippy::too_many_arguments)]
pub fn render_stopping<A: ember::accel::Accel>(
    scene: &Scene,
    accel: &A,
    camera: &ember::scene::Camera,
    settings: &ember::render::RenderSettings,
    film: ember::film::Film,
    first_pass_spp: u32,
    stop_after: Option<u64>,
) -> ember::film::Film {
    use std::sync::atomic::{AtomicU64, AtomicUsize, Ordering};
    let stop = AtomicUsize::new(0);
    let taken = AtomicU64::new(0);
    let on_samples = |n: u64| {
        let total = taken.fetch_add(n, Ordering::Relaxed) + n;
        if stop_after.is_some_and(|limit| total >= limit) {
            stop.store(2, Ordering::Relaxed);
        }
    };
    let control = ember::render::RenderControl {
        stop: &stop,
        on_samples: &on_samples,
        first_pass_spp,
        checkpoint: None,
        deadline: None,
        on_pass: &|_| {},
        on_guide: None,
    };
    let (film, stats) =
        ember::render::render_progressive(scene, accel, camera, settings, film, &control);
    assert_eq!(stats.samples, taken.load(Ordering::Relaxed));
    film
}

/// Mean over pixels and channels of |a − b| / (|b| + 0.01).
pub fn mean_relative_difference(a: &Image, b: &Image) -> f64 {
    let sum: f64 = a
        .pixels
        .iter()
        .zip(&b.pixels)
        .flat_map(|(p, q)| (0..3).map(move |c| (f64::from(p[c]), f64::from(q[c]))))
        .map(|(x, y)| (x - y).abs() / (y.abs() + 0.01))
        .sum();
    sum / (3 * a.pixels.len()) as f64
}

/// The power a scene's lights send out: Σ area · |Ke| over its emissive triangles (in
/// an instanced scene, those of its world-space light mesh), each area from the
/// triangle's corners rather than the mesh's own `area`.
pub fn emitted_power(scene: &Scene) -> f64 {
    let mesh = scene.light_mesh();
    scene
        .emitters
        .iter()
        .map(|&t| {
            let [a, b, c] = mesh.triangles[t as usize].map(|i| mesh.positions[i as usize]);
            let area = 0.5 * f64::from((b - a).cross(c - a).length());
            let m = &scene.materials[mesh.material[t as usize] as usize];
            area * f64::from(m.emission.element_sum())
        })
        .sum()
}

/// The settings of the image comparisons (compose, instancing): 64², 16 spp, depth 6,
/// `mis`, seed 11.
pub fn small_mis_settings() -> ember::render::RenderSettings {
    ember::render::RenderSettings {
        width: 64,
        height: 64,
        spp: 16,
        max_depth: 6,
        seed: 11,
        integrator: ember::integrator::IntegratorKind::Mis,
        light_sampler: Default::default(),
        adaptive: None,
        guiding: None,
        engine: Default::default(),
    }
}

/// Irradiance at `p` (unit normal `n`) from a uniformly emitting polygon `v` of
/// radiance `radiance` wholly in front of `p`'s plane (Lambert's formula):
/// `L/2 |Σ θ_i (n · unit(r_i × r_{i+1}))|` over its edges seen from `p`.
pub fn lambert_irradiance(p: Vec3, n: Vec3, v: &[Vec3], radiance: f64) -> f64 {
    let r: Vec<DVec3> = v.iter().map(|x| (*x - p).as_dvec3().normalize()).collect();
    let n = n.as_dvec3();
    let sum: f64 = (0..r.len())
        .map(|i| {
            let (a, b) = (r[i], r[(i + 1) % r.len()]);
            let theta = a.dot(b).clamp(-1.0, 1.0).acos();
            theta * n.dot(a.cross(b).normalize_or_zero())
        })
        .sum();
    radiance * 0.5 * sum.abs()
}
