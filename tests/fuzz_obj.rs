//! Fuzzing OBJ + MTL text through ember's scene conversion, on the stable toolchain
//! (cargo-fuzz needs nightly): proptest generates inputs from an OBJ/MTL grammar with
//! hostile values (NaN, huge and negative indices, missing libraries...) and also
//! mutates the bytes of the Cornell box. No input may panic; a scene that loads must
//! be internally consistent, no larger than its text, and render without panicking.
//!
//! By default a bounded number of cases runs (fast enough for `cargo test`).
//! `EMBER_FUZZ_SECONDS=N` runs batches until N seconds have passed and prints how many
//! inputs were tried (`.ci/fuzz.sh N` does this under a memory cap). Every failure
//! found becomes a case in `regressions` below.

mod common;

use std::collections::HashMap;

use common::fuzz::render_tiny;
use ember::scene::{check_against_tobj, load_obj_from_str, LoadOptions, Scene};
use proptest::prelude::*;

/// An input: OBJ text and its in-memory material libraries.
#[derive(Clone, Debug)]
struct Input {
    obj: String,
    mtl: HashMap<String, String>,
}

/// Strategies below take `odd`, the weight of hostile choices against 40 for ordinary
/// ones: inputs are generated both mostly valid (so they get past the parser and into
/// conversion and rendering) and thoroughly hostile.
fn number(odd: u32) -> impl Strategy<Value = String> {
    prop_oneof![
        40 => (-10.0f32..10.0).prop_map(|v| v.to_string()),
        odd => any::<f32>().prop_map(|v| v.to_string()),
        odd => prop::sample::select(vec![
            "nan", "NaN", "inf", "-inf", "1e39", "-1e39", "1e-45", "0", "-0", "", "x",
            "1e", "--1", "0x10", "340282350000000000000000000000000000000",
        ])
        .prop_map(str::to_owned),
    ]
}

/// One face corner: `v`, `v/t`, `v//n` or `v/t/n`, with indices that may be negative,
/// zero, past the end or absurdly large.
fn index(odd: u32) -> impl Strategy<Value = String> {
    prop_oneof![
        40 => (1i64..8).prop_map(|i| i.to_string()),
        odd => (-12i64..0).prop_map(|i| i.to_string()),
        odd => (8i64..16).prop_map(|i| i.to_string()),
        odd => Just("0".to_owned()),
        odd => prop::sample::select(vec![
            "4294967296", "3000000000", "-3000000000", "18446744073709551615",
            "99999999999999999999", "2147483648", "",
        ])
        .prop_map(str::to_owned),
    ]
}

fn corner(odd: u32) -> impl Strategy<Value = String> {
    (index(odd), index(odd), index(odd), 0..4u8).prop_map(|(v, t, n, form)| match form {
        0 => v,
        1 => format!("{v}/{t}"),
        2 => format!("{v}//{n}"),
        _ => format!("{v}/{t}/{n}"),
    })
}

const MTL_NAMES: [&str; 3] = ["a.mtl", "b.mtl", "missing.mtl"];
const MATERIALS: [&str; 4] = ["red", "light", "glass", "undefined"];

fn numbers(odd: u32, n: usize) -> impl Strategy<Value = String> {
    let count = prop_oneof![40 => Just(n..n + 1), odd => Just(0..n + 2)];
    count.prop_flat_map(move |c| prop::collection::vec(number(odd), c).prop_map(|n| n.join(" ")))
}

fn obj_line(odd: u32) -> impl Strategy<Value = String> {
    let corners =
        |odd, lo, hi| prop::collection::vec(corner(odd), lo..hi).prop_map(|c| c.join(" "));
    prop_oneof![
        60 => numbers(odd, 3).prop_map(|n| format!("v {n}")),
        10 => numbers(odd, 2).prop_map(|n| format!("vt {n}")),
        10 => numbers(odd, 3).prop_map(|n| format!("vn {n}")),
        40 => corners(odd, 3, 6).prop_map(|c| format!("f {c}")),
        odd => corners(odd, 0, 3).prop_map(|c| format!("f {c}")),
        4 => corners(odd, 0, 4).prop_map(|c| format!("l {c}")),
        4 => corners(odd, 0, 3).prop_map(|c| format!("p {c}")),
        10 => prop::sample::select(MATERIALS.to_vec()).prop_map(|m| format!("usemtl {m}")),
        4 => prop::sample::select(MTL_NAMES[..2].to_vec()).prop_map(|m| format!("mtllib {m}")),
        odd => Just("mtllib missing.mtl".to_owned()),
        4 => "[a-z ]{0,6}".prop_map(|n| format!("o {n}")),
        4 => "[a-z ]{0,6}".prop_map(|n| format!("g {n}")),
        4 => prop::sample::select(vec!["s 1", "s off", "# comment", "", "\\", "f", "v"])
            .prop_map(str::to_owned),
        odd => "[ -~]{0,20}",
        odd => any::<Vec<u8>>().prop_map(|b| String::from_utf8_lossy(&b).into_owned()),
    ]
}

fn mtl_line(odd: u32) -> impl Strategy<Value = String> {
    let colour = prop_oneof![40 => numbers(odd, 3), 10 => numbers(odd, 1)];
    prop_oneof![
        20 => prop::sample::select(MATERIALS.to_vec()).prop_map(|m| format!("newmtl {m}")),
        40 => (prop::sample::select(vec!["Kd", "Ks", "Ke", "Ka", "Tf"]), colour)
            .prop_map(|(k, c)| format!("{k} {c}")),
        20 => (prop::sample::select(vec!["Ns", "Ni", "d", "Tr"]), number(odd))
            .prop_map(|(k, v)| format!("{k} {v}")),
        10 => (0u16..12).prop_map(|i| format!("illum {i}")),
        odd => (0u16..300).prop_map(|i| format!("illum {i}")),
        odd => "[ -~]{0,12}".prop_map(|t| format!("map_Kd {t}")),
        odd => "[ -~]{0,20}",
    ]
}

/// OBJ text from the grammar. Mostly-valid inputs (small `odd`) start with eight each
/// of `v`, `vt` and `vn`, so that the usual indices 1..8 refer to something.
fn grammar_input(odd: u32) -> impl Strategy<Value = Input> {
    let mtl_text = prop::collection::vec(mtl_line(odd), 0..16).prop_map(|l| l.join("\n"));
    let prefix = prop::collection::vec(
        (numbers(odd, 3), numbers(odd, 2), numbers(odd, 3))
            .prop_map(|(v, t, n)| format!("v {v}\nvt {t}\nvn {n}")),
        if odd < 10 { 8..9 } else { 0..9 },
    );
    (
        prefix,
        prop::collection::vec(obj_line(odd), 0..40),
        prop::collection::vec(mtl_text, if odd < 10 { 2..3 } else { 0..3 }),
    )
        .prop_map(|(prefix, lines, mtls)| Input {
            obj: prefix
                .into_iter()
                .chain(lines)
                .collect::<Vec<_>>()
                .join("\n"),
            mtl: MTL_NAMES.iter().map(|n| n.to_string()).zip(mtls).collect(),
        })
}

/// A valid scene to mutate: the Cornell box shipped with ember.
const CORNELL_OBJ: &str = include_str!("../meshes/CornellBox-Original.obj");
const CORNELL_MTL: &str = include_str!("../meshes/CornellBox-Original.mtl");

/// Byte-level mutations of the Cornell box: overwrite, insert, delete, duplicate.
fn mutated_input() -> impl Strategy<Value = Input> {
    let edit = (
        any::<prop::sample::Index>(),
        0..4u8,
        any::<u8>(),
        1usize..64,
    );
    (
        prop::collection::vec(edit.clone(), 1..12),
        prop::collection::vec(edit, 0..6),
    )
        .prop_map(|(obj_edits, mtl_edits)| {
            let obj = mutate(CORNELL_OBJ.as_bytes(), &obj_edits);
            let mtl = mutate(CORNELL_MTL.as_bytes(), &mtl_edits);
            Input {
                obj,
                mtl: HashMap::from([("CornellBox-Original.mtl".to_owned(), mtl)]),
            }
        })
}

fn mutate(bytes: &[u8], edits: &[(prop::sample::Index, u8, u8, usize)]) -> String {
    let mut b = bytes.to_vec();
    for (at, kind, byte, len) in edits {
        let i = at.index(b.len().max(1)).min(b.len());
        match kind {
            0 if i < b.len() => b[i] = *byte,
            1 => b.insert(i, *byte),
            2 => {
                let end = (i + len).min(b.len());
                b.drain(i..end);
            }
            _ => {
                let end = (i + len).min(b.len());
                let copy = b[i..end].to_vec();
                b.splice(i..i, copy);
            }
        }
    }
    String::from_utf8_lossy(&b).into_owned()
}

/// What every input must satisfy: no panic (proptest reports one as a failure), and a
/// scene that loads is consistent, bounded by its text, and renders.
/// Whether the input loaded (true) or was refused with an error.
fn check(input: &Input) -> Result<bool, TestCaseError> {
    // The parallel OBJ reader either leaves the input to tobj or reads it as tobj does.
    let oracle = check_against_tobj(&input.obj, &input.mtl);
    prop_assert!(oracle.is_ok(), "parallel reader against tobj: {:?}", oracle);
    let Ok((scene, report)) = load_obj_from_str(&input.obj, &input.mtl, &LoadOptions::default())
    else {
        return Ok(false);
    };
    check_scene(&scene, input)?;
    prop_assert_eq!(report.triangles, scene.mesh.triangles.len());
    render_tiny(&scene).map(|_| true)
}

fn check_scene(scene: &Scene, input: &Input) -> Result<(), TestCaseError> {
    let mesh = &scene.mesh;
    let text_len = input.obj.len();
    // A face needs at least two bytes per extra corner and a vertex ~4 bytes: no
    // input may produce more elements than it has bytes.
    prop_assert!(mesh.triangles.len() <= text_len);
    prop_assert!(mesh.positions.len() <= text_len);
    prop_assert!(!mesh.triangles.is_empty());
    prop_assert_eq!(mesh.material.len(), mesh.triangles.len());
    prop_assert!(mesh.normals.is_empty() || mesh.normals.len() == mesh.positions.len());
    prop_assert!(mesh.uvs.is_empty() || mesh.uvs.len() == mesh.positions.len());
    prop_assert!(mesh.positions.iter().all(|p| p.is_finite()));
    prop_assert!(mesh.normals.iter().all(|n| n.is_finite()));
    prop_assert!(mesh.uvs.iter().all(|t| t.is_finite()));
    for (t, tri) in mesh.triangles.iter().enumerate() {
        prop_assert!(tri.iter().all(|&i| (i as usize) < mesh.positions.len()));
        prop_assert!((mesh.material[t] as usize) < scene.materials.len());
        prop_assert!(mesh.area(t as u32) > 0.0);
    }
    for m in &scene.materials {
        prop_assert!(m.diffuse.is_finite() && m.specular.is_finite() && m.emission.is_finite());
        if let Some(tex) = m.diffuse_texture {
            prop_assert!((tex as usize) < scene.textures.len());
        }
    }
    for &e in &scene.emitters {
        prop_assert!((e as usize) < mesh.triangles.len());
    }
    Ok(())
}

fn input() -> impl Strategy<Value = Input> {
    prop_oneof![grammar_input(1), grammar_input(40), mutated_input()]
}

#[test]
fn fuzz_obj_text() {
    common::fuzz::run("fuzz_obj_text", "loaded and rendered", input(), check);
}

/// Inputs the fuzzer (or review) found problems with, kept so they never come back.
mod regressions {
    use super::*;

    fn loads_or_errs(obj: &str, mtl: &[(&str, &str)]) {
        let input = Input {
            obj: obj.to_owned(),
            mtl: mtl
                .iter()
                .map(|(k, v)| (k.to_string(), v.to_string()))
                .collect(),
        };
        check(&input).unwrap();
    }

    #[test]
    fn face_index_claiming_billions_fails_fast() {
        let obj = "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3000000000\n";
        let err = load_obj_from_str(obj, &HashMap::new(), &LoadOptions::default())
            .unwrap_err()
            .to_string();
        assert!(
            err.contains("<memory>.obj") && err.contains("line 4"),
            "{err}"
        );
        assert!(
            err.contains("3000000000") && err.contains("3 vertices in the file"),
            "{err}"
        );
        loads_or_errs("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 -3000000000\n", &[]);
        loads_or_errs(
            "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 18446744073709551615\n",
            &[],
        );
    }

    const TRIANGLE: &str = "mtllib a.mtl\nusemtl m\nv 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n";

    /// tobj 4.0.5 panicked (`try_into().unwrap()`) on a colour with fewer than three
    /// numbers; found by the fuzzer as `Ks 10.0000` in a mutated Cornell box MTL.
    #[test]
    fn colour_with_fewer_than_three_numbers_does_not_panic() {
        for colour in ["Ks", "Kd 0.5 0.5", "Ke # x", "Ka\t"] {
            let mtl = HashMap::from([("a.mtl".to_owned(), format!("newmtl m\n{colour}\n"))]);
            let err = load_obj_from_str(TRIANGLE, &mtl, &LoadOptions::default())
                .unwrap_err()
                .to_string();
            assert!(err.contains("a.mtl:2:"), "{err}");
        }
        // One number is grey, as the MTL spec says.
        let mtl = HashMap::from([("a.mtl".to_owned(), "newmtl m\nKd 0.25\r\n".to_owned())]);
        let (scene, _) = load_obj_from_str(TRIANGLE, &mtl, &LoadOptions::default()).unwrap();
        assert_eq!(scene.materials[0].diffuse, glam::Vec3::splat(0.25));
    }

    /// tobj 4.0.5 computed `vt * 2 + 1` unchecked: a texture index of -2^63 (or any
    /// huge one) overflowed; found by the fuzzer.
    #[test]
    fn huge_texture_and_normal_indices_do_not_overflow() {
        let base = "v 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0\nvn 0 0 1\n";
        for face in [
            "f 1/-9223372036854775808 2/1 3/1",
            "f 1/9223372036854775807 2/1 3/1",
            "f 1//-9223372036854775808 2//1 3//1",
            "f 1/4611686018427387904/1 2/1/1 3/1/1",
            "l 1/-99999999999 2",
            "p -9223372036854775808",
        ] {
            let err = load_obj_from_str(
                &format!("{base}{face}\n"),
                &HashMap::new(),
                &LoadOptions::default(),
            );
            assert!(err.unwrap_err().to_string().contains("line 6"), "{face}");
        }
        loads_or_errs(&format!("{base}f 1/0/0 2/1/1 3/1/1\n"), &[]);
        // A relative index is resolved against what was read before it: two normals
        // exist in the file, but only one before the face.
        let err = load_obj_from_str(
            &format!("{base}f 1//-2 2//1 3//1\nvn 0 0 1\n"),
            &HashMap::new(),
            &LoadOptions::default(),
        );
        assert!(err.unwrap_err().to_string().contains("1 normals before it"));
    }

    /// Vertices near f32::MAX put the framing camera and the hit points beyond Embree's
    /// ±1.844e18 range; Debian's Embree (built with assertions) aborted the process in
    /// `rtcIntersect1` (`ray.valid()`). Found by the fuzzer; such rays are now misses.
    #[test]
    fn vertices_near_float_max_render_without_aborting() {
        loads_or_errs("v 0 0 0\nv 3e38 0 0\nv 0 3e38 0\nf 1 2 3\n", &[]);
        loads_or_errs("v -3e38 -3e38 0\nv 3e38 0 0\nv 0 3e38 1e30\nf 1 2 3\n", &[]);
    }

    /// A library that is not there is a warning naming it, or with `strict` the error.
    #[test]
    fn missing_in_memory_library_is_a_warning_or_with_strict_an_error() {
        let obj = "mtllib nope.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n";
        let (_, report) = load_obj_from_str(obj, &HashMap::new(), &LoadOptions::default()).unwrap();
        assert_eq!(report.warnings.len(), 1, "{:?}", report.warnings);
        assert!(
            report.warnings[0].contains("nope.mtl"),
            "{:?}",
            report.warnings
        );
        let strict = LoadOptions { strict: true };
        let err = load_obj_from_str(obj, &HashMap::new(), &strict).unwrap_err();
        assert!(err.to_string().contains("nope.mtl"), "{err}");
    }

    #[test]
    fn in_memory_cornell_box_matches_the_file() {
        let mtl = HashMap::from([("CornellBox-Original.mtl".to_owned(), CORNELL_MTL.to_owned())]);
        let (memory, _) = load_obj_from_str(CORNELL_OBJ, &mtl, &LoadOptions::default()).unwrap();
        let path = concat!(
            env!("CARGO_MANIFEST_DIR"),
            "/meshes/CornellBox-Original.obj"
        );
        let (disk, _) = ember::scene::load_obj(path.as_ref()).unwrap();
        assert_eq!(memory.mesh.triangles, disk.mesh.triangles);
        assert_eq!(memory.mesh.positions, disk.mesh.positions);
        assert_eq!(memory.materials, disk.materials);
        assert_eq!(memory.emitters, disk.emitters);
    }
}
