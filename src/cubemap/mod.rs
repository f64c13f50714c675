//! The DIRT deep cubemap: the only acceleration structure, rebuilt from the current triangles
//! every time it is used. Six camera-centred faces of `grid`² tiles; each tile holds `bins`
//! depth-binned linked lists of triangle ids, over a min/max depth hierarchy. Built by two
//! raster passes (tile depth bounds, then list insertion with storage atomics) and a reduction;
//! traced by `shaders/dirt.wgsl`.

pub mod bench;

use std::num::NonZeroU64;

use bevy::prelude::*;
use bevy::render::render_resource::binding_types::{
    storage_buffer_read_only_sized, storage_buffer_sized, uniform_buffer_sized,
};
use bevy::render::render_resource::*;
use bevy::render::renderer::{RenderDevice, RenderQueue};
use bytemuck::{Pod, Zeroable};

use crate::output::AsyncReadback;
use crate::pipelines::RppmShaders;
use crate::scene::gpu::SceneBuffers;
use crate::timing::{Stage, StageTimer};

/// Resolution, tiling and binning of a deep cubemap.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, serde::Serialize)]
pub struct CubemapConfig {
    /// Pixels along each face's edge.
    pub resolution: u32,
    /// Pixels along a tile's edge (1, 2 or 4): one list set per tile.
    pub tile_size: u32,
    /// Depth bins per tile.
    pub bins: u32,
}

impl CubemapConfig {
    /// This configuration at the largest resolution (halving down to 16) whose faces fit the
    /// GPU's largest render target and whose tile-list heads fit one buffer binding.
    pub fn fitted(mut self, limit_bytes: u64, max_dimension: u32) -> Self {
        // The largest per-tile buffer: list heads (4 bytes a bin) or bounds (8 bytes).
        let heads = |c: &Self| 6 * (c.grid() as u64).pow(2) * (c.bins as u64 * 4).max(8);
        while self.resolution > 16
            && (heads(&self) > limit_bytes || self.resolution > max_dimension)
        {
            self.resolution /= 2;
        }
        self
    }

    /// Tiles along each face's edge.
    pub fn grid(&self) -> u32 {
        (self.resolution / self.tile_size.max(1)).max(1)
    }

    /// Levels of the min/max hierarchy, tiles up to one cell per face.
    pub fn levels(&self) -> u32 {
        32 - self.grid().leading_zeros()
    }

    /// First cell of each level in the hierarchy buffer, and the total cell count.
    fn level_offsets(&self) -> ([[u32; 4]; 4], u32) {
        let mut offsets = [[0u32; 4]; 4];
        let mut total = 0;
        for level in 0..self.levels().min(16) {
            offsets[level as usize / 4][level as usize % 4] = total;
            let cells = (self.grid() >> level).max(1);
            total += 6 * cells * cells;
        }
        (offsets, total)
    }
}

/// `DirtParams` in common.wgsl (112 bytes).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable)]
pub struct DirtParams {
    pub centre: [f32; 4],
    pub grid: u32,
    pub bins: u32,
    pub node_capacity: u32,
    pub levels: u32,
    pub near: f32,
    pub triangle_count: u32,
    pub _pad: [u32; 2],
    pub level_offsets: [[u32; 4]; 4],
}

/// Byte stride of the per-level uniforms of the hierarchy reduction.
const LEVEL_STRIDE: u64 = 256;

/// Group 3 of any shader that traces rays: 0 params, 1 hierarchy, 2 heads, 3 nodes.
pub fn trace_layout() -> BindGroupLayoutDescriptor {
    let read = || storage_buffer_read_only_sized(false, None);
    BindGroupLayoutDescriptor::new(
        "rppm_cubemap_trace_layout",
        &BindGroupLayoutEntries::sequential(
            ShaderStages::COMPUTE | ShaderStages::FRAGMENT,
            (
                uniform_buffer_sized(false, NonZeroU64::new(size_of::<DirtParams>() as u64)),
                read(),
                read(),
                read(),
            ),
        ),
    )
}

/// Pipelines of the build, and the layouts a tracer binds the cubemap with.
#[derive(Resource)]
pub struct CubemapPipelines {
    pub build_layout: BindGroupLayoutDescriptor,
    pub level_layout: BindGroupLayoutDescriptor,
    /// [`trace_layout`].
    pub trace_layout: BindGroupLayoutDescriptor,
    bounds: CachedRenderPipelineId,
    insert: CachedRenderPipelineId,
    hierarchy_base: CachedComputePipelineId,
    hierarchy_reduce: CachedComputePipelineId,
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
        let params = uniform_buffer_sized(false, NonZeroU64::new(size_of::<DirtParams>() as u64));
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
                ),
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
        let raster = |entry: &'static str| RenderPipelineDescriptor {
            label: Some(format!("rppm_cubemap_{entry}").into()),
            layout: vec![scene_layout.clone(), build_layout.clone()],
            vertex: VertexState {
                shader: shaders.dirt_build.clone(),
                entry_point: Some("vertex".into()),
                ..default()
            },
            fragment: Some(FragmentState {
                shader: shaders.dirt_build.clone(),
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
                shader: shaders.dirt_build.clone(),
                entry_point: Some(entry.into()),
                ..default()
            })
        };
        Self {
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
            build_layout,
            level_layout,
            trace_layout,
        }
    }

    /// Whether every build pipeline is compiled.
    pub fn ready(&self, cache: &PipelineCache) -> bool {
        cache.get_render_pipeline(self.bounds).is_some()
            && cache.get_render_pipeline(self.insert).is_some()
            && cache.get_compute_pipeline(self.hierarchy_base).is_some()
            && cache.get_compute_pipeline(self.hierarchy_reduce).is_some()
    }
}

/// One deep cubemap's buffers. Sizes follow the configuration, the scene and the list
/// capacity; lists that overflow are counted (never written out of bounds), and the owner
/// grows the capacity and builds again.
pub struct DeepCubemap {
    pub config: CubemapConfig,
    pub params: DirtParams,
    params_buffer: Buffer,
    tile_bounds: Buffer,
    heads: Buffer,
    nodes: Buffer,
    counters: Buffer,
    /// The counters on their way back without a stall, so lists grow in every app.
    counter_probe: AsyncReadback,
    hierarchy: Buffer,
    levels: Buffer,
    atlas: TextureView,
    build_group: BindGroup,
    level_group: BindGroup,
    /// Group 1 of a tracing shader.
    pub trace_group: BindGroup,
}

fn buffer(device: &RenderDevice, label: &'static str, size: u64, usage: BufferUsages) -> Buffer {
    device.create_buffer(&BufferDescriptor {
        label: Some(label),
        size: size.max(16),
        usage,
        mapped_at_creation: false,
    })
}

impl DeepCubemap {
    /// Buffers for `config` around `centre`, with room for `node_capacity` list entries.
    #[allow(clippy::too_many_arguments)]
    pub fn new(
        device: &RenderDevice,
        queue: &RenderQueue,
        cache: &PipelineCache,
        pipelines: &CubemapPipelines,
        scene: &SceneBuffers,
        config: CubemapConfig,
        centre: Vec3,
        node_capacity: u32,
    ) -> Result<Self, String> {
        let grid = config.grid();
        let tiles = 6 * grid as u64 * grid as u64;
        let limit = device
            .limits()
            .max_storage_buffer_binding_size
            .min(device.limits().max_buffer_size);
        let largest = (tiles * config.bins as u64 * 4).max(node_capacity as u64 * 8);
        if largest > limit {
            return Err(format!(
                "a {}² cubemap with {} bins needs a {largest}-byte buffer, over this GPU's \
                 limit of {limit} bytes",
                config.resolution, config.bins
            ));
        }
        let (level_offsets, cells) = config.level_offsets();
        let params = DirtParams {
            centre: centre.extend(1.0).into(),
            grid,
            bins: config.bins,
            node_capacity,
            levels: config.levels(),
            near: near_limit(scene),
            triangle_count: scene.triangle_count(),
            _pad: [0; 2],
            level_offsets,
        };
        let storage = BufferUsages::STORAGE | BufferUsages::COPY_DST | BufferUsages::COPY_SRC;
        let params_buffer = device.create_buffer_with_data(&BufferInitDescriptor {
            label: Some("rppm_cubemap_params"),
            contents: bytemuck::bytes_of(&params),
            usage: BufferUsages::UNIFORM | BufferUsages::COPY_DST,
        });
        let tile_bounds = buffer(device, "rppm_cubemap_tile_bounds", tiles * 8, storage);
        let heads = buffer(
            device,
            "rppm_cubemap_heads",
            tiles * config.bins as u64 * 4,
            storage,
        );
        let nodes = buffer(
            device,
            "rppm_cubemap_nodes",
            node_capacity as u64 * 8,
            storage,
        );
        let counters = buffer(device, "rppm_cubemap_counters", 16, storage);
        let hierarchy = buffer(device, "rppm_cubemap_hierarchy", cells as u64 * 8, storage);
        let levels = buffer(
            device,
            "rppm_cubemap_levels",
            config.levels() as u64 * LEVEL_STRIDE,
            BufferUsages::UNIFORM | BufferUsages::COPY_DST,
        );
        for level in 0..config.levels() {
            queue.write_buffer(&levels, level as u64 * LEVEL_STRIDE, &level.to_le_bytes());
        }
        let atlas = device
            .create_texture(&TextureDescriptor {
                label: Some("rppm_cubemap_atlas"),
                size: Extent3d {
                    width: 3 * grid,
                    height: 2 * grid,
                    depth_or_array_layers: 1,
                },
                mip_level_count: 1,
                sample_count: 1,
                dimension: TextureDimension::D2,
                format: TextureFormat::Depth32Float,
                usage: TextureUsages::RENDER_ATTACHMENT,
                view_formats: &[],
            })
            .create_view(&TextureViewDescriptor::default());
        let build_group = device.create_bind_group(
            "rppm_cubemap_build_group",
            &cache.get_bind_group_layout(&pipelines.build_layout),
            &BindGroupEntries::sequential((
                params_buffer.as_entire_binding(),
                tile_bounds.as_entire_binding(),
                heads.as_entire_binding(),
                nodes.as_entire_binding(),
                counters.as_entire_binding(),
                hierarchy.as_entire_binding(),
            )),
        );
        let level_group = device.create_bind_group(
            "rppm_cubemap_level_group",
            &cache.get_bind_group_layout(&pipelines.level_layout),
            &BindGroupEntries::single(BufferBinding {
                buffer: &levels,
                offset: 0,
                size: BufferSize::new(16),
            }),
        );
        let trace_group = device.create_bind_group(
            "rppm_cubemap_trace_group",
            &cache.get_bind_group_layout(&pipelines.trace_layout),
            &BindGroupEntries::sequential((
                params_buffer.as_entire_binding(),
                hierarchy.as_entire_binding(),
                heads.as_entire_binding(),
                nodes.as_entire_binding(),
            )),
        );
        Ok(Self {
            config,
            params,
            params_buffer,
            tile_bounds,
            heads,
            nodes,
            counters,
            counter_probe: AsyncReadback::new(device, 16),
            hierarchy,
            levels,
            atlas,
            build_group,
            level_group,
            trace_group,
        })
    }

    /// Follows a changed scene (its triangle count and size); takes effect at the next build.
    pub fn set_scene(&mut self, queue: &RenderQueue, scene: &SceneBuffers) {
        self.params.triangle_count = scene.triangle_count();
        self.params.near = near_limit(scene);
        queue.write_buffer(&self.params_buffer, 0, bytemuck::bytes_of(&self.params));
    }

    /// Moves the cubemap's centre (the camera moved); takes effect at the next build.
    pub fn set_centre(&mut self, queue: &RenderQueue, centre: Vec3) {
        self.params.centre = centre.extend(1.0).into();
        queue.write_buffer(&self.params_buffer, 0, bytemuck::bytes_of(&self.params));
    }

    /// A first list capacity for a scene: a few entries per tile, more for many triangles.
    pub fn initial_capacity(config: CubemapConfig, triangles: u32) -> u32 {
        let tiles = 6 * config.grid() as u64 * config.grid() as u64;
        (tiles * 3 + triangles as u64 * 16).min(u32::MAX as u64 / 2) as u32
    }

    /// Bytes held per buffer.
    pub fn memory(&self) -> Vec<(&'static str, u64)> {
        let grid = self.config.grid() as u64;
        vec![
            ("cubemap_tile_bounds", self.tile_bounds.size()),
            ("cubemap_heads", self.heads.size()),
            ("cubemap_nodes", self.nodes.size()),
            ("cubemap_hierarchy", self.hierarchy.size()),
            ("cubemap_atlas", 6 * grid * grid * 4),
            (
                "cubemap_params",
                self.params_buffer.size() + self.levels.size() + self.counters.size(),
            ),
        ]
    }

    /// The buffer holding (nodes used, nodes that did not fit).
    pub fn counters(&self) -> &Buffer {
        &self.counters
    }

    /// The list counters of an earlier build, when their non-blocking read-back has arrived.
    pub fn poll_counters(&self, device: &RenderDevice) -> Option<[u32; 2]> {
        let bytes = self.counter_probe.poll(device)?;
        let counters: &[u32] = bytemuck::cast_slice(&bytes);
        Some([counters[0], counters[1]])
    }

    /// Records the whole build: clear, tile bounds, list insertion, hierarchy.
    pub fn encode_build(
        &self,
        encoder: &mut CommandEncoder,
        cache: &PipelineCache,
        pipelines: &CubemapPipelines,
        scene_group: &BindGroup,
        timer: &mut StageTimer,
    ) {
        let (Some(bounds), Some(insert), Some(base), Some(reduce)) = (
            cache.get_render_pipeline(pipelines.bounds),
            cache.get_render_pipeline(pipelines.insert),
            cache.get_compute_pipeline(pipelines.hierarchy_base),
            cache.get_compute_pipeline(pipelines.hierarchy_reduce),
        ) else {
            return;
        };
        for b in [&self.tile_bounds, &self.heads, &self.counters] {
            encoder.clear_buffer(b, 0, None);
        }
        let vertices = self.params.triangle_count * 6;
        for pipeline in [bounds, insert] {
            let mut pass = encoder.begin_render_pass(&RenderPassDescriptor {
                label: Some("rppm_cubemap_raster"),
                color_attachments: &[],
                depth_stencil_attachment: Some(RenderPassDepthStencilAttachment {
                    view: &self.atlas,
                    depth_ops: Some(Operations {
                        load: LoadOp::Clear(0.0),
                        store: StoreOp::Discard,
                    }),
                    stencil_ops: None,
                }),
                timestamp_writes: timer.render_pass(Stage::CubemapBuild),
                occlusion_query_set: None,
                multiview_mask: None,
            });
            pass.set_pipeline(pipeline);
            pass.set_bind_group(0, scene_group, &[]);
            pass.set_bind_group(1, &self.build_group, &[]);
            pass.draw(0..vertices, 0..6);
        }
        let mut pass = encoder.begin_compute_pass(&ComputePassDescriptor {
            label: Some("rppm_cubemap_hierarchy"),
            timestamp_writes: timer.compute_pass(Stage::CubemapBuild),
        });
        pass.set_bind_group(0, scene_group, &[]);
        pass.set_bind_group(1, &self.build_group, &[]);
        pass.set_pipeline(base);
        let grid = self.config.grid();
        pass.dispatch_workgroups((6 * grid * grid).div_ceil(64), 1, 1);
        pass.set_pipeline(reduce);
        for level in 1..self.config.levels() {
            let cells = (grid >> level).max(1);
            pass.set_bind_group(2, &self.level_group, &[level * LEVEL_STRIDE as u32]);
            pass.dispatch_workgroups((6 * cells * cells).div_ceil(64), 1, 1);
        }
        drop(pass);
        self.counter_probe.encode_copy(encoder, &self.counters);
    }
}

/// Depth below which geometry is not recorded: a millionth of the scene's size.
fn near_limit(scene: &SceneBuffers) -> f32 {
    (scene.data.bounding_sphere().1 * 1e-6).max(1e-9)
}

/// Queues the build pipelines once the scene layout exists.
pub(crate) fn init_cubemap_pipelines(
    mut commands: Commands,
    cache: Res<PipelineCache>,
    shaders: Res<RppmShaders>,
    pipelines: Res<crate::pipelines::RppmPipelines>,
) {
    commands.insert_resource(CubemapPipelines::new(
        &cache,
        &shaders,
        &pipelines.scene_layout,
    ));
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn hierarchy_levels_reach_one_cell() {
        let c = CubemapConfig {
            resolution: 256,
            tile_size: 2,
            bins: 8,
        };
        assert_eq!(c.grid(), 128);
        assert_eq!(c.levels(), 8);
        let (offsets, total) = c.level_offsets();
        assert_eq!(offsets[0][1], 6 * 128 * 128);
        assert_eq!(total, (0..8).map(|l| 6 * (128u32 >> l).pow(2)).sum::<u32>());
    }
}
