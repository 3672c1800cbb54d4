"""docs/cpp.md's examples run as written."""

from __future__ import annotations

import contextlib
import io
import re

import numpy as np

from ppaloc.cpp import run_program
from ppaloc.sim.demo import synthetic_scene

from .conftest import PROGRAMS

DOC = PROGRAMS.parents[2] / "docs" / "cpp.md"


def _blocks(lang: str) -> list[str]:
    return re.findall(rf"```{lang}\n(.*?)```", DOC.read_text(), flags=re.S)


def test_the_example_program(cxx, tmp_path):
    path = tmp_path / "edges.cpp"
    path.write_text(_blocks("cpp")[0])
    frames = [synthetic_scene(seed=i) for i in range(3)]
    result = run_program(path, frames, settings={"threshold": "30"}, out=tmp_path / "run")
    assert len([t for t in result.texts if t.startswith("edge pixels")]) == 3
    for frame, out in zip(frames, result.session.outputs, strict=True):
        c = frame.astype(np.float32) / 2 - 64
        east = np.zeros_like(c)
        east[:, :-1] = c[:, 1:]
        d = np.abs(c - east)
        r5 = d - 30 > 0
        r6 = np.zeros_like(r5)
        r6[1:] |= r5[:-1]  # the north neighbour's bit
        r6[:, :-1] |= r5[:, 1:]  # the east neighbour's bit
        np.testing.assert_array_equal(out[1], d)
        np.testing.assert_array_equal(out[2], r5 | r6)
    assert (tmp_path / "run" / "displays" / "mask" / "frame_0002.png").exists()


def test_the_kernel_export_example():
    code = _blocks("python")[0]
    shown = DOC.read_text().split(code, 1)[1].split("```", 1)[1].split("\n\n", 2)[1]
    printed = io.StringIO()
    with contextlib.redirect_stdout(printed):
        exec(compile(code, "cpp.md", "exec"), {})
    want = "\n".join(line[4:] for line in shown.splitlines())
    assert printed.getvalue().strip() == want.strip()


def test_the_trace_export_example():
    code = _blocks("python")[1]
    namespace: dict = {}
    printed = io.StringIO()
    with contextlib.redirect_stdout(printed):
        exec(compile(code, "cpp.md", "exec"), namespace)
    claim = next(ln for ln in code.splitlines() if ln.startswith("print")).split("# ")[1]
    assert printed.getvalue().strip() == claim
    tracer, loc = namespace["tracer"], namespace["loc"]
    assert [t.sim for t in tracer.traces] == [loc.pipeline.sim]  # not the mapping sensor
    assert namespace["source"].startswith("// a ppaloc program\n")
