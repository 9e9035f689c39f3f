"""The device buffer manifest: every array a kernel reads, declared once.

Each :class:`Param` is one kernel parameter. The manifest generates

* the kernels' parameter lists and argument lists (``TX_GEOM_PARAMS`` /
  ``TX_GEOM_ARGS``, ``TX_SURFACE_PARAMS`` / ``TX_SURFACE_ARGS``,
  ``TX_LIGHT_PARAMS`` / ``TX_LIGHT_ARGS``: :func:`opencl_macros`, emitted
  into the generated header with the structs of texray.device.layout),
* the upload of a compiled scene (:class:`Uploaded`: one read-only buffer per
  scene array, absent arrays passed as NULL),
* the arguments in kernel order (:meth:`Uploaded.args`) and
* the memory report (:func:`device_bytes`),

so adding a buffer is one line here (as Cycles' ``data_arrays.h``).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pyopencl as cl

SCENE, COUNT, RENDER = "scene", "count", "render"


@dataclass(frozen=True)
class Param:
    """One kernel parameter. ``source``: SCENE, a CompiledScene array (``field``) uploaded
    once; COUNT, the length of the CompiledScene array ``field`` as a uint; RENDER, a value
    the render passes (``field`` unused)."""
    name: str            # the kernel's parameter name
    ctype: str           # the OpenCL type: a struct of texray.device.layout, float4, ushort, uint...
    space: str           # "__global const", "__constant" or "" (passed by value)
    source: str
    field: str = ""
    doc: str = ""
    feature: str = ""    # a Features flag: the parameter exists only in programs compiled with it

    def present(self, features) -> bool:
        return not self.feature or bool(getattr(features, self.feature))

    def declaration(self) -> str:
        pointer = "*" if self.space else ""
        return f"{self.space + ' ' if self.space else ''}{self.ctype}{pointer} {self.name}"


_G = "__global const"

# The scene's geometry: what traversal reads (kernels/accel/bvh.h and the shapes).
GEOM = (
    Param("nodes", "float4", _G, SCENE, "nodes", "layout.BVH4_NODE read as 8 float4 per node"),
    Param("nnodes", "uint", "", COUNT, "nodes", "the traversal's node budget"),
    Param("tris", "TriVerts", _G, SCENE, "tri_verts", "triangle vertices, BVH leaf order"),
    Param("spheres", "Sphere", _G, SCENE, "spheres"),
    Param("cylinders", "Cylinder", _G, SCENE, "cylinders"),
    Param("quads", "QuadVerts", _G, SCENE, "quad_verts"),
    Param("displaced", "Displaced", _G, SCENE, "displaced"),
    Param("heights", "ushort", _G, SCENE, "heights", "unorm16 height fields and their min-max pyramids"),
    Param("instances", "Instance", _G, SCENE, "instances", "mesh instances (kernels/accel/instance.h)", "instances"),
    Param("ninstances", "uint", "", COUNT, "instances", "instance indices at or above are misses", "instances"),
)
# What the surface stage reads besides the geometry.
SURFACE = (
    Param("tri_shade", "TriShade", _G, SCENE, "tri_shade"),
    Param("quad_shade", "QuadShade", _G, SCENE, "quad_shade"),
    Param("normals", "float", _G, SCENE, "normals", "per-vertex shading normals, 3 floats each"),
    Param("uvs", "float", _G, SCENE, "uvs", "per-vertex texture coordinates, 2 floats each"),
    Param("materials", "Material", _G, SCENE, "materials"),
    Param("textures", "TextureInfo", _G, SCENE, "textures"),
    Param("texels", "half", _G, SCENE, "texels", "RGBA half texels of every texture and MIP level"),
    Param("objects", "ObjectInfo", _G, SCENE, "objects", "per-object projection frames and normal matrices"),
    Param("cam", "Camera", "__constant", RENDER),
    Param("image_w", "uint", "", RENDER),
    Param("image_h", "uint", "", RENDER),
    Param("spp", "uint", "", RENDER),
)
# The lights, for the shadow and shading stages.
LIGHTS = (
    Param("lights", "PointLight", _G, SCENE, "lights"),
    Param("nlights", "uint", "", COUNT, "lights"),
)
GROUPS = {"GEOM": GEOM, "SURFACE": SURFACE, "LIGHT": LIGHTS}

# Every uploaded scene array, in manifest order: the CompiledScene fields the device reads.
SCENE_ARRAYS = tuple(p.field for g in GROUPS.values() for p in g if p.source == SCENE)


def opencl_macros() -> str:
    """``#define TX_<GROUP>_PARAMS`` (the parameter declarations) and ``TX_<GROUP>_ARGS``
    (the names, to pass them on) for every group."""
    lines = []
    for group, params in GROUPS.items():
        flags = sorted({p.feature for p in params if p.feature})
        if not flags:
            lines.append(f"#define TX_{group}_PARAMS " + ", ".join(p.declaration() for p in params))
            lines.append(f"#define TX_{group}_ARGS " + ", ".join(p.name for p in params))
            continue
        # A parameter of a feature is declared only in programs compiled with it (one
        # flag per group so far: both variants spelled out).
        (flag,) = flags
        macro = f"TX_{flag.upper()}"
        for cond, with_it in ((f"#if {macro}", True), ("#else", False)):
            lines.append(cond)
            ps = [p for p in params if not p.feature or with_it]
            lines.append(f"#define TX_{group}_PARAMS " + ", ".join(p.declaration() for p in ps))
            lines.append(f"#define TX_{group}_ARGS " + ", ".join(p.name for p in ps))
        lines.append("#endif")
    return "\n".join(lines) + "\n"


def device_bytes(cs) -> dict[str, int]:
    """Bytes each uploaded array of the compiled scene ``cs`` takes on the device (absent or
    empty arrays are not uploaded)."""
    out = {}
    for name in SCENE_ARRAYS:
        a = getattr(cs, name)
        if a is not None and a.nbytes:
            out[name] = int(a.nbytes)
    return out


class Uploaded:
    """The device buffers of one compiled scene: every SCENE array of the manifest, read
    only (None for arrays the scene does not use: the kernels get NULL and the scene's
    program does not compile the code that reads them)."""

    def __init__(self, ctx, cs):
        mf = cl.mem_flags
        self.buffers, self.counts = {}, {}
        self.features = cs.features
        for params in GROUPS.values():
            for p in params:
                if not p.present(cs.features):
                    continue
                a = getattr(cs, p.field) if p.field else None
                if p.source == SCENE:
                    self.buffers[p.name] = (None if a is None or a.nbytes == 0 else
                                            cl.Buffer(ctx, mf.READ_ONLY | mf.COPY_HOST_PTR,
                                                      hostbuf=np.ascontiguousarray(a)))
                elif p.source == COUNT:
                    self.counts[p.name] = np.uint32(0 if a is None else len(a))

    def args(self, group, **render):
        """The arguments of ``group`` ("GEOM", "SURFACE", "LIGHT") in kernel order; RENDER
        parameters are given by name."""
        out = []
        for p in GROUPS[group]:
            if not p.present(self.features):
                continue
            if p.source == SCENE:
                out.append(self.buffers[p.name])
            elif p.source == COUNT:
                out.append(self.counts[p.name])
            else:
                out.append(render[p.name])
        return tuple(out)

    @property
    def geom(self):
        """The TX_GEOM_PARAMS arguments."""
        return self.args("GEOM")

    @property
    def light(self):
        """The TX_LIGHT_PARAMS arguments."""
        return self.args("LIGHT")
