"""A display output's own scan (``scamp5_output_events``, ``_boundingbox``) is host-side
time, the frame's ``loop_us``, as ``scamp5_output_image``'s is (docs/cpp.md, "Modelled
time"): the chip's part of a frame is the same with and without it (programs/outputs.cpp)."""

from __future__ import annotations

import numpy as np
import pytest

from ppaloc.cpp import compile_program, run_program

from .conftest import PROGRAMS

SOURCE = PROGRAMS / "outputs.cpp"
FRAMES = [np.full((16, 16), 90, np.uint8)] * 3


@pytest.fixture(scope="module")
def runs(cxx):
    compile_program(SOURCE)
    return [
        run_program(SOURCE, FRAMES, settings={"mode": str(mode)}, timeout=60).timing()
        for mode in (0, 1)
    ]


def test_an_outputs_scan_is_loop_time_not_the_chips(runs):
    shown, hidden = runs
    for a, b in zip(shown["frames"], hidden["frames"], strict=True):
        assert a["chip_us"] == pytest.approx(b["chip_us"])
        assert a["loop_us"] > b["loop_us"]
        assert a["modelled_us"] - b["modelled_us"] == pytest.approx(a["loop_us"] - b["loop_us"])
