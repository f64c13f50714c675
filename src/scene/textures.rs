//! Material textures for the tracing stages: each image a material uses, box-filtered down to
//! at most [`MAX_TEXTURE_SIZE`] texels a side with its whole mip chain, as RGBA8 texels in
//! one storage buffer that every stage reads the same way (compute and raster, llvmpipe and
//! GPUs alike: no bindless arrays, no sampler limits). `shaders/scene/scene.wgsl` samples it.

use std::sync::OnceLock;

use bevy::color::ColorToComponents;
use bevy::image::Image;
use bevy::math::{Vec2, Vec4};
use bevy::render::render_resource::TextureFormat;
use bytemuck::{Pod, Zeroable};

/// Largest side of a packed texture (texels): photon and camera-path lookups need far less
/// than a 4K source, and the camera's first hit sees the scene at its own resolution.
pub const MAX_TEXTURE_SIZE: u32 = 1024;

/// Bytes of texels a scene may hold; larger sets are packed again at half the size, so one
/// binding stays well inside llvmpipe's 128 MiB limit.
pub const TEXEL_BUDGET: u64 = 64 << 20;

/// A texture slot left empty in [`super::GpuMaterial::textures`].
pub const NO_TEXTURE: u32 = u32::MAX;

/// Where a packed texture lies in the texel buffer (32 bytes).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct GpuTexture {
    /// First texel of level 0; level l+1 follows level l.
    pub offset: u32,
    pub width: u32,
    pub height: u32,
    pub levels: u32,
    /// 1: texels hold sRGB-encoded colour (decoded to linear when sampled).
    pub srgb: u32,
    pub _pad: [u32; 3],
}

/// An image, downsampled, with its mip chain: RGBA8 texels packed in u32 (r in the low byte).
#[derive(Clone, Debug, PartialEq)]
pub struct PackedTexture {
    pub width: u32,
    pub height: u32,
    pub srgb: bool,
    /// Level 0 then every smaller level down to 1×1.
    pub texels: Vec<u32>,
}

impl PackedTexture {
    /// Packs `image`, halving it until no side exceeds `max_size`. Fails on images without
    /// CPU data (render-world only) or in a format that has no per-texel colour read.
    pub fn from_image(image: &Image, max_size: u32) -> Result<Self, String> {
        let (width, height) = (image.width(), image.height());
        if width == 0 || height == 0 || image.texture_descriptor.size.depth_or_array_layers != 1 {
            return Err(format!(
                "a {width}×{height}×{} image is not a 2D texture",
                image.texture_descriptor.size.depth_or_array_layers
            ));
        }
        let format = image.texture_descriptor.format;
        let srgb = format.is_srgb();
        let Some(data) = image.data.as_ref() else {
            return Err("its texels are not kept in the main world (RenderAssetUsages)".into());
        };
        let texels: Vec<u32> = match format {
            TextureFormat::Rgba8Unorm | TextureFormat::Rgba8UnormSrgb
                if data.len() as u64 >= 4 * width as u64 * height as u64 =>
            {
                data.chunks_exact(4)
                    .take((width * height) as usize)
                    .map(|c| u32::from_le_bytes([c[0], c[1], c[2], c[3]]))
                    .collect()
            }
            _ => {
                let mut out = Vec::with_capacity((width * height) as usize);
                for y in 0..height {
                    for x in 0..width {
                        let c = image
                            .get_color_at(x, y)
                            .map_err(|e| format!("format {format:?} cannot be read: {e}"))?;
                        out.push(if srgb {
                            pack(c.to_srgba().to_f32_array())
                        } else {
                            pack(c.to_linear().to_f32_array())
                        });
                    }
                }
                out
            }
        };
        let mut level = Level {
            width,
            height,
            texels,
        };
        while level.width > max_size.max(1) || level.height > max_size.max(1) {
            level = level.half(srgb);
        }
        let (width, height) = (level.width, level.height);
        let mut all = level.texels.clone();
        while level.width > 1 || level.height > 1 {
            level = level.half(srgb);
            all.extend_from_slice(&level.texels);
        }
        Ok(Self {
            width,
            height,
            srgb,
            texels: all,
        })
    }

    /// Mip levels, down to 1×1.
    pub fn levels(&self) -> u32 {
        32 - self.width.max(self.height).leading_zeros()
    }

    /// Bilinear lookup at `uv` (repeating) in level 0, in linear values: the CPU twin of
    /// `sample_texture` in scene.wgsl, for emitter powers.
    pub fn sample(&self, uv: Vec2) -> Vec4 {
        let size = Vec2::new(self.width as f32, self.height as f32);
        let p = (uv - uv.floor()) * size - 0.5;
        let i = p.floor();
        let f = p - i;
        let texel = |dx: f32, dy: f32| {
            let x = (i.x + dx).rem_euclid(size.x) as u32;
            let y = (i.y + dy).rem_euclid(size.y) as u32;
            self.decode(self.texels[(y * self.width + x) as usize])
        };
        let top = texel(0.0, 0.0).lerp(texel(1.0, 0.0), f.x);
        let bottom = texel(0.0, 1.0).lerp(texel(1.0, 1.0), f.x);
        top.lerp(bottom, f.y)
    }

    fn decode(&self, texel: u32) -> Vec4 {
        let b = texel.to_le_bytes();
        let c = |v: u8| {
            if self.srgb {
                srgb_to_linear(v)
            } else {
                v as f32 / 255.0
            }
        };
        Vec4::new(c(b[0]), c(b[1]), c(b[2]), b[3] as f32 / 255.0)
    }

    /// Index of the first texel of level `level`.
    pub fn level_start(&self, level: u32) -> usize {
        (0..level)
            .map(|l| ((self.width >> l).max(1) * (self.height >> l).max(1)) as usize)
            .sum()
    }

    /// Its entry in a texel buffer starting at `offset` that holds it from level `first`.
    pub fn gpu(&self, offset: u32, first: u32) -> GpuTexture {
        GpuTexture {
            offset,
            width: (self.width >> first).max(1),
            height: (self.height >> first).max(1),
            levels: self.levels() - first,
            srgb: self.srgb as u32,
            _pad: [0; 3],
        }
    }
}

struct Level {
    width: u32,
    height: u32,
    texels: Vec<u32>,
}

impl Level {
    /// The next level: each texel the mean of up to 2×2 (averaged in linear light for sRGB).
    fn half(&self, srgb: bool) -> Level {
        let (w, h) = ((self.width / 2).max(1), (self.height / 2).max(1));
        let mut texels = Vec::with_capacity((w * h) as usize);
        for y in 0..h {
            for x in 0..w {
                let mut sum = [0.0f32; 4];
                let xs = [(2 * x).min(self.width - 1), (2 * x + 1).min(self.width - 1)];
                let ys = [
                    (2 * y).min(self.height - 1),
                    (2 * y + 1).min(self.height - 1),
                ];
                for sy in ys {
                    for sx in xs {
                        let b = self.texels[(sy * self.width + sx) as usize].to_le_bytes();
                        for k in 0..4 {
                            sum[k] += if srgb && k < 3 {
                                srgb_to_linear(b[k])
                            } else {
                                b[k] as f32 / 255.0
                            };
                        }
                    }
                }
                let mean = sum.map(|s| s / 4.0);
                texels.push(if srgb {
                    pack([
                        linear_to_srgb(mean[0]),
                        linear_to_srgb(mean[1]),
                        linear_to_srgb(mean[2]),
                        mean[3],
                    ])
                } else {
                    pack(mean)
                });
            }
        }
        Level {
            width: w,
            height: h,
            texels,
        }
    }
}

fn pack(c: [f32; 4]) -> u32 {
    let q = c.map(|v| (v.clamp(0.0, 1.0) * 255.0).round() as u8);
    u32::from_le_bytes(q)
}

fn srgb_to_linear(v: u8) -> f32 {
    static TABLE: OnceLock<[f32; 256]> = OnceLock::new();
    TABLE.get_or_init(|| {
        std::array::from_fn(|i| {
            let c = i as f32 / 255.0;
            if c <= 0.04045 {
                c / 12.92
            } else {
                ((c + 0.055) / 1.055).powf(2.4)
            }
        })
    })[v as usize]
}

fn linear_to_srgb(c: f32) -> f32 {
    if c <= 0.003_130_8 {
        c * 12.92
    } else {
        1.055 * c.powf(1.0 / 2.4) - 0.055
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use bevy::asset::RenderAssetUsages;
    use bevy::render::render_resource::{Extent3d, TextureDimension};

    fn image(
        width: u32,
        height: u32,
        format: TextureFormat,
        texel: impl Fn(u32, u32) -> [u8; 4],
    ) -> Image {
        let mut data = Vec::new();
        for y in 0..height {
            for x in 0..width {
                data.extend_from_slice(&texel(x, y));
            }
        }
        Image::new(
            Extent3d {
                width,
                height,
                depth_or_array_layers: 1,
            },
            TextureDimension::D2,
            data,
            format,
            RenderAssetUsages::all(),
        )
    }

    #[test]
    fn mip_chain_keeps_the_mean_in_linear_light() {
        // A black and white checker in sRGB: its mean is linear 0.5, not sRGB 0.5.
        let checker = image(8, 4, TextureFormat::Rgba8UnormSrgb, |x, y| {
            let v = if (x + y) % 2 == 0 { 255 } else { 0 };
            [v, v, v, 255]
        });
        let packed = PackedTexture::from_image(&checker, 1024).unwrap();
        assert_eq!((packed.width, packed.height, packed.levels()), (8, 4, 4));
        assert_eq!(packed.texels.len(), 32 + 8 + 2 + 1);
        let last = packed.decode(*packed.texels.last().unwrap());
        assert!((last.x - 0.5).abs() < 0.01, "{last}");
        assert_eq!(last.w, 1.0);
    }

    #[test]
    fn large_images_are_halved_to_the_cap_and_linear_formats_stay_linear() {
        let grey = image(64, 16, TextureFormat::Rgba8Unorm, |_, _| [128, 64, 0, 255]);
        let packed = PackedTexture::from_image(&grey, 16).unwrap();
        assert_eq!((packed.width, packed.height, packed.srgb), (16, 4, false));
        let s = packed.sample(Vec2::new(3.3, -0.7));
        assert!((s.x - 128.0 / 255.0).abs() < 1e-3 && (s.y - 64.0 / 255.0).abs() < 1e-3);
    }

    #[test]
    fn bilinear_lookup_repeats_across_the_edge() {
        // Two texels, 0 and 1: at u = 0 (the edge) the lookup mixes both halves equally.
        let ramp = image(2, 1, TextureFormat::Rgba8Unorm, |x, _| {
            let v = (x * 255) as u8;
            [v, v, v, 255]
        });
        let packed = PackedTexture::from_image(&ramp, 1024).unwrap();
        assert!((packed.sample(Vec2::new(0.0, 0.5)).x - 0.5).abs() < 1e-3);
        assert!((packed.sample(Vec2::new(0.75, 0.5)).x - 1.0).abs() < 1e-3);
        assert!((packed.sample(Vec2::new(1.25, 0.5)).x - 0.0).abs() < 1e-3);
    }

    #[test]
    fn images_without_data_are_refused() {
        let mut empty = image(2, 2, TextureFormat::Rgba8Unorm, |_, _| [0; 4]);
        empty.data = None;
        assert!(PackedTexture::from_image(&empty, 1024).is_err());
    }
}
