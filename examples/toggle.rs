//! The smallest game with photon mapping: a lit room, and G switches global illumination on
//! and off. `--headless --frames N --out FILE.png` renders offscreen instead of in a window.
mod common;

use bevy::prelude::*;
use bevy_rppm::PhotonMapping;
use common::{ExampleArgs, ExampleCamera, example_app};

fn main() {
    example_app("bevy_rppm: toggle", "G: GI on/off", ExampleArgs::from_env())
        .add_systems(Startup, setup)
        .add_systems(Update, toggle)
        .run();
}

fn setup(
    mut commands: Commands,
    mut meshes: ResMut<Assets<Mesh>>,
    mut materials: ResMut<Assets<StandardMaterial>>,
) {
    let floor = meshes.add(Plane3d::default().mesh().size(8.0, 8.0));
    commands.spawn((Mesh3d(floor), MeshMaterial3d(materials.add(Color::WHITE))));
    let red = materials.add(Color::srgb(0.9, 0.15, 0.1));
    let pillar = meshes.add(Cuboid::new(1.0, 2.0, 1.0));
    commands.spawn((
        Mesh3d(pillar),
        MeshMaterial3d(red),
        Transform::from_xyz(-1.0, 1.0, 0.0),
    ));
    let glass = materials.add(StandardMaterial {
        specular_transmission: 1.0,
        perceptual_roughness: 0.0,
        ior: 1.5,
        ..default()
    });
    let ball = meshes.add(Sphere::new(0.6).mesh().ico(4).unwrap());
    commands.spawn((
        Mesh3d(ball),
        MeshMaterial3d(glass),
        Transform::from_xyz(1.0, 0.6, 0.8),
    ));
    commands.spawn((PointLight::default(), Transform::from_xyz(1.5, 3.5, 2.0)));
    commands.spawn((
        Camera3d::default(),
        Transform::from_xyz(0.0, 2.5, 6.0).looking_at(Vec3::new(0.0, 0.8, 0.0), Vec3::Y),
        PhotonMapping::default(),
        // A tonemapper that needs no lookup table (the crate leaves out Bevy's LUTs).
        bevy::core_pipeline::tonemapping::Tonemapping::AcesFitted,
        ExampleCamera,
    ));
}

fn toggle(keys: Res<ButtonInput<KeyCode>>, mut cameras: Query<&mut PhotonMapping>) {
    if keys.just_pressed(KeyCode::KeyG) {
        for mut gi in &mut cameras {
            gi.enabled = !gi.enabled;
        }
    }
}
