//! `ember bench`: Embree against the native BVH (and, with the `peers` feature, the
//! published Rust BVH crates) on the same meshes and the same rays. Measures build time,
//! memory and rays per second for coherent primary rays, incoherent diffuse bounces and
//! shadow rays, on one thread and on several, through the single-ray and the 8-ray
//! packet API. For OBJ meshes it also times reading the scene (the first part of
//! `ember render`'s time to first sample).
//!
//! The benchmark is part of the binary, not of the renderer library: the library
//! gives it the backends, and these modules do the rest. They name the library as
//! `ember::` and each other as `super::`, so the Criterion benchmark and the tests can
//! include the meshes and ray sets by path.
//!
//! - [`procedural`]: procedural meshes of any size (sphere, soup);
//! - [`mesh`]: the mesh measured on (from an OBJ or procedural);
//! - [`rays`]: the primary, diffuse and shadow ray sets;
//! - [`timing`]: best-of-N timing and throughput on a thread pool;
//! - [`measure`]: the builds and traversals of one mesh;
//! - [`report`]: the measurements, as a table and as JSON;
//! - [`plot`]: the measurements as a chart (`--plot FILE.svg`);
//! - `peers` (feature `peers`): the published BVH crates behind `ember::accel::Accel`.

mod measure;
mod mesh;
#[cfg(feature = "peers")]
mod peers;
mod plot;
mod procedural;
mod rays;
mod report;
mod timing;

use std::path::{Path, PathBuf};
use std::time::Instant;

use anyhow::{bail, Context, Result};
use clap::Args;
use glam::Vec3;

use super::machine::Machine;
use super::{parse_vec3, verbosity};
use ember::embree::Device;
use ember::io;
use ember::scene::CameraSettings;
use measure::BenchOptions;
use mesh::BenchMesh;
use procedural::Procedural;
use report::Loading;

#[derive(Args)]
pub struct BenchArgs {
    /// Meshes (.obj, .ply) to benchmark on (materials with Ke > 0 become the shadow rays' targets).
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
    #[arg(long, default_value_t = 0.5, value_parser = parse_min_time)]
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
    #[arg(long, value_name = "FILE")]
    json_out: Option<PathBuf>,
    /// Draw Mrays/s per backend and ray kind to FILE.svg, a bar chart per mesh.
    #[arg(long, value_name = "FILE.svg")]
    plot: Option<PathBuf>,
}

/// Refuses to benchmark a mesh of `triangles` with `rays` per set that does not fit in
/// memory, before it is made.
fn check_memory(mesh: &str, triangles: u64, rays: u64) -> Result<()> {
    let needed = procedural::bench_memory_bytes(triangles, rays);
    let what = format!("benchmarking {mesh} ({triangles} triangles, {rays} rays per set)");
    ember::limits::check_fits(&what, needed).map_err(anyhow::Error::msg)
}

/// Seconds each measurement repeats for: 0 (one run) to an hour.
fn parse_min_time(s: &str) -> Result<f64, String> {
    match s.trim().parse::<f64>() {
        Ok(v) if (0.0..=3600.0).contains(&v) => Ok(v),
        _ => Err(format!(
            "{s:?} is not a number of seconds between 0 and 3600"
        )),
    }
}

pub fn run(args: BenchArgs) -> Result<()> {
    if args.meshes.is_empty() && args.procedural.is_empty() {
        bail!("nothing to benchmark: give a mesh (.obj, .ply) or --procedural KIND:COUNT");
    }
    // Fail on an impossible output before spending minutes measuring.
    if let Some(path) = &args.json_out {
        io::check_writable(path)?;
        let meshes: Vec<(&str, &Path)> = args
            .meshes
            .iter()
            .map(|p| ("the mesh", p.as_path()))
            .collect();
        super::check_distinct_files(&[("--json-out", path)], &meshes)?;
    }
    if let Some(path) = &args.plot {
        if !path
            .extension()
            .is_some_and(|e| e.eq_ignore_ascii_case("svg"))
        {
            bail!(
                "--plot {}: the chart is SVG, give a .svg file",
                path.display()
            );
        }
        io::check_writable(path)?;
    }
    let machine = Machine::of(&Device::new("")?.info());
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
    let mut loadings = Vec::new();
    for source in sources {
        let mesh = match source {
            Source::Obj(path) => {
                let start = Instant::now();
                let mesh = BenchMesh::from_obj(path)?;
                check_memory(&mesh.name, mesh.triangles().len() as u64, args.rays)?;
                loadings.push(Loading {
                    mesh: mesh.name.clone(),
                    file_bytes: mesh.obj_bytes,
                    seconds: start.elapsed().as_secs_f64(),
                });
                mesh
            }
            Source::Procedural(p) => {
                check_memory(&p.to_string(), p.most_triangles(), args.rays)?;
                BenchMesh::procedural(p, args.seed)
            }
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
        let loading = loadings.iter().find(|l| l.mesh == mesh.name);
        if verbosity::status() {
            eprintln!(
                "benchmarking {}: {} triangles{}",
                mesh.name,
                mesh.triangles().len(),
                loading.map_or(String::new(), |l| format!("; {}", l.summary()))
            );
        }
        let measured = measure::run(&mesh, &options)
            .with_context(|| format!("benchmark of {} failed", mesh.name))?;
        results.extend(measured);
    }

    let table = format!(
        "ember bench on {}\n{}\n{}",
        machine.summary(),
        report::table(&results, &loadings),
        report::LEGEND
    );
    let document = report::to_json(
        &results,
        &loadings,
        options.rays,
        &options.threads,
        &machine,
    );
    let json = serde_json::to_string_pretty(&document)?;
    if let Some(path) = &args.json_out {
        io::write_atomically(path, json.as_bytes())?;
    }
    if let Some(path) = &args.plot {
        let svg = plot::svg(&results, &machine.summary())
            .map_err(|e| anyhow::anyhow!("cannot draw the chart {}: {e}", path.display()))?;
        io::write_atomically(path, svg.as_bytes())?;
    }
    if args.json {
        if verbosity::status() {
            eprint!("{table}");
        }
        println!("{json}");
    } else {
        print!("{table}");
    }
    Ok(())
}
