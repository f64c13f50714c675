//! The motion bench's plot: relMSE against frame for `Reset` and `Reuse`.

use std::path::Path;

use plotters::prelude::*;

use super::{MotionResult, MotionRow};

/// A run's legend, colour and value per row.
type Series = (&'static str, RGBColor, fn(&MotionRow) -> f64);

/// `motion.png` in `dir`: relMSE of each run against frame, log scale, with a legend.
pub fn write_plot(result: &MotionResult, dir: &Path, title: &str) -> Result<(), String> {
    let err = |e: &dyn std::fmt::Debug| format!("plotting failed: {e:?}");
    crate::trade::plot::register_fonts();
    let (w, h) = (900u32, 480u32);
    let mut rgb = vec![0u8; (w * h * 3) as usize];
    {
        let root = BitMapBackend::with_buffer(&mut rgb, (w, h)).into_drawing_area();
        root.fill(&WHITE).map_err(|e| err(&e))?;
        let values = result.rows.iter().flat_map(|r| [r.reset, r.reuse]);
        let values: Vec<f64> = values.filter(|v| v.is_finite() && *v > 0.0).collect();
        let lo = values.iter().copied().fold(f64::MAX, f64::min).max(1e-8) / 2.0;
        let hi = values.iter().copied().fold(0.0, f64::max).max(lo * 4.0) * 2.0;
        let last = result.rows.last().map_or(1, |r| r.frame + 1) as f64;
        let mut chart = ChartBuilder::on(&root)
            .caption(title, ("sans-serif", 18))
            .margin(12)
            .x_label_area_size(40)
            .y_label_area_size(64)
            .build_cartesian_2d(0.0..last, (lo..hi).log_scale())
            .map_err(|e| err(&e))?;
        chart
            .configure_mesh()
            .x_desc("frame (count)")
            .y_desc("relMSE against the converged frozen frame")
            .draw()
            .map_err(|e| err(&e))?;
        let runs: [Series; 2] = [
            (
                "Reset (RPPM: restart on change)",
                RGBColor(214, 39, 40),
                |r| r.reset,
            ),
            ("Reuse (temporal history)", RGBColor(31, 119, 180), |r| {
                r.reuse
            }),
        ];
        for (label, colour, value) in runs {
            let points: Vec<(f64, f64)> = result
                .rows
                .iter()
                .map(|r| (r.frame as f64, value(r).max(lo)))
                .collect();
            chart
                .draw_series(LineSeries::new(points.clone(), colour.stroke_width(2)))
                .map_err(|e| err(&e))?
                .label(label)
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
    crate::image_io::write_rgb8_png(&dir.join("motion.png"), w, h, &rgb)
}
