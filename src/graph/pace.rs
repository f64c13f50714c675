//! How many iterations the next frames run under [`IterationsPerFrame`]: a controller fed by
//! the GPU time an iteration took (timestamps). Pure arithmetic, unit-tested here.

use crate::settings::IterationsPerFrame;

/// Weight of a new reading in the smoothed cost of an iteration.
const SMOOTHING: f64 = 0.3;

/// The iteration count of a view's frames, and the cost it was chosen from.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct IterationController {
    /// Iterations a frame now; 0 before the first frame.
    pub count: u32,
    /// Smoothed ms an iteration (0 before a reading).
    pub ms: f64,
}

impl IterationController {
    /// The count for this frame under `setting` (which may have changed since the last).
    pub fn count(&mut self, setting: IterationsPerFrame) -> u32 {
        self.count = match setting {
            IterationsPerFrame::Fixed(n) => n.max(1),
            // A new budget starts at one iteration and climbs as readings come in.
            IterationsPerFrame::GpuMilliseconds { max, .. } => self.count.clamp(1, max.max(1)),
        };
        self.count
    }

    /// Takes one timed frame: the GPU ms of all its stages, the iterations those were of,
    /// and the wall-clock ms an iteration took (counted on a `software` adapter, whose
    /// timestamps see part of its work). Returns whether the count moved.
    pub fn observe(
        &mut self,
        setting: IterationsPerFrame,
        gpu_ms: f64,
        iterations: u32,
        wall_ms_per_iteration: f64,
        software: bool,
    ) -> bool {
        let IterationsPerFrame::GpuMilliseconds { milliseconds, max } = setting else {
            return false;
        };
        if iterations == 0 || !gpu_ms.is_finite() || gpu_ms <= 0.0 {
            return false; // nothing timed: stay
        }
        let mut ms = gpu_ms / iterations as f64;
        if software && wall_ms_per_iteration.is_finite() {
            ms = ms.max(wall_ms_per_iteration);
        }
        self.ms = if self.ms > 0.0 {
            self.ms + SMOOTHING * (ms - self.ms)
        } else {
            ms
        };
        let best = (milliseconds as f64 / self.ms)
            .floor()
            .clamp(1.0, max.max(1) as f64) as u32;
        // At most a doubling a frame: one cheap reading (a frame of few photons) is no reason
        // to jump to `max`.
        let next = best.min(self.count.max(1) * 2);
        let moved = next != self.count;
        self.count = next;
        moved
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const BUDGET: IterationsPerFrame = IterationsPerFrame::GpuMilliseconds {
        milliseconds: 20.0,
        max: 64,
    };

    #[test]
    fn fixed_runs_its_count_and_ignores_timings() {
        let mut c = IterationController::default();
        assert_eq!(c.count(IterationsPerFrame::Fixed(3)), 3);
        assert!(!c.observe(IterationsPerFrame::Fixed(3), 1.0, 3, 1.0, false));
        assert_eq!(c.count(IterationsPerFrame::Fixed(3)), 3);
    }

    #[test]
    fn a_budget_climbs_by_doublings_to_what_fits() {
        let mut c = IterationController::default();
        assert_eq!(c.count(BUDGET), 1);
        // 2.5 ms an iteration: 8 fit in 20 ms.
        let mut seen = Vec::new();
        for _ in 0..6 {
            let n = c.count(BUDGET);
            c.observe(BUDGET, 2.5 * n as f64, n, 9.0, false);
            seen.push(c.count);
        }
        assert_eq!(seen, [2, 4, 8, 8, 8, 8]);
    }

    #[test]
    fn a_budget_falls_at_once_when_iterations_cost_more() {
        let mut c = IterationController { count: 16, ms: 1.0 };
        // Readings of 10 ms an iteration: the smoothed cost passes 2 ms at once.
        c.observe(BUDGET, 160.0, 16, 10.0, false);
        assert!(c.count <= 6, "{c:?}");
        for _ in 0..20 {
            let n = c.count(BUDGET);
            c.observe(BUDGET, 10.0 * n as f64, n, 10.0, false);
        }
        assert_eq!(c.count, 2);
    }

    #[test]
    fn a_software_adapter_counts_its_wall_clock() {
        // llvmpipe: timestamps say 2 ms, an iteration takes 300 ms.
        let mut c = IterationController::default();
        c.count(BUDGET);
        c.observe(BUDGET, 2.0, 1, 300.0, true);
        assert_eq!(c.count, 1);
        // The same readings on a GPU, whose frame waits on the CPU: more iterations.
        let mut g = IterationController::default();
        g.count(BUDGET);
        g.observe(BUDGET, 2.0, 1, 300.0, false);
        assert_eq!(g.count, 2);
    }

    #[test]
    fn nothing_timed_leaves_the_count_and_max_bounds_it() {
        let mut c = IterationController::default();
        c.count(BUDGET);
        assert!(!c.observe(BUDGET, 0.0, 1, 5.0, false));
        assert!(!c.observe(BUDGET, f64::NAN, 1, 5.0, false));
        assert!(!c.observe(BUDGET, 1.0, 0, 5.0, false));
        let small = IterationsPerFrame::GpuMilliseconds {
            milliseconds: 1000.0,
            max: 3,
        };
        for _ in 0..8 {
            let n = c.count(small);
            c.observe(small, 0.1 * n as f64, n, 1.0, false);
        }
        assert_eq!(c.count(small), 3);
    }
}
