"""Adaptive sampling's rounds (texray.renderer.adaptive); the stopping rule, which the device
runs, is tests/kernels/test_adaptive_decide.py's."""
import numpy as np

from texray.renderer import adaptive as A


def test_round_sizes():
    assert [A.round_size(s) for s in (1, 4, 8, 16, 64, 1024)] == [1, 4, 4, 4, 8, 128]
    # then each round as many samples as all before it, up to spp in all
    assert A.round_sizes(32) == [4, 4, 8, 16]
    assert A.round_sizes(24) == [4, 4, 8, 8]
    assert A.round_sizes(1024) == [128, 128, 256, 512]
    assert A.round_sizes(3) == [3] and A.round_sizes(5) == [4, 1]
    for spp in range(1, 300):
        r = A.round_sizes(spp)
        assert sum(r) == spp and min(r) >= 1 and len(r) <= 8
