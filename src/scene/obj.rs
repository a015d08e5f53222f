//! Loading Wavefront OBJ scenes (with their MTL materials and `map_Kd` textures) through
//! `tobj` (the geometry of ordinary files through its parallel twin, `obj_parallel`),
//! and validating what they return before anything is rendered.

use std::borrow::Cow;
use std::cell::RefCell;
use std::collections::HashMap;
use std::path::{Path, PathBuf};

use glam::{Vec2, Vec3};

use super::obj_text::{normalize_mtl_colours, strip_comments};
use super::textures::TextureLoader;
use super::{Material, MaterialMaps, MtlValues, Scene, SceneError, TextureKind, TriangleMesh};

/// Facts about a load worth telling the user.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct LoadReport {
    /// Bytes of OBJ text read (what the loading rate is measured in).
    pub obj_bytes: u64,
    pub triangles: usize,
    pub vertices: usize,
    pub materials: usize,
    pub emitters: usize,
    /// Zero-area (or otherwise degenerate) triangles that were dropped.
    pub degenerate_dropped: usize,
    /// Non-fatal oddities, one line each (for example a `usemtl` with no definition).
    pub warnings: Vec<String>,
}

/// Reads a file whole; non-UTF-8 bytes (common in comments of old exporters) become
/// U+FFFD instead of failing the load.
fn read_text(path: &Path) -> std::io::Result<String> {
    let bytes = match read_in_parallel(path) {
        Some(bytes) => bytes,
        None => std::fs::read(path)?,
    };
    Ok(match String::from_utf8(bytes) {
        Ok(s) => s,
        Err(e) => String::from_utf8_lossy(e.as_bytes()).into_owned(),
    })
}

/// A regular file's bytes, read in pieces on all threads (a single reader leaves
/// most of a large OBJ's load waiting on one core's copy from the page cache); `None`
/// where that does not work (a pipe, a file that changed size), to read it plainly.
#[cfg(unix)]
fn read_in_parallel(path: &Path) -> Option<Vec<u8>> {
    use rayon::prelude::*;
    use std::os::unix::fs::FileExt;
    const PIECE: usize = 8 << 20;
    let file = std::fs::File::open(path).ok()?;
    let meta = file.metadata().ok()?;
    if !meta.is_file() {
        return None;
    }
    let mut bytes = vec![0; usize::try_from(meta.len()).ok()?];
    bytes
        .par_chunks_mut(PIECE)
        .enumerate()
        .try_for_each(|(i, piece)| file.read_exact_at(piece, (i * PIECE) as u64))
        .ok()?;
    // Nothing past the length we read: the file did not grow meanwhile.
    let at_end = matches!(file.read_at(&mut [0], meta.len()), Ok(0));
    at_end.then_some(bytes)
}

#[cfg(not(unix))]
fn read_in_parallel(_: &Path) -> Option<Vec<u8>> {
    None
}

/// Whether `usemtl` appears in the text outside comments.
fn mentions_usemtl(text: &str) -> bool {
    memchr::memmem::find_iter(text.as_bytes(), "usemtl").any(|at| {
        let line_start = text[..at].rfind('\n').map_or(0, |i| i + 1);
        !text[line_start..at].contains('#')
    })
}

/// Refuses face, line and point indices that point outside the file before tobj sees
/// them: a positive index past the number of `v`, `vt` or `vn` statements in the whole
/// file, or a negative (relative) one reaching before the first statement read so far.
/// tobj 4.0 does unchecked arithmetic on indices (`vt * 2 + 1` on a relative index
/// resolved below zero), which overflows. One pass over the text, so an index claiming
/// billions fails at once, naming its line. Indices within bounds are left to tobj.
fn check_face_indices(text: &str) -> Result<(), String> {
    let kind_of = |line: &str| match line.split_whitespace().next() {
        Some("v") => Some(0),
        Some("vt") => Some(1),
        Some("vn") => Some(2),
        _ => None,
    };
    let mut total = [0u64; 3];
    for line in text.lines() {
        if let Some(k) = kind_of(line) {
            total[k] += 1;
        }
    }
    const WHAT: [&str; 3] = ["vertices", "texture coordinates", "normals"];
    let mut so_far = [0u64; 3];
    for (n, line) in text.lines().enumerate() {
        if let Some(k) = kind_of(line) {
            so_far[k] += 1;
            continue;
        }
        let mut words = line.split_whitespace();
        if !matches!(words.next(), Some("f" | "l" | "p")) {
            continue;
        }
        for corner in words {
            for (kind, index) in corner.split('/').enumerate().take(3) {
                let Ok(i) = index.parse::<i64>() else {
                    continue; // empty (`v//n`) or malformed: tobj reports the latter
                };
                if i == 0 {
                    return Err(format!(
                        "line {}: index 0 is invalid: OBJ indices start at 1",
                        n + 1
                    ));
                }
                let (limit, whence) = if i < 0 {
                    (so_far[kind], "before it")
                } else {
                    (total[kind], "in the file")
                };
                if i.unsigned_abs() > limit {
                    return Err(format!(
                        "line {}: index {i} is out of range: there are {limit} {} {whence}",
                        n + 1,
                        WHAT[kind]
                    ));
                }
            }
        }
    }
    Ok(())
}

fn vec3(a: [f32; 3]) -> Vec3 {
    Vec3::from_array(a)
}

/// Where an OBJ's material libraries and textures are looked up: beside the file on
/// disk, or in a map of in-memory MTL texts (which has no textures).
enum Sources<'a> {
    Disk { dir: PathBuf },
    Memory { mtl: &'a HashMap<String, String> },
}

impl Sources<'_> {
    /// The text of the material library `name`, and the directory its textures are
    /// relative to (disk only).
    fn read_mtl(
        &self,
        name: &Path,
    ) -> Result<(PathBuf, String, Option<PathBuf>), (PathBuf, String)> {
        match self {
            Sources::Disk { dir } => {
                let path = dir.join(name);
                match read_text(&path) {
                    Ok(text) => {
                        let mtl_dir = path.parent().unwrap_or(Path::new("")).to_path_buf();
                        Ok((path, text, Some(mtl_dir)))
                    }
                    Err(e) => Err((path, e.to_string())),
                }
            }
            Sources::Memory { mtl } => match mtl.get(&*name.to_string_lossy()) {
                Some(text) => Ok((name.to_owned(), text.clone(), None)),
                None => Err((name.to_owned(), "no such material library in memory".into())),
            },
        }
    }
}

/// Most bytes of memory one byte of OBJ text costs while loading and building: the text
/// itself, tobj's arrays and index map, ember's mesh and Embree's BVH. Measured (peak
/// resident memory of `ember render` minus that of the Cornell box) over file size:
/// 5.1 for the Stanford bunny (2.4 MB), 2.1 for Sponza (7.6 MB); 8 leaves room for files
/// with shorter lines.
pub const MEMORY_PER_OBJ_BYTE: u64 = 8;

/// Triangle and vertex indices are `u32` and Embree's primitive ids too; 2^31 triangles
/// keeps every index and count well inside that.
pub const MAX_TRIANGLES: u64 = 1 << 31;

/// Loads an OBJ file, its material libraries and textures into a [`Scene`].
///
/// A file too large for the memory available (see [`crate::limits`]) is refused
/// before it is read.
pub fn load_obj(path: &Path) -> Result<(Scene, LoadReport), SceneError> {
    let io = |source| SceneError::Io {
        path: path.to_owned(),
        source,
    };
    let meta = std::fs::metadata(path).map_err(io)?;
    if meta.is_dir() {
        return Err(SceneError::IsDirectory {
            path: path.to_owned(),
        });
    }
    let needed = meta.len().saturating_mul(MEMORY_PER_OBJ_BYTE);
    if let Some(available) = crate::limits::available_memory() {
        if needed > available {
            return Err(SceneError::TooLarge {
                path: path.to_owned(),
                what: format!(
                    "the file is {}, which needs about {} of memory to load and build; only {} is available",
                    crate::limits::human_bytes(meta.len()),
                    crate::limits::human_bytes(needed),
                    crate::limits::human_bytes(available)
                ),
            });
        }
    }
    let text = read_text(path).map_err(io)?;
    let dir = path.parent().unwrap_or(Path::new("")).to_path_buf();
    load_obj_text(path, text.into(), &Sources::Disk { dir })
}

/// Loads an OBJ scene from text in memory; `mtl` maps each `mtllib` name to the text of
/// that material library. Textures (`map_Kd`) cannot be resolved and are an error.
/// Errors name the OBJ as `<memory>.obj`.
pub fn load_obj_from_str(
    obj: &str,
    mtl: &HashMap<String, String>,
) -> Result<(Scene, LoadReport), SceneError> {
    load_obj_text(
        Path::new("<memory>.obj"),
        obj.into(),
        &Sources::Memory { mtl },
    )
}

/// The one conversion from OBJ text to a scene, for files and in-memory text alike.
/// The text is let go of once parsed, before the mesh is built.
fn load_obj_text(
    path: &Path,
    text: Cow<'_, str>,
    sources: &Sources<'_>,
) -> Result<(Scene, LoadReport), SceneError> {
    let obj_bytes = text.len() as u64;
    let names_materials = mentions_usemtl(&text);
    let Parsed {
        models,
        materials: tobj_materials,
        mtl_dirs,
    } = parse(path, &text, sources)?;
    drop(text);
    let mut report = LoadReport {
        obj_bytes,
        ..LoadReport::default()
    };
    // Faces without a (known) material use a matte grey at the end of the list.
    let default_material = tobj_materials.len() as u32;
    let mesh = build_mesh(path, &models, default_material, &mut report)?;
    // The mesh holds the geometry now: free tobj's copy before textures are decoded.
    drop(models);
    // In memory there is no directory to search: every texture is "not found".
    let mut search_dirs = Vec::new();
    if let Sources::Disk { dir } = sources {
        search_dirs.push(dir.clone());
        search_dirs.extend(mtl_dirs);
    }
    let mut loader = TextureLoader::new(search_dirs);
    let mut materials = build_materials(&tobj_materials, &mut loader, &mut report)?;
    materials.push(Material::default());
    if names_materials && tobj_materials.is_empty() {
        report.warnings.push(
            "faces name materials but no material library was loaded; they render grey".into(),
        );
    }
    let TextureLoader {
        textures,
        alpha_maps,
        ..
    } = loader;
    let mut scene = Scene::new(mesh, materials, textures);
    scene.alpha_maps = alpha_maps;
    report.triangles = scene.mesh.triangles.len();
    report.vertices = scene.mesh.positions.len();
    report.materials = tobj_materials.len();
    report.emitters = scene.emitters.len();
    Ok((scene, report))
}

/// What tobj read: the models, their materials, and the folders the MTL files came
/// from (textures are looked up there too).
struct Parsed {
    models: Vec<tobj::Model>,
    materials: Vec<tobj::Material>,
    mtl_dirs: Vec<PathBuf>,
}

/// Reads the OBJ text (with comments) in parallel ([`obj_parallel`]), or with tobj
/// where that declines, reading each `mtllib` ourselves so that a missing or broken
/// library is an error naming the file, not a silently grey scene; then refuses counts
/// that do not fit ember's indices.
fn parse(path: &Path, text: &str, sources: &Sources<'_>) -> Result<Parsed, SceneError> {
    let mtl_error: RefCell<Option<SceneError>> = RefCell::new(None);
    let mtl_dirs: RefCell<Vec<PathBuf>> = RefCell::new(Vec::new());
    let load_mtl = |name: &Path| -> tobj::MTLLoadResult {
        let fail = |mtl_path: PathBuf, reason: String| {
            mtl_error.borrow_mut().get_or_insert(SceneError::Mtl {
                path: mtl_path,
                obj: path.to_owned(),
                reason,
            });
            Err(tobj::LoadError::OpenFileFailed)
        };
        let (mtl_path, text, mtl_dir) = match sources.read_mtl(name) {
            Ok(found) => found,
            Err((mtl_path, reason)) => return fail(mtl_path, reason),
        };
        mtl_dirs.borrow_mut().extend(mtl_dir);
        let text = match normalize_mtl_colours(&text) {
            Ok(t) => t,
            Err(reason) => return fail(mtl_path, reason),
        };
        let loaded = tobj::load_mtl_buf(&mut text.as_bytes());
        match loaded
            .as_ref()
            .map(|(materials, _)| materials.iter().find_map(unusable_value))
        {
            Err(e) => fail(mtl_path, format!("{e}")),
            Ok(Some(reason)) => fail(mtl_path, reason),
            Ok(None) => loaded,
        }
    };
    let options = tobj::LoadOptions {
        single_index: true,
        triangulate: true,
        ignore_points: true,
        ignore_lines: true,
    };
    let obj_error = |reason: String| SceneError::Obj {
        path: path.to_owned(),
        reason,
    };
    let loaded = match super::obj_parallel::load_obj(text, &load_mtl) {
        Some(loaded) => loaded,
        None => {
            let text = strip_comments(text);
            check_face_indices(&text).map_err(obj_error)?;
            tobj::load_obj_buf(&mut text.as_bytes(), &options, load_mtl)
        }
    };
    if let Some(e) = mtl_error.into_inner() {
        return Err(e);
    }
    let (models, materials) = loaded.map_err(|e| obj_error(e.to_string()))?;
    let materials = materials.map_err(|e| obj_error(format!("materials: {e}")))?;
    let triangle_count: u64 = models.iter().map(|m| m.mesh.indices.len() as u64 / 3).sum();
    let vertex_count: u64 = models
        .iter()
        .map(|m| m.mesh.positions.len() as u64 / 3)
        .sum();
    check_counts(triangle_count, vertex_count).map_err(|what| SceneError::TooLarge {
        path: path.to_owned(),
        what,
    })?;
    Ok(Parsed {
        models,
        materials,
        mtl_dirs: mtl_dirs.into_inner(),
    })
}

/// The largest `Ni` ember accepts: past it the glass's `1/η²` comes near `f32`'s
/// smallest normal numbers and refraction is no longer finite arithmetic (real
/// dielectrics stay below 5; the MTL specification allows up to 10).
pub const MAX_IOR: f32 = 1000.0;

/// Why a material's numbers would make its samples non-finite, if they would:
/// `Kd`, `Ks`, `Ke`, `Ns` and `Ni` must be finite (and `Ni` at most [`MAX_IOR`]).
/// (`d`, `Tr`, `Pr` and `Pm` are checked to lie in [0, 1] where they are read.)
fn unusable_value(m: &tobj::Material) -> Option<String> {
    let colours = [("Kd", m.diffuse), ("Ks", m.specular), ("Ke", m.emissive)];
    let bad = |key: &str, value: String| {
        Some(format!(
            "material {:?}: {key} {value} is not finite",
            m.name
        ))
    };
    for (key, colour) in colours {
        if let Some(c) = colour.filter(|c| !c.iter().all(|x| x.is_finite())) {
            return bad(key, format!("{} {} {}", c[0], c[1], c[2]));
        }
    }
    for (key, value) in [("Ns", m.shininess), ("Ni", m.optical_density)] {
        if let Some(v) = value.filter(|v| !v.is_finite()) {
            return bad(key, v.to_string());
        }
    }
    m.optical_density.filter(|&ni| ni > MAX_IOR).map(|ni| {
        format!(
            "material {:?}: Ni {ni} is past {MAX_IOR}, where glass is no longer finite arithmetic",
            m.name
        )
    })
}

/// ember's materials from tobj's, with their textures and opacity maps decoded.
fn build_materials(
    tobj_materials: &[tobj::Material],
    loader: &mut TextureLoader,
    report: &mut LoadReport,
) -> Result<Vec<Material>, SceneError> {
    let mut zero_opacity = Vec::new();
    let mut materials = Vec::with_capacity(tobj_materials.len() + 1);
    for m in tobj_materials {
        let (texture, kd_alpha) = match &m.diffuse_texture {
            Some(name) => {
                let (texture, alpha) = loader.diffuse(name, &m.name)?;
                (Some(texture), alpha)
            }
            None => (None, None),
        };
        let values = MtlValues {
            kd: m.diffuse.map(vec3),
            ks: m.specular.map(vec3),
            ke: m.emissive.map(vec3),
            ns: m.shininess,
            ni: m.optical_density,
            illum: m.illumination_model,
            pr: unit_parameter(m, "Pr")?,
            pm: unit_parameter(m, "Pm")?,
            maps: material_maps(m, loader)?,
        };
        let mut material = Material::from_mtl(&m.name, &values, texture);
        material.opacity = match opacity_constant(m)? {
            Some(0.0) => {
                zero_opacity.push(m.name.clone());
                1.0
            }
            d => d.unwrap_or(1.0),
        };
        // An explicit `map_d` wins over the alpha channel of `map_Kd`.
        material.opacity_map = match &m.dissolve_texture {
            Some(name) => Some(loader.opacity(name, &m.name)?),
            None => kd_alpha,
        };
        materials.push(material);
    }
    if !zero_opacity.is_empty() {
        report.warnings.push(zero_opacity_warning(&zero_opacity));
    }
    Ok(materials)
}

/// The texture maps of a material other than `map_Kd` and `map_d`, decoded.
fn material_maps(
    m: &tobj::Material,
    loader: &mut TextureLoader,
) -> Result<MaterialMaps, SceneError> {
    use TextureKind::{Colour, Scalar, Vector};
    let extra = |key: &str| m.unknown_param.get(key).map(String::as_str);
    // tobj reads `bump` and `map_Bump` into `normal_texture`; they are height maps.
    let slots: [(Option<&str>, &'static str, TextureKind); 7] = [
        (m.specular_texture.as_deref(), "map_Ks", Colour),
        (m.shininess_texture.as_deref(), "map_Ns", Scalar),
        (extra("map_Ke"), "map_Ke", Colour),
        (extra("map_Pr"), "map_Pr", Scalar),
        (extra("map_Pm"), "map_Pm", Scalar),
        (m.normal_texture.as_deref(), "bump", Scalar),
        (extra("norm"), "norm", Vector),
    ];
    let mut ids = [None; 7];
    let mut bump_scale = 1.0;
    for (k, (statement, slot, kind)) in slots.into_iter().enumerate() {
        if let Some(statement) = statement {
            let (id, scale) = loader.texture(statement, slot, &m.name, kind)?;
            ids[k] = Some(id);
            if slot == "bump" {
                bump_scale = scale;
            }
        }
    }
    let [specular, shininess, emission, roughness, metallic, bump, normal] = ids;
    Ok(MaterialMaps {
        specular,
        shininess,
        emission,
        roughness,
        metallic,
        bump,
        bump_scale,
        normal,
    })
}

/// A PBR extension scalar (`Pr`, `Pm`): a number in [0, 1], or an error naming it.
fn unit_parameter(m: &tobj::Material, key: &str) -> Result<Option<f32>, SceneError> {
    let Some(text) = m.unknown_param.get(key) else {
        return Ok(None);
    };
    let word = text.split_whitespace().next().unwrap_or("");
    match word.parse::<f32>() {
        Ok(x) if (0.0..=1.0).contains(&x) => Ok(Some(x)),
        _ => Err(SceneError::Material {
            material: m.name.clone(),
            reason: format!("{key} {text:?} is not a number in [0, 1]"),
        }),
    }
}

/// One indexed mesh from every model: positions, normals and UVs checked to be
/// finite, faces checked to be in range, degenerate triangles dropped and counted.
fn build_mesh(
    path: &Path,
    models: &[tobj::Model],
    default_material: u32,
    report: &mut LoadReport,
) -> Result<TriangleMesh, SceneError> {
    let mut mesh = TriangleMesh::default();
    // Sized once, with room for one more vertex and triangle: Embree reads these
    // arrays in place and loads their last items 16 bytes at a time
    // (`Device::build_shared_triangle_scene`).
    let vertices: usize = models.iter().map(|m| m.mesh.positions.len() / 3).sum();
    let triangles: usize = models.iter().map(|m| m.mesh.indices.len() / 3).sum();
    mesh.positions.reserve_exact(vertices + 1);
    mesh.triangles.reserve_exact(triangles + 1);
    mesh.material.reserve_exact(triangles);
    let mut attributes = AttributePresence::default();
    for model in models {
        let offset = mesh.positions.len();
        append_attributes(path, &model.mesh, &mut mesh, &mut attributes)?;
        let material = match model.mesh.material_id {
            Some(id) if (id as u32) < default_material => id as u32,
            _ => default_material,
        };
        let count = model.mesh.positions.len() / 3;
        for tri in model.mesh.indices.chunks_exact(3) {
            if tri.iter().any(|&i| i as usize >= count) {
                return Err(SceneError::Obj {
                    path: path.to_owned(),
                    reason: format!("face index out of range in object {:?}", model.name),
                });
            }
            let tri = [0, 1, 2].map(|k| (offset + tri[k] as usize) as u32);
            let [a, b, c] = tri.map(|i| mesh.positions[i as usize]);
            let doubled_area = (b - a).cross(c - a).length();
            if !(doubled_area > 0.0 && doubled_area.is_finite()) {
                report.degenerate_dropped += 1;
                continue;
            }
            mesh.triangles.push(tri);
            mesh.material.push(material);
        }
    }
    // Defined bytes in the room past the ends, which Embree's 16-byte loads touch.
    if let Some(slot) = mesh.positions.spare_capacity_mut().first_mut() {
        slot.write(Vec3::ZERO);
    }
    if let Some(slot) = mesh.triangles.spare_capacity_mut().first_mut() {
        slot.write([0; 3]);
    }
    if mesh.triangles.is_empty() {
        let detail = if report.degenerate_dropped > 0 {
            format!(
                " (all {} triangles are degenerate)",
                report.degenerate_dropped
            )
        } else {
            " (no face statements were found)".to_owned()
        };
        return Err(SceneError::Empty {
            path: path.to_owned(),
            detail,
        });
    }
    Ok(mesh)
}

/// Whether any model so far had normals or UVs: once one has, every vertex gets one
/// (zero where its model had none).
#[derive(Default)]
struct AttributePresence {
    normals: bool,
    uvs: bool,
}

/// Appends one model's vertex positions, normals and UVs to `mesh`.
fn append_attributes(
    path: &Path,
    m: &tobj::Mesh,
    mesh: &mut TriangleMesh,
    any: &mut AttributePresence,
) -> Result<(), SceneError> {
    let offset = mesh.positions.len();
    let count = m.positions.len() / 3;
    for (i, p) in m.positions.chunks_exact(3).enumerate() {
        let p = Vec3::new(p[0], p[1], p[2]);
        if !p.is_finite() {
            return Err(non_finite(path, "vertex", offset + i + 1, p));
        }
        mesh.positions.push(p);
    }
    // tobj's single index gives attributes per vertex, or none for the whole model.
    if m.normals.len() == m.positions.len() && count > 0 {
        if !any.normals {
            mesh.normals.resize(offset, Vec3::ZERO);
            any.normals = true;
        }
        for (i, n) in m.normals.chunks_exact(3).enumerate() {
            let n = Vec3::new(n[0], n[1], n[2]);
            if !n.is_finite() {
                return Err(non_finite(path, "normal", offset + i + 1, n));
            }
            mesh.normals.push(n);
        }
    } else if any.normals {
        mesh.normals.resize(offset + count, Vec3::ZERO);
    }
    if m.texcoords.len() / 2 == count && count > 0 {
        if !any.uvs {
            mesh.uvs.resize(offset, Vec2::ZERO);
            any.uvs = true;
        }
        for (i, t) in m.texcoords.chunks_exact(2).enumerate() {
            let t = Vec2::new(t[0], t[1]);
            if !t.is_finite() {
                return Err(non_finite(
                    path,
                    "texture coordinate",
                    offset + i + 1,
                    t.extend(0.0),
                ));
            }
            mesh.uvs.push(t);
        }
    } else if any.uvs {
        mesh.uvs.resize(offset + count, Vec2::ZERO);
    }
    Ok(())
}

/// Refuses meshes whose triangle or vertex count does not fit ember's `u32` indices.
pub fn check_counts(triangles: u64, vertices: u64) -> Result<(), String> {
    if triangles > MAX_TRIANGLES {
        return Err(format!(
            "{triangles} triangles is more than the {MAX_TRIANGLES} ember supports"
        ));
    }
    if vertices > u64::from(u32::MAX) {
        return Err(format!(
            "{vertices} vertices is more than the {} ember supports",
            u32::MAX
        ));
    }
    Ok(())
}

fn non_finite(path: &Path, what: &'static str, index: usize, value: Vec3) -> SceneError {
    SceneError::NonFinite {
        path: path.to_owned(),
        what,
        index,
        value: format!("{} {} {}", value.x, value.y, value.z),
    }
}

/// A material's constant opacity: `d`, else `1 − Tr` (`d` wins when both are given,
/// as in tinyobjloader), else `None`. A value outside [0, 1] is an error.
fn opacity_constant(m: &tobj::Material) -> Result<Option<f32>, SceneError> {
    let bad = |reason: String| SceneError::Material {
        material: m.name.clone(),
        reason,
    };
    let tr = match m.unknown_param.get("Tr") {
        Some(text) => {
            let word = text.split_whitespace().next().unwrap_or("");
            let tr: f32 = word
                .parse()
                .map_err(|_| bad(format!("Tr {text:?} is not a number")))?;
            Some((tr, 1.0 - tr))
        }
        None => None,
    };
    let (statement, value, opacity) = match (m.dissolve, tr) {
        (Some(d), _) => ("d", d, d),
        (None, Some((tr, opacity))) => ("Tr", tr, opacity),
        (None, None) => return Ok(None),
    };
    if !(0.0..=1.0).contains(&value) {
        return Err(bad(format!(
            "{statement} {value} is outside [0, 1] (0 is transparent for d, opaque for Tr)"
        )));
    }
    Ok(Some(opacity))
}

/// The one warning for materials whose `d 0` (or `Tr 1`) ember renders opaque.
fn zero_opacity_warning(names: &[String]) -> String {
    let shown: Vec<&str> = names.iter().take(3).map(String::as_str).collect();
    let more = match names.len() {
        n if n > 3 => format!(" and {} more", n - 3),
        _ => String::new(),
    };
    format!(
        "{} material(s) ({}{more}) say `d 0` or `Tr 1`, fully transparent; many exporters \
         write that meaning opaque, so, like obj2gltf, ember renders them opaque \
         (use `d 0.001` for an almost invisible surface)",
        names.len(),
        shown.join(", ")
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn counts_past_u32_indices_are_refused() {
        assert!(check_counts(MAX_TRIANGLES, u64::from(u32::MAX)).is_ok());
        let err = check_counts(MAX_TRIANGLES + 1, 3).unwrap_err();
        assert!(err.contains("2147483649 triangles"), "{err}");
        let err = check_counts(1, u64::from(u32::MAX) + 1).unwrap_err();
        assert!(err.contains("4294967296 vertices"), "{err}");
    }

    #[test]
    fn face_indices_are_bounded_by_the_statements_they_refer_to() {
        let ok = "v 0 0 0\nv 1 0 0\nf 1 2 3\nv 0 1 0\nf -3 -2 -1\n";
        assert!(check_face_indices(ok).is_ok());
        // Relative indices count only what came before; positive ones the whole file.
        let err = check_face_indices("v 0 0 0\nf -2 1 1\nv 1 0 0\n").unwrap_err();
        assert!(
            err.starts_with("line 2:") && err.contains("1 vertices before it"),
            "{err}"
        );
        let err = check_face_indices("v 0 0 0\nvt 0 0\nf 1/2 1/1 1/1\n").unwrap_err();
        assert!(err.contains("1 texture coordinates in the file"), "{err}");
        // Malformed numbers are left to tobj, which reports them.
        assert!(check_face_indices("v 0 0 0\nf a b c\n").is_ok());
    }
}
