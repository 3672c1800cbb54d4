"""Lazy frame sequences: loaded on access, sliceable, cached, read-only."""

from __future__ import annotations

import numpy as np
import pytest

from ppaloc.datasets.frames import FrameSequence, RenderedFrames


def _counting(n: int, cache: int = 4):
    calls: list[int] = []

    def load(i: int) -> np.ndarray:
        calls.append(i)
        return np.full((2, 3), i, np.uint8)

    return FrameSequence(load, range(n), cache=cache), calls


def test_nothing_loaded_until_access_and_slices_stay_lazy():
    seq, calls = _counting(100)
    assert len(seq) == 100 and calls == []
    sub = seq[10:50:10]
    assert len(sub) == 4 and calls == []
    assert sub[1][0, 0] == 20 and sub[-1][0, 0] == 40
    assert calls == [20, 40]
    assert sub.source_indices.tolist() == [10, 20, 30, 40]
    assert [int(f[0, 0]) for f in sub[::2]] == [10, 30]


def test_lru_cache_keeps_recent_frames_only():
    seq, calls = _counting(10, cache=2)
    seq[0], seq[1], seq[0], seq[2], seq[1]
    # 0 and 1 load; 0 is a hit; 2 evicts 1 (least recent); 1 loads again.
    assert calls == [0, 1, 2, 1]


def test_frames_are_read_only_and_index_checked():
    seq, _ = _counting(3)
    with pytest.raises(ValueError, match="read-only"):
        seq[0][0, 0] = 9
    with pytest.raises(IndexError, match="frame index 3 out of range for 3 frames"):
        seq[3]


def test_rendered_frames_select_positions():
    seq = RenderedFrames(lambda i: np.array([[i]], np.uint8), 6)
    assert [int(f[0, 0]) for f in seq.select([5, 0, 2])] == [5, 0, 2]


def test_image_frames_pickle(tmp_path):
    import pickle

    from PIL import Image

    from ppaloc.datasets.frames import ImageFrames

    for k in range(3):
        Image.fromarray(np.full((2, 2), 10 * k, np.uint8)).save(tmp_path / f"{k}.png")
    seq = ImageFrames(sorted(tmp_path.glob("*.png")))[1:]
    again = pickle.loads(pickle.dumps(seq))
    assert [int(f[0, 0]) for f in again] == [10, 20]
