//! Area lights placed by a scene: a quad, a disk or a sphere, made into emissive
//! triangles, so that every mechanism that serves a mesh's emitters serves them too
//! (the light sampler and its BVH, MIS, path guiding, both accelerators, shards).
//!
//! Each emits uniform radiance from one side, Lambertian: a quad or a disk from the
//! side its local −z points to (from both sides when two-sided), a sphere outwards.
//! Given a power `P` instead, the radiance is `P / (π A)` for the tessellated area `A`
//! in the world (`P / (2π A)` two-sided: the power is split over both faces), so that
//! the triangles send out exactly `P`: a disk is a fan of [`DISK_SEGMENTS`] triangles
//! inscribed in its circle, a sphere a subdivided icosahedron inscribed in it
//! ([`SPHERE_SUBDIVISIONS`]); their areas fall short of `πr²` and `4πr²` by 0.04% and
//! 0.5% (`tests/lights.rs` bounds the error). A light reflects nothing: its material
//! is black but for its emission.

use std::collections::HashMap;
use std::f32::consts::PI;

use glam::{Affine3A, Vec3};

use super::{Material, Scene, TriangleMesh};

/// Triangles of a disk's fan.
pub const DISK_SEGMENTS: u32 = 128;
/// How often a sphere's icosahedron is subdivided (each time every triangle into 4):
/// `20 · 4^n` triangles, 1280.
pub const SPHERE_SUBDIVISIONS: u32 = 3;

/// The shape of an area light, in its own space.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum AreaShape {
    /// `width × height` in the xy-plane, centred on the origin.
    Quad { width: f32, height: f32 },
    /// A disk of `radius` in the xy-plane, centred on the origin.
    Disk { radius: f32 },
    /// A sphere of `radius` around the origin.
    Sphere { radius: f32 },
}

/// How bright an area light is (times its colour, per channel).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum AreaEmission {
    /// W/m²/sr.
    Radiance(f32),
    /// W, all it sends out: `π A L` for area `A` and radiance `L` (`2π A L` when
    /// two-sided).
    Power(f32),
}

/// An area light: a shape placed in the world.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct AreaLight {
    pub shape: AreaShape,
    pub transform: Affine3A,
    pub colour: Vec3,
    pub emission: AreaEmission,
    /// Whether a quad or a disk lights both sides (a sphere is never two-sided).
    pub two_sided: bool,
}

impl AreaLight {
    /// The light's triangles in the world, wound so that their counter-clockwise
    /// normals point to the side it lights (turned back under a mirroring transform).
    pub fn triangles(&self) -> Vec<[Vec3; 3]> {
        let mirrored = self.transform.matrix3.determinant() < 0.0;
        local_triangles(self.shape)
            .into_iter()
            .map(|t| {
                let [a, b, c] = t.map(|p| self.transform.transform_point3(p));
                if mirrored {
                    [a, c, b]
                } else {
                    [a, b, c]
                }
            })
            .collect()
    }

    /// How many triangles it is made of.
    pub fn triangle_count(&self) -> usize {
        match self.shape {
            AreaShape::Quad { .. } => 2,
            AreaShape::Disk { .. } => DISK_SEGMENTS as usize,
            AreaShape::Sphere { .. } => 20 * 4usize.pow(SPHERE_SUBDIVISIONS),
        }
    }

    /// The tessellated area in the world.
    pub fn area(&self) -> f32 {
        self.triangles()
            .iter()
            .map(|[a, b, c]| 0.5 * f64::from((*b - *a).cross(*c - *a).length()))
            .sum::<f64>() as f32
    }

    /// Radiance per channel, W/m²/sr.
    pub fn radiance(&self) -> Vec3 {
        match self.emission {
            AreaEmission::Radiance(l) => l * self.colour,
            AreaEmission::Power(p) => p / (self.faces() * PI * self.area()) * self.colour,
        }
    }

    /// Power per channel, W: `π A L` from each emitting face.
    pub fn power(&self) -> Vec3 {
        self.faces() * PI * self.area() * self.radiance()
    }

    /// How many faces emit.
    fn faces(&self) -> f32 {
        if self.two_sided {
            2.0
        } else {
            1.0
        }
    }
}

/// The area lights as one scene in world space (to be placed once, unmoved): their
/// triangles, each light with a material of its own named `names[i]`.
pub fn area_light_scene(lights: &[AreaLight], names: &[String]) -> Scene {
    let mut mesh = TriangleMesh::default();
    let mut materials = Vec::with_capacity(lights.len());
    for (i, light) in lights.iter().enumerate() {
        for t in light.triangles() {
            let base = mesh.positions.len() as u32;
            mesh.positions.extend(t);
            mesh.triangles.push([base, base + 1, base + 2]);
            mesh.material.push(i as u32);
        }
        materials.push(Material {
            name: names.get(i).cloned().unwrap_or_default(),
            diffuse: Vec3::ZERO,
            emission: light.radiance(),
            two_sided_emission: light.two_sided,
            ..Material::default()
        });
    }
    Scene::new(mesh, materials, Vec::new())
}

/// The shape's triangles in its own space, wound to light the side of −z (a quad or a
/// disk) or outwards (a sphere).
fn local_triangles(shape: AreaShape) -> Vec<[Vec3; 3]> {
    match shape {
        AreaShape::Quad { width, height } => {
            let (x, y) = (0.5 * width, 0.5 * height);
            let [a, b, c, d] =
                [(-x, -y), (x, -y), (x, y), (-x, y)].map(|(x, y)| Vec3::new(x, y, 0.0));
            vec![[a, c, b], [a, d, c]]
        }
        AreaShape::Disk { radius } => {
            let rim = |k: u32| {
                let phi = 2.0 * PI * (k % DISK_SEGMENTS) as f32 / DISK_SEGMENTS as f32;
                Vec3::new(radius * phi.cos(), radius * phi.sin(), 0.0)
            };
            (0..DISK_SEGMENTS)
                .map(|k| [Vec3::ZERO, rim(k + 1), rim(k)])
                .collect()
        }
        AreaShape::Sphere { radius } => icosphere(SPHERE_SUBDIVISIONS)
            .into_iter()
            .map(|t| t.map(|p| radius * p))
            .collect(),
    }
}

/// The unit icosahedron subdivided `levels` times, its new vertices pushed out onto
/// the unit sphere, wound outwards. Shared edges get one midpoint, so the surface is
/// closed.
fn icosphere(levels: u32) -> Vec<[Vec3; 3]> {
    let t = (1.0 + 5.0f32.sqrt()) / 2.0;
    let mut vertices: Vec<Vec3> = [
        (-1.0, t, 0.0),
        (1.0, t, 0.0),
        (-1.0, -t, 0.0),
        (1.0, -t, 0.0),
        (0.0, -1.0, t),
        (0.0, 1.0, t),
        (0.0, -1.0, -t),
        (0.0, 1.0, -t),
        (t, 0.0, -1.0),
        (t, 0.0, 1.0),
        (-t, 0.0, -1.0),
        (-t, 0.0, 1.0),
    ]
    .map(|(x, y, z)| Vec3::new(x, y, z).normalize())
    .to_vec();
    let mut faces: Vec<[u32; 3]> = vec![
        [0, 11, 5],
        [0, 5, 1],
        [0, 1, 7],
        [0, 7, 10],
        [0, 10, 11],
        [1, 5, 9],
        [5, 11, 4],
        [11, 10, 2],
        [10, 7, 6],
        [7, 1, 8],
        [3, 9, 4],
        [3, 4, 2],
        [3, 2, 6],
        [3, 6, 8],
        [3, 8, 9],
        [4, 9, 5],
        [2, 4, 11],
        [6, 2, 10],
        [8, 6, 7],
        [9, 8, 1],
    ];
    for _ in 0..levels {
        let mut midpoints: HashMap<(u32, u32), u32> = HashMap::new();
        let mut midpoint = |a: u32, b: u32, vertices: &mut Vec<Vec3>| {
            *midpoints.entry((a.min(b), a.max(b))).or_insert_with(|| {
                let m = (vertices[a as usize] + vertices[b as usize]).normalize();
                vertices.push(m);
                vertices.len() as u32 - 1
            })
        };
        let mut finer = Vec::with_capacity(faces.len() * 4);
        for [a, b, c] in faces {
            let ab = midpoint(a, b, &mut vertices);
            let bc = midpoint(b, c, &mut vertices);
            let ca = midpoint(c, a, &mut vertices);
            finer.extend([[a, ab, ca], [b, bc, ab], [c, ca, bc], [ab, bc, ca]]);
        }
        faces = finer;
    }
    faces
        .into_iter()
        .map(|f| f.map(|i| vertices[i as usize]))
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every shape is wound to light its side: a quad's and a disk's normals point to
    /// −z, a sphere's away from its centre, and a mirror keeps them so.
    #[test]
    fn triangles_face_the_lit_side() {
        for transform in [
            Affine3A::IDENTITY,
            Affine3A::from_scale(Vec3::new(-1.0, 2.0, 1.0)),
        ] {
            for shape in [
                AreaShape::Quad {
                    width: 2.0,
                    height: 1.0,
                },
                AreaShape::Disk { radius: 1.0 },
            ] {
                let light = AreaLight {
                    shape,
                    transform,
                    colour: Vec3::ONE,
                    emission: AreaEmission::Radiance(1.0),
                    two_sided: false,
                };
                for [a, b, c] in light.triangles() {
                    assert!(
                        (b - a).cross(c - a).z < 0.0,
                        "{shape:?} under {transform:?}"
                    );
                }
            }
            let sphere = AreaLight {
                shape: AreaShape::Sphere { radius: 1.0 },
                transform,
                colour: Vec3::ONE,
                emission: AreaEmission::Radiance(1.0),
                two_sided: false,
            };
            let triangles = sphere.triangles();
            assert_eq!(triangles.len(), 20 * 4usize.pow(SPHERE_SUBDIVISIONS));
            for [a, b, c] in triangles {
                assert!((b - a).cross(c - a).dot(a + b + c) > 0.0);
            }
        }
    }
}
