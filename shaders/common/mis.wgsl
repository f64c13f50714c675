// Multiple importance sampling of emitters at the rough vertices camera paths go on from
// (glossy metals, rough glass): the emitters are sampled there as lights too, and each way
// of finding an emitter is weighted by the power heuristic, so a small bright panel seen in
// a rough reflection or through frosted glass is not found by chance alone (fireflies).
// `path_f` and `path_pdf` mirror `scatter_photon` as camera paths use it (`lobe_bounce`) on
// the materials `mis_vertex` admits, so that both estimators add up to the same integral.
#define_import_path bevy_rppm::mis

#import bevy_rppm::common::{Material, PI, DELTA_ROUGHNESS, luminance}
#import bevy_rppm::bsdf::{specular_f0, specular_at, specular_average, cosine_lobes_energy, ggx_d, translucency, layered}
#ifdef ROUGH_REFRACTION
#import bevy_rppm::bsdf::{rough_glass_share, smith_g1, fresnel_dielectric}
#endif

// Whether a camera path going on from a surface of m samples the emitters there: its lobes
// are rough, and have no layer `path_f` leaves out (a clearcoat, diffuse transmission).
fn mis_vertex(m: Material) -> bool {
    var plain = m.perceptual_roughness >= DELTA_ROUGHNESS;
#ifdef CLEARCOAT
    plain = plain && m.clearcoat.x <= 0.0;
#endif
#ifdef DIFFUSE_TRANSMISSION
    plain = plain && translucency(m) <= 0.0;
#endif
    return plain;
}

// The power heuristic's weight of the strategy that drew a direction with density `chosen`
// against the other's `other`.
fn power_heuristic(chosen: f32, other: f32) -> f32 {
    if !(chosen > 0.0) {
        return 0.0;
    }
    // As a ratio of capped densities: a huge one (a grazing emitter) gives 0 or 1, not inf/inf.
    let r = min(other, 1e18) / min(chosen, 1e18);
    return 1.0 / (1.0 + r * r);
}

// Rough glass's share of the surface (0 where the scene has none).
fn rough_share(m: Material) -> f32 {
#ifdef ROUGH_REFRACTION
    return rough_glass_share(m);
#else
    return 0.0;
#endif
}

// f(wo, wi) of a `mis_vertex` surface seen from wo (on n's side, `front` whether that is the
// outside), from `layers` = bsdf_eval of its `layered` part: rough glass reflects with the
// Fresnel of the side wo is on and refracts, with the camera path's η² of radiance crossing
// (Walter et al. 2007).
fn path_f(layers: vec3<f32>, m: Material, n: vec3<f32>, wo: vec3<f32>, wi: vec3<f32>, front: bool) -> vec3<f32> {
    let rough = rough_share(m);
    var f = layers * (1.0 - rough);
#ifdef ROUGH_REFRACTION
    if rough > 0.0 {
        f += vec3<f32>(rough * rough_glass_f(m, n, wo, wi, front));
    }
#endif
    return f;
}

// The density (solid angle) with which `scatter_photon` draws wi for a camera path at a
// `mis_vertex` surface seen from wo.
fn path_pdf(m: Material, n: vec3<f32>, wo: vec3<f32>, wi: vec3<f32>, front: bool) -> f32 {
    let rough = rough_share(m);
    var p = 0.0;
#ifdef ROUGH_REFRACTION
    p = rough * rough_glass_pdf(m, n, wo, wi, front);
#endif
    let mu_o = dot(n, wo);
    let mu_i = dot(n, wi);
    if mu_i <= 0.0 || mu_o <= 0.0 {
        return p;
    }
    let l = layered(m);
    let f0 = specular_f0(l);
    let o = specular_at(l, f0, mu_o);
    var left = 1.0;
#ifdef GLOSSY
    let p_glossy = min(luminance(o.single), left);
    left -= p_glossy;
    let h = normalize(wo + wi);
    let n_dot_h = max(dot(n, h), 0.0);
    let a = l.perceptual_roughness * l.perceptual_roughness;
    p += (1.0 - rough) * p_glossy * ggx_d(n_dot_h, a) * n_dot_h / (4.0 * max(dot(wo, h), 1e-6));
#endif
    let p_cosine = min(luminance(cosine_lobes_energy(l, f0, o, specular_average(l))), left);
    return p + (1.0 - rough) * p_cosine * mu_i / PI;
}

#ifdef ROUGH_REFRACTION
// The microfacet normal that turns wo into wi (reflected when both lie on n's side, else
// refracted, η = n on wo's side / n on wi's), facing n; zero where none does.
fn glass_half_vector(n: vec3<f32>, wo: vec3<f32>, wi: vec3<f32>, eta: f32) -> vec3<f32> {
    var h = select(-(eta * wo + wi), wo + wi, dot(n, wi) > 0.0);
    if dot(h, h) <= 1e-12 {
        return vec3<f32>(0.0);
    }
    h = normalize(h);
    return select(h, -h, dot(h, n) < 0.0);
}

// Rough glass's f(wo, wi) for a camera path at it (`scatter_rough_glass`'s lobe).
fn rough_glass_f(m: Material, n: vec3<f32>, wo: vec3<f32>, wi: vec3<f32>, front: bool) -> f32 {
    let cos_o = dot(n, wo);
    let cos_i = dot(n, wi);
    let eta = select(m.ior, 1.0 / m.ior, front);
    let h = glass_half_vector(n, wo, wi, eta);
    let oh = dot(wo, h);
    let ih = dot(wi, h);
    let denominator = eta * oh + ih;
    if cos_o <= 0.0 || oh <= 0.0 || (cos_i > 0.0) != (ih > 0.0) || abs(cos_i) < 1e-6 || abs(denominator) < 1e-4 {
        return 0.0;
    }
    let a = m.perceptual_roughness * m.perceptual_roughness;
    let g = smith_g1(cos_o, a) * smith_g1(abs(cos_i), a);
    let d = ggx_d(dot(n, h), a);
    let fresnel = fresnel_dielectric(oh, eta);
    if cos_i > 0.0 {
        return fresnel * d * g / (4.0 * cos_o * cos_i);
    }
    return eta * eta * oh * abs(ih) * (1.0 - fresnel) * g * d / (cos_o * abs(cos_i) * denominator * denominator);
}

// The density with which `scatter_rough_glass` draws wi from wo.
fn rough_glass_pdf(m: Material, n: vec3<f32>, wo: vec3<f32>, wi: vec3<f32>, front: bool) -> f32 {
    let eta = select(m.ior, 1.0 / m.ior, front);
    let h = glass_half_vector(n, wo, wi, eta);
    let oh = dot(wo, h);
    let ih = dot(wi, h);
    let cos_i = dot(n, wi);
    let denominator = eta * oh + ih;
    if dot(n, wo) <= 0.0 || oh <= 0.0 || (cos_i > 0.0) != (ih > 0.0) || abs(denominator) < 1e-4 {
        return 0.0;
    }
    let a = m.perceptual_roughness * m.perceptual_roughness;
    let n_dot_h = dot(n, h);
    let fresnel = fresnel_dielectric(oh, eta);
    let normals = ggx_d(n_dot_h, a) * n_dot_h;
    if cos_i > 0.0 {
        return fresnel * normals / (4.0 * oh);
    }
    return (1.0 - fresnel) * normals * abs(ih) / (denominator * denominator);
}
#endif
