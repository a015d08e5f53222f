//! `ember render`: the flags ([`args`], a scene file's among them: [`scene_file`])
//! become one plan, checked before any work ([`plan`]); the scene is loaded ([`load`]),
//! the chosen accelerator built (here), and the render runs and writes its files
//! ([`session`]), saying what it does as it goes ([`report`]).

mod args;
mod load;
mod plan;
mod report;
mod scene_file;
mod session;

pub use args::RenderArgs;
pub use load::LoadedScene;
pub use report::camera_flags;

use std::process::ExitCode;
use std::sync::Arc;
use std::time::{Duration, Instant};

use anyhow::{Context, Result};

use super::scene_input::SceneFormat;
use ember::accel::{
    instanced_bvh, instanced_embree, instanced_filtered_bvh, AccelKind, Bvh, EmbreeBackend,
};
use ember::embree::BuildQuality;
use ember::scene::{Instancing, Opacity, SceneFile};
use load::{load_scene, render_device};
use plan::RenderPlan;
use session::finish_render;

/// `ember render`; `user` holds the command line's arguments after `render`, which a
/// scene file's settings go before.
pub fn run(args: RenderArgs, user: &[std::ffi::OsString]) -> Result<ExitCode> {
    let started = Instant::now();
    let (args, scene_file) = if SceneFormat::of(&args.scene)? == SceneFormat::SceneFile {
        let file = SceneFile::read(&args.scene)?;
        (scene_file::render_args(&file, user)?, Some(file))
    } else {
        ((args, scene_file::model_camera_choice(user)?), None)
    };
    let mut plan = RenderPlan::from_args(args.0);
    plan.camera.choice = args.1;
    plan.scene_file = scene_file;
    plan.check()?;
    plan.resume_defaults()?;
    let mut pool = rayon::ThreadPoolBuilder::new();
    if let Some(n) = plan.threads {
        pool = pool.num_threads(n as usize);
    }
    let pool = pool.build().context("cannot start worker threads")?;
    // The loader parses in parallel: on the render's threads, as many as asked for.
    let loaded = pool.install(|| load_scene(&plan))?;
    // A file camera's aspect ratio may have completed the image's size.
    if loaded.size != (plan.settings.width, plan.settings.height) {
        (plan.settings.width, plan.settings.height) = loaded.size;
        plan.check_size()?;
    }
    let timeline = Timeline {
        started,
        loaded: started.elapsed(),
        first_sample: Duration::ZERO,
    };
    let positions = &loaded.scene.mesh.positions;
    let triangles = &loaded.scene.mesh.triangles;
    // Cut-outs, unless EMBER_NO_CUTOUTS=1 turns them off: for measuring what they cost
    // only (the image is then wrong, though its checkpoint identity is not told).
    let cutouts = match std::env::var_os("EMBER_NO_CUTOUTS") {
        Some(v) if v == "1" => None,
        _ => loaded.scene.opacity(),
    };
    if let Some(instancing) = &loaded.scene.instancing {
        return render_instanced(&plan, &loaded, &pool, instancing, cutouts, &timeline);
    }
    // One generic render per backend (and per filter): the match picks the type, no
    // dynamic dispatch.
    match plan.accel {
        AccelKind::Embree => {
            let device = render_device(plan.threads)?;
            let quality = BuildQuality::High;
            // Embree reads the mesh in place: the render borrows it, no copies.
            let accel =
                EmbreeBackend::build_shared(&device, positions, triangles, quality, cutouts)
                    .context("cannot build the Embree scene")?;
            finish_render(&plan, &loaded, &pool, &accel, &timeline)
        }
        AccelKind::Bvh => {
            let bvh = pool
                .install(|| Bvh::build(positions, triangles))
                .context("cannot build the native BVH")?;
            match cutouts {
                Some(opacity) => {
                    finish_render(&plan, &loaded, &pool, &bvh.with_filter(opacity), &timeline)
                }
                None => finish_render(&plan, &loaded, &pool, &bvh, &timeline),
            }
        }
    }
}

/// The scene as `ember render SCENE` with no other flag would render it: loaded, its
/// sky set (a scene file's environment, or the white sky of a scene without
/// emitters), and its camera chosen (a scene file's, or the automatic one).
pub fn load_as_rendered(path: &std::path::Path, strict: bool) -> Result<LoadedScene> {
    let user = [std::ffi::OsString::from(path)];
    let ((args, choice), file) = match SceneFormat::of(path)? {
        SceneFormat::SceneFile => {
            let file = SceneFile::read(path)?;
            (scene_file::render_args(&file, &user)?, Some(file))
        }
        SceneFormat::Model => {
            let args = scene_file::command_line_args(&user)?;
            ((args, scene_file::model_camera_choice(&user)?), None)
        }
    };
    let mut plan = RenderPlan::from_args(args);
    plan.camera.choice = choice;
    plan.scene_file = file;
    plan.load.strict = strict;
    load_scene(&plan)
}

/// [`finish_render`] of an instanced scene, on the two-level structure of its backend.
fn render_instanced(
    plan: &RenderPlan,
    loaded: &LoadedScene,
    pool: &rayon::ThreadPool,
    instancing: &Instancing,
    cutouts: Option<Arc<Opacity>>,
    timeline: &Timeline,
) -> Result<ExitCode> {
    let mesh = &loaded.scene.mesh;
    match plan.accel {
        AccelKind::Embree => {
            let device = render_device(plan.threads)?;
            let quality = BuildQuality::High;
            let accel = instanced_embree(&device, mesh, instancing, quality, cutouts.as_ref())
                .context("cannot build the Embree scene")?;
            finish_render(plan, loaded, pool, &accel, timeline)
        }
        AccelKind::Bvh => match cutouts {
            Some(opacity) => {
                let bvh = pool
                    .install(|| instanced_filtered_bvh(mesh, instancing, &opacity))
                    .context("cannot build the native BVH")?;
                finish_render(plan, loaded, pool, &bvh, timeline)
            }
            None => {
                let bvh = pool
                    .install(|| instanced_bvh(mesh, instancing))
                    .context("cannot build the native BVH")?;
                finish_render(plan, loaded, pool, &bvh, timeline)
            }
        },
    }
}

/// When the render started, when its scene was loaded and when its first sample was
/// taken: the summary tells the time to the first sample and how much was loading.
#[derive(Clone, Copy)]
pub struct Timeline {
    started: Instant,
    /// From the start to a loaded scene (OBJ, materials, textures, environment).
    loaded: Duration,
    /// From the start to the first sample (the accelerator built).
    first_sample: Duration,
}

impl Timeline {
    /// The timeline as the first sample is about to be taken.
    fn at_first_sample(&self) -> Timeline {
        Timeline {
            first_sample: self.started.elapsed(),
            ..*self
        }
    }
}
