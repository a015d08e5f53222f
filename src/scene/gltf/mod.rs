//! Loading glTF 2.0 scenes (`.gltf` with its buffers and images, `.glb`) through the
//! `gltf` crate: the meshes its nodes place, its materials and textures, its
//! `KHR_lights_punctual` lights and its cameras.
//!
//! A mesh that one node places is baked into world space with the others like it; a
//! mesh that several nodes place is held once and placed by instances
//! ([`crate::scene::instanced`]), on both backends. Skins, morph targets and
//! animations are not applied: meshes render in their bind pose, with one note.
//! Everything the file says that ember cannot honour is one warning; everything that
//! makes it unreadable one error naming the file.

mod accessor;
mod cameras;
mod images;
mod lights;
mod materials;
mod nodes;
mod primitives;
mod source;

pub use cameras::FileCamera;
use materials::GltfValues;

use std::path::Path;

use glam::{Affine3A, Vec3};

use super::obj::check_counts;
use super::warnings::{LoadOptions, Warnings};
use super::{
    instanced, LoadReport, LoadedModel, MeshPart, Scene, SceneError, TriangleMesh, VertexColours,
};
use crate::geometry::Instance;
use crate::limits::check_fits;
use materials::Materials;
use primitives::Counts;

/// Bytes of memory one placement by an instance holds (as a scene file's).
const MEMORY_PER_INSTANCE: u64 = super::MEMORY_PER_PLACEMENT;

/// Loads the glTF at `path` (`.gltf` or `.glb`).
pub fn load_gltf(path: &Path, options: &LoadOptions) -> Result<LoadedModel, SceneError> {
    let fail = |reason: String| SceneError::Gltf {
        path: path.to_owned(),
        reason,
    };
    let source = source::read(path).map_err(fail)?;
    let document = &source.document;
    let mut warnings = Warnings::new(options);
    let at = path.display();
    for name in &source.unsupported {
        warnings.push(format!(
            "{at}: uses the extension {name}, which ember does not read; what it adds is ignored"
        ));
    }
    let placed = nodes::place(document).map_err(fail)?;
    let Materials {
        mut materials,
        uv,
        made,
    } = materials::read_materials(&source, &mut warnings)?;
    let default_material = materials.len() as u32;
    // The specification's default material: white, metallic 1, roughness 1.
    materials.push(materials::metallic_roughness(&GltfValues {
        name: "default".into(),
        base_colour: Vec3::ONE,
        metallic: 1.0,
        roughness: 1.0,
        opacity: 1.0,
        ..GltfValues::default()
    }));
    // Meshes one node places are baked into the world; the others are placed by instances.
    let mut uses = vec![0usize; document.meshes().len()];
    for &(m, _) in &placed.meshes {
        uses[m] += 1;
    }
    let meshes: Vec<gltf::Mesh<'_>> = document.meshes().collect();
    let mut entries: Vec<(gltf::Mesh<'_>, Affine3A)> = placed
        .meshes
        .iter()
        .filter(|&&(m, _)| uses[m] == 1)
        .map(|(m, t)| (meshes[*m].clone(), *t))
        .collect();
    let baked = entries.len();
    let mut shared: Vec<usize> = Vec::new();
    for &(m, _) in &placed.meshes {
        if uses[m] > 1 && !shared.contains(&m) {
            shared.push(m);
            entries.push((meshes[m].clone(), Affine3A::IDENTITY));
        }
    }
    let (vertices, triangles) = primitives::declared_counts(&entries);
    check_counts(triangles, vertices).map_err(|what| SceneError::TooLarge {
        path: path.to_owned(),
        what,
    })?;
    let instances = placed.meshes.len() - baked;
    check_fits(
        &format!("{instances} placements of meshes by nodes"),
        (instances as u64).saturating_mul(MEMORY_PER_INSTANCE),
    )
    .map_err(fail)?;
    let mut counts = Counts::default();
    let mut mesh = TriangleMesh::default();
    let ends = primitives::append_meshes(
        &mut mesh,
        &entries,
        &source.buffers,
        &uv,
        default_material,
        &mut counts,
    )
    .map_err(fail)?;
    drop(entries);
    if mesh.triangles.is_empty() {
        return Err(SceneError::Empty {
            path: path.to_owned(),
            detail: empty_detail(&placed, &counts),
        });
    }
    mesh.pad_for_embree();
    let mut scene = Scene::new(mesh, materials, made.textures);
    scene.alpha_maps = made.alpha_maps;
    if !shared.is_empty() {
        let (parts, instances) = parts_and_instances(&scene, &placed, &shared, baked, &ends);
        scene = instanced(scene, parts, instances).map_err(|e| fail(e.to_string()))?;
    }
    for &(index, world) in &placed.lights {
        let light = document
            .lights()
            .and_then(|mut l| l.nth(index))
            .expect("a validated document's light index");
        scene
            .lights
            .push(lights::light(&light, &world).map_err(fail)?);
    }
    let mut cameras = Vec::with_capacity(placed.cameras.len());
    for &(index, _, world) in &placed.cameras {
        let camera = document
            .cameras()
            .nth(index)
            .expect("a validated camera index");
        cameras.push(cameras::camera(&camera, &world).map_err(fail)?);
    }
    notes(path, document, &placed, &counts, &mut warnings);
    let contents = contents(document, &placed, &uses);
    let report = LoadReport {
        obj_bytes: source.buffers.iter().map(|b| b.len() as u64).sum(),
        triangles: scene.mesh.triangles.len(),
        vertices: scene.mesh.positions.len(),
        materials: document.materials().len(),
        emitters: scene.emitters.len(),
        lights: scene.lights.len(),
        degenerate_dropped: counts.degenerate_dropped,
        vertex_colours: counts.colours.then_some(VertexColours::Unit),
        warnings: warnings.lines,
        // A primitive without a material takes glTF's default one, not ember's.
        default_material: None,
    };
    Ok(LoadedModel {
        scene,
        report,
        cameras,
        contents,
    })
}

/// Why a file has no triangles: what it placed, and what was skipped.
fn empty_detail(placed: &nodes::Placed, counts: &Counts) -> String {
    if placed.meshes.is_empty() {
        return " (its scene places no mesh)".into();
    }
    let mut why = Vec::new();
    if counts.skipped_primitives > 0 {
        why.push(format!(
            "{} primitives of points or lines",
            counts.skipped_primitives
        ));
    }
    if counts.degenerate_dropped > 0 {
        why.push(format!(
            "{} degenerate triangles",
            counts.degenerate_dropped
        ));
    }
    match why.is_empty() {
        true => " (its meshes hold no triangles)".into(),
        false => format!(" (only {})", why.join(" and ")),
    }
}

/// The parts of an instanced glTF (the baked meshes as one part at the identity, if
/// any, then each shared mesh) and the instances that place them.
fn parts_and_instances(
    scene: &Scene,
    placed: &nodes::Placed,
    shared: &[usize],
    baked: usize,
    ends: &[u32],
) -> (Vec<MeshPart>, Vec<Instance>) {
    let mesh = &scene.mesh;
    let part = |range: std::ops::Range<u32>| {
        let triangles = &mesh.triangles[range.start as usize..range.end as usize];
        let (lo, hi) = super::triangle_bounds(&mesh.positions, triangles);
        MeshPart {
            triangles: range,
            bounds: [lo, hi],
        }
    };
    let mut parts = Vec::new();
    let mut instances = Vec::new();
    let baked_end = if baked == 0 { 0 } else { ends[baked - 1] };
    if baked_end > 0 {
        parts.push(part(0..baked_end));
        instances.push(Instance {
            mesh: 0,
            transform: Affine3A::IDENTITY,
        });
    }
    // A shared mesh left without triangles (lines, degenerate ones) is no part.
    let mut part_of = Vec::with_capacity(shared.len());
    let mut start = baked_end;
    for k in 0..shared.len() {
        let end = ends[baked + k];
        part_of.push((end > start).then_some(parts.len() as u32));
        if end > start {
            parts.push(part(start..end));
        }
        start = end;
    }
    for &(m, transform) in &placed.meshes {
        let part = shared.iter().position(|&s| s == m).and_then(|k| part_of[k]);
        if let Some(mesh) = part {
            instances.push(Instance { mesh, transform });
        }
    }
    (parts, instances)
}

/// One note for each thing the file has that ember leaves out.
fn notes(
    path: &Path,
    document: &gltf::Document,
    placed: &nodes::Placed,
    counts: &Counts,
    warnings: &mut Warnings,
) {
    let at = path.display();
    if counts.skipped_primitives > 0 {
        warnings.push(format!(
            "{at}: {} primitives of points or lines are skipped (ember renders triangles)",
            counts.skipped_primitives
        ));
    }
    if counts.no_positions > 0 {
        warnings.push(format!(
            "{at}: {} primitives without POSITION are skipped",
            counts.no_positions
        ));
    }
    let animated = document.animations().next().is_some();
    if placed.skinned || counts.morph_targets || animated {
        warnings.push(format!(
            "{at}: skins, morph targets and animations are not applied: meshes render in \
             their bind pose and nodes at their rest transforms"
        ));
    }
    let ranged = document
        .lights()
        .is_some_and(|mut l| l.any(|light| light.range().is_some()));
    if ranged {
        warnings.push(format!(
            "{at}: lights' range is ignored: ember's point and spot lights fall off as 1/d² \
             everywhere"
        ));
    }
    let mixed = document.samplers().filter(|s| images::filter(s).1).count();
    if mixed > 0 {
        warnings.push(format!(
            "{at}: {mixed} samplers filter magnification and minification differently; a \
             lookup in ember has no footprint to tell them apart, so their textures are \
             filtered bilinearly"
        ));
    }
}

/// `ember info`'s lines about what the file holds: its meshes and how often each is
/// placed, and its lights.
fn contents(document: &gltf::Document, placed: &nodes::Placed, uses: &[usize]) -> Vec<String> {
    let mut lines = vec![format!(
        "meshes: {} ({} placed by {} nodes)",
        document.meshes().len(),
        uses.iter().filter(|&&n| n > 0).count(),
        placed.meshes.len()
    )];
    for mesh in document.meshes() {
        let name = mesh
            .name()
            .map_or_else(|| format!("mesh {}", mesh.index()), |n| format!("{n:?}"));
        lines.push(format!(
            "  {name}: {} primitives, placed {} times",
            mesh.primitives().len(),
            uses[mesh.index()]
        ));
    }
    lines.push(format!(
        "lights (KHR_lights_punctual): {}",
        placed.lights.len()
    ));
    for &(index, world) in &placed.lights {
        if let Some(light) = document.lights().and_then(|mut l| l.nth(index)) {
            let p = world.translation;
            lines.push(format!(
                "  {} at ({}, {}, {})",
                lights::label(&light),
                p.x,
                p.y,
                p.z
            ));
        }
    }
    lines
}
