//! Refraction showcase: a glass Stanford bunny (clear glass, IOR 1.5) under a point light,
//! focusing a caustic onto the floor and bending the wall seen through it. The scene is
//! `assets/glass_bunny.gltf`, made by `tools/bunny_gltf.py` from the npm package `bunny`.
//! Keys: G GI on/off, M Full/Indirect mode, + / − photons per iteration, R restart, O overlay;
//! drag the mouse to orbit. `--headless --frames N --out FILE.png` renders offscreen instead.
mod common;

use bevy::prelude::*;
use common::gltf_example;

fn main() {
    gltf_example(
        "bevy_rppm: glass bunny",
        "glass_bunny.gltf",
        Vec3::new(0.0, 0.45, 0.0),
    )
    .run();
}
