//! A pool with an animated water surface over a tiled floor: sunlight refracted by the waves
//! makes caustics that move with the water (the RPPM paper's pool scene). The water mesh is
//! rewritten every frame through `Assets<Mesh>`; photon mapping keeps 8 iterations of its
//! caustics through the motion (`RppmHistory::Reuse`, the default).
//! Keys: G GI on/off, P pause the water (PPM then converges), O overlay.
//! `--headless --frames N --out FILE.png` renders offscreen instead; `--time T` holds the
//! water at T seconds.
mod common;

use bevy::asset::RenderAssetUsages;
use bevy::core_pipeline::tonemapping::Tonemapping;
use bevy::mesh::{Indices, PrimitiveTopology, VertexAttributeValues};
use bevy::prelude::*;
use bevy_rppm::{IterationsPerFrame, PhotonCount, PhotonMapping};
use common::{ExampleArgs, ExampleCamera, example_app};

/// Water grid cells along each side, and the pool's half width and depth in metres.
const CELLS: usize = 48;
const HALF: f32 = 2.0;
const DEPTH: f32 = 1.0;

#[derive(Resource)]
struct Water(Handle<Mesh>);

fn main() {
    example_app(
        "bevy_rppm: pool",
        "G: GI on/off  P: pause water",
        ExampleArgs::from_env(),
    )
    .add_systems(Startup, setup)
    .add_systems(Update, (waves, toggle))
    .run();
}

fn setup(
    mut commands: Commands,
    mut meshes: ResMut<Assets<Mesh>>,
    mut materials: ResMut<Assets<StandardMaterial>>,
) {
    // A floor of tiles in two colours, and four walls.
    let tile = meshes.add(Plane3d::default().mesh().size(0.5, 0.5));
    let colours = [Color::srgb(0.9, 0.92, 0.95), Color::srgb(0.25, 0.55, 0.85)];
    let tiles = colours.map(|c| materials.add(StandardMaterial::from(c)));
    for i in 0..8 {
        for j in 0..8 {
            let at = Vec3::new(
                -HALF + 0.25 + 0.5 * i as f32,
                -DEPTH,
                -HALF + 0.25 + 0.5 * j as f32,
            );
            let material = tiles[(i + j) % 2].clone();
            commands.spawn((
                Mesh3d(tile.clone()),
                MeshMaterial3d(material),
                Transform::from_translation(at),
            ));
        }
    }
    let wall = meshes.add(Cuboid::new(2.0 * HALF, DEPTH, 0.1));
    for k in 0..4 {
        let angle = k as f32 * std::f32::consts::FRAC_PI_2;
        let at = Quat::from_rotation_y(angle) * Vec3::new(0.0, -DEPTH / 2.0, HALF + 0.05);
        commands.spawn((
            Mesh3d(wall.clone()),
            MeshMaterial3d(tiles[1].clone()),
            Transform::from_translation(at).with_rotation(Quat::from_rotation_y(angle)),
        ));
    }
    let water = meshes.add(water_mesh(0.0));
    commands.insert_resource(Water(water.clone()));
    let glass = materials.add(StandardMaterial {
        specular_transmission: 1.0,
        perceptual_roughness: 0.0,
        ior: 1.33,
        ..default()
    });
    commands.spawn((Mesh3d(water), MeshMaterial3d(glass)));
    commands.spawn((
        DirectionalLight {
            illuminance: 3000.0,
            ..default()
        },
        Transform::default().looking_to(Vec3::new(0.3, -1.0, 0.2), Vec3::Y),
    ));
    commands.spawn((
        Camera3d::default(),
        Transform::from_xyz(0.0, 3.2, 4.2).looking_at(Vec3::new(0.0, -DEPTH, 0.0), Vec3::Y),
        PhotonMapping {
            photons_per_iteration: PhotonCount::Fixed(131_072),
            // A game's GI budget: as many iterations a frame as fit 12 GPU ms (one on a CPU).
            iterations_per_frame: IterationsPerFrame::GpuMilliseconds {
                milliseconds: 12.0,
                max: 8,
            },
            ..default()
        },
        // A tonemapper that needs no lookup table (the crate leaves out Bevy's LUTs).
        Tonemapping::AcesFitted,
        ExampleCamera,
    ));
}

fn height(x: f32, z: f32, t: f32) -> f32 {
    0.04 * (2.1 * x + 1.3 * t).sin()
        + 0.03 * (2.7 * z - 0.9 * t).sin()
        + 0.02 * (1.7 * (x + z) + 2.0 * t).sin()
}

/// The water surface at time t: a grid over the pool, indexed, with smooth normals.
fn water_mesh(t: f32) -> Mesh {
    let n = CELLS + 1;
    let step = 2.0 * HALF / CELLS as f32;
    let positions: Vec<[f32; 3]> = (0..n * n)
        .map(|k| {
            let (x, z) = (-HALF + step * (k % n) as f32, -HALF + step * (k / n) as f32);
            [x, height(x, z, t), z]
        })
        .collect();
    let mut indices = Vec::with_capacity(CELLS * CELLS * 6);
    for j in 0..CELLS {
        for i in 0..CELLS {
            let a = (j * n + i) as u32;
            let (b, c, d) = (a + 1, a + n as u32, a + n as u32 + 1);
            indices.extend([a, c, b, b, c, d]);
        }
    }
    Mesh::new(
        PrimitiveTopology::TriangleList,
        RenderAssetUsages::default(),
    )
    .with_inserted_attribute(Mesh::ATTRIBUTE_POSITION, positions)
    .with_inserted_indices(Indices::U32(indices))
    .with_computed_smooth_normals()
}

/// Moves the waves one thirtieth of a second per frame (deterministic, headless or not),
/// unless paused (P) or held at `--time`; an unchanged surface is left alone, so photon
/// mapping accumulates.
fn waves(
    args: Res<ExampleArgs>,
    keys: Res<ButtonInput<KeyCode>>,
    water: Res<Water>,
    mut meshes: ResMut<Assets<Mesh>>,
    mut clock: Local<Option<f32>>,
    mut paused: Local<bool>,
) {
    if keys.just_pressed(KeyCode::KeyP) {
        *paused = !*paused;
    }
    let t = match (args.time, *clock) {
        (Some(held), _) => held,
        (None, Some(t)) if *paused => t,
        (None, t) => t.unwrap_or(0.0) + 1.0 / 30.0,
    };
    if *clock == Some(t) {
        return;
    }
    *clock = Some(t);
    let Some(mut mesh) = meshes.get_mut(&water.0) else {
        return;
    };
    if let Some(VertexAttributeValues::Float32x3(positions)) =
        mesh.attribute_mut(Mesh::ATTRIBUTE_POSITION)
    {
        for p in positions.iter_mut() {
            p[1] = height(p[0], p[2], t);
        }
    }
    mesh.compute_smooth_normals();
}

fn toggle(keys: Res<ButtonInput<KeyCode>>, mut cameras: Query<&mut PhotonMapping>) {
    if keys.just_pressed(KeyCode::KeyG) {
        for mut gi in &mut cameras {
            gi.enabled = !gi.enabled;
        }
    }
}
