//! OBJ/MTL files as real exporters write them must load, with the right geometry.

use std::path::Path;

use ember::scene::{load_obj, Material, Model, MtlValues, Scene};
use glam::{Vec2, Vec3};

fn load(files: &[(&str, &[u8])]) -> (Scene, ember::scene::LoadReport) {
    let dir = tempfile::tempdir().unwrap();
    for (name, content) in files {
        std::fs::write(dir.path().join(name), content).unwrap();
    }
    load_obj(&dir.path().join("scene.obj")).expect("loads")
}

#[test]
fn crlf_tabs_trailing_spaces_and_relative_indices() {
    let obj = b"# exporter comment\r\nv\t0 0 0\r\nv  1 0 0  \r\nv 1 1 0\t\r\nv 0 1 0\r\ng quad \r\nf -4 -3 -2 -1   \r\n";
    let (scene, report) = load(&[("scene.obj", obj)]);
    assert_eq!(report.triangles, 2);
    assert_eq!(scene.mesh.positions[2], Vec3::new(1.0, 1.0, 0.0));
    let area: f32 = (0..2).map(|t| scene.mesh.area(t)).sum();
    assert!((area - 1.0).abs() < 1e-6, "quad area {area}");
}

#[test]
fn polygons_of_many_sides_are_triangulated() {
    // A regular 12-gon of circumradius 1: area 3, split into 10 triangles.
    let mut obj = String::new();
    for k in 0..12 {
        let a = k as f32 * std::f32::consts::TAU / 12.0;
        obj += &format!("v {} {} 0\n", a.cos(), a.sin());
    }
    obj += "f 1 2 3 4 5 6 7 8 9 10 11 12\n";
    let (scene, report) = load(&[("scene.obj", obj.as_bytes())]);
    assert_eq!(report.triangles, 10);
    let area: f32 = (0..10).map(|t| scene.mesh.area(t)).sum();
    assert!((area - 3.0).abs() < 1e-5, "{area}");
    // All triangles wind the same way as the polygon (normal +z).
    assert!((0..10).all(|t| scene.mesh.area_normal(t).z > 0.0));
}

#[test]
fn index_forms_with_normals_and_uvs() {
    let obj = b"v 0 0 0\nv 1 0 0\nv 0 1 0\nv 1 1 0\nvt 0 0\nvt 1 0\nvt 0 1\nvn 0 0 1\nvn 0 0 -1\n\
f 1/1/1 2/2/1 3/3/1\nf 2//2 4//2 3//2\nf 1/1 2/2 3/3\n";
    let (scene, report) = load(&[("scene.obj", obj)]);
    assert_eq!(report.triangles, 3);
    // Shading normals keep to the geometric side; the file's -z normals are flipped to +z.
    for prim in 0..3 {
        let hit = ember::accel::Hit {
            t: 1.0,
            prim,
            u: 0.2,
            v: 0.3,
            instance: 0,
        };
        let s = scene.mesh.surface(&hit);
        assert!(
            s.ns.dot(s.ng) > 0.99,
            "prim {prim}: ns {} ng {}",
            s.ns,
            s.ng
        );
    }
    let hit = ember::accel::Hit {
        t: 1.0,
        prim: 0,
        u: 0.25,
        v: 0.5,
        instance: 0,
    };
    let s = scene.mesh.surface(&hit);
    assert!((s.uv - Vec2::new(0.25, 0.5)).length() < 1e-6);
    assert!((s.p - Vec3::new(0.25, 0.5, 0.0)).length() < 1e-6);
}

#[test]
fn non_utf8_bytes_in_comments() {
    let mut obj = b"# caf\xe9 \xff\xfe export\nv 0 0 0\nv 1 0 0\nv 0 1 0\n".to_vec();
    obj.extend_from_slice(b"f 1 2 3 # \x80\x81\n");
    let (_, report) = load(&[("scene.obj", &obj)]);
    assert_eq!(report.triangles, 1);
}

#[test]
fn degenerate_triangles_are_dropped_and_counted() {
    let obj = b"v 0 0 0\nv 1 0 0\nv 0 1 0\nv 2 0 0\nf 1 2 3\nf 1 2 4\nf 1 1 3\n";
    let (scene, report) = load(&[("scene.obj", obj)]);
    assert_eq!(report.degenerate_dropped, 2);
    assert_eq!(scene.mesh.triangles, vec![[0, 1, 2]]);
}

#[test]
fn materials_map_to_bsdfs_and_emitters() {
    let obj = b"mtllib m.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\n\
usemtl wall\nf 1 2 3\nusemtl lamp\nf 1 2 3\nusemtl chrome\nf 1 2 3\nusemtl glass\nf 1 2 3\nusemtl plastic\nf 1 2 3\nusemtl undefined\nf 1 2 3\n";
    let mtl = b"newmtl wall\r\n  Kd 0.5 0.25 0.125\r\nnewmtl lamp\nKd 0.78 0.78 0.78\nKe 17 12 4\n\
newmtl chrome\nKd 0 0 0\nKs 0.9 0.9 0.9\nNs 1000\nillum 3\nnewmtl glass\nNi 1.5\nd 0.1\nillum 7\n\
newmtl plastic\nKd 0.5 0.5 0.5\nKs 0.1 0.1 0.1\nNs 200\n";
    let (scene, report) = load(&[("scene.obj", obj), ("m.mtl", mtl)]);
    assert_eq!(report.triangles, 6);
    let by_tri: Vec<_> = scene
        .mesh
        .material
        .iter()
        .map(|&m| &scene.materials[m as usize])
        .collect();
    assert_eq!(by_tri[0].model, Model::Lambert);
    assert_eq!(by_tri[0].diffuse, Vec3::new(0.5, 0.25, 0.125));
    assert_eq!(by_tri[1].emission, Vec3::new(17.0, 12.0, 4.0));
    assert_eq!(scene.emitters, vec![1]);
    let alpha_1000 = (2.0f32 / 1002.0).sqrt();
    assert_eq!(by_tri[2].model, Model::Conductor { alpha: alpha_1000 });
    assert_eq!(by_tri[3].model, Model::Glass { ior: 1.5 });
    assert_eq!(
        by_tri[4].model,
        Model::Coated {
            alpha: (2.0f32 / 202.0).sqrt()
        }
    );
    // `d` < 1 is opacity (a cut-out), not glass; the other materials are opaque.
    assert_eq!(by_tri[3].opacity, 0.1);
    assert!(by_tri.iter().filter(|m| !m.is_opaque()).count() == 1);
    // The undefined material is one warning, naming the OBJ's line and the name.
    let [warning] = report.warnings.as_slice() else {
        panic!("{:?}", report.warnings);
    };
    assert!(
        warning.contains("scene.obj:15: usemtl \"undefined\""),
        "{warning}"
    );
    assert_eq!(by_tri[5].name, "default");
}

#[test]
fn textures_are_read_as_srgb_and_looked_up_by_uv() {
    let dir = tempfile::tempdir().unwrap();
    // 2x1 image: left texel sRGB 188 (≈ 0.5 linear), right texel black.
    let img = image::RgbImage::from_raw(2, 1, vec![188, 188, 188, 0, 0, 0]).unwrap();
    img.save(dir.path().join("t.png")).unwrap();
    std::fs::write(
        dir.path().join("m.mtl"),
        "newmtl t\nKd 1 1 1\nmap_Kd t.png\n",
    )
    .unwrap();
    std::fs::write(
        dir.path().join("scene.obj"),
        "mtllib m.mtl\nusemtl t\nv 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0.25 0.5\nvt 0.25 0.5\nvt 0.25 0.5\nf 1/1 2/2 3/3\n",
    )
    .unwrap();
    let (scene, _) = load_obj(&dir.path().join("scene.obj")).unwrap();
    let hit = ember::accel::Hit {
        t: 1.0,
        prim: 0,
        u: 0.3,
        v: 0.3,
        instance: 0,
    };
    let albedo = scene.albedo(&scene.mesh.surface(&hit));
    assert!((albedo.x - 0.5029).abs() < 2e-3, "{albedo}");
}

#[test]
fn the_bundled_cornell_box() {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("meshes/CornellBox-Original.obj");
    let (scene, report) = load_obj(&path).unwrap();
    // ../shared/meshes/PROVENANCE.md: 72 vertices, quads split into 36 triangles, 8
    // materials. (tobj keeps only the vertices that faces use.)
    assert_eq!((report.triangles, report.materials), (36, 8));
    assert!(report.vertices <= 72);
    assert_eq!(scene.emitters.len(), 2);
    let (lo, hi) = scene.bounds();
    assert!((lo - Vec3::new(-1.02, 0.0, -1.04)).length() < 1e-5);
    assert!((hi - Vec3::new(1.0, 1.99, 0.99)).length() < 1e-5);
    for &t in &scene.emitters {
        let n = scene.mesh.area_normal(t).normalize();
        assert!(n.y < -0.999, "the light faces down, got {n}");
        assert!(scene
            .mesh
            .vertices(t)
            .iter()
            .all(|v| (v.y - 1.98).abs() < 1e-6));
    }
    let light_area: f32 = scene.emitters.iter().map(|&t| scene.mesh.area(t)).sum();
    assert!((light_area - 0.47 * 0.38).abs() < 1e-3, "{light_area}");
}

/// The MTL mapping table of the README, row by row: the first rule that applies.
#[test]
fn mtl_mapping_takes_the_first_rule_that_applies() {
    let grey = Some(Vec3::splat(0.5));
    let alpha = |ns: f32| (2.0 / (ns + 2.0)).sqrt();
    let model =
        |values: MtlValues, texture: Option<u32>| Material::from_mtl("m", &values, texture).model;
    let mtl = |kd, ks, ns, ni, illum| MtlValues {
        kd,
        ks,
        ns,
        ni,
        illum,
        ..MtlValues::default()
    };
    // Rule 1: illum 4, 6, 7, 9 is glass whatever else is set; Ni ≤ 1 or absent is 1.5.
    for illum in [4, 6, 7, 9] {
        assert_eq!(
            model(mtl(grey, grey, Some(10.0), Some(2.5), Some(illum)), None),
            Model::Glass { ior: 2.5 }
        );
    }
    assert_eq!(
        model(mtl(grey, None, None, Some(0.8), Some(7)), None),
        Model::Glass { ior: 1.5 }
    );
    assert_eq!(
        model(mtl(None, None, None, None, Some(4)), None),
        Model::Glass { ior: 1.5 }
    );
    // Rule 2: illum 3 or 5, or Ks > 0 with Kd = 0 and no map_Kd; Ns absent is 0.
    for illum in [3, 5] {
        assert_eq!(
            model(mtl(grey, grey, Some(98.0), None, Some(illum)), None),
            Model::Conductor { alpha: alpha(98.0) }
        );
    }
    assert_eq!(
        model(mtl(None, grey, None, None, Some(2)), None),
        Model::Conductor { alpha: 1.0 }
    );
    // Rule 3: Kd (or map_Kd) and Ks.
    assert_eq!(
        model(mtl(grey, grey, Some(20.0), None, None), None),
        Model::Coated { alpha: alpha(20.0) }
    );
    assert_eq!(
        model(mtl(None, grey, Some(20.0), None, Some(2)), Some(0)),
        Model::Coated { alpha: alpha(20.0) }
    );
    // Rule 4: everything else.
    assert_eq!(
        model(mtl(grey, None, None, None, None), None),
        Model::Lambert
    );
    assert_eq!(
        model(mtl(None, None, None, None, Some(2)), None),
        Model::Lambert
    );
    // Colours are clamped to [0, 1]: nothing reflects more than it receives.
    let bright = Material::from_mtl(
        "b",
        &mtl(
            Some(Vec3::splat(3.0)),
            Some(Vec3::new(-1.0, 2.0, 0.5)),
            None,
            None,
            None,
        ),
        None,
    );
    assert_eq!(bright.diffuse, Vec3::ONE);
    assert_eq!(bright.specular, Vec3::new(0.0, 1.0, 0.5));
}
