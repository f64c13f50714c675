//! One camera's deep cubemap: its buffers, sized by the configuration, the scene and the list
//! capacity, and the build it records.

use bevy::prelude::*;
use bevy::render::render_resource::*;
use bevy::render::renderer::{RenderDevice, RenderQueue};

use super::bvh::BvhBuffers;
use super::{BIG_TRIANGLES, BuildContext, CubemapConfig, CubemapParams, CubemapPipelines};
use crate::ppm::grown_capacity;
use crate::scene::SceneBuffers;
use crate::scene::place::dispatch_size;
use crate::stats::readback::{AsyncReadback, read_back};
use crate::stats::timing::{FrameWork, Stage, StageTimer};
use crate::view::binding_limit;

/// Byte stride of the per-level uniforms of the hierarchy reduction.
const LEVEL_STRIDE: u64 = 256;

/// One deep cubemap's buffers. Sizes follow the configuration, the scene and the list
/// capacity; lists that overflow are counted (never written out of bounds), and the owner
/// grows the capacity and builds again.
pub struct DeepCubemap {
    pub config: CubemapConfig,
    pub params: CubemapParams,
    params_buffer: Buffer,
    tile_bounds: Buffer,
    heads: Buffer,
    nodes: Buffer,
    counters: Buffer,
    /// The counters on their way back without a stall, so lists grow in every app.
    counter_probe: AsyncReadback,
    hierarchy: Buffer,
    /// [count, ids…] of the triangles kept out of the lists (`BIG_TRIANGLES`).
    big: Buffer,
    levels: Buffer,
    atlas: TextureView,
    build_group: BindGroup,
    classify_group: BindGroup,
    level_group: BindGroup,
    /// Group 3 of a tracing shader, with the view's hierarchy under `RppmTracer::Bvh` (see
    /// [`Self::bind_bvh`]), else a stand-in.
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

/// Group 3 of a tracing shader: the cubemap's params, hierarchy, heads, nodes and big
/// triangles, and a hierarchy's nodes and triangle ids.
fn trace_group(
    device: &RenderDevice,
    layout: &BindGroupLayout,
    [params, hierarchy, heads, nodes, big]: [&Buffer; 5],
    bvh: &BvhBuffers,
) -> BindGroup {
    device.create_bind_group(
        "rppm_cubemap_trace_group",
        layout,
        &BindGroupEntries::sequential((
            params.as_entire_binding(),
            hierarchy.as_entire_binding(),
            heads.as_entire_binding(),
            nodes.as_entire_binding(),
            big.as_entire_binding(),
            &bvh.nodes_view,
            &bvh.corners_view,
        )),
    )
}

impl DeepCubemap {
    /// The most list entries one binding holds (8 bytes each).
    pub fn most_nodes(device: &RenderDevice) -> u32 {
        (binding_limit(device) / 8).min(u32::MAX as u64) as u32
    }

    /// Buffers for `config` around `centre`, with room for `node_capacity` list entries.
    pub fn new(
        ctx: &BuildContext,
        config: CubemapConfig,
        centre: Vec3,
        node_capacity: u32,
    ) -> Result<Self, String> {
        let BuildContext {
            device,
            queue,
            cache,
            pipelines,
            scene,
            ..
        } = *ctx;
        let grid = config.grid();
        let tiles = 6 * grid as u64 * grid as u64;
        let limit = binding_limit(device);
        let largest = (tiles * config.bins as u64 * 4).max(node_capacity as u64 * 8);
        if largest > limit {
            return Err(format!(
                "a {}² cubemap with {} bins needs a {largest}-byte buffer, over this GPU's \
                 limit of {limit} bytes",
                config.resolution, config.bins
            ));
        }
        let (level_offsets, cells) = config.level_offsets();
        let params = CubemapParams {
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
        let big = buffer(
            device,
            "rppm_cubemap_big",
            (1 + BIG_TRIANGLES as u64) * 4,
            storage,
        );
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
                big.as_entire_binding(),
            )),
        );
        let classify_group = device.create_bind_group(
            "rppm_cubemap_classify_group",
            &cache.get_bind_group_layout(&pipelines.classify_layout),
            &BindGroupEntries::with_indices((
                (0, params_buffer.as_entire_binding()),
                (7, big.as_entire_binding()),
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
        let trace_group = trace_group(
            device,
            &cache.get_bind_group_layout(&pipelines.trace_layout),
            [&params_buffer, &hierarchy, &heads, &nodes, &big],
            &BvhBuffers::empty(device),
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
            big,
            levels,
            atlas,
            build_group,
            classify_group,
            level_group,
            trace_group,
        })
    }

    /// Binds `bvh` for tracing shaders (`RppmTracer::Bvh`) in place of the stand-in.
    pub fn bind_bvh(&mut self, device: &RenderDevice, layout: &BindGroupLayout, bvh: &BvhBuffers) {
        let own = [
            &self.params_buffer,
            &self.hierarchy,
            &self.heads,
            &self.nodes,
            &self.big,
        ];
        self.trace_group = trace_group(device, layout, own, bvh);
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
        let tiles = config.tiles() as u64;
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
            ("cubemap_big_triangles", self.big.size()),
            ("cubemap_atlas", 6 * grid * grid * 4),
            (
                "cubemap_params",
                self.params_buffer.size() + self.levels.size() + self.counters.size(),
            ),
        ]
    }

    /// A cubemap whose lists hold every entry of its first build: built now (the GPU waited
    /// for), and made again with room for what the build asked for while entries were lost
    /// (at most 4 times), or once smaller when it used under half its room. Without compiled build pipelines it is returned unbuilt.
    pub fn fitted(
        ctx: &BuildContext,
        config: CubemapConfig,
        centre: Vec3,
        mut capacity: u32,
    ) -> Result<(Self, Fit), String> {
        let mut fit = Fit::default();
        loop {
            let cubemap = Self::new(ctx, config, centre, capacity)?;
            if !ctx.pipelines.ready(ctx.cache) {
                return Ok((cubemap, fit));
            }
            let ([used, lost], ms) = cubemap.build_now(ctx);
            fit.used = used.min(capacity);
            fit.build_ms = ms;
            if lost == 0 {
                // A first guess far above what the build used is given back once (room for
                // a quarter more, and at least one entry a tile for what the scene gains).
                let tiles = config.tiles();
                let snug = grown_capacity(used).max(tiles);
                if fit.overflows == 0 && !fit.shrunk && capacity > 2 * snug {
                    fit.shrunk = true;
                    capacity = snug;
                    continue;
                }
                return Ok((cubemap, fit));
            }
            if fit.overflows >= 4 {
                return Ok((cubemap, fit));
            }
            // No more room than one buffer binding holds: past it, entries stay lost (counted).
            let grown = grown_capacity(used).min(Self::most_nodes(ctx.device));
            if grown <= capacity {
                return Ok((cubemap, fit));
            }
            fit.overflows += 1;
            capacity = grown;
        }
    }

    /// Builds once, submitted now, and waits for the GPU: the list counters (entries asked
    /// for, entries lost) and the build's GPU ms.
    pub fn build_now(&self, ctx: &BuildContext) -> ([u32; 2], f64) {
        let mut timer = StageTimer::new(ctx.device, ctx.queue, 16);
        timer.begin_frame(FrameWork {
            iterations: 1,
            photons: 0,
        });
        let mut encoder = ctx
            .device
            .create_command_encoder(&CommandEncoderDescriptor::default());
        self.encode_build(
            &mut encoder,
            ctx.cache,
            ctx.pipelines,
            ctx.scene_group,
            &mut timer,
        );
        timer.end_frame(&mut encoder);
        ctx.queue.submit([encoder.finish()]);
        timer.start_readback();
        timer.collect(ctx.device, true);
        let counters = read_back(ctx.device, ctx.queue, &self.counters).unwrap_or_default();
        let counters: &[u32] = bytemuck::cast_slice(&counters);
        let at = |i: usize| counters.get(i).copied().unwrap_or(0);
        ([at(0), at(1)], timer.last_ms.iter().sum())
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
        let (Some(classify), Some(bounds), Some(insert), Some(base), Some(reduce)) = (
            cache.get_compute_pipeline(pipelines.classify),
            cache.get_render_pipeline(pipelines.bounds),
            cache.get_render_pipeline(pipelines.insert),
            cache.get_compute_pipeline(pipelines.hierarchy_base),
            cache.get_compute_pipeline(pipelines.hierarchy_reduce),
        ) else {
            return;
        };
        for b in [&self.tile_bounds, &self.heads, &self.counters, &self.big] {
            encoder.clear_buffer(b, 0, None);
        }
        {
            let mut pass = encoder.begin_compute_pass(&ComputePassDescriptor {
                label: Some("rppm_cubemap_classify"),
                timestamp_writes: timer.compute_pass(Stage::CubemapBuild),
            });
            pass.set_pipeline(classify);
            pass.set_bind_group(0, scene_group, &[]);
            pass.set_bind_group(1, &self.classify_group, &[]);
            // 65 535 groups a dimension: the least any device allows.
            let [x, y] = dispatch_size(self.params.triangle_count, 65_535);
            pass.dispatch_workgroups(x, y, 1);
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

/// How [`DeepCubemap::fitted`] went.
#[derive(Clone, Copy, Debug, Default)]
pub struct Fit {
    /// Builds that lost entries and were made again with more room.
    pub overflows: u32,
    /// Whether a first guess far above what the build used was made again smaller.
    pub shrunk: bool,
    /// List entries the last build used.
    pub used: u32,
    /// GPU ms of the last build.
    pub build_ms: f64,
}

/// Depth below which geometry is not recorded: a millionth of the scene's size.
fn near_limit(scene: &SceneBuffers) -> f32 {
    (scene.data.bounding_sphere().1 * 1e-6).max(1e-9)
}
