// Photon tracing: photons leave every light, chosen by power, and are traced through the deep
// cubemap; a photon is stored at every diffuse or rough-glossy hit after its first bounce
// (direct light is the local-illumination stage's), then scattered by the material
// (bsdf.wgsl's scatter_photon: diffuse, GGX glossy, mirror, Fresnel glass) or absorbed.
#import bevy_rppm::common::{Light, Emitter, Photon, IterationParams, PI, cubemap_tile, pack_normal, LIGHT_POINT, LIGHT_SPOT, LIGHT_DIRECTIONAL, basis_around, cosine_direction}
#import bevy_rppm::sampling::{random, pcg_hash, sphere_cap, cone_local}
#import bevy_rppm::scene::{triangle_at, face_normal, material_at, as_seen_from, normal_at, interpolated_normal, triangle_point, uniform_barycentrics, part_barycentrics, lights, emitters, light_cdf, find_source}
#import bevy_rppm::cubemap::{cubemap, trace_ray, NO_HIT}
#import bevy_rppm::bsdf::{stores_photons, scatter_photon, bent_cosine}
#ifdef ABSORPTION
#import bevy_rppm::scene::medium_after
#endif
#ifdef PANES
#import bevy_rppm::panes::{PaneWalk, panes_on, pane_walk, pane_segment, pane_scatter, pane_direct, pane_too_thick}
#import bevy_rppm::pane_rays::through_panes
#endif

@group(1) @binding(0) var<uniform> params: IterationParams;

// The photons in the order they are stored; photons/sort.wgsl orders them by tile.
@group(2) @binding(0) var<storage, read_write> photons: array<Photon>;
// [-, photons stored (placed or not), -, -].
@group(2) @binding(1) var<storage, read_write> photon_count: array<atomic<u32>, 4>;
// Per cubemap tile, the photons stored in it.
@group(2) @binding(2) var<storage, read_write> tile_counts: array<atomic<u32>>;
// Per photon, its cubemap tile and its rank among the tile's photons.
@group(2) @binding(3) var<storage, read_write> photon_tiles: array<vec2<u32>>;

struct Ray {
    origin: vec3<f32>,
    direction: vec3<f32>,
    flux: vec3<f32>,
    // Triangle the ray leaves (NO_HIT at a light).
    ignore: u32,
    // Where it left its light, or for a sun's or the sky's photon the way back to it (w 1).
    source: vec4<f32>,
}

fn uniform_sphere(u: vec2<f32>) -> vec3<f32> {
    let z = 1.0 - 2.0 * u.x;
    let r = sqrt(max(1.0 - z * z, 0.0));
    let phi = 2.0 * PI * u.y;
    return vec3<f32>(r * cos(phi), r * sin(phi), z);
}

// How far the camera sees, as local illumination counted it this iteration (eye_paths.wgsl).
@group(1) @binding(1) var<storage, read_write> seen: array<atomic<u32>, 16>;

// `seen_radius`, found once per workgroup (not per photon) at the start of `trace`.
var<workgroup> seen_near: f32;

// The radius around the camera within which 90 % of the visible pixels lie, when under half
// the scene's radius (a room in a wide landscape, a window's view out included); else 0.
fn seen_radius() -> f32 {
    var total = 0u;
    for (var k = 0u; k < 16u; k += 1u) {
        total += atomicLoad(&seen[k]);
    }
    var within = 0u;
    for (var k = 15u; k >= 1u; k -= 1u) {
        within += atomicLoad(&seen[k]);
        if f32(within) >= 0.9 * f32(total) && total > 0u {
            return params.scene_sphere.w * exp2(-f32(k));
        }
    }
    return 0.0;
}

// Where a photon travelling along `direction` (a sun's or the sky's) starts, and the area it
// stands for (1/pdf), on a disc across the scene upstream. Where the camera sees only nearby
// (`seen_radius`), the photons start on discs around the camera's line along `direction`,
// from that radius up, each 4× wider than the last up to the scene's: half the photons on the
// nearest, the rest alike on the others, so that their density falls as 1/d² away from the
// camera as the pixels' need does (a pixel twice as far covers four times the area); the pdf
// sums every disc, so every part of the scene is still reached.
fn emission_disc(direction: vec3<f32>, rng: ptr<function, u32>) -> vec4<f32> {
    let scene = params.scene_sphere;
    let b = basis_around(direction);
    var near = scene.w;
    var levels = 1u;
    if params.seen_region != 0u {
        let radius = seen_near;
        if radius > 0.0 {
            near = radius;
            levels = min(u32(ceil(0.5 * log2(scene.w / radius))), 7u) + 1u;
        }
    }
    let c = params.camera_position.xyz - scene.xyz;
    let camera = vec2<f32>(dot(c, b[0]), dot(c, b[1]));
    // Disc k < levels - 1: around the camera, 4^k × `near`; the last, the scene's. Half the
    // photons start on the nearest, the other half on the wider ones alike.
    var level = levels - 1u;
    if levels > 1u {
        let u = random(rng);
        let wider = min(u32((2.0 * u - 1.0) * f32(levels - 1u)), levels - 2u) + 1u;
        level = select(wider, 0u, u < 0.5);
    }
    let last = level == levels - 1u;
    let centre = select(camera, vec2<f32>(0.0), last);
    let radius = select(near * exp2(2.0 * f32(level)), scene.w, last);
    let r = radius * sqrt(random(rng));
    let phi = 2.0 * PI * random(rng);
    let at = centre + r * vec2<f32>(cos(phi), sin(phi));
    var density = 1.0 / (PI * scene.w * scene.w);
    if levels > 1u {
        let wider = 0.5 / f32(levels - 1u);
        density = select(0.0, wider * density, dot(at, at) <= scene.w * scene.w);
        let d2 = dot(at - camera, at - camera);
        for (var k = 0u; k + 1u < levels; k += 1u) {
            let rk = near * exp2(2.0 * f32(k));
            let share = select(wider, 0.5, k == 0u);
            density += select(0.0, share / (PI * rk * rk), d2 <= rk * rk);
        }
    }
    let origin = scene.xyz - direction * (2.0 * scene.w) + b * vec3<f32>(at, 0.0);
    return vec4<f32>(origin, 1.0 / density);
}

// The direction a photon leaves an emitter's point `x` by, and cos θ / pdf (w). Within the
// cone of the sphere its photons can meet (src/scene/receivers.rs), uniform in solid angle,
// where that cone is narrower than 60° from its axis: a panel wider than what lies under it
// sent most photons past everything by its cosine. Else by the cosine (π). Both give each
// direction toward the scene its cosine's share of the power, so no light is lost or added.
fn emitted_direction(x: vec3<f32>, n: vec3<f32>, e: Emitter, rng: ptr<function, u32>) -> vec4<f32> {
    let u = vec2<f32>(random(rng), random(rng));
    let to = vec3<f32>(e.toward_x, e.toward_y, e.toward_z) - x;
    let r2 = e.toward_radius * e.toward_radius;
    let d2 = dot(to, to);
    let width = sphere_cap(e.toward_radius, d2);
    if width > 0.0 && r2 < 0.75 * d2 {
        let w = basis_around(to * inverseSqrt(d2)) * cone_local(width, u);
        // A direction behind the emitter (the sphere may reach there) carries nothing.
        return vec4<f32>(w, max(dot(w, n), 0.0) * 2.0 * PI * width);
    }
    return vec4<f32>(cosine_direction(n, u), PI);
}

fn emit(rng: ptr<function, u32>) -> Ray {
    let index = find_source(random(rng), 0u, params.source_count - 1u);
    let previous = select(0.0, light_cdf[index - 1u], index > 0u);
    // Each photon carries the source's power over (its probability × photons emitted).
    let share = 1.0 / (max(light_cdf[index] - previous, 1e-12) * f32(params.photons));
    var ray: Ray;
    ray.ignore = NO_HIT;
#ifdef SKY
    if index == params.source_count - 1u {
        // The sky (the last source): a direction uniform on the sphere, from a disc across
        // the scene's bounding sphere upstream of it; 4π directions × πR² carry its power.
        let direction = uniform_sphere(vec2<f32>(random(rng), random(rng)));
        let start = emission_disc(direction, rng);
        ray.origin = start.xyz;
        ray.direction = direction;
        ray.flux = params.sky.rgb * (4.0 * PI * start.w * share);
        ray.source = vec4<f32>(-direction, 1.0);
        return ray;
    }
#endif
    if index >= params.light_count {
        let e = emitters[index - params.light_count];
        let t = triangle_at(e.triangle);
        let u = random(rng);
        let b = part_barycentrics(e.part, uniform_barycentrics(u, random(rng)));
        ray.origin = triangle_point(t, b);
        let n = face_normal(t);
        let leaving = emitted_direction(ray.origin, n, e, rng);
        ray.direction = leaving.xyz;
        let emitted = material_at(e.triangle, b, 0.0).emissive.rgb;
        ray.flux = emitted * (leaving.w * e.area * share);
        ray.ignore = e.triangle;
        ray.source = vec4<f32>(ray.origin, 0.0);
        return ray;
    }
    let l = lights[index];
    if l.kind == LIGHT_DIRECTIONAL {
        let start = emission_disc(l.direction.xyz, rng);
        ray.origin = start.xyz;
        ray.direction = l.direction.xyz;
        ray.flux = l.radiance.rgb * (start.w * share);
        ray.source = vec4<f32>(-ray.direction, 1.0);
        return ray;
    }
    ray.origin = l.position.xyz;
    if l.kind == LIGHT_SPOT {
        // Uniform in the outer cone's solid angle, weighted by Bevy's falloff a².
        let local = cone_local(1.0 - l.cos_outer, vec2<f32>(random(rng), random(rng)));
        let cos_theta = local.z;
        ray.direction = basis_around(l.direction.xyz) * local;
        let a = clamp((cos_theta - l.cos_outer) / max(l.cos_inner - l.cos_outer, 1e-6), 0.0, 1.0);
        let falloff = select(a * a, 1.0, l.cos_inner <= l.cos_outer);
        ray.flux = l.radiance.rgb * (2.0 * PI * (1.0 - l.cos_outer) * falloff * share);
        if l.position.w > 0.0 {
            // A sphere light: from the side of its sphere the photon leaves.
            let u = uniform_sphere(vec2<f32>(random(rng), random(rng)));
            ray.origin += l.position.w * select(-u, u, dot(u, ray.direction) >= 0.0);
        }
        ray.source = vec4<f32>(ray.origin, 0.0);
        return ray;
    }
    if l.position.w > 0.0 {
        // A sphere light: Lambertian from a point of its surface, so that every direction
        // sees a disc of radiance I/(πR²), intensity I.
        let u = uniform_sphere(vec2<f32>(random(rng), random(rng)));
        ray.origin += l.position.w * u;
        ray.direction = cosine_direction(u, vec2<f32>(random(rng), random(rng)));
    } else {
        ray.direction = uniform_sphere(vec2<f32>(random(rng), random(rng)));
    }
    ray.flux = l.radiance.rgb * (4.0 * PI * share);
    ray.source = vec4<f32>(ray.origin, 0.0);
    return ray;
}

// A photon at x, caustic or not (`photon_caustic`: the lowest bit of its incoming direction,
// a 32 767th of one of its coordinates).
fn store(x: vec3<f32>, ray: Ray, n: vec3<f32>, caustic: bool) {
    let slot = atomicAdd(&photon_count[1], 1u);
    if slot < params.photon_capacity {
        let tile = cubemap_tile(cubemap, x).index;
        photon_tiles[slot] = vec2<u32>(tile, atomicAdd(&tile_counts[tile], 1u));
        let incoming = (pack_normal(-ray.direction) & ~1u) | select(0u, 1u, caustic);
        photons[slot] = Photon(x, incoming, ray.flux, pack_normal(n));
    }
}

// The random numbers of photon `index` this iteration.
fn photon_seed(index: u32) -> u32 {
    return pcg_hash(index ^ pcg_hash(params.sequence * 0x9e3779b9u + 0x632be5abu));
}

// Path regeneration: `photon_lanes` invocations trace the iteration's photons, each taking
// the next (index + lanes) when its photon ends, so the lanes of a SIMD group stay busy
// until all their photons are done instead of idling behind the longest path of the group.
#ifdef NORMAL_MAP
// What a photon keeps of its scattered weight where a normal map bends the shading normal n
// away from the surface's own (`plane`): its flux is irradiance on the surface, which the
// bent normal receives by its own cosine (wi), and it leaves as radiance the surface sends
// out by its own cosine (wo), not the bent one it was drawn by: Veach's adjoint BSDF for
// shading normals, |wi·n| |wo·plane| / (|wi·plane| |wo·n|). A direction on one side of the
// surface and the other of n is dropped, as Mitsuba's `normalmap` drops it. Without it a
// bumpy floor sent too much light out at grazing angles (the wall above it 4–11 % bright).
fn bent_scatter(n: vec3<f32>, plane: vec3<f32>, wi: vec3<f32>, wo: vec3<f32>) -> f32 {
    if all(n == plane) {
        return 1.0;
    }
    let out_bent = dot(wo, n);
    let out_plane = dot(wo, plane);
    if dot(wi, n) * dot(wi, plane) <= 0.0 || out_bent * out_plane <= 0.0 {
        return 0.0;
    }
    // The cosine lobes are drawn about `plane` already (scatter_photon's `around`): their way
    // out is weighed there, and this factor's undoes it but for its floor, met only in the
    // last 1 % above n's horizon.
    return bent_cosine(n, plane, wi) * abs(out_plane) / max(abs(out_bent), 0.01);
}

// The most a photon's flux may grow by `bent_scatter` along its path. Each factor is at most
// 2 000, and a few bounces in a glossy metal's grooves multiplied one photon of 2 million to
// 2 % of `grooved_metal`'s image (a red disc of 80× the wall's light after 30 iterations,
// relMSE 1.77). Capped, the grooved scenes lose 0.15–0.2 % of their energy.
const BENT_GAIN_MAX: f32 = 32.0;
#endif

@compute @workgroup_size(64, 1, 1)
fn trace(@builtin(global_invocation_id) id: vec3<u32>, @builtin(local_invocation_index) lane: u32) {
    if params.seen_region != 0u {
        if lane == 0u {
            seen_near = seen_radius();
        }
        workgroupBarrier();
    }
    let lanes = params.photon_lanes;
    var index = id.x;
    if index >= lanes || index >= params.photons {
        return;
    }
    var rng = photon_seed(index);
    var ray = emit(&rng);
    var depth = 0u;
    // Whether every surface the photon met stored none (`photon_caustic` past the first).
    var caustic = true;
    let t_min = params.scene_sphere.w * 1e-6;
#ifdef ABSORPTION
    // σ of the coloured glass the photon is in (lights are outside every medium).
    var medium = vec3<f32>(0.0);
#endif
#ifdef PANES
    // Light through panes is direct light, the shadow rays' (common/panes.wgsl).
    let panes = panes_on(params);
    var walk = pane_walk();
#endif
#ifdef NORMAL_MAP
    // What `bent_scatter` multiplied this photon's flux by so far.
    var bent_gain = 1.0;
#endif
    // Segments this invocation may trace: its photons × the depth each may reach.
    let steps = ((params.photons - 1u - index) / lanes + 1u) * params.max_photon_depth;
    for (var step = 0u; step < steps; step += 1u) {
        var ended = true;
        let hit = trace_ray(ray.origin, ray.direction, t_min, 1.0e30, ray.ignore);
        // A photon that left carrying nothing (behind its emitter) ends.
        var reached = hit.triangle != NO_HIT && any(ray.flux > vec3<f32>(0.0));
#ifdef ABSORPTION
        // Absorbed by roulette on the channel that keeps most, the others weighted to match,
        // so that a photon keeps its power and coloured glass does not trace faint ones long.
        let transmittance = exp(-medium * hit.t);
        let survive = max(transmittance.x, max(transmittance.y, transmittance.z));
        reached = reached && random(&rng) < survive;
        ray.flux *= transmittance / max(survive, 1e-30);
#endif
        if reached {
            let t = triangle_at(hit.triangle);
            let x = ray.origin + ray.direction * hit.t;
            let geometric = face_normal(t);
            let front = dot(geometric, ray.direction) < 0.0;
            let m = as_seen_from(material_at(hit.triangle, hit.uv, 0.0), front);
            // Shading normal (normal map applied) and the kernel's (stored), on the side the
            // photon arrives from.
            var interpolated = interpolated_normal(t, hit.uv);
            var n = normal_at(hit.triangle, hit.uv, interpolated);
            if !front {
                n = -n;
                interpolated = -interpolated;
            }
            let direct_only = params.direct_photons != 0u;
            var indirect = depth > 0u;
#ifdef PANES
            walk = pane_segment(walk, hit.t);
            let far = ray.source.w > 0.0;
            if indirect && panes && pane_direct(walk) && stores_photons(m) && (far || !pane_too_thick(walk)) {
                // Shadow rays bring its light where they find the way back to its source: a
                // sun's or the sky's always (the way is the photon's own, reversed).
                indirect = false;
                if !far {
                    let to = ray.source.xyz - x;
                    let lit = through_panes(x, normalize(to), length(to), hit.triangle, t_min, true).rgb;
                    indirect = all(lit <= vec3<f32>(0.0));
                }
            }
#endif
            if (indirect || direct_only) && stores_photons(m) {
                store(x, ray, interpolated, caustic && depth > 0u);
            }
            caustic = caustic && !stores_photons(m);
            var s = scatter_photon(m, n, interpolated, -ray.direction, front, &rng);
#ifdef NORMAL_MAP
            let bent = bent_scatter(n, interpolated, -ray.direction, s.direction);
            let allowed = min(bent_gain * bent, max(bent_gain, BENT_GAIN_MAX));
            s.weight *= allowed / bent_gain;
            bent_gain = max(allowed, 1e-30);
#endif
            if !direct_only && any(s.weight > vec3<f32>(0.0)) && depth + 1u < params.max_photon_depth {
#ifdef ABSORPTION
                medium = medium_after(medium, m, front, dot(s.direction, n) < 0.0);
#endif
#ifdef PANES
                walk = pane_scatter(walk, m, n, front, dot(s.direction, n) < 0.0);
#endif
                ray.origin = x;
                ray.direction = s.direction;
                ray.flux *= s.weight;
                ray.ignore = hit.triangle;
                depth += 1u;
                ended = false;
            }
        }
        if ended {
            index += lanes;
            if index >= params.photons {
                return;
            }
            rng = photon_seed(index);
            ray = emit(&rng);
            depth = 0u;
            caustic = true;
#ifdef ABSORPTION
            medium = vec3<f32>(0.0);
#endif
#ifdef NORMAL_MAP
            bent_gain = 1.0;
#endif
#ifdef PANES
            walk = pane_walk();
#endif
        }
    }
}
