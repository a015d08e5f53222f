//! The three ray sets every backend traces: coherent primary rays from a camera,
//! incoherent diffuse bounces and shadow rays from the surface points the camera sees.

use glam::Vec3;
use rayon::prelude::*;

use super::mesh::BenchMesh;
use ember::accel::{Accel, Ray};
use ember::sampling::{cosine_hemisphere, uniform_triangle, Onb, Rng};
use ember::scene::CameraSettings;

/// The camera the primary rays would come from is not a camera.
#[derive(Debug, thiserror::Error)]
#[error("invalid camera: {0}")]
pub struct CameraError(String);

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
    ) -> Result<RaySets, CameraError> {
        let (lo, hi) = mesh.bounds();
        let settings = camera.unwrap_or_else(|| CameraSettings::framing(lo, hi, 40.0));
        settings.validate().map_err(CameraError)?;
        let primary = primary_rays(&settings, n);
        let surfaces = visible_surfaces(mesh, reference, &primary);

        let mut rng = Rng::seeded(seed);
        // Where secondary ray `i` starts: a seen surface point (with the normal facing
        // the camera), or when nothing is seen anywhere in the box, facing anywhere.
        let origin = |i: usize, rng: &mut Rng| -> (Vec3, Vec3) {
            if surfaces.is_empty() {
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
            let target = shadow_target(mesh, (lo, hi), &mut rng);
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

/// `n` camera rays through pixel centres of a square image, tile by tile.
fn primary_rays(settings: &CameraSettings, n: usize) -> Vec<Ray> {
    let side = ((n as f64).sqrt().ceil() as u32).max(1);
    let cam = settings.camera(side, side);
    let mut primary = Vec::with_capacity(n);
    for ty in (0..side).step_by(16) {
        for tx in (0..side).step_by(16) {
            for y in ty..(ty + 16).min(side) {
                for x in tx..(tx + 16).min(side) {
                    if primary.len() == n {
                        return primary;
                    }
                    primary.push(cam.ray(x as f32 + 0.5, y as f32 + 0.5));
                }
            }
        }
    }
    primary
}

/// The surface points the primary rays hit, lifted off the surface towards the camera:
/// (point, geometric normal facing the camera). The mesh computes the points, as for
/// the renderer.
fn visible_surfaces<A: Accel>(
    mesh: &BenchMesh,
    reference: &A,
    primary: &[Ray],
) -> Vec<(Vec3, Vec3)> {
    primary
        .par_iter()
        .filter_map(|ray| {
            let surface = mesh.mesh.surface(&reference.intersect(ray)?);
            let ng = surface.ng;
            let ng = if ng.dot(ray.dir) > 0.0 { -ng } else { ng };
            let p = surface.p;
            (ng != Vec3::ZERO).then_some((p + ng * spawn_offset(p), ng))
        })
        .collect()
}

/// A uniform point on a random light, or without lights, a point in the mesh's box
/// `lo..hi`.
fn shadow_target(mesh: &BenchMesh, (lo, hi): (Vec3, Vec3), rng: &mut Rng) -> Vec3 {
    if mesh.lights.is_empty() {
        lo + (hi - lo) * Vec3::new(rng.f32(), rng.f32(), rng.f32())
    } else {
        let t = mesh.lights[rng.below(mesh.lights.len() as u32) as usize];
        let [a, b, c] = mesh.mesh.vertices(t);
        let (u, v) = uniform_triangle(rng.f32(), rng.f32());
        (1.0 - u - v) * a + u * b + v * c
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use ember::accel::EmbreeAccel;
    use ember::embree::{BuildQuality, Device};

    #[test]
    fn ray_sets_start_on_the_visible_surface() {
        let mesh = BenchMesh::procedural("sphere:5k".parse().unwrap(), 1);
        let device = Device::new("").unwrap();
        let (v, t) = (mesh.positions(), mesh.triangles());
        let embree = EmbreeAccel::build(&device, v, t, BuildQuality::Low).unwrap();
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
}
