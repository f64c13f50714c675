//! The deep-cubemap correctness harness (DIRT's): random rays traced through the deep cubemap
//! and by brute force against every triangle, both on the GPU, compared; with build and trace
//! GPU times. The same rays go through the bounding-volume hierarchy too
//! ([`crate::cubemap::bvh`]), the peer the deep cubemap is measured against.

use std::sync::Arc;
use std::time::Instant;

use bevy::prelude::*;
use bevy::render::extract_resource::ExtractResource;
use bevy::render::render_resource::binding_types::{
    storage_buffer_read_only_sized, storage_buffer_sized,
};
use bevy::render::render_resource::*;
use bevy::render::renderer::{RenderDevice, RenderQueue};
use bytemuck::{Pod, Zeroable};
use serde::Serialize;

use crate::cubemap::bvh::BvhBuffers;
use crate::cubemap::{BuildContext, CubemapConfig, CubemapPipelines, DeepCubemap, trace_layout};
use crate::scene::SceneData;
use crate::scene::prepare::{SceneBuffers, storage_buffer};
use crate::shaders::RppmShaders;
use crate::stats::readback::read_back;
use crate::view::ViewLayouts;

/// A ray as the harness uploads it (`Ray` in cubemap_bench.wgsl).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable)]
pub struct BenchRay {
    /// xyz origin, w t_min.
    pub origin: [f32; 4],
    /// xyz direction, w the triangle the ray leaves (as bits; u32::MAX for none).
    pub direction: [f32; 4],
}

const NO_HIT: u32 = u32::MAX;

/// A small deterministic generator (PCG), so every run traces the same rays.
struct Rng(u64);

impl Rng {
    fn next(&mut self) -> f32 {
        self.0 = self
            .0
            .wrapping_mul(6_364_136_223_846_793_005)
            .wrapping_add(1_442_695_040_888_963_407);
        let x = (((self.0 >> 18) ^ self.0) >> 27) as u32;
        let x = x.rotate_right((self.0 >> 59) as u32);
        (x >> 8) as f32 / (1u32 << 24) as f32
    }

    fn sphere(&mut self) -> Vec3 {
        let z = 1.0 - 2.0 * self.next();
        let phi = std::f32::consts::TAU * self.next();
        let r = (1.0 - z * z).max(0.0).sqrt();
        Vec3::new(r * phi.cos(), r * phi.sin(), z)
    }
}

/// Half the rays start anywhere inside the scene's bounds in uniform directions; half leave a
/// random point of a random triangle (area-weighted), cosine-distributed on the side facing
/// `centre`, skipping the triangle they leave.
pub fn bench_rays(data: &SceneData, centre: Vec3, count: u32) -> Vec<BenchRay> {
    let mut rng = Rng(0x853c_49e6_748f_ea9b);
    let (lo, hi) = data.bounds;
    let (_, radius) = data.bounding_sphere();
    let t_min = radius * 1e-5;
    let triangles = data.world_triangles();
    let areas: Vec<f32> = triangles.iter().map(|t| t.area()).collect();
    let total: f32 = areas.iter().sum();
    let mut rays = Vec::with_capacity(count as usize);
    for i in 0..count {
        if i % 2 == 0 || triangles.is_empty() {
            let u = Vec3::new(rng.next(), rng.next(), rng.next());
            let origin = lo + (hi - lo) * (0.01 + 0.98 * u);
            rays.push(BenchRay {
                origin: origin.extend(t_min).into(),
                direction: rng.sphere().extend(f32::from_bits(NO_HIT)).into(),
            });
            continue;
        }
        let mut pick = rng.next() * total;
        let index = areas.iter().position(|&a| {
            pick -= a;
            pick <= 0.0
        });
        let index = index.unwrap_or(areas.len() - 1);
        let [a, b, c] = triangles[index].positions();
        let (r1, r2) = (rng.next().sqrt(), rng.next());
        let point = a * (1.0 - r1) + b * (r1 * (1.0 - r2)) + c * (r1 * r2);
        let mut normal = (b - a).cross(c - a).normalize();
        if normal.dot(centre - point) < 0.0 {
            normal = -normal;
        }
        let direction = (normal + rng.sphere()).normalize_or(normal);
        rays.push(BenchRay {
            origin: point.extend(t_min).into(),
            direction: direction.extend(f32::from_bits(index as u32)).into(),
        });
    }
    rays
}

/// Asks the render world to run the harness once the scene is on the GPU.
#[derive(Resource, Clone, ExtractResource)]
pub struct CubemapBenchRequest {
    pub configs: Vec<CubemapConfig>,
    pub rays: Arc<Vec<BenchRay>>,
    /// Rays traced for the timing (the compared rays, repeated).
    pub timing_rays: u32,
    pub centre: Vec3,
}

/// What traced a row's rays.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Tracer {
    DeepCubemap,
    /// The CPU-built hierarchy (`resolution`, `tile_size` and `bins` are 0; `build_ms` is the
    /// CPU's wall clock, `nodes_used` its node count).
    Bvh,
}

/// One configuration's result.
#[derive(Clone, Debug, Serialize)]
pub struct CubemapBenchRow {
    pub tracer: Tracer,
    /// The scene's triangles.
    pub triangles: u32,
    pub resolution: u32,
    pub tile_size: u32,
    pub bins: u32,
    pub rays: u32,
    /// Fraction of rays where the cubemap and brute force agree (same triangle, or same t within
    /// 1e-4 relative, or both miss).
    pub agreement: f64,
    /// Brute force hits, the cubemap misses.
    pub false_misses: u32,
    /// The cubemap hits, brute force misses.
    pub false_hits: u32,
    /// Both hit, at different triangles and distances.
    pub wrong_hits: u32,
    pub build_ms: f64,
    pub timing_rays: u32,
    pub trace_ms: f64,
    pub brute_force_ms: f64,
    pub bytes: u64,
    pub nodes_used: u32,
    /// Builds that overflowed the lists and were redone with more room.
    pub overflow_rebuilds: u32,
}

/// The harness's results, in the main world.
#[derive(Resource, Default, Debug)]
pub struct CubemapBenchResults(pub Option<Result<Vec<CubemapBenchRow>, String>>);

#[derive(Resource, Deref)]
pub(super) struct BenchSender(pub crossbeam_channel::Sender<Vec<CubemapBenchRow>>);

#[derive(Resource, Deref)]
pub(super) struct BenchReceiver(pub crossbeam_channel::Receiver<Vec<CubemapBenchRow>>);

pub(super) fn receive_results(
    receiver: Res<BenchReceiver>,
    mut results: ResMut<CubemapBenchResults>,
) {
    while let Ok(rows) = receiver.try_recv() {
        results.0 = Some(Ok(rows));
    }
}

/// Ray-tracing pipelines of the harness.
#[derive(Resource)]
pub struct BenchPipelines {
    rays_layout: BindGroupLayoutDescriptor,
    trace: CachedComputePipelineId,
    brute_force: CachedComputePipelineId,
    bvh: CachedComputePipelineId,
}

pub(super) fn init_bench_pipelines(
    mut commands: Commands,
    cache: Res<PipelineCache>,
    shaders: Res<RppmShaders>,
    layouts: Res<ViewLayouts>,
) {
    let rays_layout = BindGroupLayoutDescriptor::new(
        "rppm_bench_rays_layout",
        &BindGroupLayoutEntries::sequential(
            ShaderStages::COMPUTE,
            (
                storage_buffer_read_only_sized(false, None),
                storage_buffer_sized(false, None),
            ),
        ),
    );
    let layout = vec![
        layouts.scene.clone(),
        empty_layout(),
        rays_layout.clone(),
        trace_layout(),
    ];
    let pipeline = |entry: &'static str| {
        cache.queue_compute_pipeline(ComputePipelineDescriptor {
            label: Some(format!("rppm_bench_{entry}").into()),
            layout: layout.clone(),
            shader: shaders.cubemap_bench.clone(),
            entry_point: Some(entry.into()),
            ..default()
        })
    };
    commands.insert_resource(BenchPipelines {
        trace: pipeline("trace"),
        brute_force: pipeline("brute_force"),
        bvh: pipeline("bvh"),
        rays_layout,
    });
}

/// Group 1 is the per-iteration constants in the PPM stages; the harness has none.
pub(super) fn empty_layout() -> BindGroupLayoutDescriptor {
    BindGroupLayoutDescriptor::new("rppm_bench_empty_layout", &[])
}

/// Everything one harness run needs from the render world.
struct Gpu<'a> {
    device: &'a RenderDevice,
    queue: &'a RenderQueue,
    cache: &'a PipelineCache,
    cubemap: &'a CubemapPipelines,
    bench: &'a BenchPipelines,
    scene: &'a SceneBuffers,
    scene_group: BindGroup,
    empty_group: BindGroup,
    rays: Buffer,
    bvh: BvhBuffers,
}

impl Gpu<'_> {
    fn submit(&self, encoder: CommandEncoder) {
        self.queue.submit([encoder.finish()]);
    }

    /// Traces `count` rays (cycling through the stored ones) with `pipeline`; returns the hits
    /// and the wall-clock ms from submission to completion (llvmpipe's timestamps overlap).
    fn trace(
        &self,
        pipeline: CachedComputePipelineId,
        cubemap: &DeepCubemap,
        count: u32,
        read: bool,
    ) -> (Vec<[f32; 4]>, f64) {
        let hits = self.device.create_buffer(&BufferDescriptor {
            label: Some("rppm_bench_hits"),
            size: count as u64 * 16,
            usage: BufferUsages::STORAGE | BufferUsages::COPY_SRC,
            mapped_at_creation: false,
        });
        let group = self.device.create_bind_group(
            "rppm_bench_rays_group",
            &self.cache.get_bind_group_layout(&self.bench.rays_layout),
            &BindGroupEntries::sequential((
                self.rays.as_entire_binding(),
                hits.as_entire_binding(),
            )),
        );
        let mut encoder = self
            .device
            .create_command_encoder(&CommandEncoderDescriptor::default());
        if let Some(pipeline) = self.cache.get_compute_pipeline(pipeline) {
            let mut pass = encoder.begin_compute_pass(&ComputePassDescriptor {
                label: Some("rppm_bench_trace"),
                timestamp_writes: None,
            });
            pass.set_pipeline(pipeline);
            pass.set_bind_group(0, &self.scene_group, &[]);
            pass.set_bind_group(1, &self.empty_group, &[]);
            pass.set_bind_group(2, &group, &[]);
            pass.set_bind_group(3, &cubemap.trace_group, &[]);
            pass.dispatch_workgroups(count.div_ceil(64), 1, 1);
        }
        let _ = self.device.poll(PollType::wait_indefinitely());
        let start = Instant::now();
        self.submit(encoder);
        let _ = self.device.poll(PollType::wait_indefinitely());
        let ms = start.elapsed().as_secs_f64() * 1e3;
        let hits = if read {
            read_back(self.device, self.queue, &hits)
                .map(|b| bytemuck::cast_slice(&b).to_vec())
                .unwrap_or_default()
        } else {
            Vec::new()
        };
        (hits, ms)
    }

    /// What building a cubemap needs.
    fn build_context(&self) -> BuildContext<'_> {
        BuildContext {
            device: self.device,
            queue: self.queue,
            cache: self.cache,
            pipelines: self.cubemap,
            scene: self.scene,
            scene_group: &self.scene_group,
        }
    }

    /// Mean wall-clock ms of a few builds, each waited for (with its counters' read-back).
    fn time_build(&self, cubemap: &DeepCubemap) -> f64 {
        let runs = 3;
        let ctx = self.build_context();
        let start = Instant::now();
        for _ in 0..runs {
            cubemap.build_now(&ctx);
        }
        start.elapsed().as_secs_f64() * 1e3 / runs as f64
    }
}

/// Compares cubemap hits with brute-force hits: (agreeing, false misses, false hits, wrong hits).
pub fn compare(cubemap: &[[f32; 4]], brute: &[[f32; 4]]) -> (u32, u32, u32, u32) {
    let mut counts = (0, 0, 0, 0);
    for (d, b) in cubemap.iter().zip(brute) {
        let (hd, hb) = (d[1].to_bits() != NO_HIT, b[1].to_bits() != NO_HIT);
        match (hd, hb) {
            (false, false) => counts.0 += 1,
            (false, true) => counts.1 += 1,
            (true, false) => counts.2 += 1,
            (true, true) => {
                let same_t = (d[0] - b[0]).abs() <= 1e-4 * b[0].abs().max(1e-6);
                if d[1].to_bits() == b[1].to_bits() || same_t {
                    counts.0 += 1;
                } else {
                    counts.3 += 1;
                }
            }
        }
    }
    counts
}

#[expect(
    clippy::too_many_arguments,
    reason = "the render-world resources a harness run uses"
)]
pub(super) fn run_cubemap_bench(
    request: Option<Res<CubemapBenchRequest>>,
    scene: Option<Res<SceneBuffers>>,
    device: Res<RenderDevice>,
    queue: Res<RenderQueue>,
    cache: Res<PipelineCache>,
    layouts: Res<ViewLayouts>,
    cubemap: Res<CubemapPipelines>,
    bench: Res<BenchPipelines>,
    sender: Res<BenchSender>,
    mut done: Local<bool>,
) {
    let (Some(request), Some(scene)) = (request, scene) else {
        return;
    };
    let ready = cubemap.ready(&cache)
        && cache.get_compute_pipeline(bench.trace).is_some()
        && cache.get_compute_pipeline(bench.brute_force).is_some()
        && cache.get_compute_pipeline(bench.bvh).is_some();
    if *done || !ready || scene.data.instances.is_empty() {
        return;
    }
    *done = true;
    let shadow_views = storage_buffer(&device, "rppm_bench_no_shadow_views", &[[0u32; 4]]);
    let scene_group = scene.bind_group(&device, &cache, &layouts.scene, &shadow_views);
    let rays = storage_buffer(&device, "rppm_bench_rays", &request.rays);
    let empty_group = device.create_bind_group(
        "rppm_bench_empty_group",
        &cache.get_bind_group_layout(&empty_layout()),
        &[],
    );
    let gpu = Gpu {
        device: &device,
        queue: &queue,
        cache: &cache,
        cubemap: &cubemap,
        bench: &bench,
        scene: &scene,
        scene_group,
        empty_group,
        rays,
        bvh: BvhBuffers::build(&device, &queue, &scene.data),
    };
    let mut encoder = device.create_command_encoder(&CommandEncoderDescriptor::default());
    (gpu.bvh).encode_fill(&mut encoder, &device, &cache, &cubemap, &gpu.scene_group);
    gpu.submit(encoder);
    let count = request.rays.len() as u32;
    let mut rows = Vec::new();
    let mut brute: Option<(Vec<[f32; 4]>, f64)> = None;
    // The first guess no larger than one binding holds (as a view's cubemap starts).
    let most = DeepCubemap::most_nodes(&device);
    let trace_layout = gpu.cache.get_bind_group_layout(&gpu.cubemap.trace_layout);
    for &config in &request.configs {
        let capacity = DeepCubemap::initial_capacity(config, scene.triangle_count()).min(most);
        let fitted = DeepCubemap::fitted(&gpu.build_context(), config, request.centre, capacity);
        let (mut cube, fit) = match fitted {
            Ok(built) => built,
            Err(reason) => {
                warn!("bevy_rppm: deep-cubemap setting {config:?} skipped: {reason}");
                continue;
            }
        };
        cube.bind_bvh(gpu.device, &trace_layout, &gpu.bvh);
        let brute = brute.get_or_insert_with(|| gpu.trace(bench.brute_force, &cube, count, true));
        let (hits, _) = gpu.trace(bench.trace, &cube, count, true);
        let (agree, false_misses, false_hits, wrong_hits) = compare(&hits, &brute.0);
        let (_, trace_ms) = gpu.trace(bench.trace, &cube, request.timing_rays, false);
        if rows.is_empty() {
            rows.push(bvh_row(&gpu, &cube, brute, request.timing_rays));
        }
        rows.push(CubemapBenchRow {
            tracer: Tracer::DeepCubemap,
            triangles: scene.triangle_count(),
            resolution: config.resolution,
            tile_size: config.tile_size,
            bins: config.bins,
            rays: count,
            agreement: agree as f64 / count.max(1) as f64,
            false_misses,
            false_hits,
            wrong_hits,
            build_ms: gpu.time_build(&cube),
            timing_rays: request.timing_rays,
            trace_ms,
            brute_force_ms: brute.1,
            bytes: cube.memory().iter().map(|(_, b)| b).sum(),
            nodes_used: fit.used,
            overflow_rebuilds: fit.overflows,
        });
    }
    // The hierarchy's row last, so that the default setting stays first.
    if !rows.is_empty() {
        rows.rotate_left(1);
    }
    let _ = sender.send(rows);
}

/// The hierarchy's row: the same rays, compared with the same brute force (`cubemap`'s trace
/// group holds the hierarchy).
fn bvh_row(
    gpu: &Gpu,
    cubemap: &DeepCubemap,
    brute: &(Vec<[f32; 4]>, f64),
    timing_rays: u32,
) -> CubemapBenchRow {
    let count = brute.0.len() as u32;
    let (hits, _) = gpu.trace(gpu.bench.bvh, cubemap, count, true);
    let (agree, false_misses, false_hits, wrong_hits) = compare(&hits, &brute.0);
    let (_, trace_ms) = gpu.trace(gpu.bench.bvh, cubemap, timing_rays, false);
    CubemapBenchRow {
        tracer: Tracer::Bvh,
        triangles: gpu.scene.triangle_count(),
        resolution: 0,
        tile_size: 0,
        bins: 0,
        rays: count,
        agreement: agree as f64 / count.max(1) as f64,
        false_misses,
        false_hits,
        wrong_hits,
        build_ms: gpu.bvh.build_ms,
        timing_rays,
        trace_ms,
        brute_force_ms: brute.1,
        bytes: gpu.bvh.bytes,
        nodes_used: gpu.bvh.node_count,
        overflow_rebuilds: 0,
    }
}
