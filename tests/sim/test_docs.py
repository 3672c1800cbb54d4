"""The Python examples of docs/sim.md and docs/sim-controller.md run as written and
compute what they claim."""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pytest

from ppaloc.sim import R5, A
from ppaloc.sim.demo import synthetic_scene

DOCS = Path(__file__).resolve().parents[2] / "docs"
DOC = DOCS / "sim.md"


def python_blocks(doc: Path = DOC) -> list[str]:
    return re.findall(r"```python\n(.*?)```", doc.read_text(encoding="utf-8"), re.S)


def run(block: str, capsys: pytest.CaptureFixture[str]) -> tuple[dict, list[str]]:
    """Execute a block; return its namespace and the printed lines with the comment
    each ``print`` line carries (``print(x)  # expected``)."""
    ns: dict = {}
    exec(compile(block, str(DOC), "exec"), ns)
    printed = capsys.readouterr().out.splitlines()
    claimed = [ln.split("#", 1)[1].strip() for ln in block.splitlines() if ln.startswith("print")]
    return ns, list(zip(printed, claimed, strict=True))


def test_there_are_two_examples() -> None:
    assert len(python_blocks()) == 2


def test_programming_model_example(capsys) -> None:
    ns, printed = run(python_blocks()[0], capsys)
    for got, claim in printed:
        assert got == claim
    y = ns["frame"] / 2 - 64  # get_image: p/2 - 64
    east_y = np.pad(y[:, 1:], ((0, 0), (0, 1)))  # 0 beyond the east edge
    assert np.array_equal(ns["edges"], np.clip(y - east_y, -128, 127))
    # the replay captured the second scene
    y2 = synthetic_scene(seed=1) / 2 - 64
    assert np.array_equal(ns["sim"].read(A), y2)


def test_porting_example_matches_numpy(capsys) -> None:
    ns, printed = run(python_blocks()[1], capsys)
    for got, claim in printed:
        assert got == claim
    y = ns["frame"] / 2 - 64
    east_y = np.pad(y[:, 1:], ((0, 0), (0, 1)))
    grad = np.minimum(np.abs(np.clip(y - east_y, -128, 127)), 127)
    r5 = grad - ns["threshold"] > 0
    north = np.pad(r5[:-1, :], ((1, 0), (0, 0)))
    east = np.pad(r5[:, 1:], ((0, 0), (0, 1)))
    expected = r5 | north | east
    assert 0.01 < expected.mean() < 0.5  # edges of the shapes: neither all nor nothing
    assert np.array_equal(ns["edges"], expected)


def test_controller_host_example(capsys) -> None:
    (block,) = python_blocks(DOCS / "sim-controller.md")
    ns, printed = run(block, capsys)
    assert len(printed) == 4
    for got, claim in printed:
        assert got == claim
    assert ns["sim"].read(R5).sum() == 2
