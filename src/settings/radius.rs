//! The gather radius the Knaus–Zwicker sequence starts from.

use bevy::prelude::*;

/// The initial gather radius, in pixels of the camera view.
#[derive(Reflect, Clone, Copy, Debug, PartialEq)]
#[reflect(Default, Clone, PartialEq)]
pub enum InitialRadius {
    /// This many pixels whatever the view and the photon count. Range 0.25..=256.
    Pixels(f32),
    /// As many photons a kernel as this many pixels hold in a 256 × 256 view of 262 144
    /// photons an iteration: `pixels · √(width · height / 256² · 262 144 / photons)`, photons
    /// the most [`crate::PhotonCount`] allows. A kernel's noise is set by the photons it
    /// holds, so a fixed size in pixels held 16 times fewer at 64² or with 16 384 photons,
    /// and blurred a view of 1024² that holds 16 times more. Caustic photons are gathered
    /// over no more than these pixels ([`InitialRadius::caustic_scale`]). Range 0.25..=256,
    /// default 6 (the suite measured at 4, 6 and 8 pixels; the README's *initial radius*
    /// sections).
    PhotonShare(f32),
}

impl Default for InitialRadius {
    fn default() -> Self {
        Self::PhotonShare(6.0)
    }
}

/// The view and photon count [`InitialRadius::PhotonShare`] is given for.
const SHARE_VIEW_PIXELS: f64 = 256.0 * 256.0;
const SHARE_PHOTONS: f64 = 262_144.0;

impl InitialRadius {
    /// The radius in pixels for a view of `size` and `photons` an iteration, at most a quarter
    /// of the view's larger side (wider blurs it all and makes every splat cover it).
    pub fn pixels(self, size: UVec2, photons: u32) -> f32 {
        let largest = (size.x.max(size.y) as f32 / 4.0).max(0.25);
        let radius = match self {
            Self::Pixels(pixels) => pixels,
            Self::PhotonShare(pixels) => {
                let view = size.x as f64 * size.y as f64;
                let photons = photons.max(1) as f64;
                (pixels as f64 * (view / SHARE_VIEW_PIXELS * SHARE_PHOTONS / photons).sqrt()) as f32
            }
        };
        radius.clamp(0.25, largest)
    }

    /// The share of the radius caustic photons (light that met only mirrors, glass and
    /// smooth metal since it left its source) are gathered over, in (0, 1]: a photon share
    /// grows past its pixels for them no further. Their density has detail a wide disc blurs
    /// away, as Jensen's caustic map has a smaller radius than his global one; a still
    /// estimate's radius shrinks over its iterations, but a moving one keeps its window's.
    /// The `pool` example (1280 × 720, 131 072 photons) gathered its caustics over 32 pixels
    /// and showed none.
    pub fn caustic_scale(self, size: UVec2, photons: u32) -> f32 {
        let pixels = self.pixels(size, photons);
        match self {
            Self::Pixels(_) => 1.0,
            Self::PhotonShare(share) => (share.max(0.25) / pixels).min(1.0),
        }
    }

    /// The value it is given in, in pixels.
    pub(crate) fn value_mut(&mut self) -> &mut f32 {
        match self {
            Self::Pixels(pixels) | Self::PhotonShare(pixels) => pixels,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_photon_share_holds_as_many_photons_at_any_view_and_count() {
        let share = InitialRadius::PhotonShare(6.0);
        assert_eq!(share.pixels(UVec2::splat(256), 262_144), 6.0);
        // A quarter of the pixels: half the radius.
        assert_eq!(share.pixels(UVec2::splat(128), 262_144), 3.0);
        // A sixteenth of the photons: four times the radius.
        assert_eq!(share.pixels(UVec2::splat(256), 16_384), 24.0);
        assert_eq!(share.pixels(UVec2::splat(64), 16_384), 6.0);
        // Photons in the disc: radius² / (view / photons) the same in all.
        let held = |size: UVec2, photons: u32| {
            let r = share.pixels(size, photons) as f64;
            r * r * photons as f64 / (size.x as f64 * size.y as f64)
        };
        let at_256 = held(UVec2::splat(256), 262_144);
        let wide = held(UVec2::new(1280, 720), 1 << 20);
        assert!((wide / at_256 - 1.0).abs() < 1e-6, "{wide} vs {at_256}");
    }

    #[test]
    fn caustics_take_no_share_wider_than_its_pixels() {
        let share = InitialRadius::PhotonShare(6.0);
        // Few photons a pixel: the share's 31.8 pixels, 6 for caustics.
        let example = UVec2::new(1280, 720);
        let pixels = share.pixels(example, 131_072);
        assert!(pixels > 31.0);
        let caustic = pixels * share.caustic_scale(example, 131_072);
        assert!((caustic - 6.0).abs() < 1e-4, "{caustic}");
        // Many: the share, smaller, for both.
        assert_eq!(share.caustic_scale(UVec2::splat(128), 262_144), 1.0);
        // A fixed radius is kept.
        assert_eq!(
            InitialRadius::Pixels(12.0).caustic_scale(example, 1024),
            1.0
        );
    }

    #[test]
    fn the_radius_stays_within_a_quarter_of_the_view() {
        let share = InitialRadius::PhotonShare(6.0);
        assert_eq!(share.pixels(UVec2::splat(64), 1), 16.0);
        assert_eq!(share.pixels(UVec2::splat(256), 0), 64.0);
        assert_eq!(
            InitialRadius::Pixels(100.0).pixels(UVec2::new(40, 8), 1000),
            10.0
        );
        assert_eq!(
            InitialRadius::Pixels(4.0).pixels(UVec2::splat(1024), 16),
            4.0
        );
        // Never below a quarter pixel, even in a view of one pixel or none.
        assert_eq!(share.pixels(UVec2::ZERO, 262_144), 0.25);
        assert_eq!(InitialRadius::Pixels(0.01).pixels(UVec2::ONE, 1), 0.25);
    }
}
