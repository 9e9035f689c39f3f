"""Small test kernels built against texray's own headers (kernels/*.h), to check device
functions one at a time against float64 references."""
import pyopencl as cl

from texray.device import layout
from texray.device import KERNEL_DIR

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
    """Kernels of ``source`` (which #includes some of ``headers``) after texray.layout's
    declarations, built once per context, header contents, source and options."""
    heads = "".join((KERNEL_DIR / h).read_text() for h in headers)
    key = (rt.context.int_ptr, hash(heads), hash(source), tuple(options))
    prg = _cache.get(key)
    if prg is None:
        # the headers' hash in the source: pyopencl's binary cache must not serve stale includes
        src = f"/* {hash(heads)} */\n" + layout.opencl_declarations() + source
        built = cl.Program(rt.context, src).build(options=list(options) + ["-I", str(KERNEL_DIR)])
        prg = _cache[key] = Kernels(built)
    return prg
