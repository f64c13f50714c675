//! The render-graph system and what feeds it: each camera's state ([`state`]), prepared every
//! frame ([`prepare`]), recorded ([`node`]) and reported back ([`report`]).

mod node;
pub mod pace;
mod prepare;
mod report;
mod stages;
pub mod state;

use bevy::core_pipeline::schedule::{Core3d, Core3dSystems};
use bevy::prelude::*;
use bevy::render::{Render, RenderApp, RenderSystems};

pub(crate) struct GraphPlugin;

impl Plugin for GraphPlugin {
    fn build(&self, app: &mut App) {
        let Some(render_app) = app.get_sub_app_mut(RenderApp) else {
            return;
        };
        render_app
            .add_systems(
                Render,
                (prepare::drop_stale_views, prepare::prepare_views)
                    .chain()
                    .after(crate::scene::prepare::prepare_scene)
                    .in_set(RenderSystems::PrepareResources),
            )
            .add_systems(Render, report::report_views.after(RenderSystems::Render))
            .add_systems(
                Core3d,
                node::rppm_node
                    .after(Core3dSystems::MainPass)
                    .before(Core3dSystems::EarlyPostProcess),
            );
    }
}
