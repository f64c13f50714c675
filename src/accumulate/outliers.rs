//! Outliers: before an iteration is folded in, a camera path's sample far above its pixel's
//! and surface's estimate so far keeps a bound that grows with the pixel's iterations and
//! spreads the rest over its surface's pixels around it (`shaders/accumulate/outliers.wgsl`).
//! Run where camera paths go on past the G-buffer, whose rare paths to a small bright light
//! (through rough glass, by a Fresnel reflection) are single samples of 10³ in pixels that
//! read 1: the image keeps its energy, and the light lands where it falls on average. The
//! first iteration, with no estimate yet, weighs each sample against its neighbours'.

use bevy::prelude::*;
use bevy::render::render_resource::binding_types::{
    storage_buffer_read_only_sized, storage_buffer_sized, texture_2d,
};
use bevy::render::render_resource::*;
use bevy::render::renderer::RenderDevice;

use crate::gbuffer::GBuffer;
use crate::importons::EyePaths;
use crate::shaders::RppmShaders;
use crate::view::layouts::params_entry;
use crate::view::pixel_buffer;

/// The two passes: `bound` (each pixel's sample bounded, the rest kept aside) and `spread`
/// (each pixel's share of what its neighbours kept aside).
pub struct OutlierPipelines {
    /// Group 1 (group 0: the scene's): 0 params (dynamic offset), 1 samples, 2 the running estimate, 3 what each pixel
    /// spreads, 4 G-buffer position, 5 G-buffer normal, 6 importon radiance.
    pub layout: BindGroupLayoutDescriptor,
    pub passes: [CachedComputePipelineId; 2],
}

impl OutlierPipelines {
    pub fn new(
        cache: &PipelineCache,
        shaders: &RppmShaders,
        scene: &BindGroupLayoutDescriptor,
    ) -> Self {
        let unfilterable = TextureSampleType::Float { filterable: false };
        let layout = BindGroupLayoutDescriptor::new(
            "rppm_outliers_layout",
            &BindGroupLayoutEntries::sequential(
                ShaderStages::COMPUTE,
                (
                    params_entry(),
                    storage_buffer_sized(false, None),
                    storage_buffer_read_only_sized(false, None),
                    storage_buffer_sized(false, None),
                    texture_2d(unfilterable),
                    texture_2d(unfilterable),
                    storage_buffer_sized(false, None),
                ),
            ),
        );
        let passes = ["bound", "spread"].map(|entry| {
            cache.queue_compute_pipeline(ComputePipelineDescriptor {
                label: Some(format!("rppm_outliers_{entry}").into()),
                layout: vec![scene.clone(), layout.clone()],
                shader: shaders.outliers.clone(),
                entry_point: Some(entry.into()),
                ..default()
            })
        });
        Self { layout, passes }
    }
}

/// One camera's light kept aside by `bound` (16 bytes a pixel), and the group of both passes.
pub struct Outliers {
    excess: Buffer,
    group: Option<BindGroup>,
}

impl Outliers {
    pub fn new(device: &RenderDevice, size: UVec2) -> Self {
        let excess = pixel_buffer(device, size, "rppm_outliers", 16, BufferUsages::empty());
        Self {
            excess,
            group: None,
        }
    }

    pub fn bytes(&self) -> u64 {
        self.excess.size()
    }

    /// Binds this frame's samples, estimate and G-buffer.
    pub fn bind(
        &mut self,
        device: &RenderDevice,
        layout: &BindGroupLayout,
        params: BufferBinding,
        eye_paths: &EyePaths,
        radiance: &Buffer,
        gbuffer: &GBuffer,
    ) {
        self.group = Some(device.create_bind_group(
            "rppm_outliers_group",
            layout,
            &BindGroupEntries::sequential((
                params,
                eye_paths.samples.as_entire_binding(),
                radiance.as_entire_binding(),
                self.excess.as_entire_binding(),
                &gbuffer.position,
                &gbuffer.normal,
                eye_paths.radiance.as_entire_binding(),
            )),
        ));
    }

    /// Records both passes into the accumulation's compute pass, before it folds the samples.
    pub fn dispatch(
        &self,
        pass: &mut ComputePass,
        passes: [&ComputePipeline; 2],
        scene_group: &BindGroup,
        size: UVec2,
        offset: u32,
    ) {
        let Some(group) = &self.group else { return };
        for pipeline in passes {
            pass.set_pipeline(pipeline);
            pass.set_bind_group(0, scene_group, &[]);
            pass.set_bind_group(1, group, &[offset]);
            pass.dispatch_workgroups(size.x.div_ceil(8), size.y.div_ceil(8), 1);
        }
    }
}
