"""Files: TOML scene files (:mod:`.scenefile`), whole glTF scenes (:mod:`.gltf_scene`),
mesh files (:mod:`.meshfile`: OBJ, PLY, OFF, STL through trimesh, with OBJ's MTL
materials from :mod:`.mtl`; glTF through :mod:`.gltf`, :mod:`.gltf_data` and
:mod:`.gltf_materials`), images through OpenImageIO (:mod:`.images`) and the sRGB
transfer functions (:mod:`.colour`)."""
