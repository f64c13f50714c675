// Ray tracing through the deep cubemap (or, with RppmTracer::Bvh, a bounding-volume
// hierarchy: trace_ray picks). A ray is cut where it crosses from one cube face to
// the next; in each face it is marched through the tile grid in image space with the min/max
// hierarchy (a cell whose depth range the ray's depth interval misses is skipped whole, and
// the march climbs a level), and at the finest level only the triangles in the depth bins
// that the ray's depth interval crosses are tested, exactly and watertight.
#define_import_path bevy_rppm::cubemap

#import bevy_rppm::common::{CubemapParams, face_basis, level_offset, face_of, BIG_TRIANGLES, row_texel}
#import bevy_rppm::scene::{triangle_at, opaque_at, normal_at, interpolated_normal}
#import bevy_rppm::common::IterationParams
#import bevy_rppm::camera::camera_ray_at

@group(3) @binding(0) var<uniform> cubemap: CubemapParams;
@group(3) @binding(1) var<storage, read> hierarchy: array<vec2<f32>>;
@group(3) @binding(2) var<storage, read> heads: array<u32>;
@group(3) @binding(3) var<storage, read> nodes: array<vec2<u32>>;
// [count, ids…] of the triangles kept out of the lists (build.wgsl's `classify`).
@group(3) @binding(4) var<storage, read> big: array<u32>;
// The hierarchy that RppmTracer::Bvh traces instead (a stand-in otherwise), in two float
// textures (src/cubemap/bvh/texels.rs; `row_texel`): llvmpipe fetches a texel for 8 lanes at
// once, where it reads a storage buffer one lane and one load at a time (3x cheaper). Node i is texels 2i, 2i + 1: (min, first), (max, count), count -1 for an
// inner node (children first and first + 1), else a leaf of triangles first..first + count;
// triangle k of the leaves is texels 3k..3k + 2: its corners, the first's w its id.
@group(3) @binding(5) var bvh_nodes: texture_2d<f32>;
@group(3) @binding(6) var bvh_triangles: texture_2d<f32>;

struct BvhNode {
    min: vec3<f32>,
    first: u32,
    max: vec3<f32>,
    // -1: an inner node.
    count: f32,
}

// MAX_DEPTH in src/cubemap/bvh/build.rs.
const BVH_STACK: u32 = 48u;
fn bvh_node(i: u32) -> BvhNode {
    let lo = textureLoad(bvh_nodes, row_texel(2u * i), 0);
    let hi = textureLoad(bvh_nodes, row_texel(2u * i + 1u), 0);
    return BvhNode(lo.xyz, u32(lo.w), hi.xyz, hi.w);
}

const NO_HIT: u32 = 0xffffffffu;
const FAR: f32 = 1.0e30;

struct Hit {
    t: f32,
    triangle: u32,
    // Barycentric weights of the triangle's second and third vertices.
    uv: vec2<f32>,
}

// A ray in the watertight test's shear space (Woop, Benthin, Wald 2013), found once per ray:
// rows x, y, z take a point relative to the origin to the permuted, sheared coordinates.
struct RayFrame {
    o: vec3<f32>,
    x: vec3<f32>,
    y: vec3<f32>,
    z: vec3<f32>,
}

fn ray_frame(o: vec3<f32>, d: vec3<f32>) -> RayFrame {
    let ad = abs(d);
    // The axis along which d is largest becomes z; x and y follow it cyclically, swapped
    // where d points down z so that the winding is kept.
    var ez = vec3<f32>(1.0, 0.0, 0.0);
    if ad.y > ad.x && ad.y >= ad.z {
        ez = vec3<f32>(0.0, 1.0, 0.0);
    } else if ad.z > ad.x && ad.z > ad.y {
        ez = vec3<f32>(0.0, 0.0, 1.0);
    }
    var ex = ez.zxy;
    var ey = ez.yzx;
    let dz = dot(ez, d);
    if dz < 0.0 {
        let swap = ex;
        ex = ey;
        ey = swap;
    }
    let sz = 1.0 / dz;
    return RayFrame(o, ex - (dot(ex, d) * sz) * ez, ey - (dot(ey, d) * sz) * ez, sz * ez);
}

// Watertight ray/triangle intersection: edges are tested in the ray's shear space, where each
// vertex is placed alone, so a ray through a shared edge hits one of its two triangles.
// Returns (t, u, v) with t < 0 on a miss.
fn intersect_triangle(r: RayFrame, pa: vec3<f32>, pb: vec3<f32>, pc: vec3<f32>) -> vec3<f32> {
    let a = pa - r.o;
    let b = pb - r.o;
    let c = pc - r.o;
    let ax = dot(r.x, a);
    let ay = dot(r.y, a);
    let bx = dot(r.x, b);
    let by = dot(r.y, b);
    let cx = dot(r.x, c);
    let cy = dot(r.y, c);
    let u = cx * by - cy * bx;
    let v = ax * cy - ay * cx;
    let w = bx * ay - by * ax;
    if (u < 0.0 || v < 0.0 || w < 0.0) && (u > 0.0 || v > 0.0 || w > 0.0) {
        return vec3<f32>(-1.0);
    }
    let det = u + v + w;
    if det == 0.0 {
        return vec3<f32>(-1.0);
    }
    let t = (u * dot(r.z, a) + v * dot(r.z, b) + w * dot(r.z, c)) / det;
    return vec3<f32>(t, v / det, w / det);
}

fn consider(r: RayFrame, id: u32, t_min: f32, best: ptr<function, Hit>) {
    let t = triangle_at(id);
    consider_corners(r, t.position_a, t.position_b, t.position_c, id, t_min, best);
}

// Triangle `id` of corners pa, pb, pc.
fn consider_corners(r: RayFrame, pa: vec3<f32>, pb: vec3<f32>, pc: vec3<f32>, id: u32, t_min: f32, best: ptr<function, Hit>) {
    let h = intersect_triangle(r, pa, pb, pc);
    // Equal distances (an edge two triangles share) go to the lower index, not to whichever
    // the list, filled by atomics in no set order, gives first.
    let nearer = h.x < (*best).t || (h.x == (*best).t && id < (*best).triangle);
    if h.x > t_min && nearer {
        *best = Hit(h.x, id, h.yz);
    }
}

// The ray in one face's frame: screen coordinate s(t) = (p + t q) / (w + t r).
struct FaceRay {
    p: vec2<f32>,
    q: vec2<f32>,
    w: f32,
    r: f32,
}

// Parameter where the screen coordinate along `axis` reaches the grid line `line`.
fn t_at_line(ray: FaceRay, axis: u32, line: f32) -> f32 {
    let g = f32(cubemap.grid);
    // Grid x grows with screen u, grid y shrinks with screen v.
    let s = select(1.0 - line / g * 2.0, line / g * 2.0 - 1.0, axis == 0u);
    let den = ray.q[axis] - s * ray.r;
    if den == 0.0 {
        return FAR;
    }
    return (s * ray.w - ray.p[axis]) / den;
}

// A grid line beyond the vanishing point is never reached: its solution lies behind the ray
// or behind the centre. Such crossings count as never.
fn ahead(ray: FaceRay, t: f32, crossing: f32) -> f32 {
    if crossing > t && ray.w + crossing * ray.r > 0.0 {
        return crossing;
    }
    return FAR;
}

fn grid_at(ray: FaceRay, t: f32) -> vec2<f32> {
    let s = (ray.p + t * ray.q) / (ray.w + t * ray.r);
    let g = f32(cubemap.grid);
    return vec2<f32>((s.x + 1.0) * 0.5 * g, (1.0 - s.y) * 0.5 * g);
}

// Marches the part [t0, t1] of the ray that lies in face f.
fn trace_face(r: RayFrame, o: vec3<f32>, d: vec3<f32>, f: u32, t0: f32, t1: f32, t_min: f32, ignore: u32, best: ptr<function, Hit>) {
    let basis = transpose(face_basis(f));
    let lo = basis * (o - cubemap.centre.xyz);
    let ld = basis * d;
    let ray = FaceRay(lo.xy, ld.xy, lo.z, ld.z);
    var t = t0;
    // Start beyond the near limit of recorded geometry.
    if ray.w + t * ray.r < cubemap.near {
        if ray.r <= 0.0 {
            return;
        }
        t = (cubemap.near - ray.w) / ray.r;
    }
    let end = min(t1, (*best).t);
    if t >= end {
        return;
    }
    let grid = cubemap.grid;
    let g = f32(grid);
    // Direction of motion through the grid (constant along a line's projection).
    let du = ray.q.x * ray.w - ray.p.x * ray.r;
    let dv = -(ray.q.y * ray.w - ray.p.y * ray.r);
    let step = vec2<i32>(select(select(0, -1, du < 0.0), 1, du > 0.0), select(select(0, -1, dv < 0.0), 1, dv > 0.0));
    // The starting cell, a hair past t so that a start on a grid line picks the cell ahead.
    let probe = min(end - t, 1e-5 * (abs(t) + length(lo) / max(length(ld), 1e-30)));
    let start = grid_at(ray, t + 0.5 * probe);
    var cell = vec2<i32>(clamp(floor(start), vec2<f32>(0.0), vec2<f32>(g - 1.0)));
    var level = 0u;
    let top = cubemap.levels - 1u;
    for (var guard = 0u; guard < 64u * grid + 256u; guard += 1u) {
        if t >= end || (*best).t <= t {
            return;
        }
        let size = i32(1u << level);
        let coarse = cell >> vec2<u32>(level);
        // Where the ray leaves this cell in x and in y.
        var tx = FAR;
        var ty = FAR;
        if step.x != 0 {
            tx = ahead(ray, t, t_at_line(ray, 0u, f32((coarse.x + select(0, 1, step.x > 0)) * size)));
        }
        if step.y != 0 {
            ty = ahead(ray, t, t_at_line(ray, 1u, f32((coarse.y + select(0, 1, step.y > 0)) * size)));
        }
        let t_exit = min(min(tx, ty), end);
        let z0 = ray.w + t * ray.r;
        let z1 = ray.w + t_exit * ray.r;
        let zr = vec2<f32>(min(z0, z1) * (1.0 - 1e-4), max(z0, z1) * (1.0 + 1e-4));
        let cells = max(grid >> level, 1u);
        let index = level_offset(cubemap, level) + (f * cells + u32(coarse.y)) * cells + u32(coarse.x);
        let range = hierarchy[index];
        let overlaps = range.x <= zr.y && range.y >= zr.x;
        if overlaps && level > 0u {
            level -= 1u;
            continue;
        }
        if overlaps {
            test_tile(r, f, cell, zr, range, t_min, ignore, best);
            if (*best).t <= t_exit {
                return;
            }
        }
        // Leave the cell through the nearer of its two exits.
        if t_exit >= end {
            return;
        }
        if tx <= ty {
            cell.x = select(coarse.x * size - 1, (coarse.x + 1) * size, step.x > 0);
            let y = i32(floor(grid_at(ray, t_exit).y));
            cell.y = clamp(y, coarse.y * size, coarse.y * size + size - 1);
        } else {
            cell.y = select(coarse.y * size - 1, (coarse.y + 1) * size, step.y > 0);
            let x = i32(floor(grid_at(ray, t_exit).x));
            cell.x = clamp(x, coarse.x * size, coarse.x * size + size - 1);
        }
        if any(cell < vec2<i32>(0)) || any(cell >= vec2<i32>(i32(grid))) {
            return;
        }
        t = t_exit;
        if !overlaps {
            level = min(level + 1u, top);
        }
    }
}

// Tests the triangles of the tile's bins that the ray's depth interval `zr` crosses.
fn test_tile(r: RayFrame, f: u32, cell: vec2<i32>, zr: vec2<f32>, range: vec2<f32>, t_min: f32, ignore: u32, best: ptr<function, Hit>) {
    let grid = cubemap.grid;
    let tile = (f * grid + u32(cell.y)) * grid + u32(cell.x);
    let width = (range.y - range.x) / f32(cubemap.bins);
    var first = 0u;
    var last = cubemap.bins - 1u;
    if width > 0.0 {
        first = u32(clamp(floor((zr.x - range.x) / width), 0.0, f32(cubemap.bins - 1u)));
        last = u32(clamp(floor((zr.y - range.x) / width), 0.0, f32(cubemap.bins - 1u)));
    }
    for (var b = first; b <= last; b += 1u) {
        var node = heads[tile * cubemap.bins + b];
        for (var guard = 0u; node != 0u && guard < cubemap.node_capacity; guard += 1u) {
            let entry = nodes[node - 1u];
            if entry.x != ignore {
                consider(r, entry.x, t_min, best);
            }
            node = entry.y;
        }
    }
}

// Nearest hit in (t_min, t_max) through the deep cubemap, skipping triangle `ignore` (the one
// a bounce ray leaves; NO_HIT for none). `d` need not be normalised; t is in its units.
fn trace_cubemap(o: vec3<f32>, d: vec3<f32>, t_min: f32, t_max: f32, ignore: u32) -> Hit {
    var best = Hit(min(t_max, FAR), NO_HIT, vec2<f32>(0.0));
    let r = ray_frame(o, d);
    // The big triangles first: a near hit among them ends the march early.
    let bigs = big[0];
    if bigs <= BIG_TRIANGLES {
        for (var i = 0u; i < bigs; i += 1u) {
            let id = big[1u + i];
            if id != ignore {
                consider(r, id, t_min, &best);
            }
        }
    }
    let oc = o - cubemap.centre.xyz;
    // Parameters where the ray crosses the planes between faces (|x|=|y|, |x|=|z|, |y|=|z|).
    var cuts: array<f32, 8>;
    var n = 0u;
    let planes = array<vec3<f32>, 6>(
        vec3(1.0, -1.0, 0.0), vec3(1.0, 1.0, 0.0), vec3(1.0, 0.0, -1.0),
        vec3(1.0, 0.0, 1.0), vec3(0.0, 1.0, -1.0), vec3(0.0, 1.0, 1.0),
    );
    for (var i = 0u; i < 6u; i += 1u) {
        let den = dot(planes[i], d);
        if den != 0.0 {
            let t = -dot(planes[i], oc) / den;
            if t > t_min && t < best.t {
                // Insertion sort: at most six cuts.
                var j = n;
                while j > 0u && cuts[j - 1u] > t {
                    cuts[j] = cuts[j - 1u];
                    j -= 1u;
                }
                cuts[j] = t;
                n += 1u;
            }
        }
    }
    var t0 = max(t_min, 0.0);
    for (var i = 0u; i <= n; i += 1u) {
        let t1 = select(best.t, cuts[i], i < n);
        if t0 >= best.t {
            break;
        }
        if t1 > t0 {
            let mid = t0 + 0.5 * min(t1 - t0, 1.0e20);
            trace_face(r, o, d, face_of(oc + d * mid), t0, t1, t_min, ignore, &best);
        }
        t0 = max(t0, t1);
    }
    return best;
}

// Where the ray enters a node's box within (0, t_max), or FAR_BOX on a miss.
const FAR_BOX: f32 = 3.0e38;
const BOX_SLACK: f32 = 4e-6;

fn enter_box(o: vec3<f32>, inv: vec3<f32>, n: BvhNode, t_max: f32) -> f32 {
    let t0 = (n.min - o) * inv;
    let t1 = (n.max - o) * inv;
    let lo = min(t0, t1);
    let hi = max(t0, t1);
    let near = max(max(lo.x, lo.y), max(lo.z, 0.0));
    // A box's entry distance rounds otherwise than a triangle's in it: entered a hair beyond
    // t_max, a face coplanar with the best hit (a glass block resting on a floor) is still
    // tested, and the nearer of the two by the last bit wins, as in brute force.
    let far = min(min(hi.x, hi.y), min(hi.z, t_max * (1.0 + BOX_SLACK)));
    return select(FAR_BOX, near, near <= far);
}

// The stacked node the current best hit may still be beaten in, or BVH_DONE: its box was
// entered at `entry`, before its far side, so only the best hit's distance can cull it now.
fn bvh_pop(stack: ptr<function, array<u32, BVH_STACK>>, entry: ptr<function, array<f32, BVH_STACK>>, top: ptr<function, u32>, best: f32) -> u32 {
    while *top > 0u {
        *top -= 1u;
        if (*entry)[*top] <= best * (1.0 + BOX_SLACK) {
            return (*stack)[*top];
        }
    }
    return BVH_DONE;
}

const BVH_DONE: u32 = 0xffffffffu;

// Nearest hit by a stack walk of the hierarchy, nearer child first; triangles are tested as
// brute force tests them. With `any`, the first hit found (a shadow ray's question).
// While-while (Aila and Laine 2009): down through inner nodes until every lane is at a leaf,
// then the leaves, so that lanes run the box tests together and the triangle tests together
// (llvmpipe runs both sides of a branch for all 8 lanes). A node is fetched once, when its
// parent tests its box; the other child is stacked with its entry distance.
fn trace_bvh(o: vec3<f32>, d: vec3<f32>, t_min: f32, t_max: f32, ignore: u32, any: bool) -> Hit {
    var best = Hit(t_max, NO_HIT, vec2<f32>(0.0));
    let r = ray_frame(o, d);
    // A zero component's reciprocal as a huge number of its sign, never NaN in the slabs.
    let inv = 1.0 / select(d, vec3<f32>(1e-30), abs(d) < vec3<f32>(1e-30));
    var stack: array<u32, BVH_STACK>;
    var entry: array<f32, BVH_STACK>;
    var top = 0u;
    var n = bvh_node(0u);
    if enter_box(o, inv, n, t_max) == FAR_BOX {
        return best;
    }
    loop {
        var done = false;
        while n.count < 0.0 {
            let first = n.first;
            let n0 = bvh_node(first);
            let n1 = bvh_node(first + 1u);
            let a = enter_box(o, inv, n0, best.t);
            let b = enter_box(o, inv, n1, best.t);
            if min(a, b) < FAR_BOX {
                let near_first = a <= b;
                if max(a, b) < FAR_BOX && top < BVH_STACK {
                    stack[top] = select(first, first + 1u, near_first);
                    entry[top] = max(a, b);
                    top += 1u;
                }
                n = BvhNode(
                    select(n1.min, n0.min, near_first),
                    select(n1.first, n0.first, near_first),
                    select(n1.max, n0.max, near_first),
                    select(n1.count, n0.count, near_first),
                );
            } else {
                let next = bvh_pop(&stack, &entry, &top, best.t);
                done = next == BVH_DONE;
                n = bvh_node(select(next, 0u, done));
                n.count = select(n.count, 0.0, done);
            }
        }
        let end = n.first + u32(n.count);
        for (var k = n.first; k < end; k += 1u) {
            let a = textureLoad(bvh_triangles, row_texel(3u * k), 0);
            let id = u32(a.w);
            if id != ignore {
                let b = textureLoad(bvh_triangles, row_texel(3u * k + 1u), 0).xyz;
                let c = textureLoad(bvh_triangles, row_texel(3u * k + 2u), 0).xyz;
                consider_corners(r, a.xyz, b, c, id, t_min, &best);
            }
        }
        if done || (any && best.triangle != NO_HIT) {
            break;
        }
        let next = bvh_pop(&stack, &entry, &top, best.t);
        if next == BVH_DONE {
            break;
        }
        n = bvh_node(next);
    }
    return best;
}

// Nearest triangle in (t_min, t_max), alpha aside.
fn nearest_triangle(o: vec3<f32>, d: vec3<f32>, t_min: f32, t_max: f32, ignore: u32) -> Hit {
#ifdef BVH
    return trace_bvh(o, d, t_min, min(t_max, FAR), ignore, false);
#else
    return trace_cubemap(o, d, t_min, t_max, ignore);
#endif
}

// Most cut-out layers a ray passes (a ray past this many is taken as a miss).
const ALPHA_LAYERS: u32 = 64u;

// Nearest hit in (t_min, t_max) by the view's tracer: the deep cubemap, or with BVH the
// hierarchy. With cut-outs or blended alpha (ALPHA_TEST), the nearest triangle, then on past
// it while the ray meets a hole there: alpha is looked up once per hit, not for every
// triangle tested (in the triangle loop, llvmpipe paid for the lookup at every test, taken
// or not, and traced at half speed even in scenes without alpha).
fn trace_ray(o: vec3<f32>, d: vec3<f32>, t_min: f32, t_max: f32, ignore: u32) -> Hit {
#ifdef ALPHA_TEST
    var near = t_min;
    var skip = ignore;
    for (var layer = 0u; layer < ALPHA_LAYERS; layer += 1u) {
        let hit = nearest_triangle(o, d, near, t_max, skip);
        if hit.triangle == NO_HIT || opaque_at(hit.triangle, hit.uv) {
            return hit;
        }
        // On from just short of the hole, past its triangle: a triangle at the same distance
        // (a cut-out decal on a floor) is still met.
        near = max(near, hit.t * (1.0 - 1e-6));
        skip = hit.triangle;
    }
    return Hit(min(t_max, FAR), NO_HIT, vec2<f32>(0.0));
#else
    return nearest_triangle(o, d, t_min, t_max, ignore);
#endif
}

// Whether anything lies in (t_min, t_max) along the ray: the hierarchy stops at its first hit
// (with alpha, the first hit found need not be the nearest, so the nearest is looked for).
fn occluded(o: vec3<f32>, d: vec3<f32>, t_min: f32, t_max: f32, ignore: u32) -> bool {
#ifdef ALPHA_TEST
    return trace_ray(o, d, t_min, t_max, ignore).triangle != NO_HIT;
#else
#ifdef BVH
    return trace_bvh(o, d, t_min, min(t_max, FAR), ignore, true).triangle != NO_HIT;
#else
    return trace_cubemap(o, d, t_min, t_max, ignore).triangle != NO_HIT;
#endif
#endif
}

// What the camera's ray through `at` (pixels of the iteration's image) meets, as a G-buffer
// texel keeps it: [0] position (w ±(triangle + 1), negative seen from behind; 0: nothing),
// [1] shading normal facing the ray (w the footprint, the world size of a pixel there).
fn camera_hit(params: IterationParams, at: vec2<f32>) -> array<vec4<f32>, 2> {
    let ray = camera_ray_at(params, at);
    let hit = trace_ray(ray.origin, ray.direction, 0.0, FAR, NO_HIT);
    if hit.triangle == NO_HIT {
        return array<vec4<f32>, 2>(vec4<f32>(0.0), vec4<f32>(0.0, 0.0, 1.0, 0.0));
    }
    let t = triangle_at(hit.triangle);
    let front = dot(cross(t.position_b - t.position_a, t.position_c - t.position_a), ray.direction) < 0.0;
    let n = normal_at(hit.triangle, hit.uv, interpolated_normal(t, hit.uv));
    let x = ray.origin + ray.direction * hit.t;
    let footprint = params.pixel_spread * select(distance(x, params.camera_position.xyz), 1.0, params.orthographic != 0u);
    let tag = f32(hit.triangle + 1u);
    return array<vec4<f32>, 2>(vec4<f32>(x, select(-tag, tag, front)), vec4<f32>(select(-n, n, front), footprint));
}
