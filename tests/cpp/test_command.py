"""``ppaloc cpp run``'s inputs: --set values and the frames of an image or a dataset."""

from __future__ import annotations

import numpy as np
import pytest
from PIL import Image

from ppaloc.cpp.command import load_frames, parse_settings
from ppaloc.errors import PpalocError


def test_parse_settings():
    assert parse_settings(["threshold=30", " dilate = off"]) == {"threshold": "30", "dilate": "off"}
    with pytest.raises(PpalocError, match="must be NAME=VALUE"):
        parse_settings(["threshold"])


def test_frames_from_an_image(tmp_path):
    path = tmp_path / "scene.png"
    Image.fromarray(np.full((40, 60), 200, np.uint8)).save(path)
    frames = load_frames(path, None, 3)
    assert len(frames) == 3 and frames[0].shape == (256, 256) and frames[0].dtype == np.uint8
    assert int(frames[0][100, 100]) == 200


def test_frames_from_a_dataset_and_defaults():
    frames = load_frames(None, "synthetic:?places=12&seed=2", 2)
    assert len(frames) == 2 and frames[1].shape == (256, 256)
    assert load_frames(None, None, None) is None  # run_program's default scene
    assert len(load_frames(None, None, 2)) == 2
    with pytest.raises(PpalocError, match="not both"):
        load_frames("a.png", "synthetic:", None)
    with pytest.raises(PpalocError, match=r"--frames 0 must be in \[1, 2000\]"):
        load_frames(None, None, 0)
    with pytest.raises(PpalocError, match="held in memory"):  # refused before any is made
        load_frames(None, None, 10**8)


@pytest.mark.parametrize("timeout", [float("inf"), float("nan"), 1e300, 0, -1])
def test_a_timeout_out_of_range_is_refused_before_the_build(tmp_path, timeout):
    from ppaloc.cpp.run import run_program

    with pytest.raises(PpalocError, match=r"timeout=.* must be a number of seconds in"):
        run_program(tmp_path / "none.cpp", timeout=timeout)
