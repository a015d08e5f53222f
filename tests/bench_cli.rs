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
        .arg("--plot")
        .arg(dir.path().join("bench.svg"))
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

    // The machine the figures come from, as the table's header names it.
    let machine = &doc["machine"];
    assert!(!machine["cpu"].as_str().unwrap().is_empty(), "{machine}");
    assert!(!machine["isa"].as_str().unwrap().is_empty(), "{machine}");
    assert!(machine["hardware_threads"].as_u64().unwrap() >= 1);
    let embree = doc["embree_version"].as_str().unwrap();
    assert!(
        embree.starts_with('3') || embree.starts_with('4'),
        "{embree}"
    );
    assert_eq!(machine["embree_version"], embree);
    assert!(doc["baselines"]["traversal"]
        .as_str()
        .unwrap()
        .contains("Embree single"));
    // The table (on stderr with --json) names the same machine, and has its legend.
    let table = String::from_utf8_lossy(&out.stderr);
    assert!(table.contains(machine["cpu"].as_str().unwrap()), "{table}");
    assert!(table.contains(&format!("Embree {embree}")), "{table}");
    assert!(
        table.contains("Legend:") && table.contains("embree single (base)"),
        "{table}"
    );

    // The chart: one panel per mesh, a bar per backend and API, in one SVG document.
    let svg = std::fs::read_to_string(dir.path().join("bench.svg")).unwrap();
    assert!(svg.starts_with("<svg") && svg.trim_end().ends_with("</svg>"));
    for text in [
        "CornellBox-Original.obj",
        "sphere:2000",
        "embree packet8",
        "embree packet16",
        "bvh single",
    ] {
        assert!(svg.contains(text), "the chart has no {text:?}");
    }

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
        assert!(["single", "packet8", "packet16", "direct"].contains(&r["api"].as_str().unwrap()));
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
    for api in ["packet8", "packet16"] {
        assert!(results
            .iter()
            .any(|r| r["api"] == api && r["mode"] == "diffuse"));
    }
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

    // Each ratio is the row's rate over Embree single's on the same rays and threads.
    for r in results.iter().filter(|r| r["mode"] == "primary") {
        let base = results
            .iter()
            .find(|b| {
                b["mesh"] == r["mesh"]
                    && b["backend"] == "embree"
                    && b["api"] == "single"
                    && b["mode"] == "primary"
                    && b["threads"] == r["threads"]
            })
            .unwrap();
        let want = r["mrays_per_s"].as_f64().unwrap() / base["mrays_per_s"].as_f64().unwrap();
        let got = r["vs_embree"].as_f64().unwrap();
        assert!((got - want).abs() < 1e-9 * want, "{r}");
    }
}

#[test]
fn unwritable_plot_is_refused_before_measuring() {
    for (path, what) in [
        ("/nonexistent-dir/chart.svg", "nonexistent-dir"),
        ("/tmp/chart.png", "svg"),
    ] {
        let out = ember()
            .args(["bench", "--procedural", "sphere:100000", "--plot", path])
            .output()
            .unwrap();
        assert!(!out.status.success());
        let err = String::from_utf8_lossy(&out.stderr);
        assert_eq!(err.trim_end().lines().count(), 1, "{err}");
        assert!(err.starts_with("error:") && err.contains(what), "{err}");
        assert!(out.stdout.is_empty());
    }
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
    // A bad flag value is clap's error, with its usage line; nothing to do is ember's.
    let out = ember()
        .args(["bench", "--procedural", "cube:10"])
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(2));
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.starts_with("error: invalid value 'cube:10'"), "{err}");
    assert!(err.contains("--help"), "{err}");
    let out = ember().args(["bench"]).output().unwrap();
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(err.trim_end().lines().count(), 1, "{err}");
    assert!(err.starts_with("error: nothing to benchmark"), "{err}");
}
