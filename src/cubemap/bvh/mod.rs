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
    /// Each instance as the hierarchy holds it: what tells a moved one.
    placed: Vec<Placed>,
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

    /// Follows the scene's geometry: nothing where no instance moved, a refit where the
    /// instances are the same ones (a transform or a pose changed), sending only the nodes
    /// that changed; a build is wanted where instances came or went, or a box grew too much.
    pub fn follow(&mut self, queue: &RenderQueue, data: &SceneData) -> Follow {
        let start = Instant::now();
        let now = placed(data);
        let same_shape = now.len() == self.placed.len()
            && now.iter().zip(&self.placed).all(|(a, b)| {
                (a.instance.first_world, a.instance.triangle_count)
                    == (b.instance.first_world, b.instance.triangle_count)
            });
        if !same_shape {
            return Follow::Build;
        }
        let mut moved: Vec<(usize, [Vec3; 3])> = Vec::new();
        for (p, old) in now.iter().zip(&self.placed) {
            if (p.mesh, p.instance.rows) == (old.mesh, old.instance.rows) {
                continue;
            }
            let local = &data.meshes[p.instance.mesh as usize].triangles;
            let first = p.instance.first_world as usize;
            moved.extend(
                local
                    .iter()
                    .enumerate()
                    .map(|(k, t)| (first + k, p.instance.place(t).positions())),
            );
        }
        if moved.is_empty() {
            return Follow::Same;
        }
        let Some(changed) = self.hierarchy.refit(&moved) else {
            return Follow::Build;
        };
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
        Follow::Refitted
    }
}

/// What [`BvhBuffers::follow`] did with a changed scene.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Follow {
    /// No triangle moved (a light or a material changed): nothing done.
    Same,
    /// Moved triangles were refitted and their nodes sent.
    Refitted,
    /// A build is wanted instead; the hierarchy is not to be used as it is.
    Build,
}

/// An instance as the hierarchy holds it, with its mesh's identity.
struct Placed {
    mesh: usize,
    instance: GpuInstance,
}

fn placed(data: &SceneData) -> Vec<Placed> {
    data.instances
        .iter()
        .map(|i| Placed {
            mesh: data
                .meshes
                .get(i.mesh as usize)
                .map_or(0, |m| Arc::as_ptr(m) as usize),
            instance: *i,
        })
        .collect()
}
