//! The photon store: room for the photons an iteration stores, sized from the stores counted
//! in earlier iterations as the cubemap's lists are (a photon with no room is lost, and
//! counted). Until a count arrives it holds the worst case, so no first iteration loses one.

use std::sync::atomic::{AtomicU32, Ordering};

use bevy::render::render_resource::*;
use bevy::render::renderer::{RenderDevice, RenderQueue};

use super::PhotonPipeline;
use super::map::PhotonMap;
use crate::cubemap::TracingGroups;
use crate::importons::storage;
use crate::ppm::{grown_capacity, photon_store_capacity};
use crate::scene::SceneBuffers;
use crate::settings::{PhotonMapping, RppmDebugView};
use crate::stats::readback::{AsyncReadback, read_back};
use crate::stats::timing::{Stage, StageTimer};

/// Bytes of one stored photon (`Photon` in common.wgsl).
pub const PHOTON_BYTES: u64 = 32;

/// Weight of a lower count in the stores per photon remembered: a store shrinks over a few
/// readings, not for one quiet iteration.
const DECAY: f64 = 0.125;

/// What a store is sized from: stores per emitted photon, counted by earlier iterations.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct StoreFit {
    /// The most stores per emitted photon seen lately (a higher count is taken at once, a
    /// lower one slowly); none before the first count.
    per_photon: Option<f64>,
    /// Photons the last count found no room for.
    pub lost: u32,
}

impl StoreFit {
    /// Takes a count: `stored` photons wanted a place (all of them, placed or not) out of
    /// `emitted`, in a store of `capacity`.
    pub fn observe(&mut self, stored: u32, emitted: u32, capacity: u32) {
        if emitted == 0 {
            return;
        }
        self.lost = stored.saturating_sub(capacity);
        let seen = stored as f64 / emitted as f64;
        self.per_photon = Some(match self.per_photon {
            Some(p) if seen < p => p + (seen - p) * DECAY,
            _ => seen,
        });
    }

    /// Room for `photons` a iteration: the stores counted, a quarter more and 4 standard
    /// deviations (the count's noise), at most `worst`. `current` stays while it holds that
    /// and not twice that, so a store is not made again for every change of the count.
    pub fn capacity(&self, photons: u32, worst: f64, current: u32) -> u32 {
        let Some(per_photon) = self.per_photon else {
            return worst.ceil() as u32;
        };
        let stores = photons as f64 * per_photon;
        let spared = grown_capacity(stores.ceil() as u32) as f64;
        let wanted = (spared + 4.0 * stores.sqrt() + 1024.0).min(worst).ceil();
        let kept = current as f64;
        if kept >= wanted && kept <= 2.0 * wanted {
            current
        } else {
            wanted as u32
        }
    }
}

/// Photons a view's store holds for `photons` a iteration: what `fit` counted, or the worst
/// case ([`photon_store_capacity`]) until a count arrives, capped by the GPU's largest storage
/// binding; `current` stays while it fits. 0 when nothing emits or no photon can be stored.
pub(crate) fn store_capacity(
    settings: &PhotonMapping,
    photons: u32,
    scene: &SceneBuffers,
    device: &RenderDevice,
    fit: &StoreFit,
    current: u32,
) -> u32 {
    let direct = settings.debug_view == RppmDebugView::DirectPhotons;
    let stores = if direct {
        1
    } else {
        settings.max_photon_depth - 1
    };
    if scene.data.light_cdf.is_empty() || photons == 0 || stores == 0 {
        return 0;
    }
    let worst = photon_store_capacity(photons, stores, scene.max_scatter, direct);
    let most = (device.limits().max_storage_buffer_binding_size / PHOTON_BYTES) as f64;
    fit.capacity(photons, worst.min(most), current)
}

/// One camera's photon store, when the scene has lights to emit from: the photons as tracing
/// stores them, and the map the sort orders them into.
pub struct PhotonStore {
    /// The photons in the order they were stored.
    pub stored: Buffer,
    /// Per stored photon, its cubemap tile and its rank among the tile's photons.
    pub tiles: Buffer,
    /// [-, photons stored (placed or not), -, -].
    pub count: Buffer,
    /// The photons by tile, which both splats gather from.
    pub map: PhotonMap,
    group: BindGroup,
    /// The count's non-blocking read-back, and the photons emitted by the iteration it copied.
    probe: AsyncReadback,
    probe_photons: AtomicU32,
    /// Photons emitted by the last trace recorded, until a blocking read takes the count.
    traced: AtomicU32,
}

impl PhotonStore {
    /// Room for `capacity` photons, mapped into `tiles` tiles (the cubemap's).
    pub fn new(
        device: &RenderDevice,
        cache: &PipelineCache,
        pipeline: &PhotonPipeline,
        capacity: u32,
        tiles: u32,
    ) -> Self {
        let stored = storage(device, "rppm_photons", capacity as u64 * PHOTON_BYTES);
        let photon_tiles = storage(device, "rppm_photon_tiles", capacity as u64 * 8);
        let count = device.create_buffer_with_data(&BufferInitDescriptor {
            label: Some("rppm_photon_count"),
            contents: bytemuck::cast_slice(&[0u32; 4]),
            usage: BufferUsages::STORAGE | BufferUsages::COPY_DST | BufferUsages::COPY_SRC,
        });
        let map = PhotonMap::new(
            device,
            cache,
            &pipeline.sort,
            tiles,
            [&stored, &photon_tiles],
        );
        let group = device.create_bind_group(
            "rppm_photon_store_group",
            &cache.get_bind_group_layout(&pipeline.store_layout),
            &BindGroupEntries::sequential((
                stored.as_entire_binding(),
                count.as_entire_binding(),
                map.tile_counts.as_entire_binding(),
                photon_tiles.as_entire_binding(),
            )),
        );
        Self {
            stored,
            tiles: photon_tiles,
            count,
            map,
            group,
            probe: AsyncReadback::new(device, 16),
            probe_photons: AtomicU32::new(0),
            traced: AtomicU32::new(0),
        }
    }

    /// Photon tracing for one iteration: `photons` by `lanes` invocations.
    pub fn encode_trace(
        &self,
        encoder: &mut CommandEncoder,
        pipeline: &ComputePipeline,
        groups: &TracingGroups,
        [photons, lanes]: [u32; 2],
        timer: &mut StageTimer,
    ) {
        encoder.clear_buffer(&self.count, 4, Some(4));
        encoder.clear_buffer(&self.map.tile_counts, 0, None);
        let mut pass = encoder.begin_compute_pass(&ComputePassDescriptor {
            label: Some("rppm_photon_trace"),
            timestamp_writes: timer.compute_pass(Stage::PhotonTrace),
        });
        groups.bind(&mut pass, pipeline, &self.group);
        pass.dispatch_workgroups(lanes.div_ceil(64), 1, 1);
        drop(pass);
        self.traced.store(photons, Ordering::Relaxed);
        if self.probe.encode_copy(encoder, &self.count) {
            self.probe_photons.store(photons, Ordering::Relaxed);
        }
    }

    /// (photons stored, photons emitted) of the last iteration, waiting for the GPU; none when
    /// no trace was recorded since the last count (pipelines still compiling).
    pub fn read_count(&self, device: &RenderDevice, queue: &RenderQueue) -> Option<(u32, u32)> {
        let emitted = self.traced.swap(0, Ordering::Relaxed);
        let bytes = (emitted > 0).then(|| read_back(device, queue, &self.count))??;
        Some((bytemuck::cast_slice::<u8, u32>(&bytes)[1], emitted))
    }

    /// (photons stored, photons emitted) of an earlier iteration, once its non-blocking
    /// read-back has arrived. The count goes on past the capacity: it is what was wanted.
    pub fn poll_count(&self, device: &RenderDevice) -> Option<(u32, u32)> {
        let bytes = self.probe.poll(device)?;
        let count: &[u32] = bytemuck::cast_slice(&bytes);
        Some((count[1], self.probe_photons.load(Ordering::Relaxed)))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_store_follows_the_counted_stores_and_holds_a_sudden_rise() {
        let worst = 65_536.0 * 15.0;
        let mut fit = StoreFit::default();
        // Nothing counted: the worst case.
        let first = fit.capacity(65_536, worst, 0);
        assert_eq!(first, worst as u32);
        // 1.2 stores per photon: a quarter more with the margin, far under the worst case.
        fit.observe(78_643, 65_536, first);
        assert_eq!(fit.lost, 0);
        let fitted = fit.capacity(65_536, worst, first);
        assert!(
            (1.25 * 78_643.0..1.35 * 78_643.0).contains(&(fitted as f64)),
            "{fitted}"
        );
        // Noise in the count keeps the store; twice the photons grows it.
        fit.observe(76_000, 65_536, fitted);
        assert_eq!(fit.capacity(65_536, worst, fitted), fitted);
        assert!(fit.capacity(131_072, worst, fitted) > 2 * 78_643);
        // A count past the store is lost, counted, and taken at once.
        fit.observe(200_000, 65_536, fitted);
        assert_eq!(fit.lost, 200_000 - fitted);
        let grown = fit.capacity(65_536, worst, fitted);
        assert!(grown >= 250_000, "{grown}");
        // A lower count shrinks the store only after several readings, never past the worst.
        let mut shrinking = fit;
        let mut readings = 0;
        while shrinking.capacity(65_536, worst, grown) == grown {
            shrinking.observe(70_000, 65_536, grown);
            readings += 1;
        }
        assert!(readings > 3, "{readings}");
        assert!(fit.capacity(65_536, 100_000.0, 0) <= 100_000);
        // An iteration that emitted nothing says nothing.
        let before = fit;
        fit.observe(0, 0, 10);
        assert_eq!(fit, before);
    }
}
