//! The sampling building blocks against their mathematical definitions.

use std::f64::consts::PI;

use ember::sampling::{cosine_hemisphere, Onb, Rng};
use glam::Vec3;

/// Upper 0.1% quantile of chi-square with `dof` degrees of freedom (Wilson–Hilferty).
fn chi2_critical(dof: usize) -> f64 {
    let k = dof as f64;
    let z = 3.09; // one-sided 99.9%
    k * (1.0 - 2.0 / (9.0 * k) + z * (2.0 / (9.0 * k)).sqrt()).powi(3)
}

#[test]
fn cosine_samples_follow_cos_theta_over_pi() {
    // Bins in (cos θ, φ); the expected count of each bin is N × ∫ cos θ / π dω over it,
    // computed exactly: ∫ cos θ sin θ dθ dφ / π = (c1² − c0²) Δφ / (2π) for c = cos θ.
    const THETA_BINS: usize = 10;
    const PHI_BINS: usize = 16;
    const N: usize = 400_000;
    let mut counts = [[0usize; PHI_BINS]; THETA_BINS];
    let mut rng = Rng::seeded(1);
    for _ in 0..N {
        let d = cosine_hemisphere(rng.f32(), rng.f32());
        assert!((d.length() - 1.0).abs() < 1e-5, "not unit: {d}");
        assert!(d.z >= 0.0, "below the hemisphere: {d}");
        let ct = (d.z as f64).clamp(0.0, 1.0 - 1e-12);
        let phi = (d.y as f64).atan2(d.x as f64).rem_euclid(2.0 * PI);
        let i = (ct * THETA_BINS as f64) as usize;
        let j = ((phi / (2.0 * PI)) * PHI_BINS as f64) as usize % PHI_BINS;
        counts[i][j] += 1;
    }
    let mut chi2 = 0.0;
    for (i, row) in counts.iter().enumerate() {
        let (c0, c1) = (
            i as f64 / THETA_BINS as f64,
            (i + 1) as f64 / THETA_BINS as f64,
        );
        let p = (c1 * c1 - c0 * c0) / PHI_BINS as f64;
        for &observed in row {
            let expected = p * N as f64;
            chi2 += (observed as f64 - expected).powi(2) / expected;
        }
    }
    let dof = THETA_BINS * PHI_BINS - 1;
    assert!(chi2 < chi2_critical(dof), "chi2 {chi2} over {dof} dof");
}

#[test]
fn onb_is_orthonormal_and_right_handed_for_any_normal() {
    let mut rng = Rng::seeded(9);
    let mut normals: Vec<Vec3> = (0..10_000)
        .map(|_| ember::sampling::uniform_sphere(rng.f32(), rng.f32()))
        .collect();
    // The classic trouble spots: the poles and the axes.
    normals.extend([Vec3::Z, -Vec3::Z, Vec3::X, -Vec3::X, Vec3::Y, -Vec3::Y]);
    normals.push(Vec3::new(0.0, 1e-7, -1.0).normalize());
    for w in normals {
        let onb = Onb::from_w(w);
        for (a, b) in [(onb.u, onb.v), (onb.v, onb.w), (onb.u, onb.w)] {
            assert!(a.dot(b).abs() < 1e-5, "not orthogonal for {w}");
        }
        for e in [onb.u, onb.v, onb.w] {
            assert!((e.length() - 1.0).abs() < 1e-5, "not unit for {w}");
        }
        assert!(onb.u.cross(onb.v).dot(onb.w) > 0.999, "left-handed for {w}");
        let d = Vec3::new(0.3, -0.4, 0.866);
        assert!((onb.to_local(onb.to_world(d)) - d).length() < 1e-5);
    }
}

#[test]
fn random_streams_are_uniform_and_distinct() {
    // Mean and variance of U[0,1): 1/2 and 1/12, over many (pixel, sample) streams.
    let mut sum = 0.0f64;
    let mut sum2 = 0.0f64;
    let n = 200_000;
    for i in 0..n {
        let x = Rng::for_sample(5, i / 16, i % 16).f32() as f64;
        assert!((0.0..1.0).contains(&x));
        sum += x;
        sum2 += x * x;
    }
    let mean = sum / n as f64;
    let var = sum2 / n as f64 - mean * mean;
    assert!(
        (mean - 0.5).abs() < 4.0 * (1.0 / 12.0 / n as f64).sqrt(),
        "{mean}"
    );
    assert!((var - 1.0 / 12.0).abs() < 2e-3, "{var}");
    assert_ne!(
        Rng::for_sample(1, 2, 3).f32(),
        Rng::for_sample(1, 3, 2).f32()
    );
}

/// Whether the 2^m points tile every elementary interval of area 2^-m (boxes of
/// `2^-a × 2^-(m-a)`) exactly once: the (0, m, 2)-net property of the first two
/// dimensions of a Sobol sequence, which Owen scrambling keeps.
fn is_02_net(points: &[(f32, f32)]) -> bool {
    let m = points.len().trailing_zeros();
    assert_eq!(points.len(), 1 << m);
    (0..=m).all(|a| {
        let (nx, ny) = (1usize << a, 1usize << (m - a));
        let mut seen = vec![false; points.len()];
        points.iter().all(|&(x, y)| {
            let cell = (x * nx as f32) as usize * ny + (y * ny as f32) as usize;
            !std::mem::replace(&mut seen[cell], true)
        })
    })
}

#[test]
fn a_pixels_samples_are_stratified_in_the_pixel_and_at_the_first_vertex() {
    for pixel in [0u64, 7, 123_456] {
        let mut camera = Vec::new();
        let mut first_vertex = Vec::new();
        for sample in 0..64 {
            let mut rng = Rng::for_pixel_sample(3, pixel, sample);
            camera.push(rng.pair());
            rng.start_vertex(1);
            first_vertex.push(rng.pair());
        }
        assert!(is_02_net(&camera), "pixel {pixel}: camera draws");
        assert!(
            is_02_net(&first_vertex),
            "pixel {pixel}: first-vertex draws"
        );
        // Independent draws are almost never a net (64 points in 64 cells, all once).
        let random: Vec<_> = (0..64)
            .map(|s| Rng::for_sample(3, pixel, s).pair())
            .collect();
        assert!(!is_02_net(&random));
    }
    // Pixels get differently scrambled sequences.
    let first = |pixel| Rng::for_pixel_sample(3, pixel, 0).f32();
    assert_ne!(first(1), first(2));
}

/// Each sample on its own must be uniform, whichever sample of whichever pixel it is,
/// at every depth and past the sequence's 2^16 points (where the stream is PCG's).
#[test]
fn stratified_draws_are_uniform_over_pixels() {
    for sample in [0u64, 1, 37, 65_535, 65_536, 1 << 20] {
        let n = 40_000;
        let (mut sum, mut sum2) = ([0.0f64; 3], [0.0f64; 3]);
        for pixel in 0..n {
            let mut rng = Rng::for_pixel_sample(9, pixel, sample);
            let camera = rng.f32();
            rng.start_vertex(1);
            let vertex1 = rng.f32();
            rng.start_vertex(2);
            let vertex2 = rng.f32();
            for (k, x) in [camera, vertex1, vertex2].into_iter().enumerate() {
                assert!((0.0..1.0).contains(&x));
                sum[k] += f64::from(x);
                sum2[k] += f64::from(x) * f64::from(x);
            }
        }
        for k in 0..3 {
            let mean = sum[k] / n as f64;
            let var = sum2[k] / n as f64 - mean * mean;
            let sigma = (1.0 / 12.0 / n as f64).sqrt();
            assert!(
                (mean - 0.5).abs() < 5.0 * sigma,
                "sample {sample} draw {k}: mean {mean}"
            );
            assert!(
                (var - 1.0 / 12.0).abs() < 4e-3,
                "sample {sample} draw {k}: var {var}"
            );
        }
    }
}

#[test]
fn fine_draws_cover_their_cells_uniformly() {
    // `below` cuts a draw into up to 2^32 cells: with a million cells, each must be
    // about equally likely, which 23-bit floats alone could not give (2^23 / 10^6 is
    // not an integer, so some cells would get 8 values and others 9: 12% apart).
    let n = 1_000_000u32;
    let mut rng = Rng::seeded(4);
    let draws = 4_000_000;
    let mut per_residue = [0u32; 9];
    for _ in 0..draws {
        let i = rng.below(n);
        assert!(i < n);
        // Cells whose 23-bit float coverage would differ fall in different residues.
        per_residue[((u64::from(i) << 23) % u64::from(n) * 9 / u64::from(n)) as usize] += 1;
    }
    let expected = draws as f64 / 9.0;
    for (r, &c) in per_residue.iter().enumerate() {
        assert!(
            (f64::from(c) - expected).abs() < 5.0 * expected.sqrt(),
            "residue class {r}: {c} draws, expected {expected}"
        );
    }
}
