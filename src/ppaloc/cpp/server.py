"""The simulator's end of the pipe: serve a running SCAMP-5d program's calls on a ``Scamp5``.

:class:`Session` decodes the messages of :mod:`ppaloc.cpp.protocol`: kernel bodies are
recorded on the simulator on their first run and replayed by id afterwards; controller
calls are dispatched by name to :data:`HANDLERS`, which call the simulator with hardware
addresses (``scamp_addr=True``, as a device program writes them) and answer readouts in the
device's buffer layouts. The session also keeps what the run produced: display images per
frame (register images, and the events, boxes and byte images of :mod:`ppaloc.cpp.displays`),
posted text and data, the host-side calls that have no effect here (LEDs, frame triggers,
io agents: :attr:`Session.host_log`), modelled time per kernel and per frame.
"""

from __future__ import annotations

import functools
import inspect
import re
import shlex
import struct
import warnings
from collections import Counter
from collections.abc import Callable, Iterator, Sequence
from contextlib import contextmanager
from dataclasses import dataclass, field
from pathlib import PurePath, PureWindowsPath
from typing import Any, Protocol

import numpy as np

from ppaloc.cpp.displays import box_outlines, byte_image, event_marks, subsample
from ppaloc.cpp.frames import FrameSource
from ppaloc.cpp.protocol import (
    DEVICE_ERRORS,
    ICW_STACK_OVERFLOW,
    LINE_BITS,
    LINE_MASK,
    OPS,
    REGISTER_NAMES,
    TAGS,
    VERSION,
)
from ppaloc.errors import PpalocError
from ppaloc.sim import Direction, Kernel, Register, Scamp5
from ppaloc.sim.controller import MAX_EVENTS, to_scamp_buffer
from ppaloc.sim.kernel import MAX_ICWS, IcwStackWarning
from ppaloc.sim.registers import register_by_name
from ppaloc.sim.render import plane_to_image

__all__ = [
    "HANDLERS",
    "SAVED_FOLDER",
    "GuiItem",
    "KernelStats",
    "LiveHook",
    "ProgramError",
    "Session",
    "events_buffer",
    "gui_name",
    "pack_dreg_rows",
    "saved_image_path",
]

_REGS: tuple[Register, ...] = tuple(register_by_name(n) for n in REGISTER_NAMES)
_HELLO, _DEF, _RUN, _CALL, _EXIT, _FILE = (
    OPS[k] for k in ("HELLO", "DEF", "RUN", "CALL", "EXIT", "FILE")
)
_INT, _AREG, _DREG, _DIR, _STR, _LIST, _BYTES = (
    TAGS[k] for k in ("INT", "AREG", "DREG", "DIR", "STR", "LIST", "BYTES")
)
_HEAD = struct.Struct("<BI")
_ARG = struct.Struct("<Bi")


class ProgramError(PpalocError):
    """A SCAMP-5d program asked the simulator for something it cannot do."""


@dataclass
class KernelStats:
    """One distinct kernel body of a run: where it was written, what it holds, its cost."""

    id: int
    line: int
    calls: list[str]
    body: list[tuple[str, int, list]] = field(default_factory=list, repr=False)
    kernel: Kernel | None = None
    dynamic: bool = False
    runs: int = 0
    modelled_us: float = 0.0
    file: str = "program"
    #: Every C++ object holding it was destroyed: it left the ICW stack, and a later launch
    #: (of the same body recorded again) records it again, as the device does.
    freed: bool = False

    def as_dict(self) -> dict[str, Any]:
        """A JSON-ready summary."""
        k = self.kernel
        return {
            "id": self.id,
            "file": self.file,
            "line": self.line,
            "calls": self.calls,
            "icws": 0 if k is None else len(k),
            "counts": {} if k is None else k.counts,
            "runs": self.runs,
            "modelled_us_per_run": self.modelled_us / self.runs if self.runs else 0.0,
            "modelled_us_total": self.modelled_us,
        }


@functools.cache
@dataclass(frozen=True)
class GuiItem:
    """A slider or switch of the run: its text, kind, range and the shim's handle for it."""

    kind: str
    text: str
    lo: int
    hi: int
    handle: int | None = None


class LiveHook(Protocol):
    """What a live view (:class:`ppaloc.cpp.live.LiveView`) offers a session."""

    def frame_done(self, session: Session) -> list[tuple[str, int]]:
        """Called at each frame loop control, before the next frame starts: take what the
        frame produced and give the slider and switch changes to apply, ``(text, value)``
        pairs already checked against the items' ranges."""
        ...


@functools.cache
def _direction_slots(name: str) -> frozenset[int]:
    """Positions of a kernel function's direction parameters (``dir``, ``dir2``)."""
    fn = getattr(Kernel, name, None)
    if fn is None:
        return frozenset()
    params = list(inspect.signature(fn).parameters)[1:]
    return frozenset(i for i, p in enumerate(params) if p in ("dir", "dir2"))


def _directions(name: str, args: list) -> list:
    """Integer directions (``DNEWS(R6, R5, 5)``, the device takes an ``int``) as Direction."""
    slots = _direction_slots(name)
    if not slots:
        return args
    return [
        Direction(a) if i in slots and type(a) is int and 0 <= a <= 15 else a
        for i, a in enumerate(args)
    ]


def _shown_call(call: tuple[str, int, list]) -> str:
    """A kernel body's call as messages give it: ``movx(B, A, north)``."""
    return f"{call[0]}({', '.join(map(_show, call[2]))})"


def _call_error(at: str, call: str, exc: Exception) -> str:
    """``file:line: call: message``, the call named once where the simulator's message
    already begins with it, in its own spelling (``in sub(A, B, A): ...``, ``bus(A, A)
    lists A twice``, ``DNEWS(R5, R1, south, 0): ...`` with the default it filled in)."""
    text = str(exc)
    name = call.partition("(")[0]
    named = text.startswith((f"{name}(", f"in {name}("))
    return f"{at}: {text}" if named else f"{at}: {call}: {text}"


def _show(arg: Any) -> str:
    if isinstance(arg, tuple):
        return "{" + ", ".join(map(_show, arg)) + "}"
    if isinstance(arg, Register):
        return arg.name
    if isinstance(arg, Direction):
        return "|".join(m.name for m in Direction if m in arg) or "0"
    if isinstance(arg, bytes):
        return f"<{len(arg)} bytes>"
    return repr(arg)


@dataclass
class Session:
    """Serve one run of a program on ``sim``, the frames given in turn.

    Parameters
    ----------
    sim : Scamp5
        The simulator every call runs on.
    frames : FrameSource or sequence of ndarray
        The exposures: frame ``k`` is what PIX sees during the ``k``-th pass of the frame
        loop (frame 0 also before it). Each is taken from the source when its pass starts
        (:attr:`source`), so a stream's frames reach the program as they are decoded; the
        frames end when the source does, or early when it fails (:attr:`FrameSource.error`,
        also in :attr:`warnings`).
    settings : dict
        Slider and switch values by their GUI text (``--set NAME=VALUE``).
    program : str
        The program's name for messages.
    out_folder : path, optional
        The run's output folder (``--out``), where ``vs_sim::save_image`` files go (under
        ``saved/``, written with the rest of the folder); None: the run keeps no files, and
        ``vs_sim::save_image`` stops the program in one line.
    """

    sim: Scamp5
    frames: FrameSource | Sequence[np.ndarray]
    settings: dict[str, str] = field(default_factory=dict)
    program: str = "program"
    kernels: dict[int, KernelStats] = field(default_factory=dict)
    displays: dict[int, str] = field(default_factory=dict)
    outputs: list[dict[int, np.ndarray]] = field(default_factory=list)
    texts: list[tuple[int, str]] = field(default_factory=list)
    frame_us: list[float] = field(default_factory=list)
    calls: Counter = field(default_factory=Counter)
    gui_values: dict[str, int] = field(default_factory=dict)
    warnings: list[str] = field(default_factory=list)
    # place -> [first frame, count, index in warnings]
    divisions_by_zero: dict[str, list[int]] = field(default_factory=dict)
    device_errors: int = 0  # vs_device_error_bits, as the frame loop's answer carries them
    # vs_gpio_*: pin -> [is an output, pulled up, output latch]
    gpio: dict[int, list[bool]] = field(default_factory=dict)
    loops: int = 0
    finished: bool = False
    frame_loop_us: list[float] = field(default_factory=list)
    host_log: list[tuple[int, str]] = field(default_factory=list)
    posts: list[dict[str, Any]] = field(default_factory=list)
    post_channel: int = 0
    gui_items: dict[str, GuiItem] = field(default_factory=dict)
    live: LiveHook | None = None
    files: dict[int, str] = field(default_factory=dict)
    out_folder: PurePath | None = None
    # by path under the output folder's saved/ (the last save of a path wins): an 8-bit
    # image of vs_sim::save_image, or the console's text of vs_post_text("!save NAME")
    saved: dict[str, np.ndarray | str] = field(default_factory=dict)
    # the host app's console: the posted lines since its last "!clear", and how many
    # times it was cleared (the live view's text panel follows both)
    console: list[tuple[int, str]] = field(default_factory=list)
    console_clears: int = 0
    _saved_folders: set[str] = field(default_factory=set)
    _bitstack: list | None = None
    _frame_start_us: float = 0.0
    _loop_us: float = 0.0
    _changes: list[tuple[int, int]] = field(default_factory=list)

    def __post_init__(self) -> None:
        self.source = (
            self.frames if isinstance(self.frames, FrameSource) else FrameSource(self.frames)
        )
        first = self.source.peek()
        if first is not None:
            self.sim.set_image(first)
        self.unused = set(self.settings)
        self._matched: dict[str, list[str]] = {}

    # -------------------------------------------------------------- places
    def file_of(self, code: int) -> str:
        """The name of the source file of a wire location ``code`` (the program's name for
        a file the shim did not name)."""
        return self.files.get(code >> LINE_BITS, self.program)

    def at(self, code: int) -> str:
        """A wire location as messages give it: ``"file.cpp:LINE"``, the file where the
        call was written (the program's own, a second source or an included header)."""
        return f"{self.file_of(code)}:{code & LINE_MASK}"

    # -------------------------------------------------------------- frames
    @property
    def frame(self) -> int:
        """The frame the program is in (0 before the loop starts)."""
        return max(self.loops - 1, 0)

    def _output(self, handle: int, plane: np.ndarray, line: int) -> None:
        if handle not in self.displays:
            raise ProgramError(
                f"{self.at(line)}: display handle {handle} was not created by vs_gui_add_display"
            )
        while len(self.outputs) <= self.frame:
            self.outputs.append({})
        self.outputs[self.frame][handle] = plane

    def note(self, text: str) -> None:
        """Record a host-side call that has no effect here (an LED, a frame trigger, ...),
        with the frame it came in (``host.txt``)."""
        self.host_log.append((self.frame, text))

    def display(self, handle: int, line: int) -> str:
        """The name of display ``handle``; a one-line error if no display has it."""
        if handle not in self.displays:
            raise ProgramError(
                f"{self.at(line)}: display handle {handle} was not created by vs_gui_add_display"
            )
        return self.displays[handle]

    def host(self, call: str, units: float = 0.0) -> None:
        """Charge a host-side cost (loop control, output to the host) to stage ``loop``,
        the boundary docs/sim-controller.md keeps apart from the chip's work."""
        with self.host_side():
            self.sim.timing.charge_call(call, units)

    @contextmanager
    def host_side(self) -> Iterator[None]:
        """Simulator calls made for the host, as a display output's own scan: in stage
        ``loop``, their time the frame's ``loop_us`` (docs/cpp.md, "Modelled time")."""
        timing = self.sim.timing
        t0 = timing.now_us
        with self.sim.stage("loop"):
            yield
        self._loop_us += timing.now_us - t0

    def loop(self) -> int:
        """``vs_frame_loop_control``: 1 to run the next frame, 0 when the frames are done.

        A frame's modelled time runs from its loop control call to the next one.
        """
        changes = self.live.frame_done(self) if self.live is not None else []
        self._changes = []
        now = self.sim.timing.now_us
        if self.loops:
            self.frame_us.append(now - self._frame_start_us)
            self.frame_loop_us.append(self._loop_us)
        self._frame_start_us = now
        self._loop_us = 0.0
        self.host("vs_frame_loop_control")
        self.loops += 1
        frame = self.source.take()
        if frame is None:
            self.finished = True
            if self.source.error is not None:
                self.warnings.append(f"the frames ended early: {self.source.error}")
            return 0
        self.sim.set_image(frame)
        for text, value in changes:
            item = self.gui_items[text]
            held = min(max(value, item.lo), item.hi)  # the host's slider holds its range
            if held != value:  # (a value set on the page before the program narrowed it)
                self.note(
                    f"live view: {item.kind} {text!r} set to {value}, outside its range "
                    f"[{item.lo}, {item.hi}] since the program set it: {held}"
                )
                value = held
            else:
                self.note(f"live view: {item.kind} {text!r} set to {value}")
            self.gui_values[text] = value
            if item.handle is not None:
                self._changes.append((item.handle, value))
        return 1

    def counted_loop(self) -> bytes:
        """``vs_loop_counter_inc`` in a program that never waits for the frame trigger
        (its loop runs free on the device): the end of a frame and the start of the next,
        :meth:`loop_answer`'s answer. The frame it ends began with the program, so the
        first one also counts as frame 0's start (its modelled time from the run's start).
        """
        if self.loops == 0:
            self.loops = 1
            self.source.take()  # frame 0, exposed since the program started
        return self.loop_answer()

    def loop_answer(self) -> bytes:
        """The answer to ``vs_frame_loop_control``: :meth:`loop`'s value, then the handles
        and values of the sliders and switches a live view changed (:mod:`ppaloc.cpp.protocol`).
        """
        go = self.loop()
        errors = [(DEVICE_ERRORS, self.device_errors)] if self.device_errors else []
        pairs = self._changes + errors
        return _i32(go) + b"".join(struct.pack("<ii", h, v) for h, v in pairs)

    # -------------------------------------------------------------- messages
    def handle(self, op: int, payload: memoryview) -> bytes | None:
        """Serve one message; the answer's payload, or None when none is due."""
        if op == _RUN:
            self._run(struct.unpack_from("<I", payload)[0])
            return None
        if op == _CALL:
            return self._call(payload)
        if op == _DEF:
            self._define(payload)
            return None
        if op == _HELLO:
            version = struct.unpack_from("<I", payload)[0]
            if version != VERSION:
                raise ProgramError(
                    f"{self.program} speaks shim protocol {version}, this ppaloc {VERSION}: "
                    "rebuild it (delete the build cache)"
                )
            return struct.pack("<HH", self.sim.rows, self.sim.cols)
        if op == _FILE:
            fid, size = struct.unpack_from("<IB", payload)
            self.files[fid] = bytes(payload[5 : 5 + size]).decode("utf-8", "replace")
            return None
        if op == _EXIT:
            return None
        raise ProgramError(f"{self.program}: unknown message {op} from the shim")

    @staticmethod
    def _args(payload: memoryview, at: int, n: int) -> tuple[list[Any], int]:
        out: list[Any] = []
        for _ in range(n):
            tag, value = _ARG.unpack_from(payload, at)
            at += _ARG.size
            if tag == _INT:
                out.append(value)
            elif tag == _AREG or tag == _DREG:
                out.append(_REGS[value])
            elif tag == _DIR:
                out.append(Direction(value))
            elif tag == _STR:
                out.append(bytes(payload[at : at + value]).decode("utf-8", "replace"))
                at += value
            elif tag == _LIST:
                items, at = Session._args(payload, at, value)
                out.append(tuple(items))
            elif tag == _BYTES:
                out.append(bytes(payload[at : at + value]))
                at += value
            else:
                raise ProgramError(f"unknown argument tag {tag} from the shim")
        return out, at

    @staticmethod
    def body(payload: memoryview | bytes, at: int, n: int) -> list[tuple[str, int, list]]:
        """The ``n`` calls of a kernel body from ``at``: ``(name, line, args)`` each."""
        payload = memoryview(payload)
        body = []
        for _ in range(n):
            size = payload[at]
            name = bytes(payload[at + 1 : at + 1 + size]).decode()
            at += 1 + size
            call_line, nargs = struct.unpack_from("<IB", payload, at)
            args, at = Session._args(payload, at + 5, nargs)
            body.append((name, call_line, args))
        return body

    def _define(self, payload: memoryview) -> None:
        kid, line, dynamic, n = struct.unpack_from("<IIBI", payload)
        body = self.body(payload, 13, n)
        calls = [_shown_call(b) for b in body]
        self.kernels[kid] = KernelStats(
            kid, line & LINE_MASK, calls, body, dynamic=bool(dynamic), file=self.file_of(line)
        )

    def _run(self, kid: int) -> None:
        stats = self.kernels.get(kid)
        if stats is None:
            raise ProgramError(f"{self.program}: kernel {kid} was run before it was defined")
        timing = self.sim.timing
        t0 = timing.now_us
        if stats.kernel is None or stats.freed:
            stats.freed = False
            kernel = self.sim.kernel()
            try:
                with warnings.catch_warnings(record=True) as caught, kernel as k:
                    warnings.simplefilter("always")
                    if stats.dynamic:  # freed after its launch on the device: off the stack
                        k.move_to_heap(True)
                    for name, line, args in stats.body:
                        try:
                            getattr(k, name)(*_directions(name, args))
                        except (PpalocError, TypeError) as exc:
                            call = f"{name}({', '.join(map(_show, args))})"
                            raise ProgramError(_call_error(self.at(line), call, exc)) from None
            except ProgramError:
                raise
            except PpalocError as exc:  # the kernel as a whole (e.g. too many ICWs)
                raise ProgramError(
                    f"{stats.file}:{stats.line}: the kernel begun here: {exc}"
                ) from None
            stats.kernel = kernel
            found = [
                f"{stats.file}:{stats.line}: {w.message}"
                for w in caught  # the stack's own warning is worded for C++ below
                if not issubclass(w.category, IcwStackWarning)
            ]
            dropped = getattr(kernel, "dropped", 0)
            if dropped:
                self.device_errors |= ICW_STACK_OVERFLOW
                if len(kernel) + dropped > MAX_ICWS:  # too long for the stack on its own
                    fix = f"split it into kernels of at most {MAX_ICWS} ICWs"
                else:
                    fix = "free some, use dynamic kernels or move_to_heap(true)"
                found.append(
                    f"{stats.file}:{stats.line}: the kernel begun here lost {dropped} of its "
                    f"ICWs: the 1024-ICW stack that static kernels share is full ({fix})"
                )
            # a kernel recorded again after it was freed says it once
            self.warnings += [w for w in found if w not in self.warnings]
        else:
            stats.kernel.run()
        stats.runs += 1
        stats.modelled_us += timing.now_us - t0

    def _call(self, payload: memoryview) -> bytes | None:
        want = payload[0]
        size = payload[1]
        name = bytes(payload[2 : 2 + size]).decode()
        at = 2 + size
        line, nargs = struct.unpack_from("<IB", payload, at)
        args, _ = self._args(payload, at + 5, nargs)
        handler = HANDLERS.get(name)
        if handler is None:
            raise ProgramError(f"{self.at(line)}: {name} is not served by this simulator")
        if not name.startswith("ppaloc_"):  # the shim's own messages are not the program's
            self.calls[name] += 1
        try:
            result = handler(self, args, line)
        except ProgramError:
            raise
        except PpalocError as exc:
            call = f"{name}({', '.join(map(_show, args))})"
            raise ProgramError(_call_error(self.at(line), call, exc)) from None
        if not want:
            return None
        return b"" if result is None else result

    # -------------------------------------------------------------- GUI items
    def _setting_for(self, kind: str, text: str) -> str | None:
        """The ``--set`` name that sets the item ``text``: the text as declared, or else the
        text without its trailing colons and spaces (``threshold`` for ``"threshold: "``)."""
        if text in self.settings:
            names = [text]
        else:
            names = [n for n in self.settings if gui_name(n) == gui_name(text)]
        if len(names) > 1:
            raise ProgramError(
                f"--set {names[0]}=... and --set {names[1]}=... both name the {kind} "
                f"{text!r} of {self.program}: give it once"
            )
        if not names:
            return None
        self._matched.setdefault(names[0], []).append(text)
        return names[0]

    def gui_value(
        self,
        kind: str,
        text: str,
        lo: int,
        hi: int,
        init: int,
        line: int,
        handle: int | None = None,
    ) -> int:
        """The value of a slider, switch or button: ``--set NAME=VALUE`` or its initial value
        (a button's 0; ``--set NAME=1`` presses it once at the start).

        ``NAME`` is the item's text as the program declares it, or that text without its
        trailing colons and spaces (``--set threshold=30`` sets ``"threshold: "``).
        """
        if lo > hi:  # as vs_gui_set_slider_range refuses it: no value could be set
            raise ProgramError(
                f"{self.at(line)}: vs_gui_add_{kind}({text!r}, {lo}, {hi}, {init}): the minimum "
                "is above the maximum"
            )
        name = self._setting_for(kind, text)
        if name is not None:
            self.unused.discard(name)
            raw = self.settings[name]
            if kind != "slider" and raw.lower() in ("on", "true", "yes", "off", "false", "no"):
                value = int(raw.lower() in ("on", "true", "yes"))
            elif re.fullmatch(r"\s*[+-]?[0-9]{1,4000}\s*", raw):  # as typed: not 1_0, not ٣
                value = int(raw)
            else:
                raise ProgramError(
                    f"--set {name}={raw}: the {kind} takes an integer in [{lo}, {hi}]"
                )
            if not lo <= value <= hi:
                raise ProgramError(
                    f"--set {name}={value} is outside the {kind}'s range [{lo}, {hi}] "
                    f"({self.at(line)})"
                )
        else:  # the host's slider holds only values of its range: the nearest end
            value = min(max(init, lo), hi)
            if value != init:
                self.warnings.append(
                    f"{self.at(line)}: vs_gui_add_{kind}({text!r}, {lo}, {hi}, {init}): the "
                    f"initial value is outside the range the {kind} allows; it starts at "
                    f"{value}, as the host's {kind} holds"
                )
        self.gui_values[text] = value
        self.gui_items[text] = GuiItem(kind, text, lo, hi, handle)
        return value

    def check_settings(self) -> None:
        """Refuse a ``--set`` name that no slider or switch of the run had, or that named
        two of them; the message lists the names as they are typed after ``--set``."""
        for name in sorted(self.settings):
            items = list(dict.fromkeys(self._matched.get(name, [])))
            if len(items) > 1:
                shown = ", ".join(shlex.quote(t) for t in items)
                raise PpalocError(
                    f"--set {name}=... names {len(items)} items of {self.program} ({shown}): "
                    "give one of them exactly as declared"
                )
        if self.unused:
            raise PpalocError(
                f"--set {sorted(self.unused)[0]}=...: {self.program} has no slider, switch "
                f"or button of that name (it has: {', '.join(self.gui_names()) or 'none'})"
            )

    def gui_names(self) -> list[str]:
        """The run's sliders, switches and buttons as ``--set`` takes them: without their
        trailing colons and spaces unless two items share that name, quoted for a shell if
        need be."""
        texts = list(self.gui_values)
        bare = Counter(gui_name(t) for t in texts)
        return [shlex.quote(gui_name(t) if bare[gui_name(t)] == 1 else t) for t in texts]


def gui_name(text: str) -> str:
    """A GUI item's text without surrounding spaces and trailing colons: its ``--set`` name.

    >>> gui_name("threshold: ")
    'threshold'
    """
    return re.sub(r"[\s:]+$", "", text).strip()


# ------------------------------------------------------------------ handlers
Handler = Callable[[Session, list, int], "bytes | None"]


def _i32(v: int) -> bytes:
    return struct.pack("<i", int(v))


def _global_sum(n: int) -> Handler:
    def handler(s: Session, a: list, line: int) -> bytes:
        grid = np.zeros((n, n), np.uint8)
        total = getattr(s.sim, f"global_sum_{n * n}")(a[0], out=grid)
        return _i32(total) + to_scamp_buffer(grid).tobytes()

    return handler


def _shift(s: Session, a: list, line: int) -> None:
    reg, h, v, boundary, refresh = a
    if reg.kind == "analog":
        s.sim.shift(reg, h, v)
    else:
        s.sim.shift(reg, h, v, boundary, refresh)


def pack_dreg_rows(rows: np.ndarray) -> bytes:
    """Digital rows (array orientation) as the device's scan buffer: 32 bytes per row,
    byte ``j`` bit ``k`` = hardware column ``8 j + k`` (column 0 at the east edge)."""
    hardware = np.asarray(rows, bool)[:, ::-1]
    packed = np.packbits(hardware, axis=1, bitorder="little")
    out = np.zeros((len(hardware), 32), np.uint8)
    out[:, : packed.shape[1]] = packed[:, :32]
    return out.tobytes()


def events_buffer(events: np.ndarray, max_num: int) -> bytes:
    """``(row, hardware column)`` events as the device's buffer: ``(column, row)`` byte
    pairs, ``max_num`` slots, the unused ones ``(0, 0)`` (the end marker)."""
    buf = np.zeros((max_num, 2), np.uint8)
    events = np.asarray(events).reshape(-1, 2)
    if len(events):
        buf[: len(events)] = events[:, ::-1]
    return buf.tobytes()


def _scan_dreg(s: Session, a: list, line: int) -> bytes:
    dreg, r0, r1 = a
    return pack_dreg_rows(s.sim.scan_dreg(dreg, r0, min(r1, s.sim.rows - 1)))


def _events(s: Session, method: str, dreg: Register, max_num: int, *dirs: int) -> np.ndarray:
    """The events a device scan of ``max_num`` slots (the header's ``uint16_t``) finds:
    "up to 4000 events can be scanned" (``scamp5_output.hpp``), so a larger ``max_num``
    scans 4000 and leaves the slots beyond them as end markers; 0 scans nothing."""
    scanned = min(max_num, MAX_EVENTS)
    if scanned == 0:
        return np.zeros((0, 2), np.int64)
    return getattr(s.sim, method)(dreg, scanned, *dirs, scamp_addr=True)


def _scan_events(s: Session, a: list, line: int) -> bytes:
    dreg, max_num, h_dir, v_dir = a
    return events_buffer(_events(s, "scan_events", dreg, max_num, h_dir, v_dir), max_num)


def _scan_events_rc(s: Session, a: list, line: int) -> bytes:
    dreg, max_num, h_dir, v_dir = a
    events = _events(s, "scan_events_rc", dreg, max_num, h_dir, v_dir)
    buf = np.zeros((max_num, 2), np.uint8)  # (row, column) pairs: the row first
    if len(events):
        buf[: len(events)] = events
    return buf.tobytes()


def _bounding_box(s: Session, a: list, line: int) -> bytes:
    box = s.sim.scan_boundingbox(a[0], scamp_addr=True)
    return bytes(4) if box is None else np.asarray(box, np.uint8).ravel().tobytes()


def _flags(method: str, n_plain: int) -> Handler:
    """``sim.method`` whose arguments after the first ``n_plain`` are 0/1 flags."""

    def handler(s: Session, a: list, line: int) -> None:
        args = [*a[:n_plain], *(bool(v) if isinstance(v, int) else v for v in a[n_plain:])]
        getattr(s.sim, method)(*args)

    return handler


def _flags_addr(method: str, n_plain: int) -> Handler:
    """As :func:`_flags`, with hardware addresses."""

    def handler(s: Session, a: list, line: int) -> None:
        args = [*a[:n_plain], *(bool(v) for v in a[n_plain:])]
        getattr(s.sim, method)(*args, scamp_addr=True)

    return handler


def _output_image(s: Session, a: list, line: int) -> None:
    reg, handle = a
    sim = s.sim
    if reg.kind == "analog":  # the whole plane through the ADC, one byte per element
        s.host("scan_areg", sim.rows * sim.cols)
        s.host("usb_output", sim.rows * sim.cols)
    else:
        s.host("scan_dreg", sim.rows)
        s.host("usb_output", sim.rows * sim.cols // 8)
    s._output(handle, sim.read(reg), line)


#: The most bit-planes one bit-stack output takes (the value is accumulated in 64 bits).
MAX_BITSTACK = 32


def _bitstack_begin(s: Session, a: list, line: int) -> None:
    n_bits = int(a[1])
    if not 1 <= n_bits <= MAX_BITSTACK:
        raise ProgramError(
            f"{s.at(line)}: scamp5_output_bitstack_begin with {n_bits} bits: use 1 to "
            f"{MAX_BITSTACK}"
        )
    s._bitstack = [a[0], n_bits, []]


def _bitstack_bit(s: Session, a: list, line: int) -> None:
    if s._bitstack is None:
        raise ProgramError(f"{s.at(line)}: a bit-stack bit before scamp5_output_bitstack_begin")
    s.host("scan_dreg", s.sim.rows)
    s.host("usb_output", s.sim.rows * s.sim.cols // 8)
    s._bitstack[2].append(s.sim.read(a[0]))


def _bitstack_end(s: Session, a: list, line: int) -> None:
    if s._bitstack is None:
        raise ProgramError(f"{s.at(line)}: scamp5_output_bitstack_end without a begin")
    handle, n_bits, bits = s._bitstack
    s._bitstack = None
    if len(bits) != n_bits:
        raise ProgramError(
            f"{s.at(line)}: the bit-stack was begun with {n_bits} bits but got {len(bits)}"
        )
    value = np.zeros((s.sim.rows, s.sim.cols), np.int64)
    for plane in bits:  # most significant bit first
        value = (value << 1) | plane.astype(np.int64)
    top = (1 << n_bits) - 1 if n_bits else 1
    grey = np.floor(value * (255.0 / top) + 0.5)
    s._output(handle, (grey - 128.0).astype(np.float32), line)


def _add_display(s: Session, a: list, line: int) -> None:
    text, handle = a[0], a[1]
    s.displays[handle] = text


def _set_slider_range(s: Session, a: list, line: int) -> None:
    """``vs_gui_set_slider_range(handle, min, max)`` (the shim has checked the handle and
    ``min <= max``): recorded, and the slider's range is the new one, which the live view
    shows and holds its values to; its value is left as it is."""
    handle, lo, hi = a
    s.note(f"vs_gui_set_slider_range({handle}, {lo}, {hi})")
    for text, item in s.gui_items.items():
        if item.handle == handle and item.kind == "slider":
            s.gui_items[text] = GuiItem(item.kind, text, lo, hi, handle)


def _slider(kind: str) -> Handler:
    def handler(s: Session, a: list, line: int) -> bytes:
        text, lo, hi, init, *handle = a  # the handle since protocol 4
        return _i32(s.gui_value(kind, text, lo, hi, init, line, *handle))

    return handler


#: A post that is one of the host app's console commands (vs_post.hpp, ``vs_post_text``):
#: ``!clear`` or ``!save [NAME]`` as its first line; what follows a newline is text.
CONSOLE_COMMAND = re.compile(r"!(clear|save)(?:[ \t]+([^\n]*?))?[ \t]*(?:\n|$)")


def _post_text(s: Session, a: list, line: int) -> None:
    """``vs_post_text``: the text goes to ``text.txt`` as posted, and to the host app's
    console (the live view's text panel) unless it is a console command: ``!clear``
    empties the console, ``!save NAME`` keeps its text as ``saved/NAME`` (``.txt`` added
    to a name without a suffix; ``saved/console_FRAME.txt`` without a name)."""
    text = a[0]
    s.host("usb_output", len(text.encode()))
    s.texts.append((s.frame, text))
    command = CONSOLE_COMMAND.match(text)
    if command is None:
        s.console.append((s.frame, text))
        return
    verb, name = command.groups()
    if verb == "clear":
        s.note('vs_post_text("!clear"): the console cleared')
        s.console.clear()
        s.console_clears += 1
    else:
        _save_console(s, name or f"console_{s.frame:04d}", command.group(0).rstrip(), line)
    rest = text[command.end() :]
    if rest:
        s.console.append((s.frame, rest))


def _save_console(s: Session, name: str, posted: str, line: int) -> None:
    """``!save NAME`` (``posted``): the console's posts, one a line, as ``saved/NAME`` (a
    name refused as ``vs_sim::save_image`` refuses a path is a warning; nothing is
    saved)."""
    call = f"vs_post_text({posted!r})"
    rel, problem = saved_image_path(name if PurePath(name).suffix else f"{name}.txt")
    if rel is not None:
        problem = _saved_clash(s, rel)
    if problem is not None:
        where = s.at(line) if line & LINE_MASK else s.program  # the shim sends no line
        s.warnings.append(f"{where}: {call}: not saved: {problem}")
        return
    s.saved[rel] = "".join(t if t.endswith("\n") else f"{t}\n" for _, t in s.console)
    s._saved_folders.update(_parents(rel))
    posts = f"{len(s.console)} post{'' if len(s.console) == 1 else 's'}"
    s.note(f"{call}: the console's {posts} saved as {SAVED_FOLDER}/{rel}")


def _wait(s: Session, a: list, line: int) -> None:
    """``vs_wait(usec)``: a polled delay of ``usec`` microseconds (a ``uint32_t``, sent
    as its 4 bytes) on the sensor's controller, on the modelled clock. It is the chip's
    side of the frame (``chip_us``), as kernels and controller calls are, not the host
    link's (``loop``): the public programs that call it wait out an exposure between
    ``getpix`` kernels."""
    s.sim.timing.charge_call("vs_wait", int.from_bytes(a[0][:4], "little"))


def _stopwatch(s: Session, a: list, line: int) -> bytes:
    return struct.pack("<d", s.sim.timing.now_us)


def _sim(method: str, *, addr: bool = False, reply: str | None = None) -> Handler:
    """A handler calling ``sim.method(*args)`` (with hardware addresses when ``addr``)."""

    def handler(s: Session, a: list, line: int) -> bytes | None:
        fn = getattr(s.sim, method)
        result = fn(*a, scamp_addr=True) if addr else fn(*a)
        if reply == "int":
            return _i32(result)
        if reply == "buffer":
            return to_scamp_buffer(result).tobytes()
        return None

    return handler


# ------------------------------------------------------------------ outputs beyond images
def _output_areg(s: Session, a: list, line: int) -> None:
    reg, handle, step, r0, c0 = a
    s.display(handle, line)
    plane = subsample(s.sim.read(reg), step, r0, c0)
    s.host("scan_areg", plane.size)
    s.host("usb_output", plane.size)
    s._output(handle, plane, line)


def _output_events(s: Session, a: list, line: int) -> None:
    dreg, handle, max_num, h_dir, v_dir = a
    s.display(handle, line)
    with s.host_side():  # a display output's scan, as scamp5_output_image's
        found = _events(s, "scan_events", dreg, max_num, h_dir, v_dir)
    buffer = events_buffer(found, max_num)
    s.host("usb_output", len(buffer))
    s._output(handle, event_marks((s.sim.rows, s.sim.cols), buffer, max_num), line)


def _output_boundingbox(s: Session, a: list, line: int) -> bytes:
    dreg, handle = a
    s.display(handle, line)
    with s.host_side():  # a display output's scan, as scamp5_output_image's
        found = s.sim.scan_boundingbox(dreg, scamp_addr=True)
    box = bytes(4) if found is None else np.asarray(found, np.uint8).ravel().tobytes()
    s.host("usb_output", len(box))
    # the register's own box, drawn even where its bytes are zeros (a 1 at the top-right
    # element alone), which the buffer cannot tell from an empty register
    shape = (s.sim.rows, s.sim.cols)
    s._output(handle, box_outlines(shape, box, 1, empty_zeros=found is None), line)
    return box


def _display_boxes(s: Session, a: list, line: int) -> None:
    handle, data, count = a
    s.display(handle, line)
    s.host("usb_output", 4 * count)
    s._output(handle, box_outlines((s.sim.rows, s.sim.cols), data, count), line)


def _display_events(s: Session, a: list, line: int) -> None:
    handle, data, count = a
    s.display(handle, line)
    s.host("usb_output", 2 * count)
    s._output(handle, event_marks((s.sim.rows, s.sim.cols), data, count), line)


def _scamp5_image(data: bytes, w: int, h: int) -> np.ndarray:
    """A ``scamp5_display_image*`` buffer as a plane: "column major format, starting from
    top right" (``scamp5_output.hpp``), the layout ``scamp5_scan_areg`` fills."""
    return byte_image(data, w, h, column_major=True, right_to_left=True)


def _display_image(s: Session, a: list, line: int) -> None:
    handle, data, w, h = a
    s.display(handle, line)
    s.host("usb_output", w * h)
    s._output(handle, _scamp5_image(data, w, h), line)


def _shown_before(s: Session, handle: int, shape: tuple[int, int]) -> np.ndarray | None:
    """A copy of the image display ``handle`` shows now, the newest of any frame so far
    (a patch goes "over the previous image in the display", ``scamp5_output.hpp``), as an
    analogue plane (a digital register's image as -128 and 127, drawn alike); None where
    it has shown nothing of the display's size."""
    for frame in range(min(s.frame, len(s.outputs) - 1), -1, -1):
        shown = s.outputs[frame].get(handle)
        if shown is None:
            continue
        if shown.shape != shape:
            return None
        if shown.dtype == bool:
            return np.where(shown, 127.0, -128.0).astype(np.float32)
        return np.array(shown, dtype=np.float32)
    return None


def _display_image_patch(s: Session, a: list, line: int) -> None:
    handle, data, w, h, r0, c0 = a
    s.display(handle, line)
    rows, cols = (s.sim.rows, s.sim.cols)
    if r0 + h > rows or c0 + w > cols:
        raise ProgramError(
            f"{s.at(line)}: scamp5_display_image_patch: a {w} x {h} patch at row {r0}, "
            f"hardware column {c0} runs off the {cols} x {rows} display; place it within it"
        )
    patch = _scamp5_image(data, w, h)
    plane = _shown_before(s, handle, (rows, cols))
    if plane is None:
        plane = np.full((rows, cols), -128.0, np.float32)  # nothing shown yet: black
    # rows r0.., hardware columns c0..: its first byte is the patch's top-right element
    plane[r0 : r0 + h, cols - c0 - w : cols - c0] = patch
    s.host("usb_output", w * h)
    s._output(handle, plane, line)


def _gui_display_image(s: Session, a: list, line: int) -> None:
    handle, data, w, h, fmt = a
    s.display(handle, line)
    plane = byte_image(
        data, w, h, fmt & 0xF, bottom_to_top=bool(fmt & 0x10), right_to_left=bool(fmt & 0x20),
        column_major=bool(fmt & 0x40), channel_array=bool(fmt & 0x80),
    )  # fmt: skip
    s.host("usb_output", len(data))
    s._output(handle, plane, line)


def _gui_display_text(s: Session, a: list, line: int) -> None:
    handle, c, r, text, rgba = a
    name = s.display(handle, line)
    colour = ", ".join(str((rgba >> (8 * k)) & 0xFF) for k in range(4))
    s.host("usb_output", len(text.encode()) + 8)
    s.note(f"vs_gui_display_text: {name!r} at row {r}, column {c}, RGBA ({colour}): {text!r}")


#: ``vs_gui_set_lineplot``'s data directions (its ``format``).
LINEPLOT_FORMATS = ("auto", "row series", "column series")


def _graph(kind: str) -> Handler:
    """``vs_gui_set_scope`` / ``_barplot`` / ``_lineplot``: a display drawn as a graph."""

    def handler(s: Session, a: list, line: int) -> bytes:
        handle, lo, hi, n, _opt = a
        name = s.display(handle, line)
        if lo >= hi:
            raise ProgramError(
                f"{s.at(line)}: vs_gui_set_{kind}({name!r}, {lo}, {hi}, ...): the "
                "minimum must be below the maximum"
            )
        if kind == "lineplot" and not 0 <= n < len(LINEPLOT_FORMATS):
            raise ProgramError(
                f"{s.at(line)}: vs_gui_set_lineplot({name!r}, {lo}, {hi}, {n}): format "
                "is 0 (auto), 1 (row series) or 2 (column series)"
            )
        shape = f"as {LINEPLOT_FORMATS[n]}" if kind == "lineplot" else f"{n} wide"
        s.note(f"vs_gui_set_{kind}: {name!r} shows posted values in [{lo}, {hi}], {shape}")
        return _i32(handle)

    return handler


def _post_channel(s: Session, a: list, line: int) -> None:
    s.post_channel = int(a[0])


_POST_TYPES = {"vs_post_int8": "<i1", "vs_post_int16": "<i2", "vs_post_int32": "<i4",
               "vs_post_float": "<f4"}  # fmt: skip


def _post(name: str) -> Handler:
    """``vs_post_int8`` ... ``vs_post_float``: a ``rows`` x ``cols`` array to the host,
    kept with its frame and channel (``posts.json``)."""
    dtype = np.dtype(_POST_TYPES[name])

    def handler(s: Session, a: list, line: int) -> None:
        data, rows, cols = a
        if rows < 0 or cols < 0 or rows * cols * dtype.itemsize > len(data):
            raise ProgramError(f"{s.at(line)}: {name} of {rows} x {cols}: a bad size")
        values = np.frombuffer(data, dtype, rows * cols).reshape(rows, cols)
        s.host("usb_output", len(data))
        s.posts.append(
            {"frame": s.frame, "channel": s.post_channel, "type": name[len("vs_post_"):],
             "data": values.tolist()}
        )  # fmt: skip

    return handler


#: The frame trigger modes of the device (``VS_FRAME_TRIGGER_*``), by number.
TRIGGER_MODES = ("CONST_LOOP", "CONST_PIX", "GPIO_HIGH", "GPIO_LOW", "GPIO_RISE", "GPIO_FALL",
                 "SYNC")  # fmt: skip
#: The board's LEDs (``VS_LED_0`` ... ``VS_LED_2``).
LEDS = 3


def _accepted(name: str, check: Callable[[list], str | None] | None = None) -> Handler:
    """A host-side call with no meaning on the simulator (an LED, a voltage, a frame
    trigger, ...): checked with ``check`` (which returns what is wrong, or None) and
    recorded in ``host.txt``; frames come as given, so a trigger paces nothing."""

    def handler(s: Session, a: list, line: int) -> None:
        call = f"{name}({', '.join(map(_show, a))})"
        problem = check(a) if check else None
        if problem:
            raise ProgramError(f"{s.at(line)}: {call}: {problem}")
        s.note(call)

    return handler


def _led(a: list) -> str | None:
    return None if 0 <= a[0] < LEDS else f"the board has LEDs 0 to {LEDS - 1} (VS_LED_0 ...)"


#: The pins of the board's GPIO port 6 (``vs_gpio.h``: ``VS_GPIO_X0`` is pin 23).
GPIO_PINS = 32


def _gpio(name: str) -> Handler:
    """``vs_gpio_as_input``, ``_as_output``, ``_output``, ``_input`` (``vs_gpio.h``): the
    board's pins, wired to nothing here. Configurations and outputs are recorded in
    ``host.txt``; an input reads its pull (``pu`` 1: high), an output the level it drives,
    a pin never configured its state out of reset, an input pulled up (1)."""

    def handler(s: Session, a: list, line: int) -> bytes | None:
        pin = a[0]
        call = f"{name}({', '.join(map(_show, a))})"
        if not 0 <= pin < GPIO_PINS:
            raise ProgramError(
                f"{s.at(line)}: {call}: GPIO port 6 has pins 0 to {GPIO_PINS - 1} "
                "(VS_GPIO_X0 ... VS_GPIO_X4 are the board's)"
            )
        state = s.gpio.setdefault(pin, [False, True, False])
        if name == "vs_gpio_input":
            return _i32(int(state[2] if state[0] else state[1]))
        if name == "vs_gpio_as_input":
            state[0], state[1] = False, a[1] != 0
        elif name == "vs_gpio_as_output":
            state[0] = True
        else:
            state[2] = a[1] != 0
        s.note(call)
        return None

    return handler


def _trigger_mode(a: list) -> str | None:
    mode, arg = a
    if not 0 <= mode < len(TRIGGER_MODES):
        return f"mode {mode} is not a frame trigger mode; use VS_FRAME_TRIGGER_* (0 to 6)"
    if TRIGGER_MODES[mode] in ("CONST_LOOP", "CONST_PIX", "SYNC") and arg <= 0:
        return f"a rate of {arg} Hz: give a rate above 0"
    return None


def _trigger_fraction(a: list) -> str | None:
    num, den = a
    return None if num > 0 and den > 0 else "the interval num/den s needs num and den above 0"


def _host_event(s: Session, a: list, line: int) -> None:
    s.note(f"host: {a[0]}")


def _division_by_zero(s: Session, a: list, line: int) -> None:
    """An integer division by zero the shim gave the device's result (0) and went on from:
    one warning per place (``file.cpp:LINE``), with its first frame and its count."""
    path, _, number = str(a[0]).rpartition(":")
    place = f"{PurePath(path).name}:{number}" if path else "an unknown place"
    if place not in s.divisions_by_zero:
        s.divisions_by_zero[place] = [s.frame, 0, len(s.warnings)]
        s.warnings.append("")
    seen = s.divisions_by_zero[place]
    seen[1] += 1
    s.warnings[seen[2]] = (
        f"{place}: an integer division by zero (first in frame {seen[0]}, {seen[1]} in all) "
        "gave 0, as the device's run-time library does, and the program went on"
    )


def _kernel_freed(s: Session, a: list, line: int) -> None:
    """The last C++ object holding a kernel was destroyed (``delete``, the end of its
    scope): the kernel leaves the ICW stack, as the device's destructor takes it off."""
    stats = s.kernels.get(a[0])
    if stats is not None and stats.kernel is not None and not stats.freed:
        stats.kernel.leave_stack()
        stats.freed = True


def _static_kernel_changed(s: Session, a: list, line: int) -> None:
    """A static kernel begun again whose body would now record other calls: it runs as
    first recorded (as on the device), and the run warns once per place, naming the first
    call that differs."""
    kid, n, data = a
    recorded = s.kernels[kid].calls if kid in s.kernels else []
    now = [_shown_call(c) for c in Session.body(data, 0, n)]
    k = next((i for i, (x, y) in enumerate(zip(now, recorded, strict=False)) if x != y), None)
    if k is not None:
        what = f"{now[k]} where it recorded {recorded[k]}"
    else:
        what = f"{len(now)} calls where it recorded {len(recorded)}"
    s.warnings.append(
        f"{s.at(line)}: the static kernel begun here was begun again in frame {s.frame} with "
        f"other calls ({what}): it runs as first recorded, as on the device (the device's "
        "simulator records it again at every pass); use scamp5_dynamic_kernel_begin() for a "
        "kernel that changes"
    )


#: Where ``vs_sim::save_image`` files go in the run's output folder.
SAVED_FOLDER = "saved"


def saved_image_path(path: str) -> tuple[str | None, str | None]:
    """A ``vs_sim::save_image`` path as a path under the run's ``saved/`` folder:
    ``(relative path, None)``, or ``(None, what is wrong)``. Either separator is taken
    (the device's simulator runs on Windows); absolute paths, drives and ``..`` are refused,
    so every file stays inside the run's folder.

    >>> saved_image_path("./frames/edge.bmp")
    ('frames/edge.bmp', None)
    >>> saved_image_path("C:/edge.bmp")[0] is None
    True
    >>> saved_image_path("../edge.bmp")[1]
    "'..' would leave the run's folder: give a path inside it, e.g. 'edge.bmp'"
    """
    parsed = PureWindowsPath(path)
    if parsed.drive or parsed.root:
        return None, (
            "an absolute path: give one relative to the run's folder (written under "
            f"--out/{SAVED_FOLDER}/), e.g. 'edge.bmp'"
        )
    if ".." in parsed.parts:
        return None, "'..' would leave the run's folder: give a path inside it, e.g. 'edge.bmp'"
    if not parsed.parts or path.endswith(("/", "\\")):
        return None, "the path names no file: give a file name, e.g. 'edge.bmp'"
    if any(len(part.encode()) > 255 for part in parsed.parts):
        return None, "a name in the path is longer than 255 bytes"
    return "/".join(parsed.parts), None


def _save_image(s: Session, a: list, line: int) -> None:
    """``vs_sim::save_image``: the register as the 8-bit image a readout gives (analogue: the
    ADC's codes ``v + 128``, without readout noise; digital: 0/255), kept for the run's
    folder (``saved/PATH``, a BMP). A simulator-only call: no modelled time."""
    reg, path = a
    call = f"vs_sim::save_image({_show(reg)}, {path!r})"
    if s.out_folder is None:
        raise ProgramError(
            f"{s.at(line)}: {call}: this run has no output folder to save into: give one "
            "(ppaloc cpp run --out DIR, run_program(..., out=DIR))"
        )
    rel, problem = saved_image_path(path)
    if rel is not None:
        problem = _saved_clash(s, rel)
    if problem is not None:
        raise ProgramError(f"{s.at(line)}: {call}: {problem}")
    s.saved[rel] = plane_to_image(s.sim.read(reg))
    s._saved_folders.update(_parents(rel))


def _parents(rel: str) -> list[str]:
    """The folders of a path under ``saved/``: ``a``, ``a/b`` for ``a/b/c.bmp``."""
    return ["/".join(rel.split("/")[:k]) for k in range(1, rel.count("/") + 1)]


def _saved_clash(s: Session, rel: str) -> str | None:
    """Why ``saved/rel`` cannot be written beside what this run saved (a file where a
    folder is wanted, or the reverse), or None."""
    clash = next((p for p in _parents(rel) if p in s.saved), None)
    if clash is not None:
        return f"{clash!r} is a file this run saved, not a folder"
    if rel in s._saved_folders:
        return f"{rel!r} is a folder of files this run saved"
    return None


#: Every call the shim sends, by name: ``handler(session, args, line) -> answer or None``.
HANDLERS: dict[str, Handler] = {
    "scamp5_get_image": _sim("scamp5_get_image"),
    "scamp5_in": _sim("scamp5_in"),
    "scamp5_load_in": _sim("load_in"),
    "scamp5_load_in_value": _sim("load_in"),
    "scamp5_shift": _shift,
    "scamp5_read_areg": _sim("read_areg", addr=True, reply="int"),
    "scamp5_global_sum_16": _global_sum(4),
    "scamp5_global_sum_64": _global_sum(8),
    "scamp5_global_or": _sim("global_or", addr=True, reply="int"),
    "scamp5_global_count": _sim("global_count", reply="int"),
    "scamp5_load_point": _sim("load_point", addr=True),
    "scamp5_load_rect": _sim("load_rect", addr=True),
    "scamp5_load_pattern": _sim("load_pattern", addr=True),
    "scamp5_select_point": _sim("select_point", addr=True),
    "scamp5_select_rect": _sim("select_rect", addr=True),
    "scamp5_select_pattern": _sim("select_pattern", addr=True),
    "scamp5_scan_areg": _sim("scan_areg", addr=True, reply="buffer"),
    "scamp5_scan_areg_8x8": _sim("scan_areg_8x8", reply="buffer"),
    "scamp5_scan_areg_mean_8x8": _sim("scan_areg_mean_8x8", reply="buffer"),
    "scamp5_scan_dreg": _scan_dreg,
    "scamp5_scan_events": _scan_events,
    "scamp5_load_dac": _sim("load_dac"),
    "scamp5_load_dac_value": _sim("load_dac"),
    "scamp5_diffuse": _flags("diffuse", 2),
    "scamp5_flood": _flags("flood", 4),
    "scamp5_kernel_all": lambda s, a, line: s.sim.kernel_all(),
    "scamp5_kernel_refresh_dreg": lambda s, a, line: s.sim.kernel_refresh_dreg(),
    "scamp5_select_col": _sim("select_col", addr=True),
    "scamp5_select_row": _sim("select_row"),
    "scamp5_select_colx": _sim("select_colx"),
    "scamp5_select_rowx": _sim("select_rowx"),
    "scamp5_global_sum_fast": _sim("global_sum_fast", reply="int"),
    "scamp5_global_sum_sparse": _sim("global_sum_sparse", addr=True, reply="int"),
    "scamp5_global_sum_region": _sim("global_sum_region", addr=True, reply="int"),
    "vs_scamp5_get_parameter": _sim("vs_scamp5_get_parameter", reply="int"),
    "scamp5_scan_events_rc": _scan_events_rc,
    "scamp5_scan_boundingbox": _bounding_box,
    "scamp5_draw_begin": _sim("draw_begin"),
    "scamp5_draw_end": lambda s, a, line: s.sim.draw_end(),
    "scamp5_draw_pixel": _sim("draw_pixel", addr=True),
    "scamp5_draw_point": _sim("draw_point", addr=True, reply="int"),
    "scamp5_draw_rect": _sim("draw_rect", addr=True),
    "scamp5_draw_line": _flags_addr("draw_line", 4),
    "scamp5_draw_circle": _flags_addr("draw_circle", 3),
    "scamp5_draw_negate": lambda s, a, line: s.sim.draw_negate(),
    "scamp5_output_image": _output_image,
    "scamp5_output_bitstack_begin": _bitstack_begin,
    "scamp5_output_bitstack_bit": _bitstack_bit,
    "scamp5_output_bitstack_end": _bitstack_end,
    "vs_gui_add_display": _add_display,
    "vs_gui_add_slider": _slider("slider"),
    "vs_gui_add_switch": _slider("switch"),
    "vs_gui_add_button": _slider("button"),
    "vs_gui_set_slider_range": _set_slider_range,
    "vs_post_text": _post_text,
    "vs_frame_loop_control": lambda s, a, line: s.loop_answer(),
    "vs_wait_frame_trigger": lambda s, a, line: s.loop_answer(),
    "vs_loop_counter_inc": lambda s, a, line: s.counted_loop(),
    "vs_stopwatch_now": _stopwatch,
    "vs_wait": _wait,
}

# The device API beyond the chip: outputs other than whole images, host graphics and data
# posts (drawn or kept), and host-only calls (accepted and recorded).
HANDLERS.update(
    {
        "scamp5_output_areg": _output_areg,
        "scamp5_output_events": _output_events,
        "scamp5_output_boundingbox": _output_boundingbox,
        "scamp5_display_boundingbox": _display_boxes,
        "scamp5_display_events": _display_events,
        "scamp5_display_image": _display_image,
        "scamp5_display_image_patch": _display_image_patch,
        "vs_gui_display_image": _gui_display_image,
        "vs_gui_display_text": _gui_display_text,
        "vs_gui_set_scope": _graph("scope"),
        "vs_gui_set_barplot": _graph("barplot"),
        "vs_gui_set_lineplot": _graph("lineplot"),
        "vs_post_set_channel": _post_channel,
        **{name: _post(name) for name in _POST_TYPES},
        **{
            fn: _gpio(fn)
            for fn in ("vs_gpio_as_input", "vs_gpio_as_output", "vs_gpio_output", "vs_gpio_input")
        },
        "vs_led_on": _accepted("vs_led_on", _led),
        "vs_led_off": _accepted("vs_led_off", _led),
        "vs_led_toggle": _accepted("vs_led_toggle", _led),
        "vs_configure_frame_trigger": _accepted("vs_configure_frame_trigger", _trigger_mode),
        "vs_frame_trigger_set": _accepted("vs_frame_trigger_set", _trigger_fraction),
        "vs_enable_frame_trigger": _accepted("vs_enable_frame_trigger"),
        "vs_disable_frame_trigger": _accepted("vs_disable_frame_trigger"),
        "vs_gui_save_image": _accepted("vs_gui_save_image"),
        "vs_scamp5_configure_voltage": _accepted("vs_scamp5_configure_voltage"),
        "vs_post_bind_io_agent": _accepted("vs_post_bind_io_agent"),
        "scamp5_bind_io_agent": _accepted("scamp5_bind_io_agent"),
        "scamp5_kernel::print_debug_info": _accepted("scamp5_kernel::print_debug_info"),
        "allow_highspeed": _accepted("allow_highspeed"),
        **{
            fn: _accepted(fn)
            for fn in (
                "scamp5_kernel_begin_print",
                "vs_gui_save_snapshots",
                "vs_on_gui_start_recording",
                "vs_on_gui_stop_recording",
                "vs_on_user_value",
                "vs_wait_io_agent",
                "vs_vision_chip_rest",
                "vs_scamp5_rest",
            )
        },
        "vs_host_event": _host_event,
        "ppaloc_division_by_zero": _division_by_zero,
        "ppaloc_static_kernel_changed": _static_kernel_changed,
        "ppaloc_kernel_freed": _kernel_freed,
        "vs_sim::save_image": _save_image,
        "vs_scamp5_set_dac": _sim("load_dac"),
        **{
            fn: _accepted(fn)
            for fn in (
                "vs_scamp5_calibrate_dac",
                "vs_scamp5_calibrate_mid",
                "vs_scamp5_calibrate_global_sum",
                "vs_scamp5_configure_clock",
                "vs_gui_request_file",
                "vs_gui_request_image",
            )
        },
        **{
            f"vs_gui_graphics_api::{fn}": _accepted(f"vs_gui_graphics_api::{fn}")
            for fn in (
                "m_push",
                "m_pop",
                "m_translate",
                "m_rotate",
                "m_rotate_atan2",
                "m_scale",
                "set_color",
                "set_linewidth",
                "set_pointsize",
                "draw_point",
                "draw_line",
                "draw_rect",
                "draw_circle",
            )
        },
        **{
            f"vs_sim::{fn}": _accepted(f"vs_sim::{fn}")
            for fn in (
                "config",
                "enable_keyboard_control",
                "reset_model",
                "pix_integrate",
                "reset_video",
                "use_subpix",
            )
        },
    }
)


def serve(session: Session, read: Callable[[], bytes], write: Callable[[bytes], None]) -> None:
    """Serve messages until the program's end of the pipe closes.

    ``read()`` returns the next bytes (b"" at the end), ``write(data)`` sends an answer.
    A :class:`ProgramError` stops the service; a pending answer then carries an error
    status, so the program stops too.
    """
    buf = b""
    head = _HEAD.size
    while True:
        chunk = read()
        if not chunk:
            return
        buf = buf + chunk if buf else chunk
        view = memoryview(buf)  # over immutable bytes: slices never pin a resize
        n = len(buf)
        start = 0
        try:
            while n - start >= head:
                op, size = _HEAD.unpack_from(view, start)
                end = start + head + size
                if end > n:
                    break
                answer = session.handle(op, view[start + head : end])
                start = end
                if answer is not None:
                    write(struct.pack("<II", 0, len(answer)) + answer)
        except ProgramError:
            write(struct.pack("<II", 1, 0))
            raise
        buf = buf[start:]
