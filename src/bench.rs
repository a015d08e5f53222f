//! `ember bench`: Embree against the native BVH (and, with the `peers` feature, published
//! BVH crates) on the same meshes and the same rays. Measures build time, memory and
//! rays per second for coherent primary rays, incoherent diffuse bounces and shadow
//! rays, on one thread and on several, through the single-ray and the 8-ray packet API.

use std::hint::black_box;
use std::path::Path;
use std::time::Instant;

use glam::Vec3;
use rayon::prelude::*;
use serde_json::{json, Value};

use crate::accel::{Accel, Bvh, BvhError, EmbreeAccel, Ray};
use crate::embree::{raw_rays, BuildQuality, Device, EmbreeError, RawRay, PACKET_WIDTH};
use crate::sampling::{cosine_hemisphere, uniform_triangle, Onb, Rng};
use crate::scene::{load_obj, CameraSettings, Procedural, SceneError};

/// Why a benchmark could not run.
#[derive(Debug, thiserror::Error)]
pub enum BenchError {
    #[error(transparent)]
    Embree(#[from] EmbreeError),
    #[error("native BVH: {0}")]
    Bvh(#[from] BvhError),
    #[error("cannot start {0} worker threads: {1}")]
    Threads(usize, String),
    #[error("the mesh {0} has no triangles")]
    Empty(String),
    #[error("invalid camera: {0}")]
    Camera(String),
    #[error("{0}")]
    Peer(String),
}

/// A mesh to benchmark on: positions, triangles, and the triangles that emit (shadow
/// rays aim at them when there are any, else at random points in the bounding box).
pub struct BenchMesh {
    pub name: String,
    pub positions: Vec<Vec3>,
    pub triangles: Vec<[u32; 3]>,
    pub lights: Vec<u32>,
}

impl BenchMesh {
    /// The triangles of an OBJ scene; its emissive triangles are the lights.
    pub fn from_obj(path: &Path) -> Result<BenchMesh, SceneError> {
        let (scene, _) = load_obj(path)?;
        let name = path.file_name().map_or_else(
            || path.display().to_string(),
            |n| n.to_string_lossy().into(),
        );
        Ok(BenchMesh {
            name,
            positions: scene.mesh.positions,
            triangles: scene.mesh.triangles,
            lights: scene.emitters,
        })
    }

    /// A procedural mesh, named by its specification (`sphere:1000000`).
    pub fn procedural(p: Procedural, seed: u64) -> BenchMesh {
        let (positions, triangles) = p.generate(seed);
        BenchMesh {
            name: p.to_string(),
            positions,
            triangles,
            lights: Vec::new(),
        }
    }

    /// Lower and upper corners of the box around the vertices the triangles use.
    pub fn bounds(&self) -> (Vec3, Vec3) {
        crate::scene::triangle_bounds(&self.positions, &self.triangles)
    }
}

/// What to measure.
#[derive(Clone, Debug)]
pub struct BenchOptions {
    /// Rays in each set (primary, diffuse, shadow).
    pub rays: usize,
    /// Thread counts to measure with (builds and traversal).
    pub threads: Vec<usize>,
    /// Each measurement repeats until it has run at least this long.
    pub min_seconds: f64,
    pub seed: u64,
    /// Camera for the primary rays; `None` frames the mesh from +z.
    pub camera: Option<CameraSettings>,
}

impl Default for BenchOptions {
    fn default() -> Self {
        BenchOptions {
            rays: 1 << 20,
            threads: vec![1],
            min_seconds: 0.5,
            seed: 1,
            camera: None,
        }
    }
}

/// What a measurement measured.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Mode {
    Build,
    Primary,
    Diffuse,
    Shadow,
    /// Embree queries that end at once (empty interval): the fixed cost of one call
    /// through ember's wrapper and the FFI, an upper bound of the wrapper's overhead.
    CallOverhead,
}

impl Mode {
    pub fn as_str(self) -> &'static str {
        match self {
            Mode::Build => "build",
            Mode::Primary => "primary",
            Mode::Diffuse => "diffuse",
            Mode::Shadow => "shadow",
            Mode::CallOverhead => "call_overhead",
        }
    }
}

/// How rays were handed to the structure.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Api {
    Single,
    /// Embree's `rtcIntersect8` / `rtcOccluded8`.
    Packet8,
    /// Embree called directly (rays in its own layout, bare `rtcIntersect1` calls), the
    /// baseline of the wrapper's cost.
    Direct,
}

impl Api {
    pub fn as_str(self) -> &'static str {
        match self {
            Api::Single => "single",
            Api::Packet8 => "packet8",
            Api::Direct => "direct",
        }
    }
}

/// One line of the table, one object of the JSON `results`.
#[derive(Clone, Debug, PartialEq)]
pub struct Measurement {
    pub mesh: String,
    pub triangles: usize,
    pub backend: &'static str,
    pub mode: Mode,
    pub api: Api,
    pub threads: usize,
    /// Embree's build quality (`low`, `medium`, `high`) for Embree builds.
    pub quality: Option<&'static str>,
    pub build_ms: Option<f64>,
    pub mrays_per_s: Option<f64>,
    /// Rays per pass and how many of them hit (or were occluded).
    pub rays: usize,
    pub hits: usize,
    /// Bytes of the structure measured (for traversal: the one traced).
    pub memory_bytes: usize,
    /// See [`Traced::cpu_per_wall`].
    pub cpu_per_wall: Option<f64>,
}

impl Measurement {
    pub fn to_json(&self) -> Value {
        let mut v = json!({
            "mesh": self.mesh,
            "triangles": self.triangles,
            "backend": self.backend,
            "mode": self.mode.as_str(),
            "api": self.api.as_str(),
            "threads": self.threads,
            "memory_bytes": self.memory_bytes,
        });
        let obj = v.as_object_mut().expect("json! object");
        if let Some(q) = self.quality {
            obj.insert("quality".into(), q.into());
        }
        if let Some(ms) = self.build_ms {
            obj.insert("build_ms".into(), ms.into());
        }
        if let Some(m) = self.mrays_per_s {
            obj.insert("mrays_per_s".into(), m.into());
            obj.insert("rays".into(), self.rays.into());
            obj.insert("hits".into(), self.hits.into());
            if let Some(c) = self.cpu_per_wall {
                obj.insert("cpu_per_wall".into(), c.into());
            }
        }
        v
    }
}

/// The three ray sets every backend traces.
pub struct RaySets {
    pub primary: Vec<Ray>,
    pub diffuse: Vec<Ray>,
    pub shadow: Vec<Ray>,
}

/// Offset of a ray origin off a surface at `p`, as the integrator's `spawn_point`.
fn spawn_offset(p: Vec3) -> f32 {
    3e-5 * (1.0 + p.abs().max_element())
}

impl RaySets {
    /// `n` rays of each kind. Primary rays come from a camera (in 16×16 tiles, row by
    /// row inside each, so consecutive rays are neighbours); diffuse and shadow rays
    /// start at the primary hits that `reference` finds, on the side the camera sees.
    pub fn generate<A: Accel>(
        mesh: &BenchMesh,
        reference: &A,
        n: usize,
        seed: u64,
        camera: Option<CameraSettings>,
    ) -> Result<RaySets, BenchError> {
        let (lo, hi) = mesh.bounds();
        let settings = camera.unwrap_or_else(|| CameraSettings::framing(lo, hi, 40.0));
        settings.validate().map_err(BenchError::Camera)?;
        let side = ((n as f64).sqrt().ceil() as u32).max(1);
        let cam = settings.camera(side, side);
        let mut primary = Vec::with_capacity(n);
        'tiles: for ty in (0..side).step_by(16) {
            for tx in (0..side).step_by(16) {
                for y in ty..(ty + 16).min(side) {
                    for x in tx..(tx + 16).min(side) {
                        if primary.len() == n {
                            break 'tiles;
                        }
                        primary.push(cam.ray(x as f32 + 0.5, y as f32 + 0.5));
                    }
                }
            }
        }

        // Surface points seen by the camera: (point, normal facing the camera).
        let surfaces: Vec<(Vec3, Vec3)> = primary
            .par_iter()
            .filter_map(|ray| {
                let hit = reference.intersect(ray)?;
                let [a, b, c] =
                    mesh.triangles[hit.prim as usize].map(|i| mesh.positions[i as usize]);
                let ng = (b - a).cross(c - a).normalize_or_zero();
                let ng = if ng.dot(ray.dir) > 0.0 { -ng } else { ng };
                let p = (1.0 - hit.u - hit.v) * a + hit.u * b + hit.v * c;
                (ng != Vec3::ZERO).then_some((p + ng * spawn_offset(p), ng))
            })
            .collect();

        let mut rng = Rng::seeded(seed);
        let origin = |i: usize, rng: &mut Rng| -> (Vec3, Vec3) {
            if surfaces.is_empty() {
                // Nothing seen: start anywhere in the box, facing anywhere.
                let p = lo + (hi - lo) * Vec3::new(rng.f32(), rng.f32(), rng.f32());
                (p, Vec3::Y)
            } else {
                surfaces[i % surfaces.len()]
            }
        };
        let mut diffuse = Vec::with_capacity(n);
        for i in 0..n {
            let (p, normal) = origin(i, &mut rng);
            let local = cosine_hemisphere(rng.f32(), rng.f32());
            diffuse.push(Ray::new(p, Onb::from_w(normal).to_world(local)));
        }
        let mut shadow = Vec::with_capacity(n);
        for i in 0..n {
            let (p, _) = origin(i, &mut rng);
            let target = if mesh.lights.is_empty() {
                lo + (hi - lo) * Vec3::new(rng.f32(), rng.f32(), rng.f32())
            } else {
                let t = mesh.lights[rng.below(mesh.lights.len() as u32) as usize];
                let [a, b, c] = mesh.triangles[t as usize].map(|i| mesh.positions[i as usize]);
                let (u, v) = uniform_triangle(rng.f32(), rng.f32());
                (1.0 - u - v) * a + u * b + v * c
            };
            // Stop just short of the target, which may lie on a light's own triangle.
            shadow.push(Ray::segment(p, target - p, 1.0 - 1e-4));
        }
        Ok(RaySets {
            primary,
            diffuse,
            shadow,
        })
    }
}

fn pool(threads: usize) -> Result<rayon::ThreadPool, BenchError> {
    rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .map_err(|e| BenchError::Threads(threads, e.to_string()))
}

/// Runs `f` once to warm up, then again until `min_seconds` have passed; returns the
/// best time of one run, in seconds, and the last result.
pub fn best_time<T>(min_seconds: f64, mut f: impl FnMut() -> T) -> (f64, T) {
    let mut out = f();
    let (mut best, mut total, mut runs) = (f64::INFINITY, 0.0, 0);
    while runs < 2 || total < min_seconds {
        let start = Instant::now();
        out = black_box(f());
        let s = start.elapsed().as_secs_f64();
        best = best.min(s);
        total += s;
        runs += 1;
        if runs >= 1000 {
            break;
        }
    }
    (best, out)
}

/// Rays per work item handed to a rayon worker.
const CHUNK: usize = 512;

/// The outcome of tracing one ray set.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Traced {
    /// Millions of rays per second, from the best pass.
    pub mrays_per_s: f64,
    pub rays: usize,
    pub hits: usize,
    /// Processor seconds the whole process used per wall-clock second while measuring
    /// (Linux only): near the thread count when the threads really ran in parallel,
    /// lower when other programs took the cores, which caps any speed-up.
    pub cpu_per_wall: Option<f64>,
}

/// Processor time this process has used so far, from `/proc/self/stat` (user + system
/// clock ticks, which Linux counts at 100 per second).
fn process_cpu_seconds() -> Option<f64> {
    let stat = std::fs::read_to_string("/proc/self/stat").ok()?;
    // Fields after the parenthesised command name; utime and stime are the 12th and
    // 13th of them (the 14th and 15th of the line).
    let mut fields = stat.rsplit_once(')')?.1.split_whitespace().skip(11);
    let utime: f64 = fields.next()?.parse().ok()?;
    let stime: f64 = fields.next()?.parse().ok()?;
    Some((utime + stime) / 100.0)
}

/// Traces `rays` on `pool`; `trace(chunk)` returns how many hit.
fn throughput<R: Sync>(
    pool: &rayon::ThreadPool,
    rays: &[R],
    min_seconds: f64,
    trace: impl Fn(&[R]) -> usize + Sync,
) -> Traced {
    pool.install(|| {
        let (cpu, wall) = (process_cpu_seconds(), Instant::now());
        let (seconds, hits) = best_time(min_seconds, || {
            rays.par_chunks(CHUNK).map(&trace).sum::<usize>()
        });
        let wall = wall.elapsed().as_secs_f64();
        let cpu_per_wall = cpu
            .zip(process_cpu_seconds())
            .filter(|_| wall > 0.05)
            .map(|(a, b)| (b - a) / wall);
        Traced {
            mrays_per_s: rays.len() as f64 / seconds / 1e6,
            rays: rays.len(),
            hits,
            cpu_per_wall,
        }
    })
}

fn count_hits<A: Accel>(accel: &A, rays: &[Ray]) -> usize {
    rays.iter().filter(|r| accel.intersect(r).is_some()).count()
}

fn count_occluded<A: Accel>(accel: &A, rays: &[Ray]) -> usize {
    rays.iter().filter(|r| accel.occluded(r)).count()
}

fn count_hits8(accel: &EmbreeAccel, rays: &[Ray], coherent: bool) -> usize {
    let mut hits = [None; PACKET_WIDTH];
    rays.chunks(PACKET_WIDTH)
        .map(|packet| {
            accel
                .scene()
                .intersect8(packet, &mut hits[..packet.len()], coherent);
            hits[..packet.len()].iter().filter(|h| h.is_some()).count()
        })
        .sum()
}

fn count_occluded8(accel: &EmbreeAccel, rays: &[Ray]) -> usize {
    let mut occluded = [false; PACKET_WIDTH];
    rays.chunks(PACKET_WIDTH)
        .map(|packet| {
            accel
                .scene()
                .occluded8(packet, &mut occluded[..packet.len()]);
            occluded[..packet.len()].iter().filter(|&&o| o).count()
        })
        .sum()
}

/// The three ray sets in Embree's own layout, for the direct-call baseline.
struct DirectRays {
    primary: Vec<RawRay>,
    diffuse: Vec<RawRay>,
    shadow: Vec<RawRay>,
}

/// Collects the measurements of one mesh.
struct Recorder<'a> {
    mesh: &'a BenchMesh,
    out: Vec<Measurement>,
}

impl Recorder<'_> {
    #[allow(clippy::too_many_arguments)]
    fn push(
        &mut self,
        backend: &'static str,
        mode: Mode,
        api: Api,
        threads: usize,
        quality: Option<&'static str>,
        build_ms: Option<f64>,
        traced: Option<Traced>,
        memory_bytes: usize,
    ) {
        self.out.push(Measurement {
            mesh: self.mesh.name.clone(),
            triangles: self.mesh.triangles.len(),
            backend,
            mode,
            api,
            threads,
            quality,
            build_ms,
            mrays_per_s: traced.map(|t| t.mrays_per_s),
            rays: traced.map_or(0, |t| t.rays),
            hits: traced.map_or(0, |t| t.hits),
            cpu_per_wall: traced.and_then(|t| t.cpu_per_wall),
            memory_bytes,
        });
    }

    /// A build that took `seconds`.
    fn build(
        &mut self,
        backend: &'static str,
        threads: usize,
        quality: Option<&'static str>,
        seconds: f64,
        memory_bytes: usize,
    ) {
        let ms = Some(seconds * 1e3);
        let (mode, api) = (Mode::Build, Api::Single);
        self.push(backend, mode, api, threads, quality, ms, None, memory_bytes);
    }

    /// Primary, diffuse and shadow throughput of one backend on every thread count.
    fn trace_single<A: Accel>(
        &mut self,
        accel: &A,
        rays: &RaySets,
        pools: &[(usize, rayon::ThreadPool)],
        min_seconds: f64,
    ) {
        let memory = accel.memory_bytes();
        for (threads, pool) in pools {
            for (mode, set) in [
                (Mode::Primary, &rays.primary),
                (Mode::Diffuse, &rays.diffuse),
            ] {
                let traced = Some(throughput(pool, set, min_seconds, |c| count_hits(accel, c)));
                self.push(
                    accel.name(),
                    mode,
                    Api::Single,
                    *threads,
                    None,
                    None,
                    traced,
                    memory,
                );
            }
            let traced = Some(throughput(pool, &rays.shadow, min_seconds, |c| {
                count_occluded(accel, c)
            }));
            self.push(
                accel.name(),
                Mode::Shadow,
                Api::Single,
                *threads,
                None,
                None,
                traced,
                memory,
            );
        }
    }
}

/// Builds every backend on `mesh` and measures it. Embree traces the tree it builds at
/// high quality (what `ember render` uses); builds are timed at every quality.
pub fn run(mesh: &BenchMesh, options: &BenchOptions) -> Result<Vec<Measurement>, BenchError> {
    if mesh.triangles.is_empty() {
        return Err(BenchError::Empty(mesh.name.clone()));
    }
    let min = options.min_seconds;
    let pools: Vec<(usize, rayon::ThreadPool)> = options
        .threads
        .iter()
        .map(|&t| Ok((t, pool(t)?)))
        .collect::<Result<_, BenchError>>()?;
    let mut rec = Recorder {
        mesh,
        out: Vec::new(),
    };
    let (vertices, triangles) = (&mesh.positions, &mesh.triangles);

    // Builds, on each thread count.
    for (threads, pool) in &pools {
        let device = Device::new(&format!("threads={threads}"))?;
        for (quality, name) in [
            (BuildQuality::Low, "low"),
            (BuildQuality::Medium, "medium"),
            (BuildQuality::High, "high"),
        ] {
            let (s, built) = best_time(min, || {
                EmbreeAccel::build(&device, vertices, triangles, quality)
            });
            rec.build("embree", *threads, Some(name), s, built?.memory_bytes());
        }
        let (s, built) = pool.install(|| best_time(min, || Bvh::build(vertices, triangles)));
        rec.build("bvh", *threads, None, s, built?.memory_bytes());
        #[cfg(feature = "peers")]
        {
            use crate::accel::peers::{BvhCrateAccel, ObvhsAccel};
            let (s, built) =
                pool.install(|| best_time(min, || ObvhsAccel::build(vertices, triangles)));
            let memory = built.map_err(BenchError::Peer)?.memory_bytes();
            rec.build("obvhs", *threads, None, s, memory);
            let (s, built) =
                pool.install(|| best_time(min, || BvhCrateAccel::build(vertices, triangles)));
            let memory = built.map_err(BenchError::Peer)?.memory_bytes();
            rec.build("bvh-crate", *threads, None, s, memory);
        }
    }

    // Traversal.
    let device = Device::new("")?;
    let embree = EmbreeAccel::build(&device, vertices, triangles, BuildQuality::High)?;
    let bvh = pools
        .last()
        .expect("at least one thread count")
        .1
        .install(|| Bvh::build(vertices, triangles))?;
    let rays = RaySets::generate(mesh, &embree, options.rays, options.seed, options.camera)?;

    let memory = embree.memory_bytes();
    let direct = DirectRays {
        primary: raw_rays(&rays.primary),
        diffuse: raw_rays(&rays.diffuse),
        shadow: raw_rays(&rays.shadow),
    };
    for (k, (threads, pool)) in pools.iter().enumerate() {
        let t = *threads;
        let push = |rec: &mut Recorder, mode, api, traced| {
            rec.push("embree", mode, api, t, None, None, Some(traced), memory);
        };
        // Through the wrapper, then the same rays through bare Embree calls right
        // after (the wrapper's cost is the gap), then through the packet API.
        rec.trace_single(&embree, &rays, &pools[k..=k], min);
        let scene = embree.scene();
        for (mode, set) in [
            (Mode::Primary, &direct.primary),
            (Mode::Diffuse, &direct.diffuse),
        ] {
            let traced = throughput(pool, set, min, |c| scene.count_hits_direct(c));
            push(&mut rec, mode, Api::Direct, traced);
        }
        let traced = throughput(pool, &direct.shadow, min, |c| {
            scene.count_occluded_direct(c)
        });
        push(&mut rec, Mode::Shadow, Api::Direct, traced);
        for (mode, set, coherent) in [
            (Mode::Primary, &rays.primary, true),
            (Mode::Diffuse, &rays.diffuse, false),
        ] {
            let traced = throughput(pool, set, min, |c| count_hits8(&embree, c, coherent));
            push(&mut rec, mode, Api::Packet8, traced);
        }
        let traced = throughput(pool, &rays.shadow, min, |c| count_occluded8(&embree, c));
        push(&mut rec, Mode::Shadow, Api::Packet8, traced);
        // Empty intervals: Embree returns before traversing, so what remains is the
        // cost of the call itself through the wrapper.
        let empty: Vec<Ray> = rays
            .diffuse
            .iter()
            .map(|r| Ray {
                tmin: 1.0,
                tmax: 0.0,
                ..*r
            })
            .collect();
        let traced = throughput(pool, &empty, min, |c| count_hits(&embree, c));
        push(&mut rec, Mode::CallOverhead, Api::Single, traced);
    }
    drop(embree);

    rec.trace_single(&bvh, &rays, &pools, min);
    drop(bvh);

    #[cfg(feature = "peers")]
    {
        use crate::accel::peers::{BvhCrateAccel, ObvhsAccel};
        let all = &pools.last().expect("at least one thread count").1;
        let obvhs = all
            .install(|| ObvhsAccel::build(vertices, triangles))
            .map_err(BenchError::Peer)?;
        rec.trace_single(&obvhs, &rays, &pools, min);
        drop(obvhs);
        let crate_bvh = all
            .install(|| BvhCrateAccel::build(vertices, triangles))
            .map_err(BenchError::Peer)?;
        rec.trace_single(&crate_bvh, &rays, &pools, min);
    }

    Ok(rec.out)
}

/// The JSON document `ember bench --json` prints: the measurements and the setup.
pub fn to_json(results: &[Measurement], options: &BenchOptions, embree_version: &str) -> Value {
    json!({
        "ember_version": env!("CARGO_PKG_VERSION"),
        "embree_version": embree_version,
        "rays_per_set": options.rays,
        "threads": options.threads,
        "results": results.iter().map(Measurement::to_json).collect::<Vec<_>>(),
    })
}

/// The human-readable table: per mesh, builds then traversal, with the ratio to Embree
/// (medium quality for builds, single rays for traversal), the speed-up over the
/// fewest threads, and how many cores the process kept busy while tracing (`cpu`: a
/// speed-up cannot exceed it, so a low value means other programs held the cores).
pub fn table(results: &[Measurement]) -> String {
    use std::fmt::Write;
    let mut s = String::new();
    let mut meshes: Vec<&str> = results.iter().map(|m| m.mesh.as_str()).collect();
    meshes.dedup();
    for mesh in meshes {
        let rows: Vec<&Measurement> = results.iter().filter(|m| m.mesh == mesh).collect();
        let _ = writeln!(
            s,
            "\n{mesh}: {} triangles, {} rays per set",
            rows[0].triangles,
            rows.iter().map(|m| m.rays).max().unwrap_or(0)
        );
        let _ = writeln!(
            s,
            "{:<9} {:<13} {:<8} {:>3} {:>11} {:>10} {:>9} {:>9} {:>5} {:>7}",
            "backend",
            "mode",
            "api",
            "thr",
            "build ms",
            "Mrays/s",
            "vs embree",
            "vs 1 thr",
            "cpu",
            "MB"
        );
        let find = |backend: &str, mode: Mode, api: Api, threads: usize, quality| {
            rows.iter()
                .find(|m| {
                    m.backend == backend
                        && m.mode == mode
                        && m.api == api
                        && m.threads == threads
                        && m.quality == quality
                })
                .copied()
        };
        let min_threads = rows.iter().map(|m| m.threads).min().unwrap_or(1);
        for m in &rows {
            let name = match m.quality {
                Some(q) => format!("{}-{q}", m.mode.as_str()),
                None => m.mode.as_str().to_owned(),
            };
            let (build, rate, base, scale) = match (m.build_ms, m.mrays_per_s) {
                (Some(ms), _) => {
                    let base = find(
                        "embree",
                        Mode::Build,
                        Api::Single,
                        m.threads,
                        Some("medium"),
                    )
                    .and_then(|e| e.build_ms)
                    .map(|e| format!("{:.2}x", e / ms));
                    let one = find(m.backend, Mode::Build, m.api, min_threads, m.quality)
                        .and_then(|o| o.build_ms)
                        .filter(|_| m.threads != min_threads)
                        .map(|o| format!("{:.2}x", o / ms));
                    (format!("{ms:.2}"), String::new(), base, one)
                }
                (None, Some(r)) => {
                    let base = find("embree", m.mode, Api::Single, m.threads, None)
                        .and_then(|e| e.mrays_per_s)
                        .filter(|_| m.mode != Mode::CallOverhead)
                        .map(|e| format!("{:.2}x", r / e));
                    let one = find(m.backend, m.mode, m.api, min_threads, None)
                        .and_then(|o| o.mrays_per_s)
                        .filter(|_| m.threads != min_threads)
                        .map(|o| format!("{:.2}x", r / o));
                    (String::new(), format!("{r:.2}"), base, one)
                }
                (None, None) => (String::new(), String::new(), None, None),
            };
            let _ = writeln!(
                s,
                "{:<9} {:<13} {:<8} {:>3} {:>11} {:>10} {:>9} {:>9} {:>5} {:>7.1}",
                m.backend,
                name,
                m.api.as_str(),
                m.threads,
                build,
                rate,
                base.unwrap_or_default(),
                scale.unwrap_or_default(),
                m.cpu_per_wall
                    .map(|c| format!("{c:.2}"))
                    .unwrap_or_default(),
                m.memory_bytes as f64 / 1e6
            );
        }
    }
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sphere() -> (BenchMesh, EmbreeAccel) {
        let mesh = BenchMesh::procedural("sphere:5k".parse().unwrap(), 1);
        let device = Device::new("").unwrap();
        let accel =
            EmbreeAccel::build(&device, &mesh.positions, &mesh.triangles, BuildQuality::Low)
                .unwrap();
        (mesh, accel)
    }

    #[test]
    fn ray_sets_start_on_the_visible_surface() {
        let (mesh, embree) = sphere();
        let rays = RaySets::generate(&mesh, &embree, 3000, 1, None).unwrap();
        assert_eq!(rays.primary.len(), 3000);
        assert_eq!(rays.diffuse.len(), 3000);
        assert_eq!(rays.shadow.len(), 3000);
        // The camera is outside the unit sphere, so bounces start just outside its
        // (tessellated) surface and leave into the outer hemisphere.
        for r in &rays.diffuse {
            let d = r.origin.length();
            assert!(d > 0.99 && d < 1.001, "origin at radius {d}");
            assert!(r.dir.dot(r.origin) > -0.05, "{r:?} heads inwards");
            assert!((r.dir.length() - 1.0).abs() < 1e-4);
        }
        // Shadow rays end just short of a point inside the bounding box.
        for r in &rays.shadow {
            let end = r.at(1.0);
            assert!(end.abs().max_element() <= 1.0 + 1e-5);
            assert!(r.tmax < 1.0 && r.tmax > 0.99);
        }
    }

    #[test]
    fn run_measures_every_backend_mode_and_thread_count() {
        let (mesh, _) = sphere();
        let options = BenchOptions {
            rays: 512,
            threads: vec![1, 2],
            min_seconds: 0.0,
            ..BenchOptions::default()
        };
        let results = run(&mesh, &options).unwrap();
        for backend in ["embree", "bvh"] {
            for mode in [Mode::Build, Mode::Primary, Mode::Diffuse, Mode::Shadow] {
                for threads in [1, 2] {
                    assert!(results
                        .iter()
                        .any(|m| m.backend == backend && m.mode == mode && m.threads == threads));
                }
            }
        }
        // Same rays, same answers.
        let hits = |backend: &str, mode: Mode, api: Api| {
            results
                .iter()
                .find(|m| m.backend == backend && m.mode == mode && m.api == api)
                .unwrap()
                .hits
        };
        for mode in [Mode::Primary, Mode::Diffuse, Mode::Shadow] {
            let wrapped = hits("embree", mode, Api::Single);
            assert_eq!(wrapped, hits("bvh", mode, Api::Single), "{mode:?}");
            assert_eq!(wrapped, hits("embree", mode, Api::Direct), "{mode:?}");
            assert_eq!(wrapped, hits("embree", mode, Api::Packet8), "{mode:?}");
        }
        // The camera sees the sphere (diffuse rays leave a convex mesh and miss).
        assert!(hits("embree", Mode::Primary, Api::Single) > 0);
        let table = table(&results);
        assert!(table.contains("sphere:") && table.contains("diffuse"));
        let json = to_json(&results, &options, "test");
        assert_eq!(json["results"].as_array().unwrap().len(), results.len());
    }
}
