// Direct splatting, as a gather: each pixel's G-buffer point (its importon at the camera)
// visits the deep cubemap tiles its gather sphere reaches, a run of the photon map per row of
// tiles (photons/sort.wgsl), and adds the photons inside its kernel: a disc of the gather radius on its
// surface, flattened along its normal. The estimate is Σ f(wo, wi) Φ / (π r²), summed in
// registers, one thread a pixel: no quad per photon, no blending, and the work is the
// photons near visible surfaces.
// SUBSAMPLED (ISPM): the target has one texel per n×n pixels, gathered at one representative
// pixel of the block, and holds incident light Σ Φ / (π r²) for the joint-bilateral upsampling
// in shaders/accumulate/accumulate.wgsl, which applies each full-resolution pixel's own BSDF.
#import bevy_rppm::common::{Material, Outgoing, Photon, IterationParams, PI, basis_around, faces_reached, gather_radius, splat_weight, subsample_representative, unpack_normal}
#import bevy_rppm::camera::toward_eye
#import bevy_rppm::scene::{gbuffer_material, resolved_material, resolved_kernel_normal, kernel_normal}
#import bevy_rppm::bsdf::{bsdf_from, bsdf_gathered, bent_cosine, glass_share, translucency, stores_photons}
#import bevy_rppm::cubemap::cubemap
#import bevy_rppm::photon_map::{photons, photon_disc, CAUSTIC_DISC, NO_DISC, face_gather, gather_row_run, next_in_kernel, disc_point, kernel_scale, kernel_stats_after, kernel_count, disc_count, disc_shares}

@group(1) @binding(0) var<uniform> params: IterationParams;

// Bindings 0 and 1: the photon map and its tiles' starts (photons/map.wgsl).
@group(2) @binding(2) var gbuffer_position: texture_2d<f32>;
@group(2) @binding(3) var gbuffer_normal: texture_2d<f32>;
// Each pixel's textures, looked up once by local illumination (`resolve_surface`); a
// stand-in when the scene has none.
@group(2) @binding(4) var<storage, read> surfaces: array<vec4<u32>>;
@group(2) @binding(5) var splats: texture_storage_2d<rgba32float, write>;
#ifdef ADAPTIVE_KERNEL
// Per pixel, what its kernels met since the radius sequence began (`kernel_scale`).
@group(2) @binding(6) var<storage, read_write> kernel_stats: array<vec4<f32>>;

// Photons a kernel held this iteration: all, and those within half its radius.
var<private> held: vec2<f32>;
#endif
// The caustic photons a kernel gathered (`photon_caustic`), within `caustic_scale` of its
// radius, where that is under 1 (`gather_run`'s sum holds the others then).
var<private> caustics: vec3<f32>;

// What one pixel's kernel needs of its G-buffer point.
struct Kernel {
    position: vec3<f32>,
    radius: f32,
    // The plane the kernel lies in (the interpolated normal where a normal map bends the
    // shading normal).
    plane: vec3<f32>,
    index: u32,
    // Planes of surfaces beside the kernel that meet its plane at a crease (`creases_around`),
    // as (n, d) with n·x + d > 0 on the kernel centre's side; bit c of `convex` set where the
    // centre lies behind crease c's surface (a convex edge), bit c of `glass` where it is glass.
    creases: array<vec4<f32>, 2>,
    crease_count: u32,
    convex: u32,
    glass: u32,
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
        // Past a crease beside the kernel the disc's area is left out, and so are its photons
        // there (a thin screen standing on the floor has other light behind it).
        if crease_past(k, p.position) < k.crease_count {
            continue;
        }
#ifdef GLASS
        // Under glass or water that meets the surface (a wall below the water line), other
        // light arrives than on the surface the camera sees: the disc's area leaves it out too.
        if disc_view(k, p.position) == UNDER_GLASS {
            continue;
        }
#endif
#ifdef ADAPTIVE_KERNEL
#ifndef SUBSAMPLED
        held += kernel_count(p.position - k.position, k.radius);
#endif
#endif
        let in_disc = photon_disc(params, p, k.position, k.radius);
        if in_disc == NO_DISC {
            continue;
        }
#ifdef SUBSAMPLED
        let light = p.flux;
#else
        // The photons' density is irradiance on the kernel's plane; a normal map's bent
        // normal receives it by its own cosine instead (on either side: diffuse transmission).
        let incoming = unpack_normal(p.incoming);
        let bend = select(1.0, bent_cosine(shading, k.plane, incoming), bent);
        let light = bsdf_gathered(m, out, shading, wo, incoming) * (bend * p.flux);
#endif
        if in_disc == CAUSTIC_DISC {
            caustics += light;
        } else {
            sum += light;
        }
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
    // Past a crease beside the kernel, q is off surface, whatever the pixel it projects
    // into shows: the crease runs through pixels whose one sample shows either surface.
    let past = crease_past(k, q);
    if past < k.crease_count {
        if (k.convex & (1u << past)) != 0u {
            return OFF_EDGE;
        }
        return select(INSIDE, UNDER_GLASS, (k.glass & (1u << past)) != 0u);
    }
    let clip = params.clip_from_world * vec4<f32>(q, 1.0);
    if clip.w <= 0.0 {
        return ON_SURFACE;
    }
    let uv = vec2<f32>(0.5, -0.5) * clip.xy / clip.w + 0.5;
    let at = vec2<i32>(floor(uv * vec2<f32>(params.size)));
    if any(at < vec2<i32>(0)) || any(at >= vec2<i32>(params.size)) {
        return ON_SURFACE;
    }
    let centre = vec2<i32>(i32(k.index % params.size.x), i32(k.index / params.size.x));
    if all(at == centre) {
        return ON_SURFACE;
    }
    let g = textureLoad(gbuffer_position, at, 0);
    if g.w == 0.0 {
        return OFF_EDGE;
    }
    let height = dot(g.xyz - k.position, k.plane);
    let slack = params.kernel_flattening * k.radius;
    if abs(height) <= slack {
        return ON_SURFACE;
    }
    let n = textureLoad(gbuffer_normal, at, 0);
    let plane = plane_at(at, g, n.xyz);
    if crease_near(k, g, plane, n.w) {
        // On the centre's side of a surface that meets the plane near the kernel (its pixel
        // may show either surface), q is on surface; past it, as past the creases beside.
        let crease = crease_of(k, g.xyz, plane);
        if dot(crease.plane.xyz, q) + crease.plane.w >= 0.0 {
            return ON_SURFACE;
        }
        if crease.convex {
            return OFF_EDGE;
        }
    } else if height < 0.0 {
        return OFF_EDGE;
    } else if !behind_what_meets(k, q, g, plane, n.w) {
        return ON_SURFACE;
    }
    return select(INSIDE, UNDER_GLASS, glass_share(gbuffer_material(g, 0.0)) > 0.0);
}

// The first of kernel k's creases that q lies past, or its crease count if none.
fn crease_past(k: Kernel, q: vec3<f32>) -> u32 {
    for (var c = 0u; c < k.crease_count; c += 1u) {
        if dot(k.creases[c].xyz, q) + k.creases[c].w < 0.0 {
            return c;
        }
    }
    return k.crease_count;
}

// The plane of a surface at g (normal `plane`) that meets the kernel's at a crease, as
// (n, d) with n·x + d >= 0 on the kernel centre's side; convex where the centre lies behind
// that surface (an edge), not in front of it (a corner).
struct Crease {
    plane: vec4<f32>,
    convex: bool,
}

fn crease_of(k: Kernel, g: vec3<f32>, plane: vec3<f32>) -> Crease {
    let side = dot(k.position - g, plane);
    let facing = select(-1.0, 1.0, side >= 0.0);
    return Crease(vec4<f32>(plane * facing, -dot(plane, g) * facing), side < 0.0);
}

// How far from the kernel a surface may lie and still be taken for one that meets the
// kernel's plane at a crease, in radii (or footprints): a corner seen at a slant puts the
// wall that hides the disc points past it a few radii before them.
const CREASE_REACH: f32 = 4.0;

// Whether the surface at g (plane normal `plane`, footprint `footprint`) meets the kernel's
// plane at a crease near the kernel.
fn crease_near(k: Kernel, g: vec4<f32>, plane: vec3<f32>, footprint: f32) -> bool {
    return dot(plane, k.plane) <= CREASE_COS && distance(g.xyz, k.position) <= CREASE_REACH * max(k.radius, footprint);
}

// Whether q lies inside what the G-buffer shows at `at` (g, in front of the kernel's plane):
// within the radius of it, or behind its surface where that surface is near the kernel (a
// corner seen at a slant puts the wall more than a radius before the disc points past it).
fn behind_what_meets(k: Kernel, q: vec3<f32>, g: vec4<f32>, plane: vec3<f32>, footprint: f32) -> bool {
    if distance(g.xyz, q) <= k.radius {
        return true;
    }
    return distance(g.xyz, k.position) <= 2.0 * max(k.radius, footprint) && dot(q - g.xyz, plane) < 0.0;
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
// surface the disc is off it too, and so are its photons there (`gather_run`). y: the share
// of its inner half (`disc_count`).
fn disc_on_surface(k: Kernel) -> vec2<f32> {
    let frame = basis_around(k.plane);
    var on = vec2<f32>(0.0);
    for (var i = 0u; i < DISC_POINTS; i += 1u) {
        let q = k.position + disc_point(frame, k.radius, i, DISC_POINTS);
        on += disc_count(disc_view(k, q) == ON_SURFACE, i, DISC_POINTS);
    }
    return disc_shares(on, DISC_POINTS);
}

// The normals of two surfaces that meet at a crease are further apart than this (~25°).
const CREASE_COS: f32 = 0.9;

// The creases beside kernel k: the planes its eight neighbouring pixels show that meet its
// plane (`crease_near`), two at most (a room's corner), each oriented towards the centre. A
// crease inside the kernel's own pixel is where its neighbours show the other surface.
fn creases_around(k_in: Kernel, pixel: vec2<i32>) -> Kernel {
    var k = k_in;
    for (var j = 0; j < 9; j += 1) {
        let at = pixel + vec2<i32>(j % 3 - 1, j / 3 - 1);
        if j == 4 || any(at < vec2<i32>(0)) || any(at >= vec2<i32>(params.size)) || k.crease_count == 2u {
            continue;
        }
        let g = textureLoad(gbuffer_position, at, 0);
        if g.w == 0.0 {
            continue;
        }
        let n = textureLoad(gbuffer_normal, at, 0);
        let plane = plane_at(at, g, n.xyz);
        if !crease_near(k, g, plane, n.w) || (k.crease_count == 1u && abs(dot(plane, k.creases[0].xyz)) > CREASE_COS) {
            continue;
        }
        let crease = crease_of(k, g.xyz, plane);
        let c = k.crease_count;
        k.creases[c] = crease.plane;
        k.convex |= select(0u, 1u << c, crease.convex);
        k.glass |= select(0u, 1u << c, glass_share(gbuffer_material(g, 0.0)) > 0.0);
        k.crease_count += 1u;
    }
    return k;
}

// A pixel that gathers nothing this iteration keeps its kernel's statistics, but for a new
// radius sequence.
fn skip_kernel(texel: vec2<i32>, index: u32) {
    textureStore(splats, texel, vec4<f32>(0.0));
#ifdef ADAPTIVE_KERNEL
    if params.radius_restart != 0u {
        kernel_stats[index] = vec4<f32>(0.0);
    }
#endif
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
    let index = u32(pixel.y) * params.size.x + u32(pixel.x);
    let gp = textureLoad(gbuffer_position, pixel, 0);
    if gp.w == 0.0 {
        skip_kernel(texel, index);
        return;
    }
#ifdef ADAPTIVE_KERNEL
    let stats = kernel_stats[index];
    let scale = kernel_scale(params, stats);
#else
    let scale = 1.0;
#endif
    let gn = textureLoad(gbuffer_normal, pixel, 0);
#ifdef TEXTURED
    let plane = resolved_kernel_normal(surfaces[index], gn.xyz);
#else
    let plane = kernel_normal(gp, gn.xyz);
#endif
    var k = Kernel(gp.xyz, gather_radius(params, params.splat_radius * scale, gn.w), plane, index, array<vec4<f32>, 2>(), 0u, 0u, 0u);
#ifdef TEXTURED
    let m = resolved_material(gp, surfaces[index]);
#else
    let m = gbuffer_material(gp, gn.w);
#endif
    // No photon is stored on mirrors, clear or rough glass and smooth glossy metal, so none is
    // gathered there: their light comes by camera paths. (Water filling the view made the
    // splat walk 50 photons a pixel to find none.)
    if !stores_photons(m) {
        skip_kernel(texel, index);
        return;
    }
    k = creases_around(k, pixel);
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
    let share = disc_on_surface(k);
#ifdef ADAPTIVE_KERNEL
    kernel_stats[index] = kernel_stats_after(params, stats, params.splat_radius * scale, held, share);
#endif
    let density = splat_weight(params) / (PI * k.radius * k.radius * share.x);
    var light = sum * density;
    if params.caustic_scale < 1.0 {
        // The caustic photons over their own disc's area on surface.
        var narrow = k;
        narrow.radius *= params.caustic_scale;
        let area = PI * narrow.radius * narrow.radius * disc_on_surface(narrow).x;
        light += caustics * (splat_weight(params) / area);
    }
    textureStore(splats, texel, vec4<f32>(light, 0.0));
}
