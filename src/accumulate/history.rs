//! A view's history kept through motion (`RppmHistory::Reuse`): each pixel's surface and the
//! running mean of its direct light, and last frame's copies of those and of the estimate,
//! which a camera move reprojects from.

use bevy::prelude::*;
use bevy::render::render_resource::*;
use bevy::render::renderer::RenderDevice;

use crate::view::per_pixel_binding_fits;

pub struct History {
    /// Three blocks of one vec4 a pixel: surface (position, packed normal), direct light
    /// (mean, count) and indirect light since the last change (mean, count)
    /// (`shaders/accumulate/`).
    pub history: Buffer,
    pub previous_radiance: Buffer,
    pub previous_history: Buffer,
}

/// Bytes a pixel of the largest history buffer (three vec4 blocks, bound whole).
const HISTORY_BYTES: u64 = 48;

/// Whether the view's history fits this device's bindings; a target too large for them runs
/// `Reuse` as `Reset` (with a warning) rather than fail.
pub(crate) fn history_fits(device: &RenderDevice, size: UVec2) -> bool {
    per_pixel_binding_fits(device, size, HISTORY_BYTES, "history")
        .inspect_err(|e| warn_once!("bevy_rppm: {e}: RppmHistory::Reuse runs as Reset"))
        .is_ok()
}

impl History {
    pub fn new(device: &RenderDevice, size: UVec2) -> Self {
        let pixels = size.x as u64 * size.y as u64;
        let buffer = |label: &'static str, bytes: u64, usage: BufferUsages| {
            device.create_buffer(&BufferDescriptor {
                label: Some(label),
                size: pixels * bytes,
                usage: BufferUsages::STORAGE | usage,
                mapped_at_creation: false,
            })
        };
        Self {
            history: buffer("rppm_history", HISTORY_BYTES, BufferUsages::COPY_SRC),
            previous_radiance: buffer("rppm_previous_radiance", 16, BufferUsages::COPY_DST),
            previous_history: buffer(
                "rppm_previous_history",
                HISTORY_BYTES,
                BufferUsages::COPY_DST,
            ),
        }
    }

    /// Copies the estimate (`radiance`) and the history to last frame's.
    pub fn encode_keep(&self, encoder: &mut CommandEncoder, radiance: &Buffer) {
        for (from, to) in [
            (radiance, &self.previous_radiance),
            (&self.history, &self.previous_history),
        ] {
            encoder.copy_buffer_to_buffer(from, 0, to, 0, to.size());
        }
    }

    /// Copies the means since the last change to last iteration's, which the neighbourhoods
    /// of this one read (its own writes would race with them).
    pub fn encode_keep_fresh(&self, encoder: &mut CommandEncoder) {
        let block = self.history.size() / 3;
        encoder.copy_buffer_to_buffer(
            &self.history,
            2 * block,
            &self.previous_history,
            2 * block,
            block,
        );
    }

    pub fn bytes(&self) -> u64 {
        [
            &self.history,
            &self.previous_radiance,
            &self.previous_history,
        ]
        .iter()
        .map(|b| b.size())
        .sum()
    }
}
