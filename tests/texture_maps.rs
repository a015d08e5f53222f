//! Bump maps, normal maps and the other texture slots against known answers. Every
//! scene is a real OBJ/MTL with image files written here, so the loader's reading of
//! the statements is tested with the shading.
//!
//! - A constant tangent-space normal map tilting a flat quad's normal by θ shades
//!   exactly like the quad tilted by θ: same radiance towards the same viewer under
//!   the same light.
//! - A height map rising linearly in u (slope `s` per unit of u, times `-bm k`) on a
//!   quad with `∂p/∂u = L x̂` gives the normal `(−k s, 0, L)/|…|`.
//! - A normal map pointing below the surface lets no light through it.

mod common;

use std::path::Path;

use common::{with_embree, Built};
use ember::accel::{Hit, Ray};
use ember::integrator::{IntegratorKind, PathTracer, RayCount};
use ember::sampling::Rng;
use ember::scene::{load_obj, load_obj_with, LoadOptions, Scene, SceneError};
use glam::Vec3;
use image::{DynamicImage, GrayImage, Luma, Rgb, Rgb32FImage, RgbImage};

/// Writes `obj`, `mtl` (as `scene.mtl`) and `files` to a new folder and loads them.
fn load(obj: &str, mtl: &str, files: &[(&str, DynamicImage)]) -> Result<Scene, SceneError> {
    let dir = tempfile::tempdir().unwrap();
    write_files(dir.path(), obj, mtl, files);
    load_obj(&dir.path().join("scene.obj")).map(|(scene, _)| scene)
}

fn write_files(dir: &Path, obj: &str, mtl: &str, files: &[(&str, DynamicImage)]) {
    std::fs::write(dir.join("scene.obj"), obj).unwrap();
    std::fs::write(dir.join("scene.mtl"), mtl).unwrap();
    for (name, image) in files {
        let path = dir.join(name);
        std::fs::create_dir_all(path.parent().unwrap()).unwrap();
        image.save(&path).unwrap();
    }
}

/// A quad of material `surface` (corners `q`, UVs over the unit square, counter-
/// clockwise around its normal) and a small square light of material `light`, 0.2
/// wide, centred at `light_centre`, facing down.
fn quad_and_light(q: [Vec3; 4], light_centre: Vec3) -> String {
    let mut obj = String::from("mtllib scene.mtl\n");
    for p in q {
        obj += &format!("v {} {} {}\n", p.x, p.y, p.z);
    }
    for (dx, dy) in [(-0.1, -0.1), (-0.1, 0.1), (0.1, 0.1), (0.1, -0.1)] {
        let p = light_centre + Vec3::new(dx, dy, 0.0);
        obj += &format!("v {} {} {}\n", p.x, p.y, p.z);
    }
    obj += "vt 0 0\nvt 1 0\nvt 1 1\nvt 0 1\n";
    obj += "usemtl surface\nf 1/1 2/2 3/3\nf 1/1 3/3 4/4\n";
    obj += "usemtl light\nf 5/1 6/2 7/3\nf 5/1 7/3 8/4\n";
    obj
}

const LIGHT: &str = "newmtl light\nKd 0 0 0\nKe 20 20 20\n";

/// The mean radiance arriving at `eye` from the origin, by next-event estimation and
/// direct light only, over `n` samples.
fn radiance_at_origin(built: &Built, eye: Vec3, kind: IntegratorKind, n: u64) -> Vec3 {
    let tracer = PathTracer::new(&built.scene, &built.accel, 2, kind);
    let mut count = RayCount::default();
    let mut sum = glam::DVec3::ZERO;
    for i in 0..n {
        let mut rng = Rng::for_sample(7, 0, i);
        let ray = Ray::new(eye, (-eye).normalize());
        sum += tracer.radiance(ray, &mut rng, &mut count).as_dvec3();
    }
    (sum / n as f64).as_vec3()
}

/// An EXR of one colour (exact f32 values, no sRGB curve).
fn exr(colour: Vec3) -> DynamicImage {
    DynamicImage::ImageRgb32F(Rgb32FImage::from_pixel(4, 4, Rgb(colour.to_array())))
}

/// The square [-half, half]² in the xy plane (normal +z), turned by `turn`.
fn square(half: f32, turn: glam::Quat) -> [Vec3; 4] {
    [(-1.0, -1.0), (1.0, -1.0), (1.0, 1.0), (-1.0, 1.0)]
        .map(|(x, y)| turn * Vec3::new(x * half, y * half, 0.0))
}

#[test]
fn a_constant_normal_map_shades_like_the_tilted_plane() {
    let tilt = 30f32.to_radians();
    // Tilted towards +u (red channel) and towards +v (green channel: +v is "up").
    let turns = [
        glam::Quat::from_rotation_y(tilt),
        glam::Quat::from_rotation_x(-tilt),
    ];
    for turn in turns {
        let n = turn * Vec3::Z;
        assert_tilt_matches(n, turn);
    }
}

/// The quad with a normal map of the constant normal `n` against the quad turned by
/// `turn` (whose normal is `n`), under the same light and seen by the same viewer.
fn assert_tilt_matches(n: Vec3, turn: glam::Quat) {
    let light = Vec3::new(0.6, 0.3, 2.0);
    let eye = Vec3::new(-0.8, 0.4, 3.0);
    // A glossy lobe as well as a diffuse one, so the frame matters, not just the normal.
    let material = "newmtl surface\nKd 0.5 0.4 0.3\nKs 0.2 0.2 0.2\nPr 0.5\n";
    let mapped = load(
        &quad_and_light(square(1.0, glam::Quat::IDENTITY), light),
        &format!("{material}norm tilt.exr\n{LIGHT}"),
        &[("tilt.exr", exr(0.5 * n + Vec3::splat(0.5)))],
    )
    .unwrap();
    let tilted = load(
        &quad_and_light(square(1.0, turn), light),
        &format!("{material}{LIGHT}"),
        &[],
    )
    .unwrap();
    // The shading normal itself, at the quad's centre.
    let hit = Hit {
        t: 1.0,
        prim: 0,
        u: 0.25,
        v: 0.5,
        instance: 0,
    };
    let ns = mapped.surface(&hit).ns;
    assert!((ns - n).length() < 1e-5, "{ns} vs {n}");
    // Tangents exist only where a normal map needs them.
    assert_eq!(mapped.tangents.len(), mapped.mesh.positions.len());
    assert!(tilted.tangents.is_empty());
    let (mapped, tilted) = (with_embree(mapped), with_embree(tilted));
    for kind in [IntegratorKind::Light, IntegratorKind::Mis] {
        let a = radiance_at_origin(&mapped, eye, kind, 20_000);
        let b = radiance_at_origin(&tilted, eye, kind, 20_000);
        // The same light points are drawn for both (same random streams), so the
        // estimates agree far below their own noise.
        let relative = (a - b).abs().max_element() / b.max_element();
        assert!(
            b.min_element() > 0.0 && relative < 2e-3,
            "{kind:?} {n}: {a} vs {b}"
        );
    }
}

/// An 8-bit flat normal map (128, 128, 255) leaves the normal within its quantisation.
#[test]
fn a_flat_eight_bit_normal_map_keeps_the_normal() {
    let flat = DynamicImage::ImageRgb8(RgbImage::from_pixel(4, 4, Rgb([128, 128, 255])));
    let obj = quad_and_light(square(1.0, glam::Quat::IDENTITY), Vec3::new(0.0, 0.0, 2.0));
    let mtl = format!("newmtl surface\nKd 0.5 0.5 0.5\nnorm flat.png\n{LIGHT}");
    let scene = load(&obj, &mtl, &[("flat.png", flat)]).unwrap();
    let ns = centre(&scene).ns;
    assert!((ns - Vec3::Z).length() < 2.0 / 255.0 * 2.0, "{ns}");
}

/// A ramp `h = i / 64` over the 64 texel columns, `rows` high: slope 1 per unit of u.
fn height_ramp_exr() -> DynamicImage {
    DynamicImage::ImageRgb32F(Rgb32FImage::from_fn(
        64,
        4,
        |x, _| Rgb([x as f32 / 64.0; 3]),
    ))
}

#[test]
fn a_height_ramp_tilts_the_normal_by_its_known_slope() {
    // Quad [0, 2]² (∂p/∂u = 2 x̂, ∂p/∂v = 2 ŷ), heights h·k with k = -bm 0.5.
    let q = [(0.0, 0.0), (2.0, 0.0), (2.0, 2.0), (0.0, 2.0)].map(|(x, y)| Vec3::new(x, y, 0.0));
    let obj = quad_and_light(q, Vec3::new(1.0, 1.0, 3.0));
    // EXR (exact ramp, slope 1) and 8-bit PNG (texel i holds i/255 over 256 columns:
    // slope 256/255).
    let png = DynamicImage::ImageLuma8(GrayImage::from_fn(256, 2, |x, _| Luma([x as u8])));
    // Rising along v instead (row 0 is the top, v = 1): slope 1 in v.
    let along_v = DynamicImage::ImageRgb32F(Rgb32FImage::from_fn(4, 64, |_, y| {
        Rgb([(63 - y) as f32 / 64.0; 3])
    }));
    let (u_slope, v_slope) = (Vec3::new(-0.5, 0.0, 2.0), Vec3::new(0.0, -0.5, 2.0));
    for (file, image, slope, statement) in [
        ("h.exr", height_ramp_exr(), u_slope, "bump -bm 0.5 h.exr"),
        (
            "h.png",
            png,
            u_slope * Vec3::new(256.0 / 255.0, 1.0, 1.0),
            "map_Bump -bm 0.5 h.png",
        ),
        ("v.exr", along_v, v_slope, "bump -bm 0.5 v.exr"),
    ] {
        let mtl = format!("newmtl surface\nKd 0.5 0.5 0.5\n{statement}\n{LIGHT}");
        let scene = load(&obj, &mtl, &[(file, image)]).unwrap();
        let expected = slope.normalize();
        // Points away from the seams at u, v = 0 (where the ramps wrap).
        for (u, v) in [(0.3, 0.2), (0.1, 0.1), (0.2, 0.6)] {
            let hit = Hit {
                t: 1.0,
                prim: 0,
                u,
                v,
                instance: 0,
            };
            let s = scene.surface(&hit);
            assert!(s.uv.cmpgt(glam::Vec2::splat(0.05)).all());
            assert!(s.uv.cmplt(glam::Vec2::splat(0.95)).all());
            assert!(
                (s.ns - expected).length() < 1e-4,
                "{file}: {} vs {expected}",
                s.ns
            );
            assert_eq!(s.ng, Vec3::Z, "the geometric normal is untouched");
        }
    }
}

#[test]
fn normals_mapped_below_the_surface_let_no_light_through() {
    // The map's normal points 11° below the quad (z < 0), towards +x.
    let below = Vec3::new(1.0, 0.0, -0.2).normalize();
    let map = exr(0.5 * below + Vec3::splat(0.5));
    let mtl =
        format!("newmtl surface\nKd 0.8 0.8 0.8\nKs 0.2 0.2 0.2\nPr 0.3\nnorm n.exr\n{LIGHT}");
    // The light under the quad, facing up at its back; the viewer above.
    let obj = quad_and_light(square(1.0, glam::Quat::IDENTITY), Vec3::new(0.5, 0.0, -1.0)).replace(
        "f 5/1 6/2 7/3\nf 5/1 7/3 8/4",
        "f 5/1 7/3 6/2\nf 5/1 8/4 7/3",
    );
    let built = with_embree(load(&obj, &mtl, &[("n.exr", map.clone())]).unwrap());
    for kind in [
        IntegratorKind::Light,
        IntegratorKind::Mis,
        IntegratorKind::Bsdf,
        IntegratorKind::Mixture,
    ] {
        let l = radiance_at_origin(&built, Vec3::new(-0.5, 0.2, 2.0), kind, 4_000);
        assert_eq!(l, Vec3::ZERO, "{kind:?}");
    }
    // The BSDF there is zero for every pair of directions on opposite sides, and not
    // black on the lit side: the bent normal still reflects.
    let scene = &built.scene;
    let s = scene.surface(&Hit {
        t: 1.0,
        prim: 0,
        u: 0.3,
        v: 0.3,
        instance: 0,
    });
    assert!(s.ns.dot(s.ng) > 0.0);
    let mut rng = Rng::seeded(3);
    let mut lit = 0.0;
    for _ in 0..2_000 {
        let wo = ember::sampling::uniform_sphere(rng.f32(), rng.f32());
        let wi = ember::sampling::uniform_sphere(rng.f32(), rng.f32());
        let f = scene.bsdf(&s, wo).eval(wo, wi);
        if wo.z * wi.z <= 0.0 {
            assert_eq!(f, Vec3::ZERO, "wo {wo} wi {wi}");
        } else {
            lit += f.x;
        }
    }
    assert!(lit > 0.0);
    // Lit from above instead, the same surface reflects light.
    let obj = quad_and_light(square(1.0, glam::Quat::IDENTITY), Vec3::new(0.5, 0.0, 2.0));
    let lit_from_above = with_embree(load(&obj, &mtl, &[("n.exr", map)]).unwrap());
    let l = radiance_at_origin(
        &lit_from_above,
        Vec3::new(-0.5, 0.2, 2.0),
        IntegratorKind::Mis,
        2_000,
    );
    assert!(l.min_element() > 0.0 && l.is_finite());
}

/// A one-triangle scene whose material is `mtl`, with UV (0.5, 0.5) everywhere.
fn point_scene(mtl: &str, files: &[(&str, DynamicImage)]) -> Result<Scene, SceneError> {
    let obj = "mtllib scene.mtl\nusemtl m\nv 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0.5 0.5\nf 1/1 2/1 3/1\n";
    load(obj, &format!("newmtl m\n{mtl}\n"), files)
}

fn centre(scene: &Scene) -> ember::scene::SurfacePoint {
    scene.surface(&Hit {
        t: 1.0,
        prim: 0,
        u: 0.3,
        v: 0.3,
        instance: 0,
    })
}

fn srgb_to_linear(c: f32) -> f32 {
    if c <= 0.04045 {
        c / 12.92
    } else {
        ((c + 0.055) / 1.055).powf(2.4)
    }
}

#[test]
fn every_format_decodes_colour_as_srgb_and_data_as_linear() {
    let ldr = DynamicImage::ImageRgb8(RgbImage::from_pixel(8, 8, Rgb([200, 100, 50])));
    let code = Vec3::new(200.0, 100.0, 50.0) / 255.0;
    let srgb = Vec3::new(
        srgb_to_linear(code.x),
        srgb_to_linear(code.y),
        srgb_to_linear(code.z),
    );
    let hdr_value = Vec3::new(0.75, 0.5, 0.25);
    let hdr = exr(hdr_value);
    let cases: [(&str, &DynamicImage, Vec3, f32); 6] = [
        ("t.png", &ldr, srgb, 1e-6),
        ("t.tga", &ldr, srgb, 1e-6),
        ("t.bmp", &ldr, srgb, 1e-6),
        // JPEG is lossy: a flat colour comes back within a code or two.
        ("t.jpg", &ldr, srgb, 0.02),
        ("t.exr", &hdr, hdr_value, 1e-6),
        ("t.hdr", &hdr, hdr_value, 0.01),
    ];
    for (file, image, expected, tolerance) in cases {
        let image = if file.ends_with(".hdr") {
            DynamicImage::ImageRgb32F(image.to_rgb32f())
        } else {
            (*image).clone()
        };
        let scene = point_scene(&format!("Kd 1 1 1\nmap_Kd {file}"), &[(file, image)]).unwrap();
        let albedo = scene.albedo(&centre(&scene));
        assert!(
            (albedo - expected).abs().max_element() < tolerance,
            "{file}: {albedo} vs {expected}"
        );
    }
    // The same 8-bit grey as data: a metallic of 100/255, not sRGB-decoded.
    let grey = DynamicImage::ImageLuma8(GrayImage::from_pixel(4, 4, Luma([100])));
    let scene = point_scene("Kd 1 0 0\nmap_Pm m.png", &[("m.png", grey)]).unwrap();
    let metallic = scene.params(&centre(&scene)).metallic;
    assert!((metallic - 100.0 / 255.0).abs() < 1e-6, "{metallic}");
}

#[test]
fn names_with_spaces_backslashes_and_options() {
    let white = DynamicImage::ImageRgb8(RgbImage::from_pixel(2, 2, Rgb([255, 255, 255])));
    let scene = point_scene(
        "Kd 1 1 1\nmap_Kd -s 1 1 1 -o 0 0 -clamp off -bm 2 my textures\\wood grain.png",
        &[("my textures/wood grain.png", white)],
    )
    .unwrap();
    assert_eq!(scene.albedo(&centre(&scene)), Vec3::ONE);
}

/// A texture that is absent is one warning naming the slot (the scene loads without the
/// map), or with `strict` the error; one that is there but damaged, or a statement
/// that does not read, is an error either way.
#[test]
fn missing_corrupt_or_badly_optioned_textures() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("bad.png"), b"not an image").unwrap();
    let cases = [
        ("map_Ks gone.png", "map_Ks", "not found", true),
        ("norm gone.png", "norm", "not found", true),
        ("map_Pr bad.png", "map_Pr", "bad.png", false),
        ("bump -bm x h.png", "bump", "-bm", false),
        ("map_Ke -frobnicate 1 e.png", "map_Ke", "-frobnicate", false),
    ];
    for (statement, slot, detail, absent) in cases {
        let obj = "mtllib scene.mtl\nusemtl m\nv 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n";
        std::fs::write(dir.path().join("scene.obj"), obj).unwrap();
        let mtl = format!("newmtl m\nKd 1 1 1\n{statement}\n");
        std::fs::write(dir.path().join("scene.mtl"), mtl).unwrap();
        let path = dir.path().join("scene.obj");
        let strict = LoadOptions { strict: true };
        let message = match load_obj_with(&path, &strict) {
            Ok(_) => panic!("{statement} loaded with --strict"),
            Err(e) => e.to_string(),
        };
        assert!(!message.contains('\n'), "{message}");
        assert!(
            message.contains(slot) && message.contains(detail),
            "{statement}: {message}"
        );
        match load_obj(&path) {
            Ok((scene, report)) => {
                assert!(absent, "{statement} loaded");
                let [warning] = report.warnings.as_slice() else {
                    panic!("{statement}: {:?}", report.warnings);
                };
                assert!(warning.starts_with(&message), "{warning} vs {message}");
                let maps = &scene.materials[0].maps;
                assert!(maps.specular.is_none() && maps.normal.is_none());
            }
            Err(e) => assert!(!absent && e.to_string() == message, "{statement}: {e}"),
        }
    }
    let message = point_scene("Pr 2", &[]).err().unwrap().to_string();
    assert!(message.contains("Pr"), "{message}");
}

#[test]
fn roughness_and_metallic_map_onto_the_ggx_models() {
    // Pr sets α = Pr²; Pm = 1 turns the diffuse colour into the Fresnel of a conductor.
    let red = point_scene("Kd 0.8 0.1 0.1\nKs 0.04 0.04 0.04\nPr 0.5\nPm 1", &[]).unwrap();
    let s = centre(&red);
    let p = red.params(&s);
    assert_eq!(p.alpha, 0.25);
    let metal = ember::bsdf::Bsdf::glossy(Vec3::ZERO, Vec3::new(0.8, 0.1, 0.1), 0.25, s.ns, s.ng);
    let bsdf = red.bsdf(&s, Vec3::Z);
    let mut rng = Rng::seeded(5);
    for _ in 0..200 {
        let wo = ember::sampling::uniform_sphere(rng.f32(), rng.f32());
        let wi = ember::sampling::uniform_sphere(rng.f32(), rng.f32());
        let (a, b) = (bsdf.eval(wo, wi), metal.eval(wo, wi));
        assert!((a - b).abs().max_element() <= 1e-5 * b.max_element().max(1.0));
    }
    // map_Pr multiplies Pr (1 when absent): a grey of 51/255 = 0.2 gives α = 0.04.
    let grey = DynamicImage::ImageLuma8(GrayImage::from_pixel(2, 2, Luma([51])));
    let rough = point_scene(
        "Kd 0.5 0.5 0.5\nKs 0.1 0.1 0.1\nmap_Pr r.png",
        &[("r.png", grey)],
    )
    .unwrap();
    let alpha = rough.params(&centre(&rough)).alpha;
    assert!((alpha - 0.04).abs() < 1e-6, "{alpha}");
    // A colour map_Ks replaces Ks and turns a Lambert material into a coated one.
    let ks = DynamicImage::ImageRgb8(RgbImage::from_pixel(2, 2, Rgb([255, 0, 0])));
    let coated = point_scene("Kd 0.5 0.5 0.5\nmap_Ks s.png", &[("s.png", ks)]).unwrap();
    assert_eq!(coated.params(&centre(&coated)).specular, Vec3::X);
    assert!(matches!(
        coated.materials[0].model,
        ember::scene::Model::Coated { .. }
    ));
}

#[test]
fn textured_emission_is_sampled_consistently() {
    // A light whose map_Ke is white on its left half (u < 0.5) and black on the right,
    // centred over the receiver: by symmetry the receiver gets half the light of the
    // untextured one, whichever way the estimator finds the light.
    let half = DynamicImage::ImageRgb8(RgbImage::from_fn(64, 2, |x, _| {
        Rgb([if x < 32 { 255 } else { 0 }; 3])
    }));
    let surface = "newmtl surface\nKd 0.5 0.5 0.5\n";
    let obj = quad_and_light(square(1.0, glam::Quat::IDENTITY), Vec3::new(0.0, 0.0, 0.5));
    let plain = with_embree(load(&obj, &format!("{surface}{LIGHT}"), &[]).unwrap());
    let textured = with_embree(
        load(
            &obj,
            &format!("{surface}{LIGHT}map_Ke half.png\n"),
            &[("half.png", half)],
        )
        .unwrap(),
    );
    // Seen from beside the light, which would hide the receiver from straight above.
    let eye = Vec3::new(0.0, -1.5, 2.0);
    let reference = radiance_at_origin(&plain, eye, IntegratorKind::Light, 20_000);
    for kind in [
        IntegratorKind::Light,
        IntegratorKind::Mis,
        IntegratorKind::Mixture,
        IntegratorKind::Bsdf,
    ] {
        let n = if kind == IntegratorKind::Bsdf {
            1_000_000
        } else {
            40_000
        };
        let l = radiance_at_origin(&textured, eye, kind, n);
        let ratio = l.x / reference.x;
        assert!((ratio - 0.5).abs() < 0.02, "{kind:?}: {ratio}");
    }
}
