//! glTF 2.0 scenes against mathematics and against ember's own OBJ path: a point, spot
//! and directional light of `KHR_lights_punctual` in candela and lux at 683 lm/W, placed
//! by their nodes; `doubleSided` emission from both faces against Lambert's formula;
//! the Cornell box as glTF beside the OBJ; a mesh two nodes share
//! stored once and rendered as two copies are, on both backends; the file's cameras;
//! `KHR_texture_transform`; alpha modes; strips and fans; and hostile files, each one
//! `error:` line and a non-zero exit.

mod common;

use std::f64::consts::PI;
use std::path::{Path, PathBuf};

use common::gltf::{floor_quad, png_data_uri, refused, GltfBuilder};
use common::{ember_in, with_embree, Built};
use ember::accel::{Accel, Ray};
use ember::image::{compare, Image};
use ember::integrator::{IntegratorKind, PathTracer, RayCount};
use ember::sampling::Rng;
use ember::scene::{load_gltf, LoadOptions, Material};
use glam::{DVec3, Vec3};
use serde_json::json;

const ALBEDO: f32 = 0.8;

/// A white (base colour [`ALBEDO`]) dielectric of roughness 1, metallic 0.
fn rough_white() -> serde_json::Value {
    json!({"pbrMetallicRoughness": {"baseColorFactor": [ALBEDO, ALBEDO, ALBEDO, 1.0],
        "metallicFactor": 0.0, "roughnessFactor": 1.0}})
}

/// A floor of side 100 at y = 0 facing up, of material `material`.
fn with_floor(gltf: &mut GltfBuilder, material: serde_json::Value) {
    let m = gltf.material(material);
    let (p, uv, i) = floor_quad(50.0, 0.0);
    let mesh = gltf.mesh(&p, Some(&uv), &i, Some(m));
    gltf.node(json!({"mesh": mesh}), true);
}

fn write(dir: &Path, name: &str, bytes: &[u8]) -> PathBuf {
    let path = dir.join(name);
    std::fs::write(&path, bytes).unwrap();
    path
}

fn load(gltf: &GltfBuilder) -> Built {
    let dir = tempfile::tempdir().unwrap();
    let path = write(dir.path(), "scene.gltf", gltf.to_gltf().as_bytes());
    let loaded = load_gltf(&path, &LoadOptions::default()).expect("loads");
    with_embree(loaded.scene)
}

/// The radiance leaving the floor at `(x, 0, z)` straight up, each of `n` samples.
fn floor_radiance(built: &Built, x: f32, z: f32, n: u64) -> Vec<Vec3> {
    let tracer = PathTracer::new(&built.scene, &built.accel, 4, IntegratorKind::Mis);
    let mut count = RayCount::default();
    (0..n)
        .map(|i| {
            let mut rng = Rng::for_sample(3, 0, i);
            tracer.radiance(
                Ray::new(Vec3::new(x, 3.0, z), -Vec3::Y),
                &mut rng,
                &mut count,
            )
        })
        .collect()
}

/// The scene of `gltf` with its first material (the floor's) made a white Lambertian
/// of [`ALBEDO`]: what these tests check is the light, its units and its place; the
/// glTF BRDF has tests of its own (tests/metallic_roughness.rs).
fn load_lambert_floor(gltf: &GltfBuilder) -> Built {
    let mut built = load(gltf);
    built.scene.materials[0] = Material {
        diffuse: Vec3::splat(ALBEDO),
        ..Material::default()
    };
    built
}

/// Lambert's radiance under irradiance `e`: `ρ/π · E`.
fn lambert(e: DVec3) -> DVec3 {
    f64::from(ALBEDO) / PI * e
}

fn assert_close(label: &str, got: Vec3, expected: DVec3, relative: f64) {
    for c in 0..3 {
        let (g, e) = (f64::from(got[c]), expected[c]);
        assert!(
            (g - e).abs() <= relative * e.abs() + 1e-7,
            "{label}, channel {c}: {g} against {e}"
        );
    }
}

/// A point light of `I` cd placed by its node at height `h` gives the floor at distance
/// `d` the irradiance `(I/683) cos θ / d²`, under it and at an angle; one light sample
/// of a delta light is exact.
#[test]
fn a_point_light_in_candela_gives_i_over_683_cos_theta_over_d_squared() {
    let mut gltf = GltfBuilder::default();
    with_floor(&mut gltf, rough_white());
    let candela = [1000.0f32, 500.0, 250.0];
    let light =
        gltf.light(json!({"type": "point", "intensity": 1000.0, "color": [1.0, 0.5, 0.25]}));
    let at = [0.2f32, 1.5, -0.1];
    gltf.node(
        json!({"translation": at, "extensions": {"KHR_lights_punctual": {"light": light}}}),
        true,
    );
    let built = load_lambert_floor(&gltf);
    let light_at = Vec3::from(at).as_dvec3();
    for (x, z) in [(0.2f32, -0.1f32), (1.7, -0.1), (-1.0, 1.2)] {
        let to_light = light_at - DVec3::new(x.into(), 0.0, z.into());
        let d = to_light.length();
        let cos = to_light.y / d;
        let intensity = DVec3::from(candela.map(f64::from)) / 683.0;
        let expected = lambert(intensity * cos / (d * d));
        for got in floor_radiance(&built, x, z, 8) {
            assert_close(&format!("({x}, {z})"), got, expected, 2e-3);
        }
    }
}

/// A floor and a small emissive panel 1.5 above it facing up, away from the floor, of
/// a material `doubleSided` or not; with the emissive material's index.
fn panel_facing_up(double_sided: bool) -> (GltfBuilder, [Vec3; 4]) {
    let mut gltf = GltfBuilder::default();
    with_floor(&mut gltf, rough_white());
    let m = gltf.material(json!({"emissiveFactor": [1.0, 0.5, 0.25],
        "pbrMetallicRoughness": {"baseColorFactor": [0.0, 0.0, 0.0, 1.0]},
        "doubleSided": double_sided}));
    let (p, uv, i) = floor_quad(0.3, 1.5);
    let mesh = gltf.mesh(&p, Some(&uv), &i, Some(m));
    gltf.node(json!({"mesh": mesh}), true);
    (gltf, p.map(Vec3::from))
}

/// glTF's `doubleSided` gives double-sided lighting, the back face lit with its normal
/// reversed: an emissive material so marked emits from both faces (as Cycles renders
/// it). Its back, seen directly, has its emission, and it lights the floor under it
/// by Lambert's formula; without `doubleSided` the back is black and the floor dark.
/// The flag is set on emissive materials only.
#[test]
fn double_sided_emissive_materials_emit_from_both_faces() {
    for double_sided in [true, false] {
        let (gltf, panel) = panel_facing_up(double_sided);
        let built = load_lambert_floor(&gltf);
        assert!(!built.scene.materials[0].two_sided_emission);
        assert_eq!(built.scene.materials[1].two_sided_emission, double_sided);
        let emission = Vec3::new(1.0, 0.5, 0.25);
        let seen = if double_sided { emission } else { Vec3::ZERO };
        for kind in [
            IntegratorKind::Bsdf,
            IntegratorKind::Light,
            IntegratorKind::Mixture,
            IntegratorKind::Mis,
        ] {
            let tracer = PathTracer::new(&built.scene, &built.accel, 1, kind);
            let mut rng = Rng::seeded(1);
            let up = Ray::new(Vec3::new(0.05, 0.5, -0.1), Vec3::Y);
            let got = tracer.radiance(up, &mut rng, &mut RayCount::default());
            assert_eq!(got, seen, "{kind:?}, doubleSided {double_sided}");
        }
        // Direct light (depth 2) on the floor beside the panel's foot, so that the
        // ray down misses the panel.
        let p = Vec3::new(0.8, 0.0, 0.4);
        let irradiance: DVec3 =
            emission.as_dvec3() * common::lambert_irradiance(p, Vec3::Y, &panel, 1.0);
        let tracer = PathTracer::new(&built.scene, &built.accel, 2, IntegratorKind::Mis);
        let mut sums = common::stats::SampleSums::default();
        for i in 0..20_000 {
            let mut rng = Rng::for_sample(5, 0, i);
            let down = Ray::new(p + Vec3::new(0.0, 3.0, 0.0), -Vec3::Y);
            sums.add(tracer.radiance(down, &mut rng, &mut RayCount::default()));
        }
        let expected = match double_sided {
            true => lambert(irradiance),
            false => DVec3::ZERO,
        };
        sums.assert_mean(&format!("floor, doubleSided {double_sided}"), expected);
    }
    // `ember info` says so, and counts the power of both faces.
    let dir = tempfile::tempdir().unwrap();
    let (gltf, _) = panel_facing_up(true);
    write(dir.path(), "panel.gltf", gltf.to_gltf().as_bytes());
    let info = ember_in(&["info", "panel.gltf"], dir.path());
    let stdout = String::from_utf8_lossy(&info.stdout);
    assert!(info.status.success(), "{stdout}");
    for line in ["from both faces", "(pi x area x luminance of Ke x 2 faces)"] {
        assert!(
            stdout.contains(line),
            "`ember info` lacks {line:?}:\n{stdout}"
        );
    }
    // A doubleSided material that does not emit has nothing to emit from either face.
    let mut gltf = GltfBuilder::default();
    with_floor(&mut gltf, json!({"doubleSided": true}));
    assert!(!load(&gltf).scene.materials[0].two_sided_emission);
}

/// A spot turned by its node to point down lights fully inside its inner cone and
/// not at all outside its outer one; a sun of `E` lux turned 60° from the zenith gives
/// `(E/683) cos 60°`.
#[test]
fn spot_and_directional_lights_follow_their_nodes() {
    // −Z turned to −Y: a quarter turn about +X, clockwise.
    let down = [
        -std::f32::consts::FRAC_1_SQRT_2,
        0.0,
        0.0,
        std::f32::consts::FRAC_1_SQRT_2,
    ];
    let mut gltf = GltfBuilder::default();
    with_floor(&mut gltf, rough_white());
    let spot = gltf.light(json!({"type": "spot", "intensity": 683.0,
        "spot": {"innerConeAngle": 0.3, "outerConeAngle": 0.5}}));
    gltf.node(
        json!({"translation": [0.0, 2.0, 0.0], "rotation": down,
               "extensions": {"KHR_lights_punctual": {"light": spot}}}),
        true,
    );
    let built = load_lambert_floor(&gltf);
    // tan 0.2 · 2 is inside the inner cone, tan 0.6 · 2 outside the outer one.
    let inside = 2.0 * 0.2f32.tan();
    let cos = 2.0 / (4.0 + f64::from(inside * inside)).sqrt();
    let d2 = 4.0 + f64::from(inside * inside);
    let expected = lambert(DVec3::ONE * cos / d2);
    assert_close(
        "inside",
        floor_radiance(&built, inside, 0.0, 1)[0],
        expected,
        2e-3,
    );
    let outside = 2.0 * 0.6f32.tan();
    assert_eq!(floor_radiance(&built, 0.0, outside, 1)[0], Vec3::ZERO);

    let mut gltf = GltfBuilder::default();
    with_floor(&mut gltf, rough_white());
    let sun = gltf.light(json!({"type": "directional", "intensity": 6830.0}));
    // Down, then tilted 60° about +Z.
    let tilt = glam::Quat::from_rotation_z(60f32.to_radians()) * glam::Quat::from_array(down);
    gltf.node(
        json!({"rotation": tilt.to_array(), "translation": [5.0, 9.0, 1.0],
               "extensions": {"KHR_lights_punctual": {"light": sun}}}),
        true,
    );
    let built = load_lambert_floor(&gltf);
    let cos = 0.5;
    let expected = lambert(DVec3::ONE * 10.0 * cos);
    assert_close(
        "sun",
        floor_radiance(&built, 0.3, 0.7, 1)[0],
        expected,
        2e-3,
    );
}

/// Two quads in front of the camera under a white sky.
fn two_quads(shared: bool) -> GltfBuilder {
    let mut gltf = GltfBuilder::default();
    let red = gltf.material(json!({"pbrMetallicRoughness": {
        "baseColorFactor": [0.8, 0.2, 0.1, 1.0], "metallicFactor": 0.0, "roughnessFactor": 0.5}}));
    let quad: [[f32; 3]; 4] = [
        [-0.5, -0.5, 0.0],
        [0.5, -0.5, 0.0],
        [0.5, 0.5, 0.0],
        [-0.5, 0.5, 0.0],
    ];
    let indices = [0, 1, 2, 0, 2, 3];
    let first = gltf.mesh(&quad, None, &indices, Some(red));
    let second = match shared {
        true => first,
        false => gltf.mesh(&quad, None, &indices, Some(red)),
    };
    gltf.node(
        json!({"mesh": first, "translation": [-0.6, 0.0, 0.0]}),
        true,
    );
    // The second turned about +Y and mirrored: the instance's normals and winding turn.
    gltf.node(
        json!({"mesh": second, "translation": [0.6, 0.1, -0.3],
               "rotation": [0.0, 0.258819, 0.0, 0.9659258], "scale": [1.0, -1.2, 1.0]}),
        true,
    );
    gltf
}

/// A mesh two nodes place is stored once and placed by two instances, and renders as
/// the same mesh written twice (baked into the world) does, on both backends.
#[test]
fn a_mesh_two_nodes_share_is_stored_once_and_renders_as_two_copies() {
    let dir = tempfile::tempdir().unwrap();
    let shared = write(
        dir.path(),
        "shared.gltf",
        two_quads(true).to_gltf().as_bytes(),
    );
    let copies = write(dir.path(), "copies.glb", &two_quads(false).to_glb());
    let loaded = load_gltf(&shared, &LoadOptions::default()).unwrap();
    assert_eq!(loaded.scene.mesh.triangles.len(), 2, "the mesh once");
    let instancing = loaded.scene.instancing.as_ref().expect("instanced");
    assert_eq!(instancing.instances.len(), 2);
    assert_eq!(instancing.placed_triangles(), 4);
    let baked = load_gltf(&copies, &LoadOptions::default()).unwrap();
    assert!(baked.scene.instancing.is_none());
    assert_eq!(baked.scene.mesh.triangles.len(), 4);
    for accel in ["embree", "bvh"] {
        let mut images = Vec::new();
        for file in ["shared.gltf", "copies.glb"] {
            let out = format!("{file}-{accel}.exr");
            let run = ember_in(
                &[
                    "render",
                    file,
                    "--accel",
                    accel,
                    "--spp",
                    "16",
                    "--width",
                    "48",
                    "--height",
                    "32",
                    "--eye",
                    "0,0,3",
                    "--look-at",
                    "0,0,0",
                    "-o",
                    &out,
                ],
                dir.path(),
            );
            assert!(
                run.status.success(),
                "{}",
                String::from_utf8_lossy(&run.stderr)
            );
            images.push(Image::load(&dir.path().join(&out)).unwrap());
        }
        let error = compare(&images[0], &images[1]).unwrap();
        assert!(error.rel_mse < 1e-4, "{accel}: relMSE {}", error.rel_mse);
        let (a, b) = (images[0].mean(), images[1].mean());
        assert!(
            (a - b).abs().max_element() < 1e-3 * a.max_element(),
            "{accel}: {a} {b}"
        );
    }
}

/// The glTF Cornell box (the OBJ's geometry, Kd as base colour, metallic 0, roughness
/// 1: scripts/make_gltf_test_data.py) renders close to the OBJ (means within 5%). They
/// differ by glTF's dielectric: a GGX specular layer (Schlick's Fresnel from 0.04) over
/// the Lambert base, which it dims by what it reflects, where the MTL's walls are
/// Lambert `Kd` alone; the layer sends light back most at grazing angles. The file's
/// materials are not `doubleSided`, so its lamp emits downwards only, as the OBJ's
/// does: the bound compares materials, not lamps. (Blender's export of the box,
/// tests/data/gltf/cornell-original.glb, is `doubleSided` throughout: its lamp also
/// lights the ceiling 1 cm above it from its back, and renders brighter than the OBJ.)
#[test]
fn the_cornell_box_as_gltf_renders_close_to_the_obj() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let dir = tempfile::tempdir().unwrap();
    let mut means = Vec::new();
    for scene in [
        "tests/data/gltf/cornell-box.gltf",
        "meshes/CornellBox-Original.obj",
    ] {
        let out = dir.path().join("out.exr");
        let mut args = vec![
            "render", scene, "--spp", "64", "--width", "48", "--height", "48",
        ];
        args.extend(common::CORNELL_CAMERA);
        args.extend(["-o", out.to_str().unwrap()]);
        let run = ember_in(&args, root);
        assert!(
            run.status.success(),
            "{}",
            String::from_utf8_lossy(&run.stderr)
        );
        means.push(Image::load(&out).unwrap().mean());
    }
    let (gltf, obj) = (means[0], means[1]);
    for c in 0..3 {
        let ratio = gltf[c] / obj[c];
        assert!(
            (ratio - 1.0).abs() < 0.05,
            "channel {c}: glTF {gltf}, OBJ {obj}"
        );
    }
}

/// The camera a file's node places is the default, printed as flags (its eye the
/// node's origin, looking along its −Z with `yfov`); `--camera` picks another by name
/// or index, and the flags given override it.
#[test]
fn the_files_first_camera_is_the_default_and_camera_picks_another() {
    let mut gltf = GltfBuilder::default();
    with_floor(&mut gltf, rough_white());
    gltf.json["cameras"] = json!([
        {"name": "front", "type": "perspective", "perspective": {"yfov": 0.5, "znear": 0.1}},
        {"name": "top", "type": "perspective", "perspective": {"yfov": 1.0, "znear": 0.1, "aspectRatio": 1.5}},
    ]);
    gltf.node(json!({"camera": 0, "translation": [0.0, 1.0, 5.0]}), true);
    let down = [
        -std::f32::consts::FRAC_1_SQRT_2,
        0.0,
        0.0,
        std::f32::consts::FRAC_1_SQRT_2,
    ];
    gltf.node(
        json!({"camera": 1, "translation": [0.0, 8.0, 0.0], "rotation": down}),
        true,
    );
    let dir = tempfile::tempdir().unwrap();
    write(dir.path(), "cams.gltf", gltf.to_gltf().as_bytes());
    let info = ember_in(&["info", "cams.gltf"], dir.path());
    let out = String::from_utf8_lossy(&info.stdout);
    assert!(
        info.status.success(),
        "{}",
        String::from_utf8_lossy(&info.stderr)
    );
    let fov = 0.5f32.to_degrees();
    let line =
        format!("camera (the file's camera \"front\"): --eye 0,1,5 --look-at 0,1,4 --fov {fov}");
    assert!(out.contains(&line), "{out}");
    assert!(out.contains("cameras: 2"), "{out}");
    let render = |extra: &[&str]| {
        let mut args = vec![
            "render",
            "cams.gltf",
            "--spp",
            "1",
            "--width",
            "8",
            "--height",
            "8",
        ];
        args.extend(extra);
        let run = ember_in(&args, dir.path());
        (
            run.status.success(),
            String::from_utf8_lossy(&run.stderr).into_owned(),
        )
    };
    for pick in ["top", "1"] {
        let (ok, err) = render(&["--camera", pick]);
        assert!(ok, "{err}");
        let fov = 1.0f32.to_degrees();
        assert!(
            err.contains("camera (the file's camera \"top\"): --eye 0,8,0"),
            "{err}"
        );
        assert!(err.contains(&format!("--fov {fov}")), "{err}");
    }
    let (ok, err) = render(&["--camera", "front", "--fov", "60", "--eye", "0,2,6"]);
    assert!(ok, "{err}");
    assert!(
        err.contains("--eye 0,2,6 --look-at 0,1,4 --fov 60"),
        "{err}"
    );
    let (ok, err) = render(&["--camera", "side"]);
    assert!(!ok);
    assert_eq!(err.lines().count(), 1, "{err}");
    assert!(
        err.starts_with("error: --camera \"side\"") && err.contains("\"front\", \"top\""),
        "{err}"
    );
}

/// A 2×1 texture, black on the left and white on the right, as a PNG in a data: URI.
fn black_white_texture(gltf: &mut GltfBuilder, transform: Option<serde_json::Value>) -> usize {
    let image = image::RgbImage::from_fn(2, 1, |x, _| image::Rgb([255 * x as u8; 3]));
    gltf.json["images"] = json!([{"uri": png_data_uri(image)}]);
    gltf.json["textures"] = json!([{"source": 0}]);
    let mut info = json!({"index": 0});
    if let Some(t) = transform {
        gltf.uses("KHR_texture_transform", false);
        info["extensions"] = json!({"KHR_texture_transform": t});
    }
    gltf.material(json!({"pbrMetallicRoughness": {"baseColorTexture": info,
        "metallicFactor": 0.0, "roughnessFactor": 1.0}}))
}

/// The base colour at texture coordinates `(u, v)` of a unit quad that maps them
/// linearly: glTF's (0,0) at its corner (−1, 0, −1), its (1,1) at (1, 0, 1).
fn albedo_at(built: &Built, u: f32, v: f32) -> f32 {
    let (x, z) = (2.0 * u - 1.0, 2.0 * v - 1.0);
    let ray = Ray::new(Vec3::new(x, 1.0, z), -Vec3::Y);
    let hit = built.accel.intersect(&ray).expect("the quad");
    built.scene.albedo(&built.scene.surface(&hit)).x
}

fn textured_quad(transform: Option<serde_json::Value>) -> Built {
    let mut gltf = GltfBuilder::default();
    let material = black_white_texture(&mut gltf, transform);
    let (p, uv, i) = floor_quad(1.0, 0.0);
    let mesh = gltf.mesh(&p, Some(&uv), &i, Some(material));
    gltf.node(json!({"mesh": mesh}), true);
    load(&gltf)
}

/// `KHR_texture_transform` moves the texture as the extension states: `offset` shifts
/// the coordinates, `rotation` turns them by `mat3(cos, sin, −sin, cos)`, `scale`
/// stretches them; the image's left half is black, its right white.
#[test]
fn texture_transform_moves_the_texture_as_stated() {
    let plain = textured_quad(None);
    assert!(albedo_at(&plain, 0.25, 0.5) < 0.01);
    assert!(albedo_at(&plain, 0.75, 0.5) > 0.99);
    // u + 0.5: the left half reads the white texel.
    let shifted = textured_quad(Some(json!({"offset": [0.5, 0.0]})));
    assert!(albedo_at(&shifted, 0.25, 0.5) > 0.99);
    assert!(albedo_at(&shifted, 0.75, 0.5) < 0.01);
    // A quarter turn: u' = cos·u − sin·v = −v, which wraps to 1 − v.
    let turned = textured_quad(Some(json!({"rotation": std::f32::consts::FRAC_PI_2})));
    assert!(albedo_at(&turned, 0.5, 0.25) > 0.99, "u' = 0.75");
    assert!(albedo_at(&turned, 0.5, 0.75) < 0.01, "u' = 0.25");
    // u · 0.5: the middle of the quad, halfway between the texels, reads the left one.
    assert!((albedo_at(&plain, 0.5, 0.5) - 0.5).abs() < 0.01);
    let scaled = textured_quad(Some(json!({"scale": [0.5, 1.0]})));
    assert!(albedo_at(&scaled, 0.5, 0.5) < 0.01);
}

/// `MASK` cuts at `alphaCutoff` (a constant alpha under it removes the surface),
/// `BLEND` keeps the alpha as a stochastic cut-out, `OPAQUE` ignores it.
#[test]
fn alpha_modes_become_cut_outs() {
    let mut gltf = GltfBuilder::default();
    let material = |mode: &str, alpha: f32| {
        json!({"alphaMode": mode, "alphaCutoff": 0.4,
               "pbrMetallicRoughness": {"baseColorFactor": [1.0, 1.0, 1.0, alpha]}})
    };
    for (mode, alpha) in [
        ("MASK", 0.3),
        ("MASK", 0.5),
        ("BLEND", 0.25),
        ("OPAQUE", 0.1),
    ] {
        let m = gltf.material(material(mode, alpha));
        let (p, uv, i) = floor_quad(1.0, 0.0);
        let mesh = gltf.mesh(&p, Some(&uv), &i, Some(m));
        gltf.node(json!({"mesh": mesh}), true);
    }
    let built = load(&gltf);
    let opacity: Vec<f32> = built.scene.materials.iter().map(|m| m.opacity).collect();
    assert_eq!(
        opacity,
        [0.0, 1.0, 0.25, 1.0, 1.0],
        "the default material last"
    );
}

/// Strips and fans become the triangles the specification lists; points and lines are
/// skipped with one note; one GLB and one .gltf of the same document load alike.
#[test]
fn strips_fans_and_lines() {
    let mut gltf = GltfBuilder::default();
    let m = gltf.material(rough_white());
    // A strip of four vertices and a fan of four: two triangles each, facing +y.
    let strip = gltf.floats(
        &[
            [-1.0, 0.0, -1.0],
            [-1.0, 0.0, 1.0],
            [0.0, 0.0, -1.0],
            [0.0, 0.0, 1.0],
        ]
        .map(|v: [f32; 3]| v.to_vec()),
        "VEC3",
    );
    let fan = gltf.floats(
        &[
            [0.0, 0.0, 1.0],
            [1.0, 0.0, 1.0],
            [1.0, 0.0, -1.0],
            [0.0, 0.0, -1.0],
        ]
        .map(|v: [f32; 3]| v.to_vec()),
        "VEC3",
    );
    gltf.json["meshes"] = json!([{"primitives": [
        {"attributes": {"POSITION": strip}, "mode": 5, "material": m},
        {"attributes": {"POSITION": fan}, "mode": 6, "material": m},
        {"attributes": {"POSITION": fan}, "mode": 1, "material": m},
    ]}]);
    gltf.node(json!({"mesh": 0}), true);
    let dir = tempfile::tempdir().unwrap();
    let glb = write(dir.path(), "s.glb", &gltf.to_glb());
    let loaded = load_gltf(&glb, &LoadOptions::default()).unwrap();
    let mesh = &loaded.scene.mesh;
    assert_eq!(mesh.triangles.len(), 4);
    for t in 0..4 {
        let n = mesh.area_normal(t as u32);
        assert!(n.y > 0.0 && n.x == 0.0 && n.z == 0.0, "triangle {t}: {n}");
    }
    let area: f32 = (0..4).map(|t| mesh.area(t)).sum();
    assert!((area - 4.0).abs() < 1e-6, "{area}");
    let notes = &loaded.report.warnings;
    assert_eq!(notes.len(), 1, "{notes:?}");
    assert!(
        notes[0].contains("1 primitives of points or lines are skipped"),
        "{notes:?}"
    );
    let gltf_file = write(dir.path(), "s.gltf", gltf.to_gltf().as_bytes());
    let same = load_gltf(&gltf_file, &LoadOptions::default()).unwrap();
    assert_eq!(same.scene.mesh.positions, loaded.scene.mesh.positions);
}

/// A small valid scene: one quad under a point light.
fn valid() -> GltfBuilder {
    let mut gltf = GltfBuilder::default();
    with_floor(&mut gltf, rough_white());
    let light = gltf.light(json!({"type": "point", "intensity": 100.0}));
    gltf.node(
        json!({"translation": [0.0, 1.0, 0.0], "extensions": {"KHR_lights_punctual": {"light": light}}}),
        true,
    );
    gltf
}

/// Hostile files: each is one error line naming the file, and no panic.
#[test]
fn hostile_files_are_one_error_line() {
    let glb = valid().to_glb();
    refused(
        "truncated.glb",
        &glb[..glb.len() / 2],
        "the GLB header says",
    );
    let mut lying = glb.clone();
    lying[12..16].copy_from_slice(&u32::MAX.to_le_bytes());
    refused("lying-chunk.glb", &lying, "chunk says 4294967295 bytes");
    refused("header.glb", &glb[..10], "truncated");
    let mut version = glb.clone();
    version[4] = 1;
    refused("version.glb", &version, "GLB version 1");

    let mut far = valid();
    far.json["accessors"][0]["byteOffset"] = json!(4096);
    refused("offset.gltf", far.to_gltf().as_bytes(), "reach byte");
    let mut huge = valid();
    huge.json["accessors"][0]["count"] = json!(1_000_000_000u64);
    refused(
        "count.gltf",
        huge.to_gltf().as_bytes(),
        "values, its POSITION",
    );
    let mut huge_indices = valid();
    huge_indices.json["accessors"][2]["count"] = json!(1_000_000_000u64);
    refused(
        "indices.gltf",
        huge_indices.to_gltf().as_bytes(),
        "1000000000 elements reach byte",
    );
    // Every attribute of 10^9 values, so that their counts agree: the count is checked
    // against the buffer before anything is sized by it.
    let mut all_huge = valid();
    for (_, accessor) in all_huge.json["meshes"][0]["primitives"][0]["attributes"]
        .clone()
        .as_object()
        .unwrap()
    {
        all_huge.json["accessors"][accessor.as_u64().unwrap() as usize]["count"] =
            json!(1_000_000_000u64);
    }
    refused(
        "all-huge.gltf",
        all_huge.to_gltf().as_bytes(),
        "1000000000 elements reach byte",
    );
    let mut sparse = valid();
    let sparse_indices = sparse.view(&99u32.to_le_bytes());
    let sparse_values = sparse.view(&[0.5f32, 0.2, 1.0].map(f32::to_le_bytes).concat());
    sparse.json["accessors"][0]["sparse"] = json!({"count": 1,
        "indices": {"bufferView": sparse_indices, "componentType": 5125},
        "values": {"bufferView": sparse_values}});
    refused(
        "sparse.gltf",
        sparse.to_gltf().as_bytes(),
        "sparse index 99 is out of range",
    );
    let mut out_of_range = valid();
    let bad = out_of_range.indices(&[0, 1, 99]);
    out_of_range.json["meshes"][0]["primitives"][0]["indices"] = json!(bad);
    refused(
        "index.gltf",
        out_of_range.to_gltf().as_bytes(),
        "index 99 is out of range",
    );
    let mut missing_view = valid();
    missing_view.json["accessors"][0]["bufferView"] = json!(77);
    refused(
        "view.gltf",
        missing_view.to_gltf().as_bytes(),
        "invalid glTF",
    );

    let text = valid().to_gltf();
    let broken = text.replacen(";base64,", ";base64,@@", 1);
    refused("base64.gltf", broken.as_bytes(), "base64 is broken");
    let plain = text.replacen(";base64,", ",", 1);
    refused("plain.gltf", plain.as_bytes(), "not base64");
    let mut external = valid().json;
    external["buffers"] = json!([{"byteLength": 8, "uri": "missing.bin"}]);
    refused(
        "buffer.gltf",
        external.to_string().as_bytes(),
        "missing.bin",
    );
    let mut remote = valid().json;
    remote["buffers"] = json!([{"byteLength": 8, "uri": "https://example.com/a.bin"}]);
    refused(
        "remote.gltf",
        remote.to_string().as_bytes(),
        "names a resource elsewhere",
    );

    let mut infinite = valid();
    infinite.json["nodes"][0]["translation"] = json!([1e39, 0.0, 0.0]);
    refused(
        "infinite.gltf",
        infinite.to_gltf().as_bytes(),
        "translation that is not finite",
    );
    let mut overflow = valid();
    overflow.json["nodes"][0]["scale"] = json!([3e38, 3e38, 3e38]);
    overflow.json["nodes"][1]["children"] = json!([0]);
    overflow.json["nodes"][1]["scale"] = json!([3e38, 3e38, 3e38]);
    overflow.json["scenes"][0]["nodes"] = json!([1]);
    refused("overflow.gltf", overflow.to_gltf().as_bytes(), "not finite");
    let mut cycle = valid();
    cycle.json["nodes"][0]["children"] = json!([1]);
    cycle.json["nodes"][1]["children"] = json!([0]);
    refused("cycle.gltf", cycle.to_gltf().as_bytes(), "its own ancestor");
    let mut own_child = valid();
    own_child.json["nodes"][0]["children"] = json!([0]);
    refused("self.gltf", own_child.to_gltf().as_bytes(), "its own child");
    let mut two_parents = valid();
    two_parents.node(json!({"children": [1]}), true);
    two_parents.json["nodes"][0]["children"] = json!([1]);
    refused(
        "parents.gltf",
        two_parents.to_gltf().as_bytes(),
        "a child of both",
    );

    let mut required = valid();
    required.uses("KHR_draco_mesh_compression", true);
    refused(
        "draco.gltf",
        required.to_gltf().as_bytes(),
        "requires the extension KHR_draco_mesh_compression",
    );
    let mut spot = valid();
    spot.json["extensions"]["KHR_lights_punctual"]["lights"][0] = json!({"type": "spot", "intensity": 1.0, "spot": {"innerConeAngle": 1.0, "outerConeAngle": 0.5}});
    refused("spot.gltf", spot.to_gltf().as_bytes(), "cone angles");
    refused("json.gltf", b"{\"asset\": ", "invalid JSON");
    refused(
        "empty.gltf",
        br#"{"asset": {"version": "2.0"}}"#,
        "no triangles",
    );
}

/// An image file that is absent is a warning and the material keeps its factor, as an
/// OBJ's missing texture is; with `--strict` it is an error. An extension the file
/// uses without requiring it is one warning.
#[test]
fn a_missing_image_warns_and_strict_refuses() {
    let mut gltf = valid();
    gltf.json["images"] = json!([{"uri": "textures/wood%20grain.png"}]);
    gltf.json["textures"] = json!([{"source": 0}]);
    gltf.json["materials"][0]["pbrMetallicRoughness"]["baseColorTexture"] = json!({"index": 0});
    gltf.uses("KHR_materials_sheen", false);
    let dir = tempfile::tempdir().unwrap();
    write(dir.path(), "tex.gltf", gltf.to_gltf().as_bytes());
    let out = ember_in(
        &[
            "render", "tex.gltf", "--spp", "1", "--width", "4", "--height", "4",
        ],
        dir.path(),
    );
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{err}");
    let warnings: Vec<&str> = err.lines().filter(|l| l.starts_with("warning:")).collect();
    assert_eq!(warnings.len(), 2, "{err}");
    assert!(
        warnings.iter().any(|w| w.contains("wood grain.png")
            && w.contains("file not found")
            && w.contains("baseColorFactor 0.8 0.8 0.8")),
        "{err}"
    );
    assert!(
        warnings.iter().any(|w| w.contains("KHR_materials_sheen")),
        "{err}"
    );
    let out = ember_in(
        &["render", "tex.gltf", "--strict", "--spp", "1"],
        dir.path(),
    );
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success());
    assert_eq!(err.lines().count(), 1, "{err}");
    assert!(
        err.starts_with("error: texture") && err.contains("wood grain.png"),
        "{err}"
    );
    // Present, it is read from beside the file.
    std::fs::create_dir(dir.path().join("textures")).unwrap();
    image::RgbImage::from_pixel(1, 1, image::Rgb([255, 0, 0]))
        .save(dir.path().join("textures/wood grain.png"))
        .unwrap();
    let loaded = load_gltf(&dir.path().join("tex.gltf"), &LoadOptions { strict: true }).unwrap();
    assert_eq!(loaded.scene.textures.len(), 1);
}

/// A scene file places a glTF with `[[mesh]]` (and `[[obj]]` still), instances of it
/// included, its lights with it.
#[test]
fn scene_files_place_gltf_files() {
    let dir = tempfile::tempdir().unwrap();
    write(
        dir.path(),
        "quads.gltf",
        two_quads(true).to_gltf().as_bytes(),
    );
    write(dir.path(), "lamp.glb", &valid().to_glb());
    let toml = "[[mesh]]\nfile = \"quads.gltf\"\n\n[[obj]]\nfile = \"lamp.glb\"\ntranslate = [0, -2, 0]\n\n\
                [[instance]]\nmesh = \"quads\"\ntranslate = [0, 0, -2]\n";
    write(dir.path(), "scene.toml", toml.as_bytes());
    let out = ember_in(&["info", "scene.toml"], dir.path());
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    // Two placements of the two-quad glTF (two instances each) and the lamp's floor.
    assert!(
        text.contains("; 5 placements put 10 triangles in the world"),
        "{text}"
    );
    assert!(text.contains("1 placed light"), "{text}");
}
