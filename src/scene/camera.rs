//! The camera: eye, look-at point and up vector, and a projection: perspective (a
//! vertical field of view, through a pinhole or a thin lens of an aperture radius and a
//! focus distance) or orthographic (parallel rays across a view of a given height).

use glam::{Affine3A, Vec3};

use crate::geometry::Ray;

/// Where the camera is and what it sees. Row 0 of the image is the top; image-right is
/// the camera's +x (`forward × up`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CameraSettings {
    pub eye: Vec3,
    pub look_at: Vec3,
    pub up: Vec3,
    /// Perspective (a vertical field of view) or orthographic (a view's height).
    pub projection: Projection,
    /// The lens of a perspective camera: a pinhole, or a thin lens with depth of field.
    pub lens: Lens,
}

/// How image positions map to rays.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Projection {
    /// Rays leave the eye (or the lens) through the image; the vertical field of view
    /// in degrees, in (0, 180).
    Perspective { vfov_degrees: f32 },
    /// Rays run parallel to the view direction from the plane through the eye that
    /// faces it; the image spans `height` scene units vertically about the eye.
    Orthographic { height: f32 },
}

impl Projection {
    /// A perspective projection of vertical field of view `vfov_degrees`.
    pub const fn perspective(vfov_degrees: f32) -> Projection {
        Projection::Perspective { vfov_degrees }
    }

    /// The vertical field of view of a perspective projection.
    pub fn vfov_degrees(&self) -> Option<f32> {
        match *self {
            Projection::Perspective { vfov_degrees } => Some(vfov_degrees),
            Projection::Orthographic { .. } => None,
        }
    }

    /// The view's height of an orthographic projection.
    pub fn ortho_height(&self) -> Option<f32> {
        match *self {
            Projection::Orthographic { height } => Some(height),
            Projection::Perspective { .. } => None,
        }
    }
}

/// A thin lens: rays leave a disk of `aperture_radius` (world units) about the eye,
/// centred on the view direction, and meet again on the plane `focus_distance` in
/// front of the eye, so that plane is sharp and a point at depth `z` spreads over a
/// disk of radius `aperture_radius · |1 − focus_distance / z|` measured on that plane
/// (the thin-lens circle of confusion). An aperture of 0 is the pinhole.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Lens {
    pub aperture_radius: f32,
    /// Distance from the eye to the plane in focus, along the view direction;
    /// `None`: the distance to the look-at point.
    pub focus_distance: Option<f32>,
}

impl Lens {
    pub const PINHOLE: Lens = Lens {
        aperture_radius: 0.0,
        focus_distance: None,
    };

    pub fn is_pinhole(&self) -> bool {
        self.aperture_radius == 0.0
    }
}

impl Default for Lens {
    fn default() -> Self {
        Lens::PINHOLE
    }
}

/// A camera ready to generate rays for one image size.
#[derive(Clone, Copy, Debug)]
pub struct Camera {
    eye: Vec3,
    forward: Vec3,
    /// Image-right, scaled so that x in [-1, 1] spans the image width (at unit depth
    /// for a perspective camera, in scene units for an orthographic one).
    right: Vec3,
    /// Image-up, scaled so that y in [-1, 1] spans the image height.
    up: Vec3,
    width: f32,
    height: f32,
    /// Orthographic: rays along `forward` from `eye + sx·right + sy·up`.
    parallel: bool,
    /// The lens disk's axes (image-right and image-up, scaled by the aperture
    /// radius) and the focus distance; zero axes for a pinhole.
    lens_right: Vec3,
    lens_up: Vec3,
    focus_distance: f32,
}

/// A camera without a lens, as [`Camera::ray`] computes with: with `sx = 2x/width − 1`
/// and `sy = 1 − 2y/height`, the ray through image position `(x, y)` leaves `eye` along
/// `forward + sx·right + sy·up` (normalised), or, when `parallel` (orthographic), leaves
/// `eye + sx·right + sy·up` along `forward`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CameraFrame {
    pub eye: Vec3,
    pub forward: Vec3,
    pub right: Vec3,
    pub up: Vec3,
    pub width: f32,
    pub height: f32,
    pub parallel: bool,
}

impl CameraSettings {
    /// A view of the box `lo..hi` from its +z side (OBJ scenes are y-up), far enough
    /// back that the whole box fits in the vertical field of view.
    pub fn framing(lo: Vec3, hi: Vec3, vfov_degrees: f32) -> Self {
        let center = 0.5 * (lo + hi);
        let half = 0.5 * (hi - lo);
        let half_fov = (0.5 * vfov_degrees).to_radians();
        // Fit the front face's half-extent (x or y) in view, measured from that face.
        let extent = half.x.max(half.y).max(1e-6);
        let distance = half.z + extent / half_fov.tan();
        CameraSettings {
            eye: center + Vec3::new(0.0, 0.0, distance),
            look_at: center,
            up: Vec3::Y,
            projection: Projection::perspective(vfov_degrees),
            lens: Lens::PINHOLE,
        }
    }

    /// Checks that the settings describe a camera: distinct eye and target, an up vector
    /// not parallel to the view direction, a field of view strictly between 0 and 180
    /// or an orthographic height above 0, and a lens only on a perspective camera.
    pub fn validate(&self) -> Result<(), String> {
        let finite = self.eye.is_finite() && self.look_at.is_finite() && self.up.is_finite();
        if !finite {
            return Err("camera vectors must be finite".into());
        }
        match self.projection {
            Projection::Perspective { vfov_degrees } => {
                if !(vfov_degrees > 0.0 && vfov_degrees < 180.0) {
                    return Err(format!(
                        "field of view must be between 0 and 180 degrees (exclusive), got \
                         {vfov_degrees}"
                    ));
                }
            }
            Projection::Orthographic { height } => {
                if !(height.is_finite() && height > 0.0) {
                    return Err(format!(
                        "an orthographic view's height must be finite and above 0, got {height}"
                    ));
                }
                if !self.lens.is_pinhole() {
                    return Err("depth of field (--aperture) does not apply to an \
                                orthographic camera, whose rays are parallel"
                        .into());
                }
            }
        }
        let forward = self.look_at - self.eye;
        if forward.length_squared() < 1e-12 {
            return Err("camera eye and look-at point are the same".into());
        }
        if forward.normalize().cross(self.up).length_squared() < 1e-10 {
            return Err("camera up vector is parallel to the view direction".into());
        }
        self.lens.validate()
    }

    /// The camera moved by `transform` (a scene file's placement of the model that
    /// holds it): its eye, view direction and up vector, and an orthographic view's
    /// height scaled as the transform scales the camera's vertical.
    pub fn placed(&self, transform: &Affine3A) -> CameraSettings {
        let forward = self.look_at - self.eye;
        let up = forward.cross(self.up).cross(forward).normalize_or_zero();
        let projection = match self.projection {
            Projection::Orthographic { height } => Projection::Orthographic {
                height: height * transform.transform_vector3(up).length(),
            },
            perspective => perspective,
        };
        let eye = transform.transform_point3(self.eye);
        CameraSettings {
            eye,
            look_at: eye + transform.transform_vector3(forward),
            up: transform.transform_vector3(self.up),
            projection,
            lens: self.lens,
        }
    }

    /// The camera for an image of `width × height` pixels. Call [`validate`] first.
    ///
    /// [`validate`]: CameraSettings::validate
    pub fn camera(&self, width: u32, height: u32) -> Camera {
        let forward = (self.look_at - self.eye).normalize();
        let right = forward.cross(self.up).normalize();
        let up = right.cross(forward);
        // Half the image's height: at unit depth, or in scene units.
        let (half, parallel) = match self.projection {
            Projection::Perspective { vfov_degrees } => {
                ((0.5 * vfov_degrees).to_radians().tan(), false)
            }
            Projection::Orthographic { height } => (0.5 * height, true),
        };
        let aspect = width as f32 / height as f32;
        let focus_distance = self
            .lens
            .focus_distance
            .unwrap_or_else(|| (self.look_at - self.eye).length());
        Camera {
            eye: self.eye,
            forward,
            right: right * half * aspect,
            up: up * half,
            width: width as f32,
            height: height as f32,
            parallel,
            lens_right: right * self.lens.aperture_radius,
            lens_up: up * self.lens.aperture_radius,
            focus_distance,
        }
    }
}

impl Lens {
    /// A radius of at least 0 and a focus distance above 0, both finite.
    fn validate(&self) -> Result<(), String> {
        if !(self.aperture_radius.is_finite() && self.aperture_radius >= 0.0) {
            return Err(format!(
                "aperture radius must be finite and at least 0, got {}",
                self.aperture_radius
            ));
        }
        match self.focus_distance {
            Some(d) if !(d.is_finite() && d > 0.0) => Err(format!(
                "focus distance must be finite and above 0, got {d}"
            )),
            _ => Ok(()),
        }
    }
}

impl Camera {
    /// The ray through image position `(x, y)` in pixels, `(0, 0)` being the top-left
    /// corner of the image. Its direction is normalised.
    #[inline]
    pub fn ray(&self, x: f32, y: f32) -> Ray {
        let sx = 2.0 * x / self.width - 1.0;
        let sy = 1.0 - 2.0 * y / self.height;
        if self.parallel {
            return Ray::new(self.eye + sx * self.right + sy * self.up, self.forward);
        }
        let dir = (self.forward + sx * self.right + sy * self.up).normalize();
        Ray::new(self.eye, dir)
    }

    /// What [`ray`](Self::ray) computes with, for code that makes camera rays in
    /// lanes: `None` for a thin lens.
    pub fn frame(&self) -> Option<CameraFrame> {
        (!self.has_lens()).then_some(CameraFrame {
            eye: self.eye,
            forward: self.forward,
            right: self.right,
            up: self.up,
            width: self.width,
            height: self.height,
            parallel: self.parallel,
        })
    }

    /// Whether rays come from a lens disk (then [`lens_ray`](Self::lens_ray) takes
    /// two more random numbers) rather than from the eye alone.
    #[inline]
    pub fn has_lens(&self) -> bool {
        self.lens_right != Vec3::ZERO
    }

    /// The ray through image position `(x, y)` from the point `lens` (two uniforms
    /// in `[0, 1)`, mapped to the disk area-uniformly) of the thin lens: it passes
    /// where the pinhole ray meets the plane in focus.
    #[inline]
    pub fn lens_ray(&self, x: f32, y: f32, lens: (f32, f32)) -> Ray {
        let sx = 2.0 * x / self.width - 1.0;
        let sy = 1.0 - 2.0 * y / self.height;
        // The pinhole direction has unit depth along `forward`.
        let focus =
            self.eye + self.focus_distance * (self.forward + sx * self.right + sy * self.up);
        let (dx, dy) = crate::sampling::concentric_disk(lens.0, lens.1);
        let origin = self.eye + dx * self.lens_right + dy * self.lens_up;
        Ray::new(origin, (focus - origin).normalize())
    }
}
