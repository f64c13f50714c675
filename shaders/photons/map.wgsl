// The photon map as photons/sort.wgsl orders it, by deep-cubemap tile, for the gathers of
// both splats (group 2, bindings 0 and 1 of their stages).
#define_import_path bevy_rppm::photon_map

#import bevy_rppm::common::{Photon, IterationParams, CubemapParams, splat_survives, unpack_normal, face_basis, face_tiles}
#import bevy_rppm::cubemap::cubemap

@group(2) @binding(0) var<storage, read> photons: array<Photon>;
// Per cubemap tile, its first photon in the map; then the photon count.
@group(2) @binding(1) var<storage, read> tile_starts: array<u32>;

// The run of the map [start, end) that holds tiles x0..=x1 of row y of `face` (tiles are
// numbered row by row, as cubemap_tile numbers them); empty when x1 < x0.
fn row_run(face: u32, y: i32, x0: i32, x1: i32) -> vec2<u32> {
    let first = (face * cubemap.grid + u32(y)) * cubemap.grid + u32(x0);
    return vec2<u32>(tile_starts[first], tile_starts[first + u32(max(x1 - x0 + 1, 0))]);
}

// A gather sphere seen on one cubemap face: the box of tiles it reaches (face_tiles) and,
// where its projection is an ellipse, that ellipse, so that a row of tiles walks only the
// tiles its band of the ellipse covers: the box's corners hold a quarter of its photons and
// none of them is in the sphere. The ellipse is the conic
// a x² + 2h xy + b y² + 2g x + 2f y + k <= 0 of the offset (x, y) of face coordinates from
// the sphere's centre's, written in the cone's sin² s2 so that nothing cancels when the
// sphere is small and far.
struct FaceGather {
    tiles: vec4<i32>,
    centre: vec2<f32>,
    // (a, h, b) and (g, f, k).
    quadratic: vec3<f32>,
    linear: vec3<f32>,
    // The x offsets of the leftmost and rightmost points, then their y offsets.
    extremes: vec4<f32>,
    ellipse: bool,
}

fn face_gather(d: CubemapParams, p: vec3<f32>, r: f32, face: u32) -> FaceGather {
    var out: FaceGather;
    out.tiles = face_tiles(d, p, r, face);
    out.ellipse = false;
    let l = transpose(face_basis(face)) * (p - d.centre.xyz);
    let distance2 = dot(l, l);
    let s2 = r * r / distance2;
    if !(s2 < 1.0) || out.tiles.x > out.tiles.y {
        return out;
    }
    let u = l * inverseSqrt(distance2);
    // A cone that reaches the face's horizon projects to a hyperbola: the box then.
    if u.z <= 0.0 || u.z * u.z <= s2 * 1.01 {
        return out;
    }
    let c2 = 1.0 - s2;
    let a = c2 - u.x * u.x;
    let h = -u.x * u.y;
    let b = c2 - u.y * u.y;
    let g = -s2 * u.x / u.z;
    let f = -s2 * u.y / u.z;
    let k = -s2 / (u.z * u.z);
    // The points with a vertical tangent lie on h x + b y + f = 0.
    let qa = a * b - h * h;
    let qb = g * b - h * f;
    let qc = k * b - f * f;
    let disc = qb * qb - qa * qc;
    if qa <= 0.0 || b <= 0.0 || a <= 0.0 || disc < 0.0 {
        return out;
    }
    let x_lo = (-qb - sqrt(disc)) / qa;
    let x_hi = (-qb + sqrt(disc)) / qa;
    out.extremes = vec4<f32>(x_lo, x_hi, -(h * x_lo + f) / b, -(h * x_hi + f) / b);
    out.centre = u.xy / u.z;
    out.quadratic = vec3<f32>(a, h, b);
    out.linear = vec3<f32>(g, f, k);
    out.ellipse = true;
    return out;
}

// The ellipse's x offset at y offset t: its left end (side -1) or right end (side 1).
fn ellipse_end(seen: FaceGather, t: f32, side: f32) -> f32 {
    let half_b = seen.quadratic.y * t + seen.linear.x;
    let c = (seen.quadratic.z * t + 2.0 * seen.linear.y) * t + seen.linear.z;
    let disc = max(half_b * half_b - seen.quadratic.x * c, 0.0);
    return (side * sqrt(disc) - half_b) / seen.quadratic.x;
}

// The map's run for row y of a face gather: the tiles of the ellipse's band of face y
// coordinates [1 - 2 (y + 1) / grid, 1 - 2 y / grid] (widened by far more than f32's error,
// far less than a tile), within the box. A concave right end is widest at its extreme point
// when the band holds it, else at the band's edge nearest it (the left end likewise).
fn gather_row_run(seen: FaceGather, face: u32, y: i32) -> vec2<u32> {
    if !seen.ellipse {
        return row_run(face, y, seen.tiles.x, seen.tiles.y);
    }
    let grid = f32(cubemap.grid);
    let margin = 1e-4;
    let t0 = 1.0 - 2.0 * f32(y + 1) / grid - seen.centre.y - margin;
    let t1 = 1.0 - 2.0 * f32(y) / grid - seen.centre.y + margin;
    let lo = seen.centre.x + ellipse_end(seen, clamp(seen.extremes.z, t0, t1), -1.0) - margin;
    let hi = seen.centre.x + ellipse_end(seen, clamp(seen.extremes.w, t0, t1), 1.0) + margin;
    let x0 = max(i32(floor((lo + 1.0) * 0.5 * grid)), seen.tiles.x);
    let x1 = min(i32(floor((hi + 1.0) * 0.5 * grid)), seen.tiles.y);
    return row_run(face, y, x0, x1);
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
