//! Edges through a camera move (`RppmHistory::Reuse`): what the view shows and reads back is
//! the estimate with each edge's pixels reconstructed from eight rays through their footprint
//! (subpixel reconstruction, `shaders/accumulate/resolve.wgsl`). A frame whose camera moved
//! rasterizes all its iterations at one jitter, so each pixel's history holds one surface
//! and an edge's pixel one side; the still frames after it show a falling share of the
//! resolve as their jitter anti-aliases edges itself ([`resolve_share`]), then the estimate
//! as it is.

use bevy::prelude::*;
use bevy::render::render_resource::binding_types::{
    storage_buffer_read_only_sized, storage_buffer_sized, texture_2d,
};
use bevy::render::render_resource::*;
use bevy::render::renderer::RenderDevice;
use bevy::shader::Shader;

use crate::cubemap;
use crate::gbuffer::GBuffer;
use crate::importons::dispatch_per_pixel;
use crate::scene::{Lookups, texture_defs};
use crate::stats::timing::{Stage, StageTimer};
use crate::view::{ViewLayouts, pixel_buffer};

/// The share of the resolved edges in what a frame shows, `since` iterations after the last
/// frame whose camera moved, under a `window` of history: whole in that frame, falling as a
/// still view's jittered iterations, which anti-alias edges themselves, take over the pixels'
/// estimates (the one-jitter part's share is at most `window / (window + since)`); none once
/// that is a half: the resolve of an estimate its jitter anti-aliased blurs it (measured).
pub fn resolve_share(window: u32, since: u32) -> f32 {
    let kept = window.max(1) as f32;
    let share = kept / (kept + since as f32);
    (2.0 * share - 1.0).max(0.0)
}

/// The pass, specialized by [`ResolveKey`].
pub struct ResolvePipeline {
    /// Group 2 (0 the scene's, 1 params, 3 tracing): 0 G-buffer position, 1 G-buffer normal,
    /// 2 the estimate, 3 what is shown.
    pub layout: BindGroupLayoutDescriptor,
    view: ViewLayouts,
    shader: Handle<Shader>,
}

/// What the rays through an edge's pixels need.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct ResolveKey {
    /// The scene's material lookups (cut-outs the rays pass).
    pub lookups: Lookups,
    /// Rays through the hierarchy (`BVH`).
    pub bvh: bool,
}

impl ResolvePipeline {
    pub fn new(view: &ViewLayouts, shader: Handle<Shader>) -> Self {
        let unfilterable = TextureSampleType::Float { filterable: false };
        let layout = BindGroupLayoutDescriptor::new(
            "rppm_resolve_layout",
            &BindGroupLayoutEntries::sequential(
                ShaderStages::COMPUTE,
                (
                    texture_2d(unfilterable),
                    texture_2d(unfilterable),
                    storage_buffer_read_only_sized(false, None),
                    storage_buffer_sized(false, None),
                ),
            ),
        );
        Self {
            layout,
            view: view.clone(),
            shader,
        }
    }
}

impl SpecializedComputePipeline for ResolvePipeline {
    type Key = ResolveKey;

    fn specialize(&self, key: ResolveKey) -> ComputePipelineDescriptor {
        let mut shader_defs = texture_defs(key.lookups);
        if key.bvh {
            shader_defs.push("BVH".into());
        }
        ComputePipelineDescriptor {
            label: Some("rppm_resolve".into()),
            layout: vec![
                self.view.scene.clone(),
                self.view.params.clone(),
                self.layout.clone(),
                cubemap::trace_layout(),
            ],
            shader: self.shader.clone(),
            shader_defs,
            ..default()
        }
    }
}

/// What a `Reuse` view shows and reads back, and the pass's group.
pub struct Resolved {
    pub shown: Buffer,
    group: Option<BindGroup>,
}

impl Resolved {
    pub fn new(device: &RenderDevice, size: UVec2) -> Self {
        let usage = BufferUsages::COPY_SRC | BufferUsages::COPY_DST;
        Self {
            shown: pixel_buffer(device, size, "rppm_shown", 16, usage),
            group: None,
        }
    }

    /// Binds this frame's G-buffer and the estimate.
    pub fn bind(
        &mut self,
        device: &RenderDevice,
        cache: &PipelineCache,
        pipeline: &ResolvePipeline,
        gbuffer: &GBuffer,
        radiance: &Buffer,
    ) {
        self.group = Some(device.create_bind_group(
            "rppm_resolve_group",
            &cache.get_bind_group_layout(&pipeline.layout),
            &BindGroupEntries::sequential((
                &gbuffer.position,
                &gbuffer.normal,
                radiance.as_entire_binding(),
                self.shown.as_entire_binding(),
            )),
        ));
    }

    /// The estimate with its edges reconstructed, in a frame where the resolve has a share;
    /// the estimate as it is until `pass` (and the view's tracing groups) are there.
    pub fn encode(
        &self,
        encoder: &mut CommandEncoder,
        pass: Option<(&ComputePipeline, [&BindGroup; 3])>,
        radiance: &Buffer,
        offset: u32,
        size: UVec2,
        timer: &mut StageTimer,
    ) {
        let (Some((pipeline, [scene, params, tracing])), Some(group)) = (pass, &self.group) else {
            encoder.copy_buffer_to_buffer(radiance, 0, &self.shown, 0, self.shown.size());
            return;
        };
        let mut pass = encoder.begin_compute_pass(&ComputePassDescriptor {
            label: Some("rppm_resolve"),
            timestamp_writes: timer.compute_pass(Stage::Accumulate),
        });
        pass.set_pipeline(pipeline);
        pass.set_bind_group(3, tracing, &[]);
        dispatch_per_pixel(&mut pass, [scene, params, group], offset, size);
    }
}

#[cfg(test)]
mod tests {
    use super::resolve_share;

    #[test]
    fn the_resolves_share_is_whole_after_a_move_and_falls_to_none() {
        assert_eq!(resolve_share(8, 0), 1.0);
        let shares: Vec<f32> = (0..=24).map(|n| resolve_share(8, n)).collect();
        assert!(shares.windows(2).all(|w| w[1] <= w[0]));
        assert!((resolve_share(8, 4) - 1.0 / 3.0).abs() < 1e-6);
        assert_eq!(resolve_share(8, 8), 0.0);
        assert_eq!(resolve_share(0, 0), 1.0);
        assert_eq!(resolve_share(8, u32::MAX), 0.0);
    }
}
