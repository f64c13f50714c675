// Indirect splatting: every stored photon is splatted onto the deep cubemap face that holds
// it, over the tiles its gather radius can reach there; each tile's importon list is tested,
// and a photon inside an importon's radius, on its surface, adds
// throughput · f(wo, wi) · Φ / (π r²) to the importon's pixel.
#import bevy_rppm::common::{Photon, Importon, IterationParams, PI, cubemap_tile, splat_survives, splat_weight}
#import bevy_rppm::scene::{triangles, barycentrics, material_at}
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

// The tiles a splat may span on each side, at most.
const MAX_REACH: i32 = 8;

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
        let f = bsdf_eval(material_at(imp.triangle, barycentrics(triangles[imp.triangle], imp.position), 0.0), imp.normal, imp.outgoing, p.incoming);
        let c = imp.throughput * f * p.flux * (splat_weight(params) / (PI * r * r));
        add_f32(4u * pixel, c.x);
        add_f32(4u * pixel + 1u, c.y);
        add_f32(4u * pixel + 2u, c.z);
    }
}

@compute @workgroup_size(64, 1, 1)
fn main(@builtin(global_invocation_id) id: vec3<u32>) {
    if id.x >= min(photon_count[1], params.photon_capacity) || importon_stats[1] == 0u {
        return;
    }
    let p = photons[id.x];
    let tile = cubemap_tile(cubemap, p.position);
    let radius = bitcast<f32>(importon_stats[0]);
    // The radius seen from the centre, in tiles, at the photon's depth.
    var reach = MAX_REACH;
    if tile.depth > radius {
        // Twice the central scale: near a face's edges a tile spans less angle.
        reach = min(i32(ceil(radius / (tile.depth - radius) * f32(cubemap.grid))), MAX_REACH);
    }
    let g = i32(cubemap.grid);
    let c = vec2<i32>(tile.cell);
    for (var y = max(c.y - reach, 0); y <= min(c.y + reach, g - 1); y += 1) {
        for (var x = max(c.x - reach, 0); x <= min(c.x + reach, g - 1); x += 1) {
            let index = (tile.face * cubemap.grid + u32(y)) * cubemap.grid + u32(x);
            gather(p, id.x, importon_heads[index]);
        }
    }
}
