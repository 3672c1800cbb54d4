"""The real Nordland half route (1788 summer frames) as a map of both kinds."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from ppaloc.datasets import load_dataset
from ppaloc.topomap import TopoMap, build_topomap

pytestmark = pytest.mark.data


@pytest.fixture(scope="module")
def summer(nordland_dir: Path) -> list[np.ndarray]:
    data = load_dataset(f"nordland:{nordland_dir}?ref=summer&query=winter")
    return [np.asarray(f) for f in data.reference]


@pytest.mark.parametrize(("kind", "tiles"), [("lowres", 2), ("lbp", 1)])
def test_nordland_map_fits_and_round_trips(
    summer: list[np.ndarray], kind: str, tiles: int, tmp_path: Path
) -> None:
    m = build_topomap(summer, kind, dataset="nordland summer")
    assert len(m) == 1788 and m.n_tiles == tiles
    rects = m.layout.pe_rects(len(m))
    assert rects[:, 0].max() == tiles - 1
    loaded = TopoMap.load(m.save(tmp_path / f"{kind}.npz"))
    assert loaded.equals(m) and loaded.provenance["dataset"] == "nordland summer"


def test_nordland_keyframes_drop_repeats(summer: list[np.ndarray]) -> None:
    # The first three frames are blank and the train stops a few times: identical
    # consecutive views collapse into one node.
    m = build_topomap(summer, "lowres", keyframe_threshold=0)
    assert 1000 < len(m) < 1788
    assert m.frame_index[0] == 0 and m.frame_index[1] >= 3
