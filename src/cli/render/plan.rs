//! The plan of a render: every flag mapped once to what the render does, and the
//! checks that refuse, before any work, what cannot succeed (an unwritable output, a
//! missing checkpoint, an image too large for memory).

use std::ops::Range;
use std::path::{Path, PathBuf};
use std::time::Duration;

use anyhow::{bail, Context, Result};
use glam::Vec3;

use super::super::check_image_output;
use super::super::tev::DisplayAddress;
use super::args::RenderArgs;
use super::load::env_bytes;
use ember::accel::AccelKind;
use ember::film::aov::Aov;
use ember::film::checkpoint::{FilmReader, Header, Identity};
use ember::film::shard_samples;
use ember::guiding::Guiding;
use ember::image::Tonemap;
use ember::integrator::IntegratorKind;
use ember::light::LightSamplerKind;
use ember::render::{self, Adaptive, Engine, RenderSettings, ResumedDefaults};
use ember::scene::{Lens, LoadOptions, Projection, SceneFile};

/// What the camera flags ask for; the defaults depend on the scene's bounds.
pub struct CameraRequest {
    pub eye: Option<Vec3>,
    pub look_at: Option<Vec3>,
    pub up: Vec3,
    pub fov: f32,
    /// `--ortho-height`: an orthographic camera instead of `fov`.
    pub ortho_height: Option<f32>,
    pub lens: Lens,
    pub choice: CameraChoice,
}

impl CameraRequest {
    /// The projection the flags ask for.
    pub fn projection(&self) -> Projection {
        match self.ortho_height {
            Some(height) => Projection::Orthographic { height },
            None => Projection::perspective(self.fov),
        }
    }
}

/// Which camera of the model files (a glTF's, or those of the glTF files a scene file
/// places) the render goes through, and which flags override it.
#[derive(Clone, Debug, Default)]
pub struct CameraChoice {
    /// By name, or by its index from 0.
    pub name: Option<String>,
    /// Without a name, whether their first camera is used (not when a scene file's
    /// `[camera.NAME]` table is).
    pub first: bool,
    /// The scene file's key that gave `name`, and its place, for errors about it.
    pub named_at: Option<(String, Range<usize>)>,
    /// Which of `eye`, `look-at`, `up`, `fov`, `ortho-height` (they override the file's
    /// camera), `width` and `height` (the file camera's aspect ratio completes them)
    /// were given.
    pub given: Vec<&'static str>,
}

/// Everything `ember render` was asked to do, mapped from the flags once.
pub struct RenderPlan {
    pub scene: PathBuf,
    /// The scene file, when `scene` is one.
    pub scene_file: Option<SceneFile>,
    /// The image, or with `--shard` the shard file.
    pub output: PathBuf,
    /// Where checkpoints go (the shard file itself for a shard).
    pub checkpoint: PathBuf,
    pub checkpoint_every: Option<Duration>,
    pub resume: bool,
    pub threads: Option<u32>,
    pub accel: AccelKind,
    pub settings: RenderSettings,
    pub camera: CameraRequest,
    pub background: Option<Vec3>,
    pub env: Option<EnvRequest>,
    pub tonemap: Tonemap,
    /// Passes written beside the image (EXR output only).
    pub aovs: Vec<Aov>,
    pub denoise: bool,
    pub time_limit: Option<Duration>,
    pub shard: Option<(u32, u32)>,
    /// `--guide-image` and its pixel.
    pub guide_image: Option<(PathBuf, (u32, u32))>,
    /// Whether `--guide-image` shows the sky's distribution (`--guide-sky`).
    pub guide_sky: bool,
    /// The sample indices this process renders: `0..spp`, or the shard's.
    pub samples: Range<u32>,
    /// Whether `--guiding-iterations` and `--min-spp` were given (else a resume takes
    /// the checkpoint's: see [`RenderPlan::resume_defaults`]).
    pub guiding_iterations_given: bool,
    pub min_spp_given: bool,
    /// How the scene is loaded (`--strict`).
    pub load: LoadOptions,
    /// The tev viewer to stream the image in progress to (`--display`).
    pub display: Option<DisplayAddress>,
    /// Print the summary as JSON on stdout (`--json`).
    pub json: bool,
}

impl RenderPlan {
    pub fn from_args(args: RenderArgs) -> RenderPlan {
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
        let min_spp_given = args.min_spp.is_some();
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
                engine: args.engine.into(),
            },
            camera: CameraRequest {
                eye: args.eye,
                look_at: args.look_at,
                up: args.up,
                fov: args.fov,
                ortho_height: args.ortho_height,
                lens: Lens {
                    aperture_radius: args.aperture.unwrap_or(0.0),
                    focus_distance: args.focus_distance,
                },
                choice: CameraChoice {
                    name: args.camera,
                    first: true,
                    ..CameraChoice::default()
                },
            },
            background: args.background,
            env: args.env.map(|path| EnvRequest {
                path,
                scale: args.env_scale,
                rotate: args.env_rotate,
            }),
            tonemap: args.tone.into(),
            aovs: args.aov,
            denoise: args.denoise,
            time_limit: args.time_limit.map(Duration::from_secs_f64),
            shard: args.shard,
            guide_image: args.guide_image.zip(args.guide_pixel),
            guide_sky: args.guide_sky,
            samples,
            guiding_iterations_given,
            min_spp_given,
            load: LoadOptions {
                strict: args.strict,
            },
            display: args.display,
            json: args.json,
        }
    }

    pub fn pixels(&self) -> u64 {
        u64::from(self.settings.width) * u64::from(self.settings.height)
    }

    /// The one rule of `--resume` for settings whose default follows `--spp` (which a
    /// resume may raise): left to their defaults, `--guiding-iterations` and
    /// `--min-spp` are the checkpoint's; given, they must equal it (loading the
    /// checkpoint compares every setting that decides the samples, and refuses).
    pub fn resume_defaults(&mut self) -> Result<()> {
        if !self.resume {
            return Ok(());
        }
        let theirs = ResumedDefaults::of(&FilmReader::open(&self.checkpoint)?.header.identity);
        if let (Some(guiding), false) = (
            self.settings.guiding.as_mut(),
            self.guiding_iterations_given,
        ) {
            guiding.iterations = theirs.guiding_iterations.unwrap_or(guiding.iterations);
        }
        if let (Some(adaptive), false) = (self.settings.adaptive.as_mut(), self.min_spp_given) {
            adaptive.min_spp = theirs.min_spp.unwrap_or(adaptive.min_spp);
        }
        Ok(())
    }

    /// Refuses the settings the wavefront engine does not render yet.
    fn check_engine(&self) -> Result<()> {
        if self.settings.engine != Engine::Wavefront {
            return Ok(());
        }
        let s = &self.settings;
        let refused = if s.integrator != IntegratorKind::Mis {
            "an --integrator other than mis"
        } else if s.guiding.is_some() {
            "--guiding"
        } else if !self.aovs.is_empty() || self.denoise {
            "--aov or --denoise"
        } else if !matches!(
            s.light_sampler,
            LightSamplerKind::Auto | LightSamplerKind::Alias
        ) {
            "a --light-sampler other than alias"
        } else if self.camera.lens.aperture_radius > 0.0 {
            "--aperture"
        } else {
            return Ok(());
        };
        bail!("--engine wavefront does not render with {refused} yet")
    }

    /// Refuses what can be refused before loading anything: an unwritable or unknown
    /// output, bad environment, a missing checkpoint, an image too large for memory.
    pub fn check(&self) -> Result<()> {
        self.check_outputs()?;
        env_bytes(ember::limits::MEMORY_LIMIT_ENV)?;
        env_bytes("EMBER_EMBREE_MEMORY_LIMIT")?;
        self.check_engine()?;
        // What is there but cannot be read (a folder, a named pipe) is refused by the
        // checkpoint's reader, saying what it is.
        if self.resume && !self.checkpoint.exists() {
            bail!(
                "cannot resume: there is no checkpoint {}",
                self.checkpoint.display()
            );
        }
        self.check_size()
    }

    /// Refuses an image size that `--guide-pixel` is outside of, or that does not fit
    /// in memory; again once a file camera's aspect ratio has set the size.
    pub fn check_size(&self) -> Result<()> {
        let (w, h) = (self.settings.width, self.settings.height);
        if let Some((_, (x, y))) = self.guide_image {
            if x >= w || y >= h {
                bail!("--guide-pixel {x},{y} is outside the {w}x{h} image");
            }
        }
        // width × height × spp fits in u64 for every value the flags accept (at most
        // 2^28 × 10^6); checked all the same.
        (self.pixels())
            .checked_mul(u64::from(self.settings.spp))
            .context("width × height × spp overflows")?;
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
        let partial = partial_output(&self.output);
        if self.shard.is_none() {
            check_image_output(&self.output, &self.aovs, self.denoise)?;
            check_image_output(&partial, &self.aovs, self.denoise)?;
        }
        ember::io::check_writable(&self.checkpoint)?;
        let mut outputs: Vec<(&str, &Path)> = match self.shard {
            Some(_) => vec![("the shard file", &self.output)],
            None => vec![
                ("the image", &self.output),
                ("the partial image", &partial),
                ("the checkpoint", &self.checkpoint),
            ],
        };
        if let Some((path, _)) = &self.guide_image {
            check_image_output(path, &[], false)?;
            outputs.push(("--guide-image", path));
        }
        let mut inputs: Vec<(&str, &Path)> = vec![("the scene", &self.scene)];
        if let Some(file) = &self.scene_file {
            inputs.extend(file.objs.iter().map(|o| ("the mesh", o.path.as_path())));
        }
        if let Some(env) = &self.env {
            inputs.push(("the environment map", &env.path));
        }
        super::super::check_distinct_files(&outputs, &inputs)
    }

    /// The header of this render's checkpoints or shard file.
    pub fn header(&self, identity: Identity) -> Header {
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
pub struct EnvRequest {
    pub path: PathBuf,
    pub scale: f32,
    pub rotate: f32,
}

fn default_output(scene: &Path) -> PathBuf {
    let stem = scene.file_stem().unwrap_or_else(|| "ember".as_ref());
    PathBuf::from(stem).with_extension("png")
}

/// `out.png` -> `out.partial.png`: where an interrupted render's image goes, so that a
/// partial image is never mistaken for the finished one.
pub fn partial_output(output: &Path) -> PathBuf {
    let ext = output
        .extension()
        .map(|e| e.to_string_lossy().into_owned())
        .unwrap_or_default();
    output.with_extension(format!("partial.{ext}"))
}

fn default_checkpoint(output: &Path) -> PathBuf {
    let mut name = output.as_os_str().to_owned();
    name.push(".checkpoint");
    PathBuf::from(name)
}
