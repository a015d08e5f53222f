//! The meshes `ember bench` measures on: an OBJ scene's triangles, or a procedural mesh.

use std::path::Path;

use glam::Vec3;

use super::procedural::Procedural;
use ember::scene::{load_model, SceneError, TriangleMesh};

/// A mesh to benchmark on, and the triangles that emit (shadow rays aim at them when
/// there are any, else at random points in the bounding box).
pub struct BenchMesh {
    pub name: String,
    /// The scene's mesh, so ray sets find surface points the way the renderer does.
    pub mesh: TriangleMesh,
    pub lights: Vec<u32>,
    /// Bytes of OBJ text read (0 for procedural meshes).
    pub obj_bytes: u64,
}

impl BenchMesh {
    /// The triangles of a mesh file (OBJ, PLY); its emissive triangles are the lights.
    pub fn from_obj(path: &Path) -> Result<BenchMesh, SceneError> {
        let model = load_model(path, &Default::default())?;
        let (scene, report) = (model.scene, model.report);
        let name = path.file_name().map_or_else(
            || path.display().to_string(),
            |n| n.to_string_lossy().into(),
        );
        Ok(BenchMesh {
            name,
            mesh: scene.mesh,
            lights: scene.emitters,
            obj_bytes: report.obj_bytes,
        })
    }

    /// A procedural mesh, named by its specification (`sphere:1000000`).
    pub fn procedural(p: Procedural, seed: u64) -> BenchMesh {
        let (positions, triangles) = p.generate(seed);
        BenchMesh::from_triangles(p.to_string(), positions, triangles)
    }

    /// A mesh of bare triangles (one material, no normals or texture coordinates).
    pub fn from_triangles(name: String, positions: Vec<Vec3>, triangles: Vec<[u32; 3]>) -> Self {
        let material = vec![0; triangles.len()];
        BenchMesh {
            name,
            mesh: TriangleMesh {
                positions,
                triangles,
                material,
                ..TriangleMesh::default()
            },
            lights: Vec::new(),
            obj_bytes: 0,
        }
    }

    pub fn positions(&self) -> &[Vec3] {
        &self.mesh.positions
    }

    pub fn triangles(&self) -> &[[u32; 3]] {
        &self.mesh.triangles
    }

    /// Lower and upper corners of the box around the vertices the triangles use.
    pub fn bounds(&self) -> (Vec3, Vec3) {
        self.mesh.bounds()
    }
}
