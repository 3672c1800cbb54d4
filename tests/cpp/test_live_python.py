"""The live view fed by a Python program: displays, text, sliders and switches."""

from __future__ import annotations

import io
import json
import threading
import urllib.error
import urllib.request

import numpy as np
import pytest
from PIL import Image

from ppaloc.cpp.live import LiveError, LiveView, image_8bit
from ppaloc.cpp.livestate import Refused

from .conftest import LiveClient, wait_until

RAMP = np.arange(12, dtype=np.float64).reshape(3, 4)  # 0 .. 11: scaled to 0 .. 255


class Loop(LiveClient):
    """A Python program in a thread: per frame it reads a slider and a switch, shows an
    image and a line of text, until it reads level 42 (or 1500 frames: 15 s for the page's
    change to come on a loaded machine; the loop ends at 42)."""

    def __init__(self) -> None:
        self.urls: list[str] = []
        self.view = LiveView(program="demo loop", frames=1500, fps=100, announce=self.urls.append)
        self.read: list[tuple[int, bool]] = []
        self.error: Exception | None = None
        self.thread = threading.Thread(target=self._run, daemon=True)
        self.thread.start()

    def _run(self) -> None:
        try:
            with self.view as view:
                for _ in range(1500):
                    level = view.slider("level", 0, 100, 10)
                    invert = view.switch("invert")
                    self.read.append((level, invert))
                    view.display("ramp", RAMP)
                    view.display("mask", (RAMP > level / 10) != invert)
                    view.text(f"level {level} invert {int(invert)}")
                    view.frame_done()
                    if level == 42:
                        break
        except Exception as exc:  # handed to the test
            self.error = exc

    def get(self, path: str) -> bytes:
        with urllib.request.urlopen(self.url + path, timeout=10) as r:
            return r.read()

    def end(self) -> None:
        self.thread.join(30)
        assert not self.thread.is_alive()
        if self.error is not None:
            raise self.error


def test_a_display_a_slider_and_a_switch_reach_the_python_program():
    loop = Loop()

    def shown() -> dict | None:
        s = json.loads(loop.get("state.json"))
        return s if len(s["displays"]) == 2 and s["texts"] else None

    s = wait_until(shown, "showed the displays and text")
    assert s["program"] == "demo loop" and s["frames"] == 1500 and not s["finished"]
    assert [(d["id"], d["name"]) for d in s["displays"]] == [(0, "ramp"), (1, "mask")]
    assert s["displays"][0]["src"].startswith("display/0.png?v=")
    assert s["items"] == [
        {"name": "level", "kind": "slider", "min": 0, "max": 100, "value": 10},
        {"name": "invert", "kind": "switch", "min": 0, "max": 1, "value": 0},
    ]
    assert s["texts"][0] == {"frame": 0, "text": "level 10 invert 0"}
    ramp = np.asarray(Image.open(io.BytesIO(loop.get(s["displays"][0]["src"]))))
    assert ramp.tolist() == [[0, 23, 46, 70], [93, 116, 139, 162], [185, 209, 232, 255]]
    mask = np.asarray(Image.open(io.BytesIO(loop.get(s["displays"][1]["src"]))))
    assert mask.tolist() == [[0, 0, 255, 255], [255] * 4, [255] * 4]  # RAMP > 1

    assert loop.post({"name": "invert", "value": True}) == (200, '{"name": "invert", "value": 1}')
    assert loop.post({"name": "level", "value": 42}) == (200, '{"name": "level", "value": 42}')
    assert loop.post({"name": "level", "value": 101}) == (
        400,
        "'level'=101 is outside the slider's range [0, 100]\n",
    )
    loop.end()
    assert loop.read[0] == (10, False) and loop.read[-1] == (42, True)
    assert set(loop.read) <= {(10, False), (10, True), (42, True)}  # as set, in order
    final = loop.view.state()
    assert final["finished"] and final["frame"] == len(loop.read)
    assert final["texts"][-1] == {"frame": len(loop.read) - 1, "text": "level 42 invert 1"}
    mask = np.asarray(Image.open(io.BytesIO(loop.view.png(1))))
    assert mask.tolist() == [[255] * 4, [255, 0, 0, 0], [0] * 4]  # RAMP <= 4.2
    with pytest.raises(urllib.error.URLError):  # the server stopped with the program
        urllib.request.urlopen(loop.url + "state.json", timeout=5)


def test_changes_wait_for_the_frame_boundary_and_are_given_back():
    with LiveView(fps=10_000) as view:
        assert view.slider("gain", -5, 5, 0) == 0
        assert view.set("gain", -5) == ("gain", -5)
        assert view.slider("gain", -5, 5, 0) == 0  # not before the frame ends
        assert view.state()["items"][0]["value"] == -5  # the page shows the queued value
        assert view.frame_done() == [("gain", -5)]
        assert view.slider("gain", -5, 5, 0) == -5
        assert view.frame_done() == []
        view.text("a line", frame=7)
        view.display("d", np.zeros((2, 2), np.uint8), frame=1)
    s = view.state()
    assert s["frame"] == 2 and s["finished"] and s["frames"] is None
    assert s["texts"] == [{"frame": 7, "text": "a line"}] and s["displays"][0]["frame"] == 1
    with pytest.raises(Refused, match="python has finished: nothing more to set"):
        view.set("gain", 1)


def test_bad_displays_and_items_are_refused_in_one_line():
    view = LiveView()
    view.slider("level", 0, 10, 5)
    for call, message in [
        (lambda: view.display("d", np.zeros((2, 2, 3))), r"display 'd': an image is a 2-D array"),
        (lambda: view.display("d", np.array([["a"]])), r"got shape \(1, 1\) of <U1"),
        (lambda: view.display("", np.zeros((2, 2))), r"display name '' must be a non-empty"),
        (lambda: view.slider("s", 5, 1, 3), r"slider 's': give lo <= value <= hi"),
        (lambda: view.slider("s", 0, 9, 1.5), r"slider 's': value=1.5 must be an integer"),
        (lambda: view.slider("level", 0, 20, 5), r"slider 'level' \[0, 20\] was declared as"),
        (lambda: view.switch("level"), r"switch 'level' \[0, 1\] was declared as slider"),
        (lambda: LiveView(program=""), r"program='' must be a non-empty name"),
        (lambda: LiveView(frames=-1), r"frames=-1 must be a count"),
        (lambda: LiveView(fps=1e-300), r"fps=1e-300 must be .* in \[0.001, 10000\]"),
    ]:
        with pytest.raises(LiveError, match=message):
            call()
    with pytest.raises(Refused, match=r"'gain' is not a slider or switch of python"):
        view.set("gain", 1)
    with pytest.raises(LiveError, match="serves one run"):
        view.start().start()
    view.close()


def test_image_8bit_draws_every_kind_of_image():
    assert image_8bit(np.array([[3, 200]], np.uint8)).tolist() == [[3, 200]]
    assert image_8bit(np.array([[-1, 1]])).tolist() == [[0, 255]]
    assert image_8bit(np.full((1, 2), 7.0)).tolist() == [[128, 128]]
    assert image_8bit(np.array([[np.nan, 2.0, 4.0]])).tolist() == [[0, 0, 255]]
    assert image_8bit(np.array([[np.nan]])).tolist() == [[0]]
