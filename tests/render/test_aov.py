"""AOVs: the surface stage's per-pixel geometry against float64 references, written to EXR."""
import numpy as np
import OpenImageIO as oiio
import pytest

import texray as tx
from texray.device import layout
from reference import scene_hits
from scenes_for_tests import textured_box_scene

W, H = 64, 48


def test_triangle_aovs_match_float64(device):
    scene = textured_box_scene()
    img = tx.render(scene, W, H, spp=1, device=device, aovs=tuple(layout.AOVS))
    cs, org, d, t, b1, b2, tri = scene_hits(scene, W, H)
    hit = tri >= 0
    flat = {k: v.reshape(W * H, -1) for k, v in img.aov.items()}
    # Background: NaN geometry, -1 ids.
    assert np.all(np.isnan(flat["uv"][~hit])) and np.all(flat["primitive_id"][~hit] == -1)
    assert np.all(flat["object_id"][~hit] == -1)
    # Hits, away from silhouettes where float32 may pick the neighbour.
    i = tri[hit]
    ts = cs.tri_shade[i]
    B1, B2 = b1[hit, None], b2[hit, None]
    B0 = 1 - B1 - B2
    margin = np.minimum(np.minimum(B0, B1), B2)[:, 0]
    ok = margin > 1e-3
    p0, p1, p2 = (cs.tri_verts[k][i].astype(np.float64) for k in ("p0", "p1", "p2"))
    pos = B0 * p0 + B1 * p1 + B2 * p2
    np.testing.assert_allclose(flat["position"][hit][ok], pos[ok], atol=1e-5)
    depth = t[hit] * np.linalg.norm(d[hit], axis=1)
    np.testing.assert_allclose(flat["depth"][hit][ok, 0], depth[ok], rtol=1e-5)
    np.testing.assert_array_equal(flat["object_id"][hit][ok, 0], ts["object"][ok])
    np.testing.assert_array_equal(flat["primitive_id"][hit][ok, 0], ts["prim"][ok])
    uvs = cs.uvs.reshape(-1, 2).astype(np.float64)
    has_uv = (ts["flags"] & layout.TRI_HAS_UVS) != 0
    uv = B0 * uvs[ts["v"][:, 0]] + B1 * uvs[ts["v"][:, 1]] + B2 * uvs[ts["v"][:, 2]]
    sel = ok & has_uv
    assert sel.sum() > 500
    np.testing.assert_allclose(flat["uv"][hit][sel], uv[sel], atol=1e-5)
    ng = np.cross(p1 - p0, p2 - p0)
    ng /= np.linalg.norm(ng, axis=1, keepdims=True)
    np.testing.assert_allclose(flat["normal"][hit][ok], ng[ok], atol=1e-5)
    # dP/du, dP/dv: P - P0 = du dP/du + dv dP/dv across the triangle's edges (uv'd triangles).
    dpdu, dpdv = flat["dpdu"][hit], flat["dpdv"][hit]
    duv1 = uvs[ts["v"][:, 1]] - uvs[ts["v"][:, 0]]
    rebuilt = duv1[:, :1] * dpdu + duv1[:, 1:] * dpdv
    np.testing.assert_allclose(rebuilt[sel], (p1 - p0)[sel], atol=1e-4)


def test_zero_uv_area_triangle_gets_a_finite_frame(device):
    p = np.array([[-1, 0, 1], [1, 0, 1], [0, 0, -1]], float)
    scene = tx.Scene(camera=tx.Camera(eye=(0, 3, 0.01), look_at=(0, 0, 0)))
    scene.add(tx.Mesh(p, np.array([[0, 1, 2]]), uvs=np.full((3, 2), 0.5), name="flat-uv",
                      material=tx.Material(diffuse=tx.Texture.from_array(np.ones((2, 2, 3))))))
    img = tx.render(scene, 16, 16, device=device, aovs=("dpdu", "dpdv", "normal"))
    hit = ~np.isnan(img.aov["normal"][..., 0])
    assert hit.sum() > 20
    du, dv, n = (img.aov[k][hit] for k in ("dpdu", "dpdv", "normal"))
    assert np.all(np.isfinite(du)) and np.all(np.isfinite(dv))
    np.testing.assert_allclose(np.einsum("ij,ij->i", du, n), 0, atol=1e-6)
    np.testing.assert_allclose(np.linalg.norm(np.cross(du, dv), axis=1), 1, atol=1e-5)


def test_aovs_are_saved_as_exr_channels(tmp_path):
    scene = textured_box_scene()
    img = tx.render(scene, 16, 12, spp=1, device="cpu", aovs=("uv", "depth", "object_id"))
    path = tmp_path / "aov.exr"
    img.save(path)
    buf = oiio.ImageBuf(str(path))
    names = list(buf.spec().channelnames)        # OpenEXR may store channels in its own order
    assert sorted(names) == sorted(["R", "G", "B", "uv.u", "uv.v", "depth", "object_id"])
    px = buf.get_pixels(oiio.FLOAT)
    ch = {name: px[:, :, i] for i, name in enumerate(names)}
    np.testing.assert_array_equal(ch["depth"], img.aov["depth"][:, :, 0])
    np.testing.assert_array_equal(ch["object_id"], img.aov["object_id"][:, :, 0])
    np.testing.assert_array_equal(ch["uv.v"], img.aov["uv"][:, :, 1])
    np.testing.assert_array_equal(ch["R"], img.rgb[:, :, 0])


def test_unknown_aov_is_an_error():
    with pytest.raises(tx.SceneError, match=r"aovs: unknown AOV 'albedo'"):
        tx.render(tx.Scene(), 4, 4, aovs=("albedo",))
