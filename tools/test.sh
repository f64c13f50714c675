#!/usr/bin/env bash
# Runs every test: unit tests and the GPU tests on whatever Vulkan adapter is present
# (Mesa's software one on machines without a GPU). One test at a time: each GPU test runs a
# whole Bevy app, and the CI machine has 2 cores.
set -euo pipefail
cd "$(dirname "$0")/.."
bash tools/setup.sh
cargo test -- --test-threads=1
