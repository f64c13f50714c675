//! Placement: the world-space triangle table made on the GPU from the meshes and their
//! instances (shaders/scene/place.wgsl), once per change of either.

use bevy::prelude::*;
use bevy::render::render_resource::binding_types::{
    storage_buffer_read_only_sized, storage_buffer_sized,
};
use bevy::render::render_resource::*;
use bevy::render::renderer::{RenderDevice, RenderQueue};

use crate::shaders::RppmShaders;

/// Threads per workgroup of `place`.
const WORKGROUP: u32 = 64;

/// The placement pipelines: 0 the meshes' triangles, 1 the instances, 2 the world triangles.
/// `marking` marks the triangles that moved from where the buffer held them; `new` fills a
/// new buffer, whose triangles none moved.
#[derive(Resource)]
pub struct PlacePipeline {
    layout: BindGroupLayoutDescriptor,
    marking: CachedComputePipelineId,
    new: CachedComputePipelineId,
}

pub(crate) fn init_place_pipeline(
    mut commands: Commands,
    shaders: Res<RppmShaders>,
    cache: Res<PipelineCache>,
) {
    let layout = BindGroupLayoutDescriptor::new(
        "rppm_place_layout",
        &BindGroupLayoutEntries::sequential(
            ShaderStages::COMPUTE,
            (
                storage_buffer_read_only_sized(false, None),
                storage_buffer_read_only_sized(false, None),
                storage_buffer_sized(false, None),
            ),
        ),
    );
    let queue = |entry_point: &str| {
        cache.queue_compute_pipeline(ComputePipelineDescriptor {
            label: Some(format!("rppm_{entry_point}").into()),
            layout: vec![layout.clone()],
            shader: shaders.place.clone(),
            entry_point: Some(entry_point.to_owned().into()),
            ..default()
        })
    };
    let (marking, new) = (queue("place"), queue("place_new"));
    commands.insert_resource(PlacePipeline {
        layout,
        marking,
        new,
    });
}

impl PlacePipeline {
    /// Whether the pipelines have compiled (the scene waits for them).
    pub fn ready(&self, cache: &PipelineCache) -> bool {
        [self.marking, self.new]
            .iter()
            .all(|&id| cache.get_compute_pipeline(id).is_some())
    }

    /// Places `count` triangles into `world` (`new`: a buffer just made, whose triangles are
    /// not marked moved) and submits at once, so that every later submission (this frame's
    /// views) sees them.
    pub fn place(
        &self,
        device: &RenderDevice,
        queue: &RenderQueue,
        cache: &PipelineCache,
        [local, instances, world]: [&Buffer; 3],
        count: u32,
        new: bool,
    ) {
        let id = if new { self.new } else { self.marking };
        let Some(pipeline) = cache.get_compute_pipeline(id) else {
            return;
        };
        let group = device.create_bind_group(
            "rppm_place_group",
            &cache.get_bind_group_layout(&self.layout),
            &BindGroupEntries::sequential((
                local.as_entire_binding(),
                instances.as_entire_binding(),
                world.as_entire_binding(),
            )),
        );
        let max_groups = device.limits().max_compute_workgroups_per_dimension;
        let [x, y] = dispatch_size(count, max_groups);
        let mut encoder = device.create_command_encoder(&CommandEncoderDescriptor {
            label: Some("rppm_place"),
        });
        {
            let mut pass = encoder.begin_compute_pass(&ComputePassDescriptor {
                label: Some("rppm_place"),
                timestamp_writes: None,
            });
            pass.set_pipeline(pipeline);
            pass.set_bind_group(0, &group, &[]);
            pass.dispatch_workgroups(x, y, 1);
        }
        queue.submit([encoder.finish()]);
    }
}

/// Workgroups (x, y) of 64 threads covering `count` threads, x at most `max_groups` (the
/// device's limit per dimension): for a pass over every triangle.
pub(crate) fn dispatch_size(count: u32, max_groups: u32) -> [u32; 2] {
    let groups = count.div_ceil(WORKGROUP).max(1);
    let x = groups.min(max_groups.max(1));
    [x, groups.div_ceil(x)]
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn dispatch_covers_every_triangle_within_the_limit() {
        for (count, limit) in [
            (1, 65535),
            (64, 65535),
            (65, 65535),
            (5_000_000, 65535),
            (1000, 3),
        ] {
            let [x, y] = dispatch_size(count, limit);
            assert!(x <= limit && x * y * WORKGROUP >= count, "{count} {limit}");
            assert!(
                (x * (y - 1)) * WORKGROUP < count.max(1),
                "{count} {limit}: too many"
            );
        }
    }
}
