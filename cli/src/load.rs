//! Loading a glTF file into a headless app: checked first (`validate`), loaded once, its
//! default scene spawned, and what Bevy's loader leaves out of it set (`extensions`).

use std::path::Path;
use std::time::Instant;

use bevy::asset::{LoadState, RecursiveDependencyLoadState, UntypedAssetId};
use bevy::gltf::Gltf;
use bevy::prelude::*;
use bevy::world_serialization::{WorldAsset, WorldAssetRoot, WorldInstanceReady};

use crate::headless::{STALL, check_gpu_adapter, headless_app};
use crate::validate::{Access, check_gltf};

/// Loads a glTF file into a fresh headless app and runs it until its default scene is spawned
/// and extracted. Every failure is a one-line message.
pub fn load_gltf(scene: &Path) -> Result<App, String> {
    load_gltf_with(scene, Access::default())
}

/// [`load_gltf`], with what the file may reach besides itself.
pub fn load_gltf_with(scene: &Path, access: Access) -> Result<App, String> {
    let meta =
        std::fs::metadata(scene).map_err(|e| format!("cannot read {}: {e}", scene.display()))?;
    if !meta.is_file() {
        return Err(format!("{} is not a file", scene.display()));
    }
    let extras = check_gltf(scene, access)?;
    check_gpu_adapter()?;
    let absolute = std::fs::canonicalize(scene)
        .map_err(|e| format!("cannot read {}: {e}", scene.display()))?;
    let root = absolute.parent().unwrap_or(Path::new("/"));
    let file = absolute
        .file_name()
        .map(|f| f.to_string_lossy().to_string())
        .unwrap_or_default();
    let mut app = headless_app(root);
    if let Some([r, g, b]) = extras.sky {
        app.insert_resource(bevy_rppm::RppmSky {
            color: Color::linear_rgb(r, g, b),
            radiance: 1.0,
        });
    }
    // The file alone is loaded and its scene taken from it: a request for a labelled part
    // (`Scene0`) forces its file's load again (bevy#10549), and that second load, landing
    // late, replaced every material, undoing what `extensions::apply` set.
    let gltf: Handle<Gltf> = app.world().resource::<AssetServer>().load(file.clone());
    let start = Instant::now();
    // Every texture it names loaded: one that fails (missing, not an image) is an error,
    // not an image without it.
    wait(&mut app, scene, gltf.id().untyped(), start, |app| {
        let server = app.world().resource::<AssetServer>();
        server.is_loaded_with_dependencies(&gltf)
    })?;
    let Some(handle) = (app.world().resource::<Assets<Gltf>>().get(&gltf)).and_then(default_scene)
    else {
        return Err(format!("{} has no scene", scene.display()));
    };
    app.insert_resource(LoadedGltf(gltf));
    let scene_id = handle.id().untyped();
    let root_entity = app.world_mut().spawn(WorldAssetRoot(handle)).id();
    app.world_mut().entity_mut(root_entity).observe(
        |_: On<WorldInstanceReady>, mut commands: Commands| {
            commands.insert_resource(SceneReady);
        },
    );
    wait(&mut app, scene, scene_id, start, |app| {
        app.world().contains_resource::<SceneReady>()
    })?;
    crate::extensions::apply(app.world_mut(), &file, &extras);
    app.update(); // let extraction see the spawned meshes
    Ok(app)
}

/// The scene a file shows: its default (glTF's `scene`), as tools/reference.py renders it;
/// else its first.
pub fn default_scene(gltf: &Gltf) -> Option<Handle<WorldAsset>> {
    (gltf.default_scene.clone()).or_else(|| gltf.scenes.first().cloned())
}

/// Updates `app` until `ready`, failing with the load error of `asset` (and of what it
/// depends on) or after [`STALL`] from `start`.
fn wait(
    app: &mut App,
    scene: &Path,
    asset: UntypedAssetId,
    start: Instant,
    ready: impl Fn(&App) -> bool,
) -> Result<(), String> {
    while !ready(app) {
        app.update();
        let server = app.world().resource::<AssetServer>();
        // The error's first line: the rest is a backtrace where one is asked for.
        let failed = |e: &dyn std::fmt::Display| {
            let e = e.to_string();
            let line = e.lines().next().unwrap_or_default().to_string();
            format!("cannot load {}: {line}", scene.display())
        };
        if let Some(LoadState::Failed(e)) = server.get_load_state(asset) {
            return Err(failed(&e));
        }
        let dependencies = server.get_recursive_dependency_load_state(asset);
        if let Some(RecursiveDependencyLoadState::Failed(e)) = dependencies {
            return Err(failed(&e));
        }
        if start.elapsed() > STALL {
            return Err(format!(
                "{} did not load within {} s",
                scene.display(),
                STALL.as_secs()
            ));
        }
    }
    Ok(())
}

#[derive(Resource)]
struct SceneReady;

/// The loaded glTF itself, held so that a later request for it (its animations) finds it
/// loaded: without a handle alive it would be loaded again, and the scene's instance spawned
/// anew from the second load, undoing a pose set meanwhile.
#[derive(Resource)]
pub struct LoadedGltf(pub Handle<Gltf>);
