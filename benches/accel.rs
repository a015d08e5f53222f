//! Embree against the native BVH on a small mesh (a 20k-triangle sphere and the Cornell
//! box): build time, and single-ray throughput for primary, diffuse and shadow rays.
//! The same measurements as `ember bench`, under Criterion's statistics.

use std::hint::black_box;
use std::path::Path;

use criterion::{criterion_group, criterion_main, BenchmarkId, Criterion, Throughput};

use ember::accel::{Accel, Bvh, EmbreeAccel, Ray};
use ember::embree::{BuildQuality, Device};

// The benchmark's meshes and ray sets live in the binary (src/cli/bench/), not in the
// library; they are written to be included by path.
#[allow(dead_code, unused_imports)]
#[path = "../src/cli/bench/mesh.rs"]
mod mesh;
#[allow(dead_code, unused_imports)]
#[path = "../src/cli/bench/procedural.rs"]
mod procedural;
#[allow(dead_code, unused_imports)]
#[path = "../src/cli/bench/rays.rs"]
mod rays;

use mesh::BenchMesh;
use rays::RaySets;

const RAYS: usize = 4096;

fn meshes() -> Vec<BenchMesh> {
    let sphere = BenchMesh::procedural("sphere:20k".parse().unwrap(), 1);
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("meshes/CornellBox-Original.obj");
    let cornell = BenchMesh::from_obj(&path).expect("the Cornell box ships with ember");
    vec![sphere, cornell]
}

fn trace<A: Accel>(accel: &A, rays: &[Ray], occlusion: bool) -> usize {
    if occlusion {
        rays.iter().filter(|r| accel.occluded(r)).count()
    } else {
        rays.iter().filter(|r| accel.intersect(r).is_some()).count()
    }
}

fn accel(c: &mut Criterion) {
    let device = Device::new("threads=1").expect("Embree device");
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(1)
        .build()
        .unwrap();
    for mesh in meshes() {
        let (v, t) = (mesh.positions(), mesh.triangles());
        let mut build = c.benchmark_group(format!("build/{}", mesh.name));
        build.sample_size(20);
        build.bench_function("embree-medium", |b| {
            b.iter(|| EmbreeAccel::build(&device, v, t, BuildQuality::Medium).unwrap())
        });
        build.bench_function("bvh", |b| {
            b.iter(|| pool.install(|| Bvh::build(v, t).unwrap()))
        });
        build.finish();

        let embree = EmbreeAccel::build(&device, v, t, BuildQuality::High).unwrap();
        let bvh = Bvh::build(v, t).unwrap();
        let rays = RaySets::generate(&mesh, &embree, RAYS, 1, None).unwrap();
        let mut group = c.benchmark_group(format!("trace/{}", mesh.name));
        group.throughput(Throughput::Elements(RAYS as u64));
        for (mode, set, occlusion) in [
            ("primary", &rays.primary, false),
            ("diffuse", &rays.diffuse, false),
            ("shadow", &rays.shadow, true),
        ] {
            group.bench_with_input(BenchmarkId::new("embree", mode), set, |b, set| {
                b.iter(|| trace(&embree, black_box(set), occlusion))
            });
            group.bench_with_input(BenchmarkId::new("bvh", mode), set, |b, set| {
                b.iter(|| trace(&bvh, black_box(set), occlusion))
            });
        }
        group.finish();
    }
}

criterion_group!(benches, accel);
criterion_main!(benches);
