//! The hierarchy as the GPU walks it: two float textures (`bvh_nodes`, `bvh_triangles` in
//! shaders/cubemap/trace.wgsl) rather than storage buffers. llvmpipe fetches a texel for all
//! lanes of a SIMD group at once but reads a storage buffer one lane and one load at a time;
//! the walk is nearly all reads, and a texture made it about 3x cheaper there.

use bevy::render::render_resource::*;
use bevy::render::renderer::{RenderDevice, RenderQueue};

use super::build::{BvhNode, INNER};

/// Texels a row of a texture read as a flat array (`row_texel` in common.wgsl: 1 << 12).
pub const TEXELS_WIDE: u32 = 1 << 12;

/// A texture of `count` RGBA32 float texels in rows of [`TEXELS_WIDE`], and its view.
pub(super) fn texels_texture(
    device: &RenderDevice,
    label: &'static str,
    count: u32,
    usage: TextureUsages,
) -> (Texture, TextureView) {
    let texture = device.create_texture(&TextureDescriptor {
        label: Some(label),
        size: extent(count),
        mip_level_count: 1,
        sample_count: 1,
        dimension: TextureDimension::D2,
        format: TextureFormat::Rgba32Float,
        usage: usage | TextureUsages::TEXTURE_BINDING,
        view_formats: &[],
    });
    let view = texture.create_view(&TextureViewDescriptor::default());
    (texture, view)
}

fn extent(count: u32) -> Extent3d {
    Extent3d {
        width: count.clamp(1, TEXELS_WIDE),
        height: count.div_ceil(TEXELS_WIDE).max(1),
        depth_or_array_layers: 1,
    }
}

/// Whether a hierarchy over `triangles` fits textures of this device: at most 2n − 1 nodes
/// of 2 texels, and 3 texels a triangle.
pub fn fits(device: &RenderDevice, triangles: u32) -> bool {
    let rows = (4 * triangles as u64).div_ceil(TEXELS_WIDE as u64);
    rows <= device.limits().max_texture_dimension_2d as u64
}

/// Node `i` as texels 2i, 2i + 1: (min, first), (max, count), count −1 for an inner node.
pub fn node_texels(nodes: &[BvhNode]) -> Vec<[f32; 4]> {
    nodes
        .iter()
        .flat_map(|n| {
            let count = if n.count == INNER {
                -1.0
            } else {
                n.count as f32
            };
            [
                [n.min[0], n.min[1], n.min[2], n.first as f32],
                [n.max[0], n.max[1], n.max[2], count],
            ]
        })
        .collect()
}

/// Writes `texels` from texel `start` on, a row's part at a time.
pub(super) fn write_texels(
    queue: &RenderQueue,
    texture: &Texture,
    start: u32,
    texels: &[[f32; 4]],
) -> u64 {
    let width = texture.width();
    let mut at = start;
    let mut rest = texels;
    while !rest.is_empty() {
        let (x, y) = (at % width, at / width);
        let n = rest.len().min((width - x) as usize);
        queue.write_texture(
            TexelCopyTextureInfo {
                texture,
                mip_level: 0,
                origin: Origin3d { x, y, z: 0 },
                aspect: TextureAspect::All,
            },
            bytemuck::cast_slice(&rest[..n]),
            TexelCopyBufferLayout {
                offset: 0,
                bytes_per_row: Some(16 * n as u32),
                rows_per_image: None,
            },
            Extent3d {
                width: n as u32,
                height: 1,
                depth_or_array_layers: 1,
            },
        );
        at += n as u32;
        rest = &rest[n..];
    }
    16 * texels.len() as u64
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn nodes_become_two_texels_with_exact_links() {
        let inner = BvhNode {
            min: [0.0, 1.0, 2.0],
            first: 1,
            max: [3.0, 4.0, 5.0],
            count: INNER,
        };
        let leaf = BvhNode {
            first: (1 << 24) - 1,
            count: 4,
            ..inner
        };
        let t = node_texels(&[inner, leaf]);
        assert_eq!(t[0], [0.0, 1.0, 2.0, 1.0]);
        assert_eq!(t[1], [3.0, 4.0, 5.0, -1.0]);
        assert_eq!(t[2][3] as u32, (1 << 24) - 1);
        assert_eq!(t[3][3], 4.0);
        assert_eq!(extent(1).width, 1);
        assert_eq!(extent(TEXELS_WIDE + 1).height, 2);
    }
}
