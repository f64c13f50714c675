//! Image files and the metrics of `shared/docs/CONVENTIONS.md`: raw linear EXR, tonemapped PNG
//! previews, relMSE, energy ratio and bad pixels.

use std::path::Path;

/// A linear RGB float image, row-major from the top-left.
#[derive(Clone, Debug, PartialEq)]
pub struct RgbImage {
    pub width: usize,
    pub height: usize,
    pub pixels: Vec<[f32; 3]>,
}

impl RgbImage {
    pub fn from_rgba(width: u32, height: u32, rgba: &[[f32; 4]]) -> Self {
        Self {
            width: width as usize,
            height: height as usize,
            pixels: rgba.iter().map(|p| [p[0], p[1], p[2]]).collect(),
        }
    }

    pub fn at(&self, x: usize, y: usize) -> [f32; 3] {
        self.pixels[y * self.width + x]
    }

    /// Mean of every channel of every pixel.
    pub fn mean(&self) -> f64 {
        let sum: f64 = self.pixels.iter().flatten().map(|&v| v as f64).sum();
        sum / (3 * self.pixels.len()).max(1) as f64
    }
}

/// Writes raw radiance as 32-bit float RGB OpenEXR.
pub fn write_exr(path: &Path, image: &RgbImage) -> Result<(), String> {
    exr::prelude::write_rgb_file(path, image.width, image.height, |x, y| {
        let [r, g, b] = image.at(x, y);
        (r, g, b)
    })
    .map_err(|e| format!("cannot write {}: {e}", path.display()))
}

/// Reads the first RGB(A) layer of an OpenEXR file.
pub fn read_exr(path: &Path) -> Result<RgbImage, String> {
    let image = exr::prelude::read_first_rgba_layer_from_file(
        path,
        |size, _| RgbImage {
            width: size.0,
            height: size.1,
            pixels: vec![[0.0; 3]; size.0 * size.1],
        },
        |image: &mut RgbImage, pos, (r, g, b, _a): (f32, f32, f32, f32)| {
            let w = image.width;
            image.pixels[pos.1 * w + pos.0] = [r, g, b];
        },
    )
    .map_err(|e| format!("cannot read {}: {e}", path.display()))?;
    Ok(image.layer_data.channel_data.pixels)
}

/// Luminance-preserving Reinhard, then the sRGB transfer curve; for people, never for metrics.
pub fn tonemap_srgb8(rgb: [f32; 3]) -> [u8; 3] {
    let l = 0.2126 * rgb[0] + 0.7152 * rgb[1] + 0.0722 * rgb[2];
    let scale = if l.is_finite() && l > 0.0 {
        1.0 / (1.0 + l)
    } else {
        0.0
    };
    rgb.map(|c| {
        let v = (c * scale).clamp(0.0, 1.0);
        let s = if v <= 0.003_130_8 {
            12.92 * v
        } else {
            1.055 * v.powf(1.0 / 2.4) - 0.055
        };
        (s * 255.0 + 0.5) as u8
    })
}

/// Writes a tonemapped 8-bit sRGB PNG preview.
pub fn write_png(path: &Path, image: &RgbImage) -> Result<(), String> {
    let bytes: Vec<u8> = image
        .pixels
        .iter()
        .flat_map(|&p| tonemap_srgb8(p))
        .collect();
    write_rgb8_png(path, image.width as u32, image.height as u32, &bytes)
}

/// Writes 8-bit RGB rows as a PNG.
pub fn write_rgb8_png(path: &Path, width: u32, height: u32, rgb: &[u8]) -> Result<(), String> {
    let err = |e: &dyn std::fmt::Display| format!("cannot write {}: {e}", path.display());
    let file = std::fs::File::create(path).map_err(|e| err(&e))?;
    let mut encoder = png::Encoder::new(std::io::BufWriter::new(file), width, height);
    encoder.set_color(png::ColorType::Rgb);
    encoder.set_depth(png::BitDepth::Eight);
    let mut writer = encoder.write_header().map_err(|e| err(&e))?;
    writer.write_image_data(rgb).map_err(|e| err(&e))
}

/// mean((t − r)² / (r² + 0.01)) over all pixels and channels.
pub fn relmse(test: &RgbImage, reference: &RgbImage) -> Result<f64, String> {
    let errors = pixel_errors(test, reference)?;
    Ok(errors.iter().sum::<f64>() / errors.len().max(1) as f64)
}

/// Each pixel's relative squared error, its channels' mean: the relMSE is their mean.
pub fn pixel_errors(test: &RgbImage, reference: &RgbImage) -> Result<Vec<f64>, String> {
    same_size(test, reference)?;
    Ok(test
        .pixels
        .iter()
        .zip(&reference.pixels)
        .map(|(t, r)| {
            (0..3)
                .map(|c| relative_error(t[c] as f64, r[c] as f64))
                .sum::<f64>()
                / 3.0
        })
        .collect())
}

/// One channel's (t − r)² / (r² + 0.01), whose mean is the relMSE.
pub fn relative_error(t: f64, r: f64) -> f64 {
    (t - r).powi(2) / (r * r + 0.01)
}

/// mean(t) / mean(r).
pub fn energy_ratio(test: &RgbImage, reference: &RgbImage) -> Result<f64, String> {
    same_size(test, reference)?;
    Ok(test.mean() / reference.mean())
}

/// Count of NaN or infinite channel values.
pub fn bad_pixels(image: &RgbImage) -> usize {
    image
        .pixels
        .iter()
        .flatten()
        .filter(|v| !v.is_finite())
        .count()
}

/// Both images have the same size.
pub fn same_size(a: &RgbImage, b: &RgbImage) -> Result<(), String> {
    if (a.width, a.height) != (b.width, b.height) {
        return Err(format!(
            "image sizes differ: {}x{} against {}x{}",
            a.width, a.height, b.width, b.height
        ));
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn exr_round_trip_and_metrics() {
        let image = RgbImage {
            width: 3,
            height: 2,
            pixels: (0..6).map(|i| [i as f32, 0.5, 1e-3 * i as f32]).collect(),
        };
        let path = std::env::temp_dir().join(format!("rppm_io_{}.exr", std::process::id()));
        write_exr(&path, &image).unwrap();
        let back = read_exr(&path).unwrap();
        std::fs::remove_file(&path).ok();
        assert_eq!(back, image);
        assert_eq!(relmse(&image, &back).unwrap(), 0.0);
        assert_eq!(energy_ratio(&image, &back).unwrap(), 1.0);
        let mut doubled = image.clone();
        doubled.pixels.iter_mut().flatten().for_each(|v| *v *= 2.0);
        assert!((energy_ratio(&doubled, &image).unwrap() - 2.0).abs() < 1e-9);
        doubled.pixels[0][0] = f32::NAN;
        assert_eq!(bad_pixels(&doubled), 1);
    }

    #[test]
    fn tonemap_is_monotone_and_bounded() {
        assert_eq!(tonemap_srgb8([0.0; 3]), [0, 0, 0]);
        assert_eq!(tonemap_srgb8([f32::NAN; 3]), [0, 0, 0]);
        let a = tonemap_srgb8([0.5; 3])[0];
        let b = tonemap_srgb8([5.0; 3])[0];
        assert!(a < b && b < 255);
    }
}
