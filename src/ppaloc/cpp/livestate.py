"""What a live view shows: displays, sliders and switches, posted text and progress.

:class:`LiveState` is the one thing :class:`ppaloc.cpp.live.LiveView` serves. A C++ run's
session (:class:`ppaloc.cpp.server.Session`) fills it at each frame loop control; a Python
program fills it through the view's own methods (:meth:`ppaloc.cpp.live.LiveView.display`,
``text``, ``slider``, ``switch``, ``frame_done``). The browser reads :meth:`LiveState.state`
and :meth:`LiveState.png` and queues item changes with :meth:`LiveState.set`; the producer
takes them with :meth:`LiveState.take_changes` between frames. Every method is thread-safe
(the HTTP server answers from its own threads).
"""

from __future__ import annotations

import io
import threading
from collections.abc import Callable, Iterable, Iterator
from contextlib import contextmanager
from typing import Any

import numpy as np
from PIL import Image

__all__ = ["TEXT_LINES", "LiveState", "Refused"]

#: Posted text lines the state keeps (the newest).
TEXT_LINES = 200


class Refused(Exception):
    """A request refused with an HTTP status and a one-line message."""

    def __init__(self, status: int, message: str) -> None:
        super().__init__(message)
        self.status = status


class LiveState:
    """The displays, items, text and progress of one run, as a live view shows them.

    Parameters
    ----------
    program : str
        The run's name (the page's title).
    frames : int, optional
        Frames the run will take at most (None: not known).

    Examples
    --------
    >>> s = LiveState("demo", frames=2)
    >>> s.put_item("gain", "slider", 0, 10, 3)
    >>> s.set("gain", 7)
    ('gain', 7)
    >>> s.take_changes()
    [('gain', 7)]
    >>> s.state()["items"]
    [{'name': 'gain', 'kind': 'slider', 'min': 0, 'max': 10, 'value': 3}]
    """

    def __init__(self, program: str = "program", frames: int | None = None) -> None:
        self._lock = threading.RLock()
        self.program = program
        self.frames = frames
        self.done = 0  # frames completed
        self.finished = False
        self._names: dict[int, str] = {}
        # handle: (serial, frame, array, render to uint8)
        self._planes: dict[int, tuple[int, int, np.ndarray, Callable[[np.ndarray], np.ndarray]]]
        self._planes = {}
        self._png: dict[int, tuple[int, bytes]] = {}
        self._serial = 0
        self._items: dict[str, dict[str, Any]] = {}
        self._pending: dict[str, int] = {}
        self._texts: list[tuple[int, str]] = []

    @contextmanager
    def batch(self) -> Iterator[LiveState]:
        """Hold the lock over several updates, so the page never sees half a frame."""
        with self._lock:
            yield self

    # ------------------------------------------------------------ the producer's side
    def name_displays(self, names: dict[int, str]) -> None:
        """Set every display's name by handle (those without one show ``display H``)."""
        with self._lock:
            self._names = dict(names)

    def put_display(
        self,
        handle: int,
        array: np.ndarray,
        frame: int,
        render: Callable[[np.ndarray], np.ndarray],
        name: str | None = None,
    ) -> None:
        """Display ``handle``'s newest image: ``array`` from ``frame``, drawn by ``render``
        (to a (rows, cols) uint8 image, once, when the page first asks for it)."""
        with self._lock:
            self._serial += 1
            self._planes[handle] = (self._serial, frame, array, render)
            if name is not None:
                self._names[handle] = name

    def put_texts(self, lines: Iterable[tuple[int, str]]) -> None:
        """Append posted ``(frame, text)`` lines (the newest :data:`TEXT_LINES` are kept)."""
        with self._lock:
            self._texts = (self._texts + list(lines))[-TEXT_LINES:]

    def clear_texts(self) -> None:
        """Empty the text panel (a program's ``vs_post_text("!clear")``)."""
        with self._lock:
            self._texts = []

    def put_item(self, name: str, kind: str, lo: int, hi: int, value: int) -> None:
        """Declare or update a slider or switch (``kind``) with range [lo, hi] and value."""
        with self._lock:
            self._items[name] = {"name": name, "kind": kind, "min": lo, "max": hi, "value": value}

    def item(self, name: str) -> dict[str, Any] | None:
        """The item ``name`` as last put (a copy), or None."""
        with self._lock:
            item = self._items.get(name)
            return None if item is None else dict(item)

    def progress(self, done: int, *, finished: bool, frames: int | None = None) -> None:
        """Frames completed, whether the run has finished, and (when given) its frames."""
        with self._lock:
            self.done = done
            self.finished = finished
            if frames is not None:
                self.frames = frames

    def take_changes(self) -> list[tuple[str, int]]:
        """The item changes queued since the last call, ``(name, value)``, in order."""
        with self._lock:
            changes = list(self._pending.items())
            self._pending.clear()
        return changes

    # ------------------------------------------------------------ the browser's side
    def state(self) -> dict[str, Any]:
        """What the page shows, JSON-ready."""
        with self._lock:
            return {
                "program": self.program,
                "frame": self.done,
                "frames": self.frames,
                "finished": self.finished,
                "displays": [
                    {
                        "id": h,
                        "name": self._names.get(h, f"display {h}"),
                        "frame": frame,
                        "src": f"display/{h}.png?v={serial}",
                    }
                    for h, (serial, frame, _, _) in sorted(self._planes.items())
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
                raise Refused(404, f"no display {handle} has an image yet")
            serial, _, array, render = self._planes[handle]
            cached = self._png.get(handle)
        if cached is not None and cached[0] == serial:
            return cached[1]
        buf = io.BytesIO()
        Image.fromarray(render(array)).save(buf, "PNG", compress_level=1)
        data = buf.getvalue()
        with self._lock:
            self._png[handle] = (serial, data)
        return data

    def set(
        self, name: object, value: object, match: Callable[[str], str] = str
    ) -> tuple[str, int]:
        """Queue an item's new value for the next frame; refuse a bad one (:class:`Refused`).

        ``name`` is the item's name, or one that ``match`` maps to the same key as exactly
        one item's; ``value`` an integer in the item's range (a switch also takes
        ``true``/``false``).
        """
        with self._lock:
            if not isinstance(name, str):
                raise Refused(400, f"name {name!r} must be a slider's or switch's text")
            texts = [name] if name in self._items else [
                t for t in self._items if match(t) == match(name)
            ]  # fmt: skip
            if len(texts) != 1:
                known = ", ".join(repr(t) for t in self._items) or "none"
                what = "names more than one item" if texts else "is not a slider or switch"
                raise Refused(400, f"{name!r} {what} of {self.program} (it has: {known})")
            item = self._items[texts[0]]
            if isinstance(value, bool) and item["kind"] == "switch":
                value = int(value)
            if isinstance(value, bool) or not isinstance(value, int):
                raise Refused(400, f"{texts[0]!r} takes an integer, not {value!r}")
            if not item["min"] <= value <= item["max"]:
                raise Refused(
                    400,
                    f"{texts[0]!r}={value} is outside the {item['kind']}'s range "
                    f"[{item['min']}, {item['max']}]",
                )
            if self.finished:
                raise Refused(400, f"{self.program} has finished: nothing more to set")
            self._pending[texts[0]] = value
            return texts[0], value
