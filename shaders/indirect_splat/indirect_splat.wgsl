// Indirect splatting, as a gather: the photon map holds the stored photons by deep cubemap
// tile (photons/sort.wgsl); each importon visits the tiles its own gather sphere reaches, on
// every face (a sphere near a face's edge reaches the next face), and adds the photons inside
// its radius, on its surface: throughput · f(wo, wi) · Φ over the area of its disc that lies on
// surface (π r² times `disc_on_surface`). The work is the photons
// near importons, each importon's sum stays in registers (no atomics), and a large radius
// elsewhere costs no one else.
#import bevy_rppm::common::{Material, Outgoing, Photon, Importon, IterationParams, PI, NO_IMPORTON, basis_around, faces_reached, splat_weight, unpack_normal}
#import bevy_rppm::scene::{triangle_at, barycentrics, material_at}
#import bevy_rppm::bsdf::{bsdf_from, bsdf_toward, glass_share, translucency}
#import bevy_rppm::cubemap::{cubemap, trace_ray, NO_HIT}
#import bevy_rppm::photon_map::{photons, face_gather, gather_row_run, next_in_kernel, disc_point, disc_share}

@group(1) @binding(0) var<uniform> params: IterationParams;

// Bindings 0 and 1: the photon map and its tiles' starts (photons/map.wgsl).
@group(2) @binding(2) var<storage, read> importons: array<Importon>;
// Per pixel, the photons its importon gathered (rgb).
@group(2) @binding(3) var<storage, read_write> importon_radiance: array<vec4<f32>>;

// The photons of run `run` of the map that importon `imp` (of `pixel`, on material `m`, `out`
// its bsdf_from) gathers.
fn gather_run(imp: Importon, m: Material, out: Outgoing, pixel: u32, run: vec2<u32>) -> vec3<f32> {
    var sum = vec3<f32>(0.0);
    let both_sides = translucency(m) > 0.0;
    var i = next_in_kernel(run.x, run.y, params, imp.position, imp.normal, imp.radius, pixel, both_sides);
    while i < run.y {
        let p = photons[i];
        sum += bsdf_toward(m, out, imp.normal, imp.outgoing, unpack_normal(p.incoming)) * p.flux;
        i = next_in_kernel(i + 1u, run.y, params, imp.position, imp.normal, imp.radius, pixel, both_sides);
    }
    return sum;
}

// Points of an importon's disc checked for a surface (`disc_point`; the direct splat's
// G-buffer test, shaders/splat/splat.wgsl, has no G-buffer here).
const DISC_POINTS: u32 = 8u;

// The share of an importon's disc that lies on surface: a point of the disc does not count
// where a ray along the plane, just above it, from the centre meets an opaque surface before
// it (a corner, an object standing on the surface: no photon lands beyond). At least a
// quarter.
fn disc_on_surface(imp: Importon) -> f32 {
    let frame = basis_around(imp.normal);
    let r = imp.radius;
    let origin = imp.position + imp.normal * (0.5 * params.kernel_flattening * r);
    var on = 0.0;
    for (var i = 0u; i < DISC_POINTS; i += 1u) {
        let q = disc_point(frame, r, i, DISC_POINTS);
        let rho = length(q);
        let hit = trace_ray(origin, q / rho, 0.0, rho, imp.triangle);
        var counts = hit.triangle == NO_HIT;
        if !counts {
            // Past glass or water the disc counts, unlike the direct splat's (`disc_view`):
            // with no G-buffer to look its photons up in, they all count here, so its area does.
            counts = glass_share(material_at(hit.triangle, hit.uv, 0.0)) > 0.0;
        }
        on += select(0.0, 1.0, counts);
    }
    return disc_share(on, DISC_POINTS);
}

@compute @workgroup_size(64, 1, 1)
fn gather(@builtin(global_invocation_id) id: vec3<u32>) {
    let pixel = id.x;
    if pixel >= params.size.x * params.size.y || importons[pixel].triangle == NO_IMPORTON {
        return;
    }
    let imp = importons[pixel];
    let m = material_at(imp.triangle, barycentrics(triangle_at(imp.triangle), imp.position), 0.0);
    let out = bsdf_from(m, imp.normal, imp.outgoing);
    var sum = vec3<f32>(0.0);
    let faces = faces_reached(cubemap, imp.position, imp.radius);
    for (var i = 0u; i < faces.y; i += 1u) {
        let face = (faces.x + i) % 6u;
        let seen = face_gather(cubemap, imp.position, imp.radius, imp.normal, params.kernel_flattening, face);
        for (var y = seen.tiles.z; y <= seen.tiles.w; y += 1) {
            sum += gather_run(imp, m, out, pixel, gather_row_run(seen, face, y));
        }
    }
    let r = imp.radius;
    let area = PI * r * r * disc_on_surface(imp);
    importon_radiance[pixel] = vec4<f32>(imp.throughput * sum * (splat_weight(params) / area), 0.0);
}
