//! Reading MTL material libraries as the common exporters write them (3ds Max, Blender,
//! Maya, SketchUp), into tobj's `Material`, the form both OBJ readers merge.
//!
//! - A statement is a key and its values, separated by any run of spaces and tabs;
//!   indentation, trailing blanks, CRLF (or old Mac CR) line ends, blank lines and a
//!   UTF-8 byte-order mark are all fine. Keys are matched without regard to case.
//! - `#` starts a comment at the start of a line, or after the numbers of a statement.
//!   A material name (`newmtl`) and a texture statement take the rest of their line,
//!   spaces included, as tobj reads them.
//! - Colours (`Ka`, `Kd`, `Ks`, `Ke`, `Tf`) take one number (grey) or three, or
//!   `xyz X [Y Z]` (CIE XYZ, converted to linear sRGB); `spectral` curves are not read
//!   (one warning; the colour stays unset).
//! - Keys ember has no use for (`Ka`, `Tf`, `sharpness`, `Ps`, `map_Ka`, `refl`, …) are
//!   read and ignored. An unknown key is one warning per library, not an error.
//! - A value that does not read is an error naming its line, the material and what was
//!   expected. Numbers must be finite.

use std::collections::HashMap;

use super::texture_files::parse_statement;

/// What a library defines, and what the user should hear about it.
#[derive(Debug, Default)]
pub(super) struct MtlLibrary {
    pub materials: Vec<tobj::Material>,
    /// `(line, message)`: each unknown key once, statements outside a material, colours
    /// given as spectral curves.
    pub warnings: Vec<(usize, String)>,
}

/// Why a library cannot be read: its line (from 1) and what was expected there.
#[derive(Debug, PartialEq, Eq)]
pub(super) struct MtlSyntaxError {
    pub line: usize,
    pub message: String,
}

/// How the values of a key are read, and where they go.
#[derive(Clone, Copy, PartialEq, Eq)]
enum Kind {
    Colour(Colour),
    Number(Number),
    /// `illum`: a whole number from 0 to 255.
    Illum,
    /// A texture statement (`[-options] file`) in the slot that ember reads.
    Map(Map),
    /// Read for its syntax (or not at all) and dropped.
    Ignored,
}

#[derive(Clone, Copy, PartialEq, Eq)]
enum Colour {
    Ka,
    Kd,
    Ks,
    Ke,
    Tf,
}

#[derive(Clone, Copy, PartialEq, Eq)]
enum Number {
    Ns,
    Ni,
    D,
    Tr,
    Pr,
    Pm,
}

#[derive(Clone, Copy, PartialEq, Eq)]
enum Map {
    Ka,
    Kd,
    Ks,
    Ns,
    D,
    Bump,
    /// Kept under its canonical name in `unknown_param` (`map_Ke`, `norm`, `map_Pr`,
    /// `map_Pm`), where the loader looks for it.
    Extra(&'static str),
}

/// Every key ember knows, lower-cased, with its canonical spelling.
const KEYS: [(&str, &str, Kind); 35] = [
    ("ka", "Ka", Kind::Colour(Colour::Ka)),
    ("kd", "Kd", Kind::Colour(Colour::Kd)),
    ("ks", "Ks", Kind::Colour(Colour::Ks)),
    ("ke", "Ke", Kind::Colour(Colour::Ke)),
    ("tf", "Tf", Kind::Colour(Colour::Tf)),
    ("ns", "Ns", Kind::Number(Number::Ns)),
    ("ni", "Ni", Kind::Number(Number::Ni)),
    ("d", "d", Kind::Number(Number::D)),
    ("tr", "Tr", Kind::Number(Number::Tr)),
    ("pr", "Pr", Kind::Number(Number::Pr)),
    ("pm", "Pm", Kind::Number(Number::Pm)),
    ("illum", "illum", Kind::Illum),
    ("map_ka", "map_Ka", Kind::Map(Map::Ka)),
    ("map_kd", "map_Kd", Kind::Map(Map::Kd)),
    ("map_ks", "map_Ks", Kind::Map(Map::Ks)),
    ("map_ns", "map_Ns", Kind::Map(Map::Ns)),
    ("map_d", "map_d", Kind::Map(Map::D)),
    ("bump", "bump", Kind::Map(Map::Bump)),
    ("map_bump", "map_Bump", Kind::Map(Map::Bump)),
    ("map_ke", "map_Ke", Kind::Map(Map::Extra("map_Ke"))),
    ("norm", "norm", Kind::Map(Map::Extra("norm"))),
    ("map_pr", "map_Pr", Kind::Map(Map::Extra("map_Pr"))),
    ("map_pm", "map_Pm", Kind::Map(Map::Extra("map_Pm"))),
    // Written by exporters, not rendered by ember.
    ("sharpness", "sharpness", Kind::Ignored),
    ("ps", "Ps", Kind::Ignored),
    ("pc", "Pc", Kind::Ignored),
    ("pcr", "Pcr", Kind::Ignored),
    ("aniso", "aniso", Kind::Ignored),
    ("anisor", "anisor", Kind::Ignored),
    ("km", "Km", Kind::Ignored),
    ("map_ps", "map_Ps", Kind::Ignored),
    ("disp", "disp", Kind::Ignored),
    ("decal", "decal", Kind::Ignored),
    ("refl", "refl", Kind::Ignored),
    ("map_refl", "map_refl", Kind::Ignored),
];

/// Reads the text of a material library.
pub(super) fn parse_mtl(text: &str) -> Result<MtlLibrary, MtlSyntaxError> {
    let mut reader = Reader::default();
    for (n, line) in lines(text).enumerate() {
        reader.statement(n + 1, line)?;
    }
    Ok(reader.finish())
}

/// The lines of `text` without their ends: split at `\n` (a `\r` before it dropped),
/// or at `\r` in a file that has no `\n` at all.
fn lines(text: &str) -> impl Iterator<Item = &str> {
    let text = text.strip_prefix('\u{feff}').unwrap_or(text);
    let end = if text.contains('\n') { '\n' } else { '\r' };
    text.split(end)
}

#[derive(Default)]
struct Reader {
    library: MtlLibrary,
    current: Option<tobj::Material>,
    /// Unknown keys as written: the line each was first seen on, and how many times.
    unknown: Vec<(String, usize, usize)>,
    /// Each unknown key's place in `unknown`: a library of a million distinct keys is
    /// read in linear time, not quadratic.
    unknown_at: HashMap<String, usize>,
}

impl Reader {
    fn statement(&mut self, line: usize, text: &str) -> Result<(), MtlSyntaxError> {
        let text = text.trim();
        if text.is_empty() || text.starts_with('#') {
            return Ok(());
        }
        let (key, rest) = split_key(text);
        if key.eq_ignore_ascii_case("newmtl") {
            return self.new_material(line, rest);
        }
        let Some(&(_, canonical, kind)) = KEYS.iter().find(|k| key.eq_ignore_ascii_case(k.0))
        else {
            self.unknown_key(line, key);
            return Ok(());
        };
        let Some(material) = self.current.as_mut() else {
            self.library
                .warnings
                .push((line, format!("`{key}` comes before any newmtl: ignored")));
            return Ok(());
        };
        let error = |message: String| MtlSyntaxError {
            line,
            message: format!("material {:?}: {canonical}: {message}", material.name),
        };
        match kind {
            Kind::Colour(which) => match colour(rest).map_err(error)? {
                Some(value) => set_colour(material, which, value),
                None => self.library.warnings.push((
                    line,
                    format!(
                        "material {:?}: {canonical} is a spectral curve, which ember does \
                         not read: {canonical} is left unset",
                        material.name
                    ),
                )),
            },
            Kind::Number(which) => set_number(material, which, number(rest).map_err(error)?),
            Kind::Illum => material.illumination_model = Some(illum(rest).map_err(error)?),
            Kind::Map(slot) => set_map(material, slot, texture(slot, rest).map_err(error)?),
            Kind::Ignored => {}
        }
        Ok(())
    }

    fn new_material(&mut self, line: usize, name: &str) -> Result<(), MtlSyntaxError> {
        if name.is_empty() {
            return Err(MtlSyntaxError {
                line,
                message: "newmtl: expected a material name".into(),
            });
        }
        self.library.materials.extend(self.current.take());
        self.current = Some(tobj::Material {
            name: name.to_owned(),
            ..tobj::Material::default()
        });
        Ok(())
    }

    fn unknown_key(&mut self, line: usize, key: &str) {
        match self.unknown_at.get(key) {
            Some(&at) => self.unknown[at].2 += 1,
            None => {
                self.unknown_at.insert(key.to_owned(), self.unknown.len());
                self.unknown.push((key.to_owned(), line, 1));
            }
        }
    }

    fn finish(mut self) -> MtlLibrary {
        self.library.materials.extend(self.current.take());
        for (key, line, count) in self.unknown {
            let more = match count {
                1 => String::new(),
                n => format!(" (and on {} more lines)", n - 1),
            };
            self.library
                .warnings
                .push((line, format!("unknown key `{key}` ignored{more}")));
        }
        self.library.warnings.sort_by_key(|(line, _)| *line);
        self.library
    }
}

/// The first word of a statement and the rest, trimmed; the first run of spaces or
/// tabs (or any other white space) separates them.
fn split_key(text: &str) -> (&str, &str) {
    match text.find(char::is_whitespace) {
        Some(end) => (&text[..end], text[end..].trim()),
        None => (text, ""),
    }
}

/// The numbers of a statement's values, up to a `#` comment.
fn words(values: &str) -> impl Iterator<Item = &str> {
    values
        .split_whitespace()
        .take_while(|w| !w.starts_with('#'))
}

fn finite(word: &str) -> Result<f32, String> {
    word.parse::<f32>()
        .ok()
        .filter(|v| v.is_finite())
        .ok_or_else(|| format!("expected a finite number, found {word:?}"))
}

/// One number; anything after it is ignored, as tobj ignored it.
fn number(values: &str) -> Result<f32, String> {
    let mut words = words(values).peekable();
    // `d -halo 0.5`: the halo form of dissolve is read as plain dissolve.
    words.next_if(|w| w.eq_ignore_ascii_case("-halo"));
    match words.next() {
        Some(word) => finite(word),
        None => Err("expected a number, found nothing".into()),
    }
}

fn illum(values: &str) -> Result<u8, String> {
    let word = words(values).next().unwrap_or("");
    let whole = word
        .parse::<u8>()
        .ok()
        .or_else(|| match word.parse::<f32>() {
            Ok(v) if v.fract() == 0.0 && (0.0..=255.0).contains(&v) => Some(v as u8),
            _ => None,
        });
    whole.ok_or_else(|| {
        format!("expected an illumination model (a whole number 0-10), found {word:?}")
    })
}

/// A colour: `r g b`, `grey`, `xyz X [Y Z]`, or `spectral FILE [factor]` (`None`).
/// Values past the third are ignored, as tobj ignored them.
fn colour(values: &str) -> Result<Option<[f32; 3]>, String> {
    let words: Vec<&str> = words(values).collect();
    let expected = "expected three numbers (or one for grey, or xyz X Y Z)";
    let values = match words.is_empty() {
        true => "nothing".to_owned(),
        false => format!("{:?}", words.join(" ")),
    };
    match words.as_slice() {
        [first, ..] if first.eq_ignore_ascii_case("spectral") => Ok(None),
        [first, rest @ ..] if first.eq_ignore_ascii_case("xyz") => {
            let xyz = match rest {
                [x] => [finite(x)?; 3],
                [x, y, z, ..] => [finite(x)?, finite(y)?, finite(z)?],
                _ => return Err(format!("{expected}, found {values}")),
            };
            Ok(Some(xyz_to_linear_srgb(xyz)))
        }
        [grey] => Ok(Some([finite(grey)?; 3])),
        [r, g, b, ..] => Ok(Some([finite(r)?, finite(g)?, finite(b)?])),
        _ => Err(format!("{expected}, found {values}")),
    }
}

/// CIE XYZ (D65) to linear sRGB (IEC 61966-2-1).
fn xyz_to_linear_srgb([x, y, z]: [f32; 3]) -> [f32; 3] {
    [
        3.240_454_2 * x - 1.537_138_5 * y - 0.498_531_4 * z,
        -0.969_266 * x + 1.876_010_8 * y + 0.041_556 * z,
        0.055_643_4 * x - 0.204_025_9 * y + 1.057_225_2 * z,
    ]
}

/// A texture statement of a slot: the options and file name as written. The slots
/// ember reads are checked here (options and a file name), so that a mistake names
/// its line; the others only need a value.
fn texture(slot: Map, values: &str) -> Result<String, String> {
    if values.is_empty() {
        return Err("expected a file name".into());
    }
    if slot != Map::Ka {
        parse_statement(values)?;
    }
    Ok(values.to_owned())
}

fn set_colour(m: &mut tobj::Material, which: Colour, value: [f32; 3]) {
    match which {
        Colour::Ka => m.ambient = Some(value),
        Colour::Kd => m.diffuse = Some(value),
        Colour::Ks => m.specular = Some(value),
        Colour::Ke => m.emissive = Some(value),
        Colour::Tf => {
            let [r, g, b] = value;
            m.unknown_param.insert("Tf".into(), format!("{r} {g} {b}"));
        }
    }
}

fn set_number(m: &mut tobj::Material, which: Number, value: f32) {
    let mut extra = |key: &str| m.unknown_param.insert(key.into(), value.to_string());
    match which {
        Number::Ns => m.shininess = Some(value),
        Number::Ni => m.optical_density = Some(value),
        Number::D => m.dissolve = Some(value),
        Number::Tr => drop(extra("Tr")),
        Number::Pr => drop(extra("Pr")),
        Number::Pm => drop(extra("Pm")),
    }
}

fn set_map(m: &mut tobj::Material, slot: Map, statement: String) {
    let field = match slot {
        Map::Ka => &mut m.ambient_texture,
        Map::Kd => &mut m.diffuse_texture,
        Map::Ks => &mut m.specular_texture,
        Map::Ns => &mut m.shininess_texture,
        Map::D => &mut m.dissolve_texture,
        Map::Bump => &mut m.normal_texture,
        Map::Extra(key) => {
            m.unknown_param.insert(key.into(), statement);
            return;
        }
    };
    *field = Some(statement);
}

/// The library's materials as tobj's loaders return them: the list and the index of
/// each name (a later definition of a name wins, as in tobj).
pub(super) fn tobj_result(materials: Vec<tobj::Material>) -> tobj::MTLLoadResult {
    let ids = materials
        .iter()
        .enumerate()
        .map(|(i, m)| (m.name.clone(), i))
        .collect();
    Ok((materials, ids))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn one(text: &str) -> tobj::Material {
        let library = parse_mtl(text).unwrap();
        assert_eq!(library.materials.len(), 1, "{text}");
        library.materials.into_iter().next().unwrap()
    }

    #[test]
    fn exporter_layouts_read_alike() {
        let clean = one("newmtl Red Paint\nKd 0.8 0.1 0.1\nNs 20\nillum 2\nmap_Kd a b.png\n");
        let max = one(
            "# 3ds Max Wavefront OBJ Exporter\r\nnewmtl  Red Paint \r\n\tNs 20.0000\r\n\
             \tTf 1.0000 1.0000 1.0000 \r\n\tillum 2\r\n\tKa 0.5880 0.5880 0.5880\r\n\
             \tKd\t0.8000 0.1000 0.1000   \r\n\tmap_Kd  a b.png \r\n",
        );
        assert_eq!(max.name, "Red Paint");
        assert_eq!(max.diffuse, clean.diffuse);
        assert_eq!(max.shininess, clean.shininess);
        assert_eq!(max.illumination_model, clean.illumination_model);
        assert_eq!(max.diffuse_texture, clean.diffuse_texture);
        let mac = one("newmtl Red Paint\rKD 0.8 0.1 0.1\rNS 20\rILLUM 2\rMAP_KD a b.png\r");
        assert_eq!(mac.diffuse, clean.diffuse);
        assert_eq!(mac.diffuse_texture, clean.diffuse_texture);
    }

    /// The libraries ember ships read as tobj read them, field for field.
    #[test]
    fn shipped_libraries_read_as_tobj_read_them() {
        let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("meshes");
        let mut read = 0;
        for entry in std::fs::read_dir(dir).unwrap() {
            let path = entry.unwrap().path();
            if path.extension().is_none_or(|e| e != "mtl") {
                continue;
            }
            let text = std::fs::read_to_string(&path).unwrap();
            let ours = parse_mtl(&text).unwrap();
            assert!(ours.warnings.is_empty(), "{path:?}: {:?}", ours.warnings);
            let (theirs, _) = tobj::load_mtl_buf(&mut text.as_bytes()).unwrap();
            assert_eq!(ours.materials.len(), theirs.len(), "{path:?}");
            for (a, b) in ours.materials.iter().zip(&theirs) {
                let fields = |m: &tobj::Material| {
                    format!(
                        "{:?} {:?} {:?} {:?} {:?} {:?} {:?} {:?} {:?} {:?} {:?}",
                        m.name,
                        m.diffuse,
                        m.specular,
                        m.emissive,
                        m.shininess,
                        m.optical_density,
                        m.dissolve,
                        m.illumination_model,
                        m.diffuse_texture,
                        m.normal_texture,
                        m.dissolve_texture
                    )
                };
                assert_eq!(fields(a), fields(b), "{path:?}");
            }
            read += 1;
        }
        assert!(read >= 5, "{read} libraries");
    }

    #[test]
    fn colour_forms() {
        let m =
            one("newmtl m\nKd 0.5\nKs xyz 0.9505 1 1.089\nKe 1 2 3 # comment\nKa spectral x.rfl\n");
        assert_eq!(m.diffuse, Some([0.5; 3]));
        // D65 white is (1, 1, 1) in linear sRGB.
        let ks = m.specular.unwrap();
        assert!(ks.iter().all(|c| (c - 1.0).abs() < 1e-3), "{ks:?}");
        assert_eq!(m.emissive, Some([1.0, 2.0, 3.0]));
        assert_eq!(m.ambient, None);
    }

    #[test]
    fn unknown_keys_warn_once_each() {
        let library = parse_mtl("newmtl m\nfoo 1\nKd 1 1 1\nfoo 2\nbar\nd -halo 0.5\n").unwrap();
        let warnings: Vec<String> = library
            .warnings
            .iter()
            .map(|(l, w)| format!("{l}: {w}"))
            .collect();
        assert_eq!(
            warnings,
            [
                "2: unknown key `foo` ignored (and on 1 more lines)",
                "5: unknown key `bar` ignored"
            ]
        );
        assert_eq!(library.materials[0].dissolve, Some(0.5));
    }

    #[test]
    fn errors_name_the_line_and_what_was_expected() {
        let cases = [
            (
                "newmtl m\nKd 1 zebra 0\n",
                2,
                "Kd: expected a finite number, found \"zebra\"",
            ),
            ("newmtl m\n\nKe 1 2\n", 3, "Ke: expected three numbers"),
            (
                "newmtl m\nNi inf\n",
                2,
                "material \"m\": Ni: expected a finite number",
            ),
            (
                "newmtl m\nillum two\n",
                2,
                "illum: expected an illumination model",
            ),
            ("newmtl m\nmap_Kd\n", 2, "map_Kd: expected a file name"),
            ("newmtl m\nbump -bm x h.png\n", 2, "-bm"),
            ("Kd 1 1 1\nnewmtl \n", 2, "newmtl: expected a material name"),
        ];
        for (text, line, message) in cases {
            let error = parse_mtl(text).unwrap_err();
            assert_eq!(error.line, line, "{text}");
            assert!(error.message.contains(message), "{text}: {}", error.message);
        }
    }
}
