// Shared structs and helpers of every bevy_rppm stage. Layouts mirror src/scene/mod.rs,
// src/view/params.rs and src/cubemap/config.rs byte for byte.
#define_import_path bevy_rppm::common

#import bevy_rppm::sampling::pcg_hash

const PI: f32 = 3.141592653589793;

// Below this perceptual roughness the specular lobe is a perfect mirror (src/bsdf.rs).
const DELTA_ROUGHNESS: f32 = 0.02;

// A triangle as stored (52 bytes, src/scene/packed.rs); `triangle_at` unpacks it.
// A placed triangle's `material` is its material's index, with MOVED_TRIANGLE set where its
// latest placement moved it (shaders/scene/place.wgsl): motion history tells a moving
// object's pixels from a still one's.
const MOVED_TRIANGLE: u32 = 0x80000000u;
const MATERIAL_INDEX: u32 = 0x7fffffffu;

struct PackedTriangle {
    ax: f32, ay: f32, az: f32,
    bx: f32, by: f32, bz: f32,
    cx: f32, cy: f32, cz: f32,
    material: u32,
    normal_a: u32,
    normal_b: u32,
    normal_c: u32,
}

// Octahedral unit normals in two snorm16 (src/scene/packed.rs).
fn unpack_normal(v: u32) -> vec3<f32> {
    let e = unpack2x16snorm(v);
    let z = 1.0 - abs(e.x) - abs(e.y);
    var xy = e;
    if z < 0.0 {
        xy = (1.0 - abs(e.yx)) * select(vec2<f32>(-1.0), vec2<f32>(1.0), e >= vec2<f32>(0.0));
    }
    return normalize(vec3<f32>(xy, z));
}

// As `pack_normal` in src/scene/packed.rs.
fn pack_normal(n: vec3<f32>) -> u32 {
    let o = n / max(abs(n.x) + abs(n.y) + abs(n.z), 1e-20);
    var e = o.xy;
    if o.z < 0.0 {
        e = (1.0 - abs(e.yx)) * select(vec2<f32>(-1.0), vec2<f32>(1.0), e >= vec2<f32>(0.0));
    }
    return pack2x16snorm(e);
}

struct Triangle {
    position_a: vec3<f32>,
    material: u32,
    position_b: vec3<f32>, pad_b: u32,
    position_c: vec3<f32>, pad_c: u32,
    normal_a: vec3<f32>,
    pad_na: u32,
    normal_b: vec3<f32>,
    pad_nb: u32,
    normal_c: vec3<f32>,
    pad_nc: u32,
}

struct Material {
    base_color: vec4<f32>,
    emissive: vec4<f32>,
    metallic: f32,
    perceptual_roughness: f32,
    reflectance: f32,
    specular_transmission: f32,
    ior: f32,
    flags: u32,
    alpha_cutoff: f32,
    pad: u32,
    // Bevy's uv_transform: 2×2 part by columns (xy, zw), translation in uv_offset.xy.
    uv_transform: vec4<f32>,
    uv_offset: vec4<f32>,
    // Base colour, metallic-roughness, emissive and normal map textures, or NO_TEXTURE.
    textures: vec4<u32>,
    // Beer–Lambert σ inside the material (m⁻¹, rgb): coloured glass.
    absorption: vec4<f32>,
    // Bevy's specular_tint (rgb): the dielectric F0 is 0.16·(reflectance·tint)².
    specular_tint: vec4<f32>,
    // Clearcoat: x strength, y perceptual roughness.
    clearcoat: vec2<f32>,
    // Bevy's diffuse_transmission: the diffuse lobe's share that leaves through the back.
    diffuse_transmission: f32,
    pad_transmission: u32,
}

// Material flags (MaterialFlags in src/scene/mod.rs).
const MATERIAL_DOUBLE_SIDED: u32 = 1u;
const MATERIAL_TEXTURED: u32 = 2u;
const MATERIAL_ALPHA_MASK: u32 = 4u;
const MATERIAL_ALPHA_HASHED: u32 = 8u;
const MATERIAL_UNLIT: u32 = 16u;
const MATERIAL_FLIP_NORMAL_Y: u32 = 32u;
const NO_TEXTURE: u32 = 0xffffffffu;

// Texture coordinates and linear vertex colours (16-bit unorm rg, ba) of a triangle's corners.
struct TriangleAttributes {
    uv_a: vec2<f32>,
    uv_b: vec2<f32>,
    uv_c: vec2<f32>,
    color_a: vec2<u32>,
    color_b: vec2<u32>,
    color_c: vec2<u32>,
}

// A packed texture: RGBA8 texels from `offset`, level l + 1 right after level l.
struct Texture {
    offset: u32,
    width: u32,
    height: u32,
    levels: u32,
    srgb: u32,
    // Wrap along u (bits 0-1) and v (2-3): 0 repeat, 1 clamp, 2 mirror; bit 4 nearest
    // magnification, bit 5 nearest minification (TextureSampler::bits in src/scene/textures.rs).
    sampler: u32,
    pad_b: u32,
    pad_c: u32,
}

const LIGHT_POINT: u32 = 0u;
const LIGHT_SPOT: u32 = 1u;
const LIGHT_DIRECTIONAL: u32 = 2u;

struct Light {
    kind: u32,
    shadow_layer: u32,
    cos_inner: f32,
    cos_outer: f32,
    position: vec4<f32>,
    direction: vec4<f32>,
    // rgb: W/sr (point, spot) or W/m² (directional); w: power for photon splitting.
    radiance: vec4<f32>,
}

struct Emitter {
    triangle: u32,
    // The part of the triangle (src/scene/parts.rs; 0 the whole), `area` its area.
    part: u32,
    area: f32,
    power: f32,
    cdf: f32,
    // The sphere bounding what its photons meet (src/scene/receivers.rs); radius 0: unknown.
    toward_x: f32,
    toward_y: f32,
    toward_z: f32,
    toward_radius: f32,
}

// One view a shadow map is rendered from: a cube face of a point, spot or area-light sample,
// or a directional light's orthographic map.
struct ShadowView {
    clip_from_world: mat4x4<f32>,
    // xyz: eye (perspective) or direction light travels (orthographic); w: 1 perspective, 0 ortho.
    origin: vec4<f32>,
    axis: vec4<f32>, // unit, the way the view looks
    near: f32,
    far: f32,
    // World-space size of one texel at unit distance (perspective) or absolute (ortho).
    texel: f32,
    pad: f32,
}

// Per-iteration constants (uniform, one 256-byte slot per iteration of a frame).
struct IterationParams {
    clip_from_world: mat4x4<f32>,
    // Inverse of the (jittered) clip_from_world: camera rays through any pixel position.
    world_from_clip: mat4x4<f32>,
    camera_position: vec4<f32>,
    // Area-light sample for this iteration: position (w = 1 if any), normal, radiance / pdf.
    area_position: vec4<f32>,
    area_normal: vec4<f32>,
    area_weight: vec4<f32>,
    size: vec2<u32>,
    iteration: u32,
    light_count: u32,
    // World-space pixel size at unit view depth (perspective) or absolute (ortho).
    pixel_spread: f32,
    orthographic: u32,
    // First shadow view of this iteration's area-light cube, and its first texture layer.
    area_view: u32,
    area_layer: u32,
    shadow_resolution: u32,
    exposure: f32,
    tonemap: u32,
    // Photons emitted this iteration, bounces each may take, room in the photon buffer.
    photons: u32,
    max_photon_depth: u32,
    photon_capacity: u32,
    // Entries of the photon-emission CDF (lights, then emitters).
    source_count: u32,
    // Knaus–Zwicker gather radius this iteration, in pixels (world radius = this × footprint).
    splat_radius: f32,
    // Vertices a camera path may have (1: the G-buffer only).
    max_eye_depth: u32,
    // 1: each splat fragment survives with probability 1/2 and counts twice.
    splat_russian_roulette: u32,
    // 1: direct light from photons (stored at their first hit), for checking photon flux.
    direct_photons: u32,
    // 1 (mode Indirect): leave out the light of first camera hits, which Bevy renders.
    indirect_only: u32,
    // Bounding sphere of the scene: centre, radius (directional-light photons start on a disc).
    scene_sphere: vec4<f32>,
    // Gather kernel's extent along the surface normal over its radius (ISPM's flattening).
    kernel_flattening: f32,
    // Photons are splatted on every n-th pixel, then upsampled (1: every pixel).
    indirect_subsampling: u32,
    // Iterations of history a pixel keeps (0xffffffff: all), and HistoryFlags (params.rs).
    history_cap: u32,
    history_flags: u32,
    // Last frame's unjittered clip_from_world, for reprojecting history.
    previous_clip_from_world: mat4x4<f32>,
    // The sky's radiance (linear RGB), w 1 when there is one (the last photon source; SKY).
    sky: vec4<f32>,
    // Index of this iteration's random numbers: the iteration, shifted by the seed.
    sequence: u32,
    // Invocations tracing the photons (photons/trace.wgsl regenerates paths).
    photon_lanes: u32,
    // Power of all emissive triangles together (luminance W, as the CPU's emitter table).
    emitter_power: f32,
    // 1 when photons leave a sun or the sky, whose emission follows how far the camera sees.
    seen_region: u32,
    // This iteration's sub-pixel jitter (pixels, x right, y down) before the pixels' centres.
    jitter: vec2<f32>,
    // Where local illumination shades each pixel past its G-buffer sample (pixels; 0: there).
    shading_jitter: vec2<f32>,
    // The share of resolve.wgsl's edges in what the frame shows (0: the estimate as it is).
    resolve_share: f32,
    // 1: a radius sequence's first iteration after a restart or a camera move (kernel stats).
    radius_restart: u32,
    // The share of the radius caustic photons are gathered over (photon_map::photon_caustic).
    caustic_scale: f32,
    // This iteration's weight in the running mean: its photons over the radius's, in (0, 1].
    photon_weight: f32,
    // Where last frame's camera was (w 1), or, orthographic, the way toward it (w 0).
    previous_eye: vec4<f32>,
}

// What f(wo, ·) needs of a material and wo alone (bsdf.wgsl's `bsdf_from`), found once for
// the many directions a gather weighs. Here, not in bsdf.wgsl: naga_oil passes a struct
// between modules as one type only when a third module defines it.
struct Outgoing {
    // F0, specular_f0 (naga_oil takes no digit in an imported struct's field name).
    fresnel: vec3<f32>,
    n_dot_v: f32,
    // `specular_at` wo: single, lost, dielectric; `specular_average`.
    single: vec3<f32>,
    lost: f32,
    dielectric: f32,
    average: vec2<f32>,
    // What a clearcoat lets through toward wo (1 without one).
    coat: f32,
}

// Texel i of a texture read as a flat array, rows of 1 << TEXEL_ROW_SHIFT texels (TEXELS_WIDE
// in src/cubemap/bvh/texels.rs). Data that hot loops read lives in such textures: llvmpipe
// fetches a texel for its 8 lanes at once but reads a storage buffer a lane at a time.
const TEXEL_ROW_SHIFT: u32 = 12u;

fn row_texel(i: u32) -> vec2<u32> {
    return vec2<u32>(i & ((1u << TEXEL_ROW_SHIFT) - 1u), i >> TEXEL_ROW_SHIFT);
}

// A stored photon, 32 bytes: the gathers read every photon of the tiles they visit, and
// llvmpipe loads a storage buffer lane by lane.
struct Photon {
    position: vec3<f32>,
    // Direction towards where the photon came from (pack_normal; bit 0: `photon_caustic`).
    incoming: u32,
    // Flux the photon carries (W), linear RGB.
    flux: vec3<f32>,
    // Shading normal at the hit, on the side the photon arrived from (pack_normal).
    normal: u32,
}

fn triangle_position(t: Triangle, corner: u32) -> vec3<f32> {
    switch corner {
        case 0u: { return t.position_a; }
        case 1u: { return t.position_b; }
        default: { return t.position_c; }
    }
}

fn triangle_normal(t: Triangle, corner: u32) -> vec3<f32> {
    switch corner {
        case 0u: { return t.normal_a; }
        case 1u: { return t.normal_b; }
        default: { return t.normal_c; }
    }
}

fn luminance(c: vec3<f32>) -> f32 {
    return dot(c, vec3<f32>(0.2126, 0.7152, 0.0722));
}

// The deep cubemap : a camera-centred cube of `grid`² tiles per face, each holding
// `bins` depth-binned linked lists of triangle ids, and a min/max depth hierarchy.
struct CubemapParams {
    centre: vec4<f32>,
    grid: u32,
    bins: u32,
    node_capacity: u32,
    levels: u32,
    // Depth below which geometry is not recorded (avoids the projection singularity).
    near: f32,
    triangle_count: u32,
    pad_a: u32,
    pad_b: u32,
    // First cell of each hierarchy level in `hierarchy` (level l at [l / 4][l % 4]).
    level_offsets: array<vec4<u32>, 4>,
}

// Triangles that look big from the cubemap's centre are kept out of its lists and tested by
// every ray once (src/cubemap/mod.rs): a big triangle lands in every bin of every tile it
// covers, and a ray would meet it again in each. At most this many; past it, none is big.
const BIG_TRIANGLES: u32 = 128u;

// Whether a triangle's bounding sphere (about its centroid) is wider than a tenth of its
// distance from `centre` (more than about 6° across), or holds the centre.
fn looks_big(a: vec3<f32>, b: vec3<f32>, c: vec3<f32>, centre: vec3<f32>) -> bool {
    let m = (a + b + c) / 3.0;
    let r = sqrt(max(max(dot(a - m, a - m), dot(b - m, b - m)), dot(c - m, c - m)));
    return r > 0.1 * length(m - centre);
}

// Axes of cube face f (order +X −X +Y −Y +Z −Z): columns U, V (screen right, up) and A (axis).
fn face_basis(f: u32) -> mat3x3<f32> {
    switch f {
        case 0u: { return mat3x3<f32>(vec3(0.0, 0.0, -1.0), vec3(0.0, 1.0, 0.0), vec3(1.0, 0.0, 0.0)); }
        case 1u: { return mat3x3<f32>(vec3(0.0, 0.0, 1.0), vec3(0.0, 1.0, 0.0), vec3(-1.0, 0.0, 0.0)); }
        case 2u: { return mat3x3<f32>(vec3(1.0, 0.0, 0.0), vec3(0.0, 0.0, -1.0), vec3(0.0, 1.0, 0.0)); }
        case 3u: { return mat3x3<f32>(vec3(1.0, 0.0, 0.0), vec3(0.0, 0.0, 1.0), vec3(0.0, -1.0, 0.0)); }
        case 4u: { return mat3x3<f32>(vec3(1.0, 0.0, 0.0), vec3(0.0, 1.0, 0.0), vec3(0.0, 0.0, 1.0)); }
        default: { return mat3x3<f32>(vec3(-1.0, 0.0, 0.0), vec3(0.0, 1.0, 0.0), vec3(0.0, 0.0, -1.0)); }
    }
}

// Cube face whose frustum holds direction v, in the order of face_basis.
fn face_of(v: vec3<f32>) -> u32 {
    let a = abs(v);
    if a.x >= a.y && a.x >= a.z {
        return select(1u, 0u, v.x > 0.0);
    }
    if a.y >= a.z {
        return select(3u, 2u, v.y > 0.0);
    }
    return select(5u, 4u, v.z > 0.0);
}

// Offset of hierarchy level l.
fn level_offset(d: CubemapParams, l: u32) -> u32 {
    return d.level_offsets[l / 4u][l % 4u];
}

// The world gather radius of a pixel or importon: `pixels` footprints, kept within scene-
// relative bounds so it neither vanishes nor covers the scene.
fn gather_radius(params: IterationParams, pixels: f32, footprint: f32) -> f32 {
    let scale = params.scene_sphere.w;
    return clamp(pixels * footprint, 1e-6 * scale, 0.1 * scale);
}

// The full-resolution pixel that stands for subsampled texel `texel` (the block's centre).
fn subsample_representative(params: IterationParams, texel: vec2<u32>) -> vec2<i32> {
    let n = params.indirect_subsampling;
    return vec2<i32>(min(texel * n + n / 2u, params.size - 1u));
}

// Russian roulette on a splat: false to drop it; the kept ones count twice (unbiased).
fn splat_survives(params: IterationParams, a: u32, b: u32) -> bool {
    if params.splat_russian_roulette == 0u {
        return true;
    }
    return (pcg_hash(a ^ pcg_hash(b ^ pcg_hash(params.sequence))) & 1u) == 0u;
}

fn splat_weight(params: IterationParams) -> f32 {
    return select(1.0, 2.0, params.splat_russian_roulette != 0u);
}

// An orthonormal basis around unit n (Duff et al. 2017).
fn basis_around(n: vec3<f32>) -> mat3x3<f32> {
    let s = select(-1.0, 1.0, n.z >= 0.0);
    let a = -1.0 / (s + n.z);
    let b = n.x * n.y * a;
    return mat3x3<f32>(vec3<f32>(1.0 + s * n.x * n.x * a, s * b, -s * n.x), vec3<f32>(b, s + n.y * n.y * a, -n.y), n);
}

// Cosine-distributed direction around unit n.
fn cosine_direction(n: vec3<f32>, u: vec2<f32>) -> vec3<f32> {
    let r = sqrt(u.x);
    let phi = 2.0 * PI * u.y;
    return basis_around(n) * vec3<f32>(r * cos(phi), r * sin(phi), sqrt(max(1.0 - u.x, 0.0)));
}

// A camera path's end on a non-specular surface after specular bounces: it gathers photons
// in its radius (indirect splatting). 64 bytes; one per pixel, index = pixel.
struct Importon {
    position: vec3<f32>,
    // Triangle it lies on; NO_IMPORTON when the pixel has none this iteration.
    triangle: u32,
    normal: vec3<f32>,
    // In a pixel's own slot: how many importons its other camera paths left past the
    // image's slots (rough glass, eye_paths.wgsl), and (`first_extra`) the first's slot.
    extras: u32,
    // Product of the bounces' weights from the camera (over the pixel's importons).
    throughput: vec3<f32>,
    radius: f32,
    // Direction towards the previous path vertex.
    outgoing: vec3<f32>,
    first_extra: u32,
}

const NO_IMPORTON: u32 = 0xffffffffu;

// Tile of the deep cubemap holding world point p (face, tile x, tile y) and its depth.
struct CubemapTile {
    index: u32,
    face: u32,
    cell: vec2<f32>,
    depth: f32,
}

fn cubemap_tile(d: CubemapParams, p: vec3<f32>) -> CubemapTile {
    let v = p - d.centre.xyz;
    let f = face_of(v);
    let l = transpose(face_basis(f)) * v;
    let g = f32(d.grid);
    let s = l.xy / max(l.z, 1e-30);
    let cell = clamp(vec2<f32>((s.x + 1.0) * 0.5 * g, (1.0 - s.y) * 0.5 * g), vec2<f32>(0.0), vec2<f32>(g - 1.0));
    let c = vec2<u32>(cell);
    return CubemapTile((f * d.grid + c.y) * d.grid + c.x, f, cell, l.z);
}

// The slope s / c of direction (s, c) in a face's (a, z) plane when the face sees it
// (|s| <= c); else -2 or 2 for the side it passed (below -45°, above 45°).
fn face_slope(s: f32, c: f32) -> f32 {
    if c > 0.0 && abs(s) <= c {
        return s / c;
    }
    return select(-2.0, 2.0, s > 0.0 || (s == 0.0 && c < 0.0));
}

// The range of s = a / z a face's coordinate takes over a sphere of radius r centred at
// (a, z) in the face's frame, clipped to the face (|s| <= 1): between the tangents from the
// cubemap's centre to its disc on the (a, z) plane (no trigonometry: llvmpipe runs it
// lane by lane). Empty (x > y) when outside the face; the whole face when the tangents are
// 90° or more apart.
fn face_span(a: f32, z: f32, r: f32) -> vec2<f32> {
    let d2 = a * a + z * z;
    if d2 <= 2.0 * r * r {
        return vec2<f32>(-1.0, 1.0);
    }
    // The centre's direction (sin t, cos t) turned by ±p, sin p = r / d.
    let d = sqrt(d2);
    let sin_t = a / d;
    let cos_t = z / d;
    let sin_p = r / d;
    let cos_p = sqrt(d2 - r * r) / d;
    let lo = face_slope(sin_t * cos_p - cos_t * sin_p, cos_t * cos_p + sin_t * sin_p);
    let hi = face_slope(sin_t * cos_p + cos_t * sin_p, cos_t * cos_p - sin_t * sin_p);
    if lo > 1.5 || hi < -1.5 {
        return vec2<f32>(1.0, -1.0);
    }
    return vec2<f32>(max(lo, -1.0), min(hi, 1.0));
}

// The faces a gather of radius r around p visits: x the face that holds p, y how many from
// it on (mod 6): 1 when the sphere lies within that face's view (its spans there are not
// clipped, so no other face holds a photon it reaches), else all 6.
fn faces_reached(d: CubemapParams, p: vec3<f32>, r: f32) -> vec2<u32> {
    let v = p - d.centre.xyz;
    let own = face_of(v);
    let l = transpose(face_basis(own)) * v;
    let sx = face_span(l.x, l.z, r);
    let sy = face_span(l.y, l.z, r);
    let within = sx.x > -1.0 && sx.y < 1.0 && sy.x > -1.0 && sy.y < 1.0;
    return vec2<u32>(own, select(6u, 1u, within));
}

// The tiles of cubemap face `face` that a sphere of radius r around p reaches, numbered as
// cubemap_tile numbers them (x grows with s.x, y falls with s.y): (x0, x1, y0, y1), empty
// (x0 > x1) when the sphere misses the face. The photon map holds each photon in its tile.
fn face_tiles(d: CubemapParams, p: vec3<f32>, r: f32, face: u32) -> vec4<i32> {
    let l = transpose(face_basis(face)) * (p - d.centre.xyz);
    let sx = face_span(l.x, l.z, r);
    let sy = face_span(l.y, l.z, r);
    if sx.x > sx.y || sy.x > sy.y {
        return vec4<i32>(1, 0, 1, 0);
    }
    let g = f32(d.grid);
    let last = i32(d.grid) - 1;
    return vec4<i32>(
        clamp(i32(floor((sx.x + 1.0) * 0.5 * g)), 0, last),
        clamp(i32(floor((sx.y + 1.0) * 0.5 * g)), 0, last),
        clamp(i32(floor((1.0 - sy.y) * 0.5 * g)), 0, last),
        clamp(i32(floor((1.0 - sy.x) * 0.5 * g)), 0, last),
    );
}
