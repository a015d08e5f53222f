//! A parallel reader of OBJ geometry that gives exactly the models tobj gives with
//! ember's options (single index, triangulated, points and lines ignored), on all
//! threads: the text is cut into chunks at line ends, the `v`/`vt`/`vn` statements of
//! each chunk are counted, then every chunk is parsed straight into its share of the
//! attribute arrays, and the faces are joined into models in file order.
//!
//! It covers what real files say (`v x y z`, vertex colours `v x y z r g b` when every
//! vertex has them, `vt`, `vn`, faces of three or more corners, `o`, `g`, `usemtl`,
//! `mtllib`, comments, unknown statements such as `s`). On anything else it declines
//! and tobj reads the file instead: `l` and `p` statements, `w`, colours on some
//! vertices only, faces of fewer than three corners, indices that are zero, malformed
//! or point forward or outside the file, and every error. So unusual input and every
//! error message go the way they went before. Numbers are read with the standard
//! library's parsers, as tobj reads them, so the values are the same bits;
//! `tests/obj_parallel.rs` holds the two readers to that. Names (`usemtl`, `mtllib`)
//! are read by `obj_text`'s functions, as ember gives them to tobj.

use std::collections::HashMap;
use std::ops::Range;
use std::path::Path;

use rayon::prelude::*;
use rustc_hash::FxHashMap;

use super::obj_text::{argument, used_material};

/// tobj's "no texture coordinate / normal" for a corner.
const MISSING: u32 = u32::MAX;

/// Chunks smaller than this are not worth a task of their own.
const MIN_CHUNK_BYTES: usize = 1 << 20;

/// Reads the models of `text` as `tobj::load_obj_buf` would, loading each `mtllib`
/// with `load_mtl` in file order; `None` where the text needs tobj (see the module
/// documentation). `text` may hold comments: everything from a `#` to the end of its
/// line is ignored, as ember strips it before tobj sees it.
pub fn load_obj<ML>(text: &str, mut load_mtl: ML) -> Option<tobj::LoadResult>
where
    ML: FnMut(&Path) -> tobj::MTLLoadResult,
{
    let chunks = split_at_lines(text, rayon::current_num_threads() * 4);
    let counts: Vec<Counts> = chunks.par_iter().map(|c| count_statements(c)).collect();
    let total = counts.iter().fold(Counts::default(), |a, c| a.plus(c));
    if [total.v, total.vt, total.vn]
        .iter()
        .any(|&n| n > u64::from(MISSING))
    {
        return None;
    }
    let coloured = first_vertex_has_colour(text);
    let mut attributes = Attributes {
        positions: vec![0.0; 3 * total.v as usize],
        texcoords: vec![0.0; 2 * total.vt as usize],
        normals: vec![0.0; 3 * total.vn as usize],
        colours: vec![0.0; if coloured { 3 * total.v as usize } else { 0 }],
        coloured,
    };
    let parsed: Option<Vec<ChunkFaces>> = attributes
        .split(&counts)
        .into_par_iter()
        .zip(chunks.par_iter())
        .map(|(mut slices, text)| parse_chunk(text, &mut slices))
        .collect();
    let parsed = parsed?;
    let mut join = Join::new(&attributes);
    // Each chunk's corners are let go of once joined, as the models grow.
    for chunk in parsed {
        join.chunk(&chunk, &mut load_mtl);
    }
    Some(Ok(join.finish()))
}

/// Whether the first `v` statement of the text has a colour (six numbers): then every
/// vertex must, else none may (this reader declines otherwise).
fn first_vertex_has_colour(text: &str) -> bool {
    lines(text)
        .map(|line| words(line))
        .find_map(|mut words| (words.next() == Some("v")).then(|| words.count() == 6))
        .unwrap_or(false)
}

/// `text` cut into about `pieces` chunks, each ending at a line end (or the text's end).
fn split_at_lines(text: &str, pieces: usize) -> Vec<&str> {
    let target = (text.len() / pieces.max(1)).max(MIN_CHUNK_BYTES);
    let mut chunks = Vec::new();
    let mut rest = text;
    while !rest.is_empty() {
        let end = match rest.len() > target {
            true => memchr::memchr(b'\n', &rest.as_bytes()[target..])
                .map_or(rest.len(), |i| target + i + 1),
            false => rest.len(),
        };
        let (chunk, tail) = rest.split_at(end);
        chunks.push(chunk);
        rest = tail;
    }
    chunks
}

/// How many `v`, `vt` and `vn` statements a chunk has.
#[derive(Clone, Copy, Default, Debug, PartialEq, Eq)]
struct Counts {
    v: u64,
    vt: u64,
    vn: u64,
}

impl Counts {
    fn plus(self, other: &Counts) -> Counts {
        Counts {
            v: self.v + other.v,
            vt: self.vt + other.vt,
            vn: self.vn + other.vn,
        }
    }
}

/// The lines of a chunk without their comments (`#` to the end of the line), found
/// with SIMD searches: one for the next `#` or line end, one more for a comment's end.
fn lines(text: &str) -> impl Iterator<Item = &str> {
    let bytes = text.as_bytes();
    let mut at = 0;
    std::iter::from_fn(move || {
        if at >= bytes.len() {
            return None;
        }
        let start = at;
        let (end, next) = match memchr::memchr2(b'\n', b'#', &bytes[start..]) {
            Some(i) if bytes[start + i] == b'\n' => (start + i, start + i + 1),
            Some(i) => {
                let comment = start + i;
                let eol =
                    memchr::memchr(b'\n', &bytes[comment..]).map_or(bytes.len(), |j| comment + j);
                (comment, eol + 1)
            }
            None => (bytes.len(), bytes.len()),
        };
        at = next;
        // Both ends are at ASCII bytes (or the end), so they are character boundaries.
        Some(&text[start..end])
    })
}

/// The whole of `line` (a line of `text` as [`lines`] gives it), its comment included.
fn whole_line<'a>(text: &'a str, line: &str) -> &'a str {
    let start = line.as_ptr() as usize - text.as_ptr() as usize;
    let rest = &text[start..];
    &rest[..memchr::memchr(b'\n', rest.as_bytes()).unwrap_or(rest.len())]
}

/// The words of a line, split where tobj splits them (Unicode white space), quickly
/// when the line is plain ASCII. (ASCII splitting does not count the vertical tab as
/// white space; Unicode splitting does.)
fn words(line: &str) -> Words<'_> {
    if line.bytes().all(|b| b < 0x80 && b != 0x0b) {
        Words::Ascii(line.split_ascii_whitespace())
    } else {
        Words::Unicode(line.split_whitespace())
    }
}

enum Words<'a> {
    Ascii(std::str::SplitAsciiWhitespace<'a>),
    Unicode(std::str::SplitWhitespace<'a>),
}

impl<'a> Iterator for Words<'a> {
    type Item = &'a str;

    #[inline]
    fn next(&mut self) -> Option<&'a str> {
        match self {
            Words::Ascii(w) => w.next(),
            Words::Unicode(w) => w.next(),
        }
    }
}

/// Counts the `v`, `vt` and `vn` statements of a chunk, looking only as far into each
/// line as its first word.
fn count_statements(text: &str) -> Counts {
    let mut counts = Counts::default();
    let bytes = text.as_bytes();
    let mut start = 0;
    let ends = memchr::memchr_iter(b'\n', bytes).chain(std::iter::once(bytes.len()));
    for end in ends {
        let line = &text[start..end];
        start = end + 1;
        let first = match ascii_first_word(line.as_bytes()) {
            Some(word) => word,
            None => lines(line)
                .next()
                .and_then(|l| words(l).next())
                .unwrap_or("")
                .as_bytes(),
        };
        match first {
            b"v" => counts.v += 1,
            b"vt" => counts.vt += 1,
            b"vn" => counts.vn += 1,
            _ => {}
        }
    }
    counts
}

/// The first word of a line (up to white space or a comment), where ASCII white space
/// alone decides it; `None` where a non-ASCII byte or a vertical tab (white space to
/// tobj, not to ASCII splitting) is met first.
#[inline]
fn ascii_first_word(line: &[u8]) -> Option<&[u8]> {
    let blank = |b: u8| matches!(b, b' ' | b'\t' | b'\r' | 0x0c);
    let start = line.iter().position(|&b| !blank(b)).unwrap_or(line.len());
    let mut end = start;
    while end < line.len() && !blank(line[end]) && line[end] != b'#' {
        if line[end] >= 0x80 || line[end] == 0x0b {
            return None;
        }
        end += 1;
    }
    Some(&line[start..end])
}

/// The whole file's vertex attributes, flat as tobj keeps them.
struct Attributes {
    positions: Vec<f32>,
    texcoords: Vec<f32>,
    normals: Vec<f32>,
    /// Per vertex when `coloured`, else empty.
    colours: Vec<f32>,
    coloured: bool,
}

/// One chunk's share of [`Attributes`], and how many of each came before it (what
/// its indices count from).
struct ChunkSlices<'a> {
    positions: &'a mut [f32],
    texcoords: &'a mut [f32],
    normals: &'a mut [f32],
    /// Empty when the file has no colours.
    colours: &'a mut [f32],
    coloured: bool,
    before: Counts,
}

impl Attributes {
    /// Disjoint slices of the arrays, one per chunk, in chunk order.
    fn split(&mut self, counts: &[Counts]) -> Vec<ChunkSlices<'_>> {
        let (mut p, mut t, mut n, mut k) = (
            &mut self.positions[..],
            &mut self.texcoords[..],
            &mut self.normals[..],
            &mut self.colours[..],
        );
        let coloured = self.coloured;
        let mut before = Counts::default();
        let mut slices = Vec::with_capacity(counts.len());
        for c in counts {
            let (p_here, p_rest) = std::mem::take(&mut p).split_at_mut(3 * c.v as usize);
            let (t_here, t_rest) = std::mem::take(&mut t).split_at_mut(2 * c.vt as usize);
            let (n_here, n_rest) = std::mem::take(&mut n).split_at_mut(3 * c.vn as usize);
            let k_count = if coloured { 3 * c.v as usize } else { 0 };
            let (k_here, k_rest) = std::mem::take(&mut k).split_at_mut(k_count);
            (p, t, n, k) = (p_rest, t_rest, n_rest, k_rest);
            slices.push(ChunkSlices {
                positions: p_here,
                texcoords: t_here,
                normals: n_here,
                colours: k_here,
                coloured,
                before,
            });
            before = before.plus(c);
        }
        slices
    }
}

/// A statement that shapes the models, and how many of its chunk's triangles come
/// before it.
struct Event<'a> {
    triangles_before: usize,
    statement: Statement<'a>,
}

enum Statement<'a> {
    /// `o` or `g`, with the line it is on (tobj names the model after it).
    Object(&'a str),
    /// `usemtl`, with the material's name.
    UseMaterial(&'a str),
    /// `mtllib`, with the library's file name.
    MaterialLibrary(&'a str),
}

/// One chunk's triangles as three corners each (indices into the whole file's
/// attributes, 0-based), and the statements between them.
#[derive(Default)]
struct ChunkFaces<'a> {
    v: Vec<u32>,
    /// Texture coordinate of each corner, or empty when no corner in the chunk has one.
    vt: Vec<u32>,
    /// Normal of each corner, or empty when no corner in the chunk has one.
    vn: Vec<u32>,
    events: Vec<Event<'a>>,
}

/// Parses one chunk into its attribute slices; `None` where tobj must read the file.
fn parse_chunk<'a>(text: &'a str, out: &mut ChunkSlices<'_>) -> Option<ChunkFaces<'a>> {
    let mut faces = ChunkFaces::default();
    let mut seen = Counts::default();
    let mut corners = Vec::new();
    for line in lines(text) {
        let mut words = words(line);
        match words.next() {
            Some("v") => {
                let at = 3 * seen.v as usize;
                read_floats(&mut words, out.positions.get_mut(at..at + 3)?)?;
                if out.coloured {
                    read_floats(&mut words, out.colours.get_mut(at..at + 3)?)?;
                }
                // A fourth value (w), or colours on some vertices only: tobj's business.
                if words.next().is_some() {
                    return None;
                }
                seen.v += 1;
            }
            Some("vt") => {
                let at = 2 * seen.vt as usize;
                read_floats(&mut words, out.texcoords.get_mut(at..at + 2)?)?;
                seen.vt += 1;
            }
            Some("vn") => {
                let at = 3 * seen.vn as usize;
                read_floats(&mut words, out.normals.get_mut(at..at + 3)?)?;
                seen.vn += 1;
            }
            Some("f") => {
                let so_far = out.before.plus(&seen);
                corners.clear();
                for word in words {
                    corners.push(parse_corner(word, &so_far)?);
                }
                faces.push_polygon(&corners)?;
            }
            Some("l" | "p") => return None,
            Some("o" | "g") => faces.event(Statement::Object(line)),
            Some("usemtl") => {
                let name = used_material(whole_line(text, line))?;
                faces.event(Statement::UseMaterial(name))
            }
            Some("mtllib") => faces.event(Statement::MaterialLibrary(argument(line, "mtllib")?)),
            _ => {}
        }
    }
    let filled = seen.v as usize * 3 == out.positions.len()
        && seen.vt as usize * 2 == out.texcoords.len()
        && seen.vn as usize * 3 == out.normals.len();
    filled.then_some(faces)
}

/// Reads exactly `out.len()` numbers (tobj ignores any after them, as for `vt u v w`).
fn read_floats<'a>(words: &mut impl Iterator<Item = &'a str>, out: &mut [f32]) -> Option<()> {
    for value in out {
        let word = words.next()?;
        *value = match plain_decimal(word.as_bytes()) {
            Some(v) => v,
            None => word.parse().ok()?,
        };
    }
    Some(())
}

/// Powers of ten that are exact in `f32` (5^10 < 2^24).
const EXACT_POWERS_OF_TEN: [f32; 11] = [1e0, 1e1, 1e2, 1e3, 1e4, 1e5, 1e6, 1e7, 1e8, 1e9, 1e10];

/// The value of a plain decimal (`-12.345678`: an optional minus, digits, at most one
/// point) as `f32::from_str` gives it, bit for bit, or `None` to leave it to that.
/// Clinger's fast path: when the digits, read as an integer, are below 2^24 and at most
/// ten follow the point, both the integer and the power of ten are exact in `f32`, so
/// their one correctly rounded quotient is the correctly rounded value. That covers what
/// exporters write (six decimals), without the general parser's work.
#[inline]
fn plain_decimal(bytes: &[u8]) -> Option<f32> {
    let (negative, digits) = match bytes.split_first()? {
        (b'-', rest) => (true, rest),
        _ => (false, bytes),
    };
    let (mut mantissa, mut decimals, mut point, mut any) = (0u32, 0usize, false, false);
    for &b in digits {
        match b {
            b'0'..=b'9' => {
                mantissa = mantissa * 10 + u32::from(b - b'0');
                if mantissa >= 1 << 24 {
                    return None;
                }
                decimals += usize::from(point);
                any = true;
            }
            b'.' if !point => point = true,
            _ => return None,
        }
    }
    if !any || decimals >= EXACT_POWERS_OF_TEN.len() {
        return None;
    }
    let value = mantissa as f32 / EXACT_POWERS_OF_TEN[decimals];
    Some(if negative { -value } else { value })
}

/// One face corner `v`, `v/vt`, `v//vn` or `v/vt/vn`, as 0-based indices into the
/// whole file, given how many of each came before it; `None` unless every index names
/// something already read.
fn parse_corner(word: &str, so_far: &Counts) -> Option<[u32; 3]> {
    let mut indices = [MISSING; 3];
    let limits = [so_far.v, so_far.vt, so_far.vn];
    for (k, part) in word.split('/').enumerate() {
        if k == 3 {
            return None;
        }
        if part.is_empty() {
            continue;
        }
        let i = index(part)?;
        let resolved = if i < 0 { limits[k] as i64 + i } else { i - 1 };
        if resolved < 0 || resolved >= limits[k] as i64 {
            return None;
        }
        indices[k] = resolved as u32;
    }
    (indices[0] != MISSING).then_some(indices)
}

/// An index as tobj reads it (`isize::from_str`), quickly for plain digits.
#[inline]
fn index(text: &str) -> Option<i64> {
    let bytes = text.as_bytes();
    if bytes.len() <= 9 && bytes.iter().all(u8::is_ascii_digit) {
        return Some(bytes.iter().fold(0, |n, &d| n * 10 + i64::from(d - b'0')));
    }
    text.parse::<isize>().ok().map(|i| i as i64)
}

impl<'a> ChunkFaces<'a> {
    fn event(&mut self, statement: Statement<'a>) {
        self.events.push(Event {
            triangles_before: self.v.len() / 3,
            statement,
        });
    }

    /// Triangulates a face as a fan around its first corner, as tobj does.
    fn push_polygon(&mut self, corners: &[[u32; 3]]) -> Option<()> {
        if corners.len() < 3 {
            return None;
        }
        for k in 1..corners.len() - 1 {
            for c in [corners[0], corners[k], corners[k + 1]] {
                self.push_corner(c);
            }
        }
        Some(())
    }

    fn push_corner(&mut self, [v, vt, vn]: [u32; 3]) {
        let n = self.v.len();
        self.v.push(v);
        for (list, value) in [(&mut self.vt, vt), (&mut self.vn, vn)] {
            if value != MISSING || !list.is_empty() {
                // The first corner with one: the earlier corners had none.
                list.resize(n, MISSING);
                list.push(value);
            }
        }
    }

    /// The corner `i` as (v, vt, vn).
    #[inline]
    fn corner(&self, i: usize) -> [u32; 3] {
        let get = |list: &Vec<u32>| list.get(i).copied().unwrap_or(MISSING);
        [self.v[i], get(&self.vt), get(&self.vn)]
    }
}

/// Joins the chunks' triangles into tobj's models in file order: a new model at each
/// `o`/`g` and at each change of material, with tobj's per-model vertex numbering.
struct Join<'a> {
    attributes: &'a Attributes,
    models: Vec<tobj::Model>,
    materials: Vec<tobj::Material>,
    material_ids: HashMap<String, usize>,
    material_error: Option<tobj::LoadError>,
    /// The model being read: its name, material and triangles so far.
    name: String,
    material: Option<usize>,
    mesh: tobj::Mesh,
    /// Per-model vertex numbering: by position alone while no corner has a texture
    /// coordinate or normal (`by_position`, indexed by position), else by all three.
    by_position: Vec<u32>,
    /// The positions numbered in `by_position`, to reset it when the model ends.
    numbered: Vec<u32>,
    by_corner: FxHashMap<[u32; 3], u32>,
    keyed_by_corner: bool,
}

impl<'a> Join<'a> {
    fn new(attributes: &'a Attributes) -> Self {
        Join {
            attributes,
            models: Vec::new(),
            materials: Vec::new(),
            material_ids: HashMap::new(),
            material_error: None,
            name: "unnamed_object".to_owned(),
            material: None,
            mesh: tobj::Mesh::default(),
            by_position: vec![MISSING; attributes.positions.len() / 3],
            numbered: Vec::new(),
            by_corner: FxHashMap::default(),
            keyed_by_corner: false,
        }
    }

    /// Adds one chunk's triangles and statements.
    fn chunk<ML>(&mut self, chunk: &ChunkFaces<'_>, load_mtl: &mut ML)
    where
        ML: FnMut(&Path) -> tobj::MTLLoadResult,
    {
        let mut done = 0;
        for event in &chunk.events {
            self.triangles(chunk, done..event.triangles_before);
            done = event.triangles_before;
            match event.statement {
                Statement::Object(line) => {
                    self.end_model_if_it_has_faces();
                    // tobj names the model after the whole line past its first character.
                    let first = line.chars().next().map_or(0, char::len_utf8);
                    self.name = line[first..].trim().to_owned();
                    if self.name.is_empty() {
                        self.name = "unnamed_object".to_owned();
                    }
                }
                Statement::UseMaterial(name) => {
                    let id = self.material_ids.get(name).copied();
                    if id != self.material {
                        self.end_model_if_it_has_faces();
                    }
                    self.material = id;
                }
                Statement::MaterialLibrary(name) => self.merge(load_mtl(Path::new(name))),
            }
        }
        self.triangles(chunk, done..chunk.v.len() / 3);
    }

    /// tobj's merge of a material library into the materials so far.
    fn merge(&mut self, loaded: tobj::MTLLoadResult) {
        match loaded {
            Ok((mut materials, ids)) => {
                let offset = self.materials.len();
                self.materials.append(&mut materials);
                for (name, id) in ids {
                    self.material_ids.insert(name, id + offset);
                }
            }
            Err(e) => self.material_error = Some(e),
        }
    }

    fn end_model_if_it_has_faces(&mut self) {
        if !self.mesh.indices.is_empty() {
            self.end_model();
        }
    }

    /// Closes the model being read and starts an empty one with the same name and
    /// material.
    fn end_model(&mut self) {
        self.forget_positions();
        self.by_corner.clear();
        self.keyed_by_corner = false;
        let mesh = std::mem::take(&mut self.mesh);
        self.models.push(tobj::Model::new(
            tobj::Mesh {
                material_id: self.material,
                ..mesh
            },
            self.name.clone(),
        ));
    }

    /// Empties the numbering by position alone.
    fn forget_positions(&mut self) {
        for v in self.numbered.drain(..) {
            self.by_position[v as usize] = MISSING;
        }
    }

    /// Adds triangles `range` of `chunk` to the model being read, numbering their
    /// vertices as tobj does: in order of first use, one per distinct corner.
    fn triangles(&mut self, chunk: &ChunkFaces<'_>, range: Range<usize>) {
        let corners = 3 * range.start..3 * range.end;
        let plain = chunk.vt.is_empty() && chunk.vn.is_empty();
        if plain && !self.keyed_by_corner {
            for &v in &chunk.v[corners] {
                let mut slot = self.by_position[v as usize];
                if slot == MISSING {
                    slot = (self.mesh.positions.len() / 3) as u32;
                    self.by_position[v as usize] = slot;
                    self.numbered.push(v);
                    self.push_position(v as usize);
                }
                self.mesh.indices.push(slot);
            }
            return;
        }
        if !self.keyed_by_corner {
            // The first corner with more than a position in this model: carry the
            // numbering so far over to the full key.
            for &v in &self.numbered {
                let key = [v, MISSING, MISSING];
                self.by_corner.insert(key, self.by_position[v as usize]);
            }
            self.forget_positions();
            self.keyed_by_corner = true;
        }
        for i in corners {
            self.add_corner(chunk.corner(i));
        }
    }

    /// Appends vertex `v`'s position (and colour) to the model being read.
    #[inline]
    fn push_position(&mut self, v: usize) {
        let a = self.attributes;
        self.mesh
            .positions
            .extend_from_slice(&a.positions[3 * v..][..3]);
        if a.coloured {
            self.mesh
                .vertex_color
                .extend_from_slice(&a.colours[3 * v..][..3]);
        }
    }

    /// Adds one corner, keyed by all three indices.
    fn add_corner(&mut self, key: [u32; 3]) {
        let next = (self.mesh.positions.len() / 3) as u32;
        let index = *self.by_corner.entry(key).or_insert(next);
        if index == next {
            let [v, vt, vn] = key.map(|i| i as usize);
            let a = self.attributes;
            self.push_position(v);
            if vt != MISSING as usize {
                self.mesh
                    .texcoords
                    .extend_from_slice(&a.texcoords[2 * vt..][..2]);
            }
            if vn != MISSING as usize {
                self.mesh
                    .normals
                    .extend_from_slice(&a.normals[3 * vn..][..3]);
            }
        }
        self.mesh.indices.push(index);
    }

    /// Everything is joined: the models, and the materials as tobj returns them.
    fn finish(
        mut self,
    ) -> (
        Vec<tobj::Model>,
        Result<Vec<tobj::Material>, tobj::LoadError>,
    ) {
        // tobj ends the last model whether or not it has faces.
        self.end_model();
        let materials = match self.material_error {
            Some(e) if self.materials.is_empty() => Err(e),
            _ => Ok(self.materials),
        };
        (self.models, materials)
    }
}

/// The test oracle: `Ok(true)` when this reader reads `obj` exactly as tobj does (the
/// same models, vertex for vertex and bit for bit, and the same materials), `Ok(false)`
/// when it declines, with `mtl` mapping each `mtllib` name to its text; otherwise what
/// differs. Public (hidden) for the tests.
pub fn check_against_tobj(obj: &str, mtl: &HashMap<String, String>) -> Result<bool, String> {
    let load_mtl = |name: &Path| -> tobj::MTLLoadResult {
        let text = mtl
            .get(&*name.to_string_lossy())
            .ok_or(tobj::LoadError::OpenFileFailed)?;
        let library =
            super::mtl::parse_mtl(text).map_err(|_| tobj::LoadError::MaterialParseError)?;
        super::mtl::tobj_result(library.materials)
    };
    let Some(ours) = load_obj(obj, load_mtl) else {
        return Ok(false);
    };
    let options = tobj::LoadOptions {
        single_index: true,
        triangulate: true,
        ignore_points: true,
        ignore_lines: true,
    };
    // ember's own text rules, as they run before tobj.
    let stripped = super::obj_text::strip_comments(obj);
    let theirs = match super::obj_text::pad_vertex_colours(&stripped) {
        Ok(text) => tobj::load_obj_buf(&mut text.as_bytes(), &options, load_mtl),
        Err(_) => Err(tobj::LoadError::PositionParseError),
    };
    let (ours, theirs) = match (ours, theirs) {
        (Ok(ours), Ok(theirs)) => (ours, theirs),
        (ours, theirs) => {
            return Err(format!(
                "this reader {:?}, tobj {:?}",
                ours.err(),
                theirs.err()
            ))
        }
    };
    same_models(&ours.0, &theirs.0)?;
    let names = |m: &Result<Vec<tobj::Material>, tobj::LoadError>| {
        m.as_ref()
            .map(|m| m.iter().map(|m| m.name.clone()).collect::<Vec<_>>())
            .map_err(|e| e.to_string())
    };
    if names(&ours.1) != names(&theirs.1) {
        return Err("the materials differ".into());
    }
    Ok(true)
}

/// `Ok` when the models are the same, field by field and bit for bit.
fn same_models(ours: &[tobj::Model], theirs: &[tobj::Model]) -> Result<(), String> {
    if ours.len() != theirs.len() {
        return Err(format!("{} models, tobj {}", ours.len(), theirs.len()));
    }
    let bits = |v: &[f32]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
    for (i, (a, b)) in ours.iter().zip(theirs).enumerate() {
        let (m, n) = (&a.mesh, &b.mesh);
        let same = a.name == b.name
            && m.material_id == n.material_id
            && m.indices == n.indices
            && bits(&m.positions) == bits(&n.positions)
            && bits(&m.texcoords) == bits(&n.texcoords)
            && bits(&m.normals) == bits(&n.normals)
            && bits(&m.vertex_color) == bits(&n.vertex_color);
        if !same {
            return Err(format!("model {i} ({:?}) differs", a.name));
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn plain_decimals_read_as_the_standard_parser_reads_them() {
        let mut words: Vec<String> = [
            "0",
            "-0",
            "0.0",
            "-0.000000",
            "1.",
            ".5",
            "-.5",
            "16777215",
            "16777216",
            "1.6777215",
            "0.1",
            "0.3",
            "-123.456789",
            "9999999.9",
            "0.0000000001",
            "0.00000000001",
            "007.50",
            "1e5",
            "+1",
            "-",
            ".",
            "1..2",
            "",
            "1.2.3",
        ]
        .map(str::to_owned)
        .to_vec();
        // Six-decimal values as the grid writer and most exporters print them.
        let mut x = 0.000_123_4f64;
        while x < 2e7 {
            for v in [x, -x, x * 1.000_7] {
                words.push(format!("{v:.6}"));
                words.push(format!("{v:.3}"));
                words.push(format!("{v}"));
            }
            x *= 1.37;
        }
        for word in &words {
            let expected = word.parse::<f32>().ok().map(f32::to_bits);
            if let Some(v) = plain_decimal(word.as_bytes()) {
                assert_eq!(Some(v.to_bits()), expected, "{word}");
            }
        }
        assert_eq!(
            plain_decimal(b"-0.000000").map(f32::to_bits),
            Some((-0.0f32).to_bits())
        );
        assert!(plain_decimal(b"0.123456").is_some());
    }
}
