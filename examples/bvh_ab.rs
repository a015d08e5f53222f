//! Interleaved A/B timing of the native BVH against Embree on `ember bench`'s ray sets,
//! single-threaded: both trace the same chunk of rays in turn, many times, and the
//! ratio of their best times per chunk is reported. On a loaded machine this is far
//! steadier than timing each backend for a while after the other.
//!
//! `cargo run --release --example bvh_ab -- MESH.obj [ROUNDS]`

#[allow(dead_code)]
#[path = "../src/cli/bench/mesh.rs"]
mod mesh;
#[allow(dead_code)]
#[path = "../src/cli/bench/procedural.rs"]
mod procedural;
#[allow(dead_code)]
#[path = "../src/cli/bench/rays.rs"]
mod rays;

use std::hint::black_box;
use std::time::Instant;

use ember::accel::{Accel, Bvh, EmbreeAccel, Ray};
use ember::embree::{BuildQuality, Device};

fn time(f: impl Fn() -> usize) -> f64 {
    let start = Instant::now();
    black_box(f());
    start.elapsed().as_secs_f64()
}

fn main() -> anyhow::Result<()> {
    let args: Vec<String> = std::env::args().collect();
    let path = std::path::Path::new(&args[1]);
    let rounds: usize = args.get(2).map_or(Ok(15), |s| s.parse())?;
    let mesh = mesh::BenchMesh::from_obj(path)?;
    let (v, t) = (mesh.positions(), mesh.triangles());
    let device = Device::new("threads=1")?;
    let embree = EmbreeAccel::build(&device, v, t, BuildQuality::High)?;
    let pool = rayon::ThreadPoolBuilder::new().num_threads(1).build()?;
    let bvh = pool.install(|| Bvh::build(v, t))?;
    let rays = rays::RaySets::generate(&mesh, &embree, 1 << 16, 1, None)?;
    let sets: [(&str, &[Ray], bool); 3] = [
        ("primary", &rays.primary, false),
        ("diffuse", &rays.diffuse, false),
        ("shadow", &rays.shadow, true),
    ];
    let count = |a: &dyn Accel, rays: &[Ray], shadow: bool| {
        if shadow {
            rays.iter().filter(|r| a.occluded(r)).count()
        } else {
            rays.iter().filter(|r| a.intersect(r).is_some()).count()
        }
    };
    for (name, set, shadow) in sets {
        // Per chunk of rays, the best of `rounds` for each backend: a chunk takes about
        // a millisecond, short enough that most rounds run without being preempted.
        let (mut be, mut bb) = (0.0, 0.0);
        for chunk in set.chunks(2048) {
            let (mut ce, mut cb) = (f64::INFINITY, f64::INFINITY);
            for _ in 0..rounds {
                ce = ce.min(time(|| count(&embree, chunk, shadow)));
                cb = cb.min(time(|| count(&bvh, chunk, shadow)));
            }
            be += ce;
            bb += cb;
        }
        let n = set.len() as f64 / 1e6;
        println!(
            "{} {name}: embree {:.2} bvh {:.2} Mrays/s, ratio {:.3}",
            mesh.name,
            n / be,
            n / bb,
            be / bb
        );
    }
    Ok(())
}
