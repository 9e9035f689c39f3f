"""Ray packets (kernels/accel/packet.h): TX_PACKET rays traced as one give the scalar
traversals' answers, ray for ray, bit for bit -- any hit (occluded) and closest hit (t,
barycentrics, primitive) -- on coherent and incoherent rays, rays parallel to box faces,
degenerate rays mixed into packets, rays aimed at shared edges and vertices (ties: the
lower triangle index, whatever the order), per-ray intervals, every primitive kind (the
lane-by-lane path); and the fused kernel's images do not depend on the packet width. The
scalar traversals are held to float64 references in test_traversal.py; the packets are
held to them here."""
import dataclasses
import os
import re
import subprocess
import sys

import numpy as np
import pytest
import trimesh

import texray as tx
from texray.device.features import packet_width, Features
from texray.errors import DeviceError
from texray.renderer.trace import Tracer

WIDTHS = (8, 16)


def _tracers(monkeypatch, scene, device):
    """{width: Tracer} for the scalar traversal (0) and each packet width."""
    out = {}
    for w in (0, *WIDTHS):
        monkeypatch.setenv("TEXRAY_PACKET", str(w))
        out[w] = Tracer(scene, device)
        assert out[w].packet == w
    return out


def _assert_same(tracers, org, d, tmin=0.0, tmax=1.0, max_near=0.0):
    """Occluded (t in (tmin, tmax)) and closest hits (t in (tmin, 2 tmax)) of every width
    equal the scalar traversal's (closest hits within rounding of another hit: at most a
    fraction ``max_near`` of them); returns the scalar occlusion."""
    o32, d32 = org.astype(np.float32), d.astype(np.float32)
    ref, _ = tracers[0].occluded(o32, d32, tmin, tmax)
    href = tracers[0].closest(o32, d32, tmin, 2 * np.asarray(tmax, np.float32))
    for w in WIDTHS:
        got, _ = tracers[w].occluded(o32, d32, tmin, tmax)
        bad = np.flatnonzero(got != ref)
        assert bad.size == 0, f"width {w}: {bad.size} of {len(ref)} rays differ from the scalar traversal, " \
                              f"e.g. ray {bad[:5]}"
        if tracers[w].compiled.features.instances:
            continue                    # closest-hit packets leave instances to the scalar traversal
        h = tracers[w].closest(o32, d32, tmin, 2 * np.asarray(tmax, np.float32))
        same = np.ones(len(ref), bool)
        for f in ("t", "b1", "b2", "prim"):
            a, b = getattr(h, f), getattr(href, f)
            same &= (a == b) | (np.isnan(a) & np.isnan(b))
        # Bit for bit, except where the closest hits lie within rounding of each other in t (a
        # ray through a shared vertex or edge): the box tests' rounding then lets a traversal's
        # order decide which one it keeps (accel/packet.h). Then both are hits at that t.
        near = (h.prim >= 0) & (href.prim >= 0) & (np.abs(h.t - href.t) <= 4e-7 * np.abs(href.t))
        bad = np.flatnonzero(~same & ~near)
        assert bad.size == 0, f"width {w}: closest hit differs on {bad.size} rays, e.g. {bad[:5]}: " \
                              f"t {h.t[bad[:3]]} prim {h.prim[bad[:3]]} against t {href.t[bad[:3]]} prim {href.prim[bad[:3]]}"
        assert (~same).mean() <= max_near, f"width {w}: {(~same).mean():.2%} of the closest hits differ"
    assert (href.prim >= 0).any(), "no closest hit to compare"
    return ref


def _soup(rng, n=3000):
    pts = rng.uniform(-1, 1, (n, 1, 3)) + rng.normal(0, 0.08, (n, 3, 3))
    scene = tx.Scene()
    scene.add(tx.Mesh(pts.reshape(-1, 3), np.arange(3 * n).reshape(-1, 3), name="soup"))
    return scene


def _shadow_bundles(rng, n_bundles, light, spread=0.01):
    """Coherent packets as the renderer makes them: 16 origins within a small disc each,
    toward one light (d reaches it at t = 1)."""
    centres = rng.uniform(-1.2, 1.2, (n_bundles, 1, 3))
    org = (centres + rng.normal(0, spread, (n_bundles, 16, 3))).reshape(-1, 3)
    return org, np.asarray(light, np.float64) - org


def _by_shear_axes(d):
    """An order of the rays d that groups them by the watertight test's shear axes (the
    direction's largest component and its sign), so that nearly every packet of consecutive
    rays shares one shear (PacketRay.uniform, triangle_packet's short form) -- all six of
    them -- where random rays mostly mix them (the general rows)."""
    d = np.asarray(d, np.float32)
    kz = np.argmax(np.abs(d), axis=1)
    return np.argsort(2 * kz + (d[np.arange(len(d)), kz] < 0), kind="stable")


def test_packets_equal_scalar_on_coherent_and_random_rays(device, rng, monkeypatch):
    tr = _tracers(monkeypatch, _soup(rng), device)
    org, d = _shadow_bundles(rng, 400, (3.0, 4.0, 2.0))
    occ = _assert_same(tr, org, d)
    assert 0.2 < occ.mean() < 0.95, f"{occ.mean():.2f} occluded: the rays test nothing"
    org = rng.uniform(-2.5, 2.5, (5003, 3))                 # incoherent, n not a multiple of 16
    d = rng.uniform(-1, 1, (5003, 3)) - org
    occ = _assert_same(tr, org, d)
    assert 0.2 < occ.mean() < 0.95
    o = _by_shear_axes(d)
    np.testing.assert_array_equal(_assert_same(tr, org[o], d[o]), occ[o])


def test_packets_equal_scalar_on_degenerate_and_parallel_rays(device, rng, monkeypatch):
    """Rays failing ray_valid (NaN, inf, zero or tiny directions, empty and NaN intervals)
    inside packets with valid ones, axis-parallel directions (the exact slab re-test),
    origins on box faces, and per-ray intervals."""
    tr = _tracers(monkeypatch, _soup(rng, 1500), device)
    n = 16 * 300
    org = rng.uniform(-1.5, 1.5, (n, 3))
    d = rng.uniform(-1, 1, (n, 3))
    d[::7, rng.integers(0, 3)] = 0.0                          # parallel to a face
    d[3::11, :2] = 0.0                                        # along an axis
    org[5::13] = np.round(org[5::13], 1)                      # on round coordinates (box faces of the soup)
    bad = np.arange(2, n, 17)
    kinds = [np.nan, np.inf, -np.inf, 0.0, 1e-31, 1e38]
    for i, k in zip(bad, np.resize(kinds, bad.size)):
        if k in (0.0, 1e-31):
            d[i] = k
        elif k == 1e38:
            d[i, 0] = 1e38
        else:
            (org if i % 2 else d)[i, i % 3] = k
    tmin = np.where(np.arange(n) % 19 == 0, 0.5, 0.0)
    tmax = rng.uniform(0.2, 3.0, n)
    tmax[::23] = 0.0                                          # empty interval (tmin >= tmax)
    tmax[1::29] = np.nan
    ref = _assert_same(tr, org, d, tmin.astype(np.float32), tmax.astype(np.float32))
    assert not ref[bad].any(), "an invalid ray was reported occluded"
    assert 0.1 < ref.mean() < 0.9


def test_packets_equal_scalar_on_rays_in_box_faces(device, monkeypatch):
    """Rays with a zero direction component whose origin lies exactly in a box face and
    tmin > 0: the fast slab test misses them (0 x 2^100 = 0 < tmin), the exact re-test
    (box_entry_parallel) enters, and the unit square's edge at x = 1 is hit."""
    scene = tx.Scene()
    sq = np.array([[0, 0, 0.5], [1, 0, 0.5], [1, 1, 0.5], [0, 1, 0.5]], np.float64)
    cube = trimesh.creation.box(bounds=((0, 0, 0), (1, 1, 1)))
    scene.add(tx.Mesh(np.concatenate([sq, np.asarray(cube.vertices)]),
                      np.concatenate([[[0, 1, 2], [0, 2, 3]], np.asarray(cube.faces) + 4]), name="cube"))
    tr = _tracers(monkeypatch, scene, device)
    y = np.linspace(0.05, 0.95, 64)
    org = np.stack([np.ones_like(y), y, -np.ones_like(y)], axis=1)
    d = np.tile([0.0, 0.0, 1.0], (len(y), 1))
    occ = _assert_same(tr, org, d, np.float32(0.01), np.float32(10.0))
    assert occ.all(), f"{(~occ).sum()} rays along the face x = 1 missed the square's edge"



def _segments_meet_triangles(org, target, tris, grow):
    """Whether the float64 segments org -> target (t in (0, 1)) meet any of the triangles tris
    (k, 3, 3) scaled by 1 + grow about their centroids (grow < 0: shrunk), reference.intersect."""
    from reference import intersect
    c = tris.mean(axis=1, keepdims=True)
    p = c + (tris - c) * (1.0 + grow)
    return intersect(org, target - org, p[:, 0], p[:, 1], p[:, 2], tmax=np.ones(len(org)))[3] >= 0


def test_rays_leave_a_plane_from_the_plane(device, rng, monkeypatch):
    """Rays with tmin = 0 from points exactly on a ground plane (two triangles: a flat leaf
    box the ray leaves at t = 0), beside and inside the box of a tetrahedron standing on it: a
    box the ray leaves at t <= 0 is not entered (accel/bvh.h box4_entry, packet.h
    box_entry_packet: no hit in it could pass the triangle test's t > 0 bound), one it starts in
    is, and the answers are the float64 reference's -- a ray up is occluded exactly where its
    segment meets the tetrahedron, a ray down never, and the plane never occludes its own points;
    every packet width as the scalar traversal."""
    ground = np.array([[-4, 0, -4], [4, 0, -4], [4, 0, 4], [-4, 0, 4]], np.float64)
    base = np.array([[-0.5, 0.0, -0.5], [0.5, 0.0, -0.5], [0.0, 0.0, 0.5]])
    apex = np.array([0.0, 1.0, 0.0])
    tet = np.array([[base[0], base[1], apex], [base[1], base[2], apex], [base[2], base[0], apex]])
    scene = tx.Scene()
    scene.add(tx.Mesh(ground, np.array([[0, 2, 1], [0, 3, 2]]), name="ground"))
    scene.add(tx.Mesh(np.concatenate([base, apex[None]]), np.array([[0, 1, 3], [1, 2, 3], [2, 0, 3], [0, 2, 1]]),
                      name="tetrahedron"))
    tr = _tracers(monkeypatch, scene, device)
    # ground points around the tetrahedron, half of them in its box's footprint (beside its base)
    xz = np.concatenate([rng.uniform(-0.5, 0.5, (3000, 2)), rng.uniform(-2, 2, (3000, 2))]).astype(np.float32)
    org = np.stack([xz[:, 0], np.zeros(len(xz), np.float32), xz[:, 1]], axis=1).astype(np.float64)
    inside_base = _segments_meet_triangles(org + [0, 1, 0], org - [0, 1, 0], base[None], 1e-4)
    org = org[~inside_base]
    target = rng.uniform([-0.6, 0.05, -0.6], [0.6, 1.2, 0.6], (len(org), 3)).astype(np.float32).astype(np.float64)
    up = _assert_same(tr, org, target - org)
    inner = _segments_meet_triangles(org, target, tet, -1e-5)
    outer = _segments_meet_triangles(org, target, tet, 1e-5)
    sure = inner == outer
    in_box = (np.abs(org[:, 0]) < 0.5) & (np.abs(org[:, 2]) < 0.5)
    assert sure.mean() > 0.99 and 0.2 < inner.mean() < 0.8 and inner[in_box].mean() > 0.2
    bad = np.flatnonzero(sure & (up != inner))
    assert bad.size == 0, f"{bad.size} rays from the plane disagree with the float64 test, e.g. {bad[:5]}"
    down = ((target - org) * np.array([1.0, -1.0, 1.0])).astype(np.float32)
    for w, t in tr.items():
        occ, _ = t.occluded(org.astype(np.float32), down, 0.0, 1.0)
        assert not occ.any(), f"width {w}: {occ.sum()} rays down from the plane were occluded"
        h = t.closest(org.astype(np.float32), down, 0.0, 2.0)
        assert (h.prim < 0).all(), f"width {w}: {(h.prim >= 0).sum()} rays down from the plane hit something"

def test_packets_are_watertight_on_shared_edges(device, monkeypatch):
    """Rays through the vertices and edge midpoints of a closed icosphere, from inside:
    every one hits (scalar and packet alike), none slips between triangles."""
    s = trimesh.creation.icosphere(subdivisions=3)
    scene = tx.Scene()
    scene.add(tx.Mesh(np.asarray(s.vertices), np.asarray(s.faces), name="ico"))
    tr = _tracers(monkeypatch, scene, device)
    v = np.asarray(s.vertices)
    e = np.asarray(s.edges_unique)
    targets = np.concatenate([v, 0.5 * (v[e[:, 0]] + v[e[:, 1]])])
    org = np.zeros_like(targets) + np.array([1e-3, -2e-3, 5e-4])
    for o in (np.arange(len(targets)), _by_shear_axes(targets - org)):   # packets of mixed and of one shear
        occ = _assert_same(tr, org[o], 2.0 * (targets - org)[o], max_near=0.05)
        assert occ.all(), f"{(~occ).sum()} rays through edges or vertices escaped"


def test_packets_test_other_kinds_lane_by_lane(device, rng, monkeypatch):
    """Spheres, cylinders, quads, a displaced quad and instances beside triangles: leaves of
    those kinds go through the scalar leaf_hit per lane, with the same answers."""
    scene = tx.Scene()
    scene.add(tx.Sphere(center=(0.6, 0.2, 0.0), radius=0.4))
    scene.add(tx.Cylinder(radius=0.3, z_range=(-0.4, 0.4), origin=(-0.6, -0.4, 0.2), axis_z=(0, 1, 0)))
    scene.add(tx.Quad((-1.5, -1.0, -1.5), (1.5, -1.0, -1.5), (1.5, -1.0, 1.5), (-1.5, -1.0, 1.5)))
    h = rng.uniform(0, 1, (16, 16, 1)).astype(np.float32)
    scene.add(tx.Quad((-1, 1, -1), (1, 1, -1), (1, 1, 1), (-1, 1, 1),
                      material=tx.Material(displacement=tx.Displacement(tx.Texture(h, name="h"), scale=0.2))))
    box = trimesh.creation.box(extents=(0.3, 0.3, 0.3))
    mesh = tx.Mesh(np.asarray(box.vertices), np.asarray(box.faces), name="box")
    for x in (-0.8, 0.0, 0.8):
        scene.add(tx.Instance(mesh, tx.Transform(translate=(x, -0.6, -0.7))))
    scene.add(_soup(rng, 200).objects[0])
    tr = _tracers(monkeypatch, scene, device)
    org, d = _shadow_bundles(rng, 300, (0.3, 3.0, 0.4), spread=0.05)
    occ = _assert_same(tr, org, d)
    assert 0.1 < occ.mean() < 0.95


def test_packet_quads_equal_the_scalar_patch_test(device, rng, monkeypatch):
    """Quads are tested against whole packets (geometry/quad_packet.h): t, the patch's (u, v)
    and the quad hit equal quad_intersect_corners' per ray, bit for bit, on a rectangle, a
    twisted (saddle) patch, a trapezoid and a bow-tie, for
    incoherent rays, coherent bundles, and rays grazing the rectangle along both of its
    edge directions (the per-lane transposition)."""
    scene = tx.Scene()
    scene.add(tx.Quad((-1, -1, 0), (1, -1, 0), (1, 1, 0), (-1, 1, 0)))
    scene.add(tx.Quad((-0.5, -0.5, 1.0), (0.5, -0.5, 1.3), (0.5, 0.5, 1.0), (-0.5, 0.5, 1.3)))    # saddle
    scene.add(tx.Quad((1.2, -1, 0.5), (2.4, -1, 0.5), (2.0, 0, 0.9), (1.6, 0, 0.9)))              # trapezoid
    scene.add(tx.Quad((-2.4, -1, 0.2), (-1.2, 0, 0.2), (-1.2, -1, 0.6), (-2.4, 0, 0.6)))          # bow-tie
    tr = _tracers(monkeypatch, scene, device)
    n = 4000
    org = rng.uniform(-2.5, 2.5, (n, 3)) + np.array([0, 0, 1.5])
    d = rng.normal(0, 1, (n, 3)) * 4
    _assert_same(tr, org, d)
    bo, bd = _shadow_bundles(rng, 200, (0.2, 0.1, 4.0), spread=0.05)
    _assert_same(tr, bo + np.array([0, 0, -1.5]), bd)
    # grazing the rectangle at z = 0: 1e-3 to 1e-6 out of its plane, along x and along y
    k = 2000
    g = rng.uniform(-0.9, 0.9, (k, 3))
    slope = 10.0 ** rng.uniform(-6, -3, k) * rng.choice([-1, 1], k)
    along_x = np.stack([np.full(k, 1.0), rng.uniform(-0.1, 0.1, k), slope], axis=1)
    along_y = along_x[:, [1, 0, 2]]
    for dirs in (along_x, along_y):
        o = np.stack([g[:, 0], g[:, 1], np.zeros(k)], axis=1) - 0.5 * dirs
        _assert_same(tr, o, dirs * 2)
    # from just off the rectangle, toward it and away (the hits near t = 0 that the patch
    # test's t_floor rejects or keeps)
    o = np.concatenate([g[:, :2], 10.0 ** rng.uniform(-6, -3, (k, 1)) * rng.choice([-1, 1], (k, 1))], axis=1)
    _assert_same(tr, o, rng.normal(0, 1, (k, 3)))
    href = tr[0].closest(org.astype(np.float32), d.astype(np.float32), 0.0, np.float32(2.0))
    kinds = href.prim[href.prim >= 0]
    assert len(np.unique(kinds)) >= 3, "the rays should hit several of the quads"


def test_packet_spheres_equal_the_scalar_sphere_test(device, rng, monkeypatch):
    """Spheres are tested against whole packets (geometry/sphere_packet.h): t and the sphere
    hit equal sphere_intersect's per ray, bit for bit: incoherent rays, coherent bundles,
    rays grazing a silhouette (nearly double roots), rays leaving a sphere's surface outward
    and inward (the early miss and the near root's c_ok), and a tiny sphere far away."""
    scene = tx.Scene()
    scene.add(tx.Sphere(center=(0.0, 0.0, 0.0), radius=1.0))
    scene.add(tx.Sphere(center=(2.2, 0.3, 0.1), radius=0.5))
    scene.add(tx.Sphere(center=(-1.8, -0.2, 0.4), radius=0.3))
    scene.add(tx.Sphere(center=(900.0, 500.0, -300.0), radius=1e-3))
    tr = _tracers(monkeypatch, scene, device)
    n = 4000
    org = rng.uniform(-3, 3, (n, 3))
    _assert_same(tr, org, rng.normal(0, 1, (n, 3)) * 6)
    bo, bd = _shadow_bundles(rng, 200, (0.4, 4.0, 3.0), spread=0.05)
    _assert_same(tr, bo * 2, bd)
    k = 2000
    # from the unit sphere's surface (to float precision, just outside or inside), any direction
    u = rng.normal(0, 1, (k, 3))
    u /= np.linalg.norm(u, axis=1, keepdims=True)
    on = u * (1.0 + rng.choice([-1, 1], (k, 1)) * 10.0 ** rng.uniform(-7, -4, (k, 1)))
    _assert_same(tr, on, rng.normal(0, 1, (k, 3)))
    # from points exactly on it (c = 0: the root at the origin is not a hit)
    axes = np.repeat(np.concatenate([np.eye(3), -np.eye(3)]), 64, axis=0)
    _assert_same(tr, axes, rng.normal(0, 1, axes.shape))
    # grazing the unit sphere's silhouette: tangent rays 1e-7..1e-3 inside or outside it
    side = np.cross(u, rng.normal(0, 1, (k, 3)))
    side /= np.linalg.norm(side, axis=1, keepdims=True)
    off = u * (1.0 + rng.choice([-1, 1], (k, 1)) * 10.0 ** rng.uniform(-7, -3, (k, 1)))
    _assert_same(tr, off - 3 * side, 6 * side)
    # toward the tiny far sphere, through its centre and its rim
    target = np.array([900.0, 500.0, -300.0]) + rng.normal(0, 1.2e-3, (k, 3))
    src = rng.uniform(-1, 1, (k, 3)) * 0.01
    _assert_same(tr, src, (target - src) * 0.6)
    href = tr[0].closest(src.astype(np.float32), ((target - src) * 0.6).astype(np.float32), 0.0, np.float32(2.0))
    assert (href.prim >= 0).mean() > 0.1, "rays should hit the tiny far sphere"


def test_rendered_images_do_not_depend_on_the_packet_width(device, monkeypatch):
    """The fused kernel with packets: the same image bit for bit at every width, with spp
    not a multiple of the width, three lights (one under the floor), smooth normals (the
    lifted shadow origins), and adaptive sampling."""
    scene = tx.load_scene(tx_scene("bench/textured_meshes.toml"))
    scene.lights.append(tx.PointLight(position=(0.5, -2.0, 0.5), intensity=(5.0, 5.0, 5.0)))
    images = {}
    for w in (0, *WIDTHS):
        monkeypatch.setenv("TEXRAY_PACKET", str(w))
        a = tx.render(scene, 48, 36, 21, device=device, seed=3)
        b = tx.render(scene, 48, 36, 24, device=device, adaptive=0.05)    # rounds 4, 4, 8, 8: 2 pixels per item
        images[w] = (a.rgb, b.rgb, b.stats["samples"])
    for w in WIDTHS:
        assert np.array_equal(images[w][0], images[0][0]), f"width {w}: 21 spp differs"
        assert np.array_equal(images[w][1], images[0][1]) and images[w][2] == images[0][2], \
            f"width {w}: adaptive differs"
    lit = images[0][0]
    assert lit.std() > 0.05 and np.isfinite(lit).all()


@pytest.mark.parametrize("name", ["bench/textured_meshes.toml", "bench/globe.toml", "bench/brick_wall.toml"])
def test_packets_without_shadow_rays_keep_the_image(device, monkeypatch, name):
    """render(shadows=False) and a scene without lights take packets too (the camera rays,
    surfaces and shading; light_visible_packet then traces nothing): the scalar image bit for
    bit at every width, and no darker anywhere than the shadowed image (each light's term
    only added where the shadowed render drops it), brighter where a shadow fell."""
    scene = tx.load_scene(tx_scene(name))
    dark = dataclasses.replace(scene, lights=[], ambient=(0.3, 0.25, 0.2))
    out = {}
    for w in (0, *WIDTHS):
        monkeypatch.setenv("TEXRAY_PACKET", str(w))
        a = tx.render(scene, 37, 23, 5, device=device, seed=2, shadows=False)
        b = tx.render(dark, 37, 23, 5, device=device, seed=2)
        assert a.stats["packet"] == w and b.stats["packet"] == w
        out[w] = (a.rgb, b.rgb)
        if w == 0:
            lit = tx.render(scene, 37, 23, 5, device=device, seed=2).rgb
    for w in WIDTHS:
        assert np.array_equal(out[w][0], out[0][0]), f"width {w}: shadows=False differs"
        assert np.array_equal(out[w][1], out[0][1]), f"width {w}: no lights differs"
    assert np.isfinite(out[0][0]).all() and np.all(out[0][0] >= lit)
    if name == "bench/textured_meshes.toml":         # the vase's and torus's shadows on the ground
        assert (out[0][0] > lit).any()               # (a lone sphere or wall shadows nothing)
    assert out[0][1].std() > 0.01 and np.isfinite(out[0][1]).all()


@pytest.mark.parametrize("spp", [1, 2, 3, 4, 12, 16])
def test_several_pixels_per_work_item_keep_the_image(device, monkeypatch, spp):
    """Where a pixel's samples per launch leave lanes of its last packet empty, each work-item
    takes several pixels (8, 4, 8, 2, 2 at 1, 2, 3, 4, 12 spp; 1 at 16: pixels_per_item) so
    that their samples, pixel by pixel, fill the packets: the
    image is the scalar one bit for bit, on an image whose pixel count is no multiple of 8
    (37 x 23: a work-item's last pixels past the tile's end), cut into tiles of 97 pixels
    (every tile ends inside a work-item's group), with and without jitter."""
    from texray.device import runtime
    from texray.device.features import pixels_per_item
    scene = tx.load_scene(tx_scene("bench/textured_meshes.toml"))
    scene.lights.append(tx.PointLight(position=(0.5, -2.0, 0.5), intensity=(5.0, 5.0, 5.0)))
    out = {}
    for w in (0, *WIDTHS):
        monkeypatch.setenv("TEXRAY_PACKET", str(w))
        a = tx.render(scene, 37, 23, spp, device=device, seed=5)
        b = tx.render(scene, 37, 23, spp, device=device, seed=5, tile_pixels=97, jitter=False)
        assert a.stats["packet"] == w
        out[w] = (a.rgb, b.rgb)
    for w in WIDTHS:
        assert np.array_equal(out[w][0], out[0][0]), f"width {w}, {spp} spp: the image differs"
        assert np.array_equal(out[w][1], out[0][1]), f"width {w}, {spp} spp, tiles: the image differs"
    assert out[0][0].std() > 0.05 and np.isfinite(out[0][0]).all()
    monkeypatch.setenv("TEXRAY_PACKET", "8")
    expect = {1: 8, 2: 4, 3: 8, 4: 2, 12: 2, 16: 1}[spp]
    assert pixels_per_item(Features(shadows=True, triangles=True), runtime(device).kind, spp) == expect


def tx_scene(rel):
    from conftest import ROOT
    return ROOT / "scenes" / rel


def test_packet_rule():
    """Packets where they measured faster: PoCL, with or without shadow rays; at any spp, several pixels per
    work-item where one pixel's samples leave lanes empty (pixels_per_item: the fewest packets
    per pixel, then the fewest pixels), adaptive sampling's rounds too (pixels from its
    list); 16 lanes for every scene. Intel's runtime: only when forced (TEXRAY_PACKET), for its
    slow packet builds."""
    from texray.device.features import pixels_per_item
    mix = Features(shadows=True, triangles=True, spheres=True)
    ada = Features(shadows=True, quads=True, triangles=False, adaptive=True)
    assert [packet_width(mix, "pocl", n) for n in (1, 2, 3, 4, 16)] == [16] * 5
    assert [pixels_per_item(mix, "pocl", n) for n in (1, 2, 3, 4, 5, 6, 7, 8, 9, 12, 16, 20, 24)] == \
        [16, 8, 16, 4, 16, 8, 16, 2, 16, 4, 1, 4, 2]
    assert [packet_width(ada, "pocl", n) for n in (1, 3, 4, 8)] == [16] * 4
    assert [pixels_per_item(ada, "pocl", n) for n in (1, 3, 4, 8)] == [16, 16, 4, 2]
    tri = Features(shadows=True, triangles=True, vertex_normals=True, textures=True, adaptive=True)
    assert [packet_width(tri, "pocl", n) for n in (1, 4, 16)] == [16] * 3
    assert [pixels_per_item(tri, "pocl", n) for n in (1, 2, 3, 4, 5, 6, 7, 8, 9, 12, 16, 20, 24, 32)] == \
        [16, 8, 16, 4, 16, 8, 16, 2, 16, 4, 1, 4, 2, 1]
    for other in ("spheres", "cylinders", "quads", "displacement", "displaced_meshes", "instances"):
        assert packet_width(dataclasses.replace(tri, **{other: True}), "pocl", 16) == 16, other
    assert packet_width(tri, "nvidia", 16) == 0 and pixels_per_item(tri, "nvidia", 1) == 1
    assert packet_width(tri, "intel-cpu", 16) == 0 and pixels_per_item(tri, "intel-cpu", 1) == 1
    assert packet_width(tri, None, 16) == 0
    # without shadow rays too: the camera rays, surfaces and shading are packets all the same
    assert packet_width(Features(shadows=False, triangles=True), "pocl", 16) == 16
    assert pixels_per_item(Features(shadows=False, triangles=True), "pocl", 1) == 16
    assert packet_width(Features(shadows=False, triangles=True), "nvidia", 16) == 0
    assert packet_width(Features.generic(), "pocl", 16) == 16


def test_light_blocks_rule():
    """One light per sample with packets (not adaptive sampling or instances): light blocks
    (stages/fused.cl TX_LIGHT_BLOCKS), a packet of 16 holding one block of light_block's
    samples of each of 16 / b pixels (b >= 2: 4 spp, two lights: 8 pixels, 16 spp: 2); where
    the blocks are single samples (spp no multiple of twice the light count) the pixels fill
    the packets as without; every such program takes several pixels per work-item."""
    from texray.device.features import compile_options, light_block, light_blocks, pixels_per_item
    one = Features(shadows=True, triangles=True, one_light=True, max_lights=2)
    spps = (1, 2, 3, 4, 8, 12, 16, 24, 32)
    assert [light_block(n, 2) for n in spps] == [1, 1, 1, 2, 4, 2, 8, 4, 8]
    assert [pixels_per_item(one, "pocl", n, block=light_block(n, 2)) for n in spps] == [16, 8, 16, 8, 4, 8, 2, 4, 2]
    assert [pixels_per_item(one, "pocl", n) for n in spps] == [16, 8, 16, 4, 2, 4, 1, 2, 1]   # no block given
    assert light_blocks(one, "pocl", 16) and not light_blocks(one, "nvidia", 16)
    for other in ("adaptive", "instances"):
        assert not light_blocks(dataclasses.replace(one, **{other: True}), "pocl", 16), other
        assert pixels_per_item(dataclasses.replace(one, **{other: True}), "pocl", 16, block=8) == 1, other
    assert not light_blocks(dataclasses.replace(one, one_light=False), "pocl", 16)
    opts = compile_options(one, "pocl", 32)
    assert opts["TX_LIGHT_BLOCKS"] == 1 and opts["TX_MULTI_PIXEL"] == 1
    opts = compile_options(dataclasses.replace(one, one_light=False), "pocl", 32)
    assert opts["TX_LIGHT_BLOCKS"] == 0 and opts["TX_MULTI_PIXEL"] == 0
    assert compile_options(one, "nvidia", 16)["TX_LIGHT_BLOCKS"] == 0


def test_tracer_packet_rule(monkeypatch):
    """The Tracer's batches of rays take the kind's width of TRACE_PACKET_WIDTHS on every scene
    (8 on PoCL, where frames take 16), none on other kinds; TEXRAY_PACKET overrides it as
    it does the renderer's rule."""
    from texray.device.features import trace_packet_width
    monkeypatch.delenv("TEXRAY_PACKET", raising=False)
    tri = Features(shadows=True, triangles=True)
    mix = Features(shadows=True, triangles=True, spheres=True)
    assert trace_packet_width(tri, "pocl") == 8 and packet_width(tri, "pocl", 16) == 16
    assert trace_packet_width(mix, "pocl") == 8 and packet_width(mix, "pocl", 16) == 16
    assert trace_packet_width(tri, "nvidia") == 0 and trace_packet_width(tri, "intel-cpu") == 0
    assert trace_packet_width(tri, None) == 0
    assert trace_packet_width(Features(shadows=False, triangles=True), "pocl") == 8
    for w in (0, 8, 16):
        monkeypatch.setenv("TEXRAY_PACKET", str(w))
        assert trace_packet_width(tri, "pocl") == w
    monkeypatch.setenv("TEXRAY_PACKET", "4")
    with pytest.raises(DeviceError):
        trace_packet_width(tri, "pocl")


def test_tracer_takes_its_rule(device, monkeypatch):
    """A Tracer on a scene of triangles alone builds the rule's width (8 lanes on PoCL)."""
    from texray.device.features import trace_packet_width
    monkeypatch.delenv("TEXRAY_PACKET", raising=False)
    tr = Tracer(_soup(np.random.default_rng(3), 50), device)
    f = dataclasses.replace(tr.compiled.features, shadows=True)
    assert tr.packet == trace_packet_width(f, tr.rt.kind)
    if tr.rt.kind == "pocl":
        assert tr.packet == 8 and packet_width(f, "pocl", 16) == 16


def test_renders_choose_packets_by_samples_per_launch(device, monkeypatch):
    """render() builds the packet program where the device's rule has packets (any spp,
    adaptive rounds too); stats say which."""
    from texray.device import runtime
    from texray.renderer.frame import launch_samples
    monkeypatch.delenv("TEXRAY_PACKET", raising=False)
    assert launch_samples(64, 48, 16) == 16 and launch_samples(64, 48, 64, adaptive=0.1) == 8
    assert launch_samples(64, 48, 3) == 3
    scene = tx.load_scene(tx_scene("bench/textured_meshes.toml"))
    width = {"pocl": 16}.get(runtime(device).kind, 0)
    assert [tx.render(scene, 16, 12, spp, device=device).stats["packet"] for spp in (1, 4, 16)] == [width] * 3
    assert tx.render(scene, 16, 12, 3, device=device, adaptive=0.1).stats["packet"] == width
    assert tx.render(scene, 16, 12, 64, device=device, adaptive=0.1).stats["packet"] == width
    assert tx.render(tx.load_scene(tx_scene("bench/globe.toml")), 16, 12, 16, device=device).stats["packet"] == width
    assert tx.render(scene, 16, 12, 16, device=device, shadows=False).stats["packet"] == width


# A child process: the scene rendered at 16 lanes on PoCL, its image's bytes as hex.
_RENDER_16 = r"""
import hashlib, sys
import texray as tx
img = tx.render(tx.load_scene(sys.argv[1]), 24, 16, 4, device="pocl")
assert img.stats["packet"] == 16, img.stats["packet"]
print(hashlib.sha256(img.rgb.tobytes()).hexdigest())
"""


@pytest.mark.parametrize("name", ["textured_meshes", "mixed"])
def test_sixteen_lane_programs_load_again_from_the_driver_cache(tmp_path, name):
    """PoCL's program at 16 lanes, built in one process, loads from PoCL's cache in the next and
    renders the same image: on an AVX2 target with PoCL's AVX-512 library, calls of its 16-lane
    vstore16/vload16/convert_float16 once left a cached program without kernels (and aborted
    code generation; core/builtins.h). Triangles, spheres and quads (mixed), each packet test."""
    from texray.device import devices
    if not any("portable computing language" in d.platform.lower() for d in devices()):
        pytest.skip("no PoCL device")
    env = dict(os.environ, POCL_CACHE_DIR=str(tmp_path / "pocl"), TEXRAY_PACKET="16")
    scene = str(tx_scene(f"bench/{name}.toml"))
    runs = [subprocess.run([sys.executable, "-c", _RENDER_16, scene], env=env, capture_output=True, text=True)
            for _ in range(2)]
    for i, r in enumerate(runs):
        assert r.returncode == 0, f"run {i + 1} (cache {'empty' if i == 0 else 'filled'}):\n{r.stderr[-3000:]}"
    assert list((tmp_path / "pocl").rglob("program.bc")), "PoCL cached no program"
    assert runs[0].stdout.split()[-1] == runs[1].stdout.split()[-1]


def test_a_program_without_kernels_is_a_build_error(rt):
    """A program that builds but holds no kernels (how a cached binary that did not load looked:
    clCreateKernel's INVALID_KERNEL_NAME later) is a BuildError naming the device."""
    from texray.errors import BuildError
    with pytest.raises(BuildError, match=f"on {re.escape(rt.device.name.strip())}.*no kernels"):
        rt.build("/* no kernel */\n", ["-DTX_NO_KERNEL_PROBE=1"])


def test_packet_override_is_checked(monkeypatch):
    monkeypatch.setenv("TEXRAY_PACKET", "12")
    with pytest.raises(DeviceError, match="TEXRAY_PACKET: expected 0, 8 or 16, got '12'"):
        packet_width(Features(), "pocl")
    monkeypatch.setenv("TEXRAY_PACKET", "8")
    assert packet_width(Features(triangles=True, spheres=True), "nvidia") == 8


_STORE_GEOM = r"""
/* A Geom as 17 floats: p, ng, dpdu, dpdv, uv, perr. */
inline void store_geom(const Geom* g, __global float* o)
{
    vstore3(g->p, 0, o); vstore3(g->ng, 0, o + 3); vstore3(g->dpdu, 0, o + 6); vstore3(g->dpdv, 0, o + 9);
    vstore2(g->uv, 0, o + 12); vstore3(g->perr, 0, o + 14);
}
"""


_SPHERE_GEOM_KERNEL = r"""
#include "core/common.h"
#include "core/accurate.h"
#include "geometry/sphere.h"
#include "accel/packet.h"
""" + _STORE_GEOM + r"""
/* Work-item i: rays TX_PACKET i .. as one packet, ray k against sphere sidx[k]: sphere_geom
 * lane by lane (out_s) and sphere_geom_packet over the lanes with a hit (out_p), 17 floats
 * each (p, ng, dpdu, dpdv, uv, perr); hit[k] whether sphere_intersect hit. */
__kernel void sphere_geoms(__global const Sphere* spheres, __global const uint* sidx, __global const float* rays,
                           __global float* out_s, __global float* out_p, __global int* hit, uint n)
{
    uint i = get_global_id(0);
    if (i >= n) return;
    PacketRay pr;
    uint idx[TX_PACKET];
    int act[TX_PACKET];
    float tt[TX_PACKET];
    Geom gs[TX_PACKET], gp[TX_PACKET];
    for (uint j = 0; j < (uint)TX_PACKET; ++j) {
        uint k = TX_PACKET * i + j;
        float3 o = vload3(2 * k, rays), d = vload3(2 * k + 1, rays);
        idx[j] = sidx[k];
        float t = 0.0f;
        act[j] = sphere_intersect(spheres + idx[j], o, d, 0.0f, INFINITY, &t) ? -1 : 0;
        tt[j] = t;
        if (act[j]) sphere_geom(spheres + idx[j], o, d, t, gs + j);
        packet_set_lane(&pr, j, o, d, 0.0f, INFINITY);
    }
    packet_setup(&pr, (pint)(TX_LANES(act)));
    pint m = (pint)(TX_LANES(act));
    if (any(m))
        sphere_geom_packet(spheres, idx, m, pf3(pr.ox, pr.oy, pr.oz), pf3(pr.dx, pr.dy, pr.dz), (pfloat)(TX_LANES(tt)),
                           gp, (GeomLanes*)0);
    for (uint j = 0; j < (uint)TX_PACKET; ++j) {
        uint k = TX_PACKET * i + j;
        hit[k] = act[j];
        if (!act[j]) continue;
        store_geom(gs + j, out_s + 17 * k);
        store_geom(gp + j, out_p + 17 * k);
    }
}
"""


@pytest.mark.parametrize("width", WIDTHS)
def test_packet_sphere_geometry_equals_sphere_geom(rt, rng, width):
    """sphere_geom_packet (geometry/sphere_packet.h: the fused kernel's sphere hits, with its
    own atan2, hypot and unit vector) gives sphere_geom's point, normals, tangents, uv and
    error bound bit for bit, each lane on its own sphere: rotated frames, random rays, rays
    from inside, rays through the poles and onto the phi = 0 seam, grazing rays, a sphere of
    radius 1e-3 at 1e4, one 1e5 from the origin, and radii 2e-14, 1e4 and 1e18."""
    import pyopencl as cl
    from kernel_harness import build_test_program
    from texray.device import layout
    from texray.device.features import compile_options

    def frame():
        q, _ = np.linalg.qr(rng.normal(size=(3, 3)))
        return q[:, 0], q[:, 2]
    spheres = np.zeros(8, layout.SPHERE)
    centres = [(0, 0, 0), (0.3, -0.2, 0.1), (1e4, -2e3, 5e3), (0, 0, 0), (1e5, 1e5, -1e5), (2, 1, -1),
               (1e-13, 0, 0), (0, 0, 0)]
    radii = [1.0, 0.5, 1e-3, 1e4, 3.0, 0.7, 2e-14, 1e18]      # 2e-14: tx_hypot scales up; 1e18: the host's limit
    for i, (c, r) in enumerate(zip(centres, radii)):
        ax, az = ((1, 0, 0), (0, 0, 1)) if i in (0, 3) else frame()
        spheres[i]["center"], spheres[i]["radius"], spheres[i]["axis_x"], spheres[i]["axis_z"] = c, r, ax, az
    n = 4096
    sid = rng.integers(0, len(spheres), n).astype(np.uint32)
    c = np.array(centres, np.float64)[sid]
    r = np.array(radii, np.float64)[sid][:, None]
    az = spheres["axis_z"][sid].astype(np.float64)
    ax = spheres["axis_x"][sid].astype(np.float64)
    u = rng.normal(size=(n, 3))
    u /= np.linalg.norm(u, axis=1, keepdims=True)
    kind = np.arange(n) % 6
    target = c + r * u                                               # random points on the sphere
    target[kind == 1] = (c + r * az * np.where(rng.random((n, 1)) < 0.5, 1, -1))[kind == 1]   # the poles
    target[kind == 2] = (c + r * ax)[kind == 2]                      # the seam, phi = 0
    org = target + r * 4 * rng.normal(size=(n, 3))                    # from outside, any side
    org[kind == 3] = (c + 0.3 * r * rng.normal(size=(n, 3)))[kind == 3]     # from inside: the far root
    tangent = np.cross(u, rng.normal(size=(n, 3)))
    tangent /= np.linalg.norm(tangent, axis=1, keepdims=True)
    graze = c + r * u * (1 - 10.0 ** rng.uniform(-6, -2, (n, 1)))
    org[kind == 4] = (graze - 3 * r * tangent)[kind == 4]
    target[kind == 4] = graze[kind == 4]
    d = target - org
    d /= np.linalg.norm(d, axis=1, keepdims=True)     # unit: |f x d| of |f| = 4e18 and |d| = 4e18 overflows
    rays = np.stack([org, d], axis=1).astype(np.float32)
    opts = {**compile_options(Features(spheres=True, triangles=False)), "TX_PACKET": width}
    k = build_test_program(rt, (), _SPHERE_GEOM_KERNEL, [f"-D{a}={b}" for a, b in opts.items()])
    mf = cl.mem_flags
    ins = [cl.Buffer(rt.context, mf.READ_ONLY | mf.COPY_HOST_PTR, hostbuf=np.ascontiguousarray(a))
           for a in (spheres, sid, rays)]
    out_s, out_p = np.zeros((n, 17), np.float32), np.zeros((n, 17), np.float32)
    hit = np.zeros(n, np.int32)
    bufs = [cl.Buffer(rt.context, mf.WRITE_ONLY, a.nbytes) for a in (out_s, out_p, hit)]
    k.sphere_geoms(rt.queue, (n // width,), None, *ins, *bufs, np.uint32(n // width))
    for a, b in zip((out_s, out_p, hit), bufs):
        cl.enqueue_copy(rt.queue, a, b)
    h = hit != 0
    assert h.mean() > 0.5 and all(h[kind == i].any() for i in range(6)), [h[kind == i].mean() for i in range(6)]
    assert all(h[sid == i].any() for i in range(len(spheres))), str([h[sid == i].mean() for i in range(len(spheres))])
    same = out_s[h].view(np.uint32) == out_p[h].view(np.uint32)
    bad = np.flatnonzero(~same.all(axis=1))
    assert bad.size == 0, f"{bad.size} hits differ, e.g. fields {np.flatnonzero(~same[bad[0]])}: " \
                          f"{out_s[h][bad[0]]} against {out_p[h][bad[0]]}"
    # the poles and the seam were reached: u = 0 at the seam, v in {0, 1} at a pole
    uv = out_s[h][:, 12:14]
    assert (uv[:, 0] == 0).any() and ((uv[:, 1] < 1e-3) | (uv[:, 1] > 1 - 1e-3)).any()


_QUAD_GEOM_KERNEL = r"""
#include "core/common.h"
#include "core/accurate.h"
#include "geometry/quad.h"
#include "accel/packet.h"
""" + _STORE_GEOM + r"""
/* Work-item i: lanes k = TX_PACKET i .. with quad qidx[k] at the parameters (u, v)[k]:
 * quad_geom lane by lane (out_s) and quad_geom_packet (out_p), 17 floats each. */
__kernel void quad_geoms(__global const QuadVerts* quads, __global const QuadShade* qs, __global const uint* qidx,
                         __global const float* params, __global float* out_s, __global float* out_p, uint n)
{
    uint i = get_global_id(0);
    if (i >= n) return;
    uint idx[TX_PACKET];
    float pu[TX_PACKET], pv[TX_PACKET];
    Geom gs[TX_PACKET], gp[TX_PACKET];
    for (uint j = 0; j < (uint)TX_PACKET; ++j) {
        uint k = TX_PACKET * i + j;
        idx[j] = qidx[k];
        pu[j] = params[2 * k]; pv[j] = params[2 * k + 1];
        quad_geom(quads + idx[j], qs + idx[j], (float2)(pu[j], pv[j]), gs + j);
    }
    quad_geom_packet(quads, qs, idx, (pint)(-1), (pfloat)(TX_LANES(pu)), (pfloat)(TX_LANES(pv)), gp, (GeomLanes*)0);
    for (uint j = 0; j < (uint)TX_PACKET; ++j) {
        uint k = TX_PACKET * i + j;
        store_geom(gs + j, out_s + 17 * k);
        store_geom(gp + j, out_p + 17 * k);
    }
}
"""


@pytest.mark.parametrize("width", WIDTHS)
def test_packet_quad_geometry_equals_quad_geom(rt, rng, width):
    """quad_geom_packet (geometry/quad_packet.h: the fused kernel's quad hits) gives quad_geom's
    point, normal, tangents, uv and error bound bit for bit, each lane on its own quad:
    parallelogram, trapezoid, saddle, bow-tie, three collinear corners and four (the normal's
    fallbacks), a rotated and mirrored uv map and a singular one (the tangents' fallback), a
    quad 1e5 from the origin and one 1e-3 across; at random parameters, the corners and edges."""
    import pyopencl as cl
    from kernel_harness import build_test_program
    from texray.device import layout
    from texray.device.features import compile_options
    corners = [
        [(0, 0, 0), (2, 0, 0), (2, 1, 0), (0, 1, 0)],                       # rectangle
        [(0, 0, 0), (3, 0, 0), (2, 1, 0.2), (1, 1, 0.2)],                   # trapezoid
        [(0, 0, 0), (1, 0, 2), (1, 1, 0), (0, 1, 2)],                       # saddle (z the largest)
        [(0, 0, 0), (1, 1, 0), (1, 0, 0), (0, 1, 0)],                       # bow-tie
        [(0, 0, 0), (1, 0, 0), (2, 0, 0), (0, 1, 0)],                       # three collinear
        [(0, 0, 0), (1, 0, 0), (2, 0, 0), (3, 0, 0)],                       # all collinear: +z
        [(1e5, 1e5, 1e5), (1e5 + 1, 1e5, 1e5), (1e5 + 1, 1e5 + 1, 1e5 + 0.5), (1e5, 1e5 + 1, 1e5)],
        [(0, 0, 0), (1e-3, 0, 0), (1e-3, 1e-3, 1e-4), (0, 1e-3, 0)],
        [(0, 0, 0), (0, 1, 0), (2, 0, 0), (1, 1, 0)],                       # a Z: no normal at v = 1/2
    ]
    uvs = [(0, 0, 1, 0, 1, 1, 0, 1), (1, 0, 0, 0, 0, 2, 1, 2), (0.2, 0.1, 0.9, 0.3, 0.7, 1.1, 0.1, 0.8),
           (0, 0, 1, 0, 2, 0, 3, 0),                                          # singular
           (0, 0, 1, 1, 2, 2.00001, 1, 1.00001)]                              # |det| / size 5e-6: below 2^-16
    quads = np.zeros(len(corners) * len(uvs), layout.QUAD_VERTS)
    shade = np.zeros(len(quads), layout.QUAD_SHADE)
    for i, (c, t) in enumerate((c, t) for c in corners for t in uvs):
        quads[i]["p0"], quads[i]["p1"], quads[i]["p2"], quads[i]["p3"] = c
        shade[i]["uv"] = t
    n = 4096
    qid = rng.integers(0, len(quads), n).astype(np.uint32)
    params = rng.random((n, 2)).astype(np.float32)
    params[::5] = rng.integers(0, 2, (len(params[::5]), 2))                      # corners
    params[1::5, 0] = rng.integers(0, 2, len(params[1::5]))                      # edges
    params[2::5, 1] = 0.5                                                        # the Z's fold
    params[3::5] = np.stack([np.ones(len(params[3::5])), 10.0 ** rng.uniform(-9, -5, len(params[3::5]))], 1)
    # (next to the corner p1, where the three-collinear quad's tangents are nearly parallel)
    opts = {**compile_options(Features(quads=True, triangles=False)), "TX_PACKET": width}
    k = build_test_program(rt, (), _QUAD_GEOM_KERNEL, [f"-D{a}={b}" for a, b in opts.items()])
    mf = cl.mem_flags
    ins = [cl.Buffer(rt.context, mf.READ_ONLY | mf.COPY_HOST_PTR, hostbuf=np.ascontiguousarray(a))
           for a in (quads, shade, qid, params)]
    out_s, out_p = np.zeros((n, 17), np.float32), np.zeros((n, 17), np.float32)
    bufs = [cl.Buffer(rt.context, mf.WRITE_ONLY, a.nbytes) for a in (out_s, out_p)]
    k.quad_geoms(rt.queue, (n // width,), None, *ins, *bufs, np.uint32(n // width))
    for a, b in zip((out_s, out_p), bufs):
        cl.enqueue_copy(rt.queue, a, b)
    assert np.isfinite(out_s).all()
    same = out_s.view(np.uint32) == out_p.view(np.uint32)
    bad = np.flatnonzero(~same.all(axis=1))
    assert bad.size == 0, f"{bad.size} lanes differ, e.g. quad {qid[bad[0]]} at {params[bad[0]]}, fields " \
                          f"{np.flatnonzero(~same[bad[0]])}: {out_s[bad[0]]} against {out_p[bad[0]]}"
    # the fallbacks were taken: +z for the collinear quad, tangents = dP/du, dP/dv for the singular uv map
    k_uv = len(uvs)
    assert (out_s[qid // k_uv == 5, 3:6] == (0, 0, 1)).all()
    z = (qid // k_uv == 8) & (params[:, 1] == 0.5)
    assert z.any() and (np.abs(out_s[z, 5]) == 1).all()          # the Z's fold: a diagonal or triangle normal


_TRI_GEOM_KERNEL = r"""
#include "core/common.h"
#include "core/accurate.h"
#include "geometry/triangle.h"
#include "accel/packet.h"
""" + _STORE_GEOM + r"""
/* Work-item i: lanes k = TX_PACKET i .. with triangle tidx[k] at the barycentrics (b1, b2)[k]
 * (lanes with lane[k] = 0 left out of the mask): triangle_geom lane by lane (out_s) and
 * triangle_geom_packet (out_p), 17 floats each; on[0] = TX_TRI_GEOM_PACKET. */
__kernel void tri_geoms(__global const TriVerts* tris, __global const TriShade* ts, __global const float* uvs,
                        __global const uint* tidx, __global const float* bary, __global const int* lane,
                        __global float* out_s, __global float* out_p, __global int* on, uint n)
{
    uint i = get_global_id(0);
    if (i == 0) on[0] = TX_TRI_GEOM_PACKET;
    if (i >= n) return;
#if TX_TRI_GEOM_PACKET
    uint idx[TX_PACKET];
    float b1[TX_PACKET], b2[TX_PACKET];
    int ml[TX_PACKET];
    Geom gs[TX_PACKET], gp[TX_PACKET];
    for (uint j = 0; j < (uint)TX_PACKET; ++j) {
        uint k = TX_PACKET * i + j;
        idx[j] = tidx[k];
        b1[j] = bary[2 * k]; b2[j] = bary[2 * k + 1];
        ml[j] = lane[k] ? -1 : 0;
        triangle_geom(tris + idx[j], ts + idx[j], b1[j], b2[j], uvs, gs + j);
        gp[j] = gs[j];
        gp[j].p.x = -7.0f;                        /* a lane outside the mask must keep this */
    }
    triangle_geom_packet(tris, ts, uvs, idx, PLOAD(ml), PLOAD(b1), PLOAD(b2), gp, (GeomLanes*)0);
    for (uint j = 0; j < (uint)TX_PACKET; ++j) {
        uint k = TX_PACKET * i + j;
        store_geom(gs + j, out_s + 17 * k);
        store_geom(gp + j, out_p + 17 * k);
    }
#endif
}
"""


@pytest.mark.parametrize("width", WIDTHS)
def test_packet_triangle_geometry_equals_triangle_geom(rt, rng, width):
    """triangle_geom_packet (geometry/triangle_packet.h: the fused kernel's triangle hits on
    PoCL) gives triangle_geom's point, normal, tangents, uv and error bound bit for bit, each
    lane on its own triangle: ordinary and sliver triangles, with and without uvs, a mirrored
    and a rotated uv map, singular ones (zero area, below 2^-16: the tangents' fallback),
    edges beyond 2^64 (the cross product overflows: scaled edges), a triangle 1e-20 across
    (|n|^2 underflows: normalize3's scaled path), a degenerate one (zero normal), one 1e5
    from the origin; at random barycentrics, the vertices and edges; lanes outside the mask
    keep their Geom."""
    import pyopencl as cl
    from kernel_harness import build_test_program
    from texray.device import layout
    from texray.device.features import compile_options
    corners = [
        [(0, 0, 0), (1, 0, 0), (0, 1, 0)],
        [(0.3, -1, 2), (2, 0.5, -1), (-1, 2, 0.7)],
        [(0, 0, 0), (1, 0, 1e-4), (2, 1e-3, 0)],                                  # sliver
        [(-3e19, 0, 0), (3e19, 1e19, 0), (0, 3e19, 2e19)],                         # edges beyond 2^64
        [(1e-20, 0, 0), (2e-20, 1e-20, 0), (1e-20, 1e-20, 1e-20)],                 # |n|^2 underflows
        [(0, 0, 0), (1, 1, 1), (2, 2, 2)],                                         # collinear: n = 0
        [(1e5, 1e5, 1e5), (1e5 + 1, 1e5, 1e5 + 0.5), (1e5, 1e5 + 1, 1e5)],
        [(0, 0, 0), (0, 0, 1), (0, 1, 0)],                                         # x largest, any_tangent's other side
    ]
    uv_sets = [None, [(0, 0), (1, 0), (0, 1)], [(1, 0), (0, 0), (1, 2)], [(0.2, 0.1), (0.9, 0.3), (0.4, 1.1)],
               [(0, 0), (1, 1), (2, 2)],                                             # singular
               [(0, 0), (1, 1), (2, 2.00001)]]                                        # |det| / size below 2^-16
    ntri = len(corners) * len(uv_sets)
    tris = np.zeros(ntri, layout.TRI_VERTS)
    shade = np.zeros(ntri, layout.TRI_SHADE)
    uvs = []
    for i, (c, t) in enumerate((c, t) for c in corners for t in uv_sets):
        tris[i]["p0"], tris[i]["p1"], tris[i]["p2"] = c
        if t is not None:
            shade[i]["v"] = [len(uvs), len(uvs) + 1, len(uvs) + 2]
            shade[i]["flags"] = layout.TRI_HAS_UVS
            uvs.extend(t)
    uvs = np.asarray(uvs, np.float32).ravel()
    n = 4096
    tid = rng.integers(0, ntri, n).astype(np.uint32)
    b = rng.random((n, 2))
    b = np.where(b.sum(1, keepdims=True) > 1, 1 - b, b).astype(np.float32)
    b[::7] = np.array([(0, 0), (1, 0), (0, 1)], np.float32)[rng.integers(0, 3, len(b[::7]))]   # vertices
    b[1::7, 1] = 1 - b[1::7, 0]                                                              # the far edge
    b[2::7, 0] = 0                                                                           # an edge
    lane = (rng.random(n) < 0.85).astype(np.int32)
    opts = {**compile_options(Features(triangles=True)), "TX_PACKET": width}
    k = build_test_program(rt, (), _TRI_GEOM_KERNEL, [f"-D{a}={b_}" for a, b_ in opts.items()])
    mf = cl.mem_flags
    ins = [cl.Buffer(rt.context, mf.READ_ONLY | mf.COPY_HOST_PTR, hostbuf=np.ascontiguousarray(a))
           for a in (tris, shade, uvs, tid, b, lane)]
    out_s, out_p = np.zeros((n, 17), np.float32), np.zeros((n, 17), np.float32)
    on = np.zeros(1, np.int32)
    bufs = [cl.Buffer(rt.context, mf.WRITE_ONLY, a.nbytes) for a in (out_s, out_p, on)]
    k.tri_geoms(rt.queue, (n // width,), None, *ins, *bufs, np.uint32(n // width))
    for a, buf in zip((out_s, out_p, on), bufs):
        cl.enqueue_copy(rt.queue, a, buf)
    if not on[0]:
        assert "-DTX_POCL=1" not in rt.device_defines
        pytest.skip("triangle_geom_packet is compiled on PoCL only")
    assert np.isfinite(out_s).all()
    masked = lane == 1
    assert (out_p[~masked, 0] == -7.0).all()
    same = out_s.view(np.uint32) == out_p.view(np.uint32)
    bad = np.flatnonzero(~same.all(axis=1) & masked)
    assert bad.size == 0, f"{bad.size} lanes differ, e.g. triangle {tid[bad[0]]} at {b[bad[0]]}, fields " \
                          f"{np.flatnonzero(~same[bad[0]])}: {out_s[bad[0]]} against {out_p[bad[0]]}"
    # the fallbacks were taken: unit normals from the overflowing and the tiny triangles,
    # a zero normal for the collinear one, unit tangents where the uv map is singular
    k_uv = len(uv_sets)
    for c in (3, 4):
        assert np.allclose(np.linalg.norm(out_s[tid // k_uv == c, 3:6], axis=1), 1, atol=1e-6)
    assert (out_s[tid // k_uv == 5, 3:6] == 0).all()
    sing = (tid % k_uv >= 4) & (tid // k_uv != 5) & masked
    assert sing.any() and np.allclose(np.linalg.norm(out_p[sing, 6:9], axis=1), 1, atol=1e-6)


_LIGHT_KERNEL = r"""
#include "core/common.h"
#include "core/accurate.h"
#include "shading/light.h"
#include "accel/packet.h"
#include "shading/light_packet.h"

/* Work-item i: lanes k = TX_PACKET i .. with the 25 floats in[25 k ..] (p, ns, kd, ks,
 * shininess, v, the light's position and intensity, c), vis[k], the first ms[i] lanes
 * live: c += light_term lane by lane (out_s) and by light_term_packet (out_p), 3 floats
 * each; with step 0 every lane takes lane 0's intensity. on[0] = TX_LIGHT_PACKET. */
__kernel void light_terms(__global const float* in, __global const int* vis_in, __global const uint* ms, uint step,
                          __global float* out_s, __global float* out_p, __global int* on, uint n)
{
    uint i = get_global_id(0);
    if (i == 0) on[0] = TX_LIGHT_PACKET;
    if (i >= n) return;
#if TX_LIGHT_PACKET
    Surface s[TX_PACKET];
    float3 v[TX_PACKET], lpos[TX_PACKET], li[TX_PACKET], cs[TX_PACKET], cp[TX_PACKET];
    uchar vis[TX_PACKET];
    uint m = ms[i];
    for (uint j = 0; j < (uint)TX_PACKET; ++j) {
        __global const float* f = in + 25 * (TX_PACKET * i + j);
        vstore3(vload3(0, f), 0, s[j].p);
        vstore3(vload3(0, f + 3), 0, s[j].ns);
        vstore3(vload3(0, f + 6), 0, s[j].kd);
        vstore3(vload3(0, f + 9), 0, s[j].ks);
        s[j].shininess = f[12];
        s[j].valid = 1u;
        v[j] = vload3(0, f + 13);
        lpos[j] = vload3(0, f + 16);
        li[j] = vload3(0, f + 19);
        cs[j] = cp[j] = vload3(0, f + 22);
        vis[j] = vis_in[TX_PACKET * i + j] != 0;
    }
    for (uint j = 0; j < m; ++j)
        if (vis[j]) cs[j] += light_term(s + j, v[j], lpos[j], li[j * step]);
    light_term_packet(s, v, lpos, li, step, vis, m, cp);
    for (uint j = 0; j < (uint)TX_PACKET; ++j) {
        vstore3(cs[j], 0, out_s + 3 * (TX_PACKET * i + j));
        vstore3(cp[j], 0, out_p + 3 * (TX_PACKET * i + j));
    }
#endif
}
"""


@pytest.mark.parametrize("width", WIDTHS)
@pytest.mark.parametrize("step", [1, 0])
def test_packet_light_terms_equal_light_term(rt, rng, width, step):
    """light_term_packet (shading/light_packet.h: the fused kernel's shading on PoCL) adds
    light_term's value bit for bit to every visible lane and nothing to the others: lights
    from 1e-30 to 1e30 away (|l|^2 under- and overflowing: the scaled path) and at the point
    itself, intensities not finite or at the float range's ends, surfaces lit from behind
    (N.L <= 0), shininess 0 to 1e30 and NaN, negative kd, sums that start at -0; a light per
    lane and one for all (step 0); partial chunks (m < lanes)."""
    import pyopencl as cl
    from kernel_harness import build_test_program
    from texray.device.features import compile_options
    n_items = 512
    n = n_items * width
    unit = lambda a: a / np.linalg.norm(a, axis=1, keepdims=True)
    p = rng.normal(size=(n, 3)) * rng.choice([1.0, 1e-20, 1e20, 1e5], (n, 1), p=[0.7, 0.1, 0.1, 0.1])
    dist = 10.0 ** rng.uniform(-30, 30, (n, 1))
    near = rng.random(n) < 0.5                                        # ordinary distances
    dist[near] = rng.uniform(0.5, 20, (near.sum(), 1))
    lpos = p + unit(rng.normal(size=(n, 3))) * dist
    lpos[::23] = p[::23]                                               # the light at the point
    ns = unit(rng.normal(size=(n, 3)))
    kd = rng.uniform(-0.2, 1, (n, 3))
    ks = rng.uniform(0, 1, (n, 3))
    shin = rng.choice([0.0, 1e-3, 1.0, 25.0, 1e4, 1e30, np.nan], n, p=[0.05, 0.1, 0.2, 0.45, 0.1, 0.05, 0.05])
    v = unit(rng.normal(size=(n, 3)))
    li = rng.uniform(0, 100, (n, 3))
    li[::17] = rng.choice([np.inf, np.nan, 3.4e38, 1e-38, 0.0], (len(li[::17]), 3))
    c = rng.uniform(0, 1, (n, 3))
    c[::5] = -0.0
    data = np.concatenate([p, ns, kd, ks, shin[:, None], v, lpos, li, c], axis=1).astype(np.float32)
    assert data.shape[1] == 25
    vis = (rng.random(n) < 0.8).astype(np.int32)
    ms = rng.integers(1, width + 1, n_items).astype(np.uint32)
    ms[::3] = width
    opts = {**compile_options(Features(triangles=True)), "TX_PACKET": width, "TX_SPECULAR": 1}
    k = build_test_program(rt, (), _LIGHT_KERNEL, [f"-D{a}={b}" for a, b in opts.items()])
    mf = cl.mem_flags
    ins = [cl.Buffer(rt.context, mf.READ_ONLY | mf.COPY_HOST_PTR, hostbuf=np.ascontiguousarray(a))
           for a in (data, vis, ms)]
    out_s, out_p = np.zeros((n, 3), np.float32), np.zeros((n, 3), np.float32)
    on = np.zeros(1, np.int32)
    bufs = [cl.Buffer(rt.context, mf.WRITE_ONLY, a.nbytes) for a in (out_s, out_p, on)]
    k.light_terms(rt.queue, (n_items,), None, *ins, np.uint32(step), *bufs, np.uint32(n_items))
    for a, buf in zip((out_s, out_p, on), bufs):
        cl.enqueue_copy(rt.queue, a, buf)
    if not on[0]:
        assert "-DTX_POCL=1" not in rt.device_defines
        pytest.skip("light_term_packet is compiled on PoCL only")
    same = (out_s.view(np.uint32) == out_p.view(np.uint32)).all(axis=1)
    bad = np.flatnonzero(~same)
    assert bad.size == 0, f"{bad.size} lanes differ, e.g. lane {bad[0]}: inputs {data[bad[0]]}, " \
                          f"{out_s[bad[0]]} against {out_p[bad[0]]}"
    # the cases were met: lanes that added a term, lanes lit from behind or unlit, and
    # distances past the float range's squares
    lane = np.arange(n) % width
    live = (vis == 1) & (lane < np.repeat(ms, width))
    added = live & (out_s != data[:, 22:25]).any(axis=1)
    assert added.sum() > n // 10 and (live & ~added).sum() > n // 10
    d = np.linalg.norm(lpos - p, axis=1)
    assert (added & ((d > 1e20) | (d < 1e-20))).any()


def test_avx512_rule(monkeypatch):
    """TX_AVX512 on PoCL where the CPU has AVX-512: the Tracer and every program but those with
    a curved shape or mesh displaced by the search (the generic program among them), with or
    without shadow rays; TEXRAY_AVX512=0 off, =1 every PoCL program; never another kind or a
    CPU without it."""
    from texray.device import features
    tri = Features(shadows=True, triangles=True, textures=True, vertex_normals=True)
    mix = Features(shadows=True, triangles=True, spheres=True, quads=True, textures=True)
    planet = Features(shadows=True, triangles=False, displacement=True, displaced_curved_search=True)
    flat = Features(shadows=False, triangles=False, quads=True, textures=True)     # no shadow rays
    monkeypatch.delenv("TEXRAY_AVX512", raising=False)
    monkeypatch.setattr(features, "cpu_avx512", lambda: True)
    assert features.avx512(tri, "pocl") and features.avx512(mix, "pocl")
    assert not features.avx512(planet, "pocl") and features.avx512(flat, "pocl")
    assert not features.avx512(dataclasses.replace(planet, shadows=False), "pocl")
    assert not features.avx512(Features.generic(), "pocl")
    assert features.avx512(dataclasses.replace(planet, displaced_curved_search=False), "pocl")
    assert features.avx512(planet, "pocl", rays=True) and features.avx512(flat, "pocl", rays=True)
    assert features.avx512(dataclasses.replace(tri, shadows=False), "pocl")
    assert features.compile_options(tri, "pocl", 16)["TX_AVX512"] == 1
    assert features.compile_options(planet, "pocl", 16)["TX_AVX512"] == 0
    for kind in ("nvidia", "intel-cpu", None):
        assert not features.avx512(tri, kind) and features.compile_options(tri, kind)["TX_AVX512"] == 0
    monkeypatch.setenv("TEXRAY_AVX512", "1")
    assert features.avx512(planet, "pocl") and not features.avx512(mix, "nvidia")
    monkeypatch.setenv("TEXRAY_AVX512", "0")
    assert not features.avx512(tri, "pocl") and not features.avx512(tri, "pocl", rays=True)
    monkeypatch.setenv("TEXRAY_AVX512", "1")
    monkeypatch.setattr(features, "cpu_avx512", lambda: False)
    assert not features.avx512(tri, "pocl") and not features.avx512(mix, "pocl", rays=True)
    monkeypatch.setenv("TEXRAY_AVX512", "yes")
    with pytest.raises(DeviceError, match="TEXRAY_AVX512: expected 0 or 1, got 'yes'"):
        features.avx512(tri, "pocl")


@pytest.mark.parametrize("name, search", [("bench/planet.toml", True), ("displacement/torus_search.toml", True),
                                          ("bench/displaced_wall.toml", False),
                                          ("displacement/curved_maxmip.toml", False), ("bench/globe.toml", False)])
def test_a_curved_shape_or_mesh_displaced_by_the_search_is_a_feature(name, search):
    """Features.displaced_curved_search (the AVX-512 rule's input): a sphere, cylinder or mesh
    displaced by the search; not a quad's search, not maxmip, not an undisplaced scene."""
    from texray.compile import compile_scene
    assert compile_scene(tx.load_scene(tx_scene(name))).features.displaced_curved_search is search


def _need_avx512(device):
    from texray.device import features, runtime
    if runtime(device).kind != "pocl" or not features.cpu_avx512():
        pytest.skip("AVX-512 programs are PoCL's on a CPU with AVX-512")


@pytest.mark.parametrize("name", ["textured_meshes", "mixed"])
def test_avx512_programs_render_the_same_image(device, monkeypatch, name):
    """The program with AVX-512 (kernels/texray.cl TX_AVX512) renders the AVX2 program's image
    bit for bit: triangles alone (its rule; several pixels per work-item at 3 spp, and adaptive
    sampling) and spheres, quads and triangles (forced; 3 spp)."""
    _need_avx512(device)
    scene = tx.load_scene(tx_scene(f"bench/{name}.toml"))
    out = {}
    for flag in ("0", "1"):
        monkeypatch.setenv("TEXRAY_AVX512", flag)
        out[flag] = [tx.render(scene, 40, 28, 3, device=device, seed=2).rgb]
        if name == "textured_meshes":
            out[flag].append(tx.render(scene, 40, 28, 16, device=device, adaptive=0.05).rgb)
    for a, b in zip(out["0"], out["1"]):
        assert a.std() > 0.02 and np.array_equal(a, b)


def test_avx512_tracer_hits_equal_avx2(device, rng, monkeypatch):
    """The Tracer's AVX-512 program finds the AVX2 program's hits and occlusions exactly."""
    _need_avx512(device)
    scene = _soup(rng, 300)
    monkeypatch.delenv("TEXRAY_PACKET", raising=False)
    org = rng.uniform(-2, 2, (4096, 3)).astype(np.float32)
    d = (rng.uniform(-1, 1, (4096, 3)) - 0.3 * org).astype(np.float32)
    got = {}
    for flag in ("0", "1"):
        monkeypatch.setenv("TEXRAY_AVX512", flag)
        tr = Tracer(scene, device)
        assert tr.packet == 8
        got[flag] = (tr.closest(org, d, tmax=10.0), tr.occluded(org, d, tmax=1.0)[0])
    (h0, o0), (h1, o1) = got["0"], got["1"]
    for f in ("t", "b1", "b2", "prim"):
        assert np.array_equal(getattr(h0, f), getattr(h1, f), equal_nan=True), f
    assert (h0.prim >= 0).sum() > 100
    assert np.array_equal(o0, o1) and 0 < o0.sum() < len(o0)


def _scalar_and_packet(rt, source, kernel, features, width, rec, cols):
    """Build ``source`` for ``features`` at TX_PACKET ``width`` and run its ``kernel(in, out_s,
    out_p, n)`` over the records ``rec`` (``width`` per work-item): (out_s, out_p), ``cols``
    floats per record each, NaN where the kernel wrote nothing."""
    import pyopencl as cl
    from kernel_harness import build_test_program
    from texray.device.features import compile_options
    opts = {**compile_options(features), "TX_PACKET": width}
    k = build_test_program(rt, (), source, [f"-D{a}={b}" for a, b in opts.items()])
    n, mf = len(rec), cl.mem_flags
    bi = cl.Buffer(rt.context, mf.READ_ONLY | mf.COPY_HOST_PTR, hostbuf=rec)
    out_s = np.full((n, cols), np.nan, np.float32)
    out_p = out_s.copy()
    bs = cl.Buffer(rt.context, mf.READ_WRITE | mf.COPY_HOST_PTR, hostbuf=out_s)
    bp = cl.Buffer(rt.context, mf.READ_WRITE | mf.COPY_HOST_PTR, hostbuf=out_p)
    getattr(k, kernel)(rt.queue, (n // width,), None, bi, bs, bp, np.uint32(n // width))
    cl.enqueue_copy(rt.queue, out_s, bs)
    cl.enqueue_copy(rt.queue, out_p, bp)
    return out_s, out_p


_SHADOW_ORIGINS_KERNEL = r"""
#include "texray.cl"

/* Work-item i: records TX_PACKET i .. (16 floats each: p, lift, ng, ns, offset, valid's bits) as
 * one chunk of m = TX_PACKET (odd i: TX_PACKET - 3, the lanes past m reading lane m - 1's):
 * shadow_origins_packet (out_p) and shadow_origin lane by lane (out_s), 7 floats each (the
 * origin, the side test's normal, whether valid). */
__kernel void shadow_origins(__global const float* in, __global float* out_s, __global float* out_p, uint n)
{
    uint i = get_global_id(0);
    if (i >= n) return;
    uint m = (i & 1u) ? (uint)TX_PACKET - 3u : (uint)TX_PACKET;
    Surface s[TX_PACKET];
    for (uint j = 0; j < (uint)TX_PACKET; ++j) {
        __global const float* r = in + 16 * (TX_PACKET * i + j);
        for (int c = 0; c < 3; ++c) {
            s[j].p[c] = r[c]; s[j].lift[c] = r[3 + c]; s[j].ng[c] = r[6 + c]; s[j].ns[c] = r[9 + c];
        }
        s[j].offset = r[12];
        s[j].valid = as_uint(r[13]);
    }
    ShadowLanes sl;
    shadow_origins_packet(s, m, &sl);
    float o[7][TX_PACKET];
    PSTORE(sl.o.x, o[0]); PSTORE(sl.o.y, o[1]); PSTORE(sl.o.z, o[2]);
    PSTORE(sl.n.x, o[3]); PSTORE(sl.n.y, o[4]); PSTORE(sl.n.z, o[5]);
    PSTORE(as_pfloat(sl.valid), o[6]);
    for (uint j = 0; j < m; ++j) {
        __global float* a = out_p + 7 * (TX_PACKET * i + j);
        __global float* b = out_s + 7 * (TX_PACKET * i + j);
        for (int c = 0; c < 7; ++c) a[c] = o[c][j];
        int lifted = 0;
        float3 org = shadow_origin(s + j, &lifted);
        float3 nn = lifted ? vload3(0, s[j].ns) : vload3(0, s[j].ng);
        vstore3(org, 0, b); vstore3(nn, 0, b + 3);
        b[6] = as_float(s[j].valid ? -1 : 0);
    }
}
"""


@pytest.mark.parametrize("width", WIDTHS)
def test_packet_shadow_origins_equal_shadow_origin(rt, rng, width):
    """shadow_origins_packet (shading/shadow.h: the fused kernel's shadow origins, with
    accel/packet_vec.h's offset_point and nextafter) gives shadow_origin's origin and side-test
    normal bit for bit in every valid lane: random points and normals, lifts on both sides of
    the lifted test, normal components 0, -0 and NaN, points whose offset lands on 0 and -0,
    denormals, infinities, NaNs, huge offsets, and chunks shorter than the packet."""
    n = 1 << 15
    rec = np.zeros((n, 16), np.float32)
    rec[:, 0:3] = rng.normal(size=(n, 3)) * 10.0 ** rng.uniform(-6, 6, (n, 1))
    off = (10.0 ** rng.uniform(-8, 0, n)).astype(np.float32)
    rec[:, 12] = off
    lift = rng.normal(size=(n, 3)) * (4 * off[:, None] * rng.uniform(0.5, 1.5, (n, 1)) / np.sqrt(3))
    rec[:, 3:6] = np.where(rng.random((n, 1)) < 0.3, 0, lift)
    ng = rng.normal(size=(n, 3))
    ng /= np.linalg.norm(ng, axis=1, keepdims=True)
    rec[:, 6:9] = ng
    rec[:, 9:12] = rng.normal(size=(n, 3))
    kind = np.arange(n) % 8
    z = kind == 1                                             # normal components 0 and -0
    rec[z, 6] = 0.0
    rec[z, 7] = -0.0
    k2 = kind == 2                                            # p + ng * offset lands on 0 or -0 (exact:
    rec[k2, 12] = np.float32(2.0 ** -10)                      # a power of two, no lift)
    rec[k2, 3:6] = 0.0
    rec[k2, 0:3] = -rec[k2, 6:9] * rec[k2, 12:13]
    k3 = kind == 3                                            # special values anywhere
    special = np.float32([0.0, -0.0, np.inf, -np.inf, np.nan, 1e-45, -1e-45, 1e-40, 3.4e38, -3.4e38, 1.0])
    rec[k3, :13] = rng.choice(special, (k3.sum(), 13))
    k4 = kind == 4                                            # random bit patterns
    rec[k4, :13] = rng.integers(0, 1 << 32, (k4.sum(), 13), dtype=np.uint64).astype(np.uint32).view(np.float32)
    rec[kind == 5, 12] = np.float32(1e30)                     # a huge offset
    valid = np.where(rng.random(n) < 0.85, np.uint32(1), np.uint32(0))
    rec[:, 13] = valid.view(np.float32)
    out_s, out_p = _scalar_and_packet(rt, _SHADOW_ORIGINS_KERNEL, "shadow_origins",
                                      Features(quads=True, triangles=False, textures=True), width, rec, 7)
    lane = np.arange(n) % width
    ran = np.where((np.arange(n) // width) % 2 == 1, lane < width - 3, True)
    assert np.array_equal(out_p[ran, 6].view(np.int32), out_s[ran, 6].view(np.int32))
    live = ran & (valid == 1)
    a, b = out_p[live, :6].view(np.uint32), out_s[live, :6].view(np.uint32)
    same = (a == b) | (np.isnan(out_p[live, :6]) & np.isnan(out_s[live, :6]))
    bad = np.flatnonzero(~same.all(axis=1))
    assert bad.size == 0, f"{bad.size} lanes differ, e.g. record {rec[live][bad[0]]!r}: {out_p[live][bad[0]]!r} " \
                          f"against {out_s[live][bad[0]]!r}"
    # the cases happened: lifted and not, steps from 0, infinities, NaNs
    lifted_lane = np.any(out_s[live, 3:6] != rec[live, 6:9], axis=1) & np.all(np.isfinite(rec[live, 6:12]), axis=1)
    assert lifted_lane.sum() > 1000 and (~lifted_lane).sum() > 1000
    o = out_s[live, :3]
    assert (np.abs(o[kind[live] == 2]) == np.float32(1e-45)).any()
    assert np.isinf(o).any() and np.isnan(o).any() and (live.sum() > n // 2)


_LIFT_KERNEL = r"""
#include "texray.cl"

/* Lane j of work-item i: input record TX_PACKET i + j (23 floats: the point p, the corners
 * p0, p1, p2, the vertex normals n0, n1, n2 as stored, b1, b2): terminator_lift with
 * normalize3's unit normals (surface_geometry's call) into out_s, terminator_lift_packet with
 * pf3_normalize3's (surface_packet's) into out_p, 3 floats each. */
__kernel void lifts(__global const float* in, __global float* out_s, __global float* out_p, uint n)
{
    uint i = get_global_id(0);
    if (i >= n) return;
    float c[23][TX_PACKET];
    for (uint j = 0; j < (uint)TX_PACKET; ++j)
        for (int k = 0; k < 23; ++k) c[k][j] = in[23 * (TX_PACKET * i + j) + k];
#define V3(k) pf3(PLOAD(c[k]), PLOAD(c[k + 1]), PLOAD(c[k + 2]))
    pfloat b1 = PLOAD(c[21]), b2 = PLOAD(c[22]);
    pfloat3 l = terminator_lift_packet(V3(0), V3(3), V3(6), V3(9), pf3_normalize3(V3(12)), pf3_normalize3(V3(15)),
                                       pf3_normalize3(V3(18)), 1.0f - b1 - b2, b1, b2);
#undef V3
    float o[3][TX_PACKET];
    PSTORE(l.x, o[0]); PSTORE(l.y, o[1]); PSTORE(l.z, o[2]);
    for (uint j = 0; j < (uint)TX_PACKET; ++j) {
#define S3(k) (float3)(c[k][j], c[k + 1][j], c[k + 2][j])
        float3 ls = terminator_lift(S3(0), S3(3), S3(6), S3(9), normalize3(S3(12)), normalize3(S3(15)),
                                    normalize3(S3(18)), 1.0f - c[21][j] - c[22][j], c[21][j], c[22][j]);
#undef S3
        __global float* a = out_s + 3 * (TX_PACKET * i + j);
        __global float* b = out_p + 3 * (TX_PACKET * i + j);
        a[0] = ls.x; a[1] = ls.y; a[2] = ls.z;
        b[0] = o[0][j]; b[1] = o[1][j]; b[2] = o[2][j];
    }
}
"""


@pytest.mark.parametrize("width", WIDTHS)
def test_packet_terminator_lift_equals_terminator_lift(rt, rng, width):
    """terminator_lift_packet (shading/surface_packet.h: the fused kernel's shadow-ray lift on
    smooth meshes, from pf3_normalize3's unit vertex normals) gives terminator_lift's lift of
    normalize3's normals bit for bit: points on triangles whose normals bend toward and away
    from the point (lifted and not), scales from 1e-6 to 1e6, far from the origin, normals not
    unit (tiny, huge, zero), barycentrics outside [0, 1], special values and random bits."""
    if rt.kind != "pocl":
        pytest.skip("surface packets are PoCL's (shading/surface_packet.h)")
    n = 1 << 15
    rec = np.zeros((n, 23), np.float32)
    scale = 10.0 ** rng.uniform(-6, 6, (n, 1))
    centre = rng.normal(size=(n, 3)) * 10.0 ** rng.uniform(0, 7, (n, 1))
    corners = centre[:, None, :] + rng.normal(size=(n, 3, 3)) * scale[:, None, :]
    face = np.cross(corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0])
    face /= np.linalg.norm(face, axis=1, keepdims=True) + 1e-300
    normals = face[:, None, :] + rng.normal(size=(n, 3, 3)) * 0.4        # bent both ways
    normals *= 10.0 ** rng.uniform(-20, 20, (n, 3, 1))                     # not unit, some huge or tiny
    b = rng.dirichlet((1, 1, 1), n)
    b[::7] = rng.uniform(-0.5, 1.5, (len(b[::7]), 3))                      # outside the triangle
    rec[:, 0:3] = np.einsum("ni,nij->nj", b, corners)
    rec[:, 3:12] = corners.reshape(n, 9)
    rec[:, 12:21] = normals.reshape(n, 9)
    rec[:, 21], rec[:, 22] = b[:, 1], b[:, 2]
    kind = np.arange(n) % 10
    rec[kind == 1, 12:15] = 0.0                                             # a zero normal
    k2 = kind == 2
    special = np.float32([0.0, -0.0, np.inf, -np.inf, np.nan, 1e-45, -1e-45, 1e-40, 3.4e38, -3.4e38, 1.0])
    rec[k2] = rng.choice(special, (k2.sum(), 23))
    k3 = kind == 3
    rec[k3] = rng.integers(0, 1 << 32, (k3.sum(), 23), dtype=np.uint64).astype(np.uint32).view(np.float32)
    out_s, out_p = _scalar_and_packet(rt, _LIFT_KERNEL, "lifts",
                                      Features(triangles=True, vertex_normals=True, textures=True), width, rec, 3)
    same = (out_p.view(np.uint32) == out_s.view(np.uint32)) | (np.isnan(out_p) & np.isnan(out_s))
    bad = np.flatnonzero(~same.all(axis=1))
    assert bad.size == 0, f"{bad.size} lanes differ, e.g. record {rec[bad[0]]!r}: {out_p[bad[0]]!r} " \
                          f"against {out_s[bad[0]]!r}"
    # the cases happened: lifted (a nonzero finite lift) and not, on ordinary records
    plain = kind >= 4
    lifted = np.all(np.isfinite(out_s), axis=1) & np.any(out_s != 0, axis=1)
    assert (lifted & plain).sum() > 3000 and (~lifted & plain).sum() > 3000
    assert np.isnan(out_s).any()


_BEAM_KERNEL = r"""
#include "texray.cl"

/* Work-item i: rays TX_PACKET i .. (8 floats each: org, dir, tmin, tmax) as one packet, every
 * lane active; against the nq wide nodes' boxes of boxes + 24 (i nq + q) .. (lo_x, hi_x, lo_y,
 * hi_y, lo_z, hi_z as float4s of four children): res[4 (i nq + q) + c] = bit 0 the beam test's
 * answer for child c (beam_box4, with the packet's largest tmax), bit 1 whether a lane enters
 * it (box_entry_packet), bit 2 whether the packet has a beam. */
__kernel void beam_boxes(__global const float* rays, __global const float* boxes, __global int* res, uint n, uint nq)
{
    uint i = get_global_id(0);
    if (i >= n) return;
    PacketRay r;
    for (uint j = 0; j < (uint)TX_PACKET; ++j) {
        __global const float* a = rays + 8 * (TX_PACKET * i + j);
        packet_set_lane(&r, j, vload3(0, a), vload3(0, a + 3), a[6], a[7]);
    }
    pint act = (pint)(-1);
    packet_setup(&r, act);
    for (uint q = 0; q < nq; ++q) {
        __global const float4* b = (__global const float4*)(boxes + 24 * (i * nq + q));
        float4 lox = b[0], hix = b[1], loy = b[2], hiy = b[3], loz = b[4], hiz = b[5];
        int4 bh = r.beam ? beam_box4(&r, lox, hix, loy, hiy, loz, hiz, r.bmax.w) : (int4)(-1);
        int bl[4] = { bh.s0, bh.s1, bh.s2, bh.s3 };
        float l[6][4];
        vstore4(lox, 0, l[0]); vstore4(hix, 0, l[1]); vstore4(loy, 0, l[2]);
        vstore4(hiy, 0, l[3]); vstore4(loz, 0, l[4]); vstore4(hiz, 0, l[5]);
        for (int c = 0; c < 4; ++c) {
            pint e = act & (box_entry_packet(&r, l[0][c], l[1][c], l[2][c], l[3][c], l[4][c], l[5][c], r.tmax, act)
                            < INFINITY);
            res[4 * (i * nq + q) + c] = (bl[c] != 0) | (any(e) ? 2 : 0) | (r.beam ? 4 : 0);
        }
    }
}
"""


@pytest.mark.parametrize("width", WIDTHS)
def test_the_beam_test_never_drops_a_box_a_lane_enters(rt, rng, width):
    """beam_box4 (accel/packet.h: the interval-arithmetic test of a packet against a wide
    node's four boxes) answers 0 only for boxes no lane's box_entry_packet enters, on
    packets as the renderer makes them (a pixel's samples' camera rays, shadow rays toward one
    light), packets whose lanes' signs differ along one axis (shadow rays toward two lights)
    and wider ones, at scales 1e-4 to 1e4 and 1e4 from the origin, with intervals
    (tmin > 0, short tmax), against boxes around the rays, boxes whose faces pass exactly
    through points of one lane's ray or with a corner on one (that lane at its decision's edge:
    without the far distances' 1 + 2 gamma(3) the beam drops boxes), flat boxes, boxes
    behind the origins and empty ones; and it does cull (most boxes no lane enters), so the
    traversals skip their lane-by-lane tests. Packets whose lanes' signs differ along every
    axis have no beam."""
    import pyopencl as cl
    from kernel_harness import build_test_program
    from texray.device.features import compile_options
    npk, nq = 2048, 16
    scale = 10.0 ** rng.uniform(-4, 4, (npk, 1, 1))
    centre = rng.normal(size=(npk, 1, 3)) * scale * np.where(rng.random((npk, 1, 1)) < 0.2, 1e4 / scale, 1.0)
    spread = scale * 10.0 ** rng.uniform(-4, -0.5, (npk, 1, 1))
    spread[rng.random(npk) < 0.2] = 0.0                            # one ray in every lane: tight bounds
    org = centre + rng.normal(size=(npk, width, 3)) * spread
    aim = centre + rng.normal(size=(npk, 1, 3)) * scale * 3 + rng.normal(size=(npk, width, 3)) * spread
    d = aim - org
    wide = rng.random(npk) < 0.25                                  # incoherent packets: mixed signs
    d[wide] = rng.normal(size=(wide.sum(), width, 3)) * scale[wide]
    split = ~wide & (rng.random(npk) < 0.25)                       # one axis' signs mixed (two lights)
    d[split, ::2, 0] = -d[split, ::2, 0]
    tmin = np.where(rng.random((npk, width)) < 0.3, rng.uniform(0, 0.5, (npk, width)), 0.0)
    tmax = np.where(rng.random((npk, width)) < 0.5, rng.uniform(0.5, 1.0, (npk, width)), 1.0)
    tmax[rng.random(npk) < 0.2] = np.inf
    rays = np.concatenate([org, d, tmin[..., None], tmax[..., None]], axis=2).astype(np.float32)
    # boxes: around the packet's path, some faces exactly through a lane's ray point
    t = rng.uniform(-0.2, 1.2, (npk, nq, 4, 1))
    lane = rng.integers(0, width, (npk, nq, 4))
    pk = np.arange(npk)[:, None, None]
    p = rays[pk, lane, 0:3] + t * rays[pk, lane, 3:6]
    half = scale[:, :, :, None].reshape(npk, 1, 1, 1) * 10.0 ** rng.uniform(-3, 0, (npk, nq, 4, 3))
    off = rng.normal(size=(npk, nq, 4, 3)) * half * 2
    lo, hi = p + off - half, p + off + half
    edge = rng.random((npk, nq, 4)) < 0.4                          # a face through the lane's point
    ax = rng.integers(0, 3, (npk, nq, 4))
    side = rng.random((npk, nq, 4)) < 0.5
    pe = p.astype(np.float32)
    for a in range(3):
        sel = edge & (ax == a)
        lo[..., a] = np.where(sel & side, pe[..., a], lo[..., a])
        hi[..., a] = np.where(sel & ~side, pe[..., a], hi[..., a])
    lo, hi = np.minimum(lo, hi), np.maximum(lo, hi)
    corner = rng.random((npk, nq, 4)) < 0.3                        # a corner on the lane's point: the
    below = rng.random((npk, nq, 4, 3)) < 0.5                      # ray through it or just past it
    lo = np.where(corner[..., None] & ~below, pe, lo)
    hi = np.where(corner[..., None] & below, pe, hi)
    lo = np.where(corner[..., None] & below, pe - 2 * half, lo)
    hi = np.where(corner[..., None] & ~below, pe + 2 * half, hi)
    flat = rng.random((npk, nq, 4)) < 0.1                          # flat boxes
    hi[..., 1] = np.where(flat, lo[..., 1], hi[..., 1])
    empty = rng.random((npk, nq, 4)) < 0.05
    lo[empty], hi[empty] = np.inf, -np.inf
    boxes = np.stack([lo[..., 0], hi[..., 0], lo[..., 1], hi[..., 1], lo[..., 2], hi[..., 2]], axis=2)
    boxes = np.ascontiguousarray(boxes.astype(np.float32))         # (npk, nq, 6, 4)
    opts = {**compile_options(Features(triangles=True)), "TX_PACKET": width}
    k = build_test_program(rt, (), _BEAM_KERNEL, [f"-D{a}={b}" for a, b in opts.items()])
    mf = cl.mem_flags
    br = cl.Buffer(rt.context, mf.READ_ONLY | mf.COPY_HOST_PTR, hostbuf=rays)
    bb = cl.Buffer(rt.context, mf.READ_ONLY | mf.COPY_HOST_PTR, hostbuf=boxes)
    res = np.zeros(npk * nq * 4, np.int32)
    bo = cl.Buffer(rt.context, mf.WRITE_ONLY, res.nbytes)
    k.beam_boxes(rt.queue, (npk,), None, br, bb, bo, np.uint32(npk), np.uint32(nq))
    cl.enqueue_copy(rt.queue, res, bo)
    res = res.reshape(npk, nq * 4)
    beam, enters, has = (res & 1) != 0, (res & 2) != 0, (res & 4) != 0
    assert has[~wide].mean() > 0.9 and not has[wide].all(), "coherent packets should have a beam"
    assert has[split].mean() > 0.9, "packets with one axis' signs mixed should have a beam"
    dropped = has & ~beam & enters
    assert not dropped.any(), f"{dropped.sum()} boxes a lane enters failed the beam test, e.g. packet " \
                              f"{np.argwhere(dropped)[:3]}"
    missed = has & ~enters
    assert missed.sum() > 1000 and (~beam[missed]).mean() > 0.5, \
        f"the beam culled {(~beam[missed]).mean():.1%} of the {missed.sum()} boxes no lane enters"
    near = has & enters
    assert near.sum() > 1000
