// Deep cubemap build. Every triangle is drawn once per cube face as the screen-space bounding
// rectangle of its part in front of the centre, dilated by half a tile: rasterising that
// rectangle covers every tile the triangle touches (conservative, without conservative
// rasterisation hardware). The six faces sit side by side in a 3×2 atlas.
//   fragment_bounds: each tile's [min, max] depth of covering geometry (atomic min/max).
//   fragment_insert: the triangle id into every depth bin its span in the tile overlaps.
// Then `reduce` builds the min/max hierarchy, level 0 from the tile bounds. Before all,
// `classify` lists the triangles that look big from the centre (`looks_big`): they stay out
// of the tiles, and every ray tests them once.
#import bevy_rppm::common::{CubemapParams, face_basis, level_offset, looks_big, BIG_TRIANGLES}
#import bevy_rppm::scene::{triangles, triangle_at}

@group(1) @binding(0) var<uniform> cubemap: CubemapParams;
@group(1) @binding(1) var<storage, read_write> tile_bounds: array<atomic<u32>>;
@group(1) @binding(2) var<storage, read_write> heads: array<atomic<u32>>;
@group(1) @binding(3) var<storage, read_write> nodes: array<vec2<u32>>;
@group(1) @binding(4) var<storage, read_write> counters: array<atomic<u32>>;
@group(1) @binding(5) var<storage, read_write> hierarchy: array<vec2<f32>>;
// [count, ids…] of the big triangles, as `classify` left it.
@group(1) @binding(6) var<storage, read> big: array<u32>;
// The same, written by `classify` (bound alone with the params).
@group(1) @binding(7) var<storage, read_write> big_list: array<atomic<u32>>;

const BIG: f32 = 3.0e38;

struct VertexOut {
    @builtin(position) clip: vec4<f32>,
    @location(0) @interpolate(flat) triangle: u32,
    @location(1) @interpolate(flat) face: u32,
    // Depth range of the triangle's clipped part.
    @location(2) @interpolate(flat) depth: vec2<f32>,
}

// Clips the triangle (face-local coordinates) against depth >= near; returns the screen
// bounding box (xy min, zw max) and, through `depth`, the clipped depth range.
fn clipped_bounds(l: array<vec3<f32>, 3>, near: f32, depth: ptr<function, vec2<f32>>) -> vec4<f32> {
    var lo = vec2<f32>(BIG);
    var hi = vec2<f32>(-BIG);
    var zr = vec2<f32>(BIG, -BIG);
    for (var i = 0u; i < 3u; i += 1u) {
        let a = l[i];
        let b = l[(i + 1u) % 3u];
        if a.z >= near {
            let s = a.xy / a.z;
            lo = min(lo, s);
            hi = max(hi, s);
            zr = vec2<f32>(min(zr.x, a.z), max(zr.y, a.z));
        }
        if (a.z >= near) != (b.z >= near) {
            let t = (near - a.z) / (b.z - a.z);
            let p = mix(a, b, t);
            let s = p.xy / near;
            lo = min(lo, s);
            hi = max(hi, s);
            zr = vec2<f32>(min(zr.x, near), max(zr.y, near));
        }
    }
    *depth = zr;
    return vec4<f32>(lo, hi);
}

@vertex
fn vertex(@builtin(vertex_index) vertex: u32, @builtin(instance_index) face: u32) -> VertexOut {
    let id = vertex / 6u;
    let corner = vertex % 6u;
    let t = triangle_at(id);
    let basis = transpose(face_basis(face));
    let c = cubemap.centre.xyz;
    let l = array<vec3<f32>, 3>(basis * (t.position_a - c), basis * (t.position_b - c), basis * (t.position_c - c));
    var depth: vec2<f32>;
    let bounds = clipped_bounds(l, cubemap.near, &depth);
    // A big triangle is in the big list (unless there were too many to list any).
    let listed = big[0] <= BIG_TRIANGLES && looks_big(t.position_a, t.position_b, t.position_c, c);
    var out: VertexOut;
    out.triangle = id;
    out.face = face;
    out.depth = depth;
    // Grid coordinates: x right, y down, in tiles; dilated by half a tile (plus a little, so
    // that tiles merely touched are covered too).
    let g = f32(cubemap.grid);
    let pad = 0.5 + 1e-3;
    let gmin = clamp(vec2<f32>((bounds.x + 1.0) * 0.5 * g, (1.0 - bounds.w) * 0.5 * g) - pad, vec2(0.0), vec2(g));
    let gmax = clamp(vec2<f32>((bounds.z + 1.0) * 0.5 * g, (1.0 - bounds.y) * 0.5 * g) + pad, vec2(0.0), vec2(g));
    let empty = depth.x > depth.y || any(gmin >= gmax) || listed;
    // Quad corners: two triangles (0,1,2), (2,1,3) of the rectangle.
    let k = array<u32, 6>(0u, 1u, 2u, 2u, 1u, 3u)[corner];
    var grid_pos = vec2<f32>(select(gmin.x, gmax.x, (k & 1u) != 0u), select(gmin.y, gmax.y, (k & 2u) != 0u));
    if empty {
        grid_pos = vec2<f32>(0.0);
    }
    // Atlas: face f in cell (f % 3, f / 3) of a 3×2 grid of faces.
    let atlas = (vec2<f32>(f32(face % 3u), f32(face / 3u)) * g + grid_pos) / vec2<f32>(3.0 * g, 2.0 * g);
    out.clip = vec4<f32>(atlas.x * 2.0 - 1.0, 1.0 - atlas.y * 2.0, 0.5, 1.0);
    return out;
}

// The tile under a fragment, and its index among all tiles.
fn tile_of(position: vec2<f32>, face: u32) -> vec3<u32> {
    let g = cubemap.grid;
    let p = vec2<u32>(position) - vec2<u32>(face % 3u, face / 3u) * g;
    let tile = min(p, vec2<u32>(g - 1u));
    return vec3<u32>(tile, (face * g + tile.y) * g + tile.x);
}

// Depth span of the triangle's plane over the tile's pyramid, clamped to its clipped range;
// the whole range when the plane's depth is not monotone there (plane through the centre).
fn tile_span(id: u32, face: u32, tile: vec2<u32>, range: vec2<f32>) -> vec2<f32> {
    let t = triangle_at(id);
    let basis = transpose(face_basis(face));
    let c = cubemap.centre.xyz;
    let a = basis * (t.position_a - c);
    let n = cross(basis * (t.position_b - c) - a, basis * (t.position_c - c) - a);
    let d = dot(n, a);
    let g = f32(cubemap.grid);
    var lo = BIG;
    var hi = -BIG;
    var signs = 0;
    for (var i = 0u; i < 4u; i += 1u) {
        let corner = vec2<f32>(tile + vec2<u32>(i & 1u, i >> 1u));
        let s = vec2<f32>(corner.x / g * 2.0 - 1.0, 1.0 - corner.y / g * 2.0);
        let den = dot(n, vec3<f32>(s, 1.0));
        signs += select(-1, 1, den > 0.0);
        let z = d / den;
        lo = min(lo, z);
        hi = max(hi, z);
    }
    if abs(signs) != 4 || !(lo <= hi) {
        return range;
    }
    let span = vec2<f32>(max(lo, range.x), min(hi, range.y));
    if span.x > span.y {
        return range;
    }
    // A relative margin keeps rounding from opening gaps between neighbouring triangles.
    return vec2<f32>(span.x * (1.0 - 1e-4), span.y * (1.0 + 1e-4));
}

@fragment
fn fragment_bounds(in: VertexOut) {
    let tile = tile_of(in.clip.xy, in.face);
    let span = tile_span(in.triangle, in.face, tile.xy, in.depth);
    // Depths are positive, so their bit patterns order like the values; the minimum is kept
    // inverted so that a zero-cleared buffer means "empty".
    atomicMax(&tile_bounds[2u * tile.z], ~bitcast<u32>(span.x));
    atomicMax(&tile_bounds[2u * tile.z + 1u], bitcast<u32>(span.y));
}

fn tile_range(index: u32) -> vec2<f32> {
    return vec2<f32>(bitcast<f32>(~atomicLoad(&tile_bounds[2u * index])), bitcast<f32>(atomicLoad(&tile_bounds[2u * index + 1u])));
}

// Bin of depth z in a tile spanning `range` (clamped to the tile's bins).
fn bin_of(z: f32, range: vec2<f32>) -> u32 {
    let width = (range.y - range.x) / f32(cubemap.bins);
    if !(width > 0.0) {
        return 0u;
    }
    return u32(clamp(floor((z - range.x) / width), 0.0, f32(cubemap.bins - 1u)));
}

@fragment
fn fragment_insert(in: VertexOut) {
    let tile = tile_of(in.clip.xy, in.face);
    let span = tile_span(in.triangle, in.face, tile.xy, in.depth);
    let range = tile_range(tile.z);
    for (var b = bin_of(span.x, range); b <= bin_of(span.y, range); b += 1u) {
        // Every entry asked for is counted, also past the capacity, so that one regrowth to
        // the count read back fits them all.
        let node = atomicAdd(&counters[0], 1u);
        if node >= cubemap.node_capacity {
            atomicAdd(&counters[1], 1u);
            continue;
        }
        // Lists are linked through node + 1, so that 0 ends a list.
        let next = atomicExchange(&heads[tile.z * cubemap.bins + b], node + 1u);
        nodes[node] = vec2<u32>(in.triangle, next);
    }
}

@compute @workgroup_size(64, 1, 1)
fn classify(@builtin(global_invocation_id) id: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let index = id.y * groups.x * 64u + id.x;
    if index >= cubemap.triangle_count {
        return;
    }
    let t = triangle_at(index);
    if looks_big(t.position_a, t.position_b, t.position_c, cubemap.centre.xyz) {
        let slot = atomicAdd(&big_list[0], 1u);
        if slot < BIG_TRIANGLES {
            atomicStore(&big_list[1u + slot], index);
        }
    }
}

// Level 0 of the hierarchy: tile bounds as floats (empty tiles get an empty range).
@compute @workgroup_size(64, 1, 1)
fn hierarchy_base(@builtin(global_invocation_id) id: vec3<u32>) {
    let count = 6u * cubemap.grid * cubemap.grid;
    if id.x >= count {
        return;
    }
    let bits = vec2<u32>(atomicLoad(&tile_bounds[2u * id.x]), atomicLoad(&tile_bounds[2u * id.x + 1u]));
    var range = vec2<f32>(BIG, -BIG);
    if bits.y != 0u {
        range = vec2<f32>(bitcast<f32>(~bits.x), bitcast<f32>(bits.y));
    }
    hierarchy[id.x] = range;
}

struct Level {
    level: u32,
}
@group(2) @binding(0) var<uniform> level: Level;

// Level l from level l − 1: the min and max over 2×2 cells.
@compute @workgroup_size(64, 1, 1)
fn hierarchy_reduce(@builtin(global_invocation_id) id: vec3<u32>) {
    let size = max(cubemap.grid >> level.level, 1u);
    let below = max(cubemap.grid >> (level.level - 1u), 1u);
    if id.x >= 6u * size * size {
        return;
    }
    let face = id.x / (size * size);
    let cell = vec2<u32>(id.x % size, (id.x / size) % size);
    let src = level_offset(cubemap, level.level - 1u) + face * below * below;
    var range = vec2<f32>(BIG, -BIG);
    for (var i = 0u; i < 4u; i += 1u) {
        let c = min(cell * 2u + vec2<u32>(i & 1u, i >> 1u), vec2<u32>(below - 1u));
        let r = hierarchy[src + c.y * below + c.x];
        range = vec2<f32>(min(range.x, r.x), max(range.y, r.y));
    }
    hierarchy[level_offset(cubemap, level.level) + id.x] = range;
}
