#!/usr/bin/env bash
# The library crate pulls in no window, UI, text, font, image-file, plotting or argument
# crates: a game that adds bevy_rppm gets only what a render plugin needs.
set -euo pipefail
cd "$(dirname "$0")/.."
tree=$(cargo tree -p bevy_rppm -e normal --prefix none --format '{p}')
forbidden='^(winit|x11rb|x11-dl|bevy_winit|bevy_ui|bevy_ui_render|bevy_text|plotters|exr|png|zune-jpeg|jpeg-decoder|clap|indicatif|csv|anyhow|serde_json) '
if bad=$(grep -E "$forbidden" <<<"$tree" | sort -u) && [ -n "$bad" ]; then
    echo "check_lean: bevy_rppm depends on crates a render plugin does not need:" >&2
    echo "$bad" >&2
    exit 1
fi
echo "check_lean: bevy_rppm's normal dependencies hold no window, UI, font, image-file, plotting or CLI crate"
