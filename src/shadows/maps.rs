//! The views shadow maps are rendered from, and one camera's shadow-map array.

use bevy::prelude::*;
use bevy::render::render_resource::*;
use bevy::render::renderer::{RenderDevice, RenderQueue};
use bytemuck::{Pod, Zeroable};

use super::SHADOW_FORMAT;
use crate::scene::{GpuLight, LightKind, SceneData};

/// The cube faces in the order the shaders' `cube_face` picks them: +X −X +Y −Y +Z −Z.
const CUBE_FACES: [(Vec3, Vec3); 6] = [
    (Vec3::X, Vec3::Y),
    (Vec3::NEG_X, Vec3::Y),
    (Vec3::Y, Vec3::Z),
    (Vec3::NEG_Y, Vec3::Z),
    (Vec3::Z, Vec3::Y),
    (Vec3::NEG_Z, Vec3::Y),
];

/// One view a shadow map is rendered from (112 bytes; `ShadowView` in common.wgsl).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable)]
pub struct ShadowView {
    pub clip_from_world: [[f32; 4]; 4],
    pub origin: [f32; 4],
    pub axis: [f32; 4],
    pub near: f32,
    pub far: f32,
    pub texel: f32,
    pub _pad: f32,
}

/// Six perspective views around `eye` that reach every point of the scene's bounding sphere.
pub fn cube_views(eye: Vec3, scene: &SceneData, resolution: u32) -> [ShadowView; 6] {
    let (centre, radius) = scene.bounding_sphere();
    let radius = radius.max(1e-3);
    let far = (eye.distance(centre) + radius) * 1.01;
    let near = (far * 1e-5).max(1e-5);
    let projection = Mat4::perspective_rh(std::f32::consts::FRAC_PI_2, 1.0, near, far);
    CUBE_FACES.map(|(axis, up)| ShadowView {
        clip_from_world: (projection * Mat4::look_to_rh(eye, axis, up)).to_cols_array_2d(),
        origin: eye.extend(1.0).into(),
        axis: axis.extend(0.0).into(),
        near,
        far,
        texel: 2.0 / resolution as f32,
        _pad: 0.0,
    })
}

/// An orthographic view along `direction` covering the scene's bounding sphere.
pub fn directional_view(direction: Vec3, scene: &SceneData, resolution: u32) -> ShadowView {
    let (centre, radius) = scene.bounding_sphere();
    let r = radius.max(1e-3) * 1.01;
    let eye = centre - direction * 2.0 * r;
    let up = if direction.y.abs() > 0.9 {
        Vec3::Z
    } else {
        Vec3::Y
    };
    let projection = Mat4::orthographic_rh(-r, r, -r, r, r, 3.0 * r);
    ShadowView {
        clip_from_world: (projection * Mat4::look_to_rh(eye, direction, up)).to_cols_array_2d(),
        origin: direction.extend(0.0).into(),
        axis: direction.extend(0.0).into(),
        near: r,
        far: 3.0 * r,
        texel: 2.0 * r / resolution as f32,
        _pad: 0.0,
    }
}

/// The shadow views of every punctual light, in the layer order of [`GpuLight::shadow_layer`].
pub fn light_views(scene: &SceneData, resolution: u32) -> Vec<ShadowView> {
    let mut views = Vec::new();
    for light in &scene.lights {
        views.extend(views_of(light, scene, resolution));
    }
    views
}

fn views_of(light: &GpuLight, scene: &SceneData, resolution: u32) -> Vec<ShadowView> {
    match LightKind::from_u32(light.kind) {
        LightKind::Point | LightKind::Spot => {
            cube_views(Vec4::from(light.position).truncate(), scene, resolution).to_vec()
        }
        LightKind::Directional => {
            vec![directional_view(
                Vec4::from(light.direction).truncate(),
                scene,
                resolution,
            )]
        }
    }
}

/// The shadow-map array of one view and the buffer of views it is rendered from.
pub struct ShadowMaps {
    /// Whether the maps are real: only views without traced shadows need them.
    pub mapped: bool,
    /// Views of the punctual lights (more than `light_layers` past the device's layers).
    pub light_views: u32,
    pub resolution: u32,
    /// Layers of the punctual lights; the area-light cube follows them.
    pub light_layers: u32,
    pub has_area: bool,
    /// Every layer, for sampling.
    pub array_view: TextureView,
    /// One view per layer, for rendering.
    pub layer_views: Vec<TextureView>,
    /// Light views, then 6 area views per iteration slot.
    pub views: Buffer,
    /// Scene epoch whose light maps are in the texture; `None` until rendered.
    pub rendered_epoch: Option<u64>,
    /// Whether this frame's first iteration renders the light maps (after a scene change);
    /// set in prepare.
    pub render_lights: bool,
}

impl ShadowMaps {
    /// Shadow maps for `scene`'s lights when `mapped`; else a one-texel stand-in for the
    /// bindings (traced shadows read none), so that a thousand lights cost nothing here.
    pub fn new(
        device: &RenderDevice,
        scene: &SceneData,
        resolution: u32,
        iteration_slots: u32,
        mapped: bool,
    ) -> Self {
        let wanted: u32 = scene
            .lights
            .iter()
            .map(|l| LightKind::from_u32(l.kind).shadow_views())
            .sum();
        let has_area = mapped && !scene.emitters.is_empty();
        let area_layers = if has_area { 6 } else { 0 };
        // Past the device's array layers, the last lights go unshadowed (a warning says so).
        let most = device.limits().max_texture_array_layers;
        if mapped && wanted + area_layers > most {
            warn_once!(
                "bevy_rppm: {wanted} shadow-map layers are more than this GPU's {most}; \
                 the last lights cast no shadow"
            );
        }
        let light_views = if mapped { wanted } else { 0 };
        let light_layers = light_views.min(most.saturating_sub(area_layers));
        let resolution = if mapped { resolution } else { 1 };
        let layers = (light_layers + area_layers).clamp(1, most);
        let texture = device.create_texture(&TextureDescriptor {
            label: Some("rppm_shadow_maps"),
            size: Extent3d {
                width: resolution,
                height: resolution,
                depth_or_array_layers: layers,
            },
            mip_level_count: 1,
            sample_count: 1,
            dimension: TextureDimension::D2,
            format: SHADOW_FORMAT,
            usage: TextureUsages::RENDER_ATTACHMENT | TextureUsages::TEXTURE_BINDING,
            view_formats: &[],
        });
        let array_view = texture.create_view(&TextureViewDescriptor {
            dimension: Some(TextureViewDimension::D2Array),
            ..default()
        });
        let layer_views = (0..layers)
            .map(|layer| {
                texture.create_view(&TextureViewDescriptor {
                    dimension: Some(TextureViewDimension::D2),
                    base_array_layer: layer,
                    array_layer_count: Some(1),
                    ..default()
                })
            })
            .collect();
        let view_count = light_views + 6 * iteration_slots;
        let views = device.create_buffer(&BufferDescriptor {
            label: Some("rppm_shadow_views"),
            size: (view_count.max(1) as u64) * std::mem::size_of::<ShadowView>() as u64,
            usage: BufferUsages::STORAGE | BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        Self {
            resolution,
            light_layers,
            has_area,
            mapped,
            light_views,
            array_view,
            layer_views,
            views,
            rendered_epoch: None,
            render_lights: false,
        }
    }

    pub fn bytes(&self) -> u64 {
        let layers = self.layer_views.len() as u64;
        layers * (self.resolution as u64).pow(2) * 4 + self.views.size()
    }

    /// Index of the first area view of an iteration slot.
    pub fn area_view_base(&self, slot: u32) -> u32 {
        self.light_views + 6 * slot
    }

    /// Marks the light maps for rendering in this frame's first iteration if they do not
    /// hold `epoch` yet (and the frame runs an iteration).
    pub fn schedule_light_maps(&mut self, epoch: u64, iterations: u32) {
        self.render_lights = iterations > 0 && self.rendered_epoch != Some(epoch);
        if self.render_lights {
            self.rendered_epoch = Some(epoch);
        }
    }

    /// `(view, layer)` pairs an iteration slot renders: the light maps (first slot, when
    /// scheduled) and the slot's area-light cube.
    pub fn layers(&self, slot: u32) -> Vec<(u32, u32)> {
        let mut layers: Vec<(u32, u32)> = Vec::new();
        if slot == 0 && self.render_lights {
            layers.extend((0..self.light_layers).map(|l| (l, l)));
        }
        if self.has_area {
            let (views, layer) = (self.area_view_base(slot), self.light_layers);
            layers.extend((0..6).map(|f| (views + f, layer + f)));
        }
        layers
    }

    pub fn write_light_views(&self, queue: &RenderQueue, scene: &SceneData) {
        let views = light_views(scene, self.resolution);
        if self.mapped && !views.is_empty() {
            queue.write_buffer(&self.views, 0, bytemuck::cast_slice(&views));
        }
    }

    pub fn write_area_views(&self, queue: &RenderQueue, slot: u32, views: &[ShadowView; 6]) {
        let offset = self.area_view_base(slot) as u64 * std::mem::size_of::<ShadowView>() as u64;
        queue.write_buffer(&self.views, offset, bytemuck::cast_slice(views));
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn cube_faces_cover_their_axis() {
        let scene = SceneData {
            bounds: (Vec3::splat(-1.0), Vec3::splat(1.0)),
            ..default()
        };
        let views = cube_views(Vec3::ZERO, &scene, 64);
        for (i, (axis, _)) in CUBE_FACES.iter().enumerate() {
            let m = Mat4::from_cols_array_2d(&views[i].clip_from_world);
            let clip = m * (*axis * 0.5).extend(1.0);
            let ndc = clip.truncate() / clip.w;
            assert!(ndc.x.abs() < 1e-4 && ndc.y.abs() < 1e-4 && (0.0..1.0).contains(&ndc.z));
        }
    }
}
