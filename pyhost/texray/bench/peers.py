"""Peers on the same work: Embree (``embreex``) and Mitsuba 3 (``mitsuba``).

Installed with the optional extra ``texray[peers]``. Every function here runs a
peer on exactly the work texray does and says, in the ``notes`` of its result,
which conventions were undone to make the two comparable:

* :func:`available` -- which peers import, their versions, the Mitsuba variant chosen.
* :func:`primary_rays` / :func:`shadow_rays` -- the bench's rays (pixel-centre
  primary rays of a camera; shadow rays from their hits toward a point light).
* :func:`embree_rays` -- Embree's closest-hit and any-hit throughput on those
  rays and mesh, BVH build time, and its agreement with texray's hits.
* :func:`comparable_scene` -- the texray scene both renderers render: ambient 0,
  specular 0 (Mitsuba has no Phong lobe), bump maps differentiated exactly (Mitsuba's
  bumpmap: texray's ``delta="analytic"``).
* :func:`mitsuba_spec` -- a texray :class:`~texray.scene.Scene` as plain numpy
  data in Mitsuba's conventions (pure Python: testable without Mitsuba);
  :func:`mitsuba_scene_dict` turns it into a ``mi.load_dict`` dictionary.
* :func:`mitsuba_render` -- render a scene with Mitsuba's ``direct`` integrator;
  :class:`MitsubaFrames` -- the same scene loaded once, timed frame by frame.
* :func:`compare_images` -- RMSE, mean absolute and relative differences.

Conventions undone (Mitsuba): Lambert's 1/pi (the point lights' intensity is
multiplied by pi, so images compare directly); texture rows (texray's v = 0 is
the image's bottom row, Mitsuba's bitmap puts row 0 at v = 0: bitmaps are given
flipped; the sphere's v = theta/pi is texray's 1 - v: sphere lookups flip v
back); one-sided BSDFs (``twosided``, as texray shades both sides);
background (Mitsuba returns 0 for misses: its alpha composites texray's
background); texray's ambient term and Phong lobe have no Mitsuba equivalent
(both renderers render the scene without them).
"""
from __future__ import annotations

import dataclasses
import math
import os
import time
import warnings
from concurrent.futures import ThreadPoolExecutor

import numpy as np

from ..errors import SceneError
from ..scene import Cylinder, Material, Mesh, Quad, Scene, Sphere, Texture
from ..scene.shape import materials_of
from .suite import median_spread

MITSUBA_VARIANT = "llvm_ad_rgb"
FALLBACK_VARIANT = "scalar_rgb"
MIN_LLVM = 16     # LLVM 15 (Debian 12's default) aborts on spheres: "Cannot select: fmaximum"
LLVM_HINT = ("install the system libLLVM 19 (Debian/Ubuntu: `apt-get install libllvm19`) or point "
             "DRJIT_LIBLLVM_PATH at a libLLVM >= 16")


class PeerMissing(ImportError):
    """A peer package is not installed (``pip install 'texray[peers]'``)."""


class Unsupported(SceneError):
    """A scene feature Mitsuba cannot represent identically (the message names the object)."""


# --------------------------------------------------------------------------- availability

_variant_state = {}


def _import_embree():
    try:
        from embreex import rtcore_scene
        from embreex.mesh_construction import TriangleMesh
    except ImportError as e:
        raise PeerMissing(f"Embree is not installed: pip install embreex (or 'texray[peers]'): {e}") from None
    return rtcore_scene, TriangleMesh


def _import_mitsuba():
    try:
        import drjit
        import mitsuba
    except ImportError as e:
        raise PeerMissing(f"Mitsuba 3 is not installed: pip install mitsuba (or 'texray[peers]'): {e}") from None
    return mitsuba, drjit


def mitsuba_variant(preferred=MITSUBA_VARIANT):
    """Set and return ``(variant, reason)``: ``preferred`` if it loads with a usable libLLVM, else
    ``scalar_rgb`` with a warning saying why (``reason`` is None when the preferred one loaded)."""
    if preferred in _variant_state:
        return _variant_state[preferred]
    mi, dr = _import_mitsuba()
    reason = None
    if preferred.startswith("llvm_"):
        try:
            mi.set_variant(preferred)
            major = dr.detail.llvm_version()[0]
            if major < MIN_LLVM:
                reason = (f"Mitsuba's {preferred} found libLLVM {major}, which aborts on spheres; {LLVM_HINT}")
        except Exception as e:             # drjit raises several kinds when libLLVM is missing
            reason = f"Mitsuba's {preferred} cannot load ({type(e).__name__}: {e}); {LLVM_HINT}"
    else:
        mi.set_variant(preferred)
    if reason:
        warnings.warn(f"{reason}. Falling back to {FALLBACK_VARIANT} (about 11x slower).", RuntimeWarning,
                      stacklevel=2)
        mi.set_variant(FALLBACK_VARIANT)
        chosen = FALLBACK_VARIANT
    else:
        chosen = preferred
    _variant_state[preferred] = (chosen, reason)
    return chosen, reason


def available() -> dict:
    """Which peers import: ``{"embree": {"ok", "version" | "error"}, "mitsuba": {"ok", "version",
    "drjit", "variant", "llvm", "variant_note" | "error"}}``. Sets Mitsuba's variant."""
    out = {}
    try:
        _import_embree()
        from importlib.metadata import version
        out["embree"] = {"ok": True, "version": version("embreex")}
    except Exception as e:       # PeerMissing, or a metadata lookup failing in an odd install
        out["embree"] = {"ok": False, "error": str(e)}
    try:
        mi, dr = _import_mitsuba()
        variant, reason = mitsuba_variant()
        llvm = None
        if variant.startswith("llvm_"):
            llvm = ".".join(map(str, dr.detail.llvm_version()))
        out["mitsuba"] = {"ok": True, "version": mi.__version__, "drjit": dr.__version__, "variant": variant,
                          "llvm": llvm, "variant_note": reason}
    except PeerMissing as e:
        out["mitsuba"] = {"ok": False, "error": str(e)}
    return out


# --------------------------------------------------------------------------- rays

def primary_rays(camera, size):
    """(origins, dirs) float32 (size^2, 3) of pixel-centre rays of a square ``size`` x ``size``
    image (row 0 at the top), directions unnormalized as texray's raygen makes them."""
    eye, fwd, right, up = camera.basis(1.0)
    px = (np.arange(size) + 0.5) / size * 2 - 1
    x, y = np.meshgrid(px, -px)
    dirs = (fwd + x[..., None] * right + y[..., None] * up).reshape(-1, 3).astype(np.float32)
    org = np.ascontiguousarray(np.broadcast_to(eye.astype(np.float32), dirs.shape))
    return org, dirs


def shadow_rays(origins, dirs, t, hit, light_position, offset=1e-4):
    """(origins, dirs) float32 of shadow rays from the hit points toward a point light, for
    t in (0, 1). The origin moves ``offset`` outward along p/|p| (the bench mesh is star-shaped
    about 0), as ``texray bench`` does."""
    p = origins[hit] + t[hit, None] * dirs[hit]
    n = p / np.linalg.norm(p, axis=1, keepdims=True)
    so = (p + offset * n).astype(np.float32)
    sd = (np.asarray(light_position, np.float32) - so).astype(np.float32)
    return so, sd


def texray_face_ids(compiled, hits):
    """Face index (into the mesh's own ``faces``) of each texray hit, -1 for a miss, for a
    single-mesh scene (``Hits.prim`` indexes the compiled triangles in BVH leaf order)."""
    prim = np.asarray(hits.prim)
    out = np.full(len(prim), -1, np.int64)
    hit = prim >= 0
    out[hit] = compiled.tri_shade["prim"][prim[hit]]
    return out


# --------------------------------------------------------------------------- Embree

def _chunks(n, k):
    edges = np.linspace(0, n, k + 1).astype(int)
    return [slice(a, b) for a, b in zip(edges[:-1], edges[1:]) if b > a]


def embree_rays(positions, faces, origins, dirs, shadow_origins=None, shadow_dirs=None, repeat=5,
                threads=None, texray_hits=None, texray_occluded=None) -> dict:
    """Embree 4 (embreex) on the given mesh and rays.

    Primary rays: closest hit, t in [0, inf). Shadow rays: any hit with t in [0, 1] (dirs reach the
    light at t = 1). Throughputs are Mrays/s, median/min/max over ``repeat`` runs after one warm-up,
    wall clock around ``scene.run`` (embreex traces one ray at a time and releases the GIL: rays
    are split over ``threads`` Python threads, default ``os.cpu_count()``).

    ``texray_hits``: optional ``(t, face)`` arrays of texray's closest hits on the same rays
    (face = index into ``faces``, -1 for a miss; see :func:`texray_face_ids`): adds the fraction
    of rays whose hit/miss and face agree and the relative t difference where both hit the same
    face. ``texray_occluded``: optional bool array for the shadow rays: adds their agreement.
    """
    rtcs, TriangleMesh = _import_embree()
    threads = max(1, int(threads or os.cpu_count() or 1))
    v = np.ascontiguousarray(positions, np.float32)
    f = np.ascontiguousarray(faces, np.int32)
    origins, dirs = np.ascontiguousarray(origins, np.float32), np.ascontiguousarray(dirs, np.float32)

    builds, scene = [], None
    probe_o, probe_d = origins[:1], dirs[:1]
    for _ in range(max(1, min(repeat, 3))):
        t0 = time.perf_counter()
        scene = rtcs.EmbreeScene()
        TriangleMesh(scene, v, f)
        scene.run(probe_o, probe_d, query="OCCLUDED")     # Embree builds the BVH on first use (commit)
        builds.append(time.perf_counter() - t0)

    pool = ThreadPoolExecutor(threads) if threads > 1 else None

    def run(o, d, **kw):
        if pool is None:
            return [scene.run(o, d, **kw)]
        parts = _chunks(len(o), threads)
        return list(pool.map(lambda s: scene.run(o[s], d[s], **({**kw, "dists": kw["dists"][s]}
                                                               if "dists" in kw else kw)), parts))

    try:
        primary, res = [], None
        for i in range(repeat + 1):
            t0 = time.perf_counter()
            res = run(origins, dirs, output=1)
            dt = time.perf_counter() - t0
            if i:
                primary.append(len(origins) / dt * 1e-6)
        tfar = np.concatenate([r["tfar"] for r in res])
        prim = np.concatenate([r["primID"] for r in res]).astype(np.int64)
        prim[prim < 0] = -1
        out = {"peer": "embree", "threads": threads, "triangles": int(len(f)), "rays": int(len(origins)),
               "build_s": median_spread(builds), "hit_fraction": float((prim >= 0).mean()),
               "primary_mrays_s": median_spread(primary),
               "notes": ["same float32 mesh and rays as texray; Embree times are wall clock around "
                         "embreex's scene.run (numpy in/out included), texray's are device kernel time",
                         f"rays split over {threads} Python thread(s); embreex traces one ray at a time"]}
        if texray_hits is not None:
            t_ours, face_ours = (np.asarray(a) for a in texray_hits)
            same = face_ours == prim
            both = same & (prim >= 0)
            rel = np.abs(tfar[both] - t_ours[both]) / np.maximum(np.abs(t_ours[both]), 1e-30)
            out["agreement"] = {"hit_face_agree": float(same.mean()),
                                "hit_miss_agree": float(((face_ours >= 0) == (prim >= 0)).mean()),
                                "t_rel_diff_median": float(np.median(rel)) if rel.size else 0.0,
                                "t_rel_diff_max": float(rel.max()) if rel.size else 0.0}
        if shadow_origins is not None:
            so = np.ascontiguousarray(shadow_origins, np.float32)
            sd = np.ascontiguousarray(shadow_dirs, np.float32)
            ones = np.ones(len(so), np.float32)
            shadow, occ = [], None
            for i in range(repeat + 1):
                t0 = time.perf_counter()
                occ = run(so, sd, dists=ones, query="OCCLUDED")
                dt = time.perf_counter() - t0
                if i:
                    shadow.append(len(so) / dt * 1e-6)
            occluded = np.concatenate(occ) >= 0
            out.update({"shadow_rays": int(len(so)), "shadow_occluded_fraction": float(occluded.mean()),
                        "shadow_mrays_s": median_spread(shadow)})
            if texray_occluded is not None:
                out.setdefault("agreement", {})["shadow_agree"] = float(
                    (np.asarray(texray_occluded, bool) == occluded).mean())
    finally:
        if pool is not None:
            pool.shutdown()
    return out


# --------------------------------------------------------------------------- scene conversion

def comparable_scene(scene: Scene):
    """(scene, notes): a copy of ``scene`` that both texray and Mitsuba render the same way:
    ambient 0 (texray's unshadowed ambient kd has no Mitsuba counterpart), specular 0 (texray's
    Phong (R.V)^n lobe has none either) and every bump map with ``delta="analytic"``, the
    exact gradient of the bilinear interpolant, which is what Mitsuba's ``bumpmap``
    computes (texray's default, central differences one texel apart, reads four bilinear
    lookups to Mitsuba's one: not the same work, nor the same normal). Objects, textures
    and lights are shared, not copied."""
    notes = []
    if np.any(np.asarray(scene.ambient, float) != 0):
        notes.append(f"ambient {tuple(scene.ambient)} set to 0 in both renders")
    mats, objects, dropped, exact = {}, [], 0, 0
    def without_specular(m):
        nonlocal dropped, exact
        if id(m) not in mats:
            _, ks, _ = m.validate()
            fields = {}
            if np.any(ks > 0):
                dropped += 1
                fields["specular"] = 0.0
                if getattr(m, "shininess_map", None) is not None:
                    fields["shininess_map"] = None
            bump = getattr(m, "bump", None)
            if bump is not None and bump.delta != "analytic":
                exact += 1
                fields["bump"] = dataclasses.replace(bump, delta="analytic")
            mats[id(m)] = dataclasses.replace(m, **fields) if fields else m
        return mats[id(m)]

    for obj in scene.objects:
        new = [without_specular(m) for m in materials_of(obj)]
        objects.append(dataclasses.replace(obj, material=new if isinstance(obj.material, (list, tuple)) else new[0]))
    if dropped:
        notes.append(f"specular set to 0 in {dropped} material(s) in both renders (Mitsuba has no Phong lobe)")
    if exact:
        notes.append(f"bump delta set to 'analytic' in {exact} material(s) in both renders (Mitsuba's bumpmap "
                     "differentiates the bilinear height field exactly)")
    out = dataclasses.replace(scene, ambient=(0.0, 0.0, 0.0), objects=objects)
    if hasattr(scene, "render_settings"):
        out.render_settings = scene.render_settings
    return out, notes


def camera_to_world(camera, aspect=1.0):
    """Mitsuba's perspective ``to_world`` (4x4 float64) for a texray camera: columns
    (left, up, forward, eye), Mitsuba's camera space being +x left, +y up, +z forward."""
    eye, fwd, right, up = camera.basis(aspect)
    m = np.eye(4)
    m[:3, 0] = -right / np.linalg.norm(right)
    m[:3, 1] = up / np.linalg.norm(up)
    m[:3, 2] = fwd
    m[:3, 3] = eye
    return m


FLIP_V = np.array([[1.0, 0.0, 0.0], [0.0, -1.0, 1.0], [0.0, 0.0, 1.0]])   # (u, v) -> (u, 1 - v)


def _uv_matrix(texture):
    """texray's UV transform of a texture as a 3x3 affine matrix (identity if none)."""
    m = np.eye(3)
    if texture.uv_transform is not None:
        m[:2] = texture.uv_transform.matrix()
    return m


def _texels(texture, kind):
    """(H, W, 4) float32 values of a texture as texray's device reads them in a role: ``"colour"``
    (sRGB decoded) or ``"data"`` (stored values)."""
    if kind == "data" and hasattr(texture, "levels"):
        return texture.levels("data", mip=False)[0]
    return texture.rgba


def texture_spec(texture: Texture, scale=(1.0, 1.0, 1.0), channels=3, flip_v=False, kind="colour"):
    """A texray texture as a Mitsuba bitmap: rows flipped (Mitsuba's row 0 is v = 0, texray's v = 0
    is the bottom row), colour channels times ``scale`` (a tint: bilinear filtering is linear, so this
    is exact), raw (values as texray's device reads them for the role ``kind``), same filter
    (trilinear has no Mitsuba counterpart: bilinear, noted) and wrap mode, and ``to_uv`` = texray's
    UV transform, after (u, v) -> (u, 1 - v) when ``flip_v`` (the sphere's Mitsuba v is texray's 1 - v)."""
    px = _texels(texture, kind)[::-1, :, :channels].astype(np.float32)
    if channels == 3:
        px = px * np.asarray(scale, np.float32)
    filt = getattr(texture, "filter", "bilinear")
    to_uv = _uv_matrix(texture) @ (FLIP_V if flip_v else np.eye(3))
    return {"bitmap": np.ascontiguousarray(px), "wrap_mode": texture.wrap,
            "filter_type": "nearest" if filt == "nearest" else "bilinear",
            "trilinear_as_bilinear": filt == "trilinear", "raw": True, "to_uv": to_uv}


def bump_spec(material, flip_v=False):
    """The material's bump map as Mitsuba ``bumpmap`` data, or None. Duck-typed on
    ``material.bump`` with ``.texture`` (a Texture), ``.height`` (world units per texture unit) and
    ``.delta`` (texray's finite-difference step; Mitsuba differentiates the bilinear patch
    exactly, so it is not used). Height is the texture's first channel; Mitsuba bumps along the
    outward normal, ``scale`` = height; its shadowing term and normal flipping are off."""
    bump = getattr(material, "bump", None)
    if bump is None:
        return None
    tex = texture_spec(bump.texture, channels=1, flip_v=flip_v, kind="data")
    return {"texture": tex, "scale": float(bump.height), "use_shadowing_function": False,
            "flip_invalid_normals": False, "delta_ignored": getattr(bump, "delta", None)}


def material_spec(material: Material, flip_v=False, where=""):
    """{"reflectance": RGB array or texture_spec, "bump": bump_spec or None}: texray's kd (N.L) with
    no 1/pi becomes Mitsuba's two-sided ``diffuse`` (kd/pi: the lights carry the pi)."""
    kd, _, _ = material.validate()
    for role in ("label", "normal_map"):
        if getattr(material, role, None) is not None:
            raise Unsupported(f"{where}material.{role}: not converted to Mitsuba")
    if isinstance(material.diffuse, Texture):
        refl = texture_spec(material.diffuse, scale=kd, flip_v=flip_v)
    else:
        refl = kd.astype(np.float64)
    return {"reflectance": refl, "bump": bump_spec(material, flip_v)}


def _frame_matrix(x, z, origin, scales):
    m = np.eye(4)
    y = np.cross(z, x)
    m[:3, 0], m[:3, 1], m[:3, 2] = x * scales[0], y * scales[1], z * scales[2]
    m[:3, 3] = origin
    return m


def shape_spec(obj):
    """One texray object as Mitsuba shape data (world space), or raises :class:`Unsupported`."""
    where = f"{obj.name}: "
    if getattr(obj, "mapping", None) is not None:
        raise Unsupported(f"{where}mapping: projection mappings have no Mitsuba equivalent")
    if isinstance(obj, Mesh):
        if len(obj.materials) > 1:
            raise Unsupported(f"{where}material: {len(obj.materials)} materials on one mesh are not converted")
        p, n = obj.world()
        return {"kind": "mesh", "name": obj.name, "positions": p, "faces": obj.faces,
                "uvs": None if obj.uvs is None else np.asarray(obj.uvs, np.float64), "normals": n,
                "material": material_spec(obj.materials[0], where=where)}
    if isinstance(obj, Sphere):
        c, r, x, z = obj.world()
        # Mitsuba: uv = (phi/2pi, theta/pi) in its to_world frame; texray: (phi/2pi, 1 - theta/pi)
        return {"kind": "sphere", "name": obj.name, "to_world": _frame_matrix(x, z, c, (r, r, r)),
                "material": material_spec(obj.material, flip_v=True, where=where)}
    if isinstance(obj, Cylinder):
        o, r, x, z, (z0, z1), (t0, t1) = obj.world()
        if not math.isclose(t1 - t0, 2 * math.pi, rel_tol=1e-9):
            raise Unsupported(f"{where}theta_range: Mitsuba's cylinder is a full turn; "
                              f"{np.degrees(t0):g}..{np.degrees(t1):g} degrees is not")
        y = np.cross(z, x)
        xr = math.cos(t0) * x + math.sin(t0) * y        # Mitsuba's phi = 0 at texray's theta_min
        # Mitsuba: open, local z in [0, 1], uv = (phi/2pi, z): texray's uv for a full turn
        return {"kind": "cylinder", "name": obj.name, "to_world": _frame_matrix(xr, z, o + z0 * z, (r, r, z1 - z0)),
                "material": material_spec(obj.material, where=where)}
    if isinstance(obj, Quad):
        p, uv = obj.world()
        note = None
        if not (np.allclose(p[0] + p[2], p[1] + p[3], atol=1e-9 * np.abs(p).max())
                and np.allclose(uv[0] + uv[2], uv[1] + uv[3], atol=1e-12)):
            note = (f"{obj.name}: not a parallelogram (in position or uv): two triangles approximate "
                    "texray's bilinear patch")
        return {"kind": "mesh", "name": obj.name, "positions": p, "faces": np.array([[0, 1, 2], [0, 2, 3]]),
                "uvs": uv, "normals": None, "material": material_spec(obj.material, where=where), "note": note}
    raise Unsupported(f"{where}unknown object type {type(obj).__name__}")


def mitsuba_spec(scene: Scene, width, height, spp=16, seed=0, sampler="multijitter") -> dict:
    """The Mitsuba 3 equivalent of ``scene`` as plain numpy data (no Mitsuba import):
    sensor (to_world, fov, fov_axis "y", film size, box filter), integrator ``direct`` with one
    emitter sample and no BSDF sample, point lights with intensity times pi, shapes, background
    (composited through the film's alpha) and ``notes``. Render ``comparable_scene(scene)`` with
    texray to compare (ambient and specular are not converted). ``sampler="centre"``: one sample
    at each pixel centre (Mitsuba's unjittered stratified sampler; texray's ``jitter=False``)."""
    notes = ["Lambert: Mitsuba's diffuse is kd/pi; point-light intensities multiplied by pi",
             "bitmaps given bottom row first (texray v = 0 is the image's bottom row, Mitsuba's row 0 "
             "is v = 0); spheres flip v (Mitsuba v = theta/pi = texray 1 - v)",
             "BSDFs wrapped in twosided (texray shades both sides)",
             "background composited through Mitsuba's alpha: rgb + (1 - alpha) * background",
             "direct integrator, emitter_samples=1, bsdf_samples=0: with k lights Mitsuba samples one "
             "light per camera sample (weight k), texray evaluates every light (upstream issue #1861 "
             "makes emitter_samples=k wrong with several lights)",
             f"pixel samples: Mitsuba '{sampler}' vs texray's correlated multi-jitter, box filter both"]
    if np.any(np.asarray(scene.ambient, float) != 0):
        notes.append("scene ambient is not converted (render comparable_scene(scene) with texray)")
    shapes = []
    for obj in scene.objects:
        s = shape_spec(obj)
        if s.get("note"):
            notes.append(s["note"])
        if any(np.any(m.validate()[1] > 0) for m in materials_of(obj)):
            notes.append(f"{obj.name}: specular lobe not converted")
        refl = s["material"]["reflectance"]
        if isinstance(refl, dict) and refl["trilinear_as_bilinear"]:
            notes.append(f"{obj.name}: trilinear (MIP-mapped) texture rendered bilinear by Mitsuba")
        if s["material"]["bump"] is not None:
            notes.append(f"{obj.name}: bump as Mitsuba bumpmap (scale = height, exact bilinear gradient = "
                         "texray's delta='analytic', no shadowing function, no normal flipping"
                         + ("" if s['material']['bump']['delta_ignored'] == "analytic" else
                            f"; texray's delta={s['material']['bump']['delta_ignored']!r} is not converted") + ")")
        shapes.append(s)
    lights = []
    for light in scene.lights:
        pos, inten = light.validate()
        lights.append({"position": pos, "intensity": inten * math.pi})
    return {"sensor": {"to_world": camera_to_world(scene.camera, width / height),
                       "fov": float(scene.camera.fov_y), "fov_axis": "y", "width": int(width),
                       "height": int(height), "rfilter": "box"},
            "sampler": ({"type": "stratified", "sample_count": 1, "jitter": False, "seed": int(seed)}
                        if sampler == "centre" else
                        {"type": sampler, "sample_count": int(spp), "seed": int(seed)}),
            "integrator": {"type": "direct", "emitter_samples": 1, "bsdf_samples": 0},
            "lights": lights, "shapes": shapes,
            "background": np.asarray(scene.background, np.float64), "notes": notes}


def _bitmap_dict(mi, t, one_channel=False):
    m = t["to_uv"]
    to_uv = mi.ScalarTransform4f([[m[0, 0], m[0, 1], 0, m[0, 2]], [m[1, 0], m[1, 1], 0, m[1, 2]],
                                  [0, 0, 1, 0], [0, 0, 0, 1]])
    bmp = mi.Bitmap(t["bitmap"], pixel_format=mi.Bitmap.PixelFormat.Y if one_channel
                    else mi.Bitmap.PixelFormat.RGB)
    return {"type": "bitmap", "bitmap": bmp, "raw": t["raw"], "filter_type": t["filter_type"],
            "wrap_mode": t["wrap_mode"], "to_uv": to_uv}


def _bsdf_dict(mi, mat):
    r = mat["reflectance"]
    refl = _bitmap_dict(mi, r) if isinstance(r, dict) else {"type": "rgb", "value": [float(c) for c in r]}
    bsdf = {"type": "diffuse", "reflectance": refl}
    b = mat["bump"]
    if b is not None:
        bsdf = {"type": "bumpmap", "arbitrary": _bitmap_dict(mi, b["texture"], one_channel=True),
                "scale": b["scale"], "use_shadowing_function": b["use_shadowing_function"],
                "flip_invalid_normals": b["flip_invalid_normals"], "bsdf": bsdf}
    return {"type": "twosided", "material": bsdf}


def _mesh(mi, s, bsdf):
    props = mi.Properties()
    props["bsdf"] = mi.load_dict(bsdf)
    p = np.asarray(s["positions"], np.float32)
    f = np.asarray(s["faces"], np.uint32)
    mesh = mi.Mesh(s["name"], len(p), len(f), props=props, has_vertex_normals=s["normals"] is not None,
                   has_vertex_texcoords=s["uvs"] is not None)
    params = mi.traverse(mesh)

    def put(key, a):
        # the buffer's own type: mi.Float is an array in the llvm variants but a Python float
        # in scalar_rgb (the fallback without a usable libLLVM), whose buffers are ArrayXf
        params[key] = type(params[key])(np.ravel(a))

    put("vertex_positions", p)
    put("faces", f)
    if s["normals"] is not None:
        put("vertex_normals", np.asarray(s["normals"], np.float32))
    if s["uvs"] is not None:
        put("vertex_texcoords", np.asarray(s["uvs"], np.float32))
    params.update()
    return mesh


def mitsuba_scene_dict(spec) -> dict:
    """A ``mi.load_dict`` dictionary from :func:`mitsuba_spec` (Mitsuba's variant must be set)."""
    mi, _ = _import_mitsuba()
    se = spec["sensor"]
    d = {"type": "scene",
         "integrator": dict(spec["integrator"]),
         "sensor": {"type": "perspective", "to_world": mi.ScalarTransform4f(se["to_world"].tolist()),
                    "fov": se["fov"], "fov_axis": se["fov_axis"],
                    "sampler": dict(spec["sampler"]),
                    "film": {"type": "hdrfilm", "width": se["width"], "height": se["height"],
                             "pixel_format": "rgba", "component_format": "float32",
                             "sample_border": False, "rfilter": {"type": se["rfilter"]}}}}
    for i, light in enumerate(spec["lights"]):
        d[f"light_{i}"] = {"type": "point", "position": [float(c) for c in light["position"]],
                           "intensity": {"type": "rgb", "value": [float(c) for c in light["intensity"]]}}
    for i, s in enumerate(spec["shapes"]):
        bsdf = _bsdf_dict(mi, s["material"])
        if s["kind"] == "mesh":
            d[f"shape_{i}"] = _mesh(mi, s, bsdf)
        else:
            d[f"shape_{i}"] = {"type": s["kind"], "to_world": mi.ScalarTransform4f(s["to_world"].tolist()),
                               "bsdf": bsdf}
    return d


class MitsubaFrames:
    """A scene loaded into Mitsuba once, rendered frame by frame on demand: the bench times its
    frames between texray's (:func:`texray.bench.compare_peers.frames`: one frame of each
    renderer per round), so that a change of the shared machine's load falls on both and the
    ratio of one run is measured under one load, not texray's frames in one minute and
    Mitsuba's in the next.

    ``load_s``: scene conversion + ``mi.load_dict`` (BVH build and texture upload);
    ``first_render_s``: the first frame (JIT compilation, or its disk cache); ``rgb``: the last
    frame, float32 (H, W, 3), linear, background composited, directly comparable with texray's
    render of :func:`comparable_scene` ``(scene)``; ``notes``: the equal-work conventions.
    """

    def __init__(self, scene: Scene, width, height, spp, seed=0, variant=MITSUBA_VARIANT,
                 sampler="multijitter"):
        self._mi, _ = _import_mitsuba()
        self.variant, self.variant_note = mitsuba_variant(variant)
        self.width, self.height, self.spp, self.seed = width, height, spp, seed
        self._spec = mitsuba_spec(scene, width, height, spp, seed, sampler)
        self.notes = self._spec["notes"]
        t0 = time.perf_counter()
        self._scene = self._mi.load_dict(mitsuba_scene_dict(self._spec))
        self.load_s = time.perf_counter() - t0
        self.first_render_s = self.frame()

    def frame(self) -> float:
        """Render one frame (the same seed: the same image each time); its wall-clock seconds."""
        t = time.perf_counter()
        img = np.array(self._mi.render(self._scene, spp=self.spp, seed=self.seed), dtype=np.float32)  # evaluated
        dt = time.perf_counter() - t
        rgb = img[..., :3] + (1.0 - img[..., 3:4]) * self._spec["background"].astype(np.float32)
        self.rgb = np.ascontiguousarray(rgb, dtype=np.float32)
        return dt

    def stats(self, times) -> dict:
        """The stats dict of :func:`mitsuba_render` for frames that took ``times`` seconds."""
        frame = median_spread(times) if times else None
        return {"peer": "mitsuba", "variant": self.variant, "variant_note": self.variant_note,
                "version": self._mi.__version__, "width": self.width, "height": self.height, "spp": self.spp,
                "load_s": self.load_s, "first_render_s": self.first_render_s, "render_s": frame,
                "msamples_s": self.width * self.height * self.spp / frame["median"] * 1e-6 if frame else None,
                "notes": self.notes}


def mitsuba_render(scene: Scene, width, height, spp, seed=0, repeat=1, variant=MITSUBA_VARIANT,
                   sampler="multijitter"):
    """Render ``scene`` with Mitsuba 3 (``direct`` integrator, hard shadows) at ``spp`` samples.

    Returns ``(rgb, stats)``: rgb float32 (H, W, 3), linear, background composited, directly
    comparable with texray's render of :func:`comparable_scene` ``(scene)``. stats: variant,
    ``load_s`` (scene conversion + ``mi.load_dict``: BVH build and texture upload), ``first_render_s``
    (includes JIT compilation, or its disk cache), ``render_s`` (median/min/max over ``repeat``
    further renders), ``msamples_s`` and the equal-work ``notes`` (:class:`MitsubaFrames`).
    """
    m = MitsubaFrames(scene, width, height, spp, seed, variant, sampler)
    times = [m.frame() for _ in range(repeat)]
    return m.rgb, m.stats(times)


# --------------------------------------------------------------------------- images

def compare_images(ours, theirs, threshold=0.05) -> dict:
    """Differences of two linear RGB images (H, W, 3) rendered after undoing conventions:
    ``rmse``, ``mean_abs``, ``rel_mean_diff`` (mean(theirs - ours) / mean(ours), the brightness
    bias), ``rel_mean_abs`` (mean |theirs - ours| / mean(ours)), ``frac_pixels_over`` (pixels whose
    largest channel difference exceeds ``threshold``) and ``psnr_db`` (peak = ours' max)."""
    a = np.asarray(ours, np.float64)
    b = np.asarray(theirs, np.float64)
    if a.shape != b.shape:
        raise ValueError(f"compare_images: shapes differ: {a.shape} vs {b.shape}")
    d = b - a
    rmse = float(np.sqrt(np.mean(d * d)))
    mean = float(np.mean(a))
    peak = float(a.max()) if a.size else 0.0
    return {"rmse": rmse, "mean_abs": float(np.mean(np.abs(d))),
            "rel_mean_diff": float(np.mean(d)) / mean if mean else float("nan"),
            "rel_mean_abs": float(np.mean(np.abs(d))) / mean if mean else float("nan"),
            "frac_pixels_over": float(np.mean(np.abs(d).max(axis=-1) > threshold)),
            "threshold": threshold,
            "psnr_db": float(20 * np.log10(peak / rmse)) if rmse > 0 and peak > 0 else float("inf")}
