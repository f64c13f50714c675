// The white furnace: what a surface reflects under uniform unit radiance, for the BSDF as the
// splats and direct light evaluate it and as photons scatter off it. One workgroup per case.
#import bevy_rppm::common::{Material, PI, cosine_direction}
#import bevy_rppm::sampling::{random, pcg_hash}
#import bevy_rppm::bsdf::{bsdf_eval, scatter_photon}
#import bevy_rppm::microfacet::{sample_ggx, has_glossy_lobe, visible_normal_pdf}

struct Case {
    material: Material,
    // x: cosine of the direction light leaves (eval) or arrives from (photons); y: samples
    // per invocation.
    setting: vec4<f32>,
}

@group(2) @binding(0) var<storage, read> cases: array<Case>;
// Per case: the eval estimate, then the photon estimate (rgb).
@group(2) @binding(1) var<storage, read_write> results: array<vec4<f32>>;

const THREADS: u32 = 256u;
var<workgroup> eval_sums: array<vec3<f32>, THREADS>;
var<workgroup> photon_sums: array<vec3<f32>, THREADS>;

// ∫ f(wo, wi) cos θi dωi by one-sample MIS of cosine, GGX and clearcoat GGX sampling, and the mean photon
// weight for light arriving from wo.
@compute @workgroup_size(256, 1, 1)
fn furnace(@builtin(workgroup_id) group: vec3<u32>, @builtin(local_invocation_index) local: u32) {
    let c = cases[group.x];
    let m = c.material;
    let n = vec3<f32>(0.0, 0.0, 1.0);
    let mu = clamp(c.setting.x, 1e-3, 1.0);
    let wo = vec3<f32>(sqrt(1.0 - mu * mu), 0.0, mu);
    let samples = u32(c.setting.y);
    var rng = pcg_hash(local * 0x9e3779b9u ^ pcg_hash(group.x + 0x632be5abu));
    var eval_sum = vec3<f32>(0.0);
    var photon_sum = vec3<f32>(0.0);
    let glossy = has_glossy_lobe(m);
    let a = m.perceptual_roughness * m.perceptual_roughness;
    // A glossy clearcoat is a third strategy, by its own roughness.
    var coat = m;
    coat.perceptual_roughness = m.clearcoat.y;
    let coated = m.clearcoat.x > 0.0 && has_glossy_lobe(coat);
    let a_coat = coat.perceptual_roughness * coat.perceptual_roughness;
    let strategies = 1.0 + select(0.0, 1.0, glossy) + select(0.0, 1.0, coated);
    for (var k = 0u; k < samples; k += 1u) {
        let u = vec2<f32>(random(&rng), random(&rng));
        var wi = cosine_direction(n, u);
        let pick = random(&rng) * strategies;
        if glossy && pick >= 1.0 && pick < 2.0 {
            wi = sample_ggx(m, n, wo, u).xyz;
        } else if coated && pick >= strategies - 1.0 {
            wi = sample_ggx(coat, n, wo, u).xyz;
        }
        let cos_i = dot(n, wi);
        if cos_i > 0.0 {
            let h = normalize(wi + wo);
            let jacobian = 1.0 / (4.0 * max(dot(wo, h), 1e-6));
            var pdf = cos_i / PI;
            if glossy {
                pdf += visible_normal_pdf(n, wo, h, a) * jacobian;
            }
            if coated {
                pdf += visible_normal_pdf(n, wo, h, a_coat) * jacobian;
            }
            eval_sum += bsdf_eval(m, n, wo, wi) * cos_i * strategies / max(pdf, 1e-12);
        }
        photon_sum += scatter_photon(m, n, n, wo, true, &rng).weight;
    }
    eval_sums[local] = eval_sum;
    photon_sums[local] = photon_sum;
    workgroupBarrier();
    for (var stride = THREADS / 2u; stride > 0u; stride /= 2u) {
        if local < stride {
            eval_sums[local] += eval_sums[local + stride];
            photon_sums[local] += photon_sums[local + stride];
        }
        workgroupBarrier();
    }
    if local == 0u {
        let total = f32(samples * THREADS);
        results[2u * group.x] = vec4<f32>(eval_sums[0] / total, 0.0);
        results[2u * group.x + 1u] = vec4<f32>(photon_sums[0] / total, 0.0);
    }
}
