"""Procedural geometry for texray (pure, vectorized numpy): the scene files'
generators and the benchmark's meshes.

Every generator returns a :class:`MeshData`. Conventions:

* Units are arbitrary scene units; ``y`` is up.
* Faces are counter-clockwise seen from outside, so the right-hand-rule face
  normal ``(p1 - p0) x (p2 - p0)`` points outwards.
* UVs follow OBJ/OpenGL: ``u`` runs along texture columns (left to right),
  ``v = 0`` is the BOTTOM row of the image and ``v = 1`` the top row.
* Seams are duplicated (``u = 0`` and ``u = 1`` are distinct vertices at the
  same position), so UVs never wrap inside a triangle. Closed shapes become
  watertight once coincident vertices are merged.
* Every vertex is referenced by at least one face, and no face is degenerate.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

__all__ = ["MeshData", "grid", "lathe", "uv_sphere", "torus", "vase_profile", "vase", "displaced_sphere",
           "bench_mesh"]

@dataclass
class MeshData:
    """Indexed triangle mesh.

    positions: (V, 3) float64; faces: (F, 3) int64, counter-clockwise seen from
    outside; uvs: (V, 2) float64 or None; normals: (V, 3) float64 unit vectors
    or None.
    """
    positions: np.ndarray
    faces: np.ndarray
    uvs: np.ndarray | None = None
    normals: np.ndarray | None = None

    @property
    def n_vertices(self) -> int:
        return len(self.positions)

    @property
    def n_triangles(self) -> int:
        return len(self.faces)


def _normalize(v):
    """Unit vectors along the last axis (zero vectors stay zero)."""
    n = np.linalg.norm(v, axis=-1, keepdims=True)
    return v / np.where(n > 0, n, 1.0)


def _grid_faces(n_cols, n_rows):
    """Faces of a (n_rows+1) x (n_cols+1) vertex grid, index = j*(n_cols+1)+i.

    Returns ``(lower, upper)``, each (n_rows, n_cols, 3) int64: the triangles
    (a, b, c) and (a, c, d) of quad (i, j) with a=(i,j), b=(i+1,j),
    c=(i+1,j+1), d=(i,j+1); both are counter-clockwise in (i, j) space.
    """
    i = np.arange(n_cols)[None, :]
    j = np.arange(n_rows)[:, None]
    a = j * (n_cols + 1) + i
    b, d = a + 1, a + (n_cols + 1)
    c = d + 1
    lower = np.stack(np.broadcast_arrays(a, b, c), axis=-1).astype(np.int64)
    upper = np.stack(np.broadcast_arrays(a, c, d), axis=-1).astype(np.int64)
    return lower, upper


def _compact(positions, faces, uvs=None, normals=None):
    """Drop vertices no face references; return a MeshData."""
    used = np.zeros(len(positions), dtype=bool)
    used[faces.ravel()] = True
    remap = np.cumsum(used) - 1
    pick = (lambda a: None if a is None else np.ascontiguousarray(a[used]))
    return MeshData(positions[used], remap[faces].astype(np.int64),
                    pick(uvs), pick(normals))


def grid(nu, nv, size=(1.0, 1.0), uv_scale=1.0):
    """Plane in XZ at y=0 facing +y, centred at the origin.

    nu, nv: number of quads along x (u) and along -z (v). size: (size_x,
    size_z). Seen from above (+y) with +x to the right, +v points towards -z,
    so the texture appears upright. UVs span [0, uv_scale] (a scalar or a
    (su, sv) pair; > 1 repeats the texture). 2*nu*nv triangles.
    """
    u = np.linspace(0.0, 1.0, nu + 1)
    v = np.linspace(0.0, 1.0, nv + 1)
    uu, vv = np.meshgrid(u, v)                      # (nv+1, nu+1), row = v
    sx, sz = size
    pos = np.stack([(uu - 0.5) * sx, np.zeros_like(uu), (0.5 - vv) * sz], -1)
    uvs = np.stack([uu, vv], -1) * np.broadcast_to(uv_scale, (2,))
    lower, upper = _grid_faces(nu, nv)
    faces = np.concatenate([lower.reshape(-1, 3), upper.reshape(-1, 3)])
    normals = np.broadcast_to([0.0, 1.0, 0.0], pos.shape).reshape(-1, 3).copy()
    return MeshData(pos.reshape(-1, 3), faces, uvs.reshape(-1, 2), normals)


def _profile_tangents(profile, s, closed):
    """d(profile)/ds (unit) at each point; periodic differences if closed."""
    if closed:
        # central difference over the wrap: neighbours of the seam point are
        # the second and second-to-last points (first == last point).
        prev = np.concatenate([profile[-2:-1], profile[:-1]])
        nxt = np.concatenate([profile[1:], profile[1:2]])
        t = nxt - prev
    else:
        t = np.gradient(profile, s, axis=0)
    return _normalize(t)


def lathe(profile_rz, n_around, profile_normals=None):
    """Surface of revolution about +y of a (radius, height) profile.

    profile_rz: (N, 2) points (radius >= 0, height), N >= 2, consecutive
    points distinct. Ordered so that the material lies to the right of the
    direction of travel in the (radius, height) plane (e.g. bottom-to-top for
    an outer wall) to get outward normals. A profile whose first and last
    points coincide is treated as closed (a torus-like tube).
    n_around: number of segments around the axis (seam column duplicated).
    profile_normals: optional (N, 2) (radial, y) normals; by default they are
    the profile's tangent rotated by -90 degrees (smooth shading).

    UVs: u = angle / 2pi (u increases eastwards seen from outside, u = 0 on
    +z), v = normalized arc length along the profile (0 at its first point).
    Points on the axis (radius 0) at either end of the profile become a
    triangle fan (no degenerate triangles), with u at the middle of each
    column.
    """
    prof = np.asarray(profile_rz, dtype=np.float64)
    n_prof = len(prof)
    seg = np.linalg.norm(np.diff(prof, axis=0), axis=1)
    s = np.concatenate([[0.0], np.cumsum(seg)])
    closed = bool(np.allclose(prof[0], prof[-1]))
    if profile_normals is None:
        t = _profile_tangents(prof, s, closed)
        nrz = np.stack([t[:, 1], -t[:, 0]], -1)
    else:
        nrz = _normalize(np.asarray(profile_normals, dtype=np.float64))

    u = np.linspace(0.0, 1.0, n_around + 1)
    phi = 2.0 * np.pi * u
    sin_p, cos_p = np.sin(phi)[None, :], np.cos(phi)[None, :]
    r, h = prof[:, 0:1], prof[:, 1:2]
    pos = np.stack(np.broadcast_arrays(r * sin_p, h, r * cos_p), -1)
    nr, ny = nrz[:, 0:1], nrz[:, 1:2]
    nrm = np.stack(np.broadcast_arrays(nr * sin_p, ny, nr * cos_p), -1)
    uu = np.broadcast_to(u[None, :], (n_prof, n_around + 1)).copy()
    vv = np.broadcast_to((s / s[-1])[:, None], uu.shape)

    on_axis = np.abs(prof[:, 0]) < 1e-12
    half = 0.5 / n_around
    if on_axis[0]:       # bottom fan: triangles (a, c, d) use columns 0..n-1
        uu[0] = u + half
    if on_axis[-1]:      # top fan: triangles (a, b, c) use columns 1..n
        uu[-1] = u - half

    lower, upper = _grid_faces(n_around, n_prof - 1)
    keep_lower = ~on_axis[:-1]      # (a, b, c) degenerate if row j on axis
    keep_upper = ~on_axis[1:]       # (a, c, d) degenerate if row j+1 on axis
    faces = np.concatenate([lower[keep_lower].reshape(-1, 3),
                            upper[keep_upper].reshape(-1, 3)])
    uvs = np.stack([uu, vv], -1).reshape(-1, 2)
    return _compact(pos.reshape(-1, 3), faces, uvs, nrm.reshape(-1, 3))


def _semicircle(n_lat):
    """(n_lat+1, 2) unit semicircle profile from south to north pole."""
    theta = np.linspace(np.pi, 0.0, n_lat + 1)         # polar angle from +y
    prof = np.stack([np.sin(theta), np.cos(theta)], -1)
    prof[[0, -1], 0] = 0.0
    return prof


def uv_sphere(n_lon, n_lat, radius=1.0):
    """UV sphere centred at the origin, poles on the y axis.

    n_lon: segments around (seam column duplicated at u = 0/1, on +z);
    n_lat: segments from pole to pole (>= 2). v = 0 at the south pole (-y),
    v = 1 at the north pole; the pole rows are triangle fans.
    2 * n_lon * (n_lat - 1) triangles; exact radial normals.
    """
    prof = _semicircle(n_lat)
    return lathe(prof * radius, n_lon, profile_normals=prof)


def torus(n_major, n_minor, R=1.0, r=0.3):
    """Torus about the y axis: tube radius r around a circle of radius R.

    n_major: segments around y (u); n_minor: segments around the tube (v,
    starting on the outer equator, going up first). Both seams duplicated.
    2 * n_major * n_minor triangles; exact normals.
    """
    t = np.linspace(0.0, 2.0 * np.pi, n_minor + 1)
    circle = np.stack([np.cos(t), np.sin(t)], -1)
    circle[-1] = circle[0]
    prof = circle * r + np.array([R, 0.0])
    return lathe(prof, n_major, profile_normals=circle)


def _chaikin(points, iterations):
    """Chaikin corner cutting of an open polyline, endpoints kept."""
    p = np.asarray(points, dtype=np.float64)
    for _ in range(iterations):
        a, b = p[:-1], p[1:]
        q = np.stack([0.75 * a + 0.25 * b, 0.25 * a + 0.75 * b], 1)
        p = np.concatenate([p[:1], q.reshape(-1, 2)[1:-1], p[-1:]])
    return p


def _resample_adaptive(points, n, turn_weight=0.15):
    """n points along a polyline, evenly spaced in arc length + turn_weight *
    accumulated turning angle (radians), so tight bends get more samples."""
    d = np.diff(points, axis=0)
    seg = np.linalg.norm(d, axis=1)
    ang = np.arctan2(d[:, 1], d[:, 0])
    turn = np.abs((np.diff(ang) + np.pi) % (2 * np.pi) - np.pi)
    # charge half of each vertex's turn to the segments on either side
    cost = seg + 0.5 * turn_weight * (np.r_[0.0, turn] + np.r_[turn, 0.0])
    c = np.concatenate([[0.0], np.cumsum(cost)])
    t = np.linspace(0.0, c[-1], n)
    return np.stack([np.interp(t, c, points[:, k]) for k in range(2)], -1)


def vase_profile(n_points=48, height=1.0, wall=0.025):
    """(n_points, 2) (radius, height) profile of a closed, thick-walled vase.

    Starts at the centre of the base (on the axis), runs out along the base,
    up the curvy outer wall, over a rounded lip, down the inner wall and ends
    at the centre of the inner floor: revolved, it is a watertight solid.
    """
    # outer wall control polygon: foot, belly, neck, flared lip (unit height)
    outer = np.array([
        [0.00, 0.000], [0.13, 0.000], [0.16, 0.004], [0.17, 0.025],
        [0.15, 0.055], [0.16, 0.080],
        [0.26, 0.160], [0.33, 0.300], [0.32, 0.440], [0.24, 0.580],
        [0.14, 0.700], [0.115, 0.800], [0.13, 0.900], [0.19, 0.985],
    ])
    lip = np.array([[0.205, 1.000], [0.195, 1.012], [0.178, 1.002]])
    inner = outer[::-1].copy()
    inner[:, 0] -= wall
    inner = inner[1:-5]                               # stop above the foot
    floor_h = 0.08 + wall
    inner = np.concatenate([inner[:-1], [[0.12, floor_h + 0.02],
                                         [0.08, floor_h], [0.0, floor_h]]])
    ctrl = np.concatenate([outer, lip, inner]) * [1.0, height]
    return _resample_adaptive(_chaikin(ctrl, 5), n_points)


def vase(n_around=48, n_profile=36):
    """Closed thick-walled vase, 1 unit tall, standing on y = 0.

    u runs around, v along the profile arc length (0 at the base centre,
    ~0.5 at the lip, 1 at the inner floor). Smooth normals.
    2 * n_around * (n_profile - 2) triangles (3264 by default).
    """
    return lathe(vase_profile(n_profile), n_around)


def displaced_sphere(n_lon, n_lat, amplitude=0.05, n_waves=12, seed=0):
    """UV sphere of radius 1 + amplitude * bumps(direction).

    bumps(d) = sum of n_waves plane waves sin(k_i . d + phase_i) with random
    |k_i| in [4, 16], scaled to an RMS of 1 (so amplitude is the RMS radius
    offset): smooth everywhere (poles included), and the normals are exact:
    n ~ r d - grad_S r, with grad_S the tangential gradient on the unit
    sphere. Triangle count and UVs as :func:`uv_sphere`.
    """
    base = uv_sphere(n_lon, n_lat)
    d = base.normals                                   # unit directions
    rng = np.random.default_rng(seed)
    k = _normalize(rng.normal(size=(n_waves, 3))) * rng.uniform(4, 16, (n_waves, 1))
    phase = rng.uniform(0, 2 * np.pi, n_waves)
    arg = d @ k.T + phase                              # (V, n_waves)
    scale = amplitude / np.sqrt(0.5 * n_waves)
    r = 1.0 + scale * np.sin(arg).sum(1)
    grad = scale * (np.cos(arg) @ k)                   # (V, 3) 3-D gradient
    grad_s = grad - np.sum(grad * d, 1, keepdims=True) * d
    normals = _normalize(r[:, None] * d - grad_s)
    return MeshData(d * r[:, None], base.faces, base.uvs, normals)


def bench_mesh(target_triangles=1_000_000, amplitude=0.05, seed=0):
    """Bumpy sphere with about ``target_triangles`` triangles (within 1 % for
    targets >= ~2000), for benchmarks: :func:`displaced_sphere` with
    n_lon ~ 2 (n_lat - 1)."""
    m = max(1, int(round(np.sqrt(target_triangles / 4.0))))   # n_lat - 1
    n_lon = max(3, int(round(target_triangles / (2.0 * m))))
    return displaced_sphere(n_lon, m + 1, amplitude=amplitude, seed=seed)
