//! What a guide learnt, seen from one pixel: the directional distributions of the
//! region of the first point the pixel's centre ray scatters at (through mirrors and
//! glass, as a path would), of all incident light and of the sky seen directly, as
//! images (`ember render --guide-image`, `--guide-sky`).

use glam::{Vec2, Vec3};

use crate::accel::Accel;
use crate::guiding::{mass_in_cone, QuadTree, SdTree};
use crate::sampling::Rng;
use crate::scene::{Camera, Scene};

/// The learnt distributions at one pixel's first non-delta vertex.
#[derive(Clone, Debug, PartialEq)]
pub struct GuideView {
    /// The vertex, and its shading normal turned to the side the ray came from.
    pub p: Vec3,
    pub normal: Vec3,
    /// The region's probability of drawing from the guide rather than the BSDF.
    pub selection: f32,
    /// The region's share of sky samples drawn from the guide.
    pub sky_share: f32,
    /// The region's distribution of all incident light, which scattered directions
    /// follow.
    pub all_light: GuidePicture,
    /// The region's distribution of the sky it sees directly, which sky samples
    /// follow.
    pub sky: GuidePicture,
}

/// One of a region's distributions, as a picture.
#[derive(Clone, Debug, PartialEq)]
pub struct GuidePicture {
    /// The share of the distribution's mass below the vertex's surface (what the fold
    /// mirrors onto the side the BSDF reflects into).
    pub below: f64,
    pub width: u32,
    pub height: u32,
    /// Density per steradian, row by row ([`crate::guiding::QuadTree::density_image`]).
    pub density: Vec<f32>,
}

impl GuidePicture {
    fn of(tree: &QuadTree, normal: Vec3, (width, height): (u32, u32)) -> Self {
        GuidePicture {
            below: mass_in_cone(&|d| tree.pdf(d), -normal, std::f32::consts::FRAC_PI_2),
            width,
            height,
            density: tree.density_image(width, height),
        }
    }
}

/// The learnt distributions at the first non-delta vertex of the ray through the
/// centre of pixel `(x, y)` (the lens's centre for a thin lens), as `size` images.
/// Delta vertices are passed as one path would (glass refracts or reflects by a draw
/// of a fixed stream). `None` when the ray leaves the scene or meets no non-delta
/// vertex within `max_depth` segments.
#[allow(clippy::too_many_arguments)]
pub fn guide_view<A: Accel>(
    scene: &Scene,
    accel: &A,
    camera: &Camera,
    tree: &SdTree,
    (x, y): (u32, u32),
    max_depth: u32,
    size: (u32, u32),
) -> Option<GuideView> {
    let mut ray = camera.ray(x as f32 + 0.5, y as f32 + 0.5);
    let mut rng = Rng::seeded(0x6775_6964_6576_6965);
    for _ in 0..max_depth.max(1) {
        let hit = accel.intersect(&ray)?;
        let surface = scene.surface(&hit);
        let wo = -ray.dir;
        let bsdf = scene.bsdf(&surface, wo);
        if bsdf.is_delta() {
            let (u1, u2) = rng.pair();
            let sample = bsdf.sample(wo, Vec2::new(u1, u2))?;
            ray = surface.origin().spawn(sample.wi);
            continue;
        }
        let normal = if wo.dot(surface.ng) < 0.0 {
            -surface.ns
        } else {
            surface.ns
        };
        return Some(GuideView {
            p: surface.p,
            normal,
            selection: tree.selection_at(surface.p),
            sky_share: tree.sky_share_at(surface.p),
            all_light: GuidePicture::of(tree.at(surface.p), normal, size),
            sky: GuidePicture::of(tree.sky_at(surface.p), normal, size),
        });
    }
    None
}
