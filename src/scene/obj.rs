//! Loading Wavefront OBJ scenes (with their MTL materials and textures) through `tobj`
//! (the geometry of ordinary files through its parallel twin, `obj_parallel`; the
//! material libraries through ember's own reader, `mtl`, for both), and validating what
//! they return before anything is rendered.
//!
//! Whichever reader reads the geometry, the rest is one path: material libraries and
//! textures are found by the rules of `asset_paths`, absent ones are warnings (or, with
//! [`LoadOptions::strict`], errors) through `warnings`, and the `usemtl` names no
//! library defines are found by scanning the text.

use std::borrow::Cow;
use std::cell::RefCell;
use std::collections::{HashMap, HashSet};
use std::path::{Path, PathBuf};

use glam::{Vec2, Vec3};

use super::asset_paths;
use super::mtl::{self, parse_mtl};
use super::obj_text::{pad_vertex_colours, strip_comments, used_material};
use super::texture_files::{Referrer, TextureLoader};
use super::warnings::{LoadOptions, Warnings};
use super::{Material, MaterialMaps, MtlValues, Scene, SceneError, TextureKind, TriangleMesh};
use crate::io::{InputFile, ReadError};
use crate::limits::{check_fits, human_bytes};

/// Facts about a load worth telling the user.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct LoadReport {
    /// Bytes of OBJ text read (what the loading rate is measured in).
    pub obj_bytes: u64,
    pub triangles: usize,
    pub vertices: usize,
    pub materials: usize,
    pub emitters: usize,
    /// Lights a scene file places (`[[light]]`), area lights among them.
    pub lights: usize,
    /// Zero-area (or otherwise degenerate) triangles that were dropped.
    pub degenerate_dropped: usize,
    /// How the file wrote its vertex colours (`v x y z r g b`), if it has them.
    pub vertex_colours: Option<VertexColours>,
    /// The material of the faces the file gives none (ember's default), when some
    /// face uses it: the one a scene file's `color` sets.
    pub default_material: Option<u32>,
    /// Non-fatal oddities, one line each, each naming its file (for example a `usemtl`
    /// with no definition).
    pub warnings: Vec<String>,
}

impl LoadReport {
    /// `12 triangles, 3 materials, 2 emissive triangles, 1 placed light, vertex colours
    /// (0-255), 1 warning`: the counts, with the placed lights, the vertex colours and
    /// the warnings where there are any.
    pub fn summary(&self) -> String {
        let colours = self.vertex_colours.map_or(String::new(), |c| {
            format!(", vertex colours ({})", c.range())
        });
        let warnings = match self.warnings.len() {
            0 => String::new(),
            1 => ", 1 warning".to_owned(),
            n => format!(", {n} warnings"),
        };
        let lights = match self.lights {
            0 => String::new(),
            1 => ", 1 placed light".to_owned(),
            n => format!(", {n} placed lights"),
        };
        format!(
            "{} triangles, {} materials, {} emissive triangles{lights}{colours}{warnings}",
            self.triangles, self.materials, self.emitters
        )
    }
}

/// How an OBJ wrote its vertex colours: every value at most 1 reads as [0, 1]; a file
/// with any value above 1 reads as 0-255 and is divided by 255.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum VertexColours {
    Unit,
    Bytes,
}

impl VertexColours {
    /// `"[0, 1]"` or `"0-255"`, for the summary.
    pub fn range(self) -> &'static str {
        match self {
            VertexColours::Unit => "[0, 1]",
            VertexColours::Bytes => "0-255",
        }
    }
}

/// The text of the file at `path`, after checking that `per_byte` bytes of memory for
/// each of its bytes fit in the memory available.
fn read_checked(path: &Path, per_byte: u64) -> Result<String, ReadError> {
    let input = InputFile::open(path)?;
    let what = format!("the file ({})", human_bytes(input.len()));
    check_fits(&what, input.len().saturating_mul(per_byte))
        .map_err(|reason| ReadError::new(path, reason))?;
    read_text(input)
}

/// Reads an opened file whole; non-UTF-8 bytes (common in comments of old exporters)
/// become U+FFFD instead of failing the load.
fn read_text(input: InputFile) -> Result<String, ReadError> {
    let bytes = read_in_parallel(input)?;
    Ok(match String::from_utf8(bytes) {
        Ok(s) => s,
        Err(e) => String::from_utf8_lossy(e.as_bytes()).into_owned(),
    })
}

/// A regular file's bytes, read in pieces on all threads: a single reader leaves most
/// of a large OBJ's load waiting on one core's copy from the page cache.
#[cfg(unix)]
fn read_in_parallel(input: InputFile) -> Result<Vec<u8>, ReadError> {
    use rayon::prelude::*;
    use std::os::unix::fs::FileExt;
    const PIECE: usize = 8 << 20;
    let fail = |e: std::io::Error| ReadError::new(input.path(), e.to_string());
    let len = usize::try_from(input.len())
        .map_err(|_| ReadError::new(input.path(), "it is too large to read"))?;
    let mut bytes = vec![0; len];
    bytes
        .par_chunks_mut(PIECE)
        .enumerate()
        .try_for_each(|(i, piece)| input.file().read_exact_at(piece, (i * PIECE) as u64))
        .map_err(|e| match e.kind() {
            std::io::ErrorKind::UnexpectedEof => {
                ReadError::new(input.path(), "it became shorter while being read")
            }
            _ => fail(e),
        })?;
    // Nothing past the length read: the file did not grow meanwhile.
    match input.file().read_at(&mut [0], input.len()) {
        Ok(0) => Ok(bytes),
        Ok(_) => Err(ReadError::new(input.path(), "it grew while being read")),
        Err(e) => Err(fail(e)),
    }
}

#[cfg(not(unix))]
fn read_in_parallel(input: InputFile) -> Result<Vec<u8>, ReadError> {
    input.read_all()
}

/// The material names the text's `usemtl` statements give, each once, with the line
/// of its first use, read as both OBJ readers read them.
fn used_materials(text: &str) -> Vec<(usize, String)> {
    let mut used: Vec<(usize, String)> = Vec::new();
    let mut seen: HashSet<&str> = HashSet::new();
    let (mut line, mut counted) = (1, 0);
    for at in memchr::memmem::find_iter(text.as_bytes(), "usemtl") {
        let start = text[..at].rfind('\n').map_or(0, |i| i + 1);
        let end = text[at..].find('\n').map_or(text.len(), |i| at + i);
        let Some(name) = used_material(&text[start..end]) else {
            continue;
        };
        line += memchr::memchr_iter(b'\n', &text.as_bytes()[counted..start]).count();
        counted = start;
        if seen.insert(name) {
            used.push((line, name.to_owned()));
        }
    }
    used
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

/// What the faces of a library that is absent use.
const INSTEAD_OF_LIBRARY: &str = "the faces that name its materials use ember's default material";

/// A material library as loaded: the folder its textures are looked up in (none in
/// memory), and how many materials it gave, in the order both readers merge them.
struct Library {
    folder: Option<PathBuf>,
    materials: usize,
}

impl Sources<'_> {
    /// The file of the material library `written` names (found by the rules of
    /// `asset_paths`) and its text; `None` (warned) when it is absent.
    fn read_mtl(
        &self,
        obj: &Path,
        written: &str,
        warnings: &mut Warnings,
    ) -> Result<Option<(PathBuf, String, Option<PathBuf>)>, SceneError> {
        let error = |path: PathBuf, reason| SceneError::Mtl {
            path,
            obj: obj.to_owned(),
            reason,
        };
        match self {
            Sources::Disk { dir } => {
                let found = asset_paths::find(written, &[dir]);
                let missing = |reason| error(dir.join(written), reason);
                let Some(path) = warnings.located(found, missing, INSTEAD_OF_LIBRARY)? else {
                    return Ok(None);
                };
                let text = read_mtl(&path).map_err(|e| error(path.clone(), e.reason))?;
                let folder = path.parent().unwrap_or(Path::new("")).to_path_buf();
                Ok(Some((path, text, Some(folder))))
            }
            Sources::Memory { mtl } => match mtl.get(written) {
                Some(text) => Ok(Some((written.into(), text.clone(), None))),
                None => {
                    let reason = "no such material library in memory".into();
                    warnings.absent(error(written.into(), reason), INSTEAD_OF_LIBRARY)?;
                    Ok(None)
                }
            },
        }
    }

    /// The libraries one `mtllib` statement names: the whole of `written` when a
    /// library goes by that name (names may hold spaces), otherwise each of its words,
    /// as the OBJ specification's `mtllib a.mtl b.mtl` lists several.
    fn library_names<'w>(&self, written: &'w str) -> Vec<&'w str> {
        let whole = match self {
            Sources::Disk { dir } => asset_paths::find(written, &[dir]).is_some(),
            Sources::Memory { mtl } => mtl.contains_key(written),
        };
        match written.split_whitespace().collect::<Vec<_>>() {
            words if words.len() > 1 && !whole => words,
            _ => vec![written],
        }
    }

    /// Reads and checks the material library `written` names: its materials (none when
    /// it is absent), with its warnings (unknown keys) said as `FILE:LINE: …`.
    fn load_mtl(
        &self,
        obj: &Path,
        written: &str,
        warnings: &mut Warnings,
    ) -> Result<Option<(Library, Vec<tobj::Material>)>, SceneError> {
        let Some((path, text, folder)) = self.read_mtl(obj, written, warnings)? else {
            return Ok(None);
        };
        let library = parse_mtl(&text).map_err(|e| SceneError::MtlSyntax {
            path: path.clone(),
            line: e.line,
            obj: obj.to_owned(),
            reason: e.message,
        })?;
        if let Some(reason) = library.materials.iter().find_map(unusable_value) {
            return Err(SceneError::Mtl {
                path,
                obj: obj.to_owned(),
                reason,
            });
        }
        for (line, warning) in library.warnings {
            warnings.push(format!("{}:{line}: {warning}", path.display()));
        }
        let loaded = Library {
            folder,
            materials: library.materials.len(),
        };
        Ok(Some((loaded, library.materials)))
    }
}

/// Most bytes of memory one byte of OBJ text costs while loading and building: the text
/// itself, tobj's arrays and index map, ember's mesh and Embree's BVH. Measured (peak
/// resident memory of `ember render` minus that of the Cornell box) over file size:
/// 5.1 for the Stanford bunny (2.4 MB), 2.1 for Sponza (7.6 MB); 8 leaves room for files
/// with shorter lines.
pub const MEMORY_PER_OBJ_BYTE: u64 = 8;

/// Most bytes of memory one byte of MTL text costs while loading, besides its
/// materials: the text, its copies, and the reader's record of the keys it does not
/// know (a `KEY VALUE` line of a distinct key, 7 bytes or more when they are many,
/// keeps its key, its count and its warning). An upper bound of the worst case
/// measured (benches/results/2026-12-06-memory-estimates.md).
pub const MEMORY_PER_MTL_BYTE: u64 = 48;

/// Bytes of memory one `newmtl` costs while loading: the reader's material and ember's (an
/// upper bound of what was measured, as above).
pub const MEMORY_PER_MATERIAL: u64 = 1024;

/// The text of the material library at `path`, after checking that its text and its
/// materials fit in the memory available.
fn read_mtl(path: &Path) -> Result<String, ReadError> {
    let text = read_checked(path, MEMORY_PER_MTL_BYTE)?;
    // As the MTL reader reads them: the first word of a line, in any case.
    let materials = text
        .lines()
        .filter(|l| {
            l.split_whitespace()
                .next()
                .is_some_and(|w| w.eq_ignore_ascii_case("newmtl"))
        })
        .count() as u64;
    check_fits(
        &format!("its {materials} materials"),
        materials.saturating_mul(MEMORY_PER_MATERIAL),
    )
    .map_err(|reason| ReadError::new(path, reason))?;
    Ok(text)
}

/// Triangle and vertex indices are `u32` and Embree's primitive ids too; 2^31 triangles
/// keeps every index and count well inside that.
pub const MAX_TRIANGLES: u64 = 1 << 31;

/// Loads an OBJ file, its material libraries and textures into a [`Scene`], with
/// absent inputs as warnings ([`LoadOptions::default`]).
pub fn load_obj(path: &Path) -> Result<(Scene, LoadReport), SceneError> {
    load_obj_with(path, &LoadOptions::default())
}

/// Loads an OBJ file, its material libraries and textures into a [`Scene`].
///
/// A file too large for the memory available (see [`crate::limits`]) is refused
/// before it is read.
pub fn load_obj_with(
    path: &Path,
    options: &LoadOptions,
) -> Result<(Scene, LoadReport), SceneError> {
    let text = read_checked(path, MEMORY_PER_OBJ_BYTE)?;
    let dir = path.parent().unwrap_or(Path::new("")).to_path_buf();
    load_obj_text(path, text.into(), &Sources::Disk { dir }, options)
}

/// Loads an OBJ scene from text in memory; `mtl` maps each `mtllib` name to the text of
/// that material library. Textures cannot be found: each is absent (a warning, or with
/// `strict` an error). Errors name the OBJ as `<memory>.obj`.
pub fn load_obj_from_str(
    obj: &str,
    mtl: &HashMap<String, String>,
    options: &LoadOptions,
) -> Result<(Scene, LoadReport), SceneError> {
    load_obj_text(
        Path::new("<memory>.obj"),
        obj.into(),
        &Sources::Memory { mtl },
        options,
    )
}

/// The one conversion from OBJ text to a scene, for files and in-memory text alike.
/// The text is let go of once parsed, before the mesh is built.
fn load_obj_text(
    path: &Path,
    text: Cow<'_, str>,
    sources: &Sources<'_>,
    options: &LoadOptions,
) -> Result<(Scene, LoadReport), SceneError> {
    let obj_bytes = text.len() as u64;
    // A byte-order mark (Windows tools write one) would hide the first statement.
    let body = text.strip_prefix('\u{feff}').unwrap_or(&text);
    let used = used_materials(body);
    let mut warnings = Warnings::new(options);
    let Parsed {
        models,
        materials: tobj_materials,
        libraries,
    } = parse(path, body, sources, &mut warnings)?;
    drop(text);
    let mut report = LoadReport {
        obj_bytes,
        ..LoadReport::default()
    };
    // Faces without a (known) material use the default material at the end of the list.
    let default_material = tobj_materials.len() as u32;
    let mesh = build_mesh(path, &models, default_material, &mut report)?;
    // The mesh holds the geometry now: free tobj's copy before textures are decoded.
    drop(models);
    let default = default_material_for(&mesh);
    warn_undefined(path, &used, &tobj_materials, &default, &mut warnings)?;
    let obj_dir = match sources {
        Sources::Disk { dir } => Some(dir.as_path()),
        Sources::Memory { .. } => None,
    };
    let mut loader = TextureLoader::default();
    let sources = MaterialSources {
        obj: path,
        libraries: &libraries,
        obj_dir,
    };
    let mut materials = build_materials(&tobj_materials, &sources, &mut loader, &mut warnings)?;
    materials.push(default);
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
    report.default_material = scene
        .mesh
        .material
        .contains(&default_material)
        .then_some(default_material);
    report.warnings.extend(warnings.lines);
    Ok((scene, report))
}

/// The material of faces that name none, or one no library defines: matte grey, or
/// white where the vertices carry colours, so that the colours are what is seen.
pub(super) fn default_material_for(mesh: &TriangleMesh) -> Material {
    let mut default = Material::default();
    if !mesh.colours.is_empty() {
        default.diffuse = Vec3::ONE;
    }
    default
}

/// One warning (or with `--strict` an error) for each material a `usemtl` names that
/// no library defines.
fn warn_undefined(
    path: &Path,
    used: &[(usize, String)],
    defined: &[tobj::Material],
    default: &Material,
    warnings: &mut Warnings,
) -> Result<(), SceneError> {
    let d = default.diffuse;
    let instead = format!(
        "its faces use ember's default material (diffuse {} {} {})",
        d.x, d.y, d.z
    );
    let defined: HashSet<&str> = defined.iter().map(|m| m.name.as_str()).collect();
    for (line, name) in used {
        if !defined.contains(name.as_str()) {
            let error = SceneError::UndefinedMaterial {
                path: path.to_owned(),
                line: *line,
                name: name.clone(),
            };
            warnings.absent(error, &instead)?;
        }
    }
    Ok(())
}

/// What tobj read: the models, their materials, and the libraries they came from, in
/// order (a material's textures are looked up beside its library).
struct Parsed {
    models: Vec<tobj::Model>,
    materials: Vec<tobj::Material>,
    libraries: Vec<Library>,
}

/// Reads the OBJ text (with comments) in parallel ([`obj_parallel`]), or with tobj
/// where that declines, reading each `mtllib` ourselves ([`Sources::load_mtl`]) so that
/// an absent library is a warning and a broken one an error naming the file and line;
/// then refuses counts that do not fit ember's indices.
fn parse(
    path: &Path,
    text: &str,
    sources: &Sources<'_>,
    warnings: &mut Warnings,
) -> Result<Parsed, SceneError> {
    let mtl_error: RefCell<Option<SceneError>> = RefCell::new(None);
    let libraries: RefCell<Vec<Library>> = RefCell::new(Vec::new());
    let warnings = RefCell::new(warnings);
    let load_mtl = |name: &Path| -> tobj::MTLLoadResult {
        let written = name.to_string_lossy();
        let mut materials = Vec::new();
        for name in sources.library_names(&written) {
            match sources.load_mtl(path, name, &mut warnings.borrow_mut()) {
                Ok(Some((library, more))) => {
                    libraries.borrow_mut().push(library);
                    materials.extend(more);
                }
                Ok(None) => {}
                Err(e) => {
                    mtl_error.borrow_mut().get_or_insert(e);
                    return Err(tobj::LoadError::OpenFileFailed);
                }
            }
        }
        mtl::tobj_result(materials)
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
            let text = pad_vertex_colours(&text).map_err(obj_error)?;
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
        libraries: libraries.into_inner(),
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

/// Where the materials came from: their libraries in load order (each gave the next
/// `materials` of the list) and the OBJ's folder (none in memory).
struct MaterialSources<'a> {
    obj: &'a Path,
    libraries: &'a [Library],
    obj_dir: Option<&'a Path>,
}

impl MaterialSources<'_> {
    /// The folders material `index`'s textures are looked up in: its library's, then
    /// the OBJ's (as many exporters write paths relative to the OBJ).
    fn folders(&self, index: usize) -> Vec<&Path> {
        let mut first = 0;
        let library = self.libraries.iter().find(|l| {
            first += l.materials;
            index < first
        });
        let mut folders: Vec<&Path> = library
            .and_then(|l| l.folder.as_deref())
            .into_iter()
            .collect();
        if let Some(dir) = self.obj_dir.filter(|d| !folders.contains(d)) {
            folders.push(dir);
        }
        folders
    }
}

/// ember's materials from tobj's, with their textures and opacity maps decoded.
fn build_materials(
    tobj_materials: &[tobj::Material],
    sources: &MaterialSources<'_>,
    loader: &mut TextureLoader,
    warnings: &mut Warnings,
) -> Result<Vec<Material>, SceneError> {
    let mut zero_opacity = Vec::new();
    let mut materials = Vec::with_capacity(tobj_materials.len() + 1);
    for (index, m) in tobj_materials.iter().enumerate() {
        let folders = sources.folders(index);
        let (texture, kd_alpha) = match &m.diffuse_texture {
            Some(name) => {
                let referrer = referrer(m, &folders, "map_Kd");
                let loaded = loader.diffuse(name, &referrer, warnings)?;
                (loaded.map(|(t, _)| t), loaded.and_then(|(_, a)| a))
            }
            None => (None, None),
        };
        let values = MtlValues {
            // A `map_Kd` whose file is absent leaves the constant, or the default.
            kd: m.diffuse.map(vec3).or_else(|| {
                (m.diffuse_texture.is_some() && texture.is_none())
                    .then_some(Material::default().diffuse)
            }),
            ks: m.specular.map(vec3),
            ke: m.emissive.map(vec3),
            ns: m.shininess,
            ni: m.optical_density,
            illum: m.illumination_model,
            pr: unit_parameter(m, "Pr")?,
            pm: unit_parameter(m, "Pm")?,
            maps: material_maps(m, &folders, loader, warnings)?,
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
            Some(name) => loader.opacity(name, &referrer(m, &folders, "map_d"), warnings)?,
            None => kd_alpha,
        };
        materials.push(material);
    }
    if !zero_opacity.is_empty() {
        let warning = zero_opacity_warning(&zero_opacity);
        warnings.push(format!("{}: {warning}", sources.obj.display()));
    }
    Ok(materials)
}

/// Material `m`'s map `slot` as the texture loader sees it: looked up in `folders`,
/// replaced as [`instead_of_map`] says where its file is absent.
fn referrer<'a>(m: &'a tobj::Material, folders: &'a [&'a Path], slot: &str) -> Referrer<'a> {
    Referrer {
        material: &m.name,
        folders,
        instead: instead_of_map(m, slot),
    }
}

/// What a material uses where the file of its map `slot` is absent: the constant of
/// the same key, or what that key's absence means.
fn instead_of_map(m: &tobj::Material, slot: &str) -> String {
    let colour = |c: [f32; 3]| format!("{} {} {}", c[0], c[1], c[2]);
    let extra = |key: &str| m.unknown_param.get(key).cloned();
    let (key, constant, otherwise) = match slot {
        "map_Kd" => (
            "Kd",
            m.diffuse.map(colour),
            "ember's default diffuse 0.5 0.5 0.5",
        ),
        "map_Ks" => ("Ks", m.specular.map(colour), "no specular colour"),
        "map_Ke" => ("Ke", m.emissive.map(colour), "no emission"),
        "map_Ns" => ("Ns", m.shininess.map(|v| v.to_string()), "Ns 0"),
        "map_Pr" => ("Pr", extra("Pr"), "the roughness of Ns"),
        "map_Pm" => ("Pm", extra("Pm"), "no metal"),
        "map_d" => (
            "d",
            m.dissolve.map(|v| v.to_string()),
            "d and Tr as given (opaque without them)",
        ),
        _ => return "the surface is shaded with its own normals".into(),
    };
    match constant {
        Some(value) => format!("the material uses {key} {value} instead"),
        None => format!("the material uses {otherwise} instead"),
    }
}

/// The texture maps of a material other than `map_Kd` and `map_d`, decoded; a map
/// whose file is absent is left out.
fn material_maps(
    m: &tobj::Material,
    folders: &[&Path],
    loader: &mut TextureLoader,
    warnings: &mut Warnings,
) -> Result<MaterialMaps, SceneError> {
    use TextureKind::{Colour, Scalar, Vector};
    let extra = |key: &str| m.unknown_param.get(key).map(String::as_str);
    // `bump` and `map_Bump` are read into `normal_texture`; they are height maps.
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
        let Some(statement) = statement else {
            continue;
        };
        let referrer = referrer(m, folders, slot);
        let loaded = loader.texture(statement, slot, &referrer, kind, warnings)?;
        if let Some((id, scale)) = loaded {
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
        ..MaterialMaps::default()
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
    let mut attributes = AttributePresence {
        colour_scale: colour_scale(path, models, report)?,
        ..AttributePresence::default()
    };
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
    mesh.pad_for_embree();
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

/// Whether any model so far had normals, UVs or colours: once one has, every vertex
/// gets one (zero normals and UVs, white colours, where its model had none); and what
/// the file's colours are multiplied by.
#[derive(Default)]
struct AttributePresence {
    normals: bool,
    uvs: bool,
    colours: bool,
    colour_scale: f32,
}

/// What the file's vertex colours are multiplied by: 1 when every value is at most 1,
/// 1/255 when some value is above it (0-255 as written). Records which in `report`;
/// a value that is negative, not finite or above 255 is an error.
fn colour_scale(
    path: &Path,
    models: &[tobj::Model],
    report: &mut LoadReport,
) -> Result<f32, SceneError> {
    let mut offset = 0;
    let mut highest = 0.0f32;
    for model in models {
        for (i, c) in model.mesh.vertex_color.chunks_exact(3).enumerate() {
            let c = Vec3::new(c[0], c[1], c[2]);
            if !c.is_finite() {
                return Err(non_finite(path, "vertex colour", offset + i + 1, c));
            }
            if c.min_element() < 0.0 || c.max_element() > 255.0 {
                return Err(SceneError::Obj {
                    path: path.to_owned(),
                    reason: format!(
                        "vertex colour {} {} {} (vertex {}) is neither in [0, 1] nor in 0-255",
                        c.x,
                        c.y,
                        c.z,
                        offset + i + 1
                    ),
                });
            }
            highest = highest.max(c.max_element());
        }
        offset += model.mesh.positions.len() / 3;
    }
    if models.iter().all(|m| m.mesh.vertex_color.is_empty()) {
        return Ok(1.0);
    }
    let (kind, scale) = match highest > 1.0 {
        true => (VertexColours::Bytes, 1.0 / 255.0),
        false => (VertexColours::Unit, 1.0),
    };
    report.vertex_colours = Some(kind);
    Ok(scale)
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
    if m.vertex_color.len() == m.positions.len() && count > 0 {
        if !any.colours {
            mesh.colours.resize(offset, Vec3::ONE);
            any.colours = true;
        }
        let scale = any.colour_scale;
        let colours = m.vertex_color.chunks_exact(3);
        mesh.colours
            .extend(colours.map(|c| Vec3::new(c[0], c[1], c[2]) * scale));
    } else if any.colours {
        mesh.colours.resize(offset + count, Vec3::ONE);
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
