//! The `ember` command under hostile conditions: signals during a render, checkpoints
//! and resuming, inputs too large for memory, and Embree failures. (Malformed scenes
//! and bad flags are in `cli_bad_input.rs`.)

use std::io::{BufRead, BufReader, Read};
use std::path::{Path, PathBuf};
use std::process::{Command, Output, Stdio};

use ember::image::Image;

const EMBER: &str = env!("CARGO_BIN_EXE_ember");

fn cornell() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("meshes/CornellBox-Original.obj")
}

fn ember(args: &[&str], env: &[(&str, &str)]) -> Output {
    let mut cmd = Command::new(EMBER);
    cmd.args(args);
    for (k, v) in env {
        cmd.env(k, v);
    }
    cmd.output().expect("ember runs")
}

fn stderr(out: &Output) -> String {
    String::from_utf8_lossy(&out.stderr).into_owned()
}

/// The last line of stderr, which must be the one-line error.
fn error_line(out: &Output) -> String {
    assert!(!out.status.success(), "expected failure: {}", stderr(out));
    let text = stderr(out);
    let last = text.lines().last().unwrap_or("").to_owned();
    assert!(last.starts_with("error: "), "{text}");
    last
}

fn leftovers(dir: &Path) -> Vec<String> {
    std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .filter(|n| n.ends_with(".tmp") || n.starts_with(".ember"))
        .collect()
}

/// Starts a render that cannot finish soon, waits until it says it is rendering (the
/// signal handlers are in place by then), sends `signal` with the `kill` command and
/// returns the exit status and stderr.
fn interrupt(dir: &Path, signal: &str) -> (Option<i32>, String) {
    let out = dir.join("out.png");
    let mut child = Command::new(EMBER)
        .args(["render", cornell().to_str().unwrap(), "-o"])
        .arg(&out)
        .args(["--width", "24", "--height", "20", "--spp", "1000000"])
        .args(["--threads", "1"])
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let mut err = BufReader::new(child.stderr.take().unwrap());
    let mut text = String::new();
    loop {
        let mut line = String::new();
        assert!(
            err.read_line(&mut line).unwrap() > 0,
            "ember ended early: {text}"
        );
        text.push_str(&line);
        if line.starts_with("rendering") {
            break;
        }
    }
    // Give the workers a moment to take some samples (the test holds whether or not
    // they did: a partial image may be black).
    std::thread::sleep(std::time::Duration::from_millis(300));
    let killed = Command::new("kill")
        .args([signal, &child.id().to_string()])
        .status()
        .unwrap();
    assert!(killed.success());
    err.read_to_string(&mut text).unwrap();
    let status = child.wait().unwrap();
    (status.code(), text)
}

fn check_partial(dir: &Path, code: Option<i32>, expected: i32, text: &str) {
    assert_eq!(code, Some(expected), "{text}");
    assert!(text.contains("out.partial.png"), "{text}");
    // The finished name is not used for a partial image.
    assert!(!dir.join("out.png").exists());
    let partial = Image::load(&dir.join("out.partial.png")).unwrap();
    assert_eq!((partial.width, partial.height), (24, 20));
    // Whole: every pixel decoded, none NaN.
    assert_eq!(partial.pixels.len(), 24 * 20);
    assert!(partial.pixels.iter().all(|p| p.is_finite()));
    assert!(dir.join("out.png.checkpoint").is_file());
    assert_eq!(leftovers(dir), Vec::<String>::new());
}

#[test]
fn sigint_writes_the_partial_image_and_exits_130() {
    let dir = tempfile::tempdir().unwrap();
    let (code, text) = interrupt(dir.path(), "-INT");
    check_partial(dir.path(), code, 130, &text);
    assert!(text.contains("interrupted by SIGINT"), "{text}");
}

#[test]
fn sigterm_writes_the_partial_image_and_exits_143() {
    let dir = tempfile::tempdir().unwrap();
    let (code, text) = interrupt(dir.path(), "-TERM");
    check_partial(dir.path(), code, 143, &text);
    assert!(text.contains("interrupted by SIGTERM"), "{text}");
}

fn render_args<'a>(out: &'a str, spp: &'a str) -> Vec<&'a str> {
    vec![
        "render", "--width", "20", "--height", "18", "--spp", spp, "--seed", "7", "-o", out,
    ]
}

#[test]
fn resuming_a_checkpoint_equals_an_uninterrupted_render_bit_for_bit() {
    let dir = tempfile::tempdir().unwrap();
    let scene = cornell();
    let scene = scene.to_str().unwrap();
    let p = |n: &str| dir.path().join(n).to_str().unwrap().to_owned();
    let (first, resumed, direct, ckpt) = (
        p("first.exr"),
        p("resumed.exr"),
        p("direct.exr"),
        p("c.ckpt"),
    );

    let mut args = render_args(&first, "3");
    args.extend([scene, "--checkpoint-every", "1000", "--checkpoint", &ckpt]);
    assert!(ember(&args, &[]).status.success());
    // With --checkpoint-every the resumed render keeps its final checkpoint (a later
    // --resume refines it) and says where it is.
    let mut args = render_args(&resumed, "8");
    args.extend([
        scene,
        "--resume",
        "--checkpoint",
        &ckpt,
        "--checkpoint-every",
        "1000",
    ]);
    let out = ember(&args, &[]);
    assert!(out.status.success(), "{}", stderr(&out));
    assert!(stderr(&out).contains("resuming from 3 spp"));
    assert!(
        stderr(&out).contains(&format!("kept the checkpoint {ckpt}")),
        "{}",
        stderr(&out)
    );
    let mut args = render_args(&direct, "8");
    args.push(scene);
    assert!(ember(&args, &[]).status.success());

    let (a, b) = (
        Image::load(resumed.as_ref()).unwrap(),
        Image::load(direct.as_ref()).unwrap(),
    );
    let bits = |f: &Image| {
        f.pixels
            .iter()
            .flat_map(|p| p.to_array().map(f32::to_bits))
            .collect::<Vec<_>>()
    };
    assert_eq!(bits(&a), bits(&b));
    assert_eq!(
        std::fs::read(&resumed).unwrap(),
        std::fs::read(&direct).unwrap()
    );
    assert_ne!(bits(&a), bits(&Image::load(first.as_ref()).unwrap()));

    // Mismatched settings are refused, naming the setting.
    let mut args = render_args(&resumed, "8");
    args.extend([scene, "--resume", "--checkpoint", &ckpt, "--fov", "50"]);
    let line = error_line(&ember(&args, &[]));
    assert!(
        line.contains("fov 40.0") && line.contains("fov 50.0"),
        "{line}"
    );
    // A checkpoint past the requested samples cannot be continued to fewer.
    let mut args = render_args(&resumed, "2");
    args.extend([scene, "--resume", "--checkpoint", &ckpt]);
    let line = error_line(&ember(&args, &[]));
    assert!(line.contains("already has 8 samples per pixel"), "{line}");
    // A damaged checkpoint is refused.
    let mut bytes = std::fs::read(&ckpt).unwrap();
    bytes.truncate(bytes.len() - 100);
    std::fs::write(&ckpt, bytes).unwrap();
    let mut args = render_args(&resumed, "9");
    args.extend([scene, "--resume", "--checkpoint", &ckpt]);
    let line = error_line(&ember(&args, &[]));
    assert!(line.contains("not a valid ember checkpoint"), "{line}");
    assert_eq!(leftovers(dir.path()), Vec::<String>::new());
}

#[test]
fn a_finished_resume_removes_its_checkpoint_and_partial_image() {
    let dir = tempfile::tempdir().unwrap();
    let scene = cornell();
    let scene = scene.to_str().unwrap();
    let p = |n: &str| dir.path().join(n).to_str().unwrap().to_owned();
    let (out, partial, ckpt) = (p("out.exr"), p("out.partial.exr"), p("out.exr.checkpoint"));
    let mut args = render_args(&out, "3");
    args.extend([scene, "--checkpoint-every", "1000"]);
    assert!(ember(&args, &[]).status.success());
    assert!(Path::new(&ckpt).is_file());
    // What an interrupted render leaves beside the checkpoint.
    std::fs::copy(&out, &partial).unwrap();
    std::fs::remove_file(&out).unwrap();
    let mut args = render_args(&out, "8");
    args.extend([scene, "--resume"]);
    let run = ember(&args, &[]);
    assert!(run.status.success(), "{}", stderr(&run));
    assert!(Path::new(&out).is_file());
    assert!(!Path::new(&partial).exists(), "the partial image is left");
    assert!(!Path::new(&ckpt).exists(), "the checkpoint is left");
    assert_eq!(leftovers(dir.path()), Vec::<String>::new());
}

#[test]
fn resume_without_a_checkpoint_is_refused_before_loading() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("x.png");
    let line = error_line(&ember(
        &[
            "render",
            cornell().to_str().unwrap(),
            "--resume",
            "-o",
            out.to_str().unwrap(),
        ],
        &[],
    ));
    assert!(
        line.contains("no checkpoint") && line.contains("x.png.checkpoint"),
        "{line}"
    );
}

#[test]
fn an_obj_larger_than_memory_is_refused_before_reading() {
    let dir = tempfile::tempdir().unwrap();
    let huge = dir.path().join("huge.obj");
    let file = std::fs::File::create(&huge).unwrap();
    // A sparse terabyte: nothing is written, and ember must not try to read it. A file
    // system without sparse files gets 16 MiB of zeros and a budget to match.
    let (size, budget, budget_text) = match file.set_len(1 << 40) {
        Ok(()) => ("1.0 TiB", "8589934592", "8.0 GiB"),
        Err(_) => {
            file.set_len(16 << 20).unwrap();
            ("16.0 MiB", "67108864", "64.0 MiB")
        }
    };
    let out = dir.path().join("o.png");
    let line = error_line(&ember(
        &[
            "render",
            huge.to_str().unwrap(),
            "--width",
            "4",
            "--height",
            "4",
            "-o",
            out.to_str().unwrap(),
        ],
        &[("EMBER_MEMORY_LIMIT", budget)],
    ));
    assert!(line.contains("huge.obj") && line.contains(size), "{line}");
    assert!(
        line.contains(&format!("{budget_text} is available")),
        "{line}"
    );

    // The same check with a small file and a small budget.
    let line = error_line(&ember(
        &[
            "render",
            cornell().to_str().unwrap(),
            "--width",
            "4",
            "--height",
            "4",
            "-o",
            out.to_str().unwrap(),
        ],
        &[("EMBER_MEMORY_LIMIT", "10000")],
    ));
    assert!(
        line.contains("CornellBox-Original.obj") && line.contains("9.8 KiB"),
        "{line}"
    );
}

#[test]
fn an_image_larger_than_memory_is_refused_before_any_work() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("o.png");
    let line = error_line(&ember(
        &[
            "render",
            "/nonexistent.obj",
            "--width",
            "16384",
            "--height",
            "16384",
            "-o",
            out.to_str().unwrap(),
        ],
        &[("EMBER_MEMORY_LIMIT", "1073741824")],
    ));
    // Refused on the image alone: the missing scene is not even looked at.
    assert!(
        line.contains("a 16384x16384 image needs") && line.contains("1.0 GiB"),
        "{line}"
    );
}

#[test]
fn a_device_configuration_embree_rejects_is_one_error_line() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("o.png");
    let line = error_line(&ember(
        &[
            "render",
            cornell().to_str().unwrap(),
            "-o",
            out.to_str().unwrap(),
        ],
        &[("EMBER_EMBREE_CONFIG", "threads=abc")],
    ));
    assert!(
        line.contains("Embree") && line.contains("threads=abc"),
        "{line}"
    );
    assert!(!out.exists());
}

#[test]
fn embree_running_out_of_memory_is_one_error_line() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("o.png");
    let line = error_line(&ember(
        &[
            "render",
            cornell().to_str().unwrap(),
            "-o",
            out.to_str().unwrap(),
        ],
        &[("EMBER_EMBREE_MEMORY_LIMIT", "2000")],
    ));
    // 2000 bytes hold the Cornell box's buffers but not its BVH: Embree's own build
    // fails when the memory monitor refuses, and says so.
    assert!(
        line.contains("out of memory") && line.contains("2000 bytes"),
        "{line}"
    );
    assert!(line.contains("memory monitor"), "{line}");
    assert!(!out.exists());
}

#[test]
fn a_memory_limit_that_is_not_a_number_is_an_error() {
    for var in ["EMBER_MEMORY_LIMIT", "EMBER_EMBREE_MEMORY_LIMIT"] {
        let line = error_line(&ember(
            &[
                "render",
                cornell().to_str().unwrap(),
                "-o",
                "/tmp/never-written.png",
            ],
            &[(var, "lots")],
        ));
        assert!(
            line.contains(var) && line.contains("whole number of bytes"),
            "{line}"
        );
    }
}

#[test]
fn a_texture_larger_than_memory_is_refused_naming_its_size() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    std::fs::write(
        d.join("t.obj"),
        "mtllib t.mtl\nusemtl m\nv 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0\nf 1/1 2/1 3/1\n",
    )
    .unwrap();
    std::fs::write(d.join("t.mtl"), "newmtl m\nKd 1 1 1\nmap_Kd big.png\n").unwrap();
    image::RgbImage::new(2000, 1500)
        .save(d.join("big.png"))
        .unwrap();
    let out = d.join("o.png");
    let line = error_line(&ember(
        &[
            "render",
            d.join("t.obj").to_str().unwrap(),
            "--width",
            "8",
            "--height",
            "8",
            "-o",
            out.to_str().unwrap(),
        ],
        // Room for the scene and the image, not for the decoded texture (9 MB), the
        // decoder's working copy and allowance (9 MB and 4 MiB) and its copy at the
        // 12 bytes per texel of a floating-point one (36 MB): 55.5 MiB.
        &[("EMBER_MEMORY_LIMIT", "20000000")],
    ));
    assert!(
        line.contains("big.png") && line.contains("a 2000x1500 texture needs 55.5 MiB"),
        "{line}"
    );
}

#[test]
fn a_killed_render_leaves_a_whole_checkpoint() {
    use ember::accel::AccelKind;
    use ember::film::checkpoint;
    use ember::integrator::IntegratorKind;
    use ember::render::RenderSettings;
    use ember::scene::{load_obj, CameraSettings};

    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("k.png");
    let ckpt = dir.path().join("k.png.checkpoint");
    let mut child = Command::new(EMBER)
        .args(["render", cornell().to_str().unwrap(), "-o"])
        .arg(&out)
        .args([
            "--width", "24", "--height", "20", "--spp", "1000000", "--seed", "5",
        ])
        .args(["--threads", "1", "--checkpoint-every", "0.05"])
        .stderr(Stdio::null())
        .spawn()
        .unwrap();
    // Wait for the first checkpoint (an event, not a deadline), then a few more writes.
    while !ckpt.exists() {
        assert!(child.try_wait().unwrap().is_none(), "ember ended early");
        std::thread::sleep(std::time::Duration::from_millis(20));
    }
    std::thread::sleep(std::time::Duration::from_millis(200));
    // SIGKILL: no handler runs; only what was written atomically before survives.
    child.kill().unwrap();
    child.wait().unwrap();

    let (scene, _) = load_obj(&cornell()).unwrap();
    let (lo, hi) = scene.bounds();
    let settings = RenderSettings {
        width: 24,
        height: 20,
        spp: 1_000_000,
        max_depth: 8,
        seed: 5,
        integrator: IntegratorKind::default(),
        light_sampler: Default::default(),
        adaptive: None,
        guiding: None,
        engine: Default::default(),
    };
    let camera = CameraSettings::framing(lo, hi, 40.0);
    let identity = ember::render::identity(&scene, &camera, &settings, AccelKind::Embree);
    let progress = checkpoint::load(&ckpt, &identity, 0..settings.spp).unwrap();
    assert!(progress.total_done() > 0);
    assert!(!out.exists());
}
