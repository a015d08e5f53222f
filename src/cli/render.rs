//! `ember render`: check every input, load the scene, build the chosen accelerator,
//! render progressively with checkpoints and signal handling, write the image.

use std::path::{Path, PathBuf};
use std::process::ExitCode;
use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};
use std::sync::Arc;
use std::time::Duration;

use anyhow::{bail, Context, Result};
use clap::Args;
use glam::Vec3;
use indicatif::{ProgressBar, ProgressStyle};
use signal_hook::consts::{SIGINT, SIGTERM};

use super::{parse_fov, parse_seconds, parse_vec3};
use ember::accel::{Accel, AccelKind, Bvh, EmbreeAccel};
use ember::checkpoint;
use ember::embree::{BuildQuality, Device};
use ember::film;
use ember::integrator::IntegratorKind;
use ember::render::{self, Checkpointing, Progress, RenderControl, RenderSettings, RenderStats};
use ember::scene::{load_obj, Camera, CameraSettings, LoadReport, Scene};

#[derive(Args)]
pub struct RenderArgs {
    /// The OBJ scene (its MTL libraries and textures are read from beside it).
    scene: PathBuf,
    /// Output image; the extension picks the format: .png, .exr or .hdr
    /// [default: the scene's name with .png, in the current directory]
    #[arg(short, long)]
    output: Option<PathBuf>,
    /// Image width in pixels.
    #[arg(long, default_value_t = 512, value_parser = clap::value_parser!(u32).range(1..=16384))]
    width: u32,
    /// Image height in pixels.
    #[arg(long, default_value_t = 512, value_parser = clap::value_parser!(u32).range(1..=16384))]
    height: u32,
    /// Samples per pixel.
    #[arg(long, default_value_t = 64, value_parser = clap::value_parser!(u32).range(1..=1_000_000))]
    spp: u32,
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
    /// Radiance of a uniform sky behind the scene, R,G,B [default: 0,0,0, or 1,1,1
    /// when the scene has no emissive material, so that it is not rendered black].
    #[arg(long, value_parser = parse_vec3, allow_hyphen_values = true)]
    background: Option<Vec3>,
    /// Light-transport estimator.
    #[arg(long, value_enum, default_value_t = IntegratorKind::default())]
    integrator: IntegratorKind,
    /// Write the progress to the checkpoint file every SECONDS (atomically), so that a
    /// killed render loses at most that much work; the final state is kept too.
    #[arg(long, value_name = "SECONDS", value_parser = parse_seconds)]
    checkpoint_every: Option<f64>,
    /// Checkpoint file [default: the output path with ".checkpoint" appended].
    #[arg(long, value_name = "FILE")]
    checkpoint: Option<PathBuf>,
    /// Continue from the checkpoint file to --spp samples per pixel. The scene, camera,
    /// size, seed, depth and integrator must be the ones the checkpoint was made with.
    #[arg(long)]
    resume: bool,
    /// Which structure answers the ray queries; the same seed gives the same image with
    /// either (up to floating-point ties).
    #[arg(long, value_enum, default_value_t = AccelKind::Embree)]
    accel: AccelKind,
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

pub fn run(args: RenderArgs) -> Result<ExitCode> {
    let output = args
        .output
        .clone()
        .unwrap_or_else(|| default_output(&args.scene));
    // Fail on an unwritable or unknown output before spending time on the render.
    film::check_writable(&output)?;
    env_bytes(ember::limits::MEMORY_LIMIT_ENV)?;
    let embree_limit = env_bytes("EMBER_EMBREE_MEMORY_LIMIT")?;
    let checkpoint_path = args
        .checkpoint
        .clone()
        .unwrap_or_else(|| default_checkpoint(&output));
    if args.resume && !checkpoint_path.is_file() {
        bail!(
            "cannot resume: there is no checkpoint {}",
            checkpoint_path.display()
        );
    }
    // Refuse images that cannot fit before loading anything. (width × height × spp fits
    // in u64 for every value the flags accept: at most 2^28 × 10^6.)
    let pixels = u64::from(args.width) * u64::from(args.height);
    pixels
        .checked_mul(u64::from(args.spp))
        .context("width × height × spp overflows")?;
    ember::limits::check_fits(
        &format!("a {}x{} image", args.width, args.height),
        render::render_memory_bytes(args.width, args.height),
    )
    .map_err(anyhow::Error::msg)?;

    let (mut scene, report) = load_obj(&args.scene)?;
    let unlit = scene.emitters.is_empty() && args.background.is_none();
    scene.background = match args.background {
        Some(b) if b.min_element() < 0.0 => bail!("--background must not be negative"),
        Some(b) => b,
        None if unlit => Vec3::ONE,
        None => Vec3::ZERO,
    };
    let (lo, hi) = scene.bounds();
    let framing = CameraSettings::framing(lo, hi, args.fov);
    let camera_settings = CameraSettings {
        eye: args.eye.unwrap_or(framing.eye),
        look_at: args.look_at.unwrap_or(framing.look_at),
        up: args.up,
        vfov_degrees: args.fov,
    };
    camera_settings
        .validate()
        .map_err(anyhow::Error::msg)
        .context("invalid camera")?;
    let camera = camera_settings.camera(args.width, args.height);
    let settings = RenderSettings {
        width: args.width,
        height: args.height,
        spp: args.spp,
        max_depth: args.max_depth,
        seed: args.seed,
        integrator: args.integrator,
    };

    let mut pool = rayon::ThreadPoolBuilder::new();
    if let Some(n) = args.threads {
        pool = pool.num_threads(n as usize);
    }
    let pool = pool.build().context("cannot start worker threads")?;
    let job = RenderJob {
        args: &args,
        scene: &scene,
        report: &report,
        unlit,
        camera_settings,
        camera,
        settings,
        output,
        checkpoint_path,
        pixels,
    };
    // One generic render per backend: the match picks the type, no dynamic dispatch.
    match args.accel {
        AccelKind::Embree => {
            let device = Device::new(&embree_config(args.threads))?;
            if let Some(limit) = embree_limit {
                device.set_memory_limit(Some(usize::try_from(limit).unwrap_or(usize::MAX)));
            }
            let accel = EmbreeAccel::build(
                &device,
                &scene.mesh.positions,
                &scene.mesh.triangles,
                BuildQuality::High,
            )
            .context("cannot build the Embree scene")?;
            finish_render(&job, &pool, &accel)
        }
        AccelKind::Bvh => {
            let accel = pool
                .install(|| Bvh::build(&scene.mesh.positions, &scene.mesh.triangles))
                .context("cannot build the native BVH")?;
            finish_render(&job, &pool, &accel)
        }
    }
}

/// Everything a render needs once its inputs are checked, whatever the backend.
struct RenderJob<'a> {
    args: &'a RenderArgs,
    scene: &'a Scene,
    report: &'a LoadReport,
    unlit: bool,
    camera_settings: CameraSettings,
    camera: Camera,
    settings: RenderSettings,
    output: PathBuf,
    checkpoint_path: PathBuf,
    pixels: u64,
}

/// Renders with checkpoints and signal handling, then writes the image (or, when
/// interrupted, the partial image and a checkpoint).
fn finish_render<A: Accel>(
    job: &RenderJob<'_>,
    pool: &rayon::ThreadPool,
    accel: &A,
) -> Result<ExitCode> {
    let RenderJob {
        args,
        scene,
        report,
        unlit,
        ref camera_settings,
        ref camera,
        ref settings,
        ref output,
        ref checkpoint_path,
        pixels,
    } = *job;
    let identity = checkpoint::identity(scene, camera_settings, settings);
    let progress = if args.resume {
        checkpoint::load(checkpoint_path, &identity, settings.spp)?
    } else {
        Progress::new(settings.width, settings.height)
    };
    let resumed_from = progress.min_done();

    // From here on Ctrl-C or SIGTERM stops the workers and writes what there is; a
    // second one exits at once. (Before, the default action ends the process: there
    // is nothing to save yet.)
    let stop = Arc::new(AtomicUsize::new(0));
    let stopping = Arc::new(AtomicBool::new(false));
    for signal in [SIGINT, SIGTERM] {
        // The conditional shutdown runs first: on the first signal `stopping` is still
        // false, so only the flags below are set.
        signal_hook::flag::register_conditional_shutdown(signal, 128 + signal, stopping.clone())
            .and_then(|_| signal_hook::flag::register(signal, stopping.clone()))
            .and_then(|_| signal_hook::flag::register_usize(signal, stop.clone(), signal as usize))
            .context("cannot install the signal handlers")?;
    }
    let save_checkpoint = |progress: &Progress| -> Result<()> {
        checkpoint::save(checkpoint_path, &identity, progress)
            .context("cannot write the checkpoint")
    };
    let periodic = |progress: &Progress| {
        if let Err(e) = save_checkpoint(progress) {
            eprintln!("warning: {e:#}");
        }
    };
    // Only now that every input has been checked: a failing run prints one line.
    for warning in &report.warnings {
        eprintln!("warning: {}: {warning}", args.scene.display());
    }
    if unlit {
        eprintln!(
            "note: the scene has no emissive material: it is lit by a white sky (see --background)"
        );
    }
    eprintln!(
        "loaded {}: {} triangles, {} materials, {} emissive triangles{}",
        args.scene.display(),
        report.triangles,
        report.materials,
        report.emitters,
        if report.degenerate_dropped > 0 {
            format!(
                ", {} degenerate triangles dropped",
                report.degenerate_dropped
            )
        } else {
            String::new()
        }
    );

    eprintln!(
        "rendering {}x{} at {} spp{}",
        settings.width,
        settings.height,
        settings.spp,
        if args.resume {
            format!(", resuming from {resumed_from} spp")
        } else {
            String::new()
        }
    );
    let control_checkpoint = args.checkpoint_every.map(|s| Checkpointing {
        every: Duration::from_secs_f64(s),
        write: &periodic,
    });
    let (progress, stats) = pool.install(|| {
        render_with_progress(
            scene,
            accel,
            camera,
            settings,
            progress,
            &stop,
            control_checkpoint,
        )
    });

    let signal = stop.load(Ordering::SeqCst);
    if signal != 0 && progress.min_done() < settings.spp {
        let partial = partial_output(output);
        progress.film().save(&partial)?;
        save_checkpoint(&progress)?;
        eprintln!(
            "interrupted by {} after {} of {} samples per pixel (at least {} in every pixel): \
             wrote the partial image {} and the checkpoint {} (continue with --resume)",
            if signal == SIGTERM as usize {
                "SIGTERM"
            } else {
                "SIGINT"
            },
            progress.total_done() / pixels.max(1),
            settings.spp,
            progress.min_done(),
            partial.display(),
            checkpoint_path.display()
        );
        return Ok(ExitCode::from((128 + signal).min(255) as u8));
    }
    progress.film().save(output)?;
    if args.checkpoint_every.is_some() || args.resume {
        // Keep the final state: a later --resume with a higher --spp refines it.
        save_checkpoint(&progress)?;
    }
    eprintln!(
        "wrote {}: {}x{}, {} spp, {} in {:.2} s: {:.0} samples/s, {:.2} Mrays/s{}",
        output.display(),
        args.width,
        args.height,
        args.spp,
        accel.name(),
        stats.seconds,
        stats.samples_per_second(),
        stats.mrays_per_second(),
        if stats.dropped_samples > 0 {
            format!(", {} NaN/infinite samples dropped", stats.dropped_samples)
        } else {
            String::new()
        }
    );
    Ok(ExitCode::SUCCESS)
}

fn render_with_progress<A: Accel>(
    scene: &Scene,
    accel: &A,
    camera: &ember::scene::Camera,
    settings: &RenderSettings,
    progress: Progress,
    stop: &AtomicUsize,
    checkpoint: Option<Checkpointing<'_>>,
) -> (Progress, RenderStats) {
    let total = u64::from(settings.width) * u64::from(settings.height) * u64::from(settings.spp);
    let bar = ProgressBar::new(total);
    bar.set_position(progress.total_done());
    bar.set_style(
        ProgressStyle::with_template(
            "{spinner} [{elapsed_precise}] {wide_bar} {percent}% (eta {eta})",
        )
        .expect("static template is valid"),
    );
    let control = RenderControl {
        stop,
        on_samples: &|samples| bar.inc(samples),
        first_pass_spp: 1,
        checkpoint,
    };
    let result = render::render_progressive(scene, accel, camera, settings, progress, &control);
    bar.finish_and_clear();
    result
}
