// Indirect splatting: every stored photon is splatted onto each deep cubemap tile its gather
// sphere reaches, on every face (a splat near a face's edge reaches the next face, or the
// importons there would miss its photons); each tile's importon list is tested,
// and a photon inside an importon's radius, on its surface, adds
// throughput · f(wo, wi) · Φ / (π r²) to the importon's pixel.
#import bevy_rppm::common::{Photon, Importon, IterationParams, PI, face_basis, splat_survives, splat_weight}
#import bevy_rppm::scene::{triangle_at, barycentrics, material_at}
#import bevy_rppm::bsdf::bsdf_eval
#import bevy_rppm::cubemap::cubemap

@group(1) @binding(0) var<uniform> params: IterationParams;

@group(2) @binding(0) var<storage, read> photons: array<Photon>;
@group(2) @binding(1) var<storage, read> photon_count: array<u32, 4>;
@group(2) @binding(2) var<storage, read> importons: array<Importon>;
@group(2) @binding(3) var<storage, read> importon_heads: array<u32>;
@group(2) @binding(4) var<storage, read> importon_stats: array<u32, 8>;
// Per pixel rgb (+ pad) as f32 bits, summed with compare-exchange.
@group(2) @binding(5) var<storage, read_write> importon_radiance: array<atomic<u32>>;

fn add_f32(index: u32, value: f32) {
    var old = atomicLoad(&importon_radiance[index]);
    loop {
        let swapped = atomicCompareExchangeWeak(&importon_radiance[index], old, bitcast<u32>(bitcast<f32>(old) + value));
        if swapped.exchanged {
            return;
        }
        old = swapped.old_value;
    }
}

fn gather(p: Photon, photon: u32, list: u32) {
    var node = list;
    for (var guard = 0u; node != 0u && guard < arrayLength(&importons); guard += 1u) {
        let pixel = node - 1u;
        let imp = importons[pixel];
        node = imp.next;
        let offset = p.position - imp.position;
        let r = imp.radius;
        if dot(offset, offset) > r * r || abs(dot(offset, imp.normal)) > params.kernel_flattening * r || dot(p.normal, imp.normal) < 0.5 {
            continue;
        }
        if !splat_survives(params, photon, pixel) {
            continue;
        }
        let f = bsdf_eval(material_at(imp.triangle, barycentrics(triangle_at(imp.triangle), imp.position), 0.0), imp.normal, imp.outgoing, p.incoming);
        let c = imp.throughput * f * p.flux * (splat_weight(params) / (PI * r * r));
        add_f32(4u * pixel, c.x);
        add_f32(4u * pixel + 1u, c.y);
        add_f32(4u * pixel + 2u, c.z);
    }
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

@compute @workgroup_size(64, 1, 1)
fn main(@builtin(global_invocation_id) id: vec3<u32>) {
    if id.x >= min(photon_count[1], params.photon_capacity) || importon_stats[1] == 0u {
        return;
    }
    let p = photons[id.x];
    let radius = bitcast<f32>(importon_stats[0]);
    let v = p.position - cubemap.centre.xyz;
    let g = f32(cubemap.grid);
    let last = i32(cubemap.grid) - 1;
    for (var face = 0u; face < 6u; face += 1u) {
        let l = transpose(face_basis(face)) * v;
        let sx = face_span(l.x, l.z, radius);
        let sy = face_span(l.y, l.z, radius);
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
                gather(p, id.x, importon_heads[index]);
            }
        }
    }
}
