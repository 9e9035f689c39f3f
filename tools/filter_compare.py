#!/usr/bin/env python3
"""Render scenes/roles/grazing_floor.toml once per texture filter (bilinear, trilinear,
anisotropic; 1 jittered sample per pixel, seed 0) and stack the images, labelled, into one
PNG (README "Textures").

    python tools/filter_compare.py [--out docs/filter_compare.png] [--device cpu] [--spp 1]
"""
from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np
from PIL import Image, ImageDraw

import texray as tx
from texray.io.colour import linear_to_srgb

ROOT = Path(__file__).resolve().parent.parent
FILTERS = ("bilinear", "trilinear", "anisotropic")


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--scene", default=str(ROOT / "scenes" / "roles" / "grazing_floor.toml"))
    ap.add_argument("--out", default=str(ROOT / "docs" / "filter_compare.png"))
    ap.add_argument("--device", default=None)
    ap.add_argument("--spp", type=int, default=1)
    args = ap.parse_args(argv)
    scene = tx.Scene.load(args.scene)
    w, h = scene.render_settings.get("width", 640), scene.render_settings.get("height", 200)
    rows = []
    for f in FILTERS:
        img = tx.render(scene, w, h, args.spp, device=args.device, texture_filter=f)
        rgb = (np.clip(linear_to_srgb(np.clip(img.rgb, 0, 1)), 0, 1) * 255 + 0.5).astype(np.uint8)
        tile = Image.fromarray(rgb)
        draw = ImageDraw.Draw(tile)
        label = f"{f}, {args.spp} spp"
        draw.rectangle((4, 4, 10 + 6 * len(label), 18), fill=(0, 0, 0))
        draw.text((7, 5), label, fill=(255, 255, 255))
        rows.append(tile)
    out = Image.new("RGB", (w, h * len(rows) + 2 * (len(rows) - 1)), (255, 255, 255))
    for i, tile in enumerate(rows):
        out.paste(tile, (0, i * (h + 2)))
    out.save(args.out)
    print(f"wrote {args.out}")


if __name__ == "__main__":
    main()
