//! A view's history kept through motion (`RppmHistory::Reuse`): each pixel's surface and the
//! running mean of its direct light, and last frame's copies of those and of the estimate,
//! which a camera move reprojects from (made at the view's first change).

use bevy::prelude::*;
use bevy::render::render_resource::*;
use bevy::render::renderer::RenderDevice;

use crate::view::{per_pixel_binding_fits, pixel_buffer};

pub struct History {
    /// Blocks of one vec4 a pixel: surface (position, packed normal), direct light (mean,
    /// count), indirect light since the last change (mean, count), where camera paths go on
    /// past the G-buffer (glass, mirrors) the point they showed, and where textures or
    /// vertex colours vary albedo the mean albedo of the direct light's samples
    /// (`shaders/accumulate/`).
    pub history: Buffer,
    /// Last frame's estimate and history, which a camera move reprojects from and a settling
    /// change clamps with: made at the view's first change (`make_previous`), as a still
    /// view reads neither.
    previous: Option<[Buffer; 2]>,
    /// Bound in their place until then.
    placeholder: Buffer,
    size: UVec2,
    /// Bytes a pixel of `history`.
    pixel_bytes: u64,
}

/// Bytes a pixel of the history buffer (bound whole): three vec4 blocks, one for the points
/// that glass and mirrors show where camera paths go on (`importons`), and one for the
/// albedo where it varies (`demodulated`).
const fn history_bytes(importons: bool, demodulated: bool) -> u64 {
    48 + if importons { 16 } else { 0 } + if demodulated { 16 } else { 0 }
}

/// Whether the view's history fits this device's bindings; a target too large for them runs
/// `Reuse` as `Reset` (with a warning) rather than fail.
pub(crate) fn history_fits(
    device: &RenderDevice,
    size: UVec2,
    importons: bool,
    demodulated: bool,
) -> bool {
    per_pixel_binding_fits(
        device,
        size,
        history_bytes(importons, demodulated),
        "history",
    )
    .inspect_err(|e| warn_once!("bevy_rppm: {e}: RppmHistory::Reuse runs as Reset"))
    .is_ok()
}

impl History {
    pub fn new(device: &RenderDevice, size: UVec2, importons: bool, demodulated: bool) -> Self {
        let bytes = history_bytes(importons, demodulated);
        Self {
            history: pixel_buffer(device, size, "rppm_history", bytes, BufferUsages::COPY_SRC),
            previous: None,
            size,
            pixel_bytes: bytes,
            placeholder: pixel_buffer(
                device,
                UVec2::ONE,
                "rppm_history_placeholder",
                bytes,
                BufferUsages::empty(),
            ),
        }
    }

    /// Makes last frame's copies, unless made; returns whether they were made now.
    pub fn make_previous(&mut self, device: &RenderDevice) -> bool {
        if self.previous.is_some() {
            return false;
        }
        let (size, copy) = (self.size, BufferUsages::COPY_DST);
        self.previous = Some([
            pixel_buffer(device, size, "rppm_previous_radiance", 16, copy),
            pixel_buffer(
                device,
                size,
                "rppm_previous_history",
                self.pixel_bytes,
                copy,
            ),
        ]);
        true
    }

    /// What binds as last frame's estimate and history.
    pub fn previous_bindings(&self) -> [&Buffer; 2] {
        match &self.previous {
            Some([radiance, history]) => [radiance, history],
            None => [&self.placeholder; 2],
        }
    }

    /// Copies the estimate (`radiance`) and the history to last frame's.
    pub fn encode_keep(&self, encoder: &mut CommandEncoder, radiance: &Buffer) {
        let Some([previous_radiance, previous_history]) = &self.previous else {
            return;
        };
        for (from, to) in [
            (radiance, previous_radiance),
            (&self.history, previous_history),
        ] {
            encoder.copy_buffer_to_buffer(from, 0, to, 0, to.size());
        }
    }

    /// Copies the means since the last change to last iteration's, which the neighbourhoods
    /// of this one read (its own writes would race with them).
    pub fn encode_keep_fresh(&self, encoder: &mut CommandEncoder) {
        let Some([_, previous_history]) = &self.previous else {
            return;
        };
        let block = 16 * u64::from(self.size.x) * u64::from(self.size.y);
        encoder.copy_buffer_to_buffer(&self.history, 2 * block, previous_history, 2 * block, block);
    }

    pub fn bytes(&self) -> u64 {
        let previous = self.previous.iter().flatten();
        [&self.history, &self.placeholder]
            .into_iter()
            .chain(previous)
            .map(|b| b.size())
            .sum()
    }
}
