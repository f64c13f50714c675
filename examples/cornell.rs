//! The Cornell box under photon mapping, with an orbiting camera.
//! Keys: G GI on/off, M Full/Indirect mode, + / − photons per iteration, R restart, O overlay;
//! drag the mouse to orbit. `--headless --frames N --out FILE.png` renders offscreen instead.
mod common;

use bevy::prelude::*;
use common::gltf_example;

fn main() {
    gltf_example(
        "bevy_rppm: Cornell box",
        "cornell_box.gltf",
        Vec3::new(0.0, 1.0, 0.0),
    )
    .run();
}
