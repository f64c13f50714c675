//! Headless rendering: a Bevy app with no window that loads a glTF scene, renders it with
//! photon mapping into an offscreen target and hands back the raw radiance. The `rppm` CLI and
//! the tests both run through here.

use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::time::{Duration, Instant};

use bevy::camera::RenderTarget;
use bevy::core_pipeline::tonemapping::Tonemapping;
use bevy::prelude::*;
use bevy::render::RenderPlugin;
use bevy::render::error_handler::{RenderError, RenderErrorHandler, RenderErrorPolicy};
use bevy::render::render_resource::{TextureFormat, TextureUsages};
use bevy::render::settings::RenderCreation;
use bevy::window::ExitCondition;

use bevy_rppm::cubemap::CubemapConfig;
use bevy_rppm::debug::bench::{
    CubemapBenchRequest, CubemapBenchResults, CubemapBenchRow, bench_rays,
};
use bevy_rppm::{
    PhotonMapping, RadianceImage, RppmHistory, RppmPlugin, RppmRadiance, RppmReadback, RppmScene,
    RppmStats, ViewStats,
};

use crate::image_io::RgbImage;
use crate::load::load_gltf;

/// What to do when no GPU adapter is found.
pub const INSTALL_HINT: &str = "no GPU adapter found. On a machine without a GPU, install Mesa's \
     software Vulkan driver (Debian/Ubuntu: `sudo apt-get install mesa-vulkan-drivers`), then run \
     again";

/// Finds a GPU adapter the way Bevy will, before Bevy would panic without one; returns its name.
pub fn check_gpu_adapter() -> Result<String, String> {
    adapter_info().map(|info| info.name)
}

/// Whether the adapter a render gets is a CPU emulating a GPU (llvmpipe), where
/// `RppmTracer::Auto` traces through the BVH.
pub fn software_adapter() -> Result<bool, String> {
    adapter_info().map(|info| info.device_type == wgpu::DeviceType::Cpu)
}

fn adapter_info() -> Result<wgpu::AdapterInfo, String> {
    let instance = wgpu::Instance::new(wgpu::InstanceDescriptor {
        backends: wgpu::Backends::from_env().unwrap_or(wgpu::Backends::all()),
        ..wgpu::InstanceDescriptor::new_without_display_handle()
    });
    let adapter = bevy::tasks::block_on(instance.request_adapter(&wgpu::RequestAdapterOptions {
        power_preference: wgpu::PowerPreference::HighPerformance,
        ..Default::default()
    }))
    .map_err(|e| format!("{INSTALL_HINT} ({e})"))?;
    Ok(adapter.get_info())
}

/// A windowless Bevy app with the photon-mapping plugin, ready for `update()`; assets load
/// relative to `asset_root`.
pub fn headless_app(asset_root: &Path) -> App {
    let mut app = headless_app_unfinished(asset_root);
    app.finish();
    app.cleanup();
    app
}

/// The same app, not yet finished: for `App::run()` (it loops with no delay between frames).
pub fn headless_app_unfinished(asset_root: &Path) -> App {
    let mut app = App::new();
    let plugins = DefaultPlugins
        .set(AssetPlugin {
            file_path: asset_root.display().to_string(),
            ..default()
        })
        .set(WindowPlugin {
            primary_window: None,
            exit_condition: ExitCondition::DontExit,
            ..default()
        })
        .set(RenderPlugin {
            render_creation: RenderCreation::Automatic(Box::default()),
            // Pipelines ready on the first frame: iteration counts are then exact.
            synchronous_pipeline_compilation: true,
            ..default()
        })
        // No display server here; rendering goes to images.
        .disable::<bevy::winit::WinitPlugin>();
    // The process has one logger: the first app sets it, later ones (benches, tests) use it.
    static LOGGER_SET: std::sync::atomic::AtomicBool = std::sync::atomic::AtomicBool::new(false);
    let plugins = if LOGGER_SET.swap(true, std::sync::atomic::Ordering::SeqCst) {
        plugins.disable::<bevy::log::LogPlugin>()
    } else {
        // A failed asset load is our one error line (`load_gltf`), not a log with a backtrace.
        plugins.set(bevy::log::LogPlugin {
            filter:
                "warn,wgpu=error,naga=warn,bevy_light=error,bevy_asset::server=off,bevy_rppm=info"
                    .into(),
            ..default()
        })
    };
    app.add_plugins(plugins).add_plugins((
        RppmPlugin,
        bevy::app::ScheduleRunnerPlugin::run_loop(Duration::ZERO),
    ));
    app.insert_resource(RenderErrorHandler(keep_render_error));
    app
}

/// The first error wgpu reported (validation, out of memory, device lost), on one line: the
/// render loop reports it at once instead of waiting to call the render stalled.
#[derive(Resource)]
pub struct RenderFailure(pub String);

/// Bevy's default handling (stop rendering, exit with an error), keeping the error's text.
fn keep_render_error(
    error: &RenderError,
    main_world: &mut World,
    _: &mut World,
) -> RenderErrorPolicy {
    if !main_world.contains_resource::<RenderFailure>() {
        let text = error.description.split_whitespace().collect::<Vec<_>>();
        main_world.insert_resource(RenderFailure(format!("{:?}: {}", error.ty, text.join(" "))));
    }
    main_world.write_message(AppExit::error());
    RenderErrorPolicy::StopRendering
}

/// An offscreen colour target of the given size.
pub fn offscreen_target(images: &mut Assets<Image>, width: u32, height: u32) -> RenderTarget {
    let mut image = Image::new_target_texture(width, height, TextureFormat::Rgba8UnormSrgb, None);
    image.texture_descriptor.usage |= TextureUsages::COPY_SRC;
    RenderTarget::Image(images.add(image).into())
}

/// What a render has reached, each time a new iteration comes back.
pub struct Progress<'a> {
    pub iteration: u32,
    /// Wall-clock seconds since the frame that rendered the first iteration.
    pub seconds: f64,
    pub budget: Budget,
    pub image: &'a RadianceImage,
}

#[derive(Clone, Copy, Debug)]
pub enum Budget {
    Iterations(u32),
    Seconds(f64),
}

/// A headless render of a glTF file.
#[derive(Clone, Debug)]
pub struct RenderRequest {
    pub scene: PathBuf,
    pub width: u32,
    pub height: u32,
    pub budget: Budget,
    pub settings: PhotonMapping,
}

/// The result: raw radiance and what it cost.
#[derive(Clone, Debug)]
pub struct RenderResult {
    pub image: RgbImage,
    pub iterations: u32,
    /// Wall time from the first iteration to the last.
    pub seconds: f64,
    pub stats: ViewStats,
    pub camera_from_scene: bool,
    pub triangles: usize,
    pub lights: usize,
    pub emitters: usize,
}

/// The longest a render may go without progress before it is called stalled.
pub(crate) const STALL: Duration = Duration::from_secs(120);

/// Renders a glTF scene headless. Every failure is a one-line message.
pub fn render_gltf(
    request: &RenderRequest,
    progress: impl FnMut(&Progress),
) -> Result<RenderResult, String> {
    check_size(request)?;
    let mut app = load_gltf(&request.scene)?;
    render_loaded(&mut app, request, progress)
}

/// The image size is inside 1..=16384 on both sides.
pub fn check_size(request: &RenderRequest) -> Result<(), String> {
    let valid = 1..=16384;
    if valid.contains(&request.width) && valid.contains(&request.height) {
        return Ok(());
    }
    Err(format!(
        "image size {}x{} is outside 1..=16384",
        request.width, request.height
    ))
}

/// Renders a scene that [`load_gltf`] loaded (and the caller may have changed since: scaled,
/// relit) through its first camera, or a default one, as `request` asks.
pub fn render_loaded(
    app: &mut App,
    request: &RenderRequest,
    mut progress: impl FnMut(&Progress),
) -> Result<RenderResult, String> {
    check_size(request)?;
    // A still: a late change (an image still loading) starts the estimate again rather than
    // lingering in its history.
    let mut request = request.clone();
    request.settings.history = RppmHistory::Reset;
    let request = &request;
    app.update(); // extraction sees the caller's changes
    let camera_from_scene = attach_camera(app, request)?;
    let mut query = app
        .world_mut()
        .query_filtered::<Entity, With<PhotonMapping>>();
    let camera = query
        .single(app.world())
        .map_err(|e| format!("no camera to render from: {e}"))?;
    run_until_done(app, camera, request, &mut progress).map(|(image, stats, seconds)| {
        let data = app.world().resource::<RppmScene>().data.clone();
        RenderResult {
            iterations: image.iteration,
            image: RgbImage::from_rgba(image.width, image.height, &image.pixels),
            seconds,
            stats,
            camera_from_scene,
            triangles: data.triangle_count(),
            lights: data.lights.len(),
            emitters: data.emitters.len(),
        }
    })
}

/// Runs the deep-cubemap harness on a glTF scene: the cubemap centred at the scene's camera (or the
/// default camera), `rays` compared with brute force, `timing_rays` timed, per configuration.
pub fn bench_dirt(
    scene: &Path,
    configs: Vec<CubemapConfig>,
    rays: u32,
    timing_rays: u32,
) -> Result<(Vec<CubemapBenchRow>, Vec3), String> {
    let mut app = load_gltf(scene)?;
    let data = app.world().resource::<RppmScene>().data.clone();
    if data.instances.is_empty() {
        return Err(format!("{} has no triangles to trace", scene.display()));
    }
    let mut cameras = app
        .world_mut()
        .query_filtered::<&GlobalTransform, With<Camera3d>>();
    let centre = cameras
        .iter(app.world())
        .next()
        .map(|t| t.translation())
        .unwrap_or_else(|| default_camera(&data).translation);
    app.insert_resource(CubemapBenchRequest {
        configs,
        rays: Arc::new(bench_rays(&data, centre, rays)),
        timing_rays,
        centre,
    });
    let start = Instant::now();
    loop {
        app.update();
        if let Some(result) = app
            .world_mut()
            .resource_mut::<CubemapBenchResults>()
            .0
            .take()
        {
            return result.map(|rows| (rows, centre));
        }
        if start.elapsed() > Duration::from_secs(3600) {
            return Err("the deep-cubemap harness did not finish within an hour".into());
        }
    }
}

/// The documented default camera: 45° vertical field of view, on the +Z side of the scene's
/// bounds, looking down −Z at their centre, far enough to see the bounding sphere.
pub fn default_camera(data: &bevy_rppm::SceneData) -> Transform {
    let (centre, radius) = data.bounding_sphere();
    let distance = radius.max(1e-3) / (DEFAULT_FOV * 0.5).sin() * 1.05;
    Transform::from_translation(centre + Vec3::Z * distance).looking_at(centre, Vec3::Y)
}

const DEFAULT_FOV: f32 = std::f32::consts::FRAC_PI_4;

/// Renders from the scene's first camera, or from a default one: 45° vertical field of view,
/// on the +Z side of the scene's bounds, looking down −Z at their centre, with the request's
/// settings and read-back. Returns whether the scene had a camera.
pub fn attach_camera(app: &mut App, request: &RenderRequest) -> Result<bool, String> {
    let world = app.world_mut();
    let target = offscreen_target(
        &mut world.resource_mut::<Assets<Image>>(),
        request.width,
        request.height,
    );
    let mut settings = request.settings.clone();
    if let Budget::Iterations(n) = request.budget {
        settings.max_iterations = Some(n);
    }
    let components = (target, settings, RppmReadback, Tonemapping::None, Msaa::Off);
    let mut cameras = world.query_filtered::<Entity, With<Camera3d>>();
    let found: Vec<Entity> = cameras.iter(world).collect();
    if let Some(&first) = found.first() {
        for &other in &found[1..] {
            if let Some(mut camera) = world.get_mut::<Camera>(other) {
                camera.is_active = false;
            }
        }
        world.entity_mut(first).insert(components);
        return Ok(true);
    }
    let transform = default_camera(&world.resource::<RppmScene>().data);
    world.spawn((
        Camera3d::default(),
        Projection::Perspective(PerspectiveProjection {
            fov: DEFAULT_FOV,
            ..default()
        }),
        transform,
        components,
    ));
    Ok(false)
}

/// Where the GPU time of the last reported frame went, for a stall's message.
fn stalled_stage(stats: Option<&ViewStats>) -> String {
    let slowest = stats.and_then(|s| {
        s.stage_ms
            .iter()
            .max_by(|a, b| a.1.total_cmp(b.1))
            .map(|(stage, ms)| (stage, ms, s.stage_ms.values().sum::<f64>()))
    });
    match slowest {
        Some((stage, ms, all)) if all > 0.0 => {
            format!(" (its last frame spent {ms:.0} of {all:.0} GPU ms in {stage})")
        }
        _ => " (no GPU time came back: pipelines compiling, or the GPU hung)".into(),
    }
}

/// The error that stopped `camera`'s rendering, if any: one wgpu reported (validation, out
/// of memory, device lost), or a pipeline that failed to build.
pub fn failed(world: &World, camera: Entity) -> Result<(), String> {
    if let Some(failure) = world.get_resource::<RenderFailure>() {
        return Err(format!("the GPU refused to render ({})", failure.0));
    }
    let error = world.resource::<RppmStats>().views.get(&camera);
    match error.and_then(|s| s.error.clone()) {
        Some(error) => Err(error),
        None => Ok(()),
    }
}

fn run_until_done(
    app: &mut App,
    camera: Entity,
    request: &RenderRequest,
    progress: &mut impl FnMut(&Progress),
) -> Result<(RadianceImage, ViewStats, f64), String> {
    let mut first_iteration: Option<Instant> = None;
    let mut last_progress = (0u32, Instant::now());
    // The clock starts with the frame before the first iteration came back: the one that
    // rendered it (its result is read back a frame later).
    let mut previous_frame = Instant::now();
    loop {
        let rendering_frame = previous_frame;
        previous_frame = Instant::now();
        app.update();
        let world = app.world();
        failed(world, camera)?;
        let Some(image) = world
            .resource::<RppmRadiance>()
            .images
            .get(&camera)
            .cloned()
        else {
            if last_progress.1.elapsed() > STALL {
                let stats = world.resource::<RppmStats>().views.get(&camera);
                return Err(format!(
                    "rendering stalled: no image came back from the GPU{}",
                    stalled_stage(stats)
                ));
            }
            continue;
        };
        let stats = world
            .resource::<RppmStats>()
            .views
            .get(&camera)
            .cloned()
            .unwrap_or_default();
        if image.iteration > 0 && first_iteration.is_none() {
            first_iteration = Some(rendering_frame);
        }
        let seconds = first_iteration.map_or(0.0, |t| t.elapsed().as_secs_f64());
        if image.iteration != last_progress.0 {
            last_progress = (image.iteration, Instant::now());
            progress(&Progress {
                iteration: image.iteration,
                seconds,
                budget: request.budget,
                image: &image,
            });
        } else if last_progress.1.elapsed() > STALL {
            return Err(format!(
                "rendering stalled at iteration {}{}",
                image.iteration,
                stalled_stage(Some(&stats))
            ));
        }
        let done = match request.budget {
            Budget::Iterations(n) => image.iteration >= n,
            Budget::Seconds(s) => image.iteration > 0 && seconds >= s,
        };
        if done {
            return Ok((image, stats, seconds));
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_stall_names_the_slowest_stage() {
        let mut stats = ViewStats::default();
        assert!(stalled_stage(Some(&stats)).contains("no GPU time"));
        stats.stage_ms.insert("photon_trace".into(), 900.0);
        stats.stage_ms.insert("gbuffer".into(), 2.0);
        let message = stalled_stage(Some(&stats));
        assert!(
            message.contains("900 of 902 GPU ms in photon_trace"),
            "{message}"
        );
    }
}
