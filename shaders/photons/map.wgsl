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

// Widening of each row's band and ends, in face coordinates: far more than f32's error, far
// less than a tile.
const MARGIN: f32 = 1e-4;
// Share of the ellipsoid that bounds a kernel spent on its thickness: semi-axes r / √(1 − w)
// across and h / √w along the normal hold the cylinder of radius r and half-height h.
const DISC_SHARE: f32 = 0.2;

// A projection on a cubemap face: the conic a x² + 2h xy + b y² + 2g x + 2f y + k <= 0 of
// offsets from the kernel's centre's projection (src/photons/ellipse.rs mirrors this and
// tests that no point of a kernel falls outside its rows' ranges).
struct Conic {
    // (a, h, b) and (g, f, k).
    quadratic: vec3<f32>,
    linear: vec3<f32>,
    // The x offsets of the leftmost and rightmost points, then their y offsets.
    extremes: vec4<f32>,
    // The y offsets of the lowest and highest points.
    heights: vec2<f32>,
    valid: bool,
}

// The conic of the ellipsoid (x - p)ᵀ M (x - p) <= 1 seen from the cubemap's centre, for u
// the unit direction to p, s2 its semi-axis across over |p|, squared, and m = semi-axis² · M:
// written about the centre's projection in these units, so that nothing cancels when the
// kernel is small and far. Not valid where it is no bounded ellipse (the ellipsoid holds the
// centre or reaches the face's horizon).
fn conic(u: vec3<f32>, s2: f32, m: mat3x3<f32>) -> Conic {
    var out: Conic;
    out.valid = false;
    let mu = m * u;
    let e = dot(u, mu) - s2;
    if u.z <= 0.0 || e <= 0.0 {
        return out;
    }
    let a = e * m[0].x - mu.x * mu.x;
    let h = e * m[1].x - mu.x * mu.y;
    let b = e * m[1].y - mu.y * mu.y;
    let g = -s2 * mu.x / u.z;
    let f = -s2 * mu.y / u.z;
    let k = -s2 * (e + s2) / (u.z * u.z);
    // The points with a vertical tangent lie on h x + b y + f = 0, those with a horizontal
    // one on a x + h y + g = 0.
    let qa = a * b - h * h;
    let qb = g * b - h * f;
    let qc = k * b - f * f;
    let disc = qb * qb - qa * qc;
    if a <= 0.0 || b <= 0.0 || qa <= 0.01 * a * b || disc < 0.0 {
        return out;
    }
    let x_lo = (-qb - sqrt(disc)) / qa;
    let x_hi = (-qb + sqrt(disc)) / qa;
    let qb_y = f * a - h * g;
    let disc_y = max(qb_y * qb_y - qa * (k * a - g * g), 0.0);
    out.extremes = vec4<f32>(x_lo, x_hi, -(h * x_lo + f) / b, -(h * x_hi + f) / b);
    out.heights = vec2<f32>(-qb_y - sqrt(disc_y), -qb_y + sqrt(disc_y)) / qa;
    out.quadratic = vec3<f32>(a, h, b);
    out.linear = vec3<f32>(g, f, k);
    out.valid = true;
    return out;
}

// The conic's x offset at y offset t: its left end (side -1) or right end (side 1).
fn conic_end(c: Conic, t: f32, side: f32) -> f32 {
    let half_b = c.quadratic.y * t + c.linear.x;
    let k = (c.quadratic.z * t + 2.0 * c.linear.y) * t + c.linear.z;
    let disc = max(half_b * half_b - c.quadratic.x * k, 0.0);
    return (side * sqrt(disc) - half_b) / c.quadratic.x;
}

// The x offsets the conic reaches over the band of y offsets [t0, t1]: a concave right end
// is widest at its extreme point when the band holds it, else at the band's edge nearest
// it (the left end likewise).
fn conic_band(c: Conic, t0: f32, t1: f32) -> vec2<f32> {
    return vec2<f32>(
        conic_end(c, clamp(c.extremes.z, t0, t1), -1.0),
        conic_end(c, clamp(c.extremes.w, t0, t1), 1.0),
    );
}

// A gather kernel seen on one cubemap face, so that it walks only the tiles its projection
// covers, row by row, not the box of tiles its sphere reaches (face_tiles), whose corners
// hold a quarter of the box's photons and none of the kernel's. The kernel is the ball of
// radius r cut to a slab of half-thickness h about its plane; its projection lies in that of
// the sphere and in that of an ellipsoid holding the cut ball, which for a surface seen at
// a grazing angle is far narrower.
struct FaceGather {
    // The box of tiles, its rows cut to those the projection reaches.
    tiles: vec4<i32>,
    centre: vec2<f32>,
    sphere: Conic,
    disc: Conic,
}

// The kernel of radius r around p whose plane has normal `plane` (any length: the kernel
// keeps |plane · offset| <= flattening · r).
fn face_gather(d: CubemapParams, p: vec3<f32>, r: f32, plane: vec3<f32>, flattening: f32, face: u32) -> FaceGather {
    var out: FaceGather;
    out.tiles = face_tiles(d, p, r, face);
    out.sphere.valid = false;
    out.disc.valid = false;
    let basis = transpose(face_basis(face));
    let l = basis * (p - d.centre.xyz);
    let distance2 = dot(l, l);
    let s2 = r * r / distance2;
    if !(s2 < 1.0) || out.tiles.x > out.tiles.y {
        return out;
    }
    let u = l * inverseSqrt(distance2);
    let identity = mat3x3<f32>(vec3<f32>(1.0, 0.0, 0.0), vec3<f32>(0.0, 1.0, 0.0), vec3<f32>(0.0, 0.0, 1.0));
    out.sphere = conic(u, s2, identity);
    if !out.sphere.valid {
        return out;
    }
    out.centre = u.xy / u.z;
    var heights = out.sphere.heights;
    let length_n = length(plane);
    if length_n > 0.0 {
        let n = basis * plane / length_n;
        let h = flattening / length_n;
        // Semi-axes² r² / (1 - w) across and (h r)² / w along n, over the first.
        let along = DISC_SHARE / ((1.0 - DISC_SHARE) * h * h);
        out.disc = conic(u, s2 / (1.0 - DISC_SHARE), identity + mat3x3<f32>(n * n.x, n * n.y, n * n.z) * (along - 1.0));
        if out.disc.valid {
            heights = vec2<f32>(max(heights.x, out.disc.heights.x), min(heights.y, out.disc.heights.y));
        }
    }
    let grid = f32(d.grid);
    out.tiles.z = max(out.tiles.z, i32(floor((1.0 - (out.centre.y + heights.y + MARGIN)) * 0.5 * grid)));
    out.tiles.w = min(out.tiles.w, i32(floor((1.0 - (out.centre.y + heights.x - MARGIN)) * 0.5 * grid)));
    return out;
}

// The map's run for row y of a face gather: the tiles of the band of face y coordinates
// [1 - 2 (y + 1) / grid, 1 - 2 y / grid] that both projections reach, within the box.
fn gather_row_run(seen: FaceGather, face: u32, y: i32) -> vec2<u32> {
    if !seen.sphere.valid {
        return row_run(face, y, seen.tiles.x, seen.tiles.y);
    }
    let grid = f32(cubemap.grid);
    let t0 = 1.0 - 2.0 * f32(y + 1) / grid - seen.centre.y - MARGIN;
    let t1 = 1.0 - 2.0 * f32(y) / grid - seen.centre.y + MARGIN;
    var band = conic_band(seen.sphere, t0, t1);
    if seen.disc.valid {
        let disc = conic_band(seen.disc, t0, t1);
        band = vec2<f32>(max(band.x, disc.x), min(band.y, disc.y));
    }
    let lo = seen.centre.x + band.x - MARGIN;
    let hi = seen.centre.x + band.y + MARGIN;
    let x0 = max(i32(floor((lo + 1.0) * 0.5 * grid)), seen.tiles.x);
    let x1 = min(i32(floor((hi + 1.0) * 0.5 * grid)), seen.tiles.y);
    return row_run(face, y, x0, x1);
}

// Whether a stored photon is caustic: it met only surfaces that store none (mirrors, glass,
// smooth metal) since its source, and is gathered over `caustic_scale` of the radius
// (InitialRadius::caustic_scale).
fn photon_caustic(p: Photon) -> bool {
    return (p.incoming & 1u) != 0u;
}

// Which of a kernel's discs photon `p`, inside the kernel of radius r about `centre`, counts
// in (`photon_disc`): the whole disc; the caustic photons' own, `caustic_scale` of r, where
// that is under 1; none, a caustic photon past its own.
const WHOLE_DISC: u32 = 0u;
const CAUSTIC_DISC: u32 = 1u;
const NO_DISC: u32 = 2u;

fn photon_disc(params: IterationParams, p: Photon, centre: vec3<f32>, r: f32) -> u32 {
    if params.caustic_scale >= 1.0 || !photon_caustic(p) {
        return WHOLE_DISC;
    }
    return select(NO_DISC, CAUSTIC_DISC, distance(p.position, centre) <= r * params.caustic_scale);
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

// The kernel's disc is checked for surface at points of a Fermat spiral, at the centres of
// equal areas (the gathers' `disc_on_surface`): the photons are divided by the area of the
// disc that lies on surface, not π r² (none land past a corner or an edge). Point i of
// `count`, on the disc of radius r in the plane of `frame` (its first two axes).
fn disc_point(frame: mat3x3<f32>, r: f32, i: u32, count: u32) -> vec3<f32> {
    let rho = r * sqrt((f32(i) + 0.5) / f32(count));
    let phi = f32(i) * 2.3999632;
    return rho * (cos(phi) * frame[0] + sin(phi) * frame[1]);
}

// The share of the disc on surface from `on` of `count` points, at least a quarter (a thin
// surface's disc is not divided by next to nothing).
fn disc_share(on: f32, count: u32) -> f32 {
    return max(on / f32(count), 0.25);
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

// Adaptive kernels (PhotonMapping::adaptive_kernel), for both splats: per pixel, what its
// kernels met since the radius sequence began (under `Reuse`, within the history window
// while a change settles), as `vec4(mean density over the disc, over its
// inner half (photons per square pixel), mean squared radius met at (pixels²), iterations)`.

// A photon `offset` from the centre of a kernel of radius `r`, counted for its statistics:
// (1, 1 where within half the radius).
fn kernel_count(offset: vec3<f32>, r: f32) -> vec2<f32> {
    return vec2<f32>(1.0, select(0.0, 1.0, 4.0 * dot(offset, offset) < r * r));
}

// Point `i` of a disc's `count` (`disc_point`), `seen` on surface or not, counted for its
// shares: (all, within half the radius, where the first quarter of the points lie).
fn disc_count(seen: bool, i: u32, count: u32) -> vec2<f32> {
    let on = select(0.0, 1.0, seen);
    return vec2<f32>(on, select(0.0, on, i < count / 4u));
}

// The shares of a disc and of its inner half on surface, from `disc_count`'s sum `on` over
// `count` points.
fn disc_shares(on: vec2<f32>, count: u32) -> vec2<f32> {
    return vec2<f32>(disc_share(on.x, count), disc_share(on.y, count / 4u));
}

// The iterations of `w` a pixel's statistics count: under `Reuse` a settling change keeps the
// last `history_cap`, as the estimate does.
fn kernel_iterations(params: IterationParams, w: f32) -> f32 {
    return min(w, f32(params.history_cap));
}

// The smallest share of the global radius a kernel takes.
const LEAST_SCALE: f32 = 0.25;

// This iteration's kernel radius, in global radii, from the pixel's `stats`
// (PhotonMapping::adaptive_kernel). A disc's mean of a density f is f + r² ∇²f / 8, its inner
// half's f + r² ∇²f / 32, so the disc's relative bias B is 4/3 of the inner density's
// relative departure from the whole's, less three standard deviations of that departure's
// noise; it grows as s². After n iterations of m photons a disc the estimate's relative
// variance is 1 / (n m s²): B² s⁴ + 1 / (n m s²) is least at s⁶ = 1 / (2 n m B²).
fn kernel_scale(params: IterationParams, stats: vec4<f32>) -> f32 {
    if params.radius_restart != 0u || stats.w < 2.0 || stats.x <= 0.0 {
        return 1.0;
    }
    let r2 = params.splat_radius * params.splat_radius;
    let n = kernel_iterations(params, stats.w);
    let inner = stats.y * 0.25 * stats.z * n;
    let departure = abs(1.0 - stats.y / stats.x) - 3.0 / sqrt(max(inner, 1.0));
    let bias = 4.0 / 3.0 * departure * r2 / stats.z;
    if bias <= 0.0 {
        return 1.0;
    }
    let balance = 1.0 / (2.0 * (n + 1.0) * stats.x * r2 * bias * bias);
    return clamp(pow(balance, 1.0 / 6.0), LEAST_SCALE, 1.0);
}

// `stats` with this iteration's kernel of `radius` pixels, which held `photons.x` photons
// over `share.x` of its disc, `photons.y` of them within half the radius (`share.y` of it).
fn kernel_stats_after(params: IterationParams, stats: vec4<f32>, radius: f32, photons: vec2<f32>, share: vec2<f32>) -> vec4<f32> {
    let kept = select(stats, vec4<f32>(0.0), params.radius_restart != 0u);
    let r2 = radius * radius;
    let sample = vec3<f32>(photons.x / (share.x * r2), 4.0 * photons.y / (share.y * r2), r2);
    let n = kernel_iterations(params, kept.w) + 1.0;
    return vec4<f32>(kept.xyz + (sample - kept.xyz) / n, n);
}
