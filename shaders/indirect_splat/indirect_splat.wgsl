// Indirect splatting, as a gather: the photon map holds the stored photons by deep cubemap
// tile (photons/sort.wgsl); each importon visits the tiles its own gather sphere reaches, on
// every face (a sphere near a face's edge reaches the next face), and adds the photons inside
// its radius, on its surface: throughput · f(wo, wi) · Φ over the area of its disc that lies on
// surface (π r² times the share `disc_of` finds). The work is the photons
// near importons, each importon's sum stays in registers (no atomics), and a large radius
// elsewhere costs no one else.
#import bevy_rppm::common::{Material, Outgoing, Photon, Importon, IterationParams, PI, NO_IMPORTON, basis_around, faces_reached, splat_weight, unpack_normal}
#import bevy_rppm::scene::{triangle_at, face_normal, barycentrics, material_at}
#import bevy_rppm::bsdf::{bsdf_from, bsdf_toward, glass_share, translucency}
#import bevy_rppm::cubemap::{cubemap, trace_ray, NO_HIT}
#import bevy_rppm::photon_map::{photons, photon_disc, CAUSTIC_DISC, NO_DISC, face_gather, gather_row_run, next_in_kernel, disc_point, kernel_scale, kernel_stats_after, kernel_count, disc_count, disc_share, disc_shares}

@group(1) @binding(0) var<uniform> params: IterationParams;

// Bindings 0 and 1: the photon map and its tiles' starts (photons/map.wgsl).
@group(2) @binding(2) var<storage, read> importons: array<Importon>;
// Per pixel, the photons its importon gathered (rgb).
@group(2) @binding(3) var<storage, read_write> importon_radiance: array<vec4<f32>>;
#ifdef ADAPTIVE_KERNEL
// Per pixel, what its own importon's kernels met since the radius sequence began
// (`kernel_scale`; cleared when the sequence restarts, src/graph/node.rs), in pixels of the
// importon's footprint.
@group(2) @binding(4) var<storage, read_write> kernel_stats: array<vec4<f32>>;

// Photons a kernel held this iteration: all, and those within half its radius; the shares
// of its disc on surface (`Disc::shares`).
var<private> held: vec2<f32>;
var<private> gathered_shares: vec2<f32>;
#endif
// The caustic photons a kernel gathered (`photon_caustic`), within `caustic_scale` of its
// radius, where that is under 1 (`gather_run`'s sum holds the others then).
var<private> caustics: vec3<f32>;

// The photons of run `run` of the map that importon `imp` (of `pixel`, on material `m`, `out`
// its bsdf_from) gathers, but those past glass that meets its surface (`disc`).
fn gather_run(imp: Importon, m: Material, out: Outgoing, pixel: u32, run: vec2<u32>, disc: Disc) -> vec3<f32> {
    var sum = vec3<f32>(0.0);
    let both_sides = translucency(m) > 0.0;
    var i = next_in_kernel(run.x, run.y, params, imp.position, imp.normal, imp.radius, pixel, both_sides);
    while i < run.y {
        let p = photons[i];
        i = next_in_kernel(i + 1u, run.y, params, imp.position, imp.normal, imp.radius, pixel, both_sides);
        if past_glass(disc, p.position) {
            continue;
        }
#ifdef ADAPTIVE_KERNEL
        held += kernel_count(p.position - imp.position, imp.radius);
#endif
        let in_disc = photon_disc(params, p, imp.position, imp.radius);
        if in_disc == NO_DISC {
            continue;
        }
        let light = bsdf_toward(m, out, imp.normal, imp.outgoing, unpack_normal(p.incoming)) * p.flux;
        if in_disc == CAUSTIC_DISC {
            caustics += light;
        } else {
            sum += light;
        }
    }
    return sum;
}

// Directions along an importon's disc traced for a surface that ends it (`disc_of`; the
// direct splat's G-buffer test, shaders/splat/splat.wgsl, has no G-buffer here).
const DISC_POINTS: u32 = 8u;
// Points its shares are counted on, each against the surface met along the traced direction
// nearest its own: 8 points, one a direction, read a wall across the disc 1/8 at a time,
// in steps a whole row of pixels along the wall shares (a bright line at a pool's floor).
const SHARE_POINTS: u32 = 32u;
// Glass surfaces met within a disc that are kept as its cuts.
const CUTS: u32 = 2u;

// Of the traced points' directions (`disc_point`'s golden angle), the nearest to point j of
// SHARE_POINTS: four bits a point, eight points a word (src/indirect_splat/disc.rs finds
// them by angle and checks these).
fn nearest_direction(j: u32) -> u32 {
    let words = vec4<u32>(0x76543210u, 0x21043210u, 0x21076543u, 0x54376543u);
    return (words[j / 8u] >> (4u * (j % 8u))) & 15u;
}

#ifdef GLASS
// The plane of glass triangle `t`, met at `hit`, turned to face `centre`.
fn cut_plane(t: u32, hit: vec3<f32>, centre: vec3<f32>) -> vec4<f32> {
    var n = face_normal(triangle_at(t));
    n = select(n, -n, dot(n, centre - hit) < 0.0);
    return vec4<f32>(n, -dot(n, hit));
}
#endif

// An importon's disc: the share of it that lies on surface, and the planes of the glass or
// water that meets the surface within it (the centre on their positive side).
struct Disc {
    // The shares of the disc and of its inner half (`disc_shares`).
    shares: vec2<f32>,
    // The share of the caustic photons' disc (`caustic_scale` of the radius).
    caustic_share: f32,
    cut_count: u32,
    cuts: array<vec4<f32>, CUTS>,
}

// Whether q lies past one of the disc's cuts: under glass or water that meets the surface (a
// wall below the water line), where other light arrives than at the centre, as the direct
// splat's `disc_view` finds it through the G-buffer.
fn past_glass(disc: Disc, q: vec3<f32>) -> bool {
    var past = false;
#ifdef GLASS
    for (var c = 0u; c < disc.cut_count; c += 1u) {
        past = past || dot(disc.cuts[c].xyz, q) + disc.cuts[c].w < 0.0;
    }
#endif
    return past;
}

// Where the opaque surface met along a traced direction `dir` at distance t ends the disc
// (normal n): the line it cuts the disc's plane (normal `plane`) in, as (m, w) with the
// offsets q past it where m · q > w. A surface nearly in the plane (a ramp), or met at a
// grazing angle (whose line would pass by the centre, though it may end just before the
// hit), ends it across the direction.
const GRAZING_COS: f32 = 0.3;

fn end_line(dir: vec3<f32>, t: f32, n: vec3<f32>, plane: vec3<f32>) -> vec4<f32> {
    var m = n - dot(n, plane) * plane;
    m = select(dir, normalize(m), dot(m, m) > 0.09);
    m = select(m, -m, dot(m, dir) < 0.0);
    m = select(dir, m, dot(m, dir) > GRAZING_COS);
    return vec4<f32>(m, t * dot(m, dir));
}

// An importon's disc: a point of it does not count where the ray along the plane, just above
// it, from the centre toward it, or the traced direction nearest it, meets an opaque
// surface before it (a corner, an object standing on the surface: no photon lands beyond),
// nor where it lies past glass or water met so (the photons there are left out too). At
// least a quarter.
fn disc_of(imp: Importon) -> Disc {
    let frame = basis_around(imp.normal);
    let r = imp.radius;
    let origin = imp.position + imp.normal * (0.5 * params.kernel_flattening * r);
    var disc = Disc(vec2<f32>(1.0), 1.0, 0u, array<vec4<f32>, CUTS>(vec4<f32>(0.0), vec4<f32>(0.0)));
    // Per traced direction, the line past which the disc is off surface (none: past 2r).
    var ends: array<vec4<f32>, DISC_POINTS>;
    var ended = false;
    for (var i = 0u; i < DISC_POINTS; i += 1u) {
        let q = disc_point(frame, r, i, DISC_POINTS);
        let dir = q / length(q);
        ends[i] = vec4<f32>(dir, 2.0 * r);
        // To the rim, not to the point: a surface met past it still ends the points beside.
        let hit = trace_ray(origin, dir, 0.0, r, imp.triangle);
        if hit.triangle == NO_HIT {
            continue;
        }
#ifdef GLASS
        if glass_share(material_at(hit.triangle, hit.uv, 0.0)) > 0.0 {
            if disc.cut_count < CUTS {
                let at = origin + hit.t * dir;
                disc.cuts[disc.cut_count] = cut_plane(hit.triangle, at, imp.position);
                disc.cut_count += 1u;
            }
            continue;
        }
#endif
        ends[i] = end_line(dir, hit.t, face_normal(triangle_at(hit.triangle)), imp.normal);
        ended = true;
    }
    if !ended && disc.cut_count == 0u {
        return disc; // an open disc: most importons
    }
    // The caustic disc's points lie along the same directions, nearer (`caustic_scale`).
    let scale = params.caustic_scale;
    var on = vec2<f32>(0.0);
    var caustic_on = 0.0;
    for (var j = 0u; j < SHARE_POINTS; j += 1u) {
        let q = disc_point(frame, r, j, SHARE_POINTS);
        let end = ends[nearest_direction(j)];
        on += disc_count(dot(end.xyz, q) <= end.w && !past_glass(disc, imp.position + q), j, SHARE_POINTS);
        if scale < 1.0 {
            let near = q * scale;
            caustic_on += select(0.0, 1.0, dot(end.xyz, near) <= end.w && !past_glass(disc, imp.position + near));
        }
    }
    disc.shares = disc_shares(on, SHARE_POINTS);
    // Read only where the caustic disc is narrower (`gathered`).
    disc.caustic_share = disc_share(caustic_on, SHARE_POINTS);
    return disc;
}

// The light importon `imp` (of `pixel`) brings: the photons in its disc, over the disc's
// area on surface.
fn gathered(imp: Importon, pixel: u32) -> vec3<f32> {
    let m = material_at(imp.triangle, barycentrics(triangle_at(imp.triangle), imp.position), 0.0);
    let out = bsdf_from(m, imp.normal, imp.outgoing);
    let disc = disc_of(imp);
    var sum = vec3<f32>(0.0);
    caustics = vec3<f32>(0.0);
    let faces = faces_reached(cubemap, imp.position, imp.radius);
    for (var i = 0u; i < faces.y; i += 1u) {
        let face = (faces.x + i) % 6u;
        let seen = face_gather(cubemap, imp.position, imp.radius, imp.normal, params.kernel_flattening, face);
        for (var y = seen.tiles.z; y <= seen.tiles.w; y += 1) {
            sum += gather_run(imp, m, out, pixel, gather_row_run(seen, face, y), disc);
        }
    }
#ifdef ADAPTIVE_KERNEL
    gathered_shares = disc.shares;
#endif
    let r = imp.radius;
    let area = PI * r * r * disc.shares.x;
    var light = imp.throughput * sum * (splat_weight(params) / area);
    if params.caustic_scale < 1.0 {
        // The caustic photons over their own disc's area on surface.
        let narrow = r * params.caustic_scale;
        light += imp.throughput * caustics * (splat_weight(params) / (PI * narrow * narrow * disc.caustic_share));
    }
    return light;
}

// A pixel's importon and those its other camera paths left (`Importon::extras`).
@compute @workgroup_size(64, 1, 1)
fn gather(@builtin(global_invocation_id) id: vec3<u32>) {
    let pixel = id.x;
    if pixel >= params.size.x * params.size.y {
        return;
    }
    let own = importons[pixel];
    if own.triangle == NO_IMPORTON && own.extras == 0u {
        return;
    }
    var sum = vec3<f32>(0.0);
#ifdef ADAPTIVE_KERNEL
    // The pixel's kernels shrink where they blur (a caustic's rim seen in a mirror, a floor
    // under glass beside the light around it), by what its own importon's met.
    let stats = kernel_stats[pixel];
    let scale = kernel_scale(params, stats);
#else
    let scale = 1.0;
#endif
    // One call of the gather (its copies cost compile time on a CPU rasteriser).
    for (var k = 0u; k <= own.extras; k += 1u) {
        var imp = own;
        if k > 0u {
            imp = importons[own.first_extra + k - 1u];
        }
        if imp.triangle != NO_IMPORTON {
            imp.radius *= scale;
            sum += gathered(imp, pixel);
#ifdef ADAPTIVE_KERNEL
            if k == 0u {
                kernel_stats[pixel] = kernel_stats_after(params, stats, params.splat_radius * scale, held, gathered_shares);
            }
#endif
        }
    }
    importon_radiance[pixel] = vec4<f32>(sum, 0.0);
}
