//! Direct light's shadows: a depth cube per point and spot light, one orthographic map per
//! directional light (rendered once per scene change), and a cube at this iteration's sample
//! on the emissive surfaces (rendered every iteration, so area-light shadows soften as
//! iterations average). `shaders/shadows/lighting.wgsl` samples them.

mod maps;

use bevy::prelude::*;
use bevy::render::render_resource::*;
use bevy::render::{RenderApp, RenderStartup};

pub use maps::{ShadowMaps, ShadowView, cube_views, directional_view, light_views};

use crate::shaders::RppmShaders;
use crate::stats::timing::{Stage, StageTimer};
use crate::view::ViewLayouts;

pub const SHADOW_FORMAT: TextureFormat = TextureFormat::Depth32Float;

/// Past this many point, spot and directional lights, a point's direct light draws this many
/// of them by power (`MANY_LIGHTS` in `shaders/shadows/lighting.wgsl`): it is sampled.
pub const MANY_LIGHTS: usize = 8;

pub(crate) struct ShadowsPlugin;

impl Plugin for ShadowsPlugin {
    fn build(&self, app: &mut App) {
        if let Some(render_app) = app.get_sub_app_mut(RenderApp) {
            render_app.add_systems(RenderStartup, init_shadow_pipeline);
        }
    }
}

/// The depth-only pipeline every shadow view is rendered with.
#[derive(Resource)]
pub struct ShadowPipeline(pub CachedRenderPipelineId);

fn init_shadow_pipeline(
    mut commands: Commands,
    cache: Res<PipelineCache>,
    shaders: Res<RppmShaders>,
    layouts: Res<ViewLayouts>,
) {
    let id = cache.queue_render_pipeline(RenderPipelineDescriptor {
        label: Some("rppm_shadow_pipeline".into()),
        layout: vec![layouts.scene.clone()],
        vertex: VertexState {
            shader: shaders.shadow_map.clone(),
            ..default()
        },
        depth_stencil: Some(depth_state(SHADOW_FORMAT, CompareFunction::Less)),
        ..default()
    });
    commands.insert_resource(ShadowPipeline(id));
}

/// A depth test that writes, with `compare`.
pub fn depth_state(format: TextureFormat, compare: CompareFunction) -> DepthStencilState {
    DepthStencilState {
        format,
        depth_write_enabled: Some(true),
        depth_compare: Some(compare),
        stencil: default(),
        bias: default(),
    }
}

/// Renders shadow views into layers: `(view index, texture layer)` pairs.
pub fn render_layers(
    encoder: &mut CommandEncoder,
    pipeline: &RenderPipeline,
    scene_group: &BindGroup,
    maps: &ShadowMaps,
    triangle_count: u32,
    pairs: impl Iterator<Item = (u32, u32)>,
    timer: &mut StageTimer,
) {
    for (view, layer) in pairs {
        let mut pass = encoder.begin_render_pass(&RenderPassDescriptor {
            label: Some("rppm_shadow_map"),
            color_attachments: &[],
            depth_stencil_attachment: Some(RenderPassDepthStencilAttachment {
                view: &maps.layer_views[layer as usize],
                depth_ops: Some(Operations {
                    load: LoadOp::Clear(1.0),
                    store: StoreOp::Store,
                }),
                stencil_ops: None,
            }),
            timestamp_writes: timer.render_pass(Stage::ShadowMaps),
            occlusion_query_set: None,
            multiview_mask: None,
        });
        pass.set_pipeline(pipeline);
        pass.set_bind_group(0, scene_group, &[]);
        pass.draw(0..triangle_count * 3, view..view + 1);
    }
}

#[cfg(test)]
mod tests {
    /// `MANY_LIGHTS` is the shader's.
    #[test]
    fn many_lights_is_the_shaders() {
        let path = concat!(env!("CARGO_MANIFEST_DIR"), "/shaders/shadows/lighting.wgsl");
        let text = std::fs::read_to_string(path).unwrap();
        let line = format!("const MANY_LIGHTS: u32 = {}u;", super::MANY_LIGHTS);
        assert!(text.contains(&line), "lighting.wgsl has no `{line}`");
    }
}
