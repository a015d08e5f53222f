//! What the fuzz targets share (tests/fuzz_*.rs, stable toolchain, proptest): the run
//! loop (a bounded number of cases under `cargo test`; batches until
//! `EMBER_FUZZ_SECONDS` have passed under .ci/fuzz.sh) and a tiny Embree render of
//! whatever scene an input loaded into.

use std::sync::OnceLock;
use std::time::{Duration, Instant};

use ember::accel::{instanced_bvh, instanced_embree, Accel, EmbreeAccel};
use ember::embree::{BuildQuality, Device};
use ember::integrator::IntegratorKind;
use ember::render::{self, RenderSettings};
use ember::scene::{CameraSettings, Scene};
use proptest::prelude::*;
use proptest::test_runner::{Config, TestRunner};

/// Runs `check` on inputs from `strategy`: one batch of 256 by default, batches until
/// `EMBER_FUZZ_SECONDS` seconds have passed when that is set. A failing input panics
/// with proptest's (shrunk) case. `check` returns whether the input got through (was
/// loaded, read) rather than refused; the summary line printed at the end, starting
/// with `name`, counts both, with `through` saying what getting through is.
pub fn run<T: std::fmt::Debug>(
    name: &str,
    through: &str,
    strategy: impl Strategy<Value = T>,
    check: impl Fn(&T) -> Result<bool, TestCaseError>,
) {
    let seconds: Option<u64> = std::env::var("EMBER_FUZZ_SECONDS")
        .ok()
        .and_then(|s| s.parse().ok());
    let batch = 256;
    let start = Instant::now();
    let mut inputs = 0u64;
    let slowest = std::cell::Cell::new(Duration::ZERO);
    let passed = std::cell::Cell::new(0u64);
    loop {
        // A fresh runner per batch: each starts from a new random seed.
        let mut runner = TestRunner::new(Config {
            cases: batch,
            failure_persistence: None,
            ..Config::default()
        });
        let result = runner.run(&strategy, |input| {
            let t = Instant::now();
            let r = check(&input);
            slowest.set(slowest.get().max(t.elapsed()));
            passed.set(passed.get() + u64::from(matches!(r, Ok(true))));
            r.map(drop)
        });
        inputs += u64::from(batch);
        if let Err(e) = result {
            panic!("{name}: fuzz failure after ~{inputs} inputs: {e}");
        }
        match seconds {
            Some(s) if start.elapsed() < Duration::from_secs(s) => {}
            _ => break,
        }
    }
    eprintln!(
        "{name}: {inputs} inputs ({} {through}) in {:.1} s, slowest {:.1} ms",
        passed.get(),
        start.elapsed().as_secs_f64(),
        slowest.get().as_secs_f64() * 1e3
    );
}

fn device() -> &'static Device {
    static DEVICE: OnceLock<Device> = OnceLock::new();
    DEVICE.get_or_init(|| Device::new("threads=1").expect("Embree device"))
}

/// Builds the Embree scene and renders 4x4 pixels at 1 sample, framing the scene: the
/// loader must never hand the rest of ember something that makes it panic. Returns
/// how many samples were NaN or infinite (dropped by the film).
pub fn render_tiny(scene: &Scene) -> Result<u64, TestCaseError> {
    let accel = EmbreeAccel::build(
        device(),
        &scene.mesh.positions,
        &scene.mesh.triangles,
        BuildQuality::Low,
    );
    let accel = match accel {
        Ok(a) => a,
        Err(e) => return Err(TestCaseError::fail(format!("Embree build failed: {e}"))),
    };
    render_on(scene, &accel, 4)
}

/// Renders 4x4 pixels at 1 sample on `accel`, framing the scene; every pixel must be
/// finite. Returns how many samples were NaN or infinite (dropped by the film).
fn render_on<A: Accel>(scene: &Scene, accel: &A, max_depth: u32) -> Result<u64, TestCaseError> {
    let (lo, hi) = scene.bounds();
    let camera = CameraSettings::framing(lo, hi, 40.0);
    if camera.validate().is_err() {
        return Ok(0);
    }
    let settings = RenderSettings {
        width: 4,
        height: 4,
        spp: 1,
        max_depth,
        seed: 1,
        integrator: IntegratorKind::Bsdf,
        light_sampler: Default::default(),
        adaptive: None,
        guiding: None,
        engine: Default::default(),
    };
    let (film, stats) = render::render(scene, accel, &camera.camera(4, 4), &settings, &|_| {});
    prop_assert!(film.pixels.iter().all(|p| p.is_finite()));
    Ok(stats.dropped_samples)
}

/// An instanced scene on both backends; a plain one on Embree ([`render_tiny`]).
pub fn render_both(scene: &Scene) -> Result<(), TestCaseError> {
    let Some(instancing) = &scene.instancing else {
        return render_tiny(scene).map(drop);
    };
    let embree = instanced_embree(device(), &scene.mesh, instancing, BuildQuality::Low, None)
        .map_err(|e| TestCaseError::fail(format!("Embree build failed: {e}")))?;
    render_on(scene, &embree, 3)?;
    let bvh = instanced_bvh(&scene.mesh, instancing)
        .map_err(|e| TestCaseError::fail(format!("BVH build failed: {e}")))?;
    render_on(scene, &bvh, 3).map(drop)
}
