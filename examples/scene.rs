//! Any glTF scene with photon mapping, in a window: `cargo run --example scene -- PATH.gltf`.
//! The scene brings its camera and lights (`tools/stage.py` adds both, and a floor, to an asset
//! that has none, such as Bevy's FlightHelmet); what `rppm` reads beyond Bevy's loader (a
//! sky, sphere lights, diffuse transmission) is read here too. Keys as in `cornell`; dragging
//! orbits the origin. `--headless --frames N --out FILE.png` renders offscreen instead.
mod common;

use std::path::PathBuf;

use bevy::prelude::*;
use bevy::world_serialization::WorldInstanceReady;
use bevy_rppm_cli::{extensions, validate};
use clap::Parser;
use common::{ExampleArgs, gltf_example_in};

#[derive(Parser)]
struct SceneArgs {
    /// The glTF or GLB file.
    scene: PathBuf,
    #[command(flatten)]
    example: ExampleArgs,
}

fn main() -> AppExit {
    let args = SceneArgs::parse();
    // Checked as `rppm` checks it: bad input is one line here, not a panic in Bevy's loader.
    let extras = match validate::check_gltf(&args.scene, validate::Access::default()) {
        Ok(extras) => extras,
        Err(e) => {
            eprintln!("scene: {e}");
            return AppExit::error();
        }
    };
    let absolute = match std::fs::canonicalize(&args.scene) {
        Ok(path) => path,
        Err(e) => {
            eprintln!("scene: cannot read {}: {e}", args.scene.display());
            return AppExit::error();
        }
    };
    let root = absolute.parent().unwrap_or(&absolute).to_path_buf();
    let file = absolute
        .file_name()
        .map(|f| f.to_string_lossy().to_string())
        .unwrap_or_default();
    let mut app = gltf_example_in("bevy_rppm: scene", &root, &file, Vec3::ZERO, args.example);
    if let Some([r, g, b]) = extras.sky {
        app.insert_resource(bevy_rppm::RppmSky {
            color: Color::linear_rgb(r, g, b),
            radiance: 1.0,
        });
    }
    app.add_observer(move |_: On<WorldInstanceReady>, mut commands: Commands| {
        let (file, extras) = (file.clone(), extras.clone());
        commands.queue(move |world: &mut World| extensions::apply(world, &file, &extras));
    });
    app.run()
}
