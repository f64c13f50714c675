//! The sky (`RppmSky`): under a uniform sky, white Lambertian surfaces shine with the sky's
//! radiance everywhere, concave corners included (a white furnace: direct sky light, photons
//! from the sky and their bounces must add up exactly), a grey floor reflects albedo × sky,
//! and a pixel that sees nothing shows the sky.

use bevy_rppm::RppmSky;

use super::util::*;

/// `plane_scene`'s floor with a 1 m cube on it, every surface of `albedo`, under a sky of
/// radiance 2; the camera sees the floor, the cube's top and the corners between them.
fn sky_scene(albedo: f32, size: u32) -> (App, Entity) {
    let mut app = gpu_app();
    let settings = PhotonMapping {
        max_photon_depth: 12,
        photons_per_iteration: PhotonCount::Fixed(65_536),
        // 1/8 m at 32²: the gather disc of a floor point by the cube stays mostly on the
        // floor (a wider one reaches under the cube, where no photon lands, and darkens it).
        initial_radius: InitialRadius::Pixels(1.0),
        ..default()
    };
    let (camera, plane) = plane_scene(&mut app, (), size, settings);
    let world = app.world_mut();
    let material = matte(
        &mut world.resource_mut::<Assets<StandardMaterial>>(),
        albedo,
    );
    world
        .entity_mut(plane)
        .insert(MeshMaterial3d(material.clone()));
    let cube = Cuboid::new(1.0, 1.0, 1.0);
    spawn_mesh(world, cube, material, Transform::from_xyz(0.5, 0.5, 0.0));
    world.insert_resource(RppmSky {
        color: Color::WHITE,
        radiance: 2.0,
    });
    (app, camera)
}

#[test]
fn a_white_scene_under_a_uniform_sky_is_a_furnace() {
    let (mut app, camera) = sky_scene(1.0, 32);
    let image = estimate_after(&mut app, camera, 64, "furnace");
    let stats = app.world().resource::<RppmStats>().views[&camera].clone();
    assert!(stats.shader_paths.iter().any(|p| p == "SKY"), "{stats:?}");
    let mean = region_mean(&image, 0..32, 0..32);
    // The floor along the cube's −X side (x −0.5..0 m, 8 pixels a metre): concave, light
    // bounces between the two.
    let corner = region_mean(&image, 12..20, 12..16);
    println!("furnace: mean {mean:.4}, by the cube's side {corner:.4} (the sky: 2)");
    assert!((mean / 2.0 - 1.0).abs() < 0.02, "mean {mean}");
    // The pixel column touching the cube keeps some boundary bias (its gather disc reaches
    // under the cube), which shrinks with the radius.
    assert!((corner / 2.0 - 1.0).abs() < 0.05, "by the cube {corner}");
}

#[test]
fn a_grey_floor_reflects_albedo_times_the_sky() {
    let (mut app, camera) = sky_scene(0.5, 16);
    // Far from the cube the floor sees the whole sky: 0.5 × 2 = 1, up to the light the
    // cube sends back to it (about 2 % there).
    let image = estimate_after(&mut app, camera, 8, "grey floor");
    let far = region_mean(&image, 0..16, 0..4);
    println!("grey floor: {far:.4} (albedo × sky: 1)");
    assert!((far - 1.0).abs() < 0.04, "{far}");
}
