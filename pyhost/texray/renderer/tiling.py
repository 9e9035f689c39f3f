"""How a render is cut into launches: bands of whole rows that fit the device's memory
and a launch's time budget."""
from __future__ import annotations

from ..device import layout
from ..errors import DeviceError
from .. import validate as V


# Samples per launch of the fused kernel (pixels x samples): bounds a launch's run time
# like MAX_TILE_PIXELS does for the stage kernels.
MAX_FUSED_SAMPLES = 1 << 22

# The most rays in flight per launch: bounds a launch's run time (GPU display watchdogs
# kill kernels after ~2 s; 2^20 incoherent rays take a few ms on a GPU, ~0.5 s on PoCL).
MAX_TILE_PIXELS = 1 << 20


def plan_rows(width, height, per_ray_bytes, scene_bytes, dev, memory_limit=None, tile_pixels=None) -> int:
    """Rows per tile: whole rows, as many as fit both ``tile_pixels`` (default
    MAX_TILE_PIXELS) and the device memory left after the scene's arrays, within
    ``memory_limit`` (default a quarter of the device's memory) and the largest
    single allocation. Raises DeviceError when not even one row fits."""
    if memory_limit is None:
        memory_limit = dev.global_mem_size // 4
    memory_limit = V.integer(memory_limit, "memory_limit", "render: ", 1)
    free = memory_limit - scene_bytes
    if free < per_ray_bytes * width:
        raise DeviceError(f"render: the scene's arrays take {scene_bytes / 2**20:.1f} MiB and one row of "
                          f"{width} pixels {per_ray_bytes * width / 2**20:.2f} MiB, more than the memory "
                          f"limit {memory_limit / 2**20:.1f} MiB of {dev.name.strip()}")
    max_buffer = max(layout.SURFACE.itemsize, 4 * layout.AOV_FLOATS)    # the largest per-ray buffer
    by_memory = min(free // per_ray_bytes, dev.max_mem_alloc_size // max_buffer)
    limit = MAX_TILE_PIXELS if tile_pixels is None else V.integer(tile_pixels, "tile_pixels", "render: ", 1)
    pixels = min(by_memory, limit)
    return int(max(1, min(height, pixels // width)))


def fused_samples(width, height, spp, rows=1) -> int:
    """Samples of every pixel that one launch of the fused kernel sums (each launch adds
    its sum to the pixel's accumulator, so this fixes the order of the additions): all
    ``spp`` where ``rows`` rows' take at most MAX_FUSED_SAMPLES (adaptive sampling: a block
    of rows, its unit), else as many as fit; launches of fewer rows keep within
    MAX_FUSED_SAMPLES (:func:`fused_rows`). A function of the image alone, not of the tiles
    a device's memory or ``tile_pixels`` cut it into, so any band of rows rendered alone
    sums its samples as the whole image does.

    A pixel's samples in one launch run through one work-item, a packet's lanes one pixel's
    samples (texray.device.features.pixels_per_item). Until 2026-12-07 the launches covered
    the default tile's rows and split the samples instead (640x480 at 16 spp: launches of 13
    and 3, packets shared by pixels): the textured meshes' frame took 1.10 times as long
    (208 against 190 ms, PoCL, the AMD EPYC)."""
    return max(1, spp if width * rows * spp <= MAX_FUSED_SAMPLES else MAX_FUSED_SAMPLES // (width * rows))


def fused_rows(width, per_launch, rows=1) -> int:
    """The most rows a launch of the fused kernel takes with ``per_launch`` samples per pixel
    (:func:`fused_samples`): at most MAX_FUSED_SAMPLES pixel samples, and at least ``rows``."""
    return max(rows, MAX_FUSED_SAMPLES // (width * per_launch))
