//! The Embree backend of [`Accel`]: a thin forwarding layer over `crate::embree::Scene`.

use std::sync::Arc;

use glam::Vec3;

use super::{Accel, Hit, HitFilter, Ray};
use crate::embree::{BuildQuality, Device, EmbreeError, Scene};

/// A triangle mesh committed to Embree.
pub struct EmbreeAccel {
    scene: Scene,
}

impl EmbreeAccel {
    pub fn build(
        device: &Device,
        vertices: &[Vec3],
        triangles: &[[u32; 3]],
        quality: BuildQuality,
    ) -> Result<Self, EmbreeError> {
        Ok(EmbreeAccel {
            scene: device.build_triangle_scene(vertices, triangles, quality)?,
        })
    }

    /// A mesh whose hits `filter` decides (cut-outs), through Embree's filter functions.
    pub fn build_filtered<F: HitFilter>(
        device: &Device,
        vertices: &[Vec3],
        triangles: &[[u32; 3]],
        quality: BuildQuality,
        filter: Arc<F>,
    ) -> Result<Self, EmbreeError> {
        Ok(EmbreeAccel {
            scene: device.build_filtered_triangle_scene(vertices, triangles, quality, filter)?,
        })
    }

    /// The underlying scene, for the packet API.
    pub fn scene(&self) -> &Scene {
        &self.scene
    }
}

impl Accel for EmbreeAccel {
    fn name(&self) -> &'static str {
        "embree"
    }

    #[inline]
    fn intersect(&self, ray: &Ray) -> Option<Hit> {
        self.scene.intersect(ray)
    }

    #[inline]
    fn occluded(&self, ray: &Ray) -> bool {
        self.scene.occluded(ray)
    }

    fn memory_bytes(&self) -> usize {
        self.scene.memory_bytes()
    }
}
