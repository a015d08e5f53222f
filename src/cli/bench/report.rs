//! What `ember bench` measured, and how it is shown: one [`Measurement`] per row, the
//! human-readable table and the JSON document.

use std::fmt::Write;

use serde_json::{json, Value};

/// What a measurement measured.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Mode {
    Build,
    Primary,
    Diffuse,
    Shadow,
    /// Embree queries that end at once (empty interval): the fixed cost of one call
    /// through ember's wrapper and the FFI, an upper bound of the wrapper's overhead.
    CallOverhead,
}

impl Mode {
    pub fn as_str(self) -> &'static str {
        match self {
            Mode::Build => "build",
            Mode::Primary => "primary",
            Mode::Diffuse => "diffuse",
            Mode::Shadow => "shadow",
            Mode::CallOverhead => "call_overhead",
        }
    }
}

/// How rays were handed to the structure.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Api {
    Single,
    /// Embree's `rtcIntersect8` / `rtcOccluded8`.
    Packet8,
    /// Embree called directly (rays in its own layout, bare `rtcIntersect1` calls), the
    /// baseline of the wrapper's cost.
    Direct,
}

impl Api {
    pub fn as_str(self) -> &'static str {
        match self {
            Api::Single => "single",
            Api::Packet8 => "packet8",
            Api::Direct => "direct",
        }
    }
}

/// One line of the table, one object of the JSON `results`.
#[derive(Clone, Debug, PartialEq)]
pub struct Measurement {
    pub mesh: String,
    pub triangles: usize,
    pub backend: &'static str,
    pub mode: Mode,
    pub api: Api,
    pub threads: usize,
    /// Embree's build quality (`low`, `medium`, `high`) for Embree builds.
    pub quality: Option<&'static str>,
    pub build_ms: Option<f64>,
    pub mrays_per_s: Option<f64>,
    /// Rays per pass and how many of them hit (or were occluded).
    pub rays: usize,
    pub hits: usize,
    /// Bytes of the structure measured (for traversal: the one traced).
    pub memory_bytes: usize,
    /// See [`super::timing::Traced::cpu_per_wall`].
    pub cpu_per_wall: Option<f64>,
}

impl Measurement {
    pub fn to_json(&self) -> Value {
        let mut v = json!({
            "mesh": self.mesh,
            "triangles": self.triangles,
            "backend": self.backend,
            "mode": self.mode.as_str(),
            "api": self.api.as_str(),
            "threads": self.threads,
            "memory_bytes": self.memory_bytes,
        });
        let obj = v.as_object_mut().expect("json! object");
        if let Some(q) = self.quality {
            obj.insert("quality".into(), q.into());
        }
        if let Some(ms) = self.build_ms {
            obj.insert("build_ms".into(), ms.into());
        }
        if let Some(m) = self.mrays_per_s {
            obj.insert("mrays_per_s".into(), m.into());
            obj.insert("rays".into(), self.rays.into());
            obj.insert("hits".into(), self.hits.into());
            if let Some(c) = self.cpu_per_wall {
                obj.insert("cpu_per_wall".into(), c.into());
            }
        }
        v
    }
}

/// How long an OBJ mesh took to read into a scene (positions, triangles, materials and
/// textures), as `ember render` reads it: the first part of its time to first sample.
#[derive(Clone, Debug, PartialEq)]
pub struct Loading {
    pub mesh: String,
    pub file_bytes: u64,
    pub seconds: f64,
}

impl Loading {
    pub fn mb_per_s(&self) -> f64 {
        self.file_bytes as f64 / 1e6 / self.seconds.max(1e-9)
    }

    /// One line for the table and the progress output.
    pub fn summary(&self) -> String {
        format!(
            "scene read in {:.3} s (OBJ {:.1} MB at {:.0} MB/s, with its MTL and textures)",
            self.seconds,
            self.file_bytes as f64 / 1e6,
            self.mb_per_s()
        )
    }

    fn to_json(&self) -> Value {
        json!({
            "mesh": self.mesh,
            "file_bytes": self.file_bytes,
            "seconds": self.seconds,
            "mb_per_s": self.mb_per_s(),
        })
    }
}

/// The JSON document `ember bench --json` prints: the measurements and the setup.
pub fn to_json(
    results: &[Measurement],
    loadings: &[Loading],
    rays_per_set: usize,
    threads: &[usize],
    embree_version: &str,
) -> Value {
    json!({
        "ember_version": env!("CARGO_PKG_VERSION"),
        "embree_version": embree_version,
        "rays_per_set": rays_per_set,
        "threads": threads,
        "loading": loadings.iter().map(Loading::to_json).collect::<Vec<_>>(),
        "results": results.iter().map(Measurement::to_json).collect::<Vec<_>>(),
    })
}

/// The human-readable table: per mesh, builds then traversal, with the ratio to Embree
/// (medium quality for builds, single rays for traversal), the speed-up over the
/// fewest threads, and how many cores the process kept busy while tracing (`cpu`: a
/// speed-up cannot exceed it, so a low value means other programs held the cores).
pub fn table(results: &[Measurement], loadings: &[Loading]) -> String {
    let mut s = String::new();
    let mut meshes: Vec<&str> = results.iter().map(|m| m.mesh.as_str()).collect();
    meshes.dedup();
    for mesh in meshes {
        let rows: Vec<&Measurement> = results.iter().filter(|m| m.mesh == mesh).collect();
        let _ = writeln!(
            s,
            "\n{mesh}: {} triangles, {} rays per set",
            rows[0].triangles,
            rows.iter().map(|m| m.rays).max().unwrap_or(0)
        );
        if let Some(loading) = loadings.iter().find(|l| l.mesh == mesh) {
            let _ = writeln!(s, "{}", loading.summary());
        }
        let _ = writeln!(
            s,
            "{:<9} {:<13} {:<8} {:>3} {:>11} {:>10} {:>9} {:>9} {:>5} {:>7}",
            "backend",
            "mode",
            "api",
            "thr",
            "build ms",
            "Mrays/s",
            "vs embree",
            "vs 1 thr",
            "cpu",
            "MB"
        );
        let mesh_rows = MeshRows(&rows);
        for m in &rows {
            let _ = writeln!(s, "{}", mesh_rows.line(m));
        }
    }
    s
}

/// The measurements of one mesh, which each row's ratios look up.
struct MeshRows<'a>(&'a [&'a Measurement]);

impl MeshRows<'_> {
    fn find(
        &self,
        backend: &str,
        mode: Mode,
        api: Api,
        threads: usize,
        quality: Option<&str>,
    ) -> Option<&Measurement> {
        self.0
            .iter()
            .find(|m| {
                m.backend == backend
                    && m.mode == mode
                    && m.api == api
                    && m.threads == threads
                    && m.quality == quality
            })
            .copied()
    }

    fn min_threads(&self) -> usize {
        self.0.iter().map(|m| m.threads).min().unwrap_or(1)
    }

    /// Build milliseconds, rays per second, and the ratios to Embree and to the fewest
    /// threads, as the table's cells.
    fn cells(&self, m: &Measurement) -> [String; 4] {
        let ratio = |x: Option<f64>| x.map(|x| format!("{x:.2}x")).unwrap_or_default();
        let min_threads = self.min_threads();
        let scaling = |other: Option<f64>| other.filter(|_| m.threads != min_threads);
        match (m.build_ms, m.mrays_per_s) {
            (Some(ms), _) => {
                let embree = self.find(
                    "embree",
                    Mode::Build,
                    Api::Single,
                    m.threads,
                    Some("medium"),
                );
                let one = self.find(m.backend, Mode::Build, m.api, min_threads, m.quality);
                [
                    format!("{ms:.2}"),
                    String::new(),
                    ratio(embree.and_then(|e| e.build_ms).map(|e| e / ms)),
                    ratio(scaling(one.and_then(|o| o.build_ms)).map(|o| o / ms)),
                ]
            }
            (None, Some(r)) => {
                let embree = self
                    .find("embree", m.mode, Api::Single, m.threads, None)
                    .filter(|_| m.mode != Mode::CallOverhead);
                let one = self.find(m.backend, m.mode, m.api, min_threads, None);
                [
                    String::new(),
                    format!("{r:.2}"),
                    ratio(embree.and_then(|e| e.mrays_per_s).map(|e| r / e)),
                    ratio(scaling(one.and_then(|o| o.mrays_per_s)).map(|o| r / o)),
                ]
            }
            (None, None) => Default::default(),
        }
    }

    fn line(&self, m: &Measurement) -> String {
        let name = match m.quality {
            Some(q) => format!("{}-{q}", m.mode.as_str()),
            None => m.mode.as_str().to_owned(),
        };
        let [build, rate, base, scale] = self.cells(m);
        format!(
            "{:<9} {:<13} {:<8} {:>3} {:>11} {:>10} {:>9} {:>9} {:>5} {:>7.1}",
            m.backend,
            name,
            m.api.as_str(),
            m.threads,
            build,
            rate,
            base,
            scale,
            m.cpu_per_wall
                .map(|c| format!("{c:.2}"))
                .unwrap_or_default(),
            m.memory_bytes as f64 / 1e6
        )
    }
}
