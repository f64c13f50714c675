//! What the examples share: a window, or with `--headless --frames N --out FILE.png` an
//! offscreen camera whose view is saved after N frames (for tests and screenshots), and an
//! on-screen overlay (O hides it) with the keys, the frame rate and the `rppm/` diagnostics.
//! Each example uses part of it.
#![allow(dead_code, reason = "each example uses part of the shared helpers")]

use std::path::{Path, PathBuf};

use bevy::camera::{Exposure, Hdr, RenderTarget};
use bevy::core_pipeline::tonemapping::Tonemapping;
use bevy::diagnostic::{DiagnosticsStore, FrameTimeDiagnosticsPlugin};
use bevy::gltf::Gltf;
use bevy::input::mouse::AccumulatedMouseMotion;
use bevy::light::GlobalAmbientLight;
use bevy::prelude::*;
use bevy::render::view::screenshot::{Screenshot, save_to_disk};
use bevy::world_serialization::WorldAssetRoot;

use bevy_rppm::stats::diagnostics::{ITERATIONS, MEMORY_MIB, stage_path};
use bevy_rppm::stats::timing::Stage;
use bevy_rppm::{PhotonCount, PhotonMapping, RppmMode, RppmPlugin, RppmStats};
use clap::Parser;

/// Command-line options every example takes.
#[derive(Parser, Resource, Clone, Debug)]
pub struct ExampleArgs {
    /// Render offscreen instead of in a window.
    #[arg(long)]
    pub headless: bool,
    /// Frames to run headless before the view is saved.
    #[arg(long, default_value_t = 60)]
    pub frames: u32,
    /// Where the headless view is saved (PNG).
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// Headless view size in pixels.
    #[arg(long, default_value_t = 320, value_parser = clap::value_parser!(u32).range(1..=8192))]
    pub width: u32,
    #[arg(long, default_value_t = 240, value_parser = clap::value_parser!(u32).range(1..=8192))]
    pub height: u32,
    /// Animated examples hold their animation at this time (seconds).
    #[arg(long, value_parser = finite_seconds)]
    pub time: Option<f32>,
}

fn finite_seconds(text: &str) -> Result<f32, String> {
    match text.parse::<f32>() {
        Ok(t) if t.is_finite() => Ok(t),
        _ => Err(format!("'{text}' is not a finite number of seconds")),
    }
}

impl ExampleArgs {
    /// The process's arguments; exits with clap's message on bad input.
    pub fn from_env() -> Self {
        Self::parse()
    }
}

/// This crate's `assets/`, wherever the example is run from.
pub fn asset_root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("assets")
}

/// The camera that headless runs render and save.
#[derive(Component, Clone, Copy, Debug, Default)]
pub struct ExampleCamera;

/// Shown in the overlay: what the keys do.
#[derive(Resource, Clone, Debug, Default)]
pub struct ExampleKeys(pub &'static str);

/// A Bevy app with the photon-mapping plugin: windowed, or headless per `args`.
pub fn example_app(title: &'static str, keys: &'static str, args: ExampleArgs) -> App {
    example_app_in(title, keys, args, &asset_root())
}

/// [`example_app`] reading its assets from `root`.
pub fn example_app_in(
    title: &'static str,
    keys: &'static str,
    args: ExampleArgs,
    root: &Path,
) -> App {
    let mut app = App::new();
    if args.headless {
        // A stale file would pass for the new screenshot.
        if let Some(out) = &args.out {
            let _ = std::fs::remove_file(out);
        }
        app = bevy_rppm_cli::headless::headless_app_unfinished(root);
        app.add_systems(Update, (offscreen_camera, save_and_exit));
    } else {
        app.add_plugins((
            DefaultPlugins
                .set(WindowPlugin {
                    primary_window: Some(Window {
                        title: title.into(),
                        ..default()
                    }),
                    ..default()
                })
                .set(AssetPlugin {
                    file_path: root.display().to_string(),
                    ..default()
                }),
            RppmPlugin,
            FrameTimeDiagnosticsPlugin::default(),
        ))
        .add_systems(Startup, spawn_overlay)
        .add_systems(Update, update_overlay);
    }
    app.insert_resource(args).insert_resource(ExampleKeys(keys));
    app
}

/// Keys of [`gltf_example`].
pub const GLTF_KEYS: &str = "G: GI  M: Full/Indirect  +/-: photons  R: restart  drag: orbit";

/// What the camera of [`gltf_example`] orbits around.
#[derive(Resource, Clone, Copy, Debug)]
pub struct OrbitTarget(pub Vec3);

/// An example that shows a glTF scene from `assets/` through its own camera, with photon
/// mapping and the keys of [`GLTF_KEYS`]; the camera orbits `target` when dragged.
pub fn gltf_example(title: &'static str, scene: &'static str, target: Vec3) -> App {
    gltf_example_in(title, &asset_root(), scene, target, ExampleArgs::from_env())
}

/// [`gltf_example`] for the scene file `scene` under `root`.
pub fn gltf_example_in(
    title: &'static str,
    root: &Path,
    scene: &str,
    target: Vec3,
    args: ExampleArgs,
) -> App {
    let mut app = example_app_in(title, GLTF_KEYS, args, root);
    let scene = scene.to_string();
    // Photon mapping replaces ambient light; the scenes' lights are a few candela.
    app.insert_resource(GlobalAmbientLight::NONE)
        .insert_resource(OrbitTarget(target))
        .add_systems(
            Startup,
            move |mut commands: Commands, assets: Res<AssetServer>| {
                commands.insert_resource(LoadingGltf(assets.load(scene.clone())));
            },
        )
        .add_observer(adopt_camera)
        .add_systems(Update, (spawn_default_scene, cast_shadows, gi_keys, orbit));
    app
}

/// The glTF file being loaded, until its scene is spawned.
#[derive(Resource)]
struct LoadingGltf(Handle<Gltf>);

/// Spawns the file's default scene (`load::default_scene`) once it is loaded: the
/// file is asked for once, as asking for a labelled part too loads it again (bevy#10549).
fn spawn_default_scene(
    loading: Option<Res<LoadingGltf>>,
    gltfs: Res<Assets<Gltf>>,
    mut commands: Commands,
    mut exit: MessageWriter<AppExit>,
) {
    let Some(gltf) = loading.and_then(|l| gltfs.get(&l.0)) else {
        return;
    };
    commands.remove_resource::<LoadingGltf>();
    match bevy_rppm_cli::load::default_scene(gltf) {
        Some(scene) => {
            commands.spawn(WorldAssetRoot(scene));
        }
        None => {
            eprintln!("the glTF file has no scene");
            exit.write(AppExit::error());
        }
    }
}

/// glTF lights come without Bevy shadows; mode Indirect shows Bevy's direct light, so give
/// them shadows as our local stage has.
fn cast_shadows(
    mut points: Query<&mut PointLight, Added<PointLight>>,
    mut spots: Query<&mut SpotLight, Added<SpotLight>>,
) {
    for mut light in &mut points {
        light.shadow_maps_enabled = true;
    }
    for mut light in &mut spots {
        light.shadow_maps_enabled = true;
    }
}

/// Gives the glTF camera photon mapping as the scene spawns it (before its first frame, which
/// Bevy's default tonemapper would render with a lookup table this crate leaves out).
fn adopt_camera(
    add: On<Add, Camera3d>,
    mut commands: Commands,
    gi: Query<(), With<PhotonMapping>>,
) {
    let camera = add.entity;
    if gi.contains(camera) {
        return;
    }
    commands.entity(camera).insert((
        PhotonMapping {
            photons_per_iteration: PhotonCount::Fixed(65_536),
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

/// G: GI on/off, M: Full/Indirect, + / −: photons per iteration (then fixed), R: restart.
fn gi_keys(keys: Res<ButtonInput<KeyCode>>, mut cameras: Query<&mut PhotonMapping>) {
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
            let n = gi.photons_per_iteration.max();
            gi.photons_per_iteration = PhotonCount::Fixed((n * 2).min(1 << 22));
        }
        if keys.just_pressed(KeyCode::Minus) || keys.just_pressed(KeyCode::NumpadSubtract) {
            let n = gi.photons_per_iteration.max();
            gi.photons_per_iteration = PhotonCount::Fixed((n / 2).max(1024));
        }
        if keys.just_pressed(KeyCode::KeyR) {
            gi.set_changed();
        }
    }
}

fn orbit(
    buttons: Res<ButtonInput<MouseButton>>,
    motion: Res<AccumulatedMouseMotion>,
    target: Res<OrbitTarget>,
    mut cameras: Query<&mut Transform, With<ExampleCamera>>,
) {
    if !buttons.pressed(MouseButton::Left) || motion.delta == Vec2::ZERO {
        return;
    }
    for mut transform in &mut cameras {
        let yaw = Quat::from_rotation_y(-motion.delta.x * 0.005);
        transform.translation = target.0 + yaw * (transform.translation - target.0);
        transform.look_at(target.0, Vec3::Y);
    }
}

fn offscreen_camera(
    mut commands: Commands,
    cameras: Query<Entity, Added<ExampleCamera>>,
    mut images: ResMut<Assets<Image>>,
    args: Res<ExampleArgs>,
) {
    for camera in &cameras {
        let target =
            bevy_rppm_cli::headless::offscreen_target(&mut images, args.width, args.height);
        commands.entity(camera).insert(target);
    }
}

/// Where a headless run is: frames since the first iteration, frames waited for it, and when
/// it came.
#[derive(Default)]
struct HeadlessClock {
    frame: u32,
    waited: u32,
    since: Option<std::time::Instant>,
}

fn save_and_exit(
    mut commands: Commands,
    args: Res<ExampleArgs>,
    cameras: Query<(Entity, &RenderTarget), With<ExampleCamera>>,
    stats: Res<RppmStats>,
    mut clock: Local<HeadlessClock>,
    mut exit: MessageWriter<AppExit>,
) {
    // Frames count from the camera's first iteration (or after 600 frames without one): a
    // scene still loading, or pipelines still compiling on a busy machine, would otherwise be
    // saved black.
    let view = cameras
        .iter()
        .next()
        .and_then(|(camera, _)| stats.views.get(&camera));
    let iteration = view.map_or(0, |s| s.iteration);
    clock.waited += 1;
    if iteration == 0 && clock.frame == 0 && clock.waited < 600 {
        return;
    }
    clock.frame += 1;
    let since = *clock.since.get_or_insert_with(std::time::Instant::now);
    let frame = clock.frame;
    if frame == args.frames {
        // Frames per second from the first iteration on, for the README's numbers.
        let seconds = since.elapsed().as_secs_f64();
        let held = view.map_or(0, |s| s.memory.values().sum::<u64>());
        println!(
            "{} frames in {seconds:.2} s: {:.1} fps at {}×{} (iteration {iteration}, {:.0} MiB held)",
            args.frames - 1,
            f64::from(args.frames - 1) / seconds.max(1e-9),
            args.width,
            args.height,
            held as f64 / f64::from(1 << 20),
        );
        if let (Some(out), Some((_, RenderTarget::Image(image)))) =
            (&args.out, cameras.iter().next())
        {
            commands
                .spawn(Screenshot::image(image.handle.clone()))
                .observe(save_to_disk(out.clone()));
        }
    }
    // The screenshot is written a few frames later.
    let written = args.out.as_ref().is_none_or(|out| out.exists());
    if frame >= args.frames && (written || frame > args.frames + 120) {
        exit.write(AppExit::Success);
    }
}

/// The overlay's text node.
#[derive(Component)]
struct Overlay;

fn spawn_overlay(mut commands: Commands) {
    commands.spawn((
        Overlay,
        Text::new(""),
        TextFont {
            font_size: FontSize::Px(14.0),
            ..default()
        },
        TextColor(Color::WHITE),
        BackgroundColor(Color::srgba(0.0, 0.0, 0.0, 0.6)),
        Node {
            position_type: PositionType::Absolute,
            top: px(8),
            left: px(8),
            padding: px(6).all(),
            ..default()
        },
    ));
}

/// Rewrites the overlay from `DiagnosticsStore`: keys, fps, iterations, memory, GPU ms of the
/// stages that ran.
fn update_overlay(
    keys: Res<ExampleKeys>,
    input: Res<ButtonInput<KeyCode>>,
    diagnostics: Res<DiagnosticsStore>,
    cameras: Query<&PhotonMapping>,
    mut overlay: Query<(&mut Text, &mut Visibility), With<Overlay>>,
) {
    let Ok((mut text, mut visibility)) = overlay.single_mut() else {
        return;
    };
    if input.just_pressed(KeyCode::KeyO) {
        visibility.toggle_visible_hidden();
    }
    let value =
        |path: &bevy::diagnostic::DiagnosticPath| diagnostics.get(path).and_then(|d| d.value());
    let fps = value(&FrameTimeDiagnosticsPlugin::FPS).unwrap_or(0.0);
    let mut lines = vec![format!("{}   O: overlay", keys.0), format!("{fps:.1} fps")];
    if cameras.iter().any(|c| c.enabled) {
        lines.push(format!(
            "{} iterations, {:.0} MiB held",
            value(&ITERATIONS).unwrap_or(0.0),
            value(&MEMORY_MIB).unwrap_or(0.0)
        ));
        lines.extend(Stage::ALL.iter().filter_map(|&stage| {
            let ms = value(&stage_path(stage)).filter(|&ms| ms > 0.0)?;
            Some(format!("{:<20}{ms:>8.2} GPU ms", stage.name()))
        }));
    } else {
        lines.push("GI off: Bevy's own lighting".into());
    }
    let joined = lines.join("\n");
    if text.0 != joined {
        text.0 = joined;
    }
}
