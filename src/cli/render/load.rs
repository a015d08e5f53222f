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
    /// The image's width and height: the flags', or completed by the file camera's
    /// aspect ratio; and the note when the flags' ratio is not the camera's.
    pub size: (u32, u32),
    pub size_note: Option<String>,
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
    let given = |flag: &str| file.is_none() || request.choice.given.contains(&flag);
    let projection = match file {
        Some(f) if !given("fov") && !given("ortho-height") => f.projection,
        _ => request.projection(),
    };
    let framing = match file {
        Some(f) => *f,
        None => CameraSettings::framing(lo, hi, request.fov),
    };
    let camera_settings = CameraSettings {
        eye: request.eye.unwrap_or(framing.eye),
        look_at: request.look_at.unwrap_or(framing.look_at),
        up: if given("up") { request.up } else { framing.up },
        projection,
        lens: request.lens,
    };
    camera_settings
        .validate()
        .map_err(anyhow::Error::msg)
        .context("invalid camera")?;
    Ok(camera_settings)
}

/// The image's size: `--width` and `--height`, the one not given derived from the
/// other by the aspect ratio of the file's camera `file` when it has one (the height
/// kept when neither is given); and the note to print when both are given and their
/// ratio is not the camera's.
fn image_size(
    request: &CameraRequest,
    (width, height): (u32, u32),
    file: Option<&FileCamera>,
) -> Result<((u32, u32), Option<String>)> {
    let Some((camera, aspect)) = file.and_then(|c| Some((c, c.aspect?))) else {
        return Ok(((width, height), None));
    };
    let given = |flag: &str| request.choice.given.contains(&flag);
    let side = |v: f64| v.round().max(1.0);
    let size = match (given("width"), given("height")) {
        (true, true) => {
            let ratio = width as f32 / height as f32;
            // Within a pixel of the camera's: what rounding a side leaves.
            let close = (ratio - aspect).abs() <= aspect / width.min(height) as f32;
            let note = (!close).then(|| {
                format!(
                    "the image's aspect ratio {width}x{height} ({ratio:.4}) is not that of the \
                     camera {:?} ({aspect:.4}): ember keeps its vertical view and shows more or \
                     less at the sides",
                    camera.name
                )
            });
            return Ok(((width, height), note));
        }
        (true, false) => (f64::from(width), side(f64::from(width) / f64::from(aspect))),
        (false, _) => (
            side(f64::from(height) * f64::from(aspect)),
            f64::from(height),
        ),
    };
    let most = f64::from(ember::limits::MAX_IMAGE_SIDE);
    if size.0 > most || size.1 > most {
        bail!(
            "the camera {:?}'s aspect ratio {aspect} makes the image {}x{}, larger than ember \
             renders (at most {most} pixels a side): give --width and --height",
            camera.name,
            size.0,
            size.1
        );
    }
    Ok(((size.0 as u32, size.1 as u32), None))
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

/// The model files' camera the request names (by name, or by its index), else their
/// first when the request takes it; `None` when they have none.
fn file_camera<'c>(plan: &RenderPlan, cameras: &'c [FileCamera]) -> Result<Option<&'c FileCamera>> {
    let choice = &plan.camera.choice;
    let Some(name) = &choice.name else {
        return Ok(cameras.first().filter(|_| choice.first));
    };
    let named: Vec<&FileCamera> = cameras.iter().filter(|c| &c.name == name).collect();
    let by_index = name.parse::<usize>().ok().and_then(|i| cameras.get(i));
    match (named.as_slice(), by_index) {
        ([camera], _) => return Ok(Some(*camera)),
        ([], Some(camera)) => return Ok(Some(camera)),
        _ => {}
    }
    let list = camera_list(plan, cameras);
    let what = match named.len() {
        0 => format!("no such camera (its cameras, by name or index from 0: {list})"),
        n => {
            let places: Vec<String> = named.iter().map(|c| place_of(c)).collect();
            format!(
                "{n} cameras of that name ({}): give its index (its cameras, in order from \
                 0: {list})",
                places.join(", ")
            )
        }
    };
    match (&plan.scene_file, &choice.named_at) {
        (Some(file), Some((key, span))) => {
            let message = format!("the scene names the camera {name:?}, but has {what}");
            Err(file.error(span.clone(), key, &message).into())
        }
        _ => bail!("--camera {name:?}: {} has {what}", plan.scene.display()),
    }
}

/// A camera as its list names it: `"NAME"`, and the `[[mesh]]` entry of a scene file's.
fn place_of(camera: &FileCamera) -> String {
    match &camera.mesh {
        Some(mesh) => format!("{:?} of [[mesh]] {mesh:?}", camera.name),
        None => format!("{:?}", camera.name),
    }
}

/// The cameras a `--camera` may name, for its error: a scene file's `[camera.NAME]`
/// tables, then the model files' cameras.
fn camera_list(plan: &RenderPlan, cameras: &[FileCamera]) -> String {
    let tables = plan.scene_file.iter().flat_map(|f| f.cameras.keys());
    let mut names: Vec<String> = tables.map(|t| format!("[camera.{t}]")).collect();
    names.extend(cameras.iter().map(place_of));
    match names.is_empty() {
        true => "none".to_owned(),
        false => names.join(", "),
    }
}

/// Loads the plan's scene, sets its sky and chooses its camera.
pub fn load_scene(plan: &RenderPlan) -> Result<LoadedScene> {
    let LoadedModel {
        mut scene,
        report,
        cameras,
        contents,
    } = match &plan.scene_file {
        Some(file) => file.load(&plan.load)?,
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
    let chosen = file_camera(plan, &cameras)?;
    let camera_settings = camera_settings(request, &scene, chosen.map(|c| &c.settings))?;
    let file_camera = chosen.map(|c| c.name.clone());
    let size = (plan.settings.width, plan.settings.height);
    let (size, size_note) = image_size(request, size, chosen)?;
    let camera = camera_settings.camera(size.0, size.1);
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
        size,
        size_note,
        placed_lights: plan
            .scene_file
            .as_ref()
            .map_or_else(Vec::new, |file| file.lights.clone()),
        file_cameras: cameras,
        file_camera,
        contents,
    })
}
