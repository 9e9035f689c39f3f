"""Instances (texray.Instance, a two-level BVH): the image, AOVs and any-hit queries of a
mesh placed by instances equal those of the same triangles copied into one Mesh per
instance (the instance's matrix applied on the host), up to float rounding of the
transformed ray and of the transformed surface point: measured max |difference| in
linear RGB 2e-5 on these scenes, tolerance 1e-4 (and a handful of silhouette pixels,
where rounding picks the other side of an edge, allowed to differ more)."""
import numpy as np
import pytest

import texray as tx
from texray.compile.scene import compile_scene
from texray.device import buffers, layout
from texray.device.features import compile_options
from texray.linalg import apply_normals, apply_points
from texray.procedural import meshes
from texray.renderer.trace import Tracer
from conftest import PORTABILITY_DEVICES

W = H = 64
TOL = 1e-4            # per channel, linear RGB
EDGE_PIXELS = 0.002   # fraction of pixels allowed beyond TOL (silhouettes)


def _matrices(n, mirror=False):
    out = []
    for i in range(n):
        t = tx.Transform(translate=(1.2 * (i % 2) - 0.6, 1.2 * (i // 2) - 0.6, -0.3 * i),
                         rotate=(10 * i, 25 * i, 5), scale=(0.5, 0.35 + 0.05 * i, 0.45))   # non-uniform
        m = t.matrix()
        if mirror and i % 2:
            m = np.diag([-1.0, 1.0, 1.0, 1.0]) @ m        # negative determinant
        out.append(m)
    return out


def _pair(n=4, smooth=True, mirror=False, floor=False, textured=False):
    """(scene with instances, the same scene with the triangles copied)."""
    md = meshes.torus(24, 12)
    mat = tx.Material(diffuse=(0.8, 0.3, 0.2), specular=(0.3, 0.3, 0.3), shininess=20)
    mesh = tx.Mesh(md.positions, md.faces, md.uvs, md.normals if smooth else None, mat,
                   transform=tx.Transform(rotate=(30, 0, 0)), name="torus")
    cam = tx.Camera(eye=(0, 0, 4), look_at=(0, 0, 0), fov_y=45)
    lights = [tx.PointLight(position=(3, 4, 5), intensity=(30, 30, 30)),
              tx.PointLight(position=(-2, 1, 6), intensity=(10, 10, 10))]
    kw = dict(camera=cam, lights=lights, ambient=(0.05,) * 3, background=(0.2, 0.2, 0.3))
    a, b = tx.Scene(**kw), tx.Scene(**kw)
    if floor:
        for s in (a, b):
            s.add(tx.Quad(p0=(-3, -1.3, 2), p1=(3, -1.3, 2), p2=(3, -1.3, -4), p3=(-3, -1.3, -4)))
    w = mesh.world()
    for i, m in enumerate(_matrices(n, mirror)):
        a.add(tx.Instance(mesh, m, name=f"inst{i}"))
        b.add(tx.Mesh(apply_points(m, w.positions), md.faces, md.uvs,
                      None if w.normals is None else apply_normals(m, w.normals), mat, name=f"copy{i}"))
    return a, b


def _close(x, y):
    d = np.abs(x - y)
    d = d.reshape(-1, d.shape[-1]).max(axis=1) if d.ndim > 2 else d.ravel()
    bad = np.mean(~(d <= TOL))
    assert bad <= EDGE_PIXELS, f"{bad:.4f} of pixels beyond {TOL} (max {np.nanmax(d)})"


@pytest.mark.parametrize("smooth,mirror", [(True, False), (False, False), (True, True), (False, True)])
def test_image_equals_copied_triangles(device, smooth, mirror):
    a, b = _pair(smooth=smooth, mirror=mirror)
    ia = tx.render(a, W, H, spp=1, device=device, cache=False)
    ib = tx.render(b, W, H, spp=1, device=device, cache=False)
    assert ia.stats["features"].instances and not ib.stats["features"].instances
    _close(ia.rgb, ib.rgb)
    assert np.mean(ia.rgb != np.asarray([0.2, 0.2, 0.3], np.float32)) > 0.1     # the tori are in view


def test_shadows_between_instances_and_stages(device):
    a, b = _pair(floor=True)
    ia = tx.render(a, W, H, spp=1, device=device, cache=False)
    ib = tx.render(b, W, H, spp=1, device=device, cache=False)
    _close(ia.rgb, ib.rgb)
    lit = tx.render(a, W, H, spp=1, device=device, cache=False, shadows=False)
    assert np.mean(np.abs(lit.rgb - ia.rgb).max(axis=-1) > 0.01) > 0.02      # instances cast shadows
    staged = tx.render(a, W, H, spp=1, device=device, cache=False, pipeline="stages")
    np.testing.assert_array_equal(staged.rgb, ia.rgb)                          # both pipelines, bit for bit


def test_aovs_agree_with_copied(device):
    a, b = _pair(mirror=True)
    names = ("object_id", "primitive_id", "normal", "shading_normal", "position", "uv", "depth", "dpdu")
    ia = tx.render(a, W, H, spp=1, device=device, cache=False, aovs=names)
    ib = tx.render(b, W, H, spp=1, device=device, cache=False, aovs=names)
    same = (ia.aov["primitive_id"] == ib.aov["primitive_id"])[..., 0] & \
           (ia.aov["object_id"] == ib.aov["object_id"])[..., 0]
    assert np.mean(same) > 0.998
    hit = same & (ib.aov["object_id"][..., 0] >= 0)
    assert hit.mean() > 0.1
    assert set(np.unique(ia.aov["object_id"][hit])) == {0.0, 1.0, 2.0, 3.0}
    for k, tol in (("normal", 1e-5), ("shading_normal", 2e-4), ("position", 1e-5), ("uv", 1e-5),
                   ("depth", 1e-5), ("dpdu", 1e-4)):
        np.testing.assert_allclose(ia.aov[k][hit], ib.aov[k][hit], atol=tol, rtol=1e-4, err_msg=k)


def test_closest_and_any_hit_queries(device):
    a, b = _pair(smooth=False, mirror=True)
    ta, tb = Tracer(a, device), Tracer(b, device)
    rng = np.random.default_rng(3)
    org = np.array([0.1, 0.2, 4.0], np.float32)
    dirs = (np.array([0, 0, -1.0]) + rng.uniform(-0.5, 0.5, (4000, 3)) * [1, 1, 0]).astype(np.float32)
    ha, hb = ta.closest(org, dirs), tb.closest(org, dirs)
    hit_a, hit_b = ha.prim >= 0, hb.prim >= 0
    assert np.mean(hit_a != hit_b) < 0.002 and hit_a.mean() > 0.05
    assert np.all((ha.prim[hit_a] >> layout.HIT_KIND_SHIFT) == layout.PRIM_INSTANCE)
    both = hit_a & hit_b
    np.testing.assert_allclose(ha.t[both], hb.t[both], rtol=1e-5)
    for tmax in (3.5, 4.0, 10.0):
        oa, _ = ta.occluded(org, dirs, 0.0, tmax)
        ob, _ = tb.occluded(org, dirs, 0.0, tmax)
        assert np.mean(oa != ob) < 0.002
    oa, _ = ta.occluded(org, dirs, 0.0, 10.0)
    np.testing.assert_array_equal(oa, hit_a)


def test_memory_one_mesh_plus_records():
    md = meshes.torus(100, 50)                   # 10,000 triangles
    mesh = tx.Mesh(md.positions, md.faces, material=tx.Material(), name="m")
    one = compile_scene(tx.Scene(objects=[tx.Instance(mesh, tx.Transform())],
                                 lights=[tx.PointLight(position=(0, 5, 0))]))
    n = 1000
    rng = np.random.default_rng(0)
    objs = [tx.Instance(mesh, tx.Transform(translate=rng.uniform(-50, 50, 3), rotate=rng.uniform(0, 360, 3)),
                        name=f"i{k}") for k in range(n)]
    cs = compile_scene(tx.Scene(objects=objs, lights=[tx.PointLight(position=(0, 5, 0))]))
    b1, bn = one.device_bytes(), cs.device_bytes()
    assert bn["tri_verts"] == b1["tri_verts"] and bn["tri_shade"] == b1["tri_shade"]
    assert bn["instances"] == n * layout.INSTANCE.itemsize
    tlas = bn["nodes"] - b1["nodes"]
    assert 0 < tlas < n * layout.BVH4_NODE.itemsize          # ~n/3 wide nodes over the instances
    assert sum(bn.values()) < sum(b1.values()) + n * (layout.INSTANCE.itemsize + layout.BVH4_NODE.itemsize)


def test_scenes_without_instances_compile_no_instance_code():
    a, b = _pair(n=1)
    assert compile_options(compile_scene(b).features)["TX_INSTANCES"] == 0
    assert compile_options(compile_scene(a).features)["TX_INSTANCES"] == 1
    macros = buffers.opencl_macros()
    assert "#if TX_INSTANCES" in macros
    without = macros.split("#else")[1].split("#endif")[0]
    assert "instances" not in without


def _mesh():
    md = meshes.torus(8, 4)
    return tx.Mesh(md.positions, md.faces, name="m")


@pytest.mark.parametrize("matrix,words", [
    (np.diag([1.0, 0.0, 1.0, 1.0]), "singular"),
    (np.diag([1.0, 1e-12, 1.0, 1.0]), "singular"),
    (np.array([[1, 0, 0, np.nan], [0, 1, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1.0]]), "element [0][3]"),
    (np.array([[1, 0, 0, 0], [0, 1, 0, 0], [0, 0, 1, 0], [0, 0, 1, 1.0]]), "last row"),
    (np.eye(3), "shape"),
    ("abc", "4x4"),
])
def test_bad_transforms_name_the_instance(matrix, words):
    with pytest.raises(tx.SceneError, match="pillar: transform") as e:
        tx.Instance(_mesh(), matrix, name="pillar")
    assert words in str(e.value)


def test_bad_mesh_and_changed_fields():
    with pytest.raises(tx.SceneError, match="pillar: mesh: expected a texray.Mesh"):
        tx.Instance("not a mesh", np.eye(4), name="pillar")
    inst = tx.Instance(_mesh(), np.eye(4), name="pillar")
    scene = tx.Scene(objects=[inst], lights=[tx.PointLight(position=(0, 5, 0))])
    inst.transform = np.zeros((4, 4))
    with pytest.raises(tx.SceneError, match="pillar: transform"):
        compile_scene(scene)


_SCENE_FILE = """
[camera]
eye = [0, 1.5, 5]
look_at = [0, 0, 0]
fov_y = 40
[scene]
background = [0.2, 0.2, 0.3]
[[lights]]
position = [3, 4, 5]
intensity = [30, 30, 30]
[materials.clay]
diffuse = [0.8, 0.4, 0.3]
[[objects]]
type = "procedural"
generator = "torus"
params = { n_major = 24, n_minor = 12 }
material = "clay"
name = "ring"
hidden = HIDDEN
[[objects]]
type = "instance"
of = "ring"
translate = [-1, 0, 0]
[[objects]]
type = "instance"
of = "ring"
translate = [1, 0, 0]
rotate = [90, 0, 0]
scale = [0.5, 1, 0.5]
"""


def test_scene_file_instances(tmp_path, device):
    path = tmp_path / "inst.toml"
    path.write_text(_SCENE_FILE.replace("HIDDEN", "true"))
    scene = tx.load_scene(path)
    assert [type(o).__name__ for o in scene.objects] == ["Instance", "Instance"]
    assert scene.objects[0].mesh is scene.objects[1].mesh
    img = tx.render(scene, 32, 24, spp=1, device=device, cache=False)
    assert img.stats["features"].instances and np.mean(img.rgb[..., 0] != np.float32(0.2)) > 0.05
    path.write_text(_SCENE_FILE.replace("HIDDEN", "false"))
    assert len(tx.load_scene(path).objects) == 3          # the mesh itself too
    bad = _SCENE_FILE.replace("HIDDEN", "true").replace('of = "ring"\ntranslate = [1', 'of = "rung"\ntranslate = [1')
    path.write_text(bad)
    with pytest.raises(tx.SceneError, match=r"objects\[2\].of: no earlier mesh object named 'rung'"):
        tx.load_scene(path)
    path.write_text(_SCENE_FILE.replace("HIDDEN", "true").replace('of = "ring"\ntranslate = [-1',
                                                                    'of = "ring"\nmaterial = "clay"\ntranslate = [-1'))
    with pytest.raises(tx.SceneError, match=r"objects\[1\].material: an instance has its mesh's material"):
        tx.load_scene(path)


def test_cache_key_follows_instances():
    from texray.compile.scene_hash import scene_key
    a, _ = _pair()
    k = scene_key(a)
    a.objects[1].transform = a.objects[1].transform.copy()
    a.objects[1].transform[0, 3] += 1e-6
    assert scene_key(a) != k


@pytest.mark.parametrize("dev", [d.index for d in PORTABILITY_DEVICES],
                         ids=[f"{d.type}:{d.name[:24]}" for d in PORTABILITY_DEVICES])
def test_every_device_agrees(dev):
    """Every OpenCL driver (Intel's CPU compiler misreads float3 arguments of out-of-line
    functions: instance_leaf takes float4), both pipelines."""
    a, b = _pair(mirror=True, floor=True)
    ia = tx.render(a, 48, 48, spp=1, device=dev, cache=False)
    ib = tx.render(b, 48, 48, spp=1, device=dev, cache=False)
    _close(ia.rgb, ib.rgb)
    staged = tx.render(a, 48, 48, spp=1, device=dev, cache=False, pipeline="stages")
    np.testing.assert_array_equal(staged.rgb, ia.rgb)


@pytest.mark.parametrize("mapped", [False, True])
def test_textured_and_projected_instances(device, mapped):
    """Texture lookups through the mesh's uvs (trilinear: ray differentials from the
    world-space dP/du, dP/dv), or a projection mapping in the mesh's space placed by the
    instance: the same as a Mesh with that Transform."""
    from texray.procedural import textures
    tex = tx.Texture(textures.checker(64, 8), name="checks", filter="trilinear")
    mat = tx.Material(diffuse=tex)
    md = meshes.torus(24, 12)
    mapping = tx.Projection(kind="cylindrical", z_axis=(0, 1, 0), scale=2.0) if mapped else None
    cam = tx.Camera(eye=(0, 0, 4), look_at=(0, 0, 0), fov_y=45)
    kw = dict(camera=cam, lights=[tx.PointLight(position=(3, 4, 5), intensity=(30, 30, 30))], ambient=(0.05,) * 3)
    a, b = tx.Scene(**kw), tx.Scene(**kw)
    mesh = tx.Mesh(md.positions, md.faces, md.uvs, md.normals, mat, name="torus", mapping=mapping)
    for i, (t, r) in enumerate((((-0.6, 0, 0), (60, 0, 0)), ((0.7, 0.2, -0.5), (20, 40, 10)))):
        tf = tx.Transform(translate=t, rotate=r, scale=(0.6, 0.4, 0.5))
        a.add(tx.Instance(mesh, tf, name=f"i{i}"))
        b.add(tx.Mesh(md.positions, md.faces, md.uvs, md.normals, mat, transform=tf, name=f"c{i}", mapping=mapping))
    ia = tx.render(a, W, H, spp=1, device=device, cache=False)
    ib = tx.render(b, W, H, spp=1, device=device, cache=False)
    assert ia.stats["features"].textures and ia.stats["features"].projections == mapped
    _close(ia.rgb, ib.rgb)


@pytest.mark.parametrize("role", ["bump", "tangent", "object"])
def test_bump_and_normal_mapped_instances(device, role):
    """Bump maps (world-space dP/du, dP/dv), tangent- and object-space normal maps (the
    object table's normal matrix of the instance after its mesh) as on a Mesh with that
    Transform."""
    from texray.procedural import textures
    rng = np.random.default_rng(5)
    if role == "bump":
        mat = tx.Material(diffuse=(0.7, 0.6, 0.5), bump=tx.Bump(tx.Texture(textures.checker(32, 4)), height=0.02))
    else:
        n = rng.normal(size=(16, 16, 3)) * 0.3 + [0, 0, 1]
        n /= np.linalg.norm(n, axis=-1, keepdims=True)
        mat = tx.Material(diffuse=(0.7, 0.6, 0.5),
                          normal_map=tx.NormalMap(tx.Texture(((n + 1) / 2).astype(np.float32)), space=role))
    md = meshes.torus(24, 12)
    cam = tx.Camera(eye=(0, 0, 4), look_at=(0, 0, 0), fov_y=45)
    kw = dict(camera=cam, lights=[tx.PointLight(position=(3, 4, 5), intensity=(30, 30, 30))], ambient=(0.05,) * 3)
    a, b = tx.Scene(**kw), tx.Scene(**kw)
    mesh = tx.Mesh(md.positions, md.faces, md.uvs, md.normals, mat, name="torus")
    for i, (t, r) in enumerate((((-0.6, 0, 0), (60, 0, 0)), ((0.7, 0.2, -0.5), (20, 40, 10)))):
        tf = tx.Transform(translate=t, rotate=r, scale=(0.6, 0.4, 0.5))
        a.add(tx.Instance(mesh, tf, name=f"i{i}"))
        b.add(tx.Mesh(md.positions, md.faces, md.uvs, md.normals, mat, transform=tf, name=f"c{i}"))
    ia = tx.render(a, W, H, spp=1, device=device, cache=False)
    ib = tx.render(b, W, H, spp=1, device=device, cache=False)
    _close(ia.rgb, ib.rgb)


def test_scene_cache_round_trip(tmp_path, monkeypatch, device):
    monkeypatch.delenv("TEXRAY_NO_CACHE", raising=False)
    monkeypatch.setenv("TEXRAY_CACHE_DIR", str(tmp_path))
    monkeypatch.setenv("TEXRAY_CACHE_MIN_S", "0")
    monkeypatch.setenv("TEXRAY_CACHE_MEMORY", "1")
    from texray.compile import cache
    cache.forget()
    a, _ = _pair()
    first = tx.render(a, 32, 32, spp=1, device=device)
    kept = tx.render(a, 32, 32, spp=1, device=device)
    cache.forget()                                        # from the file, not from memory
    again = tx.render(a, 32, 32, spp=1, device=device)
    assert [i.stats["scene_cache"] for i in (first, kept, again)] == ["stored", "kept", "hit"]
    np.testing.assert_array_equal(first.rgb, again.rgb)
    np.testing.assert_array_equal(first.rgb, kept.rgb)


def test_moving_instances_rebuild_only_the_top_level(device, monkeypatch):
    """A second compile with moved instances takes each BLAS from the first (no BLAS
    build) and renders as a compile that built everything; a changed mesh is rebuilt."""
    from texray.accel import scene_bvh
    from texray.compile import instances as inst_blas
    monkeypatch.setattr(inst_blas, "_TREES", type(inst_blas._TREES)())
    calls = []
    real = inst_blas.build_scene_bvh
    monkeypatch.setattr(inst_blas, "build_scene_bvh", lambda *a, **k: calls.append(1) or real(*a, **k))
    a, _ = _pair(n=4)
    first = tx.render(a, W, H, spp=1, device=device, cache=False)
    assert len(calls) == 1 and first.stats["blas_reused"] == 0
    for i, obj in enumerate(a.objects):                 # the next frame: every instance moved
        obj.transform = tx.Transform(translate=(0.1 * i, -0.2, 0.05 * i)).matrix() @ obj.matrix()
    moved = tx.render(a, W, H, spp=1, device=device, cache=False)
    assert len(calls) == 1 and moved.stats["blas_reused"] == 1
    inst_blas._TREES.clear()
    fresh = tx.render(a, W, H, spp=1, device=device, cache=False)
    assert len(calls) == 2 and fresh.stats["blas_reused"] == 0
    assert np.array_equal(moved.rgb, fresh.rgb) and not np.array_equal(moved.rgb, first.rgb)
    mesh = a.objects[0].mesh
    mesh.positions = mesh.positions * np.float32(1.1)   # a changed mesh: its boxes differ
    tx.render(a, W, H, spp=1, device=device, cache=False)
    assert len(calls) == 3
    assert scene_bvh.build_scene_bvh is real
