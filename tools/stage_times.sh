#!/usr/bin/env bash
# Milliseconds per stage per iteration, and memory, for a list of glTF scenes, as a markdown
# table: the numbers the issues ask for on a real GPU.
#   tools/stage_times.sh OUT_DIR SCENE.gltf... [-- extra rppm render flags]
# Defaults: 1024×1024 (SIZE), 262 144 photons (PHOTONS), photon and eye depth 3 (PHOTON_DEPTH,
# EYE_DEPTH), 32 iterations (ITERATIONS). GPU timestamps, or with `-- --profile` the wall
# time of each stage submitted alone (trustworthy on llvmpipe). RPPM names the binary
# (default: built with cargo).
set -euo pipefail
out=$1
shift
scenes=()
while [[ $# -gt 0 && $1 != -- ]]; do
    scenes+=("$1")
    shift
done
[[ ${1:-} == -- ]] && shift
mkdir -p "$out"
rppm=${RPPM:-}
if [[ -z $rppm ]]; then
    cargo build --release -p bevy_rppm_cli --bin rppm
    rppm=${CARGO_TARGET_DIR:-target}/release/rppm
fi
for scene in "${scenes[@]}"; do
    name=$(basename "${scene%.*}")
    "$rppm" render "$scene" --width "${SIZE:-1024}" --height "${SIZE:-1024}" \
        --photons "${PHOTONS:-262144}" --photon-depth "${PHOTON_DEPTH:-3}" \
        --eye-depth "${EYE_DEPTH:-3}" --iterations "${ITERATIONS:-32}" "$@" \
        --stats "$out/$name.json" >"$out/$name.log" 2>&1 ||
        echo "$name failed: $(tail -3 "$out/$name.log")"
done
python3 - "$out" "${scenes[@]}" <<'PY'
import json, os, sys
out, scenes = sys.argv[1], sys.argv[2:]
rows = []
for scene in scenes:
    name = os.path.splitext(os.path.basename(scene))[0]
    try:
        rows.append((name, json.load(open(os.path.join(out, name + ".json")))))
    except (OSError, ValueError):
        pass
wall = any(d.get("wall_ms_per_iteration") for _, d in rows)
clock = "wall_ms_per_iteration" if wall else "gpu_ms_per_iteration"
stages = sorted({s for _, d in rows for s, ms in d[clock].items() if ms > 0})
print("adapter:", rows[0][1]["adapter"] if rows else "none", "·", clock)
print("| scene | triangles | " + " | ".join(stages) + " | total ms | MiB |")
print("|---|---:|" + "---:|" * (len(stages) + 2))
for name, d in rows:
    ms = d[clock]
    mib = sum(d["memory_bytes"].values()) / 2**20
    cells = " | ".join(f"{ms.get(s, 0):.3f}" for s in stages)
    print(f"| {name} | {d['triangles']} | {cells} | {sum(ms.values()):.2f} | {mib:.0f} |")
PY
