// The scene tables, bound at group 0 by every stage (`ViewLayouts::scene` in src/view/layouts.rs).
#define_import_path bevy_rppm::scene

#import bevy_rppm::common::{Triangle, Material, Light, Emitter, ShadowView}

@group(0) @binding(0) var<storage, read> triangles: array<Triangle>;
@group(0) @binding(1) var<storage, read> shadow_views: array<ShadowView>;
@group(0) @binding(2) var<storage, read> materials: array<Material>;
@group(0) @binding(3) var<storage, read> lights: array<Light>;
@group(0) @binding(4) var<storage, read> emitters: array<Emitter>;
@group(0) @binding(5) var<storage, read> light_cdf: array<f32>;
// The GGX lobe's directional albedo and its averages (src/bsdf.rs), for bsdf.wgsl.
@group(0) @binding(6) var<storage, read> ggx_albedo: array<vec4<f32>>;

// The material of a camera G-buffer texel, whose w holds ±(triangle + 1).
fn gbuffer_material(w: f32) -> Material {
    return materials[triangles[u32(abs(w)) - 1u].material];
}

// Index of the light source in first..=last whose interval of the power CDF holds u.
fn find_source(u: f32, first: u32, last: u32) -> u32 {
    var lo = first;
    var hi = last;
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
