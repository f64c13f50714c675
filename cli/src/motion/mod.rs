//! `rppm bench motion`: a scripted animation of a glTF scene rendered frame by frame under
//! `RppmHistory::Reset` and `Reuse`, and the error of every n-th frame against the same
//! frozen state rendered to convergence (issue 13's measure of motion quality); for a slide
//! that stops, how long each run takes to settle after it and the error where things changed.

mod plot;
mod settle;

use std::path::{Path, PathBuf};
use std::time::Instant;

use bevy::prelude::*;
use bevy_rppm::{PhotonMapping, RppmHistory, RppmRadiance, RppmScene, ViewEpoch};

use crate::animation::{self, Posed};
use crate::headless::{Budget, RenderRequest, attach_camera, failed, render_loaded};
use crate::image_io::{RgbImage, relmse};
use crate::load::load_gltf;

pub use plot::write_plot;
pub use settle::{SettleRow, Settling};

/// What moves.
#[derive(Clone, Debug)]
pub enum Script {
    /// The camera circles the scene's centre about the vertical, one degree per frame.
    Orbit,
    /// The first point or spot light swings along x by a quarter of the scene's radius.
    Light,
    /// The glTF animation of this index plays at 30 frames per second.
    Animation(usize),
    /// The glTF node of this name (`None`: the first point or spot light) slides along x,
    /// towards the scene's centre, by a quarter of the scene's radius over frames F/4…F/2 of
    /// F, and stays there (`stop`).
    Slide(Option<String>),
}

/// The frames a slide moves over, from its start to its stop.
fn slide_span(frames: u32) -> (u32, u32) {
    (frames / 4, frames / 2)
}

impl Script {
    /// The first frame of the final state, for a script that stops.
    pub fn stop(&self, frames: u32) -> Option<u32> {
        matches!(self, Script::Slide(_)).then(|| slide_span(frames).1)
    }
}

pub struct MotionRequest {
    pub scene: PathBuf,
    pub script: Script,
    pub frames: u32,
    /// Every this many frames, the error against the converged frozen state.
    pub every: u32,
    pub width: u32,
    pub height: u32,
    /// The settings of both runs (`history` is set per run).
    pub settings: PhotonMapping,
    /// `Reuse`'s window.
    pub window: u32,
    pub reference_iterations: u32,
}

/// One sampled frame: relMSE of each run against the converged frozen state.
#[derive(Clone, Copy, Debug)]
pub struct MotionRow {
    pub frame: u32,
    pub reset: f64,
    pub reuse: f64,
}

/// One sampled frame's images: `Reset`, `Reuse` and the converged frozen state.
pub struct MotionImages {
    pub frame: u32,
    pub images: [RgbImage; 3],
}

pub struct MotionResult {
    pub rows: Vec<MotionRow>,
    pub images: Vec<MotionImages>,
    /// Wall seconds of each run's frames.
    pub seconds: [f64; 2],
    /// After a script's stop: every frame's error where the scene changed.
    pub settling: Option<Settling>,
}

/// Updates run past the last frame, for its estimate to come back (the render world runs a
/// frame behind, and the read-back arrives a frame later).
const LAG: u32 = 4;

/// A scene loaded and scripted: what frame `f` sets.
struct Scripted {
    app: App,
    camera: Entity,
    moved: Option<(Entity, Transform)>,
    centre: Vec3,
    radius: f32,
    posed: Option<Posed>,
}

impl Scripted {
    fn load(request: &MotionRequest, settings: PhotonMapping) -> Result<Self, String> {
        let mut app = load_gltf(&request.scene)?;
        let posed = match request.script {
            Script::Animation(index) => {
                Some(animation::pose(&mut app, &request.scene, index, 0.0)?)
            }
            _ => None,
        };
        let render = RenderRequest {
            scene: request.scene.clone(),
            width: request.width,
            height: request.height,
            budget: Budget::Iterations(u32::MAX),
            settings,
        };
        attach_camera(&mut app, &render)?;
        let world = app.world_mut();
        let camera = world
            .query_filtered::<Entity, With<PhotonMapping>>()
            .single(world)
            .map_err(|e| format!("no camera: {e}"))?;
        let (centre, radius) = world.resource::<RppmScene>().data.bounding_sphere();
        let moved = match &request.script {
            Script::Orbit => Some(camera),
            Script::Light | Script::Slide(None) => world
                .query_filtered::<Entity, Or<(With<PointLight>, With<SpotLight>)>>()
                .iter(world)
                .next()
                .map(Some)
                .ok_or("the scene has no point or spot light to move (a slide may name a node)")?,
            Script::Slide(Some(name)) => Some(
                world
                    .query::<(Entity, &Name)>()
                    .iter(world)
                    .find(|(_, n)| n.as_str() == name)
                    .map(|(e, _)| e)
                    .ok_or_else(|| format!("the scene has no node named {name:?}"))?,
            ),
            Script::Animation(_) => None,
        }
        .map(|e| (e, *world.get::<Transform>(e).unwrap()));
        Ok(Self {
            app,
            camera,
            moved,
            centre,
            radius,
            posed,
        })
    }

    /// Sets the state of frame `f` of `frames`.
    fn set(&mut self, script: &Script, f: u32, frames: u32) {
        let turn = (f as f32).to_radians();
        let swing = (std::f32::consts::TAU * f as f32 / frames as f32).sin();
        let (centre, radius) = (self.centre, self.radius);
        if let Some(posed) = &self.posed {
            posed.seek(&mut self.app, f as f32 / 30.0);
        }
        let Some((entity, start)) = self.moved else {
            return;
        };
        let mut transform = self.app.world_mut().get_mut::<Transform>(entity).unwrap();
        // Set only when it moves: a still frame must not count as a change.
        transform.set_if_neq(match script {
            Script::Orbit => {
                let mut t = start;
                t.rotate_around(centre, Quat::from_rotation_y(turn));
                t
            }
            Script::Slide(_) => {
                let (a, b) = slide_span(frames);
                let s = ((f as f32 - a as f32) / b.saturating_sub(a).max(1) as f32).clamp(0.0, 1.0);
                let towards = centre.x - start.translation.x;
                let side = if towards.abs() > 1e-3 * radius {
                    towards.signum()
                } else {
                    1.0
                };
                start.with_translation(start.translation + Vec3::X * side * 0.25 * radius * s)
            }
            _ => start.with_translation(start.translation + Vec3::X * 0.25 * radius * swing),
        });
    }

    fn image(&self) -> Option<&bevy_rppm::RadianceImage> {
        self.app
            .world()
            .resource::<RppmRadiance>()
            .images
            .get(&self.camera)
    }

    /// The changes the main world has made so far, as an estimate's `epoch` counts them.
    fn changes(&self) -> u64 {
        let world = self.app.world();
        let view = world
            .get::<ViewEpoch>(self.camera)
            .copied()
            .unwrap_or_default();
        world
            .resource::<RppmScene>()
            .epoch
            .wrapping_add(view.epoch)
            .wrapping_add(view.moves)
    }
}

/// A run's images: every sampled frame's, and every frame's from the script's stop on.
#[derive(Default)]
struct Run {
    sampled: Vec<(u32, RgbImage)>,
    settling: Vec<(u32, RgbImage)>,
    seconds: f64,
}

/// Runs the script under `history` (`still`: held at its last frame throughout).
fn run(request: &MotionRequest, history: RppmHistory, still: bool) -> Result<Run, String> {
    let settings = PhotonMapping {
        history,
        ..request.settings.clone()
    };
    let mut scripted = Scripted::load(request, settings)?;
    let state = |f: u32| if still { request.frames - 1 } else { f };
    scripted.set(&request.script, state(0), request.frames);
    // Until the pipelines are compiled and the first estimate comes back.
    let start = Instant::now();
    while scripted.image().is_none_or(|image| image.iteration == 0) {
        scripted.app.update();
        failed(scripted.app.world(), scripted.camera)?;
        if start.elapsed().as_secs() > 120 {
            return Err("no iteration within 120 s".into());
        }
    }
    // Each estimate is matched to the frame whose state it shows by its epoch (the changes
    // the render world had seen), since it comes back a frame or two later. After a stop
    // the epoch holds, so a frame is the update that read it back, in every run alike.
    let mut frame_of: Vec<(u64, u32)> = Vec::new();
    let mut out = Run::default();
    let sampled = |f: u32| f % request.every == request.every - 1;
    let stop = request.script.stop(request.frames);
    let started = Instant::now();
    let mut last = None;
    for update in 0..request.frames + LAG {
        let frame = update.min(request.frames - 1);
        scripted.set(&request.script, state(frame), request.frames);
        scripted.app.update();
        failed(scripted.app.world(), scripted.camera)?;
        frame_of.push((scripted.changes(), frame));
        let image = scripted.image().ok_or("no image came back")?;
        let shown = frame_of.iter().rev().find(|(e, _)| *e == image.epoch);
        let fresh = last != Some((image.epoch, image.iteration));
        last = Some((image.epoch, image.iteration));
        // The first estimate of the frame: the last frame, held while it comes back, adds
        // iterations after it.
        if let Some(&(_, f)) = shown {
            let rgb = || RgbImage::from_rgba(image.width, image.height, &image.pixels);
            if sampled(f) && out.sampled.last().is_none_or(|(l, _)| *l != f) {
                out.sampled.push((f, rgb()));
            }
            if fresh
                && stop.is_some_and(|s| f >= s)
                && out.settling.last().is_none_or(|(l, _)| *l != f)
            {
                out.settling.push((f, rgb()));
            }
        }
        if update + 1 == request.frames {
            out.seconds = started.elapsed().as_secs_f64();
        }
    }
    Ok(out)
}

/// The frozen state of frame `f`, converged (`reference_iterations`, `Reset`), from random
/// numbers the runs do not draw (another seed).
fn reference(request: &MotionRequest, f: u32) -> Result<RgbImage, String> {
    let settings = PhotonMapping {
        seed: request.settings.seed.wrapping_add(1),
        history: RppmHistory::Reset,
        ..request.settings.clone()
    };
    let mut scripted = Scripted::load(request, settings.clone())?;
    scripted.set(&request.script, f, request.frames);
    let render = RenderRequest {
        scene: request.scene.clone(),
        width: request.width,
        height: request.height,
        budget: Budget::Iterations(request.reference_iterations),
        settings,
    };
    render_loaded(&mut scripted.app, &render, |_| {}).map(|r| r.image)
}

/// Both runs and their errors (and, for a script that stops, a still run's); `log` hears
/// of each step.
pub fn bench_motion(
    request: &MotionRequest,
    mut log: impl FnMut(&str),
) -> Result<MotionResult, String> {
    if request.frames == 0 || request.every == 0 {
        return Err("--frames and --every must be at least 1".into());
    }
    if request.every > request.frames {
        return Err(format!(
            "--every {} is more than --frames {}: no frame would be measured",
            request.every, request.frames
        ));
    }
    log("Reset run");
    let reset = run(request, RppmHistory::Reset, false)?;
    log("Reuse run");
    let window = request.window.clamp(1, 1024);
    let reuse = run(request, RppmHistory::Reuse { iterations: window }, false)?;
    let stop = request.script.stop(request.frames);
    // Frames from the stop on share one state and one reference; a slide also needs its
    // first state's, for the region that changed.
    let state = |f: u32| stop.map_or(f, |s| f.min(s));
    let mut states: Vec<u32> = reset.sampled.iter().map(|(f, _)| state(*f)).collect();
    states.extend(stop.into_iter().flat_map(|s| [0, s]));
    states.sort_unstable();
    states.dedup();
    let mut references = std::collections::BTreeMap::new();
    for s in states {
        log(&format!("reference of frame {s}"));
        references.insert(s, reference(request, s)?);
    }
    let mut rows = Vec::new();
    let mut images = Vec::new();
    for ((frame, a), (_, b)) in reset.sampled.into_iter().zip(reuse.sampled) {
        let truth = references[&state(frame)].clone();
        rows.push(MotionRow {
            frame,
            reset: relmse(&a, &truth)?,
            reuse: relmse(&b, &truth)?,
        });
        images.push(MotionImages {
            frame,
            images: [a, b, truth],
        });
    }
    let settling = match stop {
        Some(stop) => {
            log("still run (the last frame's state throughout)");
            let still = run(request, RppmHistory::Reset, true)?;
            let runs = [reset.settling, reuse.settling, still.settling];
            let (before, after) = (&references[&0], &references[&stop]);
            Some(Settling::measure(stop, window, before, after, &runs)?)
        }
        None => None,
    };
    Ok(MotionResult {
        rows,
        images,
        seconds: [reset.seconds, reuse.seconds],
        settling,
    })
}

/// `frame<N>_{reset,reuse,reference}.{exr,png}` in `dir`, for each sampled frame.
pub fn write_images(result: &MotionResult, dir: &Path) -> Result<(), String> {
    for sampled in &result.images {
        for (image, name) in sampled.images.iter().zip(["reset", "reuse", "reference"]) {
            let stem = dir.join(format!("frame{}_{name}", sampled.frame));
            crate::image_io::write_exr(&stem.with_extension("exr"), image)?;
            crate::image_io::write_png(&stem.with_extension("png"), image)?;
        }
    }
    Ok(())
}

/// `motion.csv` in `dir`: frame, reset, reuse; `settle.csv` after a stop.
pub fn write_csv(result: &MotionResult, dir: &Path) -> anyhow::Result<()> {
    let mut csv = csv::Writer::from_path(dir.join("motion.csv"))?;
    csv.write_record(["frame", "reset_relmse", "reuse_relmse"])?;
    for r in &result.rows {
        csv.write_record([
            r.frame.to_string(),
            r.reset.to_string(),
            r.reuse.to_string(),
        ])?;
    }
    csv.flush()?;
    if let Some(s) = &result.settling {
        let mut csv = csv::Writer::from_path(dir.join("settle.csv"))?;
        csv.write_record([
            "frames_since_stop",
            "reset_region",
            "reuse_region",
            "still_region",
        ])?;
        for r in &s.rows {
            let [a, b, c] = r.region.map(|v| v.to_string());
            csv.write_record([(r.frame - s.stop).to_string(), a, b, c])?;
        }
        csv.flush()?;
    }
    Ok(())
}

/// The tables and summary lines `rppm bench motion` prints.
pub fn print_report(result: &MotionResult, frames: u32, script: &str) {
    println!("| frame | Reset relMSE | Reuse relMSE |");
    println!("|---:|---:|---:|");
    for r in &result.rows {
        println!("| {} | {:.5} | {:.5} |", r.frame, r.reset, r.reuse);
    }
    let n = result.rows.len().max(1) as f64;
    let reset = result.rows.iter().map(|r| r.reset).sum::<f64>() / n;
    let reuse = result.rows.iter().map(|r| r.reuse).sum::<f64>() / n;
    let fps = |s: f64| frames as f64 / s.max(1e-9);
    println!(
        "mean relMSE: Reset {reset:.5}, Reuse {reuse:.5} ({:.1}× lower); frames/s: Reset {:.2}, \
         Reuse {:.2} ({frames} frames, {script} script)",
        reset / reuse.max(1e-12),
        fps(result.seconds[0]),
        fps(result.seconds[1]),
    );
    if let Some(settling) = &result.settling {
        println!();
        settling.print();
    }
}
