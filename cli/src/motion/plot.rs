//! The motion bench's plots: relMSE against frame for `Reset` and `Reuse` (`motion.png`), and
//! after a stop, the changed region's relMSE for both and a still run (`settle.png`).

use std::path::Path;

use plotters::prelude::*;

use super::MotionResult;

/// A run's legend, colour and (frame, relMSE) points.
type Series = (&'static str, RGBColor, Vec<(f64, f64)>);

const RESET: (&str, RGBColor) = ("Reset (RPPM: restart on change)", RGBColor(214, 39, 40));
const REUSE: (&str, RGBColor) = ("Reuse (temporal history)", RGBColor(31, 119, 180));

/// `motion.png` in `dir` (and `settle.png` after a stop), log scale, with legends.
pub fn write_plot(result: &MotionResult, dir: &Path, title: &str) -> Result<(), String> {
    let rows = &result.rows;
    let points = |f: fn(&super::MotionRow) -> f64| -> Vec<(f64, f64)> {
        rows.iter().map(|r| (r.frame as f64, f(r))).collect()
    };
    let series = [
        (RESET.0, RESET.1, points(|r| r.reset)),
        (REUSE.0, REUSE.1, points(|r| r.reuse)),
    ];
    let axes = ("frame (count)", "relMSE against the converged frozen frame");
    line_plot(&dir.join("motion.png"), title, axes, &series)?;
    let Some(s) = &result.settling else {
        return Ok(());
    };
    let points = |run: usize| -> Vec<(f64, f64)> {
        let since = |f: u32| (f - s.stop) as f64;
        s.rows
            .iter()
            .map(|r| (since(r.frame), r.region[run]))
            .collect()
    };
    let series = [
        (RESET.0, RESET.1, points(0)),
        (REUSE.0, REUSE.1, points(1)),
        ("still (never moved)", RGBColor(90, 90, 90), points(2)),
    ];
    let axes = (
        "frames since the slide stopped (count)",
        "relMSE where the scene changed",
    );
    line_plot(&dir.join("settle.png"), title, axes, &series)
}

fn line_plot(path: &Path, title: &str, axes: (&str, &str), runs: &[Series]) -> Result<(), String> {
    let err = |e: &dyn std::fmt::Debug| format!("plotting failed: {e:?}");
    crate::trade::plot::register_fonts();
    let (w, h) = (900u32, 480u32);
    let mut rgb = vec![0u8; (w * h * 3) as usize];
    {
        let root = BitMapBackend::with_buffer(&mut rgb, (w, h)).into_drawing_area();
        root.fill(&WHITE).map_err(|e| err(&e))?;
        let values = runs.iter().flat_map(|(_, _, p)| p.iter().map(|p| p.1));
        let values: Vec<f64> = values.filter(|v| v.is_finite() && *v > 0.0).collect();
        // A log axis needs a finite, positive range (none measured: a default decade).
        let lo = values.iter().copied().fold(1.0, f64::min).max(1e-8) / 2.0;
        let hi = values.iter().copied().fold(0.0, f64::max).max(lo * 4.0) * 2.0;
        let last = runs
            .iter()
            .flat_map(|(_, _, p)| p.iter().map(|p| p.0))
            .fold(0.0, f64::max)
            + 1.0;
        let mut chart = ChartBuilder::on(&root)
            .caption(title, ("sans-serif", 18))
            .margin(12)
            .x_label_area_size(40)
            .y_label_area_size(64)
            .build_cartesian_2d(0.0..last, (lo..hi).log_scale())
            .map_err(|e| err(&e))?;
        chart
            .configure_mesh()
            .x_desc(axes.0)
            .y_desc(axes.1)
            .draw()
            .map_err(|e| err(&e))?;
        for (label, colour, points) in runs {
            let colour = *colour;
            let points: Vec<(f64, f64)> = points.iter().map(|&(x, y)| (x, y.max(lo))).collect();
            chart
                .draw_series(LineSeries::new(points.clone(), colour.stroke_width(2)))
                .map_err(|e| err(&e))?
                .label(*label)
                .legend(move |(x, y)| {
                    PathElement::new([(x, y), (x + 20, y)], colour.stroke_width(2))
                });
            chart
                .draw_series(
                    points
                        .into_iter()
                        .map(|p| Circle::new(p, 3, colour.filled())),
                )
                .map_err(|e| err(&e))?;
        }
        chart
            .configure_series_labels()
            .background_style(WHITE.mix(0.9))
            .border_style(BLACK)
            .position(SeriesLabelPosition::UpperRight)
            .draw()
            .map_err(|e| err(&e))?;
        root.present().map_err(|e| err(&e))?;
    }
    crate::image_io::write_rgb8_png(path, w, h, &rgb)
}
