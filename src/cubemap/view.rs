//! A camera's deep cubemap across frames: made, kept or dropped as the iteration needs one,
//! centred on the camera, and its lists grown when a build overflowed. Under
//! `RppmTracer::Bvh` its lists stay empty and unbuilt (photon binning still uses its tiles)
//! and the view's hierarchy, refitted while geometry moves and rebuilt once it stays, is
//! bound with it.

use bevy::prelude::*;
use bevy::render::renderer::{RenderDevice, RenderQueue};

use super::bvh::{BvhBuffers, Follow};
use super::{BuildContext, CubemapConfig, DeepCubemap};
use crate::ppm::grown_capacity;
use crate::view::binding_limit;

/// A view's hierarchy, and the scene epoch it was built from or checked against.
pub struct ViewBvh {
    pub buffers: BvhBuffers,
    epoch: u64,
    /// Frames since the geometry last changed.
    still: u32,
}

/// Frames a geometry must stay before a refitted hierarchy is built again (a build walks
/// faster; it costs the whole scene, once).
const SETTLE_FRAMES: u32 = 16;

/// One camera's deep cubemap, when a stage that traces rays needs one.
#[derive(Default)]
pub struct ViewCubemap {
    pub cubemap: Option<DeepCubemap>,
    /// List capacity for the next cubemap made, raised when a build overflowed.
    capacity: u32,
    /// (nodes used, nodes lost) of the last build read back.
    pub nodes: (u32, u32),
    /// The hierarchy (`RppmTracer::Bvh`).
    pub bvh: Option<ViewBvh>,
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
        bvh: bool,
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
            self.bvh = None;
            return Ok(());
        };
        let fitted = fitted(config, device);
        if fitted != config {
            warn_once!(
                "bevy_rppm: a {}² deep cubemap with {} bins does not fit this GPU's buffers; \
                 using {}²",
                config.resolution,
                config.bins,
                fitted.resolution
            );
        }
        if bvh {
            return self.prepare_bvh(fitted, centre, ctx);
        }
        self.bvh = None;
        let config = fitted;
        let most = DeepCubemap::most_nodes(device);
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

    /// Under `RppmTracer::Bvh`: an unbuilt cubemap with one depth bin and one list entry
    /// (only its tiles are used), and the hierarchy of the scene as it is now.
    fn prepare_bvh(
        &mut self,
        config: CubemapConfig,
        centre: Vec3,
        ctx: &BuildContext,
    ) -> Result<(), String> {
        let config = CubemapConfig { bins: 1, ..config };
        let scene = ctx.scene;
        let layout = || ctx.cache.get_bind_group_layout(&ctx.pipelines.trace_layout);
        if self.cubemap.as_ref().is_none_or(|c| c.config != config) {
            let mut cubemap = DeepCubemap::new(ctx, config, centre, 1)?;
            // A hierarchy already built stays: the new cubemap binds it.
            if let Some(bvh) = &self.bvh {
                cubemap.bind_bvh(ctx.device, &layout(), &bvh.buffers);
            }
            self.cubemap = Some(cubemap);
        }
        let Some(cubemap) = &mut self.cubemap else {
            return Ok(());
        };
        cubemap.set_centre(ctx.queue, centre);
        // Looked at when the scene changed, and updated only when its geometry did (not for a
        // light or a material): refitted while it moves, built again once it stays.
        let device = ctx.device;
        let build = |cubemap: &mut DeepCubemap| {
            let buffers = BvhBuffers::build(device, ctx.queue, &scene.data);
            cubemap.bind_bvh(device, &layout(), &buffers);
            buffers
        };
        let Some(b) = &mut self.bvh else {
            self.bvh = Some(ViewBvh {
                buffers: build(cubemap),
                epoch: scene.epoch,
                still: 0,
            });
            return Ok(());
        };
        let moved = b.epoch != scene.epoch && {
            let follow = b.buffers.follow(ctx.queue, &scene.data);
            if follow == Follow::Build {
                b.buffers = build(cubemap);
            }
            follow != Follow::Same
        };
        b.epoch = scene.epoch;
        if moved {
            b.still = 0;
        } else {
            b.still = b.still.saturating_add(1);
            if b.still == SETTLE_FRAMES && b.buffers.refitted() {
                b.buffers = build(cubemap);
            }
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

/// `config` as this GPU can hold it (a smaller resolution where its lists would not fit).
pub fn fitted(config: CubemapConfig, device: &RenderDevice) -> CubemapConfig {
    config.fitted(
        binding_limit(device),
        device.limits().max_texture_dimension_2d,
    )
}
