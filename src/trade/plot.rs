//! PNG plots of the trade: per knob, log-log relMSE against wall time (with the Pareto front
//! of all runs) and against iterations.

use std::path::Path;

use plotters::coord::Shift;
use plotters::prelude::*;
use plotters::style::{FontStyle, register_font};

use super::{Run, Sample};

const SIZE: (u32, u32) = (1200, 480);

fn err(e: impl std::fmt::Debug) -> String {
    format!("plotting failed: {e:?}")
}

/// Plotters draws text with a font registered once; Bevy's default font is compiled in.
fn register_fonts() {
    static ONCE: std::sync::Once = std::sync::Once::new();
    ONCE.call_once(|| {
        let _ = register_font(
            "sans-serif",
            FontStyle::Normal,
            bevy::text::DEFAULT_FONT_DATA,
        );
    });
}

/// Writes `<dir>/<knob>.png` for every knob of `runs`, and `<dir>/pareto.png` with all runs.
pub fn write_plots(runs: &[Run], front: &[(f64, f64)], dir: &Path) -> Result<Vec<String>, String> {
    register_fonts();
    let mut written = Vec::new();
    let mut knobs: Vec<&str> = runs.iter().map(|r| r.knob).collect();
    knobs.dedup();
    for knob in knobs {
        let chosen: Vec<&Run> = runs.iter().filter(|r| r.knob == knob).collect();
        let path = dir.join(format!("{knob}.png"));
        plot(&path, knob, &chosen, front)?;
        written.push(path.display().to_string());
    }
    let path = dir.join("pareto.png");
    plot(&path, "all runs", &runs.iter().collect::<Vec<_>>(), front)?;
    written.push(path.display().to_string());
    Ok(written)
}

fn plot(path: &Path, title: &str, runs: &[&Run], front: &[(f64, f64)]) -> Result<(), String> {
    let (w, h) = SIZE;
    let mut rgb = vec![0u8; (w * h * 3) as usize];
    {
        let root = BitMapBackend::with_buffer(&mut rgb, SIZE).into_drawing_area();
        root.fill(&WHITE).map_err(err)?;
        let (left, right) = root.split_horizontally(w / 2);
        let by_time = |s: &Sample| s.seconds;
        let by_iteration = |s: &Sample| s.iteration as f64;
        panel(
            &left,
            &format!("{title}: relMSE vs wall time"),
            "seconds",
            runs,
            by_time,
            front,
        )?;
        panel(
            &right,
            &format!("{title}: relMSE vs iterations"),
            "iterations",
            runs,
            by_iteration,
            &[],
        )?;
        root.present().map_err(err)?;
    }
    crate::image_io::write_rgb8_png(path, w, h, &rgb)
}

/// A tick label without float noise: 0.5, 2, 20, 1e3.
fn compact(v: f64) -> String {
    match v {
        v if v >= 1000.0 => format!("{v:.0e}"),
        v if v >= 1.0 => format!("{}", v.round()),
        v => format!("{}", (v * 100.0).round() / 100.0),
    }
}

/// Positive, finite extent of `values`, widened a little; (1, 10) when there is none.
fn log_range(values: impl Iterator<Item = f64>) -> std::ops::Range<f64> {
    let (lo, hi) = values
        .filter(|v| v.is_finite() && *v > 0.0)
        .fold((f64::MAX, f64::MIN), |(lo, hi), v| (lo.min(v), hi.max(v)));
    if lo > hi {
        return 1.0..10.0;
    }
    lo * 0.8..hi * 1.25
}

fn panel<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    caption: &str,
    x_label: &str,
    runs: &[&Run],
    x: impl Fn(&Sample) -> f64,
    front: &[(f64, f64)],
) -> Result<(), String> {
    let points = |run: &Run| -> Vec<(f64, f64)> {
        run.samples
            .iter()
            .map(|s| (x(s), s.relmse))
            .filter(|(a, b)| *a > 0.0 && b.is_finite() && *b > 0.0)
            .collect()
    };
    let all: Vec<(f64, f64)> = runs
        .iter()
        .flat_map(|r| points(r))
        .chain(front.iter().copied())
        .collect();
    let xs = log_range(all.iter().map(|p| p.0));
    let ys = log_range(all.iter().map(|p| p.1));
    let mut chart = ChartBuilder::on(area)
        .caption(caption, ("sans-serif", 18))
        .margin(12)
        .x_label_area_size(36)
        .y_label_area_size(64)
        .build_cartesian_2d(xs.log_scale(), ys.log_scale())
        .map_err(err)?;
    chart
        .configure_mesh()
        .x_desc(x_label)
        .y_desc("relMSE")
        .x_label_formatter(&|v| compact(*v))
        .y_label_formatter(&|v| format!("{v:.0e}"))
        .draw()
        .map_err(err)?;
    for (i, run) in runs.iter().enumerate() {
        let colour = Palette99::pick(i).to_rgba();
        let label = if runs.iter().all(|r| r.knob == run.knob) {
            run.value.clone()
        } else {
            format!("{}={}", run.knob, run.value)
        };
        chart
            .draw_series(LineSeries::new(points(run), colour.stroke_width(2)))
            .map_err(err)?
            .label(label)
            .legend(move |(x, y)| {
                PathElement::new(vec![(x, y), (x + 18, y)], colour.stroke_width(2))
            });
    }
    if !front.is_empty() {
        chart
            .draw_series(LineSeries::new(
                front.iter().copied(),
                BLACK.stroke_width(1),
            ))
            .map_err(err)?
            .label("Pareto front")
            .legend(|(x, y)| PathElement::new(vec![(x, y), (x + 18, y)], BLACK));
    }
    if runs.len() <= 12 {
        chart
            .configure_series_labels()
            .position(SeriesLabelPosition::UpperRight)
            .background_style(WHITE.mix(0.85))
            .border_style(BLACK)
            .label_font(("sans-serif", 13))
            .draw()
            .map_err(err)?;
    }
    Ok(())
}
