"""A live view of a running SCAMP-5d program: displays, sliders, switches and text in a browser.

:class:`LiveView` serves one self-contained page (no external assets) over HTTP
(:class:`http.server.ThreadingHTTPServer`, standard library only) while
:func:`ppaloc.cpp.run.run_program` runs the program. At each frame loop control the session
(:class:`ppaloc.cpp.server.Session`) hands the view what the frame produced; the page polls
``state.json`` (every 100 ms) and loads each display's newest image as a PNG. A slider or
switch moved on the page is POSTed to ``set``, checked against the item's range, and
reaches the program at its next frame loop control, as the device applies the host's GUI
messages there (value, writeback variable, ``vs_on_gui_update`` callback).

The server answers only ``/`` (the page), ``/state.json``, ``/display/HANDLE.png`` and a
POST to ``/set``; everything else is a 404. It listens on 127.0.0.1 unless another host is
given, refuses a request whose ``Host`` header names another machine while it listens on
the loopback (a web page elsewhere cannot reach it through DNS rebinding), and takes only
JSON posts (a form on another site cannot post one without the browser asking first).
Frames are paced to at most ``fps`` per second so a person can watch and steer them.
"""

from __future__ import annotations

import io
import json
import re
import socket
import threading
import time
from collections.abc import Callable
from http.server import BaseHTTPRequestHandler, ThreadingHTTPServer
from typing import Any

import numpy as np
from PIL import Image

from ppaloc.cpp.server import Session, gui_name
from ppaloc.errors import PpalocError
from ppaloc.sim.render import plane_to_image

__all__ = ["PAGE", "LiveError", "LiveView"]

#: Posted text lines the state keeps (the newest).
TEXT_LINES = 200
#: Largest POST body taken, bytes.
MAX_BODY = 4096
_LOOPBACK = frozenset({"127.0.0.1", "localhost", "::1"})


class LiveError(PpalocError):
    """A live view that cannot start (a bad host or port, an address in use)."""


class _Refused(Exception):
    """A request refused with a status and a one-line message."""

    def __init__(self, status: int, message: str) -> None:
        super().__init__(message)
        self.status = status


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

    Notes
    -----
    The view is a :class:`ppaloc.cpp.server.LiveHook`: :func:`ppaloc.cpp.run.run_program`
    opens it after compiling, sets it on the session and closes it when the run ends,
    however it ends. Time spent pacing frames does not count against the run's timeout.
    """

    def __init__(
        self,
        host: str = "127.0.0.1",
        port: int = 0,
        *,
        fps: float = 30.0,
        announce: Callable[[str], None] | None = None,
    ) -> None:
        if not isinstance(host, str) or not re.fullmatch(r"[A-Za-z0-9.:\-\[\]]+", host):
            raise LiveError(f"--host {host!r} must be a host name or address, e.g. 127.0.0.1")
        if isinstance(port, bool) or not isinstance(port, int) or not 0 <= port <= 65535:
            raise LiveError(f"--port {port!r} must be in [0, 65535] (0 picks a free port)")
        if not (isinstance(fps, int | float) and 0 < fps <= 10_000):
            raise LiveError(f"fps={fps!r} must be a number of frames per second in (0, 10000]")
        self.host = host.strip("[]")
        self.port = port
        self.fps = float(fps)
        self.announce = announce
        self.waited_s = 0.0
        self._lock = threading.Lock()
        self._program = "program"
        self._frames = 0
        self._done = 0  # frames completed
        self._finished = False
        self._names: dict[int, str] = {}
        self._planes: dict[int, tuple[int, int, np.ndarray]] = {}  # handle: (serial, frame, plane)
        self._png: dict[int, tuple[int, bytes]] = {}
        self._serial = 0
        self._items: dict[str, dict[str, Any]] = {}
        self._pending: dict[str, int] = {}
        self._texts: list[tuple[int, str]] = []
        self._seen_texts = 0
        self._last = 0.0
        self._httpd: ThreadingHTTPServer | None = None
        self._thread: threading.Thread | None = None

    # ------------------------------------------------------------ lifetime
    @property
    def url(self) -> str:
        """The page's address (after :meth:`open`)."""
        host = f"[{self.host}]" if ":" in self.host else self.host
        return f"http://{host}:{self.port}/"

    def open(self, session: Session) -> None:
        """Listen, serve in a background thread, and attach to ``session``."""
        if self._thread is not None:
            raise LiveError("a LiveView serves one run: make a new one for the next run")
        self._program = session.program
        self._frames = session.source.bound  # the most: a stream may end sooner
        handler = type("Handler", (_Handler,), {"view": self})
        server_cls = ThreadingHTTPServer
        if ":" in self.host:  # an IPv6 address
            server_cls = type(
                "Server6", (ThreadingHTTPServer,), {"address_family": socket.AF_INET6}
            )
        try:
            self._httpd = server_cls((self.host, self.port), handler)
        except OSError as exc:
            raise LiveError(
                f"live view cannot listen on {self.host}:{self.port}: "
                f"{exc.strerror or exc} (give another --port, or 0 for a free one)"
            ) from None
        self._httpd.daemon_threads = True
        self.port = self._httpd.server_address[1]
        self._thread = threading.Thread(
            target=self._httpd.serve_forever, kwargs={"poll_interval": 0.05}, daemon=True
        )
        self._thread.start()
        session.live = self
        self._last = time.perf_counter()
        if self.announce is not None:
            self.announce(self.url)

    def close(self, session: Session | None = None) -> None:
        """Take the run's last outputs (when ``session`` is given) and stop the server."""
        if session is not None:
            self._take(session, finished=True)
        if self._httpd is not None:
            self._httpd.shutdown()
            self._httpd.server_close()
            self._httpd = None

    # ------------------------------------------------------------ the session's side
    def frame_done(self, session: Session) -> list[tuple[str, int]]:
        """Take the frame just ended, wait out the frame pacing, and give the changes."""
        self._take(session, finished=False)
        wait = 1.0 / self.fps - (time.perf_counter() - self._last)
        if wait > 0:
            time.sleep(wait)
            self.waited_s += wait
        self._last = time.perf_counter()
        with self._lock:
            changes = list(self._pending.items())
            self._pending.clear()
        return changes

    def _take(self, session: Session, *, finished: bool) -> None:
        frame = session.frame
        outputs = session.outputs[frame] if len(session.outputs) > frame else {}
        texts = session.texts[self._seen_texts :]
        with self._lock:
            self._seen_texts += len(texts)
            self._names = dict(session.displays)
            for handle, plane in outputs.items():
                self._serial += 1
                self._planes[handle] = (self._serial, frame, plane)
            self._texts = (self._texts + list(texts))[-TEXT_LINES:]
            for text, item in session.gui_items.items():
                self._items[text] = {
                    "name": text,
                    "kind": item.kind,
                    "min": item.lo,
                    "max": item.hi,
                    "value": session.gui_values.get(text, item.lo),
                }
            self._done = min(session.loops, session.source.taken)  # passes begun, ended here
            self._finished = finished
            if finished and session.finished:  # a stream that ended sooner: what it gave
                self._frames = session.source.taken

    # ------------------------------------------------------------ the browser's side
    def state(self) -> dict[str, Any]:
        """What the page shows, JSON-ready."""
        with self._lock:
            return {
                "program": self._program,
                "frame": self._done,
                "frames": self._frames,
                "finished": self._finished,
                "displays": [
                    {
                        "id": h,
                        "name": self._names.get(h, f"display {h}"),
                        "frame": frame,
                        "src": f"display/{h}.png?v={serial}",
                    }
                    for h, (serial, frame, _) in sorted(self._planes.items())
                ],
                "items": [
                    {**item, "value": self._pending.get(text, item["value"])}
                    for text, item in self._items.items()
                ],
                "texts": [{"frame": f, "text": t} for f, t in self._texts],
            }

    def png(self, handle: int) -> bytes:
        """Display ``handle``'s newest image as PNG bytes (encoded once per update)."""
        with self._lock:
            if handle not in self._planes:
                raise _Refused(404, f"no display {handle} has an image yet")
            serial, _, plane = self._planes[handle]
            cached = self._png.get(handle)
        if cached is not None and cached[0] == serial:
            return cached[1]
        buf = io.BytesIO()
        Image.fromarray(plane_to_image(plane)).save(buf, "PNG", compress_level=1)
        data = buf.getvalue()
        with self._lock:
            self._png[handle] = (serial, data)
        return data

    def set(self, name: object, value: object) -> tuple[str, int]:
        """Queue a slider's or switch's new value for the next frame; refuse a bad one.

        ``name`` is the item's text as declared or without its trailing ``:`` (as
        ``--set`` takes it); ``value`` an integer in the item's range (a switch also takes
        ``true``/``false``).
        """
        with self._lock:
            if not isinstance(name, str):
                raise _Refused(400, f"name {name!r} must be a slider's or switch's text")
            texts = [name] if name in self._items else [
                t for t in self._items if gui_name(t) == gui_name(name)
            ]  # fmt: skip
            if len(texts) != 1:
                known = ", ".join(repr(t) for t in self._items) or "none"
                what = "names more than one item" if texts else "is not a slider or switch"
                raise _Refused(400, f"{name!r} {what} of {self._program} (it has: {known})")
            item = self._items[texts[0]]
            if isinstance(value, bool) and item["kind"] == "switch":
                value = int(value)
            if isinstance(value, bool) or not isinstance(value, int):
                raise _Refused(400, f"{texts[0]!r} takes an integer, not {value!r}")
            if not item["min"] <= value <= item["max"]:
                raise _Refused(
                    400,
                    f"{texts[0]!r}={value} is outside the {item['kind']}'s range "
                    f"[{item['min']}, {item['max']}]",
                )
            if self._finished:
                raise _Refused(400, f"{self._program} has finished: nothing more to set")
            self._pending[texts[0]] = value
            return texts[0], value


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
      const input = document.createElement("input");
      input.name = it.name;
      if (it.kind === "switch") { input.type = "checkbox"; }
      else { input.type = "range"; input.min = it.min; input.max = it.max; input.step = 1; }
      const out = document.createElement("output");
      input.addEventListener(it.kind === "switch" ? "change" : "input", () => {
        const v = it.kind === "switch" ? (input.checked ? 1 : 0) : Number(input.value);
        out.textContent = v;
        setItem(it.name, v);
      });
      $("items").append(label, input, out);
      row = {input: input, out: out};
      inputs.set(it.name, row);
    }
    if (document.activeElement !== row.input) {
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
