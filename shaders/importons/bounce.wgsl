// The camera path's next direction at a surface it goes on through (eye_paths.wgsl): a
// delta lobe, or the glossy lobes sampled as photons sample them.
#define_import_path bevy_rppm::eye_bounce
#import bevy_rppm::common::{Material, DELTA_ROUGHNESS, luminance}
#import bevy_rppm::sampling::random
#import bevy_rppm::bsdf::{glass_share, scatter_photon}
#import bevy_rppm::microfacet::fresnel_dielectric

struct Bounce {
    direction: vec3<f32>,
    weight: vec3<f32>,
}

// Samples the specular lobes: the mirror of metals, Fresnel-chosen reflection or refraction
// of glass. `n` faces the incoming side; `front` tells which side of the surface that is.
fn specular_bounce(m: Material, d: vec3<f32>, n: vec3<f32>, front: bool, rng: ptr<function, u32>) -> Bounce {
    let mirror = luminance(m.base_color.rgb) * m.metallic;
    let total = max(delta_share(m), 1e-6);
#ifdef MIRRORS
    if random(rng) * total < mirror {
        return Bounce(reflect(d, n), m.base_color.rgb * (total / luminance(m.base_color.rgb)));
    }
#endif
#ifdef REFRACTION
    let eta = select(m.ior, 1.0 / m.ior, front);
    let refracted = refract(d, n, eta);
    if random(rng) < fresnel_dielectric(dot(-d, n), eta) || all(refracted == vec3<f32>(0.0)) {
        return Bounce(reflect(d, n), vec3<f32>(total));
    }
    return Bounce(refracted, vec3<f32>(total));
#else
    return Bounce(d, vec3<f32>(0.0));
#endif
}

// What a surface's delta lobes carry where it is smooth: the mirror of its metal part and
// its glass (`GpuMaterial::delta_share` on the CPU).
fn delta_share(m: Material) -> f32 {
    return luminance(m.base_color.rgb) * m.metallic + glass_share(m);
}

// The camera path's next direction at a surface it goes on through: a delta lobe, or the
// glossy lobes sampled as photons sample them (the BSDF is reciprocal but for refraction).
fn next_bounce(m: Material, d: vec3<f32>, n: vec3<f32>, front: bool, rng: ptr<function, u32>) -> Bounce {
    var bounce = lobe_bounce(m, d, n, front, rng);
    if dot(bounce.direction, n) < 0.0 {
        // Through glass, smooth or rough, radiance over n² is what crossing keeps: light
        // leaving water for air is 1/1.33² as bright (photons carry flux and need no such
        // factor). Cancels through closed glass.
        let eta = select(m.ior, 1.0 / m.ior, front);
        bounce.weight *= eta * eta;
    }
    return bounce;
}

fn lobe_bounce(m: Material, d: vec3<f32>, n: vec3<f32>, front: bool, rng: ptr<function, u32>) -> Bounce {
#ifdef GLOSSY
    if m.perceptual_roughness >= DELTA_ROUGHNESS {
        let s = scatter_photon(m, n, n, -d, front, rng);
        return Bounce(s.direction, s.weight);
    }
#endif
    return specular_bounce(m, d, n, front, rng);
}
