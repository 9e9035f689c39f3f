"""Instances: one Mesh placed many times without copying its triangles (a two-level BVH:
texray.compile.instances, kernels/accel/instance.h)."""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .. import validate as V
from ..device import layout
from ..errors import SceneError
from .mesh import Mesh
from .transform import Transform

# Smallest ratio of the 3x3 part's least to greatest singular value: a transform closer to
# singular has no float32 inverse worth moving rays by (about 2^-20: a flattening by 10^6).
SINGULAR_RCOND = 1e-6


@dataclass
class Instance:
    """``mesh`` placed by ``transform`` (a texray.Transform or a 4x4 affine matrix acting
    on column vectors), after the mesh's own transform: world = transform @ mesh.transform.
    The mesh's triangles and BVH are stored once however many instances share it (the
    same Mesh object); materials, uvs and normals are the mesh's. ``name`` is what
    errors quote. A singular, non-finite or non-affine transform raises SceneError."""
    mesh: Mesh
    transform: object = None
    name: str = "<instance>"

    PRIM = layout.PRIM_INSTANCE

    def __post_init__(self):
        self.validate(check_mesh=False)       # a Mesh is validated when made

    # The object's fields the compiler reads of every shape.
    @property
    def material(self):
        return self.mesh.material

    @property
    def mapping(self):
        return self.mesh.mapping

    @property
    def materials(self):
        return self.mesh.materials

    def validate(self, check_mesh=True):
        """Check every field again; ``check_mesh=False`` skips the mesh's own fields (the
        compiler checks a mesh shared by many instances once)."""
        if not isinstance(self.name, str):
            raise SceneError(f"instance: name: expected a string, got {V.show(self.name)}")
        where = f"{self.name}: "
        V.instance(self.mesh, Mesh, "mesh", where, "a texray.Mesh")
        if check_mesh:
            self.mesh.validate()
        self.matrix()
        return self

    def matrix(self) -> np.ndarray:
        """The instance's own 4x4 float64 matrix (validated)."""
        where = f"{self.name}: transform"
        t = self.transform
        if t is None:
            return np.eye(4)
        if isinstance(t, Transform):
            m = t.matrix(where + ".")
        else:
            try:
                m = np.array(t, dtype=np.float64)
            except (TypeError, ValueError):
                raise SceneError(f"{where}: expected a texray.Transform or a 4x4 matrix, got {V.show(t)}") from None
            if m.shape != (4, 4):
                raise SceneError(f"{where}: expected a texray.Transform or a 4x4 matrix, got shape {m.shape}")
        if not np.all(np.isfinite(m)):
            i, j = np.argwhere(~np.isfinite(m))[0]
            raise SceneError(f"{where}: element [{i}][{j}] is {m[i, j]} (expected finite values)")
        if np.any(np.abs(m[:3, 3]) > V.COORD_LIMIT) or np.any(np.abs(m[:3, :3]) > V.COORD_LIMIT):
            raise SceneError(f"{where}: elements beyond +-{V.COORD_LIMIT:.0e}")
        if not np.array_equal(m[3], [0.0, 0.0, 0.0, 1.0]):
            raise SceneError(f"{where}: the last row is {V.show(m[3].tolist())}, expected [0, 0, 0, 1] "
                             "(an affine transform)")
        a = m[:3, :3]
        sv = np.linalg.svd(a, compute_uv=False)
        if not (sv[0] > 0 and sv[-1] > SINGULAR_RCOND * sv[0]):
            raise SceneError(f"{where}: singular matrix (determinant {np.linalg.det(a):.3g}, singular values "
                             f"{sv[-1]:.3g} to {sv[0]:.3g}, ratio under {SINGULAR_RCOND:g}): the instance would "
                             "be flattened")
        return m

    def world_matrix(self) -> np.ndarray:
        """Object (the mesh's input) to world: the instance's matrix after the mesh's own."""
        own = np.eye(4) if self.mesh.transform is None else self.mesh.transform.matrix()
        return self.matrix() @ own
