//! Light transport: how much radiance arrives along a camera ray.
//!
//! Depth counts path segments, the camera ray being the first: with `max_depth = 1`
//! only emitters seen directly contribute, with 2 direct lighting, and so on.

use glam::Vec3;

use crate::accel::{Accel, Ray};
use crate::sampling::{cosine_hemisphere, Onb, Rng};
use crate::scene::{Scatter, Scene, SurfacePoint};

/// Which light-transport estimator `ember render` uses.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum IntegratorKind {
    /// Path tracing that samples only the material (cosine-weighted for diffuse).
    Bsdf,
}

/// Rays traced and samples dropped while estimating radiance, per worker.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct RayCount {
    pub rays: u64,
}

/// A path tracer over one scene and one accelerator; generic so that ray queries are
/// static calls in the hot loop.
pub struct PathTracer<'a, A: Accel> {
    pub scene: &'a Scene,
    pub accel: &'a A,
    pub max_depth: u32,
    pub kind: IntegratorKind,
}

/// Where a ray leaving `surface` in direction `dir` should start: nudged off the
/// surface on the side it leaves from, by an amount that grows with the coordinates
/// (so self-intersection is avoided at any scene scale).
#[inline]
pub fn spawn_point(surface: &SurfacePoint, dir: Vec3) -> Vec3 {
    let eps = 3e-5 * (1.0 + surface.p.abs().max_element());
    let side = if dir.dot(surface.ng) >= 0.0 {
        1.0
    } else {
        -1.0
    };
    surface.p + surface.ng * (side * eps)
}

impl<A: Accel> PathTracer<'_, A> {
    /// Radiance arriving along `ray` (towards its origin).
    pub fn radiance(&self, ray: Ray, rng: &mut Rng, count: &mut RayCount) -> Vec3 {
        match self.kind {
            IntegratorKind::Bsdf => self.radiance_bsdf(ray, rng, count),
        }
    }

    /// Material sampling only: emission is picked up when a path happens to hit a light.
    fn radiance_bsdf(&self, mut ray: Ray, rng: &mut Rng, count: &mut RayCount) -> Vec3 {
        let mut radiance = Vec3::ZERO;
        let mut throughput = Vec3::ONE;
        for segment in 1..=self.max_depth {
            count.rays += 1;
            let Some(hit) = self.accel.intersect(&ray) else {
                break;
            };
            let surface = self.scene.mesh.surface(&hit);
            let material = self.scene.material(&surface);
            // Lights are one-sided: they emit on the side of their winding normal.
            if ray.dir.dot(surface.ng) < 0.0 {
                radiance += throughput * material.emission;
            }
            if segment == self.max_depth {
                break;
            }
            let albedo = self.scene.albedo(&surface);
            let dir = match material.scatter(ray.dir, surface.ng, surface.ns, albedo, rng) {
                Scatter::Diffuse { albedo, normal } => {
                    // Cosine sampling: BSDF × cos / pdf = (albedo/π · cos) / (cos/π) = albedo.
                    let local = cosine_hemisphere(rng.f32(), rng.f32());
                    throughput *= albedo;
                    Onb::from_w(normal).to_world(local)
                }
                Scatter::Specular { dir, weight } => {
                    throughput *= weight;
                    dir
                }
            };
            if throughput == Vec3::ZERO {
                break;
            }
            ray = Ray::new(spawn_point(&surface, dir), dir);
        }
        radiance
    }
}
