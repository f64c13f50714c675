//! The GGX lobe's directional albedo, tabulated for the BSDF's energy compensation
//! (`shaders/common/microfacet.wgsl`): pure maths, computed once and bound with the scene.
//!
//! With Schlick's Fresnel the single-scattering lobe reflects `F0·A(μ, r) + F90·B(μ, r)` of
//! the light arriving at cosine μ, at perceptual roughness r (Karis's split sum; Bevy's
//! `F_AB`). The shader uses it twice: what single scattering loses, `1 − E` with `E = A + B`,
//! comes back through Kulla and Conty's multiple-scattering lobe, and the diffuse lobe gets
//! only what the specular layer leaves, scaled so the pair is reciprocal (Kelemen and
//! Szirmay-Kalos): `(1 − S(μo)) (1 − S(μi)) / (1 − S_avg)`.

use std::sync::OnceLock;

/// Table cells along each axis: cosines at cell centres `(i + ½) / SIZE`, perceptual
/// roughness at nodes `j / (SIZE − 1)`.
pub const SIZE: usize = 32;
/// Quasi-random samples per cell.
const SAMPLES: u32 = 2048;
/// Below this perceptual roughness the lobe is a mirror (`DELTA_ROUGHNESS` in common.wgsl).
pub const DELTA_ROUGHNESS: f32 = 0.02;
/// Photons are stored at glossy surfaces at least this rough; camera paths go on through
/// smoother ones (`GLOSSY_STORE_ROUGHNESS` in bsdf.wgsl, which says why 0.5).
pub const GLOSSY_STORE_ROUGHNESS: f32 = 0.5;

/// `SIZE²` cells `(A, B, 0, 0)`, row by row of roughness, then `SIZE` row averages
/// `2∫·μ dμ` of `(A, B, 0, 0)`: what the shader binds as `ggx_albedo`.
pub fn ggx_albedo_table() -> &'static [[f32; 4]] {
    static TABLE: OnceLock<Vec<[f32; 4]>> = OnceLock::new();
    TABLE.get_or_init(|| {
        let mut cells = Vec::with_capacity(SIZE * SIZE + SIZE);
        let mut averages = Vec::with_capacity(SIZE);
        for j in 0..SIZE {
            let roughness = (j as f32 / (SIZE - 1) as f32).max(DELTA_ROUGHNESS);
            let mut average = [0.0f32; 4];
            for i in 0..SIZE {
                let mu = (i as f32 + 0.5) / SIZE as f32;
                let (a, b) = directional_albedo(roughness, mu);
                cells.push([a, b, 0.0, 0.0]);
                average[0] += 2.0 * a * mu / SIZE as f32;
                average[1] += 2.0 * b * mu / SIZE as f32;
            }
            averages.push(average);
        }
        cells.extend(averages);
        cells
    })
}

/// The cosine-weighted average of what the specular lobe reflects, single and multiple
/// scattering, per channel of `f0`: `specular_average` in microfacet.wgsl (0 for delta lobes).
pub fn specular_energy_average(roughness: f32, f0: [f32; 3]) -> [f32; 3] {
    if roughness < DELTA_ROUGHNESS {
        return [0.0; 3];
    }
    let table = ggx_albedo_table();
    let y = roughness.clamp(0.0, 1.0) * (SIZE - 1) as f32;
    let y0 = (y as usize).min(SIZE - 2);
    let (low, high) = (table[SIZE * SIZE + y0], table[SIZE * SIZE + y0 + 1]);
    let t = y - y0 as f32;
    let (a, b) = (
        low[0] + (high[0] - low[0]) * t,
        low[1] + (high[1] - low[1]) * t,
    );
    let f90 = (50.0 * 0.33 * (f0[0] + f0[1] + f0[2])).clamp(0.0, 1.0);
    let lost = (1.0 - a - b).max(1e-3);
    f0.map(|f| (f * a + f90 * b + f * lost).min(0.999))
}

/// `(A, B)` of the single-scattering GGX lobe (height-correlated Smith) at perceptual
/// roughness `roughness` for light from cosine `mu`, by normal-distribution sampling with
/// Hammersley points (a table computed once; `sample_ggx` in the renderer draws visible normals).
pub fn directional_albedo(roughness: f32, mu: f32) -> (f32, f32) {
    let alpha = roughness * roughness;
    let mu = mu.clamp(1e-4, 1.0);
    let v = [(1.0 - mu * mu).sqrt(), 0.0, mu];
    let (mut a, mut b) = (0.0f64, 0.0f64);
    for k in 0..SAMPLES {
        let u = ((k as f32 + 0.5) / SAMPLES as f32, radical_inverse(k));
        let cos_h = ((1.0 - u.0) / (1.0 + (alpha * alpha - 1.0) * u.0)).sqrt();
        let sin_h = (1.0 - cos_h * cos_h).max(0.0).sqrt();
        let phi = std::f32::consts::TAU * u.1;
        let h = [sin_h * phi.cos(), sin_h * phi.sin(), cos_h];
        let v_dot_h = v[0] * h[0] + v[2] * h[2];
        let n_dot_l = 2.0 * v_dot_h * h[2] - v[2];
        if n_dot_l <= 0.0 || v_dot_h <= 0.0 {
            continue;
        }
        let g = 4.0 * smith_visibility(mu, n_dot_l, alpha) * mu * n_dot_l;
        let weight = (g * v_dot_h / (mu * cos_h)) as f64;
        let fc = (1.0 - v_dot_h).powi(5) as f64;
        a += weight * (1.0 - fc);
        b += weight * fc;
    }
    ((a / SAMPLES as f64) as f32, (b / SAMPLES as f64) as f32)
}

/// Height-correlated Smith visibility `G / (4 cosθi cosθo)`, as `smith_visibility` in WGSL.
fn smith_visibility(n_dot_v: f32, n_dot_l: f32, alpha: f32) -> f32 {
    let a2 = alpha * alpha;
    let gv = n_dot_l * (n_dot_v * n_dot_v * (1.0 - a2) + a2).sqrt();
    let gl = n_dot_v * (n_dot_l * n_dot_l * (1.0 - a2) + a2).sqrt();
    0.5 / (gv + gl).max(1e-8)
}

/// Van der Corput's radical inverse in base 2.
fn radical_inverse(k: u32) -> f32 {
    k.reverse_bits() as f32 * (1.0 / 4_294_967_296.0)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn albedo_is_one_for_mirrors_and_analytic_at_alpha_one() {
        // A near-mirror reflects all light with F = 1 at any angle but grazing.
        let (a, b) = directional_albedo(DELTA_ROUGHNESS, 0.7);
        assert!((a + b - 1.0).abs() < 0.01, "{}", a + b);
        // At α = 1, D = 1/π and V = ½ / (μ + μl): the lobe reflects 1 − μ ln(1 + 1/μ) at F = 1.
        for mu in [0.1f32, 0.5, 1.0] {
            let (a, b) = directional_albedo(1.0, mu);
            let exact = 1.0 - mu * (1.0 + 1.0 / mu).ln();
            assert!(
                (a + b - exact).abs() < 0.003,
                "μ {mu}: {} against {exact}",
                a + b
            );
        }
        let head_on = directional_albedo(0.2, 1.0);
        let grazing = directional_albedo(0.2, 0.1);
        // A smooth lobe: at normal incidence Schlick's term is nearly all F0 (A), at grazing
        // much more F90 (B).
        assert!(head_on.1 < 0.1 * head_on.0);
        assert!(grazing.1 > 0.2 * grazing.0);
    }

    #[test]
    fn table_rows_and_averages_agree() {
        let table = ggx_albedo_table();
        assert_eq!(table.len(), SIZE * SIZE + SIZE);
        for j in 0..SIZE {
            let row = &table[j * SIZE..(j + 1) * SIZE];
            let average = table[SIZE * SIZE + j];
            // The cosine-weighted average lies between the row's extremes.
            let e: Vec<f32> = row.iter().map(|c| c[0] + c[1]).collect();
            let lo = e.iter().cloned().fold(f32::MAX, f32::min);
            let hi = e.iter().cloned().fold(f32::MIN, f32::max);
            let mean = average[0] + average[1];
            assert!(
                lo - 1e-3 <= mean && mean <= hi + 1e-3,
                "row {j}: {mean} not in {lo}..{hi}"
            );
            assert!(
                row.iter()
                    .all(|c| c.iter().all(|v| v.is_finite() && *v >= 0.0))
            );
        }
    }
}
