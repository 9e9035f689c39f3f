"""Prism shells of displaced triangle meshes (``Displacement(method="search")`` or
``"maxmip"`` on a Mesh): one layout.DISPLACED record of shape DISP_TRIANGLE per displaced
triangle, searched or traversed per pixel on the device (kernels/geometry/displace.h,
header comment; maxmip subdivides the shell on the device, disp_maxmip_mesh, reading the
same min-max pyramid).

The displaced surface of a triangle is S(b) = P(b) + H(uv(b)) N(b), P, N and uv
interpolated linearly from the corners (N from the unit vertex normals, not
renormalized: the tessellation, texray.compile.tessellate_mesh, renormalizes, a
difference of H (1 - |N(b)|), below 4e-4 H where neighbouring normals are 3 degrees apart).
Its shell is {P(b) + h N(b)} over the triangle and h in [slo, shi], the bound of H over
the triangle's uv footprint read from the min-max pyramid of the stored heights
(:func:`footprint_bounds`, exact for the device's interpolant).

The shell bounds the surface by construction; its five faces bound the shell, and a point's
(b1, b2, h) are unique, where the map (b, h) -> P(b) + h N(b) keeps a positive Jacobian
C(h) . N(b), C(h) = (E1 + h dN1) x (E2 + h dN2), over the whole prism. That is linear in
b, so its minimum is at a vertex normal, and quadratic in h: :func:`jacobian_ok` checks it
exactly, against MIN_JACOBIAN of the flat |E1 x E2| (at h = 0: each vertex normal within
86 degrees of the face normal). A mesh with a triangle that fails is not a set of true
bounds: compile_scene tessellates it instead, with a warning (conservative, and
crack-free). Triangles whose normals face away from their winding are turned (corners 1
and 2 swapped); zero-area triangles are skipped (they have no surface).
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..device import layout
from ..errors import SceneError
from ..scene.mesh import warn_degenerate
from .heights import METHOD_ADAPTIVE, METHOD_IDS, height_key, minmax_pyramid, quantize
from .tessellate_mesh import check_displaceable, unit_rows, vertex_normals

# The per-pixel methods that displace a mesh through its shells.
SHELL_METHODS = ("search", "maxmip")
# The kernels' TX_DISP_TRI_BAND: how far beyond its edges (in barycentrics) a triangle's
# surface is still evaluated; each footprint is widened by as much.
BAND = 2.0 ** -12
# The Jacobian of the shell's map at least this fraction of the flat triangle's (module docstring).
MIN_JACOBIAN = math.cos(math.radians(86.0))


class NotABound(Exception):
    """A triangle's prism shell would not bound its displaced surface (module docstring)."""


@dataclass
class Shells:
    """A mesh's displaced triangles, ready for records: float64 world corners p (F, 3, 3),
    unit normals n (F, 3, 3) and uvs (F, 3, 2) in shell order, the material of each (index
    into mesh.materials), the face index in the mesh, the shell's [slo, shi] and the
    shared-edge bits."""
    mesh: object
    p: np.ndarray
    n: np.ndarray
    uv: np.ndarray
    material: np.ndarray
    face: np.ndarray
    slo: np.ndarray
    shi: np.ndarray
    edges: np.ndarray


def searched_faces(mesh):
    """Boolean (F,) mask of the faces whose material is displaced per pixel (SHELL_METHODS)."""
    search = np.array([m.displacement is not None and m.displacement.method in SHELL_METHODS
                       for m in mesh.materials])
    return search[mesh.face_materials()]


def prepare(mesh) -> Shells:
    """The shells of ``mesh``'s searched faces; SceneError for what cannot be displaced,
    NotABound where a shell would not be a true bound."""
    where = f"{mesh.name}: "
    check_displaceable(mesh)
    p, n = mesh.world()
    p = np.asarray(p, np.float64)
    f = np.asarray(mesh.faces, np.int64)
    n = vertex_normals(p, f) if n is None else unit_rows(np.asarray(n, np.float64))
    uv = np.asarray(mesh.uvs, np.float64)
    fmat = mesh.face_materials()
    face = np.flatnonzero(searched_faces(mesh))
    fs = f[face].copy()
    c0 = np.cross(p[fs[:, 1]] - p[fs[:, 0]], p[fs[:, 2]] - p[fs[:, 0]])
    keep = np.linalg.norm(c0, axis=1) > 0
    if len(face) and not keep.any():
        raise SceneError(f"{where}faces: all {len(face)} displaced triangles have zero area; nothing to render")
    warn_degenerate(mesh.name, np.isin(np.arange(len(f)), face[~keep]))
    face, fs, c0 = face[keep], fs[keep], c0[keep]
    turn = np.einsum("fj,fkj->f", c0, n[fs]) < 0           # normals against the winding
    fs[turn] = fs[turn][:, [0, 2, 1]]
    edges = _shared_edges(fs)
    P, N, UV = p[fs], n[fs], uv[fs]
    slo, shi = np.zeros(len(fs)), np.zeros(len(fs))
    pyramids = {}
    for k, m in enumerate(mesh.materials):
        sel = np.flatnonzero(fmat[face] == k)
        if not len(sel):
            continue
        d = m.displacement
        key = height_key(d)
        if key not in pyramids:
            pyramids[key] = world_pyramid(d)
        t = UV[sel]
        spread = BAND * (np.abs(t[:, 1] - t[:, 0]) + np.abs(t[:, 2] - t[:, 0]))
        slo[sel], shi[sel] = footprint_bounds(pyramids[key], t.min(axis=1) - spread, t.max(axis=1) + spread,
                                              d.texture.shape[:2], d.wrap)
    bad = ~jacobian_ok(P, N, slo, shi)
    if bad.any():
        i = int(np.flatnonzero(bad)[0])
        raise NotABound(f"{where}material.displacement: {int(bad.sum())} triangle(s) (face {int(face[i])} first) "
                        f"have vertex normals more than 86 degrees from the face normal, or a shell of "
                        f"[{slo[i]:.4g}, {shi[i]:.4g}] thicker than their curvature allows")
    return Shells(mesh, P, N, UV, fmat[face], face, slo, shi, edges)


def world_pyramid(d):
    """The min-max pyramid of d's stored (quantized) heights in world units, float64:
    what the device's interpolant lies within (texray.compile.heights.pack_heights)."""
    hmin, hmax = d.bounds()
    q = quantize(d.heights())
    return [hmin + lv * ((hmax - hmin) / 65535.0) for lv in minmax_pyramid(q.astype(np.float64), d.wrap)]


def _shared_edges(fs):
    """Bit k of each triangle: its edge k (corner k to k + 1) is shared with another of ``fs``."""
    e = np.stack([fs[:, [0, 1]], fs[:, [1, 2]], fs[:, [2, 0]]], axis=1)
    key = np.sort(e, axis=2)
    _, inv, counts = np.unique(key.reshape(-1, 2), axis=0, return_inverse=True, return_counts=True)
    shared = (counts[inv.ravel()] > 1).reshape(-1, 3)
    return (shared * np.array([1, 2, 4])).sum(axis=1).astype(np.uint32)


def footprint_bounds(pyramid, uv_lo, uv_hi, shape, wrap):
    """(lo, hi) float64 bounds of the interpolant over the uv boxes [uv_lo, uv_hi] ((F, 2)
    each) from its min-max ``pyramid`` (texray.compile.heights.minmax_pyramid's cells:
    level 0 cell (cy, cx) spans x = u W + 1/2 in [cx, cx + 1], y = (1 - v) H + 1/2 in
    [cy, cy + 1]): at most 4 x 4 cells of the first level whose cells cover the box. A box
    is first moved by whole periods ("repeat") or clamped ("clamp"); one still leaving
    [0, 1]^2 (a mirror period, a box wider than the texture) takes the global range."""
    h, w = shape
    lo, hi = np.array(uv_lo, np.float64), np.array(uv_hi, np.float64)
    if wrap == "repeat":
        k = np.floor(lo)
        lo, hi = lo - k, hi - k
    elif wrap == "clamp":
        lo, hi = np.clip(lo, 0, 1), np.clip(hi, 0, 1)
    full = ~(np.all(np.isfinite(lo) & np.isfinite(hi), axis=1) & np.all((lo >= 0) & (hi <= 1), axis=1))
    lo, hi = np.where(full[:, None], 0.0, lo), np.where(full[:, None], 1.0, hi)
    x0 = np.clip(np.floor(lo[:, 0] * w + 0.5), 0, w).astype(np.int64)
    x1 = np.clip(np.floor(hi[:, 0] * w + 0.5), 0, w).astype(np.int64)
    y0 = np.clip(np.floor((1 - hi[:, 1]) * h + 0.5), 0, h).astype(np.int64)
    y1 = np.clip(np.floor((1 - lo[:, 1]) * h + 0.5), 0, h).astype(np.int64)
    level = np.zeros(len(lo), np.int64)
    top = len(pyramid) - 1
    while True:
        wide = ((x1 >> level) - (x0 >> level) > 3) | ((y1 >> level) - (y0 >> level) > 3)
        wide &= level < top
        if not wide.any():
            break
        level[wide] += 1
    level[full] = top
    out_lo, out_hi = np.empty(len(lo)), np.empty(len(lo))
    for lv in np.unique(level):
        sel = np.flatnonzero(level == lv)
        cells = pyramid[lv]
        ch, cw = cells.shape[:2]
        xa, xb = x0[sel] >> lv, np.minimum(x1[sel] >> lv, cw - 1)
        ya, yb = y0[sel] >> lv, np.minimum(y1[sel] >> lv, ch - 1)
        c = np.stack([cells[np.minimum(ya + j, yb), np.minimum(xa + i, xb)] for j in range(4) for i in range(4)])
        out_lo[sel], out_hi[sel] = c[..., 0].min(axis=0), c[..., 1].max(axis=0)
    return out_lo, out_hi


def jacobian_ok(P, N, slo, shi):
    """(F,) True where C(h) . N_i >= MIN_JACOBIAN |E1 x E2| for every vertex normal N_i and
    every h in [slo, shi] (module docstring; the minimum of the quadratic in h taken
    exactly: its ends and, for a convex one, its vertex)."""
    e1, e2 = P[:, 1] - P[:, 0], P[:, 2] - P[:, 0]
    d1, d2 = N[:, 1] - N[:, 0], N[:, 2] - N[:, 0]
    c0, c1, c2 = np.cross(e1, e2), np.cross(e1, d2) + np.cross(d1, e2), np.cross(d1, d2)
    need = MIN_JACOBIAN * np.linalg.norm(c0, axis=1)
    ok = np.ones(len(P), bool)
    for i in range(3):
        a, b, c = (np.einsum("fj,fj->f", ck, N[:, i]) for ck in (c0, c1, c2))
        worst = np.minimum(a + b * slo + c * slo ** 2, a + b * shi + c * shi ** 2)
        with np.errstate(divide="ignore", invalid="ignore"):
            hv = np.where(c > 0, -b / (2 * c), slo)
        inside = (c > 0) & (hv > slo) & (hv < shi)
        worst = np.where(inside, np.minimum(worst, a + b * hv + c * hv ** 2), worst)
        ok &= worst >= need
    return ok & np.isfinite(need)


def records(shells: Shells, obj_id, mats, index):
    """layout.DISPLACED records of ``shells`` and the float64 (lo, hi) boxes of the shells
    (the six corners P_i + slo N_i, P_i + shi N_i, of which every point is a convex
    combination). ``index``: texray.compile.heights.pack_heights' placement of each field."""
    s = shells
    rec = np.zeros(len(s.face), layout.DISPLACED)
    rec["shape"] = layout.DISP_TRIANGLE
    rec["p"], rec["e0"], rec["e1"] = s.p[:, 0], s.p[:, 1] - s.p[:, 0], s.p[:, 2] - s.p[:, 0]
    rec["n"], rec["n1"], rec["n2"] = s.n[:, 0], s.n[:, 1], s.n[:, 2]
    rec["uv"][:, :6] = s.uv.reshape(-1, 6)
    rec["slo"], rec["shi"] = _down(s.slo), _up(s.shi)
    rec["object"], rec["prim"], rec["edges"] = obj_id, s.face, s.edges
    for k, m in enumerate(s.mesh.materials):
        sel = s.material == k
        if not sel.any():
            continue
        d = m.displacement
        hmin, hmax = d.bounds()
        r = rec[sel]
        r["hoff"], r["moff"], r["levels"] = index[height_key(d)]
        r["hh"], r["hw"] = d.texture.shape[:2]
        r["wrap"] = layout.WRAP_MODES[d.wrap]
        r["hmin"], r["hmax"] = hmin, hmax
        r["method"] = METHOD_IDS[d.method] | (METHOD_ADAPTIVE if d.adaptive else 0)
        r["steps"], r["refine"] = d.steps, d.refine
        r["material"] = mats.index(m)
        rec[sel] = r
    c = np.concatenate([s.p + s.slo[:, None, None] * s.n, s.p + s.shi[:, None, None] * s.n], axis=1)
    return rec, c.min(axis=1), c.max(axis=1)


def _down(x):
    x32 = np.asarray(x, np.float32)
    return np.where(x32 > x, np.nextafter(x32, np.float32(-np.inf)), x32)


def _up(x):
    x32 = np.asarray(x, np.float32)
    return np.where(x32 < x, np.nextafter(x32, np.float32(np.inf)), x32)
