// Shadow rays through panes (common/panes.wgsl): what reaches a surface point of a light's
// light through clear glass crossed in at one face and out at a parallel one. Shared by the
// shadow rays (shadows/lighting.wgsl) and by photons, which leave to them exactly the light
// they find (photons/trace.wgsl), so that the two never count it twice or not at all.
#define_import_path bevy_rppm::pane_rays

#import bevy_rppm::cubemap::{trace_ray, NO_HIT}
#import bevy_rppm::scene::{triangle_at, material_at, interpolated_normal, normal_at}
#import bevy_rppm::microfacet::fresnel_dielectric
#import bevy_rppm::panes::{is_pane, PANE_COS, PANE_SHARE, MAX_PANES}

// What reaches x from the light `distance` along `dir` (1e30: a direction) through panes: the
// way the light comes, refracted into each pane and out of its parallel face (along dir
// again), dimmed by Fresnel at both faces and by absorption inside; 0 where anything else is
// in the way, or anything at all unless `through`. From a light at a finite distance, the glass
// crossed may be no more than PANE_SHARE of the light's distance beyond it, and the light must
// not lie inside a pane. One ray walk in the code for every segment, in a pane or between
// panes. w: 1 where the light came through a pane.
fn through_panes(x: vec3<f32>, dir: vec3<f32>, distance: f32, origin_triangle: u32, t_min: f32, through: bool) -> vec4<f32> {
    let finite = distance < 1.0e30;
    var o = x;
    var d = dir;
    var ignore = origin_triangle;
    var kept = vec3<f32>(1.0);
    var inside = 0.0;
    // In a pane: its entry face's normal (outward) and ior; w = 0 between panes.
    var entry = vec4<f32>(0.0);
    for (var k = 0u; k <= 2u * MAX_PANES; k += 1u) {
        let in_pane = entry.w > 0.0;
        let between = select((distance - dot(o - x, dir)) * (1.0 - 1e-4), 1.0e30, !finite);
        let t_max = select(between, select(1.0e30, PANE_SHARE * distance - inside, finite), in_pane);
        let hit = trace_ray(o, d, t_min, t_max, ignore);
        if hit.triangle == NO_HIT {
            if in_pane {
                break;
            }
            return vec4<f32>(kept, f32(inside > 0.0));
        }
        // Between panes, in at a pane's front face; in one, out at its parallel face.
        let p = o + d * hit.t;
        let t = triangle_at(hit.triangle);
        let front = dot(cross(t.position_b - t.position_a, t.position_c - t.position_a), d) < 0.0;
        let m = material_at(hit.triangle, hit.uv, 0.0);
        if !through || front == in_pane || !is_pane(m) || k == 2u * MAX_PANES {
            break;
        }
        let n = normal_at(hit.triangle, hit.uv, interpolated_normal(t, hit.uv));
        if in_pane {
            if m.ior != entry.w || dot(-n, entry.xyz) < PANE_COS || dot(p - x, dir) >= distance {
                break;
            }
            kept *= 1.0 - fresnel_dielectric(dot(n, d), m.ior);
#ifdef ABSORPTION
            kept *= exp(-m.absorption.rgb * hit.t);
#endif
            inside += hit.t;
            // The glass so far against the light's distance beyond it (a lamp close behind a
            // pane, whose edges' shift would show, is left to photons).
            if finite && inside > PANE_SHARE * (distance - dot(p - x, dir)) {
                break;
            }
            entry = vec4<f32>(0.0);
            d = dir;
        } else {
            d = refract(dir, n, 1.0 / m.ior);
            if all(d == vec3<f32>(0.0)) {
                break;
            }
            kept *= 1.0 - fresnel_dielectric(dot(n, -dir), 1.0 / m.ior);
            entry = vec4<f32>(n, m.ior);
        }
        o = p;
        ignore = hit.triangle;
    }
    return vec4<f32>(0.0);
}
