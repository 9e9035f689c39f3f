"""Ray throughput on the bench mesh: its scene, the SAH build of its BVH, and
closest-hit (primary) and any-hit (shadow) rays traced alone, without shading.
``texray bench`` and ``texray bench --peers`` (:mod:`texray.bench.compare_peers`,
which traces the same rays with Embree) share them."""
from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np

from .. import procedural
from ..accel import cells
from ..accel.scene_bvh import build_kind, triangle_bounds
from ..compile import compile_scene
from ..renderer.trace import Tracer
from ..scene import Camera, Mesh, PointLight, Scene
from .peers import primary_rays, shadow_rays
from .suite import median_spread


def bench_mesh_scene(triangles):
    m = procedural.bench_mesh(triangles)
    scene = Scene(camera=Camera(eye=(0.0, 0.4, 3.2), look_at=(0, 0, 0), fov_y=40),
                  lights=[PointLight((3.0, 4.0, 5.0), (40, 40, 40))])
    scene.add(Mesh(m.positions, m.faces, name=f"bench_mesh({triangles})"))
    return scene


def bench_bvh(scene, repeat):
    """(compiled scene, BVH figures): the scene's compile time and the build of its triangles'
    tree by the builder compile_scene takes (texray.accel.scene_bvh.build_kind: the cell
    builder at this size), with the numpy builder's time and SAH cost beside it."""
    t0 = time.perf_counter()
    cs = compile_scene(scene)
    compile_s = time.perf_counter() - t0
    lo, hi = triangle_bounds(cs.tri_verts)
    figures = {"triangles": int(len(lo)), "scene_compile_s": compile_s}
    for name, builder in (("", "auto"), ("numpy_", "numpy")):
        times, tree = [], None
        for _ in range(repeat):
            t0 = time.perf_counter()
            tree = build_kind(lo, hi, 0, builder)
            times.append(time.perf_counter() - t0)
        figures.update({f"{name}build_s": median_spread(times), f"{name}sah_cost": tree.sah_cost,
                        f"{name}nodes": int(len(tree.nodes)), f"{name}depth": tree.depth})
    figures["builder"] = "cells" if len(lo) >= cells.MIN_PRIMS else "numpy"
    return cs, figures


@dataclass
class RayWork:
    """The rays bench_rays traced and texray's answers, for the peers to trace the same."""
    compiled: object         # CompiledScene of the bench mesh
    mesh: object             # its texray.Mesh (positions, faces)
    org: np.ndarray
    dirs: np.ndarray
    hits: object             # texray.trace.Hits of the primary rays
    shadow_org: np.ndarray
    shadow_dirs: np.ndarray
    occluded: np.ndarray


def bench_rays(cs, scene, device, size, repeat):
    """(figures, RayWork): closest-hit Mrays/s of size^2 pixel-centre primary rays and
    any-hit Mrays/s of shadow rays from their hits toward the first light."""
    tracer = Tracer(cs, device)
    org, dirs = primary_rays(scene.camera, size)
    primary, shadow, hits = [], [], None
    for i in range(repeat + 1):
        hits = tracer.closest(org, dirs)
        if i:
            primary.append(len(dirs) / hits.seconds * 1e-6)
    hit = hits.prim >= 0
    so, sd = shadow_rays(org, dirs, hits.t, hit, scene.lights[0].position)
    for i in range(repeat + 1):
        occ, secs = tracer.occluded(so, sd, 0.0, 1.0)
        if i:
            shadow.append(len(so) / secs * 1e-6)
    figures = {"device": tracer.rt.device.name.strip(), "triangles": int(len(cs.tri_verts)),
               "rays": int(len(dirs)), "hit_fraction": float(hit.mean()),
               "primary_mrays_s": median_spread(primary),
               "shadow_rays": int(len(so)), "shadow_occluded_fraction": float(occ.mean()),
               "shadow_mrays_s": median_spread(shadow)}
    return figures, RayWork(cs, scene.objects[0], org, dirs, hits, so, sd, occ)
