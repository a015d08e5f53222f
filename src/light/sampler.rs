//! Choosing points on a scene's emissive triangles, and the solid-angle density of
//! doing so: the light half of "Ray Tracing: The Rest of Your Life", made to scale.
//!
//! A light sample first chooses the sky or an emitter (the sky by its share of the
//! estimated power). [`LightSamplerKind::Alias`] (the default with few emitters) then
//! chooses an emitter in proportion to power from an alias table and a uniform point on
//! its area, with nothing on its path that depends on the receiver but the distance
//! and cosine.
//! The others choose by the same table ([`LightSamplerKind::SolidAngle`]) or by a
//! [`LightBvh`] that weighs each emitter's power, distance and orientation as seen
//! from the receiver ([`LightSamplerKind::Bvh`]), then a direction by solid angle or
//! by area as [`Emitter`]'s rule decides.
//! Power is area × luminance of `Ke`, times the mean of the `map_Ke` texture when
//! there is one. The density of a direction is
//! `(1 − P_sky) · P(emitter | receiver) · p(direction | emitter, receiver)`, and
//! [`pdf_hit`](LightSampler::pdf_hit) computes exactly that for any direction, so MIS
//! and the mixture weigh each sample by the density it was drawn with.
//!
//! A textured emitter's radiance at the sampled point is read from its texture, as it
//! is where a ray hits it, so next-event estimation and emission found by BSDF rays
//! agree; only the choice of triangle uses the texture's mean.
//!
//! Emitters are one-sided unless their material says otherwise: they emit on the side
//! their counter-clockwise normal points to, and a point seen from behind has density
//! 0 (it is never a useful light sample). A two-sided emitter (glTF's `doubleSided`,
//! a scene file's `two-sided` light) emits from both faces: its power `2π A L` doubles
//! its weight in the choice, every density takes `|cos|` at the emitter, and the light
//! BVH mirrors its orientation cone (see [`super::bvh`]), so that
//! [`pdf_hit`](LightSampler::pdf_hit) stays the exact density of either side.
//!
//! The scene's point and spot lights are chosen with the emitters, after them in the
//! same table or tree; its suns with the sky, the two together chosen against the rest
//! as the sky alone would be. A delta light's sample carries the probability of its one
//! direction as its `pdf` (see [`super::placed`]).

use glam::{Vec2, Vec3};

use std::f32::consts::PI;
use std::sync::Arc;
use std::time::{Duration, Instant};

use super::bvh::{LightBounds, LightBvh};
use super::emitter::{Emitter, Receiver, NO_MAP};
use super::placed::{point_bounds, point_towards, point_weight, sun_power, Sun};
use crate::color::luminance;
use crate::geometry::{barycentric_error, SurfaceOrigin};
use crate::sampling::{choose_second, AliasTable, Rng, ONE_BELOW};
use crate::scene::{
    DirectionalLight, Environment, Light, Material, PointLight, Scene, Texture, TriangleMesh,
};

/// Directions towards the sky learnt outside the light module (path guiding's, at one
/// vertex: where light was found to arrive from, so where the sky is seen rather than
/// hidden by walls), which sky sampling can draw from beside the sky's own distribution.
pub trait SkyGuide {
    /// A unit direction from two uniforms in `[0, 1)`, and its density.
    fn sample_with_pdf(&self, u: Vec2) -> (Vec3, f32);
    /// Density per steradian of [`sample_with_pdf`](Self::sample_with_pdf) at the unit
    /// direction `dir`.
    fn pdf(&self, dir: Vec3) -> f32;
}

/// How an emitter and a point on it are chosen for a light sample.
///
/// The default, [`Auto`](LightSamplerKind::Auto), is the light BVH in scenes of at
/// least [`BVH_MIN_EMITTERS`] emissive triangles and version 10's alias table below,
/// so that the BVH is used only where it was measured no less efficient: with a few
/// emitters its choice buys nothing and costs time; with hundreds spread through a
/// scene it lowers the error many times over (benches/results/2026-12-02-light-sampling.md).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum LightSamplerKind {
    /// [`Bvh`](Self::Bvh) with at least [`BVH_MIN_EMITTERS`] emitters, else
    /// [`Alias`](Self::Alias) (see [`resolve`](Self::resolve)).
    #[default]
    Auto,
    /// In proportion to power, wherever the receiver is (one alias table), then a
    /// uniform point on the triangle's area: the sampler of ALGORITHM_VERSION 10.
    Alias,
    /// The same alias table, then a direction by solid angle where [`Emitter`]'s rule
    /// says it pays.
    SolidAngle,
    /// By a light BVH's importance at the receiver (power, distance, orientation),
    /// then [`Emitter`]'s solid-angle rule.
    Bvh,
}

/// The fewest emissive triangles with which [`LightSamplerKind::Auto`] uses the
/// light BVH: the smallest count measured where the BVH was not less efficient than
/// the alias table (see [`LightSamplerKind`]). A count is a proxy: what makes the BVH
/// pay is lights spread through the scene, so that distance and orientation tell
/// them apart; one finely cut panel of more triangles would still get the BVH.
pub const BVH_MIN_EMITTERS: usize = 512;

impl LightSamplerKind {
    /// Every choice, the default first.
    pub const ALL: [LightSamplerKind; 4] = [
        LightSamplerKind::Auto,
        LightSamplerKind::Alias,
        LightSamplerKind::SolidAngle,
        LightSamplerKind::Bvh,
    ];

    /// The sampler this choice means in a scene of `emitters` emissive triangles:
    /// itself, except that [`Auto`](Self::Auto) becomes the BVH or the alias table.
    pub fn resolve(self, emitters: usize) -> LightSamplerKind {
        match self {
            LightSamplerKind::Auto if emitters >= BVH_MIN_EMITTERS => LightSamplerKind::Bvh,
            LightSamplerKind::Auto => LightSamplerKind::Alias,
            other => other,
        }
    }
}

/// The scene's emitters with a distribution over them.
#[derive(Clone, Debug, Default)]
pub struct LightSampler {
    /// Global triangle index of each emitter, ascending (as in `Scene::emitters`).
    prims: Vec<u32>,
    /// What sampling needs of each emitter, copied out of the mesh so that a sample
    /// touches one small record instead of indices, vertices and materials.
    emitters: Vec<Emitter>,
    /// The scene's textures, for the `map_Ke` of emitters (`Emitter::map`).
    maps: Vec<Arc<Texture>>,
    /// Point and spot lights, chosen with the emitters by the same table or tree:
    /// choice `emitters.len() + k` is `points[k]`.
    points: Vec<PointLight>,
    /// Index in the scene's `lights` of each of `points`, and of each of `suns`.
    point_ids: Vec<u32>,
    sun_ids: Vec<u32>,
    /// Over the emitters and point lights; `None` when none has power.
    choice: Option<Choice>,
    /// `π Σ A·lum(Ke)` over the emitters (twice that for two-sided ones) and `lum(Φ)`
    /// over the point lights: their power, weighed against the sky's and the suns'.
    power: f32,
    /// Where the emitters are and which way they face, to tell cheaply which points
    /// no emitter can light (see [`may_light`](Self::may_light)).
    bounds: EmitterBounds,
    /// Light from infinitely far away, chosen with probability `sky_probability`
    /// instead of an emitter.
    sky: Option<Arc<Environment>>,
    sky_probability: f32,
    /// Directional lights, as [`with_sky`](Self::with_sky) found them; then the suns
    /// it chose by power (`None`: none is sampled), chosen after the sky with
    /// probability `sun_given_rest`, each then with probability `sun_probability`
    /// in all.
    sun_lights: Vec<DirectionalLight>,
    suns: Vec<Sun>,
    sun_table: Option<AliasTable>,
    sun_given_rest: f32,
    sun_probability: Vec<f32>,
    /// Whether a sun has a disc that rays leaving the scene may meet.
    sun_discs: bool,
    /// Whether an emitter of some power, the sky or a sun's disc can be sampled.
    hittable: bool,
    /// Whether a point light or a sun without a disc can be sampled.
    delta: bool,
    /// The probability of choosing the emitters and point lights (rather than the sky
    /// or a sun): `1 − P_sky` without suns.
    local_probability: f32,
    /// Wall time the distribution over emitters took to build.
    build_time: Duration,
}

/// The distribution over emitters and the way a point is drawn on the chosen one,
/// matched once per light sample.
#[derive(Clone, Debug)]
enum Choice {
    /// Alias table, uniform point on the area ([`LightSamplerKind::Alias`]).
    Area(AliasTable),
    /// Alias table, solid-angle rule ([`LightSamplerKind::SolidAngle`]).
    SolidAngle(AliasTable),
    /// Light BVH, solid-angle rule ([`LightSamplerKind::Bvh`]).
    Bvh(LightBvh),
}

/// What a light sample is aimed at.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum LightTarget {
    /// A point on this emissive triangle.
    Emitter(u32),
    /// The environment: the direction must leave the scene.
    Sky,
    /// A sun's disc: the light of this index in `Scene::lights`; the direction must
    /// leave the scene.
    Light(u32),
    /// A delta light (a point, a spot, a sun without a disc) of this index in
    /// `Scene::lights`: the sample's `pdf` is the probability of its one direction, no
    /// ray can find the light, and the sample's MIS weight is 1.
    Delta(u32),
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
        // A two-sided emitter lights both half-spaces: only its plane stays dark.
        let two_sided = emitters.iter().any(|e| e.two_sided);
        if axis == Vec3::ZERO || emitters.is_empty() || cos_theta <= 0.0 || two_sided {
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
    /// Radiance the light point emits towards the shading point; for a delta light,
    /// the irradiance it sends there (`I/d²`, or a sun's `E`).
    pub emission: Vec3,
}

impl LightSample {
    /// Whether it is a delta light's sample ([`LightTarget::Delta`]).
    #[inline(always)]
    pub fn is_delta(&self) -> bool {
        matches!(self.target, LightTarget::Delta(_))
    }
}

/// A light sample of [`LightSampler::draw_with_sky_guide`]: complete (an emitter's),
/// or a sky direction still to be completed ([`LightSampler::complete`]).
#[derive(Clone, Copy, Debug)]
pub enum GuidedLightDraw {
    Complete(LightSample),
    Sky(SkyDraw),
}

impl GuidedLightDraw {
    /// The unit direction towards the light.
    #[inline]
    pub fn dir(&self) -> Vec3 {
        match self {
            GuidedLightDraw::Complete(sample) => sample.dir,
            GuidedLightDraw::Sky(draw) => draw.dir,
        }
    }

    /// The point on the light a shadow ray ends at (`None` for the sky, at infinity).
    #[inline]
    pub fn point(&self) -> Option<SurfaceOrigin> {
        match self {
            GuidedLightDraw::Complete(sample) => sample.point,
            GuidedLightDraw::Sky(_) => None,
        }
    }
}

/// A sky direction drawn at a guided vertex, before its radiance and its density are
/// looked up ([`LightSampler::complete`]). Both are a cache miss or a quadtree
/// descent, and a sample whose shadow ray is blocked needs neither: in the
/// grey-white room that is most of them.
#[derive(Clone, Copy, Debug)]
pub struct SkyDraw {
    dir: Vec3,
    known: SkyDrawKnown,
}

/// What a light sample's first uniform chose, and that uniform rescaled for the
/// choice's own draw.
#[derive(Clone, Copy, Debug)]
enum SkyOrEmitter {
    Sky(f32),
    Sun(f32),
    Emitter(f32),
}

/// What the draw of a [`SkyDraw`] found on the way: the guide's density (a draw from
/// the guide) or the texel's radiance (a draw from the sky's own distribution).
#[derive(Clone, Copy, Debug)]
enum SkyDrawKnown {
    GuidePdf(f32),
    Radiance(Vec3),
}

impl LightSampler {
    /// The default sampler ([`LightSamplerKind::Auto`]) over the triangles of `mesh`
    /// whose material emits; `textures` are the scene's, for `map_Ke`.
    pub fn new(mesh: &TriangleMesh, materials: &[Material], textures: &[Arc<Texture>]) -> Self {
        Self::with_kind(mesh, materials, textures, LightSamplerKind::default())
    }

    /// The sampler over the emitters of `mesh` that chooses them as `kind` says
    /// (built once per scene: O(n) for the alias table, O(n log n) for the BVH).
    pub fn with_kind(
        mesh: &TriangleMesh,
        materials: &[Material],
        textures: &[Arc<Texture>],
        kind: LightSamplerKind,
    ) -> Self {
        Self::with_lights(mesh, materials, textures, &[], kind)
    }

    /// The sampler of everything that lights `scene`: its emitters and placed lights
    /// (chosen as `kind` says) and its sky.
    pub fn for_scene(scene: &Scene, kind: LightSamplerKind) -> Self {
        Self::with_lights(
            scene.light_mesh(),
            &scene.materials,
            &scene.textures,
            &scene.lights,
            kind,
        )
        .with_sky(scene.sky.clone(), scene.bounding_radius())
    }

    /// [`with_kind`](Self::with_kind) with the scene's `lights` that are not
    /// geometry: points and spots are chosen with the emitters, in proportion to
    /// power by the alias table (their weight `lum(Φ)/π`, as a triangle's `A·lum(L)`
    /// is), or by the light BVH as a point's bounds; suns are far lights, chosen
    /// against the sky once [`with_sky`](Self::with_sky) knows the scene's size.
    fn with_lights(
        mesh: &TriangleMesh,
        materials: &[Material],
        textures: &[Arc<Texture>],
        lights: &[Light],
        kind: LightSamplerKind,
    ) -> Self {
        let (mut points, mut point_ids, mut sun_lights, mut sun_ids) =
            (vec![], vec![], vec![], vec![]);
        for (id, light) in lights.iter().enumerate() {
            match light {
                Light::Point(point) => {
                    points.push(*point);
                    point_ids.push(id as u32);
                }
                Light::Directional(sun) => {
                    sun_lights.push(*sun);
                    sun_ids.push(id as u32);
                }
            }
        }
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
        let emitters: Vec<Emitter> = prims
            .iter()
            .map(|&t| {
                let m = material(t);
                Emitter::new(
                    mesh.vertices(t),
                    m.emission,
                    m.maps.emission.unwrap_or(NO_MAP),
                    mesh.corner_uvs(t),
                    m.two_sided_emission,
                )
            })
            .collect();
        let weights: Vec<f32> = prims
            .iter()
            .map(|&t| {
                let m = material(t);
                let mean = m.emission * mean_of(m.maps.emission);
                mesh.area(t) * luminance(mean).max(0.0) * m.emitting_faces()
            })
            .chain(points.iter().map(|p| point_weight(p).max(0.0)))
            .collect();
        let start = Instant::now();
        let choice = match kind.resolve(prims.len() + points.len()) {
            LightSamplerKind::Auto => unreachable!("resolved above"),
            LightSamplerKind::Alias => AliasTable::new(&weights).map(Choice::Area),
            LightSamplerKind::SolidAngle => AliasTable::new(&weights).map(Choice::SolidAngle),
            LightSamplerKind::Bvh => {
                let bounds: Vec<LightBounds> = emitters
                    .iter()
                    .zip(&weights)
                    .map(|(e, &w)| {
                        let bounds = LightBounds::triangle(e.vertices, e.normal, w);
                        if e.two_sided {
                            bounds.two_sided()
                        } else {
                            bounds
                        }
                    })
                    .chain(points.iter().map(point_bounds))
                    .collect();
                LightBvh::new(&bounds).map(Choice::Bvh)
            }
        };
        let mut emitters = emitters;
        if let Some(Choice::Area(table)) = &choice {
            for (i, e) in emitters.iter_mut().enumerate() {
                e.area_density = if e.area > 0.0 {
                    table.pmf(i) / e.area
                } else {
                    0.0
                };
            }
        }
        let hittable = weights[..prims.len()]
            .iter()
            .any(|&w| w > 0.0 && w.is_finite());
        let delta = !points.is_empty();
        LightSampler {
            prims,
            bounds: EmitterBounds::new(&emitters),
            emitters,
            maps: textures.to_vec(),
            points,
            point_ids,
            sun_ids,
            choice,
            power: PI * weights.iter().sum::<f32>(),
            sky: None,
            sky_probability: 0.0,
            sun_lights,
            suns: Vec::new(),
            sun_table: None,
            sun_given_rest: 0.0,
            sun_probability: Vec::new(),
            sun_discs: false,
            hittable,
            delta,
            local_probability: 1.0,
            build_time: start.elapsed(),
        }
    }

    /// Adds the environment `sky` as a light, chosen against the emitters in
    /// proportion to estimated power: the emitters' `π Σ A·lum(Ke)` against the sky's
    /// `∫ lum(L) dω` through a disc of the scene's bounding radius, `π r²`.
    ///
    /// With suns, the sky and the suns together are the far lights, chosen against
    /// the emitters and point lights as the sky alone would be, and among themselves
    /// in proportion to power: a sun's `lum(E)` through the same disc.
    pub fn with_sky(mut self, sky: Option<Arc<Environment>>, scene_radius: f32) -> Self {
        let sky = sky.filter(|s| !s.is_black());
        if !self.sun_lights.is_empty() {
            return self.with_far_lights(sky, scene_radius);
        }
        let Some(sky) = sky else {
            return self;
        };
        let sky_power = sky.luminous_intensity() * PI * scene_radius.max(1e-6).powi(2);
        let p = if self.choice.is_none() {
            1.0
        } else {
            (sky_power / (sky_power + self.power)).clamp(0.05, 0.95)
        };
        self.local_probability = 1.0 - p;
        for e in &mut self.emitters {
            e.area_density *= self.local_probability;
        }
        self.sky = Some(sky);
        self.sky_probability = p;
        self.hittable = true;
        self
    }

    /// [`with_sky`](Self::with_sky) where there are suns.
    fn with_far_lights(mut self, sky: Option<Arc<Environment>>, scene_radius: f32) -> Self {
        let area = PI * scene_radius.max(1e-6).powi(2);
        let sky_power = sky.as_ref().map_or(0.0, |s| s.luminous_intensity() * area);
        let sun_powers: Vec<f32> = self
            .sun_lights
            .iter()
            .map(|l| sun_power(l, scene_radius))
            .collect();
        let Some(table) = AliasTable::new(&sun_powers) else {
            // Black suns light nothing: the sky alone is the far light.
            self.sun_lights.clear();
            return self.with_sky(sky, scene_radius);
        };
        let suns_power: f32 = sun_powers.iter().sum();
        let far_power = sky_power + suns_power;
        let p_far = if self.choice.is_none() {
            1.0
        } else {
            (far_power / (far_power + self.power)).clamp(0.05, 0.95)
        };
        let p_sky = match sky {
            Some(_) => p_far * (sky_power / far_power),
            None => 0.0,
        };
        self.sun_given_rest = if self.choice.is_none() {
            1.0
        } else {
            ((p_far - p_sky) / (1.0 - p_sky)).clamp(0.0, 1.0)
        };
        self.local_probability = (1.0 - p_sky) * (1.0 - self.sun_given_rest);
        for e in &mut self.emitters {
            e.area_density *= self.local_probability;
        }
        let to_suns = (1.0 - p_sky) * self.sun_given_rest;
        self.sun_probability = (0..sun_powers.len())
            .map(|k| to_suns * table.pmf(k))
            .collect();
        self.suns = self.sun_lights.iter().map(Sun::new).collect();
        self.sun_discs = self.suns.iter().any(|s| !s.is_delta());
        self.hittable |= self.sun_discs || sky.is_some();
        self.delta |= self.suns.iter().any(Sun::is_delta);
        self.sun_table = Some(table);
        self.sky = sky;
        self.sky_probability = p_sky;
        self
    }

    /// How emitters are chosen (`None` without emitters of positive power).
    pub fn kind(&self) -> Option<LightSamplerKind> {
        self.choice.as_ref().map(|c| match c {
            Choice::Area(_) => LightSamplerKind::Alias,
            Choice::SolidAngle(_) => LightSamplerKind::SolidAngle,
            Choice::Bvh(_) => LightSamplerKind::Bvh,
        })
    }

    /// What building the distribution over emitters cost: wall time, and the number
    /// of BVH nodes (0 for the alias table).
    pub fn build_cost(&self) -> (Duration, usize) {
        let nodes = match &self.choice {
            Some(Choice::Bvh(bvh)) => bvh.node_count(),
            _ => 0,
        };
        (self.build_time, nodes)
    }

    /// Whether some emitter might light point `p`, that is have `p` on its emitting
    /// side (any point, with a two-sided emitter). `false` is certain: every emitter
    /// faces away from `p`, so light samples from there are worthless and the
    /// integrators skip them. (Exact for the Cornell box, whose ceiling lies behind its
    /// one-sided light.)
    ///
    /// Conservative test in O(1): `p` may be lit by an emitter point `q` with normal
    /// `n` when `(p − q) · n > 0`. Over `q` in the emitters' box and `n` in their
    /// normal cone (axis `a`, half-angle θ), the largest `(p − q) · n` is reached at
    /// a corner `q` of the box, where it is positive iff the angle between `p − q`
    /// and `a` is below 90° + θ, i.e. `(p − q)/|p − q| · a > −sin θ`.
    #[inline(always)]
    pub fn may_light(&self, p: Vec3) -> bool {
        let b = &self.bounds;
        if self.sky.is_some() || self.sun_table.is_some() || !self.points.is_empty() {
            return true;
        }
        if self.choice.is_none() {
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
        self.choice.is_none() && self.sky.is_none() && self.sun_table.is_none()
    }

    /// Whether some light is a delta light (a point, a spot, a sun without a disc),
    /// which only light samples can reach.
    #[inline(always)]
    pub fn has_delta_lights(&self) -> bool {
        self.delta
    }

    /// Whether some light can be found by a ray too (an emitter, the sky, a sun's
    /// disc): a light sample that is not a delta light's can be drawn.
    #[inline(always)]
    pub fn has_hittable_lights(&self) -> bool {
        self.hittable
    }

    /// Number of emissive triangles that can be chosen or hit.
    pub fn len(&self) -> usize {
        self.prims.len()
    }

    /// Index of triangle `prim` among the emitters: O(log n) by binary search over the
    /// sorted emitter list.
    #[inline]
    fn emitter_index(&self, prim: u32) -> Option<usize> {
        self.prims.binary_search(&prim).ok()
    }

    /// Whether light samples from `at` towards emissive triangle `prim` are drawn by
    /// solid angle (`false`: by area, or not at all).
    pub fn samples_by_solid_angle(&self, at: Receiver, prim: u32) -> bool {
        !matches!(self.choice, None | Some(Choice::Area(_)))
            && self
                .emitter_index(prim)
                .is_some_and(|i| self.emitters[i].samples_by_solid_angle(at))
    }

    /// Probability that [`sample`](Self::sample) at `at` aims at emissive triangle
    /// `prim` (0 for other triangles). Over all emitters and the sky it sums to 1
    /// wherever some light can be chosen.
    #[inline]
    pub fn choice_probability(&self, at: Receiver, prim: u32) -> f32 {
        self.emitter_index(prim)
            .map_or(0.0, |i| self.local_probability * self.chosen(at, i))
    }

    /// Probability of emitter `i` given that an emitter (not the sky) is chosen.
    #[inline]
    fn chosen(&self, at: Receiver, i: usize) -> f32 {
        match &self.choice {
            None => 0.0,
            Some(Choice::Area(table) | Choice::SolidAngle(table)) => table.pmf(i),
            Some(Choice::Bvh(bvh)) => bvh.probability(at.p, at.n, i),
        }
    }

    /// Chooses an emitter from uniform `u`: its index, its probability (given that an
    /// emitter is chosen) and `u` rescaled to a fresh uniform.
    #[inline]
    fn choose(&self, at: Receiver, u: f64) -> Option<(usize, f32, f32)> {
        match self.choice.as_ref()? {
            Choice::Area(table) | Choice::SolidAngle(table) => {
                let (i, rest) = table.sample(u);
                Some((i, table.pmf(i), rest))
            }
            Choice::Bvh(bvh) => {
                let (i, probability, rest) = bvh.sample(at.p, at.n, u);
                Some((i, probability, (rest as f32).min(ONE_BELOW)))
            }
        }
    }

    /// A point on a light for the receiver `at`, or `None` when there are no lights
    /// or the chosen point faces away from `at` (a sample worth nothing).
    #[inline]
    pub fn sample(&self, at: Receiver, rng: &mut Rng) -> Option<LightSample> {
        // One 2-D draw chooses the sky or an emitter, and the point on it (see
        // AliasTable::sample).
        let (choice, u2) = self.choose_sky_or_emitter(rng);
        match choice {
            SkyOrEmitter::Sky(u1) => self.sample_sky(rng.refine(u1), rng.refine(u2)),
            SkyOrEmitter::Sun(u1) => self.sample_sun((u1, u2), rng),
            SkyOrEmitter::Emitter(u1) => self.sample_emitter(at, (u1, u2), rng),
        }
    }

    /// A hint with no effect on any result: where the next light sample drawn from
    /// `stream` would draw from the sky's own distribution, starts loading the texel it
    /// reads first ([`Environment::prefetch`]). `guide_share` is as for
    /// [`sky_uniforms_ahead`](Self::sky_uniforms_ahead).
    #[inline]
    pub fn prefetch_sky_sample(&self, stream: Rng, guide_share: Option<f32>) {
        if let (Some(sky), Some((u_row, u_column))) = (
            self.sky.as_ref(),
            self.sky_uniforms_ahead(stream, guide_share),
        ) {
            sky.prefetch(u_row, u_column);
        }
    }

    /// The uniforms with which the next light sample drawn from `stream` (a copy of
    /// a path's stream, replayed here) would draw from the sky's own distribution
    /// ([`Environment::sample`]): for a sample of
    /// [`draw_with_sky_guide`](Self::draw_with_sky_guide) with the share
    /// `guide_share`, or of [`sample`](Self::sample) for `None`. `None` where that
    /// sample would pick an emitter or the guide, and where the next draws are
    /// stratified (the copy would compute their set a second time).
    #[inline]
    pub fn sky_uniforms_ahead(
        &self,
        mut ahead: Rng,
        guide_share: Option<f32>,
    ) -> Option<(f64, f64)> {
        if self.sky.is_none() || ahead.stratified_ahead() {
            return None;
        }
        let (SkyOrEmitter::Sky(mut u1), u2) = self.choose_sky_or_emitter(&mut ahead) else {
            return None;
        };
        // As `draw_guided_sky` chooses between the guide and the sky.
        if guide_share.is_some_and(|share| !choose_second(&mut u1, share)) {
            return None;
        }
        Some((ahead.refine(u1), ahead.refine(u2)))
    }

    /// [`sample`](Self::sample), except that where the sky is chosen, its direction
    /// comes with probability `share` from `guide` (directions learnt elsewhere, e.g.
    /// where the sky is seen from `at`) and otherwise from the sky's own distribution:
    /// the sample's density is the mixture's ([`pdf_sky_guided`](Self::pdf_sky_guided)).
    /// With a sky sample comes the guide's density along its direction, which the
    /// caller need not look up again.
    #[inline]
    pub fn sample_with_sky_guide(
        &self,
        at: Receiver,
        rng: &mut Rng,
        share: f32,
        guide: &impl SkyGuide,
    ) -> Option<(LightSample, Option<f32>)> {
        let drawn = self.draw_with_sky_guide(at, rng, share, guide)?;
        self.complete(drawn, share, guide)
    }

    /// [`sample_with_sky_guide`](Self::sample_with_sky_guide)'s draw, a sky
    /// direction's radiance and density left to [`complete`](Self::complete):
    /// most sky samples in a room meet a wall, and these need neither (see
    /// [`SkyDraw`]).
    #[inline]
    pub fn draw_with_sky_guide(
        &self,
        at: Receiver,
        rng: &mut Rng,
        share: f32,
        guide: &impl SkyGuide,
    ) -> Option<GuidedLightDraw> {
        match self.choose_sky_or_emitter(rng) {
            (SkyOrEmitter::Sky(u1), u2) => self
                .draw_guided_sky((u1, u2), share, guide, rng)
                .map(GuidedLightDraw::Sky),
            (SkyOrEmitter::Sun(u1), u2) => {
                let sun = self.sample_sun((u1, u2), rng)?;
                Some(GuidedLightDraw::Complete(sun))
            }
            (SkyOrEmitter::Emitter(u1), u2) => {
                let emitter = self.sample_emitter(at, (u1, u2), rng)?;
                Some(GuidedLightDraw::Complete(emitter))
            }
        }
    }

    /// A light sample's 2-D draw, its first uniform choosing the sky (with
    /// probability [`sky_probability`](Self::sky_probability)), else a sun or an
    /// emitter (or point light), and rescaled to a fresh uniform for the choice's own
    /// draw.
    #[inline(always)]
    fn choose_sky_or_emitter(&self, rng: &mut Rng) -> (SkyOrEmitter, f32) {
        let (mut u1, u2) = rng.pair();
        let emitter = choose_second(&mut u1, self.sky_probability);
        let choice = if !emitter {
            SkyOrEmitter::Sky(u1)
        } else if self.sun_given_rest > 0.0 && !choose_second(&mut u1, self.sun_given_rest) {
            SkyOrEmitter::Sun(u1)
        } else {
            SkyOrEmitter::Emitter(u1)
        };
        (choice, u2)
    }

    /// The light sample of `drawn` (drawn with the same `share` and `guide`), and the
    /// guide's density along a sky sample's direction; `None` where a sky sample's
    /// density is not positive (a sample worth nothing).
    #[inline]
    pub fn complete(
        &self,
        drawn: GuidedLightDraw,
        share: f32,
        guide: &impl SkyGuide,
    ) -> Option<(LightSample, Option<f32>)> {
        match drawn {
            GuidedLightDraw::Complete(sample) => Some((sample, None)),
            GuidedLightDraw::Sky(draw) => {
                let (sample, guide_pdf) = self.complete_sky(draw, share, guide)?;
                Some((sample, Some(guide_pdf)))
            }
        }
    }

    /// The emitter half of [`sample`](Self::sample), from its 2-D draw (the first
    /// uniform as [`choose_sky_or_emitter`](Self::choose_sky_or_emitter) left it).
    #[inline(always)]
    fn sample_emitter(
        &self,
        at: Receiver,
        (u1, u2): (f32, f32),
        rng: &mut Rng,
    ) -> Option<LightSample> {
        let u1 = rng.refine(u1);
        let (i, pdf, drawn) = match self.choice.as_ref()? {
            // The default: no receiver-dependent choice, no solid-angle rule on its path
            // (`area_density` already holds the sky's share and the table's pmf).
            Choice::Area(table) => {
                let (i, u1) = table.sample(u1);
                if i >= self.emitters.len() {
                    return self.sample_point(at, i, table.pmf(i));
                }
                let drawn = self.emitters[i].sample_area(at.p, [u1, u2])?;
                (i, drawn.density, drawn)
            }
            Choice::SolidAngle(_) | Choice::Bvh(_) => {
                let (i, probability, u1) = self.choose(at, u1)?;
                if i >= self.emitters.len() {
                    return self.sample_point(at, i, probability);
                }
                let drawn = self.emitters[i].sample(at, [u1, u2])?;
                let pdf = self.local_probability * probability * drawn.density;
                (i, pdf, drawn)
            }
        };
        let emitter = &self.emitters[i];
        if !pdf.is_finite() || pdf <= 0.0 {
            return None;
        }
        Some(LightSample {
            dir: drawn.dir,
            distance: drawn.distance,
            point: Some(SurfaceOrigin {
                p: drawn.point,
                error: barycentric_error(drawn.b, emitter.vertices),
                ng: emitter.normal,
            }),
            pdf,
            target: LightTarget::Emitter(self.prims[i]),
            emission: self.emission_at(emitter, drawn.b),
        })
    }

    /// The light sample of point light `i` (numbered after the emitters), chosen with
    /// `probability` given that an emitter or point light is: the light it sends to
    /// the receiver, over the probability of choosing it.
    #[inline(never)]
    fn sample_point(&self, at: Receiver, i: usize, probability: f32) -> Option<LightSample> {
        let k = i - self.emitters.len();
        let light = &self.points[k];
        let (dir, distance, arriving) = point_towards(light, at.p)?;
        let pdf = self.local_probability * probability;
        (pdf.is_finite() && pdf > 0.0).then_some(LightSample {
            dir,
            distance,
            point: Some(SurfaceOrigin {
                p: light.position,
                error: Vec3::ZERO,
                ng: -dir,
            }),
            pdf,
            target: LightTarget::Delta(self.point_ids[k]),
            emission: arriving,
        })
    }

    /// A sun's light sample, from the 2-D draw that chose the suns: one of them by
    /// power, then its one direction (a delta sun: `pdf` is the probability of
    /// choosing it) or a direction in its disc.
    #[inline(never)]
    fn sample_sun(&self, (u1, u2): (f32, f32), rng: &mut Rng) -> Option<LightSample> {
        let (k, u1) = self.sun_table.as_ref()?.sample(rng.refine(u1));
        let sun = &self.suns[k];
        let (dir, density) = sun.sample([u1, u2]);
        let pdf = match sun.is_delta() {
            true => self.sun_probability[k],
            false => self.sun_probability[k] * density,
        };
        (pdf.is_finite() && pdf > 0.0).then_some(LightSample {
            dir,
            distance: f32::INFINITY,
            point: None,
            pdf,
            target: match sun.is_delta() {
                true => LightTarget::Delta(self.sun_ids[k]),
                false => LightTarget::Light(self.sun_ids[k]),
            },
            emission: sun.emission,
        })
    }

    /// Whether some sun has a disc that a ray leaving the scene may meet.
    #[inline]
    pub fn has_sun_discs(&self) -> bool {
        self.sun_discs
    }

    /// The suns' discs that unit `dir` lies in: each one's radiance and the density
    /// with which [`sample`](Self::sample) picks `dir` by it (its MIS weight against
    /// BSDF sampling is per sun, as each emitter's is).
    #[inline]
    pub fn suns_along(&self, dir: Vec3) -> impl Iterator<Item = (Vec3, f32)> + '_ {
        self.suns
            .iter()
            .zip(&self.sun_probability)
            .filter(move |(sun, _)| sun.contains(dir))
            .map(move |(sun, p)| (sun.emission, p * sun.density(dir)))
    }

    /// The density with which [`sample`](Self::sample) picks `dir` towards a sun's
    /// disc (0 without any).
    #[inline]
    pub fn pdf_suns(&self, dir: Vec3) -> f32 {
        self.suns_along(dir).map(|(_, pdf)| pdf).sum()
    }

    /// The density with which [`sample`](Self::sample) picks `dir`, a direction
    /// leaving the scene: by the sky or by a sun's disc.
    #[inline]
    pub fn pdf_far(&self, dir: Vec3) -> f32 {
        let sky = self.pdf_sky(dir);
        match self.sun_discs {
            false => sky,
            true => sky + self.pdf_suns(dir),
        }
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

    /// The sky's direction from `guide` (where `u1 < share`) or from the sky's own
    /// distribution, `u1` and `u2` uniform in `[0, 1)`.
    fn draw_guided_sky(
        &self,
        (mut u1, u2): (f32, f32),
        share: f32,
        guide: &impl SkyGuide,
        rng: &mut Rng,
    ) -> Option<SkyDraw> {
        let sky = self.sky.as_ref()?;
        if !choose_second(&mut u1, share) {
            let (dir, guide_pdf) = guide.sample_with_pdf(Vec2::new(u1, u2));
            return Some(SkyDraw {
                dir,
                known: SkyDrawKnown::GuidePdf(guide_pdf),
            });
        }
        let drawn = sky.sample(rng.refine(u1), rng.refine(u2))?;
        Some(SkyDraw {
            dir: drawn.dir,
            known: SkyDrawKnown::Radiance(drawn.radiance),
        })
    }

    /// [`complete`](Self::complete) for a sky direction.
    #[inline]
    fn complete_sky(
        &self,
        draw: SkyDraw,
        share: f32,
        guide: &impl SkyGuide,
    ) -> Option<(LightSample, f32)> {
        let sky = self.sky.as_ref()?;
        let dir = draw.dir;
        let (guide_pdf, (emission, sky_pdf)) = match draw.known {
            SkyDrawKnown::GuidePdf(guide_pdf) => (guide_pdf, sky.radiance_and_pdf(dir)),
            // The sky's own draw knows its texel's radiance (what `radiance` finds).
            SkyDrawKnown::Radiance(radiance) => (guide.pdf(dir), (radiance, sky.pdf(dir))),
        };
        let pdf = self.sky_density(sky_pdf, Some((share, guide_pdf)));
        if !pdf.is_finite() || pdf <= 0.0 {
            return None;
        }
        let sample = LightSample {
            dir,
            distance: f32::INFINITY,
            point: None,
            pdf,
            target: LightTarget::Sky,
            emission,
        };
        Some((sample, guide_pdf))
    }

    /// The probability that a light sample picks the sky (0 without one).
    #[inline]
    pub fn sky_probability(&self) -> f32 {
        self.sky_probability
    }

    /// The solid-angle density with which [`sample_with_sky_guide`](Self::sample_with_sky_guide)
    /// picks `dir` towards the sky, given the guide's `share` and its density
    /// `guide_pdf` along `dir`.
    #[inline]
    pub fn pdf_sky_guided(&self, dir: Vec3, share: f32, guide_pdf: f32) -> f32 {
        self.sky.as_ref().map_or(0.0, |sky| {
            self.sky_density(sky.pdf(dir), Some((share, guide_pdf)))
        })
    }

    /// The solid-angle density with which [`sample`](Self::sample) picks `dir`
    /// towards the sky (0 without one).
    #[inline]
    pub fn pdf_sky(&self, dir: Vec3) -> f32 {
        self.sky
            .as_ref()
            .map_or(0.0, |sky| self.sky_density(sky.pdf(dir), None))
    }

    /// The density of a sky direction whose density by the sky's own distribution is
    /// `sky_pdf` ([`Environment::pdf`]), as [`sample`](Self::sample) picks it, or with
    /// `sky_guide` (the guide's share and density) as
    /// [`sample_with_sky_guide`](Self::sample_with_sky_guide) does; 0 where the
    /// sky is not sampled at all (none, or black).
    #[inline]
    pub fn sky_density(&self, sky_pdf: f32, sky_guide: Option<(f32, f32)>) -> f32 {
        match (&self.sky, sky_guide) {
            (None, _) => 0.0,
            (Some(_), None) => self.sky_probability * sky_pdf,
            (Some(_), Some((share, guide_pdf))) => {
                self.sky_probability * ((1.0 - share) * sky_pdf + share * guide_pdf)
            }
        }
    }

    /// The solid-angle density with which [`sample`](Self::sample) at `at` picks the
    /// point where a ray along unit `dir` first hits triangle `prim` at distance
    /// `distance` (0 when `prim` is no light or is seen from behind).
    #[inline]
    pub fn pdf_hit(&self, at: Receiver, prim: u32, dir: Vec3, distance: f32) -> f32 {
        let Some(i) = self.emitter_index(prim) else {
            return 0.0;
        };
        if let Some(Choice::Area(_)) = self.choice {
            return self.emitters[i].area_pdf(dir, distance);
        }
        let density = self.emitters[i].density(at, dir, distance);
        if density == 0.0 {
            return 0.0;
        }
        self.local_probability * self.chosen(at, i) * density
    }
}
