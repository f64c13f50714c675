// Direct splatting, as a gather: each pixel's G-buffer point (its importon at the camera)
// visits the deep cubemap tiles its gather sphere reaches, a run of the photon map per row of
// tiles (photons/sort.wgsl), and adds the photons inside its kernel: a disc of the gather radius on its
// surface, flattened along its normal. The estimate is Σ f(wo, wi) Φ / (π r²), summed in
// registers, one thread a pixel: no quad per photon, no blending, and the work is the
// photons near visible surfaces.
// SUBSAMPLED (ISPM): the target has one texel per n×n pixels, gathered at one representative
// pixel of the block, and holds incident light Σ Φ / (π r²) for the joint-bilateral upsampling
// in shaders/accumulate/accumulate.wgsl, which applies each full-resolution pixel's own BSDF.
#import bevy_rppm::common::{Material, Outgoing, Photon, IterationParams, PI, basis_around, faces_reached, gather_radius, splat_weight, subsample_representative, toward_eye, unpack_normal}
#import bevy_rppm::scene::{gbuffer_material, resolved_material, resolved_kernel_normal, kernel_normal}
#import bevy_rppm::bsdf::{bsdf_from, bsdf_gathered, glass_share, translucency, stores_photons}
#import bevy_rppm::cubemap::cubemap
#import bevy_rppm::photon_map::{photons, face_gather, gather_row_run, next_in_kernel, disc_point, disc_share}

@group(1) @binding(0) var<uniform> params: IterationParams;

// Bindings 0 and 1: the photon map and its tiles' starts (photons/map.wgsl).
@group(2) @binding(2) var gbuffer_position: texture_2d<f32>;
@group(2) @binding(3) var gbuffer_normal: texture_2d<f32>;
// Each pixel's textures, looked up once by local illumination (`resolve_surface`); a
// stand-in when the scene has none.
@group(2) @binding(4) var<storage, read> surfaces: array<vec4<u32>>;
@group(2) @binding(5) var splats: texture_storage_2d<rgba32float, write>;

// What one pixel's kernel needs of its G-buffer point.
struct Kernel {
    position: vec3<f32>,
    radius: f32,
    // The plane the kernel lies in (the interpolated normal where a normal map bends the
    // shading normal).
    plane: vec3<f32>,
    index: u32,
}

// The photons of run `run` of the map inside pixel kernel `k`: Σ f(wo, wi) Φ on material `m`
// (`out` its bsdf_from; a smooth clearcoat's lobe left to the camera path) with shading
// normal `shading` (Σ Φ, subsampled).
fn gather_run(k: Kernel, m: Material, out: Outgoing, shading: vec3<f32>, wo: vec3<f32>, run: vec2<u32>) -> vec3<f32> {
    var sum = vec3<f32>(0.0);
    let bent = any(k.plane != shading);
    let both_sides = translucency(m) > 0.0;
    var i = next_in_kernel(run.x, run.y, params, k.position, k.plane, k.radius, k.index, both_sides);
    while i < run.y {
        let p = photons[i];
        i = next_in_kernel(i + 1u, run.y, params, k.position, k.plane, k.radius, k.index, both_sides);
#ifdef GLASS
        // Under glass or water that meets the surface (a wall below the water line), other
        // light arrives than on the surface the camera sees: the disc's area leaves it out too.
        if disc_view(k, p.position) == UNDER_GLASS {
            continue;
        }
#endif
#ifdef SUBSAMPLED
        sum += p.flux;
#else
        // The photons' density is irradiance on the kernel's plane; a normal map's bent
        // normal receives it by its own cosine instead (on either side: diffuse transmission).
        let incoming = unpack_normal(p.incoming);
        let bend = select(1.0, abs(dot(shading, incoming)) / max(abs(dot(k.plane, incoming)), 0.05), bent);
        sum += bsdf_gathered(m, out, shading, wo, incoming) * (bend * p.flux);
#endif
    }
    return sum;
}

// Points of the kernel's disc checked for a surface (`disc_point`). (The spiral turned by a
// random angle each iteration, the share's noise divided the estimate: translucent's relMSE
// at 48 iterations 0.0022 → 0.0030.)
const DISC_POINTS: u32 = 16u;

// What the G-buffer shows along the line of sight of a point q on a kernel's disc (`disc_view`).
const ON_SURFACE: u32 = 0u;
// Nothing, or a surface behind the disc's plane: the plane ends before q (an edge, a rim).
const OFF_EDGE: u32 = 1u;
// An opaque surface in front of the plane within the radius: q is inside what meets the
// plane there (a corner, an object standing on the surface).
const INSIDE: u32 = 2u;
// Glass or water in front of the plane within the radius: q is under what meets the plane.
const UNDER_GLASS: u32 = 3u;

// Seen past a farther occluder, or off the image, q is on surface.
fn disc_view(k: Kernel, q: vec3<f32>) -> u32 {
    let clip = params.clip_from_world * vec4<f32>(q, 1.0);
    if clip.w <= 0.0 {
        return ON_SURFACE;
    }
    let p = (vec2<f32>(0.5, -0.5) * clip.xy / clip.w + 0.5) * vec2<f32>(params.size);
    let at = vec2<i32>(floor(p));
    if any(at < vec2<i32>(0)) || any(at >= vec2<i32>(params.size)) {
        return ON_SURFACE;
    }
    let centre = vec2<i32>(i32(k.index % params.size.x), i32(k.index / params.size.x));
    if all(at == centre) {
        return select(ON_SURFACE, OFF_EDGE, past_crease(k, q, centre, p - vec2<f32>(centre) - 0.5));
    }
    let g = textureLoad(gbuffer_position, at, 0);
    let height = dot(g.xyz - k.position, k.plane);
    let slack = params.kernel_flattening * k.radius;
    if g.w == 0.0 || height < -slack {
        return OFF_EDGE;
    }
    if height <= slack || !behind_what_meets(k, q, g, at) {
        return ON_SURFACE;
    }
    return select(INSIDE, UNDER_GLASS, glass_share(gbuffer_material(g, 0.0)) > 0.0);
}

// Whether q lies inside what the G-buffer shows at `at` (g, in front of the kernel's plane):
// within the radius of it, or behind its surface where that surface is near the kernel (a
// corner seen at a slant puts the wall more than a radius before the disc points past it).
fn behind_what_meets(k: Kernel, q: vec3<f32>, g: vec4<f32>, at: vec2<i32>) -> bool {
    if distance(g.xyz, q) <= k.radius {
        return true;
    }
    let n = textureLoad(gbuffer_normal, at, 0);
    let plane = plane_at(at, g, n.xyz);
    return distance(g.xyz, k.position) <= 2.0 * max(k.radius, n.w) && dot(q - g.xyz, plane) < 0.0;
}

// The plane of the surface the G-buffer shows at `at` (its normal map left out: bumps are
// not creases).
fn plane_at(at: vec2<i32>, g: vec4<f32>, shading: vec3<f32>) -> vec3<f32> {
#ifdef TEXTURED
    return resolved_kernel_normal(surfaces[u32(at.y) * params.size.x + u32(at.x)], shading);
#else
    return kernel_normal(g, shading);
#endif
}

// The share of the kernel's disc that lies on surface, as the G-buffer shows it: the photons
// it holds are divided by that area, not the whole disc's (a disc that reaches past a
// concave corner, or an object standing on the surface, or past a convex edge, holds none
// there: the estimate read dark along every corner). Under glass or water that meets the
// surface the disc is off it too, and so are its photons there (`gather_run`).
fn disc_on_surface(k: Kernel) -> f32 {
    let frame = basis_around(k.plane);
    var on = 0.0;
    for (var i = 0u; i < DISC_POINTS; i += 1u) {
        let q = k.position + disc_point(frame, k.radius, i, DISC_POINTS);
        on += select(0.0, 1.0, disc_view(k, q) == ON_SURFACE);
    }
    return disc_share(on, DISC_POINTS);
}

// The normals of two surfaces that meet at a crease are further apart than this (~25°).
const CREASE_COS: f32 = 0.9;

// A point q that projects into the kernel's own pixel `centre` (`d` from its middle): the
// G-buffer cannot show a corner or an edge inside it, so q is tested against the surface the
// neighbouring pixel toward q sees, where that surface meets this one at a crease: q is off
// surface on the other side of its plane from the kernel's centre (past a concave corner or a
// convex edge). The jitter moves the centre over the pixel, so the share averages to the disc's.
fn past_crease(k: Kernel, q: vec3<f32>, centre: vec2<i32>, d: vec2<f32>) -> bool {
    let size = vec2<i32>(params.size);
    let toward = select(vec2<i32>(0, i32(sign(d.y))), vec2<i32>(i32(sign(d.x)), 0), abs(d.x) >= abs(d.y));
    let at = centre + toward;
    if all(toward == vec2<i32>(0)) || any(at < vec2<i32>(0)) || any(at >= size) {
        return false;
    }
    let g = textureLoad(gbuffer_position, at, 0);
    let n = textureLoad(gbuffer_normal, at, 0);
    if g.w == 0.0 {
        return false;
    }
    let plane = plane_at(at, g, n.xyz);
    // Another surface a few footprints away is an occluder's edge, not a crease.
    if dot(plane, k.plane) > CREASE_COS || distance(g.xyz, k.position) > 3.0 * n.w {
        return false;
    }
    return dot(q - g.xyz, plane) * dot(k.position - g.xyz, plane) < 0.0;
}

@compute @workgroup_size(8, 8, 1)
fn gather(@builtin(global_invocation_id) id: vec3<u32>) {
    let texel = vec2<i32>(id.xy);
    if any(id.xy >= textureDimensions(splats)) {
        return;
    }
#ifdef SUBSAMPLED
    let pixel = subsample_representative(params, id.xy);
#else
    let pixel = texel;
#endif
    let gp = textureLoad(gbuffer_position, pixel, 0);
    if gp.w == 0.0 {
        textureStore(splats, texel, vec4<f32>(0.0));
        return;
    }
    let gn = textureLoad(gbuffer_normal, pixel, 0);
    let index = u32(pixel.y) * params.size.x + u32(pixel.x);
#ifdef TEXTURED
    let plane = resolved_kernel_normal(surfaces[index], gn.xyz);
#else
    let plane = kernel_normal(gp, gn.xyz);
#endif
    let k = Kernel(gp.xyz, gather_radius(params, params.splat_radius, gn.w), plane, index);
#ifdef TEXTURED
    let m = resolved_material(gp, surfaces[index]);
#else
    let m = gbuffer_material(gp, gn.w);
#endif
    // No photon is stored on mirrors, clear or rough glass and smooth glossy metal, so none is
    // gathered there: their light comes by camera paths. (Water filling the view made the
    // splat walk 50 photons a pixel to find none.)
    if !stores_photons(m) {
        textureStore(splats, texel, vec4<f32>(0.0));
        return;
    }
    let wo = toward_eye(params, gp.xyz);
    let out = bsdf_from(m, gn.xyz, wo);
    var sum = vec3<f32>(0.0);
    let faces = faces_reached(cubemap, k.position, k.radius);
    for (var i = 0u; i < faces.y; i += 1u) {
        let face = (faces.x + i) % 6u;
        let seen = face_gather(cubemap, k.position, k.radius, k.plane, params.kernel_flattening, face);
        for (var y = seen.tiles.z; y <= seen.tiles.w; y += 1) {
            sum += gather_run(k, m, out, gn.xyz, wo, gather_row_run(seen, face, y));
        }
    }
    let density = splat_weight(params) / (PI * k.radius * k.radius * disc_on_surface(k));
    textureStore(splats, texel, vec4<f32>(sum * density, 0.0));
}
