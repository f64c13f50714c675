#!/usr/bin/env python3
"""Averages independent Mitsuba renders of one scene (different `--seed`s) into one reference,
each weighted by its samples per pixel: the result is a render of their total spp.

    python3 tools/merge_references.py a.exr:8192 b.exr:16384 --out merged.exr
"""
import argparse

import mitsuba as mi
import numpy as np


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("renders", nargs="+", help="PATH.exr:SPP, rendered with different seeds")
    parser.add_argument("--out", required=True)
    args = parser.parse_args()
    mi.set_variant("scalar_rgb")
    total, weight = None, 0
    for item in args.renders:
        path, spp = item.rsplit(":", 1)
        bitmap = mi.Bitmap(path).convert(mi.Bitmap.PixelFormat.RGB, mi.Struct.Type.Float32)
        image = np.array(bitmap, dtype=np.float64) * int(spp)
        if total is not None and image.shape != total.shape:
            raise SystemExit(f"{path}: {image.shape[1]}x{image.shape[0]}, not the others' size")
        total = image if total is None else total + image
        weight += int(spp)
    mi.Bitmap(np.ascontiguousarray(total / weight, dtype=np.float32)).write(args.out)
    print(f"wrote {args.out}: {weight} spp from {len(args.renders)} renders")


if __name__ == "__main__":
    main()
