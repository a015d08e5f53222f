//! Loading PLY meshes (Stanford's polygon file format: ASCII, or binary in either byte
//! order) through `ply-rs-bw`, one element at a time, into a scene of one diffuse
//! material: the file carries no material, so a scene file may give its colour.
//!
//! What is read: the `vertex` element's `x y z`, `nx ny nz`, texture coordinates
//! (`u v`, `s t`, `texture_u texture_v` or `texture_s texture_t`, the first pair the
//! header declares) and colours (`red green blue` as `uchar` 0-255 or `float` 0-1,
//! multiplying the diffuse colour); the `face` element's `vertex_indices` (or
//! `vertex_index`), a list of any integer type, each polygon fanned into triangles from
//! its first corner as OBJ faces are. Other elements and properties are read past.
//!
//! The header is checked before the body is read: what it declares must fit in the
//! bytes that follow it and in memory ([`MEMORY_PER_PLY_VERTEX`]), and each face's
//! indices must name one of its vertices.

use std::io::{BufRead, BufReader, Cursor, Read};
use std::path::Path;

use glam::{Vec2, Vec3};
use ply_rs_bw::parser::{Parser, Reader};
use ply_rs_bw::ply::{
    ElementDef, Encoding, Header, PropertyAccess, PropertyAccessResult, PropertyType, ScalarType,
};

use super::obj::{check_counts, default_material_for, LoadReport, VertexColours};
use super::{LoadOptions, Scene, SceneError, TriangleMesh};
use crate::io::InputFile;
use crate::limits::check_fits;

/// Bytes of memory one declared vertex costs while loading: its position, normal,
/// texture coordinates and colour in the mesh (44 bytes), with room to spare.
pub const MEMORY_PER_PLY_VERTEX: u64 = 64;
/// Bytes of memory one triangle costs while loading: its corners and material in the
/// mesh (16 bytes), twice over for the list's growth as polygons are fanned.
pub const MEMORY_PER_PLY_TRIANGLE: u64 = 32;
/// The most bytes a header may take: real headers are a few hundred.
const MAX_HEADER_BYTES: u64 = 1 << 20;
/// The most bytes one line of an ASCII body may take (a polygon of 500 000 corners).
const MAX_LINE_BYTES: u64 = 4 << 20;

/// The names of a face's corner list.
const FACE_LISTS: [&str; 2] = ["vertex_indices", "vertex_index"];
/// The pairs of texture-coordinate names, as exporters write them.
const UV_NAMES: [[&str; 2]; 4] = [
    ["u", "v"],
    ["s", "t"],
    ["texture_u", "texture_v"],
    ["texture_s", "texture_t"],
];

/// Loads a PLY file into a [`Scene`] of one material, ember's default diffuse.
pub fn load_ply(path: &Path) -> Result<(Scene, LoadReport), SceneError> {
    load_ply_with(path, &LoadOptions::default())
}

/// Loads a PLY file into a [`Scene`]. A PLY names no other file, so `options` (which
/// say what to do about absent inputs) change nothing; the signature is every mesh
/// reader's.
pub fn load_ply_with(
    path: &Path,
    _options: &LoadOptions,
) -> Result<(Scene, LoadReport), SceneError> {
    let fail = |reason: String| SceneError::Ply {
        path: path.to_owned(),
        reason,
    };
    let input = InputFile::open(path)?;
    let file_bytes = input.len();
    let mut body = BufReader::new(Read::take(input.file(), file_bytes));
    let (header, header_lines, header_bytes) = read_header(&mut body).map_err(fail)?;
    let layout = Layout::of(&header).map_err(fail)?;
    layout
        .check_body(&header, file_bytes - header_bytes)
        .map_err(fail)?;
    layout.check_memory(path)?;
    let mut reader = BodyReader {
        body,
        encoding: header.encoding,
        line: header_lines,
        text: String::new(),
    };
    let mut mesh = layout.empty_mesh();
    let mut report = LoadReport {
        obj_bytes: file_bytes,
        ..LoadReport::default()
    };
    for def in header.elements.values() {
        match def.name.as_str() {
            "vertex" => reader.read::<Vertex>(def, |v, i| layout.add_vertex(&mut mesh, v, i)),
            "face" => reader.read::<Face>(def, |f, i| layout.add_face(path, &mut mesh, f, i)),
            _ => reader.read::<Skipped>(def, |_, _| Ok(())),
        }
        .map_err(|reason| match reason {
            Failure::Ply(reason) => fail(reason),
            Failure::Scene(e) => e,
        })?;
    }
    if layout.colours.is_some() {
        report.vertex_colours = layout.colours;
    }
    let scene = finish(path, mesh, &mut report)?;
    Ok((scene, report))
}

/// The header (checked by `ply-rs-bw`), its line count and its length in bytes: read
/// line by line up to `end_header`, at most [`MAX_HEADER_BYTES`], so that the body
/// starts right after it in `body`.
fn read_header(body: &mut impl BufRead) -> Result<(Header, usize, u64), String> {
    let mut text = Vec::new();
    let mut lines = 0;
    loop {
        let room = MAX_HEADER_BYTES - text.len() as u64;
        let read = (&mut *body)
            .take(room)
            .read_until(b'\n', &mut text)
            .map_err(|e| e.to_string())?;
        lines += 1;
        let line = text[text.len() - read..].trim_ascii();
        if lines == 1 && line != b"ply" {
            return Err("it does not start with the line `ply`: it is not a PLY file".into());
        }
        if line == b"end_header" {
            break;
        }
        if read == 0 || !text.ends_with(b"\n") {
            return Err(match text.len() as u64 >= MAX_HEADER_BYTES {
                true => format!("its header is longer than {MAX_HEADER_BYTES} bytes"),
                false => "the file ends before `end_header`".into(),
            });
        }
        check_header_line(line).map_err(|e| format!("header line {lines}: {e}"))?;
    }
    check_unique_names(&text)?;
    let parser = Parser::<Skipped>::new();
    let header = parser
        .read_header(&mut Reader::new(Cursor::new(&text)))
        .map_err(|e| format!("its header: {}", one_line(&e.to_string())))?;
    Ok((header, lines, text.len() as u64))
}

/// Refuses what the header's `element` and `property` lines may not say in a mesh
/// (the grammar itself is `ply-rs-bw`'s to check).
fn check_header_line(line: &[u8]) -> Result<(), String> {
    let text = String::from_utf8_lossy(line);
    let words: Vec<&str> = text.split_ascii_whitespace().collect();
    if words.first() == Some(&"format") && words.len() == 3 {
        let known = ["ascii", "binary_little_endian", "binary_big_endian"];
        if !known.contains(&words[1]) {
            return Err(format!(
                "unknown format {:?} (PLY is ascii, binary_little_endian or binary_big_endian)",
                words[1]
            ));
        }
        if words[2] != "1.0" {
            return Err(format!("format version {} (ember reads 1.0)", words[2]));
        }
    }
    Ok(())
}

/// Refuses a header that declares an element twice, or a property twice in one
/// element: `ply-rs-bw` keeps one of each name, and the body would be misread.
fn check_unique_names(text: &[u8]) -> Result<(), String> {
    let text = String::from_utf8_lossy(text);
    let mut elements: Vec<&str> = Vec::new();
    let mut properties: Vec<&str> = Vec::new();
    for line in text.lines() {
        let words: Vec<&str> = line.split_ascii_whitespace().collect();
        match words.as_slice() {
            ["element", name, ..] => {
                if elements.contains(name) {
                    return Err(format!("its header declares element {name:?} twice"));
                }
                elements.push(name);
                properties.clear();
            }
            ["property", .., name] => {
                if properties.contains(name) {
                    let element = elements.last().unwrap_or(&"");
                    return Err(format!(
                        "its header declares property {name:?} of element {element:?} twice"
                    ));
                }
                properties.push(name);
            }
            _ => {}
        }
    }
    Ok(())
}

/// A parser's multi-line message as one line, at most 200 characters.
fn one_line(message: &str) -> String {
    let words: Vec<&str> = message.split_whitespace().collect();
    let text = words.join(" ");
    match text.char_indices().nth(200) {
        Some((at, _)) => format!("{}…", &text[..at]),
        None => text,
    }
}

/// What the header says the mesh is: how many vertices, which attributes they carry,
/// and the size each element takes at least in the body.
struct Layout {
    vertices: u64,
    faces: u64,
    normals: bool,
    /// Which pair of [`UV_NAMES`] the texture coordinates are.
    uvs: Option<usize>,
    colours: Option<VertexColours>,
}

impl Layout {
    /// The mesh the header describes, or why ember cannot read it.
    fn of(header: &Header) -> Result<Layout, String> {
        let count = |name: &str| header.elements.get(name).map_or(0, |e| e.count as u64);
        let Some(vertex) = header.elements.get("vertex") else {
            return Err("its header declares no `element vertex`".into());
        };
        let has = |name: &str| vertex.properties.contains_key(name);
        for axis in ["x", "y", "z"] {
            match vertex.properties.get(axis).map(|p| &p.data_type) {
                Some(PropertyType::Scalar(_)) => {}
                Some(PropertyType::List(..)) => {
                    return Err(format!("vertex property {axis} is a list, not a number"))
                }
                None => return Err(format!("its vertices have no property {axis}")),
            }
        }
        let colours = match ["red", "green", "blue"].map(|c| vertex.properties.get(c)) {
            [Some(r), Some(g), Some(b)] => Some(colour_kind(&[r, g, b].map(|p| &p.data_type))?),
            _ => None,
        };
        if let Some(face) = header.elements.get("face") {
            check_face_list(face)?;
        }
        Ok(Layout {
            vertices: count("vertex"),
            faces: count("face"),
            normals: has("nx") && has("ny") && has("nz"),
            uvs: UV_NAMES.iter().position(|[u, v]| has(u) && has(v)),
            colours,
        })
    }

    /// Refuses a header that promises more elements than the `body` bytes after it
    /// can hold, before anything is allocated from its counts.
    fn check_body(&self, header: &Header, body: u64) -> Result<(), String> {
        let mut needed = 0u64;
        for def in header.elements.values() {
            let least = least_bytes(def, header.encoding);
            let bytes = least.saturating_mul(def.count as u64);
            needed = needed.saturating_add(bytes);
            if needed > body {
                return Err(format!(
                    "its header promises {} {} elements of at least {least} bytes each, \
                     but only {body} bytes follow the header",
                    def.count, def.name
                ));
            }
        }
        check_counts(self.faces, self.vertices)
    }

    /// Refuses a mesh whose declared vertices and faces do not fit in memory.
    fn check_memory(&self, path: &Path) -> Result<(), SceneError> {
        let needed = self.memory_bytes(self.faces);
        let what = format!("its {} vertices and {} faces", self.vertices, self.faces);
        check_fits(&what, needed).map_err(|what| SceneError::TooLarge {
            path: path.to_owned(),
            what,
        })
    }

    /// Bytes of memory loading the vertices and `triangles` holds.
    fn memory_bytes(&self, triangles: u64) -> u64 {
        let vertices = self.vertices.saturating_mul(MEMORY_PER_PLY_VERTEX);
        vertices.saturating_add(triangles.saturating_mul(MEMORY_PER_PLY_TRIANGLE))
    }

    /// A mesh with room for the declared vertices, and a triangle per face, plus the
    /// one more of each that Embree's 16-byte loads read past the end.
    fn empty_mesh(&self) -> TriangleMesh {
        let (vertices, faces) = (self.vertices as usize, self.faces as usize);
        let mut mesh = TriangleMesh::default();
        mesh.positions.reserve_exact(vertices + 1);
        if self.normals {
            mesh.normals.reserve_exact(vertices);
        }
        if self.uvs.is_some() {
            mesh.uvs.reserve_exact(vertices);
        }
        if self.colours.is_some() {
            mesh.colours.reserve_exact(vertices);
        }
        mesh.triangles.reserve_exact(faces + 1);
        mesh.material.reserve_exact(faces);
        mesh
    }

    /// Appends vertex `index` (counted from 0) to `mesh`, checked to be finite.
    fn add_vertex(&self, mesh: &mut TriangleMesh, v: Vertex, index: usize) -> Result<(), Failure> {
        let bad = |what: &str, value: String| {
            Failure::Ply(format!("vertex {index}: its {what} {value} is not finite"))
        };
        let p = Vec3::from_array(v.position.map(|x| x as f32));
        if !p.is_finite() {
            return Err(bad("position", format!("{} {} {}", p.x, p.y, p.z)));
        }
        mesh.positions.push(p);
        if self.normals {
            let n = Vec3::from_array(v.normal.map(|x| x as f32));
            if !n.is_finite() {
                return Err(bad("normal", format!("{} {} {}", n.x, n.y, n.z)));
            }
            mesh.normals.push(n);
        }
        if let Some(k) = self.uvs {
            let uv = Vec2::from_array(v.uv[k].map(|x| x as f32));
            if !uv.is_finite() {
                return Err(bad("texture coordinate", format!("{} {}", uv.x, uv.y)));
            }
            mesh.uvs.push(uv);
        }
        if self.colours.is_some() {
            let c = Vec3::from_array(v.colour);
            if !(c.is_finite() && c.min_element() >= 0.0 && c.max_element() <= 1.0) {
                return Err(Failure::Ply(format!(
                    "vertex {index}: its colour {} {} {} is not in [0, 1]",
                    c.x, c.y, c.z
                )));
            }
            mesh.colours.push(c);
        }
        Ok(())
    }

    /// Fans face `index` into `mesh`'s triangles from its first corner, each corner
    /// checked to name a declared vertex; the triangle list grows only after the
    /// memory it grows to is checked.
    fn add_face(
        &self,
        path: &Path,
        mesh: &mut TriangleMesh,
        face: Face,
        index: usize,
    ) -> Result<(), Failure> {
        let corners = face.corners;
        if let Some(&bad) = corners
            .iter()
            .find(|&&c| c < 0 || c as u64 >= self.vertices)
        {
            return Err(Failure::Ply(format!(
                "face {index}: vertex index {bad} is out of range (there are {} vertices)",
                self.vertices
            )));
        }
        let Some(fan) = corners.len().checked_sub(2) else {
            return Ok(()); // a point or a line: nothing to render, as in OBJ
        };
        let wanted = mesh.triangles.len() + fan + 1;
        if wanted > mesh.triangles.capacity() {
            let grown = wanted.max(mesh.triangles.capacity() * 2);
            let what = format!("its faces fanned into {grown} triangles so far");
            check_fits(&what, self.memory_bytes(grown as u64)).map_err(|what| {
                Failure::Scene(SceneError::TooLarge {
                    path: path.to_owned(),
                    what,
                })
            })?;
            check_counts(grown as u64, self.vertices).map_err(Failure::Ply)?;
            mesh.triangles.reserve_exact(grown - mesh.triangles.len());
            mesh.material.reserve_exact(grown - mesh.material.len());
        }
        let first = corners[0] as u32;
        for pair in corners[1..].windows(2) {
            mesh.triangles.push([first, pair[0] as u32, pair[1] as u32]);
            mesh.material.push(0);
        }
        Ok(())
    }
}

/// Refuses a face element whose corner list is missing, or not a list of integers.
fn check_face_list(face: &ElementDef) -> Result<(), String> {
    let Some(list) = FACE_LISTS.iter().find_map(|n| face.properties.get(*n)) else {
        return Err("its faces have no vertex_indices (or vertex_index) list".into());
    };
    match &list.data_type {
        PropertyType::List(count, item) if is_integer(count) && is_integer(item) => Ok(()),
        other => Err(format!(
            "face property {} is {}, not a list of integer indices",
            list.name,
            type_name(other)
        )),
    }
}

/// How the vertex colours are written, from their three properties' types: all
/// `uchar` (0-255) or all `float`/`double` (0-1).
fn colour_kind(types: &[&PropertyType; 3]) -> Result<VertexColours, String> {
    use ScalarType::{Double, Float, UChar};
    let scalar = |t: &PropertyType| match t {
        PropertyType::Scalar(s) => Some(s.clone()),
        PropertyType::List(..) => None,
    };
    match types.map(scalar) {
        [Some(UChar), Some(UChar), Some(UChar)] => Ok(VertexColours::Bytes),
        [Some(Float | Double), Some(Float | Double), Some(Float | Double)] => {
            Ok(VertexColours::Unit)
        }
        _ => Err(format!(
            "its vertex colours are {}, {} and {}: ember reads red, green and blue as \
             uchar (0-255) or as float (0-1)",
            type_name(types[0]),
            type_name(types[1]),
            type_name(types[2])
        )),
    }
}

fn is_integer(t: &ScalarType) -> bool {
    !matches!(t, ScalarType::Float | ScalarType::Double)
}

/// The type as a header writes it.
fn type_name(t: &PropertyType) -> String {
    let scalar = |s: &ScalarType| match s {
        ScalarType::Char => "char",
        ScalarType::UChar => "uchar",
        ScalarType::Short => "short",
        ScalarType::UShort => "ushort",
        ScalarType::Int => "int",
        ScalarType::UInt => "uint",
        ScalarType::Float => "float",
        ScalarType::Double => "double",
    };
    match t {
        PropertyType::Scalar(s) => scalar(s).to_owned(),
        PropertyType::List(c, i) => format!("list {} {}", scalar(c), scalar(i)),
    }
}

/// The fewest bytes one element of `def` takes in a body of `encoding`: its scalars
/// and list counts (empty lists) in binary; a character and a separator per property
/// in ASCII, and a line end even with none.
fn least_bytes(def: &ElementDef, encoding: Encoding) -> u64 {
    let size = |s: &ScalarType| match s {
        ScalarType::Char | ScalarType::UChar => 1,
        ScalarType::Short | ScalarType::UShort => 2,
        ScalarType::Int | ScalarType::UInt | ScalarType::Float => 4,
        ScalarType::Double => 8,
    };
    match encoding {
        Encoding::Ascii => (2 * def.properties.len() as u64).max(1),
        _ => def
            .properties
            .values()
            .map(|p| match &p.data_type {
                PropertyType::Scalar(s) | PropertyType::List(s, _) => size(s),
            })
            .sum(),
    }
}

/// Why reading an element stopped: the file's fault (one reason), or an error of
/// the load's own (the memory check) to pass on as it is.
enum Failure {
    Ply(String),
    Scene(SceneError),
}

/// The body of a PLY file after its header, read one element at a time.
struct BodyReader<R: BufRead> {
    body: R,
    encoding: Encoding,
    /// The file's lines read so far (an ASCII body's, for errors).
    line: usize,
    text: String,
}

impl<R: BufRead> BodyReader<R> {
    /// Reads the `def.count` elements of `def`, handing each with its index to `each`.
    fn read<E: PropertyAccess>(
        &mut self,
        def: &ElementDef,
        mut each: impl FnMut(E, usize) -> Result<(), Failure>,
    ) -> Result<(), Failure> {
        let parser = Parser::<E>::new();
        if def.properties.is_empty() && self.encoding != Encoding::Ascii {
            return Ok(()); // no bytes to read, however many it declares
        }
        for i in 0..def.count {
            let element = match self.encoding {
                Encoding::Ascii => self.ascii_element(&parser, def, i)?,
                Encoding::BinaryLittleEndian => {
                    parser.read_little_endian_element(&mut self.body, def)
                }
                Encoding::BinaryBigEndian => parser.read_big_endian_element(&mut self.body, def),
            };
            let element = element.map_err(|e| {
                let reason = match e.kind() {
                    std::io::ErrorKind::UnexpectedEof => "the file ends in it".to_owned(),
                    _ => one_line(&e.to_string()),
                };
                Failure::Ply(self.place(def, i, &reason))
            })?;
            each(element, i)?;
        }
        Ok(())
    }

    /// The next line of an ASCII body read as element `i` of `def`: the outer error
    /// is about the line itself (absent, too long, not text), the inner one the
    /// parser's.
    fn ascii_element<E: PropertyAccess>(
        &mut self,
        parser: &Parser<E>,
        def: &ElementDef,
        i: usize,
    ) -> Result<ply_rs_bw::parser::Result<E>, Failure> {
        self.text.clear();
        self.line += 1;
        let read = (&mut self.body)
            .take(MAX_LINE_BYTES)
            .read_line(&mut self.text)
            .map_err(|e| {
                let reason = match e.kind() {
                    std::io::ErrorKind::InvalidData => "the line is not text".to_owned(),
                    _ => e.to_string(),
                };
                Failure::Ply(self.place(def, i, &reason))
            })?;
        let reason = match read {
            0 => "the file ends before it",
            n if n as u64 == MAX_LINE_BYTES && !self.text.ends_with('\n') => {
                "the line is longer than 4 MiB"
            }
            _ => return Ok(parser.read_ascii_element(&self.text, def)),
        };
        Err(Failure::Ply(self.place(def, i, reason)))
    }

    /// `face 3 of 12 (line 20): REASON`, naming where in the body element `i` is.
    fn place(&self, def: &ElementDef, i: usize, reason: &str) -> String {
        let line = match self.encoding {
            Encoding::Ascii => format!(" (line {})", self.line),
            _ => String::new(),
        };
        format!("{} {i} of {}{line}: {reason}", def.name, def.count)
    }
}

/// The scene of the mesh read: degenerate triangles dropped (and counted), one
/// material, and the padding Embree reads past the ends.
fn finish(
    path: &Path,
    mut mesh: TriangleMesh,
    report: &mut LoadReport,
) -> Result<Scene, SceneError> {
    let positions = &mesh.positions;
    let before = mesh.triangles.len();
    mesh.triangles.retain(|t| {
        let [a, b, c] = t.map(|i| positions[i as usize]);
        let doubled_area = (b - a).cross(c - a).length();
        doubled_area > 0.0 && doubled_area.is_finite()
    });
    report.degenerate_dropped = before - mesh.triangles.len();
    mesh.material.truncate(mesh.triangles.len());
    if mesh.triangles.is_empty() {
        let detail = match report.degenerate_dropped {
            0 => " (it has no faces of three or more corners)".to_owned(),
            n => format!(" (all {n} triangles are degenerate)"),
        };
        return Err(SceneError::Empty {
            path: path.to_owned(),
            detail,
        });
    }
    mesh.pad_for_embree();
    let material = default_material_for(&mesh);
    let scene = Scene::new(mesh, vec![material], Vec::new());
    report.triangles = scene.mesh.triangles.len();
    report.vertices = scene.mesh.positions.len();
    report.default_material = Some(0);
    Ok(scene)
}

/// A vertex as the body gives it: every name ember reads, converted to `f64` (and
/// the colour scaled to [0, 1] by its type).
#[derive(Default)]
struct Vertex {
    position: [f64; 3],
    normal: [f64; 3],
    /// One pair per entry of [`UV_NAMES`].
    uv: [[f64; 2]; 4],
    colour: [f32; 3],
}

impl Vertex {
    fn set(&mut self, name: &str, value: f64) -> PropertyAccessResult {
        let slot = match name {
            "x" => &mut self.position[0],
            "y" => &mut self.position[1],
            "z" => &mut self.position[2],
            "nx" => &mut self.normal[0],
            "ny" => &mut self.normal[1],
            "nz" => &mut self.normal[2],
            _ => {
                let Some((pair, k)) = UV_NAMES.iter().enumerate().find_map(|(pair, names)| {
                    names.iter().position(|n| *n == name).map(|k| (pair, k))
                }) else {
                    return PropertyAccessResult::Ignored;
                };
                &mut self.uv[pair][k]
            }
        };
        *slot = value;
        PropertyAccessResult::Set
    }

    fn set_colour(&mut self, name: &str, value: f32) -> Option<PropertyAccessResult> {
        let k = ["red", "green", "blue"].iter().position(|c| *c == name)?;
        self.colour[k] = value;
        Some(PropertyAccessResult::Set)
    }
}

impl PropertyAccess for Vertex {
    fn new() -> Self {
        Vertex::default()
    }
    fn set_char(&mut self, name: &str, value: i8) -> PropertyAccessResult {
        self.set(name, value.into())
    }
    fn set_uchar(&mut self, name: &str, value: u8) -> PropertyAccessResult {
        let colour = self.set_colour(name, f32::from(value) / 255.0);
        colour.unwrap_or_else(|| self.set(name, value.into()))
    }
    fn set_short(&mut self, name: &str, value: i16) -> PropertyAccessResult {
        self.set(name, value.into())
    }
    fn set_ushort(&mut self, name: &str, value: u16) -> PropertyAccessResult {
        self.set(name, value.into())
    }
    fn set_int(&mut self, name: &str, value: i32) -> PropertyAccessResult {
        self.set(name, value.into())
    }
    fn set_uint(&mut self, name: &str, value: u32) -> PropertyAccessResult {
        self.set(name, value.into())
    }
    fn set_float(&mut self, name: &str, value: f32) -> PropertyAccessResult {
        let colour = self.set_colour(name, value);
        colour.unwrap_or_else(|| self.set(name, value.into()))
    }
    fn set_double(&mut self, name: &str, value: f64) -> PropertyAccessResult {
        let colour = self.set_colour(name, value as f32);
        colour.unwrap_or_else(|| self.set(name, value))
    }
}

/// A face as the body gives it: its corner list, widened to `i64`.
#[derive(Default)]
struct Face {
    corners: Vec<i64>,
}

impl Face {
    fn set<T: Into<i64>>(&mut self, name: &str, value: Vec<T>) -> PropertyAccessResult {
        if !FACE_LISTS.contains(&name) {
            return PropertyAccessResult::Ignored;
        }
        self.corners = value.into_iter().map(Into::into).collect();
        PropertyAccessResult::Set
    }
}

impl PropertyAccess for Face {
    fn new() -> Self {
        Face::default()
    }
    fn set_list_char(&mut self, name: &str, value: Vec<i8>) -> PropertyAccessResult {
        self.set(name, value)
    }
    fn set_list_uchar(&mut self, name: &str, value: Vec<u8>) -> PropertyAccessResult {
        self.set(name, value)
    }
    fn set_list_short(&mut self, name: &str, value: Vec<i16>) -> PropertyAccessResult {
        self.set(name, value)
    }
    fn set_list_ushort(&mut self, name: &str, value: Vec<u16>) -> PropertyAccessResult {
        self.set(name, value)
    }
    fn set_list_int(&mut self, name: &str, value: Vec<i32>) -> PropertyAccessResult {
        self.set(name, value)
    }
    fn set_list_uint(&mut self, name: &str, value: Vec<u32>) -> PropertyAccessResult {
        self.set(name, value)
    }
}

/// An element ember does not read (edges, materials, ...), read past.
struct Skipped;

impl PropertyAccess for Skipped {
    fn new() -> Self {
        Skipped
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ascii_elements_take_two_bytes_per_property_and_binary_their_sizes() {
        let header = "ply\nformat ascii 1.0\nelement vertex 2\nproperty float x\n\
                      property double y\nproperty uchar red\nelement face 1\n\
                      property list uchar int vertex_indices\nend_header\n";
        let text = format!("{header}1 2 3\n");
        let (header, lines, bytes) = read_header(&mut text.as_bytes()).unwrap();
        assert_eq!((lines, bytes), (9, text.len() as u64 - 6));
        let vertex = &header.elements["vertex"];
        let face = &header.elements["face"];
        assert_eq!(least_bytes(vertex, Encoding::Ascii), 6);
        assert_eq!(least_bytes(vertex, Encoding::BinaryBigEndian), 13);
        assert_eq!(least_bytes(face, Encoding::BinaryLittleEndian), 1);
    }

    #[test]
    fn names_declared_twice_are_refused() {
        let twice = "element vertex 1\nproperty float x\nproperty float x\n";
        assert!(check_unique_names(twice.as_bytes())
            .unwrap_err()
            .contains("property \"x\" of element \"vertex\" twice"));
        let again = "element vertex 1\nproperty float x\nelement vertex 2\nproperty float x\n";
        assert!(check_unique_names(again.as_bytes())
            .unwrap_err()
            .contains("element \"vertex\" twice"));
        let apart = "element vertex 1\nproperty float x\nelement face 2\nproperty float x\n";
        assert!(check_unique_names(apart.as_bytes()).is_ok());
    }

    #[test]
    fn long_messages_become_one_short_line() {
        let long = format!("a\n\tb {}", "c".repeat(500));
        let line = one_line(&long);
        assert!(line.starts_with("a b c") && !line.contains('\n'));
        assert_eq!(line.chars().count(), 201);
    }
}
