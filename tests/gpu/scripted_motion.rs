//! Scripted animations as `rppm bench motion` runs them (camera orbits, a moving light):
//! `Reuse`'s mean relMSE against each measured frame's frozen state converged, beside
//! `Reset`'s.

use std::path::Path;

use bevy_rppm_cli::motion::{MotionRequest, MotionResult, MotionRow, Script, bench_motion};

use super::util::*;

/// How `motion_means` runs a bench: `frames` frames, every `every`-th measured against its
/// frozen state converged over `reference` iterations, `per_frame` iterations a frame, `Reuse`
/// with `window`, 16 384 photons an iteration, `radius` the initial radius.
struct Run {
    frames: u32,
    every: u32,
    reference: u32,
    per_frame: u32,
    window: u32,
    radius: InitialRadius,
}

impl Run {
    /// `frames` frames of one iteration, every 4th measured, window 8, the default radius.
    fn frames(frames: u32, reference: u32) -> Self {
        Self {
            frames,
            every: 4,
            reference,
            per_frame: 1,
            window: 8,
            radius: InitialRadius::default(),
        }
    }
}

/// The bench's run of `script` on `scene` at `size`².
fn motion(scene: &str, script: Script, size: u32, run: &Run) -> MotionResult {
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
            initial_radius: run.radius,
            ..default()
        },
        window: run.window,
        reference_iterations: run.reference,
    };
    bench_motion(&request, |_| {}).unwrap()
}

/// Mean relMSE of `Reset` and `Reuse` over a run of `script` on `scene` at `size`².
fn motion_means(scene: &str, script: Script, size: u32, run: Run) -> (f64, f64) {
    let result = motion(scene, script, size, &run);
    let measured = run.frames / run.every;
    assert_eq!(result.rows.len() as u32, measured);
    let mean = |f: fn(&MotionRow) -> f64| result.rows.iter().map(f).sum::<f64>() / measured as f64;
    let (reset, reuse) = (mean(|r| r.reset), mean(|r| r.reuse));
    println!("{scene}: mean relMSE Reset {reset:.5}, Reuse {reuse:.5}");
    (reset, reuse)
}

/// Asserts that `Reuse`'s mean relMSE over the run is at least `factor` times below `Reset`'s.
fn reuse_below_reset(factor: f64, scene: &str, script: Script, size: u32, run: Run) {
    let (reset, reuse) = motion_means(scene, script, size, run);
    assert!(
        reuse * factor <= reset,
        "Reuse {reuse} against Reset {reset}"
    );
}

/// A light that swings across the Cornell box every frame (`rppm bench motion --script
/// light`, 16 frames of one iteration): `Reuse`'s mean relMSE against each frame's frozen
/// state converged is at least 1.5× below `Reset`'s, which starts again each frame. Each
/// pixel's history is clamped to its neighbourhood, not dropped where one iteration's
/// photons stray from it (1.3× before).
#[test]
fn a_moving_light_keeps_the_indirect_history() {
    reuse_below_reset(
        1.5,
        "cornell_box.gltf",
        Script::Light,
        48,
        Run::frames(16, 32),
    );
}

/// A camera orbiting rough metal spheres under a ceiling panel (`suite/glossy_metal`, 8
/// frames at 48²): `Reuse` is at least 2× below `Reset` (2.7× measured). Glossy metal keeps
/// its reprojected history only while the view turns within its lobe (1.5× when it was
/// dropped at every move), and an emitter's rim is no history of the wall beside it; kept
/// whole, both ghosted and `Reuse` read 0.8× of `Reset` (0.0625 against 0.0518).
#[test]
fn an_orbit_leaves_no_highlight_behind() {
    reuse_below_reset(
        2.0,
        "suite/glossy_metal.gltf",
        Script::Orbit,
        48,
        Run::frames(8, 64),
    );
}

/// A camera orbiting a grooved rough metal plate under a spot light (`suite/grooved_metal`,
/// 16 frames at 48²): `Reuse` is at least 2× below `Reset` (3.4× measured). Rough metal
/// keeps its history while the view turns within its lobe (the roughness squared, in
/// radians); dropped at every move, as before, it read 1.0× (64²).
#[test]
fn an_orbit_keeps_rough_metals_history() {
    reuse_below_reset(
        2.0,
        "suite/grooved_metal.gltf",
        Script::Orbit,
        48,
        Run::frames(16, 32),
    );
}

/// A camera orbiting a lantern, a light in a frosted glass box (`suite/frosted_lantern`, 16
/// frames at 64²): `Reuse` is at least 2× below `Reset` (3.4× measured). Frosted glass's
/// history was fetched where the point its camera paths reached was seen, a point its
/// roughness scatters: the light's image dragged over the glass, 0.2× `Reset`. It is now
/// fetched where its surface was, while the view turns within its lobe.
#[test]
fn an_orbit_past_a_frosted_lantern_drags_no_light() {
    reuse_below_reset(
        2.0,
        "suite/frosted_lantern.gltf",
        Script::Orbit,
        64,
        Run::frames(16, 32),
    );
}

/// A camera orbiting a pool whose floor tiles are seen through flat water (`suite/water_pool`,
/// 16 frames at 48²): `Reuse` is at least 1.4× below `Reset` (1.7× measured). What the
/// water shows is fetched where its camera paths' first diffuse point was last frame, not
/// where the water's surface was, and between pixels rather than from the nearest: before,
/// the tiles' edges dragged behind the camera and `Reuse` read 1.1× (0.0440 against 0.0505).
#[test]
fn an_orbit_over_water_keeps_the_floor_seen_through_it() {
    reuse_below_reset(
        1.4,
        "suite/water_pool.gltf",
        Script::Orbit,
        48,
        Run::frames(16, 32),
    );
}

/// A camera orbiting a closed room whose sphere light hangs in view (room 0 of
/// `random_scenes.py --count 8 --seed 35`, kept in `assets/suite/random/`; 8 frames at 48²):
/// `Reuse` is at least 4× below `Reset` (11× measured). A pixel that sees the light is marked
/// as seeing an emitter, not the wall behind it, so neither keeps the other's history: before,
/// the light's history moved with the wall and left a trail of light, and `Reuse` read 0.635
/// against `Reset`'s 0.177.
#[test]
fn an_orbit_past_a_sphere_light_leaves_no_trail() {
    reuse_below_reset(
        4.0,
        "suite/random/r35_00.gltf",
        Script::Orbit,
        48,
        Run::frames(8, 32),
    );
}

/// A camera orbiting a room with a fine checkered floor, lit by spot lights and the sun alone
/// (`assets/suite/random/r33_00.gltf`; 16 frames at 48²): `Reuse` is at least 3× below
/// `Reset` (5.3× measured). Each frame's reprojection resamples the history, which blurred
/// the checker over the window of 8 (1.1×, and 0.8× at 64²); where direct light is exact at
/// its point, a camera move keeps 3 of its samples (1.8×), the albedo it shows is each
/// pixel's footprint's now (3.0×), and its rough metal ball keeps its history (5.3×).
#[test]
fn an_orbit_keeps_a_checkered_floor_sharp() {
    reuse_below_reset(
        3.0,
        "suite/random/r33_00.gltf",
        Script::Orbit,
        48,
        Run::frames(16, 32),
    );
}

/// A camera orbiting `textured_box` (a checker floor, a striped emissive panel, a cut-out
/// screen; 16 frames at 48²): `Reuse` is at least 1.5× below `Reset` (2.0× measured; 1.0×
/// when its light's window of 8 carried the textures too, blurred by each frame's
/// reprojection). Lit by an emitter as well, its direct light is drawn, not exact, and keeps
/// the window for its noise; a camera move keeps the light and shows the albedo of each
/// pixel's footprint now.
#[test]
fn an_orbit_keeps_the_textures_of_an_emitter_lit_room_sharp() {
    reuse_below_reset(
        1.5,
        "suite/textured_box.gltf",
        Script::Orbit,
        48,
        Run::frames(16, 32),
    );
}

/// A camera orbiting the Cornell box (`rppm bench motion --script orbit`, 16 frames of one
/// iteration at 64²): `Reuse` is at least 4× below `Reset`, issue 13's bar (5.6× measured).
/// A frame whose camera moved samples one point of each pixel, so each pixel's history is
/// of one surface, and an edge's pixels are shown from eight rays through them, each taking
/// the estimate of the pixel beside it that sees what the ray met
/// (`shaders/accumulate/resolve.wgsl`). Before, each edge's pixel showed one side whole and
/// `Reuse` read 2.3×: two thirds of its error lay on the quarter of pixels at edges.
#[test]
fn an_orbit_resolves_its_edges_from_their_subpixels() {
    reuse_below_reset(
        4.0,
        "cornell_box.gltf",
        Script::Orbit,
        64,
        Run::frames(16, 32),
    );
}

/// A camera that slides across the Cornell box and stops (`--script slide --object camera`, 32
/// frames at 64²): over the window after the stop, `Reuse`'s error where the view changed is
/// within 2× that of a run that never moved (1.7× measured). The still frames after a move
/// show a falling share of its resolve (`resolve_share`); before, they showed the moving
/// frames' one-surface edges unresolved, at twice the moving frames' error (2.3× the still
/// run's). At 4-pixel discs, as measured: the default's 6 at 64² and 16 384 photons lowers
/// both (Reuse 0.0071 → 0.0056, still 0.0038 → 0.0022) but scores the still run against
/// references of its own radius (2.5×; against 512 iterations 2.1× and 2.3×).
#[test]
fn a_camera_that_stops_keeps_its_edges_resolved() {
    let script = Script::Slide(Some("camera".into()));
    let run = Run {
        radius: InitialRadius::Pixels(4.0),
        ..Run::frames(32, 32)
    };
    let result = motion("cornell_box.gltf", script, 64, &run);
    let [_, reuse, still] = result.settling.expect("the slide stops").ghost;
    println!("relMSE after the stop: Reuse {reuse:.5}, still {still:.5}");
    assert!(reuse <= 2.0 * still, "Reuse {reuse} against still {still}");
}

/// The same orbit at four iterations a frame: `Reuse` is at least 1.5× below `Reset`
/// (1.9× measured; 1.2× before). Each iteration of a frame whose camera moved keeps the
/// pixel's surface (one jitter for the G-buffer) and shades its own point of the pixel where
/// the ray through it meets that surface (`SHADING_POINTS`); when its jitter crossed edges,
/// their pixels held two surfaces and their histories were dropped at every move.
#[test]
fn an_orbit_of_four_iterations_a_frame_keeps_one_surface_a_pixel() {
    let run = Run {
        per_frame: 4,
        ..Run::frames(16, 32)
    };
    reuse_below_reset(1.5, "cornell_box.gltf", Script::Orbit, 64, run);
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
        radius: InitialRadius::default(),
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
