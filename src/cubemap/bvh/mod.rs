//! The deep cubemap's peer: a bounding-volume hierarchy built on the CPU from the scene's
//! world-space triangles, uploaded, and walked on the GPU (`trace_bvh` in
//! `shaders/cubemap/trace.wgsl`). While objects move it is refitted where they moved
//! ([`refit`]) and only the changed nodes are sent; once the scene stays still it is built
//! again. It traces a view's rays under `RppmTracer::Bvh`, and the same rays as the cubemap
//! in the DIRT harness.

mod build;
mod refit;

pub use build::{Bvh, BvhNode, INNER, MAX_DEPTH};

use std::sync::Arc;
use std::time::Instant;

use bevy::math::Vec3;
use bevy::render::render_resource::Buffer;
use bevy::render::renderer::{RenderDevice, RenderQueue};

use crate::scene::prepare::storage_buffer;
use crate::scene::{GpuInstance, SceneData};
use refit::Refittable;

/// A hierarchy on the GPU and what making it cost.
pub struct BvhBuffers {
    pub nodes: Buffer,
    pub indices: Buffer,
    pub node_count: u32,
    /// Bytes held on the GPU.
    pub bytes: u64,
    /// Wall-clock milliseconds of the CPU work of the last build or refit.
    pub build_ms: f64,
    /// Bytes the last build or refit sent to the GPU.
    pub upload_bytes: u64,
    hierarchy: Refittable,
    /// Each instance as the hierarchy holds it: its mesh (by identity) and transform.
    placed: Vec<(usize, GpuInstance)>,
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
            upload_bytes: 0,
            hierarchy: Refittable::default(),
            placed: Vec::new(),
        }
    }

    pub fn build(device: &RenderDevice, data: &SceneData) -> Self {
        let start = Instant::now();
        let triangles: Vec<_> = data
            .world_triangles()
            .iter()
            .map(|t| t.positions())
            .collect();
        let hierarchy = Refittable::build(triangles);
        let build_ms = start.elapsed().as_secs_f64() * 1e3;
        let bvh = &hierarchy.bvh;
        let bytes = bvh.bytes();
        Self {
            nodes: storage_buffer(device, "rppm_bvh_nodes", &bvh.nodes),
            indices: storage_buffer(device, "rppm_bvh_indices", &bvh.indices),
            node_count: bvh.nodes.len() as u32,
            bytes,
            build_ms,
            upload_bytes: bytes,
            placed: placed(data),
            hierarchy,
        }
    }

    /// Whether a refit changed the hierarchy since it was built (a build walks faster).
    pub fn refitted(&self) -> bool {
        self.hierarchy.refitted
    }

    /// Follows moved geometry by a refit where the instances are the same ones (a transform
    /// or a pose changed), sending only the nodes that changed; none where a build is wanted
    /// instead (instances came or went, a box grew too much).
    pub fn refit(&mut self, queue: &RenderQueue, data: &SceneData) -> Option<()> {
        let start = Instant::now();
        let now = placed(data);
        let same_shape = now.len() == self.placed.len()
            && now.iter().zip(&self.placed).all(|((_, a), (_, b))| {
                (a.first_world, a.triangle_count) == (b.first_world, b.triangle_count)
            });
        if !same_shape || self.hierarchy.triangle_count() != data.triangle_count() {
            return None;
        }
        let mut moved: Vec<(usize, [Vec3; 3])> = Vec::new();
        for (&(mesh, instance), old) in now.iter().zip(&self.placed) {
            if (mesh, instance.rows) == (old.0, old.1.rows) {
                continue;
            }
            let local = &data.meshes[instance.mesh as usize].triangles;
            let first = instance.first_world as usize;
            moved.extend(
                local
                    .iter()
                    .enumerate()
                    .map(|(k, t)| (first + k, instance.place(t).positions())),
            );
        }
        let changed = self.hierarchy.refit(&moved)?;
        self.placed = now;
        // Runs of neighbouring nodes go in one write.
        let nodes = &self.hierarchy.bvh.nodes;
        let mut sent = 0;
        let mut k = 0;
        while k < changed.len() {
            let mut end = k + 1;
            while end < changed.len() && changed[end] == changed[end - 1] + 1 {
                end += 1;
            }
            let (a, b) = (changed[k] as usize, changed[end - 1] as usize + 1);
            let bytes: &[u8] = bytemuck::cast_slice(&nodes[a..b]);
            queue.write_buffer(&self.nodes, (a * size_of::<BvhNode>()) as u64, bytes);
            sent += bytes.len() as u64;
            k = end;
        }
        self.upload_bytes = sent;
        self.build_ms = start.elapsed().as_secs_f64() * 1e3;
        Some(())
    }
}

/// Each instance with its mesh's identity.
fn placed(data: &SceneData) -> Vec<(usize, GpuInstance)> {
    data.instances
        .iter()
        .map(|i| {
            let mesh = data
                .meshes
                .get(i.mesh as usize)
                .map_or(0, |m| Arc::as_ptr(m) as usize);
            (mesh, *i)
        })
        .collect()
}
