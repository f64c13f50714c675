//! Eye paths and importons. Every pixel's first hit (from the G-buffer) is lit locally:
//! emission plus direct light with shadows, this iteration's sample before photons are added.
//! With importons, a pixel that sees a mirror or clear glass follows its camera path through
//! the deep cubemap to the first non-specular surface, lights it the same way and leaves an
//! importon there (one per pixel, two where it sees rough glass) for indirect splatting
//! (`shaders/importons/eye_paths.wgsl`).

use bevy::prelude::*;
use bevy::render::render_resource::binding_types::{
    storage_buffer_sized, texture_2d, texture_2d_array,
};
use bevy::render::render_resource::*;
use bevy::render::renderer::RenderDevice;
use bevy::render::{RenderApp, RenderStartup};
use bevy::shader::Shader;

use crate::cubemap;
use crate::gbuffer::GBuffer;
use crate::scene::{Lookups, ScatterPaths, texture_defs};
use crate::shaders::RppmShaders;
use crate::shadows::ShadowMaps;
use crate::stats::timing::{Stage, StageTimer};
use crate::view::{ViewLayouts, per_pixel_binding_fits, pixel_buffer};

/// Byte offset of the indirect splat's dispatch arguments (one thread a pixel) in the
/// importon stats buffer.
pub const GATHER_DISPATCH: u64 = 16;

/// Bytes of one pixel's importon (`Importon` in `shaders/common/common.wgsl`).
const IMPORTON_BYTES: u64 = 64;

/// Importon slots past the image's own, per pixel, where the scene has rough glass: a
/// rough-glass pixel's second importon (`SPLIT_IMPORTONS` in eye_paths.wgsl) goes there, room
/// for a quarter of the image (16 bytes a pixel). Past it a pixel's first camera path alone
/// leaves one, weighed as both: unbiased, as before the split.
const EXTRA_IMPORTONS: f64 = 0.25;

/// The extra importon slots (`EXTRA_IMPORTONS`) a target of `size` holds: none without rough
/// glass, or where they would not fit in the importons' binding with the image's own.
pub(crate) fn extra_importons(device: &RenderDevice, size: UVec2, rough_glass: bool) -> u32 {
    let per_pixel = (IMPORTON_BYTES as f64 * (1.0 + EXTRA_IMPORTONS)).ceil() as u64;
    let fits = per_pixel_binding_fits(device, size, per_pixel, "importons").is_ok();
    let pixels = size.x as f64 * size.y as f64;
    if rough_glass && fits {
        (pixels * EXTRA_IMPORTONS) as u32
    } else {
        0
    }
}

/// Whether a target of `size` can hold its importons in one binding on this device; one that
/// cannot ends its camera paths at the first surface (with a warning) rather than fail.
pub(crate) fn importons_fit(device: &RenderDevice, size: UVec2) -> bool {
    per_pixel_binding_fits(device, size, IMPORTON_BYTES, "importons")
        .inspect_err(|e| {
            warn_once!(
                "bevy_rppm: {e}: camera paths end at the first surface (no reflections, \
                 refraction or glossy paths)"
            )
        })
        .is_ok()
}

pub(crate) struct ImportonsPlugin;

impl Plugin for ImportonsPlugin {
    fn build(&self, app: &mut App) {
        if let Some(render_app) = app.get_sub_app_mut(RenderApp) {
            render_app
                .init_resource::<SpecializedComputePipelines<EyePathPipeline>>()
                .add_systems(RenderStartup, init_eye_path_pipeline);
        }
    }
}

/// The local-illumination and camera-path stage, specialized by [`EyePathKey`].
#[derive(Resource)]
pub struct EyePathPipeline {
    /// 0 G-buffer position, 1 G-buffer normal, 2 shadow maps, 3 this iteration's samples,
    /// 4 importons, 5 importon stats, 6 resolved surfaces.
    pub layout: BindGroupLayoutDescriptor,
    view: ViewLayouts,
    shader: Handle<Shader>,
}

/// Which eye-path variant a view runs.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct EyePathKey {
    /// `None` lights the first hits only; `Some(paths)` follows camera paths through mirrors,
    /// glass and smooth glossy metals with these lobes (`GLOSSY`, `MIRRORS`, `REFRACTION`)
    /// and leaves importons.
    pub importons: Option<ScatterPaths>,
    /// Shadows by rays through the view's deep cubemap (`TRACED_SHADOWS`) instead of shadow
    /// maps: whenever the view has a cubemap.
    pub traced_shadows: bool,
    /// The scene's material lookups.
    pub lookups: Lookups,
    /// The scene has a sky (`SKY`): direct light samples it, escaping paths see it.
    pub sky: bool,
    /// The scene's extra BSDF layers ([`ScatterPaths::LAYERS`]), which direct light
    /// evaluates even where no path goes on.
    pub layers: ScatterPaths,
    /// Rays through the hierarchy (`BVH`): `RppmTracer::Bvh`.
    pub bvh: bool,
    /// Camera paths at rough vertices also draw toward punctual lights a shadow ray found
    /// blocked (`LIGHT_GUIDE`, shaders/common/mis.wgsl): the scene has rough glass and
    /// punctual lights, and camera paths go on with traced shadows.
    pub light_guide: bool,
    /// Camera paths from rough vertices meet the sphere lights (a punctual light's radius)
    /// and weigh them by MIS against their shadow rays (`SPHERE_LIGHTS`): the scene has one
    /// and rough lobes (`SceneBuffers::sphere_lights`), and camera paths go on with traced
    /// shadows.
    pub sphere_lights: bool,
    /// The camera's rays and camera paths off delta lobes (mirrors, smooth glass) see the
    /// sphere lights (`SPHERE_LIGHTS_SEEN`): the scene has one.
    pub spheres_seen: bool,
    /// Camera paths at smooth glass look up the emission along its reflection besides going
    /// on (`REFLECTED_EMISSION`): the scene has smooth glass and emitters, a sky or a sphere
    /// light (a bulb's highlight on a glass ball).
    pub reflected_emission: bool,
    /// Traced shadows draw points on the emissive surfaces (`EMITTERS`): the scene has
    /// emitters, and shadows are traced.
    pub emitters: bool,
    /// Where no camera path goes on, a ray drawn by cosine also finds the emitters, weighed
    /// by MIS against the emitter sample (`EMITTER_RAYS`): a large emitter close by is drawn
    /// well. The scene has an emitter of more than a quad (`has_many_faced_emitters`), and
    /// `emitters`.
    pub emitter_rays: bool,
    /// A frame whose camera moved shades each pixel at its iterations' own points of the
    /// pixel where they meet the G-buffer's surface (`SHADING_POINTS`, one more ray walk to
    /// compile): `RppmHistory::Reuse` with traced shadows.
    pub shading_points: bool,
}

impl SpecializedComputePipeline for EyePathPipeline {
    type Key = EyePathKey;

    fn specialize(&self, key: EyePathKey) -> ComputePipelineDescriptor {
        let mut layout = vec![
            self.view.scene.clone(),
            self.view.params.clone(),
            self.layout.clone(),
        ];
        let mut shader_defs = Vec::new();
        if key.importons.is_some() || key.traced_shadows {
            layout.push(cubemap::trace_layout());
        }
        let mut paths = key.layers;
        if let Some(traced) = key.importons {
            shader_defs.push("IMPORTONS".into());
            paths |= traced - ScatterPaths::SKY;
        }
        shader_defs.extend(paths.shader_defs().into_iter().map(Into::into));
        if key.sky {
            shader_defs.push("SKY".into());
        }
        if key.traced_shadows {
            shader_defs.push("TRACED_SHADOWS".into());
        }
        if key.light_guide {
            shader_defs.push("LIGHT_GUIDE".into());
        }
        if key.sphere_lights {
            shader_defs.push("SPHERE_LIGHTS".into());
        }
        // `sphere_lights` implies a sphere light, so this is set wherever that is.
        if key.spheres_seen {
            shader_defs.push("SPHERE_LIGHTS_SEEN".into());
        }
        if key.reflected_emission {
            shader_defs.push("REFLECTED_EMISSION".into());
        }
        if key.emitters {
            shader_defs.push("EMITTERS".into());
        }
        if key.emitter_rays {
            shader_defs.push("EMITTER_RAYS".into());
        }
        if key.shading_points {
            shader_defs.push("SHADING_POINTS".into());
        }
        if key.bvh {
            shader_defs.push("BVH".into());
        }
        shader_defs.extend(texture_defs(key.lookups));
        ComputePipelineDescriptor {
            label: Some("rppm_local_illumination_pipeline".into()),
            layout,
            shader: self.shader.clone(),
            shader_defs,
            ..default()
        }
    }
}

/// Group 2 of the stage (see [`EyePathPipeline::layout`]).
pub fn eye_path_layout() -> BindGroupLayoutDescriptor {
    let unfilterable = TextureSampleType::Float { filterable: false };
    BindGroupLayoutDescriptor::new(
        "rppm_local_layout",
        &BindGroupLayoutEntries::sequential(
            ShaderStages::COMPUTE,
            (
                texture_2d(unfilterable),
                texture_2d(unfilterable),
                texture_2d_array(TextureSampleType::Depth),
                storage_buffer_sized(false, None),
                storage_buffer_sized(false, None),
                storage_buffer_sized(false, None),
                storage_buffer_sized(false, None),
            ),
        ),
    )
}

fn init_eye_path_pipeline(
    mut commands: Commands,
    shaders: Res<RppmShaders>,
    layouts: Res<ViewLayouts>,
) {
    commands.insert_resource(EyePathPipeline {
        layout: eye_path_layout(),
        view: layouts.clone(),
        shader: shaders.eye_paths.clone(),
    });
}

/// One camera's per-pixel samples and importons. The importon buffers are 16-byte stand-ins
/// when no camera path goes past the G-buffer.
pub struct EyePaths {
    /// This iteration's local sample per pixel.
    pub samples: Buffer,
    /// One importon per pixel, then the extra slots ([`extra_importons`]).
    pub importons: Buffer,
    /// [-, importons made, extra slots taken, -, gather x, y, z, -]: the stage sets the
    /// indirect splat's workgroup count only when it makes an importon.
    pub stats: Buffer,
    /// Per pixel, the photons the pixel's importon gathered (indirect splatting's output).
    pub radiance: Buffer,
    /// Per pixel of a textured scene, the first hit's textures as looked up once (base
    /// colour, metalness, roughness; `resolved_material` in shaders/scene/scene.wgsl), for
    /// the splat's many photons a pixel.
    pub surfaces: Buffer,
    /// Group 2 of the stage (made again when the scene's shadow maps change).
    pub group: Option<BindGroup>,
}

/// A storage buffer of at least 16 bytes (bindings cannot be empty).
pub fn storage(device: &RenderDevice, label: &'static str, size: u64) -> Buffer {
    device.create_buffer(&BufferDescriptor {
        label: Some(label),
        size: size.max(16),
        usage: BufferUsages::STORAGE | BufferUsages::COPY_DST,
        mapped_at_creation: false,
    })
}

impl EyePaths {
    /// Buffers for `size` pixels, with importons (and `extras` more slots) when `importons`
    /// and surfaces when `textured`.
    pub fn new(
        device: &RenderDevice,
        size: UVec2,
        importons: bool,
        extras: u32,
        textured: bool,
    ) -> Self {
        let pixels = size.x as u64 * size.y as u64;
        let per_pixel = |bytes: u64| {
            if importons { pixels * bytes } else { 0 }
        };
        let slots = per_pixel(IMPORTON_BYTES) + importons as u64 * extras as u64 * IMPORTON_BYTES;
        Self {
            samples: pixel_buffer(device, size, "rppm_samples", 16, BufferUsages::empty()),
            importons: storage(device, "rppm_importons", slots),
            stats: device.create_buffer_with_data(&BufferInitDescriptor {
                label: Some("rppm_importon_stats"),
                contents: bytemuck::cast_slice(&[0u32, 0, 0, 0, 0, 1, 1, 0]),
                usage: BufferUsages::STORAGE
                    | BufferUsages::COPY_DST
                    | BufferUsages::COPY_SRC
                    | BufferUsages::INDIRECT,
            }),
            radiance: storage(device, "rppm_importon_radiance", per_pixel(16)),
            surfaces: storage(device, "rppm_surfaces", pixels * 16 * textured as u64),
            group: None,
        }
    }

    /// Binds the G-buffer and the scene's shadow maps with the stage's own buffers.
    pub fn bind(
        &mut self,
        device: &RenderDevice,
        cache: &PipelineCache,
        pipeline: &EyePathPipeline,
        gbuffer: &GBuffer,
        shadows: &ShadowMaps,
    ) {
        self.group = Some(device.create_bind_group(
            "rppm_local_group",
            &cache.get_bind_group_layout(&pipeline.layout),
            &BindGroupEntries::sequential((
                &gbuffer.position,
                &gbuffer.normal,
                &shadows.array_view,
                self.samples.as_entire_binding(),
                self.importons.as_entire_binding(),
                self.stats.as_entire_binding(),
                self.surfaces.as_entire_binding(),
            )),
        ));
    }

    pub fn memory(&self) -> [(&'static str, u64); 4] {
        [
            ("surfaces", self.surfaces.size()),
            ("samples", self.samples.size()),
            ("importons", self.importons.size()),
            ("importon_radiance", self.radiance.size()),
        ]
    }

    /// Empties the gathered light before an iteration's camera paths.
    pub fn encode_clear(&self, encoder: &mut CommandEncoder) {
        encoder.clear_buffer(&self.radiance, 0, None);
        // The stats and the dispatch's x; its y and z stay 1.
        encoder.clear_buffer(&self.stats, 0, Some(GATHER_DISPATCH + 4));
    }

    /// Lights every pixel's first hit (and, with `cubemap`, follows its camera path).
    #[expect(clippy::too_many_arguments, reason = "the groups of a per-pixel stage")]
    pub fn encode(
        &self,
        encoder: &mut CommandEncoder,
        pipeline: &ComputePipeline,
        groups: [&BindGroup; 2],
        offset: u32,
        cubemap: Option<&BindGroup>,
        size: UVec2,
        timer: &mut StageTimer,
    ) {
        let Some(group) = &self.group else { return };
        let mut pass = encoder.begin_compute_pass(&ComputePassDescriptor {
            label: Some("rppm_local_illumination"),
            timestamp_writes: timer.compute_pass(Stage::LocalIllumination),
        });
        pass.set_pipeline(pipeline);
        if let Some(cubemap) = cubemap {
            pass.set_bind_group(3, cubemap, &[]);
        }
        dispatch_per_pixel(&mut pass, [groups[0], groups[1], group], offset, size);
    }
}

/// Binds groups 0–2 of a per-pixel compute stage and dispatches it over the view.
pub fn dispatch_per_pixel(
    pass: &mut ComputePass,
    [scene, params, own]: [&BindGroup; 3],
    offset: u32,
    size: UVec2,
) {
    pass.set_bind_group(0, scene, &[]);
    pass.set_bind_group(1, params, &[offset]);
    pass.set_bind_group(2, own, &[]);
    pass.dispatch_workgroups(size.x.div_ceil(8), size.y.div_ceil(8), 1);
}
