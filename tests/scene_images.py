"""Stored images of every scene in scenes/: what refactors are held to.

Each scene renders at WIDTH x HEIGHT, SPP samples (fused pipeline, seed 0) and is
stored twice under tests/render/scene_images/: the sha256 of the float32 image in
``hashes.json`` together with the device that rendered it (bit for bit: checked
when the test runs on that same device, driver and CPU), and a 16-bit sRGB PNG
(checked on every device within the tolerance of the device-agreement test; and
a file to look at).

    python tests/scene_images.py --write [--device D]    # after a deliberate change of the images

rewrites both; the commit says which scenes changed and why."""
from __future__ import annotations

import argparse
import hashlib
import json
import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
SCENES = ROOT / "scenes"
STORE = Path(__file__).resolve().parent / "render" / "scene_images"
WIDTH, HEIGHT, SPP = 96, 72, 2


def scene_paths():
    """Every TOML scene and whole glTF scene in scenes/."""
    return sorted([*SCENES.rglob("*.toml"), *SCENES.rglob("*.glb"), *SCENES.rglob("*.gltf")])


def key(path) -> str:
    return path.relative_to(SCENES).as_posix()


def png_path(path) -> Path:
    return STORE / (key(path).replace("/", "__").removesuffix(path.suffix) + ".png")


def device_signature(device=None) -> str:
    """The driver, the device and, for a CPU device, the widest vector instruction set its CPU
    has: PoCL names every AMD EPYC alike but links a builtin library built for that set
    (kernel-x86_64-...-avx2.bc or -avx512.bc), whose last bits differ (roles/roles.toml)."""
    from texray.device import runtime
    import pyopencl as cl
    d = runtime(device).device
    sig = f"{d.platform.version.strip()} | {d.name.strip()}"
    return sig + f" | {cpu_isa()}" if d.type & cl.device_type.CPU else sig


def cpu_isa() -> str:
    """The widest of AVX-512, AVX2 and AVX in this machine's CPU flags (Linux), else 'unknown'."""
    try:
        flags = set(next(line for line in open("/proc/cpuinfo") if line.startswith("flags")).split())
    except (OSError, StopIteration):
        return "unknown"
    return next((name for name, flag in (("avx512", "avx512f"), ("avx2", "avx2"), ("avx", "avx")) if flag in flags),
                "unknown")


def render(path, device=None):
    import texray as tx
    return tx.render(tx.Scene.load(path), WIDTH, HEIGHT, SPP, device=device, seed=0).rgb


def sha256(rgb) -> str:
    return hashlib.sha256(np.ascontiguousarray(rgb, np.float32).tobytes()).hexdigest()


def read_png(path) -> np.ndarray:
    """The stored image, linear float32 (H, W, 3)."""
    import OpenImageIO as oiio
    from texray.io.colour import srgb_to_linear
    buf = oiio.ImageBuf(str(path))
    return srgb_to_linear(np.asarray(buf.get_pixels(oiio.FLOAT), np.float64)[:, :, :3]).astype(np.float32)


def write_png(path, rgb):
    import OpenImageIO as oiio
    from texray.io.colour import linear_to_srgb
    srgb = np.clip(linear_to_srgb(np.clip(rgb, 0.0, 1.0).astype(np.float64)), 0.0, 1.0)
    spec = oiio.ImageSpec(rgb.shape[1], rgb.shape[0], 3, oiio.UINT16)
    out = oiio.ImageOutput.create(str(path))
    if out is None or not out.open(str(path), spec):
        raise RuntimeError(f"cannot write {path}: {oiio.geterror()}")
    out.write_image(np.round(srgb * 65535).astype(np.uint16))
    out.close()


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--write", action="store_true", help="render every scene and store hashes and PNGs")
    ap.add_argument("--device", default=None)
    args = ap.parse_args(argv)
    if not args.write:
        ap.error("nothing to do: pass --write")
    sys.path.insert(0, str(ROOT / "pyhost"))
    STORE.mkdir(parents=True, exist_ok=True)
    store = STORE / "hashes.json"
    old = json.loads(store.read_text()) if store.exists() else {"scenes": {}}
    sig = device_signature(args.device)
    hashes = {}
    for p in scene_paths():
        rgb = render(p, args.device)
        hashes[key(p)] = sha256(rgb)
        write_png(png_path(p), rgb)
        before = old.get("scenes", {}).get(key(p))
        print(f"{key(p)}: {hashes[key(p)][:16]} {'unchanged' if before == hashes[key(p)] else 'CHANGED'}")
    store.write_text(json.dumps({"device": sig, "width": WIDTH, "height": HEIGHT, "spp": SPP,
                                 "scenes": hashes}, indent=1) + "\n")


if __name__ == "__main__":
    main()
