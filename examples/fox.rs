//! A skinned, textured character with GI: Bevy's animated fox (`assets/fox/Fox.glb`) walks in
//! a corner of a red and a white wall under the sun, which bounce light onto its fur. Its
//! skin is posed by the animation every frame; the default `RppmHistory::Reuse` keeps the
//! estimate through the walk (the fox's own pixels start again each frame, the walls keep
//! theirs). Keys: G GI on/off, P pause the animation (PPM then converges), O overlay.
//! `--headless --frames N --out FILE.png` renders offscreen instead; `--time T` holds the
//! walk at T seconds.
mod common;

use std::f32::consts::FRAC_PI_2;

use bevy::animation::graph::AnimationGraphHandle;
use bevy::core_pipeline::tonemapping::Tonemapping;
use bevy::light::GlobalAmbientLight;
use bevy::prelude::*;
use bevy::world_serialization::{WorldAssetRoot, WorldInstanceReady};
use bevy_rppm::{PhotonCount, PhotonMapping};
use common::{ExampleArgs, ExampleCamera, example_app};

const FOX: &str = "fox/Fox.glb";
/// The fox's animations: 0 Survey, 1 Walk, 2 Run.
const WALK: usize = 1;

/// The graph and node the fox plays once its scene has spawned.
#[derive(Component)]
struct Walk {
    graph: Handle<AnimationGraph>,
    node: AnimationNodeIndex,
}

fn main() {
    example_app(
        "bevy_rppm: fox",
        "G: GI on/off  P: pause the walk",
        ExampleArgs::from_env(),
    )
    // Photon mapping replaces ambient light.
    .insert_resource(GlobalAmbientLight::NONE)
    .add_systems(Startup, setup)
    .add_systems(Update, keys)
    .run();
}

fn setup(
    mut commands: Commands,
    assets: Res<AssetServer>,
    mut graphs: ResMut<Assets<AnimationGraph>>,
    mut meshes: ResMut<Assets<Mesh>>,
    mut materials: ResMut<Assets<StandardMaterial>>,
) {
    let (graph, node) =
        AnimationGraph::from_clip(assets.load(GltfAssetLabel::Animation(WALK).from_asset(FOX)));
    commands
        .spawn((
            WorldAssetRoot(assets.load(GltfAssetLabel::Scene(0).from_asset(FOX))),
            // The fox is modelled in centimetres.
            Transform::from_scale(Vec3::splat(0.01)).with_rotation(Quat::from_rotation_y(0.6)),
            Walk {
                graph: graphs.add(graph),
                node,
            },
        ))
        .observe(play_when_ready);
    let floor = meshes.add(Plane3d::default().mesh().size(4.0, 4.0));
    let wall = meshes.add(Cuboid::new(4.0, 2.0, 0.05));
    let white = materials.add(Color::srgb(0.8, 0.8, 0.8));
    let red = materials.add(Color::srgb(0.8, 0.15, 0.1));
    commands.spawn((Mesh3d(floor), MeshMaterial3d(white.clone())));
    commands.spawn((
        Mesh3d(wall.clone()),
        MeshMaterial3d(white),
        Transform::from_xyz(0.0, 1.0, -1.0),
    ));
    commands.spawn((
        Mesh3d(wall),
        MeshMaterial3d(red),
        Transform::from_xyz(-1.0, 1.0, 0.0).with_rotation(Quat::from_rotation_y(FRAC_PI_2)),
    ));
    commands.spawn((
        DirectionalLight {
            illuminance: 3000.0,
            ..default()
        },
        Transform::default().looking_to(Vec3::new(0.5, -1.0, -0.4), Vec3::Y),
    ));
    commands.spawn((
        Camera3d::default(),
        Transform::from_xyz(1.4, 1.0, 2.0).looking_at(Vec3::new(-0.2, 0.35, -0.2), Vec3::Y),
        PhotonMapping {
            photons_per_iteration: PhotonCount::Fixed(131_072),
            ..default()
        },
        // A tonemapper that needs no lookup table (the crate leaves out Bevy's LUTs).
        Tonemapping::AcesFitted,
        ExampleCamera,
    ));
}

/// Plays the walk on the scene's animation player, or holds it at `--time`.
fn play_when_ready(
    ready: On<WorldInstanceReady>,
    mut commands: Commands,
    args: Res<ExampleArgs>,
    walks: Query<&Walk>,
    children: Query<&Children>,
    mut players: Query<&mut AnimationPlayer>,
) {
    let Ok(walk) = walks.get(ready.entity) else {
        return;
    };
    for child in children.iter_descendants(ready.entity) {
        if let Ok(mut player) = players.get_mut(child) {
            let active = player.play(walk.node).repeat();
            if let Some(t) = args.time {
                active.seek_to(t).pause();
            }
            commands
                .entity(child)
                .insert(AnimationGraphHandle(walk.graph.clone()));
        }
    }
}

/// G: GI on/off; P: pause or resume the walk.
fn keys(
    keys: Res<ButtonInput<KeyCode>>,
    mut cameras: Query<&mut PhotonMapping>,
    mut players: Query<&mut AnimationPlayer>,
) {
    if keys.just_pressed(KeyCode::KeyG) {
        for mut gi in &mut cameras {
            gi.enabled = !gi.enabled;
        }
    }
    if keys.just_pressed(KeyCode::KeyP) {
        for mut player in &mut players {
            if player.all_paused() {
                player.resume_all();
            } else {
                player.pause_all();
            }
        }
    }
}
