//! `ember render`'s flags, grouped under the headings of `--help`, and their value
//! parsers. Each flag's first paragraph is its `-h` line; the rest is for `--help`.

use std::path::PathBuf;

use clap::Args;
use glam::Vec3;

use super::super::tev::{parse_address, DisplayAddress};
use super::super::{
    parse_aov, parse_fov, parse_seconds, parse_shard, parse_vec3, AccelArg, EngineArg,
    IntegratorArg, LightSamplerArg, ToneArgs,
};
use ember::film::aov::Aov;
use ember::guiding::MAX_ITERATIONS;

/// clap's ranges take `i64`.
const MAX_SIDE: i64 = ember::limits::MAX_IMAGE_SIDE as i64;
const MAX_SPP: i64 = ember::limits::MAX_SPP as i64;

const OUTPUT: &str = "Output";
const CAMERA: &str = "Camera";
const SAMPLING: &str = "Sampling";
const LIGHTS: &str = "Lights and sky";
const PASSES: &str = "Passes and denoising";
const GUIDING: &str = "Path guiding";
const LONG: &str = "Long renders and shards";
const ADVANCED: &str = "Advanced";

#[derive(Args)]
#[command(after_long_help = "The guide (docs/guide.md) explains these flags by task.")]
pub struct RenderArgs {
    /// The scene: an OBJ, a glTF 2.0 file (.gltf, .glb), a PLY mesh (.ply), or a scene file (.toml).
    ///
    /// An OBJ's material libraries and textures, and a glTF's buffers and images, are
    /// read from beside it. A scene file holds models with transforms and instances,
    /// cameras, the environment and settings, which the flags given here override (see
    /// the guide's "Scene files").
    pub scene: PathBuf,

    /// Output image: .png, .exr or .hdr [default: the scene's name with .png].
    ///
    /// The extension picks the format: PNG is 8-bit sRGB (through --exposure and
    /// --tonemap), EXR and HDR hold linear radiance. The default is written in the
    /// current directory.
    #[arg(short, long, help_heading = OUTPUT)]
    pub output: Option<PathBuf>,
    /// Image width in pixels.
    ///
    /// Through a glTF camera that gives an aspect ratio (a perspective camera's
    /// aspectRatio, an orthographic one's xmag/ymag), the side not given is derived
    /// from the other and that ratio (--height 512 when neither is given); both given
    /// keep their ratio and the camera's vertical view.
    #[arg(long, default_value_t = 512, value_parser = clap::value_parser!(u32).range(1..=MAX_SIDE), help_heading = OUTPUT)]
    pub width: u32,
    /// Image height in pixels.
    ///
    /// See --width for a glTF camera's aspect ratio.
    #[arg(long, default_value_t = 512, value_parser = clap::value_parser!(u32).range(1..=MAX_SIDE), help_heading = OUTPUT)]
    pub height: u32,
    #[command(flatten, next_help_heading = OUTPUT)]
    pub tone: ToneArgs,
    /// Show the image in progress in the tev viewer at HOST:PORT.
    ///
    /// tev listens on localhost:14158 by default. The image is sent about once a
    /// second and when the render ends; the image written is the same. A viewer that
    /// cannot be reached, or goes away, costs one warning.
    #[arg(long, value_name = "HOST:PORT", value_parser = parse_address, help_heading = OUTPUT)]
    pub display: Option<DisplayAddress>,

    /// Print the summary as one JSON object on stdout, for scripts.
    ///
    /// The figures of the summary line (times, rates, samples, memory), the camera, and
    /// what was written; a failing run prints its error on stderr and nothing here.
    #[arg(long, help_heading = OUTPUT)]
    pub json: bool,

    /// The scene's camera to render through: a scene file's [camera.NAME], or a glTF's
    /// camera by name or index (its first is the default).
    ///
    /// In a scene file, a name that is no [camera.NAME] table names a camera of the glTF
    /// files its [[mesh]] entries place (by name, or by index from 0 in the order
    /// `ember info` lists them), placed by the entry's transform.
    #[arg(long, value_name = "NAME", help_heading = CAMERA)]
    pub camera: Option<String>,
    /// Camera position, X,Y,Z [default: in front of the scene (+z), framing it].
    ///
    /// The default camera looks at the centre of the scene's bounds from its +z side,
    /// far enough back to frame them; the summary prints it as flags to edit. For an
    /// interior, give the camera.
    #[arg(long, value_name = "X,Y,Z", value_parser = parse_vec3, allow_hyphen_values = true, help_heading = CAMERA)]
    pub eye: Option<Vec3>,
    /// Point the camera looks at, X,Y,Z [default: the centre of the scene's bounds].
    #[arg(long, value_name = "X,Y,Z", value_parser = parse_vec3, allow_hyphen_values = true, help_heading = CAMERA)]
    pub look_at: Option<Vec3>,
    /// Camera up direction, X,Y,Z.
    #[arg(long, value_name = "X,Y,Z", value_parser = parse_vec3, allow_hyphen_values = true, default_value = "0,1,0", help_heading = CAMERA)]
    pub up: Vec3,
    /// Vertical field of view in degrees, strictly between 0 and 180.
    #[arg(long, value_name = "DEGREES", default_value_t = 40.0, value_parser = parse_fov, overrides_with = "ortho_height", help_heading = CAMERA)]
    pub fov: f32,
    /// An orthographic camera whose image spans HEIGHT scene units vertically.
    ///
    /// Rays run parallel to the view direction, from the plane through --eye that
    /// faces it; the image's width spans HEIGHT times its aspect ratio. It replaces
    /// --fov (the later of the two wins); depth of field (--aperture) does not apply.
    #[arg(long, value_name = "HEIGHT", value_parser = parse_ortho_height, overrides_with = "fov", help_heading = CAMERA)]
    pub ortho_height: Option<f32>,
    /// Depth of field: the thin lens's radius in scene units [default: 0, a pinhole].
    #[arg(long, value_name = "RADIUS", value_parser = parse_aperture, help_heading = CAMERA)]
    pub aperture: Option<f32>,
    /// Distance to the plane in focus [default: the distance to --look-at].
    ///
    /// Measured from the eye along the view direction.
    #[arg(long, value_name = "DISTANCE", value_parser = parse_focus_distance, help_heading = CAMERA)]
    pub focus_distance: Option<f32>,

    /// Samples per pixel (with --noise-threshold or --time-limit, the most any takes).
    #[arg(long, default_value_t = 64, value_parser = clap::value_parser!(u32).range(1..=MAX_SPP), help_heading = SAMPLING)]
    pub spp: u32,
    /// Light-transport estimator.
    #[arg(long, value_enum, default_value_t = IntegratorArg::Mis, help_heading = SAMPLING)]
    pub integrator: IntegratorArg,
    /// Maximum path length in segments, the camera ray included.
    ///
    /// 1 shows the emitters only, 2 is direct lighting.
    #[arg(long, value_name = "N", default_value_t = 8, value_parser = clap::value_parser!(u32).range(1..=1024), help_heading = SAMPLING)]
    pub max_depth: u32,
    /// Random seed; the same seed gives the same image whatever the thread count.
    #[arg(long, default_value_t = 0, help_heading = SAMPLING)]
    pub seed: u64,
    /// Adaptive sampling: a pixel stops once its relative error is below T.
    ///
    /// After each pass, a pixel goes on only while its estimated relative error
    /// (standard error over sqrt(mean² + 0.01), as `ember compare`'s relMSE weighs it)
    /// is above T, in it or any pixel of its 5×5 neighbourhood. A render whose pixels
    /// all reach T has a relMSE of about T².
    #[arg(long, value_name = "T", value_parser = parse_threshold, help_heading = SAMPLING)]
    pub noise_threshold: Option<f32>,
    /// With --noise-threshold, the samples a pixel takes before it may stop
    /// [default: 32, or --spp if fewer].
    #[arg(long, value_name = "N", requires = "noise_threshold", value_parser = clap::value_parser!(u32).range(1..=MAX_SPP), help_heading = SAMPLING)]
    pub min_spp: Option<u32>,
    /// Render passes until SECONDS have gone by, then write the image.
    ///
    /// Counted from the start of rendering; the render ends earlier if --spp or
    /// --noise-threshold is reached first.
    #[arg(long, value_name = "SECONDS", value_parser = parse_seconds, help_heading = SAMPLING)]
    pub time_limit: Option<f64>,

    /// Radiance of a uniform sky, R,G,B [default: 0,0,0, or 1,1,1 in a scene without
    /// emitters or placed lights].
    ///
    /// A scene without any emissive material or placed light would render black, so it
    /// is lit by a white sky unless a sky is given.
    #[arg(long, value_name = "R,G,B", value_parser = parse_background, allow_hyphen_values = true, conflicts_with = "env", help_heading = LIGHTS)]
    pub background: Option<Vec3>,
    /// Light the scene with an equirectangular environment map (EXR or HDR).
    ///
    /// Linear radiance; row 0 is straight up, the middle column looks along −z.
    /// Importance-sampled as a light.
    #[arg(long, value_name = "FILE", help_heading = LIGHTS)]
    pub env: Option<PathBuf>,
    /// Multiplies the environment map's radiance.
    #[arg(long, value_name = "FACTOR", default_value_t = 1.0, value_parser = parse_env_scale, requires = "env", help_heading = LIGHTS)]
    pub env_scale: f32,
    /// Turns the environment map about +y, counter-clockwise seen from above.
    #[arg(long, value_name = "DEGREES", default_value_t = 0.0, value_parser = parse_degrees, allow_hyphen_values = true, requires = "env", help_heading = LIGHTS)]
    pub env_rotate: f32,
    /// How a light sample picks an emitter and a point on it.
    ///
    /// `auto`: `bvh` with at least 512 emissive triangles, else `alias`. `alias`: an
    /// alias table by power, a uniform point on the triangle. `solid-angle`: the same
    /// table, then a direction by solid angle where the triangle spans a wide angle.
    /// `bvh`: a light BVH weighing power, distance and orientation at the shading
    /// point, then as `solid-angle` (fewer samples for the same error with many
    /// lights, more time per sample).
    #[arg(long, value_enum, default_value_t = LightSamplerArg::Auto, help_heading = LIGHTS)]
    pub light_sampler: LightSamplerArg,

    /// Passes to add to an .exr output as layers: albedo, normal, depth, variance, spp.
    #[arg(long, value_name = "PASSES", value_delimiter = ',', value_parser = parse_aov, help_heading = PASSES)]
    pub aov: Vec<Aov>,
    /// Denoise the image with Intel Open Image Denoise.
    ///
    /// Its RT filter, guided by the albedo and normal passes; an .exr output keeps the
    /// noisy image as layer "noisy".
    #[arg(long, help_heading = PASSES)]
    pub denoise: bool,

    /// Path guiding: learn where light comes from, then sample towards it.
    ///
    /// Müller et al.'s SD-tree of the incident light, with any --integrator, trained
    /// before rendering (2^N − 1 spp over --guiding-iterations N), guides a learnt
    /// share of the scattered directions and of the sky samples in the regions where
    /// guiding pays. The training's samples are the image's first 2^N − 1 of --spp.
    #[arg(long, help_heading = GUIDING)]
    pub guiding: bool,
    /// Training iterations of --guiding; iteration k takes 2^k samples per pixel
    /// [default: the most whose 2^N − 1 samples are at most an eighth of --spp].
    ///
    /// At least 1: 3 at 64 spp, 5 at 256.
    #[arg(long, value_name = "N", requires = "guiding", value_parser = clap::value_parser!(u32).range(1..=i64::from(MAX_ITERATIONS)), help_heading = GUIDING)]
    pub guiding_iterations: Option<u32>,
    /// Write the learnt distribution at pixel --guide-pixel's first vertex to FILE.
    ///
    /// .exr, .hdr or .png: 256x128 pixels of density per steradian over an equal-area
    /// map of the sphere at the first non-delta vertex of the pixel's centre ray: rows
    /// from world +z (top) to −z by equal steps of z, columns the azimuth atan2(y, x)
    /// from 0 to 360° (a PNG is scaled so that its densest pixel is white).
    #[arg(long, value_name = "FILE", requires_all = ["guiding", "guide_pixel"], help_heading = GUIDING)]
    pub guide_image: Option<PathBuf>,
    /// The pixel of --guide-image, X,Y (0,0 is the top-left corner).
    #[arg(long, value_name = "X,Y", value_parser = parse_pixel, requires = "guide_image", help_heading = GUIDING)]
    pub guide_pixel: Option<(u32, u32)>,
    /// --guide-image shows the distribution of the sky seen directly.
    ///
    /// What the region's light samples towards the sky follow, instead of that of all
    /// the light arriving (what its scattered directions follow).
    #[arg(long, requires = "guide_image", help_heading = GUIDING)]
    pub guide_sky: bool,

    /// Write a checkpoint every SECONDS, so that a killed render loses at most that.
    ///
    /// Written atomically; the final state is kept too, for a later --resume with a
    /// higher --spp.
    #[arg(long, value_name = "SECONDS", value_parser = parse_seconds, help_heading = LONG)]
    pub checkpoint_every: Option<f64>,
    /// Checkpoint file [default: the output path with ".checkpoint" appended].
    #[arg(long, value_name = "FILE", help_heading = LONG)]
    pub checkpoint: Option<PathBuf>,
    /// Continue from the checkpoint to --spp samples per pixel.
    ///
    /// The scene, camera, size, seed, depth, integrator, accelerator, adaptive sampling
    /// and guiding must be the ones the checkpoint was made with; --guiding-iterations
    /// and --min-spp, when not given, are the checkpoint's (docs/robustness.md). Once
    /// the image is written, the checkpoint (unless --checkpoint-every keeps it) and the
    /// partial image are removed.
    #[arg(long, help_heading = LONG)]
    pub resume: bool,
    /// Render only shard I of N, to a shard file for `ember merge`.
    ///
    /// Sample indices floor(I*spp/N) .. floor((I+1)*spp/N) of every pixel, written to
    /// the output (whatever its extension). The shard file is its own checkpoint:
    /// `--resume` continues it.
    #[arg(long, value_name = "I/N", value_parser = parse_shard, requires = "output", conflicts_with = "checkpoint", help_heading = LONG)]
    pub shard: Option<(u32, u32)>,

    /// Which structure answers the ray queries.
    ///
    /// The same seed gives the same image with either (up to floating-point ties).
    #[arg(long, value_enum, default_value_t = AccelArg::Embree, help_heading = ADVANCED)]
    pub accel: AccelArg,
    /// Which engine traces the paths.
    ///
    /// `scalar`: one path at a time, every feature. `wavefront`: sixteen paths at a
    /// time in SIMD lanes, their rays as Embree packets; for now it renders untextured,
    /// opaque Lambert scenes lit by their emitters, through a pinhole or an
    /// orthographic camera, with
    /// `--integrator mis`, without passes, denoising or guiding.
    #[arg(long, value_enum, default_value_t = EngineArg::Scalar, help_heading = ADVANCED)]
    pub engine: EngineArg,
    /// Worker threads [default: all cores].
    #[arg(long, value_name = "N", value_parser = clap::value_parser!(u32).range(1..=1024), help_heading = ADVANCED)]
    pub threads: Option<u32>,
    /// Refuse the scene when a file it names is absent, instead of warning.
    ///
    /// A material library, a texture or a `usemtl` material that is absent, or a file
    /// found only by its file name or by ignoring case (see docs/input-rules.md).
    #[arg(long, help_heading = ADVANCED)]
    pub strict: bool,
}

/// A finite number for which `ok` holds, else "`s` is not `what`".
fn parse_f32(s: &str, ok: impl Fn(f32) -> bool, what: &str) -> Result<f32, String> {
    match s.trim().parse::<f32>() {
        Ok(v) if v.is_finite() && ok(v) => Ok(v),
        _ => Err(format!("{s:?} is not {what}")),
    }
}

/// A sky's radiance `R,G,B`: three finite numbers, none negative.
fn parse_background(s: &str) -> Result<Vec3, String> {
    let v = parse_vec3(s)?;
    if v.min_element() < 0.0 {
        return Err(format!("{s:?} is negative: a radiance is 0 or more"));
    }
    Ok(v)
}

fn parse_env_scale(s: &str) -> Result<f32, String> {
    parse_f32(s, |v| v >= 0.0, "a finite factor ≥ 0")
}

fn parse_threshold(s: &str) -> Result<f32, String> {
    parse_f32(s, |v| v > 0.0, "a relative error > 0 (e.g. 0.05)")
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

fn parse_ortho_height(s: &str) -> Result<f32, String> {
    parse_f32(s, |v| v > 0.0, "a height > 0 in scene units")
}

fn parse_focus_distance(s: &str) -> Result<f32, String> {
    parse_f32(s, |v| v > 0.0, "a distance > 0")
}

fn parse_degrees(s: &str) -> Result<f32, String> {
    parse_f32(s, |_| true, "an angle in degrees")
}
