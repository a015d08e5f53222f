//! Two-level scenes in Embree: one committed scene per distinct mesh, placed in a
//! top-level scene by instance geometries (`RTC_GEOMETRY_TYPE_INSTANCE`), each with its
//! affine transform at time step 0. The calls are the same in Embree 3.13 and 4.
//!
//! Embree takes each ray into the instance's object space by the inverse transform
//! without normalising its direction, so a hit's `tfar` is the world `t`; it reports
//! the mesh's `primID` and barycentrics, and the instance geometry's id in `instID[0]`
//! (ember attaches instance `i` of the list as geometry `i`). The placed meshes keep
//! their own filter functions, which Embree runs on their hits through instances too.

use std::sync::Arc;

use super::{invalid, sys, BuildQuality, Device, EmbreeError, Scene};
use crate::geometry::{object_transforms, Instance};

impl Device {
    /// A top-level scene placing `meshes` (committed scenes of this device, one per
    /// distinct mesh) by `instances`; a hit's `instance` is the index into `instances`.
    /// Refuses an instance that names no mesh or whose transform is not finite and
    /// invertible, and a mesh scene of another device.
    pub fn build_instanced_scene<'m>(
        &self,
        meshes: Vec<Scene<'m>>,
        instances: &[Instance],
        quality: BuildQuality,
    ) -> Result<Scene<'m>, EmbreeError> {
        object_transforms(instances, meshes.len()).map_err(|e| invalid(e.to_string()))?;
        if let Some(m) = meshes
            .iter()
            .position(|m| !Arc::ptr_eq(&m.device.handle, &self.handle))
        {
            return Err(invalid(format!("mesh {m} is a scene of another device")));
        }
        if instances.len() >= super::INVALID_ID as usize {
            return Err(invalid(format!(
                "{} instances are too many",
                instances.len()
            )));
        }
        let _ = self.take_error();
        let mut scene = self.new_scene(quality, false)?;
        let before = self.bytes_in_use();
        for (id, instance) in instances.iter().enumerate() {
            self.attach_instance(&scene, &meshes[instance.mesh as usize], instance, id as u32)?;
        }
        // SAFETY: the scene is live and each of its geometries is committed.
        unsafe { sys::rtcCommitScene(scene.raw) };
        self.take_error()?;
        scene.bytes = self.bytes_in_use().saturating_sub(before)
            + meshes.iter().map(Scene::memory_bytes).sum::<usize>();
        scene.placed = meshes;
        // A ray that one of the instances would take past Embree's limit in its object
        // space is a miss, as a ray past the limit in the world is.
        scene.carried = instances
            .iter()
            .map(Instance::carried)
            .fold(scene.carried, |(o, d), (io, id)| (o.min(io), d.min(id)));
        Ok(scene)
    }

    /// Attaches to `top` the instance geometry that places `mesh` by `instance`, as
    /// geometry `id`.
    fn attach_instance(
        &self,
        top: &Scene<'_>,
        mesh: &Scene<'_>,
        instance: &Instance,
        id: u32,
    ) -> Result<(), EmbreeError> {
        // SAFETY: the device is live.
        let raw = unsafe { sys::rtcNewGeometry(self.handle.raw, sys::RTC_GEOMETRY_TYPE_INSTANCE) };
        if raw.is_null() {
            self.take_error()?;
            return Err(invalid("cannot create an instance geometry".into()));
        }
        // From here `Geometry::drop` releases the handle on every path.
        let geometry = super::Geometry(raw);
        // Column-major 3×4: the three columns of the linear part, then the translation.
        let m = &instance.transform.matrix3;
        let columns = [m.x_axis, m.y_axis, m.z_axis, instance.transform.translation];
        let xfm: [f32; 12] = std::array::from_fn(|i| columns[i / 3][i % 3]);
        // SAFETY: the geometry is live and not committed; `mesh.raw` is a committed
        // scene of the same device (checked by the caller), which the instance keeps a
        // reference to and which `top` keeps alive besides (`Scene::placed`); `xfm`
        // holds the twelve floats of RTC_FORMAT_FLOAT3X4_COLUMN_MAJOR and is read
        // during the call only.
        unsafe {
            sys::rtcSetGeometryInstancedScene(raw, mesh.raw);
            sys::rtcSetGeometryTransform(
                raw,
                0,
                sys::RTC_FORMAT_FLOAT3X4_COLUMN_MAJOR,
                xfm.as_ptr().cast(),
            );
            sys::rtcCommitGeometry(raw);
            sys::rtcAttachGeometryByID(top.raw, raw, id);
        }
        drop(geometry);
        self.take_error()
    }
}
