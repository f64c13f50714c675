// Photon tracing: photons leave every light, chosen by power, and are traced through the deep
// cubemap; a photon is stored at every diffuse or rough-glossy hit after its first bounce
// (direct light is the local-illumination stage's), then scattered by the material (diffuse,
// GGX glossy, mirror, Fresnel glass) or absorbed (Russian roulette by albedo, so flux stays
// unbiased).
#import bevy_rppm::common::{Light, Photon, IterationParams, PI, LIGHT_POINT, LIGHT_SPOT, LIGHT_DIRECTIONAL, luminance, random, pcg_hash, basis_around, cosine_direction}
#import bevy_rppm::scene::{triangles, materials, lights, emitters, light_cdf}
#import bevy_rppm::cubemap::{trace_cubemap, NO_HIT}
#import bevy_rppm::bsdf::{DELTA_ROUGHNESS, GLOSSY_STORE_ROUGHNESS, has_glossy_lobe, sample_ggx, specular_f0, fresnel_schlick, fresnel_dielectric, diffuse_albedo}

@group(1) @binding(0) var<uniform> params: IterationParams;

@group(2) @binding(0) var<storage, read_write> photons: array<Photon>;
// A draw-indirect argument block: [vertices per splat quad, photons stored, 0, 0].
@group(2) @binding(1) var<storage, read_write> photon_count: array<atomic<u32>, 4>;

struct Ray {
    origin: vec3<f32>,
    direction: vec3<f32>,
    flux: vec3<f32>,
    // Triangle the ray leaves (NO_HIT at a light).
    ignore: u32,
}

fn uniform_sphere(u: vec2<f32>) -> vec3<f32> {
    let z = 1.0 - 2.0 * u.x;
    let r = sqrt(max(1.0 - z * z, 0.0));
    let phi = 2.0 * PI * u.y;
    return vec3<f32>(r * cos(phi), r * sin(phi), z);
}

// Index of the source whose CDF interval holds u.
fn pick_source(u: f32) -> u32 {
    var lo = 0u;
    var hi = params.source_count - 1u;
    while lo < hi {
        let mid = (lo + hi) / 2u;
        if light_cdf[mid] < u {
            lo = mid + 1u;
        } else {
            hi = mid;
        }
    }
    return lo;
}

fn emit(rng: ptr<function, u32>) -> Ray {
    let index = pick_source(random(rng));
    let previous = select(0.0, light_cdf[index - 1u], index > 0u);
    // Each photon carries the source's power over (its probability × photons emitted).
    let share = 1.0 / (max(light_cdf[index] - previous, 1e-12) * f32(params.photons));
    var ray: Ray;
    ray.ignore = NO_HIT;
    if index >= params.light_count {
        let e = emitters[index - params.light_count];
        let t = triangles[e.triangle];
        let r1 = sqrt(random(rng));
        let r2 = random(rng);
        ray.origin = t.position_a * (1.0 - r1) + t.position_b * (r1 * (1.0 - r2)) + t.position_c * (r1 * r2);
        let n = normalize(cross(t.position_b - t.position_a, t.position_c - t.position_a));
        ray.direction = cosine_direction(n, vec2<f32>(random(rng), random(rng)));
        ray.flux = materials[t.material].emissive.rgb * (PI * e.area * share);
        ray.ignore = e.triangle;
        return ray;
    }
    let l = lights[index];
    if l.kind == LIGHT_DIRECTIONAL {
        // A disc across the scene's bounding sphere, upstream of it.
        let radius = params.scene_sphere.w;
        let b = basis_around(l.direction.xyz);
        let r = radius * sqrt(random(rng));
        let phi = 2.0 * PI * random(rng);
        ray.origin = params.scene_sphere.xyz - l.direction.xyz * (2.0 * radius) + b * vec3<f32>(r * cos(phi), r * sin(phi), 0.0);
        ray.direction = l.direction.xyz;
        ray.flux = l.radiance.rgb * (PI * radius * radius * share);
        return ray;
    }
    ray.origin = l.position.xyz;
    if l.kind == LIGHT_SPOT {
        // Uniform in the outer cone's solid angle, weighted by Bevy's falloff a².
        let cos_theta = 1.0 - random(rng) * (1.0 - l.cos_outer);
        let sin_theta = sqrt(max(1.0 - cos_theta * cos_theta, 0.0));
        let phi = 2.0 * PI * random(rng);
        ray.direction = basis_around(l.direction.xyz) * vec3<f32>(sin_theta * cos(phi), sin_theta * sin(phi), cos_theta);
        let a = clamp((cos_theta - l.cos_outer) / max(l.cos_inner - l.cos_outer, 1e-6), 0.0, 1.0);
        let falloff = select(a * a, 1.0, l.cos_inner <= l.cos_outer);
        ray.flux = l.radiance.rgb * (2.0 * PI * (1.0 - l.cos_outer) * falloff * share);
        return ray;
    }
    ray.direction = uniform_sphere(vec2<f32>(random(rng), random(rng)));
    ray.flux = l.radiance.rgb * (4.0 * PI * share);
    return ray;
}

fn store(x: vec3<f32>, ray: Ray, n: vec3<f32>) {
    let slot = atomicAdd(&photon_count[1], 1u);
    if slot < params.photon_capacity {
        photons[slot] = Photon(x, 0u, ray.flux, 0u, -ray.direction, 0u, n, 0u);
    }
}

@compute @workgroup_size(64, 1, 1)
fn trace(@builtin(global_invocation_id) id: vec3<u32>) {
    if id.x >= params.photons {
        return;
    }
    var rng = pcg_hash(id.x ^ pcg_hash(params.iteration * 0x9e3779b9u + 0x632be5abu));
    var ray = emit(&rng);
    let t_min = params.scene_sphere.w * 1e-6;
    for (var depth = 0u; depth < params.max_photon_depth; depth += 1u) {
        let hit = trace_cubemap(ray.origin, ray.direction, t_min, 1.0e30, ray.ignore);
        if hit.triangle == NO_HIT {
            return;
        }
        let t = triangles[hit.triangle];
        let m = materials[t.material];
        let x = ray.origin + ray.direction * hit.t;
        let w = vec3<f32>(1.0 - hit.uv.x - hit.uv.y, hit.uv);
        let geometric = normalize(cross(t.position_b - t.position_a, t.position_c - t.position_a));
        let front = dot(geometric, ray.direction) < 0.0;
        // Shading normal, on the side the photon arrives from.
        var n = normalize(t.normal_a * w.x + t.normal_b * w.y + t.normal_c * w.z);
        if !front {
            n = -n;
        }
        let diffuse = diffuse_albedo(m);
        let direct_only = params.direct_photons != 0u;
        let glossy_store = has_glossy_lobe(m) && m.perceptual_roughness >= GLOSSY_STORE_ROUGHNESS;
        if (depth > 0u || direct_only) && (any(diffuse > vec3<f32>(0.0)) || glossy_store) {
            store(x, ray, n);
        }
        if direct_only {
            return;
        }
        // Scatter: diffuse, GGX glossy, mirror (delta metals) or delta dielectric; otherwise
        // absorbed. Each lobe is chosen with a probability near its albedo. Lobes no material
        // of the scene has are compiled out (GLOSSY, MIRRORS, REFRACTION).
        let delta = m.perceptual_roughness < DELTA_ROUGHNESS;
        var left = 1.0;
        let p_diffuse = min(luminance(diffuse), left);
        left -= p_diffuse;
        var u = random(&rng);
        ray.ignore = hit.triangle;
        ray.origin = x;
#ifdef GLOSSY
        let f0 = select(specular_f0(m), vec3<f32>(0.0), delta);
        let p_glossy = min(luminance(f0), left);
        left -= p_glossy;
        if u < p_glossy {
            let v = -ray.direction;
            let s = sample_ggx(m, n, v, vec2<f32>(random(&rng), random(&rng)));
            if s.w <= 0.0 {
                return;
            }
            ray.direction = s.xyz;
            ray.flux *= fresnel_schlick(f0, dot(v, normalize(v + s.xyz))) * (s.w / p_glossy);
            continue;
        }
        u -= p_glossy;
#endif
        if u < p_diffuse {
            ray.direction = cosine_direction(n, vec2<f32>(random(&rng), random(&rng)));
            ray.flux *= diffuse / p_diffuse;
            continue;
        }
        u -= p_diffuse;
#ifdef MIRRORS
        let mirror = select(vec3<f32>(0.0), m.base_color.rgb * m.metallic, delta);
        let p_mirror = min(luminance(mirror), left);
        left -= p_mirror;
        if u < p_mirror {
            ray.direction = reflect(ray.direction, n);
            ray.flux *= mirror / p_mirror;
            continue;
        }
        u -= p_mirror;
#endif
#ifdef REFRACTION
        let glass = select(0.0, m.specular_transmission * (1.0 - m.metallic), delta);
        let p_glass = min(glass, left);
        if u < p_glass {
            let eta = select(m.ior, 1.0 / m.ior, front);
            let cos_i = dot(-ray.direction, n);
            let refracted = refract(ray.direction, n, eta);
            let reflectance = fresnel_dielectric(cos_i, eta);
            if random(&rng) < reflectance || all(refracted == vec3<f32>(0.0)) {
                ray.direction = reflect(ray.direction, n);
            } else {
                ray.direction = refracted;
            }
            ray.flux *= glass / p_glass;
            continue;
        }
#endif
        return;
    }
}
