//! The `ember` command line: `ember render`, `ember bench`, `ember info`.

use std::path::{Path, PathBuf};
use std::process::ExitCode;

use anyhow::{bail, Context, Result};
use clap::{Args, Parser, Subcommand};
use glam::Vec3;
use indicatif::{ProgressBar, ProgressStyle};

use ember::accel::{Accel, AccelKind, Bvh, EmbreeAccel};
use ember::bench::{self, BenchMesh, BenchOptions};
use ember::embree::{BuildQuality, Device};
use ember::film::{self, Film};
use ember::integrator::IntegratorKind;
use ember::render::{self, RenderSettings, RenderStats};
use ember::scene::{load_obj, CameraSettings, Procedural, Scene};

#[derive(Parser)]
#[command(
    name = "ember",
    version,
    about = "A physically based path tracer for OBJ scenes, on Intel Embree"
)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Render an OBJ scene to PNG (sRGB), EXR or HDR (linear).
    Render(RenderArgs),
    /// Time Embree against the native BVH: build time, memory, and rays per second for
    /// primary, diffuse and shadow rays, single-threaded and on several threads.
    Bench(BenchArgs),
    /// Show the Embree library in use, its ISA and threads, and how ember was built.
    Info,
}

#[derive(Args)]
struct RenderArgs {
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
    /// Light-transport estimator.
    #[arg(long, value_enum, default_value_t = IntegratorKind::Bsdf)]
    integrator: IntegratorKind,
    /// Which structure answers the ray queries; the same seed gives the same image with
    /// either (up to floating-point ties).
    #[arg(long, value_enum, default_value_t = AccelKind::Embree)]
    accel: AccelKind,
}

#[derive(Args)]
struct BenchArgs {
    /// OBJ meshes to benchmark on (materials with Ke > 0 become the shadow rays' targets).
    meshes: Vec<PathBuf>,
    /// Procedural meshes, KIND:COUNT with KIND `sphere` (a subdivided unit sphere) or
    /// `soup` (random triangles in a cube) and COUNT the number of triangles, with an
    /// optional k or m suffix; comma-separated for a scaling series, e.g.
    /// `--procedural sphere:1k,sphere:100k,sphere:1m,soup:10m`.
    #[arg(long, value_delimiter = ',')]
    procedural: Vec<Procedural>,
    /// Rays in each set (primary, diffuse, shadow).
    #[arg(long, default_value_t = 1 << 18, value_parser = clap::value_parser!(u64).range(1..=1 << 28))]
    rays: u64,
    /// Thread counts to measure with, comma-separated [default: 1 and all cores].
    #[arg(long, value_delimiter = ',', value_parser = clap::value_parser!(u32).range(1..=1024))]
    threads: Vec<u32>,
    /// Seconds each measurement repeats for at least (the best run is reported).
    #[arg(long, default_value_t = 0.5, value_parser = parse_seconds)]
    min_time: f64,
    /// Random seed of the ray sets and procedural meshes.
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// Camera position for the primary rays, X,Y,Z [default: in front of the mesh (+z)].
    #[arg(long, value_parser = parse_vec3, allow_hyphen_values = true)]
    eye: Option<Vec3>,
    /// Point the camera looks at, X,Y,Z [default: the centre of the mesh's bounds].
    #[arg(long, value_parser = parse_vec3, allow_hyphen_values = true)]
    look_at: Option<Vec3>,
    /// Print one JSON document on stdout (the table goes to stderr).
    #[arg(long)]
    json: bool,
    /// Also write the JSON document to this file (atomically).
    #[arg(long)]
    json_out: Option<PathBuf>,
}

fn parse_seconds(s: &str) -> Result<f64, String> {
    match s.trim().parse::<f64>() {
        Ok(v) if (0.0..=3600.0).contains(&v) => Ok(v),
        _ => Err(format!(
            "{s:?} is not a number of seconds between 0 and 3600"
        )),
    }
}

fn parse_vec3(s: &str) -> Result<Vec3, String> {
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

fn parse_fov(s: &str) -> Result<f32, String> {
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

fn main() -> ExitCode {
    let cli = match Cli::try_parse() {
        Ok(cli) => cli,
        Err(e) if !e.use_stderr() => {
            // --help and --version go to stdout in full.
            let _ = e.print();
            return ExitCode::SUCCESS;
        }
        Err(e) => {
            // One line: clap's first line already says what is wrong with which flag.
            let text = e.render().to_string();
            eprintln!(
                "{}",
                text.lines().next().unwrap_or("error: invalid arguments")
            );
            return ExitCode::from(2);
        }
    };
    let result = match cli.command {
        Command::Render(args) => render_command(args),
        Command::Bench(args) => bench_command(args),
        Command::Info => info_command(),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {e:#}");
            ExitCode::FAILURE
        }
    }
}

fn default_output(scene: &Path) -> PathBuf {
    let stem = scene.file_stem().unwrap_or_else(|| "ember".as_ref());
    PathBuf::from(stem).with_extension("png")
}

fn render_command(args: RenderArgs) -> Result<()> {
    let output = args
        .output
        .clone()
        .unwrap_or_else(|| default_output(&args.scene));
    // Fail on an unwritable or unknown output before spending time on the render.
    film::check_writable(&output)?;

    let (scene, report) = load_obj(&args.scene)?;
    for warning in &report.warnings {
        eprintln!("warning: {}: {warning}", args.scene.display());
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
    // One generic render per backend: the match picks the type, no dynamic dispatch.
    let (film, stats, backend) = match args.accel {
        AccelKind::Embree => {
            let device_config = args
                .threads
                .map(|n| format!("threads={n}"))
                .unwrap_or_default();
            let device = Device::new(&device_config)?;
            let accel = EmbreeAccel::build(
                &device,
                &scene.mesh.positions,
                &scene.mesh.triangles,
                BuildQuality::High,
            )
            .context("cannot build the Embree scene")?;
            let (film, stats) =
                pool.install(|| render_with_progress(&scene, &accel, &camera, &settings));
            (film, stats, accel.name())
        }
        AccelKind::Bvh => {
            let accel = pool
                .install(|| Bvh::build(&scene.mesh.positions, &scene.mesh.triangles))
                .context("cannot build the native BVH")?;
            let (film, stats) =
                pool.install(|| render_with_progress(&scene, &accel, &camera, &settings));
            (film, stats, accel.name())
        }
    };
    film.save(&output)?;
    eprintln!(
        "wrote {}: {}x{}, {} spp, {} in {:.2} s: {:.0} samples/s, {:.2} Mrays/s{}",
        output.display(),
        args.width,
        args.height,
        args.spp,
        backend,
        stats.seconds,
        stats.samples_per_second(),
        stats.mrays_per_second(),
        if stats.dropped_samples > 0 {
            format!(", {} NaN/infinite samples dropped", stats.dropped_samples)
        } else {
            String::new()
        }
    );
    Ok(())
}

fn render_with_progress<A: Accel>(
    scene: &Scene,
    accel: &A,
    camera: &ember::scene::Camera,
    settings: &RenderSettings,
) -> (Film, RenderStats) {
    let bar = ProgressBar::new(u64::from(settings.width) * u64::from(settings.height));
    bar.set_style(
        ProgressStyle::with_template(
            "{spinner} [{elapsed_precise}] {wide_bar} {percent}% (eta {eta})",
        )
        .expect("static template is valid"),
    );
    let result = render::render(scene, accel, camera, settings, &|pixels| bar.inc(pixels));
    bar.finish_and_clear();
    result
}

fn bench_command(args: BenchArgs) -> Result<()> {
    if args.meshes.is_empty() && args.procedural.is_empty() {
        bail!("nothing to benchmark: give an OBJ mesh or --procedural KIND:COUNT");
    }
    // Fail on an impossible output before spending minutes measuring.
    if let Some(parent) = args.json_out.as_deref().and_then(Path::parent) {
        if !parent.as_os_str().is_empty() && !parent.is_dir() {
            bail!(
                "cannot write the JSON output: {} is not a directory",
                parent.display()
            );
        }
    }
    let all = std::thread::available_parallelism().map_or(1, |n| n.get());
    let mut threads: Vec<usize> = if args.threads.is_empty() {
        vec![1, all]
    } else {
        args.threads.iter().map(|&t| t as usize).collect()
    };
    threads.sort_unstable();
    threads.dedup();
    let mut options = BenchOptions {
        rays: args.rays as usize,
        threads,
        min_seconds: args.min_time,
        seed: args.seed,
        camera: None,
    };
    // Loaded one at a time when its turn comes: the large procedural meshes take
    // gigabytes.
    enum Source<'a> {
        Obj(&'a Path),
        Procedural(Procedural),
    }
    let sources = (args.meshes.iter().map(|p| Source::Obj(p)))
        .chain(args.procedural.iter().map(|&p| Source::Procedural(p)));

    let mut results = Vec::new();
    for source in sources {
        let mesh = match source {
            Source::Obj(path) => BenchMesh::from_obj(path)?,
            Source::Procedural(p) => BenchMesh::procedural(p, args.seed),
        };
        options.camera = match (args.eye, args.look_at) {
            (None, None) => None,
            (eye, look_at) => {
                let (lo, hi) = mesh.bounds();
                let framing = CameraSettings::framing(lo, hi, 40.0);
                Some(CameraSettings {
                    eye: eye.unwrap_or(framing.eye),
                    look_at: look_at.unwrap_or(framing.look_at),
                    ..framing
                })
            }
        };
        eprintln!(
            "benchmarking {}: {} triangles",
            mesh.name,
            mesh.triangles.len()
        );
        let measured = bench::run(&mesh, &options)
            .with_context(|| format!("benchmark of {} failed", mesh.name))?;
        results.extend(measured);
    }

    let table = bench::table(&results);
    let version = Device::new("")?.info().version;
    let json = serde_json::to_string_pretty(&bench::to_json(&results, &options, &version))?;
    if let Some(path) = &args.json_out {
        film::write_atomically(path, json.as_bytes())?;
    }
    if args.json {
        eprint!("{table}");
        println!("{json}");
    } else {
        print!("{table}");
    }
    Ok(())
}

fn info_command() -> Result<()> {
    let device = Device::new("")?;
    let info = device.info();
    let isa = match info.native_packet_width {
        16 => "AVX-512 (native 16-wide packets)",
        8 => "AVX/AVX2 (native 8-wide packets)",
        _ => "SSE (native 4-wide packets)",
    };
    println!("ember {}", env!("CARGO_PKG_VERSION"));
    println!(
        "embree: library {} (bindings generated from the {} headers in {})",
        info.version,
        info.header_version,
        env!("EMBER_EMBREE_INCLUDE")
    );
    println!("embree ISA: {isa}");
    println!(
        "embree threads: {} tasking, {} hardware threads",
        info.tasking_system,
        std::thread::available_parallelism().map_or(1, |n| n.get())
    );
    println!(
        "build: {} profile, target {}",
        if cfg!(debug_assertions) {
            "debug"
        } else {
            "release"
        },
        std::env::consts::ARCH
    );
    if info.version.is_empty() {
        bail!("Embree reported no version");
    }
    Ok(())
}
