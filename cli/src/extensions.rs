//! What a scene file says that Bevy's glTF loader does not read: a uniform sky and sphere
//! lights (our extras, which `tools/reference.py` reads too) and
//! `KHR_materials_diffuse_transmission`. Read from the JSON while it is checked
//! (`validate::check_gltf`), applied to the loaded world by [`apply`].

use bevy::gltf::{GltfAssetLabel, GltfExtras};
use bevy::prelude::*;
use serde_json::Value;

/// What the file says beyond Bevy's loader.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct SceneExtras {
    /// The default scene's `extras.rppm_sky` (`scenes[scene]`, the first where the file names
    /// none): the linear RGB radiance of a uniform sky
    /// (W·sr⁻¹·m⁻²; `bevy_rppm::RppmSky`).
    pub sky: Option<[f32; 3]>,
    /// Per glTF material index, its `KHR_materials_diffuse_transmission` factor (0..=1):
    /// `StandardMaterial::diffuse_transmission`.
    pub diffuse_transmission: Vec<(usize, f32)>,
}

pub(crate) fn scene_extras(root: &Value) -> Result<SceneExtras, String> {
    light_radii(root)?;
    Ok(SceneExtras {
        sky: sky(root)?,
        diffuse_transmission: diffuse_transmission(root)?,
    })
}

fn sky(root: &Value) -> Result<Option<[f32; 3]>, String> {
    let scene = root["scene"].as_u64().unwrap_or(0);
    let sky = &root["scenes"][scene as usize]["extras"]["rppm_sky"];
    if sky.is_null() {
        return Ok(None);
    }
    let rgb: Option<Vec<f32>> = sky.as_array().and_then(|a| {
        a.iter()
            .map(|v| v.as_f64().map(|v| v as f32).filter(|v| *v >= 0.0))
            .collect()
    });
    match rgb.as_deref() {
        Some(&[r, g, b]) => Ok(Some([r, g, b])),
        _ => Err(format!(
            "scenes[{scene}].extras.rppm_sky: expected three non-negative numbers"
        )),
    }
}

/// A light's `extras.rppm_radius` (m, `PointLight::radius` and `SpotLight::radius`: a sphere
/// light, which glTF cannot say), where given, is a non-negative number.
fn light_radii(root: &Value) -> Result<(), String> {
    let lights = &root["extensions"]["KHR_lights_punctual"]["lights"];
    for (i, light) in lights.as_array().into_iter().flatten().enumerate() {
        let radius = &light["extras"]["rppm_radius"];
        if !radius.is_null() && radius.as_f64().is_none_or(|r| r < 0.0) {
            return Err(format!(
                "extensions.KHR_lights_punctual.lights[{i}].extras.rppm_radius: expected a non-negative number"
            ));
        }
    }
    Ok(())
}

/// `KHR_materials_diffuse_transmission`: its factor, a number in 0..=1 (default 0). Its
/// colour and textures are left out (Bevy's transmitted light has the base colour).
fn diffuse_transmission(root: &Value) -> Result<Vec<(usize, f32)>, String> {
    let mut found = Vec::new();
    for (i, material) in root["materials"]
        .as_array()
        .into_iter()
        .flatten()
        .enumerate()
    {
        let extension = &material["extensions"]["KHR_materials_diffuse_transmission"];
        if extension.is_null() {
            continue;
        }
        let factor = &extension["diffuseTransmissionFactor"];
        let value = if factor.is_null() {
            0.0
        } else {
            factor
                .as_f64()
                .filter(|v| (0.0..=1.0).contains(v))
                .ok_or_else(|| {
                    format!(
                        "materials[{i}].extensions.KHR_materials_diffuse_transmission.diffuseTransmissionFactor: expected a number in 0..=1"
                    )
                })?
        };
        if !extension["diffuseTransmissionColorFactor"].is_null()
            || !extension["diffuseTransmissionTexture"].is_null()
        {
            warn!(
                "materials[{i}]: the diffuse transmission colour and textures are left out (the base colour is transmitted)"
            );
        }
        found.push((i, value as f32));
    }
    Ok(found)
}

/// Gives the loaded scene what [`SceneExtras`] says: sphere lights and the materials'
/// diffuse transmission (`file` is the scene's asset path).
pub fn apply(world: &mut World, file: &str, extras: &SceneExtras) {
    sphere_lights(world);
    for &(index, factor) in &extras.diffuse_transmission {
        for is_scale_inverted in [false, true] {
            let label = GltfAssetLabel::Material {
                index,
                is_scale_inverted,
            };
            // Bevy's PBR glTF handler adds each material's StandardMaterial as "<label>/std".
            let path = format!("{file}#{label}/std");
            let handle = world
                .resource::<AssetServer>()
                .get_handle::<StandardMaterial>(path);
            if let Some(handle) = handle
                && let Some(mut material) = world
                    .resource_mut::<Assets<StandardMaterial>>()
                    .get_mut(&handle)
            {
                material.diffuse_transmission = factor;
            }
        }
    }
}

/// Point and spot lights whose glTF extras give `rppm_radius` (checked by `light_radii`)
/// become sphere lights of that radius.
fn sphere_lights(world: &mut World) {
    let mut lights =
        world.query::<(&GltfExtras, Option<&mut PointLight>, Option<&mut SpotLight>)>();
    for (extras, point, spot) in lights.iter_mut(world) {
        let value: serde_json::Value = serde_json::from_str(&extras.value).unwrap_or_default();
        let Some(radius) = value["rppm_radius"].as_f64().map(|r| r.max(0.0) as f32) else {
            continue;
        };
        if let Some(mut point) = point {
            point.radius = radius;
        }
        if let Some(mut spot) = spot {
            spot.radius = radius;
        }
    }
}
