//! The parallel OBJ reader against its oracle, tobj: on every mesh shipped with ember
//! and on hand-made edge cases it must either decline (and leave the file to tobj) or
//! read exactly what tobj reads. The fuzz test (`tests/fuzz_obj.rs`) checks the same
//! on generated input.

use std::collections::HashMap;
use std::path::Path;

use ember::scene::check_against_tobj;

fn shipped(name: &str) -> (String, HashMap<String, String>) {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("meshes");
    let obj = std::fs::read_to_string(dir.join(format!("{name}.obj"))).unwrap();
    let mtl_name = format!("{name}.mtl");
    let mtl = std::fs::read_to_string(dir.join(&mtl_name)).unwrap();
    (obj, HashMap::from([(mtl_name, mtl)]))
}

#[test]
fn shipped_meshes_read_as_tobj_reads_them() {
    for name in [
        "CornellBox-Original",
        "CornellBox-GlossyMix",
        "CornellBox-Sphere",
        "many-lights",
        "small-light",
    ] {
        let (obj, mtl) = shipped(name);
        let read = check_against_tobj(&obj, &mtl).unwrap_or_else(|e| panic!("{name}: {e}"));
        assert!(read, "{name}: the parallel reader declined it");
    }
}

/// A mesh with every kind of corner, relative indices, polygons, groups and material
/// switches, some to unknown materials.
const EDGE_CASES: &str = "\
mtllib m.mtl
# a comment, and one after a statement below
v 0 0 0
v 1 0 0 # trailing comment
v 1 1 0
v 0 1 0
vt 0 0
vt 1 0 0.5
vt 1 1
vn 0 0 1
vn 0 0 -1
o first
usemtl red
f 1 2 3
f -4 -3 -2 -1
f 1/1 2/2 3/3
f 1//1 2//2 3//1
f 1/1/1 2/2/2 3/3/1 4/1/2
usemtl nowhere
f 1 2 3 4 1 2
g second group
s off
 usemtl red
vp 1 2 3
f 3 2 1
usemtl blue
f 4/3 3/2 2/1
usemtl Material #25
o
f 1 3 4
usemtl red # not a comment: part of the name
f 1 2 4
\tf\t2  3\t4\r
usemtl red
v 5 5 5
\u{a0}v 6 5 5
v\u{0b}5 6 5
f -1 -2 -3
";

#[test]
fn edge_cases_read_as_tobj_reads_them() {
    let mtl = HashMap::from([(
        "m.mtl".to_owned(),
        "newmtl red\nKd 1 0 0\nnewmtl blue\nKd 0 0 1\nnewmtl Material #25\nKd 0 1 0\n".to_owned(),
    )]);
    // The whole text, and every prefix ending at a line end (each a file of its own).
    for (end, _) in EDGE_CASES.match_indices('\n') {
        let text = &EDGE_CASES[..=end];
        let read = check_against_tobj(text, &mtl).unwrap_or_else(|e| panic!("{e} in:\n{text}"));
        assert!(read, "declined:\n{text}");
    }
    // With the material library missing.
    assert_eq!(check_against_tobj(EDGE_CASES, &HashMap::new()), Ok(true));
}

/// What the reader leaves to tobj (and to ember's checks before it), so that their
/// errors and quirks stay as they were.
#[test]
fn unusual_statements_and_errors_are_left_to_tobj() {
    let head = "v 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0\nvn 0 0 1\n";
    for tail in [
        "f 1 2\n",
        "l 1 2 3\n",
        "p 1\n",
        "f 0 1 2\n",
        "f 1 2 4\n",
        "f 1 2 -4\n",
        "f 1/2 2 3\n",
        "f 1//2 2 3\n",
        "f 1/1/1/1 2 3\n",
        "f 1 2 x\n",
        "f 1 2 3 \\\n",
        "f 1 2 3\nv 1 1 1\nf 1 2 5\n",
        "v 1 2\n",
        "v#1 2 3\n",
        "v 1 2 3 4\n",
        "v 1 2 3 0.5 0.5 0.5\n",
        "vt 1\n",
        "vn 1 x 0\n",
        "usemtl\n",
        "mtllib\n",
    ] {
        let text = format!("{head}{tail}f 1 2 3\n");
        assert_eq!(
            check_against_tobj(&text, &HashMap::new()),
            Ok(false),
            "{tail}"
        );
    }
}

/// Vertex colours on every vertex are read here, as tobj reads them; on some vertices
/// only, they are left to tobj (where ember gives the others white first).
#[test]
fn vertex_colours_read_as_tobj_reads_them() {
    let coloured = "v 0 0 0 1 0 0\nv 1 0 0 0 1 0\nv 0 1 0 0 0 255\nvt 0 0\n\
                    f 1/1 2/1 3/1\nv 1 1 0 0.5 0.5 0.5 # grey\nf -1 -2 -3\n";
    assert_eq!(check_against_tobj(coloured, &HashMap::new()), Ok(true));
    let mixed = "v 0 0 0 1 0 0\nv 1 0 0\nv 0 1 0 0 0 1\nf 1 2 3\n";
    assert_eq!(check_against_tobj(mixed, &HashMap::new()), Ok(false));
}

/// Large enough to be cut into several chunks, with relative indices reaching across
/// chunk boundaries and models spanning them.
#[test]
fn chunked_text_reads_as_tobj_reads_it() {
    let mut obj = String::from("mtllib m.mtl\n");
    for i in 0..60_000 {
        let x = i as f32 * 0.001;
        obj += &format!("v {x} {} 0.25\nvt {x} 0.5\nvn 0 0 1\n", x * x);
        if i >= 2 {
            obj += match i % 5 {
                0 => "f -3 -2 -1\n",
                1 => "f -1/-1/-1 -2/-2/-2 -3/-3/-3\n",
                2 => "f 1 -1 -2\n",
                3 => "usemtl red\nf -2//-2 -1//-1 -3//-3\n",
                _ => "g g\nusemtl blue\nf -1/-2 -2/-3 -3/-1\n",
            };
        }
    }
    assert!(obj.len() > 3 << 20, "{} bytes", obj.len());
    let mtl = HashMap::from([(
        "m.mtl".to_owned(),
        "newmtl red\nKd 1 0 0\nnewmtl blue\nKd 0 0 1\n".to_owned(),
    )]);
    assert_eq!(check_against_tobj(&obj, &mtl), Ok(true));
}
