//! PLY meshes (issue 46), written at run time: the same mesh in every encoding loads as
//! the same scene and renders the OBJ twin's image; a plane under a white sky has the
//! radiance of its albedo (the file's default, a scene file's `color`, vertex colours);
//! polygons fan into their area; every hostile file is one `error:` line.

mod common;

use std::path::{Path, PathBuf};
use std::sync::Arc;

use common::ply::{write_values, Encoding, PlyMesh};
use common::{ember_in as ember, with_embree};
use ember::image::Image;
use ember::integrator::IntegratorKind;
use ember::render::RenderSettings;
use ember::scene::{load_model, load_obj, load_ply, CameraSettings, Environment, Scene, SceneFile};
use glam::Vec3;

/// A box of six quads (integer corners, which every PLY type holds), the corners of each counter-clockwise seen from outside.
fn cube() -> ([[f32; 3]; 8], Vec<Vec<i64>>) {
    let corners = [
        [-1.0, 0.0, -1.0],
        [1.0, 0.0, -1.0],
        [1.0, 0.0, 1.0],
        [-1.0, 0.0, 1.0],
        [-1.0, 2.0, -1.0],
        [1.0, 2.0, -1.0],
        [1.0, 2.0, 1.0],
        [-1.0, 2.0, 1.0],
    ];
    let faces = [
        [0, 1, 2, 3],
        [4, 7, 6, 5],
        [0, 4, 5, 1],
        [1, 5, 6, 2],
        [2, 6, 7, 3],
        [3, 7, 4, 0],
    ];
    (corners, faces.iter().map(|f| f.to_vec()).collect())
}

/// The box on a floor quad, as a PLY mesh.
fn box_on_floor() -> PlyMesh {
    let (corners, mut faces) = cube();
    let floor = [
        [-3.0, 0.0, -3.0],
        [-3.0, 0.0, 3.0],
        [3.0, 0.0, 3.0],
        [3.0, 0.0, -3.0],
    ];
    let mut positions = corners.to_vec();
    positions.extend(floor);
    faces.push(vec![8, 9, 10, 11]);
    PlyMesh::new(&positions, &faces)
}

/// The OBJ of a PLY mesh's positions and faces (1-based indices).
fn obj_twin(mesh: &PlyMesh) -> String {
    let mut text = String::new();
    for v in &mesh.vertices {
        text += &format!("v {} {} {}\n", v[0] as f32, v[1] as f32, v[2] as f32);
    }
    for f in &mesh.faces {
        let corners: Vec<String> = f.iter().map(|i| (i + 1).to_string()).collect();
        text += &format!("f {}\n", corners.join(" "));
    }
    text
}

fn write(dir: &Path, name: &str, bytes: &[u8]) -> PathBuf {
    let path = dir.join(name);
    std::fs::write(&path, bytes).unwrap();
    path
}

/// `scene` under a uniform white sky, rendered with Embree at 48x40, 8 spp, seen
/// from `eye` towards `look_at`.
fn render_lit(mut scene: Scene, eye: Vec3, look_at: Vec3, fov: f32) -> Image {
    scene.sky = Some(Arc::new(Environment::constant(Vec3::ONE)));
    let built = with_embree(scene);
    let camera = CameraSettings {
        eye,
        look_at,
        up: Vec3::Y,
        projection: ember::scene::Projection::perspective(fov),
        lens: Default::default(),
    }
    .camera(48, 40);
    let settings = RenderSettings {
        width: 48,
        height: 40,
        spp: 8,
        max_depth: 6,
        seed: 7,
        integrator: IntegratorKind::Mis,
        light_sampler: Default::default(),
        adaptive: None,
        guiding: None,
        engine: Default::default(),
    };
    ember::render::render(&built.scene, &built.accel, &camera, &settings, &|_| {}).0
}

fn render_box(scene: Scene) -> Image {
    render_lit(
        scene,
        Vec3::new(1.5, 2.0, 3.0),
        Vec3::new(0.0, 0.4, 0.0),
        45.0,
    )
}

#[test]
fn every_encoding_renders_the_image_of_the_obj_twin() {
    let dir = tempfile::tempdir().unwrap();
    let mesh = box_on_floor();
    let obj = write(dir.path(), "box.obj", obj_twin(&mesh).as_bytes());
    let (twin, _) = load_obj(&obj).unwrap();
    let expected = render_box(twin);
    assert!(expected.pixels.iter().any(|p| p.max_element() > 0.1));
    for encoding in Encoding::ALL {
        let path = write(dir.path(), "box.ply", &mesh.bytes(encoding));
        let model = load_model(&path, &Default::default()).unwrap();
        let (scene, report) = (model.scene, model.report);
        assert_eq!(report.triangles, 14, "{encoding:?}");
        assert_eq!(report.vertices, 12, "{encoding:?}");
        let image = render_box(scene);
        assert!(
            image.pixels == expected.pixels,
            "{encoding:?}: the PLY's image differs from the OBJ's"
        );
    }
}

#[test]
fn every_index_type_and_byte_order_reads_the_same_mesh() {
    let dir = tempfile::tempdir().unwrap();
    let reference = {
        let path = write(dir.path(), "a.ply", &box_on_floor().bytes(Encoding::Ascii));
        load_ply(&path).unwrap().0.mesh
    };
    for (count, index) in [
        ("uchar", "uint"),
        ("ushort", "short"),
        ("int", "ushort"),
        ("uint", "int"),
    ] {
        for position in ["float", "double", "short"] {
            let mut mesh = box_on_floor();
            mesh.list_types = (count.into(), index.into());
            for p in &mut mesh.vertex_properties {
                p.0 = position.into();
            }
            for encoding in Encoding::ALL {
                let path = write(dir.path(), "b.ply", &mesh.bytes(encoding));
                let (scene, _) = load_ply(&path).unwrap();
                let what = format!("{count} {index} {position} {encoding:?}");
                assert_eq!(scene.mesh.positions, reference.positions, "{what}");
                assert_eq!(scene.mesh.triangles, reference.triangles, "{what}");
            }
        }
    }
}

/// A floor plane 200 units wide at y = 0 and the mean of the image looking down at it
/// from 1 unit above: under a uniform sky of radiance 1, a Lambertian
/// plane of albedo a that sees nothing but sky reflects radiance a (∫ a/π cos θ dω = a).
fn plane_radiance(scene: Scene) -> Vec3 {
    let image = render_lit(scene, Vec3::new(0.0, 1.0, 0.5), Vec3::ZERO, 30.0);
    let sum: Vec3 = image.pixels.iter().copied().sum();
    sum / image.pixels.len() as f32
}

fn plane() -> PlyMesh {
    let corners = [
        [-100.0, 0.0, -100.0],
        [-100.0, 0.0, 100.0],
        [100.0, 0.0, 100.0],
        [100.0, 0.0, -100.0],
    ];
    PlyMesh::new(&corners, &[vec![0, 1, 2, 3]])
}

fn assert_radiance(label: &str, got: Vec3, expected: Vec3) {
    // Lambert under a uniform sky: BSDF samples are exact, light samples nearly so.
    let tolerance = 0.01 * expected.max_element().max(0.05);
    assert!(
        (got - expected).abs().max_element() <= tolerance,
        "{label}: radiance {got}, expected {expected}"
    );
}

#[test]
fn a_plane_under_a_white_sky_has_the_radiance_of_its_albedo() {
    let dir = tempfile::tempdir().unwrap();
    let path = write(dir.path(), "plane.ply", &plane().bytes(Encoding::BigEndian));
    let (scene, report) = load_ply(&path).unwrap();
    assert_eq!(report.default_material, Some(0));
    // ember's default diffuse, 0.5 grey.
    assert_radiance("default", plane_radiance(scene), Vec3::splat(0.5));
    // A scene file's colour.
    let toml = "[[obj]]\nfile = \"plane.ply\"\ncolor = [0.2, 0.6, 0.9]\n";
    let file = SceneFile::parse(&dir.path().join("scene.toml"), toml.into()).unwrap();
    let (scene, _) = file.load_scene(&Default::default()).unwrap();
    assert_radiance("color", plane_radiance(scene), Vec3::new(0.2, 0.6, 0.9));
}

#[test]
fn vertex_colours_multiply_the_diffuse_colour() {
    let dir = tempfile::tempdir().unwrap();
    // uchar colours 0-255, over ember's white (the default where vertices have colours).
    let bytes = plane()
        .with_colour("uchar", [255.0, 102.0, 0.0])
        .bytes(Encoding::LittleEndian);
    let path = write(dir.path(), "bytes.ply", &bytes);
    let (scene, report) = load_ply(&path).unwrap();
    assert_eq!(
        report.vertex_colours,
        Some(ember::scene::VertexColours::Bytes)
    );
    assert_radiance("uchar", plane_radiance(scene), Vec3::new(1.0, 0.4, 0.0));
    // float colours 0-1, times a scene file's colour.
    let bytes = plane()
        .with_colour("float", [0.2, 0.4, 0.8])
        .bytes(Encoding::Ascii);
    write(dir.path(), "unit.ply", &bytes);
    let toml = "[[obj]]\nfile = \"unit.ply\"\ncolor = [0.5, 0.5, 1]\n";
    let file = SceneFile::parse(&dir.path().join("scene.toml"), toml.into()).unwrap();
    let (scene, report) = file.load_scene(&Default::default()).unwrap();
    assert_eq!(
        report.vertex_colours,
        Some(ember::scene::VertexColours::Unit)
    );
    assert_radiance("float", plane_radiance(scene), Vec3::new(0.1, 0.2, 0.8));
}

#[test]
fn polygons_of_many_corners_fan_into_their_area() {
    let dir = tempfile::tempdir().unwrap();
    for n in [3usize, 4, 5, 6, 7, 12, 100, 1000] {
        // A regular n-gon of radius 1 in the xz plane, and a concave-free star of it.
        let corners: Vec<[f32; 3]> = (0..n)
            .map(|k| {
                let a = std::f64::consts::TAU * k as f64 / n as f64;
                [a.cos() as f32, 0.0, -(a.sin() as f32)]
            })
            .collect();
        let face: Vec<i64> = (0..n as i64).collect();
        let path = write(
            dir.path(),
            "polygon.ply",
            &PlyMesh::new(&corners, &[face]).bytes(Encoding::Ascii),
        );
        let (scene, report) = load_ply(&path).unwrap();
        assert_eq!(report.triangles, n - 2, "{n} corners");
        let area: f64 = scene
            .mesh
            .triangles
            .iter()
            .map(|t| {
                let [a, b, c] = t.map(|i| scene.mesh.positions[i as usize].as_dvec3());
                0.5 * (b - a).cross(c - a).length()
            })
            .sum();
        let expected = 0.5 * n as f64 * (std::f64::consts::TAU / n as f64).sin();
        assert!(
            (area - expected).abs() < 1e-5 * expected,
            "{n} corners: area {area}, expected {expected}"
        );
    }
}

#[test]
fn normals_and_every_name_of_texture_coordinates_are_read() {
    let dir = tempfile::tempdir().unwrap();
    for [u, v] in [
        ["u", "v"],
        ["s", "t"],
        ["texture_u", "texture_v"],
        ["texture_s", "texture_t"],
    ] {
        let mesh = plane()
            .with("float", "nx", |_| 0.0)
            .with("float", "ny", |_| 1.0)
            .with("float", "nz", |i| i as f64 * 0.25)
            .with("float", u, |i| (i % 2) as f64)
            .with("double", v, |i| i as f64 * 0.5);
        let path = write(dir.path(), "uv.ply", &mesh.bytes(Encoding::BigEndian));
        let (scene, _) = load_ply(&path).unwrap();
        let uvs: Vec<[f32; 2]> = scene.mesh.uvs.iter().map(|t| t.to_array()).collect();
        assert_eq!(
            uvs,
            [[0.0, 0.0], [1.0, 0.5], [0.0, 1.0], [1.0, 1.5]],
            "{u} {v}"
        );
        let nz: Vec<f32> = scene.mesh.normals.iter().map(|n| n.z).collect();
        assert_eq!(nz, [0.0, 0.25, 0.5, 0.75]);
    }
}

#[test]
fn other_elements_and_properties_are_read_past() {
    let dir = tempfile::tempdir().unwrap();
    for encoding in Encoding::ALL {
        let mesh = plane()
            .with("uchar", "alpha", |_| 7.0)
            .with("int", "flags", |i| i as f64);
        // An edge element between the vertices and the faces, as some scanners write.
        let header = mesh.header(encoding).replace(
            "element face",
            "element edge 2\nproperty int vertex1\nproperty list uchar float weights\nelement face",
        );
        let full = mesh.bytes(encoding);
        let body = &full[mesh.header(encoding).len()..];
        let vertices_end = body.len() - face_bytes(encoding);
        let mut bytes = header.into_bytes();
        bytes.extend_from_slice(&body[..vertices_end]);
        for e in 0..2 {
            write_values(
                &mut bytes,
                &[
                    ("int", e as f64),
                    ("uchar", 2.0),
                    ("float", 0.5),
                    ("float", 1.5),
                ],
                encoding,
            );
        }
        bytes.extend_from_slice(&body[vertices_end..]);
        let path = write(dir.path(), "edges.ply", &bytes);
        let (scene, _) = load_ply(&path).unwrap();
        assert_eq!(scene.mesh.triangles.len(), 2, "{encoding:?}");
        assert_eq!(scene.mesh.positions[2], Vec3::new(100.0, 0.0, 100.0));
    }
}

/// The bytes of the plane's one face, `4 0 1 2 3` as uchar and ints.
fn face_bytes(encoding: Encoding) -> usize {
    match encoding {
        Encoding::Ascii => "4 0 1 2 3\n".len(),
        _ => 1 + 4 * 4,
    }
}

#[test]
fn ember_info_shows_a_ply_scene_as_it_shows_an_obj() {
    let dir = tempfile::tempdir().unwrap();
    let bytes = box_on_floor()
        .with_colour("uchar", [255.0, 255.0, 0.0])
        .bytes(Encoding::LittleEndian);
    write(dir.path(), "box.ply", &bytes);
    let out = ember(&["info", "box.ply"], dir.path());
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let text = String::from_utf8_lossy(&out.stdout);
    for line in [
        "box.ply: 14 triangles, 0 materials, 0 emissive triangles, vertex colours (0-255)",
        "triangles: 14 (12 vertices)",
        "\"default\": Lambert, Kd (1,1,1); 14 triangles",
        "sky: uniform white",
        "bounds: (-3, 0, -3) to (3, 2, 3)",
        "vertex colours: written in 0-255",
    ] {
        assert!(text.contains(line), "{line:?} not in {text}");
    }
    // And renders, through the same door.
    let out = ember(
        &[
            "render", "box.ply", "--width", "16", "--height", "16", "--spp", "1", "-o", "box.png",
        ],
        dir.path(),
    );
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(dir.path().join("box.png").exists());
}

/// A header of `elements` (after `ply` and the format line) and then `body`.
fn crafted(format: &str, elements: &str, body: &[u8]) -> Vec<u8> {
    let mut bytes = format!("ply\nformat {format} 1.0\n{elements}end_header\n").into_bytes();
    bytes.extend_from_slice(body);
    bytes
}

const XYZ: &str = "property float x\nproperty float y\nproperty float z\n";
const FACES: &str = "property list uchar int vertex_indices\n";

/// Hostile PLY files: (file name, bytes, what the one error line must say).
fn hostile() -> Vec<(&'static str, Vec<u8>, &'static str)> {
    let tri = |enc: Encoding| {
        PlyMesh::new(
            &[[0.0; 3], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]],
            &[vec![0, 1, 2]],
        )
        .bytes(enc)
    };
    let mut in_faces = tri(Encoding::LittleEndian);
    in_faces.truncate(in_faces.len() - 5);
    let mut in_vertices = tri(Encoding::LittleEndian);
    in_vertices.truncate(in_vertices.len() - 13 - 16);
    let mut long_list = tri(Encoding::BigEndian);
    let at = long_list.len() - 13; // the face's count byte
    long_list[at] = 200;
    let nan = PlyMesh::new(
        &[[0.0; 3], [f32::NAN, 0.0, 0.0], [0.0, 1.0, 0.0]],
        &[vec![0, 1, 2]],
    );
    let inf = PlyMesh::new(
        &[[0.0; 3], [1.0, f32::INFINITY, 0.0], [0.0, 1.0, 0.0]],
        &[vec![0, 1, 2]],
    );
    let out_of_range = PlyMesh::new(
        &[[0.0; 3], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]],
        &[vec![0, 1, 3]],
    );
    let negative = PlyMesh::new(
        &[[0.0; 3], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]],
        &[vec![0, -1, 2]],
    );
    let billion = format!("element vertex 1000000000\n{XYZ}element face 1\n{FACES}");
    let billion_faces = format!("element vertex 3\n{XYZ}element face 1000000000\n{FACES}");
    vec![
        ("billion.ply", crafted("binary_little_endian", &billion, &[0; 64]), "promises 1000000000 vertex elements of at least 12 bytes"),
        ("billion-ascii.ply", crafted("ascii", &billion, b"0 0 0\n"), "promises 1000000000 vertex elements"),
        ("billion-faces.ply", crafted("binary_big_endian", &billion_faces, &[0; 64]), "promises 1000000000 face elements"),
        ("in-faces.ply", in_faces, "face 0 of 1: the file ends in it"),
        ("in-vertices.ply", in_vertices, "promises 3 vertex elements of at least 12 bytes each, but only 20 bytes follow"),
        ("long-list.ply", long_list, "face 0 of 1: the file ends in it"),
        ("short-ascii.ply", crafted("ascii", &format!("element vertex 3\n{XYZ}element face 1\n{FACES}"), b"0 0 0\n1 0 0\n0 1 0              \n"), "face 0 of 1 (line 13): the file ends before it"),
        ("nan.ply", nan.bytes(Encoding::LittleEndian), "vertex 1: its position NaN 0 0 is not finite"),
        ("inf.ply", inf.bytes(Encoding::BigEndian), "vertex 1: its position 1 inf 0 is not finite"),
        ("nan-ascii.ply", crafted("ascii", &format!("element vertex 1\n{XYZ}"), b"nan 0 0\n"), "vertex 0 of 1 (line 8)"),
        ("out-of-range.ply", out_of_range.bytes(Encoding::Ascii), "face 0: vertex index 3 is out of range (there are 3 vertices)"),
        ("negative.ply", negative.bytes(Encoding::LittleEndian), "face 0: vertex index -1 is out of range"),
        ("middle.ply", crafted("binary_middle_endian", "element vertex 0\n", b""), "unknown format \"binary_middle_endian\""),
        ("version.ply", b"ply\nformat ascii 2.0\nend_header\n".to_vec(), "format version 2.0"),
        ("not-ply.ply", b"solid cube\nfacet normal 0 0 1\n".to_vec(), "it does not start with the line `ply`"),
        ("empty.ply", Vec::new(), "it does not start with the line `ply`"),
        ("no-end.ply", b"ply\nformat ascii 1.0\nelement vertex 3\n".to_vec(), "the file ends before `end_header`"),
        ("endless-header.ply", [b"ply\ncomment ".as_slice(), &vec![b'a'; 2 << 20]].concat(), "its header is longer than 1048576 bytes"),
        ("no-vertex.ply", crafted("ascii", "element face 0\nproperty list uchar int vertex_indices\n", b""), "declares no `element vertex`"),
        ("no-z.ply", crafted("ascii", "element vertex 1\nproperty float x\nproperty float y\n", b"0 0\n"), "its vertices have no property z"),
        ("twice.ply", crafted("ascii", &format!("element vertex 1\n{XYZ}property float x\n"), b"0 0 0 0\n"), "declares property \"x\" of element \"vertex\" twice"),
        ("float-indices.ply", crafted("ascii", &format!("element vertex 3\n{XYZ}element face 1\nproperty list uchar float vertex_indices\n"), b"0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n"), "face property vertex_indices is list uchar float"),
        ("no-indices.ply", crafted("ascii", &format!("element vertex 3\n{XYZ}element face 1\nproperty int material\n"), b""), "its faces have no vertex_indices"),
        ("int-colours.ply", crafted("ascii", &format!("element vertex 1\n{XYZ}property int red\nproperty int green\nproperty int blue\n"), b"0 0 0 1 2 3\n"), "its vertex colours are int, int and int"),
        ("bright.ply", PlyMesh::new(&[[0.0; 3], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]], &[vec![0, 1, 2]]).with_colour("float", [2.0, 0.0, 0.0]).bytes(Encoding::Ascii), "vertex 0: its colour 2 0 0 is not in [0, 1]"),
        ("garbage.ply", crafted("ascii", &format!("element vertex 1\n{XYZ}"), b"0 zero 0\n"), "vertex 0 of 1 (line 8)"),
        ("flat.ply", PlyMesh::new(&[[0.0; 3], [1.0, 0.0, 0.0], [2.0, 0.0, 0.0]], &[vec![0, 1, 2]]).bytes(Encoding::Ascii), "has no triangles to render (all 1 triangles are degenerate)"),
        ("points.ply", PlyMesh::new(&[[0.0; 3], [1.0, 0.0, 0.0]], &[vec![0, 1]]).bytes(Encoding::Ascii), "has no triangles to render (it has no faces of three or more corners)"),
        ("binary-text.ply", crafted("ascii", &format!("element vertex 1\n{XYZ}"), &[0xff, 0xfe, 0, 1, b' ', b' ', b'\n']), "vertex 0 of 1 (line 8): the line is not text"),
    ]
}

#[test]
fn hostile_files_are_one_error_line_naming_the_file() {
    let dir = tempfile::tempdir().unwrap();
    for (name, bytes, says) in hostile() {
        write(dir.path(), name, &bytes);
        let small = ["--spp", "1", "--width", "8", "--height", "8"];
        for args in [vec!["info", name], [&["render", name][..], &small].concat()] {
            let out = ember(&args, dir.path());
            let err = String::from_utf8_lossy(&out.stderr);
            assert_eq!(out.status.code(), Some(1), "{name}: {err}");
            assert_eq!(err.lines().count(), 1, "{name}: {err}");
            assert!(
                err.starts_with("error: ") && err.contains(name),
                "{name}: {err}"
            );
            assert!(err.contains(says), "{name}: {says:?} not in {err}");
        }
    }
    let images = std::fs::read_dir(dir.path())
        .unwrap()
        .filter(|e| {
            !e.as_ref()
                .unwrap()
                .file_name()
                .to_string_lossy()
                .ends_with(".ply")
        })
        .count();
    assert_eq!(images, 0, "a refused render left a file");
}

#[test]
fn what_is_not_a_regular_file_or_does_not_fit_in_memory_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    std::os::unix::fs::symlink("/dev/zero", dir.path().join("zero.ply")).unwrap();
    let made = std::process::Command::new("mkfifo")
        .arg(dir.path().join("pipe.ply"))
        .status()
        .unwrap();
    assert!(made.success());
    for (name, says) in [("zero.ply", "character device"), ("pipe.ply", "named pipe")] {
        let out = ember(&["info", name], dir.path());
        let err = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(1), "{err}");
        assert!(
            err.lines().count() == 1 && err.contains(name) && err.contains(says),
            "{err}"
        );
    }
    // 100 000 vertices and faces, honestly in the file, against a 1 MiB budget.
    let n = 100_000;
    let positions: Vec<[f32; 3]> = (0..n).map(|i| [i as f32, (i % 7) as f32, 0.0]).collect();
    let faces: Vec<Vec<i64>> = (0..n as i64)
        .map(|i| vec![i, (i + 1) % n as i64, (i + 2) % n as i64])
        .collect();
    write(
        dir.path(),
        "big.ply",
        &PlyMesh::new(&positions, &faces).bytes(Encoding::LittleEndian),
    );
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_ember"))
        .args(["info", "big.ply"])
        .current_dir(dir.path())
        .env("EMBER_MEMORY_LIMIT", (1 << 20).to_string())
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "{err}");
    assert!(err.contains("big.ply: its 100000 vertices and 100000 faces needs 9.2 MiB of memory, but only 1.0 MiB is available"), "{err}");
}

#[test]
fn a_polygon_fanning_past_the_budget_is_refused_as_it_grows() {
    let dir = tempfile::tempdir().unwrap();
    // One face of 200 000 corners: a header of one face, a body of 200 000 triangles.
    let n = 200_000;
    let positions: Vec<[f32; 3]> = (0..n)
        .map(|i| {
            let a = std::f64::consts::TAU * i as f64 / n as f64;
            [a.cos() as f32, 0.0, a.sin() as f32]
        })
        .collect();
    let mut mesh = PlyMesh::new(&positions, &[(0..n as i64).collect()]);
    mesh.list_types = ("uint".into(), "int".into());
    let path = write(dir.path(), "fan.ply", &mesh.bytes(Encoding::LittleEndian));
    let limit = n as u64 * ember::scene::MEMORY_PER_PLY_VERTEX + (1 << 20);
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_ember"))
        .args(["info", "fan.ply"])
        .current_dir(dir.path())
        .env("EMBER_MEMORY_LIMIT", limit.to_string())
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "{err}");
    assert!(
        err.contains("fan.ply: its faces fanned into 199999 triangles so far needs"),
        "{err}"
    );
    // Within the budget it loads (the thinnest triangles by the first corner have no
    // area in f32 and are dropped).
    let (_, report) = load_ply(&path).unwrap();
    assert_eq!(report.triangles + report.degenerate_dropped, n - 2);
}

#[test]
fn scene_files_check_color_where_it_is_written() {
    let dir = tempfile::tempdir().unwrap();
    write(dir.path(), "plane.ply", &plane().bytes(Encoding::Ascii));
    write(dir.path(), "lit.mtl", b"newmtl white\nKd 1 1 1\n");
    write(
        dir.path(),
        "lit.obj",
        b"mtllib lit.mtl\nusemtl white\nv 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n",
    );
    for (toml, says) in [
        ("[[obj]]\nfile = \"plane.ply\"\ncolor = [0.5, 2, 0]\n", "scene.toml:3:9: obj.color: a diffuse colour: three numbers in [0, 1]"),
        ("[[obj]]\nfile = \"plane.ply\"\ncolor = [0.5, 0.5]\n", "scene.toml:3:"),
        ("[[obj]]\nfile = \"plane.ply\"\nname = \"p\"\n[[instance]]\nobj = \"p\"\ncolor = [1, 1, 1]\n", "scene.toml:6:9: instance.color: an [[instance]] shares its [[obj]]'s mesh and colour"),
        ("[[obj]]\nfile = \"lit.obj\"\ncolor = [1, 0, 0]\n", "lit.obj gives every face a material: color is for faces without one"),
        ("[[obj]]\nfile = \"model.stl\"\n", "model.stl: ember reads OBJ (.obj), glTF 2.0 (.gltf, .glb), PLY (.ply) models, not .stl files"),
    ] {
        write(dir.path(), "scene.toml", toml.as_bytes());
        let out = ember(&["info", "scene.toml"], dir.path());
        let err = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(1), "{toml}: {err}");
        assert_eq!(err.lines().count(), 1, "{err}");
        assert!(err.contains(says), "{says:?} not in {err}");
    }
}
