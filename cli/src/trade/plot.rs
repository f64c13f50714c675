//! PNG plots of the trade: per knob, log-log relMSE against wall time (with the Pareto front
//! of all runs) and against iterations, and every run together; each with a legend column
//! (knob = value, and the Pareto front) beside the panels.

use std::path::Path;

use plotters::coord::Shift;
use plotters::prelude::*;
use plotters::style::{FontStyle, register_font};

use super::{Run, Sample};

/// The two panels, and the legend column to their right.
const PANELS: (u32, u32) = (1200, 480);
const LEGEND_WIDTH: u32 = 230;
/// Legend rows: one per run and one for the Pareto front.
const ROW: u32 = 18;

fn err(e: impl std::fmt::Debug) -> String {
    format!("plotting failed: {e:?}")
}

/// Plotters draws text with a font registered once; Bevy's default font is compiled in.
pub(crate) fn register_fonts() {
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
    let mut knobs: Vec<&str> = runs.iter().map(|r| r.knob.as_str()).collect();
    knobs.dedup();
    for knob in knobs {
        let chosen: Vec<&Run> = runs.iter().filter(|r| r.knob == knob).collect();
        let path = dir.join(format!("{knob}.png"));
        plot(&path, knob, &chosen, front)?;
        written.push(path.display().to_string());
    }
    // A setting shared by several knobs (each knob's base value) is one run: drawn once, and
    // named the base setting.
    let mut distinct: Vec<Run> = Vec::new();
    for run in runs {
        match distinct.iter_mut().find(|d| same_samples(d, run)) {
            Some(shared) if shared.value.is_empty() => {}
            Some(shared) => {
                shared.knob = "base setting".into();
                shared.value.clear();
            }
            None => distinct.push(run.clone()),
        }
    }
    // Runs with no error to plot (mode Indirect) stay out of the legend too.
    distinct.retain(|r| r.samples.iter().any(|s| s.relmse.is_finite()));
    let distinct: Vec<&Run> = distinct.iter().collect();
    let path = dir.join("pareto.png");
    plot(&path, "all runs", &distinct, front)?;
    written.push(path.display().to_string());
    Ok(written)
}

/// Whether two runs are one rendering (a setting several knobs share).
fn same_samples(a: &Run, b: &Run) -> bool {
    a.samples.len() == b.samples.len()
        && a.samples
            .iter()
            .zip(&b.samples)
            .all(|(x, y)| x.iteration == y.iteration && x.seconds == y.seconds)
}

/// Distinct colours (none black: black is the Pareto front).
const COLOURS: [RGBColor; 13] = [
    RGBColor(90, 90, 90),
    RGBColor(31, 119, 180),
    RGBColor(255, 127, 14),
    RGBColor(44, 160, 44),
    RGBColor(214, 39, 40),
    RGBColor(148, 103, 189),
    RGBColor(140, 86, 75),
    RGBColor(227, 119, 194),
    RGBColor(0, 128, 128),
    RGBColor(188, 189, 34),
    RGBColor(23, 190, 207),
    RGBColor(0, 0, 139),
    RGBColor(255, 187, 0),
];

/// How one run is drawn: a colour, and dashes `(dash, gap)` in pixels or a solid line.
#[derive(Clone)]
struct Style {
    colour: RGBColor,
    dash: Option<(u32, u32)>,
    label: String,
}

/// Per knob, one colour per value; across knobs, one colour per knob and a dash pattern per
/// value (the first value short dashes, the second solid, the third long dashes, ...).
fn series(runs: &[&Run]) -> Vec<Style> {
    let one_knob = runs.iter().all(|r| r.knob == runs[0].knob);
    let mut knobs: Vec<&str> = Vec::new();
    let mut seen: Vec<(&str, usize)> = Vec::new();
    runs.iter()
        .enumerate()
        .map(|(i, run)| {
            if !knobs.contains(&run.knob.as_str()) {
                knobs.push(&run.knob);
            }
            let knob = knobs.iter().position(|k| *k == run.knob).unwrap_or(0);
            let nth = seen.iter().filter(|(k, _)| *k == run.knob).count();
            seen.push((&run.knob, i));
            let dashes = [Some((4, 4)), None, Some((12, 6)), Some((2, 3))];
            let label = if run.value.is_empty() {
                run.knob.clone()
            } else {
                format!("{} = {}", run.knob, run.value)
            };
            let (colour, dash) = if one_knob {
                (i, None)
            } else {
                (knob, dashes[nth % dashes.len()])
            };
            Style {
                colour: COLOURS[colour % COLOURS.len()],
                dash,
                label,
            }
        })
        .collect()
}

fn plot(path: &Path, title: &str, runs: &[&Run], front: &[(f64, f64)]) -> Result<(), String> {
    let rows = runs.len() as u32 + 3;
    let w = PANELS.0 + LEGEND_WIDTH;
    let h = PANELS.1.max(rows * ROW + 40);
    let mut rgb = vec![0u8; (w * h * 3) as usize];
    {
        let root = BitMapBackend::with_buffer(&mut rgb, (w, h)).into_drawing_area();
        root.fill(&WHITE).map_err(err)?;
        let (panels, legend_area) = root.split_horizontally(PANELS.0);
        let styles = series(runs);
        legend(&legend_area, &styles, !front.is_empty())?;
        let (left, right) = panels.split_horizontally(PANELS.0 / 2);
        let by_time = |s: &Sample| s.seconds;
        let by_iteration = |s: &Sample| s.iteration as f64;
        panel(
            &left,
            &format!("{title}: relMSE vs wall time"),
            "wall time since the first iteration (s)",
            (runs, &styles),
            by_time,
            front,
        )?;
        panel(
            &right,
            &format!("{title}: relMSE vs iterations"),
            "iterations (count)",
            (runs, &styles),
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
    (runs, styles): (&[&Run], &[Style]),
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
        // No minor grid: on log axes its many lines smear into grey bands.
        .light_line_style(TRANSPARENT)
        .bold_line_style(RGBColor(225, 225, 225))
        .x_desc(x_label)
        .y_desc("relMSE against the reference (unitless)")
        .x_label_formatter(&|v| compact(*v))
        .y_label_formatter(&|v| format!("{v:.0e}"))
        .draw()
        .map_err(err)?;
    for (run, style) in runs.iter().zip(styles) {
        let stroke = style.colour.stroke_width(2);
        match style.dash {
            None => chart.draw_series(LineSeries::new(points(run), stroke)),
            Some((dash, gap)) => {
                chart.draw_series(DashedLineSeries::new(points(run), dash, gap, stroke))
            }
        }
        .map_err(err)?;
    }
    if !front.is_empty() {
        chart
            .draw_series(LineSeries::new(
                front.iter().copied(),
                BLACK.stroke_width(3),
            ))
            .map_err(err)?;
        chart
            .draw_series(front.iter().map(|&p| Circle::new(p, 3, BLACK.filled())))
            .map_err(err)?;
    }
    Ok(())
}

/// The legend column: a swatch and `knob = value` per run, then the Pareto front.
fn legend<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    styles: &[Style],
    pareto: bool,
) -> Result<(), String> {
    let font = ("sans-serif", 13).into_font();
    let mut y = 30;
    area.draw(&Text::new(
        "legend",
        (8, 10),
        ("sans-serif", 14).into_font(),
    ))
    .map_err(err)?;
    for style in styles {
        let stroke = style.colour.stroke_width(2);
        let (dash, gap) = style.dash.unwrap_or((26, 0));
        let mut x = 8;
        while x < 34 {
            let end = (x + dash as i32).min(34);
            area.draw(&PathElement::new(vec![(x, y + 7), (end, y + 7)], stroke))
                .map_err(err)?;
            x = end + gap as i32;
        }
        area.draw(&Text::new(style.label.clone(), (40, y), font.clone()))
            .map_err(err)?;
        y += ROW as i32;
    }
    if pareto {
        let line = PathElement::new(vec![(8, y + 7), (34, y + 7)], BLACK.stroke_width(3));
        area.draw(&line).map_err(err)?;
        area.draw(&Circle::new((21, y + 7), 3, BLACK.filled()))
            .map_err(err)?;
        area.draw(&Text::new("Pareto front (all runs)", (40, y), font))
            .map_err(err)?;
    }
    Ok(())
}
