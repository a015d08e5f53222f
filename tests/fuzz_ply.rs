//! PLY files (proptest, stable toolchain): meshes of every property and list type in
//! every encoding, written cleanly, must load as the mesh written (its positions, its
//! polygons fanned); the same files with their bytes damaged (bytes changed, cut
//! short, repeated, counts in the header made huge) must load or be refused in one
//! line naming the file, never panic, and what loads must render.
//!
//! `EMBER_FUZZ_SECONDS=N` runs for N seconds (`.ci/fuzz.sh` does).

mod common;

use common::ply::{Encoding, PlyMesh};
use ember::scene::load_ply;
use proptest::prelude::*;

/// A mesh: positions (quarters, exact in every float type; whole numbers for integer
/// types), its position type, optional attributes, faces and list types.
#[derive(Clone, Debug)]
struct Mesh {
    positions: Vec<[i32; 3]>,
    position_type: &'static str,
    normals: bool,
    uv: Option<(usize, &'static str)>,
    colours: Option<&'static str>,
    faces: Vec<Vec<i64>>,
    list_types: (&'static str, &'static str),
    encoding: Encoding,
}

/// A damage done to a file's bytes.
#[derive(Clone, Debug)]
enum Damage {
    /// Positions are taken modulo the file's length (plus one for a cut).
    Byte(u32, u8),
    Cut(u32),
    Repeat(u32, u32),
    Count(&'static str, u64),
}

fn mesh() -> impl Strategy<Value = Mesh> {
    let encoding = prop_oneof![
        Just(Encoding::Ascii),
        Just(Encoding::LittleEndian),
        Just(Encoding::BigEndian)
    ];
    let corner = prop::array::uniform3(-40i32..40);
    (
        prop::collection::vec(corner, 1..24),
        prop::sample::select(vec!["float", "double", "int", "short", "char"]),
        any::<bool>(),
        prop::option::of((0usize..4, prop::sample::select(vec!["float", "double"]))),
        prop::option::of(prop::sample::select(vec!["uchar", "float"])),
        prop::collection::vec(prop::collection::vec(0i64..1000, 0..9), 0..12),
        prop::sample::select(vec!["uchar", "ushort", "int", "uint"]),
        prop::sample::select(vec!["int", "uint", "ushort", "uchar", "char"]),
        encoding,
    )
        .prop_map(
            |(positions, position_type, normals, uv, colours, faces, count, index, encoding)| {
                let n = positions.len() as i64;
                Mesh {
                    faces: faces
                        .into_iter()
                        .map(|f| f.into_iter().map(|i| i % n).collect())
                        .collect(),
                    positions,
                    position_type,
                    normals,
                    uv,
                    colours,
                    list_types: (count, index),
                    encoding,
                }
            },
        )
}

fn damage() -> impl Strategy<Value = Damage> {
    let huge = prop_oneof![
        Just(1u64 << 30),
        Just(1_000_000_000),
        Just(u64::from(u32::MAX) + 1),
        0u64..64
    ];
    prop_oneof![
        (any::<u32>(), any::<u8>()).prop_map(|(i, b)| Damage::Byte(i, b)),
        any::<u32>().prop_map(Damage::Cut),
        (any::<u32>(), any::<u32>()).prop_map(|(a, b)| Damage::Repeat(a, b)),
        (prop::sample::select(vec!["vertex", "face"]), huge).prop_map(|(e, n)| Damage::Count(e, n)),
    ]
}

impl Mesh {
    /// The position of vertex `i` as written: quarters in float types.
    fn position(&self, i: usize) -> [f32; 3] {
        let scale = match self.position_type {
            "float" | "double" => 0.25,
            _ => 1.0,
        };
        self.positions[i].map(|x| x as f32 * scale)
    }

    fn ply(&self) -> PlyMesh {
        let positions: Vec<[f32; 3]> = (0..self.positions.len())
            .map(|i| self.position(i))
            .collect();
        let mut ply = PlyMesh::new(&positions, &self.faces);
        for p in &mut ply.vertex_properties {
            p.0 = self.position_type.into();
        }
        if self.normals {
            for axis in ["nx", "ny", "nz"] {
                ply = ply.with("float", axis, |i| (i % 3) as f64 - 1.0);
            }
        }
        if let Some((names, ty)) = self.uv {
            let [u, v] = [
                ["u", "v"],
                ["s", "t"],
                ["texture_u", "texture_v"],
                ["texture_s", "texture_t"],
            ][names];
            ply = ply
                .with(ty, u, |i| i as f64 / 8.0)
                .with(ty, v, |i| 1.0 - i as f64 / 8.0);
        }
        if let Some(ty) = self.colours {
            let top = if ty == "uchar" { 255.0 } else { 1.0 };
            for channel in ["red", "green", "blue"] {
                ply = ply.with(ty, channel, move |i| top * ((i % 5) as f64 / 4.0));
            }
        }
        ply.list_types = (self.list_types.0.into(), self.list_types.1.into());
        ply
    }

    /// The triangles the faces fan into, and how many have an area.
    fn fanned(&self) -> (usize, usize) {
        let mut all = 0;
        let mut with_area = 0;
        for f in self.faces.iter().filter(|f| f.len() >= 3) {
            for k in 1..f.len() - 1 {
                let [a, b, c] =
                    [f[0], f[k], f[k + 1]].map(|i| glam::Vec3::from(self.position(i as usize)));
                all += 1;
                with_area += usize::from((b - a).cross(c - a).length() > 0.0);
            }
        }
        (all, with_area)
    }
}

/// `bytes` with `damage` done to them.
fn damaged(mut bytes: Vec<u8>, damage: &[Damage]) -> Vec<u8> {
    for d in damage {
        let at = |x: &u32, len: usize| *x as usize % len;
        match d {
            Damage::Byte(i, b) if !bytes.is_empty() => {
                let i = at(i, bytes.len());
                bytes[i] = *b;
            }
            Damage::Cut(keep) => {
                let keep = at(keep, bytes.len() + 1);
                bytes.truncate(keep);
            }
            Damage::Repeat(a, b) if !bytes.is_empty() => {
                let (a, b) = (at(a, bytes.len()), at(b, bytes.len()));
                let piece = bytes[a.min(b)..a.max(b)].to_vec();
                bytes.splice(a.max(b)..a.max(b), piece);
            }
            Damage::Count(element, n) => {
                // Found in the bytes themselves: earlier damage may have left them
                // no longer UTF-8.
                let key = format!("element {element} ");
                let found = bytes.windows(key.len()).position(|w| w == key.as_bytes());
                if let Some(at) = found {
                    let start = at + key.len();
                    let line = bytes[start..].iter().position(|&b| b == b'\n');
                    let end = start + line.unwrap_or(0);
                    bytes.splice(start..end, n.to_string().into_bytes());
                }
            }
            _ => {}
        }
    }
    bytes
}

fn check(input: &(Mesh, Vec<Damage>)) -> Result<bool, TestCaseError> {
    let (mesh, damage) = input;
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("fuzz.ply");
    let clean = mesh.ply().bytes(mesh.encoding);
    std::fs::write(&path, &clean).unwrap();
    let (all, with_area) = mesh.fanned();
    match load_ply(&path) {
        Ok((scene, report)) => {
            prop_assert!(with_area > 0);
            prop_assert_eq!(report.triangles, with_area);
            prop_assert_eq!(report.triangles + report.degenerate_dropped, all);
            for (i, p) in scene.mesh.positions.iter().enumerate() {
                prop_assert_eq!(p.to_array(), mesh.position(i));
            }
            common::fuzz::render_tiny(&scene)?;
        }
        Err(e) => {
            prop_assert_eq!(with_area, 0, "{}", e);
            prop_assert!(
                e.to_string().contains("has no triangles to render"),
                "{}",
                e
            );
        }
    }
    std::fs::write(&path, damaged(clean, damage)).unwrap();
    match load_ply(&path) {
        Ok((scene, _)) => {
            common::fuzz::render_tiny(&scene)?;
            Ok(true)
        }
        Err(e) => {
            let text = e.to_string();
            prop_assert!(!text.contains('\n'), "{}", text);
            prop_assert!(text.contains("fuzz.ply"), "{}", text);
            Ok(false)
        }
    }
}

#[test]
fn fuzz_ply() {
    common::fuzz::run(
        "fuzz_ply",
        "damaged files loaded",
        (mesh(), prop::collection::vec(damage(), 1..4)),
        check,
    );
}

#[test]
fn a_huge_count_and_a_cut_are_refused_in_one_line() {
    let mesh = Mesh {
        positions: vec![[0, 0, 0], [4, 0, 0], [0, 4, 0]],
        position_type: "float",
        normals: true,
        uv: Some((1, "double")),
        colours: Some("uchar"),
        faces: vec![vec![0, 1, 2]],
        list_types: ("uchar", "int"),
        encoding: Encoding::BigEndian,
    };
    let huge = vec![Damage::Count("face", 1_000_000_000)];
    assert!(matches!(check(&(mesh.clone(), huge)), Ok(false)));
    let cut = vec![Damage::Cut(150)];
    assert!(matches!(check(&(mesh, cut)), Ok(false)));
}
