//! Profiling mode (`PhotonMapping::profile_stages`): each stage is submitted alone and waited
//! for, and the CPU wall time until it finished is charged to it. Trustworthy where GPU
//! timestamps are not (llvmpipe runs passes overlapped); slow, since the GPU idles between
//! stages.

use std::time::Instant;

use bevy::render::render_resource::{CommandEncoder, CommandEncoderDescriptor, PollType};
use bevy::render::renderer::{RenderDevice, RenderQueue};

use super::timing::{STAGES, Stage};

/// Wall milliseconds per stage, summed over the profiled iterations of one view. The first
/// profiled frame is left out: drivers compile shaders at their first use (llvmpipe does),
/// which would be charged to the stage that first ran them.
#[derive(Clone, Debug, Default)]
pub struct WallProfile {
    pub total_ms: [f64; STAGES],
    pub iterations: u64,
    warmed_up: bool,
}

impl WallProfile {
    /// Mean wall ms per iteration of each stage that ran (empty before any).
    pub fn per_iteration(&self) -> Vec<(&'static str, f64)> {
        if self.iterations == 0 {
            return Vec::new();
        }
        Stage::ALL
            .iter()
            .zip(self.total_ms)
            .filter(|(_, ms)| *ms > 0.0)
            .map(|(s, ms)| (s.name(), ms / self.iterations as f64))
            .collect()
    }
}

/// One frame's profiling: `stage` submits what was recorded since the last call and waits.
pub struct Checkpoints<'a> {
    device: &'a RenderDevice,
    queue: &'a RenderQueue,
    profile: &'a mut WallProfile,
    last: Instant,
}

impl<'a> Checkpoints<'a> {
    /// Submits and waits for what `encoder` holds so far (not charged), then starts the clock.
    pub fn start(
        device: &'a RenderDevice,
        queue: &'a RenderQueue,
        profile: &'a mut WallProfile,
        encoder: &mut CommandEncoder,
    ) -> Self {
        let mut checkpoints = Self {
            device,
            queue,
            profile,
            last: Instant::now(),
        };
        checkpoints.submit(encoder);
        checkpoints.last = Instant::now();
        checkpoints
    }

    fn submit(&mut self, encoder: &mut CommandEncoder) {
        let fresh = self
            .device
            .create_command_encoder(&CommandEncoderDescriptor::default());
        let recorded = std::mem::replace(encoder, fresh);
        self.queue.submit([recorded.finish()]);
        let _ = self.device.poll(PollType::wait_indefinitely());
    }

    /// Charges the time until the GPU finished what was recorded since the last checkpoint
    /// to `stage`.
    pub fn stage(&mut self, encoder: &mut CommandEncoder, stage: Stage) {
        self.submit(encoder);
        let now = Instant::now();
        if self.profile.warmed_up {
            self.profile.total_ms[stage.index()] += (now - self.last).as_secs_f64() * 1e3;
        }
        self.last = now;
    }

    /// Ends the frame: counts its `n` iterations (after the first frame).
    pub fn iterations(&mut self, n: u32) {
        if self.profile.warmed_up {
            self.profile.iterations += n as u64;
        }
        self.profile.warmed_up = true;
    }
}

/// `checkpoints.stage(encoder, stage)` when profiling.
pub fn mark(checkpoints: &mut Option<Checkpoints>, encoder: &mut CommandEncoder, stage: Stage) {
    if let Some(c) = checkpoints {
        c.stage(encoder, stage);
    }
}
