//! Shards of a split render (`ember render --shard I/N`) and `ember merge`: the merged
//! image equals the one-process render (8-bit bytes equal, linear values within f64
//! rounding), and every fault (a killed shard, a damaged, foreign, duplicated or missing
//! one) is recovered or refused in one line naming the culprit, with no image written.

use std::path::{Path, PathBuf};
use std::process::{Command, Output, Stdio};

use ember::accel::EmbreeAccel;
use ember::embree::{BuildQuality, Device};
use ember::film::Film;
use ember::image::{Image, OutputFormat};
use ember::integrator::IntegratorKind;
use ember::render::{render_progressive, RenderControl, RenderSettings};
use ember::scene::{load_obj, CameraSettings};

const EMBER: &str = env!("CARGO_BIN_EXE_ember");

fn mesh(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("meshes")
        .join(name)
}

fn ember(args: &[&str]) -> Output {
    Command::new(EMBER).args(args).output().expect("ember runs")
}

fn stderr(out: &Output) -> String {
    String::from_utf8_lossy(&out.stderr).into_owned()
}

/// The one-line error of a failed run.
fn error_line(out: &Output) -> String {
    assert!(!out.status.success(), "expected failure: {}", stderr(out));
    let text = stderr(out);
    assert_eq!(text.lines().count(), 1, "one line: {text}");
    assert!(text.starts_with("error: "), "{text}");
    text.trim_end().to_owned()
}

/// The flags of the small test render; `extra` adds flags, or overrides the defaults'
/// values when it names them (clap takes each flag once).
fn render_args<'a>(out: &'a str, extra: &[&'a str]) -> Vec<&'a str> {
    let mut args = vec!["render", "-o", out];
    let defaults = [
        ("--width", "24"),
        ("--height", "20"),
        ("--spp", "10"),
        ("--max-depth", "5"),
        ("--seed", "3"),
        ("--threads", "2"),
    ];
    for (flag, value) in defaults {
        if !extra.contains(&flag) {
            args.extend([flag, value]);
        }
    }
    args.extend(extra);
    args
}

fn render_ok(scene: &Path, out: &Path, extra: &[&str]) {
    let mut args = render_args(out.to_str().unwrap(), extra);
    args.push(scene.to_str().unwrap());
    let run = ember(&args);
    assert!(run.status.success(), "{}", stderr(&run));
}

/// Renders the shards `0/n .. n-1/n` into `dir`, returning their paths.
fn render_shards(dir: &Path, n: u32, extra: &[&str]) -> Vec<PathBuf> {
    (0..n)
        .map(|i| {
            let part = dir.join(format!("part-{i}-of-{n}.shard"));
            let shard = format!("{i}/{n}");
            let mut args = vec!["--shard", shard.as_str()];
            args.extend(extra);
            render_ok(&mesh("CornellBox-Original.obj"), &part, &args);
            part
        })
        .collect()
}

fn merge(shards: &[PathBuf], out: &Path, extra: &[&str]) -> Output {
    let mut cmd = Command::new(EMBER);
    cmd.arg("merge").args(shards).arg("-o").arg(out).args(extra);
    cmd.output().expect("ember runs")
}

/// Two linear images agree within the rounding of the f64 sums: each channel equal, or
/// one `f32` step apart where the mean lies on a rounding boundary.
fn assert_within_rounding(a: &Image, b: &Image) {
    assert_eq!((a.width, a.height), (b.width, b.height));
    for (p, q) in a.pixels.iter().zip(&b.pixels) {
        for (x, y) in p.to_array().into_iter().zip(q.to_array()) {
            assert!(
                (x - y).abs() <= x.abs().max(y.abs()) * f32::EPSILON,
                "{x} vs {y}"
            );
        }
    }
}

#[test]
fn merged_films_equal_one_process_at_any_number_of_shards() {
    let (scene, _) = load_obj(&mesh("CornellBox-Original.obj")).unwrap();
    let device = Device::new("threads=2").unwrap();
    let accel = EmbreeAccel::build(
        &device,
        &scene.mesh.positions,
        &scene.mesh.triangles,
        BuildQuality::Medium,
    )
    .unwrap();
    let (lo, hi) = scene.bounds();
    let settings = RenderSettings {
        width: 29,
        height: 17,
        spp: 10,
        max_depth: 6,
        seed: 4,
        integrator: IntegratorKind::Mis,
        light_sampler: Default::default(),
        adaptive: None,
        guiding: None,
        engine: Default::default(),
    };
    let camera = CameraSettings::framing(lo, hi, 40.0).camera(settings.width, settings.height);
    let stop = std::sync::atomic::AtomicUsize::new(0);
    let control = RenderControl {
        stop: &stop,
        on_samples: &|_| {},
        first_pass_spp: 1,
        checkpoint: None,
        deadline: None,
        on_pass: &|_| {},
        on_guide: None,
    };
    let render = |samples: std::ops::Range<u32>| {
        let film = Film::new(settings.width, settings.height, samples);
        render_progressive(&scene, &accel, &camera, &settings, film, &control).0
    };
    let whole = render(0..settings.spp);
    let png = |f: &Film| f.resolve().encode(OutputFormat::Png).unwrap();
    // N = 1 and 10 divide spp 10, 3, 4 and 7 do not; 7 includes one-sample shards.
    for n in [1u32, 2, 3, 4, 7, 10] {
        let at = |i: u32| i * settings.spp / n;
        let mut merged = render(0..at(1));
        for i in 1..n {
            merged.merge(&render(at(i)..at(i + 1)));
        }
        assert_eq!(merged.samples, whole.samples);
        let counts = |f: &Film| {
            f.pixels
                .iter()
                .map(|p| (p.done, p.kept))
                .collect::<Vec<_>>()
        };
        assert_eq!(counts(&merged), counts(&whole), "N = {n}");
        for (a, b) in merged.pixels.iter().zip(&whole.pixels) {
            let (a, b) = (a.radiance, b.radiance);
            // Regrouped additions of the same values: f64 rounding apart, no more.
            assert!((a - b).abs().max_element() <= 1e-14 * b.max_element().max(1e-300));
        }
        if n == 1 {
            assert_eq!(merged, whole, "one shard is the render itself");
        }
        assert_eq!(png(&merged), png(&whole), "8-bit output, N = {n}");
        assert_within_rounding(&merged.resolve(), &whole.resolve());
    }
}

#[test]
fn shard_files_merge_to_the_one_process_image() {
    let dir = tempfile::tempdir().unwrap();
    let whole_png = dir.path().join("whole.png");
    let whole_exr = dir.path().join("whole.exr");
    render_ok(&mesh("CornellBox-Original.obj"), &whole_png, &[]);
    render_ok(&mesh("CornellBox-Original.obj"), &whole_exr, &[]);
    for n in [3, 4] {
        let mut shards = render_shards(dir.path(), n, &[]);
        shards.reverse(); // any order
        let (png, exr) = (dir.path().join("m.png"), dir.path().join("m.exr"));
        for out in [&png, &exr] {
            let run = merge(&shards, out, &[]);
            assert!(run.status.success(), "{}", stderr(&run));
        }
        assert_eq!(
            std::fs::read(&png).unwrap(),
            std::fs::read(&whole_png).unwrap(),
            "N = {n}"
        );
        assert_within_rounding(
            &Image::load(&exr).unwrap(),
            &Image::load(&whole_exr).unwrap(),
        );
    }
}

#[test]
fn a_killed_shard_resumes_from_its_own_file() {
    let dir = tempfile::tempdir().unwrap();
    let part = dir.path().join("slow.shard");
    let scene = mesh("CornellBox-Original.obj");
    let spp = ["--spp", "4000", "--threads", "1"];
    let mut args = render_args(part.to_str().unwrap(), &spp);
    args.extend(["--shard", "0/2", "--checkpoint-every", "0.05"]);
    let mut child = Command::new(EMBER)
        .args(&args)
        .arg(&scene)
        .stderr(Stdio::null())
        .spawn()
        .unwrap();
    // Wait for the first checkpoint (an event, not a deadline), then SIGKILL: no handler
    // runs, only what was written atomically survives.
    while !part.exists() {
        assert!(child.try_wait().unwrap().is_none(), "ember ended early");
        std::thread::sleep(std::time::Duration::from_millis(20));
    }
    child.kill().unwrap();
    child.wait().unwrap();
    let other = dir.path().join("other.shard");
    let mut args = render_args(other.to_str().unwrap(), &spp);
    args.extend(["--shard", "1/2", scene.to_str().unwrap()]);
    assert!(ember(&args).status.success());

    // The killed shard is incomplete: merging it is refused, naming it.
    let out = dir.path().join("m.png");
    let line = error_line(&merge(&[part.clone(), other.clone()], &out, &[]));
    assert!(
        line.contains("slow.shard") && line.contains("incomplete"),
        "{line}"
    );
    assert!(!out.exists());
    // --allow-partial merges what it has, and says so.
    let run = merge(&[part.clone(), other.clone()], &out, &["--allow-partial"]);
    assert!(run.status.success(), "{}", stderr(&run));
    assert!(
        stderr(&run).contains("slow.shard is incomplete"),
        "{}",
        stderr(&run)
    );
    std::fs::remove_file(&out).unwrap();

    // Run again with --resume: it continues and the merge is the one-process image.
    let mut args = render_args(part.to_str().unwrap(), &spp);
    args.extend(["--shard", "0/2", "--resume", scene.to_str().unwrap()]);
    let run = ember(&args);
    assert!(
        run.status.success() && stderr(&run).contains("resuming from"),
        "{}",
        stderr(&run)
    );
    assert!(merge(&[part, other], &out, &[]).status.success());
    let whole = dir.path().join("whole.png");
    render_ok(&scene, &whole, &spp);
    assert_eq!(std::fs::read(&out).unwrap(), std::fs::read(&whole).unwrap());
}

#[test]
fn faulty_shards_are_refused_in_one_line_naming_the_file() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let shards = render_shards(d, 4, &[]);
    let out = d.join("m.exr");
    let refuse = |inputs: &[PathBuf], expect: &[&str]| {
        let line = error_line(&merge(inputs, &out, &[]));
        for e in expect {
            assert!(line.contains(e), "{line} lacks {e}");
        }
        assert!(!out.exists(), "no image after {line}");
    };
    let with = |i: usize, p: &Path| {
        let mut s = shards.clone();
        s[i] = p.to_owned();
        s
    };

    // A damaged byte in the pixels (a low bit of the last pixel's red sum, so the value
    // is still a valid one): the checksum.
    let bad = d.join("damaged.shard");
    let mut bytes = std::fs::read(&shards[2]).unwrap();
    let at = bytes.len() - 8 - ember::film::checkpoint::PIXEL_BYTES;
    bytes[at] ^= 0x04;
    std::fs::write(&bad, &bytes).unwrap();
    refuse(&with(2, &bad), &["damaged.shard", "checksum"]);
    // A truncated one.
    std::fs::write(&bad, &bytes[..bytes.len() / 2]).unwrap();
    refuse(&with(2, &bad), &["damaged.shard", "truncated"]);
    // Not a shard at all.
    std::fs::write(&bad, b"hello").unwrap();
    refuse(&with(2, &bad), &["damaged.shard", "not a valid ember"]);

    // Shards of another render: seed, spp, scene, integrator.
    let foreign = d.join("foreign");
    std::fs::create_dir(&foreign).unwrap();
    for (flags, key) in [
        (&["--seed", "4"][..], "seed 4"),
        (&["--spp", "12"][..], "spp 12"),
        (&["--integrator", "bsdf"][..], "integrator bsdf"),
    ] {
        let mut args = vec!["--shard", "1/4"];
        args.extend(flags);
        let part = foreign.join("x.shard");
        render_ok(&mesh("CornellBox-Original.obj"), &part, &args);
        refuse(&with(1, &part), &["x.shard", key]);
    }
    let part = foreign.join("scene.shard");
    render_ok(&mesh("small-light.obj"), &part, &["--shard", "3/4"]);
    refuse(&with(3, &part), &["scene.shard", "scene"]);

    // A duplicate, under the same name or another.
    let mut twice = shards.clone();
    twice.push(shards[1].clone());
    refuse(&twice, &["part-1-of-4.shard", "given twice"]);
    let copy = d.join("copy.shard");
    std::fs::copy(&shards[1], &copy).unwrap();
    twice[4] = copy;
    refuse(&twice, &["copy.shard", "duplicates", "shard 1/4"]);
    // Shards of two splittings overlap.
    let halves = render_shards(&foreign, 2, &[]);
    let mut mixed = shards[..2].to_vec();
    mixed.push(halves[1].clone());
    mixed.push(halves[0].clone());
    refuse(&mixed, &["overlaps"]);

    // A missing shard: refused, naming the samples and the shard; merged with
    // --allow-partial into an image of the others, saying what is missing.
    let three = [shards[0].clone(), shards[1].clone(), shards[3].clone()];
    refuse(
        &three,
        &["samples 5..7 of 0..10", "shard 2/4", "--allow-partial"],
    );
    let run = merge(&three, &out, &["--allow-partial"]);
    assert!(run.status.success(), "{}", stderr(&run));
    assert!(stderr(&run).contains("no shard holds samples 5..7"));
    assert!(Image::load(&out).unwrap().mean().min_element() > 0.0);
}

#[test]
fn bad_shard_and_merge_flags_are_one_line_errors() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("p.shard");
    let out = out.to_str().unwrap();
    let scene = mesh("CornellBox-Original.obj");
    let scene = scene.to_str().unwrap();
    for (flags, expect) in [
        (&["--shard", "4/4"][..], "0 <= I < N"),
        (&["--shard", "1"][..], "expected I/N"),
        (&["--shard", "0/0"][..], "0 <= I < N"),
        (
            &["--shard", "0/2", "--checkpoint", "c"][..],
            "cannot be used with",
        ),
    ] {
        let mut args = render_args(out, flags);
        args.push(scene);
        let run = ember(&args);
        let text = stderr(&run);
        // clap's message: its first line names the flag, then its usage and tips.
        let first = text.lines().next().unwrap_or_default();
        assert!(
            run.status.code() == Some(2) && first.starts_with("error:"),
            "{text}"
        );
        assert!(first.contains(expect), "{text}");
        assert!(!text.contains("panicked"), "{text}");
    }
    // --shard needs -o: a shard has no default name.
    let run = ember(&["render", scene, "--shard", "0/2"]);
    assert!(
        !run.status.success() && stderr(&run).contains("--output"),
        "{}",
        stderr(&run)
    );
    // Resuming a shard that was never started.
    let mut args = render_args(out, &["--shard", "0/2", "--resume"]);
    args.push(scene);
    assert!(error_line(&ember(&args)).contains("no checkpoint"));

    // Merge: an unknown output format is refused before any reading; a missing file is
    // named.
    let shards = render_shards(dir.path(), 2, &[]);
    let line = error_line(&merge(&shards, &dir.path().join("m.jpg"), &[]));
    assert!(
        line.contains("m.jpg") && line.contains(".png, .exr or .hdr"),
        "{line}"
    );
    let gone = vec![shards[0].clone(), dir.path().join("gone.shard")];
    let line = error_line(&merge(&gone, &dir.path().join("m.png"), &[]));
    assert!(
        line.contains("cannot read") && line.contains("gone.shard"),
        "{line}"
    );
    // An empty shard (more shards than samples) merges fine.
    let tiny = dir.path().join("tiny");
    std::fs::create_dir(&tiny).unwrap();
    let parts = render_shards(&tiny, 12, &[]);
    let run = merge(&parts, &dir.path().join("m.png"), &[]);
    assert!(run.status.success(), "{}", stderr(&run));
}

#[test]
fn resuming_from_a_file_of_another_format_version_is_one_line() {
    let dir = tempfile::tempdir().unwrap();
    let part = dir.path().join("old.shard");
    let scene = mesh("CornellBox-Original.obj");
    let mut args = render_args(part.to_str().unwrap(), &["--shard", "0/2"]);
    args.push(scene.to_str().unwrap());
    assert!(ember(&args).status.success());
    // Version 1 (before the sample range, accel and algorithm version were recorded).
    let mut bytes = std::fs::read(&part).unwrap();
    bytes[8..12].copy_from_slice(&1u32.to_le_bytes());
    std::fs::write(&part, &bytes).unwrap();
    args.insert(1, "--resume");
    let line = error_line(&ember(&args));
    assert!(
        line.contains("old.shard") && line.contains("format version 1"),
        "{line}"
    );
    let line = error_line(&merge(&[part], &dir.path().join("m.png"), &[]));
    assert!(line.contains("format version 1"), "{line}");
}
