//! The photon map: an iteration's stored photons ordered by deep-cubemap tile, a counting sort
//! after tracing (`shaders/photons/sort.wgsl`). A row of tiles is one run of the map, so the
//! gathers read neighbouring photons from neighbouring memory; per-tile linked lists sent
//! every step of a walk anywhere in the store, and the splats' time changed by half with
//! the order photons happened to be stored in.

use bevy::prelude::*;
use bevy::render::render_resource::binding_types::{
    storage_buffer_read_only_sized, storage_buffer_sized,
};
use bevy::render::render_resource::*;
use bevy::render::renderer::RenderDevice;

use crate::importons::storage;
use crate::shaders::RppmShaders;
use crate::stats::timing::{Stage, StageTimer};

/// Tiles one workgroup of the scan sums (`SCAN_BLOCK` in photons/sort.wgsl).
pub(crate) const SCAN_BLOCK: u32 = 4096;

/// The sort's passes, in order, by entry point.
const PASSES: [&str; 4] = ["scan_blocks", "scan_sums", "scan_add", "scatter"];

/// The sort's layouts and pipelines, shared by every view.
pub struct SortPipelines {
    /// Group 0 of every pass: 0 per-tile counts, 1 per-tile starts (four tiles a quad).
    pub tiles_layout: BindGroupLayoutDescriptor,
    /// Group 1 of the scans: 0 per-block sums, 1 the scatter's workgroups (apart from the
    /// scatter, which dispatches with them).
    pub scan_layout: BindGroupLayoutDescriptor,
    /// Group 1 of the scatter: 2 the photons as stored, 3 their tiles, 4 the map.
    pub scatter_layout: BindGroupLayoutDescriptor,
    /// The passes, in the order of [`PASSES`].
    pub passes: [CachedComputePipelineId; 4],
}

impl SortPipelines {
    pub fn new(cache: &PipelineCache, shaders: &RppmShaders) -> Self {
        let read = || storage_buffer_read_only_sized(false, None);
        let write = || storage_buffer_sized(false, None);
        let layout = |label: &'static str, entries: &[BindGroupLayoutEntry]| {
            BindGroupLayoutDescriptor::new(label, entries)
        };
        let tiles_layout = layout(
            "rppm_photon_sort_tiles_layout",
            &BindGroupLayoutEntries::sequential(ShaderStages::COMPUTE, (read(), write())),
        );
        let scan_layout = layout(
            "rppm_photon_scan_layout",
            &BindGroupLayoutEntries::sequential(ShaderStages::COMPUTE, (write(), write())),
        );
        let scatter_layout = layout(
            "rppm_photon_scatter_layout",
            &BindGroupLayoutEntries::with_indices(
                ShaderStages::COMPUTE,
                ((2, read()), (3, read()), (4, write())),
            ),
        );
        let passes = PASSES.map(|entry| {
            let own = if entry == "scatter" {
                &scatter_layout
            } else {
                &scan_layout
            };
            cache.queue_compute_pipeline(ComputePipelineDescriptor {
                label: Some(format!("rppm_photon_{entry}").into()),
                layout: vec![tiles_layout.clone(), own.clone()],
                shader: shaders.photon_sort.clone(),
                entry_point: Some(entry.into()),
                ..default()
            })
        });
        Self {
            tiles_layout,
            scan_layout,
            scatter_layout,
            passes,
        }
    }
}

/// One camera's photon map and the sort's buffers.
pub struct PhotonMap {
    /// The photons by tile.
    pub photons: Buffer,
    /// Per tile, the photons tracing stored in it.
    pub tile_counts: Buffer,
    /// Per tile, its first photon in the map; then the photon count.
    pub tile_starts: Buffer,
    block_sums: Buffer,
    /// The scatter's indirect dispatch, written by the scan.
    scatter_groups: Buffer,
    /// Blocks of SCAN_BLOCK tiles, one scan workgroup each.
    blocks: u32,
    /// The groups of the sort's passes: tiles, scans, scatter.
    groups: [BindGroup; 3],
}

impl PhotonMap {
    /// A map of `tiles` tiles for the photons as tracing stores them and their tiles and
    /// ranks (`[stored, photon_tiles]`, the map as large as the first).
    pub fn new(
        device: &RenderDevice,
        cache: &PipelineCache,
        sort: &SortPipelines,
        tiles: u32,
        [stored, photon_tiles]: [&Buffer; 2],
    ) -> Self {
        // The per-tile buffers hold whole quads of tiles (at least 32 bytes: 6 tiles or more).
        let quads = tiles.div_ceil(4) as u64;
        let blocks = tiles.div_ceil(SCAN_BLOCK);
        let photons = storage(device, "rppm_photon_map", stored.size());
        let tile_counts = storage(device, "rppm_photon_tile_counts", quads * 16);
        let tile_starts = storage(device, "rppm_photon_tile_starts", (quads + 1) * 16);
        // The scan counts its blocks from the tiles, so this may be padded.
        let block_sums = storage(device, "rppm_photon_block_sums", blocks as u64 * 4);
        let scatter_groups = device.create_buffer(&BufferDescriptor {
            label: Some("rppm_photon_scatter_groups"),
            size: 12,
            usage: BufferUsages::STORAGE | BufferUsages::INDIRECT,
            mapped_at_creation: false,
        });
        let group = |label, layout, entries: &[BindGroupEntry]| {
            device.create_bind_group(label, &cache.get_bind_group_layout(layout), entries)
        };
        let groups = [
            group(
                "rppm_photon_sort_tiles_group",
                &sort.tiles_layout,
                &BindGroupEntries::sequential((
                    tile_counts.as_entire_binding(),
                    tile_starts.as_entire_binding(),
                )),
            ),
            group(
                "rppm_photon_scan_group",
                &sort.scan_layout,
                &BindGroupEntries::sequential((
                    block_sums.as_entire_binding(),
                    scatter_groups.as_entire_binding(),
                )),
            ),
            group(
                "rppm_photon_scatter_group",
                &sort.scatter_layout,
                &BindGroupEntries::with_indices((
                    (2, stored.as_entire_binding()),
                    (3, photon_tiles.as_entire_binding()),
                    (4, photons.as_entire_binding()),
                )),
            ),
        ];
        Self {
            photons,
            tile_counts,
            tile_starts,
            block_sums,
            scatter_groups,
            blocks,
            groups,
        }
    }

    /// Orders the iteration's stored photons into the map (`passes` as [`PASSES`]).
    pub fn encode_sort(
        &self,
        encoder: &mut CommandEncoder,
        passes: [&ComputePipeline; 4],
        timer: &mut StageTimer,
    ) {
        let [tiles, scan, scatter_group] = &self.groups;
        let blocks = self.blocks;
        let mut pass = encoder.begin_compute_pass(&ComputePassDescriptor {
            label: Some("rppm_photon_sort"),
            timestamp_writes: timer.compute_pass(Stage::PhotonSort),
        });
        pass.set_bind_group(0, tiles, &[]);
        pass.set_bind_group(1, scan, &[]);
        let [scan_blocks, scan_sums, scan_add, scatter] = passes;
        pass.set_pipeline(scan_blocks);
        pass.dispatch_workgroups(blocks, 1, 1);
        pass.set_pipeline(scan_sums);
        pass.dispatch_workgroups(1, 1, 1);
        pass.set_pipeline(scan_add);
        pass.dispatch_workgroups(blocks, 1, 1);
        pass.set_pipeline(scatter);
        pass.set_bind_group(1, scatter_group, &[]);
        pass.dispatch_workgroups_indirect(&self.scatter_groups, 0);
    }

    /// Bytes held by the map and the sort.
    pub fn bytes(&self) -> u64 {
        [
            &self.photons,
            &self.tile_counts,
            &self.tile_starts,
            &self.block_sums,
            &self.scatter_groups,
        ]
        .iter()
        .map(|b| b.size())
        .sum()
    }
}
