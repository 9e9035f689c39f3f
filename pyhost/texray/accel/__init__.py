"""Acceleration structures: the binned-SAH binary BVH (:mod:`.bvh`), the scene's one
tree over every primitive kind (:mod:`.scene_bvh`) and its 4-wide collapse, what the
kernels traverse (:mod:`.wide`)."""
