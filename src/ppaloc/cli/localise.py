"""``ppaloc localise``: frames against a saved map, one CSV line per frame.

Frames come from image files, folders of images and videos, in the order given; a
folder's images in natural order of their file names (``img2`` before ``img10``), a
video's frames in order, read and decoded one at a time through the same reader as the
``video:`` dataset kind. A shell expands ``dir/*.png`` in text order (``frame10`` before
``frame2``), so image files of one folder given out of natural order are refused unless
the caller asks to keep the order given. Every input is opened (its header read) before
the first frame is localised.
"""

from __future__ import annotations

import sys
import time
import warnings
from collections.abc import Iterator, Sequence
from contextlib import nullcontext
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from ppaloc.errors import DataError, PpalocError
from ppaloc.fileio import atomic_write

__all__ = ["CSV_HEADER", "VIDEO_SUFFIXES", "FrameInput", "frame_inputs", "run_localise"]

CSV_HEADER = "frame,path,node,reference_frame,score,moved,latency_ms,reference_name"
"""The columns of a localise CSV (``reference_name`` added last, so a reader by position
of an earlier file still finds the others)."""

VIDEO_SUFFIXES = frozenset(
    {".mp4", ".m4v", ".mov", ".avi", ".mkv", ".webm", ".mpg", ".mpeg", ".wmv", ".ts", ".ogv"}
)
"""File suffixes taken as videos (compared lower-case); another file that Pillow cannot
read is tried as a video too."""

_FILE_FIX = "give image files, videos or folders of images (leave this file out)"


@dataclass
class FrameInput:
    """One input of ``localise``: the image files of a folder, one image file, or a video.

    Attributes
    ----------
    given : Path
        The path as given.
    images : list of Path
        The image files, in order (empty for a video).
    video : FrameSequence, optional
        The video's grey frames (``ppaloc.datasets.loaders.video.VideoFrames``).
    in_folder : bool
        Whether the images were listed from a folder (for the advice of a read error).
    """

    given: Path
    images: list[Path]
    video: Any = None
    in_folder: bool = False

    def __len__(self) -> int:
        return len(self.video) if self.video is not None else len(self.images)

    def frame(self, j: int) -> np.ndarray:
        """Frame ``j`` of this input, grey."""
        from ppaloc.datasets.images import FOLDER_FIX, read_grey

        if self.video is not None:
            return self.video[j]
        return read_grey(self.images[j], fix=FOLDER_FIX if self.in_folder else _FILE_FIX)

    def frames(self) -> Iterator[tuple[str, np.ndarray]]:
        """``(path column, grey frame)`` per frame, read one at a time."""
        from ppaloc.datasets.images import FOLDER_FIX, read_grey

        if self.video is not None:
            for j in range(len(self.video)):
                yield f"{self.given}#{j}", self.video[j]
            return
        fix = FOLDER_FIX if self.in_folder else _FILE_FIX
        for p in self.images:
            yield str(p), read_grey(p, fix=fix)


def _is_image(path: Path) -> bool:
    """Whether Pillow identifies ``path`` as an image from its header (nothing decoded)."""
    from PIL import Image, UnidentifiedImageError

    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", Image.DecompressionBombWarning)
            with Image.open(path):
                return True
    except Image.DecompressionBombError:
        return True  # an image, refused with its size when it is read
    except (UnidentifiedImageError, OSError, ValueError, SyntaxError, EOFError):
        return False


def _video(path: Path) -> Any:
    from ppaloc.datasets.loaders.video import VideoFrames

    return VideoFrames(path)


def frame_inputs(inputs: Sequence[Path], *, keep_order: bool = False) -> list[FrameInput]:
    """Open every input: folders listed, image headers read, videos opened and counted.

    Parameters
    ----------
    inputs : sequence of Path
        Image files, folders of images, videos, in the order to localise them.
    keep_order : bool
        Take image files of one folder in the order given even where it is not the
        natural order of their names.

    Raises
    ------
    DataError
        An input that does not exist, a file that is neither an image nor a video, a
        folder without images, or image files of one folder out of natural order.
    """
    from ppaloc.cli.outputs import refuse_link_loop
    from ppaloc.datasets.images import IMAGE_SUFFIXES, list_images

    out: list[FrameInput] = []
    for p in inputs:
        if p.is_dir():
            out.append(FrameInput(p, list_images(p, "frame folder"), in_folder=True))
        elif not p.is_file():
            refuse_link_loop(p, "frame")
            state = "is not a regular file" if p.exists() else "does not exist"
            raise DataError(f"frame {p} {state}; {_FILE_FIX.split(' (')[0]}")
        elif p.suffix.lower() in VIDEO_SUFFIXES:
            out.append(FrameInput(p, [], video=_video(p)))
        elif p.suffix.lower() in IMAGE_SUFFIXES or _is_image(p):
            out.append(FrameInput(p, [p]))
        else:
            try:
                out.append(FrameInput(p, [], video=_video(p)))
            except DataError:
                raise DataError(
                    f"frame {p} is neither an image ({', '.join(sorted(IMAGE_SUFFIXES))}) nor "
                    f"a video ({', '.join(sorted(VIDEO_SUFFIXES))}) that can be read; "
                    f"{_FILE_FIX}"
                ) from None
    if not out:
        raise DataError("no frames given; give image files, videos or folders of images")
    if not keep_order:
        _check_natural_order([i.given for i in out if i.images and not i.in_folder])
    return out


def _check_natural_order(files: Sequence[Path]) -> None:
    """Image files of one folder must come in natural order of their names."""
    from ppaloc.datasets.images import natural_key

    last: dict[Path, Path] = {}
    for p in files:
        folder = p.parent.resolve()
        before = last.get(folder)
        if before is not None and natural_key(p.name) < natural_key(before.name):
            raise DataError(
                f"frames are localised in the order given, and {before} comes before {p}, "
                f"which natural order of file names puts first (a shell sorts frame10 before "
                "frame2); give the folder (its images are taken in natural order), the files "
                "in natural order (ls -v), or --keep-order to localise them as given"
            )
        last[folder] = p


def _method_for_map(topomap: Any, method: str | None, map_path: Path) -> str:
    """The method to localise with: ``method`` if given, else the one the map names (its
    provenance, or its node kind); a name from the map that this install does not offer is
    refused as the map's, with the fix."""
    from ppaloc.evaluate.run import resolve_methods
    from ppaloc.localise.weighted import REPRESENTATIONS
    from ppaloc.methods import available_methods, registry

    if method:
        return resolve_methods([method])[0]
    named = topomap.provenance.get("method")
    # a map that names no method: the weighted-node method of its place, if it is one
    by_kind = f"weighted-node-{topomap.kind}" if topomap.kind in REPRESENTATIONS else None
    name = str(named) if named else (by_kind or topomap.kind)
    if name not in available_methods():
        why = "is not available in this install" if name in registry() else "is unknown here"
        source = "provenance.method" if named else f"node kind {topomap.kind!r}"
        raise DataError(
            f"map {map_path} names method {name!r} (its {source}), which {why}; give "
            f"--method, one of: {', '.join(available_methods())}"
        )
    return name


def _check_map_kind(
    topomap: Any, loc: Any, name: str, map_path: Path, *, live: bool = False
) -> None:
    """Refuse a map of another kind than ``loc`` needs, naming the methods that read it (not
    with ``live``: only ``name``'s own map would do) and how to build the right one."""
    from ppaloc.methods import registry

    own = getattr(loc, "representation", None) or getattr(loc, "kind", None)
    # the kinds it takes: its own, or several (the on-sensor "auto" runs a map's own place)
    takes = getattr(loc, "map_kinds", None) or ((own,) if own else ())
    if not takes or topomap.kind in takes:
        return
    needs = " or ".join(repr(k) for k in takes)
    readers = [m for m, s in registry().items() if s.defaults.get("representation") == topomap.kind]
    built_by = topomap.provenance.get("method")
    if built_by and built_by not in readers:
        readers.insert(0, str(built_by))
    build = f"build a map for {name} with `ppaloc map DATASET --method {name} --out MAP.npz`"
    if live:  # --live shows the sensor: another method's map is no way out
        use = build
    elif readers:
        use = f"localise it with --method {readers[0]}, or {build}"
    else:
        use = f"use a matching map, or {build}"
    raise PpalocError(
        f"map {map_path} holds {topomap.kind!r} nodes but method {name!r} needs {needs} "
        f"nodes: {use}"
    )


def csv_text(s: str) -> str:
    """``s`` as one CSV field (quoted where it holds a comma, quote or line break)."""
    return '"' + s.replace('"', '""') + '"' if any(c in s for c in ',"\r\n') else s


def _reference_names(topomap: Any, map_path: Path) -> list[str] | None:
    """The frame name of each node, where the map records them."""
    names = topomap.provenance.get("reference_names")
    if names is None:
        return None
    if (
        not isinstance(names, list)
        or len(names) != len(topomap)
        or not all(isinstance(n, str) for n in names)
    ):
        raise DataError(
            f"map {map_path}: provenance.reference_names is not a list of {len(topomap)} "
            "names; build the map again with `ppaloc map`"
        )
    return names


def _sensor_frames(sources: Sequence[FrameInput]) -> Any:
    """Every frame of ``sources`` as a lazy sequence of sensor frames (for a method that
    reads the whole query before its first step)."""
    from ppaloc.datasets import to_sensor
    from ppaloc.datasets.frames import FrameSequence

    at = [(s, j) for s in sources for j in range(len(s))]

    def read(i: int) -> np.ndarray:
        source, j = at[i]
        return to_sensor(source.frame(j))

    return FrameSequence(read, range(len(at)))


def _check_live(loc: Any, name: str) -> None:
    """``--live`` shows the sensor: refuse a method that runs on the host."""
    from ppaloc.onsensor.localiser import OnSensorLocaliser

    if not isinstance(loc, OnSensorLocaliser):
        raise PpalocError(
            f"--live shows the on-sensor localiser, and method {name!r} runs on the host: "
            "give --method onsensor-lowres, onsensor-lowres16, onsensor-lbp or onsensor-haar "
            "(with a map of their kind) or onsensor-auto (a map of any place a sensor holds; "
            "a patch map is the host's alone), or leave out --live"
        )
    loc.record_weights = True  # untimed register reads: the estimates do not change


def weights_grid(weights: np.ndarray) -> np.ndarray:
    """Node weights in node order as a near-square image, row by row.

    Node ``n`` is pixel ``(n // cols, n % cols)`` with ``cols = ceil(sqrt(N))``; the
    pixels after the last node hold the smallest weight.

    Examples
    --------
    >>> weights_grid(np.array([3.0, 1.0, 2.0])).tolist()
    [[3.0, 1.0], [2.0, 1.0]]
    """
    w = np.asarray(weights, dtype=np.float64).ravel()
    cols = max(1, int(np.ceil(np.sqrt(w.size))))
    rows = max(1, -(-w.size // cols))
    grid = np.full(rows * cols, w.min() if w.size else 0.0)
    grid[: w.size] = w
    return grid.reshape(rows, cols)


def show_frame(
    live: Any, loc: Any, frame: np.ndarray, est: Any, i: int, label: str, reference: int
) -> None:
    """Show frame ``i`` of an on-sensor run on ``live``: the sensor frame, the node weights
    and the estimate, then end the frame (paced to the view's frames per second)."""
    live.display("sensor frame", frame, frame=i)
    weights = est.weights if est.weights is not None else loc.pipeline.weights()
    name = f"weights of the {len(weights)} nodes, in node order by rows"
    live.display(name, weights_grid(weights), frame=i)
    moved = "unknown" if est.moved is None else ("yes" if est.moved else "no")
    live.text(
        f"{label}: node {est.node} (reference frame {reference}), score {est.score:.6g}, "
        f"moved {moved}",
        frame=i,
    )
    live.frame_done()


def run_localise(
    map_path: Path,
    frames: Sequence[Path],
    out: Path | None,
    *,
    method: str | None = None,
    params: dict[str, Any] | None = None,
    keep_order: bool = False,
    live: Any = None,
) -> int:
    """Localise frames against a saved map, one CSV line per frame as it is processed.

    With ``out`` the lines go to a temporary file that replaces ``out`` at the end
    (never a half-written CSV under the final name); without, to stdout. Columns
    (:data:`CSV_HEADER`): the frame's position in this run, its path (``VIDEO#INDEX``
    for a video frame), the map node, its reference frame index, the score, the motion
    decision (1, 0 or empty), the time of ``step`` in ms, and the reference frame's name
    where the map records it (empty otherwise).

    With ``live`` (a :class:`ppaloc.cpp.live.LiveView`, ``--live``) an on-sensor method's
    run is shown in a browser as it goes (:func:`show_frame`); a host method is refused.

    Returns
    -------
    int
        Frames localised.
    """
    from ppaloc.cli.outputs import check_suffix, refuse_input_as_out
    from ppaloc.datasets import to_sensor
    from ppaloc.evaluate.run import ProgressBar, check_oracle_moves, hand_query
    from ppaloc.methods import make_localiser
    from ppaloc.topomap import load_map

    topomap = load_map(map_path)
    name = _method_for_map(topomap, method, map_path)
    # the map's own parameters, whether its method is named or taken from the map (named,
    # they were dropped: the same method localised with its defaults); another method's
    # are not its own
    own = not method or name == topomap.provenance.get("method")
    stored = topomap.provenance.get("method_params") or {} if own else {}
    if not isinstance(stored, dict):
        raise DataError(f"map {map_path}: provenance.method_params is not a table of parameters")
    try:
        make_localiser(name, **stored)  # the map's own parameters, checked as the user's are
    except PpalocError as exc:
        raise DataError(f"map {map_path}: provenance.method_params refused: {exc}") from None
    loc = make_localiser(name, **{**stored, **(params or {})})
    use = getattr(loc, "use_map", None)
    if use is None:
        raise PpalocError(f"method {name!r} cannot load a saved map (it has no use_map)")
    _check_map_kind(topomap, loc, name, map_path, live=live is not None)
    if live is not None:
        _check_live(loc, name)
    names = _reference_names(topomap, map_path)
    sources = frame_inputs(frames, keep_order=keep_order)
    total = sum(len(s) for s in sources)
    # refused before the first line, as evaluate refuses them before its run
    check_oracle_moves(
        name, {**stored, **(params or {})}, total, "frames given", fix="another --param motion"
    )
    # every file read, symlinked frames too
    listed = [p for s in sources for p in s.images]
    refuse_input_as_out(out, [map_path, *frames, *listed])
    if out is not None:
        if out.is_dir():
            raise DataError(f"--out {out} is a folder; give a file name such as estimates.csv")
        check_suffix(out, "a CSV of estimates", "a name such as estimates.csv")
        if not out.parent.is_dir():  # as ppaloc map: a mistyped folder is not created
            raise DataError(
                f"cannot write the CSV to {out}: folder {out.parent} does not exist; "
                "create it first"
            )
    use(topomap)
    loc.reset()
    # an offline method (seqslam-centred) reads every frame before its first step
    hand_query(loc, _sensor_frames(sources))
    frame_index = np.asarray(topomap.frame_index)
    # The bar only when the CSV goes to a file: on stdout it would interleave with the lines.
    if live is not None:
        live.live_state.program = f"ppaloc localise {map_path.name} ({name})"
        live.live_state.frames = total
    # a file name that is not UTF-8 is written back as its own bytes, as on stdout
    csv_file = (
        atomic_write(out, "w", encoding="utf-8", errors="surrogateescape")
        if out is not None
        else nullcontext(sys.stdout)
    )
    with (
        csv_file as stream,
        ProgressBar(out is not None) as bar,
        live if live is not None else nullcontext(),
    ):
        bar.add("frames", total, label="frames")
        stream.write(CSV_HEADER + "\n")
        i = 0
        for source in sources:
            for label, grey in source.frames():
                frame = to_sensor(grey)
                t = time.perf_counter_ns()
                est = loc.step(frame)
                ms = (time.perf_counter_ns() - t) / 1e6
                moved = "" if est.moved is None else int(est.moved)
                ref_name = "" if names is None else csv_text(names[est.node])
                stream.write(
                    f"{i},{csv_text(label)},{est.node},{int(frame_index[est.node])},"
                    f"{est.score:.6g},{moved},{ms:.4f},{ref_name}\n"
                )
                stream.flush()
                if live is not None:
                    show_frame(live, loc, frame, est, i, label, int(frame_index[est.node]))
                i += 1
                bar("frames", i)
    return i
