"""Running a compiled SCAMP-5d program with every call served by the simulator.

:func:`run_program` compiles (cached), starts the program with two pipes to the simulator,
serves it (:mod:`ppaloc.cpp.server`) until it ends, stops it after ``timeout`` seconds,
turns a crash into a one-line error, and writes the run's folder whole or not at all
(:func:`ppaloc.fileio.new_folder`).
"""

from __future__ import annotations

import json
import math
import numbers
import os
import re
import select
import signal
import subprocess
import time
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
from PIL import Image

from ppaloc.cpp.build import SHIM_HEADERS, compile_program
from ppaloc.cpp.capture import Capture, finish_all
from ppaloc.cpp.displays import fit_plane
from ppaloc.cpp.frames import FrameSource
from ppaloc.cpp.project import Project, make_project, project_headers
from ppaloc.cpp.protocol import SERVER_EXIT, SHIM_EXIT
from ppaloc.cpp.server import SAVED_FOLDER, ProgramError, Session, serve
from ppaloc.errors import DataError, PpalocError, SimulatorError
from ppaloc.fileio import atomic_write, check_replaceable_folder, new_folder
from ppaloc.sim import NoiseParams, Scamp5
from ppaloc.sim.render import plane_to_image, render_montage, save_png

if TYPE_CHECKING:
    from ppaloc.cpp.live import LiveView

__all__ = [
    "FramesFailedError",
    "RunResult",
    "check_settings",
    "check_timeout",
    "run_files",
    "run_program",
    "write_outputs",
]

#: Frames of the montage (the first ones; every frame has its own PNGs).
MONTAGE_FRAMES = 8
#: The side of the device's array: a program's frames are square and at most this.
DEVICE_SIDE = 256


@dataclass
class RunResult:
    """What a run produced.

    Attributes
    ----------
    session : Session
        The served run: ``session.sim`` (the simulator, registers as the program left
        them), displays, outputs per frame, texts, kernel statistics, frame times.
    stdout : str
        What the program printed.
    wall_s : float
        Wall time of the run (compilation excluded).
    out : pathlib.Path or None
        The output folder, when one was written.
    project : Project or None
        The program's source files, include folders and defines.
    """

    session: Session
    stdout: str
    wall_s: float
    out: Path | None = None
    project: Project | None = None

    @property
    def texts(self) -> list[str]:
        """Posted text, in order."""
        return [t for _, t in self.session.texts]

    def summary(self) -> dict[str, Any]:
        """What ran, JSON-ready (``summary.json``)."""
        s = self.session
        p = self.project
        return {
            "program": s.program,
            "sources": [str(f) for f in p.sources] if p else [s.program],
            "include_dirs": [str(d) for d in p.include_dirs] if p else [],
            "defines": list(p.defines) if p else [],
            "array": [s.sim.rows, s.sim.cols],
            "frames": len(s.frame_us) if s.finished else s.frame + (1 if s.loops else 0),
            "kernels": len(s.kernels),
            "kernel_runs": sum(k.runs for k in s.kernels.values()),
            "icws_run": sum(k.runs * len(k.kernel) for k in s.kernels.values() if k.kernel),
            "calls": dict(sorted(s.calls.items())),
            "displays": {str(h): name for h, name in s.displays.items()},
            "files": run_files(s),
            "gui_values": s.gui_values,
            "texts": len(s.texts),
            "host_calls": len(s.host_log),
            "posts": len(s.posts),
            "warnings": s.warnings,
            "modelled_us": s.sim.timing.now_us,
            "wall_s": self.wall_s,
        }

    def timing(self) -> dict[str, Any]:
        """Modelled time per kernel and per frame (``timing.json``)."""
        s = self.session
        return {
            "kernels": [k.as_dict() for k in s.kernels.values()],
            "frames": [
                {"frame": i, "modelled_us": us, "chip_us": us - loop, "loop_us": loop}
                for i, (us, loop) in enumerate(zip(s.frame_us, s.frame_loop_us, strict=True))
            ],
            "total_us": s.sim.timing.now_us,
            "stages": s.sim.timing.report().as_dict(),
        }


class FramesFailedError(DataError):
    """A frame could not be read mid-run: the run ended there.

    ``result`` is the run of the frames before it (written to its folder, when one was
    asked for), as a run whose frames ended there would be.
    """

    def __init__(self, message: str, result: RunResult) -> None:
        super().__init__(message)
        self.result = result


#: The longest display folder name taken from a display's text (a file name holds at most
#: 255 bytes, and a folder's listing should stay readable).
SLUG_MAX = 64


def _slug(name: str) -> str:
    """A display's text as one folder name: characters other than letters, digits, ``_``,
    ``.`` and ``-`` as ``_``, cut to :data:`SLUG_MAX`, without leading or trailing dots and
    underscores (so ``..`` or ``.`` never names the folder above or the same one).

    >>> [_slug(n) for n in ("edges", "R5 / R6", "..", ".", ".hidden", "x" * 300)] == [
    ...     "edges", "R5_R6", "display", "display", "hidden", "x" * SLUG_MAX]
    True
    """
    return re.sub(r"[^A-Za-z0-9_.-]+", "_", name)[:SLUG_MAX].strip("._") or "display"


def display_folders(displays: dict[int, str]) -> dict[int, str]:
    """The folder of each display under ``displays/``: its name made safe for a path
    (``display`` when empty), followed by ``_HANDLE`` when displays share it, so every
    display keeps its own images.

    Examples
    --------
    >>> display_folders({1: "edges", 2: "", 3: "", 4: "a b"})
    {1: 'edges', 2: 'display_2', 3: 'display_3', 4: 'a_b'}
    >>> display_folders({1: "", 2: "", 3: "display_2"})  # a name equal to a suffixed one
    {1: 'display_1', 2: 'display_2_2', 3: 'display_2_3'}
    """
    names = {h: _slug(n) for h, n in displays.items()}
    while True:
        values = list(names.values())
        shared = {n for n in values if values.count(n) > 1}
        if not shared:
            return names
        names = {h: f"{n}_{h}" if n in shared else n for h, n in names.items()}


def _display_file(folder: str, frame: int) -> str:
    return f"displays/{folder}/frame_{frame:04d}.png"


def run_files(session: Session) -> list[str]:
    """The files a run writes below its folder's ``displays/`` and ``saved/``, relative to
    the folder, sorted (``summary.json``'s ``files``: what a later run may replace).

    Examples
    --------
    >>> from types import SimpleNamespace
    >>> s = SimpleNamespace(displays={1: "", 2: "edges"}, outputs=[{1: 0}, {2: 0}],
    ...                     saved={"a/b.bmp": 0, "log.txt": ""})
    >>> for name in run_files(s):
    ...     print(name)
    displays/display/frame_0000.png
    displays/edges/frame_0001.png
    saved/a/b.bmp
    saved/log.txt
    """
    names = display_folders(session.displays)
    shown = [
        _display_file(names[h], f) for f, outputs in enumerate(session.outputs) for h in outputs
    ]
    return sorted([*shown, *(f"{SAVED_FOLDER}/{rel}" for rel in session.saved)])


def write_outputs(result: RunResult, folder: Path) -> None:
    """Write a run's files into ``folder`` (see docs/cpp.md, "Outputs")."""
    s = result.session
    names = display_folders(s.displays)
    for frame, outputs in enumerate(s.outputs):
        for h, plane in outputs.items():
            path = folder / _display_file(names[h], frame)
            path.parent.mkdir(parents=True, exist_ok=True)
            save_png(plane_to_image(plane), path)
    tiles = {
        f"{s.displays[h] if names[h] == _slug(s.displays[h]) else names[h]} #{frame}": fit_plane(
            plane, s.sim.rows, s.sim.cols
        )
        for frame, outputs in enumerate(s.outputs[:MONTAGE_FRAMES])
        for h, plane in sorted(outputs.items())
    }
    if tiles:
        columns = max(len(o) for o in s.outputs[:MONTAGE_FRAMES])
        render_montage(tiles, folder / "montage.png", columns=columns)
    (folder / "text.txt").write_text(
        "".join(f"frame {f}: {t}\n" for f, t in s.texts), encoding="utf-8"
    )
    if s.host_log:  # host-side calls: "after the run" for the end-of-run callbacks
        ran = s.source.taken if s.finished else s.frame + 1  # a program that returned: all ran
        (folder / "host.txt").write_text(
            "".join(
                f"{f'frame {f}' if f < ran else 'after the run'}: {t}\n" for f, t in s.host_log
            ),
            encoding="utf-8",
        )
    if s.posts:
        (folder / "posts.json").write_text(json.dumps(s.posts), encoding="utf-8")
    (folder / "timing.json").write_text(json.dumps(result.timing(), indent=1), encoding="utf-8")
    (folder / "summary.json").write_text(json.dumps(result.summary(), indent=1), encoding="utf-8")
    (folder / "stdout.txt").write_text(result.stdout, encoding="utf-8")
    # vs_sim::save_image as 8-bit grey BMPs, vs_post_text("!save NAME") as UTF-8 text
    for rel, saved in s.saved.items():
        path = folder / SAVED_FOLDER / rel
        path.parent.mkdir(parents=True, exist_ok=True)
        with atomic_write(path) as f:
            if isinstance(saved, str):
                f.write(saved.encode("utf-8"))
            else:
                Image.fromarray(saved).save(f, format="BMP")


def _bad_access_place(lines: Sequence[str], files: frozenset[str]) -> str:
    """Where AddressSanitizer's first stack trace enters the program's own code: its
    innermost frame in one of ``files`` (the names of the sources and project headers),
    else its frame in ``main``; ``" at extra.cpp:4"``, or ``""``."""
    start = next(i for i, ln in enumerate(lines) if "ERROR: AddressSanitizer" in ln)
    trace: list[str] = []
    for ln in lines[start + 1 :]:
        if re.match(r"#\d+ ", ln):
            trace.append(ln)
        elif trace:
            break
    places = [re.search(r"(\S+:\d+)(?::\d+)?\s*$", ln) for ln in trace]
    own = [m.group(1) for m in places if m and Path(m.group(1).rsplit(":", 1)[0]).name in files]
    if not own:
        frame = next((ln for ln in lines if re.match(r"#\d+ .* in main ", ln)), "")
        at = re.search(r"(\S+:\d+)(?::\d+)?\s*$", frame)
        own = [at.group(1)] if at else []
    return f" at {Path(own[0]).name}" if own else ""


# AddressSanitizer's reports that are not a memory access (it reports every fatal
# signal): what each means in the program.
_ASAN_KINDS = {
    "FPE": "an arithmetic error: an integer division by zero",
    "ILL": "an illegal instruction",
}


def _abort_cause(lines: Sequence[str]) -> str:
    """What the C++ run-time printed before aborting the program: a failed ``assert``
    (``the assertion `x > 0' failed at prog.cpp:12``) or an exception nothing caught
    (``an uncaught exception std::out_of_range: index 7``), else ``""``."""
    for i, ln in enumerate(lines):
        m = re.search(r"(\S+):(\d+): [^\n]*?Assertion (.+) failed\.$", ln)
        if m:
            return f"the assertion {m.group(3)} failed at {Path(m.group(1)).name}:{m.group(2)}"
        m = re.match(r"terminate called after throwing an instance of '(.+)'$", ln)
        if m:
            what = lines[i + 1] if i + 1 < len(lines) else ""
            told = what.removeprefix("what():").strip() if what.startswith("what():") else ""
            return f"an uncaught exception {m.group(1)}{f': {told}' if told else ''}"
        if ln.startswith("terminate called without an active exception"):
            return "std::terminate called without an active exception (a `throw;` outside a catch?)"
    return ""


def _crash_message(
    program: str, code: int, stderr: str, session: Session, files: frozenset[str] = frozenset()
) -> str:
    where = f"in frame {session.frame}" if session.loops else "before the frame loop"
    lines = [ln.strip() for ln in stderr.splitlines() if ln.strip()]
    if code == SHIM_EXIT:
        shim = [ln for ln in lines if ln.startswith("ppaloc-shim:")]
        text = shim[-1].removeprefix("ppaloc-shim:").strip() if shim else "stopped by the shim"
        return text
    asan = [ln for ln in lines if "ERROR: AddressSanitizer" in ln]
    if asan:
        kind = asan[0].split("AddressSanitizer:", 1)[1].split(" on ")[0].strip()
        place = _bad_access_place(lines, files)
        what = _ASAN_KINDS.get(kind, "a bad memory access")
        return f"{program} crashed {where}: {kind} ({what}){place}"
    if code < 0:
        try:
            sig = signal.Signals(-code).name
        except ValueError:
            sig = f"signal {-code}"
        cause = _abort_cause(lines)
        return f"{program} crashed {where} ({sig}){f': {cause}' if cause else ''}"
    last = f": {lines[-1]}" if lines else ""
    return f"{program} exited with status {code} {where}{last}"


#: What a run writes at the top of its output folder.
OUTPUT_NAMES = frozenset(
    {"displays", "montage.png", "text.txt", "timing.json", "summary.json", "stdout.txt",
     "host.txt", "posts.json", SAVED_FOLDER}
)  # fmt: skip


def _recorded_files(folder: Path) -> frozenset[str]:
    """The files below ``displays/`` and ``saved/`` that the ``summary.json`` of the run's
    folder ``folder`` says the run wrote: its ``files``; for a run written before
    ``files`` was recorded, every ``frame_NNNN.png`` in the folders of its ``displays``
    (none where summary.json is unreadable)."""
    try:
        summary = json.loads((folder / "summary.json").read_bytes())
    except (OSError, ValueError, RecursionError):
        return frozenset()
    if not isinstance(summary, dict):
        return frozenset()
    files = summary.get("files")
    if isinstance(files, list):
        return frozenset(f for f in files if isinstance(f, str))
    displays = summary.get("displays")
    if not isinstance(displays, dict):
        return frozenset()
    try:
        names = display_folders({int(h): str(n) for h, n in displays.items()})
    except ValueError:
        return frozenset()
    shown = (folder / "displays" / name for name in names.values())
    return frozenset(
        f"displays/{d.name}/{p.name}"
        for d in shown
        if d.is_dir() and not d.is_symlink()
        for p in d.iterdir()
        if re.fullmatch(r"frame_\d{4,}\.png", p.name) and p.is_file() and not p.is_symlink()
    )


def _run_wrote(folder: Path, name: str, written: dict[Path, frozenset[str]]) -> bool:
    """Whether ``name``, a path relative to the run's folder ``folder``, is an entry a run
    writes there: one of :data:`OUTPUT_NAMES` at the top; below ``displays/`` and
    ``saved/``, a file its ``summary.json`` names (``written`` caches them) or a folder
    holding one."""
    head, sep, _ = name.partition("/")
    if not sep:
        return name in OUTPUT_NAMES
    if head not in ("displays", SAVED_FOLDER):
        return False
    if folder not in written:
        written[folder] = _recorded_files(folder)
    own = written[folder]
    path = folder / name
    if path.is_symlink():
        return False
    if path.is_dir():
        return any(f.startswith(name + "/") for f in own)
    return name in own


def check_output_folder(out: str | os.PathLike) -> None:
    """Refuse an ``out`` that is a file, or a non-empty folder that is not an earlier run's
    or holds an entry a run did not write, at its top or inside ``displays/`` and
    ``saved/`` (the folder is replaced whole: a user's own files must not go with it)."""
    written: dict[Path, frozenset[str]] = {}
    check_replaceable_folder(
        out,
        owned=lambda folder, name: _run_wrote(folder, name, written),
        marked=lambda folder: (folder / "summary.json").is_file(),
        markers="summary.json",
        writer="ppaloc cpp run",
        kind="run's folder",
        nested=True,
    )


def check_settings(settings: Mapping[str, object] | None) -> dict[str, str]:
    """Slider and switch values as ``--set`` gives them: text by the item's name.

    A value is a string (``"30"``, ``"on"``), an integer, a bool (a switch's ``True`` is
    1) or a float with an integer value (``30.0``); anything else is refused in one line
    naming the key and the value, before the program is built.

    >>> check_settings({"threshold": 30, "dilate": True, "gain": 2.0, "mode": "on"})
    {'threshold': '30', 'dilate': '1', 'gain': '2', 'mode': 'on'}
    """
    if settings is None:
        return {}
    if not isinstance(settings, Mapping):
        raise PpalocError(
            f"settings={settings!r} must be a mapping of slider, switch or button names to "
            'values, e.g. {"threshold": 30}'
        )
    out: dict[str, str] = {}
    for key, value in settings.items():
        if not isinstance(key, str) or not key.strip():
            raise PpalocError(
                f"settings key {key!r} must be a slider's, switch's or button's name (a "
                "non-empty string)"
            )
        if isinstance(value, str):
            text = value
        elif isinstance(value, bool | np.bool_ | numbers.Integral):
            text = str(int(value))
        elif isinstance(value, numbers.Real) and math.isfinite(value) and value == int(value):
            text = str(int(value))
        else:
            kind = (
                "an integer" if isinstance(value, numbers.Real) else "a number, a bool or a string"
            )
            raise PpalocError(
                f"settings[{key!r}]={value!r}: a slider, switch or button takes {kind}, e.g. 30, "
                "True or 'on'"
            )
        out[key] = text
    return out


MAX_TIMEOUT = 86_400
"""The longest ``timeout`` a run takes, seconds (one day; also keeps ``select`` in range)."""


def check_timeout(timeout: object) -> None:
    """Refuse a ``timeout`` that is not a number of seconds in (0, :data:`MAX_TIMEOUT`]."""
    if not (isinstance(timeout, int | float) and 0 < timeout <= MAX_TIMEOUT):
        raise PpalocError(f"timeout={timeout!r} must be a number of seconds in (0, {MAX_TIMEOUT}]")


def run_program(
    program: str | os.PathLike[str] | Sequence[str | os.PathLike[str]],
    frames: FrameSource | Iterable[np.ndarray] | None = None,
    *,
    include_dirs: Sequence[str | os.PathLike[str]] = (),
    defines: Sequence[str] = (),
    settings: Mapping[str, object] | None = None,
    timeout: float = 60.0,
    out: str | os.PathLike[str] | None = None,
    noise: str | NoiseParams = "ideal",
    seed: int = 0,
    live: LiveView | None = None,
    kernel_check: bool = True,
) -> RunResult:
    """Compile ``program`` (cached) and run it on the simulator, one frame per loop pass.

    Parameters
    ----------
    program : path or sequence of paths
        A SCAMP-5d device program (C++): its source file, or its files (compiled and
        linked together; the first names the program in messages).
    frames : FrameSource or iterable of uint8 arrays, optional
        The exposures, all of one square shape of at most 256 x 256 (the array size, as the
        device's: its addresses are 8-bit); default one synthetic scene of 256 x 256
        (``ppaloc.sim.demo.synthetic_scene``). A list is checked whole before the build; an
        iterator or a :class:`~ppaloc.cpp.frames.FrameSource` (a stream, as
        ``ppaloc cpp run --stream`` gives) is read one frame at a time as the program asks
        for the next, its first frame before the build. A frame that cannot be read, or is
        not like the first, ends the run there: the outputs of the frames before it are
        written, then its one-line error is raised.
    include_dirs : sequence of paths
        The program's header folders (``-I``).
    defines : sequence of str
        Its macros (``-D``): ``NAME`` or ``NAME=VALUE``.
    settings : mapping, optional
        Slider and switch values by their GUI text (as ``--set``): strings (``"on"``),
        integers, bools or integral floats (:func:`check_settings`).
    timeout : float
        Seconds the program may run before it is stopped.
    out : path, optional
        Folder to write (replaced whole, only when the run succeeds).
    noise, seed : simulator noise preset and seed.
    live : LiveView, optional
        A live view (:mod:`ppaloc.cpp.live`): opened once the program is built, it shows
        the displays, sliders, switches and text in a browser as frames run and feeds the
        page's slider and switch changes to the program; closed when the run ends, however
        it ends. Its frame pacing does not count against ``timeout``.
    kernel_check : bool
        Run a static kernel's body again at later passes to compare what it would record
        with its recording, warning once at the first difference (a kernel in a helper
        called with other registers); the body's other C++ statements (a counter, a
        printf) then run again too, which the device never does. False: each body runs
        once, as on the device.

    Raises
    ------
    PpalocError
        Compile errors, unmodelled calls, a bad ``--set``, a misused call (with its line),
        a timeout, a crash; no output folder is left behind.
    FramesFailedError
        A frame that could not be read, or not like the first, after the first: the
        outputs of the frames before it are written, and the error holds their ``result``.
    """
    if frames is None:
        from ppaloc.sim.demo import synthetic_scene

        frames = [synthetic_scene(seed=0)]
    source = frames if isinstance(frames, FrameSource) else FrameSource(frames)
    try:  # from here on, the source is closed however the run ends
        if out is not None:
            check_output_folder(out)
        if isinstance(frames, Sequence):  # held already: every frame is checked now
            list(FrameSource(frames))
        check_timeout(timeout)
        values = check_settings(settings)
        project = make_project(program, include_dirs, defines)
        name = project.name
        first = source.peek()  # a stream's first frame: it sets the array's size
        if first is None:
            raise PpalocError(
                source.error or "no frames to run on: give at least one image or --frames 1 or more"
            )
        shape = first.shape
        if shape[0] != shape[1] or shape[0] > DEVICE_SIDE:
            raise PpalocError(
                f"the frames are {shape[0]} x {shape[1]}: the array a device program runs on "
                f"is square and at most {DEVICE_SIDE} x {DEVICE_SIDE}, as the device's (its "
                "addresses are 8-bit); give square frames of at most that size "
                "(ppaloc.frontend.to_sensor makes any image 256 x 256)"
            )
        exe = compile_program(project)
        files = frozenset(
            p.name for p in (*project.sources, *project_headers(project, SHIM_HEADERS))
        )
        sim = Scamp5(shape[0], shape[1], noise=noise, seed=seed)
        session = Session(
            sim, source, values, program=name, out_folder=None if out is None else Path(out)
        )
        if live is not None:
            live.open(session)
        try:
            result = _serve(exe, session, name, timeout, live, files, kernel_check)
        finally:
            if live is not None:
                live.close(session)
        result.project = project
        session.check_settings()
        if out is not None:
            with new_folder(out) as stage:
                try:
                    write_outputs(result, stage)
                except SimulatorError as exc:  # a PNG the system refused (a full disk):
                    if isinstance(exc.__cause__, OSError):  # named in out, not the stage
                        raise exc.__cause__ from None
                    raise
            result.out = Path(out)
    finally:
        source.close()
    if source.error is not None:  # the frames before it ran: their outputs are kept
        kept = f"; their outputs are in {out}" if out is not None else ""
        raise FramesFailedError(
            f"{name} stopped after {source.taken} frame(s): {source.error}{kept}", result
        )
    return result


def _serve(
    exe: Path,
    session: Session,
    name: str,
    timeout: float,
    live: LiveView | None = None,
    files: frozenset[str] = frozenset(),
    kernel_check: bool = True,
) -> RunResult:
    to_sim_r, to_sim_w = os.pipe()
    to_prog_r, to_prog_w = os.pipe()
    env = dict(os.environ)
    env.update(
        PPALOC_FD_OUT=str(to_sim_w),
        PPALOC_FD_IN=str(to_prog_r),
        ASAN_OPTIONS="detect_leaks=0:abort_on_error=0",
        PPALOC_KERNEL_CHECK="1" if kernel_check else "0",
    )
    out_r, out_w = os.pipe()
    err_r, err_w = os.pipe()
    start = time.perf_counter()
    try:
        proc = subprocess.Popen(
            [str(exe)],
            stdin=subprocess.DEVNULL,
            stdout=out_w,
            stderr=err_w,
            pass_fds=(to_sim_w, to_prog_r),
            env=env,
        )
    except OSError as exc:
        for fd in (to_sim_r, to_sim_w, to_prog_r, to_prog_w, out_r, out_w, err_r, err_w):
            os.close(fd)
        raise PpalocError(f"cannot start {name}: {exc.strerror or exc}") from None
    for fd in (to_sim_w, to_prog_r, out_w, err_w):
        os.close(fd)
    out_f, err_f = Capture(out_r), Capture(err_r, tail=True)  # drained as it prints
    deadline = start + timeout
    error: PpalocError | None = None
    read_before = session.source.waited_s  # the first frame, read before the build

    def read_deadline() -> float:  # nor are a live view's pacing and reading the frames
        paced = live.waited_s if live is not None else 0.0
        return deadline + paced + session.source.waited_s - read_before

    def read() -> bytes:
        left = read_deadline() - time.perf_counter()
        ready = select.select([to_sim_r], [], [], max(left, 0))[0] if left > 0 else []
        if not ready:
            raise TimeoutError
        return os.read(to_sim_r, 1 << 16)

    def write(data: bytes) -> None:
        try:
            os.write(to_prog_w, data)
        except BrokenPipeError:
            pass

    served = False
    try:
        serve(session, read, write)
        served = True
    except TimeoutError:
        if session.loops:
            error = PpalocError(
                f"{name} did not finish within {timeout:g} s (stopped in frame "
                f"{session.frame}): a loop that never ends? raise --timeout if it needs "
                "longer"
            )
        else:  # a loop that runs free on the device (vs_process_message alone) ends here
            error = PpalocError(
                f"{name} did not finish within {timeout:g} s and never began a frame: "
                "each frame begins at vs_frame_loop_control() or vs_wait_frame_trigger() "
                "(in a loop that waits for neither, vs_loop_counter_inc() ends one); a loop "
                "that never ends, or a frame loop without any of them (call "
                "vs_frame_loop_control() at its top)? raise --timeout if it needs longer"
            )
    except ProgramError as exc:
        error = exc
    finally:
        if not served and proc.poll() is None:  # an error of any kind: stop it now
            proc.kill()
        try:
            code = proc.wait(timeout=max(read_deadline() - time.perf_counter(), 0) + 5)
        except subprocess.TimeoutExpired:
            proc.kill()
            code = proc.wait()
        os.close(to_sim_r)
        os.close(to_prog_w)
    wall = time.perf_counter() - start
    finish_all((out_f, err_f))
    stdout = out_f.head.decode("utf-8", "replace")
    if out_f.dropped:
        stdout += (
            f"\n[ppaloc: {out_f.dropped} more bytes of standard output not kept: a run "
            f"keeps the first {out_f.limit} bytes]\n"
        )
        session.warnings.append(
            f"{name} printed {len(out_f.head) + out_f.dropped} bytes to standard output; "
            f"stdout.txt keeps the first {out_f.limit}"
        )
    # the bytes dropped between the two parts: a line break, so no line joins them
    stderr = (err_f.head + (b"\n" if err_f.dropped else b"") + err_f.tail).decode(
        "utf-8", "replace"
    )
    if error is not None:
        raise error
    if code == SERVER_EXIT:  # the shim lost its pipe, and the simulator had not ended the run
        where = f"in frame {session.frame}" if session.loops else "before the frame loop"
        raise PpalocError(
            f"{name} lost its pipe to the simulator {where} (it closed the file descriptors "
            "named by PPALOC_FD_IN and PPALOC_FD_OUT?): a program must leave them open; its "
            "run is not written"
        )
    if code != 0:
        raise PpalocError(_crash_message(name, code, stderr, session, files))
    return RunResult(session, stdout, wall)
