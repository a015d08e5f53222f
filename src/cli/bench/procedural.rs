//! Procedural meshes of any size for benchmarks and tests: a finely subdivided sphere
//! (large, smooth, closed) and a soup of random triangles (overlapping, hard for a BVH).

use std::f32::consts::PI;
use std::fmt;
use std::str::FromStr;

use glam::Vec3;

use ember::sampling::{uniform_sphere, Rng};

/// Which procedural mesh.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ProceduralKind {
    /// A unit sphere as a latitude/longitude grid (triangle fans at the poles).
    Sphere,
    /// Random small triangles in the cube `[-1, 1]³`.
    Soup,
}

/// A procedural mesh request, written `KIND:COUNT` with `KIND` `sphere` or `soup` and
/// `COUNT` the approximate number of triangles, optionally with a `k` or `m` suffix
/// (`sphere:1m`, `soup:250k`, `sphere:5000`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Procedural {
    pub kind: ProceduralKind,
    pub triangles: usize,
}

/// Why a procedural mesh specification could not be read.
#[derive(Debug, thiserror::Error, PartialEq, Eq)]
#[error("invalid procedural mesh {spec:?}: {reason} (expected sphere:COUNT or soup:COUNT, e.g. sphere:1m)")]
pub struct ParseProceduralError {
    spec: String,
    reason: &'static str,
}

/// Most triangles a procedural mesh may have.
pub const MAX_PROCEDURAL_TRIANGLES: usize = 100_000_000;

impl FromStr for Procedural {
    type Err = ParseProceduralError;

    fn from_str(s: &str) -> Result<Self, Self::Err> {
        let err = |reason| ParseProceduralError {
            spec: s.to_owned(),
            reason,
        };
        let (kind, count) = s.trim().split_once(':').ok_or_else(|| err("no ':'"))?;
        let kind = match kind.to_ascii_lowercase().as_str() {
            "sphere" => ProceduralKind::Sphere,
            "soup" => ProceduralKind::Soup,
            _ => return Err(err("unknown kind")),
        };
        let count = count.trim().to_ascii_lowercase();
        let (digits, scale) = match count.strip_suffix('k') {
            Some(d) => (d, 1_000),
            None => match count.strip_suffix('m') {
                Some(d) => (d, 1_000_000),
                None => (count.as_str(), 1),
            },
        };
        let n: f64 = digits
            .parse()
            .map_err(|_| err("the count is not a number"))?;
        let triangles = (n * scale as f64).round();
        if !(triangles >= 1.0 && triangles <= MAX_PROCEDURAL_TRIANGLES as f64) {
            return Err(err("the count must be between 1 and 100m"));
        }
        Ok(Procedural {
            kind,
            triangles: triangles as usize,
        })
    }
}

impl fmt::Display for Procedural {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let kind = match self.kind {
            ProceduralKind::Sphere => "sphere",
            ProceduralKind::Soup => "soup",
        };
        write!(f, "{kind}:{}", self.triangles)
    }
}

/// Bytes of memory `ember bench` holds per triangle of a mesh it measures: the mesh,
/// and the Embree and native BVH structures built on it (each build's, one at a time,
/// beside the ones kept for the traversals). An upper bound of what was measured
/// (benches/results/2026-12-06-memory-estimates.md; pinned by
/// tests/memory_estimates.rs).
pub const BENCH_BYTES_PER_TRIANGLE: u64 = 512;
/// Bytes per ray of each set (primary, diffuse, shadow): the rays, their hits and
/// packets of all three sets (measured as above).
pub const BENCH_BYTES_PER_RAY: u64 = 400;

/// Bytes of memory `ember bench` holds at its peak measuring a mesh of `triangles`
/// with `rays` rays per set.
pub fn bench_memory_bytes(triangles: u64, rays: u64) -> u64 {
    triangles
        .saturating_mul(BENCH_BYTES_PER_TRIANGLE)
        .saturating_add(rays.saturating_mul(BENCH_BYTES_PER_RAY))
}

impl Procedural {
    /// The triangles [`generate`](Self::generate) makes, at most (the sphere's grid
    /// is within a few percent of the request).
    pub fn most_triangles(&self) -> u64 {
        self.triangles as u64 + self.triangles as u64 / 16
    }

    /// Vertices and triangles; the triangle count is close to the request (exact for
    /// the soup, within a few percent for the sphere's grid).
    pub fn generate(&self, seed: u64) -> (Vec<Vec3>, Vec<[u32; 3]>) {
        match self.kind {
            ProceduralKind::Sphere => sphere(self.triangles),
            ProceduralKind::Soup => soup(self.triangles, seed),
        }
    }
}

/// A latitude/longitude unit sphere with about `n` triangles, counter-clockwise seen
/// from outside: `stacks` rings of `2 * stacks` slices, `4 * stacks * (stacks - 1)`
/// triangles.
fn sphere(n: usize) -> (Vec<Vec3>, Vec<[u32; 3]>) {
    let stacks = ((1.0 + (1.0 + n as f64).sqrt()) / 2.0).round().max(2.0) as u32;
    let slices = 2 * stacks;
    let mut vertices = vec![Vec3::Y, -Vec3::Y];
    // Ring r (1..stacks) at polar angle r·π/stacks, slice s at azimuth s·2π/slices.
    for r in 1..stacks {
        let theta = PI * r as f32 / stacks as f32;
        for s in 0..slices {
            let phi = 2.0 * PI * s as f32 / slices as f32;
            vertices.push(Vec3::new(
                theta.sin() * phi.cos(),
                theta.cos(),
                -theta.sin() * phi.sin(),
            ));
        }
    }
    let at = |r: u32, s: u32| 2 + (r - 1) * slices + s % slices;
    let mut triangles = Vec::with_capacity((4 * stacks * (stacks - 1)) as usize);
    for s in 0..slices {
        triangles.push([0, at(1, s), at(1, s + 1)]);
        triangles.push([1, at(stacks - 1, s + 1), at(stacks - 1, s)]);
    }
    for r in 1..stacks - 1 {
        for s in 0..slices {
            let (a, b, c, d) = (at(r, s), at(r, s + 1), at(r + 1, s), at(r + 1, s + 1));
            triangles.push([a, c, d]);
            triangles.push([a, d, b]);
        }
    }
    (vertices, triangles)
}

/// `n` random triangles with centres uniform in `[-1, 1]³` and edges about as long as
/// the mean spacing of the centres, so neighbours overlap a little.
fn soup(n: usize, seed: u64) -> (Vec<Vec3>, Vec<[u32; 3]>) {
    let mut rng = Rng::seeded(seed ^ 0x5eed_5000);
    let size = 2.0 / (n as f32).cbrt();
    let mut vertices = Vec::with_capacity(3 * n);
    for _ in 0..n {
        let c = Vec3::new(rng.f32(), rng.f32(), rng.f32()) * 2.0 - 1.0;
        for _ in 0..3 {
            vertices.push(c + 0.5 * size * uniform_sphere(rng.f32(), rng.f32()));
        }
    }
    let triangles = (0..n as u32)
        .map(|t| [3 * t, 3 * t + 1, 3 * t + 2])
        .collect();
    (vertices, triangles)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parses_counts_with_suffixes() {
        let p: Procedural = "sphere:1m".parse().unwrap();
        assert_eq!(
            p,
            Procedural {
                kind: ProceduralKind::Sphere,
                triangles: 1_000_000
            }
        );
        let p: Procedural = "SOUP:2.5k".parse().unwrap();
        assert_eq!(
            p,
            Procedural {
                kind: ProceduralKind::Soup,
                triangles: 2500
            }
        );
        for bad in ["sphere", "cube:10", "sphere:x", "sphere:0", "soup:1000m"] {
            assert!(bad.parse::<Procedural>().is_err(), "{bad}");
        }
    }

    #[test]
    fn sphere_is_close_to_the_request_and_closed() {
        for n in [1000, 12_345, 1_000_000] {
            let (_, t) = sphere(n);
            let rel = (t.len() as f64 - n as f64).abs() / n as f64;
            assert!(rel < 0.05, "{n}: {} triangles", t.len());
        }
        for n in [1000, 12_345] {
            let (v, t) = sphere(n);
            assert!(v.iter().all(|p| (p.length() - 1.0).abs() < 1e-5));
            // Closed 2-manifold: every undirected edge is used by exactly two triangles,
            // once in each direction (consistent winding).
            let mut edges = std::collections::HashMap::new();
            for tri in &t {
                for k in 0..3 {
                    *edges.entry((tri[k], tri[(k + 1) % 3])).or_insert(0) += 1;
                }
            }
            assert!(edges
                .iter()
                .all(|(&(a, b), &c)| c == 1 && edges.get(&(b, a)) == Some(&1)));
            // Outward winding: the area normal points away from the centre.
            let [a, b, c] = t[t.len() / 2].map(|i| v[i as usize]);
            assert!((b - a).cross(c - a).dot(a) > 0.0);
        }
    }

    #[test]
    fn soup_has_the_exact_count_inside_the_cube() {
        let (v, t) = soup(1000, 7);
        assert_eq!(t.len(), 1000);
        assert!(v.iter().all(|p| p.abs().max_element() < 1.0 + 0.2));
    }
}
