//! PLY files written at run time for the tests (tests/ply.rs, tests/fuzz_ply.rs): a
//! vertex element of any properties and a face element of corner lists, in ASCII or
//! binary of either byte order, as exporters write them.

/// A PLY body's encoding.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Encoding {
    Ascii,
    LittleEndian,
    BigEndian,
}

impl Encoding {
    pub const ALL: [Encoding; 3] = [Encoding::Ascii, Encoding::LittleEndian, Encoding::BigEndian];

    pub fn header_name(self) -> &'static str {
        match self {
            Encoding::Ascii => "ascii",
            Encoding::LittleEndian => "binary_little_endian",
            Encoding::BigEndian => "binary_big_endian",
        }
    }
}

/// A mesh as a PLY file holds it.
#[derive(Clone, Debug)]
pub struct PlyMesh {
    /// The vertex element's properties: (type, name), such as ("float", "x").
    pub vertex_properties: Vec<(String, String)>,
    /// One value per property for each vertex.
    pub vertices: Vec<Vec<f64>>,
    /// The face list's count and index types, such as ("uchar", "int").
    pub list_types: (String, String),
    pub faces: Vec<Vec<i64>>,
}

impl PlyMesh {
    /// Positions only (`float x y z`), faces as `list uchar int vertex_indices`.
    pub fn new(positions: &[[f32; 3]], faces: &[Vec<i64>]) -> PlyMesh {
        PlyMesh {
            vertex_properties: ["x", "y", "z"]
                .map(|n| ("float".to_owned(), n.to_owned()))
                .to_vec(),
            vertices: positions
                .iter()
                .map(|p| p.iter().map(|&x| f64::from(x)).collect())
                .collect(),
            list_types: ("uchar".into(), "int".into()),
            faces: faces.to_vec(),
        }
    }

    /// Adds a vertex property of `ty` named `name`, with a value per vertex.
    pub fn with(mut self, ty: &str, name: &str, values: impl Fn(usize) -> f64) -> PlyMesh {
        self.vertex_properties.push((ty.into(), name.into()));
        for (i, v) in self.vertices.iter_mut().enumerate() {
            v.push(values(i));
        }
        self
    }

    /// Adds `red green blue` of `ty`, the same colour at every vertex.
    pub fn with_colour(self, ty: &str, rgb: [f64; 3]) -> PlyMesh {
        let [r, g, b] = rgb;
        self.with(ty, "red", move |_| r)
            .with(ty, "green", move |_| g)
            .with(ty, "blue", move |_| b)
    }

    /// The header, up to and including `end_header`.
    pub fn header(&self, encoding: Encoding) -> String {
        let mut h = format!(
            "ply\nformat {} 1.0\ncomment written by ember's tests\n",
            encoding.header_name()
        );
        h += &format!("element vertex {}\n", self.vertices.len());
        for (ty, name) in &self.vertex_properties {
            h += &format!("property {ty} {name}\n");
        }
        h += &format!("element face {}\n", self.faces.len());
        let (count, index) = &self.list_types;
        h += &format!("property list {count} {index} vertex_indices\nend_header\n");
        h
    }

    /// The whole file.
    pub fn bytes(&self, encoding: Encoding) -> Vec<u8> {
        let mut out = self.header(encoding).into_bytes();
        let types: Vec<&str> = self
            .vertex_properties
            .iter()
            .map(|(t, _)| t.as_str())
            .collect();
        for v in &self.vertices {
            let values: Vec<(&str, f64)> = types.iter().copied().zip(v.iter().copied()).collect();
            write_values(&mut out, &values, encoding);
        }
        let (count, index) = (&self.list_types.0, &self.list_types.1);
        for f in &self.faces {
            let mut values = vec![(count.as_str(), f.len() as f64)];
            values.extend(f.iter().map(|&i| (index.as_str(), i as f64)));
            write_values(&mut out, &values, encoding);
        }
        out
    }
}

/// One element's values, each of its type, as a line of ASCII or as binary.
pub fn write_values(out: &mut Vec<u8>, values: &[(&str, f64)], encoding: Encoding) {
    if encoding == Encoding::Ascii {
        let words: Vec<String> = values.iter().map(|&(t, v)| ascii(t, v)).collect();
        out.extend_from_slice(words.join(" ").as_bytes());
        out.push(b'\n');
        return;
    }
    let big = encoding == Encoding::BigEndian;
    for &(ty, v) in values {
        macro_rules! put {
            ($t:ty) => {{
                let x = v as $t;
                out.extend_from_slice(&if big {
                    x.to_be_bytes()
                } else {
                    x.to_le_bytes()
                });
            }};
        }
        match ty {
            "char" => put!(i8),
            "uchar" => put!(u8),
            "short" => put!(i16),
            "ushort" => put!(u16),
            "int" => put!(i32),
            "uint" => put!(u32),
            "float" => put!(f32),
            "double" => put!(f64),
            other => panic!("no PLY type {other}"),
        }
    }
}

/// A value as an ASCII body writes it: integers as integers, floats exactly (the
/// shortest text that reads back as the same `f32` or `f64`).
fn ascii(ty: &str, v: f64) -> String {
    match ty {
        "float" => format!("{}", v as f32),
        "double" => format!("{v}"),
        _ => format!("{}", v as i64),
    }
}
