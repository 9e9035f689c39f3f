"""The scene cache's key (texray.compile.scene_hash): equal scenes hash alike, a change of
any field the compiler reads changes the key, the camera does not, and what the hash
cannot vouch for is refused."""
import shutil

import numpy as np
import pytest

import texray as tx
from cache_scenes import edited, rich_scene, texture
from texray.compile import compile_scene, scene_hash
from texray.compile.scene_hash import Uncacheable, scene_key


def key(scene, shadows=True, texture_filter=None):
    return scene_key(scene, shadows=shadows, texture_filter=texture_filter)


def _set_colorspace(s):
    t = s.objects[0].material.diffuse
    s.objects[0].material.diffuse = tx.Texture.from_array(t.raw, colorspace="srgb", name=t.name,
                                                          filter=t.filter)


# Each changes one thing the compiled scene depends on, in a fresh rich_scene().
CHANGES = {
    "vertex": lambda s: s.objects[1].positions.__setitem__((3, 1), s.objects[1].positions[3, 1] + 1e-3),
    "face": lambda s: s.objects[1].faces.__setitem__(0, s.objects[1].faces[0, [0, 2, 1]]),
    "uv": lambda s: s.objects[0].uvs.__setitem__((2, 0), 0.5),
    "normal": lambda s: s.objects[1].normals.__setitem__((0, 0), 2.0),
    "material_ids": lambda s: s.objects[1].material_ids.__setitem__(0, 1),
    "transform": lambda s: setattr(s.objects[1].transform, "rotate", (0, 31, 0)),
    "texel": lambda s: setattr(s.objects[0].material, "diffuse", edited(s.objects[0].material.diffuse, (3, 4, 0), 0.25)),
    "colorspace": _set_colorspace,
    "texture wrap": lambda s: setattr(s.objects[0].material.diffuse, "wrap", "clamp"),
    "texture filter": lambda s: setattr(s.objects[0].material.diffuse, "filter", "nearest"),
    "texture uv_transform": lambda s: setattr(s.objects[2].material.diffuse.uv_transform, "rotation", 31.0),
    "max_aniso": lambda s: setattr(s.objects[2].material.diffuse, "max_aniso", 4),
    "texture name": lambda s: setattr(s.objects[0].material.diffuse, "name", "other"),
    "diffuse": lambda s: setattr(s.objects[1].material[0], "diffuse", (0.7, 0.3, 0.21)),
    "specular": lambda s: setattr(s.objects[2].material, "specular", 0.31),
    "shininess": lambda s: setattr(s.objects[2].material, "shininess", 41.0),
    "tint": lambda s: setattr(s.objects[0].material, "tint", (1.0, 0.9, 0.9)),
    "shininess map": lambda s: setattr(s.objects[2].material, "shininess_map", texture(50, channels=1)),
    "label placement": lambda s: setattr(s.objects[2].material.label.uv_transform, "offset", (-1.0, -0.9)),
    "bump height": lambda s: setattr(s.objects[3].material.bump, "height", 0.03),
    "bump delta": lambda s: setattr(s.objects[3].material.bump, "delta", "analytic"),
    "normal map": lambda s: setattr(s.objects[4].material.normal_map, "convention", "opengl"),
    "displacement scale": lambda s: setattr(s.objects[5].material.displacement, "scale", 0.11),
    "displacement steps": lambda s: setattr(s.objects[5].material.displacement, "steps", 17),
    "mapping": lambda s: setattr(s.objects[1].mapping, "scale", 2.5),
    "sphere radius": lambda s: setattr(s.objects[2], "radius", 0.61),
    "cylinder range": lambda s: setattr(s.objects[4], "z_range", (0.0, 1.1)),
    "quad corner": lambda s: setattr(s.objects[3], "p2", (3, 3.1, -2)),
    "object name": lambda s: setattr(s.objects[4], "name", "pole"),
    "object order": lambda s: s.objects.reverse(),
    "object added": lambda s: s.add(tx.Sphere((0, 3, 0), 0.1)),
    "light position": lambda s: setattr(s.lights[0], "position", (2.0, 4.0, 3.001)),
    "light intensity": lambda s: setattr(s.lights[1], "intensity", (4, 5, 9)),
    "light removed": lambda s: s.lights.pop(),
    "ambient": lambda s: setattr(s, "ambient", (0.04, 0.05, 0.07)),
    "background": lambda s: setattr(s, "background", (0.1, 0.12, 0.21)),
}


def test_equal_scenes_built_apart_hash_alike_and_compiling_does_not_change_the_key():
    a, b = rich_scene(), rich_scene()
    k = key(a)
    assert len(k) == 64 and int(k, 16) >= 0
    assert key(b) == k
    compile_scene(b)                   # fills the textures' MIP caches (DERIVED: not content)
    assert key(b) == k


@pytest.mark.parametrize("change", CHANGES)
def test_a_change_of_any_compiled_field_changes_the_key(change):
    base = key(rich_scene())
    s = rich_scene()
    CHANGES[change](s)
    assert key(s) != base


def test_every_change_above_changes_the_compiled_scene_or_its_names():
    """The list above is of real changes: each one compiles differently (so a hit would be wrong)."""
    base = compile_scene(rich_scene())
    for name, change in CHANGES.items():
        s = rich_scene()
        change(s)
        cs = compile_scene(s)
        differs = [f for f in ("tri_verts", "tri_shade", "spheres", "cylinders", "quad_verts", "materials",
                               "textures", "texels", "lights", "ambient", "background", "displaced", "heights",
                               "normals", "uvs", "objects", "objects_generic")
                   if not _same(getattr(base, f), getattr(cs, f))]
        if name == "object name":          # names only reach error messages; still keyed (conservative)
            continue
        assert differs or cs.texture_names != base.texture_names, name


def _same(a, b):
    if a is None or b is None:
        return a is b
    return a.dtype == b.dtype and a.shape == b.shape and a.tobytes() == b.tobytes()


def test_compile_options_are_in_the_key():
    s = rich_scene()
    assert len({key(s), key(s, shadows=False), key(s, texture_filter="nearest")}) == 3


def test_the_camera_is_not_in_the_key():
    s = rich_scene()
    k = key(s)
    s.camera = tx.Camera(eye=(4, 1, 2), look_at=(0, 0.5, 0), fov_y=30)
    assert key(s) == k


def test_sharing_is_in_the_key():
    """The compiler tells materials apart by identity: one shared material is one table entry,
    two equal ones are two. Equal values with other sharing must not hit."""
    p, f = np.eye(3), np.array([[0, 1, 2]])
    m = tx.Material(diffuse=(0.5, 0.5, 0.5))
    shared = tx.Scene(lights=[tx.PointLight((0, 0, 5))], objects=[tx.Mesh(p, f, material=m), tx.Mesh(p, f, material=m)])
    apart = tx.Scene(lights=[tx.PointLight((0, 0, 5))],
                     objects=[tx.Mesh(p, f, material=tx.Material(diffuse=(0.5, 0.5, 0.5))),
                              tx.Mesh(p, f, material=tx.Material(diffuse=(0.5, 0.5, 0.5)))])
    assert len(compile_scene(shared).materials) == 1 and len(compile_scene(apart).materials) == 2
    assert key(shared) != key(apart)
    # a texture's pixels shared by two variants (with_options) are packed once: also in the key
    t = texture(1)
    one = tx.Scene(lights=[tx.PointLight((0, 0, 5))], objects=[tx.Sphere(material=tx.Material(diffuse=t)),
                            tx.Sphere(material=tx.Material(diffuse=t.with_options(wrap="clamp")))])
    two = tx.Scene(lights=[tx.PointLight((0, 0, 5))], objects=[tx.Sphere(material=tx.Material(diffuse=texture(1))),
                            tx.Sphere(material=tx.Material(diffuse=texture(1).with_options(wrap="clamp")))])
    assert len(compile_scene(one).texels) < len(compile_scene(two).texels)
    assert key(one) != key(two)


class _MyMesh(tx.Mesh):
    pass


def test_what_the_hash_cannot_vouch_for_is_uncacheable():
    s = rich_scene()
    p, f = np.eye(3), np.array([[0, 1, 2]])
    s.add(_MyMesh(p, f))                      # a user subclass may compile differently
    with pytest.raises(Uncacheable, match="_MyMesh is not a texray type"):
        key(s)
    s = rich_scene()
    s.objects[0].material.diffuse._pixels.extra = object()     # an object of another kind
    with pytest.raises(Uncacheable, match="builtins.object"):
        key(s)
    with pytest.raises(Uncacheable):
        key(rich_scene(), texture_filter=object())


def test_the_scene_classes_keep_their_state_in_fields():
    """The walker hashes a dataclass by its fields: a scene class keeping compile-relevant
    state outside them would go unhashed. Non-dataclass classes are hashed by vars()."""
    s = rich_scene()
    objs = [s.camera, *s.lights, *s.objects, *[m for o in s.objects for m in tx.scene.shape.materials_of(o)],
            s.objects[1].transform, s.objects[1].mapping, s.objects[3].material.bump,
            s.objects[4].material.normal_map, s.objects[5].material.displacement]
    import dataclasses
    for o in objs:
        assert dataclasses.is_dataclass(o)
        assert set(vars(o)) == {f.name for f in dataclasses.fields(o)}, type(o).__name__


def test_code_changes_change_the_key(tmp_path, monkeypatch):
    copy = tmp_path / "texray"
    shutil.copytree(scene_hash.ROOT, copy, ignore=shutil.ignore_patterns("__pycache__"))
    monkeypatch.setattr(scene_hash, "ROOT", copy)
    s = rich_scene()

    def fresh_key():
        monkeypatch.setattr(scene_hash, "_code", None)
        return key(s)

    k = fresh_key()
    (copy / "renderer" / "render.py").write_text("# rendering only\n", encoding="utf-8")
    assert fresh_key() == k                    # runs after compiling: not fingerprinted
    (copy / "accel" / "bvh.py").write_text((copy / "accel" / "bvh.py").read_text() + "\n# changed\n")
    k2 = fresh_key()
    assert k2 != k
    (copy / "__init__.py").write_text((copy / "__init__.py").read_text().replace('__version__ = "', '__version__ = "9'))
    assert fresh_key() not in (k, k2)
    # the cell builder's kernel makes scene data: fingerprinted; the data packages a wheel
    # holds inside texray/ (kernels/, scenes/) are not host code
    k3 = fresh_key()
    kernels = tmp_path / "kernels"
    shutil.copytree(scene_hash.KERNEL_DIR, kernels, ignore=shutil.ignore_patterns("__pycache__"))
    monkeypatch.setattr(scene_hash, "KERNEL_DIR", kernels)
    assert fresh_key() == k3
    (kernels / "accel" / "build.cl").write_text((kernels / "accel" / "build.cl").read_text() + "\n/* changed */\n")
    assert fresh_key() != k3
    (copy / "scenes").mkdir(exist_ok=True)             # an installed wheel has it already
    (copy / "scenes" / "fuzz_data.py").write_text("# data\n")
    k4 = fresh_key()
    (copy / "scenes" / "fuzz_data.py").write_text("# other data\n")
    assert fresh_key() == k4
