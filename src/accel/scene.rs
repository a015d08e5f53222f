//! The two-level accelerators of an instanced scene ([`crate::scene::place`]): one
//! structure per distinct mesh, built in object space on that part of the scene's mesh
//! alone (its vertices and its triangles renumbered from 0), with the part's cut-outs,
//! placed by the scene's instances.

use std::sync::Arc;

use glam::Vec3;

use super::{Bvh, BvhError, EmbreeAccel, FilteredBvh, InstancedBvh};
use crate::embree::{BuildQuality, Device, EmbreeError};
use crate::scene::{Instancing, MeshPart, Opacity, PartOpacity, TriangleMesh};

/// The vertices a part's triangles use and its triangles numbered over them.
fn part_mesh(mesh: &TriangleMesh, part: &MeshPart) -> (Vec<Vec3>, Vec<[u32; 3]>) {
    let triangles = &mesh.triangles[part.triangles.start as usize..part.triangles.end as usize];
    let corners = triangles.iter().flatten().copied();
    let (lo, hi) = corners.fold((u32::MAX, 0), |(lo, hi), i| (lo.min(i), hi.max(i)));
    if lo > hi {
        return (Vec::new(), Vec::new());
    }
    let vertices = mesh.positions[lo as usize..=hi as usize].to_vec();
    let local = triangles.iter().map(|t| t.map(|i| i - lo)).collect();
    (vertices, local)
}

/// Embree: one scene per part (filtered by its cut-outs when there are any), placed by
/// instance geometries.
pub fn instanced_embree(
    device: &Device,
    mesh: &TriangleMesh,
    instancing: &Instancing,
    quality: BuildQuality,
    cutouts: Option<&Arc<Opacity>>,
) -> Result<EmbreeAccel, EmbreeError> {
    let parts = instancing
        .parts
        .iter()
        .map(|part| {
            let (vertices, triangles) = part_mesh(mesh, part);
            match cutouts {
                Some(opacity) => {
                    let filter = opacity.part(part.triangles.start);
                    EmbreeAccel::build_filtered(device, &vertices, &triangles, quality, filter)
                }
                None => EmbreeAccel::build(device, &vertices, &triangles, quality),
            }
        })
        .collect::<Result<Vec<_>, _>>()?;
    EmbreeAccel::build_instanced(device, parts, &instancing.instances, quality)
}

/// The native BVH of each part, placed under a top-level tree.
pub fn instanced_bvh(
    mesh: &TriangleMesh,
    instancing: &Instancing,
) -> Result<InstancedBvh<Bvh>, BvhError> {
    let parts = instancing
        .parts
        .iter()
        .map(|part| {
            let (vertices, triangles) = part_mesh(mesh, part);
            Ok((Bvh::build(&vertices, &triangles)?, part.bounds))
        })
        .collect::<Result<Vec<_>, BvhError>>()?;
    Ok(InstancedBvh::build(parts, &instancing.instances)?)
}

/// [`instanced_bvh`] with each part's cut-outs deciding its hits.
pub fn instanced_filtered_bvh(
    mesh: &TriangleMesh,
    instancing: &Instancing,
    opacity: &Arc<Opacity>,
) -> Result<InstancedBvh<FilteredBvh<PartOpacity>>, BvhError> {
    let parts = instancing
        .parts
        .iter()
        .map(|part| {
            let (vertices, triangles) = part_mesh(mesh, part);
            let filter = opacity.part(part.triangles.start);
            Ok((
                Bvh::build(&vertices, &triangles)?.with_filter(filter),
                part.bounds,
            ))
        })
        .collect::<Result<Vec<_>, BvhError>>()?;
    Ok(InstancedBvh::build(parts, &instancing.instances)?)
}
