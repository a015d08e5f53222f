//! A look through the camera before rendering: a grid of rays through the image, and
//! from each surface they meet a few shadow rays towards points on the emitters. It
//! tells, for a few hundred rays, whether the camera sees anything, whether it sees the
//! back of the surfaces (an interior modelled to be seen from inside, looked at from
//! outside), and whether any light reaches what it sees directly: the cases where a
//! render would come out black for a reason the user can fix.

use glam::Vec3;

use crate::accel::Accel;
use crate::geometry::{barycentric_error, SurfaceOrigin};
use crate::sampling::{uniform_triangle, Rng};
use crate::scene::{Camera, Scene};

/// Rays across and down the image.
const GRID: u32 = 16;
/// Shadow rays from each surface point met.
const LIGHT_SAMPLES: u32 = 8;

/// What the probe rays found.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct CameraProbe {
    /// Rays traced through the image.
    pub rays: u32,
    /// Of those, the ones that met a surface.
    pub hits: u32,
    /// Of the hits, those on the back of a surface (against its counter-clockwise
    /// winding's normal).
    pub back_faces: u32,
    /// Of the hits, those from which a shadow ray reached a point of an emitter;
    /// `None` when the scene has a sky or no emitter (a sky lights whatever sees it),
    /// or placed points, spots or suns, which the probe does not look for.
    pub lit: Option<u32>,
}

impl CameraProbe {
    /// Whether nearly all surfaces seen are seen from behind.
    pub fn sees_backs(&self) -> bool {
        self.hits > 0 && self.back_faces * 10 >= self.hits * 9
    }

    /// Whether no light reaches any surface seen (with emitters and no sky).
    pub fn sees_nothing_lit(&self) -> bool {
        self.hits > 0 && self.lit == Some(0)
    }
}

/// Probes the view of `camera`, of a `width × height` image, into `scene`.
pub fn probe_camera<A: Accel>(
    scene: &Scene,
    accel: &A,
    camera: &Camera,
    (width, height): (u32, u32),
) -> CameraProbe {
    let mut probe = CameraProbe {
        rays: GRID * GRID,
        lit: (scene.sky.is_none() && !scene.emitters.is_empty() && scene.lights.is_empty())
            .then_some(0),
        ..CameraProbe::default()
    };
    let mut rng = Rng::seeded(0x5eed);
    for j in 0..GRID {
        for i in 0..GRID {
            let x = (i as f32 + 0.5) / GRID as f32 * width as f32;
            let y = (j as f32 + 0.5) / GRID as f32 * height as f32;
            let ray = camera.ray(x, y);
            let Some(hit) = accel.intersect(&ray) else {
                continue;
            };
            probe.hits += 1;
            let surface = scene.surface(&hit);
            if surface.ng.dot(ray.dir) > 0.0 {
                probe.back_faces += 1;
            }
            if let Some(lit) = probe.lit.as_mut() {
                let seen_side = -ray.dir;
                if reaches_light(scene, accel, &surface.origin(), seen_side, &mut rng) {
                    *lit += 1;
                }
            }
        }
    }
    probe
}

/// Whether a shadow ray from `at`, on the side of the surface `side` points to,
/// reaches one of a few points drawn on the scene's emitters.
fn reaches_light<A: Accel>(
    scene: &Scene,
    accel: &A,
    at: &SurfaceOrigin,
    side: Vec3,
    rng: &mut Rng,
) -> bool {
    let lights = scene.light_mesh();
    let facing = at.ng.dot(side).signum();
    (0..LIGHT_SAMPLES).any(|_| {
        let k = (rng.f32() * scene.emitters.len() as f32) as usize;
        let emitter = scene.emitters[k.min(scene.emitters.len() - 1)];
        let corners = lights.vertices(emitter);
        let (b1, b2) = uniform_triangle(rng.f32(), rng.f32());
        let b = [1.0 - b1 - b2, b1, b2];
        let q = b[0] * corners[0] + b[1] * corners[1] + b[2] * corners[2];
        let n = (corners[1] - corners[0]).cross(corners[2] - corners[0]);
        let material = &scene.materials[lights.material[emitter as usize] as usize];
        // Emitters light their counter-clockwise side (or both), and the point must
        // see it from the side the camera sees.
        if !material.emits_along(q - at.p, n) || (q - at.p).dot(at.ng) * facing <= 0.0 {
            return false;
        }
        let to = SurfaceOrigin {
            p: q,
            error: barycentric_error(b, corners),
            ng: n.normalize_or_zero(),
        };
        !accel.occluded(&at.spawn_to(&to))
    })
}
