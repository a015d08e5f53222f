//! Texture samplers against their definitions: glTF's `REPEAT`, `CLAMP_TO_EDGE` and
//! `MIRRORED_REPEAT` on each axis read the texel the specification's formulas name,
//! `NEAREST` reads it exactly and `LINEAR` blends the two nearest centres; two samplers
//! on one image each keep theirs; MTL's `-clamp on` clamps; and a render of a textured
//! quad through clamped and repeating samplers differs exactly where the texture
//! coordinates leave `[0, 1]`.

mod common;

use std::path::Path;

use common::gltf::{floor_quad, png_data_uri, GltfBuilder};
use common::{ember_in, with_embree, Built};
use ember::accel::{Accel, Ray};
use ember::image::{srgb_to_linear, Image};
use ember::scene::{load_gltf, load_obj, LoadOptions, Sampler};
use glam::Vec3;
use serde_json::json;

const REPEAT: u32 = 10497;
const CLAMP: u32 = 33071;
const MIRROR: u32 = 33648;
const NEAREST: u32 = 9728;
const LINEAR: u32 = 9729;

/// The bytes of the texels: column `c` holds `LEVELS[c]` in red, row `r` `LEVELS[r]` in
/// green.
const LEVELS: [u8; 4] = [0, 85, 170, 255];

/// The 4 × 4 texture above.
fn grid() -> image::RgbImage {
    image::RgbImage::from_fn(4, 4, |x, y| {
        image::Rgb([LEVELS[x as usize], LEVELS[y as usize], 0])
    })
}

fn png(image: image::RgbImage) -> Vec<u8> {
    let mut bytes = Vec::new();
    image::DynamicImage::ImageRgb8(image)
        .write_to(
            &mut std::io::Cursor::new(&mut bytes),
            image::ImageFormat::Png,
        )
        .unwrap();
    bytes
}

/// The texel a coordinate `c` of glTF's texture space reads on an axis of 4 texels, by
/// the specification's definitions of the wrap modes.
fn texel(mode: u32, c: f32) -> usize {
    let f = match mode {
        REPEAT => c - c.floor(),
        CLAMP => c.clamp(0.0, 1.0),
        // mirror(f) = f − floor(f) where floor(f) is even, 1 − (f − floor(f)) where odd.
        MIRROR if (c.floor() as i64).rem_euclid(2) == 0 => c - c.floor(),
        MIRROR => 1.0 - (c - c.floor()),
        _ => unreachable!(),
    };
    ((f * 4.0).floor() as usize).min(3)
}

/// The linear value of byte `b` of an sRGB base colour texture.
fn linear(b: u8) -> f32 {
    srgb_to_linear(f32::from(b) / 255.0)
}

/// Quads of side 2 at y = 0 facing up, the `k`-th centred at (0, 0, 4k), each of base
/// colour texture `k`: glTF texture coordinates run from (−1, −1) at its corner
/// (−1, 0, −1) to (2, 2) at (1, 0, 1).
fn quads(gltf: &mut GltfBuilder, textures: usize) {
    for k in 0..textures {
        let m = gltf.material(
            json!({"pbrMetallicRoughness": {"baseColorTexture": {"index": k},
            "metallicFactor": 0.0, "roughnessFactor": 1.0}}),
        );
        let (p, _, i) = floor_quad(1.0, 0.0);
        let uv = [[-1.0, -1.0], [2.0, -1.0], [2.0, 2.0], [-1.0, 2.0]];
        let mesh = gltf.mesh(&p, Some(&uv), &i, Some(m));
        gltf.node(
            json!({"mesh": mesh, "translation": [0.0, 0.0, 4.0 * k as f32]}),
            true,
        );
    }
}

fn load(gltf: &GltfBuilder, dir: &Path) -> (Built, Vec<String>) {
    let path = dir.join("samplers.gltf");
    std::fs::write(&path, gltf.to_gltf()).unwrap();
    let loaded = load_gltf(&path, &LoadOptions::default()).expect("loads");
    let warnings = loaded.report.warnings.clone();
    (with_embree(loaded.scene), warnings)
}

/// The base colour of quad `k` at glTF texture coordinates `(u, v)`.
fn albedo(built: &Built, k: usize, u: f32, v: f32) -> Vec3 {
    let (x, z) = (2.0 * (u + 1.0) / 3.0 - 1.0, 2.0 * (v + 1.0) / 3.0 - 1.0);
    let ray = Ray::new(Vec3::new(x, 1.0, z + 4.0 * k as f32), -Vec3::Y);
    let hit = built.accel.intersect(&ray).expect("the quad");
    built.scene.albedo(&built.scene.surface(&hit))
}

/// Coordinates inside, before and past `[0, 1]`, none on a texel's edge.
const COORDINATES: [f32; 7] = [-0.9, -0.3, 0.1, 0.6, 1.3, 1.6, 1.9];

#[test]
fn nearest_lookups_read_the_texel_each_wrap_mode_defines() {
    let dir = tempfile::tempdir().unwrap();
    let modes = [REPEAT, CLAMP, MIRROR];
    // Every pair of modes for s and t, one texture each, all of one image.
    let pairs: Vec<(u32, u32)> = modes
        .iter()
        .flat_map(|&s| modes.iter().map(move |&t| (s, t)))
        .collect();
    let mut gltf = GltfBuilder::default();
    gltf.json["images"] = json!([{"uri": png_data_uri(grid())}]);
    gltf.json["samplers"] = json!(pairs
        .iter()
        .map(|&(s, t)| json!({"magFilter": NEAREST, "minFilter": NEAREST, "wrapS": s, "wrapT": t}))
        .collect::<Vec<_>>());
    gltf.json["textures"] = json!((0..pairs.len())
        .map(|k| json!({"source": 0, "sampler": k}))
        .collect::<Vec<_>>());
    quads(&mut gltf, pairs.len());
    let (built, warnings) = load(&gltf, dir.path());
    assert!(warnings.is_empty(), "{warnings:?}");
    assert_eq!(built.scene.textures.len(), pairs.len());
    for (k, &(s, t)) in pairs.iter().enumerate() {
        for u in COORDINATES {
            for v in COORDINATES {
                let got = albedo(&built, k, u, v);
                // Exactly the texel's value: nearest filtering blends nothing.
                let want = Vec3::new(
                    linear(LEVELS[texel(s, u)]),
                    linear(LEVELS[texel(t, v)]),
                    0.0,
                );
                assert_eq!(got, want, "wrapS {s}, wrapT {t} at ({u}, {v})");
            }
        }
    }
}

/// `LINEAR` blends the two nearest texel centres by distance; clamped past an edge, it
/// reads the edge texel alone. A sampler whose two filters differ is bilinear, with
/// one warning.
#[test]
fn linear_lookups_blend_the_nearest_texel_centres() {
    let dir = tempfile::tempdir().unwrap();
    let mut gltf = GltfBuilder::default();
    gltf.json["images"] = json!([{"uri": png_data_uri(grid())}]);
    gltf.json["samplers"] = json!([
        {"magFilter": LINEAR, "minFilter": LINEAR, "wrapS": CLAMP, "wrapT": REPEAT},
        {"magFilter": NEAREST, "minFilter": LINEAR},
        {"magFilter": NEAREST},
    ]);
    gltf.json["textures"] = json!([
        {"source": 0, "sampler": 0},
        {"source": 0, "sampler": 1},
        {"source": 0, "sampler": 2},
    ]);
    quads(&mut gltf, 3);
    let (built, warnings) = load(&gltf, dir.path());
    assert_eq!(warnings.len(), 1, "{warnings:?}");
    assert!(
        warnings[0].contains("1 samplers filter magnification and minification differently"),
        "{warnings:?}"
    );
    let close = |got: f32, want: f32| (got - want).abs() < 1e-5;
    // u = 0.3: texel-space 0.3·4 − 0.5 = 0.7 past the centre of texel 0.
    let blend = 0.3 * linear(LEVELS[0]) + 0.7 * linear(LEVELS[1]);
    for k in [0, 1] {
        let got = albedo(&built, k, 0.3, 0.6).x;
        assert!(close(got, blend), "texture {k}: {got} vs {blend}");
    }
    // Clamped: past either edge, the edge texel alone.
    assert!(close(albedo(&built, 0, -0.3, 0.6).x, linear(LEVELS[0])));
    assert!(close(albedo(&built, 0, 1.6, 0.6).x, linear(LEVELS[3])));
    // magFilter NEAREST alone: the texel itself.
    assert_eq!(albedo(&built, 2, 0.3, 0.6).x, linear(LEVELS[1]));
}

/// Two samplers on one image: each texture keeps its own (the image is decoded once,
/// a texture made per sampler); a third texture of the same image and sampler shares.
#[test]
fn two_samplers_on_one_image_each_keep_theirs() {
    let dir = tempfile::tempdir().unwrap();
    let mut gltf = GltfBuilder::default();
    gltf.json["images"] = json!([{"uri": png_data_uri(grid())}]);
    gltf.json["samplers"] = json!([
        {"magFilter": NEAREST, "minFilter": NEAREST, "wrapS": CLAMP, "wrapT": CLAMP},
        {"magFilter": NEAREST, "minFilter": NEAREST},
    ]);
    gltf.json["textures"] = json!([
        {"source": 0, "sampler": 0},
        {"source": 0, "sampler": 1},
        {"source": 0, "sampler": 0},
    ]);
    quads(&mut gltf, 3);
    let (built, _) = load(&gltf, dir.path());
    assert_eq!(built.scene.textures.len(), 2);
    let maps: Vec<Option<u32>> = built
        .scene
        .materials
        .iter()
        .map(|m| m.diffuse_texture)
        .collect();
    assert_eq!(maps[..3], [Some(0), Some(1), Some(0)]);
    for k in 0..3 {
        let mode = if k == 1 { REPEAT } else { CLAMP };
        for u in [-0.3, 1.3] {
            let want = linear(LEVELS[texel(mode, u)]);
            assert_eq!(albedo(&built, k, u, 0.6).x, want, "texture {k} at u = {u}");
        }
    }
}

/// MTL maps repeat, and clamp with `-clamp on`.
#[test]
fn mtl_clamp_on_clamps() {
    let dir = tempfile::tempdir().unwrap();
    let row = image::RgbImage::from_fn(4, 1, |x, _| image::Rgb([LEVELS[x as usize]; 3]));
    std::fs::write(dir.path().join("row.png"), png(row)).unwrap();
    let mtl = "newmtl clamped\nKd 1 1 1\nmap_Kd -clamp on row.png\n\n\
               newmtl repeating\nKd 1 1 1\nmap_Kd row.png\n";
    std::fs::write(dir.path().join("quads.mtl"), mtl).unwrap();
    // Two quads side by side at y = 0 facing up, u from −1 to 2 along x.
    let mut obj = String::from("mtllib quads.mtl\nvt -1 0.5\nvt 2 0.5\n");
    for (k, name) in ["clamped", "repeating"].iter().enumerate() {
        let z = 4.0 * k as f32;
        obj += &format!(
            "v -1 0 {}\nv 1 0 {}\nv 1 0 {}\nv -1 0 {}\nusemtl {name}\n",
            z - 1.0,
            z - 1.0,
            z + 1.0,
            z + 1.0
        );
        let b = 4 * k + 1;
        obj += &format!(
            "f {}/1 {}/2 {}/2\nf {}/1 {}/2 {}/1\n",
            b + 3,
            b + 2,
            b + 1,
            b + 3,
            b + 1,
            b
        );
    }
    std::fs::write(dir.path().join("quads.obj"), obj).unwrap();
    let (scene, _) = load_obj(&dir.path().join("quads.obj")).unwrap();
    let samplers: Vec<Sampler> = scene.textures.iter().map(|t| t.sampler).collect();
    assert_eq!(samplers, [Sampler::CLAMP, Sampler::default()]);
    let built = with_embree(scene);
    let at = |k: usize, u: f32| {
        let x = 2.0 * (u + 1.0) / 3.0 - 1.0;
        let ray = Ray::new(Vec3::new(x, 1.0, 4.0 * k as f32), -Vec3::Y);
        let hit = built.accel.intersect(&ray).expect("the quad");
        built.scene.albedo(&built.scene.surface(&hit)).x
    };
    let close = |got: f32, want: f32| (got - want).abs() < 1e-5;
    // Bilinear either way: past the edges, clamping reads the edge texel alone.
    assert!(close(at(0, -0.3), linear(LEVELS[0])));
    assert!(close(at(0, 1.6), linear(LEVELS[3])));
    // Repeating, u = −0.3 is 0.7: texel-space 2.3, between texels 2 and 3.
    let repeat = 0.7 * linear(LEVELS[2]) + 0.3 * linear(LEVELS[3]);
    assert!(close(at(1, -0.3), repeat), "{} vs {repeat}", at(1, -0.3));
}

/// A glTF quad of side 3 facing +z with an emissive 2 × 1 texture (black, white;
/// nearest) whose `u` runs from −1 to 2 across it, seen whole by an orthographic
/// camera (`xmag` = `ymag` = 1.5).
fn emissive_quad(wrap: u32) -> GltfBuilder {
    let mut gltf = GltfBuilder::default();
    let texture = image::RgbImage::from_fn(2, 1, |x, _| image::Rgb([255 * x as u8; 3]));
    gltf.json["images"] = json!([{"uri": png_data_uri(texture)}]);
    gltf.json["samplers"] =
        json!([{"magFilter": NEAREST, "minFilter": NEAREST, "wrapS": wrap, "wrapT": wrap}]);
    gltf.json["textures"] = json!([{"source": 0, "sampler": 0}]);
    let m = gltf.material(json!({"emissiveFactor": [1.0, 1.0, 1.0],
        "emissiveTexture": {"index": 0},
        "pbrMetallicRoughness": {"baseColorFactor": [0.0, 0.0, 0.0, 1.0], "metallicFactor": 0.0}}));
    let p = [
        [-1.5, -1.5, 0.0],
        [1.5, -1.5, 0.0],
        [1.5, 1.5, 0.0],
        [-1.5, 1.5, 0.0],
    ];
    let uv = [[-1.0, 0.5], [2.0, 0.5], [2.0, 0.5], [-1.0, 0.5]];
    let mesh = gltf.mesh(&p, Some(&uv), &[0, 1, 2, 0, 2, 3], Some(m));
    gltf.node(json!({"mesh": mesh}), true);
    gltf.json["cameras"] = json!([{"type": "orthographic",
        "orthographic": {"xmag": 1.5, "ymag": 1.5, "znear": 0.0, "zfar": 10.0}}]);
    gltf.node(json!({"camera": 0, "translation": [0.0, 0.0, 5.0]}), true);
    gltf
}

/// Rendered (emission only), a pixel column shows the texel of its `u`: 16 columns per
/// unit of `u`, texels half a unit wide. Clamped, the left third is black and the right
/// third white; repeating, both show the texture again; they differ exactly there.
#[test]
fn a_render_of_clamped_and_repeating_textures_differs_where_u_leaves_the_image() {
    let dir = tempfile::tempdir().unwrap();
    let render = |wrap: u32| {
        std::fs::write(dir.path().join("quad.gltf"), emissive_quad(wrap).to_gltf()).unwrap();
        let args = [
            "render",
            "quad.gltf",
            "--width",
            "48",
            "--height",
            "48",
            "--max-depth",
            "1",
            "--spp",
            "2",
            "-o",
            "out.exr",
        ];
        let run = ember_in(&args, dir.path());
        assert!(
            run.status.success(),
            "{}",
            String::from_utf8_lossy(&run.stderr)
        );
        Image::load(&dir.path().join("out.exr")).unwrap()
    };
    for wrap in [CLAMP, REPEAT, MIRROR] {
        let image = render(wrap);
        for (i, p) in image.pixels.iter().enumerate() {
            let column = i % 48;
            let u = -1.0 + (column as f32 + 0.5) / 16.0;
            // Two texels: the texel-4 index halved.
            let want = (texel(wrap, u) / 2) as f32;
            assert_eq!(p.x, want, "wrap {wrap}, pixel {i} (u = {u})");
        }
    }
    let info = ember_in(&["info", "quad.gltf"], dir.path());
    let out = String::from_utf8_lossy(&info.stdout);
    assert!(out.contains("2x1 8-bit sRGB (mirror, nearest)"), "{out}");
    let (clamped, repeating) = (render(CLAMP), render(REPEAT));
    let differ: Vec<usize> = (0..48)
        .filter(|&c| clamped.pixels[c] != repeating.pixels[c])
        .collect();
    // Where u < 0 reads white repeating (u in [−0.5, 0)), and u > 1 black (in [1, 1.5)).
    let expected: Vec<usize> = (8..16).chain(32..40).collect();
    assert_eq!(differ, expected);
}
