"""``ppaloc cpp run --live``: the live view's page, state, images and slider changes."""

from __future__ import annotations

import http.client
import io
import json
import threading
import urllib.error
import urllib.request

import numpy as np
import pytest
from PIL import Image

from ppaloc.cpp import compile_program, run_program
from ppaloc.cpp.live import PAGE, LiveError, LiveView
from ppaloc.errors import PpalocError

from .conftest import PROGRAMS, LiveClient, wait_until

LIVE = PROGRAMS / "live.cpp"
FRAMES = [np.full((64, 64), 100, np.uint8)] * 40


@pytest.fixture(scope="module")
def live_program(cxx):
    return compile_program(LIVE)


class Run(LiveClient):
    """``run_program`` with a live view in a thread; the test talks to it over HTTP."""

    def __init__(self, program=LIVE, frames=FRAMES, fps: float = 50.0, **kwargs) -> None:
        self.urls: list[str] = []
        self.view = LiveView(fps=fps, announce=self.urls.append)
        self.result = None
        self.error: Exception | None = None

        def target() -> None:
            try:
                self.result = run_program(program, frames, live=self.view, **kwargs)
            except Exception as exc:  # handed to the test
                self.error = exc

        self.thread = threading.Thread(target=target, daemon=True)
        self.thread.start()

    def get(self, path: str, headers: dict | None = None) -> tuple[int, bytes]:
        req = urllib.request.Request(self.url + path, headers=headers or {})
        try:
            with urllib.request.urlopen(req, timeout=10) as r:
                return r.status, r.read()
        except urllib.error.HTTPError as err:
            return err.code, err.read()

    def state(self) -> dict:
        return json.loads(self.get("state.json")[1])

    def wait_for(self, ready, what: str) -> dict:
        def shown() -> dict | None:
            s = self.state()
            return s if ready(s) else None

        return wait_until(shown, f"showed {what}")

    def end(self):
        self.thread.join(30)
        assert not self.thread.is_alive()
        if self.error is not None:
            raise self.error
        return self.result


def test_state_images_and_a_slider_change_reach_the_program(live_program):
    run = Run(frames=FRAMES * 3, timeout=30)  # 2.4 s of frames: room on a busy machine
    s = run.wait_for(lambda s: s["displays"] and s["texts"], "displays and text")
    assert s["program"] == "live.cpp" and s["frames"] == 120 and not s["finished"]
    assert [d["name"] for d in s["displays"]] == ["image", "mask"]
    assert s["items"] == [
        {"name": "level: ", "kind": "slider", "min": 0, "max": 100, "value": 10},
        {"name": "invert", "kind": "switch", "min": 0, "max": 1, "value": 0},
    ]
    assert s["texts"][0] == {
        "frame": 0,
        "text": "level 10 writeback 10 callback 10 (1 calls) invert 0",
    }
    status, png = run.get(s["displays"][1]["src"])
    mask = np.asarray(Image.open(io.BytesIO(png)))
    assert status == 200 and mask.shape == (64, 64)
    assert (mask == 255).all()  # 100/2 - 64 > 10 - 64 everywhere
    status, page = run.get("")
    assert status == 200 and page.decode() == PAGE

    # as --set takes it (no trailing ':'); a switch takes true
    assert run.post({"name": "level", "value": 42}) == (200, '{"name": "level: ", "value": 42}')
    assert run.post({"name": "invert", "value": True})[0] == 200
    # the state shows the values once the program has taken them, between two frames
    wanted = {"level: ": 42, "invert": 1}
    run.wait_for(lambda s: {i["name"]: i["value"] for i in s["items"]} == wanted, "the changes")
    result = run.end()
    changed = [t for t in result.texts if "level 42" in t]
    assert changed and changed[-1] == "level 42 writeback 42 callback 42 (2 calls) invert 1"
    assert result.texts[-1] == changed[-1]
    logged = [t for _, t in result.session.host_log if t.startswith("live view")]
    assert logged == [
        "live view: slider 'level: ' set to 42",
        "live view: switch 'invert' set to 1",
    ]
    assert result.session.gui_values == {"level: ": 42, "invert": 1}
    with pytest.raises(urllib.error.URLError):  # the server stopped with the run
        urllib.request.urlopen(run.url + "state.json", timeout=5)


def test_bad_requests_are_refused_in_one_line(live_program):
    run = Run(frames=FRAMES * 3, timeout=30)
    run.wait_for(lambda s: s["items"], "the sliders")
    bad = [
        ({"name": "level", "value": 101}, "'level: '=101 is outside the slider's range [0, 100]"),
        ({"name": "level", "value": "7"}, "'level: ' takes an integer, not '7'"),
        ({"name": "level", "value": 1.5}, "'level: ' takes an integer, not 1.5"),
        ({"name": "level", "value": True}, "'level: ' takes an integer, not True"),
        (
            {"name": "gain", "value": 1},
            "'gain' is not a slider or switch of live.cpp (it has: 'level: ', 'invert')",
        ),
        ({"name": "level"}, 'POST /set takes {"name": TEXT, "value": INT} exactly'),
        (b"level=3", "POST /set: the body is not JSON"),
        (
            b"[" * 2000 + b"]" * 2000,  # under MAX_BODY: once a traceback on the terminal
            'POST /set: the body nests too deeply; send {"name": TEXT, "value": INT}',
        ),
    ]
    for body, message in bad:
        assert run.post(body) == (400, message + "\n"), body
    assert run.post({"name": "level", "value": 3}, kind="text/plain")[0] == 400
    for path in ("etc/passwd", "../../etc/passwd", "display/9.png", "state.json/x", "%2e%2e/"):
        status, body = run.get(path)
        assert status == 404 and body.count(b"\n") == 1, path
    status, body = run.get("state.json", headers={"Host": "evil.example:80"})
    assert status == 403 and b"loopback" in body
    conn = http.client.HTTPConnection(run.url.split("/")[2], timeout=10)
    conn.request("POST", "/state.json", body=b"{}", headers={"Content-Type": "application/json"})
    assert conn.getresponse().status == 404
    conn.close()
    assert run.end().session.gui_values == {"level: ": 10, "invert": 0}


def test_a_range_the_program_sets_holds_the_pages_values(cxx):
    # vs_gui_set_slider_range was recorded only: the page kept the declared range, and a
    # value outside the program's new one reached it (50 with the range [0, 20])
    run = Run(program=PROGRAMS / "narrow.cpp", frames=FRAMES * 3, timeout=30)
    s = run.wait_for(lambda s: any(t["text"] == "frame 3 level 10" for t in s["texts"]), "")
    assert s["items"] == [{"name": "level: ", "kind": "slider", "min": 0, "max": 20, "value": 10}]
    assert run.post({"name": "level", "value": 50}) == (
        400,
        "'level: '=50 is outside the slider's range [0, 20]\n",
    )
    assert run.post({"name": "level", "value": 20})[0] == 200
    result = run.end()
    assert result.texts[-1].endswith("level 20")
    assert (2, "vs_gui_set_slider_range(1, 0, 20)") in result.session.host_log


def test_a_value_set_before_the_program_narrowed_the_range_is_held_to_it():
    # set on the page while the range was [0, 100]; the program narrowed it to [0, 20]
    # before the frame boundary that applies it: the host's slider holds 20, as it holds
    # an initial value outside the range at the nearer end
    from ppaloc.cpp.server import GuiItem, Session
    from ppaloc.sim import Scamp5

    class Page:
        def frame_done(self, session):
            return [("level: ", 50)]

    session = Session(Scamp5(4, 4), [np.zeros((4, 4), np.uint8)] * 2, live=Page())
    session.gui_items["level: "] = GuiItem("slider", "level: ", 0, 20, 7)
    session.gui_values["level: "] = 10
    assert session.loop() == 1
    assert session.gui_values["level: "] == 20 and session._changes == [(7, 20)]
    assert session.host_log[-1] == (
        0,
        "live view: slider 'level: ' set to 50, outside its range [0, 20] since the program "
        "set it: 20",
    )


def test_a_hang_still_ends_the_run_and_the_server(cxx, tmp_path):
    compile_program(PROGRAMS / "faults.cpp")
    run = Run(PROGRAMS / "faults.cpp", FRAMES[:1], settings={"fault": 1}, timeout=2)
    assert run.state()["program"] == "faults.cpp"
    with pytest.raises(PpalocError, match=r"did not finish within 2 s \(stopped in frame 0\)"):
        run.end()
    with pytest.raises(urllib.error.URLError):
        urllib.request.urlopen(run.url, timeout=5)


def test_bad_views_are_refused():
    for kwargs, message in [
        ({"port": 70000}, r"--port 70000 must be in \[0, 65535\]"),
        ({"port": True}, r"--port True must be"),
        ({"host": "a b"}, r"--host 'a b' must be a host name"),
        ({"fps": 0}, r"fps=0 must be"),
    ]:
        with pytest.raises(LiveError, match=message):
            LiveView(**kwargs)


def test_a_port_in_use_is_one_line_and_a_view_serves_one_run():
    from ppaloc.cpp.server import Session
    from ppaloc.sim import Scamp5

    session = Session(Scamp5(4, 4), [], program="p.cpp")
    first = LiveView()
    first.open(session)
    try:
        with pytest.raises(LiveError, match=r"one run: make a new one"):
            first.open(session)
        with pytest.raises(
            LiveError,
            match=rf"^live view cannot listen on 127\.0\.0\.1:{first.port}: .*\(give another "
            r"--port, or 0 for a free one\)$",
        ):
            LiveView(port=first.port).open(session)
        # an address this machine does not have: the host is at fault, not the port (the
        # advice was another --port)
        with pytest.raises(
            LiveError,
            match=r"^live view cannot listen on 192\.0\.2\.1:0: .*\(give --host an address of "
            r"this machine: 127\.0\.0\.1 for it alone, 0\.0\.0\.0 for every network\)$",
        ):
            LiveView(host="192.0.2.1").open(session)
    finally:
        first.close(session)


@pytest.mark.slow
def test_chromium_shows_the_displays_and_sets_a_slider(live_program, dump_dom):
    # 8 s of frames: the page's slider change must come before the last (3.2 s had 4x slack)
    run = Run(frames=FRAMES * 2, fps=10, timeout=60)
    run.wait_for(lambda s: s["items"], "the sliders")
    out = dump_dom(run.url + "?set=level=42", 3000)
    result = run.end()
    dom = out.stdout
    assert dom.count('data-loaded="1"') == 2, out.stderr[-2000:]
    assert 'data-set="ok"' in dom and '<h1 id="title">live.cpp</h1>' in dom
    assert "level 42 writeback 42 callback 42 (2 calls)" in result.texts[-1]


@pytest.mark.slow
def test_the_page_shows_a_range_the_program_sets(cxx, dump_dom):
    # the page gave a slider its min and max once, when it first showed it: the range the
    # program set later reached the state but not the page, whose slider kept [0, 100]
    import re

    program = PROGRAMS / "narrow_on_set.cpp"
    compile_program(program)
    run = Run(program=program, frames=FRAMES * 2, fps=10, timeout=60)  # as above
    run.wait_for(lambda s: s["items"], "the slider")
    out = dump_dom(run.url + "?set=level=42", 3000)
    result = run.end()
    assert "level 42 narrowed 1" in result.texts, result.texts[-3:]
    found = re.search(r'<input name="level: " type="range" min="(\d+)" max="(\d+)"', out.stdout)
    assert found is not None and found.groups() == ("0", "20"), out.stdout[-2000:]


def test_a_button_pressed_on_the_page_runs_its_callback_once_a_press(cxx):
    run = Run(program=PROGRAMS / "button.cpp", frames=FRAMES * 3, timeout=30)
    s = run.wait_for(lambda s: s["texts"], "text")
    assert s["items"] == [{"name": "store", "kind": "button", "min": 0, "max": 1, "value": 0}]
    assert run.post({"name": "store", "value": 1})[0] == 200
    run.wait_for(lambda s: any(t["text"] == "pressed 1" for t in s["texts"]), "the press")
    assert run.post({"name": "store", "value": 1})[0] == 200
    run.wait_for(lambda s: any(t["text"] == "frame 2" for t in s["texts"]), "a second press")
    result = run.end()
    assert result.texts[0] == "frame 0" and result.texts.count("pressed 1") == 2
