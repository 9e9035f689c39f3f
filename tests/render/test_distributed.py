"""Rendering on a Dask cluster (texray.renderer.distributed) and in bands of rows: the
same image as one local render, bit for bit (a band's pixels depend on the image, not
on how it is cut), for render(client=), render(rows=), render_frames and the command
line; a worker killed mid-render changes nothing; errors on a worker arrive as the
same texray exception. One LocalCluster of two worker processes (one thread each)
serves the module."""
import copy
import json
import os
import signal
import sys

import numpy as np
import pytest

import texray as tx
from texray.errors import DeviceError, SceneError
from texray.io.images import read_image
from texray.renderer import adaptive, distributed, tiling

dd = pytest.importorskip("dask.distributed")


@pytest.fixture(scope="module")
def client():
    with dd.LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None) as cluster, \
            dd.Client(cluster) as c:
        c.wait_for_workers(2, timeout=120)
        yield c
    for c in distributed._clients.values():
        c.close()
    distributed._clients.clear()


@pytest.fixture
def many_bands(monkeypatch):
    """Bands of one block (16 rows) even for small test images."""
    monkeypatch.setattr(distributed, "MIN_BAND_SAMPLES", 1)
    monkeypatch.setattr(distributed, "MIN_BAND_SECONDS", 0.0)


def _scene(scenes_dir):
    return tx.Scene.load(scenes_dir / "showcase.toml")


def test_bands_of_rows_equal_the_whole_image(scenes_dir, device, monkeypatch):
    """Rows rendered alone equal the whole image's, also where the fused kernel sums its
    samples in several launches and the tiles differ (the launch grouping comes from the
    image, not the tile)."""
    scene = _scene(scenes_dir)
    monkeypatch.setattr(tiling, "MAX_FUSED_SAMPLES", 2 * 48 * 5)      # 5 samples of 2 rows a launch
    assert tiling.fused_samples(48, 40, 5) == 5 and tiling.fused_rows(48, 5) == 2
    whole = tx.render(scene, 48, 40, 5, device=device, aovs=("depth",))
    tiled = tx.render(scene, 48, 40, 5, device=device, tile_pixels=48 * 7)
    assert whole.stats["tiles"] == tiled.stats["tiles"] == 20
    np.testing.assert_array_equal(tiled.rgb, whole.rgb)
    monkeypatch.setattr(tiling, "MAX_FUSED_SAMPLES", 2 * 48)          # 2 samples per launch, one row
    assert tiling.fused_samples(48, 40, 5) == 2
    whole = tx.render(scene, 48, 40, 5, device=device, aovs=("depth",))
    tiled = tx.render(scene, 48, 40, 5, device=device, tile_pixels=48 * 7)
    assert tiled.stats["tiles"] == 40
    np.testing.assert_array_equal(tiled.rgb, whole.rgb)
    for rows in ((0, 40), (3, 17), (16, 32), (39, 40)):
        band = tx.render(scene, 48, 40, 5, device=device, rows=rows, aovs=("depth",), tile_pixels=48 * 4)
        assert band.rgb.shape == (rows[1] - rows[0], 48, 3)
        np.testing.assert_array_equal(band.rgb, whole.rgb[rows[0]:rows[1]])
        np.testing.assert_array_equal(band.aov["depth"], whole.aov["depth"][rows[0]:rows[1]])


def test_adaptive_sampling_is_independent_of_the_tiles(scenes_dir, device):
    """A pixel's samples depend on its block of 16 rows only: any tiling of whole blocks,
    and any band of whole blocks, gives the same image and sample counts."""
    scene = _scene(scenes_dir)
    whole = tx.render(scene, 40, 48, 24, device=device, adaptive=0.05)
    tiled = tx.render(scene, 40, 48, 24, device=device, adaptive=0.05, tile_pixels=40 * 20)
    assert tiled.stats["tile_rows"] == 16 and tiled.stats["tiles"] == 3
    np.testing.assert_array_equal(tiled.rgb, whole.rgb)
    assert tiled.stats["samples"] == whole.stats["samples"] < 40 * 48 * 24
    band = tx.render(scene, 40, 48, 24, device=device, adaptive=0.05, rows=(16, 48))
    np.testing.assert_array_equal(band.rgb, whole.rgb[16:])
    with pytest.raises(SceneError, match="multiples of 16"):
        tx.render(scene, 40, 48, 24, device=device, adaptive=0.05, rows=(8, 48))


@pytest.mark.parametrize("rows, match", [((5, 5), "0 <= y0 < y1"), ((0, 41), "0 <= y0 < y1"), ((-1, 3), "0 <= y0"),
                                         ((1.0, 3), "two integers"), ("0:3", "two integers"), ((1, 2, 3), "two")])
def test_bad_rows_are_named(rows, match):
    with pytest.raises(SceneError, match=r"rows: .*" + match):
        tx.render(tx.Scene(), 8, 40, 1, rows=rows)


def test_band_sizes():
    B = adaptive.BLOCK_ROWS
    assert distributed.band_rows(640, 480, 16, 2) == 64                  # 8 bands: 4 per worker, whole blocks
    assert distributed.band_rows(640, 480, 16, 1) == 128                 # 4 bands
    assert distributed.band_rows(64, 48, 1, 8) == 48                     # too little work for two bands
    assert distributed.band_rows(4096, 4096, 64, 100) == B               # no more bands than blocks
    assert distributed.band_rows(100, 7, 1000, 4) == 7
    # workers timed at 2e7 and 1e8 pixel samples per second (GPUs): bands of at least 0.1 s of work
    assert distributed.band_rows(640, 480, 16, 2, rate=2e7) == 240       # 4.9M samples: 2 bands
    assert distributed.band_rows(640, 480, 16, 2, rate=1e8) == 480       # the frame is 0.05 s: one
    assert distributed.band_rows(640, 480, 16, 2, rate=1e5) == 64        # slower than the floor: as without
    for w, h, spp, n in ((640, 480, 16, 2), (1920, 1080, 64, 16), (33, 1000, 3, 3)):
        r = distributed.band_rows(w, h, spp, n)
        assert (r % B == 0 or r == h) and 0 < r <= h


def test_render_on_the_cluster_equals_the_local_render(scenes_dir, device, client, many_bands):
    scene = _scene(scenes_dir)
    local = tx.render(scene, 64, 72, 6, device=device, aovs=("uv", "object_id"))
    fractions = []
    far = tx.render(scene, 64, 72, 6, device=device, aovs=("uv", "object_id"), client=client,
                    progress=fractions.append)
    d = far.stats["dask"]
    assert d["bands"] == 5 and d["band_rows"] == 16 and d["workers"] == 2
    np.testing.assert_array_equal(far.rgb, local.rgb)
    for name in ("uv", "object_id"):
        np.testing.assert_array_equal(far.aov[name], local.aov[name])
    assert far.stats["samples"] == local.stats["samples"] and far.stats["triangles"] == local.stats["triangles"]
    assert fractions == sorted(fractions) and fractions[-1] == 1.0 and len(fractions) == 5
    # the scene went to the workers once: the second render sends nothing
    again = tx.render(scene, 64, 72, 6, device=device, aovs=("uv", "object_id"), client=client)
    assert d["shipped"] and d["ship_bytes"] > 0 and not again.stats["dask"]["shipped"]
    np.testing.assert_array_equal(again.rgb, local.rgb)
    # a band, adaptive sampling, and a sink given the bands in order
    ada = tx.render(scene, 64, 72, 16, device=device, adaptive=0.05, rows=(16, 72))
    far_ada = tx.render(scene, 64, 72, 16, device=device, adaptive=0.05, rows=(16, 72), client=client)
    np.testing.assert_array_equal(far_ada.rgb, ada.rgb)
    assert far_ada.stats["samples"] == ada.stats["samples"]
    got = []
    tx.render(scene, 64, 72, 6, device=device, client=client, sink=lambda y0, rgb, aov: got.append((y0, rgb)))
    assert [y0 for y0, _ in got] == [0, 16, 32, 48, 64]
    np.testing.assert_array_equal(np.concatenate([rgb for _, rgb in got]), local.rgb)


def test_a_worker_killed_mid_render_changes_nothing(scenes_dir, device, client, many_bands):
    scene = _scene(scenes_dir)
    local = tx.render(scene, 48, 160, 24, device=device)
    pids = sorted(client.run(os.getpid).values())
    killed = []

    def kill_one(fraction):
        if not killed:                    # after the first band: a band in flight dies with its worker
            killed.append(fraction)
            os.kill(pids[0], signal.SIGKILL)

    far = tx.render(scene, 48, 160, 24, device=device, client=client, progress=kill_one)
    assert killed and killed[0] < 1.0
    np.testing.assert_array_equal(far.rgb, local.rgb)
    client.wait_for_workers(2, timeout=120)      # the nanny restarts it for the next tests


def test_a_band_the_cluster_loses_is_submitted_again(scenes_dir, device, client, many_bands, monkeypatch):
    """A band task cancelled by someone else (as when a worker dies while its result is being
    fetched: Dask's "already forgotten") is submitted again, up to BAND_RETRIES times; then a
    DeviceError names the rows."""
    from texray.renderer.render import setup
    scene = _scene(scenes_dir)
    local = tx.render(scene, 48, 64, 4, device=device)
    s = setup(scene, 48, 64, 4, device=device)
    bands = distributed.submit_bands(client, s.cs, s.camera, 48, 64, 4, None, s.options)
    assert len(bands.futures) >= 3
    lost = bands.futures[1]
    client.cancel(lost)
    out = bands.collect()
    np.testing.assert_array_equal(out.rgb, local.rgb)
    assert bands.futures[1].key != lost.key          # the band went out again, under a new key
    monkeypatch.setattr(distributed, "BAND_RETRIES", 0)
    bands = distributed.submit_bands(client, s.cs, s.camera, 48, 64, 4, None, s.options)
    client.cancel(bands.futures[2])
    a, b = bands.bands[2]
    with pytest.raises(DeviceError, match=f"lost the band of rows {a}..{b - 1} 1 times"):
        bands.collect()


def test_a_scene_the_cluster_loses_is_shipped_again(scenes_dir, device, client, many_bands):
    """Where the scene's scattered copies are lost (here: cancelled), the bands on it are
    cancelled with it; each is submitted again on a scene shipped again, not on the lost one
    (which would lose it BAND_RETRIES more times: the flaky worker-killed test). Both workers
    are held busy until the scene is cancelled, so that no band can finish before it is."""
    from texray.renderer.render import setup
    scene = _scene(scenes_dir)
    local = tx.render(scene, 48, 64, 4, device=device)
    s = setup(scene, 48, 64, 4, device=device)
    go = dd.Event(f"texray-test-go-{os.getpid()}")
    held = [client.submit(lambda name: dd.Event(name).wait(120), go.name, workers=[w], pure=False)
            for w in client.scheduler_info()["workers"]]
    bands = distributed.submit_bands(client, s.cs, s.camera, 48, 64, 4, None, s.options)
    assert len(bands.futures) >= 3
    shipped, _, _ = distributed.ship(client, s.cs)
    client.cancel(shipped, force=True)
    go.set()
    assert all(f.result() for f in held)
    out = bands.collect()
    np.testing.assert_array_equal(out.rgb, local.rgb)
    again, _, info = distributed.ship(client, s.cs)
    assert again.status == "finished" and again.key != shipped.key and not info["shipped"]


def test_worker_errors_arrive_as_texray_errors(scenes_dir, client):
    scene = _scene(scenes_dir)
    with pytest.raises(DeviceError, match="no-such-device"):
        tx.render(scene, 16, 16, 1, device="no-such-device", client=client)
    with pytest.raises(SceneError, match="each worker chooses its device"):
        tx.render(scene, 16, 16, 1, device=object(), client=client)


def test_bad_clients_and_a_missing_dask_are_named(monkeypatch):
    with pytest.raises(SceneError, match="render: client: expected a dask.distributed.Client"):
        tx.render(tx.Scene(), 8, 8, 1, client=42)
    monkeypatch.setitem(sys.modules, "dask.distributed", None)      # as if not installed
    with pytest.raises(SceneError, match=r"pip install 'texray\[dask\]'"):
        tx.render(tx.Scene(), 8, 8, 1, client="tcp://127.0.0.1:1")
    with pytest.raises(SceneError, match=r"--workers: .*pip install 'texray\[dask\]'"):
        with distributed.cluster_client(None, 2):
            pass


def test_render_frames_equal_single_renders(scenes_dir, device, client, tmp_path, many_bands, monkeypatch):
    scene = _scene(scenes_dir)
    cameras = [tx.Camera(eye=(3.6 * np.sin(a), 1.4, 3.6 * np.cos(a)), look_at=(0, 0.7, 0), fov_y=32)
               for a in (0.0, 0.7, 1.4)]
    singles = []
    for cam in cameras:
        scene.camera = cam
        singles.append(tx.render(scene, 40, 32, 4, device=device).rgb)
    from texray.compile import cache as scene_cache
    compiles = []
    real = scene_cache.compile_scene
    monkeypatch.setattr(scene_cache, "compile_scene", lambda *a, **k: compiles.append(1) or real(*a, **k))
    frames = tx.render_frames(scene, cameras, 40, 32, 4, device=device, cache=False)
    far = tx.render_frames(scene, cameras, 40, 32, 4, device=device, client=client, cache=False)
    assert len(compiles) == 2              # the scene is compiled once per call, not once per frame
    assert len(frames) == len(far) == 3
    for one, a, b in zip(singles, frames, far):
        np.testing.assert_array_equal(a.rgb, one)
        np.testing.assert_array_equal(b.rgb, one)
    assert not np.array_equal(singles[0], singles[1])
    stats = tx.render_frames(scene, cameras, 40, 32, 4, device=device, client=client,
                             paths=str(tmp_path / "f{:02d}.exr"))
    assert len(stats) == 3 and all("dask" in s for s in stats)
    for i, one in enumerate(singles):
        back, _ = read_image(tmp_path / f"f{i:02d}.exr")
        np.testing.assert_allclose(back[..., :3], one, rtol=1e-3, atol=1e-3)     # half floats


def test_render_frames_of_moving_instances_rebuild_only_the_top_level(device, client):
    from texray.compile import instances as inst_blas
    from texray.procedural import meshes
    inst_blas._TREES.clear()
    md = meshes.torus(24, 12)
    mesh = tx.Mesh(md.positions, md.faces, md.uvs, md.normals, tx.Material(diffuse=(0.8, 0.3, 0.2)))
    base = tx.Scene(camera=tx.Camera(eye=(0, 0, 4), look_at=(0, 0, 0)),
                    lights=[tx.PointLight(position=(2, 3, 4), intensity=(20, 20, 20))])
    scenes = []
    for f in range(3):
        s = copy.copy(base)
        s.objects = [tx.Instance(mesh, tx.Transform(translate=(i - 1.0, 0.2 * f, 0), rotate=(30 * f, 10 * i, 0),
                                                    scale=0.4)) for i in range(3)]
        scenes.append(s)
    local = tx.render_frames(scenes, None, 48, 48, 2, device=device, cache=False)
    assert [im.stats["blas_reused"] for im in local] == [0, 1, 1]
    far = tx.render_frames(scenes, None, 48, 48, 2, device=device, cache=False, client=client)
    assert [im.stats["blas_reused"] for im in far] == [1, 1, 1]     # the trees are still held
    for a, b, s in zip(local, far, scenes):
        np.testing.assert_array_equal(a.rgb, b.rgb)
        np.testing.assert_array_equal(a.rgb, tx.render(s, 48, 48, 2, device=device, cache=False).rgb)
    assert not np.array_equal(local[0].rgb, local[1].rgb)


@pytest.mark.parametrize("args, match", [
    (([],), "no frames"), ((tx.Scene(),), "cameras: expected a list"), ((tx.Scene(), [1]), r"cameras\[0\]"),
    (([tx.Scene(), 3],), r"scenes\[1\]"), (([tx.Scene()], [tx.Camera(), tx.Camera()]), "2 cameras for 1 scenes"),
    ((tx.Scene(), [tx.Camera()], 8, 8, 1, {"paths": "one.png"}), "a single path"),
    ((tx.Scene(), [tx.Camera()], 8, 8, 1, {"paths": ["a.png", "b.png"]}), "expected 1 paths"),
    ((tx.Scene(), [tx.Camera()], 8, 8, 1, {"sink": print}), "unknown option 'sink'")])
def test_render_frames_bad_input_is_named(args, match):
    kw = args[-1] if isinstance(args[-1], dict) else {}
    pos = args[:-1] if kw else args
    with pytest.raises(SceneError, match=match):
        tx.render_frames(*pos, **kw)


def test_the_cli_on_a_scheduler_writes_the_same_file(scenes_dir, device, client, tmp_path, many_bands, capsys,
                                                     monkeypatch):
    from texray.cli import main
    scene = str(scenes_dir / "showcase.toml")
    args = ["render", scene, "--width", "48", "--height", "40", "--spp", "3", "--device", str(device), "--no-cache"]
    assert main(args + ["-o", str(tmp_path / "local.png")]) == 0
    monkeypatch.setattr(distributed, "CONNECT_TIMEOUT", "2s")
    address = client.scheduler.address
    assert main(args + ["-o", str(tmp_path / "far.png"), "--scheduler", address]) == 0
    assert "on Dask: 3 bands of 16 rows over 2 workers" in capsys.readouterr().out
    assert (tmp_path / "far.png").read_bytes() == (tmp_path / "local.png").read_bytes()
    assert main(args + ["-o", str(tmp_path / "own.png"), "--workers", "1"]) == 0     # a LocalCluster of its own
    assert "over 1 workers" in capsys.readouterr().out
    assert (tmp_path / "own.png").read_bytes() == (tmp_path / "local.png").read_bytes()
    assert main(args + ["-o", str(tmp_path / "x.png"), "--scheduler", "tcp://127.0.0.1:9"]) == 2
    assert "cannot reach the Dask scheduler" in capsys.readouterr().err


def test_bench_sweeps_run_as_tasks_with_the_same_errors(device, client, tmp_path, capsys):
    """``texray bench --scheduler``: every sweep point is a task on the cluster (the
    reference renders in bands); the errors equal a local run's exactly. The
    displacement sweep's points go the same way (one of them here: a task's image equals
    the local one)."""
    from texray.bench import sweep
    from texray.bench.suite import suite_paths
    from texray.cli import main
    args = ["bench", "--device", str(device), "--rays", "0", "--scenes", "", "--repeat", "1",
            "--sweep", "globe", "--sweep-size", "24x16", "--ref-spp", "8", "--sweep-spp", "1,2"]
    here, far = tmp_path / "here.json", tmp_path / "far.json"
    assert main(args + ["--json", str(here)]) == 0
    assert main(args + ["--json", str(far), "--scheduler", client.scheduler.address]) == 0
    capsys.readouterr()
    (a,), (b,) = (list(json.loads(p.read_text())["devices"].values()) for p in (here, far))
    sa, sb = a["sweeps"]["globe"]["series"], b["sweeps"]["globe"]["series"]
    assert list(sa) == list(sb) and len(sa) >= 2
    for name in sa:
        assert [(p["label"], p["rmse"]) for p in sa[name]] == [(p["label"], p["rmse"]) for p in sb[name]]
        assert all(p["frame_s"]["median"] > 0 for p in sb[name])
    terrain = tx.Scene.load(suite_paths(["terrain"])["terrain"])
    setting = sweep.displacement_series(terrain)[0][1][0][1]
    shared = (terrain, 16, 12, device, 1)
    (local,), (task,) = (sweep.run_points(sweep.displacement_point, shared, [setting], c) for c in (None, client))
    np.testing.assert_array_equal(task[0].rgb, local[0].rgb)
    np.testing.assert_array_equal(task[0].aov["depth"], local[0].aov["depth"])
