//! A `StandardMaterial` reduced to what the light transport reads ([`GpuMaterial`]).

use bevy::prelude::*;

use super::{GpuMaterial, GpuTexture, MaterialFlags, NO_TEXTURE, ScatterPaths, luminance};
use crate::bsdf::{DELTA_ROUGHNESS, GLOSSY_STORE_ROUGHNESS, specular_energy_average};

/// Brightest emission kept (cd/m², ten times the sun's disc): the sums of a few such
/// emitters' photons and samples stay within f32, where 3·10³⁸ overflowed to infinity.
const MAX_EMISSIVE: f32 = 1e10;

bitflags::bitflags! {
    /// What the scene's materials look up per surface point (material_at, normal_at,
    /// opaque_at in shaders/scene/scene.wgsl). Every stage that reads materials compiles only
    /// the lookups some material makes: a lookup compiled in costs llvmpipe at every call,
    /// taken or not (the alpha test alone halved the speed of tracing in textured scenes).
    #[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
    pub struct Lookups: u8 {
        /// Per-triangle attributes (texture coordinates, vertex colours), alpha or unlit.
        const TEXTURED = 1 << 0;
        const BASE_COLOR_TEXTURE = 1 << 1;
        const METALLIC_ROUGHNESS_TEXTURE = 1 << 2;
        const EMISSIVE_TEXTURE = 1 << 3;
        const NORMAL_MAP = 1 << 4;
        /// Cut-outs or blended alpha: a ray goes on through a hole it hits.
        const ALPHA_TEST = 1 << 5;
        /// Some texture is read otherwise than repeating and bilinear (clamped or mirrored
        /// coordinates, nearest texels).
        const SAMPLERS = 1 << 6;
    }
}

impl Lookups {
    /// The lookups `materials` make, with their `textures`.
    pub fn of(materials: &[GpuMaterial], textures: &[GpuTexture]) -> Self {
        let mut lookups = Self::empty();
        lookups.set(Self::SAMPLERS, textures.iter().any(|t| t.sampler != 0));
        for m in materials {
            let flags = MaterialFlags::from_bits_truncate(m.flags);
            if !flags.contains(MaterialFlags::TEXTURED) {
                continue;
            }
            lookups |= Self::TEXTURED;
            let slots = [
                Self::BASE_COLOR_TEXTURE,
                Self::METALLIC_ROUGHNESS_TEXTURE,
                Self::EMISSIVE_TEXTURE,
                Self::NORMAL_MAP,
            ];
            for (texture, slot) in m.textures.iter().zip(slots) {
                if *texture != NO_TEXTURE {
                    lookups |= slot;
                }
            }
            if flags.intersects(MaterialFlags::ALPHA_MASK | MaterialFlags::ALPHA_HASHED) {
                lookups |= Self::ALPHA_TEST;
            }
        }
        lookups
    }

    /// The shader defs of these lookups.
    pub fn shader_defs(self) -> Vec<&'static str> {
        [
            (Self::TEXTURED, "TEXTURED"),
            (Self::BASE_COLOR_TEXTURE, "BASE_COLOR_TEXTURE"),
            (
                Self::METALLIC_ROUGHNESS_TEXTURE,
                "METALLIC_ROUGHNESS_TEXTURE",
            ),
            (Self::EMISSIVE_TEXTURE, "EMISSIVE_TEXTURE"),
            (Self::NORMAL_MAP, "NORMAL_MAP"),
            (Self::ALPHA_TEST, "ALPHA_TEST"),
            (Self::SAMPLERS, "SAMPLERS"),
        ]
        .into_iter()
        .filter_map(|(lookup, def)| self.contains(lookup).then_some(def))
        .collect()
    }
}

/// The shader defs of `lookups`, for a stage's pipeline.
pub fn texture_defs(lookups: Lookups) -> Vec<bevy::shader::ShaderDefVal> {
    lookups.shader_defs().into_iter().map(Into::into).collect()
}

/// What a stage that evaluates the BSDF (a gather) needs of the materials: the lookups and
/// the extra layers among `paths` ([`ScatterPaths::LAYERS`]).
pub fn material_defs(lookups: Lookups, paths: ScatterPaths) -> Vec<bevy::shader::ShaderDefVal> {
    let mut defs = texture_defs(lookups);
    let layers = paths & ScatterPaths::LAYERS;
    defs.extend(layers.shader_defs().into_iter().map(Into::into));
    defs
}

/// Whether camera paths go on past some surface: a mirror, glass, or a smooth glossy metal
/// (roughness under [`GLOSSY_STORE_ROUGHNESS`], no diffuse lobe), where no photon is
/// stored (`!stores_photons` in bsdf.wgsl), a smooth surface partly mirror or glass (from
/// the first hit), a clearcoat that smooth (`coat_traced`), or a glossy lobe that smooth
/// beside a diffuse one ([`GpuMaterial::glossy_traced`], from the first hit). A texture
/// counts at its darkest, smoothest and most metallic texel.
pub fn has_path_surfaces(materials: &[GpuMaterial]) -> bool {
    materials.iter().any(|m| {
        if m.clearcoat[0] > 0.0 && m.clearcoat[1] < GLOSSY_STORE_ROUGHNESS {
            return true;
        }
        let [base, metal_rough, ..] = m.textures.map(|t| t != NO_TEXTURE);
        let metallic = if metal_rough && m.metallic > 0.0 {
            1.0
        } else {
            m.metallic
        };
        let roughness = if metal_rough {
            0.0
        } else {
            m.perceptual_roughness
        };
        let diffuse = (1.0 - metallic) * (1.0 - m.specular_transmission);
        let albedo = luminance([m.base_color[0], m.base_color[1], m.base_color[2]]);
        // Glass of any roughness stores no photons.
        let placed = GpuMaterial { metallic, ..*m };
        let glass = placed.glass_share() > 0.0;
        let delta = roughness < DELTA_ROUGHNESS && placed.delta_share() > 0.0;
        delta
            || m.glossy_traced()
            || (roughness < GLOSSY_STORE_ROUGHNESS || glass) && (base || diffuse * albedo <= 0.0)
    })
}

pub(super) fn material_to_gpu(m: &StandardMaterial, textures: [u32; 4]) -> GpuMaterial {
    let base = m.base_color.to_linear();
    let mut flags = MaterialFlags::empty();
    flags.set(MaterialFlags::DOUBLE_SIDED, m.double_sided);
    flags.set(MaterialFlags::UNLIT, m.unlit);
    flags.set(MaterialFlags::FLIP_NORMAL_Y, m.flip_normal_map_y);
    flags.set(
        MaterialFlags::TEXTURED,
        textures.iter().any(|&t| t != NO_TEXTURE) || m.unlit || m.alpha_mode != AlphaMode::Opaque,
    );
    let mut alpha_cutoff = 0.0;
    match m.alpha_mode {
        AlphaMode::Opaque => {}
        AlphaMode::Mask(cutoff) => {
            flags |= MaterialFlags::ALPHA_MASK;
            alpha_cutoff = if cutoff.is_finite() { cutoff } else { 0.5 };
        }
        AlphaMode::Blend
        | AlphaMode::Premultiplied
        | AlphaMode::AlphaToCoverage
        | AlphaMode::Add
        | AlphaMode::Multiply => flags |= MaterialFlags::ALPHA_HASHED,
    }
    let finite = |v: f32, fallback: f32| if v.is_finite() { v } else { fallback };
    let uv = m.uv_transform;
    let uv_ok = uv.matrix2.is_finite() && uv.translation.is_finite();
    let (matrix, offset) = if uv_ok {
        (uv.matrix2.to_cols_array(), uv.translation)
    } else {
        ([1.0, 0.0, 0.0, 1.0], Vec2::ZERO)
    };
    let base_color = [base.red, base.green, base.blue, base.alpha];
    let tint = m.specular_tint.to_linear();
    let tint = [tint.red, tint.green, tint.blue, 1.0];
    // An albedo past 1 makes light from nothing (and overflows after enough bounces).
    if base_color.iter().any(|c| !(0.0..=1.0).contains(c)) {
        warn_once!("bevy_rppm: a base colour {base_color:?} outside 0..=1 is clamped");
    }
    let emissive = [m.emissive.red, m.emissive.green, m.emissive.blue, 0.0];
    if emissive.iter().any(|c| !(0.0..=MAX_EMISSIVE).contains(c)) {
        warn_once!(
            "bevy_rppm: an emissive colour {emissive:?} outside 0..={MAX_EMISSIVE:e} is clamped"
        );
    }
    GpuMaterial {
        base_color: base_color.map(|c| finite(c, 0.0).clamp(0.0, 1.0)),
        emissive: emissive.map(|c| finite(c, 0.0).clamp(0.0, MAX_EMISSIVE)),
        metallic: finite(m.metallic, 0.0).clamp(0.0, 1.0),
        perceptual_roughness: finite(m.perceptual_roughness, 0.5).clamp(0.0, 1.0),
        reflectance: finite(m.reflectance, 0.5).clamp(0.0, 1.0),
        specular_transmission: finite(m.specular_transmission, 0.0).clamp(0.0, 1.0),
        ior: if m.ior.is_finite() && m.ior >= 1.0 {
            m.ior
        } else {
            1.5
        },
        flags: flags.bits(),
        alpha_cutoff,
        _pad: 0,
        uv_transform: matrix,
        uv_offset: [offset.x, offset.y, 0.0, 0.0],
        textures,
        absorption: absorption(m),
        specular_tint: tint.map(|c| finite(c, 1.0).max(0.0)),
        clearcoat: [
            finite(m.clearcoat, 0.0).clamp(0.0, 1.0),
            finite(m.clearcoat_perceptual_roughness, 0.5).clamp(0.0, 1.0),
        ],
        diffuse_transmission: finite(m.diffuse_transmission, 0.0).clamp(0.0, 1.0),
        _pad_transmission: 0,
    }
}

impl GpuMaterial {
    /// Clear, smooth glass and nothing else (`is_pane` in shaders/common/panes.wgsl): light
    /// crosses a flat-faced slab of it straight through.
    pub(super) fn is_pane(&self) -> bool {
        let cut = MaterialFlags::ALPHA_MASK | MaterialFlags::ALPHA_HASHED;
        self.perceptual_roughness < DELTA_ROUGHNESS
            && self.specular_transmission >= 1.0
            && self.metallic <= 0.0
            && self.clearcoat[0] <= 0.0
            && self.diffuse_transmission <= 0.0
            && !MaterialFlags::from_bits_truncate(self.flags).intersects(cut)
    }

    /// A glossy lobe too sharp to gather over (under [`GLOSSY_STORE_ROUGHNESS`]) beside a
    /// diffuse lobe: glossy plastic, a polished floor. Camera paths follow it from the first
    /// hit (`glossy_traced` in shaders/common/bsdf.wgsl). A metallic-roughness texture counts
    /// at its smoothest and least metallic texel.
    pub(super) fn glossy_traced(&self) -> bool {
        let [base, metal_rough, ..] = self.textures.map(|t| t != NO_TEXTURE);
        let (roughness, metallic) = if metal_rough {
            (DELTA_ROUGHNESS, 0.0)
        } else {
            (self.perceptual_roughness, self.metallic)
        };
        let colour = luminance([self.base_color[0], self.base_color[1], self.base_color[2]]);
        let diffuse = base || (1.0 - metallic) * (1.0 - self.specular_transmission) * colour > 0.0;
        let lobe = self.reflectance > 0.0 || self.metallic > 0.0 || metal_rough;
        (DELTA_ROUGHNESS..GLOSSY_STORE_ROUGHNESS).contains(&roughness)
            && lobe
            && diffuse
            && self.glass_share() <= 0.0
            && self.clearcoat[0] <= 0.0
            && self.diffuse_transmission <= 0.0
    }

    /// What its delta lobes carry where it is smooth: the mirror of its metal part and its
    /// glass (`delta_share` in shaders/importons/bounce.wgsl).
    pub(super) fn delta_share(&self) -> f32 {
        let base = [self.base_color[0], self.base_color[1], self.base_color[2]];
        luminance(base) * self.metallic + self.glass_share()
    }

    /// `SceneData::max_scatter_probability` of the layers under a clearcoat.
    pub(super) fn under_coat_scatter_probability(&self) -> f32 {
        let m = self;
        let base = [m.base_color[0], m.base_color[1], m.base_color[2]];
        let diffuse = (1.0 - m.metallic) * (1.0 - m.specular_transmission);
        if m.perceptual_roughness < DELTA_ROUGHNESS {
            let delta = m.delta_share();
            return (diffuse * luminance(base) + delta).min(1.0);
        }
        // The tint's largest channel, as `dielectric_f0` in microfacet.wgsl.
        let tint = m.specular_tint[..3].iter().fold(0.0_f32, |a, &t| a.max(t));
        let dielectric = (0.16 * (m.reflectance * tint).powi(2)).min(1.0);
        let f0 = base.map(|c| dielectric + (c - dielectric) * m.metallic);
        let specular = specular_energy_average(m.perceptual_roughness, f0);
        // The dielectric part's diffuse lobe (cosine_lobes in bsdf.wgsl) beside it.
        let own = specular_energy_average(m.perceptual_roughness, [dielectric; 3])[0];
        let albedo = [0, 1, 2].map(|k| {
            (1.0 - m.metallic) * (base[k] * (1.0 - m.specular_transmission) - own).max(0.0)
                + specular[k]
        });
        // Rough glass reflects or refracts nearly all it receives.
        luminance(albedo).max(m.glass_share()).min(1.0)
    }
}

/// Beer–Lambert σ (m⁻¹) of a transmissive material with a volume: white light keeps
/// `attenuation_color` after `attenuation_distance`. A `thickness` of 0 is glTF's thin wall,
/// which has no inside to absorb in.
fn absorption(m: &StandardMaterial) -> [f32; 4] {
    let distance = m.attenuation_distance;
    if !(m.thickness > 0.0
        && m.specular_transmission > 0.0
        && distance.is_finite()
        && distance > 0.0)
    {
        return [0.0; 4];
    }
    let c = m.attenuation_color.to_linear();
    // A channel of colour 0 keeps 10⁻⁶ after the distance instead of an infinite σ.
    let sigma = |c: f32| -(if c.is_finite() { c } else { 1.0 }).clamp(1e-6, 1.0).ln() / distance;
    [sigma(c.red), sigma(c.green), sigma(c.blue), 0.0]
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn absorption_is_beer_lambert_inside_a_volume_only() {
        let glass = StandardMaterial {
            specular_transmission: 1.0,
            thickness: 0.1,
            attenuation_color: Color::linear_rgb(0.5, 1.0, 0.0),
            attenuation_distance: 2.0,
            ..default()
        };
        let s = absorption(&glass);
        // exp(−σ d) = colour: σ = ln 2 / 2 for 0.5, 0 for 1, capped for 0.
        assert!((s[0] - std::f32::consts::LN_2 / 2.0).abs() < 1e-6);
        assert_eq!(s[1], 0.0);
        assert!((s[2] - 1e6f32.ln() / 2.0).abs() < 1e-4);
        // Thin-walled (thickness 0), opaque, or an infinite or broken distance: no volume.
        for m in [
            StandardMaterial {
                thickness: 0.0,
                ..glass.clone()
            },
            StandardMaterial {
                specular_transmission: 0.0,
                ..glass.clone()
            },
            StandardMaterial {
                attenuation_distance: f32::INFINITY,
                ..glass.clone()
            },
            StandardMaterial {
                attenuation_distance: f32::NAN,
                ..glass.clone()
            },
            StandardMaterial {
                attenuation_distance: -1.0,
                ..glass.clone()
            },
        ] {
            assert_eq!(absorption(&m), [0.0; 4]);
        }
        let nan = StandardMaterial {
            attenuation_color: Color::linear_rgb(f32::NAN, 0.5, 0.5),
            ..glass
        };
        assert!(absorption(&nan).iter().all(|v| v.is_finite()));
    }

    #[test]
    fn lookups_are_those_some_material_makes() {
        let plain = material_to_gpu(&StandardMaterial::default(), [NO_TEXTURE; 4]);
        assert_eq!(Lookups::of(&[plain], &[]), Lookups::empty());
        assert!(Lookups::of(&[], &[]).shader_defs().is_empty());
        // A normal map on one material, a cut-out on another: those and no more.
        let bumps = material_to_gpu(
            &StandardMaterial::default(),
            [NO_TEXTURE, NO_TEXTURE, NO_TEXTURE, 0],
        );
        let cut_out = material_to_gpu(
            &StandardMaterial {
                alpha_mode: AlphaMode::Mask(0.5),
                ..default()
            },
            [1, NO_TEXTURE, NO_TEXTURE, NO_TEXTURE],
        );
        let lookups = Lookups::of(&[plain, bumps, cut_out], &[]);
        assert_eq!(
            lookups.shader_defs(),
            ["TEXTURED", "BASE_COLOR_TEXTURE", "NORMAL_MAP", "ALPHA_TEST"]
        );
        // Blended alpha tests alpha too, with no texture at all.
        let glassy = material_to_gpu(
            &StandardMaterial {
                alpha_mode: AlphaMode::Blend,
                ..default()
            },
            [NO_TEXTURE; 4],
        );
        assert_eq!(
            Lookups::of(&[glassy], &[]),
            Lookups::TEXTURED | Lookups::ALPHA_TEST
        );
    }

    #[test]
    fn emission_stays_within_what_f32_sums_hold() {
        let gpu = |c: LinearRgba| {
            let m = StandardMaterial {
                emissive: c,
                ..default()
            };
            material_to_gpu(&m, [NO_TEXTURE; 4]).emissive
        };
        assert_eq!(
            gpu(LinearRgba::rgb(3.4e38, 2.0, 0.0)),
            [MAX_EMISSIVE, 2.0, 0.0, 0.0]
        );
        // Not a number, infinite or negative: nothing.
        assert_eq!(
            gpu(LinearRgba::rgb(f32::NAN, f32::INFINITY, -1.0)),
            [0.0; 4]
        );
    }

    #[test]
    fn camera_paths_follow_a_glossy_lobe_too_sharp_to_gather_beside_a_diffuse_one() {
        let gpu = |m: StandardMaterial| material_to_gpu(&m, [NO_TEXTURE; 4]);
        let plastic = |roughness| StandardMaterial {
            perceptual_roughness: roughness,
            ..default()
        };
        // Bevy's default (roughness 0.5) gathers its lobe; a polished floor (0.15) does not.
        assert!(!gpu(plastic(0.5)).glossy_traced());
        assert!(gpu(plastic(0.15)).glossy_traced());
        assert!(has_path_surfaces(&[gpu(plastic(0.15))]));
        assert!(!has_path_surfaces(&[gpu(plastic(0.5))]));
        // No specular layer, a mirror-smooth one, or beside a coat, glass or diffuse
        // transmission (their own paths): not traced.
        for m in [
            StandardMaterial {
                reflectance: 0.0,
                ..plastic(0.15)
            },
            plastic(0.0),
            StandardMaterial {
                clearcoat: 1.0,
                ..plastic(0.15)
            },
            StandardMaterial {
                specular_transmission: 0.5,
                ..plastic(0.15)
            },
            StandardMaterial {
                diffuse_transmission: 0.5,
                ..plastic(0.15)
            },
        ] {
            assert!(!gpu(m).glossy_traced());
        }
        // A metallic-roughness texture may hold such texels.
        let textured = material_to_gpu(&plastic(1.0), [NO_TEXTURE, 0, NO_TEXTURE, NO_TEXTURE]);
        assert!(textured.glossy_traced());
    }
}
