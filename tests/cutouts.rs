//! Cut-outs against known answers, on both backends: a quad between a point and an
//! area light lets through exactly the fraction of light its opacity says. The scenes
//! are real OBJ/MTL/PNG files, so the loader's reading of `d`, `Tr`, `map_d` and the
//! alpha of `map_Kd` is tested with the filters.

use ember::accel::{Accel, Bvh, EmbreeAccel};
use ember::embree::{BuildQuality, Device, PACKET_WIDTH};
use ember::geometry::Ray;
use ember::sampling::Rng;
use ember::scene::{load_obj, Scene, SceneError};
use glam::Vec3;
use image::{GrayImage, Luma, Rgba, RgbaImage};

/// A 2×2 quad at height 1 over the origin (the "leaf", material `leaf`, UVs over the
/// whole texture) and nothing else.
const QUAD: &str = "mtllib scene.mtl
v -1 -1 1
v 1 -1 1
v 1 1 1
v -1 1 1
vt 0 0
vt 1 0
vt 1 1
vt 0 1
usemtl leaf
f 1/1 2/2 3/3
f 1/1 3/3 4/4
";

/// An 8×8 checkerboard: cells a quarter of the quad wide.
fn checker(cell: impl Fn(bool) -> [u8; 4]) -> RgbaImage {
    RgbaImage::from_fn(8, 8, |x, y| Rgba(cell((x + y) % 2 == 0)))
}

/// Writes the quad with `mtl` (the body of material `leaf`) and `files` beside it.
fn scene(mtl: &str, files: &[(&str, image::DynamicImage)]) -> Result<Scene, SceneError> {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("scene.obj"), QUAD).unwrap();
    std::fs::write(
        dir.path().join("scene.mtl"),
        format!("newmtl leaf\n{mtl}\n"),
    )
    .unwrap();
    for (name, image) in files {
        image.save(dir.path().join(name)).unwrap();
    }
    load_obj(&dir.path().join("scene.obj")).map(|(scene, _)| scene)
}

fn loaded(mtl: &str, files: &[(&str, image::DynamicImage)]) -> Scene {
    scene(mtl, files).expect("scene loads")
}

/// The native BVH's answers for a ray: (occluded, intersected).
type BvhQuery = Box<dyn Fn(&Ray) -> (bool, bool)>;

/// The two backends over `scene`, each with its cut-out filter when it has one.
fn backends(scene: &Scene) -> (EmbreeAccel, BvhQuery) {
    let device = Device::new("").unwrap();
    let (v, t) = (&scene.mesh.positions, &scene.mesh.triangles);
    let q = BuildQuality::High;
    let bvh = Bvh::build(v, t).unwrap();
    match scene.opacity() {
        Some(op) => {
            let embree = EmbreeAccel::build_filtered(&device, v, t, q, op.clone()).unwrap();
            let bvh = bvh.with_filter(op);
            (
                embree,
                Box::new(move |r| (bvh.occluded(r), bvh.intersect(r).is_some())),
            )
        }
        None => (
            EmbreeAccel::build(&device, v, t, q).unwrap(),
            Box::new(move |r| (bvh.occluded(r), bvh.intersect(r).is_some())),
        ),
    }
}

/// Light samples on the square `[-0.5, 0.5]²` at height 2, seen from the origin: their
/// shadow rays cross the quad inside `[-0.25, 0.25]²`, 2×2 checker cells.
fn light_rays(n: usize) -> Vec<(Ray, f32)> {
    let mut rng = Rng::seeded(11);
    (0..n)
        .map(|_| {
            let (a, b) = rng.pair();
            let y = Vec3::new(a - 0.5, b - 0.5, 2.0);
            // Irradiance weight: cos at the receiver, cos at the light, over r².
            let r2 = y.length_squared();
            let w = (y.z * y.z) / (r2 * r2);
            (Ray::segment(Vec3::ZERO, y, 1.0 - 1e-4), w)
        })
        .collect()
}

/// The irradiance at the origin from the light with the quad in the way, over the
/// unshadowed irradiance, by each backend: (Embree, BVH).
fn transmitted(scene: &Scene) -> (f64, f64) {
    let (embree, bvh) = backends(scene);
    let rays = light_rays(40_000);
    let total: f64 = rays.iter().map(|(_, w)| f64::from(*w)).sum();
    let mut lit = (0.0, 0.0);
    for (ray, w) in &rays {
        let w = f64::from(*w);
        let (bvh_blocked, bvh_hit) = bvh(ray);
        let embree_blocked = embree.occluded(ray);
        // The same decision from either query: the coin belongs to the surface point.
        assert_eq!(embree_blocked, embree.intersect(ray).is_some());
        assert_eq!(bvh_blocked, bvh_hit);
        lit.0 += if embree_blocked { 0.0 } else { w };
        lit.1 += if bvh_blocked { 0.0 } else { w };
    }
    (lit.0 / total, lit.1 / total)
}

fn assert_transmits(scene: &Scene, expected: f64, tolerance: f64) {
    let (embree, bvh) = transmitted(scene);
    assert!(
        (embree - expected).abs() <= tolerance && (bvh - expected).abs() <= tolerance,
        "transmitted: embree {embree}, bvh {bvh}, expected {expected} ± {tolerance}"
    );
    // Same coins, so the backends agree far more closely than either does with 0.5.
    assert!((embree - bvh).abs() < 0.005, "embree {embree}, bvh {bvh}");
}

#[test]
fn checkerboard_map_d_lets_through_half_the_light() {
    // A grey map_d: no alpha channel, so its (linear) luminance is the opacity.
    let grey = GrayImage::from_fn(8, 8, |x, y| Luma([if (x + y) % 2 == 0 { 255 } else { 0 }]));
    let s = loaded(
        "Kd 0.5 0.5 0.5\nmap_d mask.png",
        &[("mask.png", grey.into())],
    );
    assert_transmits(&s, 0.5, 0.02);
}

#[test]
fn checkerboard_alpha_of_map_kd_lets_through_half_the_light() {
    let rgba = checker(|on| [200, 100, 50, if on { 255 } else { 0 }]);
    let s = loaded("map_Kd leaf.png", &[("leaf.png", rgba.into())]);
    assert_transmits(&s, 0.5, 0.02);
}

#[test]
fn map_d_alpha_channel_wins_over_its_colour() {
    // Bright colour, checkerboard alpha: the alpha is the opacity, not the luminance.
    let rgba = checker(|on| [255, 255, 255, if on { 255 } else { 0 }]);
    let s = loaded("Kd 1 1 1\nmap_d leaf.png", &[("leaf.png", rgba.into())]);
    assert_transmits(&s, 0.5, 0.02);
}

#[test]
fn fractional_d_lets_through_its_complement() {
    assert_transmits(&loaded("Kd 0.5 0.5 0.5\nd 0.3", &[]), 0.7, 0.02);
    // `Tr` is 1 − d; `d` wins over `Tr` when both are there.
    assert_transmits(&loaded("Kd 0.5 0.5 0.5\nTr 0.75", &[]), 0.75, 0.02);
    assert_transmits(&loaded("Kd 0.5 0.5 0.5\nd 0.3\nTr 0.9", &[]), 0.7, 0.02);
    // `d` multiplies the map: half the cells at 0.5.
    let grey = GrayImage::from_fn(8, 8, |x, y| Luma([if (x + y) % 2 == 0 { 255 } else { 0 }]));
    let s = loaded("d 0.5\nmap_d mask.png", &[("mask.png", grey.into())]);
    assert_transmits(&s, 0.75, 0.02);
}

#[test]
fn opaque_and_fully_transparent_are_exact() {
    // `d 1` installs no filter at all; `d 0` is the exporters' "opaque" (see README).
    for mtl in [
        "Kd 0.5 0.5 0.5\nd 1",
        "Kd 0.5 0.5 0.5\nd 0",
        "Kd 0.5 0.5 0.5\nTr 1",
    ] {
        let s = loaded(mtl, &[]);
        assert!(s.opacity().is_none(), "{mtl}: opaque, no filter");
        assert_transmits(&s, 0.0, 0.0);
    }
    // A black map_d: no point of the quad is there.
    let black = GrayImage::from_pixel(4, 4, Luma([0]));
    let s = loaded("map_d black.png", &[("black.png", black.into())]);
    assert_transmits(&s, 1.0, 0.0);
    // An RGBA map_Kd whose alpha is solid costs nothing either.
    let solid = checker(|on| [if on { 255 } else { 0 }, 0, 0, 255]);
    let s = loaded("map_Kd solid.png", &[("solid.png", solid.into())]);
    assert!(s.opacity().is_none());
}

#[test]
fn d_zero_is_opaque_with_one_warning() {
    let dir = tempfile::tempdir().unwrap();
    let obj = QUAD.replace(
        "usemtl leaf\nf 1/1 2/2 3/3",
        "usemtl a\nf 1/1 2/2 3/3\nusemtl b",
    );
    std::fs::write(dir.path().join("scene.obj"), obj).unwrap();
    let mtl = "newmtl a\nKd 1 1 1\nd 0\nnewmtl b\nKd 1 1 1\nd 0.000000\nnewmtl leaf\nd 1\n";
    std::fs::write(dir.path().join("scene.mtl"), mtl).unwrap();
    let (scene, report) = load_obj(&dir.path().join("scene.obj")).unwrap();
    assert!(scene.materials.iter().all(|m| m.is_opaque()));
    let warnings: Vec<_> = report
        .warnings
        .iter()
        .filter(|w| w.contains("`d 0`"))
        .collect();
    assert_eq!(warnings.len(), 1, "{:?}", report.warnings);
    assert!(
        warnings[0].contains("2 material(s) (a, b)"),
        "{}",
        warnings[0]
    );
}

#[test]
fn bad_opacity_is_an_error_naming_the_material() {
    for (mtl, says) in [
        ("d 1.5", "d 1.5 is outside [0, 1]"),
        ("Tr -0.5", "Tr -0.5 is outside [0, 1]"),
        ("Tr many", "Tr: expected a finite number, found \"many\""),
    ] {
        let err = scene(mtl, &[]).unwrap_err().to_string();
        assert!(err.contains(says), "{mtl}: {err}");
        assert!(err.contains("leaf"), "{mtl}: {err}");
    }
    // An absent map is left out (one warning, docs/input-rules.md): the leaf is opaque.
    assert!(loaded("map_d missing.png", &[]).materials[0].is_opaque());
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("junk.png"), b"not a png").unwrap();
    let (obj, mtl) = (dir.path().join("scene.obj"), dir.path().join("scene.mtl"));
    std::fs::write(&obj, QUAD).unwrap();
    std::fs::write(&mtl, "newmtl leaf\nmap_d junk.png\n").unwrap();
    let err = load_obj(&obj).unwrap_err().to_string();
    assert!(
        err.contains("junk.png (map_d of material \"leaf\")"),
        "{err}"
    );
}

/// Embree hands its filter whole packets too (`rtcIntersect8`/`rtcOccluded8`): the
/// lanes must be read from the right places in its SOA layout.
#[test]
fn packets_see_the_same_cut_outs() {
    let s = loaded("Kd 0.5 0.5 0.5\nd 0.3", &[]);
    let (embree, _) = backends(&s);
    let rays: Vec<Ray> = light_rays(8_000).into_iter().map(|(r, _)| r).collect();
    let mut agree = 0;
    for chunk in rays.chunks(PACKET_WIDTH) {
        let mut hits = [None; PACKET_WIDTH];
        let mut blocked = [false; PACKET_WIDTH];
        embree.scene().intersect8(chunk, &mut hits, false);
        embree.scene().occluded8(chunk, &mut blocked);
        for (i, ray) in chunk.iter().enumerate() {
            let single = embree.intersect(ray);
            assert_eq!(hits[i].is_some(), single.is_some());
            assert_eq!(blocked[i], single.is_some());
            agree += usize::from(single.is_some());
        }
    }
    let share = agree as f64 / rays.len() as f64;
    assert!((share - 0.3).abs() < 0.03, "{share}");
}

/// The coin is a property of the surface point, so moving the ray's origin along the
/// ray does not change what it sees, except for the rare hit whose barycentrics round
/// across a cell boundary of the quantisation (2⁻¹⁶ of the triangle).
#[test]
fn the_decision_does_not_depend_on_the_ray() {
    let s = loaded("Kd 0.5 0.5 0.5\nd 0.5", &[]);
    let (embree, _) = backends(&s);
    let rays = light_rays(20_000);
    let differ = rays
        .iter()
        .filter(|(ray, _)| {
            let nearer = Ray::segment(ray.origin + ray.dir * 0.25, ray.dir, 0.5);
            embree.occluded(ray) != embree.occluded(&nearer)
        })
        .count();
    assert!(
        differ <= rays.len() / 100,
        "{differ} of {} differ",
        rays.len()
    );
}
