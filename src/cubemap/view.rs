//! A camera's deep cubemap across frames: made, kept or dropped as the iteration needs one,
//! centred on the camera, and its lists grown when a build overflowed.

use bevy::prelude::*;
use bevy::render::renderer::{RenderDevice, RenderQueue};

use super::deep::grown_capacity;
use super::{BuildContext, CubemapConfig, DeepCubemap};

/// One camera's deep cubemap, when a stage that traces rays needs one.
#[derive(Default)]
pub struct ViewCubemap {
    pub cubemap: Option<DeepCubemap>,
    /// List capacity for the next cubemap made, raised when a build overflowed.
    capacity: u32,
    /// (nodes used, nodes lost) of the last build read back.
    pub nodes: (u32, u32),
}

impl ViewCubemap {
    /// Makes, keeps or drops the cubemap, and centres it on the camera. A new cubemap (first
    /// use, or another configuration) is built at once and its lists grown until that build
    /// loses no entry, so that the first iteration traces every triangle; later overflows (the
    /// scene grew) grow the lists from counters read back without a stall.
    pub fn prepare(
        &mut self,
        config: Option<CubemapConfig>,
        centre: Vec3,
        ctx: &BuildContext,
    ) -> Result<(), String> {
        let BuildContext {
            device,
            queue,
            scene,
            ..
        } = *ctx;
        let Some(config) = config else {
            self.cubemap = None;
            return Ok(());
        };
        let limits = device.limits();
        let limit = limits
            .max_storage_buffer_binding_size
            .min(limits.max_buffer_size);
        let fitted = config.fitted(limit, limits.max_texture_dimension_2d);
        if fitted != config {
            warn_once!(
                "bevy_rppm: a {}² deep cubemap with {} bins does not fit this GPU's buffers; \
                 using {}²",
                config.resolution,
                config.bins,
                fitted.resolution
            );
        }
        let config = fitted;
        let most = (limit / 8) as u32;
        let wanted = self.capacity.min(most);
        let stale = self
            .cubemap
            .as_ref()
            .is_none_or(|c| c.config != config || c.params.node_capacity < wanted);
        if stale {
            // Lists grown after an overflow are made without a build (no stall in a game).
            let grown = self.cubemap.as_ref().is_some_and(|c| c.config == config);
            self.cubemap = None;
            let cubemap = if grown {
                DeepCubemap::new(ctx, config, centre, wanted)?
            } else {
                // A new cubemap starts from a guess, fitted by its first build (which also
                // gives back most of a guess far too large).
                let guess = DeepCubemap::initial_capacity(config, scene.triangle_count());
                DeepCubemap::fitted(ctx, config, centre, wanted.max(guess).min(most))?.0
            };
            self.capacity = cubemap.params.node_capacity;
            self.cubemap = Some(cubemap);
        }
        if let Some(cubemap) = &mut self.cubemap {
            cubemap.set_centre(queue, centre);
        }
        Ok(())
    }

    /// Takes the list counters of a build: `waited` frames read this build's (they wait for
    /// the GPU anyway), others an earlier build's once its non-blocking read-back arrives.
    /// Lists that overflowed grow for the next build.
    pub fn read_counters(&mut self, device: &RenderDevice, queue: &RenderQueue, waited: bool) {
        let Some(cubemap) = &self.cubemap else {
            return;
        };
        let counters = if waited {
            crate::stats::readback::read_back(device, queue, cubemap.counters()).map(|bytes| {
                let c: &[u32] = bytemuck::cast_slice(&bytes);
                [c[0], c[1]]
            })
        } else {
            cubemap.poll_counters(device)
        };
        if let Some([used, lost]) = counters {
            self.nodes = (used.min(cubemap.params.node_capacity), lost);
            if lost > 0 {
                self.capacity = grown_capacity(used);
            }
        }
    }
}
