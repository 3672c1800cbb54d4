"""The difference matrix: hand-computed entries, the sampling rule, recorded from the frames
a run streams (each read once), and the single-frame estimate on each row's minimum."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from ppaloc.datasets import RouteDataset
from ppaloc.evaluate import difference as difference_module
from ppaloc.evaluate.config import EvaluateConfig
from ppaloc.evaluate.difference import (
    DifferenceMatrix,
    DifferenceRecorder,
    difference_matrix,
    sample_indices,
)
from ppaloc.evaluate.run import run_evaluation
from ppaloc.methods import make_localiser

C = math.sqrt(63 / 64)
"""|z| of every pixel of an 8x8 patch that is half one level, half another (Bessel's std)."""


def pattern(kind: str) -> np.ndarray:
    """A sensor frame whose 64x32 block means are ``kind`` in every 8x8 patch: ``h`` top
    half bright, ``H`` bottom half bright, ``v`` left half, ``V`` right half, ``flat``."""
    patch = np.full((8, 8), 50, np.uint8)
    if kind == "h":
        patch[:4] = 150
    elif kind == "H":
        patch[4:] = 150
    elif kind == "v":
        patch[:, :4] = 150
    elif kind == "V":
        patch[:, 4:] = 150
    image = np.tile(patch, (4, 8))  # (32, 64): the single-frame image size
    return np.kron(image, np.ones((8, 4), np.uint8))  # its exact block means


REFERENCE = ["h", "H", "v", "V", "flat", "h"]
QUERY = ["h", "v", "H", "flat", "V"]


def expected(q: str, r: str) -> float:
    """Mean |z_q - z_r| per pixel: 0 alike, 2C opposite, C across h/v or against flat."""
    if q == r:
        return 0.0
    if "flat" in (q, r):
        return C
    return 2 * C if q.lower() == r.lower() else C


GOLDEN = np.array([[expected(q, r) for r in REFERENCE] for q in QUERY], dtype=np.float32)


class Counted(list):
    """Frames that count how often each is read."""

    def __init__(self, frames: list[np.ndarray]) -> None:
        super().__init__(frames)
        self.reads = [0] * len(frames)

    def __getitem__(self, i):
        if isinstance(i, slice):
            raise AssertionError("a recorder must not slice the traversal")
        self.reads[i] += 1
        return super().__getitem__(i)

    def __iter__(self):
        for i in range(len(self)):
            yield self[i]


def test_a_5x6_matrix_by_hand():
    assert GOLDEN[0].tolist() == pytest.approx([0, 2 * C, C, C, C, 0])  # the golden itself
    d = difference_matrix([pattern(k) for k in REFERENCE], [pattern(k) for k in QUERY])
    assert d.values.shape == (5, 6) and d.values.dtype == np.float32
    np.testing.assert_allclose(d.values, GOLDEN, atol=2e-6)
    assert d.query_index.tolist() == [0, 1, 2, 3, 4]
    assert d.reference_index.tolist() == [0, 1, 2, 3, 4, 5]
    assert d.strides == (1, 1) and d.sampling() == "every frame"


def test_recorded_as_frames_pass_reads_each_frame_once():
    ref = Counted([pattern(k) for k in REFERENCE])
    qry = Counted([pattern(k) for k in QUERY])
    rec = DifferenceRecorder(len(ref), len(qry))
    for _ in rec.watch_reference(ref):  # a map build reads the traversal in order
        pass
    watched = rec.watch_query(qry)
    for i in range(len(qry)):
        watched[i]  # a run reads each query frame before its step
    d = rec.result(ref, qry)
    np.testing.assert_allclose(d.values, GOLDEN, atol=2e-6)
    assert ref.reads == [1] * 6 and qry.reads == [1] * 5
    assert rec.reference_seconds > 0


def test_frames_a_method_skipped_are_read_at_the_end():
    ref = Counted([pattern(k) for k in REFERENCE])
    qry = Counted([pattern(k) for k in QUERY])
    rec = DifferenceRecorder(len(ref), len(qry))
    seen = rec.watch_reference(ref)
    seen[0], seen[2]  # a build that read two frames only
    rec.watch_query(qry)[1]
    d = rec.result(ref, qry)
    np.testing.assert_allclose(d.values, GOLDEN, atol=2e-6)
    assert ref.reads == [1] * 6 and qry.reads == [1] * 5


def test_sampled_entries_are_the_full_matrix_entries():
    rng = np.random.default_rng(3)
    frames = [rng.integers(0, 256, (256, 256), dtype=np.uint8) for _ in range(10)]
    full = difference_matrix(frames, frames[:7])
    part = difference_matrix(frames, frames[:7], limit=4)
    assert part.query_index.tolist() == [0, 2, 4, 6] and part.reference_index.tolist() == [
        0,
        3,
        6,
        9,
    ]
    np.testing.assert_array_equal(part.values, full.values[np.ix_([0, 2, 4, 6], [0, 3, 6, 9])])
    assert part.sampling() == "one query frame in 2, one reference frame in 3"
    assert difference_matrix(frames, []) is None and difference_matrix([], frames) is None


@given(n=st.integers(0, 5000), limit=st.integers(1, 600))
def test_the_sampling_rule(n, limit):
    idx = sample_indices(n, limit)
    assert len(idx) <= limit and len(idx) == min(n, len(idx))
    if n:
        step = -(-n // limit)
        assert idx[0] == 0 and idx[-1] > n - 1 - step and idx[-1] <= n - 1
        assert np.all(np.diff(idx) == step)
    else:
        assert len(idx) == 0


def test_sample_indices_refuses_a_limit_below_one():
    with pytest.raises(ValueError, match="limit must be at least 1, got 0"):
        sample_indices(5, 0)


def textured_route(n: int = 24) -> RouteDataset:
    """A route of random block textures; the query sees the same places with noise."""
    rng = np.random.default_rng(7)
    blocks = np.ones((16, 16), np.uint8)
    ref = [np.kron(rng.integers(0, 256, (16, 16), np.uint8), blocks) for _ in range(n)]
    qry = [
        np.clip(f.astype(int) + rng.integers(-40, 41, f.shape), 0, 255).astype(np.uint8)
        for f in ref
    ]
    truth = [np.array([j]) for j in range(n)]
    return RouteDataset("textured", ref, qry, truth, tolerance=0, meta={"spec": "textured"})


def test_a_run_records_it_and_single_frame_lies_on_each_rows_minimum():
    ds = textured_route()
    single = make_localiser("single-frame")
    result = run_evaluation(
        EvaluateConfig(), dataset=ds, localisers={"single-frame": single}, progress=False
    )
    d = result.difference
    assert isinstance(d, DifferenceMatrix) and d.values.shape == (24, 24)
    run = result.runs["single-frame"]
    rows = np.arange(24)
    np.testing.assert_allclose(d.values[rows, run.ref_index], d.values.min(axis=1), rtol=1e-6)
    assert np.all(d.values.argmin(axis=1) == rows)  # the images alone find every place here


def test_the_recorders_time_is_taken_off_the_first_methods_build(monkeypatch):
    class Clock:  # every reading an hour later: the recorder's work looks very long
        now = 0.0

        def perf_counter(self) -> float:
            self.now += 3600.0
            return self.now

    monkeypatch.setattr(difference_module, "time", Clock())
    ds = textured_route(6)
    result = run_evaluation(
        EvaluateConfig(),
        dataset=ds,
        localisers={"a": make_localiser("single-frame"), "b": make_localiser("single-frame")},
        progress=False,
    )
    assert result.runs["a"].build_s == 0.0  # hours of recorder time off a real build
    assert 0.0 < result.runs["b"].build_s < 3600.0  # the other method's build untouched
