//! How much work an iteration and a frame do: photons per iteration, iterations per frame.

use bevy::prelude::*;

/// How many photons each iteration emits, split between lights by power.
#[derive(Reflect, Clone, Copy, Debug, PartialEq)]
#[reflect(Default, Clone, PartialEq)]
pub enum PhotonCount {
    /// Exactly this many every iteration. Range 0..=2^24.
    Fixed(u32),
    /// As many as the device affords (default, `max` 262 144): the photon stages (tracing,
    /// splatting, indirect splatting) are kept at about the GPU time of the rest of the
    /// iteration, measured by timestamps, so a CPU rasteriser and a big GPU both run many
    /// iterations a minute. The count starts at 16 384 (or `max`), probes up two octaves at a
    /// time (two iterations each) until photons cost measurably more, then moves in powers of
    /// two between 1024 and `max` (range 1024..=2^24); a change of count keeps the estimate, and
    /// the gather radius is for `max` until the timing chose a count, then for that count
    /// (the iterations before weigh by their photons).
    /// Without timestamp queries it stays at its start.
    Auto { max: u32 },
    /// As many as keep a whole iteration near `milliseconds` of GPU time (range 0.1..=60 000),
    /// between 1024 and `max`: for a game's per-frame budget.
    GpuMilliseconds { milliseconds: f32, max: u32 },
}

impl Default for PhotonCount {
    fn default() -> Self {
        Self::Auto { max: 262_144 }
    }
}

impl PhotonCount {
    /// The most photons an iteration may emit.
    pub fn max(self) -> u32 {
        match self {
            Self::Fixed(n) => n,
            Self::Auto { max } | Self::GpuMilliseconds { max, .. } => max,
        }
    }
}

/// How many PPM iterations each rendered frame runs.
#[derive(Reflect, Clone, Copy, Debug, PartialEq)]
#[reflect(Default, Clone, PartialEq)]
pub enum IterationsPerFrame {
    /// Exactly this many (range 1..=[`Self::MOST`], 64; default 1).
    Fixed(u32),
    /// As many as keep a frame's GPU time, all stages by timestamps, near `milliseconds`
    /// (range 0.1..=60 000), between 1 and `max` (range 1..=[`Self::MOST`]): a game's GI budget a frame,
    /// or a fast GPU kept busy while the CPU prepares the next frame (an iteration of a few
    /// milliseconds otherwise waits on a frame's CPU work). On a software adapter the
    /// wall-clock time of an iteration counts too (its timestamps see part of the work).
    /// Without timestamp queries it stays at 1.
    GpuMilliseconds { milliseconds: f32, max: u32 },
}

impl Default for IterationsPerFrame {
    fn default() -> Self {
        Self::Fixed(1)
    }
}

impl IterationsPerFrame {
    /// The most iterations any frame runs: a frame's timestamp queries hold about this many
    /// iterations' passes.
    pub const MOST: u32 = 64;

    /// The most iterations a frame may run.
    pub fn max(self) -> u32 {
        match self {
            Self::Fixed(n) | Self::GpuMilliseconds { max: n, .. } => n,
        }
    }
}
