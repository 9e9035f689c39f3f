"""Adaptive sampling: stop sampling the pixels whose estimate has converged.

A render with ``adaptive=threshold`` samples every pixel of a tile in rounds
(:func:`round_sizes`: the first of :func:`round_size` samples, then each as many as
all before it), the same sample indices for every pixel still sampled, so each
pixel's samples are the first ones of its spp-sample pattern (in the stratified
order of kernels/core/sampler.h cmj_cell).
After each round a pixel's error is the standard error of its mean luminance
Y = 0.2126 R + 0.7152 G + 0.0722 B,

    se = sqrt(var / n),   var = (sum Y^2 - (sum Y)^2 / n) / (n - 1),

and it has converged when ``se <= threshold * max(mean Y, FLOOR)``: a relative
error, with an absolute floor in the dark, where relative errors are not seen.
The device decides, in float32 (kernels/core/adaptive.h, stages/adaptive.cl; the
tests hold it to tests/reference.py's float64 rule), and the host reads back only
how many pixels go on (texray.renderer.frame adaptive_tile).
The estimate of a pixel can be wrong when its first samples all missed a small
feature; a pixel keeps sampling while any of its 3x3 neighbours does (a dilation
of the unconverged set), so that an edge or highlight seen by one pixel keeps its
neighbours sampling too. Pixels stop at ``spp`` samples whatever their error.

The neighbours are those of the pixel's block of BLOCK_ROWS image rows (rows
y // BLOCK_ROWS alike): tiles hold whole blocks, so what a pixel takes depends on
its block alone, never on how the image is tiled, and a band of whole blocks
rendered alone (a Dask task) equals those rows of the whole image. (A tile smaller
than a block, under a tiny memory limit, dilates within the tile.)
"""
from __future__ import annotations

FLOOR = 0.1          # mean luminance below which the error is measured absolutely (threshold * FLOOR; a kernel argument)
MIN_SAMPLES = 4      # the first round: enough samples for a variance estimate (in cmj_cell's order, README)
BLOCK_ROWS = 16      # image rows whose pixels see each other's state (the dilation's unit; a kernel argument)


def round_size(spp: int) -> int:
    """Samples of the first round: at least MIN_SAMPLES, about spp / 8."""
    return int(min(spp, max(MIN_SAMPLES, spp // 8)))


def round_sizes(spp: int) -> list[int]:
    """The rounds' sample counts, up to spp in all: the first round_size(spp), then each as
    many as all before it (at least the first's), so that a pixel takes at most about twice
    the samples it needed and a render about log2(spp / round_size) + 2 rounds, each a
    device decision, a read-back of a count and a launch (rounds of spp / 8 throughout took 8 at most: on the globe at <= 32
    spp the frame took 1.15 times as long for the same samples and error)."""
    first, done, out = round_size(spp), 0, []
    while done < spp:
        out.append(min(max(first, done), spp - done))
        done += out[-1]
    return out
