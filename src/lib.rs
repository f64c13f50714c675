//! # bevy_rppm
//!
//! Rasterisation-based progressive photon mapping for Bevy: global illumination and caustics
//! on any GPU, no ray-tracing hardware, fully dynamic scenes.
//!
//! ```no_run
//! use bevy::prelude::*;
//! use bevy_rppm::{PhotonMapping, RppmPlugin};
//!
//! App::new()
//!     .add_plugins((DefaultPlugins, RppmPlugin))
//!     .add_systems(Startup, |mut commands: Commands| {
//!         commands.spawn((Camera3d::default(), PhotonMapping::default()));
//!     })
//!     .run();
//! ```

pub mod cubemap;
mod debug_view;
pub mod diagnostics;
pub mod example;
pub mod headless;
pub mod image_io;
mod output;
mod photons;
mod pipelines;
pub mod scene;
mod settings;
mod shadows;
pub mod timing;
pub mod trade;
mod variants;
mod view;

use bevy::core_pipeline::schedule::{Core3d, Core3dSystems};
use bevy::prelude::*;
use bevy::render::extract_component::ExtractComponentPlugin;
use bevy::render::extract_resource::ExtractResourcePlugin;
use bevy::render::{Render, RenderApp, RenderStartup, RenderSystems};
use bevy::shader::Shader;

/// The README's code, compiled by `cargo test --doc`.
#[doc = include_str!("../README.md")]
#[cfg(doctest)]
pub struct ReadmeDoctests;

pub use output::{RadianceImage, RppmRadiance, RppmReadback, RppmStats, ViewStats};
pub use scene::{RppmScene, SceneData};
pub use settings::{PhotonMapping, RppmDebugView, RppmFastForward, RppmMode, RppmPreset};
pub use view::{next_radius2, radius2_after};

/// Adds photon mapping to every camera that has a [`PhotonMapping`] component.
pub struct RppmPlugin;

impl Plugin for RppmPlugin {
    fn build(&self, app: &mut App) {
        let Some(mut shader_assets) = app.world_mut().get_resource_mut::<Assets<Shader>>() else {
            error!(
                "bevy_rppm: RppmPlugin needs Bevy's render plugins; add it after DefaultPlugins"
            );
            return;
        };
        let shaders = pipelines::RppmShaders::load(&mut shader_assets);
        let (sender, receiver) = crossbeam_channel::unbounded();
        app.register_type::<PhotonMapping>()
            .register_type::<RppmReadback>()
            .add_plugins((
                scene::SceneExtractionPlugin,
                ExtractComponentPlugin::<PhotonMapping>::default(),
                ExtractResourcePlugin::<RppmScene>::default(),
                ExtractResourcePlugin::<cubemap::bench::DirtBenchRequest>::default(),
            ))
            .init_resource::<cubemap::bench::DirtBenchResults>()
            .init_resource::<RppmStats>()
            .init_resource::<RppmRadiance>()
            .insert_resource(output::MainReceiver(receiver))
            .add_systems(PreUpdate, output::receive_reports)
            .add_systems(PostUpdate, settings::validate_settings);
        diagnostics::register(app);
        let Some(render_app) = app.get_sub_app_mut(RenderApp) else {
            return;
        };
        render_app
            .insert_resource(shaders)
            .insert_resource(output::RenderSender(sender))
            .init_resource::<view::RppmViews>()
            .add_systems(
                RenderStartup,
                (
                    pipelines::init_pipelines,
                    cubemap::init_cubemap_pipelines,
                    cubemap::bench::init_bench_pipelines,
                    debug_view::init_debug_view_pipelines,
                    photons::init_photon_pipelines,
                )
                    .chain(),
            )
            .add_systems(
                Render,
                (scene::gpu::upload_scene, view::prepare_views)
                    .chain()
                    .in_set(RenderSystems::PrepareResources),
            )
            .add_systems(Render, view::report_views.after(RenderSystems::Render))
            .add_systems(
                Render,
                cubemap::bench::run_dirt_bench
                    .after(RenderSystems::PrepareResources)
                    .before(RenderSystems::Render),
            )
            .add_systems(
                Core3d,
                view::rppm_node
                    .after(Core3dSystems::MainPass)
                    .before(Core3dSystems::EarlyPostProcess),
            );
    }
}
