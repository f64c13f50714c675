//! Scene extraction: every visible `Mesh3d` + `StandardMaterial` becomes world-space triangles,
//! materials and lights in flat tables, rebuilt only when something in the scene changed.
//!
//! This runs in the main world (so games and tests can read [`RppmScene`]); the render world
//! receives the tables as one `Arc` and uploads them (see [`gpu`]).

mod deform;
mod emitters;
mod extract;
mod instances;
mod lights;
mod material;
mod mesh;
mod packed;
pub mod parts;
pub mod place;
pub mod prepare;
mod receivers;
pub mod textures;
pub(crate) mod upload;

use std::sync::Arc;

use bevy::camera::visibility::VisibilitySystems;
use bevy::prelude::*;
use bevy::render::extract_resource::{ExtractResource, ExtractResourcePlugin};
use bevy::render::{Render, RenderApp, RenderStartup, RenderSystems};
use bevy::transform::TransformSystems;
use bytemuck::{Pod, Zeroable};

use crate::bsdf::{DELTA_ROUGHNESS, specular_energy_average};

pub use instances::{GpuInstance, SceneMesh};
pub use lights::{LightKind, RppmSky, spot_cone_fraction};
pub use material::{Lookups, material_defs, texture_defs};
pub use packed::PackedTriangle;
pub use prepare::{SceneBuffers, SceneRefused};
pub use textures::{GpuTexture, NO_TEXTURE, PackedTexture};

bitflags::bitflags! {
    /// The scattering lobes a scene's materials have, and its sky: the variants of the tracing
    /// stages, so that a scene compiles and runs only its own code paths (no glass: no
    /// refraction; no sky: none of its code).
    #[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
    pub struct ScatterPaths: u16 {
        /// A rough specular layer (GGX).
        const GLOSSY = 1 << 0;
        /// Smooth metal.
        const MIRRORS = 1 << 1;
        /// Smooth glass.
        const REFRACTION = 1 << 2;
        /// A sky ([`RppmSky`]): photons leave it, paths that escape see it.
        const SKY = 1 << 3;
        /// Coloured glass: paths inside it lose light along their length (Beer–Lambert).
        const ABSORPTION = 1 << 4;
        /// Rough glass (a microfacet interface that reflects and refracts).
        const ROUGH_REFRACTION = 1 << 5;
        /// A clearcoat layer (a second GGX lobe over the others).
        const CLEARCOAT = 1 << 6;
        /// Diffuse transmission (a Lambertian lobe through to the other side).
        const DIFFUSE_TRANSMISSION = 1 << 7;
        /// Panes: clear glass with flat faces facing opposite ways, which light crosses
        /// straight through (direct light to shadow rays, shaders/common/panes.wgsl).
        const PANES = 1 << 8;
        /// A glossy lobe too sharp to gather over beside a diffuse one, which camera paths
        /// follow from the first hit and the first hit's gather leaves out.
        const GLOSSY_TRACED = 1 << 9;
        /// The layers every stage that evaluates the BSDF needs, gathers included.
        const LAYERS = Self::CLEARCOAT.bits()
            | Self::DIFFUSE_TRANSMISSION.bits()
            | Self::GLOSSY_TRACED.bits();
        /// Glass or water, smooth or rough.
        const GLASS = Self::REFRACTION.bits() | Self::ROUGH_REFRACTION.bits();
    }
}

impl ScatterPaths {
    /// The shader defs of these paths.
    pub fn shader_defs(self) -> Vec<&'static str> {
        [
            (Self::GLOSSY, "GLOSSY"),
            (Self::MIRRORS, "MIRRORS"),
            (Self::REFRACTION, "REFRACTION"),
            (Self::SKY, "SKY"),
            (Self::ABSORPTION, "ABSORPTION"),
            (Self::ROUGH_REFRACTION, "ROUGH_REFRACTION"),
            (Self::CLEARCOAT, "CLEARCOAT"),
            (Self::DIFFUSE_TRANSMISSION, "DIFFUSE_TRANSMISSION"),
            (Self::PANES, "PANES"),
            (Self::GLOSSY_TRACED, "GLOSSY_TRACED"),
        ]
        .into_iter()
        .filter_map(|(path, def)| self.contains(path).then_some(def))
        .collect()
    }
}

/// One world-space triangle (stored on the GPU packed: [`PackedTriangle`]).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct GpuTriangle {
    pub position_a: [f32; 3],
    /// Index into [`SceneData::materials`].
    pub material: u32,
    pub position_b: [f32; 3],
    pub _pad_b: u32,
    pub position_c: [f32; 3],
    pub _pad1: u32,
    pub normal_a: [f32; 3],
    pub _pad2: u32,
    pub normal_b: [f32; 3],
    pub _pad3: u32,
    pub normal_c: [f32; 3],
    pub _pad4: u32,
}

impl GpuTriangle {
    pub fn positions(&self) -> [Vec3; 3] {
        [
            self.position_a.into(),
            self.position_b.into(),
            self.position_c.into(),
        ]
    }

    /// Area in m².
    pub fn area(&self) -> f32 {
        let [a, b, c] = self.positions();
        0.5 * (b - a).cross(c - a).length()
    }
}

/// A `StandardMaterial` reduced to what the light transport uses (176 bytes). Texture lookups
/// multiply the factors, as Bevy's own shaders do (`material_at` in shaders/scene/scene.wgsl).
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, Pod, Zeroable)]
pub struct GpuMaterial {
    /// Linear RGB base colour (albedo), alpha in w.
    pub base_color: [f32; 4],
    /// Emitted radiance, linear RGB (W·sr⁻¹·m⁻²); w unused.
    pub emissive: [f32; 4],
    pub metallic: f32,
    pub perceptual_roughness: f32,
    /// Bevy's reflectance: F0 = 0.16·reflectance² for dielectrics.
    pub reflectance: f32,
    pub specular_transmission: f32,
    pub ior: f32,
    /// [`MaterialFlags`] bits.
    pub flags: u32,
    /// Alpha under which a texel is cut out (`AlphaMode::Mask`).
    pub alpha_cutoff: f32,
    pub _pad: u32,
    /// Bevy's `uv_transform`: the 2×2 part by columns (x_axis, y_axis)…
    pub uv_transform: [f32; 4],
    /// …and its translation; zw unused.
    pub uv_offset: [f32; 4],
    /// Indices into [`SceneData::textures`] of the base colour, metallic-roughness, emissive
    /// and normal map textures, or [`NO_TEXTURE`].
    pub textures: [u32; 4],
    /// What light inside the material loses per metre (Beer–Lambert σ, linear RGB, m⁻¹), from
    /// `attenuation_color` and `attenuation_distance` of a transmissive material with a
    /// `thickness` (glTF's `KHR_materials_volume`); 0 for thin-walled or clear ones. w unused.
    pub absorption: [f32; 4],
    /// Bevy's `specular_tint` (linear RGB, glTF's `KHR_materials_specular` colour): the
    /// dielectric F0 is 0.16·(reflectance·tint)², as in Bevy. w unused.
    pub specular_tint: [f32; 4],
    /// The clearcoat layer: its strength (0..=1) and perceptual roughness (0..=1).
    pub clearcoat: [f32; 2],
    /// Bevy's `diffuse_transmission` (0..=1): the share of the diffuse lobe that leaves
    /// through the other side (glTF's `KHR_materials_diffuse_transmission`).
    pub diffuse_transmission: f32,
    pub _pad_transmission: u32,
}

impl Default for GpuMaterial {
    /// Black, no tint on its specular layer, no clearcoat.
    fn default() -> Self {
        Self {
            specular_tint: [1.0; 4],
            ..Zeroable::zeroed()
        }
    }
}

impl GpuMaterial {
    /// The share of the surface that is glass: Bevy's specular transmission of a dielectric
    /// (`glass_share` in shaders/common/bsdf.wgsl).
    pub fn glass_share(&self) -> f32 {
        self.specular_transmission * (1.0 - self.metallic)
    }
}

bitflags::bitflags! {
    /// The flags of a [`GpuMaterial`], mirrored by the `MATERIAL_*` constants of
    /// shaders/common/common.wgsl.
    #[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
    pub struct MaterialFlags: u32 {
        /// Lit and seen from both sides.
        const DOUBLE_SIDED = 1 << 0;
        /// Textures or vertex colours vary it over its surfaces, or alpha or `unlit` change
        /// it: lookups read per-triangle attributes ([`SceneMesh::attributes`]).
        const TEXTURED = 1 << 1;
        /// `AlphaMode::Mask`: texels under `alpha_cutoff` are holes for every ray.
        const ALPHA_MASK = 1 << 2;
        /// Blended alpha: a ray passes a texel with probability 1 − alpha (hashed alpha).
        const ALPHA_HASHED = 1 << 3;
        /// `unlit`: shows its base colour, reflects nothing, lights nothing.
        const UNLIT = 1 << 4;
        /// `flip_normal_map_y`.
        const FLIP_NORMAL_Y = 1 << 5;
    }
}

/// What textured materials read per triangle (48 bytes): texture coordinates and vertex
/// colours (linear, 16-bit unorm pairs: rg then ba) at its three corners.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct GpuTriangleAttributes {
    pub uv: [[f32; 2]; 3],
    pub color: [[u32; 2]; 3],
}

/// A punctual light (64 bytes). Radiometric units, photometric numbers taken as radiometric.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct GpuLight {
    /// [`LightKind`] as u32.
    pub kind: u32,
    /// First layer of this light's shadow views (6 for point and spot, 1 for directional).
    pub shadow_layer: u32,
    /// cos of the spot's inner and outer half-angles.
    pub cos_inner: f32,
    pub cos_outer: f32,
    /// Position (point, spot); w: the radius of the sphere that emits (m, 0: a point).
    pub position: [f32; 4],
    /// Direction light travels (spot, directional), unit length.
    pub direction: [f32; 4],
    /// Radiant intensity W/sr (point, spot) or irradiance W/m² (directional), linear RGB; w
    /// holds the power used to split photons (W, luminance-weighted).
    pub radiance: [f32; 4],
}

/// An emissive triangle or a part of one, an area light (36 bytes).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct GpuEmitter {
    pub triangle: u32,
    /// The part of the triangle it covers (`parts`: 0 the whole; a textured emitter's parts
    /// each carry the texture's power over them).
    pub part: u32,
    /// Area in m².
    pub area: f32,
    /// Emitted power π·L·A (W, luminance-weighted), by the texture's mean over the part.
    pub power: f32,
    /// Cumulative distribution over emitters (inclusive), in (0, 1].
    pub cdf: f32,
    /// The sphere (centre, radius) bounding what its photons can meet; radius 0: unknown
    /// (a curved emitter), its photons leave over the hemisphere.
    pub toward: [f32; 4],
}

/// The scene as flat tables: meshes placed by instances, materials, textures and lights.
#[derive(Clone, Debug, Default)]
pub struct SceneData {
    /// Each mesh once, in its own space, shared with the previous extraction while it is the
    /// same (kept on the GPU then too).
    pub meshes: Vec<Arc<SceneMesh>>,
    /// The world-space triangles are the instances' meshes placed, in this order.
    pub instances: Vec<GpuInstance>,
    pub materials: Vec<GpuMaterial>,
    /// The packed textures the materials use, and their texels (RGBA8 in u32), shared with
    /// the previous extraction while its textures are the same (kept on the GPU then too).
    pub textures: Vec<GpuTexture>,
    pub texels: Arc<Vec<u32>>,
    pub lights: Vec<GpuLight>,
    pub emitters: Vec<GpuEmitter>,
    /// The sky's radiance (linear RGB; [`RppmSky`]) and in w the power it sends into the
    /// scene's bounding sphere (luminance-weighted W); all zero without one.
    pub sky: [f32; 4],
    /// Photon-emission CDF over `lights`, `emitters` then the sky, by power (inclusive, last
    /// = 1).
    pub light_cdf: Vec<f32>,
    /// Axis-aligned bounds of all world-space triangles (min, max); zero-sized when empty.
    pub bounds: (Vec3, Vec3),
}

/// Whether two tables hold the same bytes (floats compared bit for bit, as uploaded).
fn same<T: bytemuck::Pod>(a: &[T], b: &[T]) -> bool {
    bytemuck::cast_slice::<T, u8>(a) == bytemuck::cast_slice::<T, u8>(b)
}

impl SceneData {
    /// Whether `other` holds the same tables (a transform set to its own value, a paused
    /// animation writing its pose again): then nothing changed.
    pub fn same_as(&self, other: &SceneData) -> bool {
        same(&self.instances, &other.instances)
            && self.meshes.len() == other.meshes.len()
            && (self.meshes.iter().zip(&other.meshes)).all(|(a, b)| Arc::ptr_eq(a, b) || a == b)
            && same(&self.lights, &other.lights)
            && same(&self.light_cdf, &other.light_cdf)
            && self.same_light(other)
    }

    /// Whether `other` lights the scene as this does: the same lights, emitters, materials
    /// and sky (objects may have moved). A light's photon power is left out: a sun's follows
    /// the scene's bounds, which a moving object changes.
    pub fn same_light(&self, other: &SceneData) -> bool {
        let unpowered = |l: &GpuLight| GpuLight {
            radiance: [l.radiance[0], l.radiance[1], l.radiance[2], 0.0],
            ..*l
        };
        let same_lights = self.lights.len() == other.lights.len()
            && (self.lights.iter().zip(&other.lights))
                .all(|(a, b)| same(&[unpowered(a)], &[unpowered(b)]));
        same(&self.materials, &other.materials)
            && same(&self.textures, &other.textures)
            && same_lights
            && same(&self.emitters, &other.emitters)
            && self.sky == other.sky
            && (Arc::ptr_eq(&self.texels, &other.texels) || self.texels == other.texels)
    }

    /// Counts of triangles, materials, lights and emitters: what a moving scene keeps.
    pub fn shape(&self) -> [usize; 4] {
        [
            self.triangle_count(),
            self.materials.len(),
            self.lights.len(),
            self.emitters.len(),
        ]
    }

    /// Whether some material varies over its surfaces (textures, vertex colours), has alpha
    /// or is unlit: the scene then holds per-triangle attributes and texels.
    pub fn is_textured(&self) -> bool {
        self.lookups().contains(Lookups::TEXTURED)
    }

    /// The lookups the scene's materials make, which the stages compile ([`texture_defs`]).
    pub fn lookups(&self) -> Lookups {
        Lookups::of(&self.materials, &self.textures)
    }

    /// Total emitted power (luminance-weighted W) of every light and emitter.
    pub fn total_power(&self) -> f32 {
        self.lights.iter().map(|l| l.radiance[3]).sum::<f32>() + self.emitter_power() + self.sky[3]
    }

    /// Emitted power (luminance-weighted W) of the emissive triangles together.
    pub fn emitter_power(&self) -> f32 {
        self.emitters.iter().map(|e| e.power).sum()
    }

    /// Centre and radius of a sphere around the bounds.
    pub fn bounding_sphere(&self) -> (Vec3, f32) {
        let (lo, hi) = self.bounds;
        ((lo + hi) * 0.5, ((hi - lo) * 0.5).length())
    }

    /// Whether camera paths go on past some surface (`has_path_surfaces` in material.rs).
    pub fn has_path_surfaces(&self) -> bool {
        material::has_path_surfaces(&self.materials)
    }

    /// Which scattering lobes the scene's materials have.
    pub fn scatter_paths(&self) -> ScatterPaths {
        let (mut glossy, mut mirrors, mut refraction) = (false, false, false);
        let (mut absorption, mut rough_refraction) = (false, false);
        let (mut clearcoat, mut translucent) = (false, false);
        for m in &self.materials {
            absorption |= m.absorption[..3].iter().any(|&s| s > 0.0);
            clearcoat |= m.clearcoat[0] > 0.0;
            translucent |= m.diffuse_transmission > 0.0;
            let colour = m.base_color[..3].iter().any(|&c| c > 0.0);
            if m.perceptual_roughness >= DELTA_ROUGHNESS {
                glossy |= m.reflectance > 0.0 || (m.metallic > 0.0 && colour);
                rough_refraction |= m.glass_share() > 0.0;
            } else {
                mirrors |= m.metallic > 0.0 && colour;
                refraction |= m.glass_share() > 0.0;
            }
        }
        let mut paths = ScatterPaths::empty();
        // Rough glass is sampled as the glossy lobes are (camera paths go on through both).
        paths.set(ScatterPaths::GLOSSY, glossy || rough_refraction);
        paths.set(ScatterPaths::MIRRORS, mirrors);
        paths.set(ScatterPaths::REFRACTION, refraction);
        paths.set(ScatterPaths::ROUGH_REFRACTION, rough_refraction);
        paths.set(ScatterPaths::SKY, self.sky[3] > 0.0);
        paths.set(ScatterPaths::CLEARCOAT, clearcoat);
        paths.set(ScatterPaths::DIFFUSE_TRANSMISSION, translucent);
        let traced = self.materials.iter().any(|m| m.glossy_traced());
        paths.set(ScatterPaths::GLOSSY_TRACED, traced && glossy);
        paths.set(ScatterPaths::PANES, self.has_panes());
        paths.set(
            ScatterPaths::ABSORPTION,
            absorption && (refraction || rough_refraction),
        );
        paths
    }

    /// The largest probability that a photon goes on after a hit, over the scene's materials
    /// (`scatter_photon` in shaders/common/bsdf.wgsl), for light arriving cosine-distributed:
    /// the base colour's albedo (at least the specular layer's), or the mirror and glass ones.
    pub fn max_scatter_probability(&self) -> f32 {
        self.materials
            .iter()
            .flat_map(|m| {
                // A metallic-roughness texture scales both down, to any texel's value.
                let textured = m.textures[1] != NO_TEXTURE;
                let metallic = if textured {
                    vec![0.0, m.metallic]
                } else {
                    vec![m.metallic]
                };
                metallic.into_iter().map(move |metallic| GpuMaterial {
                    metallic,
                    perceptual_roughness: if textured {
                        m.perceptual_roughness.min(DELTA_ROUGHNESS)
                    } else {
                        m.perceptual_roughness
                    },
                    ..*m
                })
            })
            .map(|m| {
                // What a clearcoat reflects on average, and what it lets through.
                let coat = m.clearcoat[0] * specular_energy_average(m.clearcoat[1], [0.04; 3])[0];
                coat + (1.0 - coat) * m.under_coat_scatter_probability()
            })
            .fold(0.0, f32::max)
    }
}

/// Luminance of linear RGB (Rec. 709 weights).
pub(crate) fn luminance(rgb: [f32; 3]) -> f32 {
    0.2126 * rgb[0] + 0.7152 * rgb[1] + 0.0722 * rgb[2]
}

/// The extracted scene and the epoch that counts its changes. Any change to meshes, materials,
/// lights or transforms increments `epoch`, which restarts progressive accumulation or, under
/// `RppmHistory::Reuse`, lets it settle.
#[derive(Resource, Clone, Default, ExtractResource)]
pub struct RppmScene {
    pub data: Arc<SceneData>,
    pub epoch: u64,
    /// CPU time of the latest extraction (ms): it follows what changed, not the scene's size.
    pub extract_ms: f64,
}

/// Scene extraction in the main world, and its upload in the render world.
pub(crate) struct ScenePlugin;

impl Plugin for ScenePlugin {
    fn build(&self, app: &mut App) {
        app.register_type::<RppmSky>()
            .init_resource::<RppmScene>()
            .init_resource::<extract::ExtractionWarnings>()
            .init_resource::<mesh::MeshCache>()
            .add_plugins(ExtractResourcePlugin::<RppmScene>::default())
            .add_systems(
                PostUpdate,
                extract::extract_scene
                    .after(TransformSystems::Propagate)
                    .after(VisibilitySystems::VisibilityPropagate)
                    .after(bevy::camera::CameraUpdateSystems),
            );
        if let Some(render_app) = app.get_sub_app_mut(RenderApp) {
            render_app
                .add_systems(
                    RenderStartup,
                    (prepare::init_ggx_albedo, place::init_place_pipeline),
                )
                .add_systems(
                    Render,
                    prepare::prepare_scene.in_set(RenderSystems::PrepareResources),
                );
        }
    }

    fn finish(&self, app: &mut App) {
        app.insert_resource(extract::TextureCache::for_app(app));
    }
}
