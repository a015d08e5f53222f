//! The native BVH and Embree must answer the same ray queries the same way: over a
//! million random rays (from inside, from outside, grazing the surface, through vertices
//! and edges) on the Cornell box and procedural meshes (shipped with the repository),
//! and the bunny and Sponza from ../shared, both find the same hit or miss, at the same distance, on the same
//! triangle unless two triangles are hit at the same distance; and both agree on
//! occlusion.
//!
//! The only disagreements allowed are boundary cases, where the exact answer depends on
//! rounding: a hit within a hair of a triangle's edge, or at a distance within a hair of
//! the interval's end. Those are counted and must stay rare.
//!
//! The bunny and Sponza are not shipped: the Stanford terms forbid inclusion in a
//! product for sale, which an Apache-2.0 repository cannot promise, and Sponza comes
//! with no licence. Without ../shared the test says so on stderr and compares the
//! shipped meshes only; with `CI` set, a missing mesh fails the test.

use std::path::{Path, PathBuf};

use glam::Vec3;
use rayon::prelude::*;

use ember::accel::{Accel, Bvh, EmbreeAccel, Hit, Ray};
use ember::embree::{BuildQuality, Device};
use ember::sampling::{uniform_sphere, uniform_triangle, Rng};
use ember::scene::load_obj;

// The benchmark's procedural meshes (part of the binary, not of the library).
#[allow(dead_code)]
#[path = "../src/cli/bench/procedural.rs"]
mod procedural;
use procedural::Procedural;

/// Rays per mesh; five meshes give 1.25 million intersection rays plus as many
/// occlusion rays.
const RAYS_PER_MESH: usize = 250_000;

struct Mesh {
    name: String,
    positions: Vec<Vec3>,
    triangles: Vec<[u32; 3]>,
}

impl Mesh {
    fn corners(&self, prim: u32) -> [Vec3; 3] {
        self.triangles[prim as usize].map(|i| self.positions[i as usize])
    }

    fn bounds(&self) -> (Vec3, Vec3) {
        self.triangles.iter().flatten().fold(
            (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY)),
            |(lo, hi), &i| {
                let p = self.positions[i as usize];
                (lo.min(p), hi.max(p))
            },
        )
    }
}

fn shared(relative: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("..")
        .join("shared")
        .join(relative)
}

/// A mesh from ../shared: missing, it fails the test under CI (which has ../shared),
/// and elsewhere is left out with a warning that says how much less is tested.
fn shared_obj(relative: &str) -> Option<Mesh> {
    let path = shared(relative);
    if path.exists() {
        return Some(obj(&path));
    }
    assert!(
        std::env::var_os("CI").is_none(),
        "CI is set but {} is missing: the agreement test needs ../shared",
        path.display()
    );
    eprintln!(
        "WARNING: {} is missing, so Embree and the native BVH are NOT compared on it \
         (set up ../shared to test what CI tests)",
        path.display()
    );
    None
}

fn obj(path: &Path) -> Mesh {
    let (scene, _) = load_obj(path).expect("mesh loads");
    Mesh {
        name: path.file_name().unwrap().to_string_lossy().into(),
        positions: scene.mesh.positions,
        triangles: scene.mesh.triangles,
    }
}

fn procedural(spec: &str) -> Mesh {
    let p: Procedural = spec.parse().unwrap();
    let (positions, triangles) = p.generate(3);
    Mesh {
        name: spec.into(),
        positions,
        triangles,
    }
}

/// Random rays of four kinds, in equal numbers: from random points inside the bounding
/// box in uniform directions; from a sphere around the box towards random points in it;
/// nearly in the plane of a random triangle through a point on it (grazing); from
/// outside through a vertex or an edge midpoint (watertightness).
fn rays(mesh: &Mesh, n: usize, seed: u64) -> Vec<Ray> {
    let (lo, hi) = mesh.bounds();
    let (center, radius) = (0.5 * (lo + hi), 0.5 * (hi - lo).length());
    (0..n)
        .into_par_iter()
        .map(|i| {
            let mut rng = Rng::for_sample(seed, i as u64, 0);
            let in_box =
                |rng: &mut Rng| lo + (hi - lo) * Vec3::new(rng.f32(), rng.f32(), rng.f32());
            let tri = rng.below(mesh.triangles.len() as u32);
            let [a, b, c] = mesh.corners(tri);
            match i % 4 {
                0 => Ray::new(in_box(&mut rng), uniform_sphere(rng.f32(), rng.f32())),
                1 => {
                    let o = center + 2.0 * radius * uniform_sphere(rng.f32(), rng.f32());
                    Ray::new(o, in_box(&mut rng) - o)
                }
                2 => {
                    let (u, v) = uniform_triangle(rng.f32(), rng.f32());
                    let p = (1.0 - u - v) * a + u * b + v * c;
                    let n = (b - a).cross(c - a).normalize_or_zero();
                    let along = (b - a).normalize_or_zero() * (rng.f32() - 0.5)
                        + (c - a).normalize_or_zero() * (rng.f32() - 0.5);
                    let dir = (along + n * (rng.f32() - 0.5) * 2e-3).normalize_or(Vec3::X);
                    Ray::new(p - dir * radius * rng.f32(), dir)
                }
                _ => {
                    let target = match rng.below(3) {
                        0 => a,
                        1 => 0.5 * (a + b),
                        _ => 0.5 * (b + c),
                    };
                    let o = center + 2.0 * radius * uniform_sphere(rng.f32(), rng.f32());
                    Ray::new(o, target - o)
                }
            }
        })
        .collect()
}

/// Whether rounding may decide if `hit` is a hit at all: the hit point is within a
/// rounding distance of its triangle's edge (in scene units, larger for grazing rays),
/// or the ray grazes the triangle's plane so closely that f32 cannot tell on which side
/// of an edge it passes. Embree's default triangle test is not watertight, so such rays
/// may slip between its triangles where ember's do not, or the other way round.
fn is_boundary(ray: &Ray, hit: &Hit, [a, b, c]: [Vec3; 3]) -> bool {
    let area2 = (b - a).cross(c - a);
    let normal = area2.normalize_or_zero();
    let cos = ray.dir.normalize().dot(normal).abs();
    // Distance to each edge: the opposite vertex's barycentric times the altitude.
    let weights = [1.0 - hit.u - hit.v, hit.u, hit.v];
    let opposite = [c - b, a - c, b - a];
    let to_edge = (0..3)
        .map(|k| weights[k].max(0.0) * area2.length() / opposite[k].length().max(f32::MIN_POSITIVE))
        .fold(f32::INFINITY, f32::min);
    let size = ray.origin.abs().max_element() + hit.t * ray.dir.abs().max_element();
    cos < 1e-3 || to_edge <= 2e-5 * size / cos
}

/// Whether two distances along `ray` to the plane of a triangle with unit normal
/// `normal` are the same up to f32 rounding. Rounding of the coordinates (of size about
/// `|origin| + t |dir|`) moves the hit along the ray by that over the cosine of the
/// angle of incidence, so grazing hits get a wider tolerance.
fn same_distance(ray: &Ray, normal: Vec3, a: f32, b: f32) -> bool {
    (a - b).abs() * ray.dir.length() <= tolerance(ray, normal, a.abs().max(b.abs()))
}

/// How far apart, in scene units, two correct hit points at distance `t` may be.
fn tolerance(ray: &Ray, normal: Vec3, t: f32) -> f32 {
    let size = ray.origin.abs().max_element() + t * ray.dir.abs().max_element();
    let cos = (ray.dir.normalize().dot(normal)).abs().max(1e-6);
    4e-6 * size / cos + 1e-6 * t * ray.dir.length()
}

#[derive(Default, Debug)]
struct Tally {
    rays: usize,
    hits: usize,
    /// Hit by one, missed (or hit farther) by the other, within a hair of an edge; of
    /// rays that were not aimed at a vertex or an edge.
    boundary: usize,
    /// The same among the rays aimed at a vertex or an edge midpoint.
    aimed_at_edges: usize,
    /// Different triangles at the same distance.
    ties: usize,
    occluded: usize,
    occlusion_boundary: usize,
}

fn compare(mesh: &Mesh, device: &Device) -> Tally {
    let embree = EmbreeAccel::build(device, &mesh.positions, &mesh.triangles, BuildQuality::High)
        .expect("Embree builds");
    let bvh = Bvh::build(&mesh.positions, &mesh.triangles).expect("BVH builds");
    let rays = rays(mesh, RAYS_PER_MESH, 11);
    let tallies = rays.par_iter().enumerate().map(|(i, ray)| {
        let mut t = Tally {
            rays: 1,
            ..Tally::default()
        };
        let (e, n) = (embree.intersect(ray), bvh.intersect(ray));
        let normal = |h: &Hit| {
            let [a, b, c] = mesh.corners(h.prim);
            (b - a).cross(c - a).normalize_or_zero()
        };
        let mut on_boundary = |h: &Hit, what: &str| {
            // On an edge, or at the very start of the interval (a ray that starts on
            // a surface: robust Embree counts t = -0 as in [0, ∞), and rounding decides).
            let at_start = same_distance(ray, normal(h), h.t, ray.tmin);
            assert!(
                at_start || is_boundary(ray, h, mesh.corners(h.prim)),
                "{}: ray {i} {ray:?}: {what}: embree {e:?}, bvh {n:?}",
                mesh.name
            );
            if i % 4 == 3 {
                t.aimed_at_edges = 1;
            } else {
                t.boundary = 1;
            }
        };
        match (e, n) {
            (Some(e), Some(n)) => {
                t.hits = 1;
                if !same_distance(ray, normal(&e), e.t, n.t) {
                    // Only if the nearer hit is at an edge the other slipped past.
                    on_boundary(if e.t < n.t { &e } else { &n }, "different distances");
                } else if e.prim != n.prim {
                    t.ties = 1;
                } else {
                    // The same triangle: the barycentrics name the same point, up to
                    // the same rounding as the distance.
                    let [a, b, c] = mesh.corners(e.prim);
                    let at = |h: &Hit| (1.0 - h.u - h.v) * a + h.u * b + h.v * c;
                    let gap = (at(&e) - at(&n)).length();
                    let edge = (b - a).length().max((c - a).length());
                    assert!(
                        gap <= 4.0 * tolerance(ray, normal(&e), e.t) + 1e-5 * edge,
                        "{}: ray {i}: barycentrics differ: {e:?} vs {n:?}",
                        mesh.name
                    );
                }
            }
            (Some(h), None) | (None, Some(h)) => on_boundary(&h, "only one backend hits"),
            (None, None) => {}
        }
        // Occlusion of a segment ending at a random fraction of (up to twice) the hit
        // distance, or of the whole ray.
        let mut rng = Rng::for_sample(12, i as u64, 1);
        let segment = Ray {
            tmax: e.map_or(f32::INFINITY, |h| 2.0 * rng.f32() * h.t),
            ..*ray
        };
        let (eo, no) = (embree.occluded(&segment), bvh.occluded(&segment));
        t.occluded = usize::from(eo);
        if eo != no {
            // Allowed only when the nearest hit sits at the segment's end or on an edge.
            let near_end = e.is_some_and(|h| same_distance(ray, normal(&h), h.t, segment.tmax));
            let on_edge = [e, n]
                .iter()
                .flatten()
                .any(|h| is_boundary(ray, h, mesh.corners(h.prim)));
            assert!(
                near_end || on_edge,
                "{}: ray {i} {segment:?}: occluded by embree {eo}, by bvh {no}",
                mesh.name
            );
            if i % 4 == 3 {
                t.aimed_at_edges = 1;
            } else {
                t.occlusion_boundary = 1;
            }
        }
        t
    });
    let tally = tallies.reduce(Tally::default, |a, b| Tally {
        rays: a.rays + b.rays,
        hits: a.hits + b.hits,
        boundary: a.boundary + b.boundary,
        aimed_at_edges: a.aimed_at_edges + b.aimed_at_edges,
        ties: a.ties + b.ties,
        occluded: a.occluded + b.occluded,
        occlusion_boundary: a.occlusion_boundary + b.occlusion_boundary,
    });
    eprintln!("{}: {tally:?}", mesh.name);
    tally
}

#[test]
fn native_bvh_agrees_with_embree() {
    let device = Device::new("").expect("Embree device");
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let meshes = [
        Some(obj(&root.join("meshes/CornellBox-Original.obj"))),
        shared_obj("meshes/bunny/stanford-bunny.obj"),
        shared_obj("meshes/sponza-dabrovic/sponza.obj"),
        Some(procedural("sphere:50k")),
        Some(procedural("soup:20k")),
    ];
    let mut total = 0;
    for mesh in meshes.iter().flatten() {
        let t = compare(mesh, &device);
        total += t.rays;
        // Every kind of ray is represented: a good share hit, and some miss.
        assert!(
            t.hits > t.rays / 10 && t.hits < t.rays,
            "{}: {t:?}",
            mesh.name
        );
        // Boundary cases are rounding accidents, not a systematic difference: at most
        // one ray in 2000 for each query. (With Embree's robust mode, rays aimed at
        // shared edges agree ten times as often as without, while on the soup's
        // isolated edges robust Embree counts a few more edge hits: 91 intersection
        // and 43 occlusion cases of 250 000, against 61 and 30 without.)
        assert!(t.boundary <= t.rays / 2000, "{}: {t:?}", mesh.name);
        assert!(
            t.occlusion_boundary <= t.rays / 2000,
            "{}: {t:?}",
            mesh.name
        );
    }
    // The shipped meshes alone give 750 000 rays.
    assert!(total >= 750_000, "only {total} rays compared");
}
