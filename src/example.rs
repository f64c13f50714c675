//! What the examples share: a window, or with `--headless --frames N --out FILE.png` an
//! offscreen camera whose view is saved after N frames (for tests and screenshots), and a
//! window title that shows the keys and the progress.

use std::path::PathBuf;

use bevy::camera::RenderTarget;
use bevy::prelude::*;
use bevy::render::view::screenshot::{Screenshot, save_to_disk};

use crate::{RppmPlugin, RppmStats};

/// Command-line options every example takes.
#[derive(Resource, Clone, Debug, Default)]
pub struct ExampleArgs {
    pub headless: bool,
    /// Frames to run headless before the view is saved.
    pub frames: u32,
    /// Where the headless view is saved (PNG).
    pub out: Option<PathBuf>,
}

impl ExampleArgs {
    /// Parses `--headless`, `--frames N`, `--out FILE.png`; exits with a message on bad input.
    pub fn from_env() -> Self {
        let mut args = Self {
            frames: 60,
            ..default()
        };
        let argv: Vec<String> = std::env::args().skip(1).collect();
        let mut i = 0;
        while i < argv.len() {
            match argv[i].as_str() {
                "--headless" => args.headless = true,
                "--frames" => {
                    i += 1;
                    args.frames = argv
                        .get(i)
                        .and_then(|v| v.parse().ok())
                        .unwrap_or_else(|| fail("--frames needs a number of frames"));
                }
                "--out" => {
                    i += 1;
                    args.out = Some(
                        argv.get(i)
                            .map(PathBuf::from)
                            .unwrap_or_else(|| fail("--out needs a file name")),
                    );
                }
                other => fail(&format!("unknown option {other}")),
            }
            i += 1;
        }
        args
    }
}

fn fail(message: &str) -> ! {
    eprintln!("error: {message}\nusage: [--headless] [--frames N] [--out FILE.png]");
    std::process::exit(2);
}

/// This crate's `assets/`, wherever the example is run from.
pub fn asset_root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("assets")
}

/// The camera that headless runs render and save.
#[derive(Component, Clone, Copy, Debug, Default)]
pub struct ExampleCamera;

/// Shown in the window title: what the keys do.
#[derive(Resource, Clone, Debug, Default)]
pub struct ExampleKeys(pub &'static str);

/// A Bevy app with the photon-mapping plugin: windowed, or headless per `args`.
pub fn example_app(title: &'static str, keys: &'static str, args: ExampleArgs) -> App {
    let mut app = App::new();
    if args.headless {
        // A stale file would pass for the new screenshot.
        if let Some(out) = &args.out {
            let _ = std::fs::remove_file(out);
        }
        app = crate::headless::headless_app_unfinished(&asset_root());
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
                    file_path: asset_root().display().to_string(),
                    ..default()
                }),
            RppmPlugin,
        ))
        .add_systems(Update, show_progress);
    }
    app.insert_resource(args).insert_resource(ExampleKeys(keys));
    app
}

fn offscreen_camera(
    mut commands: Commands,
    cameras: Query<Entity, Added<ExampleCamera>>,
    mut images: ResMut<Assets<Image>>,
) {
    for camera in &cameras {
        let target = crate::headless::offscreen_target(&mut images, 320, 240);
        commands.entity(camera).insert(target);
    }
}

fn save_and_exit(
    mut commands: Commands,
    args: Res<ExampleArgs>,
    cameras: Query<&RenderTarget, With<ExampleCamera>>,
    mut frame: Local<u32>,
    mut exit: MessageWriter<AppExit>,
) {
    *frame += 1;
    if *frame == args.frames
        && let (Some(out), Some(RenderTarget::Image(image))) = (&args.out, cameras.iter().next())
    {
        commands
            .spawn(Screenshot::image(image.handle.clone()))
            .observe(save_to_disk(out.clone()));
    }
    // The screenshot is written a few frames later.
    let written = args.out.as_ref().is_none_or(|out| out.exists());
    if *frame >= args.frames && (written || *frame > args.frames + 120) {
        exit.write(AppExit::Success);
    }
}

fn show_progress(
    keys: Res<ExampleKeys>,
    stats: Res<RppmStats>,
    cameras: Query<&crate::PhotonMapping>,
    mut windows: Query<&mut Window>,
) {
    let Ok(mut window) = windows.single_mut() else {
        return;
    };
    let on = cameras.iter().any(|c| c.enabled);
    let progress = stats
        .views
        .values()
        .next()
        .filter(|_| on)
        .map(|s| {
            let ms: f64 = s.stage_ms.values().sum();
            format!("{} iterations, {ms:.1} GPU ms/frame", s.iteration)
        })
        .unwrap_or_else(|| "GI off".into());
    let title = format!("{} — {progress}", keys.0);
    if window.title != title {
        window.title = title;
    }
}
