#!/usr/bin/env python3
"""(Re)generate texray's showcase assets, deterministically.

    python tools/make_assets.py [--out scenes]

Writes into ``OUT/meshes/``: ``vase.obj``, ``torus.obj`` (v/vt/vn/f lines
only, ``f a/a/a`` with shared indices, no material library), and into
``OUT/textures/``: ``wood.png``, ``checker.png``, ``bricks.png`` (8-bit RGB,
sRGB-encoded display values) and ``bricks_height.png`` (8-bit, 1 channel,
linear height data (tagged linear) matching ``bricks.png``), all 512 x 512;
``globe_height.png`` (the continents' relief of ``globe.png``) and
``tiles_normal.png`` (a tangent-space normal map, OpenGL convention, made from a
tile height field by ``normal_map_from_height``), linear data. Height fields for
displacement mapping are 16-bit, 1 channel, linear (an 8-bit map terraces slopes
into visible steps): ``bricks_height16.png`` (``bricks_height.png`` at 16 bits, for
the showcase ``scenes/displacement/``) and, 256 x 256, the displacement bench's
``disp_wall.png`` (bricks 4 across, 8 up), ``disp_planet.png`` (1/f^2.2 fractal
mountains, tileable) and ``disp_terrain.png`` (those mountains at 1/4 height with
64 one-texel spikes of height 1).
"""
from __future__ import annotations

import argparse
import io
import sys
from pathlib import Path

import numpy as np
import OpenImageIO as oiio

REPO = Path(__file__).resolve().parent.parent
if str(REPO / "pyhost") not in sys.path:
    sys.path.append(str(REPO / "pyhost"))   # PYTHONPATH wins if set
sys.path.insert(0, str(Path(__file__).resolve().parent))   # tools/gltf_writer.py

from texray import procedural as proc  # noqa: E402
from texray.procedural.textures import _fbm as fbm  # noqa: E402  (the noise of globe(), float64)

TEX_SIZE = 512


def obj_text(mesh, comment=""):
    """OBJ text of a MeshData: v, vt (if any), vn (if any), f lines.

    Vertex, UV and normal arrays share one index, so faces are ``f a/a/a``
    (``a//a`` without UVs, ``a/a`` without normals, ``a`` with neither).
    Numbers use %.6g.
    """
    out = io.StringIO()
    for line in comment.splitlines():
        out.write(f"# {line}\n")
    np.savetxt(out, mesh.positions, fmt="v %.6g %.6g %.6g")
    if mesh.uvs is not None:
        np.savetxt(out, mesh.uvs, fmt="vt %.6g %.6g")
    if mesh.normals is not None:
        np.savetxt(out, mesh.normals, fmt="vn %.6g %.6g %.6g")
    corner = {(True, True): "%d/%d/%d", (True, False): "%d/%d",
              (False, True): "%d//%d", (False, False): "%d"}[
        (mesh.uvs is not None, mesh.normals is not None)]
    reps = corner.count("%d")
    idx = np.repeat(mesh.faces + 1, reps, axis=1)
    np.savetxt(out, idx, fmt="f " + " ".join([corner] * 3))
    return out.getvalue()


def write_obj(path, mesh, comment=""):
    Path(path).parent.mkdir(parents=True, exist_ok=True)
    with open(path, "w", newline="\n") as f:
        f.write(obj_text(mesh, comment))


def write_png(path, image, colorspace="sRGB", bits=8):
    """Write a float (H, W, C) image in [0, 1], row 0 = top, as 8- or 16-bit PNG."""
    Path(path).parent.mkdir(parents=True, exist_ok=True)
    top, dtype, fmt = (255.0, np.uint8, oiio.UINT8) if bits == 8 else (65535.0, np.uint16, oiio.UINT16)
    pixels = np.round(np.clip(image, 0.0, 1.0) * top).astype(dtype)
    h, w, c = pixels.shape
    spec = oiio.ImageSpec(w, h, c, fmt)
    spec.attribute("oiio:ColorSpace", colorspace)
    buf = oiio.ImageBuf(spec)
    buf.set_pixels(oiio.ROI(), np.ascontiguousarray(pixels))
    if not buf.write(str(path)):
        raise RuntimeError(f"writing {path}: {buf.geterror()}")


def meshes():
    """name -> (MeshData, comment) for the showcase meshes."""
    return {
        "vase": (proc.vase(n_around=48, n_profile=36),
                 "texray vase: closed thick-walled solid, 1 unit tall on y=0;"
                 "\nu around, v along the profile"),
        "ground": (proc.grid(1, 1, size=(8, 8), uv_scale=4.0),
                   "texray ground: 8x8 square at y=0 facing +y, uvs repeat 4 times"),
        "torus": (proc.torus(64, 24, R=0.7, r=0.25),
                  "texray torus about y: R=0.7, r=0.25; u around y, v around"
                  " the tube"),
    }


def textures():
    """file name -> (float image, colour space) for the showcase textures."""
    s = TEX_SIZE
    return {
        "wood.png": (proc.wood(s, seed=7), "sRGB"),
        "checker.png": (proc.checker(s, n_checks=8), "sRGB"),
        "bricks.png": (proc.bricks(s, seed=3), "sRGB"),
        "bricks_height.png": (proc.bricks_height(s, seed=3), "linear"),
        "globe.png": (proc.globe((512, 1024)), "sRGB"),
        "label.png": (proc.label((256, 512)), "sRGB"),
        "globe_height.png": (globe_height((512, 1024)), "linear"),
        "tiles_normal.png": (normal_map_from_height(
            proc.bricks_height(s, n_rows=6, n_cols=6, mortar=0.08, bevel=0.06, seed=4, offset=0.0), 6.0), "linear"),
    }


def heights16():
    """file name -> (H, W, 1) heights in [0, 1], written as 16-bit linear PNG."""
    return {"bricks_height16.png": proc.bricks_height(TEX_SIZE, seed=3), **displacement_heights()}


def displacement_heights(size=256, seed=7):
    """The displacement bench's height fields (scenes/bench/{displaced_wall,planet,terrain}.toml)."""
    rng = np.random.default_rng(seed)
    y, x = np.mgrid[0:size, 0:size] / size
    row = np.floor(y * 8)
    bx = (x * 4 + 0.5 * (row % 2)) % 1
    by = (y * 8) % 1
    wall = np.minimum(np.minimum(bx, 1 - bx) * 4, np.minimum(by, 1 - by) * 2).clip(0, 0.1) * 10
    freq = np.fft.fftfreq(size)
    spec = rng.normal(size=(size, size)) + 1j * rng.normal(size=(size, size))
    spec /= np.maximum(np.hypot(freq[None, :], freq[:, None]), 1.0 / size) ** 2.2
    mountains = np.real(np.fft.ifft2(spec))
    mountains = (mountains - mountains.min()) / np.ptp(mountains)
    terrain = 0.25 * mountains
    ij = rng.integers(0, size, (size // 4, 2))
    terrain[ij[:, 0], ij[:, 1]] = 1.0                      # one-texel spikes
    return {name: a[..., None].astype(np.float32) for name, a in
            (("disp_wall.png", wall), ("disp_planet.png", mountains), ("disp_terrain.png", terrain))}


def globe_height(size, seed=5, sea_level=0.52):
    """Relief of proc.globe's continents (same noise), 0 at sea level and below, 1 at the highest land."""
    h, w = size
    height = fbm(h, w, (3, 6), 6, seed)          # float64, as globe() draws its continents
    return np.clip((height - sea_level) / (1 - sea_level), 0, 1)[..., None].astype(np.float32)


def normal_map_from_height(height, strength):
    """Tangent-space normal map (OpenGL convention: green = +v, up the image) of a tileable
    (H, W, 1) height field in [0, 1]: n = normalize(-k dh/du, -k dh/dv, 1) by periodic central
    differences, with k = strength / texels across (heights in units of the texture's width),
    encoded as (n + 1) / 2."""
    hgt = height[..., 0].astype(np.float64)
    h, w = hgt.shape
    dh_du = (np.roll(hgt, -1, 1) - np.roll(hgt, 1, 1)) * (w / 2.0)
    dh_dv = (np.roll(hgt, 1, 0) - np.roll(hgt, -1, 0)) * (h / 2.0)      # row 0 is the top: v grows upward
    n = np.stack([-strength * dh_du / w, -strength * dh_dv / w, np.ones_like(hgt)], -1)
    n /= np.linalg.norm(n, axis=-1, keepdims=True)
    return ((n + 1.0) / 2.0).astype(np.float32)


def _look_at(eye, target, up=(0.0, 1.0, 0.0)):
    """The 4x4 node matrix of a glTF camera at ``eye`` looking at ``target`` (it looks along -Z)."""
    eye, target, up = (np.asarray(v, np.float64) for v in (eye, target, up))
    z = eye - target
    z /= np.linalg.norm(z)
    x = np.cross(up, z)
    x /= np.linalg.norm(x)
    m = np.eye(4)
    m[:3, 0], m[:3, 1], m[:3, 2], m[:3, 3] = x, np.cross(z, x), z, eye
    return m


def _rotation_y(degrees):
    """The (x, y, z, w) quaternion of a rotation about +y."""
    h = np.radians(degrees) / 2
    return [0.0, float(np.sin(h)), 0.0, float(np.cos(h))]


def gltf_still_life(path):
    """``scenes/gltf/still_life.glb``: a whole glTF scene for ``texray render`` and the
    README's "glTF scenes": a node hierarchy (a group rotated by a quaternion), a
    perspective camera, two KHR_lights_punctual point lights, and metallic-roughness
    materials: a checker floor (KHR_texture_transform repeats it 3 times), a wooden vase,
    a gold torus with a roughness map, a marble ball with a normal map (glTF scale 0.8)."""
    from gltf_writer import GltfWriter, gltf_uvs
    w = GltfWriter(generator="texray tools/make_assets.py")
    w.use_extension("KHR_texture_transform")
    size = 256
    repeat = w.sampler(wrapS=10497, wrapT=10497)

    def tex(pixels, sampler=repeat):
        return w.texture(w.image(pixels), sampler)

    def prim(m, material):
        return w.primitive(m.positions, m.faces, uvs=gltf_uvs(m.uvs), normals=m.normals, material=material)

    floor_mat = w.material(name="floor", pbrMetallicRoughness={
        "baseColorTexture": {"index": tex(proc.checker(size, n_checks=4)),
                             "extensions": {"KHR_texture_transform": {"scale": [3.0, 3.0]}}},
        "metallicFactor": 0.0, "roughnessFactor": 0.8})
    wood_mat = w.material(name="wood", pbrMetallicRoughness={
        "baseColorTexture": {"index": tex(proc.wood(size, seed=7))}, "metallicFactor": 0.0,
        "roughnessFactor": 0.45})
    # metallic-roughness texture: G = roughness (brushed streaks), B = metallic (1: all metal)
    rough = 0.35 + 0.3 * proc.value_noise(size, seed=11, cells=8)[..., 0]
    mr = np.stack([np.zeros_like(rough), rough, np.ones_like(rough)], -1)
    gold_mat = w.material(name="gold", pbrMetallicRoughness={
        "baseColorFactor": [1.0, 0.78, 0.34, 1.0], "metallicFactor": 1.0, "roughnessFactor": 1.0,
        "metallicRoughnessTexture": {"index": tex(mr)}})
    tiles = normal_map_from_height(
        proc.bricks_height(size, n_rows=6, n_cols=6, mortar=0.08, bevel=0.06, seed=4, offset=0.0), 6.0)
    marble_mat = w.material(name="marble", pbrMetallicRoughness={
        "baseColorTexture": {"index": tex(proc.marble(size, seed=3))}, "metallicFactor": 0.0,
        "roughnessFactor": 0.3}, normalTexture={"index": tex(tiles), "scale": 0.8})

    floor = w.node(name="Floor", mesh=w.mesh([prim(proc.grid(1, 1, size=(6, 6)), floor_mat)], name="floor"))
    vase = w.node(name="Vase", mesh=w.mesh([prim(proc.vase(48, 36), wood_mat)], name="vase"),
                  translation=[-0.65, 0.0, -0.1], scale=[1.3, 1.3, 1.3])
    torus = w.node(name="Torus", mesh=w.mesh([prim(proc.torus(64, 24, R=0.42, r=0.14), gold_mat)], name="torus"),
                   translation=[0.75, 0.14, 0.0])
    ball = w.node(name="Ball", mesh=w.mesh([prim(proc.uv_sphere(64, 32, radius=0.32), marble_mat)], name="ball"),
                  translation=[0.25, 0.32, 0.95])
    group = w.node(name="Group", children=[torus, ball], rotation=_rotation_y(-25.0))
    cam = w.node(name="Camera", camera=w.camera(np.radians(36.0), aspect_ratio=4 / 3, name="main"),
                 matrix=_look_at((2.2, 1.9, 3.7), (0.05, 0.45, 0.1)))
    top = w.node(name="Camera top", camera=w.camera(np.radians(45.0), aspect_ratio=1.0, name="top"),
                 matrix=_look_at((0.0, 5.0, 0.01), (0.0, 0.0, 0.0), up=(0.0, 0.0, -1.0)))
    key = w.node(name="Key light", translation=[-2.5, 4.0, 2.5],
                 extensions={"KHR_lights_punctual": {"light": w.light("point", (1.0, 0.95, 0.85), 34.0)}})
    fill = w.node(name="Fill light", translation=[3.0, 2.0, -1.5],
                  extensions={"KHR_lights_punctual": {"light": w.light("point", (0.75, 0.85, 1.0), 9.0)}})
    w.scene([floor, vase, group, cam, top, key, fill])
    return w.write(path)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", default=str(REPO / "scenes"),
                    help="output root (default: the repo's scenes/)")
    args = ap.parse_args(argv)
    out = Path(args.out)
    for name, (mesh, comment) in meshes().items():
        path = out / "meshes" / f"{name}.obj"
        write_obj(path, mesh, f"{comment}\n{mesh.n_vertices} vertices, "
                              f"{mesh.n_triangles} triangles")
        print(f"{path}: {mesh.n_vertices} v, {mesh.n_triangles} f, "
              f"{path.stat().st_size / 1024:.0f} KiB")
    for name, (image, cs) in textures().items():
        path = out / "textures" / name
        write_png(path, image, cs)
        print(f"{path}: {image.shape}, {path.stat().st_size / 1024:.0f} KiB")
    for name, image in heights16().items():
        path = out / "textures" / name
        write_png(path, image, "linear", bits=16)
        print(f"{path}: {image.shape} 16-bit, {path.stat().st_size / 1024:.0f} KiB")
    path = gltf_still_life(out / "gltf" / "still_life.glb")
    print(f"{path}: {path.stat().st_size / 1024:.0f} KiB")


if __name__ == "__main__":
    main()
