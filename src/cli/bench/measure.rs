//! The measurements of one mesh: builds of every backend at every thread count and
//! Embree quality, then primary, diffuse and shadow throughput through the single-ray
//! API (every backend), Embree's 8-ray packets, and Embree called directly.

use ember::accel::{Accel, Bvh, BvhError, EmbreeAccel, Hits16, Ray, Rays16, PACKET};
use ember::embree::{raw_rays, BuildQuality, Device, EmbreeError, RawRay, PACKET_WIDTH};
use ember::scene::CameraSettings;

use super::mesh::BenchMesh;
use super::rays::{CameraError, RaySets};
use super::report::{Api, Measurement, Mode};
use super::timing::{best_time, throughput, Traced};

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
    #[error(transparent)]
    Camera(#[from] CameraError),
    #[error("{0}")]
    #[cfg_attr(not(feature = "peers"), allow(dead_code))]
    Peer(String),
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

/// A rayon pool per thread count.
type Pools = [(usize, rayon::ThreadPool)];

fn pools(threads: &[usize]) -> Result<Vec<(usize, rayon::ThreadPool)>, BenchError> {
    threads
        .iter()
        .map(|&t| {
            let pool = rayon::ThreadPoolBuilder::new()
                .num_threads(t)
                .build()
                .map_err(|e| BenchError::Threads(t, e.to_string()))?;
            Ok((t, pool))
        })
        .collect()
}

/// Builds every backend on `mesh` and measures it. Embree traces the tree it builds at
/// high quality (what `ember render` uses); builds are timed at every quality.
pub fn run(mesh: &BenchMesh, options: &BenchOptions) -> Result<Vec<Measurement>, BenchError> {
    if mesh.triangles().is_empty() {
        return Err(BenchError::Empty(mesh.name.clone()));
    }
    let min = options.min_seconds;
    let pools = pools(&options.threads)?;
    let all = &pools.last().expect("at least one thread count").1;
    let mut rec = Recorder {
        mesh,
        out: Vec::new(),
    };
    for (threads, pool) in &pools {
        rec.builds(*threads, pool, min)?;
    }

    let (vertices, triangles) = (mesh.positions(), mesh.triangles());
    let device = Device::new("")?;
    let embree = EmbreeAccel::build(&device, vertices, triangles, BuildQuality::High)?;
    let bvh = all.install(|| Bvh::build(vertices, triangles))?;
    let rays = RaySets::generate(mesh, &embree, options.rays, options.seed, options.camera)?;
    rec.trace_embree(&embree, &rays, &pools, min);
    drop(embree);
    rec.trace_single(&bvh, &rays, &pools, min);
    drop(bvh);
    #[cfg(feature = "peers")]
    rec.trace_peers(&rays, all, &pools, min)?;
    Ok(rec.out)
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

/// Hits of `rays` queried 16 at a time as the wavefront engine queries them
/// ([`Accel::intersect16`]: Embree's `rtcIntersect16`).
fn count_hits16<A: Accel>(accel: &A, rays: &[Ray], coherent: bool) -> usize {
    let (mut packet, mut hits) = (Rays16::default(), Hits16::default());
    rays.chunks(PACKET)
        .map(|chunk| {
            let active = std::array::from_fn(|l| l < chunk.len());
            for (l, ray) in chunk.iter().enumerate() {
                packet.set(l, ray);
            }
            accel.intersect16(&active, &packet, &mut hits, coherent);
            hits.found.iter().take(chunk.len()).filter(|&&f| f).count()
        })
        .sum()
}

/// Occluded rays of `rays`, 16 at a time ([`Accel::occluded16`]).
fn count_occluded16<A: Accel>(accel: &A, rays: &[Ray]) -> usize {
    let mut packet = Rays16::default();
    rays.chunks(PACKET)
        .map(|chunk| {
            let active = std::array::from_fn(|l| l < chunk.len());
            for (l, ray) in chunk.iter().enumerate() {
                packet.set(l, ray);
            }
            let occluded = accel.occluded16(&active, &packet);
            occluded.iter().filter(|&&o| o).count()
        })
        .sum()
}

/// The three ray sets in Embree's own layout, for the direct-call baseline.
struct DirectRays {
    primary: Vec<RawRay>,
    diffuse: Vec<RawRay>,
    shadow: Vec<RawRay>,
}

/// Which row a measurement fills.
#[derive(Clone, Copy)]
struct Row {
    backend: &'static str,
    mode: Mode,
    api: Api,
    threads: usize,
}

/// Collects the measurements of one mesh.
struct Recorder<'a> {
    mesh: &'a BenchMesh,
    out: Vec<Measurement>,
}

impl Recorder<'_> {
    fn push(
        &mut self,
        row: Row,
        build: Option<(f64, &'static str)>,
        traced: Option<Traced>,
        memory_bytes: usize,
    ) {
        self.out.push(Measurement {
            mesh: self.mesh.name.clone(),
            triangles: self.mesh.triangles().len(),
            backend: row.backend,
            mode: row.mode,
            api: row.api,
            threads: row.threads,
            quality: build.map(|b| b.1).filter(|q| !q.is_empty()),
            build_ms: build.map(|b| b.0 * 1e3),
            mrays_per_s: traced.map(|t| t.mrays_per_s),
            rays: traced.map_or(0, |t| t.rays),
            hits: traced.map_or(0, |t| t.hits),
            cpu_per_wall: traced.and_then(|t| t.cpu_per_wall),
            memory_bytes,
        });
    }

    /// A build that took `seconds` (at Embree's `quality`, or "" for other backends).
    fn build(
        &mut self,
        backend: &'static str,
        threads: usize,
        quality: &'static str,
        seconds: f64,
        memory_bytes: usize,
    ) {
        let row = Row {
            backend,
            mode: Mode::Build,
            api: Api::Single,
            threads,
        };
        self.push(row, Some((seconds, quality)), None, memory_bytes);
    }

    /// A traversal measurement of `traced`.
    fn traced(&mut self, row: Row, traced: Traced, memory_bytes: usize) {
        self.push(row, None, Some(traced), memory_bytes);
    }

    /// Every backend's build time on `threads` threads (Embree at every quality).
    fn builds(
        &mut self,
        threads: usize,
        pool: &rayon::ThreadPool,
        min: f64,
    ) -> Result<(), BenchError> {
        let (vertices, triangles) = (self.mesh.positions(), self.mesh.triangles());
        let device = Device::new(&format!("threads={threads}"))?;
        for (quality, name) in [
            (BuildQuality::Low, "low"),
            (BuildQuality::Medium, "medium"),
            (BuildQuality::High, "high"),
        ] {
            let (s, built) = best_time(min, || {
                EmbreeAccel::build(&device, vertices, triangles, quality)
            });
            self.build("embree", threads, name, s, built?.memory_bytes());
        }
        let (s, built) = pool.install(|| best_time(min, || Bvh::build(vertices, triangles)));
        self.build("bvh", threads, "", s, built?.memory_bytes());
        #[cfg(feature = "peers")]
        self.peer_builds(threads, pool, min)?;
        Ok(())
    }

    /// Primary, diffuse and shadow throughput of one backend on every thread count.
    fn trace_single<A: Accel>(&mut self, accel: &A, rays: &RaySets, pools: &Pools, min: f64) {
        let memory = accel.memory_bytes();
        for (threads, pool) in pools {
            let row = |mode| Row {
                backend: accel.name(),
                mode,
                api: Api::Single,
                threads: *threads,
            };
            for (mode, set) in [
                (Mode::Primary, &rays.primary),
                (Mode::Diffuse, &rays.diffuse),
            ] {
                let traced = throughput(pool, set, min, |c| count_hits(accel, c));
                self.traced(row(mode), traced, memory);
            }
            let traced = throughput(pool, &rays.shadow, min, |c| count_occluded(accel, c));
            self.traced(row(Mode::Shadow), traced, memory);
        }
    }

    /// Embree on every thread count: through the wrapper, then the same rays through
    /// bare Embree calls right after (the wrapper's cost is the gap), then through the
    /// packet API, then the cost of a call that does no work.
    fn trace_embree(&mut self, embree: &EmbreeAccel, rays: &RaySets, pools: &Pools, min: f64) {
        let memory = embree.memory_bytes();
        let direct = DirectRays {
            primary: raw_rays(&rays.primary),
            diffuse: raw_rays(&rays.diffuse),
            shadow: raw_rays(&rays.shadow),
        };
        // Empty intervals: Embree returns before traversing, so what remains is the
        // cost of the call itself through the wrapper.
        let empty: Vec<Ray> = (rays.diffuse.iter())
            .map(|r| Ray {
                tmin: 1.0,
                tmax: 0.0,
                ..*r
            })
            .collect();
        let scene = embree.scene();
        for (k, (threads, pool)) in pools.iter().enumerate() {
            let row = |mode, api| Row {
                backend: "embree",
                mode,
                api,
                threads: *threads,
            };
            self.trace_single(embree, rays, &pools[k..=k], min);
            for (mode, set) in [
                (Mode::Primary, &direct.primary),
                (Mode::Diffuse, &direct.diffuse),
            ] {
                let traced = throughput(pool, set, min, |c| scene.count_hits_direct(c));
                self.traced(row(mode, Api::Direct), traced, memory);
            }
            let traced = throughput(pool, &direct.shadow, min, |c| {
                scene.count_occluded_direct(c)
            });
            self.traced(row(Mode::Shadow, Api::Direct), traced, memory);
            for (mode, set, coherent) in [
                (Mode::Primary, &rays.primary, true),
                (Mode::Diffuse, &rays.diffuse, false),
            ] {
                let traced = throughput(pool, set, min, |c| count_hits8(embree, c, coherent));
                self.traced(row(mode, Api::Packet8), traced, memory);
            }
            let traced = throughput(pool, &rays.shadow, min, |c| count_occluded8(embree, c));
            self.traced(row(Mode::Shadow, Api::Packet8), traced, memory);
            for (mode, set, coherent) in [
                (Mode::Primary, &rays.primary, true),
                (Mode::Diffuse, &rays.diffuse, false),
            ] {
                let traced = throughput(pool, set, min, |c| count_hits16(embree, c, coherent));
                self.traced(row(mode, Api::Packet16), traced, memory);
            }
            let traced = throughput(pool, &rays.shadow, min, |c| count_occluded16(embree, c));
            self.traced(row(Mode::Shadow, Api::Packet16), traced, memory);
            let traced = throughput(pool, &empty, min, |c| count_hits(embree, c));
            self.traced(row(Mode::CallOverhead, Api::Single), traced, memory);
        }
    }
}

#[cfg(feature = "peers")]
impl Recorder<'_> {
    /// The published crates' build times on `threads` threads.
    fn peer_builds(
        &mut self,
        threads: usize,
        pool: &rayon::ThreadPool,
        min: f64,
    ) -> Result<(), BenchError> {
        use super::peers::{BvhCrateAccel, ObvhsAccel};
        let (vertices, triangles) = (self.mesh.positions(), self.mesh.triangles());
        let (s, built) = pool.install(|| best_time(min, || ObvhsAccel::build(vertices, triangles)));
        let memory = built.map_err(BenchError::Peer)?.memory_bytes();
        self.build("obvhs", threads, "", s, memory);
        let (s, built) =
            pool.install(|| best_time(min, || BvhCrateAccel::build(vertices, triangles)));
        let memory = built.map_err(BenchError::Peer)?.memory_bytes();
        self.build("bvh-crate", threads, "", s, memory);
        Ok(())
    }

    /// The published crates' throughput, each built on the pool with the most threads.
    fn trace_peers(
        &mut self,
        rays: &RaySets,
        all: &rayon::ThreadPool,
        pools: &Pools,
        min: f64,
    ) -> Result<(), BenchError> {
        use super::peers::{BvhCrateAccel, ObvhsAccel};
        let (vertices, triangles) = (self.mesh.positions(), self.mesh.triangles());
        let obvhs = all
            .install(|| ObvhsAccel::build(vertices, triangles))
            .map_err(BenchError::Peer)?;
        self.trace_single(&obvhs, rays, pools, min);
        drop(obvhs);
        let crate_bvh = all
            .install(|| BvhCrateAccel::build(vertices, triangles))
            .map_err(BenchError::Peer)?;
        self.trace_single(&crate_bvh, rays, pools, min);
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::super::report::{table, to_json};
    use super::*;

    #[test]
    fn run_measures_every_backend_mode_and_thread_count() {
        let mesh = BenchMesh::procedural("sphere:5k".parse().unwrap(), 1);
        let options = BenchOptions {
            rays: 512,
            threads: vec![1, 2],
            min_seconds: 0.0,
            seed: 1,
            camera: None,
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
            assert_eq!(wrapped, hits("embree", mode, Api::Packet16), "{mode:?}");
        }
        // The camera sees the sphere (diffuse rays leave a convex mesh and miss).
        assert!(hits("embree", Mode::Primary, Api::Single) > 0);
        let table = table(&results, &[]);
        assert!(table.contains("sphere:") && table.contains("diffuse"));
        let machine = crate::cli::machine::Machine::of(&Device::new("").unwrap().info());
        let json = to_json(&results, &[], options.rays, &options.threads, &machine);
        assert_eq!(json["results"].as_array().unwrap().len(), results.len());
    }
}
