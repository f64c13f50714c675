#!/usr/bin/env bash
# The main job: render the default scene headless to out/ (EXR, PNG preview, stats JSON).
# Extra arguments go to the `rppm` CLI, e.g. `tools/render.sh render scene.gltf --out x.exr`.
set -euo pipefail
cd "$(dirname "$0")/.."
bash tools/setup.sh
cargo run -p bevy_rppm_cli --bin rppm -- "$@"
