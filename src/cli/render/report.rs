//! What `ember render` says: the scene loaded and the camera chosen (as flags, with a
//! note when it sees nothing lit), the start, and the summary of a finished or
//! interrupted render, as lines on stderr and, with `--json`, as one JSON object on
//! stdout.

use serde_json::{json, Value};

use super::super::verbosity;
use super::load::LoadedScene;
use super::plan::{partial_output, RenderPlan};
use super::Timeline;
use ember::film::Film;
use ember::render::{CameraProbe, PassReport, RenderStats};
use ember::scene::{CameraSettings, Projection};

/// The scene's warnings, what was loaded, and the camera ember chose.
pub fn report_loading(plan: &RenderPlan, loaded: &LoadedScene, probe: Option<&CameraProbe>) {
    let report = &loaded.report;
    verbosity::print_warnings(&report.warnings);
    if !verbosity::status() {
        return;
    }
    if loaded.unlit {
        eprintln!(
            "note: the scene has no emissive material and no placed light: it is lit by a white sky (see --background)"
        );
    }
    let dropped = match report.degenerate_dropped {
        0 => String::new(),
        n => format!(", {n} degenerate triangles dropped"),
    };
    // An instanced scene holds each OBJ once: say how much the placements put in the world.
    let placed = match &loaded.scene.instancing {
        None => String::new(),
        Some(instancing) => format!(
            ", placed {} times ({} triangles in the world)",
            instancing.instances.len(),
            instancing.placed_triangles()
        ),
    };
    eprintln!(
        "loaded {}: {}{dropped}{placed}",
        plan.scene.display(),
        report.summary()
    );
    if loaded.automatic_camera || loaded.file_camera.is_some() || verbosity::verbose() {
        let how = match (&loaded.file_camera, loaded.automatic_camera) {
            (Some(name), _) => format!("the file's camera {name:?}"),
            (None, true) => "automatic, framing the scene's bounds from +z".to_owned(),
            (None, false) => "as given".to_owned(),
        };
        eprintln!("camera ({how}): {}", camera_flags(&loaded.camera_settings));
    }
    if let Some(note) = &loaded.size_note {
        eprintln!("note: {note}");
    }
    if let Some(note) = probe.and_then(|p| camera_note(loaded, p)) {
        eprintln!("note: {note}");
    }
}

/// The camera as `ember render` flags, ready to edit (numbers as written, exactly).
pub fn camera_flags(camera: &CameraSettings) -> String {
    let v = |v: glam::Vec3| format!("{},{},{}", v.x, v.y, v.z);
    let projection = match camera.projection {
        Projection::Perspective { vfov_degrees } => format!("--fov {vfov_degrees}"),
        Projection::Orthographic { height } => format!("--ortho-height {height}"),
    };
    let mut flags = format!(
        "--eye {} --look-at {} {projection}",
        v(camera.eye),
        v(camera.look_at),
    );
    if camera.up != glam::Vec3::Y {
        flags += &format!(" --up {}", v(camera.up));
    }
    if !camera.lens.is_pinhole() {
        flags += &format!(" --aperture {}", camera.lens.aperture_radius);
        if let Some(d) = camera.lens.focus_distance {
            flags += &format!(" --focus-distance {d}");
        }
    }
    flags
}

/// One line when the automatic camera's view would render black or from behind: it
/// meets nothing, sees only the back of the surfaces (an interior from outside), or
/// sees no surface any light reaches.
fn camera_note(loaded: &LoadedScene, probe: &CameraProbe) -> Option<String> {
    let (lo, hi) = loaded.scene.bounds();
    let inside = format!(
        "give --eye and --look-at inside its bounds, ({},{},{}) to ({},{},{})",
        lo.x, lo.y, lo.z, hi.x, hi.y, hi.z
    );
    let rays = probe.rays;
    if probe.hits == 0 {
        return Some(format!(
            "none of {rays} probe rays through the image meets the scene: the image will be \
             the sky alone; check --eye and --look-at"
        ));
    }
    match (probe.sees_backs(), probe.sees_nothing_lit()) {
        (true, true) => Some(format!(
            "the automatic camera sees only the outside of a closed model, which no light \
             reaches ({} probe rays): the image will be black; if it is an interior, {inside}",
            probe.hits
        )),
        (false, true) => Some(format!(
            "no light reaches the surfaces the automatic camera sees ({} probe rays met \
             them, none of their shadow rays reached an emitter): the image may come out \
             black; {inside}",
            probe.hits
        )),
        (true, false) => Some(format!(
            "the automatic camera sees the back of the scene's surfaces ({} of {} probe \
             rays): an interior seen from outside? {inside}",
            probe.back_faces, probe.hits
        )),
        (false, false) => None,
    }
}

/// `shard 2/8 (samples 4..6 of 16)`, or nothing for a whole render.
fn shard_note(plan: &RenderPlan) -> String {
    match plan.shard {
        Some((i, n)) => format!(
            ", shard {i}/{n} (samples {}..{})",
            plan.samples.start, plan.samples.end
        ),
        None => String::new(),
    }
}

pub fn report_start(plan: &RenderPlan, film: &Film, timeline: &Timeline, obj_bytes: u64) {
    let s = &plan.settings;
    let resumed = if plan.resume {
        format!(
            ", resuming from {} spp",
            film.samples.start + film.min_done()
        )
    } else {
        String::new()
    };
    if !verbosity::status() {
        return;
    }
    let first_sample = timeline.started.elapsed();
    let loading = timeline.loaded.as_secs_f64();
    // What the rate is of: a glTF's buffers (its binary data), a PLY file, an OBJ's text.
    let read = match ember::scene::ModelFormat::of(&plan.scene) {
        Some(ember::scene::ModelFormat::Gltf) => "glTF buffers",
        Some(ember::scene::ModelFormat::Ply) => "PLY",
        _ => "OBJ",
    };
    eprintln!(
        "rendering {}x{} at {} spp{}{resumed}; first sample after {:.2} s (loading {loading:.3} s \
         at {:.0} MB/s of {read}, accelerator {:.2} s)",
        s.width,
        s.height,
        s.spp,
        shard_note(plan),
        first_sample.as_secs_f64(),
        obj_bytes as f64 / 1e6 / loading.max(1e-9),
        (first_sample - timeline.loaded).as_secs_f64(),
    );
}

/// The line of an interrupted render; `sampled`: whether every pixel had a sample, so
/// that a whole render wrote its partial image.
pub fn report_interrupted(plan: &RenderPlan, film: &Film, signal: usize, sampled: bool) {
    let name = super::super::signal_name(signal);
    let image = match plan.shard {
        None if sampled => format!(
            "the partial image {} and ",
            partial_output(&plan.output).display()
        ),
        None => "no partial image (not every pixel had a sample yet), only ".into(),
        Some(_) => String::new(),
    };
    eprintln!(
        "interrupted by {name} after {} of {} samples per pixel (at least {} in every pixel): \
         wrote {image}the checkpoint {} (continue with --resume)",
        film.total_done() / plan.pixels().max(1),
        film.samples.len(),
        film.min_done(),
        plan.checkpoint.display()
    );
}

/// The summary line of a finished render.
pub fn report_finished(
    plan: &RenderPlan,
    accel: &str,
    stats: &RenderStats,
    passes: &PassReport,
    triangles: usize,
) {
    if !verbosity::status() {
        return;
    }
    let s = &plan.settings;
    let dropped = match stats.dropped_samples {
        0 => String::new(),
        n => format!(", {n} NaN/infinite samples dropped"),
    };
    // Peak resident memory of the whole run, and per triangle what loading at scale
    // costs; below 100k triangles the process and the film outweigh the mesh, and a
    // figure per triangle would only mislead.
    let peak = match ember::limits::peak_resident_bytes() {
        Some(bytes) if triangles >= 100_000 => format!(
            ", peak memory {} ({:.0} bytes/triangle)",
            ember::limits::human_bytes(bytes),
            bytes as f64 / triangles as f64
        ),
        Some(bytes) => format!(", peak memory {}", ember::limits::human_bytes(bytes)),
        None => String::new(),
    };
    let lights = match stats.light_nodes {
        0 => String::new(),
        n => format!(
            ", light BVH of {n} nodes built in {:.1} ms",
            stats.light_build_seconds * 1e3
        ),
    };
    let spp = if s.adaptive.is_some() || plan.time_limit.is_some() {
        spp_summary(passes)
    } else {
        format!("{} spp", s.spp)
    };
    let guiding = stats.guiding.map_or(String::new(), |g| {
        format!(
            ", guiding trained in {:.2} s ({} samples, {} of them in the image; {} regions, {} of them guided, {} nodes, {})",
            g.seconds,
            g.training_samples,
            g.film_samples,
            g.leaves,
            g.guided_leaves,
            g.nodes,
            ember::limits::human_bytes(g.memory_bytes as u64)
        )
    });
    eprintln!(
        "wrote {}: {}x{}, {spp}{}, {accel} in {:.2} s: {:.0} samples/s, {:.2} Mrays/s{guiding}{dropped}{lights}{peak}",
        plan.output.display(),
        s.width,
        s.height,
        shard_note(plan),
        stats.seconds,
        stats.samples_per_second(),
        stats.mrays_per_second(),
    );
}

/// How a render ended, for its JSON summary.
pub enum Outcome<'a> {
    /// The image (or shard) is written; `checkpoint` is the checkpoint left beside it.
    Finished {
        checkpoint: Option<&'a std::path::Path>,
    },
    /// Stopped by `signal`: the checkpoint, and the partial image where `sampled`
    /// (every pixel had a sample; never for a shard).
    Interrupted { signal: usize, sampled: bool },
}

/// The figures of the summary as one JSON object (`--json`).
pub fn summary_json(
    plan: &RenderPlan,
    loaded: &LoadedScene,
    timeline: &Timeline,
    (accel, stats, passes): (&str, &RenderStats, &PassReport),
    outcome: Outcome<'_>,
) -> Value {
    let s = &plan.settings;
    let v = |v: glam::Vec3| json!([v.x, v.y, v.z]);
    let camera = &loaded.camera_settings;
    let path = |p: &std::path::Path| p.display().to_string();
    let (finished, interrupted_by, partial, checkpoint) = match outcome {
        Outcome::Finished { checkpoint } => (true, None, None, checkpoint.map(path)),
        Outcome::Interrupted { signal, sampled } => (
            false,
            Some(super::super::signal_name(signal)),
            (plan.shard.is_none() && sampled).then(|| path(&partial_output(&plan.output))),
            Some(path(&plan.checkpoint)),
        ),
    };
    let report = &loaded.report;
    json!({
        "scene": path(&plan.scene),
        "output": path(&plan.output),
        "finished": finished,
        "interrupted_by": interrupted_by,
        "partial_image": partial,
        "checkpoint": checkpoint,
        "width": s.width,
        "height": s.height,
        "spp": s.spp,
        "samples": [plan.samples.start, plan.samples.end],
        "shard": plan.shard.map(|(i, n)| json!([i, n])),
        "spp_min": passes.min_spp,
        "spp_mean": passes.mean_spp,
        "spp_max": passes.max_spp,
        "converged_fraction": passes.converged_fraction(),
        "accel": accel,
        "integrator": format!("{:?}", s.integrator).to_lowercase(),
        "seconds": stats.seconds,
        "loading_seconds": timeline.loaded.as_secs_f64(),
        "first_sample_seconds": timeline.first_sample.as_secs_f64(),
        "samples_per_second": stats.samples_per_second(),
        "mrays_per_second": stats.mrays_per_second(),
        "dropped_samples": stats.dropped_samples,
        "peak_memory_bytes": ember::limits::peak_resident_bytes(),
        "triangles": report.triangles,
        "materials": report.materials,
        "emissive_triangles": report.emitters,
        "warnings": report.warnings.len(),
        "camera": {
            "eye": v(camera.eye),
            "look_at": v(camera.look_at),
            "up": v(camera.up),
            "fov": camera.projection.vfov_degrees(),
            "ortho_height": camera.projection.ortho_height(),
            "automatic": loaded.automatic_camera,
            "flags": camera_flags(camera),
        },
        "light_bvh": (stats.light_nodes > 0).then(|| json!({
            "nodes": stats.light_nodes,
            "build_seconds": stats.light_build_seconds,
        })),
        "guiding": stats.guiding.map(|g| json!({
            "version": ember::render::GUIDE_VERSION,
            "seconds": g.seconds,
            "training_samples": g.training_samples,
            "film_samples": g.film_samples,
            "regions": g.leaves,
            "guided_regions": g.guided_leaves,
            "nodes": g.nodes,
            "memory_bytes": g.memory_bytes,
        })),
    })
}

/// `spp 16/23.5/64 (min/mean/max), 41.2% converged`.
pub fn spp_summary(report: &PassReport) -> String {
    format!(
        "spp {}/{:.1}/{} (min/mean/max), {:.1}% converged",
        report.min_spp,
        report.mean_spp,
        report.max_spp,
        100.0 * report.converged_fraction()
    )
}
