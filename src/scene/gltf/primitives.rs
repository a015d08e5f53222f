//! A glTF mesh's primitives as triangles of ember's mesh: triangle lists, strips and
//! fans (points and lines are skipped, counted for one note), indexed or not, with
//! their positions, normals, the texture coordinates their material reads and
//! `COLOR_0`, placed by a transform (the identity for a mesh that instances place).

use glam::{Affine3A, Mat3A, Vec2, Vec3};
use gltf::mesh::Mode;
use gltf::Semantic;

use rayon::prelude::*;

use super::accessor::{read_indices, read_vectors, PARALLEL_MIN};
use super::materials::UvChoice;
use crate::scene::TriangleMesh;

/// What appending primitives found worth telling.
#[derive(Default)]
pub struct Counts {
    /// Primitives of points or lines, skipped.
    pub skipped_primitives: usize,
    /// Primitives without positions, skipped.
    pub no_positions: usize,
    pub degenerate_dropped: usize,
    pub morph_targets: bool,
    /// Whether any primitive had vertex colours.
    pub colours: bool,
}

/// Which attributes the mesh keeps per vertex: once one primitive has one, every
/// vertex gets one (zero normals and UVs, white colours where its primitive had none).
#[derive(Default)]
struct Kept {
    normals: bool,
    uvs: bool,
    colours: bool,
}

/// One primitive read on its own (so that primitives are read in parallel): its
/// vertices placed by its transform, and its triangles over them.
struct Decoded {
    positions: Vec<Vec3>,
    normals: Option<Vec<Vec3>>,
    uvs: Option<Vec<Vec2>>,
    colours: Option<Vec<Vec3>>,
    /// Corners into `positions`, wound counter-clockwise; degenerate ones dropped.
    triangles: Vec<[u32; 3]>,
    material: u32,
    degenerate_dropped: usize,
    morph_targets: bool,
}

/// What one primitive gives the mesh.
enum Read {
    Triangles(Decoded),
    PointsOrLines,
    NoPositions,
}

/// Appends the primitives of `meshes` (each placed by its transform) to `mesh`, and
/// gives the number of triangles `mesh` has after each. `uv_of` gives the texture
/// coordinates each material reads; `default_material` is the index of the material
/// of primitives that name none.
pub fn append_meshes(
    mesh: &mut TriangleMesh,
    meshes: &[(gltf::Mesh<'_>, Affine3A)],
    buffers: &[Vec<u8>],
    uv_of: &[UvChoice],
    default_material: u32,
    counts: &mut Counts,
) -> Result<Vec<u32>, String> {
    let jobs: Vec<(usize, gltf::Primitive<'_>, &Affine3A)> = meshes
        .iter()
        .flat_map(|(m, transform)| m.primitives().map(move |p| (m.index(), p, transform)))
        .collect();
    let read = jobs
        .par_iter()
        .map(|(mesh, primitive, transform)| {
            read_primitive(primitive, transform, buffers, uv_of, default_material)
                .map_err(|e| format!("primitive {} of mesh {mesh}: {e}", primitive.index()))
        })
        .collect::<Result<Vec<Read>, String>>()?;
    let mut read = read.into_iter();
    let mut kept = Kept::default();
    let mut ends = Vec::with_capacity(meshes.len());
    for (gltf_mesh, _) in meshes {
        for _ in gltf_mesh.primitives() {
            match read.next().expect("one result per primitive") {
                Read::Triangles(decoded) => append(mesh, decoded, &mut kept, counts),
                Read::PointsOrLines => counts.skipped_primitives += 1,
                Read::NoPositions => counts.no_positions += 1,
            }
        }
        ends.push(mesh.triangles.len() as u32);
    }
    Ok(ends)
}

/// Appends one read primitive's vertices and triangles to `mesh`.
fn append(mesh: &mut TriangleMesh, decoded: Decoded, kept: &mut Kept, counts: &mut Counts) {
    let offset = mesh.positions.len();
    let count = decoded.positions.len();
    extend(&mut mesh.positions, decoded.positions);
    pad(
        &mut mesh.normals,
        &mut kept.normals,
        offset,
        count,
        decoded.normals,
        Vec3::ZERO,
    );
    pad(
        &mut mesh.uvs,
        &mut kept.uvs,
        offset,
        count,
        decoded.uvs,
        Vec2::ZERO,
    );
    counts.colours |= decoded.colours.is_some();
    pad(
        &mut mesh.colours,
        &mut kept.colours,
        offset,
        count,
        decoded.colours,
        Vec3::ONE,
    );
    let material = decoded.material;
    mesh.material
        .extend(decoded.triangles.iter().map(|_| material));
    let moved = |t: [u32; 3]| t.map(|i| i + offset as u32);
    match offset {
        0 => extend(&mut mesh.triangles, decoded.triangles),
        _ => mesh
            .triangles
            .extend(decoded.triangles.into_iter().map(moved)),
    }
    counts.degenerate_dropped += decoded.degenerate_dropped;
    counts.morph_targets |= decoded.morph_targets;
}

/// The vertices and triangles `meshes` declare, at most (before any is read), so that
/// counts past ember's `u32` indices are refused first.
pub fn declared_counts(meshes: &[(gltf::Mesh<'_>, Affine3A)]) -> (u64, u64) {
    let (mut vertices, mut triangles) = (0u64, 0u64);
    for (mesh, _) in meshes {
        for primitive in mesh.primitives() {
            let Some(positions) = primitive.get(&Semantic::Positions) else {
                continue;
            };
            let n = positions.count() as u64;
            let corners = primitive.indices().map_or(n, |i| i.count() as u64);
            vertices += n;
            triangles += match primitive.mode() {
                Mode::Triangles => corners / 3,
                Mode::TriangleStrip | Mode::TriangleFan => corners.saturating_sub(2),
                _ => 0,
            };
        }
    }
    (vertices, triangles)
}

/// The triangles of `count` vertices in `mode` through `indices`, as corner lists.
fn triangles(mode: Mode, indices: &[u32]) -> Vec<[u32; 3]> {
    match mode {
        Mode::Triangles => indices
            .chunks_exact(3)
            .map(|t| [t[0], t[1], t[2]])
            .collect(),
        // Every other strip triangle is wound the other way; the spec's order keeps
        // them all counter-clockwise.
        Mode::TriangleStrip => (2..indices.len())
            .map(|i| {
                let (a, b, c) = (indices[i - 2], indices[i - 1], indices[i]);
                if i % 2 == 0 {
                    [a, b, c]
                } else {
                    [b, a, c]
                }
            })
            .collect(),
        Mode::TriangleFan => (2..indices.len())
            .map(|i| [indices[i - 1], indices[i], indices[0]])
            .collect(),
        _ => Vec::new(),
    }
}

/// Reads one primitive: its triangles (points and lines skipped), the vertices they
/// use placed by `transform`, and the attributes its material needs.
fn read_primitive(
    primitive: &gltf::Primitive<'_>,
    transform: &Affine3A,
    buffers: &[Vec<u8>],
    uv_of: &[UvChoice],
    default_material: u32,
) -> Result<Read, String> {
    let mode = primitive.mode();
    if !matches!(
        mode,
        Mode::Triangles | Mode::TriangleStrip | Mode::TriangleFan
    ) {
        return Ok(Read::PointsOrLines);
    }
    let Some(positions) = primitive.get(&Semantic::Positions) else {
        return Ok(Read::NoPositions);
    };
    if positions.view().is_none() {
        return Err(format!(
            "its POSITION accessor {} has no bufferView",
            positions.index()
        ));
    }
    let count = positions.count();
    let material = primitive.material().index();
    let uv = material.map_or(
        UvChoice {
            set: 0,
            transform: None,
        },
        |m| uv_of[m],
    );
    // Every attribute counts as many values as POSITION: checked before any is read.
    let attribute = |semantic: Semantic| -> Result<Option<gltf::Accessor<'_>>, String> {
        match primitive.get(&semantic) {
            Some(a) if a.count() != count => Err(format!(
                "its {semantic:?} accessor has {} values, its POSITION {count}",
                a.count()
            )),
            other => Ok(other),
        }
    };
    let normals = attribute(Semantic::Normals)?;
    let uvs = attribute(Semantic::TexCoords(uv.set))?;
    let colours = attribute(Semantic::Colors(0))?;
    // Read first: this checks that the file holds `count` positions, which bounds every
    // allocation below (a hostile `count` would otherwise size them).
    let points = read_vectors::<3>(&positions, buffers, false)?;
    let indices = match primitive.indices() {
        Some(accessor) => read_indices(&accessor, buffers)?,
        None => (0..count as u32).collect(),
    };
    if let Some(&i) = indices.iter().find(|&&i| i as usize >= count) {
        return Err(format!(
            "index {i} is out of range: there are {count} vertices"
        ));
    }
    // Only the vertices the indices use: primitives often share one accessor of all
    // of a mesh's vertices, each using a part of it.
    let (used, indices) = compact(indices, count);
    let positions = placed_points(pick(&used, points), transform)?;
    let normal_matrix: Mat3A = transform.matrix3.inverse().transpose();
    let normals = normals
        .map(|a| read_vectors::<3>(&a, buffers, false))
        .transpose()?
        .map(|values| {
            let normal = |n: [f32; 3]| match Vec3::from(n) {
                n if n.is_finite() => Vec3::from(normal_matrix * glam::Vec3A::from(n)),
                _ => Vec3::ZERO,
            };
            let normals = pick(&used, values)
                .into_par_iter()
                .with_min_len(PARALLEL_MIN);
            normals.map(|n| normal(n).normalize_or_zero()).collect()
        });
    let uvs = uvs
        .map(|a| read_vectors::<2>(&a, buffers, false))
        .transpose()?
        .map(|values| {
            let apply = |t: [f32; 2]| Some(uv.apply(Vec2::from(t))).filter(|t| t.is_finite());
            let uvs = pick(&used, values).into_iter().map(apply);
            uvs.map(Option::unwrap_or_default).collect()
        });
    let colours = colours
        .map(|a| read_vectors::<3>(&a, buffers, true))
        .transpose()?
        .map(|values| {
            let colour = |c: [f32; 3]| Vec3::from(c).clamp(Vec3::ZERO, Vec3::ONE);
            let colours = pick(&used, values).into_iter().map(colour);
            colours
                .map(|c| if c.is_finite() { c } else { Vec3::ONE })
                .collect()
        });
    let mirrored = transform.matrix3.determinant() < 0.0;
    let (triangles, degenerate_dropped) = kept_triangles(mode, &indices, &positions, mirrored);
    Ok(Read::Triangles(Decoded {
        positions,
        normals,
        uvs,
        colours,
        triangles,
        material: material.map_or(default_material, |m| m as u32),
        degenerate_dropped,
        morph_targets: primitive.morph_targets().next().is_some(),
    }))
}

/// `points` placed by `transform`; one that is not finite there is an error.
fn placed_points(points: Vec<[f32; 3]>, transform: &Affine3A) -> Result<Vec<Vec3>, String> {
    let placed: Vec<Vec3> = points
        .into_par_iter()
        .with_min_len(PARALLEL_MIN)
        .map(|p| transform.transform_point3(Vec3::from(p)))
        .collect();
    match placed.iter().position(|p| !p.is_finite()) {
        Some(i) => {
            let p = placed[i];
            Err(format!(
                "vertex {i} is not finite ({} {} {})",
                p.x, p.y, p.z
            ))
        }
        None => Ok(placed),
    }
}

/// The triangles of `mode` through `indices` that have an area (counter-clockwise:
/// flipped where `mirrored`), and how many were dropped for having none.
fn kept_triangles(
    mode: Mode,
    indices: &[u32],
    positions: &[Vec3],
    mirrored: bool,
) -> (Vec<[u32; 3]>, usize) {
    let mut corners = triangles(mode, indices);
    let before = corners.len();
    corners.retain_mut(|t| {
        if mirrored {
            t.swap(1, 2);
        }
        let [pa, pb, pc] = t.map(|i| positions[i as usize]);
        let doubled_area = (pb - pa).cross(pc - pa).length();
        doubled_area > 0.0 && doubled_area.is_finite()
    });
    let dropped = before - corners.len();
    (corners, dropped)
}

/// The vertices `indices` use, in order of first use, and the indices renumbered to
/// them; `None` (and the indices as they are) when they use every one of `count`.
fn compact(indices: Vec<u32>, count: usize) -> (Option<Vec<u32>>, Vec<u32>) {
    let mut new_id = vec![u32::MAX; count];
    let mut used = Vec::new();
    let renumbered: Vec<u32> = indices
        .iter()
        .map(|&i| {
            let id = &mut new_id[i as usize];
            if *id == u32::MAX {
                *id = used.len() as u32;
                used.push(i);
            }
            *id
        })
        .collect();
    match used.len() == count {
        true => (None, indices),
        false => (Some(used), renumbered),
    }
}

/// The values of the vertices `used` (all of them without a list).
fn pick<T: Copy>(used: &Option<Vec<u32>>, values: Vec<T>) -> Vec<T> {
    match used {
        Some(used) => used.iter().map(|&i| values[i as usize]).collect(),
        None => values,
    }
}

/// `values` after `list`: moved whole into an empty list (the first primitive, often
/// the only one), as a copy into fresh memory would cost more than the reading.
fn extend<T>(list: &mut Vec<T>, values: Vec<T>) {
    if list.is_empty() {
        *list = values;
    } else {
        list.extend(values);
    }
}

/// Appends a primitive's `values` of one attribute (or, where it has none but others
/// had, `count` fill values), once any primitive has had that attribute.
fn pad<T: Copy>(
    list: &mut Vec<T>,
    any: &mut bool,
    offset: usize,
    count: usize,
    values: Option<Vec<T>>,
    fill: T,
) {
    match values {
        Some(values) => {
            if !*any {
                list.resize(offset, fill);
                *any = true;
            }
            extend(list, values);
        }
        None if *any => list.resize(offset + count, fill),
        None => {}
    }
}
