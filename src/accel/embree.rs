//! The Embree backend of [`Accel`]: a thin forwarding layer over `crate::embree::Scene`.

use std::sync::Arc;

use glam::Vec3;

use super::{Accel, Hit, HitFilter, Hits16, Instance, Ray, Rays16, PACKET};
use crate::embree::{BuildQuality, Device, EmbreeError, Scene};

/// A triangle mesh committed to Embree, which reads the mesh's own arrays for `'m`
/// ([`EmbreeBackend::build_shared`]) or holds copies ([`EmbreeAccel`]).
pub struct EmbreeBackend<'m> {
    scene: Scene<'m>,
}

/// Embree over copies of the mesh, independent of the arrays it was built from.
pub type EmbreeAccel = EmbreeBackend<'static>;

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
}

impl<'m> EmbreeBackend<'m> {
    /// Embree reading `vertices` and `triangles` in place, without copies, where each
    /// has room for one more item (see [`crate::embree::Device::build_shared_triangle_scene`]);
    /// with `filter` deciding hits when there are cut-outs.
    pub fn build_shared<F: HitFilter>(
        device: &Device,
        vertices: &'m Vec<Vec3>,
        triangles: &'m Vec<[u32; 3]>,
        quality: BuildQuality,
        filter: Option<Arc<F>>,
    ) -> Result<Self, EmbreeError> {
        Ok(EmbreeBackend {
            scene: device.build_shared_triangle_scene(vertices, triangles, quality, filter)?,
        })
    }

    /// A top-level scene placing `meshes` (each built on `device`) by `instances`: see
    /// [`Device::build_instanced_scene`].
    pub fn build_instanced(
        device: &Device,
        meshes: Vec<EmbreeBackend<'m>>,
        instances: &[Instance],
        quality: BuildQuality,
    ) -> Result<Self, EmbreeError> {
        let scenes = meshes.into_iter().map(|m| m.scene).collect();
        Ok(EmbreeBackend {
            scene: device.build_instanced_scene(scenes, instances, quality)?,
        })
    }

    /// The underlying scene, for the packet API.
    pub fn scene(&self) -> &Scene<'m> {
        &self.scene
    }
}

impl Accel for EmbreeBackend<'_> {
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

    #[inline(always)]
    fn intersect16(
        &self,
        active: &[bool; PACKET],
        rays: &Rays16,
        hits: &mut Hits16,
        coherent: bool,
    ) {
        self.scene.intersect16(active, rays, hits, coherent);
    }

    #[inline(always)]
    fn occluded16(&self, active: &[bool; PACKET], rays: &Rays16) -> [bool; PACKET] {
        self.scene.occluded16(active, rays)
    }
}
