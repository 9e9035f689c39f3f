"""Every struct of texray.layout has the same size and field offsets on the device
as the numpy dtype the host fills it from (the one source of truth)."""
import numpy as np
import pyopencl as cl

from texray.device import layout


def _probe_source():
    lines = [layout.opencl_declarations(), "__kernel void probe(__global uint* out) {", "  uint i = 0;"]
    for name, dt in layout.STRUCTS.items():
        lines.append(f"  out[i++] = sizeof({name});")
        for f in dt.names:
            lines.append(f"  out[i++] = (uint)((__global char*)&((__global {name}*)out)->{f} - (__global char*)out);")
    lines.append("}")
    return "\n".join(lines)


def test_struct_sizes_and_offsets_match_on_device(any_rt):
    expected = []
    for name, dt in layout.STRUCTS.items():
        expected.append((f"sizeof({name})", dt.itemsize))
        expected += [(f"{name}.{f}", dt.fields[f][1]) for f in dt.names]
    prg = cl.Program(any_rt.context, _probe_source()).build()
    out = np.zeros(len(expected), np.uint32)
    buf = cl.Buffer(any_rt.context, cl.mem_flags.WRITE_ONLY, max(out.nbytes, 4096))
    prg.probe(any_rt.queue, (1,), None, buf)
    cl.enqueue_copy(any_rt.queue, out, buf)
    mismatches = [(what, want, int(got)) for (what, want), got in zip(expected, out) if want != got]
    assert not mismatches, f"host/device layout differs (field, host, device): {mismatches}"


def test_leaf_encoding_round_trips():
    counts = np.array([1, 2, 255, layout.LEAF_COUNT_MASK])
    c, k = layout.decode_leaf(layout.encode_leaf(counts, kind=3))
    np.testing.assert_array_equal(c, counts)
    np.testing.assert_array_equal(k, 3)
