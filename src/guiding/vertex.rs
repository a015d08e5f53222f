//! The guide as one vertex of a path uses it: its region's directional distribution
//! folded onto the hemisphere its BSDF reflects into, and the region's probability of
//! drawing from the guide rather than the BSDF; likewise for sky samples, the region's
//! distribution of the sky it sees directly and its share of sky samples.
//!
//! Why the fold: a region's quadtree is learnt from every surface in it, so at a point
//! of the floor it also holds the light that arrived at a nearby wall or the sofa from
//! below the floor's plane: 10–30% of its mass on the rooms tried, which a reflective
//! BSDF turns into void samples. Folding mirrors that mass across the surface, so
//! every guided draw lands where the BSDF can reflect, and the density stays exact:
//! with `R` the mirror across the plane of the normal `n` (an involution that
//! preserves solid angle), the folded density is
//! `g_n(ω) = [ω·n > 0] · (g(ω) + g(Rω))`, which integrates to 1 over the sphere
//! because `g` does.

use glam::{Vec2, Vec3};

use super::quadtree::square_to_direction;
use super::QuadTree;
use crate::light::SkyGuide;

/// The guide at one non-delta vertex (see the module notes).
#[derive(Clone, Copy, Debug)]
pub struct VertexGuide<'a> {
    tree: &'a QuadTree,
    /// The region's distribution of the sky light it sees directly, which its sky
    /// samples are drawn from (see [`with_sky`](Self::with_sky)).
    sky: &'a QuadTree,
    /// The unit normal of the side the BSDF reflects into (the side of `wo`).
    normal: Vec3,
    /// Probability of drawing from the guide rather than the BSDF.
    selection: f32,
    /// Probability of drawing a sky sample from the guide rather than the sky's own
    /// distribution.
    sky_share: f32,
    /// The region's estimate of `∫ L |cos θ| dω`, the irradiance of its surfaces
    /// (see [`SdTree::incident_at`](super::SdTree::incident_at)).
    incident: f32,
}

impl<'a> VertexGuide<'a> {
    /// The distribution `tree` folded onto the hemisphere around the unit `normal`,
    /// drawn from with probability `selection` for scattered directions and
    /// `sky_share` for sky samples.
    #[inline]
    pub fn new(tree: &'a QuadTree, normal: Vec3, selection: f32, sky_share: f32) -> Self {
        VertexGuide {
            tree,
            sky: tree,
            normal,
            selection,
            sky_share,
            incident: 0.0,
        }
    }

    /// This guide, drawing its sky samples from `sky` (folded likewise) rather than
    /// from the distribution of all incident light: the region's sky light alone,
    /// without the light its walls and floor reflect, which a sky sample cannot find.
    #[inline]
    pub fn with_sky(mut self, sky: &'a QuadTree) -> Self {
        self.sky = sky;
        self
    }

    /// This guide, its region's estimate of `∫ L |cos θ| dω` being `incident`.
    #[inline]
    pub fn with_incident(mut self, incident: f32) -> Self {
        self.incident = incident;
        self
    }

    /// The region's estimate of `∫ L |cos θ| dω` (0 where it learnt none).
    #[inline]
    pub fn incident(&self) -> f32 {
        self.incident
    }

    /// The probability of drawing the direction from the guide.
    #[inline]
    pub fn selection(&self) -> f32 {
        self.selection
    }

    /// The unit normal the guide's density is folded about.
    #[inline]
    pub fn normal(&self) -> Vec3 {
        self.normal
    }

    /// The probability of drawing a sky sample from the guide.
    #[inline]
    pub fn sky_share(&self) -> f32 {
        self.sky_share
    }

    /// Whether the guide takes part at all: a region that learnt to draw neither
    /// scattered directions nor sky samples from it (both shares 0, where guiding did
    /// not pay for its cost) is rendered as unguided `mis` is, which is the same
    /// estimator (the mixtures' densities are then the BSDF's and the sky's own)
    /// without the guide's lookups.
    #[inline]
    pub fn guides(&self) -> bool {
        draws_from_guide(self.selection, self.sky_share)
    }

    #[inline]
    fn mirror(&self, d: Vec3) -> Vec3 {
        d - 2.0 * d.dot(self.normal) * self.normal
    }

    /// A unit direction drawn from the folded density, from two uniforms in `[0, 1)`.
    #[inline]
    pub fn sample(&self, u: Vec2) -> Vec3 {
        let d = self.tree.sample(u);
        if d.dot(self.normal) < 0.0 {
            self.mirror(d)
        } else {
            d
        }
    }

    /// [`sample`](Self::sample) and its density ([`pdf`](Self::pdf), bit for bit),
    /// the draw's own leaf cell standing in for one of the two descents the density
    /// takes (see [`QuadTree::pdf_knowing`]).
    #[inline]
    pub fn sample_with_pdf(&self, u: Vec2) -> (Vec3, f32) {
        self.folded_sample_with_pdf(self.tree, u)
    }

    /// Density per steradian of the folded distribution at the unit direction `d`.
    #[inline]
    pub fn pdf(&self, d: Vec3) -> f32 {
        self.folded_pdf(self.tree, d)
    }

    /// Density per steradian of the folded sky distribution at the unit direction `d`
    /// (see [`with_sky`](Self::with_sky)).
    #[inline]
    pub fn sky_pdf(&self, d: Vec3) -> f32 {
        self.folded_pdf(self.sky, d)
    }

    #[inline]
    fn folded_sample_with_pdf(&self, tree: &QuadTree, u: Vec2) -> (Vec3, f32) {
        let (p, cell) = tree.sample_cell(u);
        let drawn = square_to_direction(p);
        let d = if drawn.dot(self.normal) < 0.0 {
            self.mirror(drawn)
        } else {
            drawn
        };
        if d.dot(self.normal) <= 0.0 {
            return (d, 0.0);
        }
        let pdf = tree.pdf_knowing(d, &cell) + tree.pdf_knowing(self.mirror(d), &cell);
        (d, pdf)
    }

    #[inline]
    fn folded_pdf(&self, tree: &QuadTree, d: Vec3) -> f32 {
        if d.dot(self.normal) <= 0.0 {
            return 0.0;
        }
        let (direct, mirrored) = tree.pdf_pair(d, self.mirror(d));
        direct + mirrored
    }

    /// The density of the one-sample mixture of the BSDF (density `bsdf_pdf` at `d`)
    /// and this guide: the BSDF's own where nothing is drawn from the guide, without
    /// its lookup (what [`mixture_of`](Self::mixture_of) gives then, bit for bit).
    #[inline]
    pub fn mixture_pdf(&self, bsdf_pdf: f32, d: Vec3) -> f32 {
        if self.selection == 0.0 {
            return bsdf_pdf;
        }
        self.mixture_of(bsdf_pdf, self.pdf(d))
    }

    /// The mixture's density from the BSDF's and this guide's densities at a direction.
    #[inline]
    pub fn mixture_of(&self, bsdf_pdf: f32, guide_pdf: f32) -> f32 {
        (1.0 - self.selection) * bsdf_pdf + self.selection * guide_pdf
    }
}

/// Whether a region with these shares draws anything from its guide (see
/// [`VertexGuide::guides`]).
#[inline]
pub(super) fn draws_from_guide(selection: f32, sky_share: f32) -> bool {
    selection > 0.0 || sky_share > 0.0
}

/// Sky samples drawn where the region learnt that the sky is seen directly rather
/// than hidden by walls (a room lit through its windows): from its sky distribution
/// (see [`with_sky`](VertexGuide::with_sky)).
impl SkyGuide for VertexGuide<'_> {
    #[inline]
    fn sample_with_pdf(&self, u: Vec2) -> (Vec3, f32) {
        self.folded_sample_with_pdf(self.sky, u)
    }

    #[inline]
    fn pdf(&self, dir: Vec3) -> f32 {
        self.sky_pdf(dir)
    }
}
