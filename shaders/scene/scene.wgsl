// The scene tables, bound at group 0 by every stage (`ViewLayouts::scene` in src/view/layouts.rs),
// and the material lookups that apply textures and vertex colours (src/scene/textures.rs).
#define_import_path bevy_rppm::scene

#import bevy_rppm::common::{Triangle, PackedTriangle, MATERIAL_INDEX, unpack_normal, pack_normal, Material, Light, Emitter, ShadowView, TriangleAttributes, Texture, DELTA_ROUGHNESS, MATERIAL_TEXTURED, MATERIAL_ALPHA_MASK, MATERIAL_ALPHA_HASHED, MATERIAL_DOUBLE_SIDED, MATERIAL_UNLIT, MATERIAL_FLIP_NORMAL_Y, NO_TEXTURE}
#import bevy_rppm::sampling::pcg_hash

@group(0) @binding(0) var<storage, read> triangles: array<PackedTriangle>;
@group(0) @binding(1) var<storage, read> shadow_views: array<ShadowView>;
// The materials (`GpuMaterial`, MATERIAL_TEXELS texels each, MATERIALS_ROW to a row; `scene_material`):
// a texture, which llvmpipe fetches for 8 lanes at once (a storage buffer it reads lane by
// lane). Unsigned texels, so that the flags and texture indices keep their bits.
@group(0) @binding(2) var material_texels: texture_2d<u32>;
@group(0) @binding(3) var<storage, read> lights: array<Light>;
@group(0) @binding(4) var<storage, read> emitters: array<Emitter>;
@group(0) @binding(5) var<storage, read> light_cdf: array<f32>;
// The GGX lobe's directional albedo and its averages (src/bsdf.rs), for microfacet.wgsl: a texture,
// which llvmpipe fetches for 8 lanes at once (a storage buffer it reads lane by lane).
@group(0) @binding(6) var ggx_albedo: texture_2d<f32>;
// Read only by the TEXTURED variants of the stages (one zeroed item otherwise), and there
// only for MATERIAL_TEXTURED materials.
@group(0) @binding(7) var<storage, read> attributes: array<TriangleAttributes>;
@group(0) @binding(8) var<storage, read> textures: array<Texture>;
@group(0) @binding(9) var<storage, read> texels: array<u32>;

// Texels a material takes, and materials a row of `material_texels` holds (src/scene/upload.rs).
const MATERIAL_TEXELS: u32 = 10u;
const MATERIALS_ROW: u32 = 64u;

// Material i of the scene.
fn scene_material(material: u32) -> Material {
    let i = material & MATERIAL_INDEX;
    let at = vec2<u32>((i % MATERIALS_ROW) * MATERIAL_TEXELS, i / MATERIALS_ROW);
    let base_color = material_texel(at, 0u);
    let emissive = material_texel(at, 1u);
    let a = material_texel(at, 2u);
    let b = textureLoad(material_texels, at + vec2<u32>(3u, 0u), 0);
    let uv_transform = material_texel(at, 4u);
    let uv_offset = material_texel(at, 5u);
    let textures = textureLoad(material_texels, at + vec2<u32>(6u, 0u), 0);
    let absorption = material_texel(at, 7u);
    let specular_tint = material_texel(at, 8u);
    let c = material_texel(at, 9u);
    return Material(
        base_color, emissive, a.x, a.y, a.z, a.w,
        bitcast<f32>(b.x), b.y, bitcast<f32>(b.z), b.w,
        uv_transform, uv_offset, textures, absorption, specular_tint,
        c.xy, c.z, bitcast<u32>(c.w),
    );
}

// Whether a surface of material i, seen from its front (a G-buffer texel's w above 0), emits:
// its emissive factor, which a texture only scales.
fn front_emitting(material: u32, w: f32) -> bool {
    return w > 0.0 && any(scene_material(material).emissive.rgb > vec3<f32>(0.0));
}

fn material_texel(at: vec2<u32>, k: u32) -> vec4<f32> {
    return bitcast<vec4<f32>>(textureLoad(material_texels, at + vec2<u32>(k, 0u), 0));
}

// Barycentric weights (second, third vertex) of a point p on triangle t.
fn barycentrics(t: Triangle, p: vec3<f32>) -> vec2<f32> {
    let e1 = t.position_b - t.position_a;
    let e2 = t.position_c - t.position_a;
    let d = p - t.position_a;
    let d11 = dot(e1, e1);
    let d12 = dot(e1, e2);
    let d22 = dot(e2, e2);
    let den = d11 * d22 - d12 * d12;
    if den <= 0.0 {
        return vec2<f32>(0.0);
    }
    return vec2<f32>(d22 * dot(d, e1) - d12 * dot(d, e2), d11 * dot(d, e2) - d12 * dot(d, e1)) / den;
}

// The point of triangle t at barycentrics b.
fn triangle_point(t: Triangle, b: vec2<f32>) -> vec3<f32> {
    return t.position_a * (1.0 - b.x - b.y) + t.position_b * b.x + t.position_c * b.y;
}

// Triangle `i` unpacked (src/scene/packed.rs): normals from octahedral snorm16 pairs.
fn triangle_at(i: u32) -> Triangle {
    let p = triangles[i];
    return Triangle(
        vec3<f32>(p.ax, p.ay, p.az), p.material & MATERIAL_INDEX,
        vec3<f32>(p.bx, p.by, p.bz), 0u,
        vec3<f32>(p.cx, p.cy, p.cz), 0u,
        unpack_normal(p.normal_a), 0u,
        unpack_normal(p.normal_b), 0u,
        unpack_normal(p.normal_c), 0u,
    );
}

// The unit normal of a triangle's face, by its winding (not the interpolated vertex normals).
fn face_normal(t: Triangle) -> vec3<f32> {
    return normalize(cross(t.position_b - t.position_a, t.position_c - t.position_a));
}

// The vertex normals of triangle t interpolated at barycentrics b.
fn interpolated_normal(t: Triangle, b: vec2<f32>) -> vec3<f32> {
    return normalize(t.normal_a * (1.0 - b.x - b.y) + t.normal_b * b.x + t.normal_c * b.y);
}

// Barycentrics of a point uniform in area on a triangle, from two uniform numbers.
fn uniform_barycentrics(u: f32, v: f32) -> vec2<f32> {
    let r = sqrt(u);
    return vec2<f32>(r * (1.0 - v), r * v);
}

// Barycentrics b within an emitter's `part` of its triangle (src/scene/parts.rs: the level in
// the low 4 bits, then a base-4 digit a cut choosing a child of the corners).
fn part_barycentrics(part: u32, b: vec2<f32>) -> vec2<f32> {
    var p = vec2<f32>(0.0);
    var q = vec2<f32>(1.0, 0.0);
    var r = vec2<f32>(0.0, 1.0);
    for (var i = 0u; i < (part & 15u); i++) {
        let pq = 0.5 * (p + q);
        let qr = 0.5 * (q + r);
        let rp = 0.5 * (r + p);
        switch (part >> (4u + 2u * i)) & 3u {
            case 0u: { q = pq; r = rp; }
            case 1u: { p = pq; r = qr; }
            case 2u: { p = rp; q = qr; }
            default: { p = qr; q = rp; r = pq; }
        }
    }
    return p + (q - p) * b.x + (r - p) * b.y;
}

// The triangle a camera G-buffer texel sees: its w is ±(triangle + 1), negative seen from
// behind, 0 where it sees nothing.
fn gbuffer_triangle(w: f32) -> u32 {
    return u32(abs(w)) - 1u;
}

// The material of a camera G-buffer texel `footprint` metres wide.
fn gbuffer_material(position: vec4<f32>, footprint: f32) -> Material {
    let triangle = gbuffer_triangle(position.w);
    let m = material_at(triangle, barycentrics(triangle_at(triangle), position.xyz), footprint);
    return as_seen_from(m, position.w > 0.0);
}

// A G-buffer texel's textures looked up once, for stages that read them for many photons a
// pixel (the splat): base colour (half floats: x r, g; y b), whether a normal map bends the
// shading normal away from the kernel's (y's high half), metalness and roughness (z, unorm16)
// and the kernel's normal (w, octahedral).
fn resolve_surface(m: Material, kernel: vec3<f32>, shading: vec3<f32>) -> vec4<u32> {
    let bent = select(0.0, 1.0, any(kernel != shading));
    return vec4<u32>(
        pack2x16float(m.base_color.rg),
        pack2x16float(vec2<f32>(m.base_color.b, bent)),
        pack2x16unorm(vec2<f32>(m.metallic, m.perceptual_roughness)),
        pack_normal(kernel),
    );
}

// `gbuffer_material` from the texel's `resolve_surface`.
fn resolved_material(position: vec4<f32>, surface: vec4<u32>) -> Material {
    var m = scene_material(triangles[gbuffer_triangle(position.w)].material);
    m.base_color = vec4<f32>(unpack2x16float(surface.x), unpack2x16float(surface.y).x, m.base_color.a);
    let mr = unpack2x16unorm(surface.z);
    m.metallic = mr.x;
    m.perceptual_roughness = mr.y;
    if (m.flags & MATERIAL_UNLIT) != 0u {
        m.reflectance = 0.0;
        m.specular_transmission = 0.0;
    }
    return as_seen_from(m, position.w > 0.0);
}

// `kernel_normal` from the texel's `resolve_surface`.
fn resolved_kernel_normal(surface: vec4<u32>, shading: vec3<f32>) -> vec3<f32> {
    return select(shading, unpack_normal(surface.w), unpack2x16float(surface.y).y > 0.5);
}

// The material on the side a ray arrives from: the back of a one-sided (not `double_sided`)
// opaque surface absorbs all light and emits none, as a one-sided BSDF does in Mitsuba;
// glass and surfaces that let diffuse light through are two-sided by nature.
fn as_seen_from(m: Material, front: bool) -> Material {
    if front || (m.flags & MATERIAL_DOUBLE_SIDED) != 0u || m.specular_transmission > 0.0 || m.diffuse_transmission > 0.0 {
        return m;
    }
    var black = m;
    black.base_color = vec4<f32>(0.0, 0.0, 0.0, m.base_color.a);
    black.emissive = vec4<f32>(0.0, 0.0, 0.0, m.emissive.w);
    black.metallic = 0.0;
    black.reflectance = 0.0;
    return black;
}

// The medium a path is in after crossing or leaving a surface of material m: a path that
// passes through (`crossed`) enters m's volume from its front and leaves it from its back;
// one reflected stays where it was. Absorbing volumes are closed meshes, so this is exact
// unless they overlap.
fn medium_after(medium: vec3<f32>, m: Material, front: bool, crossed: bool) -> vec3<f32> {
    if !crossed {
        return medium;
    }
    return select(vec3<f32>(0.0), m.absorption.rgb, front);
}

fn uv_transform(m: Material) -> mat2x2<f32> {
    return mat2x2<f32>(m.uv_transform.xy, m.uv_transform.zw);
}

// Texture coordinates at barycentrics b (xy) and the uv units one metre spans there (z).
fn surface_uv(m: Material, triangle: u32, b: vec2<f32>) -> vec3<f32> {
    let a = attributes[triangle];
    let t = triangle_at(triangle);
    let xf = uv_transform(m);
    let ua = xf * a.uv_a;
    let ub = xf * a.uv_b;
    let uc = xf * a.uv_c;
    let uv = ua * (1.0 - b.x - b.y) + ub * b.x + uc * b.y + m.uv_offset.xy;
    let e = mat2x2<f32>(ub - ua, uc - ua);
    let world_area = length(cross(t.position_b - t.position_a, t.position_c - t.position_a));
    return vec3<f32>(uv, sqrt(abs(determinant(e)) / max(world_area, 1e-30)));
}

fn vertex_color(c: vec2<u32>) -> vec4<f32> {
    return vec4<f32>(unpack2x16unorm(c.x), unpack2x16unorm(c.y));
}

fn srgb_to_linear(c: vec3<f32>) -> vec3<f32> {
    return select(pow((c + 0.055) / 1.055, vec3<f32>(2.4)), c / 12.92, c <= vec3<f32>(0.04045));
}

// Texel `at` of a level `size` texels wide, for at in [-1, size] (sample_texture's four):
// wrapped by comparisons, not `%` (integer division, one lane at a time on llvmpipe), along
// the axes that repeat; the others keep the edge's texel.
fn texel(t: Texture, offset: u32, size: vec2<i32>, at: vec2<i32>, repeat: vec2<bool>) -> vec4<f32> {
    let low = select(at, at + size, (at < vec2<i32>(0)) & repeat);
    let wrapped = clamp(select(low, low - size, (low >= size) & repeat), vec2<i32>(0), size - 1);
    let c = unpack4x8unorm(texels[offset + u32(wrapped.y * size.x + wrapped.x)]);
    if t.srgb != 0u {
        return vec4<f32>(srgb_to_linear(c.rgb), c.a);
    }
    return c;
}

#ifdef SAMPLERS
// A texture coordinate brought into [0, 1] by its wrap mode (Wrap::apply in textures.rs).
fn wrap_uv(t: f32, mode: u32) -> f32 {
    if mode == 1u {
        return clamp(t, 0.0, 1.0);
    }
    if mode == 2u {
        let m = t - 2.0 * floor(0.5 * t);
        return select(m, 2.0 - m, m > 1.0);
    }
    return fract(t);
}
#endif

// Lookup of texture `index` at uv, in linear values, from the mip level whose texels are
// about `footprint` uv units wide (0: the finest): bilinear and repeating, or as the image's
// sampler says (SAMPLERS).
fn sample_texture(index: u32, uv: vec2<f32>, footprint: f32) -> vec4<f32> {
    let t = textures[index];
    let texels_across = footprint * f32(max(t.width, t.height));
    let level = min(u32(max(log2(max(texels_across, 1.0)), 0.0)), t.levels - 1u);
    var offset = t.offset;
    var w = t.width;
    var h = t.height;
    for (var l = 0u; l < level; l += 1u) {
        offset += w * h;
        w = max(w / 2u, 1u);
        h = max(h / 2u, 1u);
    }
    let size = vec2<i32>(i32(w), i32(h));
#ifdef SAMPLERS
    let modes = vec2<u32>(t.sampler & 3u, (t.sampler >> 2u) & 3u);
    let repeat = modes == vec2<u32>(0u);
    let at = vec2<f32>(wrap_uv(uv.x, modes.x), wrap_uv(uv.y, modes.y)) * vec2<f32>(size);
    // Magnified where a texel spans more than the footprint.
    let nearest = select(t.sampler & 32u, t.sampler & 16u, texels_across <= 1.0);
    if nearest != 0u {
        return texel(t, offset, size, vec2<i32>(floor(at)), repeat);
    }
#else
    let repeat = vec2<bool>(true);
    let at = fract(uv) * vec2<f32>(size);
#endif
    let p = at - 0.5;
    let i = vec2<i32>(floor(p));
    let f = p - floor(p);
    let top = mix(texel(t, offset, size, i, repeat), texel(t, offset, size, i + vec2<i32>(1, 0), repeat), f.x);
    let bottom = mix(texel(t, offset, size, i + vec2<i32>(0, 1), repeat), texel(t, offset, size, i + vec2<i32>(1, 1), repeat), f.x);
    return mix(top, bottom, f.y);
}

// Base colour times vertex colour times base colour texture, alpha included.
fn base_color_at(m: Material, triangle: u32, b: vec2<f32>, uv: vec3<f32>, footprint: f32) -> vec4<f32> {
    let a = attributes[triangle];
    let w = vec3<f32>(1.0 - b.x - b.y, b);
    var c = m.base_color * (vertex_color(a.color_a) * w.x + vertex_color(a.color_b) * w.y + vertex_color(a.color_c) * w.z);
#ifdef BASE_COLOR_TEXTURE
    if m.textures.x != NO_TEXTURE {
        c *= sample_texture(m.textures.x, uv.xy, footprint * uv.z);
    }
#endif
    return c;
}

// The material of `triangle` at barycentrics b with its textures and vertex colours applied
// (as Bevy's StandardMaterial multiplies them), read at the mip level of a footprint
// `footprint` metres wide (0: the finest).
fn material_at(triangle: u32, b: vec2<f32>, footprint: f32) -> Material {
    var m = scene_material(triangles[triangle].material);
#ifdef TEXTURED
    if (m.flags & MATERIAL_TEXTURED) != 0u {
        let uv = surface_uv(m, triangle, b);
        m.base_color = base_color_at(m, triangle, b, uv, footprint);
#ifdef METALLIC_ROUGHNESS_TEXTURE
        if m.textures.y != NO_TEXTURE {
            let mr = sample_texture(m.textures.y, uv.xy, footprint * uv.z);
            // A rough factor stays a rough lobe: the scene's variants hold no mirror for it.
            m.perceptual_roughness = max(m.perceptual_roughness * mr.g, min(m.perceptual_roughness, DELTA_ROUGHNESS));
            m.metallic *= mr.b;
        }
#endif
#ifdef EMISSIVE_TEXTURE
        if m.textures.z != NO_TEXTURE {
            m.emissive = vec4<f32>(m.emissive.rgb * sample_texture(m.textures.z, uv.xy, footprint * uv.z).rgb, m.emissive.w);
        }
#endif
    }
    if (m.flags & MATERIAL_UNLIT) != 0u {
        // Seen in its base colour, which lights nothing and reflects nothing.
        m.emissive = vec4<f32>(m.base_color.rgb, 0.0);
        m.base_color = vec4<f32>(0.0, 0.0, 0.0, m.base_color.a);
        m.metallic = 0.0;
        m.reflectance = 0.0;
        m.specular_transmission = 0.0;
    }
#endif
    return m;
}

// Whether a ray stops at barycentrics b of `triangle`: not in a cut-out (alpha under the
// cutoff) and, for blended alpha, with probability alpha, hashed on the hit point (hashed
// alpha testing: the camera's jitter and every new path average it out).
fn opaque_at(triangle: u32, b: vec2<f32>) -> bool {
#ifdef ALPHA_TEST
    let m = scene_material(triangles[triangle].material);
    if (m.flags & (MATERIAL_ALPHA_MASK | MATERIAL_ALPHA_HASHED)) == 0u {
        return true;
    }
    var alpha = m.base_color.a;
    if (m.flags & MATERIAL_TEXTURED) != 0u {
        alpha = base_color_at(m, triangle, b, surface_uv(m, triangle, b), 0.0).a;
    }
    if (m.flags & MATERIAL_ALPHA_MASK) != 0u {
        return alpha >= m.alpha_cutoff;
    }
    let h = pcg_hash(triangle ^ pcg_hash(bitcast<u32>(b.x) ^ pcg_hash(bitcast<u32>(b.y))));
    return alpha > f32(h >> 8u) / 16777216.0;
#else
    return true;
#endif
}

// The shading normal at barycentrics b: the interpolated normal `n` bent by the normal map in
// the tangent frame of the triangle's texture coordinates (glTF's: texture +Y towards −v).
fn normal_at(triangle: u32, b: vec2<f32>, n: vec3<f32>) -> vec3<f32> {
#ifdef NORMAL_MAP
    let m = scene_material(triangles[triangle].material);
    if (m.flags & MATERIAL_TEXTURED) == 0u || m.textures.w == NO_TEXTURE {
        return n;
    }
    let uv = surface_uv(m, triangle, b);
    // The finest level: a mip averages normals, and a surface lit through their (flatter)
    // mean is brighter than the mean of its texels' light.
    var c = sample_texture(m.textures.w, uv.xy, 0.0).xyz * 2.0 - 1.0;
    if (m.flags & MATERIAL_FLIP_NORMAL_Y) != 0u {
        c.y = -c.y;
    }
    let t = triangle_at(triangle);
    let a = attributes[triangle];
    let e1 = t.position_b - t.position_a;
    let e2 = t.position_c - t.position_a;
    let xf = uv_transform(m);
    let d1 = xf * (a.uv_b - a.uv_a);
    let d2 = xf * (a.uv_c - a.uv_a);
    let r = d1.x * d2.y - d1.y * d2.x;
    if abs(r) < 1e-20 {
        return n;
    }
    let dpdu = (e1 * d2.y - e2 * d1.y) / r;
    let dpdv = (e2 * d1.x - e1 * d2.x) / r;
    let tangent = dpdu - n * dot(n, dpdu);
    let up = -dpdv - n * dot(n, dpdv);
    if dot(tangent, tangent) < 1e-30 || dot(up, up) < 1e-30 {
        return n;
    }
    let tn = normalize(tangent);
    let bn = normalize(up - tn * dot(tn, up));
    let bent = tn * c.x + bn * c.y + n * max(c.z, 1e-3);
    return normalize(bent);
#else
    return n;
#endif
}

// The normal the gather kernel lies in at a G-buffer texel whose shading normal is `shading`:
// the interpolated normal, on the shading normal's side, where a normal map bends it (bumps
// seen by the kernel would turn away the photons of their own flat surface).
fn kernel_normal(position: vec4<f32>, shading: vec3<f32>) -> vec3<f32> {
#ifdef NORMAL_MAP
    let triangle = gbuffer_triangle(position.w);
    let t = triangle_at(triangle);
    let m = scene_material(t.material);
    if (m.flags & MATERIAL_TEXTURED) == 0u || m.textures.w == NO_TEXTURE {
        return shading;
    }
    let n = interpolated_normal(t, barycentrics(t, position.xyz));
    return select(-n, n, dot(n, shading) >= 0.0);
#else
    return shading;
#endif
}

// Index of the light source in first..=last whose interval of the power CDF holds u.
fn find_source(u: f32, first: u32, last: u32) -> u32 {
    var lo = first;
    var hi = last;
    while lo < hi {
        let mid = (lo + hi) / 2u;
        if light_cdf[mid] < u {
            lo = mid + 1u;
        } else {
            hi = mid;
        }
    }
    return lo;
}
