"""``vs_post_text``'s console commands (vs_post.hpp): ``!clear`` empties the host app's
console (the live view's text panel), ``!save NAME`` keeps its text under ``saved/``;
``text.txt`` keeps every post as it was sent (programs/console.cpp)."""

from __future__ import annotations

import json

import numpy as np
import pytest

from ppaloc.cpp import compile_program, run_program
from ppaloc.cpp.live import LiveView
from ppaloc.cpp.server import HANDLERS, Session
from ppaloc.sim import Scamp5

from .conftest import PROGRAMS

SOURCE = PROGRAMS / "console.cpp"
FRAMES = [np.zeros((8, 8), np.uint8)] * 4


@pytest.fixture(scope="module")
def result(cxx, tmp_path_factory):
    compile_program(SOURCE)
    out = tmp_path_factory.mktemp("console") / "run"
    return run_program(SOURCE, FRAMES, out=out, timeout=60), out


def test_clear_empties_the_console_and_save_keeps_what_it_holds(result):
    run, out = result
    s = run.session
    assert s.saved == {
        "first.txt": "a0\n",
        "console_0002.txt": "c1\n",  # "!save" without a name: the frame's
        "notes/log.txt": "c1\n!saved\n",  # "!saved" is text, not a command
    }
    assert s.console == [(1, "c1"), (2, "!saved")] and s.console_clears == 2
    saved = out / "saved"
    assert (saved / "first.txt").read_text() == "a0\n"
    assert (saved / "notes" / "log.txt").read_text() == "c1\n!saved\n"
    files = json.loads((out / "summary.json").read_text())["files"]
    assert files == ["saved/console_0002.txt", "saved/first.txt", "saved/notes/log.txt"]


def test_text_txt_keeps_every_post_as_sent(result):
    _, out = result
    assert (out / "text.txt").read_text() == "\n".join(
        [
            "frame 0: a0",
            "frame 0: !save first",
            "frame 1: !clear",
            "frame 1: b1",
            "frame 1: !clear\nc1",  # a post of two lines: one entry
            "frame 2: !save",
            "frame 2: !save ../outside",
            "frame 2: !saved",
            "frame 3: !save notes/log.txt\n",
        ]
    )


def test_a_name_outside_the_runs_folder_is_a_warning_and_saves_nothing(result):
    run, out = result
    assert [w for w in run.session.warnings if "!save" in w] == [
        "console.cpp: vs_post_text('!save ../outside'): not saved: '..' would leave the "
        "run's folder: give a path inside it, e.g. 'edge.bmp'"
    ]
    assert not (out / "outside.txt").exists() and not (out.parent / "outside.txt").exists()


def test_the_live_views_text_panel_follows_the_console():
    session = Session(Scamp5(4, 4), [np.zeros((4, 4), np.uint8)])
    view = LiveView(announce=lambda url: None)

    def post(text: str) -> list[str]:
        HANDLERS["vs_post_text"](session, [text], 0)
        view._take(session, finished=False)
        return [t["text"] for t in view.live_state.state()["texts"]]

    assert post("one") == ["one"]
    assert post("two") == ["one", "two"]
    assert post("!clear") == []
    assert post("!clear\nthree") == ["three"]
    assert post("!save kept") == ["three"]
    assert session.saved == {"kept.txt": "three\n"}
