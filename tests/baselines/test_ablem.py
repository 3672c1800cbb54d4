"""ABLE-M: sequence distances by recurrence equal the direct sums; lock-on; errors."""

from __future__ import annotations

import numpy as np
import pytest

from ppaloc.baselines.ablem import ABLEM, sequence_distances
from ppaloc.baselines.ldb import hamming_distances
from ppaloc.errors import PpalocError


def test_sequence_distances_golden() -> None:
    history = np.array([[1.0, 2.0, 3.0], [4.0, 5.0, 6.0]])  # frames t-1, t
    # node 0: h_t[0] + fill; node 1: h_t[1] + h_{t-1}[0]; node 2: h_t[2] + h_{t-1}[1]
    np.testing.assert_allclose(sequence_distances(history, 10.0), [14.0, 6.0, 8.0])


def test_online_recurrence_equals_direct_sum(toy_route) -> None:
    ref, query = toy_route
    a = ABLEM(length=4, record_weights=True)
    a.build_map(ref)
    per_frame = []
    for t, frame in enumerate(query[:12]):
        e = a.step(frame)
        per_frame.append(hamming_distances(a.describe(frame), a.map.descriptors))
        hist = np.array(per_frame[-4:], dtype=np.float64)
        expected = sequence_distances(hist, a.fill) + (4 - len(hist)) * a.fill
        np.testing.assert_array_equal(-e.weights, expected, err_msg=f"frame {t}")


def test_locks_on_the_toy_route(toy_route) -> None:
    ref, query = toy_route
    a = ABLEM()
    a.build_map(ref)
    est = [a.step(f) for f in query]
    nodes = np.array([e.node for e in est])
    assert np.mean(np.abs(nodes[3:] - np.arange(13, 50)) <= 1) >= 0.95
    assert all(0.0 <= e.score <= 1.0 for e in est)


def test_map_holds_packed_codes(toy_route) -> None:
    ref, _ = toy_route
    m = ABLEM(n_bits=None).build_map(ref[:20])
    assert m.kind == "able-m" and m.descriptors.shape == (20, 174)  # 1386 bits -> 174 bytes
    assert m.descriptors.dtype == np.uint8


def test_default_code_is_openables_1384_bits(toy_route) -> None:
    # OpenABLE's LDB (built with its TRAINING switch on) keeps 1384 of the 1386 comparisons,
    # a 173-byte code per image, not the 256-bit code of LDB's learned table.
    ref, _ = toy_route
    a = ABLEM()
    assert a.n_bits == 1384 and a.n_bytes == 173
    assert a.build_map(ref[:3]).descriptors.shape == (3, 173)


def test_ratio_confidence(toy_route) -> None:
    ref, query = toy_route
    a = ABLEM(confidence="ratio")
    a.build_map(ref)
    scores = [a.step(f).score for f in query]
    assert all(0.0 <= s <= 1.0 for s in scores) and scores[-1] > 0.3


def test_user_errors_name_the_fix(toy_route) -> None:
    ref, _ = toy_route
    with pytest.raises(PpalocError, match="length=0 must be at least 1 frame"):
        ABLEM(length=0)
    with pytest.raises(PpalocError, match="confidence='best' is unknown"):
        ABLEM(confidence="best")
    m = ABLEM(n_bits=256).build_map(ref[:3])
    with pytest.raises(PpalocError, match=r"shape \(32,\) but these parameters give \(174,\)"):
        ABLEM(n_bits=None).use_map(m)
