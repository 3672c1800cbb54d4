"""docs/cpp.md's examples run as written."""

from __future__ import annotations

import contextlib
import io
import re
import shlex
from pathlib import Path

import numpy as np
import pytest

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


def test_the_live_view_python_example():
    code = _blocks("python")[0]
    assert "with LiveView(" in code
    printed = io.StringIO()
    with contextlib.redirect_stdout(printed):
        exec(
            compile(code.replace("announce=print", "fps=1000, announce=print"), "cpp.md", "exec"),
            ns := {},
        )
    assert re.fullmatch(r"http://127\.0\.0\.1:\d+/\n", printed.getvalue())
    state = ns["view"].state()
    assert state["finished"] and state["frame"] == 10
    assert [d["name"] for d in state["displays"]] == ["frame", "mask"]
    assert state["texts"][-1]["text"].startswith("threshold 128: ")


def test_the_kernel_export_example():
    code = _blocks("python")[1]
    shown = DOC.read_text().split(code, 1)[1].split("```", 1)[1].split("\n\n", 2)[1]
    printed = io.StringIO()
    with contextlib.redirect_stdout(printed):
        exec(compile(code, "cpp.md", "exec"), {})
    want = "\n".join(line[4:] for line in shown.splitlines())
    assert printed.getvalue().strip() == want.strip()


def test_the_trace_export_example():
    code = _blocks("python")[2]
    namespace: dict = {}
    printed = io.StringIO()
    with contextlib.redirect_stdout(printed):
        exec(compile(code, "cpp.md", "exec"), namespace)
    claim = next(ln for ln in code.splitlines() if ln.startswith("print")).split("# ")[1]
    assert printed.getvalue().strip() == claim
    tracer, loc = namespace["tracer"], namespace["loc"]
    # not the mapping sensor; the filter's and its speed lanes' (a sensor each)
    lanes = [lane.sim for lane in loc.schedule.lanes]
    assert [t.sim for t in tracer.traces] == [loc.pipeline.sim, *lanes]
    assert namespace["source"].startswith("// a ppaloc program\n")


def test_the_frame_source_examples(cxx, tmp_path, monkeypatch):
    import shutil

    import av
    from PIL import Image

    from ppaloc.cli.main import cli

    from .test_frame_sources import _write_video

    (block,) = _blocks("sh")
    monkeypatch.chdir(tmp_path)
    shutil.copy(PROGRAMS / "means.cpp", "means.cpp")
    Path("frames").mkdir()
    for i in range(3):
        Image.fromarray(np.full((24, 32), 40 * i, np.uint8)).save(f"frames/f{i}.png")
    _write_video(Path("clip.mkv"), [10, 50, 90, 130])
    try:
        av.open("testsrc", format="lavfi").close()
        lavfi = True
    except Exception:  # FFmpeg built without lavfi: its line is skipped
        lavfi = False
    ran = {}
    for line in block.strip().splitlines():
        args = shlex.split(line)
        assert args[:3] == ["ppaloc", "cpp", "run"]
        if "lavfi" in args and not lavfi:
            continue
        cli.main(args[1:], standalone_mode=False)
        out = args[args.index("--out") + 1]
        ran[out] = Path(out, "text.txt").read_text().splitlines()
    assert ran["run-folder"] == ["frame 0: mean 0.0", "frame 1: mean 40.0", "frame 2: mean 80.0"]
    assert len(ran["run-video"]) == 2  # ?step=2 of 4
    if lavfi:
        assert len(ran["run-stream"]) == 3


def test_the_refusal_shown_for_a_users_file_in_saved_is_the_real_one(tmp_path, monkeypatch):
    from ppaloc.cpp.run import check_output_folder
    from ppaloc.errors import PpalocError

    (tmp_path / "run" / "saved").mkdir(parents=True)
    (tmp_path / "run" / "summary.json").write_text('{"files": ["saved/edge.bmp"]}')
    (tmp_path / "run" / "saved" / "edge.bmp").write_bytes(b"BM")
    (tmp_path / "run" / "saved" / "notes.txt").write_text("keep me")
    monkeypatch.chdir(tmp_path)
    with pytest.raises(PpalocError) as info:
        check_output_folder("run")
    assert f"`{info.value}`" in " ".join(DOC.read_text().split())
