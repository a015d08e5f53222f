//! Choosing points on a scene's emissive triangles, and the solid-angle density of
//! doing so: the light half of "Ray Tracing: The Rest of Your Life".
//!
//! A triangle is chosen in proportion to its power (area × luminance of `Ke`, times the
//! mean of its `map_Ke` texture when it has one) from an
//! alias table built once per scene, so the cost per sample does not grow with the
//! number of lights; then a uniform point on it. Seen from a point `p`, a point `q` on
//! triangle `i` (area `A_i`, chosen with probability `P_i`) has the density in solid
//! angle `P_i / A_i · |q − p|² / cos α`, where α is the angle between the triangle's
//! emitting normal and the direction back to `p`.
//!
//! A textured emitter's radiance at the sampled point is read from its texture, as it
//! is where a ray hits it, so next-event estimation and emission found by BSDF rays
//! agree; only the choice of triangle uses the texture's mean.
//!
//! Emitters are one-sided: they emit on the side their counter-clockwise normal points
//! to. A point seen from behind has density 0: it is never a useful light sample.

use glam::{Vec2, Vec3};

use std::f32::consts::PI;
use std::sync::Arc;

use crate::color::luminance;
use crate::geometry::{barycentric_error, SurfaceOrigin};
use crate::sampling::{uniform_triangle, AliasTable, Rng};
use crate::scene::{Environment, Material, Texture, TriangleMesh};

/// The scene's emitters with a power-proportional distribution over them.
#[derive(Clone, Debug, Default)]
pub struct LightSampler {
    /// Global triangle index of each emitter, ascending (as in `Scene::emitters`).
    prims: Vec<u32>,
    /// What sampling needs of each emitter, copied out of the mesh so that a sample
    /// touches one small record instead of indices, vertices and materials.
    emitters: Vec<Emitter>,
    /// The scene's textures, for the `map_Ke` of emitters (`Emitter::map`).
    maps: Vec<Arc<Texture>>,
    table: Option<AliasTable>,
    /// `π Σ A·lum(Ke)` over the emitters: their power, weighed against the sky's.
    power: f32,
    /// Where the emitters are and which way they face, to tell cheaply which points
    /// no emitter can light (see [`may_light`](Self::may_light)).
    bounds: EmitterBounds,
    /// Light from infinitely far away, chosen with probability `sky_probability`
    /// instead of an emitter.
    sky: Option<Arc<Environment>>,
    sky_probability: f32,
}

/// What a light sample is aimed at.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum LightTarget {
    /// A point on this emissive triangle.
    Emitter(u32),
    /// The environment: the direction must leave the scene.
    Sky,
}

/// A box around every emitter and a cone around every emitter's normal.
#[derive(Clone, Copy, Debug)]
struct EmitterBounds {
    lo: Vec3,
    hi: Vec3,
    axis: Vec3,
    /// `-sin θ` for the cone's half-angle θ; `-1` (or less) when θ ≥ 90°, where
    /// every point may be lit.
    threshold: f32,
}

impl Default for EmitterBounds {
    fn default() -> Self {
        EmitterBounds {
            lo: Vec3::ZERO,
            hi: Vec3::ZERO,
            axis: Vec3::Z,
            threshold: -1.0,
        }
    }
}

impl EmitterBounds {
    fn new(emitters: &[Emitter]) -> Self {
        let mut lo = Vec3::splat(f32::INFINITY);
        let mut hi = Vec3::splat(f32::NEG_INFINITY);
        for e in emitters {
            for v in e.vertices {
                lo = lo.min(v);
                hi = hi.max(v);
            }
        }
        let axis = emitters
            .iter()
            .map(|e| e.normal)
            .sum::<Vec3>()
            .normalize_or_zero();
        let cos_theta = emitters
            .iter()
            .map(|e| e.normal.dot(axis))
            .fold(1.0f32, f32::min);
        if axis == Vec3::ZERO || emitters.is_empty() || cos_theta <= 0.0 {
            return EmitterBounds::default();
        }
        // A little slack so that rounding never culls a point that is lit.
        let sin_theta = (1.0 - cos_theta * cos_theta).max(0.0).sqrt();
        EmitterBounds {
            lo,
            hi,
            axis,
            threshold: -sin_theta - 1e-4,
        }
    }
}

/// One emissive triangle.
#[derive(Clone, Copy, Debug)]
struct Emitter {
    vertices: [Vec3; 3],
    /// Unit normal of the emitting side (counter-clockwise winding).
    normal: Vec3,
    emission: Vec3,
    /// Probability of choosing this triangle divided by its area: the density per
    /// unit area of a sampled point on it.
    area_density: f32,
    /// Scene texture id of the `map_Ke` that multiplies `emission`, or [`NO_MAP`].
    map: u32,
    /// Texture coordinates of the corners (read only with a map).
    uvs: [Vec2; 3],
}

/// Marks an emitter without an emission texture.
const NO_MAP: u32 = u32::MAX;

/// A point chosen on a light, as seen from the point it was chosen for.
#[derive(Clone, Copy, Debug)]
pub struct LightSample {
    /// Unit direction from the shading point to the light point.
    pub dir: Vec3,
    /// Distance from the shading point to the light point.
    pub distance: f32,
    /// The light point itself, with its rounding error and the light's normal (for
    /// the far end of a shadow ray); `None` for the sky, which is at infinity.
    pub point: Option<SurfaceOrigin>,
    /// Solid-angle density with which `dir` was chosen (> 0).
    pub pdf: f32,
    /// The chosen emitter, or the sky.
    pub target: LightTarget,
    /// Radiance the light point emits towards the shading point.
    pub emission: Vec3,
}

impl LightSampler {
    /// Builds the distribution over the triangles of `mesh` whose material emits
    /// (O(n), once per scene); `textures` are the scene's, for `map_Ke`.
    pub fn new(mesh: &TriangleMesh, materials: &[Material], textures: &[Arc<Texture>]) -> Self {
        let material = |t: u32| &materials[mesh.material[t as usize] as usize];
        let prims: Vec<u32> = (0..mesh.triangles.len() as u32)
            .filter(|&t| material(t).is_emissive())
            .collect();
        // Each emission texture's mean, computed once however many triangles use it.
        let mut means: Vec<Option<Vec3>> = vec![None; textures.len()];
        let mut mean_of = |id: Option<u32>| {
            id.map_or(Vec3::ONE, |id| {
                *means[id as usize]
                    .get_or_insert_with(|| textures[id as usize].mean().max(Vec3::ZERO))
            })
        };
        let weights: Vec<f32> = prims
            .iter()
            .map(|&t| {
                let mean = material(t).emission * mean_of(material(t).maps.emission);
                mesh.area(t) * luminance(mean).max(0.0)
            })
            .collect();
        let table = AliasTable::new(&weights);
        let emitters: Vec<Emitter> = prims
            .iter()
            .enumerate()
            .map(|(i, &t)| {
                let [a, b, c] = mesh.vertices(t);
                let area = mesh.area(t);
                let probability = table.as_ref().map_or(0.0, |table| table.pmf(i));
                Emitter {
                    vertices: [a, b, c],
                    normal: (b - a).cross(c - a).normalize_or_zero(),
                    emission: material(t).emission,
                    area_density: if area > 0.0 { probability / area } else { 0.0 },
                    map: material(t).maps.emission.unwrap_or(NO_MAP),
                    uvs: mesh.corner_uvs(t),
                }
            })
            .collect();
        LightSampler {
            prims,
            bounds: EmitterBounds::new(&emitters),
            emitters,
            maps: textures.to_vec(),
            table,
            power: PI * weights.iter().sum::<f32>(),
            sky: None,
            sky_probability: 0.0,
        }
    }

    /// Adds the environment `sky` as a light, chosen against the emitters in
    /// proportion to estimated power: the emitters' `π Σ A·lum(Ke)` against the sky's
    /// `∫ lum(L) dω` through a disc of the scene's bounding radius, `π r²`.
    pub fn with_sky(mut self, sky: Option<Arc<Environment>>, scene_radius: f32) -> Self {
        let Some(sky) = sky.filter(|s| !s.is_black()) else {
            return self;
        };
        let sky_power = sky.luminous_intensity() * PI * scene_radius.max(1e-6).powi(2);
        let p = if self.table.is_none() {
            1.0
        } else {
            (sky_power / (sky_power + self.power)).clamp(0.05, 0.95)
        };
        for e in &mut self.emitters {
            e.area_density *= 1.0 - p;
        }
        self.sky = Some(sky);
        self.sky_probability = p;
        self
    }

    /// Whether some emitter might light point `p`, that is have `p` on its emitting
    /// side. `false` is certain: every emitter faces away from `p`, so light samples
    /// from there are worthless and the integrators skip them. (Exact for the
    /// Cornell box, whose ceiling lies behind its light.)
    ///
    /// Conservative test in O(1): `p` may be lit by an emitter point `q` with normal
    /// `n` when `(p − q) · n > 0`. Over `q` in the emitters' box and `n` in their
    /// normal cone (axis `a`, half-angle θ), the largest `(p − q) · n` is reached at
    /// a corner `q` of the box, where it is positive iff the angle between `p − q`
    /// and `a` is below 90° + θ, i.e. `(p − q)/|p − q| · a > −sin θ`.
    #[inline]
    pub fn may_light(&self, p: Vec3) -> bool {
        let b = &self.bounds;
        if self.sky.is_some() {
            return true;
        }
        if self.table.is_none() {
            return false;
        }
        if b.threshold <= -1.0 {
            return true;
        }
        (0..8).any(|corner| {
            let q = Vec3::new(
                if corner & 1 == 0 { b.lo.x } else { b.hi.x },
                if corner & 2 == 0 { b.lo.y } else { b.hi.y },
                if corner & 4 == 0 { b.lo.z } else { b.hi.z },
            );
            let v = p - q;
            let length = v.length();
            length == 0.0 || v.dot(b.axis) > b.threshold * length
        })
    }

    /// Whether there is anything to sample.
    pub fn is_empty(&self) -> bool {
        self.table.is_none() && self.sky.is_none()
    }

    /// Number of emissive triangles that can be chosen or hit.
    pub fn len(&self) -> usize {
        self.prims.len()
    }

    /// Density per unit area of sampled points on triangle `prim` (0 for non-emitters):
    /// O(log n) by binary search over the sorted emitter list.
    #[inline]
    pub fn area_density(&self, prim: u32) -> f32 {
        self.emitter(prim).map_or(0.0, |e| e.area_density)
    }

    #[inline]
    fn emitter(&self, prim: u32) -> Option<&Emitter> {
        self.prims
            .binary_search(&prim)
            .ok()
            .map(|i| &self.emitters[i])
    }

    /// A point on a light for the shading point `origin`, or `None` when there are no
    /// lights or the chosen point faces away from `origin` (a sample worth nothing).
    #[inline]
    pub fn sample(&self, origin: Vec3, rng: &mut Rng) -> Option<LightSample> {
        // One 2-D draw chooses the sky or an emitter, and the point on it (see
        // AliasTable::sample).
        let (u1, u2) = rng.pair();
        if u1 < self.sky_probability {
            let u1 = (u1 / self.sky_probability).min(ONE_BELOW);
            return self.sample_sky(rng.refine(u1), rng.refine(u2));
        }
        let u1 = (u1 - self.sky_probability) / (1.0 - self.sky_probability);
        let table = self.table.as_ref()?;
        let (i, u1) = table.sample(rng.refine(u1.min(ONE_BELOW)));
        let emitter = &self.emitters[i];
        let (b1, b2) = uniform_triangle(u1, u2);
        let b = [1.0 - b1 - b2, b1, b2];
        let [v0, v1, v2] = emitter.vertices;
        let point = b[0] * v0 + b[1] * v1 + b[2] * v2;
        let to_light = point - origin;
        let distance_squared = to_light.length_squared();
        let distance = distance_squared.sqrt();
        if distance.is_nan() || distance <= 0.0 {
            return None;
        }
        let dir = to_light / distance;
        let cos_light = -dir.dot(emitter.normal);
        if cos_light.is_nan() || cos_light <= 0.0 {
            return None;
        }
        let pdf = emitter.area_density * distance_squared / cos_light;
        if !pdf.is_finite() || pdf <= 0.0 {
            return None;
        }
        Some(LightSample {
            dir,
            distance,
            point: Some(SurfaceOrigin {
                p: point,
                error: barycentric_error(b, emitter.vertices),
                ng: emitter.normal,
            }),
            pdf,
            target: LightTarget::Emitter(self.prims[i]),
            emission: self.emission_at(emitter, b),
        })
    }

    /// The radiance an emitter emits at barycentrics `b`.
    #[inline]
    fn emission_at(&self, emitter: &Emitter, b: [f32; 3]) -> Vec3 {
        if emitter.map == NO_MAP {
            return emitter.emission;
        }
        let [u0, u1, u2] = emitter.uvs;
        let uv = b[0] * u0 + b[1] * u1 + b[2] * u2;
        emitter.emission * self.maps[emitter.map as usize].sample(uv).max(Vec3::ZERO)
    }

    fn sample_sky(&self, u_row: f64, u_column: f64) -> Option<LightSample> {
        let sample = self.sky.as_ref()?.sample(u_row, u_column)?;
        Some(LightSample {
            dir: sample.dir,
            distance: f32::INFINITY,
            point: None,
            pdf: self.sky_probability * sample.pdf,
            target: LightTarget::Sky,
            emission: sample.radiance,
        })
    }

    /// The solid-angle density with which [`sample`](Self::sample) picks `dir`
    /// towards the sky (0 without one).
    #[inline]
    pub fn pdf_sky(&self, dir: Vec3) -> f32 {
        self.sky
            .as_ref()
            .map_or(0.0, |sky| self.sky_probability * sky.pdf(dir))
    }

    /// The solid-angle density with which [`sample`](Self::sample) picks the point
    /// where a ray along unit `dir` first hits triangle `prim` at distance `distance`
    /// (0 when `prim` is no light or is seen from behind).
    #[inline]
    pub fn pdf_hit(&self, prim: u32, dir: Vec3, distance: f32) -> f32 {
        let Some(emitter) = self.emitter(prim) else {
            return 0.0;
        };
        let cos_light = -dir.dot(emitter.normal);
        if cos_light > 0.0 {
            emitter.area_density * distance * distance / cos_light
        } else {
            0.0
        }
    }
}

/// The largest `f32` below 1: rescaled uniforms can round up to 1.0.
const ONE_BELOW: f32 = 1.0 - f32::EPSILON / 2.0;
