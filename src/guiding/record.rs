//! What a training path leaves behind: for each non-delta vertex, the radiance that
//! arrived along the direction it scattered into, and for each light sample, the
//! radiance that arrived along the light's direction, each times the cosine at the
//! vertex (the [`Record`]s the guide's distributions are learnt from), an emitter's
//! direct light kept apart, and whether an emitter's light sample found it (how much
//! of that light the guide learns; see [`SdTree::deposit`](super::SdTree::deposit));
//! and, at guided vertices, how each such direction was drawn (the [`GuidedDraw`]s
//! the guide's shares are learnt from).
//!
//! Why the cosine: a guided direction is worth what the integrand `f·cos·L` gives
//! along it, and of that the guide can learn only what every vertex of a region
//! shares. `L` alone makes it send as many draws into grazing light as into light
//! from above, which a diffuse surface turns to almost nothing; `L·|cos|` is the
//! integrand of every diffuse vertex up to its albedo, and it stays a distribution
//! the quadtree holds exactly. The full `f·cos·L` is not shared: a glossy lobe
//! follows each vertex's own `wo`. Per sample, learning `L·|cos|` beat learning `L`
//! on every scene measured, and `f·cos·L` only on GlossyMix
//! (benches/results/2026-12-04-guiding-sittings-10-to-13.md).

use glam::Vec3;

use crate::color::channel_mean;
use crate::sampling::mix64;

/// The most vertices of one path whose incident radiance is tracked; deeper ones are
/// not recorded (the guide only needs some of them, and this keeps it allocation-free).
const MAX_OPEN: usize = 32;

/// One training record: at `p`, radiance arrived from the unit direction `dir`, and
/// `value + direct` is its estimate (mean over colour channels) times the cosine of
/// `dir` to the vertex's normal, over the density with which `dir` was drawn: `direct`
/// the part an emitter sent straight to `p` that next-event estimation samples too
/// (found by a light sample, or by the vertex's own ray where the integrator also
/// samples lights), `value` the rest. Where the light along `dir` came from the sky
/// directly, `sky` is what that sky adds to the estimate at `p`, `f·cos · Le` times its
/// MIS weight (mean over colour channels), over the same density: for a light sample
/// that found the sky, and for a vertex whose scattered ray met it (0 for every other
/// record). The region's sky distribution learns from these, the integrand of its sky
/// samples: light samples and scattered rays together estimate all the sky it sees,
/// weighed by how much of it the BSDFs there turn on along the path (the cosine, a
/// glossy lobe). `shadow` says whether the record is a light sample of an emitter,
/// and whether its shadow ray was clear: what a region learns how much of `direct` its
/// guide must carry from (see [`SdTree::deposit`](super::SdTree::deposit)); or that
/// `direct` is the light of a delta light ([`Shadow::Delta`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Record {
    pub p: Vec3,
    pub dir: Vec3,
    pub value: f32,
    pub direct: f32,
    pub sky: f32,
    pub shadow: Shadow,
}

/// Whether a [`Record`] is an emitter's light sample, and what its shadow ray found.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Shadow {
    /// Not an emitter's light sample (a scattered direction, or the sky's sample).
    Untested,
    /// An emitter's light sample whose shadow ray was clear.
    Clear,
    /// An emitter's light sample whose shadow ray was blocked.
    Blocked,
    /// A delta light's light sample (a point, a spot, a sun without a disc) whose
    /// shadow ray was clear: its `direct` light is part of what arrives at `p`, which
    /// no direction a guide draws can find, so it counts in the region's irradiance
    /// and never in its guide.
    Delta,
}

/// What a light sample found, each radiance times its MIS weight over the sample's
/// density.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum LightFound {
    /// The sky, and the same times the BSDF's `f·cos` (its integrand).
    Sky { incident: Vec3, integrand: Vec3 },
    /// An emitter, its shadow ray clear.
    Emitter(Vec3),
    /// An emitter behind something.
    EmitterBlocked,
    /// A delta light, its shadow ray clear.
    Delta(Vec3),
    /// Nothing: a sky sample blocked or below the surface.
    Nothing,
}

/// How a guided vertex at `p` drew the direction `dir` from a mixture with its guide:
/// what the mixtures' shares are learnt from, against the guide the next iteration
/// will use (see [`SdTree::refined`](super::SdTree::refined)).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GuidedDraw {
    pub p: Vec3,
    pub dir: Vec3,
    pub draw: Draw,
}

/// Which mixture a [`GuidedDraw`] came from.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Draw {
    /// The direction the path scattered into, from the BSDF–guide mixture.
    Scattered(MixtureDraw),
    /// A light sample's direction towards the sky, from the sky–guide mixture
    /// (`base_pdf` is the sky's own sampling density).
    Sky(MixtureDraw),
}

/// A direction drawn from the mixture of a base strategy (the BSDF's sampling, or the
/// sky's) and the guide, `(1 − s)·base_pdf + s·guide_scale·g(dir)` for the share `s`
/// in use, `g` the guide's density folded about `normal` (see
/// [`VertexGuide`](super::VertexGuide)).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MixtureDraw {
    /// The integrand's estimate along the direction, `f·cos · L` (mean over channels).
    pub integrand: f32,
    pub base_pdf: f32,
    /// What the guide's density is scaled by in the mixture: 1 for scattered
    /// directions, the probability of sampling the sky at all for sky samples.
    pub guide_scale: f32,
    /// The mixture's density, with which the direction was drawn.
    pub pdf: f32,
    /// The unit normal the guide's density was folded about.
    pub normal: Vec3,
}

impl MixtureDraw {
    /// The draw of a sky sample that found no light (its shadow ray blocked, or
    /// below the surface): it counts among its region's draws, and the second moments
    /// never read a density of a draw whose integrand is 0, so none is looked up.
    pub fn unlit(normal: Vec3) -> Self {
        MixtureDraw {
            integrand: 0.0,
            base_pdf: 0.0,
            guide_scale: 0.0,
            pdf: 0.0,
            normal,
        }
    }

    /// The draw of a direction whose integrand is `integrand` (per colour channel).
    pub fn new(integrand: Vec3, base_pdf: f32, guide_scale: f32, pdf: f32, normal: Vec3) -> Self {
        MixtureDraw {
            integrand: channel_mean(integrand),
            base_pdf,
            guide_scale,
            pdf,
            normal,
        }
    }
}

/// What a guided vertex tells its recorder about the draw, on request.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MixtureTerms {
    /// The BSDF's value `f·cos` in the drawn direction.
    pub bsdf_value: Vec3,
    /// The BSDF's density of that direction.
    pub bsdf_pdf: f32,
    /// The normal the guide's density is folded about.
    pub normal: Vec3,
}

/// What the path tracer tells a recorder as a path unfolds.
pub trait PathRecorder {
    /// Whether records are kept (training): a guided vertex then draws and measures
    /// with its guide even where its region learnt not to use it, since the draws are
    /// what the region's shares are learnt from (see `VertexGuide::guides`).
    const RECORDS: bool;
    /// The path left the non-delta vertex `p` of unit shading normal `normal` along
    /// `dir`, drawn with density `pdf`, and its throughput is now `throughput`: what it
    /// adds from now on, divided by that throughput, is the radiance that arrived along
    /// `dir`. At a guided vertex, `mixture` gives the draw's [`MixtureTerms`]
    /// (evaluated only if asked for).
    fn scattered(
        &mut self,
        p: Vec3,
        normal: Vec3,
        dir: Vec3,
        pdf: f32,
        throughput: Vec3,
        mixture: impl FnOnce() -> Option<MixtureTerms>,
    );
    /// The path's estimate grew by `contribution`.
    fn added(&mut self, contribution: Vec3);
    /// The path's estimate grew by `contribution`, the sky that the ray scattered by
    /// the last call to [`scattered`](Self::scattered) met (recorded with the
    /// scattering's [`MixtureTerms`], whose `f·cos` the sky's record takes).
    fn met_sky(&mut self, contribution: Vec3) {
        self.added(contribution);
    }
    /// The path's estimate grew by `contribution`, the emission that the ray scattered
    /// by the last call to [`scattered`](Self::scattered) met, of an emitter that the
    /// vertex's light samples also draw (its record's [`Record::direct`]).
    fn met_emitter(&mut self, contribution: Vec3) {
        self.added(contribution);
    }
    /// A light sample at `p` (of unit shading normal `normal`) along `dir` found
    /// `found`; `sky` gives the draw of a sky sample at a guided vertex (evaluated only
    /// if asked for).
    fn light_sample(
        &mut self,
        p: Vec3,
        normal: Vec3,
        dir: Vec3,
        found: LightFound,
        sky: impl FnOnce() -> Option<MixtureDraw>,
    );
    /// A sky direction `dir` drawn at the guided vertex `p` otherwise than by a light
    /// sample (by the light half of the book's mixture): `draw` gives the draw the
    /// region's sky share is learnt from (evaluated only if asked for).
    fn sky_draw(&mut self, _p: Vec3, _dir: Vec3, _draw: impl FnOnce() -> MixtureDraw) {}
    /// The path has ended.
    fn finish(&mut self);
}

/// Records nothing (an ordinary render): every call compiles away.
pub struct NoRecords;

impl PathRecorder for NoRecords {
    const RECORDS: bool = false;
    #[inline(always)]
    fn scattered(
        &mut self,
        _: Vec3,
        _: Vec3,
        _: Vec3,
        _: f32,
        _: Vec3,
        _: impl FnOnce() -> Option<MixtureTerms>,
    ) {
    }
    #[inline(always)]
    fn added(&mut self, _: Vec3) {}
    #[inline(always)]
    fn light_sample(
        &mut self,
        _: Vec3,
        _: Vec3,
        _: Vec3,
        _: LightFound,
        _: impl FnOnce() -> Option<MixtureDraw>,
    ) {
    }
    #[inline(always)]
    fn finish(&mut self) {}
}

#[derive(Clone, Copy, Default)]
struct Open {
    p: Vec3,
    /// `|cos|` of `dir` to the vertex's shading normal.
    cos: f32,
    dir: Vec3,
    pdf: f32,
    throughput: Vec3,
    radiance: Vec3,
    /// Of `radiance`, the sky its own ray met.
    sky: Vec3,
    /// Of `radiance`, the emission its own ray met of an emitter light samples draw.
    emitter: Vec3,
    mixture: Option<MixtureTerms>,
}

/// Records a path's vertices into `records` when it ends, and the draws of its guided
/// vertices into `draws`, a share `keep` of them (chosen by a hash of the draw, so the
/// draws kept are a function of the draws and the share; see [`keeps`]).
pub struct PathRecords<'o> {
    open: [Open; MAX_OPEN],
    len: usize,
    records: &'o mut Vec<Record>,
    draws: &'o mut Vec<GuidedDraw>,
    keep: f32,
    /// Guided draws made, kept or not.
    drawn: u64,
    /// Whether the last scattered direction is the last open vertex's.
    last_open: bool,
}

impl<'o> PathRecords<'o> {
    pub fn new(records: &'o mut Vec<Record>, draws: &'o mut Vec<GuidedDraw>, keep: f32) -> Self {
        PathRecords {
            open: [Open::default(); MAX_OPEN],
            len: 0,
            records,
            draws,
            keep,
            drawn: 0,
            last_open: false,
        }
    }

    /// The guided draws made so far, kept or not.
    pub fn drawn(&self) -> u64 {
        self.drawn
    }

    /// The vertex whose ray was the last scattered, if it is recorded.
    fn last_open(&mut self) -> Option<&mut Open> {
        match self.last_open {
            true => self.open[..self.len].last_mut(),
            false => None,
        }
    }

    fn draw(&mut self, p: Vec3, dir: Vec3, draw: Draw) {
        self.drawn += 1;
        if keeps(p, dir, self.keep) {
            self.draws.push(GuidedDraw { p, dir, draw });
        }
    }
}

impl PathRecorder for PathRecords<'_> {
    const RECORDS: bool = true;
    fn scattered(
        &mut self,
        p: Vec3,
        normal: Vec3,
        dir: Vec3,
        pdf: f32,
        throughput: Vec3,
        mixture: impl FnOnce() -> Option<MixtureTerms>,
    ) {
        if self.len < MAX_OPEN && pdf > 0.0 {
            self.open[self.len] = Open {
                p,
                cos: dir.dot(normal).abs(),
                dir,
                pdf,
                throughput,
                radiance: Vec3::ZERO,
                sky: Vec3::ZERO,
                emitter: Vec3::ZERO,
                mixture: mixture(),
            };
            self.len += 1;
            self.last_open = true;
        } else {
            self.last_open = false;
        }
    }

    fn met_sky(&mut self, contribution: Vec3) {
        self.added(contribution);
        if let Some(v) = self.last_open() {
            v.sky = per_throughput(contribution, v.throughput);
        }
    }

    fn met_emitter(&mut self, contribution: Vec3) {
        self.added(contribution);
        if let Some(v) = self.last_open() {
            v.emitter = per_throughput(contribution, v.throughput);
        }
    }

    fn added(&mut self, contribution: Vec3) {
        for v in &mut self.open[..self.len] {
            v.radiance += per_throughput(contribution, v.throughput);
        }
    }

    fn light_sample(
        &mut self,
        p: Vec3,
        normal: Vec3,
        dir: Vec3,
        found: LightFound,
        sky: impl FnOnce() -> Option<MixtureDraw>,
    ) {
        let cos = dir.dot(normal).abs();
        let record = |value: f32, direct: f32, sky: f32, shadow| Record {
            p,
            dir,
            value,
            direct,
            sky,
            shadow,
        };
        let record = match found {
            LightFound::Sky {
                incident,
                integrand,
            } => {
                let sky = channel_mean(integrand);
                record(channel_mean(incident) * cos, 0.0, sky, Shadow::Untested)
            }
            LightFound::Emitter(incident) => {
                record(0.0, channel_mean(incident) * cos, 0.0, Shadow::Clear)
            }
            LightFound::EmitterBlocked => record(0.0, 0.0, 0.0, Shadow::Blocked),
            LightFound::Delta(incident) => {
                record(0.0, channel_mean(incident) * cos, 0.0, Shadow::Delta)
            }
            LightFound::Nothing => record(0.0, 0.0, 0.0, Shadow::Untested),
        };
        if record.value.is_finite() && record.direct.is_finite() {
            self.records.push(record);
            if let Some(m) = sky() {
                self.draw(p, dir, Draw::Sky(m));
            }
        }
    }

    fn sky_draw(&mut self, p: Vec3, dir: Vec3, draw: impl FnOnce() -> MixtureDraw) {
        self.draw(p, dir, Draw::Sky(draw()));
    }

    fn finish(&mut self) {
        for i in 0..self.len {
            let v = self.open[i];
            let direct = channel_mean(v.emitter) * v.cos / v.pdf;
            let value = channel_mean(v.radiance - v.emitter).max(0.0) * v.cos / v.pdf;
            if value.is_finite() && direct.is_finite() {
                self.records.push(Record {
                    p: v.p,
                    dir: v.dir,
                    value,
                    direct,
                    sky: match v.mixture {
                        Some(terms) => channel_mean(terms.bsdf_value * v.sky) / v.pdf,
                        None => 0.0,
                    },
                    shadow: Shadow::Untested,
                });
                if let Some(terms) = v.mixture {
                    let f = terms.bsdf_value;
                    let m =
                        MixtureDraw::new(f * v.radiance, terms.bsdf_pdf, 1.0, v.pdf, terms.normal);
                    self.draw(v.p, v.dir, Draw::Scattered(m));
                }
            }
        }
        self.len = 0;
    }
}

/// What `contribution` to a path's estimate was, as radiance arriving at a vertex of
/// throughput `t`: where a channel's throughput is 0, so is everything it adds.
fn per_throughput(contribution: Vec3, t: Vec3) -> Vec3 {
    let safe = Vec3::select(t.cmpgt(Vec3::ZERO), t, Vec3::ONE);
    Vec3::select(t.cmpgt(Vec3::ZERO), contribution / safe, Vec3::ZERO)
}

/// Whether a draw at `p` along `dir` is among a share `keep` of all draws: a hash of
/// the two below `keep` (every draw where `keep` is 1). The hash is mixed once more
/// than the spatial filter's jitter of the same point and direction, so which draws
/// are kept does not depend on where their records were deposited.
pub fn keeps(p: Vec3, dir: Vec3, keep: f32) -> bool {
    keep >= 1.0 || ((mix64(hash(p, dir) ^ 0x6b65_6570) >> 40) as f32) < keep * (1u32 << 24) as f32
}

/// 64 well-mixed bits from the bits of a point and a direction (SplitMix64's
/// finaliser over them).
pub fn hash(p: Vec3, d: Vec3) -> u64 {
    let bits = |v: Vec3| {
        (
            u64::from(v.x.to_bits()) << 32 | u64::from(v.y.to_bits()),
            v.z.to_bits(),
        )
    };
    let (a, b) = bits(p);
    let (c, e) = bits(d);
    mix64(a ^ mix64(c ^ mix64(u64::from(b) << 32 | u64::from(e))))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn no_terms() -> Option<MixtureTerms> {
        None
    }

    /// A vertex's record holds the light its ray found over the ray's density: in
    /// `direct` the emitter that very ray met, in `sky` only the sky it met (times the
    /// BSDF), in `value` the rest. A light sample's record holds an emitter it found in
    /// `direct` (and says its shadow ray was clear), a blocked one nothing (and says
    /// so), the sky in `value` and its integrand in `sky`. Every record's `value` and
    /// `direct` are times the cosine at its vertex; the `sky` values are integrands,
    /// which have it already.
    #[test]
    fn records_keep_the_direct_light_each_ray_met_apart() {
        let (mut records, mut draws) = (Vec::new(), Vec::new());
        let mut recorder = PathRecords::new(&mut records, &mut draws, 1.0);
        let (a, b) = (Vec3::ZERO, Vec3::X);
        // The normals: `Y` is at cosine 0.8 to `a`'s, `Z` and `Y` at 0.8 and 0.6 to `b`'s.
        let (na, nb) = (Vec3::new(0.6, 0.8, 0.0), Vec3::new(0.0, 0.6, 0.8));
        // Vertex `a` scatters with density 0.5 and meets an emitter of radiance 1, ...
        recorder.scattered(a, na, Vec3::Y, 0.5, Vec3::ONE, no_terms);
        recorder.met_emitter(Vec3::ONE);
        // ... `b`, of throughput 0.25, whose light samples find an emitter (2 over
        // their density), an emitter's sample blocked, and the sky (4 over their
        // density, its integrand `f·cos·Le` 2 over it); the path adds them times 0.25.
        recorder.light_sample(
            b,
            nb,
            Vec3::Z,
            LightFound::Emitter(Vec3::splat(2.0)),
            || None,
        );
        recorder.added(Vec3::splat(0.5));
        recorder.light_sample(b, nb, Vec3::Z, LightFound::EmitterBlocked, || None);
        let sky = LightFound::Sky {
            incident: Vec3::splat(4.0),
            integrand: Vec3::splat(2.0),
        };
        recorder.light_sample(b, nb, Vec3::Y, sky, || None);
        recorder.added(Vec3::ONE);
        // `b` scatters with density 0.25 and `f·cos` 0.5, and its ray meets the sky,
        // 3 times `b`'s throughput of 0.25.
        let terms = || {
            Some(MixtureTerms {
                bsdf_value: Vec3::splat(0.5),
                bsdf_pdf: 0.25,
                normal: nb,
            })
        };
        recorder.scattered(b, nb, Vec3::Y, 0.25, Vec3::splat(0.25), terms);
        recorder.met_sky(Vec3::splat(0.75));
        recorder.finish();
        let record = |p, dir, value: f32, direct: f32, sky, shadow| Record {
            p,
            dir,
            value,
            direct,
            sky,
            shadow,
        };
        assert_eq!(
            records,
            [
                record(b, Vec3::Z, 0.0, 2.0 * 0.8, 0.0, Shadow::Clear),
                record(b, Vec3::Z, 0.0, 0.0, 0.0, Shadow::Blocked),
                record(b, Vec3::Y, 4.0 * 0.6, 0.0, 2.0, Shadow::Untested),
                // 1 + 0.5 + 1 + 0.75 arrived along `a`'s ray, over 0.5: the 1 its ray
                // met directly, the rest (to `a`, `b`'s emitter is light reflected).
                record(
                    a,
                    Vec3::Y,
                    2.25 * 0.8 / 0.5,
                    0.8 / 0.5,
                    0.0,
                    Shadow::Untested
                ),
                // 3 arrived along `b`'s ray, all of it sky (0.5 · 3 of the integrand),
                // over 0.25.
                record(b, Vec3::Y, 3.0 * 0.6 / 0.25, 0.0, 6.0, Shadow::Untested),
            ]
        );
    }
}
