//! A renderable scene: one triangle mesh, its materials and textures, and the list of
//! emissive triangles. Immutable once built.

mod alpha;
mod camera;
mod environment;
mod material;
mod mesh;
mod obj;
mod obj_parallel;
mod opacity;
mod textures;

pub use alpha::AlphaMap;
pub use camera::{Camera, CameraSettings};
pub use environment::{Environment, SkySample};
pub use material::{alpha_from_ns, Material, Model, MtlValues, Texture};
pub use mesh::{triangle_bounds, SurfacePoint, TriangleMesh};
pub use obj::{
    check_counts, load_obj, load_obj_from_str, LoadReport, MAX_TRIANGLES, MEMORY_PER_OBJ_BYTE,
};
#[doc(hidden)]
pub use obj_parallel::check_against_tobj;
pub use opacity::{coin, Opacity};

use glam::Vec3;
use std::path::PathBuf;
use std::sync::Arc;

use crate::bsdf::Bsdf;

/// Why a scene could not be loaded. Each message is one line that names the file.
#[derive(Debug, thiserror::Error)]
pub enum SceneError {
    #[error("cannot read {path}: {source}")]
    Io {
        path: PathBuf,
        source: std::io::Error,
    },
    #[error("{path} is a directory, not an OBJ file")]
    IsDirectory { path: PathBuf },
    #[error("{path} is not a valid OBJ file: {reason}")]
    Obj { path: PathBuf, reason: String },
    #[error("material library {path} (named by mtllib in {obj}): {reason}")]
    Mtl {
        path: PathBuf,
        obj: PathBuf,
        reason: String,
    },
    #[error("texture {path} ({slot} of material {material:?}): {reason}")]
    Texture {
        path: PathBuf,
        /// The MTL statement that names it (`map_Kd`, `map_d`).
        slot: &'static str,
        material: String,
        reason: String,
    },
    #[error("material {material:?}: {reason}")]
    Material { material: String, reason: String },
    #[error("{path}: {what} {index} is not finite ({value})")]
    NonFinite {
        path: PathBuf,
        what: &'static str,
        index: usize,
        value: String,
    },
    #[error("{path} has no triangles to render{detail}")]
    Empty { path: PathBuf, detail: String },
    #[error("{path}: {what}")]
    TooLarge { path: PathBuf, what: String },
    #[error("environment map {path}: {reason}")]
    Environment { path: PathBuf, reason: String },
}

/// Everything the integrator reads.
#[derive(Clone, Debug)]
pub struct Scene {
    pub mesh: TriangleMesh,
    pub materials: Vec<Material>,
    pub textures: Vec<Texture>,
    /// Opacity maps of the materials' cut-outs (`Material::opacity_map`), shared with
    /// the accelerator's [`Opacity`] filter.
    pub alpha_maps: Vec<Arc<AlphaMap>>,
    /// Indices of the triangles whose material emits.
    pub emitters: Vec<u32>,
    /// Radiance arriving where rays leave the scene: an environment map or a uniform
    /// sky; none (black) by default.
    pub sky: Option<Arc<Environment>>,
}

impl Scene {
    /// Assembles a scene and finds its emitters.
    pub fn new(mesh: TriangleMesh, materials: Vec<Material>, textures: Vec<Texture>) -> Self {
        let emitters = (0..mesh.triangles.len() as u32)
            .filter(|&t| materials[mesh.material[t as usize] as usize].is_emissive())
            .collect();
        Scene {
            mesh,
            materials,
            textures,
            alpha_maps: Vec::new(),
            emitters,
            sky: None,
        }
    }

    pub fn material(&self, surface: &SurfacePoint) -> &Material {
        &self.materials[surface.material as usize]
    }

    /// The diffuse reflectance at a surface point (texture lookup where there is one),
    /// clamped to [0, 1] like `Kd`.
    pub fn albedo(&self, surface: &SurfacePoint) -> Vec3 {
        let material = self.material(surface);
        match material.diffuse_texture {
            Some(t) => self.textures[t as usize]
                .sample(surface.uv)
                .clamp(Vec3::ZERO, Vec3::ONE),
            None => material.diffuse,
        }
    }

    /// The BSDF of the surface at a hit point.
    #[inline]
    pub fn bsdf(&self, surface: &SurfacePoint) -> Bsdf {
        let material = self.material(surface);
        let albedo = if material.uses_albedo() {
            self.albedo(surface)
        } else {
            Vec3::ZERO
        };
        material.bsdf(albedo, surface.ns, surface.ng)
    }

    /// The hit filter of the scene's cut-outs, or `None` when every material is opaque.
    pub fn opacity(&self) -> Option<Arc<Opacity>> {
        Opacity::of(self)
    }

    pub fn bounds(&self) -> (Vec3, Vec3) {
        self.mesh.bounds()
    }

    /// Radius of the sphere around the bounding box.
    pub fn bounding_radius(&self) -> f32 {
        let (lo, hi) = self.bounds();
        let radius = 0.5 * (hi - lo).length();
        if radius.is_finite() {
            radius
        } else {
            0.0
        }
    }

    /// Radiance arriving along a ray that leaves the scene in direction `dir`.
    #[inline]
    pub fn sky_radiance(&self, dir: Vec3) -> Vec3 {
        self.sky
            .as_ref()
            .map_or(Vec3::ZERO, |sky| sky.radiance(dir))
    }
}
