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
    load_model, Camera, CameraSettings, Environment, LoadReport, Scene, SceneLight,
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
}

/// The camera the flags ask for, what they leave out framing the scene's bounds.
fn camera_settings(request: &CameraRequest, scene: &Scene) -> Result<CameraSettings> {
    let (lo, hi) = scene.bounds();
    let framing = CameraSettings::framing(lo, hi, request.fov);
    let camera_settings = CameraSettings {
        eye: request.eye.unwrap_or(framing.eye),
        look_at: request.look_at.unwrap_or(framing.look_at),
        up: request.up,
        vfov_degrees: request.fov,
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

/// Loads the plan's scene, sets its sky and chooses its camera.
pub fn load_scene(plan: &RenderPlan) -> Result<LoadedScene> {
    let (mut scene, report) = match &plan.scene_file {
        Some(file) => file.load_scene(&plan.load)?,
        None => load_model(&plan.scene, &plan.load).map(|m| (m.scene, m.report))?,
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
    let camera_settings = camera_settings(request, &scene)?;
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
        automatic_camera: request.eye.is_none() || request.look_at.is_none(),
        camera,
        placed_lights: plan
            .scene_file
            .as_ref()
            .map_or_else(Vec::new, |file| file.lights.clone()),
    })
}
