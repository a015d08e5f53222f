//! Per-vertex tangents for tangent-space normal maps, computed from the finished mesh
//! with the MikkTSpace algorithm (the `mikktspace` crate), so that maps baked by
//! Blender, Substance or xNormal (and glTF's) decode in the frame they were baked in.
//!
//! Only triangles of normal-mapped materials take part, and a scene without normal
//! maps stores nothing: its memory per triangle does not grow. Each tangent is a
//! `Vec4`: the tangent in xyz, and in w the sign of the bitangent `B = w · (N × T)`.
//! MikkTSpace gives a tangent per triangle corner; corners that share a vertex almost
//! always agree (the algorithm splits only where UVs are mirrored, where OBJ files
//! have distinct `vt` and so distinct vertices), and the last one written wins.

use glam::{Vec3, Vec4};

use super::TriangleMesh;

/// The triangles of `mesh` given by `which`, seen by MikkTSpace.
struct Faces<'a> {
    mesh: &'a TriangleMesh,
    which: &'a [u32],
    tangents: &'a mut [Vec4],
}

impl Faces<'_> {
    fn vertex(&self, face: usize, vert: usize) -> usize {
        self.mesh.triangles[self.which[face] as usize][vert] as usize
    }
}

impl mikktspace::Geometry for Faces<'_> {
    fn num_faces(&self) -> usize {
        self.which.len()
    }

    fn num_vertices_of_face(&self, _face: usize) -> usize {
        3
    }

    fn position(&self, face: usize, vert: usize) -> [f32; 3] {
        self.mesh.positions[self.vertex(face, vert)].to_array()
    }

    /// The vertex normal, or the face's own where the file gave none.
    fn normal(&self, face: usize, vert: usize) -> [f32; 3] {
        let n = match self.mesh.normals.get(self.vertex(face, vert)) {
            Some(&n) if n != Vec3::ZERO => n,
            _ => self.mesh.area_normal(self.which[face]),
        };
        n.normalize_or_zero().to_array()
    }

    fn tex_coord(&self, face: usize, vert: usize) -> [f32; 2] {
        self.mesh.uvs[self.vertex(face, vert)].to_array()
    }

    fn set_tangent_encoded(&mut self, tangent: [f32; 4], face: usize, vert: usize) {
        let v = self.vertex(face, vert);
        self.tangents[v] = Vec4::from_array(tangent);
    }
}

/// Tangents for every vertex of `mesh` (zero for vertices of no triangle in `which`),
/// or an empty list when `which` is empty or the mesh has no texture coordinates.
pub fn mikktspace_tangents(mesh: &TriangleMesh, which: &[u32]) -> Vec<Vec4> {
    if which.is_empty() || mesh.uvs.is_empty() {
        return Vec::new();
    }
    let mut tangents = vec![Vec4::ZERO; mesh.positions.len()];
    let mut faces = Faces {
        mesh,
        which,
        tangents: &mut tangents,
    };
    // `false` only for an empty input: degenerate triangles get some tangent anyway.
    mikktspace::generate_tangents(&mut faces);
    tangents
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Vec2;

    /// A quad in the xy plane whose u runs along +x and v along +y: T = +x, and
    /// B = N × T = +y (sign +1). Mirrored in u, T = −x and the sign flips.
    #[test]
    fn tangents_follow_the_uvs() {
        for (mirror, t, sign) in [(false, Vec3::X, 1.0), (true, -Vec3::X, -1.0)] {
            let u = |x: f32| if mirror { 1.0 - x } else { x };
            let mesh = TriangleMesh {
                positions: vec![Vec3::ZERO, Vec3::X, Vec3::new(1.0, 1.0, 0.0), Vec3::Y],
                normals: Vec::new(),
                uvs: vec![
                    Vec2::new(u(0.0), 0.0),
                    Vec2::new(u(1.0), 0.0),
                    Vec2::new(u(1.0), 1.0),
                    Vec2::new(u(0.0), 1.0),
                ],
                triangles: vec![[0, 1, 2], [0, 2, 3]],
                material: vec![0, 0],
                ..TriangleMesh::default()
            };
            let tangents = mikktspace_tangents(&mesh, &[0, 1]);
            for tangent in tangents {
                assert!((tangent.truncate() - t).length() < 1e-5, "{tangent}");
                assert_eq!(tangent.w, sign);
            }
        }
    }
}
