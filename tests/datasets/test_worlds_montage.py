"""The montage of the new worlds (docs/img/synthetic-worlds.png)."""

import numpy as np
from PIL import Image

from ppaloc.datasets.synthetic.montage import WORLD_ROWS, _pick_frames, worlds_montage


def test_pick_frames_half_straight_half_turning():
    turning = np.zeros(100, bool)
    turning[30:36] = turning[70:80] = True
    picks = _pick_frames(turning, 4)
    assert len(picks) == 4 and sum(turning[picks]) == 2
    assert len(_pick_frames(np.zeros(50, bool), 4)) == 4  # a straight route: straight frames


def test_worlds_montage_writes_a_png(tmp_path):
    out = worlds_montage(tmp_path / "w.png", frames=2)
    with Image.open(out) as im:
        rows = sum(len(c) for _, _, c in WORLD_ROWS)
        assert im.size == (150 + 2 * 256, rows * (256 + 20))
