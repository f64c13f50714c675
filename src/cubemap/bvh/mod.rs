//! The deep cubemap's peer: a bounding-volume hierarchy built on the CPU from the scene's
//! world-space triangles each time the scene changes, uploaded, and walked on the GPU
//! (`trace_bvh` in `shaders/cubemap/trace.wgsl`). It traces a view's rays under
//! `RppmTracer::Bvh`, and the same rays as the cubemap in the DIRT harness.

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
    /// The stand-in a view tracing by the deep cubemap binds: an empty leaf.
    pub fn empty(device: &RenderDevice) -> Self {
        Self {
            nodes: storage_buffer(device, "rppm_bvh_nodes", &[BvhNode::default()]),
            indices: storage_buffer::<u32>(device, "rppm_bvh_indices", &[]),
            node_count: 1,
            bytes: 0,
            build_ms: 0.0,
        }
    }

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
            nodes: storage_buffer(device, "rppm_bvh_nodes", &bvh.nodes),
            indices: storage_buffer(device, "rppm_bvh_indices", &bvh.indices),
            node_count: bvh.nodes.len() as u32,
            bytes: bvh.bytes(),
            build_ms,
        }
    }
}
