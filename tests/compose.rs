//! A scene placed under a transform (`scene::compose`, what a scene file's `[[obj]]`
//! and `[[instance]]` entries give) against the same mesh written in world space as an
//! OBJ and loaded: the same image on Embree and on the native BVH, under a rotation, a
//! non-uniform scale and a mirror; its emitter lights the scene as the baked one does.

mod common;

use std::collections::HashMap;
use std::fmt::Write;
use std::path::Path;

use common::{emitted_power, mean_relative_difference, small_mis_settings};
use ember::accel::{Bvh, EmbreeAccel};
use ember::embree::{BuildQuality, Device};
use ember::image::Image;

use ember::render::render;
use ember::scene::{
    compose, load_obj, load_obj_from_str, mirrors, CameraSettings, Placement, Scene,
};
use glam::{Affine3A, DMat3, DVec3, Quat, Vec3};

fn sphere_box() -> Scene {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("meshes/CornellBox-Sphere.obj");
    load_obj(&path).expect("bundled sphere box loads").0
}

/// Rotated about a skew axis, scaled unevenly with x mirrored, and moved.
fn transform() -> Affine3A {
    Affine3A::from_scale_rotation_translation(
        Vec3::new(-1.5, 0.7, 1.2),
        Quat::from_axis_angle(Vec3::new(1.0, 2.0, 3.0).normalize(), 50f32.to_radians()),
        Vec3::new(3.0, -1.0, 2.0),
    )
}

/// The scene's mesh under `t`, written as OBJ text: positions through the transform,
/// normals through the inverse transpose (in f64), and each triangle wound so that it
/// faces the way its transformed surface does.
fn baked_obj(scene: &Scene, t: &Affine3A) -> String {
    let m = &scene.mesh;
    let linear = DMat3::from_cols(
        t.matrix3.x_axis.as_dvec3(),
        t.matrix3.y_axis.as_dvec3(),
        t.matrix3.z_axis.as_dvec3(),
    );
    let normal_matrix = linear.inverse().transpose();
    let mut s = String::from("mtllib box.mtl\n");
    for p in &m.positions {
        let q = t.transform_point3(*p);
        writeln!(s, "v {:?} {:?} {:?}", q.x, q.y, q.z).unwrap();
    }
    for n in &m.normals {
        let q = (normal_matrix * n.as_dvec3())
            .normalize_or(DVec3::ZERO)
            .as_vec3();
        writeln!(s, "vn {:?} {:?} {:?}", q.x, q.y, q.z).unwrap();
    }
    for uv in &m.uvs {
        writeln!(s, "vt {:?} {:?}", uv.x, uv.y).unwrap();
    }
    let mut current = u32::MAX;
    for (tri, &material) in m.triangles.iter().zip(&m.material) {
        if material != current {
            writeln!(s, "usemtl {}", scene.materials[material as usize].name).unwrap();
            current = material;
        }
        // The sign of the determinant says whether the transform turns the surface
        // inside out; turning two corners keeps (b − a) × (c − a) facing out.
        let [a, b, c] = if linear.determinant() < 0.0 {
            [tri[0], tri[2], tri[1]]
        } else {
            *tri
        };
        let corner = |i: u32| {
            let i = i + 1;
            match (m.uvs.is_empty(), m.normals.is_empty()) {
                (true, true) => format!("{i}"),
                (true, false) => format!("{i}//{i}"),
                (false, true) => format!("{i}/{i}"),
                (false, false) => format!("{i}/{i}/{i}"),
            }
        };
        writeln!(s, "f {} {} {}", corner(a), corner(b), corner(c)).unwrap();
    }
    s
}

/// The scene through one camera framing it, on Embree and on the native BVH.
fn images(scene: &Scene) -> [Image; 2] {
    let (lo, hi) = scene.bounds();
    let camera = CameraSettings::framing(lo, hi, 50.0).camera(64, 64);
    let s = small_mis_settings();
    let (positions, triangles) = (&scene.mesh.positions, &scene.mesh.triangles);
    let device = Device::new("").unwrap();
    let embree = EmbreeAccel::build(&device, positions, triangles, BuildQuality::High).unwrap();
    let bvh = Bvh::build(positions, triangles).unwrap();
    [
        render(scene, &embree, &camera, &s, &|_| {}).0,
        render(scene, &bvh, &camera, &s, &|_| {}).0,
    ]
}

#[test]
fn a_placed_mesh_renders_as_the_mesh_baked_into_world_space_on_both_backends() {
    let original = sphere_box();
    let t = transform();
    assert!(mirrors(&t));
    let placed = compose(&[Placement {
        scene: &original,
        transform: t,
    }]);
    let mtl = std::fs::read_to_string(
        Path::new(env!("CARGO_MANIFEST_DIR")).join("meshes/CornellBox-Sphere.mtl"),
    )
    .unwrap();
    let baked = load_obj_from_str(
        &baked_obj(&original, &t),
        &HashMap::from([("box.mtl".to_string(), mtl)]),
        &Default::default(),
    )
    .unwrap()
    .0;
    assert_eq!(placed.mesh.triangles.len(), baked.mesh.triangles.len());
    // The emitter is placed as the baked one: as many emissive triangles, the same power
    // (the transform scales areas, so neither equals the original's).
    assert_eq!(placed.emitters.len(), baked.emitters.len());
    let (p, b, o) = (
        emitted_power(&placed),
        emitted_power(&baked),
        emitted_power(&original),
    );
    assert!((p / b - 1.0).abs() < 1e-5, "placed {p}, baked {b}");
    assert!(
        (p / o - 1.0).abs() > 0.05,
        "the transform should change the light's area"
    );
    let [placed_embree, placed_bvh] = images(&placed);
    let [baked_embree, baked_bvh] = images(&baked);
    for (name, a, b) in [
        ("embree", &placed_embree, &baked_embree),
        ("bvh", &placed_bvh, &baked_bvh),
        ("embree against bvh", &placed_embree, &placed_bvh),
    ] {
        let d = mean_relative_difference(a, b);
        assert!(d < 1e-4, "{name}: mean relative difference {d:.2e}");
    }
    // The image shows the lit box (the emitter faces into it after the mirror).
    let mean: f64 = placed_embree
        .pixels
        .iter()
        .map(|p| f64::from(p.element_sum()))
        .sum::<f64>()
        / placed_embree.pixels.len() as f64;
    assert!(mean > 0.05, "mean {mean}: the placed box is dark");
}
