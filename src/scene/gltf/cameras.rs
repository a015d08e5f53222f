//! A glTF's cameras as ember's: the eye at the node's origin, looking along its −Z
//! with +Y up, the vertical field of view `yfov`. The image's aspect is ember's
//! `--width`/`--height`, not the camera's `aspectRatio`. Orthographic cameras are
//! listed but cannot be rendered through (ember's camera is a pinhole or thin lens).

use glam::{Affine3A, Vec3};
use gltf::camera::Projection;

use crate::scene::{CameraSettings, Lens};

/// A camera a file places.
#[derive(Clone, Debug, PartialEq)]
pub struct FileCamera {
    /// Its name, or `camera N`.
    pub name: String,
    /// Where it is and what it sees; `None` for an orthographic camera.
    pub settings: Option<CameraSettings>,
    /// The file's `aspectRatio`, when it gives one.
    pub aspect: Option<f32>,
}

/// The camera `camera` at the place `world` of its node `node`.
pub fn camera(camera: &gltf::Camera<'_>, world: &Affine3A) -> Result<FileCamera, String> {
    let name = camera
        .name()
        .map_or_else(|| format!("camera {}", camera.index()), str::to_owned);
    let (settings, aspect) = match camera.projection() {
        Projection::Orthographic(_) => (None, None),
        Projection::Perspective(p) => {
            let degrees = p.yfov().to_degrees();
            if !(degrees > 0.0 && degrees < 180.0) {
                return Err(format!(
                    "camera {name:?}: its yfov {} is not an angle between 0 and pi",
                    p.yfov()
                ));
            }
            let eye = world.transform_point3(Vec3::ZERO);
            let forward = world.transform_vector3(-Vec3::Z).normalize_or_zero();
            let up = world.transform_vector3(Vec3::Y).normalize_or_zero();
            let settings = CameraSettings {
                eye,
                look_at: eye + forward,
                up,
                vfov_degrees: degrees,
                lens: Lens::PINHOLE,
            };
            settings
                .validate()
                .map_err(|e| format!("camera {name:?}: its node's transform gives {e}"))?;
            (Some(settings), p.aspect_ratio())
        }
    };
    Ok(FileCamera {
        name,
        settings,
        aspect,
    })
}
