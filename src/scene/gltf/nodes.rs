//! The node hierarchy: each node's transform (TRS or matrix) composed down from its
//! scene's roots, and what each node carries (a mesh, a light, a camera) at its place
//! in the world. glTF's nodes form disjoint trees: a node that is its own ancestor,
//! or has two parents, is an error, as is a transform that is not finite.

use glam::{Affine3A, Mat4, Quat, Vec3};
use gltf::Document;

/// What the nodes of the rendered scene place, each with its node's world transform.
#[derive(Default)]
pub struct Placed {
    /// (mesh index, transform), in the order the nodes are met.
    pub meshes: Vec<(usize, Affine3A)>,
    /// (index into the file's `KHR_lights_punctual` lights, transform).
    pub lights: Vec<(usize, Affine3A)>,
    /// (camera index, node index, transform).
    pub cameras: Vec<(usize, usize, Affine3A)>,
    /// Whether some placed mesh is skinned (rendered in its bind pose).
    pub skinned: bool,
}

/// A node's own transform, or why it cannot be used.
fn local_transform(node: &gltf::Node<'_>) -> Result<Affine3A, String> {
    let fail = |what: &str| format!("node {} has a {what} that is not finite", node.index());
    match node.transform() {
        gltf::scene::Transform::Matrix { matrix } => {
            if !matrix.as_flattened().iter().all(|x| x.is_finite()) {
                return Err(fail("matrix"));
            }
            // Column-major, as glam reads it; the last row is taken as 0 0 0 1.
            Ok(Affine3A::from_mat4(Mat4::from_cols_array_2d(&matrix)))
        }
        gltf::scene::Transform::Decomposed {
            translation,
            rotation,
            scale,
        } => {
            let (t, s) = (Vec3::from(translation), Vec3::from(scale));
            let r = Quat::from_array(rotation);
            if !t.is_finite() {
                return Err(fail("translation"));
            }
            if !r.is_finite() {
                return Err(fail("rotation"));
            }
            if !s.is_finite() {
                return Err(fail("scale"));
            }
            let r = glam::Vec4::from(r)
                .try_normalize()
                .map(Quat::from_vec4)
                .ok_or_else(|| format!("node {} has a rotation of length 0", node.index()))?;
            Ok(Affine3A::from_scale_rotation_translation(s, r, t))
        }
    }
}

/// The nodes the file's default scene (or its first; or, without scenes, every node
/// without a parent) places, walked from the roots.
pub fn place(document: &Document) -> Result<Placed, String> {
    let parents = parents(document)?;
    let roots: Vec<usize> = match document
        .default_scene()
        .or_else(|| document.scenes().next())
    {
        Some(scene) => scene.nodes().map(|n| n.index()).collect(),
        None => (0..parents.len())
            .filter(|&n| parents[n].is_none())
            .collect(),
    };
    let nodes: Vec<gltf::Node<'_>> = document.nodes().collect();
    let mut placed = Placed::default();
    let mut visited = vec![false; nodes.len()];
    // Depth-first with an explicit stack: a deep hierarchy cannot overflow ours.
    let mut stack: Vec<(usize, Affine3A)> = roots
        .iter()
        .rev()
        .map(|&n| (n, Affine3A::IDENTITY))
        .collect();
    while let Some((n, parent)) = stack.pop() {
        if std::mem::replace(&mut visited[n], true) {
            return Err(match parents[n] {
                _ if in_cycle(n, &parents) => {
                    format!("node {n} is its own ancestor (the node hierarchy has a cycle)")
                }
                Some(p) => format!("node {n} is both a root of the scene and a child of node {p}"),
                None => format!("node {n} is a root of the scene twice"),
            });
        }
        let node = &nodes[n];
        let world = parent * local_transform(node)?;
        if !world.is_finite() {
            return Err(format!(
                "node {n}'s transform in the world is not finite (its ancestors' \
                 transforms multiply past f32)"
            ));
        }
        if let Some(mesh) = node.mesh() {
            placed.meshes.push((mesh.index(), world));
            placed.skinned |= node.skin().is_some();
        }
        if let Some(light) = node.light() {
            placed.lights.push((light.index(), world));
        }
        if let Some(camera) = node.camera() {
            placed.cameras.push((camera.index(), n, world));
        }
        for child in node.children().collect::<Vec<_>>().into_iter().rev() {
            stack.push((child.index(), world));
        }
    }
    Ok(placed)
}

/// Each node's parent; a node listed as the child of two nodes is an error.
fn parents(document: &Document) -> Result<Vec<Option<usize>>, String> {
    let mut parents = vec![None; document.nodes().len()];
    for node in document.nodes() {
        for child in node.children() {
            let c = child.index();
            if c == node.index() {
                return Err(format!(
                    "node {c} is its own child (the node hierarchy has a cycle)"
                ));
            }
            if let Some(other) = parents[c].replace(node.index()) {
                return Err(format!(
                    "node {c} is a child of both node {other} and node {}: glTF's nodes form trees",
                    node.index()
                ));
            }
        }
    }
    Ok(parents)
}

/// Whether following parents up from node `n` comes back to it.
fn in_cycle(n: usize, parents: &[Option<usize>]) -> bool {
    let mut at = parents[n];
    for _ in 0..parents.len() {
        match at {
            Some(p) if p == n => return true,
            Some(p) => at = parents[p],
            None => return false,
        }
    }
    false
}
