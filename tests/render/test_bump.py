"""Bump maps, normal maps and their robustness, through the renderer's AOVs and images,
against float64 closed forms (kernels/shading/bump.h, terminator.h, texray.bump).

Heights are chosen so that half-float texels store them exactly (multiples of 1/256
below 1): the ramp tests then measure the kernels' float32 arithmetic only, hence the
1e-4 tolerance on unit normals."""
import itertools

import numpy as np
import pytest
import texray as tx
from texray.device import layout
from texray.scene.mapping import project_numpy

W = 32                                   # ramp texture size


def ramp_texture(n=W, a=0.5, b=0.25):
    """H(s, t) = a s + b t at texel centres (row 0 = top, t = 1 - (j + 0.5)/n), clamped."""
    s = (np.arange(n) + 0.5) / n
    t = 1.0 - (np.arange(n) + 0.5) / n
    return tx.Texture.from_array(a * s[None, :] + b * t[:, None], wrap="clamp", name="ramp")


def top_camera():
    return tx.Camera(eye=(0, 4, 0), look_at=(0, 0, 0), up=(0, 0, -1), fov_y=35)


QUAD = ((-1, 0, 1), (1, 0, 1), (1, 0, -1), (-1, 0, -1))
UV_A = ((0, 0), (1, 0), (1, 1), (0, 1))      # u along +x, v along -z (P_u x P_v = +y, outward)
UV_B = ((0, 1), (1, 1), (1, 0), (0, 0))      # u along +x, v along +z seen from +y (P_u x P_v inward)


def plane(kind, uvs, material):
    if kind == "quad":
        return tx.Quad(*QUAD, material=material, uvs=uvs)
    p = np.array(QUAD, float)
    normals = np.tile([0.0, 1.0, 0.0], (4, 1))
    return tx.Mesh(p, np.array([[0, 1, 2], [0, 2, 3]]), uvs=np.array(uvs, float), normals=normals,
                   material=material, name="plane")


def render_aov(obj, camera, size=48, lights=None, names=("shading_normal", "normal", "uv", "dpdu", "dpdv",
                                                           "position"), device=None, **kw):
    scene = tx.Scene(camera=camera, lights=lights or [tx.PointLight((3, 5, 2), (30, 30, 30))],
                     ambient=(0.05, 0.05, 0.05))
    for o in (obj if isinstance(obj, list) else [obj]):
        scene.add(o)
    return tx.render(scene, size, size, spp=1, jitter=False, aovs=names, device=device, **kw)


def metric_gradient_normal(n, dpdu, dpdv, bu, bv):
    """normalize(n - grad_S B): the bumped normal of the height field B along n to first
    order, with the surface gradient grad_S B = [P_u P_v] G^-1 (B_u, B_v), G the metric.
    Independent of how P_u x P_v is oriented (the kernel uses the cross-product form)."""
    g = np.stack([np.stack([np.sum(dpdu * dpdu, -1), np.sum(dpdu * dpdv, -1)], -1),
                  np.stack([np.sum(dpdv * dpdu, -1), np.sum(dpdv * dpdv, -1)], -1)], -2)
    coef = np.linalg.solve(g, np.stack([np.broadcast_to(bu, n.shape[:-1]),
                                        np.broadcast_to(bv, n.shape[:-1])], -1)[..., None])[..., 0]
    r = n - coef[..., :1] * dpdu - coef[..., 1:] * dpdv
    return r / np.linalg.norm(r, axis=-1, keepdims=True)


@pytest.mark.parametrize("kind", ["quad", "triangles"])
@pytest.mark.parametrize("uvs", [UV_A, UV_B], ids=["v_along_-z", "v_along_+z"])
def test_linear_ramp_tilts_plane_normal_in_closed_form(device, kind, uvs):
    """B = h (u/2 + v/4) on the plane y = 0 spanning [-1, 1]^2 raises y by B: the height
    field y(x, z) has normal (-dy/dx, 1, -dy/dz), whatever way v runs."""
    h = 1.0
    img = render_aov(plane(kind, uvs, tx.Material(bump=tx.Bump(ramp_texture(), height=h))), top_camera(),
                     device=device)
    dv_dz = -0.5 if uvs is UV_A else 0.5
    want = np.array([-h * 0.5 * 0.5, 1.0, -h * 0.25 * dv_dz])
    want /= np.linalg.norm(want)
    uv = img.aov["uv"]
    inner = np.all((uv > 2.0 / W) & (uv < 1 - 2.0 / W), axis=-1)      # both taps on the ramp
    assert inner.sum() > 500
    np.testing.assert_allclose(img.aov["shading_normal"][inner], np.broadcast_to(want, (inner.sum(), 3)), atol=1e-4)


@pytest.mark.parametrize("shape", ["sphere", "cylinder"])
def test_linear_ramp_on_curved_primitives_matches_metric_gradient(device, shape):
    h = 2.0
    mat = tx.Material(bump=tx.Bump(ramp_texture(), height=h))
    if shape == "sphere":
        obj = tx.Sphere(center=(0, 0, 0), radius=1.0, material=mat, axis_z=(0, 1, 0), axis_x=(0, 0, 1))
    else:
        obj = tx.Cylinder(radius=1.0, z_range=(-1, 1), theta_range=(0, 360), axis_z=(0, 1, 0),
                          axis_x=(0, 0, 1), material=mat)
    img = render_aov(obj, tx.Camera(eye=(0, 0.5, 4), look_at=(0, 0, 0), fov_y=40), device=device)
    a = {k: v.astype(np.float64) for k, v in img.aov.items()}
    uv = a["uv"]
    inner = np.all((uv > 2.0 / W) & (uv < 1 - 2.0 / W), axis=-1)
    inner &= np.sum(a["normal"] * np.array([0, 0.5, 4]) / 4.03, -1) > 0.2     # away from the silhouette
    assert inner.sum() > 300
    want = metric_gradient_normal(a["normal"][inner], a["dpdu"][inner], a["dpdv"][inner], h * 0.5, h * 0.25)
    wo = np.array([0, 0.5, 4]) - a["position"][inner]
    facing = np.sum(want * wo, -1) / np.linalg.norm(wo, axis=-1) > 0.05      # not clamped (bump.h)
    assert facing.mean() > 0.8
    np.testing.assert_allclose(a["shading_normal"][inner][facing], want[facing], atol=2e-4)
    # The bump visibly tilts the normal (a test that cannot pass with no bump at all).
    assert np.median(np.linalg.norm(want - a["normal"][inner], axis=-1)) > 0.05
    # Where the tilt would face away from the viewer, the normal is clamped to face it.
    assert np.all(np.sum(a["shading_normal"][inner] * wo, -1) > 0)


def gaussian_bump(n=64, sigma=0.12):
    s = (np.arange(n) + 0.5) / n
    r2 = (s[None, :] - 0.5) ** 2 + (s[:, None] - 0.5) ** 2
    return tx.Texture.from_array(np.exp(-r2 / (2 * sigma ** 2)), name="bump")


@pytest.mark.parametrize("uvs", [UV_A, UV_B], ids=["v_along_-z", "v_along_+z"])
def test_raised_bump_is_brighter_on_the_lit_side(device, uvs):
    """A bump (not a dent) lit from +x and from -z: its +x half and its -z half are the bright ones."""
    for light, axis, sign in (((4, 1.5, 0), 0, 1), ((0, 1.5, -4), 2, -1)):
        img = render_aov(plane("quad", uvs, tx.Material(bump=tx.Bump(gaussian_bump(), height=0.3))), top_camera(),
                         lights=[tx.PointLight(light, (40, 40, 40))], names=("position",), device=device)
        lum = img.rgb.mean(-1)
        pos = img.aov["position"]
        near = np.hypot(pos[..., 0], pos[..., 2]) < 0.4
        toward = near & (sign * pos[..., axis] > 0.05)
        away = near & (sign * pos[..., axis] < -0.05)
        assert lum[toward].mean() > 1.3 * lum[away].mean(), (light, lum[toward].mean(), lum[away].mean())


def test_zero_height_renders_the_same_image_as_no_bump(device):
    checker = tx.Texture.from_array(np.kron(np.indices((4, 4)).sum(0) % 2, np.ones((8, 8)))[..., None]
                                    * [0.7, 0.5, 0.3] + 0.2, name="checker")
    images = []
    for bump in (None, tx.Bump(gaussian_bump(), height=0.0)):
        mat = tx.Material(diffuse=checker, specular=0.3, shininess=20, bump=bump)
        scene = tx.Scene(camera=tx.Camera(eye=(0, 2.5, 3), look_at=(0, 0, 0), fov_y=45),
                         lights=[tx.PointLight((2, 3, 2), (20, 20, 20))], ambient=(0.05, 0.05, 0.05))
        scene.add(tx.Quad(*QUAD, material=mat))
        scene.add(tx.Sphere(center=(0, 0.5, 0), radius=0.5, material=mat))
        images.append(tx.render(scene, 48, 40, spp=2, device=device).rgb)
    np.testing.assert_array_equal(images[0], images[1])


def constant_map(rgb, n=4):
    return tx.Texture.from_array(np.broadcast_to(np.asarray(rgb, np.float32), (n, n, 3)).copy(), name="nmap")


def test_flat_normal_map_equals_no_normal_map(device):
    base = render_aov(plane("quad", UV_A, tx.Material()), top_camera(), names=("shading_normal",), device=device)
    flat = render_aov(plane("quad", UV_A, tx.Material(normal_map=tx.NormalMap(constant_map((0.5, 0.5, 1.0))))),
                      top_camera(), names=("shading_normal",), device=device)
    # An 8-bit file's flat normal is 128/255: 0.4% off 0.5, i.e. within a half-float's 2^-11 steps of 2c - 1.
    flat8 = render_aov(plane("quad", UV_A, tx.Material(normal_map=tx.NormalMap(constant_map((128 / 255,) * 2 + (1.0,))))),
                       top_camera(), names=("shading_normal",), device=device)
    np.testing.assert_allclose(flat.aov["shading_normal"], base.aov["shading_normal"], atol=1e-6)
    np.testing.assert_allclose(flat.rgb, base.rgb, atol=1e-6)
    np.testing.assert_allclose(flat8.aov["shading_normal"], base.aov["shading_normal"], atol=6e-3)


@pytest.mark.parametrize("uvs", [UV_A, UV_B], ids=["v_along_-z", "v_along_+z"])
def test_normal_map_conventions_flip_the_bitangent_component(device, uvs):
    """Tangent (0, 0.6, 0.8): OpenGL puts +0.6 along the bitangent (P_v's side), DirectX -0.6."""
    b = np.array([0, 0, -1.0]) if uvs is UV_A else np.array([0, 0, 1.0])    # P_v's direction
    for convention, sign in (("opengl", 1), ("directx", -1)):
        mat = tx.Material(normal_map=tx.NormalMap(constant_map((0.5, 0.8, 0.9)), convention=convention))
        img = render_aov(plane("quad", uvs, mat), top_camera(), names=("shading_normal",), device=device)
        ns = img.aov["shading_normal"]
        hit = ~np.isnan(ns[..., 0])
        want = 0.8 * np.array([0, 1.0, 0]) + sign * 0.6 * b
        np.testing.assert_allclose(ns[hit], np.broadcast_to(want, (hit.sum(), 3)), atol=2e-3)


def test_object_space_normal_map_follows_the_object_transform(device):
    n_obj = np.array([0.6, 0.8, 0.0])
    tf = tx.Transform(rotate=(0, 90, 0))
    mat = tx.Material(normal_map=tx.NormalMap(constant_map((n_obj + 1) / 2), space="object"))
    p = np.array(QUAD, float)
    mesh = tx.Mesh(p, np.array([[0, 1, 2], [0, 2, 3]]), uvs=np.array(UV_A, float), material=mat, transform=tf)
    img = render_aov(mesh, top_camera(), names=("shading_normal",), device=device)
    ns = img.aov["shading_normal"]
    hit = ~np.isnan(ns[..., 0])
    want = tf.matrix()[:3, :3] @ n_obj
    assert hit.sum() > 500
    np.testing.assert_allclose(ns[hit], np.broadcast_to(want, (hit.sum(), 3)), atol=3e-3)


def test_central_differences_converge_to_the_analytic_gradient(device):
    """Smooth heights on 64^2 texels: the normal's error against delta="analytic" falls as the
    step shrinks from 8 texels to one."""
    n = 64
    s = (np.arange(n) + 0.5) / n
    hmap = 0.5 + 0.25 * np.sin(2 * np.pi * s)[None, :] * np.cos(4 * np.pi * s)[:, None]
    tex = tx.Texture.from_array(hmap, name="waves")
    normals = {}
    for delta in ("analytic", 8 / n, 4 / n, 2 / n, None):
        mat = tx.Material(bump=tx.Bump(tex, height=0.05, delta=delta))
        normals[delta] = render_aov(plane("quad", UV_A, mat), top_camera(), size=64, names=("shading_normal",),
                                    device=device).aov["shading_normal"]
    hit = ~np.isnan(normals["analytic"][..., 0])
    err = [np.sqrt(np.mean(np.sum((normals[d][hit] - normals["analytic"][hit]) ** 2, -1)))
           for d in (8 / n, 4 / n, 2 / n, None)]
    assert all(a > b for a, b in itertools.pairwise(err)), err
    assert err[-1] < 0.2 * err[0], err


def test_image_does_not_depend_on_uv_scale(device):
    """The same world height field through uvs scaled by 2 (a texture of one period instead of
    two, the same texels): the same image. Heights are world units, so B_u / |P_u| is invariant."""
    n = 32
    s = (np.arange(n) + 0.5) / n
    period = 0.5 + 0.3 * np.sin(2 * np.pi * s)[None, :] * np.sin(2 * np.pi * s)[:, None]
    images = []
    for k, hmap in ((1, np.tile(period, (2, 2))), (2, period)):
        uvs = np.array(UV_A, float) * k
        mat = tx.Material(diffuse=(0.7, 0.7, 0.7), bump=tx.Bump(tx.Texture.from_array(hmap), height=0.1))
        img = render_aov(tx.Quad(*QUAD, material=mat, uvs=uvs), tx.Camera(eye=(0, 2.5, 2.5), look_at=(0, 0, 0)),
                         lights=[tx.PointLight((2, 1, 0), (10, 10, 10))], names=("shading_normal",), device=device)
        images.append(img)
    np.testing.assert_allclose(images[0].rgb, images[1].rgb, atol=2e-5)
    tilt = np.nanmax(np.abs(images[0].aov["shading_normal"][..., 0]))
    assert tilt > 0.1                     # the bump is strong enough to tell k from 1/k scaling


@pytest.mark.parametrize("kind", ["planar", "cylindrical", "spherical"])
def test_projected_uv_derivatives_match_finite_differences(device, kind):
    """dP/du, dP/dv of an object whose uv comes from a projection: moving the float64 point
    by eps dP/du changes the float64 projected uv by (eps, 0), by eps dP/dv by (0, eps)."""
    mat = tx.Material(bump=tx.Bump(gaussian_bump(), height=0.01))
    if kind == "planar":
        proj = tx.Projection("planar", origin=(0.3, 0, 0.1), x_axis=(1, 0, 0.5), z_axis=(0.2, 1, 0.3), scale=0.7)
        obj = tx.Quad(*QUAD, material=mat, mapping=proj)
        cam = top_camera()
    elif kind == "cylindrical":
        proj = tx.Projection("cylindrical", z_axis=(0, 1, 0), x_axis=(1, 0, 0), scale=2.0)
        obj = tx.Cylinder(radius=0.8, z_range=(-1, 1), axis_z=(0, 1, 0), material=mat, mapping=proj)
        cam = tx.Camera(eye=(0.5, 0.6, 4), look_at=(0, 0, 0), fov_y=40)
    else:
        proj = tx.Projection("spherical", z_axis=(0, 1, 0), x_axis=(1, 0, 0))
        obj = tx.Sphere(radius=1.0, material=mat, mapping=proj)
        cam = tx.Camera(eye=(0.5, 2.0, 4), look_at=(0, 0, 0), fov_y=40)
    img = render_aov(obj, cam, names=("position", "dpdu", "dpdv", "uv"), device=device)
    a = {k: v.astype(np.float64).reshape(-1, v.shape[-1]) for k, v in img.aov.items()}
    hit = ~np.isnan(a["position"][:, 0])
    uv = a["uv"][hit]
    keep = (uv[:, 0] > 0.02) & (uv[:, 0] < 0.98)          # off the u seam of the angular projections
    p, dpdu, dpdv = a["position"][hit][keep], a["dpdu"][hit][keep], a["dpdv"][hit][keep]
    assert len(p) > 300
    eps = 1e-5
    for d, want in ((dpdu, (1, 0)), (dpdv, (0, 1))):
        fd = (project_numpy(proj, p + eps * d) - project_numpy(proj, p - eps * d)) / (2 * eps)
        np.testing.assert_allclose(fd, np.broadcast_to(want, fd.shape), atol=2e-3)


def test_grazing_views_never_give_backfacing_normals_or_speckles(device):
    """Steep bumps seen at 70 to 89.5 degrees from the normal with the light at the eye: every
    visible point is lit (a shading normal facing away from the viewer would leave it at
    the ambient level: a black speckle) and no value is NaN."""
    rng = np.random.default_rng(3)
    hmap = rng.random((32, 32))
    mat = tx.Material(diffuse=(0.8, 0.8, 0.8), bump=tx.Bump(tx.Texture.from_array(hmap), height=0.05))
    quad = tx.Quad((-50, 0, 50), (50, 0, 50), (50, 0, -50), (-50, 0, -50), material=mat,
                   uvs=((0, 0), (40, 0), (40, 40), (0, 40)))
    for angle in (70.0, 85.0, 89.0, 89.5):
        a = np.radians(angle)
        eye = (0.0, 2.0 * np.cos(a), 2.0 * np.sin(a))
        scene = tx.Scene(camera=tx.Camera(eye=eye, look_at=(0, 0, 0), fov_y=20),
                         lights=[tx.PointLight(eye, (4, 4, 4))], ambient=(0.01, 0.01, 0.01))
        scene.add(quad)
        img = tx.render(scene, 48, 48, spp=1, jitter=False, aovs=("shading_normal", "normal", "position"),
                        device=device)
        hit = ~np.isnan(img.aov["position"][..., 0])
        assert hit.sum() > 200 and np.all(np.isfinite(img.rgb))
        ambient = 0.01 * 0.8
        assert np.all(img.rgb[hit].min(-1) > ambient), (angle, int((img.rgb[hit].min(-1) <= ambient).sum()))
        wo = np.asarray(eye) - img.aov["position"][hit]
        wo /= np.linalg.norm(wo, axis=-1, keepdims=True)
        ns, ng = img.aov["shading_normal"][hit], img.aov["normal"][hit]
        bound = np.minimum(1 / 32, np.sum(ng * wo, -1))
        assert np.all(np.sum(ns * wo, -1) >= bound - 1e-4)
        assert np.all(np.sum(ns * ng, -1) > 0)


def test_low_poly_sphere_terminator_matches_the_analytic_sphere(device):
    """A 16 x 8 UV-sphere mesh with exact vertex normals, lit from the side: with Hanika's lifted
    shadow-ray origin its terminator shades like the analytic sphere's instead of stepping
    along the facets. Without the fix the band where the vertex normal faces the light and
    the facet does not is black (error up to ~0.2 of the lit level)."""
    from texray.procedural import uv_sphere
    m = uv_sphere(16, 8)
    light = [tx.PointLight((40, 0, 8), (1600, 1600, 1600))]
    cam = tx.Camera(eye=(0, 0, 4), look_at=(0, 0, 0), fov_y=32)
    mat = tx.Material(diffuse=(1, 1, 1))
    mesh = render_aov(tx.Mesh(m.positions, m.faces, normals=m.normals, material=mat), cam, size=96, lights=light,
                      names=("shading_normal",), device=device)
    ball = render_aov(tx.Sphere(radius=1.0, material=mat), cam, size=96, lights=light,
                      names=("shading_normal",), device=device)
    both = ~np.isnan(mesh.aov["shading_normal"][..., 0]) & ~np.isnan(ball.aov["shading_normal"][..., 0])
    lit_level = ball.rgb[both].max()
    err = np.abs(mesh.rgb - ball.rgb).max(-1)[both] / lit_level
    # Interpolated normals of a 16 x 8 mesh differ from the sphere's by up to a few degrees: 0.08 of the lit level.
    assert err.max() < 0.08, err.max()
    band = np.abs(ball.aov["shading_normal"][..., 0][both]) < 0.3           # the terminator band
    assert band.sum() > 100


def test_bad_bump_and_normal_map_input_is_a_clear_error():
    tex = gaussian_bump(8)
    with pytest.raises(tx.SceneError, match="height"):
        tx.Bump(tex, height=float("nan"))
    with pytest.raises(tx.SceneError, match="delta"):
        tx.Bump(tex, delta=2.0)
    with pytest.raises(tx.SceneError, match="delta"):
        tx.Bump(tex, delta="exact")
    with pytest.raises(tx.SceneError, match="convention.*'up'"):
        tx.NormalMap(constant_map((0.5, 0.5, 1)), convention="up")
    with pytest.raises(tx.SceneError, match="space"):
        tx.NormalMap(constant_map((0.5, 0.5, 1)), space="world")
    with pytest.raises(tx.SceneError, match="1 channel"):
        tx.NormalMap(tex)
    with pytest.raises(tx.SceneError, match="bump, normal_map"):
        tx.Sphere(material=tx.Material(bump=tx.Bump(tex), normal_map=tx.NormalMap(constant_map((0.5, 0.5, 1)))))
    with pytest.raises(tx.SceneError, match="bump: expected a texray.Bump"):
        tx.Sphere(material=tx.Material(bump=tex))
    with pytest.raises(tx.SceneError, match="texture coordinates"):
        tx.Mesh(np.array(QUAD, float), np.array([[0, 1, 2]]), material=tx.Material(bump=tx.Bump(tex)))


def test_material_layout_of_bump_and_normal_map():
    from texray.compile import compile_scene
    bump = tx.Bump(gaussian_bump(8), height=0.25, delta="analytic")
    nm = tx.NormalMap(constant_map((0.5, 0.5, 1)), convention="directx", space="object")
    scene = tx.Scene()
    scene.add(tx.Sphere(material=tx.Material(bump=bump)))
    scene.add(tx.Sphere(center=(3, 0, 0), material=tx.Material(normal_map=nm)))
    cs = compile_scene(scene)
    m = cs.materials
    assert m[0]["bump_tex"] >= 0 and m[0]["normal_tex"] == -1 and m[0]["bump_height"] == 0.25
    assert m[0]["bump_delta"] == layout.BUMP_DELTA_ANALYTIC
    assert m[1]["normal_tex"] >= 0 and m[1]["bump_tex"] == -1
    assert m[1]["normal_mode"] == layout.TX_NORMAL_DIRECTX | layout.TX_NORMAL_OBJECT
    assert cs.features.bump and cs.features.normal_maps and cs.objects is not None
    plain = tx.Scene()
    plain.add(tx.Sphere())
    f = compile_scene(plain).features
    assert not f.bump and not f.normal_maps


def test_scene_file_bump_and_normal_map(tmp_path):
    import OpenImageIO as oiio
    h = np.linspace(0, 1, 16, dtype=np.float32)[None, :].repeat(16, 0)
    out = oiio.ImageOutput.create(str(tmp_path / "h.png"))
    out.open(str(tmp_path / "h.png"), oiio.ImageSpec(16, 16, 1, "uint8"))
    out.write_image(h)
    out.close()
    text = """
[textures.h]
file = "h.png"
[textures.n]
procedural = "checker"
[materials.b]
bump = { texture = "h", height = 0.02, delta = "analytic" }
[materials.n]
normal_map = { texture = "n", convention = "directx", space = "tangent" }
[[objects]]
type = "sphere"
material = "b"
[[objects]]
type = "sphere"
center = [3, 0, 0]
material = "n"
"""
    (tmp_path / "s.toml").write_text(text)
    scene = tx.Scene.load(tmp_path / "s.toml")
    b, n = scene.objects[0].material.bump, scene.objects[1].material.normal_map
    assert b.height == 0.02 and b.delta == "analytic" and n.convention == "directx"
    from texray.compile import compile_scene
    cs = compile_scene(scene)
    assert cs.features.bump and cs.features.normal_maps
    for bad, match in (('height = "x"', r"bad\.toml: materials\.b\.bump\.height: expected int or float, got 'x'"),
                       ("height = 0.02, delta = 3.0", r"materials\.b\.bump\.delta: expected a number in \(0, 0\.5\], got 3\.0"),
                       ("height = 0.02, scale = 1", r"materials\.b\.bump\.scale: unknown key")):
        (tmp_path / "bad.toml").write_text(text.replace("height = 0.02, delta = \"analytic\"", bad))
        with pytest.raises(tx.SceneError, match=match):
            tx.Scene.load(tmp_path / "bad.toml")
    (tmp_path / "bad.toml").write_text(text.replace('convention = "directx"', 'convention = "y-up"'))
    with pytest.raises(tx.SceneError, match=r"materials\.n\.normal_map\.convention: expected one of"):
        tx.Scene.load(tmp_path / "bad.toml")
    (tmp_path / "bad.toml").write_text(text.replace('texture = "h"', 'texture = "nope"'))
    with pytest.raises(tx.SceneError, match=r"materials\.b\.bump\.texture: no texture named 'nope'"):
        tx.Scene.load(tmp_path / "bad.toml")


def test_data_textures_are_not_srgb_decoded(device):
    """A normal map tagged sRGB (as 8-bit PNGs load by default) gives the normal its stored values encode."""
    rgb = np.broadcast_to(np.float32([0.5, 0.8, 0.9]), (4, 4, 3)).copy()
    out = []
    for cs in ("linear", "srgb"):
        nm = tx.NormalMap(tx.Texture.from_array(rgb, colorspace=cs, name=cs))
        out.append(render_aov(plane("quad", UV_A, tx.Material(normal_map=nm)), top_camera(),
                              names=("shading_normal",), device=device).aov["shading_normal"])
    np.testing.assert_array_equal(out[0], out[1])
    hit = ~np.isnan(out[0][..., 0])
    np.testing.assert_allclose(out[0][hit], np.broadcast_to([0, 0.8, -0.6], (hit.sum(), 3)), atol=2e-3)
