#!/usr/bin/env python3
"""The scale table of the README: makes probe scenes of 10³–10⁶ triangles (tools/probe.py),
renders each and prints, per triangle count, start-up time, ms per iteration, GPU ms of the
cubemap build (under the BVH, its CPU build) and the photon trace, list nodes, and memory
held.

    RPPM=target/release/rppm python3 tools/probe_table.py out/probes --size 256 --iterations 4 \
        [--photons N] [--tracer auto|deep-cubemap|bvh]

GPU timestamps overlap on llvmpipe, so there the photon-trace column is left out and the
cubemap build is rough; the wall-clock ms per iteration is not.
"""
import argparse
import json
import os
import subprocess
import sys

HERE = os.path.dirname(os.path.abspath(__file__))


def main():
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("dir")
    p.add_argument("--counts", default="1e3,1e4,1e5,1e6")
    p.add_argument("--size", type=int, default=256)
    p.add_argument("--iterations", type=int, default=4)
    p.add_argument("--photons", type=int)
    p.add_argument("--tracer", choices=["auto", "deep-cubemap", "bvh"])
    args = p.parse_args()
    rppm = os.environ.get("RPPM", "rppm")
    os.makedirs(args.dir, exist_ok=True)
    print(
        "| triangles | start-up s (load + 1st it) | ms / iteration | cubemap build ms | photon trace µs / photon "
        "| list nodes | cubemap MiB | scene MiB | memory held MiB |"
    )
    print("|---:|---:|---:|---:|---:|---:|---:|---:|---:|")
    for count in args.counts.split(","):
        scene = os.path.join(args.dir, f"probe_{count}.gltf")
        if not os.path.exists(scene):
            subprocess.run([sys.executable, os.path.join(HERE, "probe.py"), count, scene], check=True, capture_output=True)
        stats = os.path.join(args.dir, f"probe_{count}.json")
        cmd = [rppm, "render", scene, "--width", str(args.size), "--height", str(args.size)]
        cmd += ["--iterations", str(args.iterations), "--stats", stats, "--out", stats[:-5] + ".png"]
        if args.photons:
            cmd += ["--photons", str(args.photons)]
        if args.tracer:
            cmd += ["--tracer", args.tracer]
        run = subprocess.run(cmd, capture_output=True, text=True)
        if run.returncode != 0:
            print(f"| {count} | failed: {run.stderr.strip().splitlines()[-1:]} |")
            continue
        d = json.load(open(stats))
        gpu, mem = d["gpu_ms_per_iteration"], d["memory_bytes"]
        per_it = d["render_seconds"] / d["iterations"]
        startup = d["total_seconds"] - d["render_seconds"] + per_it
        mib = lambda prefix: sum(v for k, v in mem.items() if k.startswith(prefix)) / 2**20  # noqa: E731
        photons = d["photons_per_iteration"]
        trace = "n/a" if "llvmpipe" in d["adapter"] else f"{gpu['photon_trace'] * 1e3 / photons:.4f}"
        # Under the BVH there is no cubemap build: its CPU build instead.
        build = gpu.get("cubemap_build") or d.get("bvh_build_ms") or 0.0
        print(
            f"| {d['triangles']} | {startup:.1f} | {per_it * 1e3:.0f} | {build:.1f} "
            f"| {trace} | {d['cubemap_nodes']} | {mib('cubemap'):.0f} "
            f"| {mib('scene'):.1f} | {sum(mem.values()) / 2**20:.0f} |",
            flush=True,
        )


if __name__ == "__main__":
    main()
