import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from ppaloc.localise import likelihood
from ppaloc.localise.likelihood import LbpDistance, LowresDistance, lowres_total_reference


@pytest.mark.parametrize("n", [1, 3, 8192, 8193])
def test_exact_matches_reference_including_clip(n):
    rng = np.random.default_rng(n)
    nodes = rng.integers(0, 256, (n, 8, 8), dtype=np.uint8)
    nodes[: min(n, 2)] = rng.choice(np.array([0, 1, 254, 255], np.uint8), (min(n, 2), 8, 8))
    sums = rng.integers(0, 256 * 1024, (8, 8))
    sums[0, :4] = [0, 1023, 261120, 260097]  # cells where the 127 clip bites
    out = np.empty(n, np.int64)
    LowresDistance(nodes).exact(sums, out)
    np.testing.assert_array_equal(out, lowres_total_reference(sums, nodes))


def test_clip_golden():
    nodes = np.full((1, 8, 8), 255, np.uint8)
    out = np.empty(1, np.int64)
    # live all 0: |0 - 255*1024| = 261120 per cell, clipped to 127*2048 = 260096
    LowresDistance(nodes).exact(np.zeros((8, 8), np.int64), out)
    assert out[0] == 64 * 260096


@settings(max_examples=30, deadline=None)
@given(st.integers(0, 2**32 - 1), st.integers(1, 40))
def test_sad_matches_direct(seed, n):
    rng = np.random.default_rng(seed)
    nodes = rng.integers(0, 256, (n, 8, 8), dtype=np.uint8)
    image = rng.integers(0, 256, (8, 8), dtype=np.uint8)
    out = np.empty(n, np.float32)
    LowresDistance(nodes).sad(image, out)
    direct = np.abs(nodes.astype(int) - image.astype(int)).sum(axis=(1, 2))
    np.testing.assert_array_equal(out, direct)


def test_chunks_are_stitched(monkeypatch):
    monkeypatch.setattr(likelihood, "_CHUNK", 3)
    rng = np.random.default_rng(1)
    nodes = rng.integers(0, 256, (10, 8, 8), dtype=np.uint8)
    sums = rng.integers(0, 255 * 1024, (8, 8))
    out = np.empty(10, np.int64)
    LowresDistance(nodes).exact(sums, out)
    np.testing.assert_array_equal(out, lowres_total_reference(sums, nodes))


def test_lbp_distance_golden():
    d = LbpDistance(np.array([0, 0b1011, 0xFFFFFFFF], np.uint32))
    out = np.empty(3, np.uint8)
    np.testing.assert_array_equal(d(0b1011, out), [3, 0, 29])


def test_bad_nodes():
    with pytest.raises(ValueError, match=r"low-res nodes must be uint8 \(N, 8, 8\)"):
        LowresDistance(np.zeros((2, 4, 4), np.uint8))
