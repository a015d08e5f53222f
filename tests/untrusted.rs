//! Every file ember reads is untrusted, and every file it writes must be whole (issue 18).
//! One test per class of failure, each built from files the test makes at run time by
//! damaging real ones: shards and checkpoints ember rendered, images ember encoded from
//! the reference shipped in tests/data. Each refusal is one error line naming the
//! user's path, a non-zero exit, and no file left behind.

use std::path::{Path, PathBuf};
use std::process::{Command, Output, Stdio};
use std::time::{Duration, Instant};

mod common;

use ember::film::checkpoint::{self, FilmReader};
use ember::image::Image;
use serde_json::{json, Value};

const EMBER: &str = env!("CARGO_BIN_EXE_ember");

fn repo(path: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join(path)
}

fn cornell() -> PathBuf {
    repo("meshes/CornellBox-Original.obj")
}

fn ember(args: &[&str], dir: &Path) -> Output {
    Command::new(EMBER)
        .args(args)
        .current_dir(dir)
        .output()
        .expect("ember runs")
}

fn stderr(out: &Output) -> String {
    String::from_utf8_lossy(&out.stderr).into_owned()
}

/// The run failed as a user should see it: non-zero exit, exactly one line on stderr,
/// an error naming every one of `names`, no panic. Returns the line.
fn one_line_error(out: &Output, names: &[&str]) -> String {
    let text = stderr(out);
    assert!(!out.status.success(), "expected a failure: {text}");
    let lines: Vec<&str> = text.lines().filter(|l| !l.trim().is_empty()).collect();
    assert_eq!(lines.len(), 1, "one error line, got: {text}");
    assert!(lines[0].starts_with("error: "), "{text}");
    for name in names {
        assert!(
            lines[0].contains(name),
            "{:?} should name {name:?}",
            lines[0]
        );
    }
    assert!(!text.contains("panicked"), "{text}");
    lines[0].to_owned()
}

/// The names of the files in `dir`.
fn files(dir: &Path) -> Vec<String> {
    let mut names: Vec<String> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    names.sort();
    names
}

fn small_render<'a>(out: &'a str, extra: &[&'a str]) -> Vec<&'a str> {
    let mut args = vec![
        "render", "--width", "16", "--height", "12", "--spp", "4", "--seed", "5", "-o", out,
    ];
    args.extend_from_slice(extra);
    args
}

// ---------------------------------------------------------------------------------
// Film files (shards and checkpoints): their layout as the format documents it, for
// crafting files whose checksum is valid: magic and version (12 bytes), the JSON
// header's length (u32) and the header, the pixel records, and the XXH3 of the rest.

struct FilmFile {
    preamble: Vec<u8>,
    header: Value,
    records: Vec<u8>,
}

impl FilmFile {
    fn read(path: &Path) -> FilmFile {
        let bytes = std::fs::read(path).unwrap();
        let len = u32::from_le_bytes(bytes[12..16].try_into().unwrap()) as usize;
        FilmFile {
            preamble: bytes[..12].to_vec(),
            header: serde_json::from_slice(&bytes[16..16 + len]).unwrap(),
            records: bytes[16 + len..bytes.len() - 8].to_vec(),
        }
    }

    /// Writes the file to `path` with its header as edited by `edit`, hashed anew.
    fn write_with(&self, path: &Path, edit: impl FnOnce(&mut Value)) {
        let mut header = self.header.clone();
        edit(&mut header);
        let json = header.to_string();
        let mut bytes = self.preamble.clone();
        bytes.extend_from_slice(&(json.len() as u32).to_le_bytes());
        bytes.extend_from_slice(json.as_bytes());
        bytes.extend_from_slice(&self.records);
        let hash = xxhash_rust::xxh3::xxh3_64(&bytes);
        bytes.extend_from_slice(&hash.to_le_bytes());
        std::fs::write(path, bytes).unwrap();
    }
}

/// Renders the two shards of a 16x12, 4 spp render of the Cornell box into `dir`
/// (`s0.shard`, `s1.shard`) and a whole render's checkpoint (`whole.ckpt`, made with
/// `--checkpoint-every` and the image `whole.exr`, which is removed).
fn real_film_files(dir: &Path) {
    let scene = cornell();
    let scene = scene.to_str().unwrap();
    for (i, name) in ["s0.shard", "s1.shard"].iter().enumerate() {
        let shard = format!("{i}/2");
        let out = ember(&small_render(name, &[scene, "--shard", &shard]), dir);
        assert!(out.status.success(), "{}", stderr(&out));
    }
    let args = ["--checkpoint", "whole.ckpt", "--checkpoint-every", "100"];
    let out = ember(
        &small_render("whole.exr", &[&[scene][..], &args[..]].concat()),
        dir,
    );
    assert!(out.status.success(), "{}", stderr(&out));
    std::fs::remove_file(dir.join("whole.exr")).unwrap();
}

/// `ember merge` of the film file `file`: beside the real second shard if it is a
/// shard, alone if it is the checkpoint of a whole render (which merges on its own).
fn merge_args(file: &str) -> Vec<&str> {
    let mut args = vec!["merge", file];
    if file.ends_with(".shard") {
        args.push("s1.shard");
    }
    args.extend(["-o", "merged.png"]);
    args
}

/// Both readers of film files refuse `bad` (a crafted `s0.shard` or `whole.ckpt`) in
/// one line naming it and each of `names`: `ember merge` (with `--allow-partial` too)
/// beside the other real shard, and `ember render --resume`. No image is written.
fn assert_refused(dir: &Path, bad: &str, names: &[&str]) {
    let scene = cornell();
    let scene = scene.to_str().unwrap();
    let names = [&[bad][..], names].concat();
    let merge = merge_args(bad);
    let line = one_line_error(&ember(&merge, dir), &names);
    assert!(!line.contains("capacity overflow"), "{line}");
    one_line_error(
        &ember(&[&merge[..], &["--allow-partial"]].concat(), dir),
        &names,
    );
    let resume = if bad.ends_with(".shard") {
        small_render("again.shard", &[scene, "--shard", "0/2", "--resume"])
    } else {
        small_render("again.exr", &[scene, "--resume", "--checkpoint", bad])
    };
    // --resume of a shard reads the output itself.
    let resume: Vec<&str> = resume
        .iter()
        .map(|a| if *a == "again.shard" { bad } else { a })
        .collect();
    one_line_error(&ember(&resume, dir), &names);
    for left in ["merged.png", "again.exr", "again.partial.exr"] {
        assert!(!dir.join(left).exists(), "{left} written for {bad}");
    }
}

// ---------------------------------------------------------------------------------
// Class 1: header fields trusted before they are checked.

/// A header (with a valid checksum) claiming a huge image, a size that differs from
/// the identity it carries, or a film that does not fit the memory available, is
/// refused by `merge` and `--resume` alike before anything is allocated from it.
#[test]
fn film_headers_are_checked_before_they_are_trusted() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    real_film_files(d);
    for real in ["s0.shard", "whole.ckpt"] {
        let file = FilmFile::read(&d.join(real));
        let bad = format!("bad-{real}");
        let path = d.join(&bad);
        // Huge: past u32 products, past the pixel count in usize, past the limits.
        for (w, h) in [
            (u32::MAX, u32::MAX),
            (65536, 65536),
            (16384, 16384),
            (0, 12),
        ] {
            file.write_with(&path, |v| {
                v["width"] = json!(w);
                v["height"] = json!(h);
                v["identity"]["width"] = json!(w.to_string());
                v["identity"]["height"] = json!(h.to_string());
            });
            let names = if w == 16384 {
                ["bytes", "promises"]
            } else {
                ["width", "outside"]
            };
            assert_refused(d, &bad, &names);
        }
        // The same number of pixels (so the length agrees) in another shape than the
        // identity's: 8x24 instead of 16x12.
        file.write_with(&path, |v| {
            v["width"] = json!(8);
            v["height"] = json!(24);
        });
        assert_refused(d, &bad, &["width 8", "width 16"]);
        // A valid file whose film does not fit in the memory available.
        let merge = merge_args(real);
        let out = Command::new(EMBER)
            .args(merge)
            .current_dir(d)
            .env("EMBER_MEMORY_LIMIT", "4096")
            .output()
            .unwrap();
        one_line_error(&out, &[real, "memory", "16x12"]);
    }
}

// ---------------------------------------------------------------------------------
// Class 2: claims not checked against the data.

/// A header's claims are checked against the data they describe: "complete" while a
/// pixel holds no samples, a sample range that is not its shard's, spp 0.
#[test]
fn film_claims_are_checked_against_their_data() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    real_film_files(d);
    for real in ["s0.shard", "whole.ckpt"] {
        let reader = FilmReader::open(&d.join(real)).unwrap();
        let header = reader.header.clone();
        let claimed = header.min_done;
        assert_eq!(claimed as usize, header.samples.len(), "{real} is complete");
        let mut film = reader.read_film().unwrap();
        let bad = format!("bad-{real}");
        let path = d.join(&bad);
        // Pixel (5, 1) lost its samples, the header still says complete.
        film.pixels[16 + 5] = Default::default();
        std::fs::write(&path, checkpoint::encode(&header, &film)).unwrap();
        let emptied = FilmFile::read(&path);
        emptied.write_with(&path, |v| {
            v["min_done"] = json!(claimed);
            v["complete"] = json!(true);
        });
        assert_refused(d, &bad, &["complete", "pixel (5, 1) has 0"]);
        // The same with only "complete" claimed (as adaptive sampling's films may).
        emptied.write_with(&path, |v| v["complete"] = json!(true));
        assert_refused(d, &bad, &["complete", "pixel (5, 1) has 0 of its"]);
        // Honest about it, the same file is incomplete: refused by merge, merged with
        // --allow-partial (beside the other shard, which sampled the pixel; alone,
        // the checkpoint leaves a pixel without a sample, and no image is written:
        // issue 48), continued by --resume.
        emptied.write_with(&path, |_| {});
        let merge = merge_args(&bad);
        one_line_error(&ember(&merge, d), &[&bad, "incomplete"]);
        let partial = ember(&[&merge[..], &["--allow-partial"]].concat(), d);
        if real == "whole.ckpt" {
            one_line_error(&partial, &["1 of the 192 pixels have no sample", "(5, 1)"]);
        } else {
            assert!(partial.status.success(), "{}", stderr(&partial));
            std::fs::remove_file(d.join("merged.png")).unwrap();
        }

        // A sample range other than the one its spp and shard give.
        let real_file = FilmFile::read(&d.join(real));
        real_file.write_with(&path, |v| v["samples"] = json!([0, 3]));
        assert_refused(d, &bad, &["samples 0..3"]);
        // spp 0, with pixels that indeed hold no samples.
        let empty = ember::film::Film::new(16, 12, 0..0);
        std::fs::write(&path, checkpoint::encode(&header, &empty)).unwrap();
        FilmFile::read(&path).write_with(&path, |v| v["spp"] = json!(0));
        assert_refused(d, &bad, &["spp 0"]);
    }
}

// ---------------------------------------------------------------------------------
// Class 3: outputs checked too late.

/// Every path a run may write is checked before the scene is loaded: the error is the
/// only line (nothing was loaded or rendered), it names the user's path, not a
/// temporary file, and the directory is left as it was.
#[test]
fn every_output_is_checked_before_any_work() {
    let dir = tempfile::tempdir().unwrap();
    let scene = cornell();
    let scene = scene.to_str().unwrap();
    let d = dir.path();
    let cases: Vec<(Vec<&str>, Vec<&str>)> = vec![
        // A checkpoint in a directory that does not exist (the reported case) ...
        (
            small_render("out.png", &[scene, "--checkpoint", "nodir/x.ckpt"]),
            vec!["nodir/x.ckpt", "nodir does not exist"],
        ),
        (
            small_render(
                "out.png",
                &[
                    scene,
                    "--checkpoint",
                    "nodir/x.ckpt",
                    "--checkpoint-every",
                    "9",
                ],
            ),
            vec!["nodir/x.ckpt"],
        ),
        // ... the default checkpoint beside an image whose name is taken by a directory
        // ("out.png.checkpoint"), and the partial image of an interruption.
        (
            small_render("ckdir.png", &[scene]),
            vec!["ckdir.png.checkpoint", "directory"],
        ),
        (
            small_render("part.png", &[scene]),
            vec!["part.partial.png", "directory"],
        ),
        // A checkpoint that would overwrite the image.
        (
            small_render("out.exr", &[scene, "--checkpoint", "out.exr"]),
            vec!["out.exr", "overwrite the image"],
        ),
        // A shard file, and a merge's image.
        (
            small_render("nodir/s.shard", &[scene, "--shard", "0/2"]),
            vec!["nodir/s.shard"],
        ),
        (
            vec!["merge", "a.shard", "-o", "nodir/m.png"],
            vec!["nodir/m.png"],
        ),
    ];
    std::fs::create_dir(d.join("ckdir.png.checkpoint")).unwrap();
    std::fs::create_dir(d.join("part.partial.png")).unwrap();
    let before = files(d);
    for (args, names) in cases {
        let started = Instant::now();
        let out = ember(&args, d);
        let line = one_line_error(&out, &names);
        assert!(!line.contains(".tmp") && !line.contains(".ember"), "{line}");
        assert!(started.elapsed() < Duration::from_secs(5), "{line}");
        assert_eq!(files(d), before, "{args:?} left files behind");
    }
}

// ---------------------------------------------------------------------------------
// Class 4: lenient decoding.

/// The reference shipped in the repository, encoded by ember's `image` crate into
/// every format ember reads: (extension, whole file).
fn encoded_images() -> Vec<(&'static str, Vec<u8>)> {
    let reference = Image::load(&repo(
        "tests/data/references/cornell-box/cornell_ref_8192spp.exr",
    ))
    .unwrap();
    // Tone-mapped to 8 bits for the 8-bit formats, as a texture would be.
    let srgb: Vec<u8> = reference
        .pixels
        .iter()
        .flat_map(|p| {
            p.to_array()
                .map(|c| (ember::image::linear_to_srgb(c) * 255.0) as u8)
        })
        .collect();
    let rgb8 = image::RgbImage::from_raw(reference.width, reference.height, srgb).unwrap();
    let rgb32 = image::Rgb32FImage::from_raw(
        reference.width,
        reference.height,
        reference.pixels.iter().flat_map(|p| p.to_array()).collect(),
    )
    .unwrap();
    let encode = |image: image::DynamicImage, format| {
        let mut bytes = std::io::Cursor::new(Vec::new());
        image.write_to(&mut bytes, format).unwrap();
        bytes.into_inner()
    };
    use image::ImageFormat as F;
    vec![
        ("jpg", encode(rgb8.clone().into(), F::Jpeg)),
        ("png", encode(rgb8.clone().into(), F::Png)),
        ("tga", encode(rgb8.clone().into(), F::Tga)),
        ("bmp", encode(rgb8.into(), F::Bmp)),
        ("exr", encode(rgb32.clone().into(), F::OpenExr)),
        ("hdr", encode(rgb32.into(), F::Hdr)),
    ]
}

/// A truncated image of any format is refused by the decoder, by `ember compare` and
/// by `ember render` (as `map_Kd`), in one line naming the file; the whole file is
/// accepted by all three.
#[test]
fn truncated_images_of_every_format_are_refused() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let reference = repo("tests/data/references/cornell-box/cornell_ref_8192spp.exr");
    let reference = reference.to_str().unwrap();
    std::fs::write(
        d.join("quad.obj"),
        "mtllib quad.mtl\nv -1 -1 0\nv 1 -1 0\nv 1 1 0\nv -1 1 0\nvt 0 0\nvt 1 0\nvt 1 1\n\
         vt 0 1\nusemtl tex\nf 1/1 2/2 3/3 4/4\n",
    )
    .unwrap();
    for (ext, bytes) in encoded_images() {
        let name = format!("tex.{ext}");
        let path = d.join(&name);
        std::fs::write(
            d.join("quad.mtl"),
            format!("newmtl tex\nKd 1 1 1\nmap_Kd {name}\n"),
        )
        .unwrap();
        let render = [
            "render", "quad.obj", "-o", "out.png", "--width", "8", "--height", "8",
        ];
        let render = [&render[..], &["--spp", "1", "--background", "1,1,1"]].concat();

        std::fs::write(&path, &bytes).unwrap();
        assert!(ember::image::decode_file(&path).is_ok(), "whole {ext}");
        let compared = ember(&["compare", &name, reference], d);
        assert!(compared.status.success(), "{ext}: {}", stderr(&compared));
        let rendered = ember(&render, d);
        assert!(rendered.status.success(), "{ext}: {}", stderr(&rendered));
        std::fs::remove_file(d.join("out.png")).unwrap();

        // Cut in half (the reported JPEG case), and with only its last tenth missing.
        for keep in [bytes.len() / 2, bytes.len() * 9 / 10] {
            std::fs::write(&path, &bytes[..keep]).unwrap();
            let reason = ember::image::decode_file(&path);
            assert!(
                reason.is_err(),
                "{ext} cut to {keep} of {} bytes decoded",
                bytes.len()
            );
            one_line_error(&ember(&["compare", &name, reference], d), &[&name]);
            one_line_error(&ember(&render, d), &[&name, "map_Kd", "\"tex\""]);
            assert!(!d.join("out.png").exists());
        }
    }
}

// ---------------------------------------------------------------------------------
// Class 5: non-finite values that would reach the samples.

/// A quad lit by a white sky, with the material `m` of `mtl`, rendered in `dir`.
fn render_quad(dir: &Path, mtl: &str) -> Output {
    std::fs::write(
        dir.join("q.obj"),
        "mtllib q.mtl\nv -1 -1 0\nv 1 -1 0\nv 1 1 0\nv -1 1 0\nvt 0 0\nvt 1 0\nvt 1 1\n\
         vt 0 1\nusemtl m\nf 1/1 2/2 3/3 4/4\n",
    )
    .unwrap();
    std::fs::write(dir.join("q.mtl"), mtl).unwrap();
    let args = [
        "render", "q.obj", "-o", "out.exr", "--width", "8", "--height", "8",
    ];
    let out = ember(
        &[&args[..], &["--spp", "4", "--background", "1,1,1"]].concat(),
        dir,
    );
    if out.status.success() {
        std::fs::remove_file(dir.join("out.exr")).unwrap();
    }
    out
}

/// Scalars and texels that would make every sample of a surface NaN are refused at
/// load, naming the file, the material and the key; their finite counterparts render
/// with no sample dropped.
#[test]
fn non_finite_material_values_and_texels_are_refused_at_load() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    for (statement, key) in [
        ("illum 7\nNi inf", "Ni"),
        ("illum 7\nNi nan", "Ni"),
        ("illum 7\nNi 1e39", "Ni"),
        ("illum 7\nNi 1e30", "Ni"),
        ("Ns inf\nKs 1 1 1", "Ns"),
        ("Kd 0.5 nan 0.5", "Kd"),
        ("Ke inf 1 1", "Ke"),
        ("Ks 1 -inf 1", "Ks"),
    ] {
        let out = render_quad(d, &format!("newmtl m\nKd 0.5 0.5 0.5\n{statement}\n"));
        one_line_error(&out, &["q.mtl", "\"m\"", key]);
    }
    for statement in ["illum 7\nNi 1.5", "illum 7\nNi 1000", "Ns 1e30\nKs 1 1 1"] {
        let out = render_quad(d, &format!("newmtl m\nKd 0.5 0.5 0.5\n{statement}\n"));
        assert!(out.status.success(), "{statement}: {}", stderr(&out));
        assert!(
            !stderr(&out).contains("dropped"),
            "{statement}: {}",
            stderr(&out)
        );
    }

    // An EXR texel that is infinite or NaN, in each kind of map (colour, scalar, vector).
    let mut texels = vec![glam::Vec3::splat(0.5); 4 * 4];
    let finite = Image {
        width: 4,
        height: 4,
        pixels: texels.clone(),
    };
    finite.save(&d.join("finite.exr")).unwrap();
    texels[6] = glam::Vec3::new(0.5, f32::INFINITY, 0.5);
    let infinite = Image {
        pixels: texels.clone(),
        ..finite.clone()
    };
    infinite.save(&d.join("inf.exr")).unwrap();
    texels[6] = glam::Vec3::new(f32::NAN, 0.5, 0.5);
    Image {
        pixels: texels,
        ..finite
    }
    .save(&d.join("nan.exr"))
    .unwrap();
    for slot in ["map_Ke", "map_Kd", "map_Ks", "map_Pr", "bump", "norm"] {
        for (file, value) in [("inf.exr", "inf"), ("nan.exr", "NaN")] {
            let out = render_quad(d, &format!("newmtl m\nKd 0.5 0.5 0.5\n{slot} {file}\n"));
            one_line_error(&out, &[file, slot, "\"m\"", "texel (2, 1)", value]);
        }
        let out = render_quad(d, &format!("newmtl m\nKd 0.5 0.5 0.5\n{slot} finite.exr\n"));
        assert!(out.status.success(), "{slot}: {}", stderr(&out));
        assert!(
            !stderr(&out).contains("dropped"),
            "{slot}: {}",
            stderr(&out)
        );
    }
}

// ---------------------------------------------------------------------------------
// Class 6: a second SIGTERM.

/// `timeout` and Slurm signal the whole process group, and more than once: SIGTERM is
/// sent again and again from just after the first until ember exits. The first
/// signal's save completes: exit 143, a whole checkpoint (large enough, 1400x1400, that
/// its write takes a while), a whole partial image where every pixel has a sample, no
/// temporary file.
#[test]
fn later_signals_cannot_cut_the_first_ones_save_short() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let mut child = Command::new(EMBER)
        .args(["render", cornell().to_str().unwrap(), "-o", "big.exr"])
        .args(["--width", "1400", "--height", "1400", "--spp", "1000000"])
        .args(["--threads", "2"])
        .current_dir(d)
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let mut err = std::io::BufReader::new(child.stderr.take().unwrap());
    let mut text = String::new();
    while !text.contains("rendering") {
        let n = std::io::BufRead::read_line(&mut err, &mut text).unwrap();
        assert!(n > 0, "ember ended early: {text}");
    }
    let term = |child: &std::process::Child| {
        Command::new("kill")
            .args(["-TERM", &child.id().to_string()])
            .status()
            .unwrap()
    };
    std::thread::sleep(Duration::from_millis(200));
    assert!(term(&child).success());
    let mut sent = 1;
    let status = loop {
        std::thread::sleep(Duration::from_millis(2));
        if let Some(status) = child.try_wait().unwrap() {
            break status;
        }
        term(&child);
        sent += 1;
    };
    std::io::Read::read_to_string(&mut err, &mut text).unwrap();
    assert!(
        sent > 5,
        "the save took too little time to be tested: {sent} signals"
    );
    assert_eq!(status.code(), Some(143), "{text}");
    assert!(text.contains("interrupted by SIGTERM"), "{text}");
    let film = FilmReader::open(&d.join("big.exr.checkpoint"))
        .unwrap()
        .read_film()
        .unwrap();
    assert_eq!((film.width, film.height), (1400, 1400));
    // A partial image only once every pixel has a sample (issue 48): the first pass
    // of 1400x1400 may not have ended by the signal.
    if film.min_done() == 0 {
        assert!(text.contains("no partial image"), "{text}");
        assert_eq!(files(d), ["big.exr.checkpoint"]);
    } else {
        let partial = Image::load(&d.join("big.partial.exr")).unwrap();
        assert_eq!(partial.pixels.len(), 1400 * 1400);
        assert_eq!(files(d), ["big.exr.checkpoint", "big.partial.exr"]);
    }
}

// =================================================================================
// Issue 48: the third round. One test per class, each making its hostile input at
// run time.

/// `ember ARGS` in `dir` with the environment `env`, killed (and the test failed) if
/// it has not ended within a minute: a reader blocked on a named pipe never ends.
fn ember_bounded(args: &[&str], dir: &Path, env: &[(&str, &str)]) -> Output {
    let mut child = Command::new(EMBER)
        .args(args)
        .current_dir(dir)
        .envs(env.iter().copied())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("ember runs");
    let started = Instant::now();
    while child.try_wait().unwrap().is_none() {
        if started.elapsed() > Duration::from_secs(60) {
            child.kill().unwrap();
            panic!("ember {args:?} still running after a minute");
        }
        std::thread::sleep(Duration::from_millis(10));
    }
    child.wait_with_output().unwrap()
}

/// A named pipe made by the `mkfifo` command.
fn mkfifo(path: &Path) {
    let made = Command::new("mkfifo").arg(path).status().unwrap();
    assert!(made.success(), "mkfifo {}", path.display());
}

/// The files of `dir` with their kinds and contents, to see that nothing changed.
fn snapshot(dir: &Path) -> Vec<(String, bool, Vec<u8>)> {
    let mut all: Vec<_> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| {
            let e = e.unwrap();
            let kind = e.file_type().unwrap();
            let bytes = if kind.is_file() {
                std::fs::read(e.path()).unwrap()
            } else {
                Vec::new()
            };
            (
                e.file_name().to_string_lossy().into_owned(),
                kind.is_file(),
                bytes,
            )
        })
        .collect();
    all.sort();
    all
}

/// A quad whose MTL library is `mtl` (`mtllib`) and whose material's `map_Kd` is
/// `texture`, written as `NAME.obj` (with `NAME.mtl` when `mtl` is that name).
fn quad_scene(dir: &Path, name: &str, mtl: &str, texture: &str) {
    std::fs::write(
        dir.join(format!("{name}.obj")),
        format!(
            "mtllib {mtl}\nv -1 -1 0\nv 1 -1 0\nv 1 1 0\nv -1 1 0\nvt 0 0\nvt 1 0\nvt 1 1\n\
             vt 0 1\nusemtl m\nf 1/1 2/2 3/3 4/4\n"
        ),
    )
    .unwrap();
    if mtl == format!("{name}.mtl") {
        let text = format!("newmtl m\nKd 1 1 1\nmap_Kd {texture}\n");
        std::fs::write(dir.join(mtl), text).unwrap();
    }
}

/// Class 1. A named pipe or `/dev/zero` (through a link named like the input) named as
/// any input ember reads (scene, OBJ in a scene file, MTL, texture, environment map,
/// denoise and compare input, shard, checkpoint, bench mesh) is refused by its kind
/// before a byte is read: one line naming it, exit 1, within a minute (no reader waits
/// for a writer or reads without end), no file left, the pipe still a pipe.
#[test]
fn named_pipes_and_devices_are_refused_by_their_kind() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let cornell = cornell();
    let cornell = cornell.to_str().unwrap();
    let reference = repo("tests/data/references/cornell-box/cornell_ref_8192spp.exr");
    let reference = reference.to_str().unwrap();
    // Named pipes, and `/dev/zero` under names that say the format ember expects.
    for ext in ["obj", "toml", "exr", "shard", "mtl", "png"] {
        mkfifo(&d.join(format!("pipe.{ext}")));
        std::os::unix::fs::symlink("/dev/zero", d.join(format!("zero.{ext}"))).unwrap();
    }
    for (input, kind, tag) in [
        ("pipe", "named pipe", "p"),
        ("zero", "character device", "z"),
    ] {
        let named = |ext: &str| format!("{input}.{ext}");
        let (obj, toml, exr, shard) = (named("obj"), named("toml"), named("exr"), named("shard"));
        // Scene files and OBJs that name the input from inside.
        let scene_obj = format!("{tag}-obj.toml");
        std::fs::write(d.join(&scene_obj), format!("[[obj]]\nfile = {obj:?}\n")).unwrap();
        let scene_env = format!("{tag}-env.toml");
        let text = format!("[environment]\nenv = {exr:?}\n[[obj]]\nfile = {cornell:?}\n");
        std::fs::write(d.join(&scene_env), text).unwrap();
        quad_scene(d, &format!("{tag}-mtl"), &named("mtl"), "none.png");
        let texture = format!("{tag}-tex");
        quad_scene(d, &texture, &format!("{texture}.mtl"), &named("png"));
        let (mtl_obj, texture_obj) = (format!("{tag}-mtl.obj"), format!("{texture}.obj"));
        fn render(scene: &str) -> Vec<&str> {
            let small = [
                "-o", "out.png", "--width", "8", "--height", "8", "--spp", "1",
            ];
            [&["render", scene][..], &small[..]].concat()
        }
        let runs: Vec<(Vec<&str>, &str)> = vec![
            (render(&obj), &obj),
            (render(&toml), &toml),
            (render(&scene_obj), &obj),
            (render(&scene_env), &exr),
            ([&render(cornell)[..], &["--env", &exr]].concat(), &exr),
            (render(&mtl_obj), "mtl"),
            (render(&texture_obj), "map_Kd"),
            (vec!["denoise", &exr, "-o", "out.exr"], &exr),
            (vec!["compare", &exr, reference], &exr),
            (vec!["compare", reference, &exr], &exr),
            (vec!["merge", &shard, "-o", "out.png"], &shard),
            (
                [&render(cornell)[..], &["--resume", "--checkpoint", &shard]].concat(),
                &shard,
            ),
            (vec!["bench", &obj, "--rays", "16", "--min-time", "0"], &obj),
        ];
        let before = snapshot(d);
        for (args, names) in runs {
            let out = ember_bounded(&args, d, &[]);
            assert_eq!(out.status.code(), Some(1), "{args:?}: {}", stderr(&out));
            one_line_error(&out, &[names, kind]);
            assert_eq!(snapshot(d), before, "{args:?} changed the folder");
        }
    }
    let pipe = std::fs::metadata(d.join("pipe.obj")).unwrap();
    assert!(std::os::unix::fs::FileTypeExt::is_fifo(&pipe.file_type()));
}

/// Class 2. What a file's header or a count claims is checked against the memory
/// limit before anything is allocated from it: a scene file of 200 000 placements, an
/// EXR claiming 100000x100000 pixels (to `denoise`, `compare`, `--env` and as a
/// texture), two images `compare` could hold one at a time but not together, an MTL
/// of 200 000 materials, `bench` of a huge procedural mesh or ray count. One line
/// naming the sizes, exit 1, no file left. (tests/memory_estimates.rs pins each
/// estimate against the real peak, and the peak of a refusal under the limit.)
#[test]
fn claims_past_the_memory_limit_are_refused_before_allocating() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let cornell = cornell();
    let cornell = cornell.to_str().unwrap();
    std::fs::write(d.join("huge.exr"), common::exr::claiming(100_000, 100_000)).unwrap();
    std::fs::write(d.join("tri.obj"), "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n").unwrap();
    let mut placed = String::from("[[obj]]\nfile = \"tri.obj\"\nname = \"t\"\n");
    for i in 0..200_000 {
        placed += &format!("[[instance]]\nobj = \"t\"\ntranslate = [{i}, 0, 0]\n");
    }
    std::fs::write(d.join("placed.toml"), placed).unwrap();
    quad_scene(d, "huge-tex", "huge-tex.mtl", "huge.exr");
    quad_scene(d, "many", "many.mtl", "none.png");
    let materials: String = (0..200_000).map(|i| format!("newmtl m{i}\n")).collect();
    std::fs::write(d.join("many.mtl"), materials).unwrap();
    let picture = Image {
        width: 1024,
        height: 768,
        pixels: vec![glam::Vec3::splat(0.5); 1024 * 768],
    };
    picture.save(&d.join("picture.exr")).unwrap();
    let small = [
        "-o", "out.png", "--width", "8", "--height", "8", "--spp", "1",
    ];
    let gib = (8u64 << 30).to_string();
    let cases: Vec<(Vec<&str>, &str, Vec<&str>)> = vec![
        (
            [&["render", "placed.toml"][..], &small].concat(),
            "64000000",
            vec!["placed.toml", "parsing it needs", "61.0 MiB is available"],
        ),
        (
            vec!["denoise", "huge.exr", "-o", "out.exr"],
            &gib,
            vec!["huge.exr", "100000x100000", "memory"],
        ),
        (
            vec!["compare", "huge.exr", "picture.exr"],
            &gib,
            vec!["huge.exr", "100000x100000", "memory"],
        ),
        (
            [&["render", cornell, "--env", "huge.exr"][..], &small].concat(),
            &gib,
            vec!["huge.exr", "100000x100000", "memory"],
        ),
        (
            [&["render", "huge-tex.obj"][..], &small].concat(),
            &gib,
            vec!["huge.exr", "map_Kd", "100000x100000"],
        ),
        // Each image alone fits in 64 MB, both together do not.
        (
            vec!["compare", "picture.exr", "picture.exr"],
            "64000000",
            vec![
                "picture.exr",
                "comparing a 1024x768 image with a 1024x768 reference",
            ],
        ),
        (
            [&["render", "many.obj"][..], &small].concat(),
            "160000000",
            vec!["many.mtl", "200000 materials"],
        ),
        (
            vec!["bench", "--procedural", "soup:100m"],
            &gib,
            vec!["soup:100000000", "memory"],
        ),
        (
            vec!["bench", "--procedural", "sphere:1k", "--rays", "268435456"],
            &gib,
            vec!["268435456 rays", "memory"],
        ),
    ];
    let before = snapshot(d);
    for (args, limit, names) in cases {
        let out = ember_bounded(&args, d, &[("EMBER_MEMORY_LIMIT", limit)]);
        assert_eq!(out.status.code(), Some(1), "{args:?}: {}", stderr(&out));
        one_line_error(&out, &names);
        assert_eq!(snapshot(d), before, "{args:?} changed the folder");
    }
}

/// Class 4. Transforms at the edge of `f32`: a scale of 1e-19 on one axis (which made
/// Embree abort on a ray it took to 1e19) and a placement 1e17 from the origin are
/// refused at their entry on both backends; a rotation axis whose length overflows
/// rotates as the axis it points along does (it was dropped: the image was the
/// unrotated one); a scale of 1e-12, which f32 and Embree carry, renders on both
/// backends alike, and so does an instanced scene seen from 1e16 away (rays its
/// instances cannot carry are misses, not an abort).
#[test]
fn transforms_are_carried_or_refused_with_the_reason() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let cornell = cornell();
    let scene = |name: &str, entry: &str| {
        let text = format!(
            "[[obj]]\nfile = {:?}\nname = \"box\"\n{entry}\n",
            cornell.to_str().unwrap()
        );
        std::fs::write(d.join(name), text).unwrap();
    };
    let render = |scene: &str, out: &str, accel: &str, extra: &[&str]| {
        let args = [
            "render", scene, "-o", out, "--width", "24", "--height", "24",
        ];
        let args = [
            &args[..],
            &["--spp", "4", "--accel", accel, "--seed", "2"],
            extra,
        ]
        .concat();
        ember_bounded(&args, d, &[])
    };
    scene("flat.toml", "scale = [1, 1e-19, 1]");
    scene(
        "far.toml",
        "[[instance]]\nobj = \"box\"\ntranslate = [1e17, 0, 0]",
    );
    for accel in ["embree", "bvh"] {
        let out = render("flat.toml", "flat.png", accel, &[]);
        one_line_error(
            &out,
            &["flat.toml:1:1: obj:", "1.000e19", "Embree can carry"],
        );
        let out = render("far.toml", "far.png", accel, &[]);
        one_line_error(&out, &["far.toml:4:1: instance:", "1.000e17"]);
    }
    scene(
        "overflow.toml",
        "rotate = { axis = [1e38, 1e38, 0], degrees = 90 }",
    );
    scene("axis.toml", "rotate = { axis = [1, 1, 0], degrees = 90 }");
    scene(
        "unrotated.toml",
        "translate = [0, 0, 0]\n[[instance]]\nobj = \"box\"\ntranslate = [5, 0, 0]",
    );
    // A quad in the plane z = 0 scaled by 1e-12 along z is the same quad, but rays in
    // its own space have z components 1e12 times the world's.
    std::fs::write(
        d.join("quad.obj"),
        "v -1 -1 0\nv 1 -1 0\nv 1 1 0\nv -1 1 0\nf 1 2 3 4\nf 1 4 3 2\n",
    )
    .unwrap();
    let quad = |name: &str, scale: &str| {
        let text = format!(
            "[[obj]]\nfile = \"quad.obj\"\nname = \"q\"\nscale = {scale}\n[[instance]]\n\
             obj = \"q\"\nscale = {scale}\ntranslate = [0.5, 0.5, -1]\n"
        );
        std::fs::write(d.join(name), text).unwrap();
    };
    quad("thin.toml", "[1, 1, 1e-12]");
    quad("plain.toml", "[1, 1, 1]");
    let sky = ["--background", "1,1,1"];
    let eye = [
        "--background",
        "1,1,1",
        "--eye",
        "1e16,1,1e16",
        "--look-at",
        "0,1,0",
    ];
    for accel in ["embree", "bvh"] {
        for (name, file, extra) in [
            ("overflow", "overflow.toml", &[][..]),
            ("axis", "axis.toml", &[][..]),
            ("unrotated", "unrotated.toml", &[][..]),
            ("thin", "thin.toml", &sky[..]),
            ("plain", "plain.toml", &sky[..]),
            ("afar", "thin.toml", &eye[..]),
        ] {
            let out = render(file, &format!("{name}-{accel}.exr"), accel, extra);
            assert!(out.status.success(), "{name} on {accel}: {}", stderr(&out));
        }
        let read = |name: &str| std::fs::read(d.join(format!("{name}-{accel}.exr"))).unwrap();
        assert!(
            read("overflow") == read("axis"),
            "{accel}: the overflowing axis rotates"
        );
        assert!(read("overflow") != read("unrotated"), "{accel}");
        let load = |name: &str| Image::load(&d.join(format!("{name}-{accel}.exr"))).unwrap();
        let (thin, plain) = (load("thin"), load("plain"));
        // Alike but for a few samples at the edges, which the transform's rounding may
        // settle the other way.
        let differ = |a: &Image, b: &Image| {
            let far = |(p, q): (&glam::Vec3, &glam::Vec3)| (*p - *q).abs().max_element() > 1e-3;
            a.pixels.iter().zip(&b.pixels).filter(|&pq| far(pq)).count()
        };
        let n = differ(&thin, &plain);
        assert!(
            n * 100 <= thin.pixels.len(),
            "{accel}: thin and plain quads differ in {n} pixels"
        );
    }
}

/// Class 5. One file under two names is one file: `--checkpoint ./out.png` or
/// `sub/../out.png`, a hard link, `--guide-image ./out.png`, a checkpoint named as the
/// partial image, an output named as an input (the OBJ, the environment map, a shard,
/// denoise's input) are refused before any work; a shard given twice under two names
/// too. A pass named twice is one layer (`render` and `merge`). No input changes.
#[test]
fn one_file_under_two_names_is_one_file() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    real_film_files(d);
    std::fs::create_dir(d.join("sub")).unwrap();
    let cornell = cornell();
    let cornell = cornell.to_str().unwrap();
    std::fs::copy(cornell, d.join("box.obj")).unwrap();
    let mtl = repo("meshes/CornellBox-Original.mtl");
    std::fs::copy(mtl, d.join("CornellBox-Original.mtl")).unwrap();
    std::fs::write(d.join("out.png"), b"the user's picture").unwrap();
    std::fs::hard_link(d.join("out.png"), d.join("linked.png")).unwrap();
    Image::new(4, 2).save(&d.join("sky.exr")).unwrap();
    std::fs::copy(d.join("sky.exr"), d.join("noisy.exr")).unwrap();
    fn render<'a>(extra: &[&'a str]) -> Vec<&'a str> {
        let args = [
            "render", "box.obj", "-o", "out.png", "--width", "8", "--height", "8",
        ];
        [&args[..], &["--spp", "2"], extra].concat()
    }
    let guide = ["--guiding", "--guide-pixel", "1,1", "--guide-image"];
    let cases: Vec<(Vec<&str>, Vec<&str>)> = vec![
        (
            render(&["--checkpoint", "./out.png"]),
            vec!["./out.png", "would overwrite the image out.png"],
        ),
        (
            render(&["--checkpoint", "sub/../out.png"]),
            vec!["sub/../out.png", "the image"],
        ),
        (
            render(&["--checkpoint", "linked.png"]),
            vec!["linked.png", "the image"],
        ),
        (
            render(&["--checkpoint", "out.partial.png"]),
            vec!["out.partial.png", "the partial image"],
        ),
        (
            render(&[&guide[..], &["./out.png"]].concat()),
            vec!["--guide-image ./out.png", "the image"],
        ),
        (
            render(&["--checkpoint", "./box.obj"]),
            vec!["./box.obj", "the scene box.obj"],
        ),
        (
            render(&[
                "--env",
                "sky.exr",
                "--guiding",
                "--guide-pixel",
                "1,1",
                "--guide-image",
                "./sky.exr",
            ]),
            vec!["sky.exr", "the environment map"],
        ),
        (
            vec!["merge", "s0.shard", "./s0.shard", "-o", "m.png"],
            vec!["./s0.shard", "given twice"],
        ),
        (
            vec!["denoise", "noisy.exr", "-o", "sub/../noisy.exr", "--no-aux"],
            vec!["sub/../noisy.exr", "the input noisy.exr"],
        ),
    ];
    std::fs::copy(d.join("s1.shard"), d.join("s1.png")).unwrap();
    let mut cases = cases;
    cases.push((
        vec!["merge", "s0.shard", "s1.png", "-o", "./s1.png"],
        vec!["./s1.png", "the shard s1.png"],
    ));
    let before = snapshot(d);
    for (args, names) in cases {
        let out = ember_bounded(&args, d, &[]);
        assert_eq!(out.status.code(), Some(1), "{args:?}: {}", stderr(&out));
        one_line_error(&out, &names);
        assert_eq!(snapshot(d), before, "{args:?} changed the folder");
    }
    // Passes named twice: each once in the EXR, from render and from merge.
    let aov = ["--aov", "albedo,normal,albedo", "--aov", "normal"];
    let out = ember_bounded(
        &[
            &["render", "box.obj", "-o", "passes.exr", "--spp", "1"][..],
            &aov,
        ]
        .concat(),
        d,
        &[],
    );
    assert!(out.status.success(), "{}", stderr(&out));
    let out = ember_bounded(
        &[
            &["merge", "s0.shard", "s1.shard", "-o", "merged.exr"][..],
            &aov,
        ]
        .concat(),
        d,
        &[],
    );
    assert!(out.status.success(), "{}", stderr(&out));
    for file in ["passes.exr", "merged.exr"] {
        let layers = ember::image::LayeredImage::read_exr(&d.join(file)).unwrap();
        let names: Vec<&str> = layers.layers.iter().map(|l| l.name.as_str()).collect();
        assert_eq!(names, ["", "albedo", "normal"], "{file}");
    }
}

/// Class 6. A run writes an image only when every pixel has a sample: a
/// `--time-limit` shorter than the first pass renders on until each pixel has one
/// (and says so); `merge --allow-partial` of shards that hold no sample is refused,
/// and no image is written.
#[test]
fn no_image_of_pixels_no_sample_reached() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let cornell = cornell();
    let cornell = cornell.to_str().unwrap();
    let args = [
        "render",
        cornell,
        "-o",
        "quick.exr",
        "--width",
        "160",
        "--height",
        "120",
    ];
    let args = [
        &args[..],
        &["--spp", "64", "--time-limit", "0.000001", "--aov", "spp"],
    ]
    .concat();
    let out = ember_bounded(&args, d, &[]);
    assert!(out.status.success(), "{}", stderr(&out));
    assert!(
        stderr(&out).contains("ended before every pixel had a sample"),
        "{}",
        stderr(&out)
    );
    let image = ember::image::LayeredImage::read_exr(&d.join("quick.exr")).unwrap();
    let spp = image.layers.iter().find(|l| l.name == "spp").unwrap();
    assert!(
        spp.data.iter().all(|&n| n >= 1.0),
        "a pixel without a sample"
    );
    // Shards 0 and 2 of 8 at 4 spp hold no samples (their ranges are empty).
    for shard in ["0/8", "2/8"] {
        let name = format!("empty-{}.shard", &shard[..1]);
        let out = ember_bounded(&small_render(&name, &[cornell, "--shard", shard]), d, &[]);
        assert!(out.status.success(), "{}", stderr(&out));
    }
    let out = ember_bounded(
        &[
            "merge",
            "empty-0.shard",
            "empty-2.shard",
            "-o",
            "m.png",
            "--allow-partial",
        ],
        d,
        &[],
    );
    one_line_error(
        &out,
        &["192 of the 192 pixels have no sample", "no image written"],
    );
    assert!(!d.join("m.png").exists());
}

/// Class 7. A standard output that cannot be written: to a full device, `info`,
/// `compare` and `bench` end with one error line and exit 1; to a closed pipe, they end
/// quietly by SIGPIPE, as Unix tools do. No panic (exit 101) in either. A standard
/// error that cannot be written ends a render the same ways, before it writes a file.
#[test]
fn an_output_that_cannot_be_written_ends_cleanly() {
    use std::os::unix::process::ExitStatusExt;
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let reference = repo("tests/data/references/cornell-box/cornell_ref_8192spp.exr");
    let reference = reference.to_str().unwrap();
    let full = || {
        std::fs::OpenOptions::new()
            .write(true)
            .open("/dev/full")
            .unwrap()
    };
    let bench = [
        "bench",
        "--procedural",
        "sphere:1k",
        "--rays",
        "64",
        "--min-time",
        "0",
    ];
    let bench = [&bench[..], &["--threads", "1"]].concat();
    for args in [vec!["info"], vec!["compare", reference, reference], bench] {
        let out = Command::new(EMBER)
            .args(&args)
            .current_dir(d)
            .stdout(full())
            .output()
            .unwrap();
        let text = stderr(&out);
        assert_eq!(out.status.code(), Some(1), "{args:?}: {text}");
        let last = text.lines().last().unwrap_or("");
        assert_eq!(
            last, "error: cannot write to standard output: No space left on device (os error 28)",
            "{args:?}: {text}"
        );
        assert!(!text.contains("panicked"), "{text}");
        // The pipe's reader is gone before ember writes.
        let mut child = Command::new(EMBER)
            .args(&args)
            .current_dir(d)
            .stdout(Stdio::piped())
            .stderr(Stdio::piped())
            .spawn()
            .unwrap();
        drop(child.stdout.take());
        let out = child.wait_with_output().unwrap();
        assert_eq!(out.status.signal(), Some(13), "{args:?}: {}", stderr(&out));
        assert!(!stderr(&out).contains("error"), "{}", stderr(&out));
    }
    let cornell = cornell();
    let render = small_render("out.png", &[cornell.to_str().unwrap()]);
    let out = Command::new(EMBER)
        .args(&render)
        .current_dir(d)
        .stderr(full())
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(1));
    let mut child = Command::new(EMBER)
        .args(&render)
        .current_dir(d)
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    drop(child.stderr.take());
    assert_eq!(child.wait().unwrap().signal(), Some(13));
    assert_eq!(files(d), Vec::<String>::new());
}

/// Class 8. One rule for settings on `--resume`: a setting whose default follows
/// `--spp` (adaptive sampling's `--min-spp`, guiding's `--guiding-iterations`), when not
/// given, is the checkpoint's, so a resume to more samples continues the render it
/// started (adaptive sampling's was refused); given, it must equal the checkpoint's.
/// What only shapes the output (`--aov`) is free. A resumed render is the render of
/// its settings done at once, bit for bit.
#[test]
fn resume_takes_the_checkpoints_defaults_and_refuses_what_differs() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let cornell = cornell();
    let cornell = cornell.to_str().unwrap();
    for (what, flags, explicit, other) in [
        (
            "adaptive",
            vec!["--noise-threshold", "0.2"],
            vec!["--min-spp", "16"],
            vec!["--min-spp", "32"],
        ),
        (
            "guided",
            vec!["--guiding"],
            vec!["--guiding-iterations", "1"],
            vec!["--guiding-iterations", "2"],
        ),
        (
            "both",
            vec!["--guiding", "--noise-threshold", "0.2"],
            vec!["--guiding-iterations", "1", "--min-spp", "16"],
            vec!["--min-spp", "32"],
        ),
    ] {
        let render = |out: &str, spp: &str, extra: &[&str]| {
            let args = [
                "render", cornell, "-o", out, "--width", "24", "--height", "20",
            ];
            let args = [&args[..], &["--seed", "3", "--spp", spp], &flags, extra].concat();
            ember_bounded(&args, d, &[])
        };
        let resumed = format!("{what}-resumed.exr");
        let out = render(&resumed, "16", &["--checkpoint-every", "100"]);
        assert!(out.status.success(), "{what}: {}", stderr(&out));
        let checkpoint = std::fs::read(d.join(format!("{resumed}.checkpoint"))).unwrap();
        let out = render(&resumed, "64", &["--resume", "--aov", "spp"]);
        assert!(out.status.success(), "{what}: {}", stderr(&out));
        let whole = format!("{what}-whole.exr");
        let out = render(&whole, "64", &[&explicit[..], &["--aov", "spp"]].concat());
        assert!(out.status.success(), "{what}: {}", stderr(&out));
        assert!(
            std::fs::read(d.join(&resumed)).unwrap() == std::fs::read(d.join(&whole)).unwrap(),
            "{what}: the resumed render differs from the whole one"
        );
        // Given, and other than the checkpoint's: refused, naming both.
        std::fs::write(d.join(format!("{resumed}.checkpoint")), &checkpoint).unwrap();
        let out = render(&resumed, "64", &[&["--resume"][..], &other].concat());
        let (key, value) = (&other[other.len() - 2][2..], other[other.len() - 1]);
        one_line_error(&out, &[&format!("{resumed}.checkpoint"), key, value]);
    }
}
