"""Procedural content, pure numpy: meshes (:mod:`.meshes`: the scene files' generators
and the benchmark's meshes) and textures (:mod:`.textures`)."""
from .meshes import MeshData, bench_mesh, displaced_sphere, grid, lathe, torus, uv_sphere, vase, vase_profile
from .textures import bricks, bricks_height, checker, globe, label, marble, tiles, value_noise, wood

__all__ = ["MeshData", "grid", "lathe", "uv_sphere", "torus", "vase_profile", "vase", "displaced_sphere", "bench_mesh",
           "value_noise", "checker", "wood", "marble", "bricks", "bricks_height", "tiles", "globe", "label"]
