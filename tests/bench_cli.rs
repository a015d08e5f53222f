//! `ember bench` end to end: a small run on the Cornell box must print one JSON document
//! with a result for every backend, mode and thread count, and write the same document
//! to `--json-out`; bad input must fail with one error line.

use std::path::Path;
use std::process::Command;

use serde_json::Value;

fn ember() -> Command {
    Command::new(env!("CARGO_BIN_EXE_ember"))
}

fn cornell() -> String {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("meshes/CornellBox-Original.obj")
        .display()
        .to_string()
}

#[test]
fn json_document_has_every_measurement() {
    let dir = tempfile::tempdir().unwrap();
    let out_file = dir.path().join("bench.json");
    let out = ember()
        .args(["bench", &cornell(), "--procedural", "sphere:2k"])
        .args(["--rays", "2000", "--threads", "1,2", "--min-time", "0"])
        .arg("--json")
        .arg("--json-out")
        .arg(&out_file)
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let doc: Value = serde_json::from_slice(&out.stdout).expect("stdout is one JSON document");
    let written: Value = serde_json::from_slice(&std::fs::read(&out_file).unwrap()).unwrap();
    assert_eq!(doc, written);

    // The OBJ's reading is timed (the procedural mesh is not read from a file).
    let loading = doc["loading"].as_array().expect("loading array");
    assert_eq!(loading.len(), 1, "{loading:?}");
    let obj_bytes = std::fs::metadata(cornell()).unwrap().len();
    assert_eq!(loading[0]["mesh"], "CornellBox-Original.obj");
    assert_eq!(loading[0]["file_bytes"].as_u64(), Some(obj_bytes));
    let seconds = loading[0]["seconds"].as_f64().unwrap();
    let rate = loading[0]["mb_per_s"].as_f64().unwrap();
    assert!(seconds > 0.0 && (rate * seconds * 1e6 - obj_bytes as f64).abs() < 1.0);

    let results = doc["results"].as_array().expect("results array");
    for r in results {
        let backend = r["backend"].as_str().unwrap();
        let mode = r["mode"].as_str().unwrap();
        assert!(r["threads"].as_u64().unwrap() >= 1);
        assert!(r["triangles"].as_u64().unwrap() > 0);
        assert!(r["memory_bytes"].as_u64().unwrap() > 0, "{r}");
        assert!(["single", "packet8", "direct"].contains(&r["api"].as_str().unwrap()));
        if mode == "build" {
            assert!(r["build_ms"].as_f64().unwrap() >= 0.0);
        } else {
            assert!(r["mrays_per_s"].as_f64().unwrap() > 0.0, "{r}");
            let (rays, hits) = (r["rays"].as_u64().unwrap(), r["hits"].as_u64().unwrap());
            assert!(hits <= rays);
        }
        assert!(!backend.is_empty());
    }
    let has = |mesh: &str, backend: &str, mode: &str, threads: u64| {
        results.iter().any(|r| {
            r["mesh"] == mesh
                && r["backend"] == backend
                && r["mode"] == mode
                && r["threads"] == threads
        })
    };
    for mesh in ["CornellBox-Original.obj", "sphere:2000"] {
        for backend in ["embree", "bvh"] {
            for mode in ["build", "primary", "diffuse", "shadow"] {
                for threads in [1, 2] {
                    assert!(
                        has(mesh, backend, mode, threads),
                        "{mesh} {backend} {mode} {threads}"
                    );
                }
            }
        }
    }
    // Embree builds at three qualities, and its packet API is measured too.
    let qualities: Vec<&str> = results
        .iter()
        .filter(|r| r["backend"] == "embree" && r["mode"] == "build")
        .filter_map(|r| r["quality"].as_str())
        .collect();
    for q in ["low", "medium", "high"] {
        assert!(qualities.contains(&q));
    }
    assert!(results
        .iter()
        .any(|r| r["api"] == "packet8" && r["mode"] == "diffuse"));
    // The same rays hit the same number of times in every backend (the Cornell box is
    // closed on five sides, so almost all primary rays hit).
    let hits = |backend: &str| {
        results
            .iter()
            .find(|r| {
                r["mesh"] == "CornellBox-Original.obj"
                    && r["backend"] == backend
                    && r["mode"] == "primary"
                    && r["api"] == "single"
            })
            .map(|r| r["hits"].as_u64().unwrap())
            .unwrap()
    };
    assert_eq!(hits("embree"), hits("bvh"));
    assert!(hits("bvh") > 1000);
}

#[test]
fn missing_mesh_is_one_error_line() {
    let out = ember()
        .args(["bench", "/nonexistent/mesh.obj"])
        .output()
        .unwrap();
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(err.trim_end().lines().count(), 1, "{err}");
    assert!(err.starts_with("error:"), "{err}");
    assert!(out.stdout.is_empty());
}

#[test]
fn bad_procedural_spec_and_nothing_to_do_are_errors() {
    for args in [&["bench", "--procedural", "cube:10"][..], &["bench"][..]] {
        let out = ember().args(args).output().unwrap();
        assert!(!out.status.success());
        let err = String::from_utf8_lossy(&out.stderr);
        assert_eq!(err.trim_end().lines().count(), 1, "{err}");
        assert!(err.starts_with("error"), "{err}");
    }
}
