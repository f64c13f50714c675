#!/usr/bin/env bash
# Installs what bevy_rppm needs on a fresh Debian/Ubuntu machine that has Rust: a Vulkan
# driver. Machines without a GPU get Mesa's software Vulkan (lavapipe).
set -euo pipefail

# An ICD manifest in either standard place, and the loader. (`grep -q` would stop reading
# early and fail the pipe under pipefail; `ls` of two globs fails when one place is empty.)
have_vulkan_driver() {
    compgen -G '/usr/share/vulkan/icd.d/*.json' >/dev/null ||
        compgen -G '/etc/vulkan/icd.d/*.json' >/dev/null || return 1
    ldconfig -p 2>/dev/null | grep 'libvulkan\.so\.1' >/dev/null
}

if ! have_vulkan_driver; then
    echo "setup: no Vulkan driver found; installing Mesa's Vulkan drivers (mesa-vulkan-drivers)" >&2
    sudo=""
    if [ "$(id -u)" != 0 ]; then sudo="sudo"; fi
    export DEBIAN_FRONTEND=noninteractive
    $sudo apt-get update -qq
    $sudo apt-get install -y -qq mesa-vulkan-drivers libvulkan1 >/dev/null
fi
