//! Scenes placed in one world: each loaded OBJ, under an affine transform, baked into
//! one mesh with the materials, textures and cut-out maps of all of them.
//!
//! Positions go through the transform, shading normals through its inverse transpose
//! (so they stay perpendicular to the surface under non-uniform scale), and a transform
//! that mirrors (negative determinant) swaps two corners of every triangle, so that the
//! geometric normal `(b − a) × (c − a)`, and with it the side an emitter lights, turns
//! with the surface instead of flipping. A triangle keeps its texture coordinates.

use std::sync::Arc;

use glam::{Affine3A, Mat3A, Vec2, Vec3};

use super::{Material, Scene, TriangleMesh};

/// One loaded scene placed in the world.
pub struct Placement<'a> {
    pub scene: &'a Scene,
    pub transform: Affine3A,
}

/// The placed scenes as one scene: triangles in order of the placements, each with its
/// own copy of its scene's materials (the same textures, shared).
pub fn compose(placements: &[Placement<'_>]) -> Scene {
    // Texture coordinates per vertex are kept when some scene has them; a triangle of a
    // scene without them then gets its own corners with the coordinates (0,0), (1,0),
    // (0,1), which interpolate to the barycentric (u, v) it would have shown alone. So
    // does a mirrored one, whose swapped corners would otherwise swap u and v.
    let uvs = placements
        .iter()
        .any(|p| !p.scene.mesh.uvs.is_empty() || mirrors(&p.transform));
    let normals = placements.iter().any(|p| !p.scene.mesh.normals.is_empty());
    let colours = placements.iter().any(|p| !p.scene.mesh.colours.is_empty());
    let mut mesh = TriangleMesh::default();
    let mut materials = Vec::new();
    let mut textures = Vec::new();
    let mut alpha_maps = Vec::new();
    for placement in placements {
        let scene = placement.scene;
        let offsets = Offsets {
            material: materials.len() as u32,
            texture: textures.len() as u32,
            alpha: alpha_maps.len() as u32,
        };
        append_mesh(
            &mut mesh,
            &scene.mesh,
            &placement.transform,
            offsets.material,
            Kept {
                uvs,
                normals,
                colours,
            },
        );
        materials.extend(scene.materials.iter().map(|m| offsets.material_of(m)));
        textures.extend(scene.textures.iter().map(Arc::clone));
        alpha_maps.extend(scene.alpha_maps.iter().map(Arc::clone));
    }
    let mut scene = Scene::new(mesh, materials, textures);
    scene.alpha_maps = alpha_maps;
    scene
}

/// Whether the transform turns right-handed frames into left-handed ones.
pub fn mirrors(transform: &Affine3A) -> bool {
    transform.matrix3.determinant() < 0.0
}

/// Where one scene's materials, textures and cut-out maps start in the composed scene.
struct Offsets {
    material: u32,
    texture: u32,
    alpha: u32,
}

impl Offsets {
    fn material_of(&self, m: &Material) -> Material {
        let texture = |t: Option<u32>| t.map(|t| t + self.texture);
        let mut m = m.clone();
        m.diffuse_texture = texture(m.diffuse_texture);
        let maps = &mut m.maps;
        maps.specular = texture(maps.specular);
        maps.shininess = texture(maps.shininess);
        maps.emission = texture(maps.emission);
        maps.roughness = texture(maps.roughness);
        maps.metallic = texture(maps.metallic);
        maps.transmission = texture(maps.transmission);
        maps.bump = texture(maps.bump);
        maps.normal = texture(maps.normal);
        m.opacity_map = m.opacity_map.map(|a| a + self.alpha);
        m
    }
}

/// Which attributes the composed mesh keeps per vertex.
struct Kept {
    uvs: bool,
    normals: bool,
    colours: bool,
}

/// Appends `part` under `transform` to `mesh`, with the attributes `kept` (white
/// colours where `part` has none).
fn append_mesh(
    mesh: &mut TriangleMesh,
    part: &TriangleMesh,
    transform: &Affine3A,
    material_offset: u32,
    kept: Kept,
) {
    let colour = |i: u32| part.colours.get(i as usize).copied().unwrap_or(Vec3::ONE);
    let normal_matrix: Mat3A = transform.matrix3.inverse().transpose();
    let mirrored = mirrors(transform);
    let corners = |[a, b, c]: [u32; 3]| if mirrored { [a, c, b] } else { [a, b, c] };
    let material = part.material.iter().map(|m| m + material_offset);
    let transform_normal = |n: &Vec3| {
        if *n == Vec3::ZERO {
            Vec3::ZERO
        } else {
            Vec3::from(normal_matrix * glam::Vec3A::from(*n)).normalize_or_zero()
        }
    };
    if kept.uvs && part.uvs.is_empty() {
        // Three corners of its own per triangle, at (0,0), (1,0), (0,1).
        for (t, tri) in part.triangles.iter().enumerate() {
            let base = mesh.positions.len() as u32;
            for (k, &i) in tri.iter().enumerate() {
                mesh.positions
                    .push(transform.transform_point3(part.positions[i as usize]));
                mesh.uvs.push([Vec2::ZERO, Vec2::X, Vec2::Y][k]);
                if kept.colours {
                    mesh.colours.push(colour(i));
                }
                if kept.normals {
                    mesh.normals.push(
                        part.normals
                            .get(i as usize)
                            .map_or(Vec3::ZERO, transform_normal),
                    );
                }
            }
            mesh.triangles.push(corners([base, base + 1, base + 2]));
            mesh.material.push(part.material[t] + material_offset);
        }
        return;
    }
    let base = mesh.positions.len() as u32;
    mesh.positions.extend(
        part.positions
            .iter()
            .map(|&p| transform.transform_point3(p)),
    );
    if kept.uvs {
        mesh.uvs.extend_from_slice(&part.uvs);
    }
    if kept.colours {
        mesh.colours
            .extend((0..part.positions.len() as u32).map(colour));
    }
    if kept.normals {
        if part.normals.is_empty() {
            mesh.normals.resize(mesh.positions.len(), Vec3::ZERO);
        } else {
            mesh.normals
                .extend(part.normals.iter().map(transform_normal));
        }
    }
    mesh.triangles
        .extend(part.triangles.iter().map(|t| corners(t.map(|i| i + base))));
    mesh.material.extend(material);
}
