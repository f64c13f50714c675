// The GGX microfacet lobe that bsdf.wgsl builds Bevy's StandardMaterial from: Fresnel, the
// distribution and Smith's masking, the directional-albedo table its multiple-scattering
// compensation reads, and drawing microfacet normals by their visible area.
#define_import_path bevy_rppm::microfacet

#import bevy_rppm::common::{Material, PI, DELTA_ROUGHNESS, basis_around}
#import bevy_rppm::scene::ggx_albedo

// Below DELTA_ROUGHNESS (common.wgsl) the specular lobe is a perfect mirror: it carries no
// light from a point in a direction other than the mirror one, so evaluation gives zero.

fn specular_f0(m: Material) -> vec3<f32> {
    return mix(tinted_f0(m), m.base_color.rgb, m.metallic);
}

// F0 of the surface's dielectric part, Bevy's: 0.16·(reflectance·specular_tint)², dimmed on
// dark rough surfaces (`matte_share`).
fn tinted_f0(m: Material) -> vec3<f32> {
    let r = m.reflectance * m.specular_tint.rgb;
    let f0 = min(0.16 * r * r, vec3<f32>(1.0));
    return f0 * matte_share(m, max(f0.x, max(f0.y, f0.z)));
}

// Roughness from which a dielectric turns towards the references' Lambert (CONVENTIONS.md).
const MATTE_FROM: f32 = 0.75;
// The most of a matte surface's darkest albedo channel its specular layer may reflect: the
// layer's sheen, E(μ)/E_avg up to 1.9 at grazing angles at roughness 1, then keeps it within
// 5 % of Lambert (at 0.15, a dark corridor's floor seen at cos θ ≤ 0.05 read 7 % bright).
const MATTE_SHARE: f32 = 0.05;

// What keeps the specular layer of an opaque dielectric (peak F0 `f0`) within MATTE_SHARE of
// its darkest albedo channel on average, the diffuse lobe reflecting the rest. Without it a
// dark matte surface reflected the layer's 4 % whatever its colour (a tile of albedo 0.02
// read 2×, walls of 0.12 11 % bright seen at a grazing angle). Full at roughness 1, none
// below MATTE_FROM, where the layer is Bevy's own.
fn matte_share(m: Material, f0: f32) -> f32 {
    let t = saturate((m.perceptual_roughness - MATTE_FROM) / (1.0 - MATTE_FROM));
    let albedo = m.base_color.rgb;
    let most = MATTE_SHARE * min(albedo.x, min(albedo.y, albedo.z));
    if t <= 0.0 || m.specular_transmission > 0.0 || f0 <= 0.0 {
        return 1.0;
    }
    // `dielectric_energy` at F0 = f: f (1 − B) + F90 B, B (the table's F90 share) within 0.0006
    // of this line from MATTE_FROM up: no table read. Its inverse below splits at F90 = 1,
    // where `specular_f90`'s 49.5 f saturates.
    let b = 0.0028 + 0.0172 * (1.0 - m.perceptual_roughness);
    if f0 * (1.0 - b) + specular_f90(vec3<f32>(f0)) * b <= most {
        return 1.0;
    }
    var f = (most - b) / (1.0 - b);
    if f < 1.0 / 49.5 {
        f = most / (1.0 + 48.5 * b);
    }
    return mix(1.0, max(f, 0.0) / f0, t);
}

// The dielectric F0's largest channel: what the diffuse lobe gives up to the specular layer
// (a tint then darkens the other channels' diffuse light a little rather than make light).
fn dielectric_f0(m: Material) -> f32 {
    let f = tinted_f0(m);
    return max(f.x, max(f.y, f.z));
}

// Reflectance at grazing angles: Bevy's, which fades to 0 as F0 does (no specular at all for
// reflectance 0).
fn specular_f90(f0: vec3<f32>) -> f32 {
    return saturate(dot(f0, vec3<f32>(50.0 * 0.33)));
}

fn fresnel_schlick(f0: vec3<f32>, f90: f32, cos_theta: f32) -> vec3<f32> {
    // (1 − cos)⁵ by products: pow is exp2(5·log2(·)), costly where it is emulated.
    let x = 1.0 - clamp(cos_theta, 0.0, 1.0);
    let x2 = x * x;
    let f = x2 * x2 * x;
    return f0 + (vec3<f32>(f90) - f0) * f;
}

fn ggx_d(n_dot_h: f32, a: f32) -> f32 {
    let a2 = a * a;
    let d = n_dot_h * n_dot_h * (a2 - 1.0) + 1.0;
    return a2 / (PI * d * d);
}

// Height-correlated Smith visibility, V = G / (4 cosθi cosθo).
fn smith_visibility(n_dot_v: f32, n_dot_l: f32, a: f32) -> f32 {
    let a2 = a * a;
    let gv = n_dot_l * sqrt(n_dot_v * n_dot_v * (1.0 - a2) + a2);
    let gl = n_dot_v * sqrt(n_dot_l * n_dot_l * (1.0 - a2) + a2);
    return 0.5 / max(gv + gl, 1e-8);
}

// The GGX lobe's directional albedo table (src/bsdf.rs): texel (x, y) at cosine x (cell
// centres) and perceptual roughness y (nodes); row ALBEDO_SIZE the cosine-weighted averages.
const ALBEDO_SIZE: u32 = 32u;

// (A, B) with the single-scattering lobe reflecting F0·A + F90·B of light from cosine mu.
fn albedo_ab(roughness: f32, mu: f32) -> vec2<f32> {
    let size = f32(ALBEDO_SIZE);
    let x = clamp(mu * size - 0.5, 0.0, size - 1.0);
    let y = clamp(roughness, 0.0, 1.0) * (size - 1.0);
    let x0 = min(u32(x), ALBEDO_SIZE - 2u);
    let y0 = min(u32(y), ALBEDO_SIZE - 2u);
    let at = vec2<u32>(x0, y0);
    let fx = x - f32(x0);
    let low = mix(albedo_texel(at), albedo_texel(at + vec2<u32>(1u, 0u)), fx);
    let high = mix(albedo_texel(at + vec2<u32>(0u, 1u)), albedo_texel(at + vec2<u32>(1u, 1u)), fx);
    return mix(low, high, y - f32(y0));
}

// The cosine-weighted averages of A and B over the hemisphere.
fn albedo_ab_average(roughness: f32) -> vec2<f32> {
    let y = clamp(roughness, 0.0, 1.0) * f32(ALBEDO_SIZE - 1u);
    let y0 = min(u32(y), ALBEDO_SIZE - 2u);
    let at = vec2<u32>(y0, ALBEDO_SIZE);
    return mix(albedo_texel(at), albedo_texel(at + vec2<u32>(1u, 0u)), y - f32(y0));
}

fn albedo_texel(at: vec2<u32>) -> vec2<f32> {
    return textureLoad(ggx_albedo, at, 0).xy;
}

// What the specular lobe does with light from cos μ: `single` is what single scattering
// reflects (F0·A + F90·B); `lost` = 1 − E(μ) what it loses at F = 1; `dielectric` all the
// lobe would reflect at the dielectric part's F0, single scattering plus Kulla and Conty's
// multiple-scattering lobe F0 (1 − E(μo)) (1 − E(μi)) / (π (1 − E_avg)), which reflects
// F0·lost. At F0 = 1 the two reflect everything, both ways (reciprocal, so photons and splats
// agree).
struct Specular {
    single: vec3<f32>,
    lost: f32,
    dielectric: f32,
}

fn specular_at(m: Material, f0: vec3<f32>, mu: f32) -> Specular {
    if !has_glossy_lobe(m) {
        return Specular(vec3<f32>(0.0), 0.0, 0.0);
    }
    let ab = albedo_ab(m.perceptual_roughness, mu);
    let single = f0 * ab.x + specular_f90(f0) * ab.y;
    let lost = saturate(1.0 - ab.x - ab.y);
    return Specular(single, lost, dielectric_energy(m, ab, lost, 1.0));
}

// What the lobe reflects at the dielectric F0, from (A, B) and 1 − A − B.
fn dielectric_energy(m: Material, ab: vec2<f32>, lost: f32, most: f32) -> f32 {
    let f0 = dielectric_f0(m);
    return min(f0 * ab.x + specular_f90(vec3<f32>(f0)) * ab.y + f0 * lost, most);
}

// Cosine-weighted averages over the hemisphere: x what the lobe reflects at the dielectric
// F0, y 1 − E_avg.
fn specular_average(m: Material) -> vec2<f32> {
    if !has_glossy_lobe(m) {
        return vec2<f32>(0.0, 1.0);
    }
    let avg = albedo_ab_average(m.perceptual_roughness);
    let lost = max(1.0 - avg.x - avg.y, 1e-3);
    return vec2<f32>(dielectric_energy(m, avg, lost, 0.999), lost);
}

// Whether the GGX lobe is a rough (non-delta) lobe.
fn has_glossy_lobe(m: Material) -> bool {
    return m.perceptual_roughness >= DELTA_ROUGHNESS;
}

// Smith's G1 for GGX.
fn smith_g1(cos_theta: f32, a: f32) -> f32 {
    let c2 = max(cos_theta * cos_theta, 1e-8);
    return 2.0 / (1.0 + sqrt(1.0 + a * a * (1.0 - c2) / c2));
}

// A microfacet normal of GGX (α = a) around n, drawn as seen from v.
fn ggx_normal(n: vec3<f32>, v: vec3<f32>, a: f32, u: vec2<f32>) -> vec3<f32> {
    // The microfacet normals v sees, by their visible area (Heitz 2018): weights stay under 1
    // at grazing v, where drawing by D alone gave weights of 1/(n·v) (fireflies at the edges
    // of rough glass and metal seen edge-on).
    let frame = basis_around(n);
    var local = v * frame;
    local.z = max(local.z, 1e-6);
    let vh = normalize(vec3<f32>(a * local.x, a * local.y, local.z));
    let length2 = vh.x * vh.x + vh.y * vh.y;
    let t1 = select(vec3<f32>(1.0, 0.0, 0.0), vec3<f32>(-vh.y, vh.x, 0.0) * inverseSqrt(max(length2, 1e-30)), length2 > 1e-12);
    let t2 = cross(vh, t1);
    let r = sqrt(u.x);
    let phi = 2.0 * PI * u.y;
    let p1 = r * cos(phi);
    let s = 0.5 * (1.0 + vh.z);
    let p2 = (1.0 - s) * sqrt(max(1.0 - p1 * p1, 0.0)) + s * r * sin(phi);
    let nh = p1 * t1 + p2 * t2 + sqrt(max(1.0 - p1 * p1 - p2 * p2, 0.0)) * vh;
    let h = normalize(vec3<f32>(a * nh.x, a * nh.y, max(nh.z, 1e-6)));
    return frame * h;
}

// The density of `ggx_normal`'s h seen from v: G1(v) max(v·h, 0) D(h) / (n·v).
fn visible_normal_pdf(n: vec3<f32>, v: vec3<f32>, h: vec3<f32>, a: f32) -> f32 {
    let n_dot_v = dot(n, v);
    let v_dot_h = dot(v, h);
    if n_dot_v <= 0.0 || v_dot_h <= 0.0 {
        return 0.0;
    }
    return smith_g1(n_dot_v, a) * v_dot_h * ggx_d(max(dot(n, h), 0.0), a) / n_dot_v;
}

// Samples the GGX lobe by its visible normals around n for light arriving from `v`
// (pointing away from the surface): returns the scattered direction (xyz) and the weight
// f·cos/pdf (w, scalar part; multiply by Fresnel), or w = 0 when it leaves below the surface.
fn sample_ggx(m: Material, n: vec3<f32>, v: vec3<f32>, u: vec2<f32>) -> vec4<f32> {
    let a = m.perceptual_roughness * m.perceptual_roughness;
    let h = ggx_normal(n, v, a, u);
    let l = reflect(-v, h);
    let n_dot_l = dot(n, l);
    let n_dot_v = dot(n, v);
    let v_dot_h = dot(v, h);
    if n_dot_l <= 0.0 || n_dot_v <= 0.0 || v_dot_h <= 0.0 {
        return vec4<f32>(l, 0.0);
    }
    // f cos / pdf with pdf = G1(v) D / (4 n·v): G / G1(v), G = 4 V (n·v)(n·l).
    let g = 4.0 * smith_visibility(n_dot_v, n_dot_l, a) * n_dot_v * n_dot_l;
    return vec4<f32>(l, g / smith_g1(n_dot_v, a));
}

// Unpolarised Fresnel reflectance of a dielectric; eta = n_incident / n_transmitted.
fn fresnel_dielectric(cos_i: f32, eta: f32) -> f32 {
    let sin2_t = eta * eta * max(1.0 - cos_i * cos_i, 0.0);
    if sin2_t >= 1.0 {
        return 1.0;
    }
    let cos_t = sqrt(1.0 - sin2_t);
    let rs = (eta * cos_i - cos_t) / (eta * cos_i + cos_t);
    let rp = (cos_i - eta * cos_t) / (cos_i + eta * cos_t);
    return 0.5 * (rs * rs + rp * rp);
}
