//! Scene files are untrusted input: text made of scene-file pieces (tables, keys, values
//! of the right and wrong types, broken syntax, stray bytes) never panics the reader or
//! the loader, and every error is one line `FILE:LINE:COLUMN: KEY: ...` inside the file.

use std::path::Path;

use ember::scene::SceneFile;
use proptest::prelude::*;

fn cornell() -> String {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("meshes/CornellBox-Original.obj");
    format!("{:?}", path.to_str().unwrap())
}

fn piece() -> impl Strategy<Value = String> {
    let obj = cornell();
    let number = prop_oneof![
        Just("0".to_string()),
        Just("-1.5".to_string()),
        Just("1e30".to_string()),
        Just("nan".to_string()),
        Just("inf".to_string()),
        (-5.0f32..5.0).prop_map(|v| format!("{v:?}")),
    ];
    let vec3 = (number.clone(), number.clone(), number.clone())
        .prop_map(|(a, b, c)| format!("[{a}, {b}, {c}]"));
    let row = (
        number.clone(),
        number.clone(),
        number.clone(),
        number.clone(),
    )
        .prop_map(|(a, b, c, d)| format!("[{a}, {b}, {c}, {d}]"));
    let matrix = prop::collection::vec(row, 0..6).prop_map(|rows| rows.join(", "));
    prop_oneof![
        Just("[[obj]]\n".to_string()),
        Just("[[instance]]\n".to_string()),
        Just("[render]\n".to_string()),
        Just("[environment]\n".to_string()),
        Just("[camera.a]\n".to_string()),
        Just("[camera.b]\n".to_string()),
        Just(format!("file = {obj}\n")),
        Just("file = \"missing.obj\"\n".to_string()),
        Just("name = \"box\"\n".to_string()),
        Just("obj = \"box\"\n".to_string()),
        vec3.clone().prop_map(|v| format!("translate = {v}\n")),
        vec3.clone().prop_map(|v| format!("scale = {v}\n")),
        number.clone().prop_map(|v| format!("scale = {v}\n")),
        (vec3.clone(), number.clone())
            .prop_map(|(a, d)| format!("rotate = {{ axis = {a}, degrees = {d} }}\n")),
        matrix.prop_map(|m| format!("matrix = [{m}]\n")),
        vec3.clone().prop_map(|v| format!("eye = {v}\n")),
        number.clone().prop_map(|v| format!("spp = {v}\n")),
        number.prop_map(|v| format!("fov = {v}\n")),
        Just("camera = \"a\"\n".to_string()),
        Just("translate = \"far\"\n".to_string()),
        Just("[[obj\n".to_string()),
        Just("= 3\n".to_string()),
        Just("é = \"ü\"\n".to_string()),
        "[ -~]{0,12}\n",
    ]
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 400, ..ProptestConfig::default() })]

    #[test]
    fn scene_files_never_panic_and_errors_are_one_line(
        start_valid in any::<bool>(),
        pieces in prop::collection::vec(piece(), 0..12),
    ) {
        // Half the files start as a valid scene, so that the loader and the transforms
        // are reached too, not only the reader's errors.
        let start = if start_valid { format!("[[obj]]\nfile = {}\nname = \"box\"\n", cornell()) } else { String::new() };
        let text: String = start + &pieces.concat();
        let lines = text.lines().count().max(1);
        let path = Path::new("fuzz.toml");
        let check = |e: &ember::scene::SceneFileError| {
            let line = e.to_string();
            assert!(!line.contains('\n'), "{line:?}");
            assert!(line.starts_with("fuzz.toml:"), "{line:?}");
            assert!(e.line >= 1 && e.line <= lines + 1 && e.column >= 1, "{line:?} in\n{text}");
        };
        match SceneFile::parse(path, text.clone()) {
            Err(e) => check(&e),
            Ok(file) => match file.load_scene(&Default::default()) {
                Err(e) => check(&e),
                Ok((scene, _)) => {
                    let (lo, hi) = scene.bounds();
                    assert!(lo.is_finite() && hi.is_finite(), "{text}");
                }
            },
        }
    }
}
