//! Filmive rendering: stopping a render anywhere (between passes, inside a tile,
//! mid-pixel) and resuming it, through a checkpoint file or not, gives the image of an
//! uninterrupted render bit for bit.

mod common;

use std::path::Path;
use std::sync::atomic::AtomicUsize;
use std::time::Duration;

use ember::accel::{AccelKind, EmbreeAccel};
use ember::embree::{BuildQuality, Device};
use ember::film::checkpoint::{self, Header, Identity};
use ember::film::Film;
use ember::integrator::IntegratorKind;
use ember::render::{render, render_progressive, Checkpointing, RenderControl, RenderSettings};
use ember::scene::{load_obj, Camera, CameraSettings, Scene};

struct Fixture {
    scene: Scene,
    accel: EmbreeAccel,
    camera_settings: CameraSettings,
    camera: Camera,
    settings: RenderSettings,
}

fn fixture() -> Fixture {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("meshes/CornellBox-Original.obj");
    let (scene, _) = load_obj(&path).unwrap();
    let device = Device::new("threads=2").unwrap();
    let accel = EmbreeAccel::build(
        &device,
        &scene.mesh.positions,
        &scene.mesh.triangles,
        BuildQuality::Medium,
    )
    .unwrap();
    let (lo, hi) = scene.bounds();
    let camera_settings = CameraSettings::framing(lo, hi, 40.0);
    // Not a multiple of the tile size, so edge tiles are partial.
    let settings = RenderSettings {
        width: 37,
        height: 21,
        spp: 6,
        max_depth: 5,
        seed: 11,
        integrator: IntegratorKind::Bsdf,
        light_sampler: Default::default(),
        adaptive: None,
        guiding: None,
        engine: Default::default(),
    };
    Fixture {
        camera: camera_settings.camera(settings.width, settings.height),
        scene,
        accel,
        camera_settings,
        settings,
    }
}

/// Renders from `progress`, stopping once `stop_after` more samples were taken.
fn run(f: &Fixture, progress: Film, first_pass_spp: u32, stop_after: Option<u64>) -> Film {
    common::render_stopping(
        &f.scene,
        &f.accel,
        &f.camera,
        &f.settings,
        progress,
        first_pass_spp,
        stop_after,
    )
}

fn identity_of(scene: &Scene, camera: &CameraSettings, settings: &RenderSettings) -> Identity {
    ember::render::identity(scene, camera, settings, AccelKind::Embree)
}

/// The header of a whole render's checkpoint.
fn header(identity: Identity, settings: &RenderSettings) -> Header {
    Header {
        identity,
        width: settings.width,
        height: settings.height,
        spp: settings.spp,
        samples: 0..settings.spp,
        shard: None,
        min_done: 0,
        complete: false,
        training: false,
    }
}

fn bits(p: &Film) -> Vec<u64> {
    p.pixels
        .iter()
        .flat_map(|s| s.radiance.to_array().map(f64::to_bits))
        .collect()
}

#[test]
fn interrupted_and_resumed_renders_equal_an_uninterrupted_one() {
    let f = fixture();
    let pixels = u64::from(f.settings.width * f.settings.height);
    let fresh = || Film::new(f.settings.width, f.settings.height, 0..f.settings.spp);
    let whole = run(&f, fresh(), u32::MAX, None);
    assert!(whole.pixels.iter().all(|p| p.done == f.settings.spp));
    assert!(whole.pixels.iter().all(|p| p.kept <= f.settings.spp));

    // The one-pass render of `render()` is the same image.
    let (film, _) = render(&f.scene, &f.accel, &f.camera, &f.settings, &|_| {});
    assert_eq!(film, whole.resolve());

    // Any pass schedule, and stops at many points (a stop lands on a tile boundary
    // after the stop flag is seen, so the exact sample count varies; any is valid).
    for (first_pass, stops) in [
        (1, vec![1, 500, 3 * pixels + 17]),
        (4, vec![pixels / 2, pixels]),
    ] {
        let mut progress = fresh();
        for (i, stop_after) in stops.into_iter().enumerate() {
            progress = run(&f, progress, first_pass, Some(stop_after));
            if i == 0 {
                // At most a tile per worker overshoots: far from all 4662 samples.
                assert!(progress.min_done() < f.settings.spp, "stopped early");
            }
        }
        let resumed = run(&f, progress, 2, None);
        assert_eq!(resumed.pixels, whole.pixels);
        assert_eq!(bits(&resumed), bits(&whole));
        assert_eq!(resumed.resolve(), whole.resolve());
    }
}

#[test]
fn a_checkpoint_round_trips_and_resumes_to_the_same_image() {
    let f = fixture();
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("c.checkpoint");
    let identity = identity_of(&f.scene, &f.camera_settings, &f.settings);
    let partial = run(
        &f,
        Film::new(f.settings.width, f.settings.height, 0..f.settings.spp),
        1,
        Some(1234),
    );
    checkpoint::save(&path, &header(identity.clone(), &f.settings), &partial).unwrap();
    let loaded = checkpoint::load(&path, &identity, 0..f.settings.spp).unwrap();
    assert_eq!(loaded, partial);
    let resumed = run(&f, loaded, 1, None);
    let whole = run(
        &f,
        Film::new(f.settings.width, f.settings.height, 0..f.settings.spp),
        u32::MAX,
        None,
    );
    assert_eq!(bits(&resumed), bits(&whole));

    // Settings that would continue a different image are refused, naming the setting.
    let mut other = f.settings;
    other.seed += 1;
    let err = checkpoint::load(
        &path,
        &identity_of(&f.scene, &f.camera_settings, &other),
        0..other.spp,
    )
    .unwrap_err();
    assert!(
        err.to_string().contains("seed 11") && err.to_string().contains("seed 12"),
        "{err}"
    );
    // So is a different scene.
    let mut scene = f.scene.clone();
    scene.mesh.positions[0].x += 1e-3;
    let err = checkpoint::load(
        &path,
        &identity_of(&scene, &f.camera_settings, &f.settings),
        0..6,
    )
    .unwrap_err();
    assert!(err.to_string().contains("scene"), "{err}");
    // So is the other accelerator: the backends may break ties differently.
    let bvh = ember::render::identity(&f.scene, &f.camera_settings, &f.settings, AccelKind::Bvh);
    let err = checkpoint::load(&path, &bvh, 0..6).unwrap_err();
    assert!(
        err.to_string().contains("accel embree") && err.to_string().contains("accel bvh"),
        "{err}"
    );
    // So is another light sampler: its samples differ. The default is not named in
    // the identity (which stays that of versions without the choice), so its side
    // reads "(none)".
    for (kind, name) in [
        (ember::light::LightSamplerKind::SolidAngle, "solid-angle"),
        (ember::light::LightSamplerKind::Bvh, "bvh4 2"),
    ] {
        let other_lights = RenderSettings {
            light_sampler: kind,
            ..f.settings
        };
        let other_identity = identity_of(&f.scene, &f.camera_settings, &other_lights);
        let err = checkpoint::load(&path, &other_identity, 0..6).unwrap_err();
        assert!(
            err.to_string().contains(&format!("light-sampler {name}"))
                && err.to_string().contains("light-sampler (none)"),
            "{err}"
        );
        // And the other way round: the default render refuses their checkpoint.
        assert_eq!(
            checkpoint::first_difference(&other_identity, &identity),
            Some(("light-sampler".into(), name.into(), "(none)".into()))
        );
    }
    // A checkpoint continues the same sample range only.
    let err = checkpoint::load(&path, &identity, 2..6).unwrap_err();
    assert!(err.to_string().contains("needs 2..6"), "{err}");
    // Any flipped byte is caught by the checksum.
    let bytes = std::fs::read(&path).unwrap();
    for at in [0, 9, 20, bytes.len() / 2, bytes.len() - 1] {
        let mut damaged = bytes.clone();
        damaged[at] ^= 0x10;
        std::fs::write(&path, &damaged).unwrap();
        assert!(
            checkpoint::load(&path, &identity, 0..6).is_err(),
            "byte {at}"
        );
    }
}

#[test]
fn periodic_checkpoints_are_whole_files() {
    let f = fixture();
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("p.checkpoint");
    let mut settings = f.settings;
    settings.spp = 40;
    let identity = identity_of(&f.scene, &f.camera_settings, &settings);
    let header = header(identity.clone(), &settings);
    let write = |p: &Film| checkpoint::save(&path, &header, p).unwrap();
    let stop = AtomicUsize::new(0);
    let control = RenderControl {
        stop: &stop,
        on_samples: &|_| {},
        first_pass_spp: 1,
        checkpoint: Some(Checkpointing {
            every: Duration::from_millis(1),
            write: &write,
        }),
        deadline: None,
        on_pass: &|_| {},
        on_guide: None,
    };
    let progress = Film::new(settings.width, settings.height, 0..settings.spp);
    let (progress, _) =
        render_progressive(&f.scene, &f.accel, &f.camera, &settings, progress, &control);
    // However many were written meanwhile, the file on disk is a complete checkpoint.
    if path.exists() {
        let loaded = checkpoint::load(&path, &identity, 0..settings.spp).unwrap();
        assert!(loaded
            .pixels
            .iter()
            .zip(&progress.pixels)
            .all(|(a, b)| a.done <= b.done));
    }
    let names: Vec<_> = std::fs::read_dir(dir.path())
        .unwrap()
        .map(|e| e.unwrap().file_name())
        .collect();
    assert!(names.len() <= 1, "no temporary files left: {names:?}");
}

#[test]
fn the_scene_hash_sees_every_value_that_shapes_the_image() {
    let f = fixture();
    let base = ember::render::scene_hash(&f.scene);
    assert_eq!(
        base,
        ember::render::scene_hash(&f.scene.clone()),
        "deterministic"
    );
    type Change = Box<dyn Fn(&mut Scene)>;
    let changes: Vec<(&str, Change)> = vec![
        ("a vertex", Box::new(|s| s.mesh.positions[3].y += 1e-4)),
        ("a triangle", Box::new(|s| s.mesh.triangles[0].swap(1, 2))),
        ("a material index", Box::new(|s| s.mesh.material[0] ^= 1)),
        ("an albedo", Box::new(|s| s.materials[0].diffuse.x *= 0.5)),
        (
            "an emission",
            Box::new(|s| s.materials[0].emission.z += 1.0),
        ),
        (
            "a texture",
            Box::new(|s| {
                s.textures
                    .push(std::sync::Arc::new(ember::scene::Texture::from_linear(
                        1,
                        1,
                        vec![glam::Vec3::ONE],
                    )))
            }),
        ),
        (
            "a normal map",
            Box::new(|s| s.materials[0].maps.normal = Some(0)),
        ),
        (
            "a roughness",
            Box::new(|s| s.materials[0].roughness = Some(0.5)),
        ),
        // The name does not shape the image.
    ];
    for (what, change) in changes {
        let mut scene = f.scene.clone();
        change(&mut scene);
        assert_ne!(ember::render::scene_hash(&scene), base, "{what}");
    }
    let mut renamed = f.scene.clone();
    renamed.materials[0].name = "another".into();
    assert_eq!(
        ember::render::scene_hash(&renamed),
        base,
        "names do not count"
    );
}

#[test]
fn checkpoints_of_another_format_version_are_refused_in_one_line() {
    let f = fixture();
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("old.checkpoint");
    let identity = identity_of(&f.scene, &f.camera_settings, &f.settings);
    let film = Film::new(f.settings.width, f.settings.height, 0..f.settings.spp);
    let mut bytes = checkpoint::encode(&header(identity.clone(), &f.settings), &film);
    for version in [1u32, 2, 3, 5] {
        bytes[8..12].copy_from_slice(&version.to_le_bytes());
        std::fs::write(&path, &bytes).unwrap();
        let err = checkpoint::load(&path, &identity, 0..6)
            .unwrap_err()
            .to_string();
        assert!(
            err.contains(&format!("format version {version}"))
                && err.contains("reads only version 4")
                && !err.contains('\n'),
            "{err}"
        );
    }
}
