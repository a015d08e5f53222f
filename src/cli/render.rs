//! `ember render`: map the flags to one plan, check every input, load the scene, build
//! the chosen accelerator, render progressively with checkpoints and signal handling,
//! and write the image, or with `--shard` the shard file.

use std::ops::Range;
use std::path::{Path, PathBuf};
use std::process::ExitCode;
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use anyhow::{bail, Context, Result};
use clap::Args;
use glam::Vec3;
use indicatif::{ProgressBar, ProgressStyle};

use super::scene_file::{is_scene_file, render_args};
use super::tev::{Display, DisplayAddress};
use super::{
    parse_fov, parse_seconds, parse_shard, parse_vec3, AccelArg, IntegratorArg, LightSamplerArg,
    ToneArgs,
};
use ember::accel::{
    instanced_bvh, instanced_embree, instanced_filtered_bvh, Accel, AccelKind, Bvh, EmbreeBackend,
};
use ember::embree::{BuildQuality, Device};
use ember::film::aov::Aov;
use ember::film::checkpoint::{self, FilmReader, Header, Identity};
use ember::film::output::FilmOutput;
use ember::film::{shard_samples, Film};
use ember::guiding::{Guiding, SdTree, MAX_ITERATIONS};
use ember::image::{self, Tonemap};
use ember::render::{
    self, Adaptive, Checkpointing, GuideView, PassReport, RenderControl, RenderSettings,
    RenderStats, GUIDING_ITERATIONS,
};
use ember::scene::{
    load_obj_with, Camera, CameraSettings, Environment, Instancing, Lens, LoadOptions, LoadReport,
    Opacity, Scene, SceneFile,
};

/// clap's ranges take `i64`.
const MAX_SIDE: i64 = ember::limits::MAX_IMAGE_SIDE as i64;
const MAX_SPP: i64 = ember::limits::MAX_SPP as i64;

#[derive(Args)]
pub struct RenderArgs {
    /// The OBJ scene (its MTL libraries and textures are read from beside it), or a
    /// scene file (.toml: OBJs with transforms and instances, cameras, environment,
    /// settings; see the README), whose settings these flags override.
    scene: PathBuf,
    /// With a scene file: the camera of its [camera.NAME] table to render through.
    #[arg(long, value_name = "NAME")]
    camera: Option<String>,
    /// Output image; the extension picks the format: .png, .exr or .hdr
    /// [default: the scene's name with .png, in the current directory]
    #[arg(short, long)]
    output: Option<PathBuf>,
    /// Render only shard I of N: sample indices floor(I*spp/N) .. floor((I+1)*spp/N) of
    /// every pixel, written to the output (whatever its extension) as a shard file for
    /// `ember merge`. The shard file is its own checkpoint: `--resume` continues it.
    #[arg(long, value_name = "I/N", value_parser = parse_shard, requires = "output", conflicts_with = "checkpoint")]
    shard: Option<(u32, u32)>,
    /// Image width in pixels.
    #[arg(long, default_value_t = 512, value_parser = clap::value_parser!(u32).range(1..=MAX_SIDE))]
    width: u32,
    /// Image height in pixels.
    #[arg(long, default_value_t = 512, value_parser = clap::value_parser!(u32).range(1..=MAX_SIDE))]
    height: u32,
    /// Samples per pixel (with --noise-threshold or --time-limit, the most any pixel takes).
    #[arg(long, default_value_t = 64, value_parser = clap::value_parser!(u32).range(1..=MAX_SPP))]
    spp: u32,
    /// Adaptive sampling: after each pass, a pixel goes on only while its estimated
    /// relative error (standard error over sqrt(mean² + 0.01), as `ember compare`'s
    /// relMSE weighs it) is above T, in it or any pixel of its 5×5 neighbourhood. A render
    /// whose pixels all reach T has a relMSE of about T².
    #[arg(long, value_name = "T", value_parser = parse_threshold)]
    noise_threshold: Option<f32>,
    /// With --noise-threshold, the samples a pixel takes before it may stop
    /// [default: 32, or --spp if fewer].
    #[arg(long, value_name = "N", requires = "noise_threshold", value_parser = clap::value_parser!(u32).range(1..=MAX_SPP))]
    min_spp: Option<u32>,
    /// Render passes until SECONDS have gone by (from the start of rendering), then
    /// write the image; earlier if --spp or --noise-threshold is reached first.
    #[arg(long, value_name = "SECONDS", value_parser = parse_seconds)]
    time_limit: Option<f64>,
    /// Render passes to add to an .exr output as layers, comma-separated:
    /// albedo, normal, depth, variance, spp.
    #[arg(long, value_name = "PASSES", value_delimiter = ',', value_parser = parse_aov)]
    aov: Vec<Aov>,
    /// Denoise the image with Intel Open Image Denoise (its RT filter, guided by the
    /// albedo and normal passes); an .exr output keeps the noisy image as layer "noisy".
    #[arg(long)]
    denoise: bool,
    /// Maximum path length in segments, the camera ray included (1: emitters only,
    /// 2: direct lighting).
    #[arg(long, default_value_t = 8, value_parser = clap::value_parser!(u32).range(1..=1024))]
    max_depth: u32,
    /// Random seed; the same seed gives the same image whatever the thread count.
    #[arg(long, default_value_t = 0)]
    seed: u64,
    /// Worker threads [default: all cores].
    #[arg(long, value_parser = clap::value_parser!(u32).range(1..=1024))]
    threads: Option<u32>,
    /// Camera position, X,Y,Z [default: in front of the scene (+z), framing its bounds].
    #[arg(long, value_parser = parse_vec3, allow_hyphen_values = true)]
    eye: Option<Vec3>,
    /// Point the camera looks at, X,Y,Z [default: the centre of the scene's bounds].
    #[arg(long, value_parser = parse_vec3, allow_hyphen_values = true)]
    look_at: Option<Vec3>,
    /// Camera up direction, X,Y,Z.
    #[arg(long, value_parser = parse_vec3, allow_hyphen_values = true, default_value = "0,1,0")]
    up: Vec3,
    /// Vertical field of view in degrees, strictly between 0 and 180.
    #[arg(long, default_value_t = 40.0, value_parser = parse_fov)]
    fov: f32,
    /// Thin-lens depth of field: the lens radius in scene units [default: 0, a pinhole].
    #[arg(long, value_name = "RADIUS", value_parser = parse_aperture)]
    aperture: Option<f32>,
    /// Distance from the eye to the plane in focus, along the view direction
    /// [default: the distance to --look-at].
    #[arg(long, value_name = "DISTANCE", value_parser = parse_focus_distance)]
    focus_distance: Option<f32>,
    /// Radiance of a uniform sky behind the scene, R,G,B [default: 0,0,0, or 1,1,1
    /// when the scene has no emissive material, so that it is not rendered black].
    #[arg(long, value_parser = parse_vec3, allow_hyphen_values = true, conflicts_with = "env")]
    background: Option<Vec3>,
    /// Light the scene with an equirectangular environment map (EXR or HDR, linear
    /// radiance; row 0 is up, the middle column looks along −z), importance-sampled
    /// as a light.
    #[arg(long, value_name = "FILE")]
    env: Option<PathBuf>,
    /// Multiplies the environment map's radiance.
    #[arg(long, value_name = "FACTOR", default_value_t = 1.0, value_parser = parse_env_scale, requires = "env")]
    env_scale: f32,
    /// Turns the environment map about the up (+y) axis, counter-clockwise seen from above.
    #[arg(long, value_name = "DEGREES", default_value_t = 0.0, value_parser = parse_degrees, allow_hyphen_values = true, requires = "env")]
    env_rotate: f32,
    /// Light-transport estimator.
    #[arg(long, value_enum, default_value_t = IntegratorArg::Mis)]
    integrator: IntegratorArg,
    /// Path guiding (Müller et al. 2017, with any --integrator): an SD-tree of the
    /// incident light, trained before rendering (2^N − 1 spp over
    /// --guiding-iterations N), guides a learnt share of the scattered directions and
    /// of the sky samples in the regions where guiding pays. The training's samples
    /// are the image's first 2^N − 1 of --spp.
    #[arg(long)]
    guiding: bool,
    /// Training iterations of --guiding; iteration k takes 2^k samples per pixel
    /// [default: the most whose 2^N − 1 samples are at most an eighth of --spp, at
    /// least 1: 3 at 64 spp, 5 at 256].
    #[arg(long, value_name = "N", requires = "guiding", value_parser = clap::value_parser!(u32).range(1..=i64::from(MAX_ITERATIONS)))]
    guiding_iterations: Option<u32>,
    /// With --guiding: write the learnt directional distribution at the first
    /// non-delta vertex of pixel --guide-pixel's centre ray to FILE (.exr, .hdr or
    /// .png), 256x128 pixels of density per steradian over an equal-area map of the
    /// sphere: rows from world +z (top) to −z by equal steps of z, columns the azimuth
    /// atan2(y, x) from 0 to 360° (a PNG is scaled so that its densest pixel is white).
    #[arg(long, value_name = "FILE", requires_all = ["guiding", "guide_pixel"])]
    guide_image: Option<PathBuf>,
    /// The pixel of --guide-image, X,Y (0,0 is the top-left corner).
    #[arg(long, value_name = "X,Y", value_parser = parse_pixel, requires = "guide_image")]
    guide_pixel: Option<(u32, u32)>,
    /// --guide-image shows the region's distribution of the sky it sees directly
    /// (what its light samples towards the sky follow) instead of that of all the
    /// light arriving (what its scattered directions follow).
    #[arg(long, requires = "guide_image")]
    guide_sky: bool,
    /// How light samples choose an emitter and a point on it: `auto` (`bvh` with at
    /// least 512 emissive triangles, else `alias`), `alias` (an alias table
    /// by power, a uniform point on the triangle), `solid-angle` (the same table, then
    /// a direction by solid angle where the triangle spans a wide angle) or `bvh` (a
    /// light BVH weighing power, distance and orientation at the shading point, then
    /// as `solid-angle`: fewer samples for the same error with many lights, more time
    /// per sample).
    #[arg(long, value_enum, default_value_t = LightSamplerArg::Auto)]
    light_sampler: LightSamplerArg,
    /// Write the progress to the checkpoint file every SECONDS (atomically), so that a
    /// killed render loses at most that much work; the final state is kept too.
    #[arg(long, value_name = "SECONDS", value_parser = parse_seconds)]
    checkpoint_every: Option<f64>,
    /// Checkpoint file [default: the output path with ".checkpoint" appended].
    #[arg(long, value_name = "FILE")]
    checkpoint: Option<PathBuf>,
    /// Continue from the checkpoint file to --spp samples per pixel. The scene, camera,
    /// size, seed, depth, integrator and accelerator must be the ones the checkpoint was
    /// made with.
    #[arg(long)]
    resume: bool,
    /// Which structure answers the ray queries; the same seed gives the same image with
    /// either (up to floating-point ties).
    #[arg(long, value_enum, default_value_t = AccelArg::Embree)]
    accel: AccelArg,
    /// Refuse the scene, instead of warning and rendering on, when a material library,
    /// a texture or a `usemtl` material is absent, or a file was found only by its file
    /// name or by ignoring case (see docs/input-rules.md).
    #[arg(long)]
    strict: bool,
    /// Show the image in progress in the tev viewer listening at HOST:PORT (tev's
    /// default is localhost:14158), about once a second and when done. The image
    /// written is the same; a viewer that cannot be reached costs one warning.
    #[arg(long, value_name = "HOST:PORT", value_parser = super::tev::parse_address)]
    display: Option<DisplayAddress>,
    #[command(flatten)]
    tone: ToneArgs,
}

fn default_output(scene: &Path) -> PathBuf {
    let stem = scene.file_stem().unwrap_or_else(|| "ember".as_ref());
    PathBuf::from(stem).with_extension("png")
}

/// `out.png` -> `out.partial.png`: where an interrupted render's image goes, so that a
/// partial image is never mistaken for the finished one.
fn partial_output(output: &Path) -> PathBuf {
    let ext = output
        .extension()
        .map(|e| e.to_string_lossy().into_owned())
        .unwrap_or_default();
    output.with_extension(format!("partial.{ext}"))
}

/// Whether two paths name one file (the same path, or links to one existing file).
fn same_file(a: &Path, b: &Path) -> bool {
    a == b || matches!((a.canonicalize(), b.canonicalize()), (Ok(a), Ok(b)) if a == b)
}

fn default_checkpoint(output: &Path) -> PathBuf {
    let mut name = output.as_os_str().to_owned();
    name.push(".checkpoint");
    PathBuf::from(name)
}

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
fn render_device(threads: Option<u32>) -> Result<Device> {
    let device = Device::new(&embree_config(threads))?;
    if let Some(limit) = env_bytes("EMBER_EMBREE_MEMORY_LIMIT")? {
        device.set_memory_limit(Some(usize::try_from(limit).unwrap_or(usize::MAX)));
    }
    Ok(device)
}

/// What the camera flags ask for; the defaults depend on the scene's bounds.
struct CameraRequest {
    eye: Option<Vec3>,
    look_at: Option<Vec3>,
    up: Vec3,
    fov: f32,
    lens: Lens,
}

/// Everything `ember render` was asked to do, mapped from the flags once.
struct RenderPlan {
    scene: PathBuf,
    /// The scene file, when `scene` is one.
    scene_file: Option<SceneFile>,
    /// The image, or with `--shard` the shard file.
    output: PathBuf,
    /// Where checkpoints go (the shard file itself for a shard).
    checkpoint: PathBuf,
    checkpoint_every: Option<Duration>,
    resume: bool,
    threads: Option<u32>,
    accel: AccelKind,
    settings: RenderSettings,
    camera: CameraRequest,
    background: Option<Vec3>,
    env: Option<EnvRequest>,
    tonemap: Tonemap,
    /// Passes written beside the image (EXR output only).
    aovs: Vec<Aov>,
    denoise: bool,
    time_limit: Option<Duration>,
    shard: Option<(u32, u32)>,
    /// `--guide-image` and its pixel.
    guide_image: Option<(PathBuf, (u32, u32))>,
    /// Whether `--guide-image` shows the sky's distribution (`--guide-sky`).
    guide_sky: bool,
    /// The sample indices this process renders: `0..spp`, or the shard's.
    samples: Range<u32>,
    /// Whether `--guiding-iterations` was given (else a resume takes the checkpoint's).
    guiding_iterations_given: bool,
    /// How the scene is loaded (`--strict`).
    load: LoadOptions,
    /// The tev viewer to stream the image in progress to (`--display`).
    display: Option<DisplayAddress>,
}

impl RenderPlan {
    fn from_args(args: RenderArgs) -> RenderPlan {
        let output = args.output.unwrap_or_else(|| default_output(&args.scene));
        let checkpoint = match (args.shard, args.checkpoint) {
            (Some(_), _) => output.clone(),
            (None, Some(path)) => path,
            (None, None) => default_checkpoint(&output),
        };
        let samples = args
            .shard
            .map_or(0..args.spp, |shard| shard_samples(args.spp, shard));
        let guiding_iterations_given = args.guiding_iterations.is_some();
        let adaptive = args.noise_threshold.map(|threshold| {
            let whole = Adaptive {
                threshold,
                min_spp: args
                    .min_spp
                    .unwrap_or_else(|| Adaptive::default_min_spp(args.spp)),
            };
            // Each shard aims at the error that its merge with the others reaches T.
            args.shard.map_or(whole, |(_, n)| whole.for_shard_of(n))
        });
        let mut aovs = args.aov;
        aovs.dedup();
        RenderPlan {
            scene: args.scene,
            scene_file: None,
            output,
            checkpoint,
            checkpoint_every: args.checkpoint_every.map(Duration::from_secs_f64),
            resume: args.resume,
            threads: args.threads,
            accel: args.accel.into(),
            settings: RenderSettings {
                width: args.width,
                height: args.height,
                spp: args.spp,
                max_depth: args.max_depth,
                seed: args.seed,
                integrator: args.integrator.into(),
                light_sampler: args.light_sampler.into(),
                adaptive,
                guiding: args.guiding.then(|| match args.guiding_iterations {
                    Some(iterations) => Guiding { iterations },
                    None => Guiding::for_spp(args.spp),
                }),
            },
            camera: CameraRequest {
                eye: args.eye,
                look_at: args.look_at,
                up: args.up,
                fov: args.fov,
                lens: Lens {
                    aperture_radius: args.aperture.unwrap_or(0.0),
                    focus_distance: args.focus_distance,
                },
            },
            background: args.background,
            env: args.env.map(|path| EnvRequest {
                path,
                scale: args.env_scale,
                rotate: args.env_rotate,
            }),
            tonemap: args.tone.into(),
            aovs,
            denoise: args.denoise,
            time_limit: args.time_limit.map(Duration::from_secs_f64),
            shard: args.shard,
            guide_image: args.guide_image.zip(args.guide_pixel),
            guide_sky: args.guide_sky,
            samples,
            guiding_iterations_given,
            load: LoadOptions {
                strict: args.strict,
            },
            display: args.display,
        }
    }

    fn pixels(&self) -> u64 {
        u64::from(self.settings.width) * u64::from(self.settings.height)
    }

    /// A resumed guided render without `--guiding-iterations` trains as its checkpoint
    /// did: the default follows `--spp`, which a resume may raise. (Where the
    /// checkpoint is not guided, loading it refuses it.)
    fn resume_guiding(&mut self) -> Result<()> {
        let Some(guiding) = self.settings.guiding.as_mut() else {
            return Ok(());
        };
        if !self.resume || self.guiding_iterations_given {
            return Ok(());
        }
        let header = FilmReader::open(&self.checkpoint)?.header;
        let theirs = header
            .identity
            .iter()
            .find(|(k, _)| k == GUIDING_ITERATIONS);
        if let Some(n) = theirs.and_then(|(_, v)| v.parse().ok()) {
            guiding.iterations = n;
        }
        Ok(())
    }

    /// Refuses what can be refused before loading anything: an unwritable or unknown
    /// output, bad environment, a missing checkpoint, an image too large for memory.
    fn check(&self) -> Result<()> {
        self.check_outputs()?;
        env_bytes(ember::limits::MEMORY_LIMIT_ENV)?;
        env_bytes("EMBER_EMBREE_MEMORY_LIMIT")?;
        if let Some((_, (x, y))) = self.guide_image {
            let (w, h) = (self.settings.width, self.settings.height);
            if x >= w || y >= h {
                bail!("--guide-pixel {x},{y} is outside the {w}x{h} image");
            }
        }
        if self.background.is_some_and(|b| b.min_element() < 0.0) {
            bail!("--background must not be negative");
        }
        if self.resume && !self.checkpoint.is_file() {
            bail!(
                "cannot resume: there is no checkpoint {}",
                self.checkpoint.display()
            );
        }
        // width × height × spp fits in u64 for every value the flags accept (at most
        // 2^28 × 10^6); checked all the same.
        (self.pixels())
            .checked_mul(u64::from(self.settings.spp))
            .context("width × height × spp overflows")?;
        let (w, h) = (self.settings.width, self.settings.height);
        // Denoising runs once the render is done, beside the film.
        let denoise = if self.denoise {
            ember::denoise::memory_bytes(w, h)
        } else {
            0
        };
        ember::limits::check_fits(
            &format!("a {w}x{h} image"),
            render::render_memory_bytes(w, h) + denoise,
        )
        .map_err(anyhow::Error::msg)
    }

    /// Every file this run may write, checked before any work: the image and the
    /// partial image an interruption leaves (whole renders; their `--aov` passes are
    /// layers of the same EXR), and the checkpoint (or the shard file, which is its own
    /// checkpoint). An interruption may come at any time,
    /// so the partial image and the checkpoint are checked even when none is asked for.
    fn check_outputs(&self) -> Result<()> {
        if self.shard.is_some() && (self.denoise || !self.aovs.is_empty()) {
            bail!("a shard holds every pass: give --denoise and --aov to `ember merge`");
        }
        if self.shard.is_none() {
            check_image_output(&self.output, &self.aovs, self.denoise)?;
            check_image_output(&partial_output(&self.output), &self.aovs, self.denoise)?;
            if same_file(&self.checkpoint, &self.output) {
                bail!(
                    "the checkpoint {} would overwrite the image: give another --checkpoint",
                    self.checkpoint.display()
                );
            }
        }
        ember::io::check_writable(&self.checkpoint)?;
        if let Some((path, _)) = &self.guide_image {
            check_image_output(path, &[], false)?;
            if same_file(path, &self.output) || same_file(path, &self.checkpoint) {
                bail!(
                    "--guide-image {} would overwrite the render's output",
                    path.display()
                );
            }
        }
        Ok(())
    }

    /// The header of this render's checkpoints or shard file.
    fn header(&self, identity: Identity) -> Header {
        Header {
            identity,
            width: self.settings.width,
            height: self.settings.height,
            spp: self.settings.spp,
            samples: self.samples.clone(),
            shard: self.shard,
            // These three are the film's, filled in when it is written.
            min_done: 0,
            complete: false,
            training: false,
        }
    }
}

/// `--env` and its scale and rotation.
struct EnvRequest {
    path: PathBuf,
    scale: f32,
    rotate: f32,
}

/// A finite number for which `ok` holds, else "`s` is not `what`".
fn parse_f32(s: &str, ok: impl Fn(f32) -> bool, what: &str) -> Result<f32, String> {
    match s.trim().parse::<f32>() {
        Ok(v) if v.is_finite() && ok(v) => Ok(v),
        _ => Err(format!("{s:?} is not {what}")),
    }
}

fn parse_env_scale(s: &str) -> Result<f32, String> {
    parse_f32(s, |v| v >= 0.0, "a finite factor ≥ 0")
}

fn parse_threshold(s: &str) -> Result<f32, String> {
    parse_f32(s, |v| v > 0.0, "a relative error > 0 (e.g. 0.05)")
}

/// Refuses, before any work, an image output that cannot be written or cannot hold
/// what is asked of it, and `--denoise` in an ember that cannot denoise.
pub fn check_image_output(output: &Path, aovs: &[Aov], denoise: bool) -> Result<()> {
    image::check_output(output)?;
    let exr = image::OutputFormat::from_path(output)? == image::OutputFormat::Exr;
    if !aovs.is_empty() && !exr {
        bail!(
            "--aov needs an .exr output, which holds the passes as layers beside the image; \
             {} holds one image",
            output.display()
        );
    }
    if denoise {
        ember::denoise::available()?;
    }
    Ok(())
}

pub fn parse_aov(s: &str) -> Result<Aov, String> {
    Aov::from_name(s.trim()).ok_or_else(|| {
        let names: Vec<&str> = Aov::ALL.iter().map(|a| a.name()).collect();
        format!("unknown pass {s:?}: choose from {}", names.join(", "))
    })
}

/// `X,Y`: a pixel.
fn parse_pixel(s: &str) -> Result<(u32, u32), String> {
    let bad = || format!("expected a pixel X,Y (two whole numbers), got {s:?}");
    let (x, y) = s.trim().split_once(',').ok_or_else(bad)?;
    Ok((
        x.trim().parse().map_err(|_| bad())?,
        y.trim().parse().map_err(|_| bad())?,
    ))
}

fn parse_aperture(s: &str) -> Result<f32, String> {
    parse_f32(s, |v| v >= 0.0, "a lens radius ≥ 0")
}

fn parse_focus_distance(s: &str) -> Result<f32, String> {
    parse_f32(s, |v| v > 0.0, "a distance > 0")
}

fn parse_degrees(s: &str) -> Result<f32, String> {
    parse_f32(s, |_| true, "an angle in degrees")
}

/// The scene with its sky set, and the camera that frames it.
struct LoadedScene {
    scene: Scene,
    report: LoadReport,
    unlit: bool,
    camera_settings: CameraSettings,
    camera: Camera,
}

fn load_scene(plan: &RenderPlan) -> Result<LoadedScene> {
    let (mut scene, report) = match &plan.scene_file {
        Some(file) => file.load_scene(&plan.load)?,
        None => load_obj_with(&plan.scene, &plan.load)?,
    };
    let unlit = scene.emitters.is_empty() && plan.background.is_none() && plan.env.is_none();
    scene.sky = match (&plan.env, plan.background) {
        (Some(env), _) => Some(Environment::load(&env.path, env.scale, env.rotate)?),
        (None, Some(b)) if b != Vec3::ZERO => Some(Environment::constant(b)),
        (None, None) if unlit => Some(Environment::constant(Vec3::ONE)),
        _ => None,
    }
    .map(Arc::new);
    let (lo, hi) = scene.bounds();
    let request = &plan.camera;
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
    let camera = camera_settings.camera(plan.settings.width, plan.settings.height);
    Ok(LoadedScene {
        scene,
        report,
        unlit,
        camera_settings,
        camera,
    })
}

/// `ember render`; `user` holds the command line's arguments after `render`, which a
/// scene file's settings go before.
pub fn run(args: RenderArgs, user: &[std::ffi::OsString]) -> Result<ExitCode> {
    let started = Instant::now();
    let (args, scene_file) = if is_scene_file(&args.scene) {
        let file = SceneFile::read(&args.scene)?;
        (render_args(&file, user)?, Some(file))
    } else {
        if args.camera.is_some() {
            bail!(
                "--camera chooses a camera of a scene file (.toml); {} is not one",
                args.scene.display()
            );
        }
        (args, None)
    };
    let mut plan = RenderPlan::from_args(args);
    plan.scene_file = scene_file;
    plan.check()?;
    plan.resume_guiding()?;
    let mut pool = rayon::ThreadPoolBuilder::new();
    if let Some(n) = plan.threads {
        pool = pool.num_threads(n as usize);
    }
    let pool = pool.build().context("cannot start worker threads")?;
    // The loader parses in parallel: on the render's threads, as many as asked for.
    let loaded = pool.install(|| load_scene(&plan))?;
    let timeline = Timeline {
        started,
        loaded: started.elapsed(),
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

/// When the render started and when its scene was loaded: the summary tells the time
/// to the first sample and how much of it was loading.
struct Timeline {
    started: Instant,
    /// From the start to a loaded scene (OBJ, materials, textures, environment).
    loaded: Duration,
}

/// Renders with checkpoints and signal handling, then writes the image or shard (or,
/// when interrupted, the partial image and a checkpoint).
fn finish_render<A: Accel>(
    plan: &RenderPlan,
    loaded: &LoadedScene,
    pool: &rayon::ThreadPool,
    accel: &A,
    timeline: &Timeline,
) -> Result<ExitCode> {
    let identity = render::identity(
        &loaded.scene,
        &loaded.camera_settings,
        &plan.settings,
        plan.accel,
    );
    let film = if plan.resume {
        checkpoint::load(&plan.checkpoint, &identity, plan.samples.clone())?
    } else {
        let s = &plan.settings;
        Film::new(s.width, s.height, plan.samples.clone())
    };
    let header = plan.header(identity);
    // From here on Ctrl-C or SIGTERM stops the workers and writes what there is.
    let stop = super::stop_on_signals()?;
    let save_checkpoint = |film: &Film| -> Result<()> {
        checkpoint::save(&plan.checkpoint, &header, film).context("cannot write the checkpoint")
    };
    let display = plan.display.clone().map(|address| {
        let name = plan.output.file_name().unwrap_or_default();
        let s = &plan.settings;
        Display::start(address, name.to_string_lossy().into_owned(), s.width, s.height)
    });
    let snapshots = Snapshots::new(plan.checkpoint_every, display.is_some());
    let periodic = |film: &Film| {
        if let Some(display) = &display {
            display.show(film.resolve());
        }
        if snapshots.checkpoint_due() {
            if let Err(e) = save_checkpoint(film) {
                eprintln!("warning: {e:#}");
            }
        }
    };
    // Only now that every input has been checked: a failing run prints one line.
    report_loading(plan, loaded);
    report_start(plan, &film, timeline, loaded.report.obj_bytes);
    let checkpointing = snapshots.every.map(|every| Checkpointing {
        every,
        write: &periodic,
    });
    let (film, stats, passes, view) =
        pool.install(|| render_with_progress(loaded, accel, plan, film, &stop, checkpointing));
    if let Some(display) = display {
        display.finish(film.resolve());
    }

    let write_image = |path: &Path| write_film_image(plan, &film, path);
    let write_checkpoint = || save_checkpoint(&film);
    let signal = stop.load(Ordering::SeqCst);
    if signal != 0 && !film.is_complete() {
        let partial = partial_output(&plan.output);
        match plan.shard {
            Some(_) => write_checkpoint()?,
            None => write_both(&partial, || write_image(&partial), write_checkpoint)?,
        }
        report_interrupted(plan, &film, signal);
        return Ok(ExitCode::from((128 + signal).min(255) as u8));
    }
    // Keep the final state of a whole render with checkpoints: a later --resume with a
    // higher --spp refines it.
    let keep_checkpoint = plan.checkpoint_every.is_some() || plan.resume;
    match plan.shard {
        Some(_) => write_checkpoint()?,
        None if keep_checkpoint => {
            write_both(&plan.output, || write_image(&plan.output), write_checkpoint)?
        }
        None => write_image(&plan.output)?,
    }
    report_finished(plan, accel.name(), &stats, &passes, loaded.report.triangles);
    if let Some((path, pixel)) = &plan.guide_image {
        write_guide_image(path, *pixel, view, plan.guide_sky)?;
    }
    Ok(ExitCode::SUCCESS)
}

/// How often the film is snapshotted while rendering: for checkpoints every
/// `--checkpoint-every`, and for `--display` about once a second.
struct Snapshots {
    every: Option<Duration>,
    checkpoint_every: Option<Duration>,
    last_checkpoint: Mutex<Instant>,
}

impl Snapshots {
    /// The live preview's interval.
    const DISPLAY_EVERY: Duration = Duration::from_secs(1);

    fn new(checkpoint_every: Option<Duration>, display: bool) -> Snapshots {
        let every = match (checkpoint_every, display) {
            (Some(c), true) => Some(c.min(Self::DISPLAY_EVERY)),
            (None, true) => Some(Self::DISPLAY_EVERY),
            (c, false) => c,
        };
        Snapshots {
            every,
            checkpoint_every,
            last_checkpoint: Mutex::new(Instant::now()),
        }
    }

    /// Whether this snapshot is also a checkpoint: the first past `--checkpoint-every`
    /// since the last (snapshots come a little late, so half an interval early counts).
    fn checkpoint_due(&self) -> bool {
        let (Some(checkpoint), Some(every)) = (self.checkpoint_every, self.every) else {
            return false;
        };
        let mut last = self.last_checkpoint.lock().unwrap_or_else(|p| p.into_inner());
        if last.elapsed() + every / 2 >= checkpoint {
            *last = Instant::now();
            return true;
        }
        false
    }
}

/// `--guide-image`'s size: twice as wide as high, as the sphere's azimuth spans twice
/// the range of its z.
const GUIDE_IMAGE_SIZE: (u32, u32) = (256, 128);

/// Writes `--guide-image` (the density as grey; the sky's with `sky`) and says what it
/// shows.
fn write_guide_image(
    path: &Path,
    (x, y): (u32, u32),
    view: Option<GuideView>,
    sky: bool,
) -> Result<()> {
    let Some(view) = view else {
        eprintln!(
            "warning: pixel {x},{y} meets no surface that scatters diffusely or glossily \
             within --max-depth: no --guide-image written"
        );
        return Ok(());
    };
    let (picture, what) = match sky {
        false => (&view.all_light, "the guide"),
        true => (&view.sky, "the sky's guide"),
    };
    // A PNG shows the density relative to its densest pixel (white); EXR and HDR hold
    // the density itself.
    let densest = picture.density.iter().fold(0.0f32, |a, &b| a.max(b));
    let png = image::OutputFormat::from_path(path)? == image::OutputFormat::Png;
    let scale = if png && densest > 0.0 {
        1.0 / densest
    } else {
        1.0
    };
    let image = image::Image {
        width: picture.width,
        height: picture.height,
        pixels: picture
            .density
            .iter()
            .map(|&d| Vec3::splat(d * scale))
            .collect(),
    };
    image.save(path)?;
    let (p, n) = (view.p, view.normal);
    eprintln!(
        "wrote {}: {what} at pixel {x},{y}'s first vertex ({:.3},{:.3},{:.3}), normal \
         ({:.2},{:.2},{:.2}): selection {:.1}, sky share {:.1}, {:.1}% of its mass below the surface, \
         densest {densest:.3} per steradian",
        path.display(),
        p.x,
        p.y,
        p.z,
        n.x,
        n.y,
        n.z,
        view.selection,
        view.sky_share,
        100.0 * picture.below
    );
    Ok(())
}

/// Writes the film's image to `path`: denoised with `--denoise` (the noisy image kept
/// as a layer in an EXR), with the `--aov` passes as layers of an EXR.
fn write_film_image(plan: &RenderPlan, film: &Film, path: &Path) -> Result<()> {
    let output = FilmOutput {
        aovs: &plan.aovs,
        denoise: plan.denoise,
        tonemap: &plan.tonemap,
    };
    Ok(output.write(film, path)?)
}

/// Writes the image at `image` and then the checkpoint; when the checkpoint fails, the
/// image is removed again: a run that fails leaves no file behind.
fn write_both(
    image: &Path,
    write_image: impl FnOnce() -> Result<()>,
    write_checkpoint: impl FnOnce() -> Result<()>,
) -> Result<()> {
    write_image()?;
    write_checkpoint().inspect_err(|_| {
        let _ = std::fs::remove_file(image);
    })
}

fn report_loading(plan: &RenderPlan, loaded: &LoadedScene) {
    let report = &loaded.report;
    for warning in &report.warnings {
        eprintln!("warning: {warning}");
    }
    if loaded.unlit {
        eprintln!(
            "note: the scene has no emissive material: it is lit by a white sky (see --background)"
        );
    }
    let dropped = match report.degenerate_dropped {
        0 => String::new(),
        n => format!(", {n} degenerate triangles dropped"),
    };
    // An instanced scene holds each OBJ once: say how much the placements put in the world.
    let placed = match &loaded.scene.instancing {
        None => String::new(),
        Some(instancing) => format!(
            ", placed {} times ({} triangles in the world)",
            instancing.instances.len(),
            instancing.placed_triangles()
        ),
    };
    eprintln!(
        "loaded {}: {}{dropped}{placed}",
        plan.scene.display(),
        report.summary()
    );
}

/// `shard 2/8 (samples 4..6 of 16)`, or nothing for a whole render.
fn shard_note(plan: &RenderPlan) -> String {
    match plan.shard {
        Some((i, n)) => format!(
            ", shard {i}/{n} (samples {}..{})",
            plan.samples.start, plan.samples.end
        ),
        None => String::new(),
    }
}

fn report_start(plan: &RenderPlan, film: &Film, timeline: &Timeline, obj_bytes: u64) {
    let s = &plan.settings;
    let resumed = if plan.resume {
        format!(
            ", resuming from {} spp",
            film.samples.start + film.min_done()
        )
    } else {
        String::new()
    };
    let first_sample = timeline.started.elapsed();
    let loading = timeline.loaded.as_secs_f64();
    eprintln!(
        "rendering {}x{} at {} spp{}{resumed}; first sample after {:.2} s (loading {loading:.2} s \
         at {:.0} MB/s of OBJ, accelerator {:.2} s)",
        s.width,
        s.height,
        s.spp,
        shard_note(plan),
        first_sample.as_secs_f64(),
        obj_bytes as f64 / 1e6 / loading.max(1e-9),
        (first_sample - timeline.loaded).as_secs_f64(),
    );
}

fn report_interrupted(plan: &RenderPlan, film: &Film, signal: usize) {
    let name = super::signal_name(signal);
    let image = match plan.shard {
        None => format!(
            "the partial image {} and ",
            partial_output(&plan.output).display()
        ),
        Some(_) => String::new(),
    };
    eprintln!(
        "interrupted by {name} after {} of {} samples per pixel (at least {} in every pixel): \
         wrote {image}the checkpoint {} (continue with --resume)",
        film.total_done() / plan.pixels().max(1),
        film.samples.len(),
        film.min_done(),
        plan.checkpoint.display()
    );
}

fn report_finished(
    plan: &RenderPlan,
    accel: &str,
    stats: &RenderStats,
    passes: &PassReport,
    triangles: usize,
) {
    let s = &plan.settings;
    let dropped = match stats.dropped_samples {
        0 => String::new(),
        n => format!(", {n} NaN/infinite samples dropped"),
    };
    // Peak resident memory of the whole run, and per triangle what loading at scale
    // costs; below 100k triangles the process and the film outweigh the mesh, and a
    // figure per triangle would only mislead.
    let peak = match ember::limits::peak_resident_bytes() {
        Some(bytes) if triangles >= 100_000 => format!(
            ", peak memory {} ({:.0} bytes/triangle)",
            ember::limits::human_bytes(bytes),
            bytes as f64 / triangles as f64
        ),
        Some(bytes) => format!(", peak memory {}", ember::limits::human_bytes(bytes)),
        None => String::new(),
    };
    let lights = match stats.light_nodes {
        0 => String::new(),
        n => format!(
            ", light BVH of {n} nodes built in {:.1} ms",
            stats.light_build_seconds * 1e3
        ),
    };
    let spp = if s.adaptive.is_some() || plan.time_limit.is_some() {
        spp_summary(passes)
    } else {
        format!("{} spp", s.spp)
    };
    let guiding = stats.guiding.map_or(String::new(), |g| {
        format!(
            ", guiding trained in {:.2} s ({} samples, {} of them in the image; {} regions, {} of them guided, {} nodes, {})",
            g.seconds,
            g.training_samples,
            g.film_samples,
            g.leaves,
            g.guided_leaves,
            g.nodes,
            ember::limits::human_bytes(g.memory_bytes as u64)
        )
    });
    eprintln!(
        "wrote {}: {}x{}, {spp}{}, {accel} in {:.2} s: {:.0} samples/s, {:.2} Mrays/s{guiding}{dropped}{lights}{peak}",
        plan.output.display(),
        s.width,
        s.height,
        shard_note(plan),
        stats.seconds,
        stats.samples_per_second(),
        stats.mrays_per_second(),
    );
}

fn render_with_progress<A: Accel>(
    loaded: &LoadedScene,
    accel: &A,
    plan: &RenderPlan,
    film: Film,
    stop: &AtomicUsize,
    checkpoint: Option<Checkpointing<'_>>,
) -> (Film, RenderStats, PassReport, Option<GuideView>) {
    let settings = &plan.settings;
    let started = Instant::now();
    let deadline = plan.time_limit.map(|limit| started + limit);
    // A time-limited render's bar is its time; any other's, its samples, less those
    // that converged pixels will not take.
    let bar = match plan.time_limit {
        Some(limit) => ProgressBar::new(limit.as_millis().max(1) as u64),
        None => {
            let pixels = u64::from(settings.width) * u64::from(settings.height);
            let bar = ProgressBar::new(pixels * film.samples.len() as u64);
            bar.set_position(film.total_done());
            bar
        }
    };
    bar.set_style(
        ProgressStyle::with_template(
            "{spinner} [{elapsed_precise}] {wide_bar} {percent}% (eta {eta}) {msg}",
        )
        .expect("static template is valid"),
    );
    let on_samples = |samples: u64| match plan.time_limit {
        Some(limit) => bar.set_position(started.elapsed().min(limit).as_millis() as u64),
        None => bar.inc(samples),
    };
    let on_pass = |report: &PassReport| {
        if plan.time_limit.is_none() {
            bar.set_length(bar.position() + report.remaining);
        }
        if settings.adaptive.is_some() || plan.time_limit.is_some() {
            bar.set_message(spp_summary(report));
        }
    };
    let (scene, camera) = (&loaded.scene, &loaded.camera);
    let view = Mutex::new(None);
    let on_guide = |tree: &SdTree| {
        if let Some((_, pixel)) = plan.guide_image {
            let size = GUIDE_IMAGE_SIZE;
            let seen =
                render::guide_view(scene, accel, camera, tree, pixel, settings.max_depth, size);
            *view.lock().unwrap_or_else(|p| p.into_inner()) = seen;
        }
    };
    let control = RenderControl {
        stop,
        on_samples: &on_samples,
        first_pass_spp: 1,
        checkpoint,
        deadline,
        on_pass: &on_pass,
        on_guide: Some(&on_guide),
    };
    let (film, stats) = render::render_progressive(scene, accel, camera, settings, film, &control);
    bar.finish_and_clear();
    let report = PassReport::of(&film);
    let view = view.into_inner().unwrap_or_else(|p| p.into_inner());
    (film, stats, report, view)
}

/// `spp 16/23.5/64 (min/mean/max), 41.2% converged`.
fn spp_summary(report: &PassReport) -> String {
    format!(
        "spp {}/{:.1}/{} (min/mean/max), {:.1}% converged",
        report.min_spp,
        report.mean_spp,
        report.max_spp,
        100.0 * report.converged_fraction()
    )
}
