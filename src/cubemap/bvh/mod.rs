//! The deep cubemap's peer: a bounding-volume hierarchy built on the CPU from the scene's
//! world-space triangles, uploaded, and walked on the GPU (`trace_bvh` in
//! `shaders/cubemap/trace.wgsl`). While objects move it is refitted where they moved
//! ([`refit`]) and only the changed nodes are sent; once the scene stays still it is built
//! again. It traces a view's rays under `RppmTracer::Bvh`, and the same rays as the cubemap
//! in the DIRT harness.

mod build;
mod refit;
mod texels;

pub use build::{Bvh, BvhNode, INNER, MAX_DEPTH};
pub use texels::{fits, node_texels};

use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::Instant;

use bevy::math::Vec3;
use bevy::render::render_resource::*;
use bevy::render::renderer::{RenderDevice, RenderQueue};

use super::CubemapPipelines;
use crate::scene::place::dispatch_size;
use crate::scene::prepare::storage_buffer;
use crate::scene::{GpuInstance, SceneData};
use refit::Refittable;
use texels::{texels_texture, write_texels};

/// A hierarchy on the GPU and what making it cost.
pub struct BvhBuffers {
    /// Two texels a node ([`node_texels`]).
    pub nodes: Texture,
    pub nodes_view: TextureView,
    /// The leaves' triangles' corners, three texels each, copied from the scene's placed
    /// triangles by `bvh_fill.wgsl` ([`BvhBuffers::encode_fill`]).
    pub corners: Texture,
    pub corners_view: TextureView,
    /// The triangle ids in leaf order, which the copy follows.
    pub indices: Buffer,
    leaf_triangles: u32,
    pub node_count: u32,
    /// Whether the corners are to be copied again (built, or the geometry moved).
    stale: AtomicBool,
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
        // Zeroed texels: a leaf of no triangles.
        let (nodes, nodes_view) =
            texels_texture(device, "rppm_bvh_nodes", 2, TextureUsages::empty());
        let (corners, corners_view) =
            texels_texture(device, "rppm_bvh_corners", 1, TextureUsages::empty());
        Self {
            nodes,
            nodes_view,
            corners,
            corners_view,
            indices: storage_buffer::<u32>(device, "rppm_bvh_indices", &[]),
            leaf_triangles: 0,
            node_count: 1,
            stale: AtomicBool::new(false),
            bytes: 0,
            build_ms: 0.0,
            upload_bytes: 0,
            hierarchy: Refittable::default(),
            placed: Vec::new(),
        }
    }

    pub fn build(device: &RenderDevice, queue: &RenderQueue, data: &SceneData) -> Self {
        let start = Instant::now();
        let triangles: Vec<_> = data
            .world_triangles()
            .iter()
            .map(|t| t.positions())
            .collect();
        let hierarchy = Refittable::build(triangles);
        let build_ms = start.elapsed().as_secs_f64() * 1e3;
        let bvh = &hierarchy.bvh;
        let node_texels = node_texels(&bvh.nodes);
        let (nodes, nodes_view) = texels_texture(
            device,
            "rppm_bvh_nodes",
            node_texels.len() as u32,
            TextureUsages::COPY_DST,
        );
        let sent = write_texels(queue, &nodes, 0, &node_texels);
        let (corners, corners_view) = texels_texture(
            device,
            "rppm_bvh_corners",
            3 * bvh.indices.len() as u32,
            TextureUsages::STORAGE_BINDING,
        );
        // Three texels of corners and an id in the order buffer a triangle.
        let bytes = sent + (3 * 16 + 4) * bvh.indices.len() as u64;
        Self {
            nodes,
            nodes_view,
            corners,
            corners_view,
            indices: storage_buffer(device, "rppm_bvh_indices", &bvh.indices),
            leaf_triangles: bvh.indices.len() as u32,
            node_count: bvh.nodes.len() as u32,
            stale: AtomicBool::new(true),
            bytes,
            build_ms,
            upload_bytes: sent + 4 * bvh.indices.len() as u64,
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
            sent += write_texels(queue, &self.nodes, 2 * a as u32, &node_texels(&nodes[a..b]));
            k = end;
        }
        // The moved triangles' corners are copied again once the scene has placed them.
        self.stale.store(true, Ordering::Relaxed);
        self.upload_bytes = sent;
        self.build_ms = start.elapsed().as_secs_f64() * 1e3;
        Follow::Refitted
    }
}

impl BvhBuffers {
    /// Copies the placed triangles' corners into the leaf-ordered texture when they are
    /// stale; `scene_group` binds the scene's triangles. Nothing where the pipeline is still
    /// compiling (the copy waits for the next call).
    pub fn encode_fill(
        &self,
        encoder: &mut CommandEncoder,
        device: &RenderDevice,
        cache: &PipelineCache,
        pipelines: &CubemapPipelines,
        scene_group: &BindGroup,
    ) {
        if !self.stale.load(Ordering::Relaxed) {
            return;
        }
        let Some(pipeline) = cache.get_compute_pipeline(pipelines.bvh_fill) else {
            return;
        };
        let group = device.create_bind_group(
            "rppm_bvh_fill_group",
            &cache.get_bind_group_layout(&pipelines.bvh_fill_layout),
            &BindGroupEntries::sequential((self.indices.as_entire_binding(), &self.corners_view)),
        );
        let mut pass = encoder.begin_compute_pass(&ComputePassDescriptor {
            label: Some("rppm_bvh_fill"),
            timestamp_writes: None,
        });
        pass.set_pipeline(pipeline);
        pass.set_bind_group(0, scene_group, &[]);
        pass.set_bind_group(1, &group, &[]);
        let limit = device.limits().max_compute_workgroups_per_dimension;
        let [x, y] = dispatch_size(self.leaf_triangles, limit);
        pass.dispatch_workgroups(x, y, 1);
        self.stale.store(false, Ordering::Relaxed);
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
