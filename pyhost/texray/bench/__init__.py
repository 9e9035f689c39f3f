"""The benchmark: ``texray bench`` (:mod:`.cli`), also ``python tools/bench.py``.

Measures, on every OpenCL device (or the ones chosen with ``--device``):

* BVH build time and SAH cost of a 1M-triangle mesh (host side, once);
* closest-hit throughput of 1024^2 pixel-centre primary rays on that mesh and
  any-hit throughput of shadow rays from the hits toward a point light (the
  work of peers.md's Embree figures);
* the suite ``scenes/bench/`` (1M-triangle mesh, textured globe, textured quad
  at grazing angles, every primitive and mapping mixed): frame time and each
  kernel stage (OpenCL profiling events) for the program specialized to the
  scene and for the generic program with every feature compiled in; cold and
  warm build times of both (fresh processes); device memory;
* ``--sweep``: the speed/accuracy knobs (spp, texture filtering) against a
  reference image, as a table and an error-against-time plot (``--plot``);
* ``--local-sizes``: frame time per work-group size;
* ``--peers``: Embree and Mitsuba 3 on the same work (``texray[peers]``).

Every figure is the median over ``--repeat`` runs after one warm-up run, with
the spread (min-max) beside it. Prints tables, writes JSON (``--json``) and a
markdown report (``--report``); ``--compare A.json B.json`` prints the ratios
between two runs.

Modules: :mod:`.cli` (the command line and the run), :mod:`.rays` (the bench
mesh, its BVH, ray throughput), :mod:`.suite` (the suite scenes, frames, kernel
stages, program variants, work-group sizes), :mod:`.buildtime` (cold and warm
builds, in fresh processes), :mod:`.sweep` (speed/accuracy knobs against a
reference), :mod:`.report` (tables, markdown, ``--compare``), :mod:`.peers`
(Embree and Mitsuba 3 driven on texray's work) and :mod:`.compare_peers`
(``--peers``: texray against them, as tables).

The renderer never imports this package.
"""

from .cli import main

__all__ = ["main"]
