//! The subcommands of the `ember` binary, one module each, and the flag parsers and
//! value enums they share. Flags are mapped to the library's types here, once: clap
//! stays out of the library.

pub mod bench;
pub mod console;
pub mod denoise;
pub mod machine;
pub mod merge;
pub mod misc;
#[cfg(test)]
mod reference;
pub mod render;
pub mod scene_input;
pub mod tev;
pub mod verbosity;

use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::Arc;

use anyhow::{Context, Result};
use clap::ValueEnum;
use glam::Vec3;
use signal_hook::consts::{SIGINT, SIGTERM};
use signal_hook::iterator::Signals;

use std::path::Path;

use anyhow::bail;
use ember::accel::AccelKind;
use ember::film::aov::Aov;
use ember::integrator::IntegratorKind;
use ember::light::LightSamplerKind;

/// From the call on, SIGINT and SIGTERM no longer end ember: the first one's number is
/// stored in the returned flag (for the caller to stop its work and save it), later
/// ones only count. GNU `timeout` and Slurm signal the whole process group, often more
/// than once, and a save under way must complete (a write is atomic, but an exit
/// half-way would leave its temporary file behind). SIGKILL still ends ember at once.
/// Before the call, the default action ends the process: there is nothing to save yet.
pub fn stop_on_signals() -> Result<Arc<AtomicUsize>> {
    let stop = Arc::new(AtomicUsize::new(0));
    let mut signals =
        Signals::new([SIGINT, SIGTERM]).context("cannot install the signal handlers")?;
    let first = stop.clone();
    // Signals arrive here in order: the first one's number stays in `stop`.
    std::thread::spawn(move || {
        for signal in signals.forever() {
            let _ = first.compare_exchange(0, signal as usize, Ordering::SeqCst, Ordering::SeqCst);
        }
    });
    Ok(stop)
}

/// `SIGTERM` or `SIGINT`, for messages.
pub fn signal_name(signal: usize) -> &'static str {
    if signal == SIGTERM as usize {
        "SIGTERM"
    } else {
        "SIGINT"
    }
}

/// Refuses, before any work, a run whose outputs name one file twice or name one of
/// its inputs, under whatever names (`./out.png`, `sub/../out.png`, a link): each is
/// `(what, path)`, as `("--checkpoint", "ck")`. Outputs that do not exist yet are
/// compared by their canonical folder and name ([`ember::io::same_file`]).
pub fn check_distinct_files(
    outputs: &[(&str, &std::path::Path)],
    inputs: &[(&str, &std::path::Path)],
) -> Result<()> {
    use ember::io::file_identity;
    let identities: Vec<_> = outputs.iter().map(|(_, p)| file_identity(p)).collect();
    for (i, (what, path)) in outputs.iter().enumerate() {
        for (j, (other, other_path)) in outputs.iter().enumerate().take(i) {
            if identities[i].same(&identities[j]) {
                anyhow::bail!(
                    "{what} {} would overwrite {other} {} (the same file)",
                    path.display(),
                    other_path.display()
                );
            }
        }
        for (input, input_path) in inputs {
            if identities[i].same(&file_identity(input_path)) {
                anyhow::bail!(
                    "{what} {} would overwrite {input} {} (the same file): ember does not \
                     overwrite what it reads",
                    path.display(),
                    input_path.display()
                );
            }
        }
    }
    Ok(())
}

/// `--accel`: which structure answers the ray queries.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum AccelArg {
    /// Intel Embree through FFI.
    Embree,
    /// ember's native Rust BVH.
    Bvh,
}

impl From<AccelArg> for AccelKind {
    fn from(arg: AccelArg) -> Self {
        match arg {
            AccelArg::Embree => AccelKind::Embree,
            AccelArg::Bvh => AccelKind::Bvh,
        }
    }
}

/// `--integrator`: the light-transport estimator.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum IntegratorArg {
    /// Path tracing that samples only the material (cosine-weighted for diffuse).
    Bsdf,
    /// Next-event estimation: direct light from light samples only, no MIS.
    Light,
    /// One sample per bounce from the 50/50 mixture of cosine and light densities.
    Mixture,
    /// Next-event estimation and material sampling combined by multiple importance
    /// sampling (power heuristic), with Russian roulette.
    Mis,
}

/// `--engine`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum EngineArg {
    /// One path at a time: every feature.
    Scalar,
    /// Sixteen paths at a time in SIMD lanes, rays as Embree packets. For now it
    /// renders untextured, opaque Lambert scenes lit by their emitters through a
    /// pinhole with `--integrator mis`, without passes, denoising or guiding.
    Wavefront,
}

impl From<EngineArg> for ember::render::Engine {
    fn from(e: EngineArg) -> Self {
        match e {
            EngineArg::Scalar => ember::render::Engine::Scalar,
            EngineArg::Wavefront => ember::render::Engine::Wavefront,
        }
    }
}

/// `--light-sampler`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum LightSamplerArg {
    /// `bvh` in scenes of at least 512 emissive triangles, `alias` below (where the
    /// BVH was measured to cost more than it gains).
    Auto,
    /// An alias table: emitters in proportion to power, wherever the point is; a
    /// uniform point on the chosen triangle's area.
    Alias,
    /// The alias table, then a direction by solid angle where the triangle spans a
    /// wide angle.
    SolidAngle,
    /// A light BVH (emitters weighed by power, distance and orientation at the point),
    /// then solid-angle sampling as for `solid-angle`.
    Bvh,
}

impl From<LightSamplerArg> for LightSamplerKind {
    fn from(arg: LightSamplerArg) -> Self {
        match arg {
            LightSamplerArg::Auto => LightSamplerKind::Auto,
            LightSamplerArg::Bvh => LightSamplerKind::Bvh,
            LightSamplerArg::Alias => LightSamplerKind::Alias,
            LightSamplerArg::SolidAngle => LightSamplerKind::SolidAngle,
        }
    }
}

impl From<IntegratorArg> for IntegratorKind {
    fn from(arg: IntegratorArg) -> Self {
        match arg {
            IntegratorArg::Bsdf => IntegratorKind::Bsdf,
            IntegratorArg::Light => IntegratorKind::Light,
            IntegratorArg::Mixture => IntegratorKind::Mixture,
            IntegratorArg::Mis => IntegratorKind::Mis,
        }
    }
}

/// `I/N`: shard I (from 0) of N.
pub fn parse_shard(s: &str) -> Result<(u32, u32), String> {
    let most = ember::limits::MAX_SHARDS;
    let bad = || format!("expected I/N with 0 <= I < N <= {most}, got {s:?}");
    let (i, n) = s.trim().split_once('/').ok_or_else(bad)?;
    let (i, n): (u32, u32) = (i.parse().map_err(|_| bad())?, n.parse().map_err(|_| bad())?);
    if i < n && n <= most {
        Ok((i, n))
    } else {
        Err(bad())
    }
}

/// A positive number of seconds (checkpoint intervals).
pub fn parse_seconds(s: &str) -> Result<f64, String> {
    let v: f64 = s
        .trim()
        .parse()
        .map_err(|_| format!("{s:?} is not a number of seconds"))?;
    if v > 0.0 && v <= 1e9 {
        Ok(v)
    } else {
        Err(format!("{v} is not a positive number of seconds"))
    }
}

/// `X,Y,Z`: three finite numbers.
pub fn parse_vec3(s: &str) -> Result<Vec3, String> {
    let parts: Vec<&str> = s.split(',').map(str::trim).collect();
    let [x, y, z] = parts.as_slice() else {
        return Err(format!("expected three numbers X,Y,Z, got {s:?}"));
    };
    let num = |t: &str| -> Result<f32, String> {
        t.parse::<f32>()
            .ok()
            .filter(|v| v.is_finite())
            .ok_or_else(|| format!("{t:?} is not a finite number"))
    };
    Ok(Vec3::new(num(x)?, num(y)?, num(z)?))
}

/// A vertical field of view in degrees, strictly between 0 and 180.
pub fn parse_fov(s: &str) -> Result<f32, String> {
    let v: f32 = s
        .trim()
        .parse()
        .map_err(|_| format!("{s:?} is not a number"))?;
    if v > 0.0 && v < 180.0 {
        Ok(v)
    } else {
        Err(format!("{v} is not between 0 and 180 degrees (exclusive)"))
    }
}

/// `--tonemap`: the curve 8-bit outputs go through.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum ToneCurveArg {
    /// sRGB, clipped at 1.
    Clip,
    /// The ACES filmic curve (Narkowicz's fit).
    Aces,
    /// Troy Sobotka's AgX, default look.
    Agx,
}

/// How PNG outputs are made from linear radiance (EXR and HDR stay linear).
#[derive(Clone, Copy, Debug, clap::Args)]
pub struct ToneArgs {
    /// Exposure in stops applied before the tone curve (PNG only).
    #[arg(long, value_name = "EV", default_value_t = 0.0, value_parser = parse_exposure, allow_hyphen_values = true)]
    pub exposure: f32,
    /// The tone curve for PNG output.
    #[arg(long, value_enum, default_value_t = ToneCurveArg::Clip)]
    pub tonemap: ToneCurveArg,
}

impl From<ToneArgs> for ember::image::Tonemap {
    fn from(args: ToneArgs) -> Self {
        use ember::image::ToneCurve;
        ember::image::Tonemap {
            exposure: args.exposure,
            curve: match args.tonemap {
                ToneCurveArg::Clip => ToneCurve::Clip,
                ToneCurveArg::Aces => ToneCurve::Aces,
                ToneCurveArg::Agx => ToneCurve::Agx,
            },
        }
    }
}

fn parse_exposure(s: &str) -> Result<f32, String> {
    let ev: f32 = s
        .trim()
        .parse()
        .map_err(|_| format!("{s:?} is not a number of stops"))?;
    if !ev.is_finite() || ev.abs() > 64.0 {
        return Err(format!("{s}: exposure must be between -64 and 64 stops"));
    }
    Ok(ev)
}

/// `--aov`'s names.
pub fn parse_aov(s: &str) -> Result<Aov, String> {
    Aov::from_name(s.trim()).ok_or_else(|| {
        let names: Vec<&str> = Aov::ALL.iter().map(|a| a.name()).collect();
        format!("unknown pass {s:?}: choose from {}", names.join(", "))
    })
}

/// Refuses, before any work, an image output that cannot be written or cannot hold
/// what is asked of it, and `--denoise` in an ember that cannot denoise.
pub fn check_image_output(output: &Path, aovs: &[Aov], denoise: bool) -> Result<()> {
    ember::image::check_output(output)?;
    let exr = ember::image::OutputFormat::from_path(output)? == ember::image::OutputFormat::Exr;
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

/// `--json`'s one object on stdout, printed once the run has succeeded (a failing run
/// prints its error on stderr and nothing on stdout).
pub fn print_json(value: &serde_json::Value) {
    let text = serde_json::to_string_pretty(value).expect("a JSON value serialises");
    println!("{text}");
}
