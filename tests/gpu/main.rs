//! End-to-end tests on a real GPU adapter (Mesa's software Vulkan in CI), one test binary:
//! scene extraction, lighting against analytic answers, the deep cubemap, convergence, modes,
//! robustness, the examples and the CLI.
//!
//! Without an adapter these tests fail with the install hint; they never skip.

#[cfg(not(feature = "debug"))]
compile_error!(
    "the GPU tests use bevy_rppm's debug views: run them as `cargo test --workspace` (the tool \
     crate turns the `debug` feature on) or with `--features debug`"
);

mod bsdf;
mod cli;
mod cubemap;
mod deform;
mod examples;
mod extraction;
mod instances;
mod lighting;
mod modes;
mod motion;
mod ppm;
mod robustness;
mod rooms;
mod scripted_motion;
mod sky;
mod suite;
mod textures;
mod util;
mod variants;
