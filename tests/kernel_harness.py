"""Small test kernels built against texray's own headers (kernels/*.h), to check device
functions one at a time against float64 references."""
import pyopencl as cl


_cache = {}


class Kernels:
    """A built program's kernels by attribute, each retrieved once (pyopencl warns on
    repeated retrieval)."""

    def __init__(self, prg):
        self._prg = prg
        self._k = {}

    def __getattr__(self, name):
        if name.startswith("_"):
            raise AttributeError(name)
        k = self._k.get(name)
        if k is None:
            k = self._k[name] = cl.Kernel(self._prg, name)
        return k


def build_test_program(rt, headers, source, options=()):
    """Kernels of ``source`` (which #includes the kernel ``headers``) built by the renderer's
    own build path (texray.device.opencl.Runtime.build: the generated declarations first,
    OpenCL C 1.2, cached per source, options and every kernel file), retrieved by attribute."""
    prg = rt.build(source, options)
    kernels = _cache.get(id(prg))
    if kernels is None or kernels._prg is not prg:
        kernels = _cache[id(prg)] = Kernels(prg)
    return kernels
