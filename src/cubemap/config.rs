//! The deep cubemap's shape: resolution, tiling, binning, its min/max hierarchy, and the
//! uniform block the shaders read (`CubemapParams` in common.wgsl). Pure arithmetic.

use bytemuck::{Pod, Zeroable};

/// Resolution, tiling and binning of a deep cubemap.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, serde::Serialize)]
pub struct CubemapConfig {
    /// Pixels along each face's edge.
    pub resolution: u32,
    /// Pixels along a tile's edge (1, 2 or 4): one list set per tile.
    pub tile_size: u32,
    /// Depth bins per tile.
    pub bins: u32,
}

impl CubemapConfig {
    /// This configuration at the largest resolution (halving down to 16) whose faces fit the
    /// GPU's largest render target and whose tile-list heads fit one buffer binding.
    pub fn fitted(mut self, limit_bytes: u64, max_dimension: u32) -> Self {
        // The largest per-tile buffer: list heads (4 bytes a bin) or bounds (8 bytes).
        let heads = |c: &Self| 6 * (c.grid() as u64).pow(2) * (c.bins as u64 * 4).max(8);
        while self.resolution > 16
            && (heads(&self) > limit_bytes || self.resolution > max_dimension)
        {
            self.resolution /= 2;
        }
        self
    }

    /// Tiles along each face's edge.
    pub fn grid(&self) -> u32 {
        (self.resolution / self.tile_size.max(1)).max(1)
    }

    /// Tiles of all six faces.
    pub fn tiles(&self) -> u32 {
        6 * self.grid() * self.grid()
    }

    /// Levels of the min/max hierarchy, tiles up to one cell per face.
    pub fn levels(&self) -> u32 {
        32 - self.grid().leading_zeros()
    }

    /// First cell of each level in the hierarchy buffer, and the total cell count.
    pub(crate) fn level_offsets(&self) -> ([[u32; 4]; 4], u32) {
        let mut offsets = [[0u32; 4]; 4];
        let mut total = 0;
        for level in 0..self.levels().min(16) {
            offsets[level as usize / 4][level as usize % 4] = total;
            let cells = (self.grid() >> level).max(1);
            total += 6 * cells * cells;
        }
        (offsets, total)
    }
}

/// Triangles that look big from the centre are kept out of the lists and tested by every ray
/// once, at most this many (past it, none is): `BIG_TRIANGLES` and `looks_big` in
/// shaders/common/common.wgsl.
pub const BIG_TRIANGLES: u32 = 128;

/// `CubemapParams` in common.wgsl (112 bytes).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable)]
pub struct CubemapParams {
    pub centre: [f32; 4],
    pub grid: u32,
    pub bins: u32,
    pub node_capacity: u32,
    pub levels: u32,
    pub near: f32,
    pub triangle_count: u32,
    pub _pad: [u32; 2],
    pub level_offsets: [[u32; 4]; 4],
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn hierarchy_levels_reach_one_cell() {
        let c = CubemapConfig {
            resolution: 256,
            tile_size: 2,
            bins: 8,
        };
        assert_eq!(c.grid(), 128);
        assert_eq!(c.levels(), 8);
        let (offsets, total) = c.level_offsets();
        assert_eq!(offsets[0][1], 6 * 128 * 128);
        assert_eq!(total, (0..8).map(|l| 6 * (128u32 >> l).pow(2)).sum::<u32>());
    }
}
