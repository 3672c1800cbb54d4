"""docs/datasets.md's first example: on the shared Nordland copy, each commented line
shows what it gives (its station stop's accepted set had gone stale)."""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np

DOC = Path(__file__).resolve().parents[2] / "docs" / "datasets.md"
BLOCK = re.findall(r"```python\n(.*?)```", DOC.read_text(), re.S)[0]


def _shown(expression: str) -> str:
    """The comment on the example's line that evaluates ``expression``."""
    (line,) = [ln for ln in BLOCK.splitlines() if ln.startswith(expression + " ")]
    return line.split("#", 1)[1].strip()


def test_the_examples_comments_are_what_the_lines_give(nordland_dir):
    from ppaloc.datasets import load_dataset, to_sensor

    spec = re.search(r'load_dataset\("([^"]+)"\)', BLOCK)[1]
    assert spec.startswith("nordland:../shared/data/nordland-64x32?")
    ds = load_dataset(spec.replace("../shared/data/nordland-64x32", str(nordland_dir)))
    assert _shown("len(ds.reference), len(ds.query)") == f"{len(ds.reference)}, {len(ds.query)}"
    assert _shown("ds.ground_truth[100]") == repr(np.asarray(ds.ground_truth[100]))
    stop = np.asarray(ds.ground_truth[150])
    assert np.array_equal(stop, np.arange(stop[0], stop[-1] + 1))  # one run of frames
    assert _shown("ds.ground_truth[150]").startswith(
        f"array([{stop[0]}, {stop[1]}, ..., {stop[-1]}]): a station stop"
    )
    roles = _shown('ds.meta["roles"]')
    assert roles.startswith("{'database': " + repr(ds.meta["roles"]["database"]) + ", ...}")
    assert _shown("sensor_image = to_sensor(ds.query[100])").startswith("(256, 256) uint8")
    assert to_sensor(ds.query[100]).shape == (256, 256)
