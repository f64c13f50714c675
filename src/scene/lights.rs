//! Bevy's punctual lights to the radiometric light table, and our sky ([`RppmSky`]).

use std::f32::consts::PI;

use bevy::ecs::system::SystemParam;
use bevy::prelude::*;

use super::{GpuLight, SceneData, luminance};

/// Light kinds, as stored in [`GpuLight::kind`].
#[repr(u32)]
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum LightKind {
    Point = 0,
    Spot = 1,
    Directional = 2,
}

impl LightKind {
    /// Shadow views the light needs: a cube for point and spot, one map for directional.
    pub fn shadow_views(self) -> u32 {
        match self {
            LightKind::Point | LightKind::Spot => 6,
            LightKind::Directional => 1,
        }
    }

    pub fn from_u32(kind: u32) -> Self {
        match kind {
            0 => LightKind::Point,
            1 => LightKind::Spot,
            _ => LightKind::Directional,
        }
    }
}

/// A uniform sky around the whole scene: every direction that no triangle covers shows
/// `color` × `radiance`. Photons leave it toward the scene, direct light samples it (traced
/// shadows: views with a deep cubemap), and camera paths that escape the scene see it, so an
/// outdoor scene gets its sky light and GI. Insert it as a resource; without one there is no
/// sky (the default) and no sky code runs.
#[derive(Resource, Clone, Copy, Debug, PartialEq, Reflect)]
#[reflect(Resource, Debug)]
pub struct RppmSky {
    /// Linear colour, multiplied by `radiance`.
    pub color: Color,
    /// Radiance, W·sr⁻¹·m⁻² (photometric numbers taken as radiometric, as for the lights), at
    /// least 0; a non-finite value is no sky. Default 1.
    pub radiance: f32,
}

impl Default for RppmSky {
    fn default() -> Self {
        Self {
            color: Color::WHITE,
            radiance: 1.0,
        }
    }
}

impl RppmSky {
    /// Linear RGB radiance; zero when unset, negative or not finite.
    pub fn rgb(&self) -> [f32; 3] {
        let c = rgb(self.color).map(|v| v * self.radiance);
        if c.iter().all(|v| v.is_finite()) {
            c.map(|v| v.max(0.0))
        } else {
            [0.0; 3]
        }
    }
}

#[derive(SystemParam)]
pub(crate) struct LightQueries<'w, 's> {
    sky: Option<Res<'w, RppmSky>>,
    /// The sky last extracted, so that removing it counts as a change.
    had_sky: Local<'s, bool>,
    points: Query<
        'w,
        's,
        (
            &'static PointLight,
            &'static GlobalTransform,
            Option<&'static InheritedVisibility>,
        ),
    >,
    spots: Query<
        'w,
        's,
        (
            &'static SpotLight,
            &'static GlobalTransform,
            Option<&'static InheritedVisibility>,
        ),
    >,
    directionals: Query<
        'w,
        's,
        (
            &'static DirectionalLight,
            &'static GlobalTransform,
            Option<&'static InheritedVisibility>,
        ),
    >,
}

impl SceneData {
    /// Whether a point or spot light has a radius (a sphere that camera paths can meet).
    pub fn has_sphere_lights(&self) -> bool {
        (self.lights.iter()).any(|l| l.kind != LightKind::Directional as u32 && l.position[3] > 0.0)
    }
}

/// Solid-angle integral of Bevy's spot falloff a², a = saturate((cosθ − cos_o)/(cos_i − cos_o)).
pub fn spot_cone_fraction(cos_inner: f32, cos_outer: f32) -> f32 {
    2.0 * PI * ((1.0 - cos_inner) + (cos_inner - cos_outer).max(0.0) / 3.0)
}

/// A point or spot light's `radius` (m): a sphere of that size emits its power, for soft
/// shadows; negative or non-finite radii are a point.
fn sphere_radius(radius: f32) -> f32 {
    if radius.is_finite() {
        radius.max(0.0)
    } else {
        0.0
    }
}

fn visible(v: Option<&InheritedVisibility>) -> bool {
    v.is_none_or(|v| v.get())
}

fn rgb(c: Color) -> [f32; 3] {
    let l = c.to_linear();
    [l.red, l.green, l.blue]
}

fn scaled(c: [f32; 3], s: f32) -> [f32; 4] {
    [c[0] * s, c[1] * s, c[2] * s, 0.0]
}

fn finite(l: &GpuLight) -> bool {
    l.position
        .iter()
        .chain(&l.direction)
        .chain(&l.radiance)
        .all(|v| v.is_finite())
}

impl LightQueries<'_, '_> {
    /// Whether the sky was inserted, changed or removed.
    pub(crate) fn sky_changed(&mut self) -> bool {
        let has = self.sky.is_some();
        let changed = has != *self.had_sky || self.sky.as_ref().is_some_and(|s| s.is_changed());
        *self.had_sky = has;
        changed
    }
}

pub(crate) fn collect_lights(q: &LightQueries, data: &mut SceneData) {
    let mut layer = 0u32;
    let (_, radius) = data.bounding_sphere();
    if let Some(sky) = &q.sky {
        let c = sky.rgb();
        // What enters the bounding sphere: 4π directions, each across a disc πR².
        let power = luminance(c) * 4.0 * PI * PI * radius * radius;
        if power > 0.0 && power.is_finite() {
            data.sky = [c[0], c[1], c[2], power];
        }
    }
    let mut push = |mut light: GpuLight, power: f32, data: &mut SceneData| {
        light.radiance[3] = power;
        // Zero or non-finite lights emit nothing; leave them out of the table entirely.
        if power.is_nan() || power <= 0.0 || !finite(&light) {
            if power != 0.0 || !finite(&light) {
                warn_once!("bevy_rppm: a light of negative or non-finite power is left out");
            }
            return;
        }
        light.shadow_layer = layer;
        layer += LightKind::from_u32(light.kind).shadow_views();
        data.lights.push(light);
    };
    for (p, t, _) in q.points.iter().filter(|(_, _, v)| visible(*v)) {
        let c = rgb(p.color);
        let intensity = p.intensity / (4.0 * PI);
        let light = GpuLight {
            kind: LightKind::Point as u32,
            position: t.translation().extend(sphere_radius(p.radius)).into(),
            radiance: scaled(c, intensity),
            ..default()
        };
        push(light, p.intensity * luminance(c), data);
    }
    for (s, t, _) in q.spots.iter().filter(|(_, _, v)| visible(*v)) {
        let c = rgb(s.color);
        let intensity = s.intensity / (4.0 * PI);
        let (cos_inner, cos_outer) = (s.inner_angle.cos(), s.outer_angle.cos());
        let light = GpuLight {
            kind: LightKind::Spot as u32,
            cos_inner,
            cos_outer,
            position: t.translation().extend(sphere_radius(s.radius)).into(),
            direction: t.forward().as_vec3().extend(0.0).into(),
            radiance: scaled(c, intensity),
            ..default()
        };
        let power = intensity * luminance(c) * spot_cone_fraction(cos_inner, cos_outer);
        push(light, power, data);
    }
    for (d, t, _) in q.directionals.iter().filter(|(_, _, v)| visible(*v)) {
        let c = rgb(d.color);
        let light = GpuLight {
            kind: LightKind::Directional as u32,
            direction: t.forward().as_vec3().extend(0.0).into(),
            radiance: scaled(c, d.illuminance),
            ..default()
        };
        push(
            light,
            d.illuminance * luminance(c) * PI * radius * radius,
            data,
        );
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn hard_cone_fraction_is_its_solid_angle() {
        let c = 0.5f32;
        assert!((spot_cone_fraction(c, c) - 2.0 * PI * (1.0 - c)).abs() < 1e-5);
        // A full falloff from the axis to 90°: 2π ∫₀¹ c² dc = 2π/3.
        assert!((spot_cone_fraction(1.0, 0.0) - 2.0 * PI / 3.0).abs() < 1e-5);
    }
}
