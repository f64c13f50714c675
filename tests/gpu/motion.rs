//! Temporal reuse (`RppmHistory::Reuse`): a still scene converges as with `Reset`, a moving
//! camera keeps its history where it reprojects, and a moved object leaves no ghost.

use bevy_rppm::RppmHistory;
use bevy_rppm_cli::image_io::relmse;

use super::util::*;

const REUSE: RppmHistory = RppmHistory::Reuse { iterations: 8 };

/// The plane under its point light with a 1 m black occluder at (`x`, 1, 0) casting a
/// shadow, seen from above through a 32² orthographic camera at `camera_x`.
fn shadow_scene(history: RppmHistory, x: f32, camera_x: f32) -> (App, Entity, Entity) {
    let mut app = gpu_app();
    let light = point_light_above(1000.0, 2.0);
    let settings = PhotonMapping {
        history,
        photons_per_iteration: PhotonCount::Fixed(65_536),
        ..default()
    };
    let (camera, _) = plane_scene(&mut app, light, 32, settings);
    app.world_mut()
        .get_mut::<Transform>(camera)
        .unwrap()
        .translation
        .x = camera_x;
    let occluder = spawn_occluder(&mut app, 0.5, 1.0, black());
    let world = app.world_mut();
    world.get_mut::<Transform>(occluder).unwrap().translation.x = x;
    (app, camera, occluder)
}

fn image(app: &App, camera: Entity) -> RgbImage {
    let image = radiance(app, camera);
    assert_finite(&image, "motion");
    RgbImage::from_rgba(image.width, image.height, &image.pixels)
}

/// Runs frames until `n` more iterations have run since a change made now and reached the
/// read-back image (the render world sees the change a frame later, and the read-back
/// arrives a frame after that).
fn iterate(app: &mut App, camera: Entity, n: u32) {
    let target = iteration(app, camera) + n + 2;
    until_iterations(app, camera, target);
}

fn history_bytes(app: &App, camera: Entity) -> Option<u64> {
    let stats = app.world().resource::<RppmStats>();
    stats.views[&camera].memory.get("history").copied()
}

/// The history's bytes still and after a camera move.
fn history_sizes(app: &mut App, camera: Entity) -> [Option<u64>; 2] {
    let still = history_bytes(app, camera);
    let world = app.world_mut();
    world.get_mut::<Transform>(camera).unwrap().translation.x += 0.1;
    iterate(app, camera, 1);
    [still, history_bytes(app, camera)]
}

/// With nothing moving, `Reuse` gives `Reset`'s estimate (to float rounding: it sums its
/// direct and indirect means apart), and holds the history without last frame's copies (48
/// of its 112 bytes a pixel, and a 48-byte placeholder); the first move makes them. Where
/// camera paths go on past the G-buffer (a glass ball) it holds what they showed too: 64 of
/// 144 bytes; where textures or vertex colours vary albedo, that albedo as well: 80 of 176.
#[test]
fn reuse_of_a_still_scene_is_reset() {
    let pixels = 32 * 32;
    let render = |history| {
        let (mut app, camera, _) = shadow_scene(history, 0.0, 0.0);
        until_iterations(&mut app, camera, 6);
        let at = radiance(&app, camera);
        if history == REUSE {
            let sizes = history_sizes(&mut app, camera);
            let expected = [Some(48 * pixels + 48), Some(112 * pixels + 48)];
            assert_eq!(sizes, expected, "still, moved");
        } else {
            assert_eq!(history_bytes(&app, camera), None, "Reset");
        }
        (at.iteration, at.pixels)
    };
    let (reset, reuse) = (render(RppmHistory::Reset), render(REUSE));
    assert_eq!(reset.0, reuse.0, "iterations");
    let worst = reset
        .1
        .iter()
        .zip(&reuse.1)
        .flat_map(|(a, b)| (0..3).map(move |c| (a[c] - b[c]).abs() / a[c].abs().max(1e-3)))
        .fold(0.0f32, f32::max);
    assert!(worst < 1e-4, "a still scene's estimate differs by {worst}");
    let (mut app, camera, _) = shadow_scene(REUSE, 0.0, 0.0);
    spawn_glass_ball(app.world_mut());
    until_iterations(&mut app, camera, 2);
    let expected = [Some(64 * pixels + 64), Some(144 * pixels + 64)];
    assert_eq!(history_sizes(&mut app, camera), expected, "with glass");
    // Vertex colours vary a surface's albedo, which the history keeps too.
    let mut mesh = quad(0.2, Some(Indices::U32(vec![0, 1, 2, 0, 2, 3])), true);
    mesh.insert_attribute(Mesh::ATTRIBUTE_COLOR, vec![[1.0, 0.5, 0.25, 1.0]; 4]);
    let material = app
        .world_mut()
        .resource_mut::<Assets<StandardMaterial>>()
        .add(Color::WHITE);
    spawn_mesh(
        app.world_mut(),
        mesh,
        material,
        Transform::from_xyz(0.6, 0.01, 0.6),
    );
    iterate(&mut app, camera, 1);
    let expected = [Some(80 * pixels + 80), Some(176 * pixels + 80)];
    assert_eq!(
        history_sizes(&mut app, camera),
        expected,
        "textured, with glass"
    );
}

/// A camera that slides 4 pixels over 4 frames, then stops, keeps its reprojected history:
/// 16 iterations after it stopped, its error against a converged still is no worse than
/// 1.5× that of a still render of 16 iterations. Without reprojection (the history taken
/// where the pixel was), the image would be 4 pixels off (relMSE ~90).
#[test]
fn a_moving_camera_keeps_its_reprojected_history() {
    let converged = {
        let (mut app, camera, _) = shadow_scene(RppmHistory::Reset, 0.3, 0.0);
        until_iterations(&mut app, camera, 48);
        until_iterations(&mut app, camera, 96);
        image(&app, camera)
    };
    let still = {
        let (mut app, camera, _) = shadow_scene(RppmHistory::Reset, 0.3, 0.0);
        until_iterations(&mut app, camera, 16);
        relmse(&image(&app, camera), &converged).unwrap()
    };
    let moving = {
        let pixel = 4.0 / 32.0;
        let (mut app, camera, _) = shadow_scene(REUSE, 0.3, -4.0 * pixel);
        until_iterations(&mut app, camera, 8);
        for _ in 0..4 {
            app.world_mut()
                .get_mut::<Transform>(camera)
                .unwrap()
                .translation
                .x += pixel;
            iterate(&mut app, camera, 1);
        }
        iterate(&mut app, camera, 16);
        relmse(&image(&app, camera), &converged).unwrap()
    };
    println!("relMSE against 96 still iterations: still 16 {still:.5}, moved then 16 {moving:.5}");
    assert!(
        moving <= 1.5 * still,
        "moving {moving} against still {still}"
    );
}

/// An occluder that jumps 1.2 m leaves no shadow behind: 4 iterations later, the floor where
/// its shadow was is as bright as in a fresh render of the new state, and its new shadow is
/// as dark (within 5 % of the lit floor).
#[test]
fn a_moved_object_leaves_no_ghost() {
    let region = |image: &RgbImage, x: std::ops::Range<usize>| region_mean(image, 12..20, x);
    let (left, right) = (4..10, 22..28);
    let fresh = {
        let (mut app, camera, _) = shadow_scene(RppmHistory::Reset, 0.6, 0.0);
        until_iterations(&mut app, camera, 16);
        image(&app, camera)
    };
    let (mut app, camera, occluder) = shadow_scene(REUSE, -0.6, 0.0);
    until_iterations(&mut app, camera, 16);
    let before = image(&app, camera);
    assert!(
        region(&before, left.clone()) < 0.3 * region(&before, right.clone()),
        "the shadow is on the left first"
    );
    app.world_mut()
        .get_mut::<Transform>(occluder)
        .unwrap()
        .translation
        .x = 0.6;
    iterate(&mut app, camera, 4);
    let after = image(&app, camera);
    let lit = region(&fresh, left.clone());
    let (old, new) = (
        (region(&after, left.clone()) - lit) / lit,
        (region(&after, right.clone()) - region(&fresh, right)) / lit,
    );
    println!(
        "4 iterations after the move, against a fresh render, over the lit floor: \
         old shadow {old:+.4}, new shadow {new:+.4}"
    );
    assert!(old.abs() < 0.05, "ghost where the shadow was: {old}");
    assert!(new.abs() < 0.05, "the new shadow lags: {new}");
}

/// A black square's material: its edges on the lit plane are all the light it changes.
fn black() -> StandardMaterial {
    StandardMaterial {
        base_color: Color::BLACK,
        reflectance: 0.0,
        perceptual_roughness: 1.0,
        ..default()
    }
}

/// What moves, 2 cm a frame along x, round the still square of `still_square_under_motion`.
#[derive(Clone, Copy)]
enum Mover {
    /// The occluder, from x = -0.9 m.
    Occluder,
    /// The point light, from above the plane's centre.
    Light,
}

/// relMSE over the 13² pixels around a still 1.06 m square of `material` on the lit plane (off
/// the pixel grid, 8 pixels a metre, 10 pixels from the occluder's shadow), against 96
/// iterations of the final state: a still render of 16 iterations, and `Reuse` after 16
/// frames in each of which `mover` moved.
fn still_square_under_motion(material: StandardMaterial, mover: Mover) -> (f64, f64) {
    use bevy_rppm_cli::image_io::pixel_errors;
    let scene = |history| {
        let (mut app, camera, occluder) = shadow_scene(history, -0.9, 0.0);
        let square = spawn_occluder(&mut app, 0.53, 0.05, material.clone());
        app.world_mut()
            .get_mut::<Transform>(square)
            .unwrap()
            .translation = Vec3::new(0.81, 0.05, 0.27);
        (app, camera, occluder)
    };
    let error = |image: &RgbImage, truth: &RgbImage| {
        let errors = pixel_errors(image, truth).unwrap();
        let window = (12..25).flat_map(|y| (16..29).map(move |x| y * image.width + x));
        window.map(|i| errors[i]).sum::<f64>() / (13.0 * 13.0)
    };
    let place = |app: &mut App, occluder: Entity, frame: u32| {
        let world = app.world_mut();
        let (moved, from) = match mover {
            Mover::Occluder => (occluder, -0.9),
            Mover::Light => {
                let mut lights = world.query_filtered::<Entity, With<PointLight>>();
                (lights.single(world).unwrap(), 0.0)
            }
        };
        world.get_mut::<Transform>(moved).unwrap().translation.x = from + 0.02 * frame as f32;
    };
    let (converged, still) = {
        let (mut app, camera, occluder) = scene(RppmHistory::Reset);
        place(&mut app, occluder, 16);
        until_iterations(&mut app, camera, 16);
        let sixteen = image(&app, camera);
        until_iterations(&mut app, camera, 96);
        let converged = image(&app, camera);
        let still = error(&sixteen, &converged);
        (converged, still)
    };
    let (mut app, camera, occluder) = scene(REUSE);
    until_iterations(&mut app, camera, 8);
    // The read-back image shows a change two frames after it is made.
    for f in 1..=18 {
        place(&mut app, occluder, f);
        app.update();
    }
    (still, error(&image(&app, camera), &converged))
}

/// An emitter's rim keeps its anti-aliasing while something else in the scene moves: after
/// 16 frames in each of which an occluder moved, the error over the emitter and its rim is
/// within 2× that of a still render of 16 iterations. Direct light that started again at
/// every change showed one jittered sample of the rim a frame, each rim pixel all lit or
/// all dark (relMSE 0.075 against the still 0.0020; 0.0007 now).
#[test]
fn an_emitters_rim_stays_smooth_while_the_scene_moves() {
    let (still, moving) = still_square_under_motion(
        StandardMaterial {
            base_color: Color::BLACK,
            emissive: LinearRgba::rgb(20.0, 20.0, 20.0),
            reflectance: 0.0,
            perceptual_roughness: 1.0,
            ..default()
        },
        Mover::Occluder,
    );
    println!("relMSE over the emitter: still 16 iterations {still:.5}, moving {moving:.5}");
    assert!(
        moving <= 2.0 * still,
        "moving {moving} against still {still}"
    );
}

/// A still object's silhouette stays anti-aliased while another object moves and no light
/// changes: its edge pixels keep averaging what their jitter sees (a black square), within 3×
/// the error of a still render of 16 iterations (the window keeps 8; 0.0031 against 0.0016
/// measured). Before, every scene change started their direct light again from one jittered
/// sample, and the edges flickered between the plane and the square (0.118).
#[test]
fn a_still_objects_edges_stay_smooth_while_another_moves() {
    let (still, moving) = still_square_under_motion(black(), Mover::Occluder);
    println!("relMSE over the still square: still 16 iterations {still:.5}, moving {moving:.5}");
    assert!(
        moving <= 3.0 * still,
        "moving {moving} against still {still}"
    );
}

/// The same silhouette while the light moves: the lit plane's direct light starts again each
/// frame (shadows follow at once), but the edge pixels, whose jitter crosses the silhouette,
/// keep a short clamped history of it: within 6× the still render's error (0.054 against
/// 0.0119 measured; the still render's 16 jittered samples cover an edge pixel better than
/// a short history does). Before, they showed one jittered sample a frame (0.143), and the
/// square, 5 cm above the plane, was no other surface than the plane to them (0.157 with
/// the short history alone).
#[test]
fn a_still_objects_edges_stay_smooth_while_the_light_moves() {
    let (still, moving) = still_square_under_motion(black(), Mover::Light);
    println!(
        "relMSE over the still square: still 16 iterations {still:.5}, light moving {moving:.5}"
    );
    assert!(
        moving <= 6.0 * still,
        "moving {moving} against still {still}"
    );
}
