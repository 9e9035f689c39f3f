"""One light per sample (render(light_sampling="one"), kernels/core/sampler.h light_pick):
each sample traces one shadow ray, toward one of the k lights weighted by k, a pixel's
samples taking the lights in turn (from a per-pixel offset where k does not divide spp). Checked against a float64 numpy
model of the pick on images lit by each light alone, against the every-light image where
the two estimators must agree, and across the kernel's paths (packets or not, several
pixels per work-item, the staged pipeline, adaptive sampling, bands of rows)."""
import dataclasses
import os

import numpy as np
import pytest

import texray as tx
from texray.cli import main
from texray.errors import SceneError

M32 = np.uint64(0xFFFFFFFF)


def hash_u32(x):
    """core/sampler.h hash_u32 in numpy (uint64 arithmetic, kept to 32 bits)."""
    x = np.asarray(x, np.uint64) & M32
    x ^= x >> np.uint64(16); x = (x * np.uint64(0x7feb352d)) & M32
    x ^= x >> np.uint64(15); x = (x * np.uint64(0x846ca68b)) & M32
    x ^= x >> np.uint64(16)
    return x


def block(spp, k):
    """core/sampler.h light_block: the largest power of two up to 8 with spp a multiple of k b."""
    b = 1
    while b < 8 and spp % (2 * b * k) == 0:
        b *= 2
    return b


def picks(width, height, seed, sample, k, spp):
    """light_pick(sample, p, light_offset(p, spp, k), k, light_block(spp, k)) for every pixel's pattern p
    (without adaptive sampling): (height, width) ints."""
    py, px = np.mgrid[0:height, 0:width].astype(np.uint64)
    pattern = hash_u32((py * np.uint64(width) + px) ^ hash_u32(seed))
    off = hash_u32(pattern ^ np.uint64(0x2c1b3c6d)) % np.uint64(k) * np.uint64(spp % k != 0)
    return ((np.uint64(sample // block(spp, k) % k) + off) % np.uint64(k)).astype(int)


_PICK_KERNEL = r"""
#include "core/common.h"
#include "core/sampler.h"
#include "core/camera.h"
__kernel void device_picks(__global uint* out, uint w, uint n, uint seed, uint spp, uint k)
{
    uint i = get_global_id(0);
    if (i >= n) return;
    uint p = pixel_pattern(w, i % w, i / w, seed);
    for (uint s = 0; s < spp; ++s)
        out[i * spp + s] = light_pick(s, p, light_offset(p, spp, k), k, light_block(spp, k));
}
"""


def device_picks(rt, width, height, seed, k, spp, adaptive):
    """The kernels' own light_pick for every sample of every pixel: (spp, height, width) ints."""
    import pyopencl as cl
    from kernel_harness import build_test_program
    prg = build_test_program(rt, (), _PICK_KERNEL, (f"-DTX_ADAPTIVE={int(bool(adaptive))}",))
    n = width * height
    out = np.zeros(n * spp, np.uint32)
    buf = cl.Buffer(rt.context, cl.mem_flags.WRITE_ONLY, out.nbytes)
    u = np.uint32
    prg.device_picks(rt.queue, (n,), None, buf, u(width), u(n), u(seed), u(spp), u(k))
    cl.enqueue_copy(rt.queue, out, buf)
    return out.reshape(height, width, spp).transpose(2, 0, 1).astype(int)


_BLOCK_KERNEL = r"""
#include "core/common.h"
#include "core/sampler.h"
__kernel void device_blocks(__global uint* out, uint nspp, uint nk)
{
    uint i = get_global_id(0);
    if (i < nspp * nk) out[i] = light_block(i / nk + 1u, i % nk + 1u);
}
"""


def test_the_hosts_light_block_is_the_kernels(rt):
    """texray.device.features.light_block (the host's choice of pixels per work-item for light
    blocks) against the kernels' light_block, spp 1..64, 1..9 lights."""
    import pyopencl as cl
    from kernel_harness import build_test_program
    from texray.device.features import light_block
    prg = build_test_program(rt, (), _BLOCK_KERNEL, ("-DTX_ADAPTIVE=0",))
    nspp, nk = 64, 9
    out = np.zeros(nspp * nk, np.uint32)
    buf = cl.Buffer(rt.context, cl.mem_flags.WRITE_ONLY, out.nbytes)
    prg.device_blocks(rt.queue, (out.size,), None, buf, np.uint32(nspp), np.uint32(nk))
    cl.enqueue_copy(rt.queue, out, buf)
    want = [light_block(s, k) for s in range(1, nspp + 1) for k in range(1, nk + 1)]
    assert out.tolist() == want and set(want) == {1, 2, 4, 8}


def alone(scene, lights):
    return dataclasses.replace(scene, lights=lights)


@pytest.mark.parametrize("path, spp, adaptive", [
    ("bench/mixed.toml", 3, None), ("bench/mixed.toml", 5, None), ("bench/textured_meshes.toml", 3, None),
    ("bench/textured_meshes.toml", 24, None), ("bench/textured_meshes.toml", 12, None), ("roles/roles.toml", 7, None),
    ("roles/roles.toml", 11, None), ("roles/roles.toml", 32, None),
    ("bench/mixed.toml", 24, 1e-30)])
def test_each_pixel_takes_the_lights_its_pick_gives(device, rt, scenes_dir, path, spp, adaptive):
    """Every sample at the pixel centre (jitter=False): a pixel's samples differ only in their
    light, so its mean is A + (k / spp) sum_l n_l (S_l - A), with A the unlit image, S_l the
    image lit by light l alone and n_l the samples the numpy model of light_pick gives l (with
    adaptive sampling the kernels' own light_pick, which the next test checks). With
    adaptive sampling at a vanishing threshold only pixels whose samples all agree stop early,
    and their mean is any count's."""
    scene = tx.Scene.load(scenes_dir / path)
    w, h, seed, k = 48, 36, 3, len(scene.lights)
    assert k >= 2
    kw = dict(device=device, seed=seed, jitter=False)
    one = tx.render(scene, w, h, spp, light_sampling="one", adaptive=adaptive, **kw)
    assert one.stats["features"].one_light and one.stats["light_sampling"] == "one"
    # at the same spp: texture footprints shrink with the sample count (kernels/texture/differentials.h)
    a = tx.render(alone(scene, []), w, h, spp, **kw).rgb.astype(np.float64)
    s = [tx.render(alone(scene, [lt]), w, h, spp, **kw).rgb.astype(np.float64) for lt in scene.lights]
    n = np.zeros((k, h, w))
    pk = device_picks(rt, w, h, seed, k, spp, adaptive) if adaptive else [picks(w, h, seed, smp, k, spp)
                                                                          for smp in range(spp)]
    if not adaptive:
        np.testing.assert_array_equal(pk, device_picks(rt, w, h, seed, k, spp, False))
    for smp in range(spp):
        n[pk[smp], np.arange(h)[:, None], np.arange(w)[None, :]] += 1
    assert (n.sum(0) == spp).all() and (n.max(0) - n.min(0)).max() <= (0 if spp % k == 0 else 1)   # stratified
    want = a + k / spp * sum(n[i][..., None] * (s[i] - a) for i in range(k))
    np.testing.assert_allclose(one.rgb, want, rtol=2e-5, atol=2e-6)
    # where k does not divide spp the offset differs from pixel to pixel: every light takes the
    # first sample somewhere; where it does, every pixel's sample s takes light (s / b) % k
    # (core/sampler.h light_offset: 0), so that several pixels' light blocks share a packet
    if spp % k or adaptive:
        assert all((np.asarray(pk[0]) == i).any() for i in range(k))
    else:
        for smp in range(spp):
            assert (np.asarray(pk[smp]) == smp // block(spp, k) % k).all()


@pytest.mark.parametrize("spp, k", [(32, 2), (16, 2), (64, 4), (24, 3), (12, 2)])
def test_adaptive_picks_are_stratified_per_row_pass_and_not_tied_to_rows(rt, spp, k):
    """With adaptive sampling the pixel's samples take the pattern's rows in turn
    (core/sampler.h cmj_cell): each run of b = rows samples (light_block) gives every light
    as many of its samples (to one, where k does not divide b), in an order of its own, so that
    no light keeps to some rows: over the pixels, each row's samples take every light."""
    w, h = 24, 16
    m = int(np.floor(np.sqrt(spp)))
    while spp % m:
        m -= 1
    rows = spp // m
    pk = device_picks(rt, w, h, 5, k, spp, True)                    # (spp, h, w)
    for start in range(0, spp - rows + 1, rows):
        run = pk[start:start + rows]
        counts = np.stack([(run == i).sum(0) for i in range(k)])
        assert counts.max(0).max() - counts.min(0).min() <= (0 if rows % k == 0 else 1), (spp, k, start)
    # sample s lies in row s % rows: the fraction of pixels that give light 0 to each row's
    # samples is near 1 / k for every row, not 0 or 1 (a light tied to rows)
    for r in range(rows):
        frac = np.mean(pk[r::rows] == 0)
        assert abs(frac - 1 / k) < 0.15, (spp, k, r, frac)


@pytest.mark.parametrize("path", ["bench/mixed.toml", "bench/textured_meshes.toml"])
def test_a_multiple_of_the_light_count_is_the_every_light_image_at_the_pixel_centre(device, scenes_dir, path):
    scene = tx.Scene.load(scenes_dir / path)
    kw = dict(device=device, jitter=False, seed=1)
    for spp in (2, 4, 12, 32):               # blocks of 1, 2, 2 and 8 samples
        one = tx.render(scene, 40, 30, spp, light_sampling="one", **kw).rgb
        every = tx.render(scene, 40, 30, spp, **kw).rgb
        assert np.abs(every - every.mean()).max() > 0.05      # a lit, shadowed image
        np.testing.assert_allclose(one, every, rtol=3e-6, atol=1e-7)


def test_it_converges_to_the_every_light_image(device, scenes_dir):
    """With jitter, one light per sample is noisier per sample but has the same mean."""
    scene = tx.Scene.load(scenes_dir / "bench/mixed.toml")
    ref = tx.render(scene, 40, 30, 256, device=device, seed=2).rgb.astype(np.float64)
    one = tx.render(scene, 40, 30, 256, device=device, seed=2, light_sampling="one").rgb
    every = tx.render(scene, 40, 30, 16, device=device, seed=3).rgb
    one16 = tx.render(scene, 40, 30, 16, device=device, seed=3, light_sampling="one").rgb
    assert abs(one.mean() / ref.mean() - 1) < 2e-3
    rmse = lambda x: np.sqrt(np.mean((x - ref) ** 2))
    assert rmse(one) < 0.5 * rmse(one16)             # 256 samples beat 16
    assert rmse(every) < rmse(one16) < 4 * rmse(every)   # the noise the cheaper samples add, bounded


@pytest.mark.parametrize("spp", [1, 2, 3, 4, 5, 12, 16, 24])
def test_every_path_gives_the_same_image(device, scenes_dir, monkeypatch, spp):
    """Packets of 8 and 16 (several pixels per work-item below 8 spp; with light blocks, at 4,
    12, 16 and 24 spp, a packet holds one block of 2, 8, 8 or 4 samples of each of 8, 2, 2 or 4
    pixels, the image's last work-item fewer pixels: pixel by pixel) and the scalar path trace
    the same shadow rays toward the same lights; the staged pipeline computes the same terms."""
    scene = tx.Scene.load(scenes_dir / "bench/textured_meshes.toml")
    kw = dict(device=device, seed=4, light_sampling="one")
    imgs = {}
    for width in ("0", "8", "16"):
        monkeypatch.setenv("TEXRAY_PACKET", width)
        imgs[width] = tx.render(scene, 37, 23, spp, **kw)
    monkeypatch.delenv("TEXRAY_PACKET")
    staged = tx.render(scene, 37, 23, spp, pipeline="stages", **kw).rgb
    every = tx.render(scene, 37, 23, spp, device=device, seed=4).rgb
    assert imgs["8"].stats["packet"] == 8 and imgs["0"].stats["packet"] == 0
    for width in ("8", "16"):
        np.testing.assert_array_equal(imgs[width].rgb, imgs["0"].rgb)
    np.testing.assert_allclose(staged, imgs["0"].rgb, rtol=4e-7, atol=1e-9)   # per-launch partial sums
    assert not np.array_equal(imgs["0"].rgb, every)     # a different estimator


@pytest.mark.parametrize("per_launch", [6, 8])
def test_light_blocks_in_launches_of_part_of_the_samples(device, scenes_dir, monkeypatch, per_launch):
    """Where a launch sums only part of a pixel's samples (tiling.MAX_FUSED_SAMPLES), light
    blocks hold for launches of whole blocks (8 of 16 samples, two lights: blocks of 8) and the
    kernel goes pixel by pixel for the others (6: launches starting inside a block): the image
    is the scalar path's either way, bit for bit."""
    from texray.renderer import tiling
    scene = tx.Scene.load(scenes_dir / "bench/textured_meshes.toml")
    w, h = 29, 11
    monkeypatch.setattr(tiling, "MAX_FUSED_SAMPLES", w * per_launch)
    assert tiling.fused_samples(w, h, 16) == per_launch
    imgs = {}
    for width in ("0", "16"):
        monkeypatch.setenv("TEXRAY_PACKET", width)
        imgs[width] = tx.render(scene, w, h, 16, device=device, seed=6, light_sampling="one")
    assert imgs["16"].stats["packet"] == 16 and imgs["0"].stats["packet"] == 0
    np.testing.assert_array_equal(imgs["16"].rgb, imgs["0"].rgb)
    assert imgs["0"].rgb.std() > 0.05


def test_rows_and_adaptive_sampling(device, scenes_dir):
    scene = tx.Scene.load(scenes_dir / "showcase.toml")
    kw = dict(device=device, light_sampling="one")
    whole = tx.render(scene, 48, 40, 6, **kw).rgb
    band = tx.render(scene, 48, 40, 6, rows=(16, 32), **kw).rgb
    np.testing.assert_array_equal(band, whole[16:32])
    ada = tx.render(scene, 48, 40, 32, adaptive=0.05, **kw)
    assert ada.stats["features"].adaptive and ada.stats["features"].one_light
    ref = tx.render(scene, 48, 40, 256, device=device, seed=9).rgb
    full = tx.render(scene, 48, 40, 32, **kw)
    err = lambda img: np.sqrt(np.mean((img - ref) ** 2))
    assert np.all(np.isfinite(ada.rgb)) and ada.stats["samples"] < 0.9 * 48 * 40 * 32
    assert err(ada.rgb) < 1.1 * err(full.rgb), (err(ada.rgb), err(full.rgb))


def test_one_light_changes_nothing_with_one_light_or_none(device, scenes_dir):
    scene = tx.Scene.load(scenes_dir / "bench/globe.toml")
    assert len(scene.lights) == 1
    a = tx.render(scene, 32, 24, 4, device=device, light_sampling="one")
    b = tx.render(scene, 32, 24, 4, device=device)
    assert not a.stats["features"].one_light
    np.testing.assert_array_equal(a.rgb, b.rgb)
    dark = alone(scene, [])
    np.testing.assert_array_equal(tx.render(dark, 16, 12, 2, device=device, light_sampling="one").rgb,
                                  tx.render(dark, 16, 12, 2, device=device).rgb)


@pytest.mark.parametrize("value", ["two", "One", None, 1])
def test_bad_values_are_named(value):
    with pytest.raises(SceneError, match=r"render: light_sampling: expected one of all, one"):
        tx.render(tx.Scene(), 8, 8, 1, light_sampling=value)


def test_scene_files_and_the_cli_take_it(tmp_path, capsys):
    body = ('[[lights]]\nposition = [0, 2, 4]\n[[lights]]\nposition = [3, 2, 1]\n'
            '[[objects]]\ntype = "sphere"\n')
    path = tmp_path / "s.toml"
    path.write_text('[render]\nwidth = 8\nheight = 6\nspp = 2\nlight_sampling = "one"\n' + body)
    scene = tx.Scene.load(path)
    assert scene.render_settings["light_sampling"] == "one"
    main(["render", str(path), "-o", str(tmp_path / "a.exr"), "--no-cache"])
    assert "one light per sample" in capsys.readouterr().out
    main(["render", str(path), "-o", str(tmp_path / "b.exr"), "--no-cache", "--light-sampling", "all"])
    assert "one light per sample" not in capsys.readouterr().out
    bad = tmp_path / "bad.toml"
    bad.write_text('[render]\nlight_sampling = "some"\n' + body)
    with pytest.raises(SceneError, match=r"bad\.toml: render\.light_sampling: expected one of all, one.*'some'"):
        tx.Scene.load(bad)
    with pytest.raises(SystemExit):
        main(["render", str(path), "-o", str(tmp_path / "c.exr"), "--light-sampling", "half"])
