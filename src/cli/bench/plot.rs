//! `ember bench --plot FILE.svg`: Mrays/s per backend and ray kind as grouped bars, one
//! panel per mesh, each group a ray kind at one thread count.

use plotters::prelude::*;

use super::report::{Api, Measurement, Mode};

/// Pixels of one mesh's panel.
const PANEL: (u32, u32) = (960, 420);

/// Bar colours, one per backend and API, in the table's column order.
const COLOURS: [RGBColor; 8] = [
    RGBColor(31, 119, 180),
    RGBColor(174, 199, 232),
    RGBColor(44, 160, 44),
    RGBColor(255, 127, 14),
    RGBColor(214, 39, 40),
    RGBColor(148, 103, 189),
    RGBColor(140, 86, 75),
    RGBColor(127, 127, 127),
];

/// The chart of `results` as an SVG document.
pub fn svg(results: &[Measurement], machine: &str) -> Result<String, String> {
    let mut meshes: Vec<&str> = results.iter().map(|m| m.mesh.as_str()).collect();
    meshes.dedup();
    let mut text = String::new();
    {
        let height = PANEL.1 * meshes.len().max(1) as u32;
        let root = SVGBackend::with_string(&mut text, (PANEL.0, height)).into_drawing_area();
        root.fill(&WHITE).map_err(|e| e.to_string())?;
        let panels = root.split_evenly((meshes.len().max(1), 1));
        for (mesh, panel) in meshes.iter().zip(&panels) {
            let rows: Vec<&Measurement> = results.iter().filter(|m| m.mesh == *mesh).collect();
            draw_mesh(panel, mesh, &rows, machine).map_err(|e| e.to_string())?;
        }
        root.present().map_err(|e| e.to_string())?;
    }
    Ok(text)
}

type Panel<'a> = DrawingArea<SVGBackend<'a>, plotters::coord::Shift>;

/// One mesh's bars: groups of (ray kind, threads), a bar per backend and API.
fn draw_mesh(
    panel: &Panel<'_>,
    mesh: &str,
    rows: &[&Measurement],
    machine: &str,
) -> Result<(), DrawingAreaErrorKind<std::io::Error>> {
    let traversal =
        |m: &&&Measurement| matches!(m.mode, Mode::Primary | Mode::Diffuse | Mode::Shadow);
    let mut series: Vec<(&str, Api)> = Vec::new();
    let mut groups: Vec<(Mode, usize)> = Vec::new();
    for m in rows.iter().filter(traversal) {
        if !series.contains(&(m.backend, m.api)) {
            series.push((m.backend, m.api));
        }
        if !groups.contains(&(m.mode, m.threads)) {
            groups.push((m.mode, m.threads));
        }
    }
    groups.sort_by_key(|&(mode, threads)| (mode as u8, threads));
    let top = rows
        .iter()
        .filter(traversal)
        .filter_map(|m| m.mrays_per_s)
        .fold(0.0f64, f64::max)
        .max(1e-3)
        // Room above the tallest bar for the legend.
        * 1.45;
    let caption = format!(
        "{mesh}, {} triangles: Mrays/s (higher is faster)",
        rows[0].triangles
    );
    let mut chart = ChartBuilder::on(panel)
        .caption(caption, ("sans-serif", 18))
        .margin(12)
        .x_label_area_size(46)
        .y_label_area_size(56)
        .build_cartesian_2d(0.0..groups.len().max(1) as f64, 0.0..top)?;
    let names: Vec<String> = groups
        .iter()
        .map(|(mode, threads)| format!("{} ({threads} thr)", mode.as_str()))
        .collect();
    chart
        .configure_mesh()
        .disable_x_mesh()
        .max_light_lines(1)
        .x_labels(groups.len().max(1) * 2 + 1)
        .x_label_formatter(&|x| {
            // Labels at the groups' centres only.
            let i = (x - 0.5).round();
            match (x - 0.5 - i).abs() < 1e-6 && i >= 0.0 {
                true => names.get(i as usize).cloned().unwrap_or_default(),
                false => String::new(),
            }
        })
        .y_desc("Mrays/s")
        .x_desc(machine)
        .draw()?;
    let width = 0.8 / series.len().max(1) as f64;
    for (k, &(backend, api)) in series.iter().enumerate() {
        let colour = COLOURS[k % COLOURS.len()];
        let bars = groups
            .iter()
            .enumerate()
            .filter_map(|(g, &(mode, threads))| {
                let m = rows.iter().find(|m| {
                    m.backend == backend && m.api == api && m.mode == mode && m.threads == threads
                })?;
                let x0 = g as f64 + 0.1 + k as f64 * width;
                let rect = [(x0, 0.0), (x0 + width * 0.92, m.mrays_per_s?)];
                Some(Rectangle::new(rect, colour.filled()))
            });
        chart
            .draw_series(bars)?
            .label(format!("{backend} {}", api.as_str()))
            .legend(move |(x, y)| Rectangle::new([(x, y - 5), (x + 12, y + 5)], colour.filled()));
    }
    chart
        .configure_series_labels()
        .position(SeriesLabelPosition::UpperRight)
        .background_style(WHITE.mix(0.85))
        .border_style(BLACK)
        .draw()?;
    Ok(())
}
