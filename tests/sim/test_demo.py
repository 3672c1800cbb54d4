"""The simulator demo runs end to end and its scene is seeded."""

from __future__ import annotations

import numpy as np
from PIL import Image

from ppaloc.sim.demo import DEMO_PNG, run_demo, synthetic_scene


def test_synthetic_scene_is_seeded():
    a, b, c = synthetic_scene(seed=1), synthetic_scene(seed=1), synthetic_scene(seed=2)
    assert a.dtype == np.uint8 and a.shape == (256, 256)
    assert (a == b).all() and not (a == c).all()
    assert a.min() < 30 and a.max() > 220  # dark block and bright disc


def test_run_demo_writes_montage_and_prints_timing(tmp_path, capsys):
    path = run_demo(tmp_path / "out")
    assert path == tmp_path / "out" / DEMO_PNG
    with Image.open(path) as img:
        assert img.size == (4 + 5 * (256 + 4), 4 + 256 + 14 + 4)
        px = np.asarray(img)
    edges = px[4 + 14 : 4 + 14 + 256, 4 + 4 * 260 : 4 + 4 * 260 + 256] == 255  # R5 tile
    assert 0.01 < edges.mean() < 0.1  # outlines of the shapes, not areas
    assert not edges[-1].any() and not edges[:, -1].any()  # the border is left out
    out = capsys.readouterr().out
    for stage in ("capture", "edges", "threshold", "readout", "total"):
        assert stage in out
    assert "global_count" in out
