//! A glTF's cameras as ember's: the eye at the node's origin, looking along its −Z
//! with +Y up (the node's scale ignored, as the specification says). A perspective
//! camera has the vertical field of view `yfov`; an orthographic one shows `2·ymag`
//! scene units vertically. `znear` and `zfar` are not read: camera rays start at the
//! camera and go on without end. The aspect ratio each was made for (`aspectRatio`,
//! or `xmag/ymag`) completes the image size the command line leaves out.

use glam::{Affine3A, Vec3};
use gltf::camera::Projection as GltfProjection;

use crate::scene::{CameraSettings, Lens, Projection};

/// A camera a file places.
#[derive(Clone, Debug, PartialEq)]
pub struct FileCamera {
    /// Its name, or `camera N`.
    pub name: String,
    /// Where it is and what it sees.
    pub settings: CameraSettings,
    /// The image's width over its height that the camera was made for: a perspective
    /// camera's `aspectRatio`, when it gives one; an orthographic camera's `xmag/ymag`.
    pub aspect: Option<f32>,
    /// For a scene file's cameras, the name of the `[[mesh]]` entry whose glTF places it.
    pub mesh: Option<String>,
}

/// The camera `camera` at the place `world` of its node.
pub fn camera(camera: &gltf::Camera<'_>, world: &Affine3A) -> Result<FileCamera, String> {
    let name = camera
        .name()
        .map_or_else(|| format!("camera {}", camera.index()), str::to_owned);
    let positive = |key: &str, v: f32| match v.is_finite() && v > 0.0 {
        true => Ok(v),
        false => Err(format!(
            "camera {name:?}: its {key} {v} is not a number above 0"
        )),
    };
    let (projection, aspect) = match camera.projection() {
        GltfProjection::Perspective(p) => {
            let degrees = p.yfov().to_degrees();
            if !(degrees > 0.0 && degrees < 180.0) {
                return Err(format!(
                    "camera {name:?}: its yfov {} is not an angle between 0 and pi",
                    p.yfov()
                ));
            }
            let aspect = match p.aspect_ratio() {
                Some(a) => Some(positive("aspectRatio", a)?),
                None => None,
            };
            (Projection::perspective(degrees), aspect)
        }
        GltfProjection::Orthographic(o) => {
            let (xmag, ymag) = (positive("xmag", o.xmag())?, positive("ymag", o.ymag())?);
            let height = 2.0 * ymag;
            (Projection::Orthographic { height }, Some(xmag / ymag))
        }
    };
    let eye = world.transform_point3(Vec3::ZERO);
    let forward = world.transform_vector3(-Vec3::Z).normalize_or_zero();
    let up = world.transform_vector3(Vec3::Y).normalize_or_zero();
    let settings = CameraSettings {
        eye,
        look_at: eye + forward,
        up,
        projection,
        lens: Lens::PINHOLE,
    };
    settings
        .validate()
        .map_err(|e| format!("camera {name:?}: its node's transform gives {e}"))?;
    Ok(FileCamera {
        name,
        settings,
        aspect,
        mesh: None,
    })
}
