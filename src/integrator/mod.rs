//! Light transport: how much radiance arrives along a camera ray.
//!
//! Depth counts path segments, the camera ray being the first: with `max_depth = 1`
//! only emitters seen directly contribute, with 2 direct lighting, and so on. A light
//! sample taken at the end of segment `k` stands for a path of `k + 1` segments, so it
//! is only taken while `k < max_depth`.
//!
//! Four estimators of the same quantity (they converge to the same image, see
//! `tests/integrators.rs`). They differ only at vertices whose BSDF is not a delta:
//! - [`IntegratorKind::Bsdf`]: the BSDF's own sampling; light is found by chance.
//! - [`IntegratorKind::Light`]: next-event estimation without MIS: direct light comes
//!   only from a light sample (shadow ray); the path goes on by BSDF sampling and
//!   ignores the emission it then hits.
//! - [`IntegratorKind::Mixture`]: "The Rest of Your Life": one direction from the
//!   50/50 mixture of the BSDF's and the lights' densities
//!   ([`MixturePdf`]`<`[`BsdfPdf`]`, `[`LightPdf`]`>`), weighted by the mixture's value.
//! - [`IntegratorKind::Mis`]: next-event estimation plus a BSDF sample, both weighted
//!   by the power heuristic with the BSDF's own density. At the last vertex the BSDF
//!   ray could only find emission, so the light sample alone (weight 1) is used there
//!   and that ray is not traced (likewise for `Light`).
//!
//! Why `Light` is next-event estimation rather than the book's "sample only the light
//! PDF": a path that only ever goes towards lights has density 0 for every other
//! direction, so it cannot converge to global illumination (only to direct light).
//!
//! With a guide ([`PathTracer::guide`]), the direction a path scatters into at a
//! non-delta vertex comes from a one-sample mixture of the estimator's own strategy
//! (the BSDF's sampling; for `mixture`, the book's mixture of BSDF and lights) and the
//! guide's, and the mixture's density takes the strategy's place in the path weight
//! (and, in `mis`, in both MIS weights; see [`crate::guiding`]). Light samples at
//! guided vertices (`light`, `mis`) draw some of their sky directions from the guide.
//!
//! At delta vertices (mirrors, smooth glass) every estimator follows the BSDF's sample,
//! and the emission found next counts in full. Russian roulette may end any path from
//! vertex [`ROULETTE_START_VERTEX`] on; a guided path's non-delta vertices play
//! adjoint-driven roulette instead, where the guide has learnt any light (`roulette`).

use glam::{Vec2, Vec3};

use crate::accel::{Accel, Hit, Ray};
use crate::bsdf::{Bsdf, BsdfSample};
use crate::color::channel_mean;
use crate::film::Sample;
use crate::guiding::{
    LightFound, MixtureDraw, MixtureTerms, NoRecords, PathRecorder, SdTree, VertexGuide,
};
use crate::light::{
    BsdfPdf, GuidedLightDraw, GuidedLightPdf, LightPdf, LightSample, LightSampler,
    LightSamplerKind, LightTarget, MixturePdf, Pdf, Receiver,
};
use crate::sampling::{choose_second, Rng};
use crate::scene::{Scene, SurfacePoint};

mod roulette;
use roulette::{expected_from, AdjointRoulette};
pub use roulette::{DIM_RATIO, DIM_SURVIVAL, MAX_HALVINGS};

/// Which light-transport estimator `ember render` uses.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum IntegratorKind {
    /// Path tracing that samples only the BSDF.
    Bsdf,
    /// Next-event estimation: direct light from light samples only, no MIS.
    Light,
    /// One sample per bounce from the 50/50 mixture of BSDF and light densities.
    Mixture,
    /// Next-event estimation and BSDF sampling combined by multiple importance
    /// sampling (power heuristic).
    #[default]
    Mis,
}

/// Rays traced while estimating radiance, per worker.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct RayCount {
    pub rays: u64,
}

/// Russian roulette may end a path at this vertex and later (vertex `k` ends segment
/// `k`), after the vertex's light sample and before it scatters: short paths carry
/// most of the image, long ones are cut in proportion to their throughput.
///
/// Why 6 (as Mitsuba's default): roulette trades variance for time, and starting it
/// early is a bad trade on interiors, where every bounce loses only part of the
/// light: on the Cornell boxes starting at 6 rather than 4 lowered the error by about a
/// fifth for a fifth more instructions (benches/results/2026-11-30-speed-against-mitsuba.md).
pub const ROULETTE_START_VERTEX: u32 = 6;

/// A path tracer over one scene and one accelerator; generic so that ray queries are
/// static calls in the hot loop.
pub struct PathTracer<'a, A: Accel> {
    pub scene: &'a Scene,
    pub accel: &'a A,
    pub max_depth: u32,
    pub kind: IntegratorKind,
    /// The distribution over the scene's emitters, built once per render.
    pub lights: LightSampler,
    /// The learnt distribution of incident light that guides the path (none:
    /// unguided).
    pub guide: Option<&'a SdTree>,
}

/// How emission met by the next ray counts, decided where that ray was chosen.
#[derive(Clone, Copy, Debug)]
enum EmissionWeight<'t> {
    /// In full: camera rays, delta bounces, BSDF-only and mixture sampling.
    Full,
    /// Not at all: the light sample at the previous vertex already counted it.
    Skip,
    /// MIS weight of a BSDF sample drawn with this density against light sampling
    /// from the receiver `from` (the vertex the ray left); with a guide, the density
    /// of the BSDF–guide mixture that drew it, and `sky_guide`: that vertex's guide,
    /// which draws some of its sky samples (see [`SkyGuideAlong`]).
    Mis {
        bsdf_pdf: f32,
        from: Receiver,
        sky_guide: Option<SkyGuideAlong<'t>>,
    },
}

impl<'t> EmissionWeight<'t> {
    /// The weight of light met by the ray, given the density with which light
    /// sampling would have chosen the same direction (asked for only under MIS).
    #[inline]
    fn weight(self, light_pdf: impl FnOnce(Receiver, Option<SkyGuideAlong<'t>>) -> f32) -> f32 {
        match self {
            EmissionWeight::Full => 1.0,
            EmissionWeight::Skip => 0.0,
            EmissionWeight::Mis {
                bsdf_pdf,
                from,
                sky_guide,
            } => power_heuristic(bsdf_pdf, light_pdf(from, sky_guide)),
        }
    }
}

/// The guide of the vertex a ray left, as the MIS weight of the sky the ray may meet
/// needs it: its share of sky samples and its sky distribution's density along the
/// ray, looked up only if the ray meets the sky.
#[derive(Clone, Copy, Debug)]
struct SkyGuideAlong<'t> {
    guide: VertexGuide<'t>,
}

impl SkyGuideAlong<'_> {
    /// The guide's sky share and its density along the ray's unit direction `dir`.
    #[inline]
    fn share_and_pdf(&self, dir: Vec3) -> (f32, f32) {
        let share = self.guide.sky_share();
        let pdf = if share > 0.0 {
            self.guide.sky_pdf(dir)
        } else {
            0.0
        };
        (share, pdf)
    }
}

/// Where a path goes from a vertex: the next direction, the factor the throughput is
/// multiplied by, and the first hit when choosing the direction needed the trace.
struct Step<'t> {
    dir: Vec3,
    weight: Vec3,
    /// The density `dir` was drawn with (a delta lobe's probability for delta steps).
    pdf: f32,
    emission: EmissionWeight<'t>,
    /// Relative index crossed by a refraction (1 otherwise).
    eta: f32,
    traced: Option<Option<Hit>>,
    /// At a guided vertex, the BSDF's value and density along `dir`, as the draw
    /// found them, and the normal its guide is folded about: what training's record
    /// of the draw holds.
    mixture: Option<MixtureTerms>,
}

/// A surface point as light sampling sees it: where it is, and the shading normal
/// whose cosine the scattered light carries, turned to the side of `wo` (the only
/// side a reflective BSDF takes light from; light sampling is only done at those).
/// A BSDF that transmits takes light from both sides: no normal.
#[inline]
fn receiver(surface: &SurfacePoint, bsdf: &Bsdf, wo: Vec3) -> Receiver {
    if bsdf.transmits() {
        return Receiver::at(surface.p);
    }
    Receiver {
        p: surface.p,
        n: reflecting_normal(surface, wo),
    }
}

/// The unit shading normal turned to the side of `wo`, the hemisphere a reflective
/// BSDF scatters into (the side of the geometric normal `wo` is on decides).
#[inline]
fn reflecting_normal(surface: &SurfacePoint, wo: Vec3) -> Vec3 {
    if wo.dot(surface.ng) < 0.0 {
        -surface.ns
    } else {
        surface.ns
    }
}

/// Sets the passes of a sample from the vertex where they are taken.
#[inline]
fn record_passes(out: &mut Sample, bsdf: &Bsdf, surface: &SurfacePoint, wo: Vec3) {
    out.albedo = bsdf.albedo();
    out.normal = if surface.ns.dot(wo) < 0.0 {
        -surface.ns
    } else {
        surface.ns
    };
}

/// Whether light samples of `light` find what the path's own rays can also find (an
/// emitter, a sun's disc): what training's records of emitters' visibility count.
#[inline]
fn light_found_by_rays(light: &LightSample) -> bool {
    matches!(
        light.target,
        LightTarget::Emitter(_) | LightTarget::Light(_)
    )
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

impl<'a, A: Accel> PathTracer<'a, A> {
    /// A tracer for `scene`, with its light distribution built once here.
    pub fn new(scene: &'a Scene, accel: &'a A, max_depth: u32, kind: IntegratorKind) -> Self {
        Self::with_light_sampler(scene, accel, max_depth, kind, LightSamplerKind::default())
    }

    /// A tracer whose light samples choose emitters as `lights` says.
    pub fn with_light_sampler(
        scene: &'a Scene,
        accel: &'a A,
        max_depth: u32,
        kind: IntegratorKind,
        lights: LightSamplerKind,
    ) -> Self {
        PathTracer {
            scene,
            accel,
            max_depth,
            kind,
            lights: LightSampler::for_scene(scene, lights),
            guide: None,
        }
    }

    /// The same tracer guided by `guide`.
    pub fn with_guide(self, guide: Option<&'a SdTree>) -> Self {
        PathTracer { guide, ..self }
    }

    #[inline]
    fn trace(&self, ray: &Ray, count: &mut RayCount) -> Option<Hit> {
        count.rays += 1;
        self.accel.intersect(ray)
    }

    /// Radiance arriving along `ray` (towards its origin); `ray.dir` must be unit.
    /// `rng` is told where each vertex's draws start (see [`Rng::start_vertex`]).
    pub fn radiance(&self, ray: Ray, rng: &mut Rng, count: &mut RayCount) -> Vec3 {
        self.sample(ray, rng, count).radiance
    }

    /// The radiance arriving along a camera ray (see [`radiance`](Self::radiance)) and
    /// the render passes of its path: albedo and shading normal at the first vertex
    /// whose BSDF is not a delta (mirrors and glass are seen through, as Open Image
    /// Denoise asks), and the distance to the first hit.
    ///
    /// The path loop is instantiated once unguided and once guided, chosen here once
    /// per sample: the unguided instantiation has no guide lookups and no recorder
    /// calls left in it (the code from before guiding existed, at the same instruction
    /// count), so a render without `--guiding` does not pay for guiding.
    #[inline]
    pub fn sample(&self, ray: Ray, rng: &mut Rng, count: &mut RayCount) -> Sample {
        match self.guide {
            None => self.path::<false, NoRecords>(ray, rng, count, &mut NoRecords),
            Some(_) => self.sample_recorded(ray, rng, count, &mut NoRecords),
        }
    }

    /// [`sample`](Self::sample), telling `recorder` what the path finds at each vertex
    /// (the training of a guide, which is always guided, at first by the uniform tree).
    /// The guided instantiation of the path loop, kept out of line so that the
    /// unguided one is inlined into the tile loop exactly as before guiding existed.
    #[inline(never)]
    pub fn sample_recorded<R: PathRecorder>(
        &self,
        ray: Ray,
        rng: &mut Rng,
        count: &mut RayCount,
        recorder: &mut R,
    ) -> Sample {
        self.path::<true, R>(ray, rng, count, recorder)
    }

    /// The path loop of [`sample_recorded`](Self::sample_recorded); `GUIDED` says
    /// whether `self.guide` is set.
    #[inline(always)]
    fn path<const GUIDED: bool, R: PathRecorder>(
        &self,
        mut ray: Ray,
        rng: &mut Rng,
        count: &mut RayCount,
        recorder: &mut R,
    ) -> Sample {
        let mut out = Sample::default();
        let mut passes_found = false;
        let mut radiance = Vec3::ZERO;
        let mut throughput = Vec3::ONE;
        // The product of η² over refractions so far: throughput without the 1/η²
        // radiance scaling, which says how much the path carries for Russian roulette.
        let mut eta_scale = 1.0f32;
        let mut emission_weight = EmissionWeight::Full;
        let mut roulette = AdjointRoulette::default();
        // Whether the ray was scattered by a vertex that training records (the sky it
        // meets is then that vertex's record of the sky).
        let mut ray_recorded = false;
        let mut hit = self.trace(&ray, count);
        out.depth = hit.map_or(0.0, |h| h.t);
        for segment in 1..=self.max_depth {
            let Some(current) = hit else {
                let sky = throughput * self.sky(ray.dir, emission_weight);
                radiance += sky;
                if ray_recorded {
                    recorder.met_sky(sky);
                } else {
                    recorder.added(sky);
                }
                if self.lights.has_sun_discs() {
                    // A sun is direct light that light samples draw too, as an emitter's.
                    let suns = throughput * self.sun_discs(ray.dir, emission_weight);
                    radiance += suns;
                    if ray_recorded && self.takes_light_samples() {
                        recorder.met_emitter(suns);
                    } else {
                        recorder.added(suns);
                    }
                }
                if !passes_found {
                    out.albedo = self
                        .scene
                        .sky_radiance(ray.dir)
                        .clamp(Vec3::ZERO, Vec3::ONE);
                }
                break;
            };
            rng.start_vertex(segment);
            if GUIDED && self.prefetches_sky() {
                let share = self.guide.map(|tree| tree.sky_share_at(ray.at(current.t)));
                self.lights.prefetch_sky_sample(rng.clone(), share);
            }
            let surface = self.scene.surface(&current);
            let emitted = throughput * self.emission(&surface, &current, ray.dir, emission_weight);
            radiance += emitted;
            // Where the vertex the ray left took a light sample too, the emitter it met
            // is light next-event estimation also carries (see `Record::direct`).
            if ray_recorded && self.takes_light_samples() {
                recorder.met_emitter(emitted);
            } else {
                recorder.added(emitted);
            }
            let wo = -ray.dir;
            if segment == self.max_depth {
                if !passes_found {
                    record_passes(&mut out, &self.scene.bsdf(&surface, wo), &surface, wo);
                }
                break;
            }
            let bsdf = self.scene.bsdf(&surface, wo);
            if !passes_found && !bsdf.is_delta() {
                record_passes(&mut out, &bsdf, &surface, wo);
                passes_found = true;
            }
            let last_vertex = segment + 1 == self.max_depth;
            let next_event = !bsdf.is_delta() && self.takes_light_samples();
            let mis = self.kind == IntegratorKind::Mis && !last_vertex;
            // Adjoint-driven roulette's survival probability (1 where it plays none),
            // where the guide has anything to go by (not the untrained one of
            // training's first iteration); elsewhere the ordinary roulette plays.
            let mut adjoint_survival = None;
            // A vertex is guided where the path scatters from it: not at the last
            // vertex of the estimators that end there with their light sample.
            let scatters = match self.kind {
                IntegratorKind::Bsdf | IntegratorKind::Mixture => true,
                IntegratorKind::Light | IntegratorKind::Mis => !last_vertex,
            };
            let guide = match self.guide {
                Some(tree) if GUIDED && scatters && !bsdf.is_delta() => {
                    // Folded to wo's side: a transmitting BSDF's own draws cover the other.
                    let guide = tree.guide_at(surface.p, reflecting_normal(&surface, wo));
                    let expected = expected_from(throughput, bsdf.albedo(), guide.incident());
                    adjoint_survival = roulette.survival(channel_mean(radiance), expected);
                    // Training measures every region's draws, used or not.
                    (R::RECORDS || guide.guides()).then_some(guide)
                }
                _ => None,
            };
            if next_event {
                let light = self.direct_light::<GUIDED, R>(
                    &surface,
                    &bsdf,
                    wo,
                    (mis, guide),
                    rng,
                    recorder,
                    count,
                );
                let light = throughput * light;
                radiance += light;
                recorder.added(light);
                if last_vertex {
                    break;
                }
            } else if !bsdf.is_delta() && self.lights.has_delta_lights() {
                let light = self.delta_light(&surface, &bsdf, wo, rng, recorder, count);
                let light = throughput * light;
                radiance += light;
                recorder.added(light);
            }
            // Roulette after what this vertex adds itself (its light sample) and before
            // it chooses where the path goes: the emission that choice aims at (the
            // mixture's light half) is then counted before a small weight could end the
            // path, which would make fireflies.
            let survive = match adjoint_survival {
                Some(survive) => survive,
                None if segment >= ROULETTE_START_VERTEX => {
                    (throughput * eta_scale).max_element().min(0.95)
                }
                None => 1.0,
            };
            if survive < 1.0 || survive.is_nan() {
                if rng.f32() >= survive || survive.is_nan() {
                    break;
                }
                throughput /= survive;
            }
            // How the emission the next ray meets counts, its MIS weight completed by
            // the step with the density it drew the ray with.
            let emission = match self.kind {
                _ if bsdf.is_delta() => EmissionWeight::Full,
                IntegratorKind::Bsdf | IntegratorKind::Mixture => EmissionWeight::Full,
                IntegratorKind::Light => EmissionWeight::Skip,
                IntegratorKind::Mis => EmissionWeight::Mis {
                    bsdf_pdf: 0.0,
                    from: receiver(&surface, &bsdf, wo),
                    sky_guide: None,
                },
            };
            let step = match (self.kind, guide) {
                _ if bsdf.is_delta() => self.bsdf_step(&bsdf, wo, emission, rng),
                (IntegratorKind::Mixture, _) => {
                    self.mixture_step(&surface, &bsdf, wo, guide, rng, recorder, count)
                }
                (_, Some(guide)) => self.guided_step(&bsdf, wo, guide, emission, rng),
                (_, None) => self.bsdf_step(&bsdf, wo, emission, rng),
            };
            let Some(step) = step else {
                break;
            };
            throughput *= step.weight;
            eta_scale *= step.eta * step.eta;
            emission_weight = step.emission;
            // Training records the guided vertices (every non-delta one it scatters
            // from: training measures every region's draws).
            ray_recorded = step.mixture.is_some();
            if ray_recorded {
                let mixture = || step.mixture;
                let (p, n) = (surface.p, surface.ns);
                recorder.scattered(p, n, step.dir, step.pdf, throughput, mixture);
            }
            if throughput == Vec3::ZERO {
                break;
            }
            ray = surface.origin().spawn(step.dir);
            hit = match step.traced {
                Some(next) => next,
                None => {
                    if !GUIDED && self.prefetches_sky() {
                        let mut next_vertex = rng.clone();
                        next_vertex.start_vertex(segment + 1);
                        self.lights.prefetch_sky_sample(next_vertex, None);
                    }
                    self.trace(&ray, count)
                }
            };
        }
        recorder.finish();
        out.radiance = radiance;
        out
    }

    /// Whether light samples are drawn from a sky, whose texel the path loop then
    /// asks the caches for ahead ([`LightSampler::prefetch_sky_sample`], a hint with
    /// no effect on any result). That texel is nearly always a miss to memory (a sky
    /// map's texels are tens of megabytes), a fifth of an unguided room's time. An
    /// unguided path asks before tracing the ray to a vertex, replaying that vertex's
    /// stream, so that the load overlaps the traversal; a guided vertex's draw depends
    /// on its region's sky share, so it asks once the ray has hit (at the hit point:
    /// the surface's own point can lie in the next region, and the hint is then of
    /// another texel), and the load overlaps the surface's shading.
    #[inline(always)]
    fn prefetches_sky(&self) -> bool {
        self.takes_light_samples() && self.lights.sky_probability() > 0.0
    }

    /// Whether the integrator takes a light sample at its non-delta vertices
    /// (next-event estimation): `light` and `mis`.
    #[inline(always)]
    fn takes_light_samples(&self) -> bool {
        matches!(self.kind, IntegratorKind::Light | IntegratorKind::Mis)
    }

    /// Emission of the surface at `hit` towards a ray travelling along `dir`, weighted
    /// as decided where the ray was chosen. Lights emit on the side of their winding
    /// normal, or on both where their material is two-sided.
    #[inline]
    fn emission(
        &self,
        surface: &SurfacePoint,
        hit: &Hit,
        dir: Vec3,
        how: EmissionWeight<'_>,
    ) -> Vec3 {
        let material = self.scene.material(surface);
        if !material.is_emissive() || !material.emits_along(dir, surface.ng) {
            return Vec3::ZERO;
        }
        self.scene.emitted(surface)
            * how.weight(|from, _| {
                let light = self.scene.light_hit(*hit);
                self.lights.pdf_hit(from, light.prim, dir, hit.t)
            })
    }

    /// Radiance of the sky seen along `dir`, weighted as decided where the ray was
    /// chosen (the sky is a light: next-event estimation samples it too).
    #[inline]
    fn sky(&self, dir: Vec3, how: EmissionWeight<'_>) -> Vec3 {
        let Some(sky) = &self.scene.sky else {
            return Vec3::ZERO;
        };
        // One lookup for both: the density's texel is the radiance's.
        let (radiance, sky_pdf) = sky.radiance_and_pdf(dir);
        let weight = how.weight(|_, sky_guide| {
            let sky_guide = sky_guide.map(|along| along.share_and_pdf(dir));
            self.lights.sky_density(sky_pdf, sky_guide)
        });
        if weight == 0.0 {
            return Vec3::ZERO;
        }
        radiance * weight
    }

    /// Radiance of the suns' discs seen along `dir` (a ray that left the scene), each
    /// weighted as decided where the ray was chosen, against the density with which
    /// light sampling picks it by that sun.
    #[inline(never)]
    fn sun_discs(&self, dir: Vec3, how: EmissionWeight<'_>) -> Vec3 {
        self.lights
            .suns_along(dir)
            .map(|(radiance, pdf)| radiance * how.weight(|_, _| pdf))
            .sum()
    }

    /// Follows the BSDF's own sample. A `Mis` emission weight is completed with the
    /// sample's density; a delta sample's next emission always counts in full.
    #[inline(always)]
    fn bsdf_step<'t>(
        &self,
        bsdf: &Bsdf,
        wo: Vec3,
        emission: EmissionWeight<'t>,
        rng: &mut Rng,
    ) -> Option<Step<'t>> {
        let (u1, u2) = rng.pair();
        let sample: BsdfSample = bsdf.sample(wo, Vec2::new(u1, u2))?;
        let emission = match emission {
            _ if sample.delta => EmissionWeight::Full,
            EmissionWeight::Mis {
                from, sky_guide, ..
            } => EmissionWeight::Mis {
                bsdf_pdf: sample.pdf,
                from,
                sky_guide,
            },
            other => other,
        };
        Some(Step {
            dir: sample.wi,
            weight: sample.weight(),
            pdf: sample.pdf,
            emission,
            eta: sample.eta,
            traced: None,
            mixture: None,
        })
    }

    /// Next-event estimation: radiance scattered towards `wo` from one light sample,
    /// `f·cos · Le / pdf` if the shadow ray is clear, times the power-heuristic weight
    /// against BSDF sampling when `mis` (against the BSDF–guide mixture with a guide).
    #[allow(clippy::too_many_arguments)]
    #[inline(always)]
    fn direct_light<const GUIDED: bool, R: PathRecorder>(
        &self,
        surface: &SurfacePoint,
        bsdf: &Bsdf,
        wo: Vec3,
        (mis, guide): (bool, Option<VertexGuide>),
        rng: &mut Rng,
        recorder: &mut R,
        count: &mut RayCount,
    ) -> Vec3 {
        if !self.lights.may_light(surface.p) {
            return Vec3::ZERO;
        }
        let at = receiver(surface, bsdf, wo);
        let Some(drawn) = self.draw_light::<GUIDED>(at, guide, rng) else {
            return Vec3::ZERO;
        };
        // Training learns a region's sky share from every sky sample, lit or not, and
        // how often its emitters' samples are blocked (a render records nothing, as for
        // lit samples below).
        let unlit = |recorder: &mut R, blocked: bool| {
            if !R::RECORDS {
                return Vec3::ZERO;
            }
            let (p, n, dir) = (surface.p, surface.ns, drawn.dir());
            match (&drawn, guide) {
                (GuidedLightDraw::Sky(_), Some(guide)) => {
                    let draw = || Some(MixtureDraw::unlit(guide.normal()));
                    recorder.light_sample(p, n, dir, LightFound::Nothing, draw);
                }
                (GuidedLightDraw::Complete(light), _) if blocked && light_found_by_rays(light) => {
                    recorder.light_sample(p, n, dir, LightFound::EmitterBlocked, || None);
                }
                _ => {}
            }
            Vec3::ZERO
        };
        let (f, bsdf_pdf) = bsdf.eval_pdf(wo, drawn.dir());
        if f == Vec3::ZERO {
            return unlit(recorder, false);
        }
        count.rays += 1;
        let shadow = match drawn.point() {
            Some(point) => surface.origin().spawn_to(&point),
            None => surface.origin().spawn(drawn.dir()),
        };
        if self.accel.occluded(&shadow) {
            return unlit(recorder, true);
        }
        // The normal the guide of a guided sky sample is folded about.
        let sky_normal = match (&drawn, guide) {
            (GuidedLightDraw::Sky(_), Some(guide)) => Some(guide.normal()),
            _ => None,
        };
        let Some(light) = self.complete_light(drawn, guide) else {
            return Vec3::ZERO;
        };
        let weight = match (mis, guide) {
            // No direction a BSDF or a guide draws can find a delta light.
            _ if light.is_delta() => 1.0,
            (false, _) => 1.0,
            (true, Some(guide)) if GUIDED => {
                power_heuristic(light.pdf, guide.mixture_pdf(bsdf_pdf, light.dir))
            }
            (true, _) => power_heuristic(light.pdf, bsdf_pdf),
        };
        // In this order, as before guiding existed: unguided samples keep their bits.
        let reflected = f * light.emission * (weight / light.pdf);
        if R::RECORDS {
            let incident = light.emission * (weight / light.pdf);
            let found = match light.target {
                LightTarget::Delta(_) => LightFound::Delta(incident),
                LightTarget::Sky => LightFound::Sky {
                    incident,
                    integrand: reflected,
                },
                _ => LightFound::Emitter(incident),
            };
            recorder.light_sample(surface.p, surface.ns, light.dir, found, || {
                sky_normal.map(|n| self.sky_draw(light.dir, light.pdf, n, f * light.emission))
            });
        }
        reflected
    }

    /// Next-event estimation of the delta lights alone, for the integrators that find
    /// every other light by the directions they scatter into (`bsdf`, `mixture`): a
    /// light sample counts where it chose a delta light, `f·cos · E / P` (weight 1:
    /// none of their directions can find one), and is worth nothing here otherwise,
    /// that light being found by the path.
    #[inline(never)]
    fn delta_light<R: PathRecorder>(
        &self,
        surface: &SurfacePoint,
        bsdf: &Bsdf,
        wo: Vec3,
        rng: &mut Rng,
        recorder: &mut R,
        count: &mut RayCount,
    ) -> Vec3 {
        let at = receiver(surface, bsdf, wo);
        let Some(light) = self.lights.sample(at, rng).filter(LightSample::is_delta) else {
            return Vec3::ZERO;
        };
        let f = bsdf.eval(wo, light.dir);
        if f == Vec3::ZERO {
            return Vec3::ZERO;
        }
        count.rays += 1;
        let shadow = match light.point {
            Some(point) => surface.origin().spawn_to(&point),
            None => surface.origin().spawn(light.dir),
        };
        if self.accel.occluded(&shadow) {
            return Vec3::ZERO;
        }
        let incident = light.emission / light.pdf;
        if R::RECORDS {
            let found = LightFound::Delta(incident);
            recorder.light_sample(surface.p, surface.ns, light.dir, found, || None);
        }
        f * incident
    }

    /// The light sample of [`direct_light`](Self::direct_light), its sky direction
    /// following the vertex's guide where it has one. A sky sample's radiance and
    /// density are looked up only once its shadow ray is clear
    /// ([`complete_light`](Self::complete_light)): training too learns a region's sky
    /// share from every sky sample, lit or not, but an unlit one counts only as a draw.
    #[inline(always)]
    fn draw_light<const GUIDED: bool>(
        &self,
        at: Receiver,
        guide: Option<VertexGuide>,
        rng: &mut Rng,
    ) -> Option<GuidedLightDraw> {
        match guide {
            Some(guide) if GUIDED => {
                let share = guide.sky_share();
                self.lights.draw_with_sky_guide(at, rng, share, &guide)
            }
            _ => {
                let light = self.lights.sample(at, rng)?;
                Some(GuidedLightDraw::Complete(light))
            }
        }
    }

    /// The light sample `drawn` at a vertex with `guide` (see
    /// [`LightSampler::complete`]).
    #[inline(always)]
    fn complete_light(
        &self,
        drawn: GuidedLightDraw,
        guide: Option<VertexGuide>,
    ) -> Option<LightSample> {
        match (drawn, guide) {
            (GuidedLightDraw::Complete(light), _) => Some(light),
            (GuidedLightDraw::Sky(_), Some(guide)) => self
                .lights
                .complete(drawn, guide.sky_share(), &guide)
                .map(|(light, _)| light),
            // A sky draw comes only from a guide.
            (GuidedLightDraw::Sky(_), None) => None,
        }
    }

    /// What a guided vertex's sky sample along `dir`, drawn with density `pdf` (its
    /// guide folded about `normal`), tells training (see
    /// [`LightSampler::sample_with_sky_guide`]): the draw its region's sky share is
    /// learnt from, `integrand` being what it found (`f·cos · Le`, 0 where unlit).
    #[inline]
    fn sky_draw(&self, dir: Vec3, pdf: f32, normal: Vec3, integrand: Vec3) -> MixtureDraw {
        MixtureDraw::new(
            integrand,
            self.lights.pdf_sky(dir),
            self.lights.sky_probability(),
            pdf,
            normal,
        )
    }

    /// The guided step at a non-delta vertex: a direction from the BSDF or the guide
    /// (with the guide's selection probability), weighted by `f·cos` over the
    /// mixture's density, which completes a `Mis` emission weight (with the guide,
    /// which draws some of the sky samples whose density that weight needs).
    #[inline]
    fn guided_step<'t>(
        &self,
        bsdf: &Bsdf,
        wo: Vec3,
        guide: VertexGuide<'t>,
        emission: EmissionWeight<'t>,
        rng: &mut Rng,
    ) -> Option<Step<'t>> {
        // One 2-D draw, as an unguided step's: its first number chooses the guide or
        // the BSDF and is stretched back to uniform within the choice. A coin of its
        // own moved the direction's pair off the dimensions the unguided step reads,
        // out of the first vertex's stratified (Sobol) set, and cost an unguided
        // region the stratification's gain.
        let (mut u1, u2) = rng.pair();
        let from_guide = !choose_second(&mut u1, guide.selection());
        let (wi, value, bsdf_pdf, guide_pdf) = if from_guide {
            let (wi, guide_pdf) = guide.sample_with_pdf(Vec2::new(u1, u2));
            let (value, pdf) = bsdf.eval_pdf(wo, wi);
            (wi, value, pdf, Some(guide_pdf))
        } else {
            let sample = bsdf.sample(wo, Vec2::new(u1, u2))?;
            // Where nothing is drawn from the guide, the mixture is the BSDF alone.
            let guide_pdf = (guide.selection() > 0.0).then(|| guide.pdf(sample.wi));
            (sample.wi, sample.value, sample.pdf, guide_pdf)
        };
        let pdf = guide_pdf.map_or(bsdf_pdf, |guide_pdf| guide.mixture_of(bsdf_pdf, guide_pdf));
        if value == Vec3::ZERO || pdf.is_nan() || pdf <= 0.0 {
            return None;
        }
        let emission = match emission {
            EmissionWeight::Mis { from, .. } => EmissionWeight::Mis {
                bsdf_pdf: pdf,
                from,
                sky_guide: Some(SkyGuideAlong { guide }),
            },
            other => other,
        };
        Some(Step {
            dir: wi,
            weight: value / pdf,
            pdf,
            emission,
            eta: bsdf.eta(wo, wi),
            traced: None,
            mixture: Some(MixtureTerms {
                bsdf_value: value,
                bsdf_pdf,
                normal: guide.normal(),
            }),
        })
    }

    /// The book's mixture step: a direction from `0.5 · bsdf + 0.5 · light`, traced
    /// here because the light density of a direction depends on what it hits, and
    /// weighted by `f·cos / mixture value`. `None` when the draw is void (a light point
    /// that is hidden or faces away), which ends the path with nothing more to add.
    ///
    /// With a `guide`, the book's mixture is itself mixed with the guide:
    /// `(1 − α) · (0.5 · bsdf + 0.5 · light) + α · guide`, α the guide's selection
    /// probability, chosen by a number of its own only where α > 0; and the light half
    /// draws its sky directions with the region's sky share from its sky guide, as a
    /// guided light sample does ([`GuidedLightPdf`]). A region that draws nothing from
    /// its guide takes the unguided step, number for number. Inlined, so that the
    /// unguided path loop, whose `guide` is always `None`, keeps none of the guide's
    /// branches.
    #[allow(clippy::too_many_arguments)]
    #[inline(always)]
    fn mixture_step<'t, R: PathRecorder>(
        &self,
        surface: &SurfacePoint,
        bsdf: &Bsdf,
        wo: Vec3,
        guide: Option<VertexGuide<'t>>,
        rng: &mut Rng,
        recorder: &mut R,
        count: &mut RayCount,
    ) -> Option<Step<'t>> {
        // Where no light can shine, the mixture is all BSDF: a light sample there would
        // be void. The weights depend only on the point, so the estimate stays unbiased.
        // So where every light is a delta light, whose draws are void too.
        if !self.lights.may_light(surface.p) || !self.lights.has_hittable_lights() {
            return match guide {
                Some(guide) => self.guided_step(bsdf, wo, guide, EmissionWeight::Full, rng),
                None => self.bsdf_step(bsdf, wo, EmissionWeight::Full, rng),
            };
        }
        let bsdf_pdf = BsdfPdf { bsdf, wo };
        let at = receiver(surface, bsdf, wo);
        let lights = &self.lights;
        match guide {
            // Training draws every guided vertex's sky directions as a guided light
            // sample would, its share learnt from them.
            Some(guide) if R::RECORDS || guide.sky_share() > 0.0 => {
                let share = guide.sky_share();
                let light_pdf = GuidedLightPdf {
                    at,
                    lights,
                    share,
                    guide: &guide,
                };
                let mixture = MixturePdf::even(bsdf_pdf, light_pdf);
                self.mixture_draw(
                    surface,
                    bsdf,
                    wo,
                    mixture,
                    Some(guide),
                    rng,
                    recorder,
                    count,
                )
            }
            _ => {
                let mixture = MixturePdf::even(bsdf_pdf, LightPdf { at, lights });
                self.mixture_draw(surface, bsdf, wo, mixture, guide, rng, recorder, count)
            }
        }
    }

    /// [`mixture_step`](Self::mixture_step)'s draw from `mixture` (the book's) and,
    /// with a `guide`, from the guide; in training, a draw the light half aimed at the
    /// sky is also a draw of the region's sky share.
    #[allow(clippy::too_many_arguments)]
    #[inline(always)]
    fn mixture_draw<'t, L: Pdf, R: PathRecorder>(
        &self,
        surface: &SurfacePoint,
        bsdf: &Bsdf,
        wo: Vec3,
        mixture: MixturePdf<BsdfPdf, L>,
        guide: Option<VertexGuide<'t>>,
        rng: &mut Rng,
        recorder: &mut R,
        count: &mut RayCount,
    ) -> Option<Step<'t>> {
        let selection = guide.map_or(0.0, |guide| guide.selection());
        let guided = match guide {
            Some(guide) if selection > 0.0 && rng.f32() < selection => {
                let (u1, u2) = rng.pair();
                Some(guide.sample_with_pdf(Vec2::new(u1, u2)))
            }
            _ => None,
        };
        let (dir, guide_pdf, drawn) = match guided {
            Some((dir, guide_pdf)) => (dir, Some(guide_pdf), None),
            None => {
                let drawn = mixture.generate(rng)?;
                (drawn.dir, None, Some(drawn))
            }
        };
        let next = self.trace(&surface.origin().spawn(dir), count);
        let light = next.map(|hit| self.scene.light_hit(hit));
        if let (true, Some(guide), Some(LightTarget::Sky)) =
            (R::RECORDS, guide, drawn.and_then(|d| d.aimed_at))
        {
            let draw = || self.mixture_sky_draw(bsdf, wo, dir, guide, next.is_none());
            recorder.sky_draw(surface.p, dir, draw);
        }
        if drawn.is_some_and(|drawn| !drawn.reached(light.as_ref())) {
            return None;
        }
        let book = mixture.value(dir, light.as_ref());
        let density = match guide {
            Some(guide) if selection > 0.0 => {
                let guide_pdf = guide_pdf.unwrap_or_else(|| guide.pdf(dir));
                guide.mixture_of(book, guide_pdf)
            }
            _ => book,
        };
        if density.is_nan() || density <= 0.0 {
            return None;
        }
        let value = bsdf.eval(wo, dir);
        Some(Step {
            dir,
            weight: value / density,
            pdf: density,
            emission: EmissionWeight::Full,
            eta: bsdf.eta(wo, dir),
            traced: Some(next),
            mixture: guide.map(|guide| MixtureTerms {
                bsdf_value: value,
                bsdf_pdf: book,
                normal: guide.normal(),
            }),
        })
    }

    /// The draw of a sky direction `dir` that the book's mixture's light half aimed
    /// at from a guided vertex, for its region's sky share: as a guided light sample's
    /// ([`sky_draw`](Self::sky_draw)), `f·cos · Le` where the ray met the sky.
    fn mixture_sky_draw(
        &self,
        bsdf: &Bsdf,
        wo: Vec3,
        dir: Vec3,
        guide: VertexGuide<'_>,
        met_sky: bool,
    ) -> MixtureDraw {
        if !met_sky {
            return MixtureDraw::unlit(guide.normal());
        }
        let pdf = self
            .lights
            .pdf_sky_guided(dir, guide.sky_share(), guide.sky_pdf(dir));
        let integrand = bsdf.eval(wo, dir) * self.scene.sky_radiance(dir);
        self.sky_draw(dir, pdf, guide.normal(), integrand)
    }
}
