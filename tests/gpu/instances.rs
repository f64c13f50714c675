//! The scene kept on the GPU: a moved object sends its instance to the GPU, not the scene's
//! triangles, and renders as if it had always stood where it moved to.

use bevy_rppm_cli::image_io::relmse;

use super::util::*;

/// `lit_plane`'s floor and light, a grey 1 m square hanging at (`x`, 1, 0) and a dense sphere
/// (about 10⁵ triangles) on the floor. Returns the camera and the square. Discs of 4 pixels:
/// the default's share of 262 144 photons is 0.75 pixels at 32², which `Auto`'s first counts
/// (16 384–65 536) leave too noisy for four iterations (moved against placed 0.0124).
fn scene(x: f32) -> (App, Entity, Entity) {
    let mut app = gpu_app();
    let (camera, _) = lit_plane(&mut app, 1000.0, 2.0, 32);
    app.world_mut()
        .get_mut::<PhotonMapping>(camera)
        .unwrap()
        .initial_radius = InitialRadius::Pixels(4.0);
    let grey = StandardMaterial {
        base_color: Color::srgb(0.3, 0.3, 0.3),
        perceptual_roughness: 1.0,
        reflectance: 0.0,
        ..default()
    };
    let square = spawn_occluder(&mut app, 0.5, 1.0, grey);
    let world = app.world_mut();
    world.get_mut::<Transform>(square).unwrap().translation.x = x;
    let material = matte(&mut world.resource_mut::<Assets<StandardMaterial>>(), 0.6);
    let sphere = Sphere::new(0.3).mesh().uv(320, 160);
    spawn_mesh(world, sphere, material, Transform::from_xyz(-1.2, 0.3, 1.2));
    (app, camera, square)
}

fn stats(app: &App, camera: Entity) -> bevy_rppm::ViewStats {
    app.world().resource::<RppmStats>().views[&camera].clone()
}

/// The estimate after `n` iterations of a scene change newer than `epoch`.
fn estimate_since(app: &mut App, camera: Entity, epoch: u64, n: u32) -> RgbImage {
    for _ in 0..100 {
        app.update();
        let image = radiance(app, camera);
        if image.epoch > epoch && image.iteration >= n {
            assert_finite(&image, "moved");
            return RgbImage::from_rgba(image.width, image.height, &image.pixels);
        }
    }
    panic!("no estimate of {n} iterations after the move in 100 frames");
}

#[test]
fn a_moved_object_sends_its_instance_and_renders_where_it_moved() {
    let (mut app, camera, square) = scene(0.0);
    app.update();
    let cold_ms = app.world().resource::<RppmScene>().extract_ms;
    let before = estimate_after(&mut app, camera, 4, "before the move");
    let first = stats(&app, camera);
    let geometry = first.scene_geometry_bytes;
    assert!(geometry >= 100_000 * 52, "{geometry} bytes of triangles");
    // The first upload is the whole scene.
    assert!(first.scene_upload_bytes > geometry, "{first:?}");
    let mut epoch = radiance(&app, camera).epoch;
    for step in 1..=3 {
        epoch = radiance(&app, camera).epoch;
        let mut transform = app.world_mut().get_mut::<Transform>(square).unwrap();
        transform.translation.x = 0.1 * step as f32;
        app.update();
    }
    let moved = estimate_since(&mut app, camera, epoch, 4);
    let last = stats(&app, camera);
    println!(
        "moving one square among {} bytes of triangles: {} bytes sent, extraction {:.2} ms \
         (the first, which made the meshes: {cold_ms:.1} ms); the BVH: {} bytes, {:.1} ms",
        last.scene_geometry_bytes,
        last.scene_upload_bytes,
        last.scene_extract_ms,
        last.bvh_upload_bytes,
        last.bvh_build_ms
    );
    // The default tracer on a software adapter, the BVH, is refitted where the square moved:
    // a few nodes are sent (none where its leaf's box held it), not the hierarchy.
    let software =
        bevy_rppm_cli::headless::software_adapter().unwrap_or_else(|hint| panic!("{hint}"));
    assert_eq!(last.memory.contains_key("bvh"), software, "{last:?}");
    assert!(last.bvh_upload_bytes * 100 < geometry, "{last:?}");
    assert_eq!(last.scene_geometry_bytes, geometry);
    assert!(
        last.scene_upload_bytes * 100 < geometry && last.scene_upload_bytes > 0,
        "{} bytes sent for one moved square",
        last.scene_upload_bytes
    );
    let (mut fresh_app, fresh_camera, _) = scene(0.3);
    let fresh = estimate_after(&mut fresh_app, fresh_camera, 4, "placed there");
    let error = relmse(&moved, &fresh).unwrap();
    let stale = relmse(&before, &fresh).unwrap();
    println!(
        "relMSE against the square placed there: moved {error:.5}, before the move {stale:.5}"
    );
    assert!(error < 0.01, "moved against placed: {error}");
    assert!(stale > 10.0 * error.max(1e-4), "before the move: {stale}");
}

/// Under `RppmTracer::Bvh` a moved object rebuilds the hierarchy: its shadow follows it, and
/// the image is the one of the object placed there from the start.
#[test]
fn the_bvh_follows_a_moved_object() {
    let bvh_scene = |x: f32| {
        let mut app = gpu_app();
        let (camera, _) = lit_plane(&mut app, 1000.0, 2.0, 32);
        let square = spawn_occluder(&mut app, 0.5, 1.0, StandardMaterial::default());
        let world = app.world_mut();
        world.get_mut::<Transform>(square).unwrap().translation.x = x;
        world.get_mut::<PhotonMapping>(camera).unwrap().tracer = bevy_rppm::RppmTracer::Bvh;
        (app, camera, square)
    };
    let (mut app, camera, square) = bvh_scene(0.0);
    let before = estimate_after(&mut app, camera, 4, "before the move");
    let epoch = radiance(&app, camera).epoch;
    app.world_mut()
        .get_mut::<Transform>(square)
        .unwrap()
        .translation
        .x = 0.6;
    app.update();
    let moved = estimate_since(&mut app, camera, epoch, 4);
    let (mut fresh_app, fresh_camera, _) = bvh_scene(0.6);
    let fresh = estimate_after(&mut fresh_app, fresh_camera, 4, "placed there");
    let error = relmse(&moved, &fresh).unwrap();
    let stale = relmse(&before, &fresh).unwrap();
    println!("BVH, relMSE against the square placed there: moved {error:.5}, before {stale:.5}");
    assert!(error < 0.01, "moved against placed: {error}");
    assert!(stale > 10.0 * error.max(1e-4), "before the move: {stale}");
}
