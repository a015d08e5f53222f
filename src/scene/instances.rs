//! Scenes whose meshes are placed by instances instead of baked into world space:
//! the scene's mesh holds each distinct mesh once, in its own (object) space, and
//! [`Instancing`] says where each copy of it stands. Memory grows with the distinct
//! meshes and the number of placements, not with the placed triangles.
//!
//! A hit names its instance and the triangle within its mesh. Shading takes that one
//! triangle to the world and computes the surface there as on the baked mesh
//! ([`Instancing::world_surface`]): corners through the transform, shading normals
//! through the inverse transpose, and under a mirror (negative determinant) two corners
//! swapped, so that the counter-clockwise normal, and with it the side an emitter
//! lights, turns with the surface. The point's error bound adds the rounding of the
//! transform, so rays leave an instance as safely as a plain surface.
//!
//! Lights are few next to surfaces, so each instance's emissive triangles are baked
//! into world space once, into the light sampler's own mesh ([`Instancing::lights`]),
//! and a hit on an emitter is told to the light sampler as its index there
//! ([`Instancing::light_id`]): next-event estimation and MIS see every emissive
//! instance as an emitter of its own.

use std::ops::Range;
use std::sync::Arc;

use glam::{Affine3A, Mat3A, Vec2, Vec3, Vec3A};

use super::mesh::Corners;
use super::{compose, Material, Placement, Scene, SurfacePoint, TriangleMesh};
use crate::geometry::{gamma, object_transforms, Hit, Instance, InstanceError};

/// Marks a triangle that does not emit in [`Instancing::emitter_ordinal`].
const NOT_EMISSIVE: u32 = u32::MAX;

/// One distinct mesh within the scene's mesh.
#[derive(Clone, Debug)]
pub struct MeshPart {
    /// Its triangles (indices into the scene mesh's triangles).
    pub triangles: Range<u32>,
    /// Lower and upper corners of its box in object space.
    pub bounds: [Vec3; 2],
}

/// What shading needs of one instance.
#[derive(Clone, Copy, Debug)]
struct Frame {
    /// The inverse transpose of the linear part, for normals.
    normals: Mat3A,
    /// Whether the transform mirrors (negative determinant).
    mirrored: bool,
    /// Index of its first emissive triangle in [`Instancing::lights`].
    first_light: u32,
}

/// Where the distinct meshes of a scene stand in the world.
#[derive(Clone, Debug)]
pub struct Instancing {
    pub parts: Vec<MeshPart>,
    /// The placements; `mesh` indexes `parts`. A hit's `instance` indexes this.
    pub instances: Vec<Instance>,
    frames: Vec<Frame>,
    /// Per triangle of the scene's mesh: its index among its part's emissive
    /// triangles, or `NOT_EMISSIVE`.
    emitter_ordinal: Vec<u32>,
    /// The emissive triangles of every instance in world space, instance after
    /// instance: the mesh the light sampler is built on.
    pub lights: TriangleMesh,
}

impl Instancing {
    /// The triangles the placements put in the world: each instance counts its part's.
    pub fn placed_triangles(&self) -> u64 {
        self.instances
            .iter()
            .map(|i| self.parts[i.mesh as usize].triangles.len() as u64)
            .sum()
    }

    /// The placements `instances` of the `parts` of `mesh` (instances already checked
    /// by [`crate::geometry::object_transforms`]).
    pub fn new(
        mesh: &TriangleMesh,
        materials: &[Material],
        parts: Vec<MeshPart>,
        instances: Vec<Instance>,
    ) -> Self {
        let emissive = |t: usize| materials[mesh.material[t] as usize].is_emissive();
        let mut emitter_ordinal = vec![NOT_EMISSIVE; mesh.triangles.len()];
        let mut part_emitters: Vec<Vec<u32>> = Vec::with_capacity(parts.len());
        for part in &parts {
            let list: Vec<u32> = part
                .triangles
                .clone()
                .filter(|&t| emissive(t as usize))
                .collect();
            for (k, &t) in list.iter().enumerate() {
                emitter_ordinal[t as usize] = k as u32;
            }
            part_emitters.push(list);
        }
        let mut lights = TriangleMesh::default();
        let mut frames = Vec::with_capacity(instances.len());
        for instance in &instances {
            frames.push(Frame {
                normals: instance.transform.matrix3.inverse().transpose(),
                mirrored: instance.transform.matrix3.determinant() < 0.0,
                first_light: lights.triangles.len() as u32,
            });
            for &t in &part_emitters[instance.mesh as usize] {
                bake_triangle(&mut lights, mesh, t, &instance.transform);
            }
        }
        Instancing {
            parts,
            instances,
            frames,
            emitter_ordinal,
            lights,
        }
    }

    /// The hit as the scene's mesh numbers its triangles.
    #[inline]
    pub fn mesh_hit(&self, hit: &Hit) -> Hit {
        let part = &self.parts[self.instances[hit.instance as usize].mesh as usize];
        Hit {
            prim: part.triangles.start + hit.prim,
            ..*hit
        }
    }

    /// The index in [`lights`](Self::lights) of the emissive triangle a hit is on, or
    /// `u32::MAX` (no light) when its triangle does not emit.
    #[inline]
    pub fn light_id(&self, hit: &Hit) -> u32 {
        let ordinal = self.emitter_ordinal[self.mesh_hit(hit).prim as usize];
        match ordinal {
            NOT_EMISSIVE => u32::MAX,
            k => self.frames[hit.instance as usize].first_light + k,
        }
    }

    /// The surface at a hit on an instance (its `prim` numbered as the scene's mesh
    /// numbers triangles: [`mesh_hit`](Self::mesh_hit)), in the world. It is computed
    /// as on the triangle baked into world space: corners through the transform,
    /// shading normals through the normal matrix and normalised, and under a mirror
    /// the second and third corners swapped with the barycentrics that weigh them, as
    /// `scene::compose` bakes it, so that an instance shades as its baked copy does
    /// value for value. The error bound adds the rounding of the transform itself.
    #[inline]
    pub fn world_surface(&self, mesh: &TriangleMesh, hit: &Hit) -> SurfacePoint {
        let transform = &self.instances[hit.instance as usize].transform;
        let frame = &self.frames[hit.instance as usize];
        let object = mesh.corners(hit.prim);
        let normal = |n: Vec3| {
            if n == Vec3::ZERO {
                Vec3::ZERO
            } else {
                Vec3::from(frame.normals * Vec3A::from(n)).normalize_or_zero()
            }
        };
        let mut corners = Corners {
            p: object.p.map(|p| transform.transform_point3(p)),
            n: object.n.map(|n| n.map(normal)),
            uv: object.uv,
            colour: object.colour,
        };
        let (mut u, mut v) = (hit.u, hit.v);
        if frame.mirrored {
            corners.p = swap_last(corners.p);
            corners.n = corners.n.map(swap_last);
            corners.uv = corners.uv.map(swap_last);
            corners.colour = corners.colour.map(swap_last);
            (u, v) = (v, u);
        }
        let mut surface = corners.surface(u, v, mesh.material[hit.prim as usize]);
        let [a, b, c] = object.p.map(Vec3::abs);
        surface.error += transform_rounding(transform, a.max(b).max(c));
        surface
    }

    /// A unit normal of instance `instance`'s object space in the world.
    #[inline]
    pub fn normal_to_world(&self, n: Vec3, instance: u32) -> Vec3 {
        let normals = &self.frames[instance as usize].normals;
        Vec3::from(*normals * Vec3A::from(n)).normalize_or_zero()
    }

    /// The box around every instance in world space.
    pub fn bounds(&self) -> (Vec3, Vec3) {
        self.instances
            .iter()
            .map(|i| i.world_bounds(self.parts[i.mesh as usize].bounds))
            .fold((Vec3::INFINITY, Vec3::NEG_INFINITY), |(lo, hi), [l, h]| {
                (lo.min(l.into()), hi.max(h.into()))
            })
    }
}

/// The corners in the order a mirrored copy winds them: the second and third swapped.
fn swap_last<T>([a, b, c]: [T; 3]) -> [T; 3] {
    [a, c, b]
}

/// A bound on the rounding error of `transform` applied to points whose coordinates
/// are at most `extent` in magnitude: `γ(3)` of the sums of absolute products (the
/// rounding of a 3×4 product per axis, as in pbrt-v4's transformed points).
fn transform_rounding(transform: &Affine3A, extent: Vec3) -> Vec3 {
    let m = transform.matrix3;
    let abs = Mat3A::from_cols(m.x_axis.abs(), m.y_axis.abs(), m.z_axis.abs());
    ((abs * Vec3A::from(extent) + transform.translation.abs()) * gamma(3)).into()
}

/// Appends triangle `t` of `mesh` under `transform` to `lights`, with corners of its
/// own: positions transformed, texture coordinates kept (the barycentric corners when
/// the mesh has none), and two corners swapped under a mirror so that its
/// counter-clockwise normal stays the surface's (see the module documentation).
fn bake_triangle(lights: &mut TriangleMesh, mesh: &TriangleMesh, t: u32, transform: &Affine3A) {
    let positions = mesh.vertices(t).map(|p| transform.transform_point3(p));
    let uvs: [Vec2; 3] = mesh.corner_uvs(t);
    let order = if transform.matrix3.determinant() < 0.0 {
        [0, 2, 1]
    } else {
        [0, 1, 2]
    };
    let base = lights.positions.len() as u32;
    for k in order {
        lights.positions.push(positions[k]);
        lights.uvs.push(uvs[k]);
    }
    lights.triangles.push([base, base + 1, base + 2]);
    lights.material.push(mesh.material[t as usize]);
}

/// The distinct `scenes` placed by `instances` (whose `mesh` indexes `scenes`) as one
/// instanced scene: their meshes, materials, textures and cut-out maps merged once in
/// object space, as [`super::compose`] merges them. A scene that is itself instanced
/// (a glTF whose meshes its nodes place) brings its parts, and each placement of it
/// places each of its instances.
pub fn place(scenes: &[&Scene], instances: Vec<Instance>) -> Result<Scene, InstanceError> {
    object_transforms(&instances, scenes.len())?;
    let mut scene = match scenes {
        [one] => (*one).clone(),
        _ => {
            let placements: Vec<Placement<'_>> = scenes
                .iter()
                .map(|&scene| Placement {
                    scene,
                    transform: Affine3A::IDENTITY,
                })
                .collect();
            compose(&placements)
        }
    };
    let mut parts = Vec::new();
    let mut first_part = Vec::with_capacity(scenes.len());
    let mut first = 0u32;
    for s in scenes {
        first_part.push(parts.len() as u32);
        match &s.instancing {
            Some(inner) => parts.extend(inner.parts.iter().map(|p| MeshPart {
                triangles: first + p.triangles.start..first + p.triangles.end,
                bounds: p.bounds,
            })),
            None => {
                let (lo, hi) = s.bounds();
                let count = s.mesh.triangles.len() as u32;
                parts.push(MeshPart {
                    triangles: first..first + count,
                    bounds: [lo, hi],
                });
            }
        }
        first += s.mesh.triangles.len() as u32;
    }
    let mut placed = Vec::with_capacity(instances.len());
    for i in &instances {
        let part = first_part[i.mesh as usize];
        match &scenes[i.mesh as usize].instancing {
            Some(inner) => placed.extend(inner.instances.iter().map(|j| Instance {
                mesh: part + j.mesh,
                transform: i.transform * j.transform,
            })),
            None => placed.push(Instance {
                mesh: part,
                transform: i.transform,
            }),
        }
    }
    // Each placement of a scene places its lights that are not geometry too.
    scene.lights = instances
        .iter()
        .flat_map(|i| {
            let lights = &scenes[i.mesh as usize].lights;
            lights.iter().map(|l| l.transformed(&i.transform))
        })
        .collect();
    instanced(scene, parts, placed)
}

/// `scene` (its mesh holding each of `parts` once, in object space) placed by
/// `instances`, whose `mesh` indexes `parts`; its lights are left as they are.
pub fn instanced(
    mut scene: Scene,
    parts: Vec<MeshPart>,
    instances: Vec<Instance>,
) -> Result<Scene, InstanceError> {
    object_transforms(&instances, parts.len())?;
    let instancing = Instancing::new(&scene.mesh, &scene.materials, parts, instances);
    scene.emitters = (0..instancing.lights.triangles.len() as u32).collect();
    scene.instancing = Some(Arc::new(instancing));
    Ok(scene)
}
