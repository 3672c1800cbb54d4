"""Small generated dataset layouts (written under tmp_path)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from PIL import Image


def _write_frames(folder: Path, values, names=None, size=(12, 16), colour=False) -> list[Path]:
    """Write one flat image per value (grey level = value) and return the paths."""
    folder.mkdir(parents=True, exist_ok=True)
    paths = []
    for k, v in enumerate(values):
        name = names[k] if names is not None else f"Image{k:03d}.png"
        a = np.full(size, int(v), np.uint8)
        if colour:
            a = np.stack([a, a, a], -1)
        p = folder / name
        Image.fromarray(a).save(p)
        paths.append(p)
    return paths


@pytest.fixture
def write_frames():
    """``write_frames(folder, values, names=None, size=(12, 16), colour=False) -> paths``."""
    return _write_frames
