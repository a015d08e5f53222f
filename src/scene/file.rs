//! Scene files (TOML, read with `serde` and `toml`): the OBJs of a scene with their
//! transforms, further instances of them, the lights it places
//! ([`super::light_table`]), named cameras, the environment and the render settings.
//!
//! The geometry is this module's to load ([`SceneFile::load_scene`]); the settings,
//! cameras and environment are handed on as [`Setting`]s (key, value, position) for
//! the command line to read as the flags of the same names. Every error is one line:
//! `FILE:LINE:COLUMN: KEY: what is wrong`. Paths are relative to the scene file.

use std::collections::BTreeMap;
use std::ops::Range;
use std::path::{Path, PathBuf};

use glam::{Affine3A, Mat4, Quat, Vec3};
use serde::Deserialize;
use toml::Spanned;

use super::light_table::{read_light, LightEntry, PlacedLight, SceneLight};
use super::{
    area_light_scene, load_model, place, AreaLight, FileCamera, LoadOptions, LoadReport,
    LoadedModel, Scene,
};
use crate::geometry::{Instance, MAX_RAY_COORDINATE, RAY_REACH};
use crate::io::InputFile;
use crate::limits::{check_fits, human_bytes};

/// What parsing a scene file holds at its peak (the `toml` crate's document, every key
/// and value with its place, and the entries read from it), from the text's structure:
/// a table (a `[header]` or an inline `{`) holds a tree node of its own, an array a
/// vector, each `key =` an entry of its table's map, each list item a value. Upper
/// bounds of what each structure was measured to cost
/// (benches/results/2026-12-06-memory-estimates.md).
const MEMORY_PER_TABLE: u64 = 2048;
const MEMORY_PER_ARRAY: u64 = 512;
const MEMORY_PER_KEY: u64 = 640;
const MEMORY_PER_ITEM: u64 = 160;
/// The text itself, and its copies in the parser's strings.
const MEMORY_PER_SCENE_BYTE: u64 = 4;

/// Bytes of memory one placement holds once loaded and rendered: its transforms and
/// frame in the scene, its entries in both backends' two-level structures (Embree's
/// instance geometry, the native BVH's instance and node). About twice what was
/// measured (the results file above; pinned by `tests/memory_estimates.rs`).
pub const MEMORY_PER_PLACEMENT: u64 = 1024;
/// Bytes per emissive triangle of a placed OBJ: its world-space copy and the light
/// sampler's records and tree over it (measured and pinned as above).
const MEMORY_PER_PLACED_EMITTER: u64 = 1024;

/// A scene-file error: one line naming the file, the line and column, and the key.
#[derive(Debug, thiserror::Error)]
#[error("{path}:{line}:{column}: {key}: {message}")]
pub struct SceneFileError {
    pub path: PathBuf,
    pub line: usize,
    pub column: usize,
    pub key: String,
    pub message: String,
}

/// One `key = value` of a settings table, where it was written.
#[derive(Clone, Debug)]
pub struct Setting {
    pub key: String,
    pub value: toml::Value,
    /// Byte range in the file, for [`SceneFile::error`].
    pub span: Range<usize>,
}

/// One placement of an OBJ: the first of each OBJ comes from its `[[obj]]` entry,
/// further ones from `[[instance]]` entries naming it.
#[derive(Clone, Debug)]
pub struct Placed {
    /// Index into [`SceneFile::objs`].
    pub obj: usize,
    pub transform: Affine3A,
    /// The entry's place in the file, for errors about its transform.
    pub span: Range<usize>,
}

/// An OBJ the scene loads once.
#[derive(Clone, Debug)]
pub struct ObjFile {
    pub name: String,
    /// Resolved against the scene file's folder.
    pub path: PathBuf,
    span: Range<usize>,
    /// `color`: the diffuse colour of the faces the file gives no material, and where
    /// it was written.
    pub color: Option<(Vec3, Range<usize>)>,
}

/// A parsed scene file.
#[derive(Debug)]
pub struct SceneFile {
    pub path: PathBuf,
    text: String,
    pub objs: Vec<ObjFile>,
    pub placements: Vec<Placed>,
    /// `[render]`: settings named as `ember render`'s flags.
    pub render: Vec<Setting>,
    /// `[environment]`: `background`, or `env` with `env-scale` and `env-rotate`.
    pub environment: Vec<Setting>,
    /// `[camera.NAME]` tables, by name.
    pub cameras: BTreeMap<String, Vec<Setting>>,
    /// `[[light]]` tables, in order.
    pub lights: Vec<SceneLight>,
}

type Table = BTreeMap<Spanned<String>, Spanned<toml::Value>>;

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct Document {
    #[serde(default)]
    render: Table,
    #[serde(default)]
    environment: Table,
    #[serde(default)]
    camera: BTreeMap<String, Table>,
    #[serde(default)]
    obj: Vec<Spanned<Entry>>,
    /// `[[mesh]]`: the same as `[[obj]]`, for any model file ember reads.
    #[serde(default)]
    mesh: Vec<Spanned<Entry>>,
    #[serde(default)]
    instance: Vec<Spanned<Entry>>,
    #[serde(default)]
    light: Vec<Spanned<LightEntry>>,
}

/// An `[[obj]]` (with `file`, and a `name` for instances to refer to) or an
/// `[[instance]]` (with `obj`, the name), and its transform.
#[derive(Deserialize)]
#[serde(deny_unknown_fields, rename_all = "kebab-case")]
pub(super) struct Entry {
    pub(super) file: Option<Spanned<String>>,
    pub(super) name: Option<Spanned<String>>,
    #[serde(alias = "mesh")]
    pub(super) obj: Option<Spanned<String>>,
    pub(super) translate: Option<Spanned<[f32; 3]>>,
    pub(super) rotate: Option<Spanned<Rotation>>,
    pub(super) scale: Option<Spanned<Scale>>,
    /// Row-major, acting on column vectors (as Mitsuba's `matrix`); the last row is
    /// `0 0 0 1`.
    pub(super) matrix: Option<Spanned<[[f32; 4]; 4]>>,
    /// The diffuse colour of the faces the file gives no material (all of a PLY's).
    pub(super) color: Option<Spanned<[f32; 3]>>,
}

#[derive(Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct Rotation {
    pub(super) axis: [f32; 3],
    pub(super) degrees: f32,
}

#[derive(Clone, Deserialize)]
#[serde(untagged)]
pub(super) enum Scale {
    Uniform(f32),
    Axes([f32; 3]),
}

impl SceneFile {
    /// Reads and checks the scene file at `path` (not yet its OBJs), after checking
    /// that reading it fits in memory.
    pub fn read(path: &Path) -> Result<SceneFile, SceneFileError> {
        let fail = |message: String| SceneFileError {
            path: path.to_owned(),
            line: 1,
            column: 1,
            key: "(file)".into(),
            message: format!("cannot read the scene file: {message}"),
        };
        let input = InputFile::open(path).map_err(|e| fail(e.reason))?;
        let what = format!("reading it ({})", human_bytes(input.len()));
        check_fits(&what, input.len()).map_err(fail)?;
        let bytes = input.read_all().map_err(|e| fail(e.reason))?;
        check_fits("parsing it", parse_memory_bytes(&bytes)).map_err(fail)?;
        let text = String::from_utf8(bytes).map_err(|e| {
            let at = e.utf8_error().valid_up_to();
            fail(format!("it is not UTF-8 text (byte {at})"))
        })?;
        Self::parse(path, text)
    }

    /// Checks the scene file `text`, read from `path`.
    pub fn parse(path: &Path, text: String) -> Result<SceneFile, SceneFileError> {
        let mut file = SceneFile {
            path: path.to_owned(),
            text,
            objs: Vec::new(),
            placements: Vec::new(),
            render: Vec::new(),
            environment: Vec::new(),
            cameras: BTreeMap::new(),
            lights: Vec::new(),
        };
        let document: Document = toml::from_str(&file.text).map_err(|e| {
            let span = e.span().unwrap_or(0..0);
            file.error(
                span.clone(),
                &file.key_of(e.message(), span.start),
                e.message(),
            )
        })?;
        let settings = |table: Table| -> Vec<Setting> {
            table
                .into_iter()
                .map(|(key, value)| Setting {
                    span: key.span(),
                    key: key.into_inner(),
                    value: value.into_inner(),
                })
                .collect()
        };
        file.render = settings(document.render);
        file.environment = settings(document.environment);
        file.cameras = document
            .camera
            .into_iter()
            .map(|(name, table)| (name, settings(table)))
            .collect();
        // `[[obj]]` and `[[mesh]]` entries, in the order they are written.
        let mut models: Vec<Spanned<Entry>> = document.obj;
        models.extend(document.mesh);
        models.sort_by_key(|entry| entry.span().start);
        for entry in models {
            file.add_obj(entry)?;
        }
        for entry in document.instance {
            file.add_instance(entry)?;
        }
        for entry in document.light {
            let light = read_light(&file, entry)?;
            file.lights.push(light);
        }
        if file.objs.is_empty() {
            return Err(file.error(
                0..0,
                "mesh",
                "the scene has no [[mesh]] (or [[obj]]) to render",
            ));
        }
        Ok(file)
    }

    /// An `[[obj]]`: the OBJ, loaded once, and its placement.
    fn add_obj(&mut self, entry: Spanned<Entry>) -> Result<(), SceneFileError> {
        let span = entry.span();
        let entry = entry.into_inner();
        let Some(file_name) = &entry.file else {
            return Err(self.error(span, "obj", "an [[obj]] needs file = \"PATH.obj\""));
        };
        if let Some(obj) = &entry.obj {
            return Err(self.error(
                obj.span(),
                "obj.obj",
                "an [[obj]] names its file; `obj =` belongs to an [[instance]]",
            ));
        }
        let name = entry.name.as_ref().map_or_else(
            || {
                Path::new(file_name.get_ref())
                    .file_stem()
                    .map_or(String::new(), |s| s.to_string_lossy().into_owned())
            },
            |n| n.get_ref().clone(),
        );
        if let Some(other) = self.objs.iter().find(|o| o.name == name) {
            let at = entry.name.as_ref().map_or(file_name.span(), Spanned::span);
            let message = format!(
                "a second OBJ named {name:?} (the first is {}): give each a distinct name",
                other.path.display()
            );
            return Err(self.error(at, "obj.name", &message));
        }
        let transform = self.transform(&entry, "obj")?;
        let color = match &entry.color {
            Some(c) if !c.get_ref().iter().all(|x| (0.0..=1.0).contains(x)) => {
                let message = "a diffuse colour: three numbers in [0, 1]";
                return Err(self.error(c.span(), "obj.color", message));
            }
            c => c.as_ref().map(|c| (Vec3::from(*c.get_ref()), c.span())),
        };
        self.placements.push(Placed {
            obj: self.objs.len(),
            transform,
            span: span.clone(),
        });
        self.objs.push(ObjFile {
            name,
            path: self.folder().join(file_name.get_ref()),
            span: file_name.span(),
            color,
        });
        Ok(())
    }

    /// An `[[instance]]`: another placement of an `[[obj]]` named before it.
    fn add_instance(&mut self, entry: Spanned<Entry>) -> Result<(), SceneFileError> {
        let span = entry.span();
        let entry = entry.into_inner();
        if let Some(f) = entry.file.as_ref().or(entry.name.as_ref()) {
            return Err(self.error(
                f.span(),
                "instance",
                "an [[instance]] places an [[obj]] by its name: obj = \"NAME\"",
            ));
        }
        if let Some(c) = &entry.color {
            let message = "an [[instance]] shares its [[obj]]'s mesh and colour: give color there";
            return Err(self.error(c.span(), "instance.color", message));
        }
        let Some(of) = &entry.obj else {
            return Err(self.error(
                span,
                "instance",
                "an [[instance]] needs obj = \"NAME\" of an [[obj]]",
            ));
        };
        let Some(obj) = self.objs.iter().position(|o| &o.name == of.get_ref()) else {
            let names: Vec<&str> = self.objs.iter().map(|o| o.name.as_str()).collect();
            let message = format!(
                "no [[obj]] is named {:?} (there are: {})",
                of.get_ref(),
                names.join(", ")
            );
            return Err(self.error(of.span(), "instance.obj", &message));
        };
        let transform = self.transform(&entry, "instance")?;
        self.placements.push(Placed {
            obj,
            transform,
            span,
        });
        Ok(())
    }

    /// The one-line error at byte range `span` of the file, about `key`.
    pub fn error(&self, span: Range<usize>, key: &str, message: &str) -> SceneFileError {
        let before = self.before(span.start);
        let line = before.matches('\n').count() + 1;
        let column = before.rsplit('\n').next().map_or(0, |l| l.chars().count()) + 1;
        SceneFileError {
            path: self.path.clone(),
            line,
            column,
            key: key.to_owned(),
            message: message.lines().next().unwrap_or("").to_owned(),
        }
    }

    /// The folder paths in the file are relative to.
    pub fn folder(&self) -> &Path {
        self.path.parent().unwrap_or(Path::new(""))
    }

    /// An entry's transform: `matrix`, or translate · rotate · scale (applied to the
    /// OBJ's points in the order scale, rotate, translate).
    pub(super) fn transform(&self, entry: &Entry, table: &str) -> Result<Affine3A, SceneFileError> {
        let trs = entry.translate.is_some() || entry.rotate.is_some() || entry.scale.is_some();
        let finite = |v: &[f32]| v.iter().all(|x| x.is_finite());
        if let Some(m) = &entry.matrix {
            if trs {
                return Err(self.error(
                    m.span(),
                    &format!("{table}.matrix"),
                    "give either matrix or translate/rotate/scale, not both",
                ));
            }
            let rows = m.get_ref();
            if !finite(rows.as_flattened()) || rows[3] != [0.0, 0.0, 0.0, 1.0] {
                return Err(self.error(
                    m.span(),
                    &format!("{table}.matrix"),
                    "an affine 4x4 matrix of finite numbers (rows; the last 0, 0, 0, 1)",
                ));
            }
            let affine = Affine3A::from_mat4(Mat4::from_cols_array_2d(rows).transpose());
            if affine.matrix3.determinant() == 0.0 || !affine.inverse().is_finite() {
                return Err(self.error(
                    m.span(),
                    &format!("{table}.matrix"),
                    "the matrix is singular (it flattens the OBJ)",
                ));
            }
            return Ok(affine);
        }
        let at = |key: &str, v: Range<usize>, message: &str| {
            self.error(v, &format!("{table}.{key}"), message)
        };
        let translate = entry.translate.as_ref().map_or([0.0; 3], |t| *t.get_ref());
        if let Some(t) = entry.translate.as_ref().filter(|t| !finite(t.get_ref())) {
            return Err(at("translate", t.span(), "must be three finite numbers"));
        }
        let rotate = match &entry.rotate {
            None => Quat::IDENTITY,
            Some(spanned) => {
                let r = spanned.get_ref();
                let axis = Vec3::from(r.axis);
                let largest = axis.abs().max_element();
                if !finite(&r.axis) || !r.degrees.is_finite() || largest == 0.0 {
                    return Err(at(
                        "rotate",
                        spanned.span(),
                        "needs a finite, non-zero axis and finite degrees",
                    ));
                }
                // Scaled to its largest component before normalising: the length of
                // [1e38, 1e38, 0] overflows f32, that of [1e-30, 0, 0] underflows.
                Quat::from_axis_angle((axis / largest).normalize(), r.degrees.to_radians())
            }
        };
        let scale = match entry.scale.as_ref().map(|s| (s.get_ref(), s.span())) {
            None => Vec3::ONE,
            Some((scale, span)) => {
                let v = match *scale {
                    Scale::Uniform(s) => Vec3::splat(s),
                    Scale::Axes(a) => Vec3::from(a),
                };
                if !v.is_finite() || v.abs().min_element() == 0.0 {
                    return Err(at(
                        "scale",
                        span,
                        "must be finite and non-zero (negative mirrors)",
                    ));
                }
                v
            }
        };
        Ok(Affine3A::from_scale_rotation_translation(
            scale,
            rotate,
            Vec3::from(translate),
        ))
    }

    /// Loads each OBJ once and places it wherever the file says, by instances: the
    /// scene holds each OBJ's mesh once (see [`super::place`]). A file of one OBJ placed
    /// once without a transform gives that OBJ's scene as `ember render OBJ` loads it,
    /// value for value. The area lights are one more mesh, placed once where they are;
    /// the other lights join the placed scenes' own [`Scene::lights`].
    pub fn load_scene(&self, options: &LoadOptions) -> Result<(Scene, LoadReport), SceneFileError> {
        self.load(options).map(|model| (model.scene, model.report))
    }

    /// [`SceneFile::load_scene`], with the cameras of the glTF files the entries name,
    /// each placed by its entry's transform, in the order of the entries.
    pub fn load(&self, options: &LoadOptions) -> Result<LoadedModel, SceneFileError> {
        // The placements alone, before any OBJ is read; all of it once they are.
        self.check_memory(&[])?;
        let mut loaded = Vec::with_capacity(self.objs.len());
        let mut cameras = Vec::new();
        for (obj, placed) in self.objs.iter().zip(&self.placements) {
            let model = load_model(&obj.path, options)
                .map_err(|e| self.error(obj.span.clone(), "obj.file", &e.to_string()))?;
            // An entry's own placement is the first of each; its cameras go with it.
            cameras.extend(model.cameras.into_iter().map(|camera| FileCamera {
                settings: camera.settings.placed(&placed.transform),
                mesh: Some(obj.name.clone()),
                ..camera
            }));
            let (mut scene, report) = (model.scene, model.report);
            if let Some((colour, span)) = &obj.color {
                let Some(default) = report.default_material else {
                    let message = format!(
                        "{} gives every face a material: color is for faces without one \
                         (all of a PLY's)",
                        obj.path.display()
                    );
                    return Err(self.error(span.clone(), "obj.color", &message));
                };
                scene.materials[default as usize].diffuse = *colour;
            }
            loaded.push((scene, report));
        }
        let (mut scene, mut report) = self.place_objs(loaded)?;
        // The lights the models place (a glTF's) and the file's own.
        let model_lights = scene.lights.len();
        scene
            .lights
            .extend(self.lights.iter().filter_map(|l| match l.light {
                PlacedLight::Light(light) => Some(light),
                PlacedLight::Area(_) => None,
            }));
        report.lights = model_lights + self.lights.len();
        Ok(LoadedModel {
            scene,
            report,
            cameras,
            contents: Vec::new(),
        })
    }

    /// The area lights, and the names of their materials.
    fn area_lights(&self) -> (Vec<AreaLight>, Vec<String>) {
        self.lights
            .iter()
            .enumerate()
            .filter_map(|(i, l)| match l.light {
                PlacedLight::Area(area) => Some((area, l.label(i))),
                PlacedLight::Light(_) => None,
            })
            .unzip()
    }

    /// The loaded OBJs placed as the file says, with the area lights.
    fn place_objs(
        &self,
        mut loaded: Vec<(Scene, LoadReport)>,
    ) -> Result<(Scene, LoadReport), SceneFileError> {
        let (areas, names) = self.area_lights();
        let identity_once =
            self.placements.len() == 1 && self.placements[0].transform == Affine3A::IDENTITY;
        if identity_once && areas.is_empty() {
            return Ok(loaded.pop().expect("one OBJ"));
        }
        let mut report = LoadReport::default();
        for (_, r) in &loaded {
            report.obj_bytes += r.obj_bytes;
            report.materials += r.materials;
            report.degenerate_dropped += r.degenerate_dropped;
            report.vertex_colours = report.vertex_colours.or(r.vertex_colours);
            report.warnings.extend(r.warnings.iter().cloned());
        }
        let mut scenes: Vec<&Scene> = loaded.iter().map(|(scene, _)| scene).collect();
        self.check_memory(&scenes)?;
        self.check_carried(&loaded)?;
        let area_scene = (!areas.is_empty()).then(|| area_light_scene(&areas, &names));
        let mut instances: Vec<Instance> = self
            .placements
            .iter()
            .map(|p| Instance {
                mesh: p.obj as u32,
                transform: p.transform,
            })
            .collect();
        if let Some(lights) = &area_scene {
            report.materials += lights.materials.len();
            instances.push(Instance {
                mesh: scenes.len() as u32,
                transform: Affine3A::IDENTITY,
            });
            scenes.push(lights);
        }
        // The transforms were checked as they were read: finite, non-zero scales.
        let scene =
            place(&scenes, instances).map_err(|e| self.error(0..0, "instance", &e.to_string()))?;
        report.triangles = scene.mesh.triangles.len();
        report.vertices = scene.mesh.positions.len();
        report.emitters = scene.emitters.len();
        Ok((scene, report))
    }
}

impl SceneFile {
    /// Refuses a placement that rays cannot reach in `f32` and Embree: the placed
    /// scene's coordinates times [`RAY_REACH`] must stay below [`MAX_RAY_COORDINATE`],
    /// and every placement must carry a ray from within that reach to its OBJ's own
    /// space below it too (an axis scaled by 1e-19 would take a ray to 1e19 there).
    fn check_carried(&self, loaded: &[(Scene, LoadReport)]) -> Result<(), SceneFileError> {
        let bounds: Vec<[Vec3; 2]> = loaded
            .iter()
            .map(|(scene, _)| {
                let (lo, hi) = scene.bounds();
                [lo, hi]
            })
            .collect();
        let instance = |p: &Placed| Instance {
            mesh: p.obj as u32,
            transform: p.transform,
        };
        let extent = |p: &Placed| {
            let [lo, hi] = instance(p).world_bounds(bounds[p.obj]);
            lo.abs().max(hi.abs()).max_element()
        };
        let world = self.placements.iter().map(extent).fold(0.0f32, f32::max);
        let reach = world * RAY_REACH;
        for (i, p) in self.placements.iter().enumerate() {
            let far = extent(p);
            let near = far * RAY_REACH < MAX_RAY_COORDINATE;
            let what = if !near {
                Some(format!(
                    "it places the OBJ {far:.3e} from the origin: rays from within {RAY_REACH} \
                     times that would pass the {MAX_RAY_COORDINATE:.3e} that f32 rays in \
                     Embree can carry"
                ))
            } else if reach < MAX_RAY_COORDINATE {
                instance(p).carry_error(reach)
            } else {
                // Another placement is too far; it is the one refused.
                None
            };
            if let Some(what) = what {
                // The first placements are the [[obj]] entries', one each.
                let table = if i < self.objs.len() {
                    "obj"
                } else {
                    "instance"
                };
                return Err(self.error(p.span.clone(), table, &what));
            }
        }
        Ok(())
    }

    /// Refuses, before placing, a scene that would not fit in memory
    /// ([`SceneFile::load_memory_bytes`]).
    fn check_memory(&self, loaded: &[&Scene]) -> Result<(), SceneFileError> {
        let what = format!(
            "{} placements of {} OBJs",
            self.placements.len(),
            self.objs.len()
        );
        check_fits(&what, self.load_memory_bytes(loaded))
            .map_err(|e| self.error(0..0, "instance", &e))
    }

    /// Bytes of memory placing the loaded OBJs `loaded` (one per [`SceneFile::objs`];
    /// an empty list counts the placements alone) and rendering them holds
    /// ([`placement_memory_bytes`]), with the area lights' mesh, placed once.
    pub fn load_memory_bytes(&self, loaded: &[&Scene]) -> u64 {
        let objs = placement_memory_bytes(loaded, self.placements.iter().map(|p| p.obj));
        let (areas, _) = self.area_lights();
        if areas.is_empty() {
            return objs;
        }
        // Three corners of its own per triangle, each triangle an emitter.
        let triangles: u64 = areas.iter().map(|a| a.triangle_count() as u64).sum();
        let mesh = (3 * triangles * 32 + triangles * 16) * 2;
        objs + mesh + MEMORY_PER_PLACEMENT + triangles * MEMORY_PER_PLACED_EMITTER
    }
}

/// Bytes of memory placing the OBJs `loaded` (empty: the placements alone) at
/// `placements` (each the index of its OBJ) and rendering them holds: each OBJ's
/// vertices (position, normal, uv) and triangles (indices, material) once, twice over
/// for the accelerator built on it, and per placement what the scene, both backends'
/// two-level structures and the light sampler keep of it ([`MEMORY_PER_PLACEMENT`]),
/// with world-space copies of its emissive triangles.
pub fn placement_memory_bytes(loaded: &[&Scene], placements: impl Iterator<Item = usize>) -> u64 {
    let meshes: u64 = loaded
        .iter()
        .map(|scene| {
            let mesh = &scene.mesh;
            (mesh.positions.len() as u64 * 32 + mesh.triangles.len() as u64 * 16) * 2
        })
        .sum();
    let emitters = |obj: usize| loaded.get(obj).map_or(0, |s| s.emitters.len() as u64);
    // An instanced scene (a glTF's nodes placing its meshes) is placed instance by instance.
    let inner = |obj: usize| {
        loaded
            .get(obj)
            .and_then(|s| s.instancing.as_ref())
            .map_or(1, |i| i.instances.len() as u64)
    };
    let placed: u64 = placements
        .map(|obj| inner(obj) * MEMORY_PER_PLACEMENT + emitters(obj) * MEMORY_PER_PLACED_EMITTER)
        .sum();
    meshes + placed
}

/// Bytes of memory parsing the scene-file text `text` holds at its peak, counted from
/// its structure (see [`MEMORY_PER_TABLE`]); brackets and signs inside strings and
/// comments count too, which only overestimates.
pub fn parse_memory_bytes(text: &[u8]) -> u64 {
    let (mut tables, mut arrays, mut keys, mut items) = (0u64, 0u64, 0u64, 0u64);
    let mut line_start = true;
    for &b in text {
        match b {
            b'[' if line_start => tables += 1,
            b'{' => tables += 1,
            b'[' => arrays += 1,
            b'=' => keys += 1,
            b',' => items += 1,
            _ => {}
        }
        line_start = b == b'\n' || (line_start && (b == b' ' || b == b'\t'));
    }
    text.len() as u64 * MEMORY_PER_SCENE_BYTE
        + tables * MEMORY_PER_TABLE
        + arrays * MEMORY_PER_ARRAY
        + keys * MEMORY_PER_KEY
        + items * MEMORY_PER_ITEM
}

impl SceneFile {
    /// The text before byte `at` (or before the character holding it).
    fn before(&self, at: usize) -> &str {
        let mut at = at.min(self.text.len());
        while !self.text.is_char_boundary(at) {
            at -= 1;
        }
        &self.text[..at]
    }

    /// The key a `toml` error is about: the one its message names (`unknown field
    /// `x``), else the one written before `=` on the error's line, else `(syntax)`.
    fn key_of(&self, message: &str, at: usize) -> String {
        let is_key = |k: &&str| {
            !k.is_empty()
                && k.chars()
                    .all(|c| c.is_alphanumeric() || c == '-' || c == '_' || c == '.')
        };
        if let Some(key) = message.split('`').nth(1).filter(is_key) {
            return key.to_owned();
        }
        let line = self.before(at).rsplit('\n').next().unwrap_or("");
        line.split_once('=')
            .map(|(k, _)| k.trim())
            .filter(is_key)
            .map_or("(syntax)".into(), str::to_owned)
    }
}
