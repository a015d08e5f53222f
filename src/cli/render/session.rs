//! One render from a loaded scene and a built accelerator: the film (new, or resumed
//! from its checkpoint), the passes with their progress bar, periodic snapshots for
//! checkpoints and the live preview, signals, and the files written at the end.

use std::path::Path;
use std::process::ExitCode;
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::Mutex;
use std::time::{Duration, Instant};

use anyhow::{Context, Result};
use glam::Vec3;
use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};

use super::super::tev::Display;
use super::super::verbosity;
use super::load::LoadedScene;
use super::plan::{partial_output, RenderPlan};
use super::report::{
    report_finished, report_interrupted, report_loading, report_start, spp_summary, summary_json,
    Outcome,
};
use super::Timeline;
use ember::accel::Accel;
use ember::film::checkpoint;
use ember::film::output::FilmOutput;
use ember::film::Film;
use ember::guiding::SdTree;
use ember::image;
use ember::render::{self, Checkpointing, GuideView, PassReport, RenderControl, RenderStats};

/// Renders with checkpoints and signal handling, then writes the image or shard (or,
/// when interrupted, the partial image and a checkpoint).
pub fn finish_render<A: Accel>(
    plan: &RenderPlan,
    loaded: &LoadedScene,
    pool: &rayon::ThreadPool,
    accel: &A,
    timeline: &Timeline,
) -> Result<ExitCode> {
    let identity = render::identity(
        &loaded.scene,
        &loaded.camera_settings,
        &plan.settings,
        plan.accel,
    );
    let film = if plan.resume {
        checkpoint::load(&plan.checkpoint, &identity, plan.samples.clone())?
    } else {
        let s = &plan.settings;
        Film::new(s.width, s.height, plan.samples.clone())
    };
    let header = plan.header(identity);
    // From here on Ctrl-C or SIGTERM stops the workers and writes what there is.
    let stop = super::super::stop_on_signals()?;
    let save_checkpoint = |film: &Film| -> Result<()> {
        checkpoint::save(&plan.checkpoint, &header, film).context("cannot write the checkpoint")
    };
    let display = plan.display.clone().map(|address| {
        let name = plan.output.file_name().unwrap_or_default();
        let s = &plan.settings;
        Display::start(
            address,
            name.to_string_lossy().into_owned(),
            s.width,
            s.height,
        )
    });
    let snapshots = Snapshots::new(plan.checkpoint_every, display.is_some());
    let periodic = |film: &Film| {
        if let Some(display) = &display {
            display.show(film.resolve());
        }
        if snapshots.checkpoint_due() {
            if let Err(e) = save_checkpoint(film) {
                eprintln!("warning: {e:#}");
            }
        }
    };
    // Only now that every input has been checked: a failing run prints one line.
    let probe = loaded.automatic_camera.then(|| {
        let size = (plan.settings.width, plan.settings.height);
        render::probe_camera(&loaded.scene, accel, &loaded.camera, size)
    });
    report_loading(plan, loaded, probe.as_ref());
    let timeline = timeline.at_first_sample();
    report_start(plan, &film, &timeline, loaded.report.obj_bytes);
    let checkpointing = snapshots.every.map(|every| Checkpointing {
        every,
        write: &periodic,
    });
    let (film, stats, passes, view) =
        pool.install(|| render_with_progress(loaded, accel, plan, film, &stop, checkpointing));
    if let Some(display) = display {
        display.finish(film.resolve());
    }
    let figures = (accel.name(), &stats, &passes);
    let signal = stop.load(Ordering::SeqCst);
    if signal != 0 && !film.is_complete() {
        let partial = partial_output(&plan.output);
        // An image is written only where every pixel has a sample.
        let sampled = film.min_done() > 0;
        match plan.shard {
            None if sampled => write_both(
                &partial,
                || write_film_image(plan, &film, &partial),
                || save_checkpoint(&film),
            )?,
            _ => save_checkpoint(&film)?,
        }
        report_interrupted(plan, &film, signal, sampled);
        if plan.json {
            let outcome = Outcome::Interrupted { signal, sampled };
            super::super::print_json(&summary_json(plan, loaded, &timeline, figures, outcome));
        }
        return Ok(ExitCode::from((128 + signal).min(255) as u8));
    }
    if let (true, Some(limit), true) =
        (stats.deadline_overrun, plan.time_limit, verbosity::status())
    {
        eprintln!(
            "note: --time-limit {} s ended before every pixel had a sample: rendered on \
             until each had one",
            limit.as_secs_f64()
        );
    }
    let kept = write_finished(plan, &film, || save_checkpoint(&film))?;
    report_finished(plan, accel.name(), &stats, &passes, loaded.report.triangles);
    if let Some((path, pixel)) = &plan.guide_image {
        write_guide_image(path, *pixel, view, plan.guide_sky)?;
    }
    if plan.json {
        let outcome = Outcome::Finished { checkpoint: kept };
        super::super::print_json(&summary_json(plan, loaded, &timeline, figures, outcome));
    }
    Ok(ExitCode::SUCCESS)
}

/// Writes a finished render: the shard file, or the image (and, with
/// `--checkpoint-every`, its final checkpoint, which a later `--resume` with a higher
/// `--spp` refines). A resumed render's checkpoint and partial image, no longer needed,
/// are removed. Returns the checkpoint left beside the image, if any.
fn write_finished<'p>(
    plan: &'p RenderPlan,
    film: &Film,
    save_checkpoint: impl FnOnce() -> Result<()>,
) -> Result<Option<&'p Path>> {
    if plan.shard.is_some() {
        save_checkpoint()?;
        return Ok(None);
    }
    let write_image = || write_film_image(plan, film, &plan.output);
    if plan.checkpoint_every.is_some() {
        write_both(&plan.output, write_image, save_checkpoint)?;
    } else {
        write_image()?;
    }
    if plan.resume {
        let mut leftovers = vec![partial_output(&plan.output)];
        if plan.checkpoint_every.is_none() {
            leftovers.push(plan.checkpoint.clone());
        }
        for path in leftovers.iter().filter(|p| p.exists()) {
            match std::fs::remove_file(path) {
                Ok(()) if verbosity::verbose() => eprintln!("removed {}", path.display()),
                Ok(()) => {}
                Err(e) => eprintln!(
                    "warning: cannot remove {}, which the finished render no longer needs: {e}",
                    path.display()
                ),
            }
        }
    }
    let kept = plan
        .checkpoint_every
        .is_some()
        .then_some(plan.checkpoint.as_path());
    if let (Some(path), true) = (kept, verbosity::status()) {
        eprintln!(
            "kept the checkpoint {} (--resume with a higher --spp refines the image; \
             delete it when done)",
            path.display()
        );
    }
    Ok(kept)
}

/// How often the film is snapshotted while rendering: for checkpoints every
/// `--checkpoint-every`, and for `--display` about once a second.
struct Snapshots {
    every: Option<Duration>,
    checkpoint_every: Option<Duration>,
    last_checkpoint: Mutex<Instant>,
}

impl Snapshots {
    /// The live preview's interval.
    const DISPLAY_EVERY: Duration = Duration::from_secs(1);

    fn new(checkpoint_every: Option<Duration>, display: bool) -> Snapshots {
        let every = match (checkpoint_every, display) {
            (Some(c), true) => Some(c.min(Self::DISPLAY_EVERY)),
            (None, true) => Some(Self::DISPLAY_EVERY),
            (c, false) => c,
        };
        Snapshots {
            every,
            checkpoint_every,
            last_checkpoint: Mutex::new(Instant::now()),
        }
    }

    /// Whether this snapshot is also a checkpoint: the first past `--checkpoint-every`
    /// since the last (snapshots come a little late, so half an interval early counts).
    fn checkpoint_due(&self) -> bool {
        let (Some(checkpoint), Some(every)) = (self.checkpoint_every, self.every) else {
            return false;
        };
        let mut last = self
            .last_checkpoint
            .lock()
            .unwrap_or_else(|p| p.into_inner());
        if last.elapsed() + every / 2 >= checkpoint {
            *last = Instant::now();
            return true;
        }
        false
    }
}

/// `--guide-image`'s size: twice as wide as high, as the sphere's azimuth spans twice
/// the range of its z.
const GUIDE_IMAGE_SIZE: (u32, u32) = (256, 128);

/// Writes `--guide-image` (the density as grey; the sky's with `sky`) and says what it
/// shows.
fn write_guide_image(
    path: &Path,
    (x, y): (u32, u32),
    view: Option<GuideView>,
    sky: bool,
) -> Result<()> {
    let Some(view) = view else {
        eprintln!(
            "warning: pixel {x},{y} meets no surface that scatters diffusely or glossily \
             within --max-depth: no --guide-image written"
        );
        return Ok(());
    };
    let (picture, what) = match sky {
        false => (&view.all_light, "the guide"),
        true => (&view.sky, "the sky's guide"),
    };
    // A PNG shows the density relative to its densest pixel (white); EXR and HDR hold
    // the density itself.
    let densest = picture.density.iter().fold(0.0f32, |a, &b| a.max(b));
    let png = image::OutputFormat::from_path(path)? == image::OutputFormat::Png;
    let scale = if png && densest > 0.0 {
        1.0 / densest
    } else {
        1.0
    };
    let image = image::Image {
        width: picture.width,
        height: picture.height,
        pixels: picture
            .density
            .iter()
            .map(|&d| Vec3::splat(d * scale))
            .collect(),
    };
    image.save(path)?;
    let (p, n) = (view.p, view.normal);
    eprintln!(
        "wrote {}: {what} at pixel {x},{y}'s first vertex ({:.3},{:.3},{:.3}), normal \
         ({:.2},{:.2},{:.2}): selection {:.1}, sky share {:.1}, {:.1}% of its mass below the surface, \
         densest {densest:.3} per steradian",
        path.display(),
        p.x,
        p.y,
        p.z,
        n.x,
        n.y,
        n.z,
        view.selection,
        view.sky_share,
        100.0 * picture.below
    );
    Ok(())
}

/// Writes the film's image to `path`: denoised with `--denoise` (the noisy image kept
/// as a layer in an EXR), with the `--aov` passes as layers of an EXR.
fn write_film_image(plan: &RenderPlan, film: &Film, path: &Path) -> Result<()> {
    let output = FilmOutput {
        aovs: &plan.aovs,
        denoise: plan.denoise,
        tonemap: &plan.tonemap,
    };
    Ok(output.write(film, path)?)
}

/// Writes the image at `image` and then the checkpoint; when the checkpoint fails, the
/// image is removed again: a run that fails leaves no file behind.
fn write_both(
    image: &Path,
    write_image: impl FnOnce() -> Result<()>,
    write_checkpoint: impl FnOnce() -> Result<()>,
) -> Result<()> {
    write_image()?;
    write_checkpoint().inspect_err(|_| {
        let _ = std::fs::remove_file(image);
    })
}

fn render_with_progress<A: Accel>(
    loaded: &LoadedScene,
    accel: &A,
    plan: &RenderPlan,
    film: Film,
    stop: &AtomicUsize,
    checkpoint: Option<Checkpointing<'_>>,
) -> (Film, RenderStats, PassReport, Option<GuideView>) {
    let settings = &plan.settings;
    let started = Instant::now();
    let deadline = plan.time_limit.map(|limit| started + limit);
    // A time-limited render's bar is its time; any other's, its samples, less those
    // that converged pixels will not take.
    let bar = match plan.time_limit {
        Some(limit) => ProgressBar::new(limit.as_millis().max(1) as u64),
        None => {
            let pixels = u64::from(settings.width) * u64::from(settings.height);
            let bar = ProgressBar::new(pixels * film.samples.len() as u64);
            bar.set_position(film.total_done());
            bar
        }
    };
    if !verbosity::status() {
        bar.set_draw_target(ProgressDrawTarget::hidden());
    }
    bar.set_style(
        ProgressStyle::with_template(
            "{spinner} [{elapsed_precise}] {wide_bar} {percent}% (eta {eta}) {msg}",
        )
        .expect("static template is valid"),
    );
    let on_samples = |samples: u64| match plan.time_limit {
        Some(limit) => bar.set_position(started.elapsed().min(limit).as_millis() as u64),
        None => bar.inc(samples),
    };
    let on_pass = |report: &PassReport| {
        if plan.time_limit.is_none() {
            bar.set_length(bar.position() + report.remaining);
        }
        if settings.adaptive.is_some() || plan.time_limit.is_some() {
            bar.set_message(spp_summary(report));
        }
    };
    let (scene, camera) = (&loaded.scene, &loaded.camera);
    let view = Mutex::new(None);
    let on_guide = |tree: &SdTree| {
        if let Some((_, pixel)) = plan.guide_image {
            let size = GUIDE_IMAGE_SIZE;
            let seen =
                render::guide_view(scene, accel, camera, tree, pixel, settings.max_depth, size);
            *view.lock().unwrap_or_else(|p| p.into_inner()) = seen;
        }
    };
    let control = RenderControl {
        stop,
        on_samples: &on_samples,
        first_pass_spp: 1,
        checkpoint,
        deadline,
        on_pass: &on_pass,
        on_guide: Some(&on_guide),
    };
    let (film, stats) = render::render_progressive(scene, accel, camera, settings, film, &control);
    bar.finish_and_clear();
    let report = PassReport::of(&film);
    let view = view.into_inner().unwrap_or_else(|p| p.into_inner());
    (film, stats, report, view)
}
