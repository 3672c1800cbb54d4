"""``ppaloc cpp run``: frames from an image, a dataset, a folder, a video or a stream, ``--set``
values, the printed summary.

The click parser (``ppaloc.cli.main``) only parses flags; this module turns them into a
:func:`ppaloc.cpp.run.run_program` call.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

from ppaloc.cpp.frames import FrameSource
from ppaloc.cpp.live import LiveView
from ppaloc.cpp.project import make_project
from ppaloc.cpp.run import (
    FramesFailedError,
    RunResult,
    check_output_folder,
    check_timeout,
    run_program,
)
from ppaloc.errors import PpalocError
from ppaloc.flags import set_once
from ppaloc.seeds import SEED_MAX

__all__ = ["load_frames", "parse_settings", "parse_stream_options", "run_cpp"]

#: Frames taken from a dataset when --frames is not given.
DATASET_FRAMES = 10


def parse_settings(items: Sequence[str]) -> dict[str, str]:
    """``["threshold=30", "edges=on"]`` -> ``{"threshold": "30", "edges": "on"}``."""
    out: dict[str, str] = {}
    for item in items:
        name, sep, value = item.partition("=")
        if not sep or not name.strip():
            raise PpalocError(f"--set {item!r} must be NAME=VALUE, e.g. --set threshold=30")
        set_once(out, name.strip(), value.strip(), f"--set {name.strip()}")
    return out


MAX_FRAMES = 2000
"""Most frames one run takes: every frame's displays are held in memory (64 KB or more
each at 256 x 256) until the run's folder is written."""


def _check_frames(frames: int | None) -> None:
    if frames is not None and not 1 <= frames <= MAX_FRAMES:
        raise PpalocError(
            f"--frames {frames} must be in [1, {MAX_FRAMES}] (every frame's displays are held "
            "in memory)"
        )


def parse_stream_options(items: Sequence[str]) -> dict[str, str]:
    """``["video_size=640x480"]`` -> ``{"video_size": "640x480"}`` (FFmpeg input options)."""
    out: dict[str, str] = {}
    for item in items:
        name, sep, value = item.partition("=")
        if not sep or not name.strip() or not value.strip():
            raise PpalocError(
                f"--stream-option {item!r} must be NAME=VALUE, an FFmpeg input option, e.g. "
                "--stream-option video_size=640x480"
            )
        set_once(out, name.strip(), value.strip(), f"--stream-option {name.strip()}")
    return out


def load_frames(
    image: Path | None,
    dataset: str | None,
    frames: int | None,
    stream: str | None = None,
    stream_format: str | None = None,
    stream_options: Sequence[str] = (),
) -> FrameSource | None:
    """The run's sensor frames (256 x 256 grey, :func:`ppaloc.frontend.to_sensor`), each
    read and converted when the run takes it.

    ``image`` repeated; a dataset's query traversal, or the one traversal of a frame
    source given alone (``folder:DIR``, ``video:FILE.mp4``, docs/datasets.md: all its
    frames unless ``frames`` bounds them); the first ``frames`` (default
    :data:`DATASET_FRAMES`) of a live ``stream`` or camera PyAV opens (``stream_format``
    as FFmpeg's ``-f``: ``v4l2``, ``lavfi``, ...), decoded as the program asks for them;
    or ``frames`` synthetic scenes. The source is opened now (a dataset's files listed, a
    stream's input opened), so what cannot be opened is refused before the run.

    Parameters
    ----------
    image, dataset, stream : at most one of them
        ``--image``, ``--dataset`` and ``--stream``.
    frames : int or None
        ``--frames``: in [1, :data:`MAX_FRAMES`].
    stream_format : str or None
        ``--stream-format``; only with ``stream``.
    stream_options : sequence of str
        ``--stream-option NAME=VALUE``: FFmpeg's input options (``video_size=640x480``,
        ``framerate=30``, ``pixel_format=gray``); only with ``stream``.

    Returns
    -------
    FrameSource of (256, 256) uint8 arrays, or None
        None when no source and no ``frames`` are given (the run's default scene). A frame
        that cannot be read ends it (:attr:`FrameSource.error`, the frame named).

    Raises
    ------
    PpalocError
        Two sources, a format without a stream, ``frames`` out of range, a folder or video
        of more than :data:`MAX_FRAMES` frames unbounded, or a source that cannot be opened
        (one line naming it).
    """
    from ppaloc.frontend import to_sensor

    _check_frames(frames)
    given = [n for n, v in (("--image", image), ("--dataset", dataset), ("--stream", stream)) if v]
    if len(given) > 1:
        raise PpalocError(f"give one of --image, --dataset and --stream, not {' and '.join(given)}")
    options = parse_stream_options(stream_options)
    if stream is None and (stream_format is not None or options):
        given = f"--stream-format {stream_format}" if stream_format else "--stream-option"
        raise PpalocError(
            f"{given} needs --stream INPUT (e.g. --stream /dev/video0 --stream-format v4l2)"
        )
    if image is not None:
        from ppaloc.datasets.images import read_grey

        frame = to_sensor(read_grey(Path(image), fix="give --image an image file"))
        return FrameSource([frame] * (frames or 1))
    if dataset is not None:
        from ppaloc.datasets.registry import (
            REFERENCE_ALONE,
            load_reference,
            parse_reference_spec,
        )

        query = load_reference(dataset).query
        spec = parse_reference_spec(dataset)
        alone = spec.kind in REFERENCE_ALONE and len(spec.paths) == 1
        if alone and frames is None and len(query) > MAX_FRAMES:
            raise PpalocError(
                f"--dataset {dataset} has {len(query)} frames, more than {MAX_FRAMES} (they "
                f"are held in memory): take the first ones with --frames, or every k-th with "
                "?step=k"
            )
        if frames is not None and frames > len(query):  # asked for: never run fewer silently
            raise PpalocError(
                f"--frames {frames}: --dataset {dataset} has {len(query)} frame(s); give "
                f"--frames {len(query)} or fewer, or leave it out"
            )
        n = min(len(query), frames or (len(query) if alone else DATASET_FRAMES))
        return FrameSource((to_sensor(query[i]) for i in range(n)), n)
    if stream is not None:
        from ppaloc.datasets.loaders.video import stream_frames

        grey = stream_frames(stream, stream_format, options)
        return FrameSource(grey, frames or DATASET_FRAMES, convert=to_sensor)
    if frames is not None:
        from ppaloc.sim.demo import synthetic_scene

        return FrameSource((synthetic_scene(seed=i) for i in range(frames)), frames)
    return None


def run_cpp(
    program: Path | Sequence[Path],
    out: Path,
    *,
    include_dirs: Sequence[Path] = (),
    defines: Sequence[str] = (),
    image: Path | None = None,
    dataset: str | None = None,
    frames: int | None = None,
    stream: str | None = None,
    stream_format: str | None = None,
    stream_options: Sequence[str] = (),
    settings: Sequence[str] = (),
    timeout: float = 60.0,
    noise: str = "ideal",
    seed: int = 0,
    quiet: bool = False,
    live: LiveView | None = None,
    kernel_check: bool = True,
) -> RunResult:
    """Run ``program`` on the simulator and write ``out``; print one summary line.

    ``live`` (``--live``) shows the run in a browser as it goes (:mod:`ppaloc.cpp.live`).
    """
    if seed < 0:
        raise PpalocError(f"--seed {seed} must be 0 or more")
    if seed > SEED_MAX:
        raise PpalocError(f"--seed {seed} is too large: give an integer in [0, {SEED_MAX}]")
    # Every value, then the program's files and the output folder, are checked before any
    # frame is read: a stream or a long video takes time to read.
    _check_frames(frames)
    check_timeout(timeout)
    values = parse_settings(settings)
    make_project(program, include_dirs, defines)
    check_output_folder(out)
    try:
        result = run_program(
            program,
            load_frames(image, dataset, frames, stream, stream_format, stream_options),
            include_dirs=include_dirs,
            defines=defines,
            settings=values,
            timeout=timeout,
            out=out,
            noise=noise,
            seed=seed,
            live=live,
            kernel_check=kernel_check,
        )
    except FramesFailedError as exc:  # the frames that ran: their warnings, then the error
        if not quiet:  # the cause itself is the error's line
            cause = exc.result.session.source.error or ""
            for warning in exc.result.session.warnings:
                if cause not in warning:
                    print(f"  warning: {warning}")
        raise
    if not quiet:
        s = result.summary()
        print(
            f"{s['program']}: {s['frames']} frame(s), {s['kernels']} kernel(s), "
            f"{s['icws_run']} ICWs run, modelled {s['modelled_us']:.1f} us, "
            f"wall {s['wall_s']:.2f} s -> {out}"
        )
        for warning in result.session.warnings:
            print(f"  warning: {warning}")
        for text in result.texts[:20]:
            print(f"  {text}")
    return result
