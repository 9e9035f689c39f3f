"""The scene's materials as the layout.MATERIAL table, with their textures' entries in
the texture table (deduplicated, in first-use order)."""
from __future__ import annotations

import numpy as np

from ..device import layout
from ..errors import SceneError
from ..scene.material import normal_role_textures


class MaterialTable:
    """Deduplicated materials and texture-table entries, in first-use order. An entry is a
    (Texture, kind) pair (texray.texture.KINDS): a texture used in roles of two kinds gets
    two entries. ``texture_filter`` (a texray.texture.FILTERS name) replaces every
    texture's filter."""

    def __init__(self, texture_filter=None):
        self.materials, self.entries, self._mi, self._ti, self._tk = [], [], {}, {}, {}
        self.texture_filter = texture_filter

    @property
    def textures(self):
        return [t for t, _ in self.entries]

    def _entry(self, t, kind):
        key = (id(t), kind)
        if key not in self._tk:
            self._tk[key] = len(self.entries)
            self.entries.append((t if self.texture_filter is None else t.with_options(filter=self.texture_filter),
                                 kind))
        return self._tk[key]

    def index(self, m):
        if id(m) not in self._mi:
            self._mi[id(m)] = len(self.materials)
            self.materials.append(m)
            for _, t, kind in m.texture_roles():
                self._entry(t, kind)
            for t in normal_role_textures(m):      # bump and normal maps: data, looked up by id
                self._ti[id(t)] = self._entry(t, "data")
        return self._mi[id(m)]

    def table(self):
        mats = np.zeros(max(len(self.materials), 1), layout.MATERIAL)
        for role in ("diffuse_tex", "specular_tex", "shininess_tex", "label_tex", "bump_tex", "normal_tex"):
            mats[role] = -1
        any_specular = False
        for i, m in enumerate(self.materials):
            kd, ks, n = m.validate(f"material {i}: ")
            mats[i]["diffuse"], mats[i]["specular"], mats[i]["shininess"] = kd, ks, n
            any_specular |= bool(np.any(ks > 0))
            for slot, t, kind in m.texture_roles():
                mats[i][slot] = self._tk[(id(t), kind)]
            if m.shininess_map is not None and m.shininess_map.raw.min() < 0:
                t = m.shininess_map
                raise SceneError(f"{t.field}: {t.name}: shininess_map values must be >= 0 (n = shininess * map), "
                                 f"got {float(t.raw.min())}")
            if m.bump is not None:
                mats[i]["bump_tex"] = self._ti[id(m.bump.texture)]
                mats[i]["bump_height"], mats[i]["bump_delta"] = m.bump.height, m.bump.device_delta()
            if m.normal_map is not None:
                mats[i]["normal_tex"] = self._ti[id(m.normal_map.texture)]
                mats[i]["normal_mode"] = m.normal_map.device_mode()
        return mats, any_specular
