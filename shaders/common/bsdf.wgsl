// Bevy StandardMaterial as a BSDF: Lambert diffuse, GGX specular (F0 = 0.16·reflectance² for
// dielectrics, base colour for metals), and delta lobes below DELTA_ROUGHNESS. Energy-conserving
// between the diffuse lobe and the dielectric layer (see diffuse_albedo).
#define_import_path bevy_rppm::bsdf

#import bevy_rppm::common::{Material, PI}

// Below this perceptual roughness the specular lobe is a perfect mirror: it carries no light
// from a point in a direction other than the mirror one, so evaluation gives zero.
const DELTA_ROUGHNESS: f32 = 0.02;

fn specular_f0(m: Material) -> vec3<f32> {
    let dielectric = vec3<f32>(0.16 * m.reflectance * m.reflectance);
    return mix(dielectric, m.base_color.rgb, m.metallic);
}

fn fresnel_schlick(f0: vec3<f32>, cos_theta: f32) -> vec3<f32> {
    let f = pow(1.0 - clamp(cos_theta, 0.0, 1.0), 5.0);
    return f0 + (vec3<f32>(1.0) - f0) * f;
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

// Albedo of the diffuse lobe: Bevy's (1 − metallic)(1 − transmission) × base colour, less what
// the dielectric specular layer reflects (F0 = 0.16·reflectance²). Bevy adds the two lobes
// without that split; for direct light the difference is a few percent, but bounced many
// times (as photons are) the extra energy compounds, so the diffuse lobe gives it back.
fn diffuse_albedo(m: Material) -> vec3<f32> {
    let layer = 0.16 * m.reflectance * m.reflectance;
    return m.base_color.rgb * ((1.0 - m.metallic) * (1.0 - m.specular_transmission) * (1.0 - layer));
}

// f(wo, wi), without the cosine. wo and wi point away from the surface.
fn bsdf_eval(m: Material, n: vec3<f32>, wo: vec3<f32>, wi: vec3<f32>) -> vec3<f32> {
    let n_dot_l = dot(n, wi);
    let n_dot_v = dot(n, wo);
    if n_dot_l <= 0.0 || n_dot_v <= 0.0 {
        return vec3<f32>(0.0);
    }
    var f = diffuse_albedo(m) / PI;
    if m.perceptual_roughness >= DELTA_ROUGHNESS {
        let a = m.perceptual_roughness * m.perceptual_roughness;
        let h = normalize(wi + wo);
        let d = ggx_d(max(dot(n, h), 0.0), a);
        let v = smith_visibility(n_dot_v, n_dot_l, a);
        f += d * v * fresnel_schlick(specular_f0(m), dot(wo, h));
    }
    return f;
}

// Photons are stored at glossy surfaces at least this rough (density estimation needs a
// lobe wide enough to gather over); smoother ones only scatter them.
const GLOSSY_STORE_ROUGHNESS: f32 = 0.3;

// Whether the GGX lobe is a rough (non-delta) lobe.
fn has_glossy_lobe(m: Material) -> bool {
    return m.perceptual_roughness >= DELTA_ROUGHNESS;
}

// Samples the GGX lobe by its normal distribution around n for light arriving from `v`
// (pointing away from the surface): returns the scattered direction (xyz) and the weight
// f·cos/pdf (w, scalar part; multiply by Fresnel), or w = 0 when it leaves below the surface.
fn sample_ggx(m: Material, n: vec3<f32>, v: vec3<f32>, u: vec2<f32>) -> vec4<f32> {
    let a = m.perceptual_roughness * m.perceptual_roughness;
    let cos_h = sqrt((1.0 - u.x) / (1.0 + (a * a - 1.0) * u.x));
    let sin_h = sqrt(max(1.0 - cos_h * cos_h, 0.0));
    let phi = 2.0 * PI * u.y;
    let t = select(vec3<f32>(1.0, 0.0, 0.0), vec3<f32>(0.0, 1.0, 0.0), abs(n.x) > 0.9);
    let x = normalize(cross(t, n));
    let y = cross(n, x);
    let h = x * (sin_h * cos(phi)) + y * (sin_h * sin(phi)) + n * cos_h;
    let l = reflect(-v, h);
    let n_dot_l = dot(n, l);
    let n_dot_v = dot(n, v);
    let v_dot_h = dot(v, h);
    if n_dot_l <= 0.0 || n_dot_v <= 0.0 || v_dot_h <= 0.0 {
        return vec4<f32>(l, 0.0);
    }
    // f cos / pdf with pdf = D (n·h) / (4 v·h): G · (v·h) / ((n·v)(n·h)), G = 4 V (n·v)(n·l).
    let g = 4.0 * smith_visibility(n_dot_v, n_dot_l, a) * n_dot_v * n_dot_l;
    return vec4<f32>(l, g * v_dot_h / (n_dot_v * cos_h));
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
