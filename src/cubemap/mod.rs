//! The deep cubemap (DIRT, Vardis et al. 2016): the only acceleration structure, rebuilt from
//! the current triangles every iteration that traces rays. Six camera-centred faces of
//! `grid`² tiles; each tile holds `bins` depth-binned linked lists of triangle ids, over a
//! min/max depth hierarchy. Built by two raster passes (tile depth bounds, then list insertion
//! with storage atomics) and a reduction (`shaders/cubemap/build.wgsl`); traced by
//! `shaders/cubemap/trace.wgsl`. Its peer, a bounding-volume hierarchy built on the CPU
//! ([`bvh`]), traces instead under `RppmTracer::Bvh`.

pub mod bvh;
mod config;
mod deep;
mod view;

use std::num::NonZeroU64;

use bevy::prelude::*;
use bevy::render::render_resource::binding_types::{
    storage_buffer_read_only_sized, storage_buffer_sized, texture_2d, texture_storage_2d,
    uniform_buffer_sized,
};
use bevy::render::render_resource::*;
use bevy::render::{RenderApp, RenderStartup};
use bevy::shader::Shader;

use bevy::render::renderer::{RenderDevice, RenderQueue};

pub use config::{BIG_TRIANGLES, CubemapConfig, CubemapParams};
pub use deep::{DeepCubemap, Fit};
pub use view::{ViewCubemap, fitted};

use crate::scene::SceneBuffers;
use crate::shaders::RppmShaders;
use crate::view::ViewLayouts;

pub(crate) struct CubemapPlugin;

impl Plugin for CubemapPlugin {
    fn build(&self, app: &mut App) {
        if let Some(render_app) = app.get_sub_app_mut(RenderApp) {
            render_app.add_systems(RenderStartup, init_cubemap_pipelines);
        }
    }
}

/// Group 3 of any shader that traces rays: 0 params, 1 hierarchy, 2 heads, 3 nodes, 4 the big
/// triangles ([`BIG_TRIANGLES`]), 5 and 6 the hierarchy's nodes and triangles' corners,
/// textures ([`bvh`]).
pub fn trace_layout() -> BindGroupLayoutDescriptor {
    let read = || storage_buffer_read_only_sized(false, None);
    BindGroupLayoutDescriptor::new(
        "rppm_cubemap_trace_layout",
        &BindGroupLayoutEntries::sequential(
            ShaderStages::COMPUTE | ShaderStages::FRAGMENT,
            (
                uniform_buffer_sized(false, NonZeroU64::new(size_of::<CubemapParams>() as u64)),
                read(),
                read(),
                read(),
                read(),
                texture_2d(TextureSampleType::Float { filterable: false }),
                texture_2d(TextureSampleType::Float { filterable: false }),
            ),
        ),
    )
}

/// Pipelines of the build, and the layouts a tracer binds the cubemap with.
#[derive(Resource)]
pub struct CubemapPipelines {
    pub build_layout: BindGroupLayoutDescriptor,
    /// `classify`'s group 1: 0 params, 7 the big-triangle list it writes.
    pub classify_layout: BindGroupLayoutDescriptor,
    pub level_layout: BindGroupLayoutDescriptor,
    /// [`trace_layout`].
    pub trace_layout: BindGroupLayoutDescriptor,
    pub(crate) classify: CachedComputePipelineId,
    pub(crate) bounds: CachedRenderPipelineId,
    pub(crate) insert: CachedRenderPipelineId,
    pub(crate) hierarchy_base: CachedComputePipelineId,
    pub(crate) hierarchy_reduce: CachedComputePipelineId,
    /// `bvh_fill.wgsl`'s group 1: 0 the leaf order, 1 the corners texture it writes.
    pub bvh_fill_layout: BindGroupLayoutDescriptor,
    pub(crate) bvh_fill: CachedComputePipelineId,
}

fn storage_rw() -> BindGroupLayoutEntryBuilder {
    storage_buffer_sized(false, None)
}

impl CubemapPipelines {
    pub fn new(
        cache: &PipelineCache,
        shaders: &RppmShaders,
        scene_layout: &BindGroupLayoutDescriptor,
    ) -> Self {
        let stages = ShaderStages::VERTEX | ShaderStages::FRAGMENT | ShaderStages::COMPUTE;
        let params =
            uniform_buffer_sized(false, NonZeroU64::new(size_of::<CubemapParams>() as u64));
        let build_layout = BindGroupLayoutDescriptor::new(
            "rppm_cubemap_build_layout",
            &BindGroupLayoutEntries::sequential(
                stages,
                (
                    params,
                    storage_rw(),
                    storage_rw(),
                    storage_rw(),
                    storage_rw(),
                    storage_rw(),
                    storage_buffer_read_only_sized(false, None),
                ),
            ),
        );
        let classify_layout = BindGroupLayoutDescriptor::new(
            "rppm_cubemap_classify_layout",
            &BindGroupLayoutEntries::with_indices(
                ShaderStages::COMPUTE,
                ((0, params), (7, storage_rw())),
            ),
        );
        let level_layout = BindGroupLayoutDescriptor::new(
            "rppm_cubemap_level_layout",
            &BindGroupLayoutEntries::single(
                ShaderStages::COMPUTE,
                uniform_buffer_sized(true, NonZeroU64::new(16)),
            ),
        );
        let trace_layout = trace_layout();
        let bvh_fill_layout = BindGroupLayoutDescriptor::new(
            "rppm_bvh_fill_layout",
            &BindGroupLayoutEntries::sequential(
                ShaderStages::COMPUTE,
                (
                    storage_buffer_read_only_sized(false, None),
                    texture_storage_2d(TextureFormat::Rgba32Float, StorageTextureAccess::WriteOnly),
                ),
            ),
        );
        let raster = |entry: &'static str| RenderPipelineDescriptor {
            label: Some(format!("rppm_cubemap_{entry}").into()),
            layout: vec![scene_layout.clone(), build_layout.clone()],
            vertex: VertexState {
                shader: shaders.cubemap_build.clone(),
                entry_point: Some("vertex".into()),
                ..default()
            },
            fragment: Some(FragmentState {
                shader: shaders.cubemap_build.clone(),
                entry_point: Some(entry.into()),
                targets: vec![],
                ..default()
            }),
            // Only for its size: nothing is tested or written.
            depth_stencil: Some(DepthStencilState {
                format: TextureFormat::Depth32Float,
                depth_write_enabled: Some(false),
                depth_compare: Some(CompareFunction::Always),
                stencil: default(),
                bias: default(),
            }),
            ..default()
        };
        let compute = |entry: &'static str, layout: Vec<BindGroupLayoutDescriptor>| {
            cache.queue_compute_pipeline(ComputePipelineDescriptor {
                label: Some(format!("rppm_cubemap_{entry}").into()),
                layout,
                shader: shaders.cubemap_build.clone(),
                entry_point: Some(entry.into()),
                ..default()
            })
        };
        Self {
            classify: compute(
                "classify",
                vec![scene_layout.clone(), classify_layout.clone()],
            ),
            bounds: cache.queue_render_pipeline(raster("fragment_bounds")),
            insert: cache.queue_render_pipeline(raster("fragment_insert")),
            hierarchy_base: compute(
                "hierarchy_base",
                vec![scene_layout.clone(), build_layout.clone()],
            ),
            hierarchy_reduce: compute(
                "hierarchy_reduce",
                vec![
                    scene_layout.clone(),
                    build_layout.clone(),
                    level_layout.clone(),
                ],
            ),
            bvh_fill: cache.queue_compute_pipeline(ComputePipelineDescriptor {
                label: Some("rppm_bvh_fill".into()),
                layout: vec![scene_layout.clone(), bvh_fill_layout.clone()],
                shader: shaders.bvh_fill.clone(),
                entry_point: Some("fill".into()),
                ..default()
            }),
            build_layout,
            classify_layout,
            level_layout,
            trace_layout,
            bvh_fill_layout,
        }
    }

    /// Whether every build pipeline is compiled.
    pub fn ready(&self, cache: &PipelineCache) -> bool {
        cache.get_compute_pipeline(self.classify).is_some()
            && cache.get_render_pipeline(self.bounds).is_some()
            && cache.get_render_pipeline(self.insert).is_some()
            && cache.get_compute_pipeline(self.hierarchy_base).is_some()
            && cache.get_compute_pipeline(self.hierarchy_reduce).is_some()
            && cache.get_compute_pipeline(self.bvh_fill).is_some()
    }
}

/// What making and building a deep cubemap needs from the render world.
pub struct BuildContext<'a> {
    pub device: &'a RenderDevice,
    pub queue: &'a RenderQueue,
    pub cache: &'a PipelineCache,
    pub pipelines: &'a CubemapPipelines,
    pub scene: &'a SceneBuffers,
    /// Group 0 of the build: the scene tables.
    pub scene_group: &'a BindGroup,
}

/// Queues the build pipelines.
fn init_cubemap_pipelines(
    mut commands: Commands,
    cache: Res<PipelineCache>,
    shaders: Res<RppmShaders>,
    layouts: Res<ViewLayouts>,
) {
    commands.insert_resource(CubemapPipelines::new(&cache, &shaders, &layouts.scene));
}

/// The bind groups every stage that traces through the cubemap shares: scene (0), this
/// iteration's constants (1, at `offset`) and the deep cubemap (3); group 2 is the stage's own.
pub struct TracingGroups<'a> {
    pub scene: &'a BindGroup,
    pub params: &'a BindGroup,
    pub offset: u32,
    pub cubemap: &'a BindGroup,
}

impl TracingGroups<'_> {
    pub fn bind(&self, pass: &mut ComputePass, pipeline: &ComputePipeline, own: &BindGroup) {
        pass.set_pipeline(pipeline);
        pass.set_bind_group(0, self.scene, &[]);
        pass.set_bind_group(1, self.params, &[self.offset]);
        pass.set_bind_group(2, own, &[]);
        pass.set_bind_group(3, self.cubemap, &[]);
    }
}

/// A tracing stage's pipeline: scene, iteration constants, its own group, the deep cubemap.
pub fn tracing_pipeline(
    label: &'static str,
    view: &ViewLayouts,
    own: &BindGroupLayoutDescriptor,
    shader: &Handle<Shader>,
) -> ComputePipelineDescriptor {
    ComputePipelineDescriptor {
        label: Some(label.into()),
        layout: vec![
            view.scene.clone(),
            view.params.clone(),
            own.clone(),
            trace_layout(),
        ],
        shader: shader.clone(),
        ..default()
    }
}
