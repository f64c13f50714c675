#!/usr/bin/env python3
"""The deep cubemap against its BVH peer (README, issue 14): for each scene, `rppm bench dirt
--json` at the default cubemap setting; prints agreement with brute force, build ms and
million rays per second of both, as a Markdown table.

    RPPM=target/release/rppm python3 tools/tracer_table.py SCENE.gltf... [--rays N]

Brute force tests every triangle for every compared ray, so scenes over 10⁵ triangles are
compared on fewer rays (--rays-large); the timing always traces --timing-rays.
"""
import argparse
import json
import os
import subprocess


def main():
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("scenes", nargs="+")
    p.add_argument("--rays", type=int, default=65536)
    p.add_argument("--rays-large", type=int, default=2048)
    p.add_argument("--timing-rays", type=int, default=1 << 20)
    args = p.parse_args()
    rppm = os.environ.get("RPPM", "rppm")
    print("| scene | triangles | tracer | agreement (false misses, hits) | build ms | M rays/s | MiB |")
    print("|---|---:|---|---:|---:|---:|---:|")
    for scene in args.scenes:
        name = os.path.splitext(os.path.basename(scene))[0]
        size = os.path.getsize(os.path.splitext(scene)[0] + ".bin") if os.path.exists(os.path.splitext(scene)[0] + ".bin") else 0
        rays = args.rays_large if size > 4_000_000 else args.rays
        cmd = [rppm, "bench", "dirt", scene, "--json", "--resolutions", "256", "--bins", "12",
               "--rays", str(rays), "--timing-rays", str(args.timing_rays)]
        run = subprocess.run(cmd, capture_output=True, text=True)
        if run.returncode != 0:
            print(f"| {name} | – | failed: {run.stderr.strip().splitlines()[-1:]} |")
            continue
        report = json.loads(run.stdout)
        for row in report["settings"]:
            triangles = f"{row['triangles']:,}".replace(",", " ")
            tracer = "deep cubemap" if row["tracer"] == "deep_cubemap" else "BVH (CPU build)"
            rate = row["timing_rays"] / max(row["trace_ms"], 1e-9) / 1e3
            print(
                f"| {name} | {triangles} | {tracer} | {row['agreement']:.5f} ({row['false_misses']}, {row['false_hits']}) "
                f"| {row['build_ms']:.1f} | {rate:.2f} | {row['bytes'] / 2**20:.1f} |"
            )


if __name__ == "__main__":
    main()
