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

use crate::shaders::RppmShaders;
use crate::stats::timing::{Stage, StageTimer};

/// Tiles one workgroup of the scan sums (`SCAN_BLOCK` in photons/sort.wgsl).
pub(crate) const SCAN_BLOCK: u32 = 4096;

/// The sort's passes, in order, by entry point.
const PASSES: [&str; 4] = ["scan_blocks", "scan_sums", "scan_add", "scatter"];

/// Tiles of the photon map for a cubemap of `grid`² tiles a face.
pub fn map_tiles(grid: u32) -> u32 {
    6 * grid * grid
}

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
    tiles: u32,
    /// The groups of the sort's passes (tiles, scans, scatter), once bound.
    groups: Option<[BindGroup; 3]>,
}

fn buffer(device: &RenderDevice, label: &'static str, bytes: u64, usage: BufferUsages) -> Buffer {
    device.create_buffer(&BufferDescriptor {
        label: Some(label),
        size: bytes,
        usage: BufferUsages::STORAGE | usage,
        mapped_at_creation: false,
    })
}

impl PhotonMap {
    /// Room for `capacity` photons of `photon_bytes` in `tiles` tiles.
    pub fn new(device: &RenderDevice, capacity: u32, photon_bytes: u64, tiles: u32) -> Self {
        // The per-tile buffers hold whole quads of tiles.
        let quads = tiles.div_ceil(4) as u64;
        let blocks = tiles.div_ceil(SCAN_BLOCK) as u64;
        Self {
            photons: buffer(
                device,
                "rppm_photon_map",
                capacity as u64 * photon_bytes,
                BufferUsages::empty(),
            ),
            tile_counts: buffer(
                device,
                "rppm_photon_tile_counts",
                quads * 16,
                BufferUsages::COPY_DST,
            ),
            tile_starts: buffer(
                device,
                "rppm_photon_tile_starts",
                (quads + 1) * 16,
                BufferUsages::empty(),
            ),
            block_sums: buffer(
                device,
                "rppm_photon_block_sums",
                blocks * 4,
                BufferUsages::empty(),
            ),
            scatter_groups: buffer(
                device,
                "rppm_photon_scatter_groups",
                12,
                BufferUsages::INDIRECT,
            ),
            tiles,
            groups: None,
        }
    }

    /// Binds the sort to the photons as stored and their tiles.
    pub fn bind(
        &mut self,
        device: &RenderDevice,
        cache: &PipelineCache,
        sort: &SortPipelines,
        stored: &Buffer,
        photon_tiles: &Buffer,
    ) {
        let tiles = device.create_bind_group(
            "rppm_photon_sort_tiles_group",
            &cache.get_bind_group_layout(&sort.tiles_layout),
            &BindGroupEntries::sequential((
                self.tile_counts.as_entire_binding(),
                self.tile_starts.as_entire_binding(),
            )),
        );
        let scan = device.create_bind_group(
            "rppm_photon_scan_group",
            &cache.get_bind_group_layout(&sort.scan_layout),
            &BindGroupEntries::sequential((
                self.block_sums.as_entire_binding(),
                self.scatter_groups.as_entire_binding(),
            )),
        );
        let scatter = device.create_bind_group(
            "rppm_photon_scatter_group",
            &cache.get_bind_group_layout(&sort.scatter_layout),
            &BindGroupEntries::with_indices((
                (2, stored.as_entire_binding()),
                (3, photon_tiles.as_entire_binding()),
                (4, self.photons.as_entire_binding()),
            )),
        );
        self.groups = Some([tiles, scan, scatter]);
    }

    /// Orders the iteration's stored photons into the map (`passes` as [`PASSES`]).
    pub fn encode_sort(
        &self,
        encoder: &mut CommandEncoder,
        passes: [&ComputePipeline; 4],
        timer: &mut StageTimer,
    ) {
        let Some([tiles, scan, scatter_group]) = &self.groups else {
            return;
        };
        let blocks = self.tiles.div_ceil(SCAN_BLOCK);
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
