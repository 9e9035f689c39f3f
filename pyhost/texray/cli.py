"""Command line: ``texray render``, ``texray devices``, ``texray bench``, ``texray cache``."""
from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

from . import __version__
from .bench import main as bench_main
from .compile import cache as scene_cache
from .device import devices
from .device.features import LIGHT_SAMPLING
from .errors import TexrayError
from .io.images import write_exr_layers
from .renderer import render
from .renderer.distributed import add_cluster_arguments, cluster_client
from .scene import Scene


class _Progress:
    """A one-line progress bar on stderr, shown only once a render has run for a second."""

    def __init__(self, stream=sys.stderr):
        self.stream, self.t0, self.shown = stream, time.perf_counter(), False

    def __call__(self, fraction):
        elapsed = time.perf_counter() - self.t0
        if not self.shown and elapsed < 1.0:      # renders under a second show no bar at all
            return
        self.shown = True
        bar = "#" * int(30 * fraction)
        eta = elapsed / max(fraction, 1e-9) - elapsed
        self.stream.write(f"\rrendering [{bar:<30}] {100 * fraction:5.1f}%  {elapsed:6.1f}s  eta {eta:5.1f}s")
        self.stream.flush()

    def close(self):
        if self.shown:
            self.stream.write("\n")


def _int_at_least(lo, what):
    """An argparse type: an integer >= lo (0 is refused for sizes, not taken for "the scene's value")."""
    def parse(text):
        try:
            v = int(text)
        except ValueError:
            v = None
        if v is None or v < lo:
            raise argparse.ArgumentTypeError(f"expected {what}, got {text}")
        return v
    return parse


_positive = _int_at_least(1, "a positive integer")
_non_negative = _int_at_least(0, "an integer >= 0")


def _positive_number(text):
    try:
        v = float(text)
    except ValueError:
        v = None
    if v is None or not v > 0 or v == float("inf"):
        raise argparse.ArgumentTypeError(f"expected a positive number, got {text}")
    return v


def _cmd_render(args):
    scene = Scene.load(args.scene, camera=args.camera)
    settings = getattr(scene, "render_settings", {})
    width = args.width if args.width is not None else settings.get("width", 640)
    height = args.height if args.height is not None else settings.get("height", 480)
    if args.width is not None and args.height is None and settings.get("aspect"):   # a glTF camera's aspect ratio
        height = max(1, round(width / settings["aspect"]))
    spp = args.spp if args.spp is not None else settings.get("spp", 4)
    seed = args.seed if args.seed is not None else settings.get("seed", 0)
    adaptive = args.adaptive if args.adaptive is not None else settings.get("adaptive")
    light_sampling = args.light_sampling or settings.get("light_sampling", "all")
    device = int(args.device) if args.device is not None and args.device.isdigit() else args.device
    bar = _Progress()
    try:
        with cluster_client(args.scheduler, args.workers) as client:
            image = render(scene, width=width, height=height, spp=spp, device=device, seed=seed, progress=bar,
                           aovs=tuple(args.aov or ()), adaptive=adaptive, cache=not args.no_cache, client=client,
                           light_sampling=light_sampling)
    finally:
        bar.close()
    image.save(args.output)
    if args.aov and not args.output.lower().endswith(".exr"):
        aov_path = Path(args.output).with_suffix(".aov.exr")
        write_exr_layers(aov_path, image.rgb, image.aov)
        print(f"AOVs ({', '.join(args.aov)}) written to {aov_path}")
    s = image.stats
    db = s["device_bytes"]
    spp_text = f"{spp} spp" if adaptive is None else f"<= {spp} spp (adaptive {adaptive:g}: {s['samples'] / (width * height):.1f} on average)"
    if s["features"].one_light:
        spp_text += ", one light per sample"
    print(f"{args.output}: {width}x{height}, {spp_text}, {s['triangles']} triangles on {s['device']}: "
          f"render {s['render_s']:.2f} s (program build {s['program_build_s']:.2f} s, "
          f"scene {s['scene_compile_s']:.2f} s); device memory {sum(db.values()) / 2**20:.1f} MiB scene "
          f"(textures {db.get('texels', 0) / 2**20:.1f}) + {s['ray_buffer_bytes'] / 2**20:.1f} MiB rays")
    if "dask" in s:
        d = s["dask"]
        shipped = f"{d['ship_bytes'] / 2**20:.1f} MiB in {d['ship_s']:.2f} s" if d["shipped"] else "held from before"
        print(f"  on Dask: {d['bands']} bands of {d['band_rows']} rows over {d['workers']} workers "
              f"(median band {d['task_s_median']:.2f} s); scene: {shipped}")


def _cmd_cache(args):
    if args.action == "clear":
        n, size = scene_cache.clear()
        print(f"removed {n} compiled scenes ({size / 2**20:.1f} MiB) from {scene_cache.settings().directory}")
        return
    i = scene_cache.info()
    print(f"{i['directory']}: {i['entries']} compiled scenes, {i['bytes'] / 2**20:.1f} MiB of at most "
          f"{i['size_limit'] / 2**20:.0f} MiB ({scene_cache.ENV_SIZE}); "
          f"{'on' if i['enabled'] else 'off (' + scene_cache.ENV_OFF + ')'}")


def _cmd_devices(args):
    devs = devices()
    if not devs:
        print("no OpenCL devices")
    for d in devs:
        print(d)


def main(argv=None):
    argv = sys.argv[1:] if argv is None else list(argv)
    if argv[:1] == ["bench"]:             # the benchmark parses its own options
        return bench_main(argv[1:])
    p = argparse.ArgumentParser(prog="texray", description="Ray trace textured scenes with OpenCL.")
    p.add_argument("--version", action="version", version=f"texray {__version__}")
    sub = p.add_subparsers(dest="command", required=True)
    r = sub.add_parser("render", help="render a scene file (.toml, .gltf, .glb) to an image",
                       description="Render a scene file (.toml, see the README's \"Scene files\"; or a whole "
                                   "glTF 2.0 file, .gltf/.glb, see \"glTF scenes\") to an image. "
                                   "--width, --height, --spp, --seed, --adaptive and --light-sampling, when not given, "
                                   "come from the scene's [render] table, else the defaults below.")
    r.add_argument("scene", help="the scene file (.toml, .gltf, .glb); paths in it are relative to it")
    r.add_argument("--camera", metavar="NAME",
                   help="glTF files: the camera node to render from (default: the file's first camera)")
    r.add_argument("-o", "--output", required=True,
                   help="output image (required): .png, .jpg, .tif (sRGB 8-bit) or .exr (linear half)")
    r.add_argument("--width", type=_positive, help="image width in pixels (default: the scene's [render] width, else 640)")
    r.add_argument("--height", type=_positive,
                   help="image height in pixels (default: the scene's [render] height, else 480)")
    r.add_argument("--spp", type=_positive, help="samples per pixel (default: the scene's [render] spp, else 4)")
    r.add_argument("--seed", type=_non_negative,
                   help="sample-pattern seed (default: the scene's [render] seed, else 0)")
    r.add_argument("--adaptive", type=_positive_number, metavar="T",
                   help="adaptive sampling: a pixel stops once the standard error of its mean luminance is <= T "
                        "x max(mean, 0.1); --spp is then the most it takes (default: the scene's [render] "
                        "adaptive, else off)")
    r.add_argument("--light-sampling", choices=LIGHT_SAMPLING,
                   help="'all': every sample sums every light (a shadow ray each); 'one': each sample traces "
                        "one shadow ray, toward one light weighted by the light count: fewer rays, more noise "
                        "per sample with several lights (default: the scene's [render] light_sampling, else all)")
    r.add_argument("--device", help="'cpu', 'gpu', an index from 'texray devices', or a name substring "
                                    "(default: PYOPENCL_CTX if set, else a GPU, else PoCL's CPU device)")
    r.add_argument("--aov", action="append", metavar="NAME",
                   help="also write this AOV (repeatable): uv, position, normal, shading_normal, depth, "
                        "primitive_id, object_id, dpdu, dpdv; into OUT if it is .exr, else OUT.aov.exr "
                        "(default: none)")
    add_cluster_arguments(r)
    r.add_argument("--no-cache", action="store_true",
                   help="compile the scene here, neither reading nor writing the scene cache (see 'texray cache')")
    r.set_defaults(func=_cmd_render)
    c = sub.add_parser("cache", help="the compiled-scene cache: 'info' (where, how big) or 'clear'",
                       description="Compiled scenes (BVH, packed arrays, MIP pyramids) are kept by content hash "
                                   "so that rendering a scene again skips compiling it (the README's \"Scene "
                                   "cache\"): TEXRAY_CACHE_DIR, TEXRAY_CACHE_SIZE, TEXRAY_NO_CACHE=1.")
    c.add_argument("action", choices=("info", "clear"), nargs="?", default="info")
    c.set_defaults(func=_cmd_cache)
    d = sub.add_parser("devices", help="list OpenCL devices")
    d.set_defaults(func=_cmd_devices)
    sub.add_parser("bench", help="run the kernel benchmark (see 'texray bench --help')")
    args = p.parse_args(argv)
    try:
        return args.func(args) or 0
    except TexrayError as e:
        print(f"texray: error: {e}", file=sys.stderr)
        return 2


if __name__ == "__main__":
    sys.exit(main())
