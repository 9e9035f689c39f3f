"""The feature set of a compiled scene, and the one function that turns it into
kernel compile-time definitions. Every ``#if`` in kernels/ uses a name emitted here."""
from __future__ import annotations

from dataclasses import dataclass


@dataclass(frozen=True)
class Features:
    textures: bool = False         # any material samples a texture
    vertex_normals: bool = False   # any mesh carries per-vertex shading normals
    specular: bool = False         # any material has ks > 0
    shadows: bool = True           # trace shadow rays (False: every light is visible)
    spheres: bool = False          # primitive kinds present in the BVH (triangles are always compiled)
    cylinders: bool = False
    quads: bool = False
    projections: bool = False      # some object generates its uv by a projection mapping
    aovs: bool = False             # the surface stage writes AOVs
    stack_size: int = 64           # BVH traversal stack; >= the tree's depth


def stack_size_for(depth: int) -> int:
    """Smallest of 32, 64, 128, ... that holds a traversal of a tree of ``depth`` levels
    (few distinct values, so few program variants)."""
    size = 32
    while size < depth + 1:
        size *= 2
    return size


def compile_options(f: Features) -> dict[str, int]:
    """``-D`` definitions for the kernels: the only place feature names become macros."""
    return {
        "TX_TEXTURES": int(f.textures),
        "TX_VERTEX_NORMALS": int(f.vertex_normals),
        "TX_SPECULAR": int(f.specular),
        "TX_SHADOWS": int(f.shadows),
        "TX_SPHERES": int(f.spheres),
        "TX_CYLINDERS": int(f.cylinders),
        "TX_QUADS": int(f.quads),
        "TX_PROJECTIONS": int(f.projections),
        "TX_AOVS": int(f.aovs),
        "TX_STACK_SIZE": int(f.stack_size),
    }
