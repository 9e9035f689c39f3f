"""Materials: the lecture's local-illumination constants and the textures that change them."""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..errors import SceneError
from .. import validate as V
from .bump import Bump, NormalMap
from .displacement import Displacement
from .texture import Label, Texture


@dataclass
class Material:
    """The lecture's local-illumination constants.

    diffuse: kd, an RGB colour or a :class:`Texture` (colour role); ``tint``
    multiplies it. specular: ks, a number, RGB or a :class:`Texture` (colour
    role: ks = its RGB). shininess: the exponent n of (R.V)^n, a number >= 0;
    shininess_map: an optional one-channel :class:`Texture` (data role, stored
    values >= 0) that multiplies it per point, n = shininess * map, so an 8/16-bit
    map in [0, 1] spans exponents 0..shininess. label: a :class:`texray.Label`
    composited over kd (after the tint): kd = lerp(kd, label.rgb, label.alpha).
    bump: a :class:`texray.Bump`; normal_map: a :class:`texray.NormalMap` (at most one
    of the two: each defines the shading normal on its own).
    displacement: a :class:`texray.Displacement` moving quads, spheres and cylinders
    along their normal (texray.scene.displacement).
    """
    diffuse: object = (0.8, 0.8, 0.8)
    specular: object = 0.0
    shininess: float = 32.0
    tint: tuple = (1.0, 1.0, 1.0)
    bump: object = None
    normal_map: object = None
    shininess_map: object = None
    label: object = None
    displacement: object = None    # a texray.Displacement: the geometry moves

    def __post_init__(self):
        self.validate()

    def validate(self, where="material."):
        if isinstance(self.diffuse, Texture):
            kd = V.rgb(self.tint, "tint", where)
        else:
            kd = V.rgb(self.diffuse, "diffuse", where) * V.rgb(self.tint, "tint", where)
            if np.any(kd > V.FLT_MAX):
                raise SceneError(f"{where}diffuse, tint: their product {V.show(kd)} overflows float32")
        ks = np.ones(3) if isinstance(self.specular, Texture) else V.rgb(self.specular, "specular", where)
        n = V.number(self.shininess, "shininess", where, 0.0)
        if self.shininess_map is not None and not isinstance(self.shininess_map, Texture):
            raise SceneError(f"{where}shininess_map: expected a texray.Texture, got {self.shininess_map!r}")
        if self.shininess_map is not None and self.shininess_map.channels != 1:
            t = self.shininess_map
            raise SceneError(f"{where}shininess_map: {t.name} has {t.channels} channels; a shininess map takes "
                             "1 (grey)")
        if self.label is not None and not isinstance(self.label, Label):
            raise SceneError(f"{where}label: expected a texray.Label, got {V.show(self.label)}")

        _check_normal_roles(self, where)
        if self.displacement is not None:
            if not isinstance(self.displacement, Displacement):
                raise SceneError(f"{where}displacement: expected a texray.Displacement, got {self.displacement!r}")
            self.displacement.validate(f"{where}displacement.")
        for t in self.textures:             # their options may have changed since they were made
            V.instance(t, Texture, "texture", where)
            t.validate()
        return kd, ks, n

    def texture_roles(self):
        """[(layout.MATERIAL slot, Texture as the device reads it, texture.KINDS kind)] of the
        colour, specular, shininess and label roles."""
        roles = []
        if isinstance(self.diffuse, Texture):
            roles.append(("diffuse_tex", self.diffuse, "colour"))
        if isinstance(self.specular, Texture):
            roles.append(("specular_tex", self.specular, "colour"))
        if self.shininess_map is not None:
            roles.append(("shininess_tex", self.shininess_map, "data"))
        if self.label is not None:
            roles.append(("label_tex", self.label.device_texture, "label"))
        return roles

    @property
    def textures(self):
        return [t for _, t, _ in self.texture_roles()] + normal_role_textures(self)


def _check_normal_roles(m, where):
    if m.bump is not None and not isinstance(m.bump, Bump):
        raise SceneError(f"{where}bump: expected a texray.Bump, got {m.bump!r}")
    if m.normal_map is not None and not isinstance(m.normal_map, NormalMap):
        raise SceneError(f"{where}normal_map: expected a texray.NormalMap, got {m.normal_map!r}")
    if m.bump is not None and m.normal_map is not None:
        raise SceneError(f"{where}bump, normal_map: a material takes one of the two (each replaces the "
                         "shading normal); bake the bump into the normal map")
    if m.bump is not None:
        m.bump.validate(f"{where}bump.")
    if m.normal_map is not None:
        m.normal_map.validate(f"{where}normal_map.")


def normal_role_textures(m):
    """The data textures of the bump / normal-map roles."""
    return [r.texture for r in (m.bump, m.normal_map) if r is not None and hasattr(r, "texture")]

