// Multiple importance sampling of emitters at the rough vertices camera paths go on from
// (glossy metals, rough glass): the emitters are sampled there as lights too, and each way
// of finding an emitter is weighted by the power heuristic, so a small bright panel seen in
// a rough reflection or through frosted glass is not found by chance alone (fireflies).
// `path_f` and `path_pdf` mirror `scatter_photon` as camera paths use it (`lobe_bounce`) on
// the materials `mis_vertex` admits, so that both estimators add up to the same integral.
#define_import_path bevy_rppm::mis

#import bevy_rppm::common::{Material, PI, DELTA_ROUGHNESS, luminance}
#ifdef LIGHT_GUIDE
#import bevy_rppm::common::{LIGHT_DIRECTIONAL, LIGHT_SPOT, basis_around}
#import bevy_rppm::sampling::random
#import bevy_rppm::scene::lights
#import bevy_rppm::bsdf::bsdf_eval
#endif
#import bevy_rppm::bsdf::{cosine_lobes_energy, translucency, layered}
#import bevy_rppm::microfacet::{specular_f0, specular_at, specular_average, ggx_d, visible_normal_pdf}
#ifdef ROUGH_REFRACTION
#import bevy_rppm::bsdf::rough_glass_share
#import bevy_rppm::microfacet::{smith_g1, fresnel_dielectric}
#endif

// Whether a camera path going on from a surface of m samples the emitters there: its lobes
// are rough, and have no layer `path_f` leaves out (a clearcoat, diffuse transmission).
fn mis_vertex(m: Material) -> bool {
    var plain = m.perceptual_roughness >= DELTA_ROUGHNESS;
#ifdef CLEARCOAT
    plain = plain && m.clearcoat.x <= 0.0;
#endif
#ifdef DIFFUSE_TRANSMISSION
    plain = plain && translucency(m) <= 0.0;
#endif
    return plain;
}

// The power heuristic's weight of the strategy that drew a direction with density `chosen`
// against the other's `other`.
fn power_heuristic(chosen: f32, other: f32) -> f32 {
    if !(chosen > 0.0) {
        return 0.0;
    }
    // As a ratio of capped densities: a huge one (a grazing emitter) gives 0 or 1, not inf/inf.
    let r = min(other, 1e18) / min(chosen, 1e18);
    return 1.0 / (1.0 + r * r);
}

// Rough glass's share of the surface (0 where the scene has none).
fn rough_share(m: Material) -> f32 {
#ifdef ROUGH_REFRACTION
    return rough_glass_share(m);
#else
    return 0.0;
#endif
}

// f(wo, wi) of a `mis_vertex` surface seen from wo (on n's side, `front` whether that is the
// outside), from `layers` = bsdf_eval of its `layered` part: rough glass reflects with the
// Fresnel of the side wo is on and refracts, with the camera path's η² of radiance crossing
// (Walter et al. 2007).
fn path_f(layers: vec3<f32>, m: Material, n: vec3<f32>, wo: vec3<f32>, wi: vec3<f32>, front: bool) -> vec3<f32> {
    let rough = rough_share(m);
    var f = layers * (1.0 - rough);
#ifdef ROUGH_REFRACTION
    if rough > 0.0 {
        f += vec3<f32>(rough * rough_glass_f(m, n, wo, wi, front));
    }
#endif
    return f;
}

// The density (solid angle) with which `scatter_photon` draws wi for a camera path at a
// `mis_vertex` surface seen from wo.
fn path_pdf(m: Material, n: vec3<f32>, wo: vec3<f32>, wi: vec3<f32>, front: bool) -> f32 {
    let rough = rough_share(m);
    var p = 0.0;
#ifdef ROUGH_REFRACTION
    p = rough * rough_glass_pdf(m, n, wo, wi, front);
#endif
    let mu_o = dot(n, wo);
    let mu_i = dot(n, wi);
    if mu_i <= 0.0 || mu_o <= 0.0 {
        return p;
    }
    let l = layered(m);
    let f0 = specular_f0(l);
    let o = specular_at(l, f0, mu_o);
    var left = 1.0;
#ifdef GLOSSY
    let p_glossy = min(luminance(o.single), left);
    left -= p_glossy;
    let h = normalize(wo + wi);
    let a = l.perceptual_roughness * l.perceptual_roughness;
    p += (1.0 - rough) * p_glossy * visible_normal_pdf(n, wo, h, a) / (4.0 * max(dot(wo, h), 1e-6));
#endif
    let p_cosine = min(luminance(cosine_lobes_energy(l, f0, o, specular_average(l))), left);
    return p + (1.0 - rough) * p_cosine * mu_i / PI;
}

#ifdef ROUGH_REFRACTION
// How rough glass turns wo into wi (`front`: wo outside): η = n on wo's side / n on wi's,
// the cosines with n, the microfacet normal that does it (reflected when both lie on n's
// side, else refracted; facing n), its cosines with wo and wi, and the refraction Jacobian's
// η (wo·h) + wi·h. `valid` where that microfacet exists and faces wo.
struct GlassTurn {
    eta: f32,
    cos_o: f32,
    cos_i: f32,
    h: vec3<f32>,
    oh: f32,
    ih: f32,
    denominator: f32,
    valid: bool,
}

fn glass_turn(m: Material, n: vec3<f32>, wo: vec3<f32>, wi: vec3<f32>, front: bool) -> GlassTurn {
    var t: GlassTurn;
    t.eta = select(m.ior, 1.0 / m.ior, front);
    t.cos_o = dot(n, wo);
    t.cos_i = dot(n, wi);
    var h = select(-(t.eta * wo + wi), wo + wi, t.cos_i > 0.0);
    let length2 = dot(h, h);
    h = select(vec3<f32>(0.0), h * inverseSqrt(max(length2, 1e-30)), length2 > 1e-12);
    t.h = select(h, -h, dot(h, n) < 0.0);
    t.oh = dot(wo, t.h);
    t.ih = dot(wi, t.h);
    t.denominator = t.eta * t.oh + t.ih;
    t.valid = t.cos_o > 0.0 && t.oh > 0.0 && (t.cos_i > 0.0) == (t.ih > 0.0) && abs(t.denominator) >= 1e-4;
    return t;
}

// Rough glass's f(wo, wi) for a camera path at it (`scatter_rough_glass`'s lobe).
fn rough_glass_f(m: Material, n: vec3<f32>, wo: vec3<f32>, wi: vec3<f32>, front: bool) -> f32 {
    let t = glass_turn(m, n, wo, wi, front);
    if !t.valid || abs(t.cos_i) < 1e-6 {
        return 0.0;
    }
    let a = m.perceptual_roughness * m.perceptual_roughness;
    let g = smith_g1(t.cos_o, a) * smith_g1(abs(t.cos_i), a);
    let d = ggx_d(dot(n, t.h), a);
    let fresnel = fresnel_dielectric(t.oh, t.eta);
    if t.cos_i > 0.0 {
        return fresnel * d * g / (4.0 * t.cos_o * t.cos_i);
    }
    let j = t.denominator * t.denominator;
    return t.eta * t.eta * t.oh * abs(t.ih) * (1.0 - fresnel) * g * d / (t.cos_o * abs(t.cos_i) * j);
}

// The density with which `scatter_rough_glass` draws wi from wo.
fn rough_glass_pdf(m: Material, n: vec3<f32>, wo: vec3<f32>, wi: vec3<f32>, front: bool) -> f32 {
    let t = glass_turn(m, n, wo, wi, front);
    if !t.valid {
        return 0.0;
    }
    let a = m.perceptual_roughness * m.perceptual_roughness;
    let fresnel = fresnel_dielectric(t.oh, t.eta);
    let normals = visible_normal_pdf(n, wo, t.h, a);
    if t.cos_i > 0.0 {
        return fresnel * normals / (4.0 * t.oh);
    }
    return (1.0 - fresnel) * normals * abs(t.ih) / (t.denominator * t.denominator);
}
#endif

// The density with which a camera path at a `mis_vertex` surface draws wi: the BSDF's, or
// with LIGHT_GUIDE its mixture with the guide's.
fn drawn_pdf(blocked: u32, m: Material, x: vec3<f32>, n: vec3<f32>, wo: vec3<f32>, wi: vec3<f32>, front: bool) -> f32 {
    let p = path_pdf(m, n, wo, wi, front);
#ifdef LIGHT_GUIDE
    let share = guide_share(blocked, m, x, n, front);
    if share > 0.0 {
        return (1.0 - share) * p + share * guide_pdf(blocked, m, x, n, wi);
    }
#endif
    return p;
}

#ifdef LIGHT_GUIDE
// Camera paths toward punctual lights behind rough glass (a lamp behind a frosted pane, seen
// in a brushed plate): such a light is found only by the shadow ray at the glass's far side,
// whose lobe the direction drawn at the near side must hit by chance (fireflies). So at rough
// vertices where a shadow ray found a light blocked, the direction is also drawn around where
// the light lies, in a lobe as wide as the far side's (that side taken of the same material);
// one-sample MIS with the BSDF (balance heuristic) keeps the mean.

// The share of directions the guide draws where it has a light.
const GUIDE_SHARE: f32 = 0.5;

// The guide's lobe toward one light: its axis, cos^k exponent k (k = 1/σ²), and the light's
// irradiance at x, by which lights are drawn (0: not guided to).
struct GuideLobe {
    axis: vec3<f32>,
    exponent: f32,
    weight: f32,
}

fn guide_lobe(light_index: u32, m: Material, x: vec3<f32>, n: vec3<f32>) -> GuideLobe {
    let l = lights[light_index];
    var dir = -l.direction.xyz;
    var irradiance = luminance(l.radiance.rgb);
    if l.kind != LIGHT_DIRECTIONAL {
        let to_light = l.position.xyz - x;
        let d2 = max(dot(to_light, to_light), 1e-12);
        dir = to_light * inverseSqrt(d2);
        irradiance /= d2;
        if l.kind == LIGHT_SPOT && dot(-dir, l.direction.xyz) < l.cos_outer {
            irradiance = 0.0;
        }
    }
    let a = max(m.perceptual_roughness * m.perceptual_roughness, 1e-3);
    // Where the light lies and the far side's lobe width (radians), in the space of the path's
    // next direction.
    var aim = dir;
    var sigma = 2.0 * a;
    if dot(dir, n) < 0.0 {
        // A light beyond glass, its far face taken parallel to this one (a slab): the path
        // leaves toward the light along the light's direction refracted in. A microfacet
        // normal turned by δ turns a refracted direction by δ·(η − 1)/η.
        aim = refract(dir, n, 1.0 / m.ior);
        if rough_share(m) <= 0.0 || all(aim == vec3<f32>(0.0)) {
            return GuideLobe(dir, 0.0, 0.0);
        }
        sigma = a * abs(m.ior - 1.0) / max(m.ior, 1.0);
    }
    // A sphere light wider than the lobe needs no aim: paths drawn by the BSDF meet it.
    if l.kind != LIGHT_DIRECTIONAL && l.position.w > sigma * length(l.position.xyz - x) {
        return GuideLobe(dir, 0.0, 0.0);
    }
    return GuideLobe(aim, min(1.0 / (sigma * sigma), 1e6), irradiance);
}

fn guide_total(blocked: u32, m: Material, x: vec3<f32>, n: vec3<f32>) -> f32 {
    var total = 0.0;
    for (var bits = blocked; bits != 0u; bits &= bits - 1u) {
        let i = firstTrailingBit(bits);
        total += guide_lobe(i, m, x, n).weight;
    }
    return total;
}

fn guide_share(blocked: u32, m: Material, x: vec3<f32>, n: vec3<f32>, front: bool) -> f32 {
    // Outside glass only: guided inside it (toward a far face taken parallel to the one the
    // path meets) the pane's edges and a hollow lantern's walls turned to fireflies.
    return select(0.0, GUIDE_SHARE, front && guide_total(blocked, m, x, n) > 0.0);
}

// cos^k around the axis, normalised over the hemisphere around it.
fn lobe_pdf(lobe: GuideLobe, wi: vec3<f32>) -> f32 {
    let c = dot(wi, lobe.axis);
    return select(0.0, (lobe.exponent + 1.0) / (2.0 * PI) * pow(max(c, 0.0), lobe.exponent), c > 0.0);
}

// The guide's density of wi: its lobes' mixture by weight.
fn guide_pdf(blocked: u32, m: Material, x: vec3<f32>, n: vec3<f32>, wi: vec3<f32>) -> f32 {
    var total = 0.0;
    var p = 0.0;
    for (var bits = blocked; bits != 0u; bits &= bits - 1u) {
        let i = firstTrailingBit(bits);
        let lobe = guide_lobe(i, m, x, n);
        if lobe.weight > 0.0 {
            total += lobe.weight;
            p += lobe.weight * lobe_pdf(lobe, wi);
        }
    }
    return select(0.0, p / total, total > 0.0);
}

// One direction from the guide: a light drawn by weight, then its lobe.
fn guide_sample(blocked: u32, m: Material, x: vec3<f32>, n: vec3<f32>, rng: ptr<function, u32>) -> vec3<f32> {
    var pick = random(rng) * guide_total(blocked, m, x, n);
    var chosen = GuideLobe(n, 0.0, 0.0);
    for (var bits = blocked; bits != 0u; bits &= bits - 1u) {
        let i = firstTrailingBit(bits);
        let lobe = guide_lobe(i, m, x, n);
        if lobe.weight > 0.0 {
            chosen = lobe;
            pick -= lobe.weight;
            if pick < 0.0 {
                break;
            }
        }
    }
    let cos_t = exp(log(max(random(rng), 1e-30)) / (chosen.exponent + 1.0));
    let sin_t = sqrt(max(1.0 - cos_t * cos_t, 0.0));
    let phi = 2.0 * PI * random(rng);
    return basis_around(chosen.axis) * vec3<f32>(sin_t * cos(phi), sin_t * sin(phi), cos_t);
}

// The camera path's next direction at a `mis_vertex` surface where the guide has a light:
// drawn by the guide or the BSDF (`bsdf_drawn`, what `lobe_bounce` drew), weighted f·|cos|
// over the mixture's density, returned in w (0: absorbed).
struct Guided {
    direction: vec3<f32>,
    weight: vec3<f32>,
    density: f32,
}

fn guided_bounce(blocked: u32, m: Material, x: vec3<f32>, n: vec3<f32>, wo: vec3<f32>, front: bool, share: f32, bsdf_drawn: vec3<f32>, bsdf_weight: vec3<f32>, use_guide: bool, rng: ptr<function, u32>) -> Guided {
    var wi = bsdf_drawn;
    if use_guide {
        wi = guide_sample(blocked, m, x, n, rng);
    } else if all(bsdf_weight <= vec3<f32>(0.0)) {
        return Guided(wi, vec3<f32>(0.0), 0.0);
    }
    let p = (1.0 - share) * path_pdf(m, n, wo, wi, front) + share * guide_pdf(blocked, m, x, n, wi);
    if !(p > 0.0) {
        return Guided(wi, vec3<f32>(0.0), 0.0);
    }
    let f = path_f(bsdf_eval(layered(m), n, wo, wi), m, n, wo, wi, front);
    return Guided(wi, f * abs(dot(n, wi)) / p, p);
}
#endif
