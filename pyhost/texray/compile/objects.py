"""The per-object table (layout.OBJECT): projection frames and normal matrices, for
scenes whose objects have projection mappings or object-space normal maps."""
from __future__ import annotations

import numpy as np

from ..device import layout
from ..linalg import apply_points
from ..scene.shape import materials_of


def _matrix(obj):
    """The object's 4x4 object-to-world matrix (an instance's after its mesh's own)."""
    if hasattr(obj, "world_matrix"):
        return obj.world_matrix()
    return np.eye(4) if obj.transform is None else obj.transform.matrix()


def object_frame(obj):
    """The object's projection frame in world space as (origin, x, y, z) rows, axes scaled so that
    dot(p_world - origin, axis) equals the object-space coordinate times the projection's scale."""
    f = obj.mapping.device_frame().astype(np.float64)
    m = _matrix(obj)
    inv_t = np.linalg.inv(m[:3, :3]).T
    return np.stack([apply_points(m, f[:1])[0], inv_t @ f[1], inv_t @ f[2], inv_t @ f[3]])


def object_table(objs, always=False):
    """layout.OBJECT per scene object, or None when no object has a projection mapping
    (unless ``always``: a program compiled with projections reads the table)."""
    if not always and not any(o.mapping is not None or _object_space_normals(o) for o in objs):
        return None
    table = np.zeros(max(len(objs), 1), layout.OBJECT)
    table["mapping"] = -1
    for i, o in enumerate(objs):
        if o.mapping is not None:
            f = object_frame(o)
            table[i]["mapping"] = o.mapping.kind_id
            table[i]["origin"], table[i]["x"], table[i]["y"], table[i]["z"] = f
        m = _matrix(o)
        table[i]["nm0"], table[i]["nm1"], table[i]["nm2"] = np.linalg.inv(m[:3, :3]).T
    return table


def _object_space_normals(obj):
    return any(m.normal_map is not None and m.normal_map.space == "object" for m in materials_of(obj))
