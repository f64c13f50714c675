//! After a script's stop: each run's error where the scene changed, frame by frame, against
//! a run that never moved; how many frames it takes to settle (lag) and how much of the old
//! state it shows meanwhile (ghost).

use crate::image_io::{RgbImage, pixel_errors};

/// One frame after the stop: relMSE over the changed region, `Reset`, `Reuse` and still.
#[derive(Clone, Copy, Debug)]
pub struct SettleRow {
    pub frame: u32,
    pub region: [f64; 3],
}

#[derive(Clone, Debug)]
pub struct Settling {
    /// The first frame of the final state.
    pub stop: u32,
    /// Share of the pixels where the converged states before and after differ.
    pub region_fraction: f64,
    pub rows: Vec<SettleRow>,
    /// `Reset`'s and `Reuse`'s frames from the stop until their region error stays within
    /// 2× the still run's (`None`: not within the run).
    pub lag: [Option<u32>; 2],
    /// Mean region relMSE over the `window` frames after the stop: `Reset`, `Reuse`, still.
    pub ghost: [f64; 3],
}

/// A pixel changed where its converged colours before and after differ by more than about
/// 20 % (relMSE's per-pixel error over 0.04): well above 64-iteration references' noise.
const CHANGED: f64 = 0.04;

impl Settling {
    /// `runs`: `Reset`'s, `Reuse`'s and the still run's frames from the stop on.
    pub fn measure(
        stop: u32,
        window: u32,
        before: &RgbImage,
        after: &RgbImage,
        runs: &[Vec<(u32, RgbImage)>; 3],
    ) -> Result<Self, String> {
        let region: Vec<bool> = pixel_errors(before, after)?
            .iter()
            .map(|&e| e > CHANGED)
            .collect();
        let count = region.iter().filter(|&&r| r).count();
        if count == 0 {
            return Err("nothing changed between the first and the last frame's state".into());
        }
        let error = |image: &RgbImage| -> Result<f64, String> {
            let errors = pixel_errors(image, after)?;
            let sum: f64 = errors
                .iter()
                .zip(&region)
                .filter(|(_, r)| **r)
                .map(|(e, _)| e)
                .sum();
            Ok(sum / count as f64)
        };
        let mut rows = Vec::new();
        for (frame, reset) in &runs[0] {
            let find = |run: &Vec<(u32, RgbImage)>| run.iter().find(|(f, _)| f == frame).cloned();
            if let (Some((_, reuse)), Some((_, still))) = (find(&runs[1]), find(&runs[2])) {
                rows.push(SettleRow {
                    frame: *frame,
                    region: [error(reset)?, error(&reuse)?, error(&still)?],
                });
            }
        }
        if rows.is_empty() {
            return Err("no frame after the stop came back in all three runs".into());
        }
        let lag = [0, 1].map(|run| {
            let settled = |r: &SettleRow| r.region[run] <= 2.0 * r.region[2];
            let last_unsettled = rows.iter().rposition(|r| !settled(r));
            match last_unsettled {
                None => Some(rows[0].frame - stop),
                Some(i) if i + 1 < rows.len() => Some(rows[i + 1].frame - stop),
                Some(_) => None,
            }
        });
        let early: Vec<&SettleRow> = rows
            .iter()
            .filter(|r| r.frame < stop + window.max(1))
            .collect();
        let ghost = [0, 1, 2].map(|run| {
            early.iter().map(|r| r.region[run]).sum::<f64>() / early.len().max(1) as f64
        });
        Ok(Self {
            stop,
            region_fraction: count as f64 / region.len() as f64,
            rows,
            lag,
            ghost,
        })
    }

    /// The table and summary lines `rppm bench motion` prints after a stop.
    pub fn print(&self) {
        println!(
            "After the stop (frame {}), relMSE where the scene changed ({:.1} % of the pixels):",
            self.stop,
            100.0 * self.region_fraction
        );
        println!("| frames since the stop | Reset | Reuse | still (never moved) |");
        println!("|---:|---:|---:|---:|");
        for r in &self.rows {
            let [a, b, c] = r.region;
            println!("| {} | {a:.5} | {b:.5} | {c:.5} |", r.frame - self.stop);
        }
        let lag = |l: Option<u32>| l.map_or("more than the run".to_string(), |l| l.to_string());
        let [a, b, c] = self.ghost;
        println!(
            "lag (frames until the changed region stays within 2× the still run's error): Reset \
             {}, Reuse {}; ghost (its mean relMSE over the window's frames after the stop): \
             Reset {a:.5}, Reuse {b:.5}, still {c:.5}",
            lag(self.lag[0]),
            lag(self.lag[1]),
        );
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn image(values: &[f32]) -> RgbImage {
        RgbImage {
            width: values.len(),
            height: 1,
            pixels: values.iter().map(|&v| [v; 3]).collect(),
        }
    }

    /// A light that moved from pixel 0 to pixel 1: the region is those two pixels; `Reset`
    /// settles at once, `Reuse` shows the old light (a ghost) for two frames, and a run
    /// that never gets within 2× of the still one has no lag.
    #[test]
    fn lag_and_ghost_follow_the_changed_region() {
        let before = image(&[1.0, 0.0, 0.5, 0.5]);
        let after = image(&[0.0, 1.0, 0.5, 0.5]);
        let still: Vec<(u32, RgbImage)> = (10..14)
            .map(|f| (f, image(&[0.0, 1.1, 0.5, 0.5])))
            .collect();
        let reset = still.clone();
        let mut reuse = still.clone();
        reuse[0].1 = before.clone();
        reuse[1].1 = image(&[0.5, 0.5, 0.5, 0.5]);
        let s = Settling::measure(10, 8, &before, &after, &[reset, reuse, still.clone()]).unwrap();
        assert_eq!(s.region_fraction, 0.5);
        assert_eq!(s.rows.len(), 4);
        assert_eq!(s.lag, [Some(0), Some(2)]);
        assert!(s.ghost[1] > 10.0 * s.ghost[0], "{:?}", s.ghost);
        let never = vec![(10, before.clone()), (11, before.clone())];
        let s = Settling::measure(10, 8, &before, &after, &[never.clone(), never, still]).unwrap();
        assert_eq!(s.lag, [None, None]);
        assert!(Settling::measure(10, 8, &after, &after, &[vec![], vec![], vec![]]).is_err());
    }
}
