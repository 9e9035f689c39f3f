"""Files: TOML scene files (:mod:`.scenefile`), mesh files through trimesh
(:mod:`.meshfile`), images through OpenImageIO (:mod:`.images`) and the sRGB transfer
functions (:mod:`.colour`)."""
