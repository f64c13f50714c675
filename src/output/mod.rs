//! Output: the estimate, times the camera's exposure, replaces the Bevy view (mode Full) or is
//! added to it before Bevy's tonemapping (mode Indirect, where the first hit's direct light is
//! left to Bevy) (`shaders/output/output.wgsl`).

use std::num::NonZeroU64;

use bevy::prelude::*;
use bevy::render::camera::ExtractedCamera;
use bevy::render::render_resource::binding_types::{
    storage_buffer_read_only_sized, uniform_buffer_sized,
};
use bevy::render::render_resource::*;
use bevy::render::renderer::RenderDevice;
use bevy::render::view::ViewTarget;
use bevy::render::{RenderApp, RenderStartup};
use bevy::shader::Shader;

use crate::settings::RppmMode;
use crate::shaders::RppmShaders;
use crate::stats::timing::{Stage, StageTimer};
use crate::view::IterationParams;

pub(crate) struct OutputPlugin;

impl Plugin for OutputPlugin {
    fn build(&self, app: &mut App) {
        if let Some(render_app) = app.get_sub_app_mut(RenderApp) {
            render_app
                .init_resource::<SpecializedRenderPipelines<OutputPipeline>>()
                .add_systems(RenderStartup, init_output_pipeline);
        }
    }
}

/// The output pass, specialized by [`OutputKey`].
#[derive(Resource)]
pub struct OutputPipeline {
    /// 0 params (dynamic offset), 1 the estimate.
    pub layout: BindGroupLayoutDescriptor,
    shader: Handle<Shader>,
}

/// The view's texture format, and whether our light is added to Bevy's (mode Indirect).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct OutputKey {
    pub format: TextureFormat,
    pub additive: bool,
}

impl SpecializedRenderPipeline for OutputPipeline {
    type Key = OutputKey;

    fn specialize(&self, key: OutputKey) -> RenderPipelineDescriptor {
        let add = BlendComponent {
            src_factor: BlendFactor::One,
            dst_factor: BlendFactor::One,
            operation: BlendOperation::Add,
        };
        let blend = key.additive.then_some(BlendState {
            color: add,
            alpha: BlendComponent::REPLACE,
        });
        RenderPipelineDescriptor {
            label: Some("rppm_output_pipeline".into()),
            layout: vec![self.layout.clone()],
            vertex: VertexState {
                shader: self.shader.clone(),
                ..default()
            },
            fragment: Some(FragmentState {
                shader: self.shader.clone(),
                targets: vec![Some(ColorTargetState {
                    format: key.format,
                    blend,
                    write_mask: ColorWrites::ALL,
                })],
                ..default()
            }),
            ..default()
        }
    }
}

fn init_output_pipeline(mut commands: Commands, shaders: Res<RppmShaders>) {
    let layout = BindGroupLayoutDescriptor::new(
        "rppm_output_layout",
        &BindGroupLayoutEntries::sequential(
            ShaderStages::FRAGMENT,
            (
                uniform_buffer_sized(true, NonZeroU64::new(size_of::<IterationParams>() as u64)),
                storage_buffer_read_only_sized(false, None),
            ),
        ),
    );
    commands.insert_resource(OutputPipeline {
        layout,
        shader: shaders.output.clone(),
    });
}

/// The variant of the output pass for a view: replacing it (Full), or added to Bevy's own
/// lighting before tonemapping (Indirect, which needs an HDR view: without one Bevy tonemaps
/// inside its shaders, and linear light added afterwards would be wrong, so nothing is added).
pub fn output_key(
    mode: RppmMode,
    camera: &ExtractedCamera,
    target: &ViewTarget,
    warned: &mut bool,
) -> Option<OutputKey> {
    let additive = mode == RppmMode::Indirect;
    if additive && !camera.hdr {
        if !*warned {
            warn!(
                "bevy_rppm: RppmMode::Indirect needs an HDR camera (add `Hdr`); showing Bevy's image alone"
            );
            *warned = true;
        }
        return None;
    }
    Some(OutputKey {
        format: target.main_texture_format(),
        additive,
    })
}

/// The output pass's groups binding a view's params and what it shows: the estimate, and
/// under `Reuse` its resolved edges (`shown`), drawn only in frames whose resolve ran; other
/// frames draw the estimate itself, with no copy.
pub struct OutputGroups {
    estimate: BindGroup,
    shown: Option<BindGroup>,
}

impl OutputGroups {
    pub fn new(
        device: &RenderDevice,
        cache: &PipelineCache,
        pipeline: &OutputPipeline,
        params: BufferBinding,
        radiance: &Buffer,
        shown: Option<&Buffer>,
    ) -> Self {
        let layout = cache.get_bind_group_layout(&pipeline.layout);
        let group = |b: &Buffer| {
            device.create_bind_group(
                "rppm_output_group",
                &layout,
                &BindGroupEntries::sequential((params.clone(), b.as_entire_binding())),
            )
        };
        Self {
            estimate: group(radiance),
            shown: shown.map(group),
        }
    }

    /// This frame's group: the resolved edges where the resolve ran (`resolved`).
    pub fn pick(&self, resolved: bool) -> &BindGroup {
        self.shown
            .as_ref()
            .filter(|_| resolved)
            .unwrap_or(&self.estimate)
    }
}

/// Draws the estimate into the view's main texture.
pub fn encode(
    encoder: &mut CommandEncoder,
    pipeline: &RenderPipeline,
    group: &BindGroup,
    target: &ViewTarget,
    timer: &mut StageTimer,
) {
    let mut pass = encoder.begin_render_pass(&RenderPassDescriptor {
        label: Some("rppm_output"),
        color_attachments: &[Some(RenderPassColorAttachment {
            view: target.main_texture_view(),
            depth_slice: None,
            resolve_target: None,
            ops: Operations {
                load: LoadOp::Load,
                store: StoreOp::Store,
            },
        })],
        depth_stencil_attachment: None,
        timestamp_writes: timer.render_pass(Stage::Output),
        occlusion_query_set: None,
        multiview_mask: None,
    });
    pass.set_pipeline(pipeline);
    pass.set_bind_group(0, group, &[0]);
    pass.draw(0..3, 0..1);
}
