//! Scene files (TOML, read with `serde` and `toml`): the OBJs of a scene with their
//! transforms, further instances of them, named cameras, the environment and the
//! render settings.
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

use super::{load_obj_with, place, LoadOptions, LoadReport, Scene};
use crate::geometry::Instance;

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
}

/// An OBJ the scene loads once.
#[derive(Clone, Debug)]
pub struct ObjFile {
    pub name: String,
    /// Resolved against the scene file's folder.
    pub path: PathBuf,
    span: Range<usize>,
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
    #[serde(default)]
    instance: Vec<Spanned<Entry>>,
}

/// An `[[obj]]` (with `file`, and a `name` for instances to refer to) or an
/// `[[instance]]` (with `obj`, the name), and its transform.
#[derive(Deserialize)]
#[serde(deny_unknown_fields, rename_all = "kebab-case")]
struct Entry {
    file: Option<Spanned<String>>,
    name: Option<Spanned<String>>,
    obj: Option<Spanned<String>>,
    translate: Option<Spanned<[f32; 3]>>,
    rotate: Option<Spanned<Rotation>>,
    scale: Option<Spanned<Scale>>,
    /// Row-major, acting on column vectors (as Mitsuba's `matrix`); the last row is
    /// `0 0 0 1`.
    matrix: Option<Spanned<[[f32; 4]; 4]>>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct Rotation {
    axis: [f32; 3],
    degrees: f32,
}

#[derive(Deserialize)]
#[serde(untagged)]
enum Scale {
    Uniform(f32),
    Axes([f32; 3]),
}

impl SceneFile {
    /// Reads and checks the scene file at `path` (not yet its OBJs).
    pub fn read(path: &Path) -> Result<SceneFile, SceneFileError> {
        let text = std::fs::read_to_string(path).map_err(|e| SceneFileError {
            path: path.to_owned(),
            line: 1,
            column: 1,
            key: "(file)".into(),
            message: format!("cannot read the scene file: {e}"),
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
        for entry in document.obj {
            file.add_obj(entry)?;
        }
        for entry in document.instance {
            file.add_instance(entry)?;
        }
        if file.objs.is_empty() {
            return Err(file.error(0..0, "obj", "the scene has no [[obj]] to render"));
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
        self.placements.push(Placed {
            obj: self.objs.len(),
            transform,
        });
        self.objs.push(ObjFile {
            name,
            path: self.folder().join(file_name.get_ref()),
            span: file_name.span(),
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
        self.placements.push(Placed { obj, transform });
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
    fn transform(&self, entry: &Entry, table: &str) -> Result<Affine3A, SceneFileError> {
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
                if !finite(&r.axis) || !r.degrees.is_finite() || axis.length_squared() < 1e-12 {
                    return Err(at(
                        "rotate",
                        spanned.span(),
                        "needs a finite, non-zero axis and finite degrees",
                    ));
                }
                Quat::from_axis_angle(axis.normalize(), r.degrees.to_radians())
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
    /// value for value.
    pub fn load_scene(&self, options: &LoadOptions) -> Result<(Scene, LoadReport), SceneFileError> {
        let mut loaded = Vec::with_capacity(self.objs.len());
        for obj in &self.objs {
            let scene = load_obj_with(&obj.path, options)
                .map_err(|e| self.error(obj.span.clone(), "obj.file", &e.to_string()))?;
            loaded.push(scene);
        }
        let identity_once =
            self.placements.len() == 1 && self.placements[0].transform == Affine3A::IDENTITY;
        if identity_once {
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
        self.check_memory(&loaded)?;
        let scenes: Vec<&Scene> = loaded.iter().map(|(scene, _)| scene).collect();
        let instances = self
            .placements
            .iter()
            .map(|p| Instance {
                mesh: p.obj as u32,
                transform: p.transform,
            })
            .collect();
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
    /// Refuses, before placing, a scene that would not fit in memory: each OBJ's
    /// vertices (position, normal, uv) and triangles (indices, material) once, twice
    /// over for the accelerator built on it, and for each placement its transforms and
    /// its world-space copies of the OBJ's emissive triangles.
    fn check_memory(&self, loaded: &[(Scene, LoadReport)]) -> Result<(), SceneFileError> {
        let meshes: u64 = loaded
            .iter()
            .map(|(scene, _)| {
                let mesh = &scene.mesh;
                (mesh.positions.len() as u64 * 32 + mesh.triangles.len() as u64 * 16) * 2
            })
            .sum();
        let placements: u64 = self
            .placements
            .iter()
            .map(|p| 256 + loaded[p.obj].0.emitters.len() as u64 * 64)
            .sum();
        let what = format!(
            "{} placements of {} OBJs",
            self.placements.len(),
            self.objs.len()
        );
        crate::limits::check_fits(&what, meshes + placements)
            .map_err(|e| self.error(0..0, "instance", &e))
    }
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
