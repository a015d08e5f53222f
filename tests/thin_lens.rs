//! The thin-lens camera against the thin-lens formula: a small emitter on the plane in
//! focus images as sharply as through a pinhole, and one at another depth spreads over
//! the circle of confusion `aperture · |1 − focus / depth|` (on the plane in focus).

mod common;

use common::{emitting_square, Built};
use ember::image::Image;
use ember::integrator::IntegratorKind;
use ember::render::{render, RenderSettings};
use ember::scene::{CameraSettings, Lens};
use glam::Vec3;

const SIZE: u32 = 128;
const FOV: f32 = 40.0;
const FOCUS: f32 = 4.0;

/// A square emitter of side `side` facing the camera, centred on the view axis at
/// `depth` in front of the eye (at the origin, looking along −z); nothing else.
fn square_at(depth: f32, side: f32) -> Built {
    emitting_square(-depth, side)
}

fn camera(lens: Lens) -> CameraSettings {
    CameraSettings {
        eye: Vec3::ZERO,
        look_at: Vec3::new(0.0, 0.0, -1.0),
        up: Vec3::Y,
        projection: ember::scene::Projection::perspective(FOV),
        lens,
    }
}

fn shoot(built: &Built, lens: Lens, spp: u32) -> Image {
    let settings = RenderSettings {
        width: SIZE,
        height: SIZE,
        spp,
        // Emitters only: the image is where camera rays meet the square.
        max_depth: 1,
        seed: 5,
        integrator: IntegratorKind::Mis,
        light_sampler: Default::default(),
        adaptive: None,
        guiding: None,
        engine: Default::default(),
    };
    let camera = camera(lens).camera(SIZE, SIZE);
    render(&built.scene, &built.accel, &camera, &settings, &|_| {}).0
}

/// The image's total, and the second moment `E[(x − x̄)² + (y − ȳ)²]` of its
/// brightness about its centroid, in pixels².
fn spread(image: &Image) -> (f64, f64) {
    let w = image.width as usize;
    let mut sum = 0.0;
    let (mut sx, mut sy, mut sxx) = (0.0, 0.0, 0.0);
    for (i, p) in image.pixels.iter().enumerate() {
        let v = f64::from(p.x);
        let (x, y) = ((i % w) as f64 + 0.5, (i / w) as f64 + 0.5);
        sum += v;
        sx += v * x;
        sy += v * y;
        sxx += v * (x * x + y * y);
    }
    let (mx, my) = (sx / sum, sy / sum);
    (sum, sxx / sum - mx * mx - my * my)
}

/// Pixels per scene unit on the plane at `depth` (the image spans `2·depth·tan(fov/2)`).
fn pixels_per_unit(depth: f32) -> f64 {
    f64::from(SIZE) / (2.0 * f64::from(depth) * (0.5 * f64::from(FOV)).to_radians().tan())
}

/// The second moment the square should have: its own pinhole image (a square of side
/// `a` pixels, `a²/6` over both axes), the box filter of a pixel (`1/6`), and the lens's
/// blur disk of radius `r` pixels (`r²/2`).
fn expected_spread(depth: f32, side: f32, blur_radius_px: f64) -> f64 {
    let a = f64::from(side) * pixels_per_unit(depth);
    a * a / 6.0 + 1.0 / 6.0 + blur_radius_px * blur_radius_px / 2.0
}

/// The thin-lens circle of confusion for a point at `depth`, in pixels.
fn circle_of_confusion_px(aperture: f32, depth: f32) -> f64 {
    f64::from(aperture) * (1.0 - f64::from(FOCUS) / f64::from(depth)).abs() * pixels_per_unit(FOCUS)
}

fn lens(aperture: f32) -> Lens {
    Lens {
        aperture_radius: aperture,
        focus_distance: Some(FOCUS),
    }
}

#[test]
fn a_square_on_the_plane_in_focus_is_as_sharp_as_through_a_pinhole() {
    let side = 0.1;
    let built = square_at(FOCUS, side);
    let (pin_sum, pin_spread) = spread(&shoot(&built, Lens::PINHOLE, 64));
    let (lens_sum, lens_spread) = spread(&shoot(&built, lens(0.3), 64));
    let expected = expected_spread(FOCUS, side, 0.0);
    for (name, s) in [("pinhole", pin_spread), ("lens", lens_spread)] {
        assert!(
            (s / expected - 1.0).abs() < 0.02,
            "{name}: spread {s:.4} px², expected {expected:.4}"
        );
    }
    // The same light reaches the film either way (the square is small and on axis).
    assert!(
        (lens_sum / pin_sum - 1.0).abs() < 0.01,
        "{lens_sum} vs {pin_sum}"
    );
}

#[test]
fn a_square_off_the_plane_in_focus_spreads_over_the_circle_of_confusion() {
    let aperture = 0.2;
    // Nearer than the plane in focus and farther: blur radii of 8.8 and 4.4 pixels.
    for depth in [2.0, 8.0] {
        // A square 6 pixels wide through a pinhole, so that many samples meet it.
        let side = (6.0 / pixels_per_unit(depth)) as f32;
        let built = square_at(depth, side);
        let (_, measured) = spread(&shoot(&built, lens(aperture), 1024));
        let coc = circle_of_confusion_px(aperture, depth);
        let expected = expected_spread(depth, side, coc);
        // The blur radius the measured spread implies, against the formula's.
        let implied = (2.0 * (measured - expected_spread(depth, side, 0.0))).sqrt();
        assert!(
            (implied / coc - 1.0).abs() < 0.01,
            "depth {depth}: spread {measured:.3} px² (expected {expected:.3}), \
             blur radius {implied:.3} px against the circle of confusion {coc:.3}"
        );
    }
}

#[test]
fn a_lens_of_aperture_zero_is_the_pinhole_bit_for_bit() {
    let built = square_at(3.0, 0.5);
    let bits = |image: &Image| {
        image
            .pixels
            .iter()
            .flat_map(|p| p.to_array().map(f32::to_bits))
            .collect::<Vec<_>>()
    };
    let pinhole = shoot(&built, Lens::PINHOLE, 4);
    let closed = shoot(&built, lens(0.0), 4);
    assert_eq!(bits(&pinhole), bits(&closed));
    // And an open lens changes the image (the square's edge at depth 3 blurs).
    assert_ne!(bits(&pinhole), bits(&shoot(&built, lens(0.1), 4)));
}

#[test]
fn a_lens_is_part_of_the_render_identity_and_a_pinhole_is_not_named() {
    let built = square_at(3.0, 0.5);
    let settings = RenderSettings {
        width: 8,
        height: 8,
        spp: 1,
        max_depth: 1,
        seed: 0,
        integrator: IntegratorKind::Mis,
        light_sampler: Default::default(),
        adaptive: None,
        guiding: None,
        engine: Default::default(),
    };
    let id = |lens: Lens| {
        ember::render::identity(
            &built.scene,
            &camera(lens),
            &settings,
            ember::accel::AccelKind::Embree,
        )
    };
    let pinhole = id(Lens::PINHOLE);
    assert!(pinhole.iter().all(|(k, _)| k != "lens"));
    // Checkpoints of a closed lens resume pinhole renders: it is the same camera.
    assert_eq!(pinhole, id(lens(0.0)));
    let open = id(lens(0.1));
    assert_ne!(pinhole, open);
    assert_ne!(open, id(lens(0.2)));
    assert_ne!(
        open,
        id(Lens {
            aperture_radius: 0.1,
            focus_distance: Some(2.0)
        })
    );
}
