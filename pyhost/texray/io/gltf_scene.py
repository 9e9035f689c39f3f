"""Whole glTF 2.0 files as a texray Scene: every mesh node with its materials, the
perspective cameras and the KHR_lights_punctual lights (texray.io.gltf reads the file).

A file without a camera gets one framing its meshes and a file without lights a point
light at the camera (a headlight), each with a warning: a scene that renders black or
shows nothing would be a silent wrong render. ``scene.render_settings`` holds the image
size the camera's aspect ratio asks for (640 pixels wide)."""
from __future__ import annotations

import warnings

import numpy as np

from ..errors import SceneError
from ..scene import Camera, Instance, Mesh, PointLight, Scene
from .. import validate as V
from .gltf import read_gltf

DEFAULT_WIDTH = 640
HEADLIGHT_IRRADIANCE = 1.0     # the headlight's irradiance at the scene's centre, texray's units


def load_gltf_scene(path, camera=None, instances=True) -> Scene:
    """The Scene of a .gltf/.glb file. ``camera``: the name of the camera node to use (default
    the first); a name the file does not have is an error listing those it has.
    ``instances``: nodes that share a glTF mesh become texray Instances of one Mesh (its
    triangles stored once: texray.scene.instance); False copies the triangles per node."""
    g = read_gltf(path)
    if not g.meshes:
        raise SceneError(f"{path}: the file's scene has no triangle meshes")
    objects = _objects(g.meshes, instances)
    lo = np.min([m.positions.min(axis=0) for m in g.meshes], axis=0)
    hi = np.max([m.positions.max(axis=0) for m in g.meshes], axis=0)
    cam, aspect = _camera(g, camera, lo, hi, path)
    lights = [light for _, light in g.lights]
    if not lights:
        eye = np.asarray(cam.eye, np.float64)
        d2 = float(np.sum((eye - (lo + hi) / 2) ** 2)) or 1.0
        lights = [PointLight(tuple(eye), (HEADLIGHT_IRRADIANCE * d2,) * 3)]
        warnings.warn(f"{path}: no KHR_lights_punctual lights: a point light at the camera lights the scene",
                      stacklevel=3)
    scene = Scene(camera=cam, lights=lights, objects=objects)
    height = max(1, int(round(DEFAULT_WIDTH / aspect))) if aspect else 480
    scene.render_settings = {"width": DEFAULT_WIDTH, "height": height}
    if aspect:
        scene.render_settings["aspect"] = float(aspect)    # texray render --width W alone keeps it
    return scene


def _objects(meshes, instances):
    """texray objects for the file's mesh nodes: a Mesh per node, or, for a glTF mesh that
    several nodes place (with ``instances``), one Mesh in the mesh's own space and an
    Instance of it per node, under the node's world matrix."""
    uses = {}
    for m in meshes:
        uses[m.mesh_index] = uses.get(m.mesh_index, 0) + 1
    shared, out = {}, []
    for m in meshes:
        # a mirroring node keeps its copy: the reader reverses its faces (glTF's front-face
        # rule), which an instance of the unmirrored mesh would not
        if (instances and m.local is not None and m.world is not None and uses[m.mesh_index] > 1
                and np.linalg.det(m.world[:3, :3]) > 0):
            if m.mesh_index not in shared:
                loc = m.local
                shared[m.mesh_index] = Mesh(loc.positions, loc.faces, loc.uvs, loc.normals,
                                            material=list(loc.materials), material_ids=loc.material_ids,
                                            name=f"{m.name.rsplit(': ', 1)[0]}: meshes[{m.mesh_index}]")
            out.append(Instance(shared[m.mesh_index], transform=m.world, name=m.name))
        else:
            out.append(Mesh(m.positions, m.faces, m.uvs, m.normals, material=list(m.materials), name=m.name,
                            material_ids=m.material_ids))
    return out


def _camera(g, name, lo, hi, path):
    """(Camera, aspect ratio or None) chosen by ``name``, the first, or one framing [lo, hi]."""
    if name is not None:
        if not isinstance(name, str):
            raise SceneError(f"{path}: camera: expected a camera name, got {V.show(name)}")
        for n, cam, aspect in g.cameras:
            if n == name:
                return cam, aspect
        have = ", ".join(repr(n) for n, _, _ in g.cameras) or "none"
        raise SceneError(f"{path}: camera: no camera named {name!r} (the file has: {have})")
    if g.cameras:
        _, cam, aspect = g.cameras[0]
        return cam, aspect
    centre, radius = (lo + hi) / 2, max(float(np.linalg.norm(hi - lo)) / 2, 1e-6)
    fov = 40.0
    dist = 1.1 * radius / np.sin(np.radians(fov / 2))
    warnings.warn(f"{path}: no perspective camera: a camera on +z frames the scene", stacklevel=4)
    return Camera(eye=tuple(centre + [0.0, 0.0, dist]), look_at=tuple(centre), fov_y=fov), None
