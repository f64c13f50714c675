// Bevy StandardMaterial as a BSDF: Lambert diffuse, GGX specular (F0 = 0.16·reflectance² for
// dielectrics, base colour for metals) with multiple-scattering compensation, and delta lobes
// below DELTA_ROUGHNESS. It keeps energy: a white surface reflects all light it receives
// (the furnace test, tests/gpu/bsdf.rs). The GGX lobe itself is in microfacet.wgsl.
#define_import_path bevy_rppm::bsdf

#import bevy_rppm::common::{Material, Outgoing, PI, DELTA_ROUGHNESS, luminance, cosine_direction}
#import bevy_rppm::sampling::random
#import bevy_rppm::microfacet::{specular_f0, specular_f90, fresnel_schlick, ggx_d, smith_visibility, albedo_ab, specular_at}
#import bevy_rppm::microfacet::{specular_average, has_glossy_lobe, smith_g1, ggx_normal, sample_ggx, fresnel_dielectric, Specular}

// The share of a surface that is glass (Bevy's specular transmission of a dielectric).
fn glass_share(m: Material) -> f32 {
    return m.specular_transmission * (1.0 - m.metallic);
}

// Bevy's diffuse colour: (1 − metallic)(1 − transmission) × base colour.
fn diffuse_color(m: Material) -> vec3<f32> {
    return m.base_color.rgb * ((1.0 - m.metallic) * (1.0 - m.specular_transmission));
}

// π f of the lobes without a direction of their own: the diffuse lobe, shaped by what the
// dielectric part's specular layer leaves on the way in and out (reciprocal, after Kelemen
// and Szirmay-Kalos), plus the multiple-scattering lobe. The base colour is the albedo a
// surface shows: averaged over directions, diffuse and specular together reflect exactly the
// diffuse colour (as the Lambertian references do, shared/docs/CONVENTIONS.md), and a white
// surface reflects all light at every angle. Bevy adds the specular layer on top of the base
// colour instead: a few percent brighter for direct light, but bounced many times (as photons
// are) it compounds. Metallic m mixes the dielectric and the metal linearly, as glTF defines
// it: the diffuse lobe is (1 − m) of the dielectric's (once a half-metal's whole specular
// energy came out of its diffuse lobe, and a metallic texture's stripe edges read dark).
fn cosine_lobes(m: Material, f0: vec3<f32>, o: Specular, i: Specular, avg: vec2<f32>) -> vec3<f32> {
    let diffuse = diffuse_albedo(m, avg) * ((1.0 - o.dielectric) * (1.0 - i.dielectric) / (1.0 - avg.x));
    return diffuse + f0 * (o.lost * i.lost / avg.y);
}

// The share of the surface that sends diffuse light through to the other side: Bevy's
// diffuse transmission of the dielectric, non-glass part, where the scene has any
// (`DIFFUSE_TRANSMISSION`). It is a Lambertian lobe of the base colour through, beside the
// other layers at 1 − share: the surface then reflects (1 − t) and transmits t of its base
// colour on average, as Bevy's split of the diffuse colour does, and keeps energy (Bevy's
// specular layer on top of both does not).
fn translucency(m: Material) -> f32 {
#ifdef DIFFUSE_TRANSMISSION
    return m.diffuse_transmission * (1.0 - m.metallic) * (1.0 - m.specular_transmission);
#else
    return 0.0;
#endif
}

// The diffuse lobe's albedo at normal shaping, from `specular_average`.
fn diffuse_albedo(m: Material, avg: vec2<f32>) -> vec3<f32> {
    let dielectric = m.base_color.rgb * (1.0 - m.specular_transmission);
    return max(dielectric - avg.x, vec3<f32>(0.0)) * ((1.0 - m.metallic) / (1.0 - avg.x));
}

// How much more of light along w a normal map's bent normal n receives than the surface's own
// (`plane`): |w·n| / |w·plane|, its denominator at least 0.05 so that grazing light is not
// boosted past 20×. Photons' density is irradiance on the surface (the gathers' bend, and a
// scattered photon's arrival in photons/trace.wgsl).
fn bent_cosine(n: vec3<f32>, plane: vec3<f32>, w: vec3<f32>) -> f32 {
    return abs(dot(n, w)) / max(abs(dot(plane, w)), 0.05);
}

// What the cosine lobes reflect of light from i (the photons' choice of them).
fn cosine_lobes_energy(m: Material, f0: vec3<f32>, i: Specular, avg: vec2<f32>) -> vec3<f32> {
    return diffuse_albedo(m, avg) * (1.0 - i.dielectric) + f0 * i.lost;
}

// f(wo, wi), without the cosine. wo and wi point away from the surface, on n's side (light
// through rough glass is carried by sampled paths, not evaluated).
fn bsdf_eval(m: Material, n: vec3<f32>, wo: vec3<f32>, wi: vec3<f32>) -> vec3<f32> {
    return bsdf_toward(m, bsdf_from(m, n, wo), n, wo, wi);
}

// The material whose layers reflect: rough glass's reflecting (opaque) part, or m.
fn layered(m: Material) -> Material {
#ifdef ROUGH_REFRACTION
    if rough_glass_share(m) > 0.0 {
        return opaque_part(m);
    }
#endif
    return m;
}

// What f(wo, ·) needs of the material and wo alone (`Outgoing`, in common.wgsl): found once
// for the many directions a gather weighs (`bsdf_toward`).
fn bsdf_from(m: Material, n: vec3<f32>, wo: vec3<f32>) -> Outgoing {
    let l = layered(m);
    let f0 = specular_f0(l);
    let n_dot_v = dot(n, wo);
    let o = specular_at(l, f0, n_dot_v);
    var coat = 1.0;
#ifdef CLEARCOAT
    coat = 1.0 - coat_albedo(m, n_dot_v);
#endif
    return Outgoing(f0, n_dot_v, o.single, o.lost, o.dielectric, specular_average(l), coat);
}

// f(wo, wi) from `out = bsdf_from(m, n, wo)`.
fn bsdf_toward(m: Material, out: Outgoing, n: vec3<f32>, wo: vec3<f32>, wi: vec3<f32>) -> vec3<f32> {
    var f = bsdf_gathered(m, out, n, wo, wi);
#ifdef GLOSSY_TRACED
    if glossy_traced(m) {
        f += glossy_lobe(m, out, n, wo, wi);
    }
#endif
#ifdef CLEARCOAT
    if coat_traced(m) {
        f += vec3<f32>(coat_lobe(m, n, wo, wi));
    }
#endif
    return f;
}

// The part of f(wo, wi) a photon gather at the camera's first hit estimates: all of it but a
// clearcoat or a glossy lobe smooth enough that the camera path follows it instead
// (`coat_traced`, `glossy_traced`).
fn bsdf_gathered(m: Material, out: Outgoing, n: vec3<f32>, wo: vec3<f32>, wi: vec3<f32>) -> vec3<f32> {
#ifdef GLOSSY_TRACED
    // Such a surface has no coat, glass or diffuse transmission: its layers alone.
    if glossy_traced(m) {
        let n_dot_l = dot(n, wi);
        if n_dot_l <= 0.0 || out.n_dot_v <= 0.0 {
            return vec3<f32>(0.0);
        }
        return diffuse_layers(m, out, n_dot_l);
    }
#endif
    var f = under_coat(m, out, n, wo, wi);
#ifdef CLEARCOAT
    f *= coat_through(m, out, n, wi);
    if !coat_traced(m) {
        f += vec3<f32>(coat_lobe(m, n, wo, wi));
    }
#endif
    return f;
}

// f(wo, wi) of the layers under a clearcoat.
fn under_coat(m: Material, out: Outgoing, n: vec3<f32>, wo: vec3<f32>, wi: vec3<f32>) -> vec3<f32> {
#ifdef DIFFUSE_TRANSMISSION
    let through = translucency(m);
    if through > 0.0 {
        if dot(n, wi) < 0.0 {
            return select(vec3<f32>(0.0), m.base_color.rgb * (through / PI), out.n_dot_v > 0.0);
        }
        return opaque_layers(m, out, n, wo, wi) * (1.0 - through);
    }
#endif
    return opaque_layers(m, out, n, wo, wi);
}

// `under_coat` but for diffuse transmission.
fn opaque_layers(m: Material, out: Outgoing, n: vec3<f32>, wo: vec3<f32>, wi: vec3<f32>) -> vec3<f32> {
#ifdef ROUGH_REFRACTION
    let glass = rough_glass_share(m);
    if glass > 0.0 {
        return glass * rough_glass_reflection(m, n, wo, wi) + (1.0 - glass) * layers_toward(layered(m), out, n, wo, wi);
    }
#endif
    return layers_toward(m, out, n, wo, wi);
}

// The diffuse and specular layers of f(wo, wi).
fn layers_toward(m: Material, out: Outgoing, n: vec3<f32>, wo: vec3<f32>, wi: vec3<f32>) -> vec3<f32> {
    let n_dot_l = dot(n, wi);
    if n_dot_l <= 0.0 || out.n_dot_v <= 0.0 {
        return vec3<f32>(0.0);
    }
    return diffuse_layers(m, out, n_dot_l) + glossy_lobe(m, out, n, wo, wi);
}

// The layers of f(wo, wi) without a direction of their own (`cosine_lobes`), for n·wi > 0.
fn diffuse_layers(m: Material, out: Outgoing, n_dot_l: f32) -> vec3<f32> {
    let i = specular_at(m, out.fresnel, n_dot_l);
    let o = Specular(out.single, out.lost, out.dielectric);
    return cosine_lobes(m, out.fresnel, o, i, out.average) / PI;
}

// The GGX lobe of f(wo, wi) (0 below DELTA_ROUGHNESS, whose lobe is a delta).
fn glossy_lobe(m: Material, out: Outgoing, n: vec3<f32>, wo: vec3<f32>, wi: vec3<f32>) -> vec3<f32> {
    let n_dot_l = dot(n, wi);
    if !has_glossy_lobe(m) || n_dot_l <= 0.0 || out.n_dot_v <= 0.0 {
        return vec3<f32>(0.0);
    }
    let a = m.perceptual_roughness * m.perceptual_roughness;
    let h = normalize(wi + wo);
    let d = ggx_d(max(dot(n, h), 0.0), a);
    let v = smith_visibility(out.n_dot_v, n_dot_l, a);
    return d * v * fresnel_schlick(out.fresnel, specular_f90(out.fresnel), dot(wo, h));
}

#ifdef GLOSSY_TRACED
// Whether camera paths follow a surface's glossy lobe from the camera's first hit rather than
// gather it: a lobe smoother than photons are stored under (GLOSSY_STORE_ROUGHNESS), where
// each photon near its peak is a blotch of its light's colour, on a surface that stores them
// for its diffuse lobe (glossy plastic, a polished floor). Beside a coat, glass or diffuse
// transmission the lobe stays gathered.
fn glossy_traced(m: Material) -> bool {
    return has_glossy_lobe(m) && m.perceptual_roughness < GLOSSY_STORE_ROUGHNESS
        && any(diffuse_color(m) > vec3<f32>(0.0)) && glass_share(m) <= 0.0
        && translucency(m) <= 0.0 && m.clearcoat.x <= 0.0;
}

// Draws the glossy lobe alone from wo (`glossy_traced`): its direction and f cos / pdf.
fn scatter_glossy(m: Material, n: vec3<f32>, wo: vec3<f32>, rng: ptr<function, u32>) -> Scatter {
    let s = sample_ggx(m, n, wo, vec2<f32>(random(rng), random(rng)));
    if s.w <= 0.0 {
        return Scatter(s.xyz, vec3<f32>(0.0));
    }
    let f0 = specular_f0(m);
    let f = fresnel_schlick(f0, specular_f90(f0), dot(wo, normalize(wo + s.xyz)));
    return Scatter(s.xyz, f * s.w);
}
#endif

// Photons are stored at glossy surfaces at least this rough (density estimation needs a
// lobe wide enough to gather over: at 0.3 each photon near a lobe's peak was a blotch of
// its light's colour, suite/many_lights); smoother ones only scatter them.
const GLOSSY_STORE_ROUGHNESS: f32 = 0.5;

// Whether photons are stored at a surface (its light is gathered there by density
// estimation): a diffuse lobe, or a glossy one at least GLOSSY_STORE_ROUGHNESS rough. Camera
// paths go on through the others: mirrors, clear glass, smooth glossy metals.
fn stores_photons(m: Material) -> bool {
    // Not at rough glass: its light comes through it, which the gather's disc cannot see.
    let glossy_store = has_glossy_lobe(m) && m.perceptual_roughness >= GLOSSY_STORE_ROUGHNESS
        && any(specular_f0(m) > vec3<f32>(0.0)) && glass_share(m) <= 0.0;
    return any(diffuse_color(m) > vec3<f32>(0.0)) || glossy_store;
}

// A photon's next direction and the factor on its flux (zero when absorbed).
struct Scatter {
    direction: vec3<f32>,
    weight: vec3<f32>,
}

// Scatters a photon that arrived from wi (pointing away from the surface; n on its side,
// `front` whether that is the front face): the adjoint of bsdf_eval plus the delta lobes
// (mirror metals, Fresnel glass). A lobe is chosen with a probability near what it reflects
// from wi, else the photon is absorbed, so flux stays unbiased. Lobes no material of the scene
// has are compiled out (GLOSSY, MIRRORS, REFRACTION).
// The cosine lobes are drawn about `around`: n, or for photons the surface's own normal where
// a normal map bends n (photons/trace.wgsl: they leave by that normal's cosine).
fn scatter_photon(material: Material, n: vec3<f32>, around: vec3<f32>, wi: vec3<f32>, front: bool, rng: ptr<function, u32>) -> Scatter {
#ifdef CLEARCOAT
    // The coat reflects what it reflects of light from wi; the rest passes it both ways.
    let coat = coat_albedo(material, max(dot(n, wi), 0.0));
    if coat > 0.0 {
        if random(rng) < coat {
            let s = scatter_coat(material, n, wi, rng);
            return Scatter(s.direction, s.weight / coat);
        }
        var s = scatter_layers(material, n, around, wi, front, rng);
        let out = dot(n, s.direction);
        if out > 0.0 {
            s.weight *= 1.0 - coat_albedo(material, out);
        }
        return s;
    }
#endif
    return scatter_layers(material, n, around, wi, front, rng);
}

// `scatter_photon` under a clearcoat.
fn scatter_layers(material: Material, n: vec3<f32>, around: vec3<f32>, wi: vec3<f32>, front: bool, rng: ptr<function, u32>) -> Scatter {
    var m = material;
#ifdef DIFFUSE_TRANSMISSION
    // Through with the translucent share's probability, Lambertian about −n.
    if random(rng) < translucency(m) {
        return Scatter(-cosine_direction(n, vec2<f32>(random(rng), random(rng))), m.base_color.rgb);
    }
#endif
#ifdef ROUGH_REFRACTION
    // Rough glass's share of the surface is its own lobe; the rest, the layers without it.
    let rough = rough_glass_share(m);
    if rough > 0.0 {
        if random(rng) < rough {
            return scatter_rough_glass(m, n, wi, front, rng);
        }
        m = opaque_part(m);
    }
#endif
    let f0 = specular_f0(m);
    let mu_i = max(dot(n, wi), 0.0);
    let i = specular_at(m, f0, mu_i);
    var left = 1.0;
    var u = random(rng);
#ifdef GLOSSY
    let p_glossy = min(luminance(i.single), left);
    left -= p_glossy;
    if u < p_glossy {
        let s = sample_ggx(m, n, wi, vec2<f32>(random(rng), random(rng)));
        if s.w <= 0.0 {
            return Scatter(s.xyz, vec3<f32>(0.0));
        }
        let f = fresnel_schlick(f0, specular_f90(f0), dot(wi, normalize(wi + s.xyz)));
        return Scatter(s.xyz, f * (s.w / p_glossy));
    }
    u -= p_glossy;
#endif
    // Diffuse and multiple scattering, both cosine-sampled.
    let avg = specular_average(m);
    let p_cosine = min(luminance(cosine_lobes_energy(m, f0, i, avg)), left);
    left -= p_cosine;
    if u < p_cosine {
        let d = cosine_direction(around, vec2<f32>(random(rng), random(rng)));
        let o = specular_at(m, f0, dot(n, d));
        var weight = cosine_lobes(m, f0, o, i, avg) / p_cosine;
        if any(around != n) {
            // Drawn by the other normal's cosine: this one's over it, none below this one.
            weight *= max(dot(n, d), 0.0) / max(dot(around, d), 1e-6);
        }
        return Scatter(d, weight);
    }
    u -= p_cosine;
    let delta = m.perceptual_roughness < DELTA_ROUGHNESS;
#ifdef MIRRORS
    let mirror = select(vec3<f32>(0.0), m.base_color.rgb * m.metallic, delta);
    let p_mirror = min(luminance(mirror), left);
    left -= p_mirror;
    if u < p_mirror {
        return Scatter(reflect(-wi, n), mirror / p_mirror);
    }
    u -= p_mirror;
#endif
#ifdef REFRACTION
    let glass = select(0.0, glass_share(m), delta);
    let p_glass = min(glass, left);
    if u < p_glass {
        let eta = select(m.ior, 1.0 / m.ior, front);
        let refracted = refract(-wi, n, eta);
        let weight = vec3<f32>(glass / p_glass);
        if random(rng) < fresnel_dielectric(mu_i, eta) || all(refracted == vec3<f32>(0.0)) {
            return Scatter(reflect(-wi, n), weight);
        }
        return Scatter(refracted, weight);
    }
#endif
    return Scatter(wi, vec3<f32>(0.0));
}

#ifdef ROUGH_REFRACTION
// Transmission at roughness from DELTA_ROUGHNESS up: a rough dielectric interface (Walter et
// al. 2007, GGX of α = roughness², Smith G1·G1), single scattering as Mitsuba's
// `roughdielectric`, with Fresnel choosing reflection or refraction through each microfacet.

// The share of a surface that is rough glass (0 for smooth glass, a delta lobe).
fn rough_glass_share(m: Material) -> f32 {
    return select(glass_share(m), 0.0, m.perceptual_roughness < DELTA_ROUGHNESS);
}

// The material without its glass: the layers that share the surface with it.
fn opaque_part(m: Material) -> Material {
    var o = m;
    o.specular_transmission = 0.0;
    return o;
}

// What the rough interface reflects, f(wo, wi), both on n's side.
fn rough_glass_reflection(m: Material, n: vec3<f32>, wo: vec3<f32>, wi: vec3<f32>) -> vec3<f32> {
    let n_dot_l = dot(n, wi);
    let n_dot_v = dot(n, wo);
    if n_dot_l <= 0.0 || n_dot_v <= 0.0 {
        return vec3<f32>(0.0);
    }
    let a = m.perceptual_roughness * m.perceptual_roughness;
    let h = normalize(wi + wo);
    // Which medium n's side is cannot be told here; reflection from the outside is what
    // direct light meets (light inside glass reaches no light source without crossing it).
    let f = fresnel_dielectric(dot(wo, h), 1.0 / m.ior);
    let g = smith_g1(n_dot_v, a) * smith_g1(n_dot_l, a);
    return vec3<f32>(f * ggx_d(dot(n, h), a) * g / (4.0 * n_dot_v * n_dot_l));
}

// Samples the rough interface for light from wi (pointing away from the surface, on n's side;
// `front` whether that is outside): a microfacet normal as wi sees them, then reflection with Fresnel's
// probability, else refraction.
fn scatter_rough_glass(m: Material, n: vec3<f32>, wi: vec3<f32>, front: bool, rng: ptr<function, u32>) -> Scatter {
    let a = m.perceptual_roughness * m.perceptual_roughness;
    let h = ggx_normal(n, wi, a, vec2<f32>(random(rng), random(rng)));
    let i_dot_h = dot(wi, h);
    let i_dot_n = dot(wi, n);
    if i_dot_h <= 0.0 || i_dot_n <= 0.0 {
        return Scatter(wi, vec3<f32>(0.0));
    }
    let eta = select(m.ior, 1.0 / m.ior, front);
    var o = reflect(-wi, h);
    let refracted = refract(-wi, h, eta);
    let reflects = random(rng) < fresnel_dielectric(i_dot_h, eta) || all(refracted == vec3<f32>(0.0));
    if !reflects {
        o = refracted;
    }
    let o_dot_n = dot(o, n);
    // Reflected below the surface, or refracted back above it: the microfacet is shadowed.
    if (reflects && o_dot_n <= 0.0) || (!reflects && o_dot_n >= 0.0) {
        return Scatter(o, vec3<f32>(0.0));
    }
    // f·cos/pdf = G1(i) G1(o) / G1(i) for both, h drawn by its visible area from wi.
    return Scatter(o, vec3<f32>(smith_g1(abs(o_dot_n), a)));
}
#endif

#ifdef CLEARCOAT
// Clearcoat, Bevy's (after Filament): a GGX lobe of F0 0.04 and F90 1 (ior 1.5) over the
// other layers, of the material's strength and its own roughness, below DELTA_ROUGHNESS a
// mirror. Single scattering, as Bevy's. The layers under it see the light it does not
// reflect, on the way in and on the way out: (1 − E(μi))(1 − E(μo)), reciprocal, so photons
// and gathers agree (what it loses between the two is not given back).
const COAT_F0: f32 = 0.04;

// E(μ): what the coat reflects of light from cosine mu, its strength included.
fn coat_albedo(m: Material, mu: f32) -> f32 {
    let strength = m.clearcoat.x;
    if strength <= 0.0 {
        return 0.0;
    }
    if m.clearcoat.y < DELTA_ROUGHNESS {
        return strength * fresnel_schlick(vec3<f32>(COAT_F0), 1.0, mu).x;
    }
    let ab = albedo_ab(m.clearcoat.y, mu);
    return strength * min(COAT_F0 * ab.x + ab.y, 1.0);
}

// What passes the coat toward wo (`out.coat`) and from wi.
fn coat_through(m: Material, out: Outgoing, n: vec3<f32>, wi: vec3<f32>) -> f32 {
    return out.coat * (1.0 - coat_albedo(m, abs(dot(n, wi))));
}

// Whether camera paths follow the coat from the camera's first hit rather than gather it: a
// coat smoother than photons are stored under (GLOSSY_STORE_ROUGHNESS), mirror included.
fn coat_traced(m: Material) -> bool {
    return m.clearcoat.x > 0.0 && m.clearcoat.y < GLOSSY_STORE_ROUGHNESS;
}

// The coat's lobe f(wo, wi) (0 for a mirror coat).
fn coat_lobe(m: Material, n: vec3<f32>, wo: vec3<f32>, wi: vec3<f32>) -> f32 {
    let n_dot_l = dot(n, wi);
    let n_dot_v = dot(n, wo);
    if m.clearcoat.x <= 0.0 || m.clearcoat.y < DELTA_ROUGHNESS || n_dot_l <= 0.0 || n_dot_v <= 0.0 {
        return 0.0;
    }
    let a = m.clearcoat.y * m.clearcoat.y;
    let h = normalize(wi + wo);
    let f = fresnel_schlick(vec3<f32>(COAT_F0), 1.0, dot(wo, h)).x;
    return m.clearcoat.x * f * ggx_d(max(dot(n, h), 0.0), a) * smith_visibility(n_dot_v, n_dot_l, a);
}

// A direction off the coat for light from wi and the coat lobe's f·cos/pdf there (its
// strength and Fresnel included): the mirror direction for a mirror coat.
fn scatter_coat(m: Material, n: vec3<f32>, wi: vec3<f32>, rng: ptr<function, u32>) -> Scatter {
    if m.clearcoat.y < DELTA_ROUGHNESS {
        return Scatter(reflect(-wi, n), vec3<f32>(coat_albedo(m, max(dot(n, wi), 0.0))));
    }
    var lobe = m;
    lobe.perceptual_roughness = m.clearcoat.y;
    let s = sample_ggx(lobe, n, wi, vec2<f32>(random(rng), random(rng)));
    if s.w <= 0.0 {
        return Scatter(s.xyz, vec3<f32>(0.0));
    }
    let f = fresnel_schlick(vec3<f32>(COAT_F0), 1.0, dot(wi, normalize(wi + s.xyz))).x;
    return Scatter(s.xyz, vec3<f32>(m.clearcoat.x * f * s.w));
}
#endif
