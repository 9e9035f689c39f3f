"""The scene description users build: camera, lights, textures, materials, meshes.

Units are arbitrary but consistent (world units); angles are degrees; colours
and intensities are linear RGB. Validation happens here, when an object is
made or loaded, so bad input fails early with the file, field and value.
"""
from __future__ import annotations

import re
import warnings
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from .errors import SceneError
from .texture import Label, Texture
from .transform import Transform, _vec3, apply_normals, apply_points
from . import validate as V


def _rgb(value, field, where="", nonneg=True):
    """A colour or intensity: a number or 3 numbers, finite in float32 (>= 0 unless ``nonneg`` is False)."""
    return V.rgb(value, field, where) if nonneg else V.vector(value, 3, field, where, broadcast=True)


def _number(value, field, where="", lo=None, hi=None, lo_open=False):
    return V.number(value, field, where, lo, hi, lo_open=lo_open)


# Smallest sine of the angle between the viewing direction and `up` that still gives a
# well-defined image orientation (the camera's right axis is their cross product).
_MIN_UP_SINE = 1e-9


@dataclass
class Camera:
    """Pinhole camera at ``eye`` looking at ``look_at``; ``fov_y`` is the vertical field of view in degrees."""
    eye: tuple = (0.0, 0.0, 5.0)
    look_at: tuple = (0.0, 0.0, 0.0)
    up: tuple = (0.0, 1.0, 0.0)
    fov_y: float = 40.0

    def __post_init__(self):
        self.basis(1.0)

    def basis(self, aspect: float, where="camera."):
        """(eye, forward, right, up) with right/up scaled so that NDC (+-1, +-1) hits the image corners."""
        eye = V.point(self.eye, "eye", where)
        look = V.point(self.look_at, "look_at", where)
        up = V.vector(self.up, 3, "up", where)
        fov = V.number(self.fov_y, "fov_y", where, 0.0, 179.0, lo_open=True)
        fwd = look - eye
        if np.linalg.norm(fwd) == 0:
            raise SceneError(f"{where}look_at: equals eye {V.show(eye)}; the camera has no direction")
        fwd /= np.linalg.norm(fwd)
        if not np.any(up != 0):
            raise SceneError(f"{where}up: expected a non-zero vector, got {V.show(self.up)}")
        up = up / np.abs(up).max()          # scaled first: the norm of (0, 1e-300, 0) underflows
        right = np.cross(fwd, up / np.linalg.norm(up))
        if np.linalg.norm(right) < _MIN_UP_SINE:
            raise SceneError(f"{where}up: {V.show(self.up)} is parallel to the viewing direction "
                             f"{V.show(fwd)}")
        right /= np.linalg.norm(right)
        true_up = np.cross(right, fwd)
        h = np.tan(np.radians(fov) / 2)
        return eye, fwd, right * h * aspect, true_up * h


@dataclass
class PointLight:
    """Point light; irradiance falls off as intensity / d^2 (the lecture's I_i / d_i^2)."""
    position: tuple
    intensity: tuple = (10.0, 10.0, 10.0)

    def __post_init__(self):
        self.validate()

    def validate(self, where="light."):
        return V.point(self.position, "position", where), V.rgb(self.intensity, "intensity", where)


@dataclass
class Material:
    """The lecture's local-illumination constants.

    diffuse: kd, an RGB colour or a :class:`Texture` (colour role); ``tint``
    multiplies it. specular: ks, a number, RGB or a :class:`Texture` (colour
    role: ks = its RGB). shininess: the exponent n of (R.V)^n, a number >= 0;
    shininess_map: an optional one-channel :class:`Texture` (data role, stored
    values >= 0) that multiplies it per point, n = shininess * map, so an 8/16-bit
    map in [0, 1] spans exponents 0..shininess. label: a :class:`texray.Label`
    composited over kd (after the tint): kd = lerp(kd, label.rgb, label.alpha).
    bump: a :class:`texray.Bump`; normal_map: a :class:`texray.NormalMap` (at most one
    of the two: each defines the shading normal on its own).
    displacement: a :class:`texray.Displacement` moving quads, spheres and cylinders
    along their normal (texray.displace).
    """
    diffuse: object = (0.8, 0.8, 0.8)
    specular: object = 0.0
    shininess: float = 32.0
    tint: tuple = (1.0, 1.0, 1.0)
    bump: object = None
    normal_map: object = None
    shininess_map: object = None
    label: object = None
    displacement: object = None    # a texray.Displacement (texray.displace): the geometry moves

    def __post_init__(self):
        self.validate()

    def validate(self, where="material."):
        if isinstance(self.diffuse, Texture):
            kd = V.rgb(self.tint, "tint", where)
        else:
            kd = V.rgb(self.diffuse, "diffuse", where) * V.rgb(self.tint, "tint", where)
            if np.any(kd > V.FLT_MAX):
                raise SceneError(f"{where}diffuse, tint: their product {V.show(kd)} overflows float32")
        ks = np.ones(3) if isinstance(self.specular, Texture) else V.rgb(self.specular, "specular", where)
        n = V.number(self.shininess, "shininess", where, 0.0)
        if self.shininess_map is not None and not isinstance(self.shininess_map, Texture):
            raise SceneError(f"{where}shininess_map: expected a texray.Texture, got {self.shininess_map!r}")
        if self.shininess_map is not None and self.shininess_map.channels != 1:
            t = self.shininess_map
            raise SceneError(f"{where}shininess_map: {t.name} has {t.channels} channels; a shininess map takes "
                             "1 (grey)")
        if self.label is not None and not isinstance(self.label, Label):
            raise SceneError(f"{where}label: expected a texray.Label, got {V.show(self.label)}")

        _check_normal_roles(self, where)
        if self.displacement is not None:
            from .displace import Displacement
            if not isinstance(self.displacement, Displacement):
                raise SceneError(f"{where}displacement: expected a texray.Displacement, got {self.displacement!r}")
            self.displacement.validate(f"{where}displacement.")
        for t in self.textures:             # their options may have changed since they were made
            V.instance(t, Texture, "texture", where)
            t.validate()
        return kd, ks, n

    def texture_roles(self):
        """[(layout.MATERIAL slot, Texture as the device reads it, texture.KINDS kind)] of the
        colour, specular, shininess and label roles."""
        roles = []
        if isinstance(self.diffuse, Texture):
            roles.append(("diffuse_tex", self.diffuse, "colour"))
        if isinstance(self.specular, Texture):
            roles.append(("specular_tex", self.specular, "colour"))
        if self.shininess_map is not None:
            roles.append(("shininess_tex", self.shininess_map, "data"))
        if self.label is not None:
            roles.append(("label_tex", self.label.device_texture, "label"))
        return roles

    @property
    def textures(self):
        return [t for _, t, _ in self.texture_roles()] + _normal_role_textures(self)


def _check_normal_roles(m, where):
    from .bump import Bump, NormalMap
    if m.bump is not None and not isinstance(m.bump, Bump):
        raise SceneError(f"{where}bump: expected a texray.Bump, got {m.bump!r}")
    if m.normal_map is not None and not isinstance(m.normal_map, NormalMap):
        raise SceneError(f"{where}normal_map: expected a texray.NormalMap, got {m.normal_map!r}")
    if m.bump is not None and m.normal_map is not None:
        raise SceneError(f"{where}bump, normal_map: a material takes one of the two (each replaces the "
                         "shading normal); bake the bump into the normal map")
    if m.bump is not None:
        m.bump.validate(f"{where}bump.")
    if m.normal_map is not None:
        m.normal_map.validate(f"{where}normal_map.")


def _normal_role_textures(m):
    """The data textures of the bump / normal-map roles."""
    return [r.texture for r in (m.bump, m.normal_map) if r is not None and hasattr(r, "texture")]


@dataclass
class Mesh:
    """A triangle mesh in world space after its ``transform``.

    positions (V, 3), faces (F, 3) vertex indices, optional per-vertex uvs
    (V, 2) and normals (V, 3). Validated on creation: non-finite coordinates,
    out-of-range indices and a textured material without uvs raise
    SceneError; zero-area triangles are kept out of the render with a warning
    (they can never be hit, so no pixel depends on them).
    """
    positions: np.ndarray
    faces: np.ndarray
    uvs: np.ndarray | None = None
    normals: np.ndarray | None = None
    material: Material = field(default_factory=Material)
    transform: Transform | None = None
    name: str = "<mesh>"
    mapping: object = None        # a texray.Projection generating uvs, or None for the mesh's own

    def __post_init__(self):
        self._validate()

    @classmethod
    def load(cls, path, material=None, transform=None, mapping=None):
        """Load OBJ, PLY, GLB/GLTF, OFF or STL through trimesh (unprocessed: nothing is silently merged or dropped)."""
        import trimesh
        path = V.file_path(path, "mesh")
        data = path.read_bytes()
        kind = path.suffix.lower().lstrip(".")
        if kind in _TEXT_MESH_FORMATS:
            try:
                data.decode("utf-8")
            except UnicodeDecodeError as e:
                raise SceneError(f"mesh: cannot read {path}: not UTF-8 text ({kind.upper()} is a text format; "
                                 f"byte {data[e.start]:#04x} at offset {e.start})") from None
        try:
            loaded = trimesh.load(str(path), process=False)
        except IndexError as e:  # trimesh's parsers index vertex arrays with the file's face indices
            raise SceneError(f"mesh: cannot read {path}: a face refers to a vertex (or uv, normal) the file does "
                             f"not define ({e})") from None
        except ModuleNotFoundError:   # trimesh guesses the encoding of undecodable text with an extra module
            raise SceneError(f"mesh: cannot read {path}: neither UTF-8 text nor a binary {kind.upper()} file "
                             "trimesh recognizes") from None
        except Exception as e:   # trimesh raises many kinds of errors for unreadable files
            raise SceneError(f"mesh: cannot read {path}: {type(e).__name__}: {e}") from None
        try:
            parts = _flatten(loaded)
        except Exception as e:   # malformed files can leave trimesh objects inconsistent
            raise SceneError(f"mesh: cannot read {path}: {type(e).__name__}: {e}") from None
        if not parts or sum(len(f) for _, f, _, _ in parts) == 0:
            raise SceneError(f"mesh: {path} contains no triangles")
        offsets = np.cumsum([0] + [len(p) for p, _, _, _ in parts])
        positions = np.concatenate([p for p, _, _, _ in parts])
        faces = np.concatenate([f + o for (_, f, _, _), o in zip(parts, offsets)])
        if kind == "obj":
            _warn_dropped_faces(path, data, len(faces))
        uvs = None if any(u is None for _, _, u, _ in parts) else np.concatenate([u for _, _, u, _ in parts])
        normals = None if any(n is None for _, _, _, n in parts) else np.concatenate([n for _, _, _, n in parts])
        return cls(positions, faces, uvs, normals,
                   material if material is not None else Material(), transform, str(path), mapping)

    def _validate(self):
        if not isinstance(self.name, str):
            raise SceneError(f"mesh: name: expected a string, got {V.show(self.name)}")
        where = f"{self.name}: "
        p = V.array(self.positions, "positions", where, 3)
        f = V.array(self.faces, "faces", where, 3, integer_values=True)
        bad = ~np.all(np.abs(p) <= V.COORD_LIMIT, axis=1)
        if bad.any():
            i = int(np.flatnonzero(bad)[0])
            what = "non-finite" if not np.all(np.isfinite(p[i])) else f"beyond +-{V.COORD_LIMIT:.0e}"
            raise SceneError(f"{where}positions: vertex {i} is {V.show(p[i])} ({int(bad.sum())} {what} vertices)")
        if f.size and (f.min() < 0 or f.max() >= len(p)):
            i = int(np.flatnonzero((f < 0).any(1) | (f >= len(p)).any(1))[0])
            raise SceneError(f"{where}faces: face {i} = {V.show(f[i])} indexes outside 0..{len(p) - 1}")
        arrays = {}
        for name, arr, width in (("uvs", self.uvs, 2), ("normals", self.normals, 3)):
            if arr is None:
                continue
            a = V.array(arr, name, where, width)
            if a.shape != (len(p), width):
                raise SceneError(f"{where}{name}: expected shape ({len(p)}, {width}), got {a.shape}")
            limit = V.COORD_LIMIT if name == "uvs" else V.FLT_MAX     # uvs are interpolated: sums must not overflow
            bad = ~np.all(np.abs(a) <= limit, axis=1)
            if bad.any():
                i = int(np.flatnonzero(bad)[0])
                raise SceneError(f"{where}{name}: vertex {i} is {V.show(a[i])} (expected finite values of magnitude "
                                 f"<= {limit:.3g})")
            arrays[name] = a
        if "normals" in arrays:
            arrays["normals"] = _tame_normals(arrays["normals"])
        if self.transform is not None:
            V.instance(self.transform, Transform, "transform", where)
            self.transform.matrix(where + "transform.")
        V.instance(self.material, Material, "material", where)
        self.material.validate(f"{where}material.")
        d = self.material.displacement
        if d is not None and d.method != "tessellate":    # tessellated shapes are meshes with the shape's material
            raise SceneError(f"{where}material.displacement: triangle meshes are not displaced (no sound "
                             "bounding volume chosen); use a quad, sphere or cylinder")
        _check_mapping(self.mapping, where)
        if self.material.textures and self.uvs is None and self.mapping is None:
            raise SceneError(f"{where}uvs: the material has a texture ({self.material.textures[0].name}) "
                             "but the mesh has no texture coordinates")
        self.positions, self.faces = p, f
        self.uvs, self.normals = arrays.get("uvs"), arrays.get("normals")

    def validate(self):
        """Check every field again (they may have been changed since the mesh was made)."""
        self._validate()
        return self

    def world(self):
        """(positions, normals) in world space, float64."""
        if self.transform is None:
            return self.positions, None if self.normals is None else np.asarray(self.normals, np.float64)
        m = self.transform.matrix(f"{self.name}: transform.")
        n = None if self.normals is None else apply_normals(m, np.asarray(self.normals, np.float64))
        return apply_points(m, self.positions), n


# Mesh formats that are text: bytes that are not UTF-8 make trimesh guess an encoding
# (and need a module it does not install), so they are refused first with a clear message.
_TEXT_MESH_FORMATS = ("obj", "off")


def _warn_dropped_faces(path, data, n_loaded):
    """Warn when an OBJ's face lines give fewer triangles than there are face lines
    (each gives at least one): a truncated or malformed file that trimesh read in part."""
    n_lines = len(re.findall(rb"^[ \t]*f[ \t]", data, re.M))
    if n_loaded < n_lines:
        warnings.warn(f"{path}: {n_lines} face lines but {n_loaded} triangles loaded: "
                      f"{n_lines - n_loaded} or more faces are malformed or truncated and were skipped",
                      stacklevel=3)


def _tame_normals(n):
    """Vertex normals are directions: rows whose length is far from 1 (outside [2^-20, 2^20])
    are scaled to unit length, so that the device's float32 dot products of them stay
    finite; zero rows stay zero. Normals of ordinary meshes are left bit for bit."""
    length = np.linalg.norm(n, axis=1)
    odd = (length > 0) & ((length > 2.0 ** 20) | (length < 2.0 ** -20))
    if odd.any():
        n = n.copy()
        n[odd] /= length[odd, None]
    return n


def _frame(z_axis, x_axis, where):
    """Orthonormal (x, y, z) from a z axis and an x direction (Gram-Schmidt)."""
    z = V.vector(z_axis, 3, "axis_z", where)
    x = V.vector(x_axis, 3, "axis_x", where)
    if np.linalg.norm(z) == 0:
        raise SceneError(f"{where}axis_z: expected a non-zero vector, got {V.show(z_axis)}")
    if np.linalg.norm(x) == 0:
        raise SceneError(f"{where}axis_x: expected a non-zero vector, got {V.show(x_axis)}")
    z = z / np.linalg.norm(z)
    x = x / np.linalg.norm(x)
    x = x - z * (x @ z)
    if np.linalg.norm(x) <= 1e-9:
        raise SceneError(f"{where}axis_x: {V.show(x_axis)} is parallel to axis_z {V.show(z_axis)}")
    x = x / np.linalg.norm(x)
    return x, np.cross(z, x), z


def _similarity(transform, where):
    """(matrix, uniform scale) of a transform; analytic shapes need a uniform scale."""
    if transform is None:
        return np.eye(4), 1.0
    V.instance(transform, Transform, "transform", where)
    m = transform.matrix(where + "transform.")
    s = np.linalg.svd(m[:3, :3], compute_uv=False)
    if not np.allclose(s, s[0], rtol=1e-9):
        raise SceneError(f"{where}transform.scale: {V.show(transform.scale)}: spheres and cylinders take a "
                         "uniform scale only")
    return m, float(s[0])


def _check_mapping(mapping, where):
    from .mapping import Projection
    if mapping is not None:
        if not isinstance(mapping, Projection):
            raise SceneError(f"{where}mapping: expected a texray.Projection, got {mapping!r}")
        try:
            mapping.validate()
        except SceneError as e:
            raise SceneError(f"{where}mapping: {e}") from None


def object_frame(obj):
    """The object's projection frame in world space as (origin, x, y, z) rows, axes scaled so that
    dot(p_world - origin, axis) equals the object-space coordinate times the projection's scale."""
    f = obj.mapping.device_frame().astype(np.float64)
    m = np.eye(4) if obj.transform is None else obj.transform.matrix()
    inv_t = np.linalg.inv(m[:3, :3]).T
    return np.stack([apply_points(m, f[:1])[0], inv_t @ f[1], inv_t @ f[2], inv_t @ f[3]])


def _placed(shape, point, where):
    """(point, uniform scale, axis_x, axis_z) of an analytic shape in world space, after
    checking its frame, transform, material and mapping."""
    m, k = _similarity(shape.transform, where)
    x, _, z = _frame(shape.axis_z, shape.axis_x, where)
    _check_material(shape.material, where)
    _check_mapping(shape.mapping, where)
    rot = m[:3, :3] / k
    return apply_points(m, point[None])[0], k, rot @ x, rot @ z


def _check_material(m, where):
    V.instance(m, Material, "material", where)
    m.validate(f"{where}material.")


def _check_curved_displacement(shape, radius, what, where):
    """The rules of a displaced sphere or cylinder: searched, not maxmip (no affine (u, v, h)
    frame), and no height below the centre or axis (the shell would turn inside out)."""
    d = shape.material.displacement
    if d is None or d.method == "tessellate":
        return
    if d.method == "maxmip":
        raise SceneError(f"{where}material.displacement.method: 'maxmip' needs (u, v, h) affine along rays: "
                         f"planar quads only; {type(shape).__name__} {shape.name} takes 'search' or 'tessellate'")
    hmin = d.bounds()[0]
    if radius + hmin < 0:
        raise SceneError(f"{where}material.displacement.offset: the lowest height {hmin:g} is below the {what} "
                         f"of radius {radius:g}")


def check_extent(points, where, field):
    """SceneError unless every coordinate of the world-space ``points`` lies within
    +-validate.COORD_LIMIT (the device computes in float32)."""
    big = np.abs(points).max(initial=0.0)
    if not big <= V.COORD_LIMIT:
        raise SceneError(f"{where}{field}: coordinates up to {big:.3g} after the transform; the device "
                         f"computes in float32 and takes |coordinates| <= {V.COORD_LIMIT:.0e}")


@dataclass
class Sphere:
    """A sphere with the lecture's parameterization: theta (polar, from axis_z) and
    phi (azimuth, from axis_x toward axis_z x axis_x); texture uv = (phi/2pi, 1 - theta/pi).
    A radius <= 0 is an error."""
    center: tuple = (0.0, 0.0, 0.0)
    radius: float = 1.0
    material: Material = field(default_factory=Material)
    axis_z: tuple = (0.0, 0.0, 1.0)
    axis_x: tuple = (1.0, 0.0, 0.0)
    transform: Transform | None = None
    name: str = "<sphere>"
    mapping: object = None

    def __post_init__(self):
        self.world()

    def validate(self):
        """Check every field again (they may have been changed since the shape was made)."""
        self.world()
        return self

    def world(self):
        """(center, radius, x, z) in world space, float64."""
        where = f"{self.name}: "
        r = V.number(self.radius, "radius", where, 0.0, lo_open=True, limit=V.COORD_LIMIT)
        c, k, x, z = _placed(self, V.point(self.center, "center", where), where)
        check_extent(np.stack([c - r * k, c + r * k]), where, "center, radius")
        _check_curved_displacement(self, r * k, "centre of a sphere", where)
        return c, r * k, x, z


@dataclass
class Cylinder:
    """The lecture's partial open cylinder: radius r around axis_z through origin,
    z in z_range, theta in theta_range (degrees, from axis_x); texture
    uv = ((theta - theta_min) / (theta_max - theta_min), (z - z_min) / (z_max - z_min)).
    An empty z or theta range is an error."""
    radius: float = 1.0
    z_range: tuple = (0.0, 1.0)
    theta_range: tuple = (0.0, 360.0)
    origin: tuple = (0.0, 0.0, 0.0)
    axis_z: tuple = (0.0, 0.0, 1.0)
    axis_x: tuple = (1.0, 0.0, 0.0)
    material: Material = field(default_factory=Material)
    transform: Transform | None = None
    name: str = "<cylinder>"
    mapping: object = None

    def __post_init__(self):
        self.world()

    def validate(self):
        """Check every field again (they may have been changed since the shape was made)."""
        self.world()
        return self

    def world(self):
        """(origin, radius, x, z, (z_min, z_max), (theta_min, theta_max) radians) in world space."""
        where = f"{self.name}: "
        r = V.number(self.radius, "radius", where, 0.0, lo_open=True, limit=V.COORD_LIMIT)
        zr = V.vector(self.z_range, 2, "z_range", where, limit=V.COORD_LIMIT)
        if not zr[0] < zr[1]:
            V.fail(where, "z_range", "[z_min, z_max] with z_min < z_max", self.z_range)
        tr = V.vector(self.theta_range, 2, "theta_range", where, limit=V.COORD_LIMIT)
        if not tr[0] < tr[1] or tr[1] - tr[0] > 360:
            V.fail(where, "theta_range", "[min, max] degrees with min < max <= min + 360", self.theta_range)
        o, k, x, z = _placed(self, V.point(self.origin, "origin", where), where)
        ends = o + np.outer(zr * k, z)
        check_extent(np.concatenate([ends - r * k, ends + r * k]), where, "origin, radius, z_range")
        _check_curved_displacement(self, r * k, "axis of a cylinder", where)
        return o, r * k, x, z, tuple(zr * k), tuple(np.radians(tr))


@dataclass
class Quad:
    """A bilinear patch P(u,v) = (1-u)(1-v)P0 + u(1-v)P1 + uv P2 + (1-u)v P3, planar or not.
    uvs: texture coordinates of P0..P3, interpolated bilinearly (default: (u, v) itself).
    A quad of zero area is an error."""
    p0: tuple
    p1: tuple
    p2: tuple
    p3: tuple
    material: Material = field(default_factory=Material)
    uvs: tuple = ((0.0, 0.0), (1.0, 0.0), (1.0, 1.0), (0.0, 1.0))
    transform: Transform | None = None
    name: str = "<quad>"
    mapping: object = None

    def __post_init__(self):
        self.world()

    def validate(self):
        """Check every field again (they may have been changed since the shape was made)."""
        self.world()
        return self

    def world(self):
        """((4, 3) corners, (4, 2) uvs) in world space, float64."""
        where = f"{self.name}: "
        p = np.stack([V.point(v, f"p{i}", where) for i, v in enumerate((self.p0, self.p1, self.p2, self.p3))])
        uv = V.array(self.uvs, "uvs", where, 2)
        if uv.shape != (4, 2) or not np.all(np.abs(uv) <= V.COORD_LIMIT):
            V.fail(where, "uvs", f"4 (u, v) pairs of numbers of magnitude <= {V.COORD_LIMIT:.0e} (interpolated in "
                   "float32)", self.uvs)
        if self.transform is not None:
            p = apply_points(self.transform.matrix(where + "transform."), p)
        check_extent(p, where, "p0..p3")
        area = np.linalg.norm(np.cross(p[1] - p[0], p[3] - p[0])) + np.linalg.norm(np.cross(p[2] - p[1], p[3] - p[2]))
        if area == 0:
            raise SceneError(f"{where}p0..p3: the quad has zero area: {p.tolist()}")
        _check_material(self.material, where)
        _check_mapping(self.mapping, where)
        d = self.material.displacement
        if d is not None and d.method != "tessellate":
            e0, e1 = p[1] - p[0], p[3] - p[0]
            size = max(np.abs(p).max(), np.linalg.norm(e0), np.linalg.norm(e1))
            # A parallelogram to float32 precision (2^-20 of its size): (u, v, h) are then
            # affine along a ray, which the search and the maxmip traversal rely on.
            if np.linalg.norm(p[0] + p[2] - p[1] - p[3]) > 2.0 ** -20 * size:
                raise SceneError(f"{where}material.displacement.method: {d.method!r} displaces planar "
                                 f"parallelogram quads only (p0 + p2 = p1 + p3); this quad's corners are "
                                 f"{V.show(p)}: use method = \"tessellate\"")
        return p, uv


def _flatten(loaded):
    """[(positions, faces, uvs | None, normals | None)] of every triangle geometry in a
    trimesh load result, with scene-graph transforms applied; nothing is merged or dropped.
    Normals are the file's own (trimesh keeps them in its cache when the file has them)."""
    import trimesh
    if isinstance(loaded, trimesh.Trimesh):
        items = [(np.eye(4), loaded)]
    elif isinstance(loaded, trimesh.Scene):
        items = []
        for node in loaded.graph.nodes_geometry:
            m, gname = loaded.graph[node]
            g = loaded.geometry.get(gname)
            if isinstance(g, trimesh.Trimesh):
                items.append((np.asarray(m, dtype=np.float64), g))
    else:
        return []
    out = []
    for m, g in items:
        identity = np.array_equal(m, np.eye(4))
        p = np.asarray(g.vertices, dtype=np.float64)
        p = p if identity else apply_points(m, p)
        uv = getattr(g.visual, "uv", None)
        n = g._cache.cache.get("vertex_normals") if hasattr(g, "_cache") else None
        if n is not None and len(n) == len(p):
            n = np.asarray(n, dtype=np.float64)
            n = n if identity else apply_normals(m, n)
        else:
            n = None
        out.append((p, np.asarray(g.faces, dtype=np.int64),
                    None if uv is None or len(uv) != len(p) else np.asarray(uv, dtype=np.float64), n))
    return out


@dataclass
class Scene:
    """A camera, point lights, an ambient term and a list of objects."""
    camera: Camera = field(default_factory=Camera)
    lights: list = field(default_factory=list)
    ambient: tuple = (0.0, 0.0, 0.0)
    background: tuple = (0.0, 0.0, 0.0)
    objects: list = field(default_factory=list)

    def __post_init__(self):
        for name in ("lights", "objects"):
            value = getattr(self, name)
            if not isinstance(value, (list, tuple)):
                raise SceneError(f"scene.{name}: expected a list, got {V.show(value)}")
            setattr(self, name, list(value))
        self.validate()

    def validate(self):
        """Check every field (the lists may have changed since the scene was made); returns
        (ambient, background) as float64 arrays."""
        V.instance(self.camera, Camera, "camera", "scene.")
        self.camera.basis(1.0)
        for name, kinds, what in (("lights", PointLight, "a texray.PointLight"), ("objects", SHAPES, _SHAPE_NAMES)):
            value = getattr(self, name)
            if not isinstance(value, list):
                raise SceneError(f"scene.{name}: expected a list, got {V.show(value)}")
            for i, item in enumerate(value):
                V.instance(item, kinds, f"{name}[{i}]", "scene.", what)
        return V.rgb(self.ambient, "ambient", "scene."), V.rgb(self.background, "background", "scene.")

    def add(self, obj):
        V.instance(obj, SHAPES, "add", "scene.", _SHAPE_NAMES)
        self.objects.append(obj)
        return obj

    @classmethod
    def load(cls, path):
        """Read a TOML scene file (see the README's "Scene files")."""
        from .scenefile import load_scene
        return load_scene(path)


SHAPES = (Mesh, Sphere, Cylinder, Quad)
_SHAPE_NAMES = "a texray Mesh, Sphere, Cylinder or Quad"


def degenerate_faces(positions, faces):
    """Boolean mask of zero-area triangles (exactly collinear in float64)."""
    a, b, c = positions[faces[:, 0]], positions[faces[:, 1]], positions[faces[:, 2]]
    return ~np.any(np.cross(b - a, c - a) != 0, axis=1)


def warn_degenerate(name, mask):
    n = int(mask.sum())
    if n:
        first = np.flatnonzero(mask)[:5].tolist()
        warnings.warn(f"{name}: {n} zero-area triangle(s) skipped (faces {first}{'...' if n > 5 else ''})",
                      stacklevel=3)
