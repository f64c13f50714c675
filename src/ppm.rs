//! The pure maths of progressive photon mapping: the Knaus–Zwicker radius schedule, the
//! per-iteration random numbers and sub-pixel jitter, and the photon store's size. A leaf:
//! nothing here touches Bevy's ECS or the GPU.

/// Knaus–Zwicker: r²ᵢ₊₁ = r²ᵢ (i + α)/(i + 1), with i counted from 1 (`iteration` from 0).
pub fn next_radius2(radius2: f64, iteration: u32, alpha: f32) -> f64 {
    let i = iteration as f64 + 1.0;
    radius2 * (i + alpha as f64) / (i + 1.0)
}

/// r² after `iterations` Knaus–Zwicker steps from `initial`.
pub fn radius2_after(initial: f64, iterations: u32, alpha: f32) -> f64 {
    (0..iterations).fold(initial, |r2, i| next_radius2(r2, i, alpha))
}

/// An iteration's weight in a pixel's running mean: its `photons` over the count the radius
/// is for (`radius_photons`), at most 1; 1 without photons. An iteration of n photons over a
/// radius sized for m estimates with m/n times the variance, and the mean of least variance
/// weighs each by the inverse.
pub(crate) fn photon_weight(photons: u32, radius_photons: u32) -> f32 {
    if photons == 0 || radius_photons == 0 {
        1.0
    } else {
        (photons as f64 / radius_photons as f64).min(1.0) as f32
    }
}

/// A deterministic hash of the iteration, the source of this iteration's random numbers.
pub(crate) fn pcg(v: u32) -> u32 {
    let state = v.wrapping_mul(747_796_405).wrapping_add(2_891_336_453);
    let word = ((state >> ((state >> 28) + 4)) ^ state).wrapping_mul(277_803_737);
    (word >> 22) ^ word
}

/// A uniform number in [0, 1) from the hash chain in `seed`.
pub(crate) fn unit_random(seed: &mut u32) -> f32 {
    *seed = pcg(*seed);
    (*seed >> 8) as f32 / (1u32 << 24) as f32
}

/// Radical inverse in `base`: a low-discrepancy sub-pixel jitter sequence.
pub(crate) fn halton(mut i: u32, base: u32) -> f32 {
    let (mut f, mut r) = (1.0f32, 0.0f32);
    while i > 0 {
        f /= base as f32;
        r += f * (i % base) as f32;
        i /= base;
    }
    r
}

/// Room for the entries a GPU list asked for (cubemap list nodes, stored photons), with a
/// quarter to spare.
pub(crate) fn grown_capacity(used: u32) -> u32 {
    (used as u64 * 5 / 4).min(u32::MAX as u64 / 2) as u32
}

/// Photons a store must hold. A photon is stored at each non-specular hit after its first
/// (direct light is the local stage's), at most `stores` times, and goes on after a hit with
/// probability at most `max_scatter` (the scene's largest albedo), so the store holds the
/// expected Σ pʲ stores per photon plus 4 standard deviations, never more than every photon
/// at every bounce. `direct`: every photon stored once, at its first hit (a debug image).
pub(crate) fn photon_store_capacity(
    photons: u32,
    stores: u32,
    max_scatter: f32,
    direct: bool,
) -> f64 {
    let photons = photons as f64;
    if direct {
        return photons;
    }
    let p = max_scatter as f64;
    let expected: f64 = (1..=stores).map(|j| p.powi(j as i32)).sum();
    let margin = 4.0 * (photons * stores as f64).sqrt() + 1024.0;
    (photons * expected * 1.1 + margin).min(photons * stores as f64)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// r² after n steps behaves as r₀² n^(α−1) / Γ(1+α): the ratio between two far points of
    /// the sequence is (n₂/n₁)^(α−1), with no underflow, NaN or growth on the way.
    #[test]
    fn radius_decay_stays_finite_and_follows_its_power_law_over_1e8_iterations() {
        for alpha in [1e-4_f32, 0.01, 0.7, 0.999, 1.0] {
            let r2_6 = radius2_after(16.0, 1_000_000, alpha);
            let r2_8 = (1_000_000..100_000_000).fold(r2_6, |r2, i| next_radius2(r2, i, alpha));
            for r2 in [r2_6, r2_8] {
                assert!(
                    r2.is_finite() && r2 > 0.0 && r2 <= 16.0,
                    "α {alpha}: r² {r2}"
                );
            }
            let expected = 100f64.powf(alpha as f64 - 1.0);
            let ratio = r2_8 / r2_6;
            assert!(
                (ratio / expected - 1.0).abs() < 1e-4,
                "α {alpha}: r² ratio {ratio} vs {expected}"
            );
        }
    }

    #[test]
    fn radius_keeps_its_size_at_alpha_one() {
        assert_eq!(radius2_after(16.0, 1000, 1.0), 16.0);
        assert_eq!(radius2_after(16.0, 0, 0.7), 16.0);
    }

    #[test]
    fn photons_weigh_a_mean_of_least_variance() {
        // `Auto` probing at 16 384, 32 768, 65 536 and 131 072 photons, four iterations each,
        // under a radius for 262 144, then 54 at 262 144: an iteration of n photons has
        // variance 262 144 / n.
        let counts: Vec<u32> = [16_384, 32_768, 65_536, 131_072]
            .iter()
            .flat_map(|&n| [n; 4])
            .chain([262_144; 54])
            .collect();
        let variance = |weights: &dyn Fn(u32) -> f64| {
            let sum: f64 = counts.iter().map(|&n| weights(n)).sum();
            let spread: f64 = counts
                .iter()
                .map(|&n| weights(n).powi(2) * 262_144.0 / n as f64)
                .sum();
            spread / (sum * sum)
        };
        let equal = variance(&|_| 1.0);
        let weighed = variance(&|n| photon_weight(n, 262_144) as f64);
        // The probe's 16 iterations held two thirds of the equal mean's variance.
        assert!(weighed < 0.5 * equal, "{weighed} vs {equal}");
        assert!((weighed - 1.0 / 57.75).abs() < 1e-9, "{weighed}");
        assert_eq!(photon_weight(0, 262_144), 1.0);
        assert_eq!(photon_weight(131_072, 65_536), 1.0);
    }

    #[test]
    fn halton_fills_the_unit_interval() {
        assert_eq!(halton(1, 2), 0.5);
        assert_eq!(halton(2, 2), 0.25);
        assert!((halton(1, 3) - 1.0 / 3.0).abs() < 1e-7);
        let mut seed = 7;
        for _ in 0..1000 {
            let u = unit_random(&mut seed);
            assert!((0.0..1.0).contains(&u));
        }
    }

    #[test]
    fn photon_store_holds_the_expected_stores_and_never_more_than_all() {
        let all = photon_store_capacity(65_536, 7, 1.0, false);
        assert_eq!(all, 65_536.0 * 7.0);
        let half = photon_store_capacity(65_536, 7, 0.5, false);
        assert!(half > 65_536.0 * 0.99 && half < 65_536.0 * 1.2, "{half}");
        assert_eq!(photon_store_capacity(1000, 7, 0.5, true), 1000.0);
    }
}
