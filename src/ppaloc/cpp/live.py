"""A live view of a running program: displays, sliders, switches and text in a browser.

:class:`LiveView` serves one self-contained page (no external assets) over HTTP
(:class:`http.server.ThreadingHTTPServer`, standard library only) showing a
:class:`~ppaloc.cpp.livestate.LiveState`: displays by name with their newest image and the
frame it came from, sliders and switches with their ranges and values, posted text, and
frames done of total. The page polls ``state.json`` (every 100 ms) and loads each display's
newest image as a PNG. A slider or switch moved (a button pressed) on the page is POSTed to
``set``, checked against the item's range, and reaches the program at its next frame
boundary.

Two kinds of producer fill the state. A C++ run: :func:`ppaloc.cpp.run.run_program` opens
the view on its session (:class:`ppaloc.cpp.server.Session`), which hands it what each
frame produced at the frame loop control, where the device applies the host's GUI messages
(value, writeback variable, ``vs_on_gui_update`` callback). Any Python program: used as a
context manager, the view is fed through :meth:`LiveView.display`, :meth:`LiveView.text`,
:meth:`LiveView.slider`, :meth:`LiveView.switch` and :meth:`LiveView.frame_done`, which
applies the page's changes between frames the same way (``ppaloc localise --live`` shows
the on-sensor localiser so).

The server answers only ``/`` (the page), ``/state.json``, ``/display/HANDLE.png`` and a
POST to ``/set``; everything else is a 404. It listens on 127.0.0.1 unless another host is
given, refuses a request whose ``Host`` header names another machine while it listens on
the loopback (a web page elsewhere cannot reach it through DNS rebinding), and takes only
JSON posts (a form on another site cannot post one without the browser asking first).
Frames are paced to at most ``fps`` per second so a person can watch and steer them.
"""

from __future__ import annotations

import errno
import json
import re
import socket
import threading
import time
from collections.abc import Callable
from http.server import BaseHTTPRequestHandler, ThreadingHTTPServer
from types import TracebackType
from typing import Any

import numpy as np

from ppaloc.cpp.livestate import TEXT_LINES, LiveState
from ppaloc.cpp.livestate import Refused as _Refused
from ppaloc.cpp.server import Session, gui_name
from ppaloc.errors import PpalocError
from ppaloc.sim.render import plane_to_image

__all__ = ["MAX_FPS", "MIN_FPS", "PAGE", "TEXT_LINES", "LiveError", "LiveView", "image_8bit"]

#: Largest POST body taken, bytes.
MAX_BODY = 4096
_LOOPBACK = frozenset({"127.0.0.1", "localhost", "::1"})
_SLIDER_LIMIT = 2**31 - 1


MIN_FPS, MAX_FPS = 0.001, 10_000
"""The pacing a live view takes: at the slowest a frame every 1000 s (a slower one would
wait beyond what a timer holds), at the fastest 10,000 a second."""


class LiveError(PpalocError):
    """A live view that cannot start (a bad host or port, an address in use) or a bad
    display, slider or switch given by the program feeding it."""


def image_8bit(array: np.ndarray) -> np.ndarray:
    """An image a Python program displays, as 8-bit grey: how :meth:`LiveView.display`
    draws it.

    ``uint8`` is shown as it is, ``bool`` as 0/255, any other number scaled so its
    smallest value is black and its largest white (a constant image is mid-grey); NaN is
    black.

    Examples
    --------
    >>> image_8bit(np.array([[0.0, 0.5, 1.0]])).tolist()
    [[0, 128, 255]]
    >>> image_8bit(np.array([[True, False]])).tolist()
    [[255, 0]]
    """
    arr = np.asarray(array)
    if arr.dtype == np.uint8:
        return arr
    if arr.dtype == bool:
        return np.where(arr, 255, 0).astype(np.uint8)
    a = arr.astype(np.float64)
    finite = np.isfinite(a)
    if not finite.any():
        return np.zeros(a.shape, np.uint8)
    lo, hi = float(a[finite].min()), float(a[finite].max())
    if hi == lo:
        return np.where(finite, 128, 0).astype(np.uint8)
    scaled = np.floor((np.where(finite, a, lo) - lo) / (hi - lo) * 255 + 0.5)
    return scaled.astype(np.uint8)


class LiveView:
    """Serve a run's displays, sliders, switches and posted text to a browser as it runs.

    Parameters
    ----------
    host : str
        Address to listen on; ``127.0.0.1`` (this machine only) by default.
    port : int
        Port in [0, 65535]; 0 picks a free one (:attr:`url` says which).
    fps : float
        Most frames per second the run is let through, so it can be watched; > 0.
    announce : callable, optional
        Called with the page's URL once the server listens (the CLI prints it on stderr).
    program : str
        The page's title for a Python program (a C++ run shows its source's name).
    frames : int, optional
        Frames a Python program will run, for the page's "N of M" (None: not known).

    Notes
    -----
    For a C++ run the view is a :class:`ppaloc.cpp.server.LiveHook`:
    :func:`ppaloc.cpp.run.run_program` opens it after compiling, sets it on the session
    and closes it when the run ends, however it ends. Time spent pacing frames does not
    count against the run's timeout.

    A Python program opens it with ``with`` (or :meth:`start` and :meth:`close`) and, per
    frame, reads its sliders and switches, shows images and text, and ends the frame with
    :meth:`frame_done`, which paces the frames and applies the values set on the page
    since the last frame: a slider moved on the page changes what :meth:`slider` returns
    from the next frame on.

    Examples
    --------
    >>> import numpy as np
    >>> with LiveView(program="demo", frames=2, fps=1000) as view:
    ...     for k in range(2):
    ...         level = view.slider("level", 0, 255, 40)
    ...         view.display("mask", np.arange(16).reshape(4, 4) > level // 16)
    ...         view.text(f"level {level}")
    ...         changes = view.frame_done()  # the page's changes, applied
    >>> view.live_state.state()["frame"], view.live_state.state()["finished"]
    (2, True)
    """

    def __init__(
        self,
        host: str = "127.0.0.1",
        port: int = 0,
        *,
        fps: float = 30.0,
        announce: Callable[[str], None] | None = None,
        program: str = "python",
        frames: int | None = None,
    ) -> None:
        if not isinstance(host, str) or not re.fullmatch(r"[A-Za-z0-9.:\-\[\]]+", host):
            raise LiveError(f"--host {host!r} must be a host name or address, e.g. 127.0.0.1")
        if isinstance(port, bool) or not isinstance(port, int) or not 0 <= port <= 65535:
            raise LiveError(f"--port {port!r} must be in [0, 65535] (0 picks a free port)")
        if not (isinstance(fps, int | float) and MIN_FPS <= fps <= MAX_FPS):
            raise LiveError(
                f"fps={fps!r} must be a number of frames per second in [{MIN_FPS}, {MAX_FPS}]"
            )
        if not isinstance(program, str) or not program:
            raise LiveError(f"program={program!r} must be a non-empty name for the page")
        if frames is not None and (
            isinstance(frames, bool) or not isinstance(frames, int) or frames < 0
        ):
            raise LiveError(f"frames={frames!r} must be a count >= 0, or None when not known")
        self.host = host.strip("[]")
        self.port = port
        self.fps = float(fps)
        self.announce = announce
        self.waited_s = 0.0
        self.live_state = LiveState(program, frames)
        self._seen_texts = 0  # the session's console lines shown, since its last clear
        self._seen_clears = 0
        self._handles: dict[str, int] = {}  # a Python program's displays by name
        self._last = 0.0
        self._httpd: ThreadingHTTPServer | None = None
        self._thread: threading.Thread | None = None

    # ------------------------------------------------------------ lifetime
    @property
    def url(self) -> str:
        """The page's address (after :meth:`open` or :meth:`start`)."""
        host = f"[{self.host}]" if ":" in self.host else self.host
        return f"http://{host}:{self.port}/"

    def open(self, session: Session) -> None:
        """Listen, serve in a background thread, and attach to ``session`` (a C++ run)."""
        if self._thread is not None:
            raise LiveError("a LiveView serves one run: make a new one for the next run")
        self.live_state.program = session.program
        self.live_state.frames = session.source.bound  # the most: a stream may end sooner
        self._serve()
        session.live = self

    def start(self) -> LiveView:
        """Listen and serve in a background thread, for a Python program to feed."""
        if self._thread is not None:
            raise LiveError("a LiveView serves one run: make a new one for the next run")
        self._serve()
        return self

    def _serve(self) -> None:
        handler = type("Handler", (_Handler,), {"view": self})
        server_cls = ThreadingHTTPServer
        if ":" in self.host:  # an IPv6 address
            server_cls = type(
                "Server6", (ThreadingHTTPServer,), {"address_family": socket.AF_INET6}
            )
        try:
            self._httpd = server_cls((self.host, self.port), handler)
        except OSError as exc:  # the host's fault (no such name, not this machine's) or the port's
            host = isinstance(exc, socket.gaierror) or exc.errno == errno.EADDRNOTAVAIL
            fix = (
                "give --host an address of this machine: 127.0.0.1 for it alone, 0.0.0.0 "
                "for every network"
                if host
                else "give another --port, or 0 for a free one"
            )
            raise LiveError(
                f"live view cannot listen on {self.host}:{self.port}: {exc.strerror or exc} ({fix})"
            ) from None
        self._httpd.daemon_threads = True
        self.port = self._httpd.server_address[1]
        self._thread = threading.Thread(
            target=self._httpd.serve_forever, kwargs={"poll_interval": 0.05}, daemon=True
        )
        self._thread.start()
        self._last = time.perf_counter()
        if self.announce is not None:
            self.announce(self.url)

    def close(self, session: Session | None = None) -> None:
        """Take the run's last outputs (a C++ run's ``session``; a Python program's run is
        marked finished) and stop the server."""
        if session is not None:
            self._take(session, finished=True)
        else:
            state = self.live_state
            state.progress(state.done, finished=True)
        if self._httpd is not None:
            self._httpd.shutdown()
            self._httpd.server_close()
            self._httpd = None

    def __enter__(self) -> LiveView:
        return self.start()

    def __exit__(
        self,
        kind: type[BaseException] | None,
        exc: BaseException | None,
        tb: TracebackType | None,
    ) -> None:
        self.close()

    # ------------------------------------------------------------ the frame boundary
    def frame_done(self, session: Session | None = None) -> list[tuple[str, int]]:
        """End a frame: take what it produced (a C++ run's ``session``), wait out the
        frame pacing, and give the item changes set on the page since the last frame,
        ``(name, value)``, already checked against the items' ranges.

        A Python program calls it without arguments at the end of each frame; the changes
        are applied to its sliders and switches before it returns.
        """
        if session is not None:
            self._take(session, finished=False)
        wait = 1.0 / self.fps - (time.perf_counter() - self._last)
        if wait > 0:
            time.sleep(wait)
            self.waited_s += wait
        self._last = time.perf_counter()
        state = self.live_state
        with state.batch():
            changes = state.take_changes()
            if session is None:
                for name, value in changes:
                    item = state.item(name)
                    assert item is not None  # set() takes only declared items
                    state.put_item(name, item["kind"], item["min"], item["max"], value)
                state.progress(state.done + 1, finished=False)
        return changes

    def _take(self, session: Session, *, finished: bool) -> None:
        frame = session.frame
        outputs = session.outputs[frame] if len(session.outputs) > frame else {}
        cleared = session.console_clears != self._seen_clears
        if cleared:  # the console was cleared since the last frame shown
            self._seen_clears, self._seen_texts = session.console_clears, 0
        texts = session.console[self._seen_texts :]
        self._seen_texts += len(texts)
        state = self.live_state
        with state.batch():
            state.name_displays(session.displays)
            for handle, plane in outputs.items():
                state.put_display(handle, plane, frame, plane_to_image)
            if cleared:
                state.clear_texts()
            state.put_texts(texts)
            for text, item in session.gui_items.items():
                value = session.gui_values.get(text, item.lo)
                state.put_item(text, item.kind, item.lo, item.hi, value)
            state.progress(
                min(session.loops, session.source.taken),  # passes begun, ended here
                finished=finished,
                # a stream that ended sooner: what it gave
                frames=session.source.taken if finished and session.finished else None,
            )

    # ------------------------------------------------------------ a Python program's side
    def display(self, name: str, image: np.ndarray, frame: int | None = None) -> None:
        """Show ``image`` ((rows, cols): uint8 as it is, bool 0/255, other numbers scaled
        from their smallest to their largest; :func:`image_8bit`) as display ``name``,
        from ``frame`` (default: the current frame, the count of :meth:`frame_done` calls).
        """
        if not isinstance(name, str) or not name:
            raise LiveError(f"display name {name!r} must be a non-empty string")
        arr = np.asarray(image)
        if arr.ndim != 2 or 0 in arr.shape or not (arr.dtype == bool or arr.dtype.kind in "uif"):
            raise LiveError(
                f"display {name!r}: an image is a 2-D array of numbers (rows, cols); got "
                f"shape {arr.shape} of {arr.dtype}"
            )
        state = self.live_state
        with state.batch():
            handle = self._handles.setdefault(name, len(self._handles))
            at = state.done if frame is None else int(frame)
            state.put_display(handle, arr.copy(), at, image_8bit, name=name)

    def text(self, line: str, frame: int | None = None) -> None:
        """Post a line of text from ``frame`` (default: the current frame)."""
        state = self.live_state
        with state.batch():
            state.put_texts([(state.done if frame is None else int(frame), str(line))])

    def slider(self, name: str, lo: int, hi: int, value: int) -> int:
        """A slider's value: declared with range [lo, hi] and starting ``value`` at the
        first call, then as the page last set it (applied at :meth:`frame_done`)."""
        return self._item(name, "slider", lo, hi, value)

    def switch(self, name: str, value: bool = False) -> bool:
        """A switch's state: ``value`` at the first call, then as the page last set it."""
        return bool(self._item(name, "switch", 0, 1, int(bool(value))))

    def _item(self, name: str, kind: str, lo: int, hi: int, value: int) -> int:
        if not isinstance(name, str) or not name:
            raise LiveError(f"a {kind}'s name {name!r} must be a non-empty string")
        for what, v in (("lo", lo), ("hi", hi), ("value", value)):
            if isinstance(v, bool) or not isinstance(v, int | np.integer):
                raise LiveError(f"{kind} {name!r}: {what}={v!r} must be an integer")
        lo, hi, value = int(lo), int(hi), int(value)
        if not -_SLIDER_LIMIT <= lo <= value <= hi <= _SLIDER_LIMIT:
            raise LiveError(
                f"{kind} {name!r}: give lo <= value <= hi (32-bit integers); got "
                f"lo={lo}, value={value}, hi={hi}"
            )
        state = self.live_state
        with state.batch():
            item = state.item(name)
            if item is None:
                state.put_item(name, kind, lo, hi, value)
                return value
            if (item["kind"], item["min"], item["max"]) != (kind, lo, hi):
                raise LiveError(
                    f"{kind} {name!r} [{lo}, {hi}] was declared as {item['kind']} "
                    f"[{item['min']}, {item['max']}]: give one name one kind and range"
                )
            return int(item["value"])

    # ------------------------------------------------------------ the browser's side
    def state(self) -> dict[str, Any]:
        """What the page shows, JSON-ready (:meth:`LiveState.state`)."""
        return self.live_state.state()

    def png(self, handle: int) -> bytes:
        """Display ``handle``'s newest image as PNG bytes (encoded once per update)."""
        return self.live_state.png(handle)

    def set(self, name: object, value: object) -> tuple[str, int]:
        """Queue a slider's or switch's new value for the next frame; refuse a bad one.

        ``name`` is the item's text as declared or without its trailing ``:`` (as
        ``--set`` takes it); ``value`` an integer in the item's range (a switch also takes
        ``true``/``false``).
        """
        return self.live_state.set(name, value, match=gui_name)


class _Handler(BaseHTTPRequestHandler):
    """The page, its state and its images; nothing else."""

    view: LiveView
    server_version = "ppaloc-live"
    sys_version = ""

    def log_message(self, format: str, *args: Any) -> None:
        """Quiet: the run prints its own summary."""

    def _send(self, status: int, body: bytes, kind: str) -> None:
        self.send_response(status)
        self.send_header("Content-Type", kind)
        self.send_header("Content-Length", str(len(body)))
        self.send_header("Cache-Control", "no-store")
        self.send_header("X-Content-Type-Options", "nosniff")
        self.end_headers()
        if self.command != "HEAD":
            self.wfile.write(body)

    def _refuse(self, exc: _Refused) -> None:
        self._send(exc.status, (str(exc) + "\n").encode(), "text/plain; charset=utf-8")

    def _check_host(self) -> None:
        if self.view.host not in _LOOPBACK:
            return
        host = self.headers.get("Host", "")
        bare = host.rsplit(":", 1)[0] if not host.endswith("]") else host
        if bare.strip("[]") not in _LOOPBACK:
            raise _Refused(403, f"Host {host!r}: the live view answers its loopback address only")

    def do_GET(self) -> None:
        """``/``, ``/state.json``, ``/display/HANDLE.png``."""
        try:
            self._check_host()
            path = self.path.split("?", 1)[0]
            if path in ("/", "/index.html"):
                self._send(200, PAGE.encode(), "text/html; charset=utf-8")
            elif path == "/state.json":
                self._send(200, json.dumps(self.view.state()).encode(), "application/json")
            elif m := re.fullmatch(r"/display/(\d{1,9})\.png", path):
                self._send(200, self.view.png(int(m.group(1))), "image/png")
            else:
                raise _Refused(404, f"{path[:80]!r}: the live view serves /, /state.json and "
                               "/display/HANDLE.png only")  # fmt: skip
        except _Refused as exc:
            self._refuse(exc)

    do_HEAD = do_GET

    def do_POST(self) -> None:
        """``/set`` with ``{"name": TEXT, "value": INT}``: a slider's or switch's value."""
        try:
            self._check_host()
            if self.path.split("?", 1)[0] != "/set":
                raise _Refused(404, f"{self.path[:80]!r}: the live view takes POST /set only")
            if self.headers.get_content_type() != "application/json":
                raise _Refused(400, 'POST /set takes JSON: {"name": "threshold", "value": 30}')
            try:
                size = int(self.headers.get("Content-Length", ""))
            except ValueError:
                raise _Refused(400, "POST /set needs a Content-Length") from None
            if not 0 < size <= MAX_BODY:
                raise _Refused(400, f"POST /set takes a body of 1 to {MAX_BODY} bytes")
            try:
                body = json.loads(self.rfile.read(size))
            except (ValueError, UnicodeDecodeError):
                raise _Refused(400, "POST /set: the body is not JSON") from None
            except RecursionError:  # "[[[[..." within MAX_BODY: no traceback on the terminal
                raise _Refused(
                    400, 'POST /set: the body nests too deeply; send {"name": TEXT, "value": INT}'
                ) from None
            if not isinstance(body, dict) or set(body) != {"name", "value"}:
                raise _Refused(400, 'POST /set takes {"name": TEXT, "value": INT} exactly')
            text, value = self.view.set(body["name"], body["value"])
            self._send(200, json.dumps({"name": text, "value": value}).encode(), "application/json")
        except _Refused as exc:
            self._refuse(exc)


#: The page: plain HTML, CSS and script, no external assets. ``?set=NAME=VALUE`` (repeatable)
#: sets items once when the page opens, so a link can open the view with chosen values.
PAGE = """<!doctype html>
<html lang="en"><head><meta charset="utf-8">
<meta name="viewport" content="width=device-width, initial-scale=1">
<title>ppaloc live view</title>
<style>
body { font: 14px system-ui, sans-serif; margin: 1em; color: #222; background: #fafafa; }
h1 { font-size: 1.2em; margin: 0 0 .3em; }
#status { color: #555; margin-bottom: 1em; }
#status.ended { color: #a40; }
#displays { display: flex; flex-wrap: wrap; gap: 1em; }
figure { margin: 0; }
figure img { width: 256px; height: 256px; image-rendering: pixelated; background: #000;
             object-fit: contain; display: block; }
figcaption { font-size: .9em; color: #444; }
#items { margin: 1em 0; display: grid; grid-template-columns: max-content 20em 4em; gap: .3em 1em;
         align-items: center; }
#items output { font-variant-numeric: tabular-nums; }
#items input[type=checkbox] { justify-self: start; }
#error { color: #b00; min-height: 1.2em; }
pre { background: #fff; border: 1px solid #ddd; padding: .5em; max-height: 16em; overflow: auto; }
</style></head>
<body>
<h1 id="title">live view</h1>
<div id="status">connecting...</div>
<div id="displays"></div>
<div id="items"></div>
<div id="error"></div>
<pre id="texts"></pre>
<script>
"use strict";
const shown = new Map(), inputs = new Map();
let applied = false;
function $(id) { return document.getElementById(id); }
async function setItem(name, value) {
  const r = await fetch("set", {method: "POST", headers: {"Content-Type": "application/json"},
                                body: JSON.stringify({name: name, value: value})});
  $("error").textContent = r.ok ? "" : await r.text();
  return r.ok;
}
function applyQuery() {
  for (const pair of new URLSearchParams(location.search).getAll("set")) {
    const at = pair.lastIndexOf("=");
    if (at > 0) setItem(pair.slice(0, at), Number(pair.slice(at + 1))).then(ok => {
      document.body.dataset.set = ok ? "ok" : "refused"; });
  }
}
function showDisplays(list) {
  for (const d of list) {
    let fig = shown.get(d.id);
    if (!fig) {
      fig = document.createElement("figure");
      const img = document.createElement("img");
      img.alt = d.name;
      img.addEventListener("load", () => { img.dataset.loaded = "1"; });
      const cap = document.createElement("figcaption");
      fig.append(img, cap);
      $("displays").append(fig);
      shown.set(d.id, fig);
    }
    const img = fig.querySelector("img");
    if (img.getAttribute("src") !== d.src) img.setAttribute("src", d.src);
    fig.querySelector("figcaption").textContent = d.name + " (frame " + d.frame + ")";
  }
}
function showItems(list) {
  for (const it of list) {
    let row = inputs.get(it.name);
    if (!row) {
      const label = document.createElement("label");
      label.textContent = it.name;
      const input = document.createElement(it.kind === "button" ? "button" : "input");
      input.name = it.name;
      const out = document.createElement("output");
      if (it.kind === "button") {
        input.type = "button"; input.textContent = "press";
        input.addEventListener("click", () => setItem(it.name, 1));
      } else {
        if (it.kind === "switch") { input.type = "checkbox"; }
        else { input.type = "range"; input.min = it.min; input.max = it.max; input.step = 1; }
        input.addEventListener(it.kind === "switch" ? "change" : "input", () => {
          const v = it.kind === "switch" ? (input.checked ? 1 : 0) : Number(input.value);
          out.textContent = v;
          setItem(it.name, v);
        });
      }
      $("items").append(label, input, out);
      row = {input: input, out: out};
      inputs.set(it.name, row);
    }
    if (row.input.type === "range") {  // the program may set its range as it runs
      row.input.min = it.min; row.input.max = it.max;
    }
    if (it.kind !== "button" && document.activeElement !== row.input) {
      if (it.kind === "switch") row.input.checked = it.value !== 0;
      else row.input.value = it.value;
      row.out.textContent = it.value;
    }
  }
}
function show(s) {
  document.title = s.program + " - ppaloc live view";
  $("title").textContent = s.program;
  $("status").textContent = (s.finished ? "finished: " : "running: ") +
    s.frame + (s.frames === null ? "" : " of " + s.frames) + " frame(s)";
  showDisplays(s.displays);
  showItems(s.items);
  const pre = $("texts"), atEnd = pre.scrollTop + pre.clientHeight >= pre.scrollHeight - 4;
  pre.textContent = s.texts.map(t => "frame " + t.frame + ": " + t.text).join("\\n");
  if (atEnd) pre.scrollTop = pre.scrollHeight;  // follow the newest unless scrolled back
  document.body.dataset.frame = s.frame;
  if (!applied && s.items.length) { applied = true; applyQuery(); }
}
async function poll() {
  try {
    const r = await fetch("state.json", {cache: "no-store"});
    show(await r.json());
    setTimeout(poll, 100);
  } catch (e) {
    $("status").textContent += " - the run has ended and the live view has stopped";
    $("status").className = "ended";
  }
}
poll();
</script>
</body></html>
"""
