"""Rendering on a Dask cluster: an image cut into bands of rows, one task per band.

``render(..., client=)`` and ``render_frames(..., client=)`` come here. The client
compiles the scene once (with the scene cache, as a local render does) and sends the
compiled scene to every worker once (:func:`ship`: ``Client.scatter(broadcast=True)``,
remembered per client by the scene's content hash, so the frames of a camera path or
a second render of the same scene send nothing). Each task then renders its band with
:func:`texray.renderer.frame.render_rows` on the worker's device; the worker keeps its
OpenCL runtime and built programs (texray.device.runtime is per process) and the
scene's device buffers (texray.renderer.uploads, keyed by the client's
:func:`~texray.renderer.uploads.compiled_key`) across tasks.

A band is a pure function of (compiled scene, camera, rows, samples, seed): its pixels
equal those rows of a local render bit for bit (texray.renderer.frame), so a task lost
with its worker is run again elsewhere and the image is unchanged. An exception on a
worker is raised on the client as the same texray exception with its message.

Band size (:func:`band_rows`): whole blocks of adaptive sampling (16 rows), about
TASKS_PER_WORKER bands per worker so that a slow or lost worker is balanced by the
others, and at least MIN_BAND_SAMPLES pixel samples per band so that the per-task
overhead (a few milliseconds: the README's "Rendering on a cluster") stays small
against the band's time.
"""
from __future__ import annotations

import argparse
import contextlib
import dataclasses
import os
import time
import uuid
import weakref
from collections import OrderedDict
from dataclasses import dataclass, field

import numpy as np

from ..errors import DeviceError, SceneError
from .. import validate as V
from .adaptive import BLOCK_ROWS
from .frame import ROW_OPTIONS, device_program, launch_samples, render_rows
from . import uploads

TASKS_PER_WORKER = 4          # bands per worker, for balance
MIN_BAND_SAMPLES = 1 << 18    # pixel samples per band at least: ~0.1 s on one PoCL core at 16 spp
MIN_BAND_SECONDS = 0.1        # ... and, once a client's workers were timed, this long a band at their rate
SHIPPED_PER_CLIENT = 4        # compiled scenes kept on a cluster per client (newest first)
INSTALL = "pip install 'texray[dask]'"
CONNECT_TIMEOUT = "10s"          # to reach a scheduler given by its address
BAND_RETRIES = 3                 # times a band the cluster lost (a task cancelled not by texray) is resubmitted

_clients: dict = {}                                   # scheduler address -> Client made for it
_shipped: "weakref.WeakKeyDictionary" = weakref.WeakKeyDictionary()   # Client -> OrderedDict(key -> Future)
_rates: "weakref.WeakKeyDictionary" = weakref.WeakKeyDictionary()     # Client -> pixel samples per second per task


def _dask(where):
    """dask.distributed, imported on first use (texray does not need it otherwise);
    SceneError saying what to install where it is missing."""
    try:
        import dask.distributed as dd
    except ImportError:
        raise SceneError(f"{where}: rendering on a Dask cluster needs dask.distributed, which is not "
                         f"installed: {INSTALL}") from None
    return dd


def connect(client, where="render: client"):
    """The dask.distributed.Client for ``client`` (a Client, or a scheduler's address, for
    which one Client per process is made and kept). SceneError without Dask installed
    (saying what to install) or for anything else; DeviceError when the scheduler cannot
    be reached."""
    dd = _dask(where)
    if isinstance(client, dd.Client):
        return client
    if isinstance(client, str) and client:
        c = _clients.get(client)
        if c is None or c.status not in ("running", "connecting"):
            try:
                c = _clients[client] = dd.Client(client, timeout=CONNECT_TIMEOUT)
            except (OSError, TimeoutError) as e:
                raise DeviceError(f"{where}: cannot reach the Dask scheduler at {client!r}: {e}") from None
        return c
    raise SceneError(f"{where}: expected a dask.distributed.Client or a scheduler address "
                     f"('tcp://host:8786'), got {V.show(client)}")


def add_cluster_arguments(parser):
    """The command line's --scheduler and --workers (texray render, texray bench)."""
    g = parser.add_mutually_exclusive_group()
    g.add_argument("--scheduler", metavar="ADDR",
                   help="render on the Dask cluster of this scheduler (tcp://host:8786); pip install 'texray[dask]'")
    g.add_argument("--workers", type=_worker_count, metavar="N",
                   help="start a Dask LocalCluster of N worker processes (one thread each) on this machine "
                        "and render on it")


def _worker_count(text):
    try:
        n = int(text)
    except ValueError:
        n = 0
    if n < 1:
        raise argparse.ArgumentTypeError(f"expected a positive number of worker processes, got {text}")
    return n


@contextlib.contextmanager
def cluster_client(scheduler=None, workers=None):
    """The Client the command line asked for (None for neither --scheduler nor --workers);
    a LocalCluster started for --workers is closed on leaving."""
    if scheduler is None and not workers:
        yield None
        return
    if scheduler is not None:
        yield connect(scheduler, "--scheduler")
        return
    if not isinstance(workers, int) or workers < 1:
        raise SceneError(f"--workers: expected a positive number of worker processes, got {V.show(workers)}")
    dd = _dask("--workers")
    with dd.LocalCluster(n_workers=workers, threads_per_worker=1, processes=True, dashboard_address=None) as cluster, \
            dd.Client(cluster) as client:
        yield client


def band_rows(width, rows, spp, workers, rate=None) -> int:
    """Rows per band for ``rows`` image rows of ``width`` pixels at ``spp`` samples on
    ``workers`` workers: a multiple of BLOCK_ROWS (or all the rows), about
    TASKS_PER_WORKER bands per worker, none under MIN_BAND_SAMPLES pixel samples, nor,
    with the workers' measured ``rate`` (pixel samples per second of one task), under
    MIN_BAND_SECONDS of work: fast (GPU) workers get bigger bands."""
    blocks = -(-rows // BLOCK_ROWS)
    least = max(MIN_BAND_SAMPLES, int(rate * MIN_BAND_SECONDS) if rate else 0, 1)
    by_overhead = max(1, width * rows * spp // least)
    bands = max(1, min(blocks, TASKS_PER_WORKER * max(1, workers), by_overhead))
    return min(rows, -(-blocks // bands) * BLOCK_ROWS)


def _for_workers(cs):
    """The compiled scene without what only the client reads."""
    return dataclasses.replace(cs, **{name: None for name in uploads.CLIENT_ONLY if name != "blas_reused"})


def ship(client, cs):
    """(a Future of ``cs`` on every worker, its key, {"shipped": whether it was sent now,
    "ship_bytes" (its arrays' bytes: all but a few kB of what is sent), "ship_s"}); a scene this client sent before, still held, is not sent again."""
    key = uploads.compiled_key(cs)
    held = _shipped.setdefault(client, OrderedDict())
    fut = held.get(key)
    if fut is not None and fut.status == "finished":
        held.move_to_end(key)
        return fut, key, {"shipped": False, "ship_bytes": 0, "ship_s": 0.0}
    slim = _for_workers(cs)
    nbytes = sum(v.nbytes for v in vars(slim).values() if isinstance(v, np.ndarray))   # the payload, not pickled twice
    t0 = time.perf_counter()
    fut = client.scatter(slim, broadcast=True, hash=False)
    fut.result()                       # wait: the ship time is a figure of its own
    held[key] = fut
    while len(held) > SHIPPED_PER_CLIENT:
        held.popitem(last=False)
    return fut, key, {"shipped": True, "ship_bytes": nbytes, "ship_s": time.perf_counter() - t0}


def render_band(cs, key, camera, width, height, spp, rows, options):
    """A task: rows ``rows`` of the image on this worker's device (options: render's
    device, seed, jitter, aovs, adaptive, pipeline, local_size, memory_limit,
    tile_pixels). Returns a dict: rows, rgb, aov, samples, render_s, worker, device."""
    t0 = time.perf_counter()
    rt, prg, local, _ = device_program(cs, options["device"], options["local_size"],
                                    launch_samples(width, height, spp, options["adaptive"]),
                                    stages=options["pipeline"] == "stages")
    build_s = time.perf_counter() - t0
    up, _ = uploads.uploaded(rt, cs, key)
    out = render_rows(rt, prg, cs, camera, width, height, spp, rows, local=local, uploaded=up,
                      **{k: options[k] for k in ROW_OPTIONS})
    return {"rows": rows, "rgb": out.rgb, "aov": out.aov, "samples": out.samples,
            "render_s": time.perf_counter() - t0, "worker": f"{os.uname().nodename}:{os.getpid()}",
            "device": rt.device.name.strip(), "tile_rows": out.tile_rows, "ray_buffer_bytes": out.ray_buffer_bytes,
            "local_size": local, "program_build_s": build_s}


@dataclass
class Bands:
    """One image's tasks on a cluster; :meth:`collect` assembles them."""
    client: object
    futures: list
    bands: list
    width: int
    rows: tuple
    ship: dict
    per_band: int
    workers: int
    t_submit: float = field(default_factory=time.perf_counter)
    resubmit: object = None     # band index -> a new future for it (see collect)

    def collect(self, progress=None, sink=None) -> "Collected":
        """The image's rows (or, with ``sink``, each band given to it in order of y0 and
        not kept); raises a task's exception (the same texray class) after cancelling the
        other tasks."""
        dd = _dask("render: client")
        y_start, y_end = self.rows
        n = y_end - y_start
        rgb = np.empty((n, self.width, 3), np.float32) if sink is None else None
        aov = {} if sink is None else None
        results, next_i, done = {}, 0, 0
        index = {f.key: i for i, f in enumerate(self.futures)}
        retries = {}
        try:
            pending = dd.as_completed(self.futures)
            for fut in pending:
                i = index[fut.key]
                try:
                    r = fut.result()
                except dd.CancelledError:
                    # Not cancelled by us (that only happens below, on the way out): the cluster
                    # lost the task, e.g. a worker died while its result was being fetched
                    # ("already forgotten"). The band is submitted again, a few times at most.
                    retries[i] = retries.get(i, 0) + 1
                    if self.resubmit is None or retries[i] > BAND_RETRIES:
                        a, b = self.bands[i]
                        raise DeviceError(f"render: client: the Dask cluster lost the band of rows {a}..{b - 1} "
                                          f"{retries[i]} times (its task was cancelled, not by texray)") from None
                    new = self.resubmit(i)
                    self.futures[i] = new
                    index[new.key] = i
                    pending.add(new)
                    continue
                done += 1
                if sink is None:
                    a, b = r["rows"]
                    rgb[a - y_start:b - y_start] = r["rgb"]
                    for name, arr in r["aov"].items():
                        if name not in aov:
                            aov[name] = np.empty((n, self.width, arr.shape[2]), np.float32)
                        aov[name][a - y_start:b - y_start] = arr
                    results[i] = _summary(r)
                else:
                    results[i] = r
                    while next_i in results and "rgb" in results[next_i]:
                        ready = results[next_i]
                        sink(ready["rows"][0], ready["rgb"], ready["aov"])
                        results[next_i] = _summary(ready)
                        next_i += 1
                if progress is not None:
                    progress(done / len(self.futures))
        except BaseException:
            self.client.cancel(self.futures)
            raise
        summaries = [results[i] for i in range(len(self.futures))]
        wall = time.perf_counter() - self.t_submit
        by_worker = {}
        for s in summaries:
            by_worker[s["worker"]] = by_worker.get(s["worker"], 0) + 1
        task_s = [s["render_s"] for s in summaries]
        if sum(task_s) > 0:                # the workers' rate, for the next render's band size
            _rates[self.client] = sum(s["samples"] for s in summaries) / sum(task_s)
        stats = {
            "device": ", ".join(sorted({s["device"] for s in summaries})),
            "render_s": wall, "samples": int(sum(s["samples"] for s in summaries)),
            "program_build_s": max(s["program_build_s"] for s in summaries), "upload_s": self.ship["ship_s"],
            "stage_s": {},
            "tile_rows": self.per_band, "tiles": len(self.bands), "local_size": summaries[0]["local_size"],
            "ray_buffer_bytes": max(s["ray_buffer_bytes"] for s in summaries),
            "dask": {"workers": self.workers, "bands": len(self.bands), "band_rows": self.per_band,
                     "task_s_median": float(np.median(task_s)), "task_s_sum": float(sum(task_s)),
                     "by_worker": by_worker, **self.ship},
        }
        return Collected(rgb=rgb, aov=aov if aov is not None else {}, stats=stats)


@dataclass
class Collected:
    rgb: np.ndarray | None
    aov: dict
    stats: dict


def _summary(r):
    return {k: v for k, v in r.items() if k not in ("rgb", "aov")}


def submit_bands(client, cs, camera, width, height, spp, rows, options) -> Bands:
    """Send the scene (once, :func:`ship`) and submit one task per band of ``rows``
    (None: the whole image)."""
    device = options["device"]
    if device is not None and (isinstance(device, bool) or not isinstance(device, (int, str))):
        raise SceneError(f"render: device: on a cluster each worker chooses its device: name it by index or "
                         f"name ('cpu', 'gpu', 0, 'NVIDIA'), not {V.show(device)}")
    y_start, y_end = (0, height) if rows is None else rows
    workers = len(client.scheduler_info().get("workers", {}))
    if workers == 0:
        try:
            client.wait_for_workers(1, timeout=60)
        except (TimeoutError, OSError):
            raise DeviceError("render: client: the Dask cluster has no workers (waited 60 s)") from None
        workers = len(client.scheduler_info().get("workers", {}))
    per = band_rows(width, y_end - y_start, spp, workers, _rates.get(client))
    fut, key, shipped = ship(client, cs)
    bands = [(a, min(a + per, y_end)) for a in range(y_start, y_end, per)]

    def submit(i):
        nonlocal fut
        # A band submitted again after the cluster lost it: where the scene went with it (the
        # scattered copies lost or cancelled, so that every task on it would be cancelled
        # again), the scene is shipped again first.
        if fut.status != "finished":
            fut = ship(client, cs)[0]
        return client.submit(render_band, fut, key, camera, width, height, spp, bands[i], options,
                             key=f"texray-band-{uuid.uuid4().hex[:12]}-{bands[i][0]}", pure=False)
    futures = [submit(i) for i in range(len(bands))]
    return Bands(client=client, futures=futures, bands=bands, width=width, rows=(y_start, y_end), ship=shipped,
                 per_band=per, workers=workers, resubmit=submit)


def render_bands(client, cs, camera, width, height, spp, rows, options, progress=None, sink=None) -> Collected:
    """``render(client=)``'s work: submit the bands, then collect them."""
    return submit_bands(client, cs, camera, width, height, spp, rows, options).collect(progress, sink)


