//! The Cornell box under photon mapping, with an orbiting camera.
//! Keys: G GI on/off, M Full/Indirect mode, + / − photons per iteration, R restart; drag the
//! mouse to orbit. `--headless --frames N --out FILE.png` renders offscreen instead.
use bevy::camera::{Exposure, Hdr};
use bevy::core_pipeline::tonemapping::Tonemapping;
use bevy::input::mouse::AccumulatedMouseMotion;
use bevy::light::GlobalAmbientLight;
use bevy::prelude::*;
use bevy::world_serialization::WorldAssetRoot;
use bevy_rppm::example::{ExampleArgs, ExampleCamera, example_app};
use bevy_rppm::{PhotonMapping, RppmMode};

const KEYS: &str = "G: GI  M: Full/Indirect  +/-: photons  R: restart  drag: orbit";
const TARGET: Vec3 = Vec3::new(0.0, 1.0, 0.0);

fn main() {
    example_app("bevy_rppm: Cornell box", KEYS, ExampleArgs::from_env())
        // Photon mapping replaces ambient light; the scene's lights are a few candela.
        .insert_resource(GlobalAmbientLight::NONE)
        .add_systems(Startup, load)
        .add_systems(Update, (adopt_camera, keys, orbit))
        .run();
}

fn load(mut commands: Commands, assets: Res<AssetServer>) {
    let scene = assets.load(GltfAssetLabel::Scene(0).from_asset("cornell_box.gltf"));
    commands.spawn(WorldAssetRoot(scene));
}

/// Gives the glTF camera photon mapping once the scene has spawned it.
fn adopt_camera(
    mut commands: Commands,
    cameras: Query<Entity, (With<Camera3d>, Without<PhotonMapping>)>,
) {
    for camera in &cameras {
        commands.entity(camera).insert((
            PhotonMapping {
                photons_per_iteration: 65_536,
                ..default()
            },
            Hdr,
            // A tonemapper that needs no lookup table (the crate leaves out Bevy's LUTs).
            Tonemapping::AcesFitted,
            // Exposure 1: radiance shown as it is (Bevy: 1 / (2^ev100 · 1.2)).
            Exposure {
                ev100: -(1.2f32).log2(),
            },
            ExampleCamera,
        ));
    }
}

fn keys(keys: Res<ButtonInput<KeyCode>>, mut cameras: Query<&mut PhotonMapping>) {
    for mut gi in &mut cameras {
        if keys.just_pressed(KeyCode::KeyG) {
            gi.enabled = !gi.enabled;
        }
        if keys.just_pressed(KeyCode::KeyM) {
            gi.mode = match gi.mode {
                RppmMode::Full => RppmMode::Indirect,
                RppmMode::Indirect => RppmMode::Full,
            };
        }
        if keys.just_pressed(KeyCode::Equal) || keys.just_pressed(KeyCode::NumpadAdd) {
            gi.photons_per_iteration = (gi.photons_per_iteration * 2).min(1 << 22);
        }
        if keys.just_pressed(KeyCode::Minus) || keys.just_pressed(KeyCode::NumpadSubtract) {
            gi.photons_per_iteration = (gi.photons_per_iteration / 2).max(1024);
        }
        if keys.just_pressed(KeyCode::KeyR) {
            gi.set_changed();
        }
    }
}

fn orbit(
    buttons: Res<ButtonInput<MouseButton>>,
    motion: Res<AccumulatedMouseMotion>,
    mut cameras: Query<&mut Transform, With<ExampleCamera>>,
) {
    if !buttons.pressed(MouseButton::Left) || motion.delta == Vec2::ZERO {
        return;
    }
    for mut transform in &mut cameras {
        let yaw = Quat::from_rotation_y(-motion.delta.x * 0.005);
        transform.translation = TARGET + yaw * (transform.translation - TARGET);
        transform.look_at(TARGET, Vec3::Y);
    }
}
