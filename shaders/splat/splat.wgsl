// Direct splatting: every stored photon is drawn as a screen-space quad around its projection,
// as wide as the gather radius; each fragment adds the photon to its pixel's importon (the
// camera G-buffer point) when the photon lies inside that importon's radius, on its surface.
// The estimate per pixel is Σ f(wo, wi) Φ / (π r²), summed by additive blending.
// SUBSAMPLED (ISPM): the target has one texel per n×n pixels, gathered at one representative
// pixel of the block, and holds incident light Σ Φ / (π r²) for the joint-bilateral upsampling
// in shaders/accumulate/accumulate.wgsl, which applies each full-resolution pixel's own BSDF.
#import bevy_rppm::common::{Photon, IterationParams, PI, gather_radius, splat_survives, splat_weight, subsample_representative}
#import bevy_rppm::scene::{gbuffer_material, resolved_material, resolved_kernel_normal, kernel_normal}
#import bevy_rppm::bsdf::bsdf_eval

@group(1) @binding(0) var<uniform> params: IterationParams;
@group(1) @binding(1) var<storage, read> photons: array<Photon>;
@group(1) @binding(2) var gbuffer_position: texture_2d<f32>;
@group(1) @binding(3) var gbuffer_normal: texture_2d<f32>;
#ifdef TEXTURED
// Each pixel's textures, looked up once by local illumination (`resolve_surface`).
@group(1) @binding(4) var<storage, read> surfaces: array<vec4<u32>>;
#endif

struct VertexOut {
    @builtin(position) clip: vec4<f32>,
    @location(0) @interpolate(flat) photon: u32,
}

@vertex
fn vertex(@builtin(vertex_index) vertex: u32, @builtin(instance_index) photon: u32) -> VertexOut {
    var out: VertexOut;
    out.photon = photon;
    out.clip = vec4<f32>(2.0, 2.0, 0.0, 1.0);
    if photon >= params.photon_capacity {
        return out;
    }
    let clip = params.clip_from_world * vec4<f32>(photons[photon].position, 1.0);
    if clip.w <= 0.0 {
        return out;
    }
    let corner = array<vec2<f32>, 6>(vec2(-1.0, -1.0), vec2(1.0, -1.0), vec2(-1.0, 1.0), vec2(-1.0, 1.0), vec2(1.0, -1.0), vec2(1.0, 1.0))[vertex];
    // Half a quad in pixels: the radius, plus one (target) pixel for the pixel's own extent.
    let half = (params.splat_radius + f32(params.indirect_subsampling)) * 2.0 / vec2<f32>(params.size);
    out.clip = vec4<f32>(clip.xy / clip.w + corner * half, 0.0, 1.0);
    return out;
}

@fragment
fn fragment(in: VertexOut) -> @location(0) vec4<f32> {
#ifdef SUBSAMPLED
    let pixel = subsample_representative(params, vec2<u32>(in.clip.xy));
#else
    let pixel = vec2<i32>(in.clip.xy);
#endif
    let gp = textureLoad(gbuffer_position, pixel, 0);
    if gp.w == 0.0 {
        discard;
    }
    let gn = textureLoad(gbuffer_normal, pixel, 0);
    let p = photons[in.photon];
    let radius = gather_radius(params, params.splat_radius, gn.w);
    let offset = p.position - gp.xyz;
#ifdef TEXTURED
    let surface = surfaces[u32(pixel.y) * params.size.x + u32(pixel.x)];
    let plane = resolved_kernel_normal(surface, gn.xyz);
#else
    let plane = kernel_normal(gp, gn.xyz);
#endif
    // Inside the gather disc, on this surface: near its plane and facing the same way.
    if dot(offset, offset) > radius * radius || abs(dot(offset, plane)) > params.kernel_flattening * radius || dot(p.normal, plane) < 0.5 {
        discard;
    }
    if !splat_survives(params, in.photon, u32(pixel.y) * params.size.x + u32(pixel.x)) {
        discard;
    }
    let density = splat_weight(params) / (PI * radius * radius);
#ifdef SUBSAMPLED
    return vec4<f32>(p.flux * density, 0.0);
#else
#ifdef TEXTURED
    let m = resolved_material(gp, surface);
#else
    let m = gbuffer_material(gp, gn.w);
#endif
    let wo = normalize(params.camera_position.xyz - gp.xyz);
    // The photons' density is irradiance on the kernel's plane; a normal map's bent normal
    // receives it by its own cosine instead.
    let bend = select(1.0, dot(gn.xyz, p.incoming) / max(dot(plane, p.incoming), 0.05), any(plane != gn.xyz));
    let f = bsdf_eval(m, gn.xyz, wo, p.incoming) * bend;
    return vec4<f32>(f * p.flux * density, 0.0);
#endif
}
