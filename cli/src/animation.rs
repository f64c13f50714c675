//! Posing a loaded glTF scene by one of its animations, held at one instant.

use std::path::Path;

use bevy::animation::graph::{AnimationGraph, AnimationGraphHandle, AnimationNodeIndex};
use bevy::animation::{AnimationClip, AnimationPlayer};
use bevy::gltf::Gltf;
use bevy::prelude::*;
use bevy_rppm::RppmScene;

/// A glTF animation set on a scene's animation players.
pub struct Posed {
    /// The clip's name (or `#index`).
    pub name: String,
    node: AnimationNodeIndex,
    /// The clip's length in seconds (0: unknown).
    duration: f32,
}

impl Posed {
    /// Holds every player at `seconds`, wrapped into the clip (a player would hold its end).
    pub fn seek(&self, app: &mut App, seconds: f32) {
        let seconds = self.wrapped(seconds);
        let world = app.world_mut();
        let mut players = world.query::<&mut AnimationPlayer>();
        for mut player in players.iter_mut(world) {
            player.play(self.node).seek_to(seconds).pause();
        }
    }

    fn wrapped(&self, seconds: f32) -> f32 {
        if self.duration > 0.0 {
            seconds % self.duration
        } else {
            0.0
        }
    }

    /// Whether every player holds `graph`, paused at `seconds`.
    fn holds(&self, app: &mut App, graph: &Handle<AnimationGraph>, seconds: f32) -> bool {
        let seconds = self.wrapped(seconds);
        let world = app.world_mut();
        let mut players = world.query::<(&AnimationPlayer, Option<&AnimationGraphHandle>)>();
        players.iter(world).all(|(player, handle)| {
            handle.is_some_and(|h| h.0 == *graph)
                && player
                    .animation(self.node)
                    .is_some_and(|a| a.is_paused() && a.seek_time() == seconds)
        })
    }
}

/// Plays animation `index` of the glTF `scene` (already loaded into `app` by
/// [`load_gltf`](crate::load::load_gltf)) on every animation player it spawned, paused at
/// `seconds` (wrapped into the clip), so the estimate converges on that pose. Returns the
/// clip, or why it cannot be played.
pub fn pose(app: &mut App, scene: &Path, index: usize, seconds: f32) -> Result<Posed, String> {
    if !seconds.is_finite() || seconds < 0.0 {
        return Err(format!("animation time {seconds} is not a time ≥ 0"));
    }
    // The handle `load_gltf` keeps: asked for anew, the file would be loaded again.
    let gltf: Handle<Gltf> = app
        .world()
        .get_resource::<crate::load::LoadedGltf>()
        .ok_or_else(|| format!("{} was not loaded by load_gltf", scene.display()))?
        .0
        .clone();
    // Loaded with its scene already; the handle resolves within a few updates.
    for _ in 0..100 {
        if app.world().resource::<Assets<Gltf>>().contains(&gltf) {
            break;
        }
        app.update();
    }
    let clip = {
        let gltfs = app.world().resource::<Assets<Gltf>>();
        let gltf = gltfs
            .get(&gltf)
            .ok_or_else(|| format!("{} is not loaded", scene.display()))?;
        let clip = gltf.animations.get(index).ok_or_else(|| {
            format!(
                "{} has {} animations; there is no animation {index}",
                scene.display(),
                gltf.animations.len()
            )
        })?;
        let name = gltf
            .named_animations
            .iter()
            .find(|(_, h)| *h == clip)
            .map_or_else(|| format!("#{index}"), |(n, _)| n.to_string());
        (clip.clone(), name)
    };
    // The clip may load after the glTF (a busy machine): without it, its length, and so every
    // seek, would be wrong.
    let started = std::time::Instant::now();
    while !app
        .world()
        .resource::<Assets<AnimationClip>>()
        .contains(&clip.0)
    {
        if started.elapsed().as_secs() > 60 {
            return Err(format!(
                "{}'s animation {index} did not load",
                scene.display()
            ));
        }
        app.update();
    }
    let duration = app
        .world()
        .resource::<Assets<AnimationClip>>()
        .get(&clip.0)
        .map_or(0.0, AnimationClip::duration);
    let (graph, node) = AnimationGraph::from_clip(clip.0);
    let graph = app
        .world_mut()
        .resource_mut::<Assets<AnimationGraph>>()
        .add(graph);
    let world = app.world_mut();
    let mut players = world.query::<(Entity, &mut AnimationPlayer)>();
    let entities: Vec<Entity> = players.iter(world).map(|(e, _)| e).collect();
    if entities.is_empty() {
        return Err(format!("{} has no animated nodes", scene.display()));
    }
    for entity in entities {
        world.get_mut::<AnimationPlayer>(entity).unwrap().stop_all();
        world
            .entity_mut(entity)
            .insert(AnimationGraphHandle(graph.clone()));
    }
    let posed = Posed {
        name: clip.1,
        node,
        duration,
    };
    let mut epoch = app.world().resource::<RppmScene>().epoch;
    posed.seek(app, seconds);
    // The pose reaches the transforms, and extraction sees it, within a few updates; more
    // where the clip's asset comes a little after the glTF's (a busy machine). Another change
    // (a texture arriving) may move the scene first, so the scene must move and then hold.
    let mut held = None;
    for _ in 0..60 {
        app.update();
        let now = app.world().resource::<RppmScene>().epoch;
        if now != epoch {
            epoch = now;
            held = Some(0);
        } else if let Some(updates) = held.as_mut() {
            *updates += 1;
            if *updates == 3 {
                break;
            }
        }
    }
    // A scene instance spawned anew meanwhile would have undone it: say so, not render unposed.
    if !posed.holds(app, &graph, seconds) {
        return Err(format!(
            "{}'s animation {index} did not hold its pose at {seconds} s",
            scene.display()
        ));
    }
    Ok(posed)
}
