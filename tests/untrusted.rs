//! Every file ember reads is untrusted, and every file it writes must be whole (issue 18).
//! One test per class of failure, each built from files the test makes at run time by
//! damaging real ones: shards and checkpoints ember rendered, images ember encoded from
//! the reference shipped in tests/data. Each refusal is one error line naming the
//! user's path, a non-zero exit, and no file left behind.

use std::path::{Path, PathBuf};
use std::process::{Command, Output, Stdio};
use std::time::{Duration, Instant};

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
        // --allow-partial, continued by --resume.
        emptied.write_with(&path, |_| {});
        let merge = merge_args(&bad);
        one_line_error(&ember(&merge, d), &[&bad, "incomplete"]);
        let partial = ember(&[&merge[..], &["--allow-partial"]].concat(), d);
        assert!(partial.status.success(), "{}", stderr(&partial));
        std::fs::remove_file(d.join("merged.png")).unwrap();

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
/// signal's save completes: exit 143, a whole partial image and a whole checkpoint
/// (large enough, 1400x1400, that its write takes a while), no temporary file.
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
    let partial = Image::load(&d.join("big.partial.exr")).unwrap();
    assert_eq!(partial.pixels.len(), 1400 * 1400);
    let film = FilmReader::open(&d.join("big.exr.checkpoint"))
        .unwrap()
        .read_film()
        .unwrap();
    assert_eq!((film.width, film.height), (1400, 1400));
    assert_eq!(files(d), ["big.exr.checkpoint", "big.partial.exr"]);
}
