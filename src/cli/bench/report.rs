//! What `ember bench` measured, and how it is shown: one [`Measurement`] per row, the
//! human-readable table and the JSON document.

use std::fmt::Write;

use serde_json::{json, Value};

use crate::cli::machine::Machine;

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
    /// Embree's `rtcIntersect16` / `rtcOccluded16`, as the wavefront engine calls them.
    Packet16,
    /// Embree called directly (rays in its own layout, bare `rtcIntersect1` calls), the
    /// baseline of the wrapper's cost.
    Direct,
}

impl Api {
    pub fn as_str(self) -> &'static str {
        match self {
            Api::Single => "single",
            Api::Packet8 => "packet8",
            Api::Packet16 => "packet16",
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
            "scene read in {:.3} s ({:.1} MB at {:.0} MB/s, with its materials and textures)",
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

/// The JSON document `ember bench --json` prints: the machine, the setup and the
/// measurements, each traversal and build with its ratio to the baseline the table
/// names (`vs_embree`) and to the fewest threads measured (`vs_fewest_threads`).
pub fn to_json(
    results: &[Measurement],
    loadings: &[Loading],
    rays_per_set: usize,
    threads: &[usize],
    machine: &Machine,
) -> Value {
    let rows: Vec<Value> = results
        .iter()
        .map(|m| {
            let mesh_rows: Vec<&Measurement> =
                results.iter().filter(|r| r.mesh == m.mesh).collect();
            let ratios = MeshRows(&mesh_rows);
            let mut v = m.to_json();
            let obj = v.as_object_mut().expect("json! object");
            if let Some(r) = ratios.vs_embree(m) {
                obj.insert("vs_embree".into(), r.into());
            }
            if let Some(r) = ratios.vs_fewest_threads(m) {
                obj.insert("vs_fewest_threads".into(), r.into());
            }
            v
        })
        .collect();
    json!({
        "ember_version": env!("CARGO_PKG_VERSION"),
        "embree_version": machine.embree_version,
        "machine": machine,
        "baselines": {
            "traversal": TRAVERSAL_BASELINE,
            "build": BUILD_BASELINE,
        },
        "rays_per_set": rays_per_set,
        "threads": threads,
        "loading": loadings.iter().map(Loading::to_json).collect::<Vec<_>>(),
        "results": rows,
        // The whole run's, from the kernel (VmHWM): what the memory check before each
        // mesh is measured against.
        "peak_resident_bytes": ember::limits::peak_resident_bytes(),
    })
}

/// What a traversal's ratio is over.
const TRAVERSAL_BASELINE: &str =
    "Embree single rays (api single), same mesh, ray kind and threads: Mrays/s over its Mrays/s";
/// What a build's ratio is over.
const BUILD_BASELINE: &str =
    "Embree's medium-quality build, same mesh and threads: its time over this build's time";

/// What the table's words mean, printed after it.
pub const LEGEND: &str = "\
Legend:
  rays       primary: coherent camera rays in 16x16 tiles; diffuse: cosine-weighted bounces
             from the points the camera sees (incoherent); shadow: occlusion rays from those
             points to the mesh's emitters, or to points in its bounds
  single     one ray a call through ember's Accel interface, as `ember render` traces
  direct     the same rays through bare rtcIntersect1/rtcOccluded1 calls, as a C program
             would: the gap to `embree single` is what ember's wrapper costs
  packet8    Embree's 8-ray packets (rtcIntersect8/rtcOccluded8)
  packet16   Embree's 16-ray packets (rtcIntersect16/rtcOccluded16), as `--engine wavefront`
             traces
  N.NNx      traversal: Mrays/s over `embree single` on the same rays and threads; builds:
             Embree's medium-quality build time over this build's; above 1 is faster
  cpu        cores the process kept busy while tracing (the lowest of the row): a speed-up
             cannot exceed it, so a low value means other programs held the cores
  MB         the structure's memory
  call overhead  rays with an empty interval, which Embree returns before traversing:
             the cost of one call through the wrapper
";

/// The human-readable tables, per mesh: builds (one row per structure, a column per
/// thread count), then traversal side by side (one row per ray kind and thread count,
/// a column per backend and API), then the cost of a call.
pub fn table(results: &[Measurement], loadings: &[Loading]) -> String {
    let mut s = String::new();
    let mut meshes: Vec<&str> = results.iter().map(|m| m.mesh.as_str()).collect();
    meshes.dedup();
    for mesh in meshes {
        let rows: Vec<&Measurement> = results.iter().filter(|m| m.mesh == mesh).collect();
        let loading = loadings
            .iter()
            .find(|l| l.mesh == mesh)
            .map_or(String::new(), |l| format!("; {}", l.summary()));
        let _ = writeln!(
            s,
            "\n{mesh}: {} triangles, {} rays per set{loading}",
            rows[0].triangles,
            rows.iter().map(|m| m.rays).max().unwrap_or(0)
        );
        let mesh_rows = MeshRows(&rows);
        s.push_str(&mesh_rows.builds());
        s.push('\n');
        s.push_str(&mesh_rows.traversal());
        s.push_str(&mesh_rows.call_overhead());
    }
    s
}

/// A traversal column: a backend through one API.
type Column = (&'static str, Api);

/// The measurements of one mesh, which the tables and ratios look up.
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

    fn thread_counts(&self) -> Vec<usize> {
        let mut threads: Vec<usize> = self.0.iter().map(|m| m.threads).collect();
        threads.sort_unstable();
        threads.dedup();
        threads
    }

    /// The ratio of `m` to its baseline: Embree's medium-quality build (builds), Embree
    /// single rays (traversal); `None` for the call overhead.
    fn vs_embree(&self, m: &Measurement) -> Option<f64> {
        match (m.build_ms, m.mrays_per_s) {
            (Some(ms), _) => {
                let base = self.find(
                    "embree",
                    Mode::Build,
                    Api::Single,
                    m.threads,
                    Some("medium"),
                );
                base.and_then(|b| b.build_ms).map(|b| b / ms)
            }
            (None, Some(rate)) if m.mode != Mode::CallOverhead => {
                let base = self.find("embree", m.mode, Api::Single, m.threads, None);
                base.and_then(|b| b.mrays_per_s).map(|b| rate / b)
            }
            _ => None,
        }
    }

    /// The speed-up of `m` over the same measurement on the fewest threads.
    fn vs_fewest_threads(&self, m: &Measurement) -> Option<f64> {
        let fewest = *self.thread_counts().first()?;
        if m.threads == fewest {
            return None;
        }
        let one = self.find(m.backend, m.mode, m.api, fewest, m.quality)?;
        match (m.build_ms, m.mrays_per_s) {
            (Some(ms), _) => one.build_ms.map(|o| o / ms),
            (None, Some(rate)) => one.mrays_per_s.map(|o| rate / o),
            _ => None,
        }
    }

    /// A cell: the figure, and its ratio to the baseline unless it is the baseline.
    fn cell(&self, m: &Measurement, figure: f64, baseline: bool) -> String {
        match self.vs_embree(m) {
            Some(r) if !baseline => format!("{figure:.2} {r:.2}x"),
            _ => format!("{figure:.2}"),
        }
    }

    fn builds(&self) -> String {
        let threads = self.thread_counts();
        let mut structures: Vec<(&'static str, Option<&'static str>)> = Vec::new();
        for m in self.0.iter().filter(|m| m.mode == Mode::Build) {
            if !structures.contains(&(m.backend, m.quality)) {
                structures.push((m.backend, m.quality));
            }
        }
        let mut header = vec!["build".to_owned()];
        header.extend(threads.iter().map(|t| format!("ms, {t} thr")));
        header.push("MB".to_owned());
        let mut grid = vec![header];
        for (backend, quality) in structures {
            let name = match quality {
                Some(q) if q == "medium" => format!("{backend} {q} (base)"),
                Some(q) => format!("{backend} {q}"),
                None => backend.to_owned(),
            };
            let mut row = vec![name];
            let mut memory = 0;
            for &t in &threads {
                let m = self.find(backend, Mode::Build, Api::Single, t, quality);
                row.push(m.map_or(String::new(), |m| {
                    memory = m.memory_bytes;
                    self.cell(m, m.build_ms.unwrap_or(0.0), quality == Some("medium"))
                }));
            }
            row.push(format!("{:.1}", memory as f64 / 1e6));
            grid.push(row);
        }
        layout(&grid, 1)
    }

    fn traversal(&self) -> String {
        let mut columns: Vec<Column> = Vec::new();
        for m in self.0.iter().filter(|m| is_traversal(m.mode)) {
            if !columns.contains(&(m.backend, m.api)) {
                columns.push((m.backend, m.api));
            }
        }
        let mut header = vec!["Mrays/s".to_owned(), "thr".to_owned()];
        header.extend(columns.iter().map(|&(backend, api)| match (backend, api) {
            ("embree", Api::Single) => "embree single (base)".to_owned(),
            _ => format!("{backend} {}", api.as_str()),
        }));
        header.push("cpu".to_owned());
        let mut grid = vec![header];
        for mode in [Mode::Primary, Mode::Diffuse, Mode::Shadow] {
            for &t in &self.thread_counts() {
                let found: Vec<Option<&Measurement>> = columns
                    .iter()
                    .map(|&(backend, api)| self.find(backend, mode, api, t, None))
                    .collect();
                if found.iter().all(Option::is_none) {
                    continue;
                }
                let mut row = vec![mode.as_str().to_owned(), t.to_string()];
                for (m, &(backend, api)) in found.iter().zip(&columns) {
                    let baseline = backend == "embree" && api == Api::Single;
                    row.push(m.map_or(String::new(), |m| {
                        self.cell(m, m.mrays_per_s.unwrap_or(0.0), baseline)
                    }));
                }
                let cpu = found
                    .iter()
                    .flatten()
                    .filter_map(|m| m.cpu_per_wall)
                    .fold(None, |a: Option<f64>, c| Some(a.map_or(c, |a| a.min(c))));
                row.push(cpu.map_or(String::new(), |c| format!("{c:.2}")));
                grid.push(row);
            }
        }
        layout(&grid, 1)
    }

    fn call_overhead(&self) -> String {
        let rates: Vec<String> = (self.0.iter())
            .filter(|m| m.mode == Mode::CallOverhead)
            .filter_map(|m| {
                Some(format!(
                    "{:.2} Mrays/s at {} thr",
                    m.mrays_per_s?, m.threads
                ))
            })
            .collect();
        match rates.is_empty() {
            true => String::new(),
            false => format!(
                "call overhead (embree single, empty rays): {}\n",
                rates.join(", ")
            ),
        }
    }
}

fn is_traversal(mode: Mode) -> bool {
    matches!(mode, Mode::Primary | Mode::Diffuse | Mode::Shadow)
}

/// `grid` as aligned text: the first `left` columns flush left, the others right.
fn layout(grid: &[Vec<String>], left: usize) -> String {
    let columns = grid.iter().map(Vec::len).max().unwrap_or(0);
    let widths: Vec<usize> = (0..columns)
        .map(|c| {
            grid.iter()
                .filter_map(|row| row.get(c))
                .map(|cell| cell.chars().count())
                .max()
                .unwrap_or(0)
        })
        .collect();
    let mut s = String::new();
    for row in grid {
        let cells: Vec<String> = row
            .iter()
            .enumerate()
            .map(|(c, cell)| match c < left {
                true => format!("{cell:<w$}", w = widths[c]),
                false => format!("{cell:>w$}", w = widths[c]),
            })
            .collect();
        let _ = writeln!(s, "{}", cells.join("  ").trim_end());
    }
    s
}
