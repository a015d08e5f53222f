//! The safe Embree wrapper against Embree's own failure paths, plus a small scene
//! queried with single rays and packets. Kept small and single-threaded enough to run
//! under valgrind (`.ci/valgrind.sh`).

use ember::accel::{Hit, Ray};
use ember::embree::{BuildQuality, Device, EmbreeErrorKind, PACKET_WIDTH};
use glam::Vec3;

/// Two unit right triangles side by side in the z = 0 plane: primitive 0 spans x in
/// [0, 1], primitive 1 spans x in [2, 3], both y in [0, 1 - (x - x0)].
fn two_triangles() -> (Vec<Vec3>, Vec<[u32; 3]>) {
    let v = vec![
        Vec3::new(0.0, 0.0, 0.0),
        Vec3::new(1.0, 0.0, 0.0),
        Vec3::new(0.0, 1.0, 0.0),
        Vec3::new(2.0, 0.0, 0.0),
        Vec3::new(3.0, 0.0, 0.0),
        Vec3::new(2.0, 1.0, 0.0),
    ];
    (v, vec![[0, 1, 2], [3, 4, 5]])
}

fn down_at(x: f32, y: f32) -> Ray {
    Ray::new(Vec3::new(x, y, 2.0), Vec3::new(0.0, 0.0, -1.0))
}

#[test]
fn configurations_embree_rejects_are_errors_not_aborts() {
    // Embree 3.13.5 and 4.x both fail to parse a non-numeric thread count or an
    // unknown hugepages value; they ignore unknown keys, so those succeed.
    for config in ["threads=abc", "hugepages=maybe"] {
        let err = Device::new(config).err().expect(config);
        assert!(err.message.contains(config), "{err}");
    }
    let err = Device::new("threads=1\0").err().unwrap();
    assert_eq!(err.kind, EmbreeErrorKind::InvalidArgument);
    assert!(Device::new("foo=bar").is_ok());
}

#[test]
fn a_build_past_the_memory_limit_is_an_out_of_memory_error() {
    let device = Device::new("threads=1").unwrap();
    let n = 2000u32;
    let vertices: Vec<Vec3> = (0..n)
        .flat_map(|i| {
            let x = i as f32;
            [
                Vec3::new(x, 0.0, 0.0),
                Vec3::new(x + 1.0, 0.0, 0.0),
                Vec3::new(x, 1.0, 0.0),
            ]
        })
        .collect();
    let triangles: Vec<[u32; 3]> = (0..n).map(|i| [3 * i, 3 * i + 1, 3 * i + 2]).collect();
    // Too little for the vertex and index buffers (96 kB): refused before Embree.
    device.set_memory_limit(Some(10_000));
    let err = device
        .build_triangle_scene(&vertices, &triangles, BuildQuality::High)
        .err()
        .expect("10 kB is far too little for 2000 triangles");
    assert_eq!(err.kind, EmbreeErrorKind::OutOfMemory);
    assert!(err.message.contains("10000 bytes"), "{err}");
    // Enough for the buffers, not for the BVH: Embree's memory monitor refuses an
    // allocation during the build and Embree reports out-of-memory.
    device.set_memory_limit(Some(110_000));
    let err = device
        .build_triangle_scene(&vertices, &triangles, BuildQuality::High)
        .err()
        .expect("no room for the BVH");
    assert_eq!(err.kind, EmbreeErrorKind::OutOfMemory);
    assert!(
        err.message.contains("memory monitor") && err.message.contains("110000 bytes"),
        "{err}"
    );
    // Nothing leaks past the failure, and the device still works without the limit.
    assert_eq!(device.bytes_in_use(), 0);
    device.set_memory_limit(None);
    let scene = device
        .build_triangle_scene(&vertices, &triangles, BuildQuality::High)
        .unwrap();
    assert!(scene.memory_bytes() > 10_000);
    let hit = scene.intersect(&down_at(1500.25, 0.25)).unwrap();
    assert_eq!(hit.prim, 1500);
}

#[test]
fn invalid_arguments_are_errors() {
    let device = Device::new("").unwrap();
    let (v, _) = two_triangles();
    let err = device
        .build_triangle_scene(&v, &[[0, 1, 6]], BuildQuality::Low)
        .err()
        .unwrap();
    assert_eq!(err.kind, EmbreeErrorKind::InvalidArgument);
    assert!(err.message.contains("vertex index 6"), "{err}");
    let err = device
        .build_triangle_scene(&v, &[], BuildQuality::Low)
        .err()
        .unwrap();
    assert_eq!(err.kind, EmbreeErrorKind::InvalidArgument);
}

#[test]
fn single_rays_hit_with_embree_barycentrics() {
    let device = Device::new("threads=1").unwrap();
    let (v, t) = two_triangles();
    let scene = device
        .build_triangle_scene(&v, &t, BuildQuality::Medium)
        .unwrap();
    // p = (1-u-v) v0 + u v1 + v v2: at (2.25, 0.5) on triangle 1, u = 0.25, v = 0.5.
    let hit = scene.intersect(&down_at(2.25, 0.5)).unwrap();
    assert_eq!(hit.prim, 1);
    assert!((hit.t - 2.0).abs() < 1e-6);
    assert!((hit.u - 0.25).abs() < 1e-6 && (hit.v - 0.5).abs() < 1e-6);
    assert!(scene.intersect(&down_at(1.5, 0.5)).is_none());
    assert!(scene.occluded(&down_at(0.2, 0.2)));
    assert!(!scene.occluded(&down_at(0.9, 0.9)));
    // tmax short of the plane: no hit.
    let mut short = down_at(0.2, 0.2);
    short.tmax = 1.5;
    assert!(scene.intersect(&short).is_none() && !scene.occluded(&short));
}

#[test]
fn rays_embree_would_reject_are_misses_not_aborts() {
    let device = Device::new("threads=1").unwrap();
    let (v, t) = two_triangles();
    let scene = device
        .build_triangle_scene(&v, &t, BuildQuality::Low)
        .unwrap();
    let bad = [
        Ray::new(Vec3::new(0.2, 0.2, 1e30), Vec3::new(0.0, 0.0, -1.0)),
        Ray::new(Vec3::new(0.2, 0.2, 2.0), Vec3::new(0.0, 0.0, -1e30)),
        Ray::new(Vec3::new(f32::NAN, 0.2, 2.0), Vec3::new(0.0, 0.0, -1.0)),
        Ray {
            tmin: f32::NAN,
            ..down_at(0.2, 0.2)
        },
    ];
    let mut hits = [None; PACKET_WIDTH];
    let mut occluded = [true; PACKET_WIDTH];
    for ray in &bad {
        assert!(scene.intersect(ray).is_none());
        assert!(!scene.occluded(ray));
    }
    // In a packet, the bad lanes miss and the good one still hits.
    let mut rays = bad.to_vec();
    rays.push(down_at(0.2, 0.2));
    scene.intersect8(&rays, &mut hits, false);
    scene.occluded8(&rays, &mut occluded);
    assert!(hits[..4].iter().all(Option::is_none) && hits[4].is_some());
    assert!(occluded[..4].iter().all(|o| !o) && occluded[4]);
}

#[test]
fn packets_agree_with_single_rays() {
    let device = Device::new("threads=1").unwrap();
    let (v, t) = two_triangles();
    let scene = device
        .build_triangle_scene(&v, &t, BuildQuality::High)
        .unwrap();
    // Lanes across both triangles, the gap and outside; 7 rays leave one lane idle.
    let rays: Vec<Ray> = [0.1, 0.6, 0.95, 1.5, 2.1, 2.5, 3.5]
        .iter()
        .map(|&x| down_at(x, 0.3))
        .collect();
    let mut hits: [Option<Hit>; PACKET_WIDTH] = [None; PACKET_WIDTH];
    let mut occluded = [false; PACKET_WIDTH];
    for coherent in [false, true] {
        scene.intersect8(&rays, &mut hits, coherent);
        for (ray, hit) in rays.iter().zip(&hits) {
            assert_eq!(*hit, scene.intersect(ray));
        }
    }
    scene.occluded8(&rays, &mut occluded);
    for (ray, o) in rays.iter().zip(&occluded) {
        assert_eq!(*o, scene.occluded(ray));
    }
    let expected: Vec<Option<u32>> = hits[..7].iter().map(|h| h.map(|h| h.prim)).collect();
    assert_eq!(
        expected,
        [Some(0), Some(0), None, None, Some(1), Some(1), None]
    );
}

/// A scene that reads the caller's arrays in place answers as one holding copies, and
/// holds less: its memory is the BVH's alone.
#[test]
fn shared_buffers_answer_as_copies_do() {
    let device = Device::new("threads=1").unwrap();
    let (mut vertices, mut triangles) = two_triangles();
    // Room for Embree's 16-byte load past the last item of each array.
    vertices.reserve_exact(1);
    triangles.reserve_exact(1);
    vertices.spare_capacity_mut()[0].write(Vec3::ZERO);
    triangles.spare_capacity_mut()[0].write([0; 3]);
    let copied = device
        .build_triangle_scene(&vertices, &triangles, BuildQuality::High)
        .unwrap();
    let shared = device
        .build_shared_triangle_scene(
            &vertices,
            &triangles,
            BuildQuality::High,
            None::<std::sync::Arc<ember::accel::Opaque>>,
        )
        .unwrap();
    for (x, y) in [(0.2, 0.2), (2.2, 0.2), (1.5, 0.5), (0.9, 0.9)] {
        let ray = down_at(x, y);
        assert_eq!(shared.intersect(&ray), copied.intersect(&ray), "{x}, {y}");
        assert_eq!(shared.occluded(&ray), copied.occluded(&ray), "{x}, {y}");
    }
    assert!(shared.memory_bytes() < copied.memory_bytes());
    // Without that room the arrays are copied, and the answers are the same.
    let (vertices, triangles) = two_triangles();
    assert_eq!(vertices.capacity(), vertices.len());
    let fallback = device
        .build_shared_triangle_scene(
            &vertices,
            &triangles,
            BuildQuality::High,
            None::<std::sync::Arc<ember::accel::Opaque>>,
        )
        .unwrap();
    assert_eq!(
        fallback.intersect(&down_at(2.2, 0.2)).map(|h| h.prim),
        Some(1)
    );
}
