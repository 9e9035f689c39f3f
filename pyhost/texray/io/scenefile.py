"""TOML scene files. The format is documented in the README ("Scene files").

Paths inside a scene file are relative to the file. Every table accepts only
the keys listed in ``_SCHEMA``; an unknown key, a wrong type or a bad value
raises SceneError naming the file, the field and the value.
"""
from __future__ import annotations


import numpy as np

try:
    import tomllib
except ModuleNotFoundError:        # Python < 3.11
    import tomli as tomllib

from ..device.features import LIGHT_SAMPLING
from ..errors import SceneError
from ..procedural import meshes as _meshes
from ..scene import (Bump, Camera, Cylinder, Displacement, Instance, Label, Material, Mesh, NormalMap, PointLight,
                     Projection, Quad, Scene, Sphere, Texture, Transform, UVTransform)
from ..scene.mapping import WRAP_MODES
from ..scene.texture import DEFAULT_MAX_ANISO
from .. import validate as V
from .gltf_scene import load_gltf_scene

_NUM = (int, float)
_VEC = (list,)
_SCHEMA = {
    "": {"camera": dict, "scene": dict, "render": dict, "lights": list, "textures": dict,
         "materials": dict, "objects": list},
    "camera": {"eye": _VEC, "look_at": _VEC, "up": _VEC, "fov_y": _NUM},
    "scene": {"ambient": _VEC, "background": _VEC},
    "render": {"width": int, "height": int, "spp": int, "seed": int, "adaptive": _NUM, "light_sampling": str},
    "lights": {"position": _VEC, "intensity": _VEC},
    "textures": {"file": str, "colorspace": str, "wrap": str, "uv_transform": dict, "filter": str,
                 "max_aniso": int, "procedural": str, "params": dict},
    "label": {"texture": str, "uv_transform": dict},
    "bump": {"texture": str, "height": _NUM, "delta": (int, float, str)},
    "normal_map": {"texture": str, "convention": str, "space": str},
    "displacement": {"texture": str, "scale": _NUM, "offset": _NUM, "method": str, "steps": int, "refine": int,
                     "adaptive": bool, "resolution": int},
    "uv_transform": {"scale": _VEC, "offset": _VEC, "rotation": _NUM},
    "mapping": {"kind": str, "origin": _VEC, "x_axis": _VEC, "z_axis": _VEC, "scale": _NUM},
    "materials": {"diffuse": (str, list), "tint": _VEC, "specular": (int, float, list, str), "shininess": _NUM,
                  "shininess_map": str, "label": (str, dict), "bump": dict, "normal_map": dict,
                  "displacement": dict},
    "objects": {"type": str, "material": str, "translate": _VEC, "rotate": _VEC, "scale": (int, float, list),
                "mapping": dict,
                "mesh": str,                                                   # type = "mesh"
                "name": str, "hidden": bool,                                   # "mesh", "procedural"
                "of": str,                                                     # type = "instance"
                "generator": str, "params": dict,                              # type = "procedural"
                "center": _VEC, "radius": _NUM, "axis_z": _VEC, "axis_x": _VEC,   # "sphere", "cylinder"
                "z_range": _VEC, "theta_range": _VEC, "origin": _VEC,          # "cylinder"
                "p0": _VEC, "p1": _VEC, "p2": _VEC, "p3": _VEC, "uvs": _VEC},  # "quad"
}
_REQUIRED = {"lights": ("position",), "mapping": ("kind",), "label": ("texture",), "bump": ("texture",),
             "normal_map": ("texture",), "displacement": ("texture",)}
# Keys each object type takes besides type, material and the transform; the first ones are required.
_OBJECT_KEYS = {
    "mesh": (("mesh",), ("name", "hidden")),
    "procedural": (("generator",), ("params", "name", "hidden")),
    "instance": (("of",), ()),
    "sphere": ((), ("center", "radius", "axis_z", "axis_x")),
    "cylinder": ((), ("radius", "z_range", "theta_range", "origin", "axis_z", "axis_x")),
    "quad": (("p0", "p1", "p2", "p3"), ("uvs",)),
}


def _check_table(table, kind, where):
    if not isinstance(table, dict):
        raise SceneError(f"{where}: expected a table, got {type(table).__name__} {table!r}")
    allowed = _SCHEMA[kind]
    for key, value in table.items():
        if key not in allowed:
            raise SceneError(f"{where}.{key}: unknown key (allowed: {', '.join(sorted(allowed))})" if where
                             else f"{key}: unknown top-level key (allowed: {', '.join(sorted(allowed))})")
        types = allowed[key] if isinstance(allowed[key], tuple) else (allowed[key],)
        if (isinstance(value, bool) and bool not in types) or not isinstance(value, types):
            names = " or ".join("array" if t is list else "table" if t is dict else "true or false" if t is bool
                                else t.__name__ for t in types)
            raise SceneError(f"{where + '.' if where else ''}{key}: expected {names}, got {value!r}")
    for key in _REQUIRED.get(kind, ()):
        if key not in table:
            raise SceneError(f"{where}: missing required key {key!r}")


def load_scene(path, camera=None) -> Scene:
    """Parse a scene file into a :class:`Scene`: TOML (the README's "Scene files";
    ``scene.render_settings`` holds its [render] table) or a whole glTF 2.0 file (.gltf,
    .glb: texray.io.gltf_scene; ``camera`` names the camera to use, default the first)."""
    path = V.file_path(path, "scene")
    if path.suffix.lower() in (".gltf", ".glb"):
        return load_gltf_scene(path, camera)
    if camera is not None:
        raise SceneError(f"{path}: camera: only a glTF file names its cameras; a TOML scene has one [camera]")
    try:
        doc = tomllib.loads(path.read_text(encoding="utf-8"))
    except (tomllib.TOMLDecodeError, UnicodeDecodeError) as e:
        raise SceneError(f"{path}: not valid TOML: {e}") from None
    base = path.parent
    try:
        return _build(doc, base, path)
    except SceneError as e:
        msg = str(e)
        raise SceneError(msg if msg.startswith(str(path)) else f"{path}: {msg}") from None


def _build(doc, base, path):
    _check_table(doc, "", "")
    cam = doc.get("camera", {})
    _check_table(cam, "camera", "camera")
    sc = doc.get("scene", {})
    _check_table(sc, "scene", "scene")
    settings = doc.get("render", {})
    _check_table(settings, "render", "render")
    sizes = {k: v for k, v in settings.items() if k not in ("adaptive", "light_sampling")}
    V.render_settings(**({"width": 1, "height": 1, "spp": 1, "seed": 0} | sizes), where="render.")
    if "adaptive" in settings:
        V.number(settings["adaptive"], "adaptive", "render.", 0.0, lo_open=True)
    if "light_sampling" in settings:
        V.one_of(settings["light_sampling"], LIGHT_SAMPLING, "light_sampling", "render.")

    lights = []
    for i, lt in enumerate(doc.get("lights", [])):
        _check_table(lt, "lights", f"lights[{i}]")
        lights.append(_renamed(lambda: PointLight(**lt), "light.", f"lights[{i}]."))

    textures = {}
    for name, tt in doc.get("textures", {}).items():
        _check_table(tt, "textures", f"textures.{name}")
        uvt = None
        if "uv_transform" in tt:
            _check_table(tt["uv_transform"], "uv_transform", f"textures.{name}.uv_transform")
            uvt = _wrap_errors(lambda: UVTransform(**tt["uv_transform"]), f"textures.{name}.")
        if tt.get("wrap", "repeat") not in WRAP_MODES:
            raise SceneError(f"textures.{name}.wrap: expected one of {', '.join(WRAP_MODES)}, got {tt['wrap']!r}")
        textures[name] = _texture(tt, name, base, uvt)

    materials = {}
    for name, mt in doc.get("materials", {}).items():
        where = f"materials.{name}"
        _check_table(mt, "materials", where)
        kw = dict(mt)
        for role in ("diffuse", "specular", "shininess_map"):
            if isinstance(kw.get(role), str):
                kw[role] = _named_texture(textures, kw[role], f"{where}.{role}")
        if "label" in kw:
            kw["label"] = _label(kw["label"], textures, f"{where}.label")
        for role, make in (("bump", Bump), ("normal_map", NormalMap), ("displacement", Displacement)):
            if role in kw:
                kw[role] = _normal_role(make, kw[role], textures, f"{where}.{role}")
        materials[name] = _renamed(lambda: Material(**kw), "material.", where + ".")

    scene = Scene(camera=Camera(**cam), lights=lights, **sc)
    eye_where = "camera."
    scene.camera.basis(1.0, eye_where)
    named = {}                  # name -> mesh, for instances (type = "instance", of = NAME)
    for i, ob in enumerate(doc.get("objects", [])):
        obj = _object(ob, f"objects[{i}]", materials, base, named)
        if "name" in ob:
            if ob["name"] in named:
                raise SceneError(f"objects[{i}].name: {ob['name']!r} names an earlier object too")
            named[ob["name"]] = obj
        if not ob.get("hidden", False):
            scene.add(obj)
    scene.render_settings = dict(settings)
    return scene


def _texture(tt, name, base, uvt):
    """textures.NAME: a file or a procedural texture (exactly one of the two)."""
    where = f"textures.{name}"
    if ("file" in tt) == ("procedural" in tt):
        raise SceneError(f"{where}: expected exactly one of 'file' or 'procedural'")
    if "params" in tt and "procedural" not in tt:
        raise SceneError(f"{where}.params: only with 'procedural'")
    opts = {"filter": tt.get("filter", "bilinear"), "wrap": tt.get("wrap", "repeat"), "uv_transform": uvt,
            "max_aniso": tt.get("max_aniso", DEFAULT_MAX_ANISO)}
    if "file" in tt:
        return Texture.load(base / tt["file"], colorspace=tt.get("colorspace", "auto"), field=where, **opts)
    if "colorspace" in tt:
        raise SceneError(f"{where}.colorspace: procedural textures know their colour space")
    params = tt.get("params", {})
    if not all(isinstance(v, (int, float, list)) and not isinstance(v, bool) for v in params.values()):
        raise SceneError(f"{where}.params: expected numbers or arrays, got {params!r}")
    params = {k: tuple(v) if isinstance(v, list) else v for k, v in params.items()}
    return _renamed(lambda: Texture.procedural(tt["procedural"], **opts, **params), "texture.", f"{where}.")


def _normal_role(make, value, textures, where):
    """A material's bump = { texture = NAME, height, delta }, normal_map = { texture = NAME,
    convention, space } or displacement = { texture = NAME, scale, offset, method, steps, refine,
    adaptive, resolution }: texray.Bump / texray.NormalMap / texray.Displacement."""
    role = {Bump: "bump", NormalMap: "normal_map", Displacement: "displacement"}[make]
    _check_table(value, role, where)
    args = dict(value, texture=_named_texture(textures, value["texture"], f"{where}.texture"))
    try:
        return make(**args)
    except SceneError as e:                  # "bump.height: ..." -> "materials.NAME.bump.height: ..."
        msg = str(e)
        raise SceneError(f"{where}.{msg[len(role) + 1:]}" if msg.startswith(role + ".") else f"{where}: {msg}") \
            from None


def _named_texture(textures, name, where):
    if name not in textures:
        raise SceneError(f"{where}: no texture named {name!r} (defined: {', '.join(textures) or 'none'})")
    return textures[name]


def _label(value, textures, where):
    """A material's label: a texture name, or { texture = NAME, uv_transform = {...} }."""
    if isinstance(value, str):
        return Label(_named_texture(textures, value, where))
    _check_table(value, "label", where)
    uvt = None
    if "uv_transform" in value:
        _check_table(value["uv_transform"], "uv_transform", f"{where}.uv_transform")
        uvt = _wrap_errors(lambda: UVTransform(**value["uv_transform"]), f"{where}.")
    return Label(_named_texture(textures, value["texture"], f"{where}.texture"), uv_transform=uvt)


def _instance(ob, where, named, tf):
    """type = "instance": the mesh object named ``of`` placed by the object's transform
    (after the mesh's own); its material and mapping are the mesh's."""
    for key in ("material", "mapping"):
        if key in ob:
            raise SceneError(f"{where}.{key}: an instance has its mesh's {key}; set it on the mesh object")
    if ob["of"] not in named:
        raise SceneError(f"{where}.of: no earlier mesh object named {ob['of']!r} "
                         f"(named: {', '.join(named) or 'none'})")
    return Instance(named[ob["of"]], tf, name=where)


def _object(ob, where, materials, base, named=None):
    _check_table(ob, "objects", where)
    kind = ob.get("type", "mesh")
    if kind not in _OBJECT_KEYS:
        raise SceneError(f"{where}.type: expected one of {', '.join(_OBJECT_KEYS)}, got {kind!r}")
    required, optional = _OBJECT_KEYS[kind]
    for key in required:
        if key not in ob:
            raise SceneError(f"{where}: missing required key {key!r} for type {kind!r}")
    common = {"type", "material", "translate", "rotate", "scale", "mapping"}
    for key in ob:
        if key not in common and key not in required and key not in optional:
            raise SceneError(f"{where}.{key}: not a key of type {kind!r} (allowed: "
                             f"{', '.join(sorted(common | set(required) | set(optional)))})")
    mat_name = ob.get("material")
    if mat_name is not None and mat_name not in materials:
        raise SceneError(f"{where}.material: no material named {mat_name!r} "
                         f"(defined: {', '.join(materials) or 'none'})")
    material = materials.get(mat_name, Material())
    tf = _wrap_errors(lambda: Transform(**{k: ob[k] for k in ("translate", "rotate", "scale") if k in ob}),
                      where + ".")
    if kind == "instance":
        return _instance(ob, where, named or {}, tf)
    args = {k: ob[k] for k in required + optional if k in ob and k not in ("name", "hidden")}
    if "mapping" in ob:
        _check_table(ob["mapping"], "mapping", f"{where}.mapping")
        args["mapping"] = _wrap_errors(lambda: Projection(**ob["mapping"]), f"{where}.mapping.")
    try:
        if kind == "mesh":
            # without a material key the file's own materials (OBJ/MTL, glTF) are kept
            return Mesh.load(base / ob["mesh"], material=materials[mat_name] if mat_name is not None else None,
                             transform=tf, mapping=args.get("mapping"))
        if kind == "procedural":
            return _procedural_mesh(ob["generator"], ob.get("params", {}), where, material, tf,
                                    args.get("mapping"))
        cls = {"sphere": Sphere, "cylinder": Cylinder, "quad": Quad}[kind]
        return cls(material=material, transform=tf, name=where, **args)
    except SceneError as e:
        raise SceneError(f"{where}.mesh: {e}" if kind == "mesh" else str(e)) from None


# Procedural meshes a scene file may name: generator -> (function, {param: type}).
def _generators():
    p = _meshes
    return {
        "bench_mesh": (p.bench_mesh, {"target_triangles": int, "amplitude": _NUM, "seed": int}),
        "uv_sphere": (p.uv_sphere, {"n_lon": int, "n_lat": int, "radius": _NUM}),
        "torus": (p.torus, {"n_major": int, "n_minor": int, "R": _NUM, "r": _NUM}),
        "vase": (p.vase, {"n_around": int, "n_profile": int}),
        "grid": (p.grid, {"nu": int, "nv": int, "size": _VEC, "uv_scale": _NUM}),
    }


# Largest procedural mesh a scene file may ask for (64M triangles: ~3 GiB of host arrays).
_MAX_GENERATED_TRIANGLES = 1 << 26


def _procedural_mesh(generator, params, where, material, tf, mapping):
    gens = _generators()
    if generator not in gens:
        raise SceneError(f"{where}.generator: expected one of {', '.join(gens)}, got {generator!r}")
    fn, schema = gens[generator]
    for key, value in params.items():
        if key not in schema:
            raise SceneError(f"{where}.params.{key}: not a parameter of {generator!r} "
                             f"(allowed: {', '.join(schema)})")
        types = schema[key] if isinstance(schema[key], tuple) else (schema[key],)
        if isinstance(value, bool) or not isinstance(value, types):
            raise SceneError(f"{where}.params.{key}: expected a {'number' if types == _NUM else types[0].__name__}"
                             f", got {value!r}")
        if types == (int,) and key != "seed" and value < 1:
            raise SceneError(f"{where}.params.{key}: expected a positive integer, got {value!r}")
    counts = [v for k, v in params.items() if schema[k] is int and k != "seed"]
    if int(np.prod(counts, dtype=np.float64)) > _MAX_GENERATED_TRIANGLES:
        raise SceneError(f"{where}.params: {generator} with {params} would exceed "
                         f"{_MAX_GENERATED_TRIANGLES} triangles")
    try:
        m = fn(**params)
    except (ValueError, TypeError) as e:
        raise SceneError(f"{where}.params: {generator}({params}): {e}") from None
    return Mesh(m.positions, m.faces, m.uvs, m.normals, material=material, transform=tf,
                name=f"{where} ({generator})", mapping=mapping)


def _renamed(make, own, where):
    """make(), with a SceneError's own prefix (``"light."``) replaced by the field's place in
    the file (``"lights[2]."``)."""
    try:
        return make()
    except SceneError as e:
        msg = str(e)
        raise SceneError(where + msg[len(own):] if msg.startswith(own) else f"{where}{msg}") from None


def _wrap_errors(make, where):
    """make(), with a SceneError's message prefixed by where it comes from in the file."""
    try:
        return make()
    except SceneError as e:
        raise SceneError(f"{where}{e}") from None
