// Panes: clear glass that light crosses straight through, in at one face and out at a parallel
// one (a window, a slab). Light that reaches a surface that way is direct light dimmed by
// Fresnel: shadow rays follow it through (`through_panes` in shadows/lighting.wgsl) and photons
// leave it to them (`PaneWalk`), so a room lit through its windows is as sharp and as quiet as
// one with open windows. Light through any other glass stays the photons' (caustics).
#define_import_path bevy_rppm::panes

#import bevy_rppm::common::{Material, DELTA_ROUGHNESS, MATERIAL_ALPHA_MASK, MATERIAL_ALPHA_HASHED}

// Two faces count as parallel when their normals are within ~0.8° (light leaves within
// ~0.4° of the way it came for glass of ior 1.5).
const PANE_COS: f32 = 0.9999;

// From a point light, a sphere or an emitter (not a sun or the sky, whose parallel light a
// slab passes unchanged), at most this share of a path's length may lie inside panes: through
// a slab of thickness t a light d away looks nearer by t(1 − 1/η), which a shadow ray that goes
// on straight to it does not see; at 1 % the light is off by under 1 %.
const PANE_SHARE: f32 = 0.01;

// At most this many panes between a surface and a light (double glazing is two).
const MAX_PANES: u32 = 4u;

// Clear, smooth glass and nothing else: no colour of its own, no coat, no cut-outs.
fn is_pane(m: Material) -> bool {
    return m.perceptual_roughness < DELTA_ROUGHNESS && m.specular_transmission >= 1.0 && m.metallic <= 0.0
        && m.clearcoat.x <= 0.0 && m.diffuse_transmission <= 0.0
        && (m.flags & (MATERIAL_ALPHA_MASK | MATERIAL_ALPHA_HASHED)) == 0u;
}

// A photon's way through panes since it left its light.
struct PaneWalk {
    // Still direct light: it has only crossed panes straight through.
    direct: bool,
    // Inside a pane: the entry face's normal (on the side the photon came from) and ior;
    // w = 0 outside.
    entry: vec4<f32>,
    // Its length so far, and the part of it inside panes.
    travelled: f32,
    inside: f32,
}

fn pane_walk() -> PaneWalk {
    return PaneWalk(true, vec4<f32>(0.0), 0.0, 0.0);
}

// The walk after a segment of length t.
fn pane_segment(w: PaneWalk, t: f32) -> PaneWalk {
    var v = w;
    v.travelled += t;
    v.inside += select(0.0, t, w.entry.w > 0.0);
    return v;
}

// The walk after the photon leaves a surface of material m (n on the side it arrived from,
// `front` whether that is the front face), `crossed` through it.
fn pane_scatter(w: PaneWalk, m: Material, n: vec3<f32>, front: bool, crossed: bool) -> PaneWalk {
    var v = w;
    if !v.direct {
        return v;
    }
    if !crossed || !is_pane(m) {
        v.direct = false;
    } else if v.entry.w <= 0.0 && front {
        v.entry = vec4<f32>(n, m.ior);
    } else if v.entry.w > 0.0 && !front && m.ior == v.entry.w && dot(n, v.entry.xyz) >= PANE_COS {
        v.entry = vec4<f32>(0.0);
    } else {
        v.direct = false;
    }
    return v;
}

// Whether a photon that arrives at a surface on walk w is direct light that shadow rays
// bring (`finite`: it left a light at a finite distance).
fn pane_direct(w: PaneWalk, finite: bool) -> bool {
    return w.direct && w.entry.w <= 0.0 && (!finite || w.inside <= PANE_SHARE * w.travelled);
}
