// Panes: clear glass that light crosses straight through, in at one face and out at a parallel
// one (a window, a slab). Light that reaches a surface that way is direct light dimmed by
// Fresnel: shadow rays follow it through (`through_panes` in shadows/panes.wgsl) and photons
// leave it to them (`PaneWalk`), so a room lit through its windows is as sharp and as quiet as
// one with open windows. Light through any other glass stays the photons' (caustics).
#define_import_path bevy_rppm::panes

#import bevy_rppm::common::{Material, IterationParams, DELTA_ROUGHNESS, MATERIAL_ALPHA_MASK, MATERIAL_ALPHA_HASHED}

// Two faces count as parallel when their normals are within ~0.8° (light leaves within
// ~0.4° of the way it came for glass of ior 1.5).
const PANE_COS: f32 = 0.9999;

// From a light at a finite distance (not a sun or the sky, whose parallel light a slab passes
// unchanged), the glass crossed may be at most this share of the light's distance beyond it:
// through a slab of thickness t a light d away looks nearer and shifted by about t(1 − 1/η),
// which a shadow ray that goes on straight to it does not see, and past a pane's edge the
// shadow ray and the photon then take different ways (a lamp 10 cm inside a glass case of
// 4 mm walls cast lines where the gather's disc blurred the photons' share).
const PANE_SHARE: f32 = 0.01;

// At most this many panes between a surface and a light (double glazing is two).
const MAX_PANES: u32 = 4u;

// Whether shadow rays look through panes and photons leave that light to them: not where Bevy
// gives the first hit's direct light (`indirect_only`) or photons give all of it.
fn panes_on(p: IterationParams) -> bool {
    return p.indirect_only == 0u && p.direct_photons == 0u;
}

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
    // Its length so far, the part of it in panes, and how far it came before the first.
    travelled: f32,
    inside: f32,
    before: f32,
    // The panes it crossed.
    crossed: u32,
}

fn pane_walk() -> PaneWalk {
    return PaneWalk(true, vec4<f32>(0.0), 0.0, 0.0, 0.0, 0u);
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
        v.before = select(v.before, v.travelled, v.inside <= 0.0);
    } else if v.entry.w > 0.0 && !front && m.ior == v.entry.w && dot(n, v.entry.xyz) >= PANE_COS {
        v.entry = vec4<f32>(0.0);
        v.crossed += 1u;
        // Shadow rays look through no more (`through_panes`).
        v.direct = v.crossed <= MAX_PANES;
    } else {
        v.direct = false;
    }
    return v;
}

// Whether a photon that arrives at a surface on walk w crossed panes only; shadow rays bring
// its light where they find the way to where it left its light (`through_panes`).
fn pane_direct(w: PaneWalk) -> bool {
    return w.direct && w.entry.w <= 0.0;
}

// Whether shadow rays cannot bring a photon's light on walk w from a light at a finite
// distance (PANE_SHARE, with room to spare for the shadow ray's slightly other way), so that
// it need not look.
fn pane_too_thick(w: PaneWalk) -> bool {
    return w.inside > 2.0 * PANE_SHARE * w.before;
}
