//! What a training path leaves behind: for each non-delta vertex, the radiance that
//! arrived along the direction it scattered into, and for each light sample, the
//! radiance that arrived along the light's direction.

use glam::Vec3;

/// The most vertices of one path whose incident radiance is tracked; deeper ones are
/// not recorded (the guide only needs some of them, and this keeps it allocation-free).
const MAX_OPEN: usize = 32;

/// One training record: at `p`, radiance arrived from the unit direction `dir`, and
/// `value` is its estimate (mean over colour channels) over the density with which
/// `dir` was drawn; `draw` says how a guided vertex drew it, where it did.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Record {
    pub p: Vec3,
    pub dir: Vec3,
    pub value: f32,
    pub draw: Option<Draw>,
}

/// How a guided vertex drew a record's direction from a mixture with its guide: what
/// the mixtures' shares are learnt from (see [`SdTree::refined`](super::SdTree::refined)).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Draw {
    /// The direction the path scattered into, from the BSDF–guide mixture.
    Scattered(MixtureDraw),
    /// A light sample's direction towards the sky, from the sky–guide mixture
    /// (`base_pdf` is the sky's own sampling density).
    Sky(MixtureDraw),
}

/// A direction drawn from the mixture of a base strategy (the BSDF's sampling, or the
/// sky's) and the guide, `(1 − s)·base_pdf + s·guide_pdf` for the share `s` in use.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MixtureDraw {
    /// The integrand's estimate along the direction, `f·cos · L` (mean over channels).
    pub integrand: f32,
    pub base_pdf: f32,
    pub guide_pdf: f32,
    /// The mixture's density, with which the direction was drawn.
    pub pdf: f32,
}

impl MixtureDraw {
    /// The draw of a direction whose integrand is `integrand` (per colour channel).
    pub fn new(integrand: Vec3, base_pdf: f32, guide_pdf: f32, pdf: f32) -> Self {
        MixtureDraw {
            integrand: mean(integrand),
            base_pdf,
            guide_pdf,
            pdf,
        }
    }
}

/// What a guided vertex tells its recorder about the draw, on request: the BSDF's
/// value `f·cos` and density and the guide's density along the direction drawn.
pub type MixtureTerms = (Vec3, f32, f32);

/// What the path tracer tells a recorder as a path unfolds.
pub trait PathRecorder {
    /// Whether records are kept (training): a guided vertex then draws and measures
    /// with its guide even where its region learnt not to use it, since the draws are
    /// what the region's shares are learnt from (see `VertexGuide::guides`).
    const RECORDS: bool;
    /// The path left the non-delta vertex `p` along `dir`, drawn with density `pdf`,
    /// and its throughput is now `throughput`: what it adds from now on, divided by
    /// that throughput, is the radiance that arrived along `dir`. At a guided vertex,
    /// `mixture` gives the draw's [`MixtureTerms`] (evaluated only if asked for).
    fn scattered(
        &mut self,
        p: Vec3,
        dir: Vec3,
        pdf: f32,
        throughput: Vec3,
        mixture: impl FnOnce() -> Option<MixtureTerms>,
    );
    /// The path's estimate grew by `contribution`.
    fn added(&mut self, contribution: Vec3);
    /// A light sample at `p` along `dir` found `incident_over_pdf` (radiance times its
    /// MIS weight, over the light sample's density); `sky` gives the draw of a sky
    /// sample at a guided vertex (evaluated only if asked for).
    fn light_sample(
        &mut self,
        p: Vec3,
        dir: Vec3,
        incident_over_pdf: Vec3,
        sky: impl FnOnce() -> Option<MixtureDraw>,
    );
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
        _: f32,
        _: Vec3,
        _: impl FnOnce() -> Option<MixtureTerms>,
    ) {
    }
    #[inline(always)]
    fn added(&mut self, _: Vec3) {}
    #[inline(always)]
    fn light_sample(&mut self, _: Vec3, _: Vec3, _: Vec3, _: impl FnOnce() -> Option<MixtureDraw>) {
    }
    #[inline(always)]
    fn finish(&mut self) {}
}

#[derive(Clone, Copy, Default)]
struct Open {
    p: Vec3,
    dir: Vec3,
    pdf: f32,
    throughput: Vec3,
    radiance: Vec3,
    mixture: Option<MixtureTerms>,
}

/// Records a path's vertices into `out` when it ends.
pub struct PathRecords<'o> {
    open: [Open; MAX_OPEN],
    len: usize,
    out: &'o mut Vec<Record>,
}

impl<'o> PathRecords<'o> {
    pub fn new(out: &'o mut Vec<Record>) -> Self {
        PathRecords {
            open: [Open::default(); MAX_OPEN],
            len: 0,
            out,
        }
    }
}

fn mean(v: Vec3) -> f32 {
    (v.x + v.y + v.z) / 3.0
}

impl PathRecorder for PathRecords<'_> {
    const RECORDS: bool = true;
    fn scattered(
        &mut self,
        p: Vec3,
        dir: Vec3,
        pdf: f32,
        throughput: Vec3,
        mixture: impl FnOnce() -> Option<MixtureTerms>,
    ) {
        if self.len < MAX_OPEN && pdf > 0.0 {
            self.open[self.len] = Open {
                p,
                dir,
                pdf,
                throughput,
                radiance: Vec3::ZERO,
                mixture: mixture(),
            };
            self.len += 1;
        }
    }

    fn added(&mut self, contribution: Vec3) {
        for v in &mut self.open[..self.len] {
            // Where a channel's throughput is 0, so is everything it adds.
            let t = v.throughput;
            let safe = Vec3::select(t.cmpgt(Vec3::ZERO), t, Vec3::ONE);
            v.radiance += Vec3::select(t.cmpgt(Vec3::ZERO), contribution / safe, Vec3::ZERO);
        }
    }

    fn light_sample(
        &mut self,
        p: Vec3,
        dir: Vec3,
        incident_over_pdf: Vec3,
        sky: impl FnOnce() -> Option<MixtureDraw>,
    ) {
        let value = mean(incident_over_pdf);
        if value.is_finite() {
            self.out.push(Record {
                p,
                dir,
                value,
                draw: sky().map(Draw::Sky),
            });
        }
    }

    fn finish(&mut self) {
        for v in &self.open[..self.len] {
            let value = mean(v.radiance) / v.pdf;
            if value.is_finite() {
                let draw = v.mixture.map(|(f, bsdf_pdf, guide_pdf)| {
                    Draw::Scattered(MixtureDraw::new(f * v.radiance, bsdf_pdf, guide_pdf, v.pdf))
                });
                self.out.push(Record {
                    p: v.p,
                    dir: v.dir,
                    value,
                    draw,
                });
            }
        }
        self.len = 0;
    }
}
