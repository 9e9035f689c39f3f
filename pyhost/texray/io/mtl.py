"""Wavefront MTL material libraries as texray Materials.

trimesh reads an OBJ's geometry and groups its faces by ``usemtl``, but keeps only a
material's ``Kd``, ``Ks``, ``Ns`` and ``map_Kd`` (decoded with Pillow, which texray does not
use); this module reads the library itself so that every statement texray has a use for
counts, its textures are read by OpenImageIO like every other texture, and a missing or
unreadable texture is an error naming the OBJ, the material and the path.

The rule (also in the README, "Materials from mesh files"):

=============================  =====================================================
``Kd``, ``map_Kd``             diffuse: the texture (sRGB) times ``Kd`` as its tint, else ``Kd``
``Ks``, ``map_Ks``             specular ks (``map_Ks`` times ``Ks``, baked into one texture)
``Ns``, ``map_Ns``             shininess n (``map_Ns``: n = Ns x map, texray's shininess_map)
``illum 0`` / ``illum 1``      no highlight: ks = 0 (``illum 2`` and above keep ``Ks``)
``bump``/``map_Bump`` ``-bm``  a Blinn bump: height = 0.01 x bm world units per texel value 1
``norm``                       a tangent-space normal map (OpenGL convention)
``-s``, ``-o``, ``-clamp on``  the texture's UV scale and offset, clamp wrap (else repeat)
``Ka``, ``Ni``, ``Tf``         read and unused: ambient is the scene's times kd; no refraction
``d``/``Tr``/``map_d``, ``Ke``, ``disp``  unused with a warning when they would change the look
                               (texray's surfaces are opaque and do not emit; ``disp`` is not
                               read: a mesh is displaced by a Displacement(method="tessellate"))
anything else                  ignored, listed in one warning per library
=============================  =====================================================
"""
from __future__ import annotations

import shlex
import warnings
from pathlib import Path

import numpy as np

from ..errors import SceneError
from ..scene.bump import Bump, NormalMap
from ..scene.mapping import UVTransform
from ..scene.material import Material
from ..scene.texture import Texture

BUMP_UNIT = 0.01         # world units of bump height per -bm unit (texray's default Bump height)

_MAPS = {"map_kd": "map_Kd", "map_ks": "map_Ks", "map_ns": "map_Ns", "bump": "bump", "map_bump": "bump",
         "norm": "norm", "map_d": "map_d", "disp": "disp", "map_ka": "map_Ka", "map_ke": "map_Ke", "refl": "refl"}
_COLOURS = ("kd", "ks", "ka", "ke", "tf")
_READ_UNUSED = {"ka", "ni", "tf", "map_ka", "sharpness"}
# Options of a map statement and how many numbers follow each (-s and -o: 1 to 3).
_OPTION_ARGS = {"-bm": 1, "-boost": 1, "-mm": 2, "-texres": 1, "-clamp": 1, "-blendu": 1, "-blendv": 1,
                "-cc": 1, "-imfchan": 1, "-type": 1, "-s": 3, "-o": 3, "-t": 3}


class _Entry:
    """One newmtl block as read: colours and numbers by statement, maps as (options, path)."""

    def __init__(self, name):
        self.name, self.values, self.maps = name, {}, {}


def read_mtl(path: Path, obj_path) -> dict[str, _Entry]:
    """{material name: entry} of the library at ``path`` (an OBJ's ``mtllib``). A missing
    library is a warning (its materials are the default), an undecodable one a SceneError
    naming the OBJ; unknown statements: one warning."""
    try:
        text = path.read_bytes().decode("utf-8")
    except FileNotFoundError:      # an OBJ copied without its library: the geometry is still good
        warnings.warn(f"{obj_path}: mtllib: {path} does not exist; its materials are the default grey",
                      stacklevel=4)
        return {}
    except UnicodeDecodeError as e:
        raise SceneError(f"{obj_path}: mtllib: {path} is not UTF-8 text (byte offset {e.start})") from None
    except OSError as e:
        raise SceneError(f"{obj_path}: mtllib: cannot read {path}: {e.strerror}") from None
    entries, cur, unknown = {}, None, set()
    for lineno, raw in enumerate(text.splitlines(), 1):
        line = raw.split("#", 1)[0].strip()
        if not line:
            continue
        key, _, rest = line.partition(" ")
        k, rest = key.lower(), rest.strip()
        where = f"{path}:{lineno}"
        if k == "newmtl":
            cur = entries[rest] = _Entry(rest)
            continue
        if cur is None:
            raise SceneError(f"{where}: {key} before any newmtl")
        if k in _COLOURS:
            cur.values[k] = _numbers(rest, where, key, (1, 3), colour=True)
        elif k in ("ns", "ni", "d", "tr", "illum", "sharpness"):
            cur.values[k] = _numbers(rest, where, key, (1, 1))[0]
        elif k in _MAPS:
            cur.maps[_MAPS[k]] = _map_statement(rest, where, key, path.parent)
        else:
            unknown.add(key)
    if unknown:
        warnings.warn(f"{path}: statements texray does not use were ignored: {', '.join(sorted(unknown))}",
                      stacklevel=4)
    return entries


def _numbers(text, where, key, counts, colour=False):
    parts = text.split()
    if colour and parts and parts[0].lower() in ("spectral", "xyz"):
        raise SceneError(f"{where}: {key} {parts[0]}: only RGB colours are read")
    try:
        vals = [float(p) for p in parts]
    except ValueError:
        raise SceneError(f"{where}: {key}: expected numbers, got {text!r}") from None
    if not counts[0] <= len(vals) <= counts[1] and not (colour and len(vals) == 1):
        raise SceneError(f"{where}: {key}: expected {counts[1]} numbers, got {text!r}")
    if not all(np.isfinite(vals)):
        raise SceneError(f"{where}: {key}: non-finite value in {text!r}")
    if colour and len(vals) == 1:
        vals = vals * 3
    return vals


def _map_statement(text, where, key, base):
    """(options {name: [values]}, texture path) of a map statement; the path is what
    follows the options (it may contain spaces)."""
    try:
        tokens = shlex.split(text, posix=True) if '"' in text else text.split()
    except ValueError:
        raise SceneError(f"{where}: {key}: cannot parse {text!r}") from None
    opts, i = {}, 0
    while i < len(tokens) and tokens[i].startswith("-") and tokens[i].lower() in _OPTION_ARGS:
        name, n = tokens[i].lower(), _OPTION_ARGS[tokens[i].lower()]
        vals = []
        i += 1
        while len(vals) < n and i < len(tokens) - 1:     # the last token is (part of) the path
            try:
                vals.append(float(tokens[i]) if name not in ("-clamp", "-blendu", "-blendv", "-cc", "-imfchan",
                                                            "-type") else tokens[i].lower())
            except ValueError:
                break
            i += 1
            if name not in ("-s", "-o", "-t", "-mm"):
                break
        if not vals:
            raise SceneError(f"{where}: {key}: option {tokens[i - 1]} without its value in {text!r}")
        opts[name] = vals
    if i >= len(tokens):
        raise SceneError(f"{where}: {key}: no texture file in {text!r}")
    name = " ".join(tokens[i:])
    p = Path(name.replace("\\", "/"))
    return opts, (p if p.is_absolute() else base / p)


def to_materials(entries: dict, names, obj_path) -> list[Material]:
    """texray Materials for the material ``names`` (trimesh's usemtl groups, in order): an
    entry of the library, else the default grey with a warning."""
    textures, out, unused, missing = {}, [], set(), []
    for name in names:
        e = entries.get(name)
        if e is None:                 # faces before any usemtl (None) take the default silently
            if name is not None:
                missing.append(name)
            out.append(Material())
            continue
        out.append(_material(e, obj_path, textures, unused))
    if missing and entries:       # (no library at all was warned about as such)
        warnings.warn(f"{obj_path}: usemtl {', '.join(map(repr, missing))}: not defined in the OBJ's "
                      "material libraries; the default material is used", stacklevel=4)
    if unused:
        warnings.warn(f"{obj_path}: material statements texray cannot render were ignored: "
                      f"{'; '.join(sorted(unused))}", stacklevel=4)
    return out


def _material(e, obj_path, textures, unused):
    v, maps, where = e.values, e.maps, f"{obj_path}: material {e.name!r}"

    def tex(statement, colorspace):
        opts, path = maps[statement]
        key = (str(path), colorspace)
        if key not in textures:
            try:
                textures[key] = Texture.load(path, colorspace=colorspace, field=f"{where}: {statement}")
            except SceneError as err:
                raise SceneError(f"{where}: {statement} {path}: {_reason(err, path)}") from None
        t = textures[key]
        scale = opts.get("-s", [1.0, 1.0])
        offset = opts.get("-o", [0.0, 0.0])
        uvt = None
        if scale[:2] != [1.0, 1.0] or offset[:2] != [0.0, 0.0]:
            # MTL: uv' = uv * s + o, about the origin; UVTransform scales about the origin too
            # (its rotation pivot is unused at rotation 0).
            scale2 = (scale + scale[-1:])[:2] if len(scale) == 1 else scale[:2]
            uvt = UVTransform(scale=tuple(scale2), offset=tuple((offset + [0.0])[:2]))
        wrap = "clamp" if opts.get("-clamp", ["off"])[0] == "on" else "repeat"
        if uvt is not None or wrap != t.wrap:
            t = t.with_options(wrap=wrap, uv_transform=uvt)
        for o in opts:
            if o not in ("-s", "-o", "-clamp", "-bm"):
                unused.add(f"{e.name}: {statement} {o}")
        return t

    kd = v.get("kd", [0.8, 0.8, 0.8])
    ks = v.get("ks", [0.0, 0.0, 0.0])
    if v.get("illum", 2) in (0, 1):
        ks = [0.0, 0.0, 0.0]
    kw = {"shininess": max(0.0, v.get("ns", 32.0))}
    if "map_Kd" in maps:
        kw["diffuse"], kw["tint"] = tex("map_Kd", "auto"), tuple(kd)
    else:
        kw["diffuse"] = tuple(kd)
    if "map_Ks" in maps and any(ks):
        t = tex("map_Ks", "auto")
        if ks == [1.0, 1.0, 1.0]:
            kw["specular"] = t
        else:        # ks = map x Ks: baked (texray's specular texture has no factor)
            kw["specular"] = Texture.from_array(t.rgba[:, :, :3] * np.asarray(ks, np.float32), name=t.name,
                                                field=f"{where}: map_Ks", wrap=t.wrap, uv_transform=t.uv_transform)
    else:
        kw["specular"] = tuple(ks)
    if "map_Ns" in maps:
        t = tex("map_Ns", "linear")
        kw["shininess_map"] = t if t.channels == 1 else Texture.from_array(
            t.raw[:, :, 0], name=t.name, field=f"{where}: map_Ns", wrap=t.wrap, uv_transform=t.uv_transform)
    if "norm" in maps:
        kw["normal_map"] = NormalMap(tex("norm", "linear"))
    elif "bump" in maps:
        bm = maps["bump"][0].get("-bm", [1.0])[0]
        kw["bump"] = Bump(tex("bump", "linear"), height=BUMP_UNIT * bm)
    if "norm" in maps and "bump" in maps:
        unused.add(f"{e.name}: bump (the material has a normal map, which replaces the shading normal)")
    opacity = v.get("d", 1.0 - v.get("tr", 0.0))
    if opacity < 1.0 or "map_d" in maps:
        unused.add(f"{e.name}: d/Tr/map_d (texray renders opaque surfaces)")
    if any(v.get("ke", [0.0])) or "map_Ke" in maps:
        unused.add(f"{e.name}: Ke/map_Ke (surfaces do not emit; use point lights)")
    if "disp" in maps:
        unused.add(f"{e.name}: disp (not read; displace the mesh with a Displacement(method='tessellate'))")
    if "refl" in maps:
        unused.add(f"{e.name}: refl (no reflections: direct illumination)")
    try:
        return Material(**kw)
    except SceneError as err:
        raise SceneError(f"{where}: {err}") from None


def _reason(err, path):
    """The part of a texture error after its file name (the caller names the file)."""
    msg = str(err)
    i = msg.find(str(path))
    rest = msg[i + len(str(path)):].lstrip(": ") if i >= 0 else ""
    return rest or msg.rsplit(": ", 1)[0].rsplit(": ", 1)[-1]   # "...file: file not found: c.png" -> "file not found"
