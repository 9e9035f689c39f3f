"""Displacement mapping: a height field moves the surface along its normal before
visibility is decided (the lecture's "Displacement Mapping" slides).

The height field is H(u, v) = offset + scale * texture.r (world units; the texture's
stored values: a data role, never sRGB-decoded), the bilinear interpolant of the
texels with the conventions of ``kernels/texture.h``: u along columns, v = 0 the
bottom row, texel centres at ((i + 0.5) / W, 1 - (j + 0.5) / H), the texture's wrap
mode outside. (u, v) are the primitive's own parameters: the bilinear (u, v) of a
quad, the uv of a sphere or cylinder (their texture coordinates); the displaced
surface is S(u, v) = P(u, v) + H(u, v) n(u, v), n the primitive's outward unit normal.

Methods (``Displacement.method``):

* ``"search"``: on the device, the lecture's search between the entry A and exit B of
  the displaced surface's bounding volume: ``steps`` linear steps to the first
  sample on the other side of the surface, then ``refine`` bisection steps
  (``kernels/displace.h``).
* ``"maxmip"``: the exact hierarchical traversal of a min-max MIP pyramid of the
  height field (Tevs, Ihrke, Seidel, "Maximum Mipmaps for Fast, Accurate, and
  Scalable Dynamic Height Field Rendering", I3D 2008), made two-sided so that
  rays from below work too: a cell is skipped when the ray's height over it lies
  entirely above its maximum or below its minimum; in a texel cell the ray meets
  the bilinear interpolant where a quadratic vanishes. Planar parallelogram quads
  (where (u, v, h) are affine along a ray).
* ``"tessellate"``: true geometry on the host (:func:`tessellate`), rendered as a
  triangle mesh: the accuracy reference.

Everything here is float64 numpy; it is also the tests' reference.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from . import layout
from .errors import SceneError
from . import validate as V

METHODS = ("search", "maxmip", "tessellate")
METHOD_IDS = {"search": layout.DISP_SEARCH, "maxmip": layout.DISP_MAXMIP}   # layout.DISPLACED.method
METHOD_ADAPTIVE = layout.DISP_ADAPTIVE                                     # its adaptive-steps bit
MAX_STEPS = 4096
MAX_REFINE = 32
MAX_RESOLUTION = 16


@dataclass
class Displacement:
    """A height field H = offset + scale * texture.r moving the surface along its
    outward normal (world units: a texel value of 1 raises it by ``scale``).

    method: "search" (linear + binary search, ``steps`` N >= 1 and ``refine`` M >= 0
    bisections), "maxmip" (exact hierarchical traversal; quads that are planar
    parallelograms) or "tessellate" (a triangle mesh, ``resolution`` vertices per
    texel and axis). adaptive: N grows with the grazing angle, N / max(|cos|, 1/8)
    (the path through the volume grows as 1/|cos|, so the height step per sample
    stays put up to 8x N).
    """
    texture: object
    scale: float = 0.1
    offset: float = 0.0
    method: str = "search"
    steps: int = 32
    refine: int = 8
    adaptive: bool = False
    resolution: int = 1

    def __post_init__(self):
        from .bump import data_texture
        self.texture = data_texture(self.texture, "displacement.")
        self.validate()

    def validate(self, where="displacement."):
        from .texture import Texture
        V.instance(self.texture, Texture, "texture", where)
        V.number(self.scale, "scale", where, limit=V.COORD_LIMIT)
        V.number(self.offset, "offset", where, limit=V.COORD_LIMIT)
        V.one_of(self.method, METHODS, "method", where)
        V.integer(self.steps, "steps", where, 1, MAX_STEPS)
        V.integer(self.refine, "refine", where, 0, MAX_REFINE)
        V.integer(self.resolution, "resolution", where, 1, MAX_RESOLUTION)
        if not isinstance(self.adaptive, (bool, np.bool_)):
            raise SceneError(f"{where}adaptive: expected true or false, got {V.show(self.adaptive)}")
        t = self.texture
        if t.uv_transform is not None and not _identity(t.uv_transform):
            raise SceneError(f"{where}texture: {t.name}: a height texture takes no uv_transform (the height "
                             "field is addressed by the primitive's own parameters)")
        h = self.heights()
        if not np.all(np.isfinite(h)):
            raise SceneError(f"{where}texture: {t.name}: heights must be finite, got "
                             f"{h[~np.isfinite(h)].flat[0]!r}")
        return self

    def heights(self) -> np.ndarray:
        """float64 (H, W) heights in world units, row 0 = the texture's top row."""
        return float(self.offset) + float(self.scale) * self.texture.raw[:, :, 0].astype(np.float64)

    @property
    def wrap(self) -> str:
        return self.texture.wrap

    def bounds(self):
        """(min, max) of H: the bilinear interpolant stays within its texels' range."""
        h = self.heights()
        return float(h.min()), float(h.max())


def _identity(tr):
    return (np.all(np.asarray(tr.scale) == 1) and np.all(np.asarray(tr.offset) == 0)
            and float(tr.rotation) % 360 == 0)


def wrap_index(i, n, mode):
    """kernels/wrap.h wrap_index, vectorized: any integer texel index -> [0, n - 1]."""
    i = np.asarray(i, dtype=np.int64)
    if n <= 1:
        return np.zeros_like(i)
    if mode == "clamp":
        return np.clip(i, 0, n - 1)
    if mode == "mirror":
        r = np.mod(i, 2 * n)
        return np.where(r < n, r, 2 * n - 1 - r)
    return np.mod(i, n)


def _taps(heights, u, v, wrap):
    h, w = heights.shape
    x = np.asarray(u, np.float64) * w - 0.5
    y = (1.0 - np.asarray(v, np.float64)) * h - 0.5
    fx, fy = np.floor(x), np.floor(y)
    ax, ay = x - fx, y - fy
    x0, x1 = wrap_index(fx.astype(np.int64), w, wrap), wrap_index(fx.astype(np.int64) + 1, w, wrap)
    y0, y1 = wrap_index(fy.astype(np.int64), h, wrap), wrap_index(fy.astype(np.int64) + 1, h, wrap)
    return (heights[y0, x0], heights[y0, x1], heights[y1, x0], heights[y1, x1]), ax, ay, w, h


def height(heights, u, v, wrap="repeat"):
    """H(u, v): the bilinear interpolant of ``heights`` (float64 (H, W), row 0 on top)."""
    (t00, t10, t01, t11), ax, ay, _, _ = _taps(heights, u, v, wrap)
    return (t00 * (1 - ax) + t10 * ax) * (1 - ay) + (t01 * (1 - ax) + t11 * ax) * ay


def height_gradient(heights, u, v, wrap="repeat"):
    """(dH/du, dH/dv) of the interpolant (exact; piecewise linear across texel cells)."""
    (t00, t10, t01, t11), ax, ay, w, h = _taps(heights, u, v, wrap)
    dx = (t10 - t00) * (1 - ay) + (t11 - t01) * ay
    dy = (t01 - t00) * (1 - ax) + (t11 - t10) * ax
    return dx * w, -dy * h


def minmax_pyramid(heights, wrap="repeat"):
    """Min-max MIP pyramid of the bilinear interpolant: [float64 (CH_l, CW_l, 2)] per level.

    Level 0 has one cell per pair of adjacent texel centres, (H + 1) x (W + 1) cells:
    cell (cy, cx) spans x = u W + 1/2 in [cx, cx + 1] and y = (1 - v) H + 1/2 in
    [cy, cy + 1], with texels (cx - 1, cx) x (cy - 1, cy) (wrapped) at its corners,
    so (min, max) of its four corners bound the interpolant exactly. Level l + 1
    halves each side (rounding up) taking min / max over 2 x 2 cells; the last
    level is one cell holding the global range.
    """
    h, w = heights.shape
    cols = wrap_index(np.arange(-1, w + 1), w, wrap)
    rows = wrap_index(np.arange(-1, h + 1), h, wrap)
    g = heights[np.ix_(rows, cols)]
    corners = np.stack([g[:-1, :-1], g[:-1, 1:], g[1:, :-1], g[1:, 1:]])
    level = np.stack([corners.min(axis=0), corners.max(axis=0)], axis=-1)
    levels = [level]
    while level.shape[0] > 1 or level.shape[1] > 1:
        ch, cw = level.shape[:2]
        ph, pw = ch + (ch & 1) * (ch > 1), cw + (cw & 1) * (cw > 1)
        lo = np.full((ph, pw), np.inf)
        hi = np.full((ph, pw), -np.inf)
        lo[:ch, :cw], hi[:ch, :cw] = level[..., 0], level[..., 1]
        sh, sw = (2 if ph > 1 else 1), (2 if pw > 1 else 1)
        lo = lo.reshape(ph // sh, sh, pw // sw, sw).min(axis=(1, 3))
        hi = hi.reshape(ph // sh, sh, pw // sw, sw).max(axis=(1, 3))
        level = np.stack([lo, hi], axis=-1)
        levels.append(level)
    return levels


UNORM = 65535        # the stored heights: unorm16 over each field's [hmin, hmax]


def quantize(h):
    """float64 heights -> uint16 q with H = hmin + q (hmax - hmin) / 65535: 2 bytes per
    texel, like a half float, but with a uniform absolute error of at most (hmax - hmin) /
    131070 where a half's grows with |H| (2^-11 H, 32x more near hmax); exact for the full
    range of 8- and 16-bit textures. A constant field stores zeros."""
    lo, hi = float(h.min()), float(h.max())
    if hi <= lo:
        return np.zeros(h.shape, np.uint16)
    return np.round((h - lo) / (hi - lo) * UNORM).astype(np.uint16)


def pack_heights(displacements):
    """One uint16 buffer for the device: per distinct height field, its H x W texels
    (:func:`quantize`d over its [hmin, hmax], which the DISPLACED record holds; row 0 on
    top) then the min-max pyramid of those stored values (interleaved min, max; level
    after level): the device dequantizes both alike, monotonically, so the pyramid bounds
    its interpolant exactly. Returns (buffer, {key: (texel offset, pyramid offset, levels)})."""
    parts, index, n = [], {}, 0
    for d in displacements:
        key = _key(d)
        if key in index:
            continue
        q = quantize(d.heights())
        pyr = minmax_pyramid(q.astype(np.float64), d.wrap)
        flat = [q.ravel()] + [lv.reshape(-1) for lv in pyr]
        index[key] = (n, n + q.size, len(pyr))
        parts.extend(flat)
        n += sum(a.size for a in flat)
    if not parts:
        return None, index
    return np.concatenate(parts).astype(np.uint16), index


def _key(d):
    return (id(d.texture.raw), d.wrap, float(d.scale), float(d.offset))


# --- Surfaces: base point, outward unit normal, and the displaced point ------------

def quad_surface(corners, u, v):
    """(P, n) of a bilinear patch at (u, v), float64: n = normalize(dP/du x dP/dv)."""
    p0, p1, p2, p3 = (np.asarray(c, np.float64) for c in corners)
    u, v = np.asarray(u)[..., None], np.asarray(v)[..., None]
    p = (1 - u) * (1 - v) * p0 + u * (1 - v) * p1 + u * v * p2 + (1 - u) * v * p3
    pu = (1 - v) * (p1 - p0) + v * (p2 - p3)
    pv = (1 - u) * (p3 - p0) + u * (p2 - p1)
    n = np.cross(pu, pv)
    return p, n / np.linalg.norm(n, axis=-1, keepdims=True)


def sphere_surface(center, radius, ax, az, u, v):
    """(P, n) of the sphere at uv = (phi / 2pi, 1 - theta / pi)."""
    ay = np.cross(az, ax)
    phi, theta = 2 * np.pi * np.asarray(u)[..., None], np.pi * (1 - np.asarray(v)[..., None])
    n = np.sin(theta) * (np.cos(phi) * ax + np.sin(phi) * ay) + np.cos(theta) * az
    return np.asarray(center) + radius * n, n


def cylinder_surface(origin, radius, ax, az, z_range, theta_range, u, v):
    """(P, n) of the partial cylinder at uv = ((theta - theta_min) / span, (z - z_min) / (z_max - z_min))."""
    ay = np.cross(az, ax)
    th = theta_range[0] + (theta_range[1] - theta_range[0]) * np.asarray(u)[..., None]
    z = z_range[0] + (z_range[1] - z_range[0]) * np.asarray(v)[..., None]
    n = np.cos(th) * ax + np.sin(th) * ay
    return np.asarray(origin) + radius * n + z * az, n


def surface_of(obj):
    """A function (u, v) -> (P, n) in world space for a Quad, Sphere or Cylinder."""
    from .scene import Cylinder, Quad, Sphere
    if isinstance(obj, Quad):
        corners, _ = obj.world()
        return lambda u, v: quad_surface(corners, u, v)
    if isinstance(obj, Sphere):
        c, r, x, z = obj.world()
        return lambda u, v: sphere_surface(c, r, x, z, u, v)
    if isinstance(obj, Cylinder):
        o, r, x, z, zr, tr = obj.world()
        return lambda u, v: cylinder_surface(o, r, x, z, zr, tr, u, v)
    raise SceneError(f"{getattr(obj, 'name', obj)}: material.displacement: displacement applies to quads, "
                     f"spheres and cylinders, not {type(obj).__name__} (no bounding volume for triangles)")


def displaced_point(obj, u, v):
    """S(u, v) = P + H n, float64 (..., 3), and the base normal n."""
    d = obj.material.displacement
    p, n = surface_of(obj)(u, v)
    return p + height(d.heights(), u, v, d.wrap)[..., None] * n, n


def _axis_nodes(n_texels, resolution):
    """Parameter values of the tessellation's vertices along one axis: the domain's ends
    and every texel centre (where the interpolant has its kinks), each interval split
    ``resolution`` times."""
    knots = np.concatenate([[0.0], (np.arange(n_texels) + 0.5) / n_texels, [1.0]])
    knots = np.unique(knots)
    f = np.arange(resolution) / resolution
    fine = (knots[:-1, None] + f[None, :] * np.diff(knots)[:, None]).ravel()
    return np.append(fine, 1.0)


def tessellate(obj, resolution=None):
    """The displaced surface of a Quad, Sphere or Cylinder as a :class:`texray.Mesh`.

    Vertices: S(u, v) on a grid through every texel centre and the domain's edges,
    each interval split ``resolution`` times (default: the Displacement's); uvs: the
    primitive's texture coordinates; normals: normalize(dS/du x dS/dv) from the
    grid's central differences (the height gradient), turned to the base normal's
    side. Zero-area triangles (poles, zero radius) are dropped.
    """
    from .scene import Mesh, Quad
    d = obj.material.displacement
    res = d.resolution if resolution is None else V.integer(resolution, "resolution", "tessellate: ", 1, MAX_RESOLUTION)
    hh, hw = d.texture.shape
    us, vs = _axis_nodes(hw, res), _axis_nodes(hh, res)
    uu, vv = np.meshgrid(us, vs)
    s, n = displaced_point(obj, uu, vv)
    su = np.gradient(s, us, axis=1)
    sv = np.gradient(s, vs, axis=0)
    nn = np.cross(su, sv)
    ln = np.linalg.norm(nn, axis=-1, keepdims=True)
    nn = np.where(ln > 0, nn / np.where(ln > 0, ln, 1), n)
    nn *= np.where(np.sum(nn * n, axis=-1, keepdims=True) < 0, -1.0, 1.0)
    if isinstance(obj, Quad):
        _, tuv = obj.world()
        a, b = uu[..., None], vv[..., None]
        uvs = (1 - a) * (1 - b) * tuv[0] + a * (1 - b) * tuv[1] + a * b * tuv[2] + (1 - a) * b * tuv[3]
    else:
        uvs = np.stack([uu, vv], axis=-1)
    ny, nx = uu.shape
    idx = np.arange(ny * nx).reshape(ny, nx)
    a, b, c, e = idx[:-1, :-1].ravel(), idx[:-1, 1:].ravel(), idx[1:, 1:].ravel(), idx[1:, :-1].ravel()
    faces = np.concatenate([np.stack([a, b, c], 1), np.stack([a, c, e], 1)])   # (u, v) order: outward
    pos = s.reshape(-1, 3)
    area = np.linalg.norm(np.cross(pos[faces[:, 1]] - pos[faces[:, 0]], pos[faces[:, 2]] - pos[faces[:, 0]]), axis=1)
    faces = faces[area > 0]
    return Mesh(pos, faces.astype(np.int64), uvs=uvs.reshape(-1, 2), normals=nn.reshape(-1, 3),
                material=obj.material, name=f"{getattr(obj, 'name', '<object>')} (tessellated)")
