//! How many photons the next iterations emit under [`PhotonCount`]: a controller fed by the
//! GPU time each stage took (timestamps). Pure arithmetic, unit-tested here.

use crate::settings::PhotonCount;
use crate::stats::timing::{FrameWork, STAGES, Stage};

/// The fewest photons an adaptive count goes down to.
pub const MIN_PHOTONS: u32 = 1024;
/// Where an adaptive count starts, before any timing is read back.
pub const START_PHOTONS: u32 = 16_384;
/// Under `Auto`, the photon stages' GPU time over the rest of the iteration's. The trade bench
/// (README) found 16 384 photons best for budgets up to 20 s on llvmpipe, where that was about
/// 1.5×, and 65 536 (about 6×) from a minute on. Since tracing got cheaper (big triangles
/// apart), the suite at 60 s measured 2, 4 and 6: 4 gave the lowest error over the suite
/// (geometric mean relMSE 0.0045, against 0.0060 at 2 and 0.0056 at 6). Since the direct
/// splat became a gather (a per-pixel cost that photons hardly change), 2, 3 and 4 gave
/// 0.0043, 0.0045 and 0.0048 (13 scenes). Once the radius followed the count chosen and a
/// probing iteration weighed by its photons, 1 against 2 gave 0.93× the error over twelve
/// scenes at 60 s (0.5: 0.92×, but `water_pool` 1.17× worse).
pub const PHOTON_SHARE: f64 = 1.0;
/// A new count is taken only when the best one is this many octaves away (hysteresis: a
/// count that the noise of timing would move back and forth stays).
const OCTAVES: f64 = 0.75;

/// Weight of a new reading in the smoothed costs: frame times on a CPU rasteriser swing by 2×
/// from frame to frame, and a count that followed each reading would too.
const SMOOTHING: f64 = 0.2;
/// Readings taken at a count before it may move again.
const SETTLE: u32 = 4;
/// Readings at each count `Auto` probes before timing chose one, and the count's growth per
/// probe. Probing iterations weigh little in the estimate (`ppm::photon_weight`); four
/// readings an octave from 16 384 took 7–11 s of `water_pool`'s first minute on llvmpipe.
const PROBE_SETTLE: u32 = 2;
const PROBE_STEP: u32 = 4;

/// The ratio of the slowest to the fastest timed count's iteration before the line is
/// fitted: photons whose cost is within the noise of timing give no slope.
const SPAN: f64 = 1.5;
/// Counts timed apart: one slot per octave (a count is a power of two, or `max`).
const SLOTS: usize = 32;
/// A slot's readings weigh at most this many in the fit (a count held for minutes would
/// otherwise outweigh every other).
const MOST_WEIGHT: u32 = 8;

/// The photon count of a view's iterations, and the costs it was chosen from.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct PhotonController {
    /// Photons per iteration now; 0 before the first frame.
    pub count: u32,
    /// Smoothed time per iteration at each count timed so far (`Auto`), by octave.
    timings: [Timing; SLOTS],
    /// Readings since the count last moved (`GpuMilliseconds`).
    readings: u32,
    /// Whether timing chose the count yet (`Auto`'s first fit, `GpuMilliseconds`' first
    /// settled readings): until then `Auto` probes ([`PROBE_STEP`], [`PROBE_SETTLE`]).
    fitted: bool,
    /// Smoothed GPU ms per photon of the photon stages, and of the other stages per
    /// iteration (`GpuMilliseconds`).
    pub per_photon_ms: f64,
    pub other_gpu_ms: f64,
}

/// Smoothed ms per iteration at a photon count.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Timing {
    pub count: u32,
    pub ms: f64,
    pub readings: u32,
}

impl Timing {
    /// The mean of the first readings, then an exponential average: a count probed twice is
    /// timed by both readings, not mostly by its first.
    fn add(&mut self, ms: f64) {
        self.readings += 1;
        let weight = (1.0 / self.readings as f64).max(SMOOTHING);
        self.ms += weight * (ms - self.ms);
    }
}

/// One frame's costs.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FrameCost {
    /// GPU ms per stage (timestamps), summed over the frame.
    pub ms: [f64; STAGES],
    /// The iterations and photons those timestamps were taken of.
    pub work: FrameWork,
    /// Wall-clock ms an iteration took (0 when unknown).
    pub wall_ms_per_iteration: f64,
}

impl PhotonController {
    /// The count for this frame under `setting` (which may have changed since the last).
    pub fn count(&mut self, setting: PhotonCount) -> u32 {
        self.count = match setting {
            PhotonCount::Fixed(n) => n,
            PhotonCount::Auto { max } | PhotonCount::GpuMilliseconds { max, .. } => {
                if self.count == 0 {
                    START_PHOTONS.min(max)
                } else {
                    self.count.clamp(MIN_PHOTONS.min(max), max)
                }
            }
        };
        self.count
    }

    /// Takes a frame's costs and moves the count toward what `setting` asks for. Returns
    /// whether it moved.
    pub fn observe(&mut self, setting: PhotonCount, cost: FrameCost) -> bool {
        let FrameWork {
            iterations,
            photons,
        } = cost.work;
        if photons == 0 || iterations == 0 || photons != self.count {
            return false; // timing of another count, or of no photon pass
        }
        let n = iterations as f64;
        let (photon_ms, other_ms) = split(&cost.ms);
        let (photon_ms, other_ms) = (photon_ms / n, other_ms / n);
        if !photon_ms.is_finite()
            || !other_ms.is_finite()
            || !cost.wall_ms_per_iteration.is_finite()
        {
            return false;
        }
        let next = match setting {
            PhotonCount::Fixed(n) => n,
            PhotonCount::Auto { max } => {
                self.auto(cost.wall_ms_per_iteration.max(photon_ms + other_ms), max)
            }
            PhotonCount::GpuMilliseconds { milliseconds, max } => {
                self.gpu_budget(photon_ms, other_ms, milliseconds as f64, max)
            }
        };
        let moved = next != self.count;
        if moved {
            self.readings = 0;
            self.count = next;
        }
        moved
    }

    /// The count the gather radius is sized for under `setting`: the count timing chose, and
    /// until it chose one the most there may be. A radius for the count an `Auto` probe starts
    /// at (16 384) blurred every iteration after it (`cornell_glass` at 72 iterations 0.00104
    /// → 0.00162); one for `max` kept discs too narrow for the count run (131 072 photons
    /// fixed beat `Auto` on all twelve suite scenes at 60 s, whose radius was for 262 144).
    pub fn radius_count(&self, setting: PhotonCount) -> u32 {
        match setting {
            PhotonCount::Fixed(n) => n,
            PhotonCount::Auto { max } | PhotonCount::GpuMilliseconds { max, .. } => {
                if self.fitted && self.count > 0 {
                    self.count.min(max)
                } else {
                    max
                }
            }
        }
    }

    /// The smoothed time per iteration at `count`, if it was timed.
    pub fn timing(&self, count: u32) -> Option<Timing> {
        let t = self.timings[slot(count)];
        (t.count == count && t.readings > 0).then_some(t)
    }

    /// `Auto`: an iteration takes a + b·n ms for n photons, by wall clock or GPU, whichever is
    /// longer (a CPU rasteriser's timestamps see part of its work, and stages overlap). a and
    /// b are fitted to the smoothed times of every count timed so far (least squares), so
    /// that the noise of two nearby counts' times does not swing the choice; the best n makes
    /// b·n = [`PHOTON_SHARE`] · a. Until two counts are timed, and until the slowest iteration
    /// takes [`SPAN`] times the fastest, the count grows ([`PROBE_STEP`]). It falls one
    /// octave at a time: where a is lost in the noise of the fit (photons nearly all of an
    /// iteration), the fit's best fell from 262 144 to the floor of 1 024 in one step.
    fn auto(&mut self, iteration_ms: f64, max: u32) -> u32 {
        let lowest = (self.count / 2).max(MIN_PHOTONS.min(max)).min(self.count);
        self.auto_best(iteration_ms, max).max(lowest)
    }

    fn auto_best(&mut self, iteration_ms: f64, max: u32) -> u32 {
        let here = &mut self.timings[slot(self.count)];
        if here.count != self.count {
            *here = Timing {
                count: self.count,
                ..Timing::default()
            };
        }
        let (settle, step) = if self.fitted {
            (SETTLE, 2)
        } else {
            (PROBE_SETTLE, PROBE_STEP)
        };
        here.add(iteration_ms);
        if here.readings < settle {
            return self.count;
        }
        let timed = || self.timings.iter().filter(|t| t.readings >= PROBE_SETTLE);
        let highest = timed().map(|t| t.count).max().unwrap_or(0);
        let slowest = timed().map(|t| t.ms).fold(0.0, f64::max);
        let fastest = timed().map(|t| t.ms).fold(f64::INFINITY, f64::min);
        // Until the photons' cost stands out of the timing noise, the count grows: a line
        // through two nearby counts' times (16 384 and 32 768 photons, both 310 ms on
        // llvmpipe) sent the count to 32 768 or 262 144 from run to run.
        let measured = slowest >= SPAN * fastest;
        let up = self.count.saturating_mul(step).min(max);
        let Some((fixed, per_photon)) = fit(timed()) else {
            return if up != self.count {
                up
            } else {
                (self.count / 2).max(MIN_PHOTONS.min(max))
            };
        };
        if !measured && self.count == highest {
            return up;
        }
        // Photons that cost nothing measurable (timing noise): one octave more from the
        // highest count timed. A jump to `max` (32 768 to 262 144 on a sunlit yard whose
        // iteration took 34 ms, less than at 16 384) set off a swing through every octave
        // between them.
        if per_photon.is_nan() || per_photon <= 0.0 {
            return if self.count == highest {
                up
            } else {
                self.count
            };
        }
        // The first fit takes its best count as it is; later ones move only past the
        // hysteresis.
        let octaves = if self.fitted { OCTAVES } else { 0.0 };
        self.fitted = true;
        count_within(
            self.count,
            per_photon * self.count as f64,
            PHOTON_SHARE * fixed.max(0.0),
            max,
            octaves,
        )
    }

    /// `GpuMilliseconds`: the photon stages' smoothed GPU time per photon fills what the
    /// other stages leave of the budget.
    fn gpu_budget(&mut self, photon_ms: f64, other_ms: f64, budget: f64, max: u32) -> u32 {
        let per_photon = photon_ms / self.count as f64;
        if self.readings == 0 && self.per_photon_ms == 0.0 {
            (self.per_photon_ms, self.other_gpu_ms) = (per_photon, other_ms);
        } else {
            self.per_photon_ms += SMOOTHING * (per_photon - self.per_photon_ms);
            self.other_gpu_ms += SMOOTHING * (other_ms - self.other_gpu_ms);
        }
        self.readings += 1;
        if self.readings < SETTLE {
            return self.count;
        }
        self.fitted = true;
        let photon_ms = self.per_photon_ms * self.count as f64;
        next_count(self.count, photon_ms, budget - self.other_gpu_ms, max)
    }
}

/// The slot of a count in [`PhotonController`]'s timings: its octave.
fn slot(count: u32) -> usize {
    (count.max(1).ilog2() as usize).min(SLOTS - 1)
}

/// The weighted least-squares line ms = a + b·n through the timings, as (a, b); `None`
/// unless two counts are timed.
fn fit<'a>(timings: impl Iterator<Item = &'a Timing>) -> Option<(f64, f64)> {
    let (mut w, mut n, mut ms, mut nn, mut n_ms) = (0.0, 0.0, 0.0, 0.0, 0.0);
    let mut counts = 0;
    for t in timings {
        let weight = t.readings.min(MOST_WEIGHT) as f64;
        let x = t.count as f64;
        w += weight;
        n += weight * x;
        ms += weight * t.ms;
        nn += weight * x * x;
        n_ms += weight * x * t.ms;
        counts += 1;
    }
    if counts < 2 {
        return None;
    }
    let (n, ms) = (n / w, ms / w);
    let spread = nn / w - n * n;
    let b = (n_ms / w - n * ms) / spread;
    Some((ms - b * n, b))
}

/// GPU ms of the stages whose work grows with the photon count, and of the others.
pub fn split(ms: &[f64; STAGES]) -> (f64, f64) {
    let mut photon = 0.0;
    let mut other = 0.0;
    for (stage, t) in Stage::ALL.iter().zip(ms) {
        match stage {
            Stage::PhotonTrace | Stage::PhotonSort | Stage::Splat | Stage::IndirectSplat => {
                photon += t
            }
            _ => other += t,
        }
    }
    (photon, other)
}

/// The count after `current` photons took `photon_ms`, when `target_ms` is what the photon
/// stages should take: a power of two (or `max`) in `MIN_PHOTONS..=max`, moved only when the
/// best count is more than [`OCTAVES`] away.
pub fn next_count(current: u32, photon_ms: f64, target_ms: f64, max: u32) -> u32 {
    count_within(current, photon_ms, target_ms, max, OCTAVES)
}

/// [`next_count`] with the hysteresis `octaves`.
fn count_within(current: u32, photon_ms: f64, target_ms: f64, max: u32, octaves: f64) -> u32 {
    let lowest = MIN_PHOTONS.min(max);
    if !photon_ms.is_finite() || photon_ms <= 0.0 || !target_ms.is_finite() {
        return current;
    }
    let best = current as f64 * target_ms.max(0.0) / photon_ms;
    if best < lowest as f64 {
        return lowest;
    }
    if (best / current as f64).log2().abs() <= octaves {
        return current;
    }
    let power = 2f64.powf(best.log2().round()).min(u32::MAX as f64) as u32;
    power.clamp(lowest, max)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn cost(photon: f64, other: f64, photons: u32) -> FrameCost {
        let mut ms = [0.0; STAGES];
        ms[Stage::PhotonTrace.index()] = photon;
        ms[Stage::CubemapBuild.index()] = other;
        FrameCost {
            ms,
            work: FrameWork {
                iterations: 1,
                photons,
            },
            wall_ms_per_iteration: 0.0,
        }
    }

    /// Feeds `frames` frames of a device where a photon costs `per_photon` ms and the rest of
    /// an iteration `other` ms, with the given timing noise, and returns the counts taken.
    fn run(setting: PhotonCount, per_photon: f64, other: f64, noise: &[f64]) -> Vec<u32> {
        let mut c = PhotonController::default();
        c.count(setting);
        let mut counts = Vec::new();
        for k in 0..64 {
            let f = noise[k % noise.len()];
            let n = c.count;
            c.observe(setting, cost(n as f64 * per_photon * f, other / f, n));
            counts.push(c.count);
        }
        counts
    }

    #[test]
    fn auto_settles_where_photons_take_their_share_of_the_rest() {
        let setting = PhotonCount::Auto { max: 1 << 20 };
        assert_eq!(PhotonController::default().count(setting), START_PHOTONS);
        // A photon costs 1 µs and the rest of an iteration 40 ms: the best count is 40 000
        // (1 × 40 ms of photons), whose nearest power of two is 32 768; timing that swings by
        // ±30 % moves it no more.
        assert_eq!(PHOTON_SHARE, 1.0);
        let counts = run(setting, 1e-3, 40.0, &[1.0]);
        assert_eq!(*counts.last().unwrap(), 32_768);
        let noisy = run(setting, 1e-3, 40.0, &[0.7, 1.3, 0.8, 1.25, 1.0, 1.4, 0.75]);
        let settled = &noisy[32..];
        assert!(settled.iter().all(|&n| n == 32_768), "{noisy:?}");
    }

    /// Noise factors in 1 ± `amplitude`, from a seed (a small LCG: the test's own draws).
    fn noise(seed: u32, amplitude: f64) -> Vec<f64> {
        let mut state = seed.wrapping_mul(747_796_405).wrapping_add(2_891_336_453);
        (0..64)
            .map(|_| {
                state = state.wrapping_mul(747_796_405).wrapping_add(2_891_336_453);
                1.0 + amplitude * (2.0 * (state >> 8) as f64 / (1u32 << 24) as f64 - 1.0)
            })
            .collect()
    }

    #[test]
    fn auto_takes_the_same_count_whatever_the_noise() {
        // `frosted_glass` on llvmpipe: 16 384 and 32 768 photons both took 310 ms an
        // iteration, 65 536 took 390: about 270 ms fixed and 1.8 µs a photon, so 150 000 is
        // best, between 131 072 and 262 144 (a fit within the noise may take either, and
        // keeps it). A line through the first two counts' noisy times sent the count to
        // 32 768 in one run of the suite and to 262 144 in the next.
        let setting = PhotonCount::Auto { max: 262_144 };
        for seed in 0..200 {
            let counts = run(setting, 1.8e-3, 270.0, &noise(seed, 0.15));
            let settled = counts[40];
            assert!(
                [131_072, 262_144].contains(&settled) && counts[40..].iter().all(|&n| n == settled),
                "seed {seed}: {counts:?}"
            );
        }
        // 40 ms fixed and 1 µs a photon: 40 000 is best, between 32 768 and 65 536.
        let setting = PhotonCount::Auto { max: 1 << 20 };
        for seed in 0..200 {
            let counts = run(setting, 1e-3, 40.0, &noise(seed, 0.15));
            let settled = counts[40];
            assert!(
                [32_768, 65_536].contains(&settled) && counts[40..].iter().all(|&n| n == settled),
                "seed {seed}: {counts:?}"
            );
        }
    }

    #[test]
    fn auto_probes_in_few_iterations() {
        // `water_pool` on llvmpipe: 510 ms an iteration and 2.5 µs a photon, best 204 000,
        // nearest 262 144. Doubling at four readings a count ran 16 iterations before it
        // (16 384 to 131 072); two octaves a step at two readings, 4.
        let setting = PhotonCount::Auto { max: 262_144 };
        let counts = run(setting, 2.5e-3, 510.0, &[1.0]);
        let last = *counts.last().unwrap();
        // counts[k] is what iteration k + 2 runs.
        let probing = counts.iter().rposition(|&n| n != last).map_or(1, |k| k + 2);
        assert_eq!((last, probing), (262_144, 4), "{counts:?}");
    }

    #[test]
    fn the_radius_is_for_the_count_timing_chose() {
        let setting = PhotonCount::Auto { max: 1 << 20 };
        let mut c = PhotonController::default();
        c.count(setting);
        // While it probes, the radius is for the most photons there may be.
        assert_eq!(c.radius_count(setting), 1 << 20);
        for _ in 0..64 {
            let n = c.count;
            c.observe(setting, cost(n as f64 * 1e-3, 40.0, n));
        }
        assert_eq!((c.count, c.radius_count(setting)), (32_768, 32_768));
        assert_eq!(c.radius_count(PhotonCount::Fixed(4096)), 4096);
        // A lower `max` than the count chosen bounds it.
        assert_eq!(c.radius_count(PhotonCount::Auto { max: 32_768 }), 32_768);
    }

    #[test]
    fn auto_falls_one_octave_at_a_time() {
        // Photons are all of an iteration (0.6 µs each): the fit finds no fixed cost, so its
        // best count is the floor, which the count reaches an octave at a time.
        let setting = PhotonCount::Auto { max: 262_144 };
        let counts = run(setting, 0.6e-3, 0.0, &[1.0]);
        assert_eq!(*counts.last().unwrap(), MIN_PHOTONS, "{counts:?}");
        let mut last = START_PHOTONS;
        for &n in &counts {
            assert!(n >= last / 2, "{counts:?}");
            last = n;
        }
    }

    #[test]
    fn wall_clock_time_counts_when_it_is_longer() {
        // The GPU's timestamps see 10 ms of the rest, the clock 100 ms.
        let setting = PhotonCount::Auto { max: 1 << 20 };
        let mut c = PhotonController::default();
        c.count(setting);
        for _ in 0..16 {
            let n = c.count;
            let mut f = cost(n as f64 * 1e-3, 10.0, n);
            f.wall_ms_per_iteration = 100.0 + n as f64 * 1e-3;
            c.observe(setting, f);
        }
        assert_eq!(c.count, 131_072); // 100 ms of photons at 1 µs: 100 000
    }

    #[test]
    fn counts_stay_in_range() {
        assert_eq!(next_count(16_384, 100.0, 0.001, 1 << 20), MIN_PHOTONS);
        assert_eq!(next_count(16_384, 0.001, 1e9, 262_144), 262_144);
        assert_eq!(next_count(16_384, 0.001, 1e9, 100_000), 100_000);
        assert_eq!(next_count(16_384, 10.0, -5.0, 262_144), MIN_PHOTONS);
        assert_eq!(next_count(16_384, 0.0, 10.0, 262_144), 16_384);
        assert_eq!(next_count(16_384, f64::NAN, 10.0, 262_144), 16_384);
        assert_eq!(next_count(500, 1.0, 1e9, 500), 500);
    }

    #[test]
    fn a_gpu_budget_fills_what_the_rest_leaves() {
        // 8 ms of other work leave 8 of 16 ms: at 0.25 µs a photon, 32 768 photons.
        let setting = PhotonCount::GpuMilliseconds {
            milliseconds: 16.0,
            max: 1 << 24,
        };
        assert_eq!(*run(setting, 0.25e-3, 8.0, &[1.0]).last().unwrap(), 32_768);
        // Timing of a count no longer in use is ignored, and a fixed count is what it says.
        let mut c = PhotonController::default();
        c.count(setting);
        assert!(!c.observe(setting, cost(1.0, 8.0, 4096)));
        assert_eq!(c.count(PhotonCount::Fixed(7)), 7);
    }
}
