//! Embree, through ember's wrapper, against an analytic ray/triangle intersection
//! computed independently in f64: same hit/miss, distance, primitive and barycentrics.

use ember::accel::Ray;
use ember::embree::{BuildQuality, Device};
use ember::sampling::{uniform_sphere, Rng};
use glam::{DVec3, Vec3};

/// Möller–Trumbore in f64: `(t, u, v)` of the hit, with `p = (1-u-v) a + u b + v c`.
fn analytic_hit(o: DVec3, d: DVec3, [a, b, c]: [DVec3; 3]) -> Option<(f64, f64, f64)> {
    let (e1, e2) = (b - a, c - a);
    let p = d.cross(e2);
    let det = e1.dot(p);
    if det.abs() < 1e-14 {
        return None;
    }
    let s = o - a;
    let u = s.dot(p) / det;
    let q = s.cross(e1);
    let v = d.dot(q) / det;
    let t = e2.dot(q) / det;
    (u >= 0.0 && v >= 0.0 && u + v <= 1.0 && t > 0.0).then_some((t, u, v))
}

fn random_point(rng: &mut Rng, scale: f32) -> Vec3 {
    Vec3::new(rng.f32() - 0.5, rng.f32() - 0.5, rng.f32() - 0.5) * 2.0 * scale
}

/// A soup of random triangles and rays through random points of random triangles (so
/// most rays hit), plus fully random rays (many miss).
struct Case {
    vertices: Vec<Vec3>,
    triangles: Vec<[u32; 3]>,
    rays: Vec<Ray>,
}

fn random_case(seed: u64, triangles: usize, rays: usize) -> Case {
    let mut rng = Rng::seeded(seed);
    let mut vertices = Vec::new();
    let mut tris = Vec::new();
    for i in 0..triangles {
        let center = random_point(&mut rng, 5.0);
        for _ in 0..3 {
            vertices.push(center + random_point(&mut rng, 1.0));
        }
        let base = 3 * i as u32;
        tris.push([base, base + 1, base + 2]);
    }
    let mut out = Vec::new();
    for k in 0..rays {
        let origin = random_point(&mut rng, 8.0);
        let target = if k % 2 == 0 {
            // Aim at a random point inside a random triangle.
            let t = rng.below(triangles as u32) as usize;
            let (u, v) = ember::sampling::uniform_triangle(rng.f32(), rng.f32());
            let [a, b, c] = tris[t].map(|i| vertices[i as usize]);
            (1.0 - u - v) * a + u * b + v * c
        } else {
            origin + uniform_sphere(rng.f32(), rng.f32())
        };
        // Unnormalised directions on purpose: t is in units of dir.
        let dir = (target - origin) * (0.5 + rng.f32());
        out.push(Ray::new(origin, dir));
    }
    Case {
        vertices,
        triangles: tris,
        rays: out,
    }
}

/// The analytic nearest hit over all triangles: (t, prim, u, v).
fn nearest(case: &Case, ray: &Ray) -> Option<(f64, u32, f64, f64)> {
    let (o, d) = (ray.origin.as_dvec3(), ray.dir.as_dvec3());
    case.triangles
        .iter()
        .enumerate()
        .filter_map(|(i, tri)| {
            let verts = tri.map(|k| case.vertices[k as usize].as_dvec3());
            analytic_hit(o, d, verts).map(|(t, u, v)| (t, i as u32, u, v))
        })
        .filter(|h| h.0 >= ray.tmin as f64 && h.0 <= ray.tmax as f64)
        .min_by(|a, b| a.0.total_cmp(&b.0))
}

/// Near-misses, near-ties and grazing hits are decided by rounding; skip those, and
/// only those.
fn is_borderline(case: &Case, ray: &Ray) -> bool {
    let (o, d) = (ray.origin.as_dvec3(), ray.dir.as_dvec3());
    let mut ts: Vec<f64> = Vec::new();
    for tri in &case.triangles {
        let [a, b, c] = tri.map(|k| case.vertices[k as usize].as_dvec3());
        // Grow and shrink the triangle about its centroid: a hit that changes is on an edge.
        let centroid = (a + b + c) / 3.0;
        let scaled = |s: f64| [a, b, c].map(|p| centroid + (p - centroid) * s);
        let grown = analytic_hit(o, d, scaled(1.0 + 1e-4));
        let shrunk = analytic_hit(o, d, scaled(1.0 - 1e-4));
        if grown.is_some() != shrunk.is_some() {
            return true;
        }
        if let Some((t, _, _)) = grown {
            // Nearly in the triangle's plane, t is ill-conditioned (a tiny tilt moves
            // the hit far along the ray): rounding decides it too.
            let cos = (b - a).cross(c - a).normalize().dot(d.normalize()).abs();
            if cos < 1e-3 {
                return true;
            }
            ts.push(t);
        }
    }
    ts.sort_by(f64::total_cmp);
    ts.windows(2)
        .any(|w| (w[1] - w[0]) <= 1e-4 * w[0].abs().max(1e-3))
}

#[test]
fn embree_hits_match_analytic_intersections() {
    let device = Device::new("").expect("Embree device");
    let mut checked = 0;
    let mut hits = 0;
    for seed in 0..4u64 {
        let case = random_case(seed, 60, 2500);
        let scene = device
            .build_triangle_scene(&case.vertices, &case.triangles, BuildQuality::High)
            .expect("scene builds");
        for ray in &case.rays {
            if is_borderline(&case, ray) {
                continue;
            }
            checked += 1;
            let expected = nearest(&case, ray);
            let got = scene.intersect(ray);
            match (expected, got) {
                (None, None) => {}
                (Some((t, prim, u, v)), Some(hit)) => {
                    hits += 1;
                    assert_eq!(hit.prim, prim, "primitive for {ray:?}");
                    let rel = (hit.t as f64 - t).abs() / t.max(1e-6);
                    assert!(rel < 1e-4, "distance {} vs analytic {t} for {ray:?}", hit.t);
                    assert!((hit.u as f64 - u).abs() < 1e-3, "u {} vs {u}", hit.u);
                    assert!((hit.v as f64 - v).abs() < 1e-3, "v {} vs {v}", hit.v);
                }
                (e, g) => panic!("hit/miss disagree for {ray:?}: analytic {e:?}, Embree {g:?}"),
            }
        }
    }
    // Most rays must have been decided, and a good share of them hits.
    assert!(checked > 9000, "only {checked} rays checked");
    assert!(hits > 3000, "only {hits} hits among {checked} rays");
}

#[test]
fn occlusion_agrees_with_intersection_and_respects_the_segment() {
    let device = Device::new("").unwrap();
    let case = random_case(42, 80, 4000);
    let scene = device
        .build_triangle_scene(&case.vertices, &case.triangles, BuildQuality::Medium)
        .unwrap();
    let mut blocked = 0;
    for ray in &case.rays {
        let hit = scene.intersect(ray);
        assert_eq!(scene.occluded(ray), hit.is_some(), "{ray:?}");
        if let Some(hit) = hit {
            blocked += 1;
            // A segment that stops short of the nearest hit is not occluded …
            let short = Ray {
                tmax: hit.t * 0.999,
                ..*ray
            };
            assert!(!scene.occluded(&short), "{short:?} stops before {}", hit.t);
            // … and a segment starting past it does not see that triangle again.
            let past = Ray {
                tmin: hit.t * 1.001,
                ..*ray
            };
            if let Some(later) = scene.intersect(&past) {
                assert!(later.t > hit.t);
            }
        }
    }
    assert!(blocked > 1000);
}

#[test]
fn packets_of_eight_match_single_rays() {
    let device = Device::new("").unwrap();
    let case = random_case(7, 50, 803);
    let scene = device
        .build_triangle_scene(&case.vertices, &case.triangles, BuildQuality::Low)
        .unwrap();
    for chunk in case.rays.chunks(8) {
        let mut hits = [None; 8];
        let mut occluded = [false; 8];
        scene.intersect8(chunk, &mut hits, false);
        scene.occluded8(chunk, &mut occluded);
        for (lane, ray) in chunk.iter().enumerate() {
            let single = scene.intersect(ray);
            assert_eq!(hits[lane].map(|h| h.prim), single.map(|h| h.prim));
            if let (Some(a), Some(b)) = (hits[lane], single) {
                assert!((a.t - b.t).abs() <= 1e-5 * b.t.abs().max(1.0));
            }
            assert_eq!(occluded[lane], single.is_some());
        }
    }
}

#[test]
fn a_committed_scene_answers_from_many_threads_at_once() {
    use rayon::prelude::*;
    let device = Device::new("").unwrap();
    let case = random_case(3, 100, 20_000);
    let scene = device
        .build_triangle_scene(&case.vertices, &case.triangles, BuildQuality::Medium)
        .unwrap();
    let serial: Vec<_> = case.rays.iter().map(|r| scene.intersect(r)).collect();
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(4)
        .build()
        .unwrap();
    let parallel: Vec<_> =
        pool.install(|| case.rays.par_iter().map(|r| scene.intersect(r)).collect());
    assert_eq!(serial, parallel);
}

#[test]
fn bad_arguments_become_errors_not_aborts() {
    let device = Device::new("").unwrap();
    let vertices = [Vec3::ZERO, Vec3::X, Vec3::Y];
    let err = device
        .build_triangle_scene(&vertices, &[[0, 1, 3]], BuildQuality::Medium)
        .err()
        .expect("index 3 of 3 vertices is refused");
    assert!(err.to_string().contains("out of range"), "{err}");
    // The device still works afterwards.
    let scene = device
        .build_triangle_scene(&vertices, &[[0, 1, 2]], BuildQuality::Medium)
        .unwrap();
    let hit = scene
        .intersect(&Ray::new(Vec3::new(0.25, 0.25, 1.0), -Vec3::Z))
        .expect("hits the triangle");
    assert!((hit.t - 1.0).abs() < 1e-6);
    assert!(scene.memory_bytes() > 0);
}

#[test]
fn device_reports_its_version() {
    let info = Device::new("").unwrap().info();
    let major = if cfg!(embree4) { "4." } else { "3." };
    assert!(info.version.starts_with(major), "{}", info.version);
    assert!([4, 8, 16].contains(&info.native_packet_width));
}
