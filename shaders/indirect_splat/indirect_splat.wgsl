// Indirect splatting, as a gather: `bin` lists every stored photon in the deep cubemap tile
// that holds it; `gather` has each importon visit the tiles its own gather sphere reaches, on
// every face (a sphere near a face's edge reaches the next face), and add the photons inside
// its radius, on its surface: throughput · f(wo, wi) · Φ / (π r²). The work is the photons
// near importons, each importon's sum stays in registers (no atomics), and a large radius
// elsewhere costs no one else.
#import bevy_rppm::common::{Material, Photon, Importon, IterationParams, PI, NO_IMPORTON, face_basis, cubemap_tile, splat_survives, splat_weight}
#import bevy_rppm::scene::{triangle_at, barycentrics, material_at}
#import bevy_rppm::bsdf::bsdf_eval
#import bevy_rppm::cubemap::cubemap

@group(1) @binding(0) var<uniform> params: IterationParams;

// `pad_a` of a binned photon: the next photon in its tile's list, as index + 1 (0 ends it).
@group(2) @binding(0) var<storage, read_write> photons: array<Photon>;
@group(2) @binding(1) var<storage, read> photon_count: array<u32, 4>;
@group(2) @binding(2) var<storage, read> importons: array<Importon>;
// Per cubemap tile, the head of its photon list (index + 1).
@group(2) @binding(3) var<storage, read_write> photon_heads: array<atomic<u32>>;
// Per pixel, the photons its importon gathered (rgb).
@group(2) @binding(4) var<storage, read_write> importon_radiance: array<vec4<f32>>;

@compute @workgroup_size(64, 1, 1)
fn bin(@builtin(global_invocation_id) id: vec3<u32>) {
    if id.x >= min(photon_count[1], params.photon_capacity) {
        return;
    }
    let tile = cubemap_tile(cubemap, photons[id.x].position);
    photons[id.x].pad_a = atomicExchange(&photon_heads[tile.index], id.x + 1u);
}

// The range of s = a / z a face's coordinate takes over a sphere of radius r centred at
// (a, z) in the face's frame, clipped to the face (|s| <= 1): the angles its disc on the
// (a, z) plane subtends from the cubemap's centre. Empty (x > y) when outside the face.
fn face_span(a: f32, z: f32, r: f32) -> vec2<f32> {
    let d = length(vec2<f32>(a, z));
    if d <= r {
        return vec2<f32>(-1.0, 1.0);
    }
    let centre = atan2(a, z);
    let half = asin(r / d);
    let lo = max(centre - half, -0.25 * PI);
    let hi = min(centre + half, 0.25 * PI);
    if lo > hi {
        return vec2<f32>(1.0, -1.0);
    }
    return vec2<f32>(tan(lo), tan(hi));
}

// The photons of one tile's list that importon `imp` (of `pixel`, on material `m`) gathers.
fn gather_list(imp: Importon, m: Material, pixel: u32, head: u32) -> vec3<f32> {
    var sum = vec3<f32>(0.0);
    var node = head;
    let r = imp.radius;
    for (var guard = 0u; node != 0u && guard < arrayLength(&photons); guard += 1u) {
        let photon = node - 1u;
        let p = photons[photon];
        node = p.pad_a;
        let offset = p.position - imp.position;
        if dot(offset, offset) > r * r || abs(dot(offset, imp.normal)) > params.kernel_flattening * r || dot(p.normal, imp.normal) < 0.5 {
            continue;
        }
        if !splat_survives(params, photon, pixel) {
            continue;
        }
        sum += bsdf_eval(m, imp.normal, imp.outgoing, p.incoming) * p.flux;
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
    let v = imp.position - cubemap.centre.xyz;
    let g = f32(cubemap.grid);
    let last = i32(cubemap.grid) - 1;
    var sum = vec3<f32>(0.0);
    for (var face = 0u; face < 6u; face += 1u) {
        let l = transpose(face_basis(face)) * v;
        let sx = face_span(l.x, l.z, imp.radius);
        let sy = face_span(l.y, l.z, imp.radius);
        if sx.x > sx.y || sy.x > sy.y {
            continue;
        }
        // Cells as cubemap_tile numbers them: x grows with s.x, y falls with s.y.
        let x0 = clamp(i32(floor((sx.x + 1.0) * 0.5 * g)), 0, last);
        let x1 = clamp(i32(floor((sx.y + 1.0) * 0.5 * g)), 0, last);
        let y0 = clamp(i32(floor((1.0 - sy.y) * 0.5 * g)), 0, last);
        let y1 = clamp(i32(floor((1.0 - sy.x) * 0.5 * g)), 0, last);
        for (var y = y0; y <= y1; y += 1) {
            for (var x = x0; x <= x1; x += 1) {
                let index = (face * cubemap.grid + u32(y)) * cubemap.grid + u32(x);
                sum += gather_list(imp, m, pixel, atomicLoad(&photon_heads[index]));
            }
        }
    }
    let r = imp.radius;
    importon_radiance[pixel] = vec4<f32>(imp.throughput * sum * (splat_weight(params) / (PI * r * r)), 0.0);
}
