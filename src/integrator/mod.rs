//! Light transport: how much radiance arrives along a camera ray.
//!
//! Depth counts path segments, the camera ray being the first: with `max_depth = 1`
//! only emitters seen directly contribute, with 2 direct lighting, and so on. A light
//! sample taken at the end of segment `k` stands for a path of `k + 1` segments, so it
//! is only taken while `k < max_depth`.
//!
//! Four estimators of the same quantity (they converge to the same image, see
//! `tests/integrators.rs`), differing only in how a diffuse vertex picks what to trace:
//! - [`IntegratorKind::Bsdf`]: cosine-weighted directions; light is found by chance.
//! - [`IntegratorKind::Light`]: next-event estimation without MIS — direct light comes
//!   only from a light sample (shadow ray), the path continues by cosine sampling and
//!   ignores the emission it then hits.
//! - [`IntegratorKind::Mixture`]: "The Rest of Your Life": one direction from the
//!   50/50 mixture of the cosine and light densities, weighted by the mixture density.
//! - [`IntegratorKind::Mis`]: next-event estimation plus the cosine sample, both
//!   weighted by the power heuristic, with Russian roulette on long paths. At the last
//!   vertex the cosine ray could only find emission, so the light sample alone (weight
//!   1) is used there and that ray is not traced.
//!
//! Why `Light` is next-event estimation rather than the book's "sample only the light
//! PDF": a path that only ever goes towards lights has density 0 for every other
//! direction, so it cannot converge to global illumination (only to direct light).
//!
//! Specular materials (metal, glass, plastic coats) keep their own delta sampling in
//! all four, and emission seen right after them counts in full.

use glam::Vec3;
use std::f32::consts::FRAC_1_PI;

use crate::accel::{Accel, Hit, Ray};
use crate::sampling::{CosinePdf, LightSampler, Pdf, Rng};
use crate::scene::{Scatter, Scene, SurfacePoint};

/// Which light-transport estimator `ember render` uses.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum IntegratorKind {
    /// Path tracing that samples only the material (cosine-weighted for diffuse).
    Bsdf,
    /// Next-event estimation: direct light from light samples only, no MIS.
    Light,
    /// One sample per bounce from the 50/50 mixture of cosine and light densities.
    Mixture,
    /// Next-event estimation and material sampling combined by multiple importance
    /// sampling (power heuristic), with Russian roulette.
    #[default]
    Mis,
}

/// Rays traced and samples dropped while estimating radiance, per worker.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct RayCount {
    pub rays: u64,
}

/// Russian roulette may end a path once it has this many segments (MIS only): short
/// paths carry most of the image, long ones are cut in proportion to their throughput.
pub const ROULETTE_START_SEGMENT: u32 = 4;

/// A path tracer over one scene and one accelerator; generic so that ray queries are
/// static calls in the hot loop.
pub struct PathTracer<'a, A: Accel> {
    pub scene: &'a Scene,
    pub accel: &'a A,
    pub max_depth: u32,
    pub kind: IntegratorKind,
    /// The distribution over the scene's emitters, built once per render.
    pub lights: LightSampler,
}

/// How emission met by the next ray counts, decided where that ray was chosen.
#[derive(Clone, Copy, Debug)]
enum EmissionWeight {
    /// In full: camera rays, specular bounces, BSDF-only and mixture sampling.
    Full,
    /// Not at all: the light sample at the previous vertex already counted it.
    Skip,
    /// MIS weight of a cosine sample drawn with this density against light sampling.
    Mis { bsdf_pdf: f32 },
}

/// Veach's power heuristic (β = 2) for a sample of density `a` against density `b`.
#[inline]
pub fn power_heuristic(a: f32, b: f32) -> f32 {
    let (a2, b2) = (a * a, b * b);
    if a2 + b2 > 0.0 {
        a2 / (a2 + b2)
    } else {
        0.0
    }
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

impl<'a, A: Accel> PathTracer<'a, A> {
    /// A tracer for `scene`, with its light distribution built once here.
    pub fn new(scene: &'a Scene, accel: &'a A, max_depth: u32, kind: IntegratorKind) -> Self {
        PathTracer {
            scene,
            accel,
            max_depth,
            kind,
            lights: LightSampler::new(scene),
        }
    }

    #[inline]
    fn trace(&self, ray: &Ray, count: &mut RayCount) -> Option<Hit> {
        count.rays += 1;
        self.accel.intersect(ray)
    }

    /// Radiance arriving along `ray` (towards its origin); `ray.dir` must be unit.
    /// `rng` is told where each vertex's draws start (see [`Rng::start_vertex`]).
    pub fn radiance(&self, mut ray: Ray, rng: &mut Rng, count: &mut RayCount) -> Vec3 {
        let mut radiance = Vec3::ZERO;
        let mut throughput = Vec3::ONE;
        let mut emission_weight = EmissionWeight::Full;
        let mut hit = self.trace(&ray, count);
        for segment in 1..=self.max_depth {
            let Some(current) = hit else {
                // The sky: never sampled by the light strategies, so it counts in full.
                radiance += throughput * self.scene.background;
                break;
            };
            rng.start_vertex(segment);
            let surface = self.scene.mesh.surface(&current);
            let material = self.scene.material(&surface);
            // Lights are one-sided: they emit on the side of their winding normal.
            if material.is_emissive() && ray.dir.dot(surface.ng) < 0.0 {
                let weight = match emission_weight {
                    EmissionWeight::Full => 1.0,
                    EmissionWeight::Skip => 0.0,
                    EmissionWeight::Mis { bsdf_pdf } => {
                        let light_pdf = self.lights.pdf_hit(current.prim, ray.dir, current.t);
                        power_heuristic(bsdf_pdf, light_pdf)
                    }
                };
                radiance += throughput * material.emission * weight;
            }
            if segment == self.max_depth {
                break;
            }
            let albedo = self.scene.albedo(&surface);
            // The next direction, and its first hit when choosing it needed the trace.
            let (dir, traced) = match material.scatter(ray.dir, surface.ng, surface.ns, albedo, rng)
            {
                Scatter::Specular { dir, weight } => {
                    throughput *= weight;
                    emission_weight = EmissionWeight::Full;
                    (dir, None)
                }
                Scatter::Diffuse { albedo, normal } => match self.kind {
                    IntegratorKind::Bsdf => {
                        // BSDF × cos / pdf = (albedo/π · cos) / (cos/π) = albedo.
                        let dir = cosine_direction(normal, rng);
                        throughput *= albedo;
                        emission_weight = EmissionWeight::Full;
                        (dir, None)
                    }
                    IntegratorKind::Light | IntegratorKind::Mis => {
                        // At the last vertex only direct light is left to find: the
                        // light sample alone (unweighted) estimates it, so no cosine
                        // ray is traced just to be weighted against it.
                        let last_vertex = segment + 1 == self.max_depth;
                        let mis = self.kind == IntegratorKind::Mis && !last_vertex;
                        radiance += throughput
                            * self.direct_light(&surface, normal, albedo, mis, rng, count);
                        if last_vertex {
                            break;
                        }
                        let dir = cosine_direction(normal, rng);
                        throughput *= albedo;
                        emission_weight = if mis {
                            EmissionWeight::Mis {
                                bsdf_pdf: dir.dot(normal).max(0.0) * FRAC_1_PI,
                            }
                        } else {
                            EmissionWeight::Skip
                        };
                        (dir, None)
                    }
                    IntegratorKind::Mixture => {
                        let Some((dir, next, factor)) =
                            self.mixture_step(&surface, normal, rng, count)
                        else {
                            break;
                        };
                        throughput *= albedo * factor;
                        emission_weight = EmissionWeight::Full;
                        (dir, Some(next))
                    }
                },
            };
            if self.kind == IntegratorKind::Mis && segment >= ROULETTE_START_SEGMENT {
                let survive = throughput.max_element().min(0.95);
                if rng.f32() >= survive {
                    break;
                }
                throughput /= survive;
            }
            if throughput == Vec3::ZERO {
                break;
            }
            ray = Ray::new(spawn_point(&surface, dir), dir);
            hit = match traced {
                Some(next) => next,
                None => self.trace(&ray, count),
            };
        }
        radiance
    }

    /// Next-event estimation at a diffuse point: radiance reflected towards the viewer
    /// from one light sample, `albedo/π · cos · Le / pdf` if the shadow ray is clear,
    /// times the power-heuristic weight against cosine sampling when `mis`.
    fn direct_light(
        &self,
        surface: &SurfacePoint,
        normal: Vec3,
        albedo: Vec3,
        mis: bool,
        rng: &mut Rng,
        count: &mut RayCount,
    ) -> Vec3 {
        if !self.lights.may_light(surface.p) {
            return Vec3::ZERO;
        }
        let Some(light) = self.lights.sample(surface.p, rng) else {
            return Vec3::ZERO;
        };
        let cos = light.dir.dot(normal);
        if cos <= 0.0 {
            return Vec3::ZERO;
        }
        let origin = spawn_point(surface, light.dir);
        // Stop just short of the light point so the light itself does not occlude it.
        let shadow = Ray::segment(origin, light.point - origin, 1.0 - 1e-4);
        count.rays += 1;
        if self.accel.occluded(&shadow) {
            return Vec3::ZERO;
        }
        let bsdf_pdf = cos * FRAC_1_PI;
        let weight = if mis {
            power_heuristic(light.pdf, bsdf_pdf)
        } else {
            1.0
        };
        albedo * (FRAC_1_PI * cos * weight / light.pdf) * light.emission
    }

    /// The book's mixture step at a diffuse point: a direction from
    /// `0.5 · cos/π + 0.5 · light`, traced here because the light density of a
    /// direction depends on what it hits. Returns the direction, its first hit and
    /// the factor `(cos/π) / mixture_pdf` the albedo is multiplied by; `None` when the
    /// draw is void (a light point that is hidden, faces away or lies below the
    /// surface), which ends the path with nothing more to add.
    fn mixture_step(
        &self,
        surface: &SurfacePoint,
        normal: Vec3,
        rng: &mut Rng,
        count: &mut RayCount,
    ) -> Option<(Vec3, Option<Hit>, f32)> {
        let cosine = CosinePdf::new(normal);
        // Where no light can shine, the mixture is all cosine: a light sample there
        // would be void. The weights depend only on the point, so the estimate stays
        // unbiased.
        if !self.lights.may_light(surface.p) {
            let dir = cosine.generate(rng)?;
            let next = self.trace(&Ray::new(spawn_point(surface, dir), dir), count);
            return Some((dir, next, 1.0));
        }
        let use_light = rng.f32() >= 0.5;
        let (dir, aimed_at) = if !use_light {
            (cosine.generate(rng)?, None)
        } else {
            let light = self.lights.sample(surface.p, rng)?;
            (light.dir, Some(light.prim))
        };
        let cosine_pdf = cosine.value(dir);
        if cosine_pdf <= 0.0 {
            return None;
        }
        let next = self.trace(&Ray::new(spawn_point(surface, dir), dir), count);
        if aimed_at.is_some() && next.map(|h| h.prim) != aimed_at {
            return None;
        }
        let light_pdf = next.map_or(0.0, |h| self.lights.pdf_hit(h.prim, dir, h.t));
        let mixture_pdf = 0.5 * cosine_pdf + 0.5 * light_pdf;
        Some((dir, next, cosine_pdf / mixture_pdf))
    }
}

/// A cosine-weighted direction around the unit `normal`.
#[inline]
fn cosine_direction(normal: Vec3, rng: &mut Rng) -> Vec3 {
    CosinePdf::new(normal).generate(rng).unwrap_or(normal)
}
