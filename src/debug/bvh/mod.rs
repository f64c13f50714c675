//! The deep cubemap's peer in the correctness harness: a bounding-volume hierarchy built on
//! the CPU from the same triangles each time the scene changes, uploaded, and walked on the GPU
//! (`trace_bvh` in `shaders/debug/cubemap_bench.wgsl`) over the same rays.

mod build;

pub use build::{Bvh, BvhNode, INNER, MAX_DEPTH};

use std::time::Instant;

use bevy::render::render_resource::Buffer;
use bevy::render::renderer::RenderDevice;

use crate::scene::SceneData;
use crate::scene::prepare::storage_buffer;

/// A hierarchy on the GPU and what making it cost.
pub struct BvhBuffers {
    pub nodes: Buffer,
    pub indices: Buffer,
    pub node_count: u32,
    pub bytes: u64,
    /// Wall-clock milliseconds of the CPU build from the scene's world-space triangles.
    pub build_ms: f64,
}

impl BvhBuffers {
    pub fn build(device: &RenderDevice, data: &SceneData) -> Self {
        let triangles: Vec<_> = data
            .world_triangles()
            .iter()
            .map(|t| t.positions())
            .collect();
        let start = Instant::now();
        let bvh = Bvh::build(&triangles);
        let build_ms = start.elapsed().as_secs_f64() * 1e3;
        Self {
            nodes: storage_buffer(device, "rppm_bench_bvh_nodes", &bvh.nodes),
            indices: storage_buffer(device, "rppm_bench_bvh_indices", &bvh.indices),
            node_count: bvh.nodes.len() as u32,
            bytes: bvh.bytes(),
            build_ms,
        }
    }
}
