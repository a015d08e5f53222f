//! Loading a render's scene: the mesh file or the scene file's meshes, the sky, the camera
//! (the automatic one framing the scene's bounds), and the Embree device to build on.

use std::sync::Arc;

use anyhow::{bail, Context, Result};
use glam::Vec3;

use super::plan::{CameraRequest, RenderPlan};
use ember::embree::Device;
use ember::light::LightSamplerKind;
use ember::render::Engine;
use ember::scene::{
    load_model, Camera, CameraSettings, Environment, FileCamera, LoadReport, LoadedModel, Scene,
    SceneLight,
};
use ember::wavefront::LaneScene;

/// The byte count in environment variable `name`, if set; anything but a whole number
/// is an error rather than silently ignored.
pub fn env_bytes(name: &str) -> Result<Option<u64>> {
    match std::env::var(name) {
        Err(std::env::VarError::NotPresent) => Ok(None),
        Ok(v) if v.trim().parse::<u64>().is_ok() => Ok(v.trim().parse().ok()),
        _ => bail!("{name} must be a whole number of bytes"),
    }
}

/// A device configuration plus `EMBER_EMBREE_CONFIG`, if set.
pub fn embree_config(threads: Option<u32>) -> String {
    let mut parts: Vec<String> = threads
        .map(|n| format!("threads={n}"))
        .into_iter()
        .collect();
    if let Ok(extra) = std::env::var("EMBER_EMBREE_CONFIG") {
        parts.push(extra);
    }
    parts.join(",")
}

/// The Embree device a render builds on: `threads` plus `EMBER_EMBREE_CONFIG`, and the
/// memory limit of `EMBER_EMBREE_MEMORY_LIMIT`, if set.
pub fn render_device(threads: Option<u32>) -> Result<Device> {
    let device = Device::new(&embree_config(threads))?;
    if let Some(limit) = env_bytes("EMBER_EMBREE_MEMORY_LIMIT")? {
        device.set_memory_limit(Some(usize::try_from(limit).unwrap_or(usize::MAX)));
    }
    Ok(device)
}

/// The scene with its sky set, and the camera that frames it.
pub struct LoadedScene {
    pub scene: Scene,
    pub report: LoadReport,
    pub unlit: bool,
    pub camera_settings: CameraSettings,
    /// What lights the scene from outside, in words (`ember info`).
    pub sky: String,
    /// Whether ember chose the eye or the point looked at (no --eye or --look-at).
    pub automatic_camera: bool,
    pub camera: Camera,
    /// The lights the scene file places (`ember info`).
    pub placed_lights: Vec<SceneLight>,
    /// The cameras a model file places (a glTF's), and the one rendered through.
    pub file_cameras: Vec<FileCamera>,
    pub file_camera: Option<String>,
    /// `ember info`'s lines about what else the model file holds.
    pub contents: Vec<String>,
}

/// The camera the flags ask for: what they leave out taken from the model file's
/// camera `file` where there is one, else framing the scene's bounds.
fn camera_settings(
    request: &CameraRequest,
    scene: &Scene,
    file: Option<&CameraSettings>,
) -> Result<CameraSettings> {
    let (lo, hi) = scene.bounds();
    let given = |flag: &str| file.is_none() || request.given.contains(&flag);
    let fov = match file {
        Some(f) if !given("fov") => f.vfov_degrees,
        _ => request.fov,
    };
    let framing = match file {
        Some(f) => *f,
        None => CameraSettings::framing(lo, hi, fov),
    };
    let camera_settings = CameraSettings {
        eye: request.eye.unwrap_or(framing.eye),
        look_at: request.look_at.unwrap_or(framing.look_at),
        up: if given("up") { request.up } else { framing.up },
        vfov_degrees: fov,
        lens: request.lens,
    };
    camera_settings
        .validate()
        .map_err(anyhow::Error::msg)
        .context("invalid camera")?;
    Ok(camera_settings)
}

/// Refuses a scene the wavefront engine does not render yet, in one line.
fn check_wavefront(plan: &RenderPlan, scene: &Scene) -> Result<()> {
    LaneScene::new(scene).map_err(anyhow::Error::msg)?;
    let kind = plan.settings.light_sampler.resolve(scene.emitters.len());
    if kind != LightSamplerKind::Alias {
        bail!("--engine wavefront chooses emitters by an alias table only; this scene has enough emitters for the light BVH");
    }
    Ok(())
}

/// The model file's camera `--camera` names (by name, or by its index), else its first
/// perspective camera; `None` when it has none.
fn file_camera<'c>(
    request: &CameraRequest,
    cameras: &'c [FileCamera],
    path: &std::path::Path,
) -> Result<Option<&'c FileCamera>> {
    let Some(name) = &request.name else {
        return Ok(cameras.iter().find(|c| c.settings.is_some()));
    };
    let by_index = name.parse::<usize>().ok().and_then(|i| cameras.get(i));
    let Some(camera) = cameras.iter().find(|c| &c.name == name).or(by_index) else {
        let names: Vec<String> = cameras.iter().map(|c| format!("{:?}", c.name)).collect();
        let list = if names.is_empty() {
            "none".to_owned()
        } else {
            names.join(", ")
        };
        bail!(
            "--camera {name:?}: {} has no such camera (its cameras, by name or index from 0: {list})",
            path.display()
        );
    };
    if camera.settings.is_none() {
        bail!(
            "--camera {name:?}: the camera {:?} of {} is orthographic; ember renders through \
             perspective cameras",
            camera.name,
            path.display()
        );
    }
    Ok(Some(camera))
}

/// Loads the plan's scene, sets its sky and chooses its camera.
pub fn load_scene(plan: &RenderPlan) -> Result<LoadedScene> {
    let LoadedModel {
        mut scene,
        report,
        cameras,
        contents,
    } = match &plan.scene_file {
        Some(file) => {
            let (scene, report) = file.load_scene(&plan.load)?;
            LoadedModel {
                scene,
                report,
                cameras: Vec::new(),
                contents: Vec::new(),
            }
        }
        None => load_model(&plan.scene, &plan.load)?,
    };
    // A placed light of any kind lights the scene: no default sky then.
    let unlit = scene.emitters.is_empty()
        && scene.lights.is_empty()
        && plan.background.is_none()
        && plan.env.is_none();
    scene.sky = match (&plan.env, plan.background) {
        (Some(env), _) => Some(Environment::load(&env.path, env.scale, env.rotate)?),
        (None, Some(b)) if b != Vec3::ZERO => Some(Environment::constant(b)),
        (None, None) if unlit => Some(Environment::constant(Vec3::ONE)),
        _ => None,
    }
    .map(Arc::new);
    let sky = match (&plan.env, plan.background) {
        (Some(env), _) => format!(
            "the environment map {} (scale {}, turned {}° about +y)",
            env.path.display(),
            env.scale,
            env.rotate
        ),
        (None, Some(b)) if b != Vec3::ZERO => format!("uniform, radiance {},{},{}", b.x, b.y, b.z),
        (None, None) if unlit => {
            "uniform white (the scene has no emitter and no placed light; --background sets another)".to_owned()
        }
        _ => "none".to_owned(),
    };
    let request = &plan.camera;
    let chosen = file_camera(request, &cameras, &plan.scene)?;
    let camera_settings =
        camera_settings(request, &scene, chosen.and_then(|c| c.settings.as_ref()))?;
    let file_camera = chosen.map(|c| c.name.clone());
    let camera = camera_settings.camera(plan.settings.width, plan.settings.height);
    if plan.settings.engine == Engine::Wavefront {
        check_wavefront(plan, &scene)?;
    }
    Ok(LoadedScene {
        scene,
        report,
        unlit,
        camera_settings,
        sky,
        automatic_camera: file_camera.is_none()
            && (request.eye.is_none() || request.look_at.is_none()),
        camera,
        placed_lights: plan
            .scene_file
            .as_ref()
            .map_or_else(Vec::new, |file| file.lights.clone()),
        file_cameras: cameras,
        file_camera,
        contents,
    })
}
