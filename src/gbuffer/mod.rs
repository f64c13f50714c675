//! The camera G-buffer: world position, shading normal, triangle and pixel footprint of the
//! first hit, rasterised from the scene's triangle buffer with this iteration's sub-pixel
//! jitter (`shaders/gbuffer/gbuffer.wgsl`).

use bevy::prelude::*;
use bevy::render::render_resource::*;
use bevy::render::renderer::RenderDevice;
use bevy::render::texture::TextureCache;
use bevy::render::{RenderApp, RenderStartup};

use crate::scene::{Lookups, texture_defs};
use crate::shaders::RppmShaders;
use crate::shadows::depth_state;
use crate::stats::timing::{Stage, StageTimer};
use crate::view::ViewLayouts;

pub const GBUFFER_FORMAT: TextureFormat = TextureFormat::Rgba32Float;
pub const DEPTH_FORMAT: TextureFormat = TextureFormat::Depth32Float;

pub(crate) struct GBufferPlugin;

impl Plugin for GBufferPlugin {
    fn build(&self, app: &mut App) {
        if let Some(render_app) = app.get_sub_app_mut(RenderApp) {
            render_app
                .init_resource::<SpecializedRenderPipelines<GBufferPipeline>>()
                .add_systems(RenderStartup, init_gbuffer_pipeline);
        }
    }
}

/// The G-buffer stage, specialized by the scene's material lookups (normal maps, alpha
/// cut-outs).
#[derive(Resource)]
pub struct GBufferPipeline {
    layouts: ViewLayouts,
    shader: Handle<Shader>,
}

impl SpecializedRenderPipeline for GBufferPipeline {
    type Key = Lookups;

    fn specialize(&self, lookups: Lookups) -> RenderPipelineDescriptor {
        let shader_defs = texture_defs(lookups);
        let target = Some(ColorTargetState {
            format: GBUFFER_FORMAT,
            blend: None,
            write_mask: ColorWrites::ALL,
        });
        RenderPipelineDescriptor {
            label: Some("rppm_gbuffer_pipeline".into()),
            layout: vec![self.layouts.scene.clone(), self.layouts.params.clone()],
            vertex: VertexState {
                shader: self.shader.clone(),
                shader_defs: shader_defs.clone(),
                ..default()
            },
            fragment: Some(FragmentState {
                shader: self.shader.clone(),
                shader_defs,
                targets: vec![target.clone(), target],
                ..default()
            }),
            // Reverse Z, as Bevy's camera projections.
            depth_stencil: Some(depth_state(DEPTH_FORMAT, CompareFunction::Greater)),
            ..default()
        }
    }
}

fn init_gbuffer_pipeline(
    mut commands: Commands,
    shaders: Res<RppmShaders>,
    layouts: Res<ViewLayouts>,
) {
    commands.insert_resource(GBufferPipeline {
        layouts: layouts.clone(),
        shader: shaders.gbuffer.clone(),
    });
}

/// One camera's G-buffer targets for this frame, from Bevy's `TextureCache` (per view and
/// size; a target no view asks for is freed after a few frames).
pub struct GBuffer {
    pub position: TextureView,
    pub normal: TextureView,
    depth: TextureView,
}

/// A 2D target that shaders read back as a texture, from the cache, drawn into or (with
/// `extra` `STORAGE_BINDING`) written by a compute pass.
pub fn target(
    cache: &mut TextureCache,
    device: &RenderDevice,
    label: &'static str,
    size: UVec2,
    format: TextureFormat,
    extra: TextureUsages,
) -> TextureView {
    cache
        .get(
            device,
            TextureDescriptor {
                label: Some(label),
                size: Extent3d {
                    width: size.x,
                    height: size.y,
                    depth_or_array_layers: 1,
                },
                mip_level_count: 1,
                sample_count: 1,
                dimension: TextureDimension::D2,
                format,
                usage: TextureUsages::RENDER_ATTACHMENT | TextureUsages::TEXTURE_BINDING | extra,
                view_formats: &[],
            },
        )
        .default_view
}

impl GBuffer {
    pub fn new(cache: &mut TextureCache, device: &RenderDevice, size: UVec2) -> Self {
        let mut target =
            |label, format| target(cache, device, label, size, format, TextureUsages::empty());
        Self {
            position: target("rppm_gbuffer_position", GBUFFER_FORMAT),
            normal: target("rppm_gbuffer_normal", GBUFFER_FORMAT),
            depth: target("rppm_gbuffer_depth", DEPTH_FORMAT),
        }
    }

    /// Whether both hold the same textures.
    pub fn same_textures(&self, other: &Self) -> bool {
        self.position.id() == other.position.id()
            && self.normal.id() == other.normal.id()
            && self.depth.id() == other.depth.id()
    }

    /// Bytes held for `pixels` pixels.
    pub fn bytes(pixels: u64) -> u64 {
        pixels * (16 + 16 + 4)
    }

    /// Rasterises the first hits of this iteration (params at `offset`).
    pub fn encode(
        &self,
        encoder: &mut CommandEncoder,
        pipeline: &RenderPipeline,
        groups: [&BindGroup; 2],
        triangles: u32,
        offset: u32,
        timer: &mut StageTimer,
    ) {
        let clear = Operations {
            load: LoadOp::Clear(LinearRgba::NONE.into()),
            store: StoreOp::Store,
        };
        let attachment = |view| {
            Some(RenderPassColorAttachment {
                view,
                depth_slice: None,
                resolve_target: None,
                ops: clear,
            })
        };
        let mut pass = encoder.begin_render_pass(&RenderPassDescriptor {
            label: Some("rppm_gbuffer"),
            color_attachments: &[attachment(&self.position), attachment(&self.normal)],
            depth_stencil_attachment: Some(RenderPassDepthStencilAttachment {
                view: &self.depth,
                depth_ops: Some(Operations {
                    load: LoadOp::Clear(0.0),
                    store: StoreOp::Discard,
                }),
                stencil_ops: None,
            }),
            timestamp_writes: timer.render_pass(Stage::GBuffer),
            occlusion_query_set: None,
            multiview_mask: None,
        });
        pass.set_pipeline(pipeline);
        pass.set_bind_group(0, groups[0], &[]);
        pass.set_bind_group(1, groups[1], &[offset]);
        pass.draw(0..triangles * 3, 0..1);
    }
}
