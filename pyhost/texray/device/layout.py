"""Every struct shared by host and device, declared once.

Each numpy dtype below is the single source of truth for one device struct:
:func:`opencl_declarations` emits the matching OpenCL C ``typedef``\\ s (written
into the generated header ``texray_layout.h`` at build time), and
``tests/portability/test_layout.py`` asks each device for ``sizeof``/``offsetof`` and
compares them with these dtypes.

All fields are 4-byte scalars or fixed arrays of them, grouped so that every
struct is a multiple of 16 bytes; kernels may therefore read a struct as
consecutive ``float4`` words (the BVH node is read as two ``float4``).
"""
from __future__ import annotations

import numpy as np

# --- BVH node: 32 bytes -----------------------------------------------------
# Interior node: count_kind == 0, children at ``first`` and ``first + 1``.
# Leaf: low 24 bits of count_kind = number of primitives (>= 1), starting at
# ``first`` in the primitive array of the leaf's kind; the top 8 bits hold
# the primitive kind (PRIM_TRIANGLE, ...), so one tree can hold several kinds
# with homogeneous leaves.
BVH_NODE = np.dtype([
    ("bmin", "<f4", (3,)), ("first", "<u4"),
    ("bmax", "<f4", (3,)), ("count_kind", "<u4"),
])
# --- 4-wide BVH node, what the kernels traverse: 128 bytes ------------------
# The bounds of up to four children, one float4 per bound and axis (read as
# eight float4: lo_x, hi_x, lo_y, hi_y, lo_z, hi_z, child, count_kind).
# Per lane: count_kind == 0 and ``child`` the wide node's index, or a leaf as
# in BVH_NODE (``child`` = first primitive). Empty lanes have lo = +inf,
# hi = -inf, a box no ray enters. Built by texray.wide.collapse.
BVH4_NODE = np.dtype([
    ("lo_x", "<f4", (4,)), ("hi_x", "<f4", (4,)),
    ("lo_y", "<f4", (4,)), ("hi_y", "<f4", (4,)),
    ("lo_z", "<f4", (4,)), ("hi_z", "<f4", (4,)),
    ("child", "<u4", (4,)), ("count_kind", "<u4", (4,)),
])
LEAF_COUNT_BITS = 24
LEAF_COUNT_MASK = (1 << LEAF_COUNT_BITS) - 1
PRIM_TRIANGLE = 0
PRIM_SPHERE = 1
PRIM_CYLINDER = 2
PRIM_QUAD = 3
PRIM_DISPLACED = 4      # a displaced quad, sphere or cylinder (DISPLACED.shape): kernels/geometry/displace.h
PRIM_INSTANCE = 5       # an instance of a mesh (INSTANCE): kernels/accel/instance.h


def encode_leaf(count, kind=PRIM_TRIANGLE):
    """Pack a leaf's primitive count and kind into ``count_kind``."""
    count = np.asarray(count, dtype=np.uint64)
    if np.any(count < 1) or np.any(count > LEAF_COUNT_MASK):
        raise ValueError(f"leaf primitive count out of range 1..{LEAF_COUNT_MASK}")
    return (count | (np.uint64(kind) << np.uint64(LEAF_COUNT_BITS))).astype(np.uint32)


def decode_leaf(count_kind):
    """Return (count, kind) arrays from ``count_kind`` (count 0 = interior)."""
    ck = np.asarray(count_kind, dtype=np.uint32)
    return ck & np.uint32(LEAF_COUNT_MASK), ck >> np.uint32(LEAF_COUNT_BITS)


def take_records(records: np.ndarray, index) -> np.ndarray:
    """``records[index]`` for an array of one of these structs, copied as whole rows:
    numpy's gather of a structured array copies field by field (up to 15x slower on a
    million triangles). The same values bit for bit."""
    size = records.dtype.itemsize
    if len(records) == 0 or size % 4 or not records.flags.c_contiguous:
        return records[index]
    rows = records.view(np.uint32).reshape(len(records), size // 4)
    return np.take(rows, index, axis=0).view(records.dtype).reshape(np.shape(index))


# --- Triangles, in BVH leaf order, as two arrays -----------------------------
# What traversal reads (48 bytes: three float4 loads, three per 64-byte line
# less than with the shading data interleaved), world-space positions:
TRI_VERTS = np.dtype([
    ("p0", "<f4", (3,)), ("pad0", "<f4"),
    ("p1", "<f4", (3,)), ("pad1", "<f4"),
    ("p2", "<f4", (3,)), ("pad2", "<f4"),
])
# What the surface stage reads for a hit (32 bytes): ``v`` indexes the
# per-vertex shading arrays (normals, uvs); ``prim`` is the face index in its
# object's input, ``object`` the object's index in the scene.
TRI_SHADE = np.dtype([
    ("v", "<u4", (3,)), ("material", "<u4"),
    ("object", "<u4"), ("prim", "<u4"), ("flags", "<u4"), ("pad0", "<u4"),
])
def word(dtype: np.dtype, field: str) -> int:
    """The 4-byte word at which ``field`` of a struct starts: where host code fills or reads
    records as plain (n, itemsize / 4) arrays (fast) instead of by field, it takes the
    columns from here, so a reordered dtype moves them."""
    off = dtype.fields[field][1]
    assert off % 4 == 0
    return off // 4


def tri_corners(tri_verts: np.ndarray) -> np.ndarray:
    """TRI_VERTS records as a float32 (n, 3, 4) view: corner k's xyz in [:, k, :3]."""
    assert [word(TRI_VERTS, f) for f in ("p0", "p1", "p2")] == [0, 4, 8] and TRI_VERTS.itemsize == 48
    return np.ascontiguousarray(tri_verts).view(np.float32).reshape(len(tri_verts), 3, 4)


TRI_HAS_NORMALS = 1
TRI_HAS_UVS = 2

# --- Analytic primitives --------------------------------------------------------
# Frames are orthonormal: axis_x (phi = 0 / theta = 0 direction) and axis_z
# (the sphere's pole theta = 0, the cylinder's axis); y = z cross x.
SPHERE = np.dtype([
    ("center", "<f4", (3,)), ("radius", "<f4"),
    ("axis_x", "<f4", (3,)), ("material", "<u4"),
    ("axis_z", "<f4", (3,)), ("object", "<u4"),
    ("prim", "<u4"), ("flags", "<u4"), ("pad0", "<u4"), ("pad1", "<u4"),
])
# Partial open cylinder of the lecture: x = r cos(theta), y = r sin(theta) in
# the frame, z in [z_min, z_max], theta in [theta_min, theta_max] (radians).
CYLINDER = np.dtype([
    ("origin", "<f4", (3,)), ("radius", "<f4"),
    ("axis_x", "<f4", (3,)), ("z_min", "<f4"),
    ("axis_z", "<f4", (3,)), ("z_max", "<f4"),
    ("theta_min", "<f4"), ("theta_max", "<f4"), ("material", "<u4"), ("object", "<u4"),
    ("prim", "<u4"), ("flags", "<u4"), ("pad0", "<u4"), ("pad1", "<u4"),
])
# Bilinear patch P(u,v) = (1-u)(1-v)P0 + u(1-v)P1 + uv P2 + (1-u)v P3, as read
# by traversal (QuadVerts) and by the surface stage (QuadShade: per-vertex
# texture coordinates u0 v0 u1 v1 u2 v2 u3 v3, interpolated bilinearly).
QUAD_VERTS = np.dtype([
    ("p0", "<f4", (3,)), ("pad0", "<f4"),
    ("p1", "<f4", (3,)), ("pad1", "<f4"),
    ("p2", "<f4", (3,)), ("pad2", "<f4"),
    ("p3", "<f4", (3,)), ("pad3", "<f4"),
])
QUAD_SHADE = np.dtype([
    ("uv", "<f4", (8,)),
    ("material", "<u4"), ("object", "<u4"), ("prim", "<u4"), ("flags", "<u4"),
])

# --- Displaced primitive: 208 bytes -------------------------------------------
# shape DISP_QUAD: a planar parallelogram P(u, v) = p + u e0 + v e1, n = unit e0 x e1.
# shape DISP_TRAPEZOID: any other planar convex quad, the bilinear patch
# P(u, v) = p + u e0 + v e1 + u v g (g = p0 - p1 + p2 - p3, in the plane), n = unit e0 x e1.
# shape DISP_SPHERE / DISP_CYLINDER: centre / origin p, frame e0 = axis_x,
# e1 = axis_z x axis_x, n = axis_z; cylinder z and theta (radians) ranges.
# The surface is P(u, v) + H(u, v) n(u, v), H in [hmin, hmax] (world units), read
# bilinearly from ``heights`` (uint16: hmin + q (hmax - hmin) / 65535) at texel ``hoff`` (hw x hh, row 0 on top,
# wrap: kernels/texture/wrap.h); its min-max pyramid (``levels`` levels, (min, max) pairs)
# starts at ``moff`` (texray.displace.minmax_pyramid). method: texray.displace
# METHOD_IDS | METHOD_ADAPTIVE; steps N, refine M: the search's knobs. uv: texture
# coordinates of the quad's corners, as QuadShade.uv.
# shape DISP_TRIANGLE: one prism shell of a displaced triangle mesh (texray.compile.shells):
# corners P0 = p, P1 = p + e0, P2 = p + e1, vertex normals n (N0), n1, n2 (unit), the surface
# P(b1, b2) + H N(b1, b2) with P and N interpolated linearly (N not renormalized); uv the
# corners' texture coordinates (u0 v0 u1 v1 u2 v2, the last pair unused); the shell spans
# h in [slo, shi] (this triangle's bound of H over its uv footprint), hmin and hmax stay
# the height field's range (the stored texels' scale); edges: bit k set when edge k (corner
# k to k + 1) is shared with another shell of the same mesh.
DISPLACED = np.dtype([
    ("p", "<f4", (3,)), ("radius", "<f4"),
    ("e0", "<f4", (3,)), ("z_min", "<f4"),
    ("e1", "<f4", (3,)), ("z_max", "<f4"),
    ("n", "<f4", (3,)), ("theta_min", "<f4"),
    ("uv", "<f4", (8,)),
    ("hmin", "<f4"), ("hmax", "<f4"), ("theta_max", "<f4"), ("material", "<u4"),
    ("object", "<u4"), ("prim", "<u4"), ("shape", "<u4"), ("method", "<u4"),
    ("hoff", "<u4"), ("moff", "<u4"), ("hw", "<u4"), ("hh", "<u4"),
    ("levels", "<u4"), ("wrap", "<u4"), ("steps", "<u4"), ("refine", "<u4"),
    ("g", "<f4", (3,)), ("edges", "<u4"),
    ("n1", "<f4", (3,)), ("slo", "<f4"),
    ("n2", "<f4", (3,)), ("shi", "<f4"),
])
DISP_QUAD, DISP_SPHERE, DISP_CYLINDER, DISP_TRAPEZOID, DISP_TRIANGLE = 0, 1, 2, 3, 4
DISP_SEARCH, DISP_MAXMIP, DISP_ADAPTIVE = 0, 1, 4     # DISPLACED.method: a method | the adaptive bit

# --- Instance of a mesh: 160 bytes --------------------------------------------
# A placed copy of a mesh whose triangles (in the mesh's own world space, "object space")
# and 4-wide BLAS are stored once in tri_verts / nodes. Rows of 3x4 matrices acting on
# column vectors: w2o world to object, o2w object to world; nrm the rows of the normal
# matrix (inverse transpose of o2w's 3x3, 4th column 0). root: the BLAS root's wide node
# index in ``nodes``; object: the instance's index in the scene (ids, AOV object_id);
# det_sign: +1, or -1 for a mirroring transform (the geometric normal's side).
INSTANCE = np.dtype([
    ("w2o", "<f4", (3, 4)), ("o2w", "<f4", (3, 4)), ("nrm", "<f4", (3, 4)),
    ("root", "<u4"), ("object", "<u4"), ("det_sign", "<f4"), ("pad0", "<u4"),
])

# --- Material: 64 bytes -----------------------------------------------------
# Texture slots are indices into the texture table, -1 = none.
MATERIAL = np.dtype([
    ("diffuse", "<f4", (3,)), ("diffuse_tex", "<i4"),
    ("specular", "<f4", (3,)), ("shininess", "<f4"),
    # texture indices into the TEXTURE table, -1 = role unused
    ("specular_tex", "<i4"), ("shininess_tex", "<i4"), ("label_tex", "<i4"), ("bump_tex", "<i4"),
    ("normal_tex", "<i4"), ("normal_mode", "<u4"),     # normal_mode: kernels' TX_NORMAL_* flags
    ("bump_height", "<f4"), ("bump_delta", "<f4"),      # world units per texture unit; step: BUMP_DELTA_*
])
# normal_mode bits (texray.bump.NormalMap): the green channel points down (DirectX), and
# the map holds object-space rather than tangent-space normals.
TX_NORMAL_DIRECTX = 1
TX_NORMAL_OBJECT = 2
# bump_delta: > 0 the central-difference step in texture coordinates; BUMP_DELTA_TEXEL one
# texel of the level in use; BUMP_DELTA_ANALYTIC the exact gradient of the bilinear interpolant.
BUMP_DELTA_TEXEL = 0.0
BUMP_DELTA_ANALYTIC = -1.0

# --- Texture table entry: 64 bytes ------------------------------------------
# Texels are RGBA half floats, linear (texray.texture: decoded per role), row 0 =
# the file's top row. A texture's ``levels`` MIP levels (1 = level 0 only) lie
# contiguously from texel ``offset`` of the shared buffer: level l is
# max(1, width >> l) x max(1, height >> l) texels and starts after the levels
# before it (kernels/texture/texture.h texture_level). ``wrap``: kernels/texture/wrap.h
# TX_WRAP_*; ``filter``: FILTER_* below. The lookup coordinates are
# (u', v') = (m0[0] u + m0[1] v + m1[0], m0[2] u + m0[3] v + m1[1]): the
# texture's UV transform (texray.mapping.UVTransform). ``max_aniso``: the most
# probes an anisotropic lookup takes (kernels/texture/texture.h texture_anisotropic).
TEXTURE = np.dtype([
    ("offset", "<u4"), ("width", "<u4"), ("height", "<u4"), ("wrap", "<u4"),
    ("m0", "<f4", (4,)),
    ("m1", "<f4", (2,)), ("levels", "<u4"), ("filter", "<u4"),
    ("max_aniso", "<u4"), ("pad0", "<u4", (3,)),
])
# Codes the device switches on, by name (kernels switch on the generated TX_WRAP_*,
# TX_MAP_* and FILTER_* macros; the host looks the names up here).
FILTERS = {"nearest": 0, "bilinear": 1, "trilinear": 2, "anisotropic": 3}      # TextureInfo.filter
WRAP_MODES = {"repeat": 0, "clamp": 1, "mirror": 2}                           # TextureInfo.wrap, Displaced.wrap
PROJECTION_KINDS = {"planar": 0, "cylindrical": 1, "spherical": 2}            # ObjectInfo.mapping (-1: none)
FILTER_NEAREST, FILTER_BILINEAR, FILTER_TRILINEAR, FILTER_ANISOTROPIC = (FILTERS[k] for k in FILTERS)

# --- Per-object data: 128 bytes -----------------------------------------------
# mapping: -1 = the primitive's own uv, else kernels/texture/mapping.h TX_MAP_* with
# the projection frame in world space (axes scaled by the projection's scale).
OBJECT = np.dtype([
    ("mapping", "<i4"), ("pad0", "<i4"), ("pad1", "<i4"), ("pad2", "<i4"),
    ("origin", "<f4", (3,)), ("pad3", "<f4"),
    ("x", "<f4", (3,)), ("pad4", "<f4"),
    ("y", "<f4", (3,)), ("pad5", "<f4"),
    ("z", "<f4", (3,)), ("pad6", "<f4"),
    # rows of the object's normal matrix (inverse transpose of its transform): object-space normal maps
    ("nm0", "<f4", (3,)), ("pad7", "<f4"),
    ("nm1", "<f4", (3,)), ("pad8", "<f4"),
    ("nm2", "<f4", (3,)), ("pad9", "<f4"),
])

# --- Point light: 32 bytes --------------------------------------------------
POINT_LIGHT = np.dtype([
    ("position", "<f4", (3,)), ("pad0", "<f4"),
    ("intensity", "<f4", (3,)), ("pad1", "<f4"),
])

# --- Camera: 64 bytes -------------------------------------------------------
# Primary ray through NDC (x, y) in [-1, 1]^2 (y up): dir = forward + x*right + y*up,
# with right/up already scaled by the field of view and aspect ratio.
CAMERA = np.dtype([
    ("eye", "<f4", (3,)), ("pad0", "<f4"),
    ("forward", "<f4", (3,)), ("pad1", "<f4"),
    ("right", "<f4", (3,)), ("pad2", "<f4"),
    ("up", "<f4", (3,)), ("pad3", "<f4"),
])

# --- Wavefront records between kernel stages --------------------------------
RAY = np.dtype([("org", "<f4", (3,)), ("tmin", "<f4"), ("dir", "<f4", (3,)), ("tmax", "<f4")])
# prim: the primitive kind << HIT_KIND_SHIFT | its index in that kind's leaf-ordered array; 0xffffffff = miss.
HIT = np.dtype([("t", "<f4"), ("b1", "<f4"), ("b2", "<f4"), ("prim", "<u4")])
# Everything the lighting stage needs about a hit; produced by the surface stage.
SURFACE = np.dtype([
    ("p", "<f4", (3,)), ("offset", "<f4"),       # offset: shadow-ray origin offset along ng
    ("ng", "<f4", (3,)), ("valid", "<u4"),       # ng faces the incoming ray
    ("ns", "<f4", (3,)), ("shininess", "<f4"),   # ns faces the incoming ray
    ("kd", "<f4", (3,)), ("pad0", "<f4"),
    ("ks", "<f4", (3,)), ("pad1", "<f4"),
    ("lift", "<f4", (3,)), ("pad2", "<f4"),      # shadow-ray origin p + lift (Hanika's terminator fix; 0: none)
])

# Hit.prim packs the primitive kind above the index of that kind's array.
HIT_KIND_SHIFT = 28
HIT_INDEX_MASK = (1 << HIT_KIND_SHIFT) - 1

# AOVs: name -> (first channel, channels) in the surface stage's per-ray AOV record.
AOVS = {
    "uv": (0, 2), "position": (2, 3), "normal": (5, 3), "shading_normal": (8, 3), "depth": (11, 1),
    "primitive_id": (12, 1), "object_id": (13, 1), "dpdu": (14, 3), "dpdv": (17, 3),
}
AOV_FLOATS = 20
AOV_LENGTHS = ("position", "depth", "dpdu", "dpdv")      # in world units (texray.compile.units)

STRUCTS = {
    "BVHNode": BVH_NODE, "BVH4Node": BVH4_NODE, "TriVerts": TRI_VERTS, "TriShade": TRI_SHADE,
    "Sphere": SPHERE, "Cylinder": CYLINDER, "QuadVerts": QUAD_VERTS, "QuadShade": QUAD_SHADE,
    "Displaced": DISPLACED, "Instance": INSTANCE, "Material": MATERIAL,
    "TextureInfo": TEXTURE, "ObjectInfo": OBJECT, "PointLight": POINT_LIGHT, "Camera": CAMERA,
    "Ray": RAY, "Hit": HIT, "Surface": SURFACE,
}

_C_TYPES = {np.dtype("<f4"): "float", np.dtype("<u4"): "uint", np.dtype("<i4"): "int"}

CONSTANTS = {
    "LEAF_COUNT_BITS": LEAF_COUNT_BITS, "LEAF_COUNT_MASK": LEAF_COUNT_MASK,
    "PRIM_TRIANGLE": PRIM_TRIANGLE, "PRIM_SPHERE": PRIM_SPHERE, "PRIM_CYLINDER": PRIM_CYLINDER,
    "PRIM_QUAD": PRIM_QUAD, "PRIM_DISPLACED": PRIM_DISPLACED,
    "PRIM_INSTANCE": PRIM_INSTANCE,
    "DISP_QUAD": DISP_QUAD, "DISP_SPHERE": DISP_SPHERE, "DISP_CYLINDER": DISP_CYLINDER,
    "DISP_TRAPEZOID": DISP_TRAPEZOID, "DISP_TRIANGLE": DISP_TRIANGLE,
    "DISP_SEARCH": DISP_SEARCH, "DISP_MAXMIP": DISP_MAXMIP, "DISP_ADAPTIVE": DISP_ADAPTIVE, "HIT_KIND_SHIFT": HIT_KIND_SHIFT, "HIT_INDEX_MASK": HIT_INDEX_MASK,
    "AOV_FLOATS": AOV_FLOATS, **{f"AOV_{k.upper()}": v[0] for k, v in AOVS.items()},
    "TRI_HAS_NORMALS": TRI_HAS_NORMALS,
    "TRI_HAS_UVS": TRI_HAS_UVS,
    "FILTER_NEAREST": FILTER_NEAREST, "FILTER_BILINEAR": FILTER_BILINEAR, "FILTER_TRILINEAR": FILTER_TRILINEAR,
    "FILTER_ANISOTROPIC": FILTER_ANISOTROPIC,
    "TX_NORMAL_DIRECTX": TX_NORMAL_DIRECTX, "TX_NORMAL_OBJECT": TX_NORMAL_OBJECT,
}


# Vector views: the kernels read these runs of a struct's floats as one float4 load
# (16-byte aligned). For each struct, the accessor prefix and {view: fields}; a view of
# one float[3] field is a float3 (the load's .xyz), of fields making 4 floats a float4.
# The accessors are generated from the dtypes' offsets (:func:`vector_views`), so the
# kernels never assume a field order: a reordered dtype moves them or fails here.
VECTOR_VIEWS = {
    "TriVerts": ("tri", {"p0": ("p0",), "p1": ("p1",), "p2": ("p2",)}),
    "QuadVerts": ("quad", {"p0": ("p0",), "p1": ("p1",), "p2": ("p2",), "p3": ("p3",)}),
    "Sphere": ("sphere", {"center_radius": ("center", "radius"), "axis_x": ("axis_x",), "axis_z": ("axis_z",)}),
    "Cylinder": ("cylinder", {"origin_radius": ("origin", "radius"), "axis_x": ("axis_x",),
                              "axis_z": ("axis_z",)}),
}


def vector_views() -> str:
    """OpenCL C accessors of :data:`VECTOR_VIEWS`, checked against the dtypes."""
    f4 = np.dtype("<f4")
    lines = []
    for struct, (prefix, views) in VECTOR_VIEWS.items():
        dt = STRUCTS[struct]
        for view, fields in views.items():
            start = dt.fields[fields[0]][1]
            at, floats = start, 0
            for name in fields:
                ftype, off = dt.fields[name][:2]
                if off != at or ftype.base != f4:
                    raise AssertionError(f"{struct}.{view}: {name} is not the next float after {at}")
                at += ftype.itemsize
                floats += ftype.itemsize // 4
            if start % 16 or floats not in (3, 4):
                raise AssertionError(f"{struct}.{view}: {floats} floats at offset {start}: not a float4 word")
            kind, swizzle = ("float4", "") if floats == 4 else ("float3", ".xyz")
            lines.append(f"static inline {kind} {prefix}_{view}(__global const {struct}* p) "
                         f"{{ return ((__global const float4*)p)[{start // 16}]{swizzle}; }}")
    return "\n".join(lines) + "\n"


# Signed codes, emitted without the unsigned suffix (compared with int fields and -1).
INT_CONSTANTS = {
    **{f"TX_WRAP_{k.upper()}": v for k, v in WRAP_MODES.items()},
    **{f"TX_MAP_{k.upper()}": v for k, v in PROJECTION_KINDS.items()},
}


def _check(name, dt):
    if dt.itemsize % 16:
        raise AssertionError(f"{name}: size {dt.itemsize} is not a multiple of 16")


def opencl_declarations() -> str:
    """OpenCL C source declaring every struct of :data:`STRUCTS` and the constants."""
    lines = ["/* Generated by texray.layout: do not edit. */",
             "#ifndef TEXRAY_LAYOUT_H", "#define TEXRAY_LAYOUT_H"]
    for k, v in CONSTANTS.items():
        lines.append(f"#define {k} {v}u")
    for k, v in INT_CONSTANTS.items():
        lines.append(f"#define {k} {v}")
    for name, dt in STRUCTS.items():
        _check(name, dt)
        lines.append("typedef struct {")
        for field in dt.names:
            base, shape = dt.fields[field][0].base, dt.fields[field][0].shape
            dims = "".join(f"[{n}]" for n in shape)
            lines.append(f"    {_C_TYPES[base]} {field}{dims};")
        lines.append(f"}} {name};")
    lines.append(vector_views())
    lines.append("#endif")
    return "\n".join(lines) + "\n"
