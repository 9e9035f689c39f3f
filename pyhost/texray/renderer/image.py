"""A render's result (:class:`Image`) and the host-memory check for images kept in memory."""
from __future__ import annotations

import os
from dataclasses import dataclass, field

import numpy as np

from ..device import layout
from ..errors import SceneError
from ..io.images import write_exr_layers, write_image


@dataclass
class Image:
    """A render: ``rgb`` is linear float32 (H, W, 3); ``aov`` maps AOV names to float32
    (H, W, C) arrays; ``stats`` holds timings and sizes."""
    rgb: np.ndarray
    aov: dict = field(default_factory=dict)
    stats: dict = field(default_factory=dict)

    def save(self, path):
        """PNG/JPEG/TIFF: sRGB-encoded 8-bit, clamped to [0, 1]; EXR: linear half RGB
        (float32 with the AOVs as further channels, ``uv.u``, ``position.x``...); HDR: linear float."""
        if self.aov and str(path).lower().endswith(".exr"):
            write_exr_layers(path, self.rgb, self.aov)
        else:
            write_image(path, self.rgb)


def host_image_bytes(width, height, aovs):
    return width * height * (16 + 4 * layout.AOV_FLOATS * bool(aovs))


def check_host_memory(nbytes, width, height):
    """SceneError when the image kept in host memory cannot fit the memory available
    (MemAvailable, which counts reclaimable caches, plus free swap)."""
    avail = _host_memory_available()
    if avail is not None and nbytes > avail:
        raise SceneError(f"render: width, height: a {width} x {height} image needs {nbytes / 2**30:.1f} GiB of host "
                         f"memory and {avail / 2**30:.1f} GiB are available; render_to_file(...) or sink= "
                         "streams the image band by band")


def _host_memory_available():
    """Bytes of host memory a new allocation can get, or None where the system does not say
    (then numpy reports a failed allocation itself)."""
    fields = {}
    try:
        with open("/proc/meminfo") as f:
            for line in f:
                key, _, rest = line.partition(":")
                fields[key] = int(rest.split()[0]) * 1024
    except (OSError, ValueError, IndexError):
        pass
    if "MemAvailable" in fields:
        return fields["MemAvailable"] + fields.get("SwapFree", 0)
    try:
        return os.sysconf("SC_AVPHYS_PAGES") * os.sysconf("SC_PAGE_SIZE")
    except (ValueError, OSError, AttributeError):
        return None
