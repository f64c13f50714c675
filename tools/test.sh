#!/usr/bin/env bash
# Runs every test: the library stays lean, then unit tests, the GPU tests on whatever Vulkan
# adapter is present (Mesa's software one on machines without a GPU), the tool crate's tests,
# the examples' build and the README's code. One test at a time: each GPU test runs a whole
# Bevy app, and the CI machine has 2 cores.
set -euo pipefail
cd "$(dirname "$0")/.."
bash tools/setup.sh
bash tools/check_lean.sh
cargo test --workspace -- --test-threads=1
