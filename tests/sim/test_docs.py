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
    y = ns["frame"] - 128.0  # get_image(A, B): the full range, p - 128
    east_y = np.pad(y[:, 1:], ((0, 0), (0, 1)))  # 0 beyond the east edge
    assert np.array_equal(ns["edges"], np.clip(y - east_y, -128, 127))
    # the replay captured the second scene
    y2 = synthetic_scene(seed=1) - 128.0
    assert np.array_equal(ns["sim"].read(A), y2)


def test_porting_example_matches_numpy(capsys) -> None:
    ns, printed = run(python_blocks()[1], capsys)
    for got, claim in printed:
        assert got == claim
    y = ns["frame"] - 128.0
    east_y = np.pad(y[:, 1:], ((0, 0), (0, 1)))
    grad = np.minimum(np.abs(np.clip(y - east_y, -128, 127)), 127)
    r5 = grad - ns["threshold"] > 0
    north = np.pad(r5[:-1, :], ((1, 0), (0, 0)))
    east = np.pad(r5[:, 1:], ((0, 0), (0, 1)))
    expected = r5 | north | east
    assert 0.01 < expected.mean() < 0.5  # edges of the shapes: neither all nor nothing
    assert np.array_equal(ns["edges"], expected)


def test_controller_host_example(capsys) -> None:
    _, block = python_blocks(DOCS / "sim-controller.md")
    ns, printed = run(block, capsys)
    assert len(printed) == 4
    for got, claim in printed:
        assert got == claim
    assert ns["sim"].read(R5).sum() == 2


def test_observer_example_counts_what_ran(capsys) -> None:
    block, _ = python_blocks(DOCS / "sim-controller.md")
    ns, printed = run(block, capsys)
    assert len(printed) == 2
    for got, claim in printed:
        assert got == claim
    assert ns["sim"].observers == ()  # detached at the end of the with block
    assert len(ns["edges"]) == 4  # movx and sub: 2 ICWs each, run twice


def test_porting_kernel_spreads_a_lone_one_south_and_west() -> None:
    from ppaloc.sim import R6, R7, Scamp5, east, north

    sim = Scamp5(5, 5)
    lone = np.zeros((5, 5), dtype=bool)
    lone[2, 2] = True
    sim.write(R5, lone)
    with sim.kernel() as k:  # the last two lines of the porting example
        k.DNEWS(R6, R5, north | east)
        k.OR(R7, R5, R6)
    assert sorted(map(tuple, np.argwhere(sim.read(R7)).tolist())) == [(2, 1), (2, 2), (3, 2)]
    text = DOC.read_text(encoding="utf-8")
    assert "dilated by one element south and west" in text
    assert "north and east" not in text.split("ports line by line")[1].split("```")[1]


def test_every_python_name_of_the_cpp_table_exists() -> None:
    from ppaloc.sim import Scamp5

    text = DOC.read_text(encoding="utf-8")
    table = text.split("### C++ names and their Python spelling")[1].split("\n\n")[2]
    names = re.findall(r"`(k|sim)\.(\w+)\(", table)
    assert len(names) > 90
    sim = Scamp5(2, 2)
    kernel = sim.kernel()
    for owner, name in names:
        assert callable(getattr(kernel if owner == "k" else sim, name)), f"{owner}.{name}"
