// The photon map as photons/sort.wgsl orders it, by deep-cubemap tile, for the gathers of
// both splats (group 2, bindings 0 and 1 of their stages).
#define_import_path bevy_rppm::photon_map

#import bevy_rppm::common::{Photon, IterationParams, splat_survives, unpack_normal}
#import bevy_rppm::cubemap::cubemap

@group(2) @binding(0) var<storage, read> photons: array<Photon>;
// Per cubemap tile, its first photon in the map; then the photon count.
@group(2) @binding(1) var<storage, read> tile_starts: array<u32>;

// The run of the map [start, end) that holds tiles x0..=x1 of row y of `face` (tiles are
// numbered row by row, as cubemap_tile numbers them).
fn row_run(face: u32, y: i32, x0: i32, x1: i32) -> vec2<u32> {
    let first = (face * cubemap.grid + u32(y)) * cubemap.grid + u32(x0);
    return vec2<u32>(tile_starts[first], tile_starts[first + u32(x1 - x0) + 1u]);
}

// Whether photon `photon` is inside the gather kernel of `pixel` (centre, plane normal,
// radius r): within r of the centre, near its plane and facing the same way (either way on
// a surface that lets diffuse light through, `both_sides`), and kept by the splat's
// roulette. Read field by field: most photons fail the first test.
fn in_kernel(params: IterationParams, photon: u32, centre: vec3<f32>, plane: vec3<f32>, r: f32, pixel: u32, both_sides: bool) -> bool {
    let offset = photons[photon].position - centre;
    if dot(offset, offset) > r * r || abs(dot(offset, plane)) > params.kernel_flattening * r {
        return false;
    }
    let facing = dot(unpack_normal(photons[photon].normal), plane);
    return select(facing, abs(facing), both_sides) >= 0.5 && splat_survives(params, photon, pixel);
}

// From photon `at` of the map on, the first before `end` inside the kernel of `pixel`
// (in_kernel); `end` when none is. The gathers evaluate the BSDF only for these: llvmpipe
// runs a loop body's code for every lane, so a BSDF behind a `continue` was paid for every
// photon walked past.
fn next_in_kernel(at: u32, end: u32, params: IterationParams, centre: vec3<f32>, plane: vec3<f32>, r: f32, pixel: u32, both_sides: bool) -> u32 {
    for (var i = at; i < end; i += 1u) {
        if in_kernel(params, i, centre, plane, r, pixel, both_sides) {
            return i;
        }
    }
    return end;
}
