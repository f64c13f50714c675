//! Temporal reuse (`RppmHistory::Reuse`): a still scene converges as with `Reset`, a moving
//! camera keeps its history where it reprojects, and a moved object leaves no ghost.

use bevy_rppm::RppmHistory;
use std::path::Path;

use bevy_rppm_cli::image_io::relmse;
use bevy_rppm_cli::motion::{MotionRequest, MotionRow, Script, bench_motion};

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
/// 144 bytes.
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

/// How `motion_means` runs a bench: `frames` frames, every `every`-th measured against its
/// frozen state converged over `reference` iterations, `per_frame` iterations a frame, `Reuse`
/// with `window`, 16 384 photons an iteration.
struct Run {
    frames: u32,
    every: u32,
    reference: u32,
    per_frame: u32,
    window: u32,
}

impl Run {
    /// `frames` frames of one iteration, every 4th measured, window 8.
    fn frames(frames: u32, reference: u32) -> Self {
        Self {
            frames,
            every: 4,
            reference,
            per_frame: 1,
            window: 8,
        }
    }
}

/// Mean relMSE of `Reset` and `Reuse` over a run of `script` on `scene` at `size`².
fn motion_means(scene: &str, script: Script, size: u32, run: Run) -> (f64, f64) {
    let request = MotionRequest {
        scene: Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("assets")
            .join(scene),
        script,
        frames: run.frames,
        every: run.every,
        width: size,
        height: size,
        settings: PhotonMapping {
            photons_per_iteration: PhotonCount::Fixed(16_384),
            iterations_per_frame: bevy_rppm::IterationsPerFrame::Fixed(run.per_frame),
            ..default()
        },
        window: run.window,
        reference_iterations: run.reference,
    };
    let result = bench_motion(&request, |_| {}).unwrap();
    let measured = run.frames / run.every;
    assert_eq!(result.rows.len() as u32, measured);
    let mean = |f: fn(&MotionRow) -> f64| result.rows.iter().map(f).sum::<f64>() / measured as f64;
    let (reset, reuse) = (mean(|r| r.reset), mean(|r| r.reuse));
    println!("{scene}: mean relMSE Reset {reset:.5}, Reuse {reuse:.5}");
    (reset, reuse)
}

/// A light that swings across the Cornell box every frame (`rppm bench motion --script
/// light`, 16 frames of one iteration): `Reuse`'s mean relMSE against each frame's frozen
/// state converged is at least 1.5× below `Reset`'s, which starts again each frame. Each
/// pixel's history is clamped to its neighbourhood, not dropped where one iteration's
/// photons stray from it (1.3× before).
#[test]
fn a_moving_light_keeps_the_indirect_history() {
    let (reset, reuse) = motion_means("cornell_box.gltf", Script::Light, 48, Run::frames(16, 32));
    assert!(reuse * 1.5 <= reset, "Reuse {reuse} against Reset {reset}");
}

/// A camera orbiting rough metal spheres under a ceiling panel (`suite/glossy_metal`, 8
/// frames at 48²): `Reuse` is at least 1.2× below `Reset` (1.5× measured). Glossy metal's
/// reprojected history (its highlights where the last view saw them) is dropped, and an
/// emitter's rim is no history of the wall beside it; before, both ghosted and `Reuse` read
/// 0.8× of `Reset` (0.0625 against 0.0518).
#[test]
fn an_orbit_leaves_no_highlight_behind() {
    let (reset, reuse) = motion_means(
        "suite/glossy_metal.gltf",
        Script::Orbit,
        48,
        Run::frames(8, 64),
    );
    assert!(reuse * 1.2 <= reset, "Reuse {reuse} against Reset {reset}");
}

/// A camera orbiting a pool whose floor tiles are seen through flat water (`suite/water_pool`,
/// 16 frames at 48²): `Reuse` is at least 1.4× below `Reset` (1.7× measured). What the
/// water shows is fetched where its camera paths' first diffuse point was last frame, not
/// where the water's surface was, and between pixels rather than from the nearest: before,
/// the tiles' edges dragged behind the camera and `Reuse` read 1.1× (0.0440 against 0.0505).
#[test]
fn an_orbit_over_water_keeps_the_floor_seen_through_it() {
    let (reset, reuse) = motion_means(
        "suite/water_pool.gltf",
        Script::Orbit,
        48,
        Run::frames(16, 32),
    );
    assert!(reuse * 1.4 <= reset, "Reuse {reuse} against Reset {reset}");
}

/// A camera orbiting a closed room whose sphere light hangs in view (room 0 of
/// `random_scenes.py --count 8 --seed 35`, kept in `assets/suite/random/`; 8 frames at 48²):
/// `Reuse` is at least 4× below `Reset` (11× measured). A pixel that sees the light is marked
/// as seeing an emitter, not the wall behind it, so neither keeps the other's history: before,
/// the light's history moved with the wall and left a trail of light, and `Reuse` read 0.635
/// against `Reset`'s 0.177.
#[test]
fn an_orbit_past_a_sphere_light_leaves_no_trail() {
    let (reset, reuse) = motion_means(
        "suite/random/r35_00.gltf",
        Script::Orbit,
        48,
        Run::frames(8, 32),
    );
    assert!(reuse * 4.0 <= reset, "Reuse {reuse} against Reset {reset}");
}

/// A camera orbiting a room with a fine checkered floor, lit by spot lights and the sun alone
/// (`assets/suite/random/r33_00.gltf`; 16 frames at 48²): `Reuse` is at least 1.4× below
/// `Reset` (1.8× measured). Each frame's reprojection resamples the history, which blurred
/// the checker over the window of 8 (1.1×, and 0.8× at 64²); where direct light is exact at
/// its point, a camera move keeps 3 of its samples.
#[test]
fn an_orbit_keeps_a_checkered_floor_sharp() {
    let (reset, reuse) = motion_means(
        "suite/random/r33_00.gltf",
        Script::Orbit,
        48,
        Run::frames(16, 32),
    );
    assert!(reuse * 1.4 <= reset, "Reuse {reuse} against Reset {reset}");
}

/// A camera orbiting the Cornell box past its right wall's plane, four iterations a frame
/// with a window of 32 (24 frames at 48²): `Reuse` is within 2× of `Reset` (1.4×
/// measured). With several iterations a frame the jitter crosses edges within a frame, and
/// a history of samples of two surfaces (the lit back wall and the right wall's dark outer
/// face, which unfolds as the camera passes its plane) was reprojected as the last sample's
/// surface: a trail of light three pixels wide over the outer face, 32× `Reset`'s error
/// (35× on an H100 at 96²). Such a history is no longer reprojected.
#[test]
fn an_orbit_of_several_iterations_a_frame_drags_no_edge() {
    let run = Run {
        frames: 24,
        every: 8,
        reference: 32,
        per_frame: 4,
        window: 32,
    };
    let (reset, reuse) = motion_means("cornell_box.gltf", Script::Orbit, 48, run);
    assert!(reuse <= 2.0 * reset, "Reuse {reuse} against Reset {reset}");
}

/// A measuring interval longer than the animation is a clear error, before anything renders
/// (it once left no frame measured and the plot's log axis looping without end).
#[test]
fn a_motion_bench_that_would_measure_nothing_says_so() {
    let request = MotionRequest {
        scene: Path::new(env!("CARGO_MANIFEST_DIR")).join("assets/cornell_box.gltf"),
        script: Script::Orbit,
        frames: 8,
        every: 100,
        width: 16,
        height: 16,
        settings: PhotonMapping::default(),
        window: 8,
        reference_iterations: 4,
    };
    let Err(error) = bench_motion(&request, |_| {}) else {
        panic!("a bench with no frame to measure ran");
    };
    assert!(error.contains("--every 100"), "{error}");
}
