"""The controller's threshold search (``detect.largest_met``) and its start from the last
frame's values on the sensor."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import example, given
from hypothesis import strategies as st

from ppaloc.localise.params import FilterParams
from ppaloc.onsensor import detect
from ppaloc.onsensor.pipeline import make_pipeline
from ppaloc.sim import C


@given(
    lo=st.integers(-130, 130),
    width=st.integers(0, 260),
    answer_at=st.integers(-1, 260),
    guess=st.none() | st.integers(-140, 400),
)
@example(lo=-127, width=254, answer_at=127, guess=0)  # the answer is the top of the range
@example(lo=-127, width=254, answer_at=-1, guess=120)  # no t holds: gallops down to lo
def test_the_search_finds_the_largest_value_the_test_holds_for(lo, width, answer_at, guess):
    hi = lo + width
    answer = lo + min(answer_at, width)  # lo - 1: the test holds nowhere in the range
    probes: list[int] = []

    def test(t: int) -> bool:
        assert lo <= t <= hi, "a probe outside the range"
        probes.append(t)
        return t <= answer

    got = detect.largest_met(test, lo, hi, guess)
    assert got == (answer if answer >= lo else None)
    assert len(probes) == len(set(probes)), "a value tested twice"
    if guess is None:
        assert len(probes) <= 1 + max(width, 1).bit_length()
    else:
        g = min(max(guess, lo), hi)
        assert len(probes) <= 2 * abs(max(answer, lo) - g).bit_length() + 2


def _lbp_pipe(n: int):
    params = FilterParams.create("lbp", arithmetic="ppa8", motion="always_forward")
    return make_pipeline("lbp", n, params, size=64)


@pytest.mark.parametrize(("last_top", "tests"), [(None, 9), (30, 2), (31, 2), (29, 3), (-90, 15)])
def test_detection_searches_from_the_last_frames_threshold(monkeypatch, last_top, tests):
    """The same ``T`` from any start; from last frame's value two ``global_or`` tests,
    where a bisection of -127..127 takes nine."""
    n = 60
    pipe = _lbp_pipe(n)
    t, br, bc = pipe.layout.node_to_block(np.arange(n))
    values = np.full(n, -20.0, np.float32)
    values[[3, 41]] = 30.8, 12.0
    w = np.full((64, 64), 99.0, np.float32)  # only the node roots count
    w[br * 4, bc * 8 + t] = values
    pipe.sim.write(C, w)
    calls = []
    at_least = detect.at_least
    monkeypatch.setattr(detect, "at_least", lambda *a: calls.append(a[2]) or at_least(*a))
    pipe.state.last_top = last_top
    assert detect.local_top(pipe.sensor, pipe.state) == 30
    assert (len(calls), pipe.state.last_top) == (tests, 30)
    # the confidence's search starts at T minus last frame's gap: 30 - 18 = 12, found at once
    calls.clear()
    pipe.state.last_gap = 18
    assert detect.outside_max(pipe.sensor, pipe.state, 0, 10, 30) == 12
    assert (calls, pipe.state.last_gap) == ([12, 13], 18)
    pipe.state.reset()
    assert (pipe.state.last_top, pipe.state.last_gap) == (None, None)
