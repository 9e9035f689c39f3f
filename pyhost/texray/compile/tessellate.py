"""Tessellation of a displaced Quad, Sphere or Cylinder: the displaced surface as a
triangle mesh (the "tessellate" method, and the accuracy reference of the others)."""
from __future__ import annotations

import numpy as np

from ..errors import SceneError
from .. import validate as V
from ..scene.displacement import MAX_RESOLUTION
from ..scene.heightfield import height
from ..scene.mesh import Mesh


def displaced_point(obj, u, v):
    """S(u, v) = P + H n, float64 (..., 3), and the base normal n."""
    d = obj.material.displacement
    if not hasattr(obj, "surface"):
        raise SceneError(f"{getattr(obj, 'name', obj)}: material.displacement: displacement applies to quads, "
                         f"spheres and cylinders, not {type(obj).__name__} (no bounding volume for triangles)")
    p, n = obj.surface(u, v)
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
    uvs = obj.texture_uv(uu, vv)
    ny, nx = uu.shape
    idx = np.arange(ny * nx).reshape(ny, nx)
    a, b, c, e = idx[:-1, :-1].ravel(), idx[:-1, 1:].ravel(), idx[1:, 1:].ravel(), idx[1:, :-1].ravel()
    faces = np.concatenate([np.stack([a, b, c], 1), np.stack([a, c, e], 1)])   # (u, v) order: outward
    pos = s.reshape(-1, 3)
    area = np.linalg.norm(np.cross(pos[faces[:, 1]] - pos[faces[:, 0]], pos[faces[:, 2]] - pos[faces[:, 0]]), axis=1)
    faces = faces[area > 0]
    return Mesh(pos, faces.astype(np.int64), uvs=uvs.reshape(-1, 2), normals=nn.reshape(-1, 3),
                material=obj.material, name=f"{getattr(obj, 'name', '<object>')} (tessellated)")
