//! Material textures for the tracing stages: each image a material uses, box-filtered down to
//! at most [`MAX_TEXTURE_SIZE`] texels a side with its whole mip chain, as RGBA8 texels in
//! one storage buffer that every stage reads the same way (compute and raster, llvmpipe and
//! GPUs alike: no bindless arrays, no sampler limits). `shaders/scene/scene.wgsl` samples it.

use std::sync::OnceLock;

use bevy::color::ColorToComponents;
use bevy::image::{Image, ImageAddressMode, ImageFilterMode, ImageSampler, ImageSamplerDescriptor};
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
    /// [`TextureSampler::bits`]: how the texture is read (0: repeating, bilinear).
    pub sampler: u32,
    pub _pad: [u32; 2],
}

/// How a coordinate outside [0, 1] reads the texture (glTF's wrap modes).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Wrap {
    #[default]
    Repeat = 0,
    /// The edge texel (`ClampToEdge`; `ClampToBorder` too, whose border colour is left out).
    Clamp = 1,
    /// Repeated, every other copy mirrored.
    Mirror = 2,
}

impl Wrap {
    fn of(mode: ImageAddressMode) -> Self {
        match mode {
            ImageAddressMode::Repeat => Self::Repeat,
            ImageAddressMode::MirrorRepeat => Self::Mirror,
            ImageAddressMode::ClampToEdge | ImageAddressMode::ClampToBorder => Self::Clamp,
        }
    }

    /// `t` brought into [0, 1] (`wrap_uv` in scene.wgsl).
    pub fn apply(self, t: f32) -> f32 {
        match self {
            Self::Repeat => t - t.floor(),
            Self::Clamp => t.clamp(0.0, 1.0),
            Self::Mirror => {
                let m = t - 2.0 * (0.5 * t).floor();
                if m > 1.0 { 2.0 - m } else { m }
            }
        }
    }
}

/// How an image is read: its sampler's wrap modes and whether it magnifies or minifies to the
/// nearest texel (pixel art) instead of blending four. Mip levels are always box-filtered.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct TextureSampler {
    /// Along u, then v.
    pub wrap: [Wrap; 2],
    pub nearest_magnification: bool,
    pub nearest_minification: bool,
}

impl TextureSampler {
    /// `image`'s sampler, or `default` (the `ImagePlugin`'s) where it names none.
    pub fn of(image: &Image, default: &ImageSamplerDescriptor) -> Self {
        let d = match &image.sampler {
            ImageSampler::Default => default,
            ImageSampler::Descriptor(d) => d,
        };
        Self {
            wrap: [Wrap::of(d.address_mode_u), Wrap::of(d.address_mode_v)],
            nearest_magnification: d.mag_filter == ImageFilterMode::Nearest,
            nearest_minification: d.min_filter == ImageFilterMode::Nearest,
        }
    }

    /// Wrap along u in bits 0–1, along v in 2–3, nearest magnification in bit 4 and
    /// minification in 5 (`SAMPLER_*` in scene.wgsl).
    pub fn bits(self) -> u32 {
        self.wrap[0] as u32
            | (self.wrap[1] as u32) << 2
            | (self.nearest_magnification as u32) << 4
            | (self.nearest_minification as u32) << 5
    }
}

/// An image, downsampled, with its mip chain: RGBA8 texels packed in u32 (r in the low byte).
#[derive(Clone, Debug, PartialEq)]
pub struct PackedTexture {
    pub width: u32,
    pub height: u32,
    pub srgb: bool,
    /// Level 0 then every smaller level down to 1×1.
    pub texels: Vec<u32>,
    pub sampler: TextureSampler,
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
            sampler: TextureSampler::default(),
        })
    }

    /// Mip levels, down to 1×1.
    pub fn levels(&self) -> u32 {
        32 - self.width.max(self.height).leading_zeros()
    }

    /// Lookup at `uv` in level 0 by the sampler (magnifying), in linear values: the CPU twin
    /// of `sample_texture` in scene.wgsl, for emitter powers.
    pub fn sample(&self, uv: Vec2) -> Vec4 {
        let size = Vec2::new(self.width as f32, self.height as f32);
        let [wrap_u, wrap_v] = self.sampler.wrap;
        let at = Vec2::new(wrap_u.apply(uv.x), wrap_v.apply(uv.y)) * size;
        // A neighbour past the edge: the far edge's texel when repeating, else the edge's.
        let index = |t: f32, n: f32, wrap: Wrap| match wrap {
            Wrap::Repeat => t.rem_euclid(n),
            _ => t.clamp(0.0, n - 1.0),
        } as u32;
        let texel = |x: f32, y: f32| {
            let (x, y) = (index(x, size.x, wrap_u), index(y, size.y, wrap_v));
            self.decode(self.texels[(y * self.width + x) as usize])
        };
        if self.sampler.nearest_magnification {
            return texel(at.x.floor(), at.y.floor());
        }
        let p = at - 0.5;
        let i = p.floor();
        let f = p - i;
        let texel = |dx: f32, dy: f32| texel(i.x + dx, i.y + dy);
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
            sampler: self.sampler.bits(),
            _pad: [0; 2],
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
    fn wrap_modes_bring_coordinates_into_the_unit_interval() {
        for (t, repeat, clamp, mirror) in [
            (0.25, 0.25, 0.25, 0.25),
            (-0.25, 0.75, 0.0, 0.25),
            (1.25, 0.25, 1.0, 0.75),
            (2.25, 0.25, 1.0, 0.25),
            (-1.25, 0.75, 0.0, 0.75),
        ] {
            assert!((Wrap::Repeat.apply(t) - repeat).abs() < 1e-6, "repeat {t}");
            assert!((Wrap::Clamp.apply(t) - clamp).abs() < 1e-6, "clamp {t}");
            assert!((Wrap::Mirror.apply(t) - mirror).abs() < 1e-6, "mirror {t}");
        }
    }

    #[test]
    fn samplers_clamp_mirror_and_pick_the_nearest_texel() {
        // A 4×1 ramp 0, 1/3, 2/3, 1 (linear values).
        let ramp = image(4, 1, TextureFormat::Rgba8Unorm, |x, _| {
            [(x * 85) as u8, 0, 0, 255]
        });
        let mut packed = PackedTexture::from_image(&ramp, 1024).unwrap();
        let red = |p: &PackedTexture, u: f32| p.sample(Vec2::new(u, 0.5)).x;
        // Repeating: past the right edge blends the last texel with the first.
        assert!((red(&packed, 1.0) - 0.5).abs() < 0.01);
        packed.sampler.wrap = [Wrap::Clamp; 2];
        assert!((red(&packed, 1.0) - 1.0).abs() < 0.01);
        assert!((red(&packed, 7.0) - 1.0).abs() < 0.01);
        assert!(red(&packed, -3.0).abs() < 0.01);
        packed.sampler.wrap = [Wrap::Mirror; 2];
        // 1.125 mirrors to 0.875, the last texel's centre.
        assert!((red(&packed, 1.125) - 1.0).abs() < 0.01);
        assert!((red(&packed, 1.875) - 0.0).abs() < 0.01);
        packed.sampler.nearest_magnification = true;
        // 0.49 lies in the second texel: no blend with the third.
        assert!((red(&packed, 0.49) - 1.0 / 3.0).abs() < 0.01);
        let default = ImageSamplerDescriptor::linear();
        assert_eq!(
            TextureSampler::of(&ramp, &default).bits(),
            Wrap::Clamp as u32 * 5
        );
        let mut nearest = ramp.clone();
        nearest.sampler = ImageSampler::Descriptor(ImageSamplerDescriptor {
            address_mode_u: ImageAddressMode::MirrorRepeat,
            address_mode_v: ImageAddressMode::Repeat,
            ..ImageSamplerDescriptor::nearest()
        });
        assert_eq!(TextureSampler::of(&nearest, &default).bits(), 2 | 16 | 32);
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
