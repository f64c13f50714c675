// Indirect splatting, as a gather: photon tracing lists every stored photon in the deep
// cubemap tile that holds it; each importon visits the tiles its own gather sphere reaches, on
// every face (a sphere near a face's edge reaches the next face), and adds the photons inside
// its radius, on its surface: throughput · f(wo, wi) · Φ / (π r²). The work is the photons
// near importons, each importon's sum stays in registers (no atomics), and a large radius
// elsewhere costs no one else.
#import bevy_rppm::common::{Material, Outgoing, Photon, Importon, IterationParams, PI, NO_IMPORTON, faces_reached, splat_weight}
#import bevy_rppm::scene::{triangle_at, barycentrics, material_at}
#import bevy_rppm::bsdf::{bsdf_from, bsdf_toward, translucency}
#import bevy_rppm::cubemap::cubemap
#import bevy_rppm::photon_lists::{photons, listed_tiles, list_head, next_in_kernel}

@group(1) @binding(0) var<uniform> params: IterationParams;

// Bindings 0 and 1: the photons and their lists (photons/lists.wgsl).
@group(2) @binding(2) var<storage, read> importons: array<Importon>;
// Per pixel, the photons its importon gathered (rgb).
@group(2) @binding(3) var<storage, read_write> importon_radiance: array<vec4<f32>>;

// The photons of one tile's list that importon `imp` (of `pixel`, on material `m`, `out` its
// bsdf_from) gathers.
fn gather_list(imp: Importon, m: Material, out: Outgoing, pixel: u32, head: u32) -> vec3<f32> {
    var sum = vec3<f32>(0.0);
    var walked = 0u;
    let both_sides = translucency(m) > 0.0;
    var node = next_in_kernel(head, &walked, params, imp.position, imp.normal, imp.radius, pixel, both_sides);
    while node != 0u {
        let p = photons[node - 1u];
        sum += bsdf_toward(m, out, imp.normal, imp.outgoing, p.incoming) * p.flux;
        node = next_in_kernel(p.next, &walked, params, imp.position, imp.normal, imp.radius, pixel, both_sides);
    }
    return sum;
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
        let tiles = listed_tiles(face, imp.position, imp.radius);
        for (var y = tiles.z; y <= tiles.w; y += 1) {
            for (var x = tiles.x; x <= tiles.y; x += 1) {
                sum += gather_list(imp, m, out, pixel, list_head(face, x, y));
            }
        }
    }
    let r = imp.radius;
    importon_radiance[pixel] = vec4<f32>(imp.throughput * sum * (splat_weight(params) / (PI * r * r)), 0.0);
}
