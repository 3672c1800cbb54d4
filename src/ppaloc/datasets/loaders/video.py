"""``video:REF.mp4,QUERY.mp4``: one video file per traversal.

Frames are decoded on access with PyAV (FFmpeg's libraries, shipped inside the ``av``
wheel). Reading forward is cheap (frames in between are decoded and dropped); going
backwards restarts decoding from the start. Use ``step`` to keep every step-th frame.
Colour frames become grey by the same ITU-R 601 rule as images.

Ground truth: ``align=index`` (default) takes frame ``i`` of both videos as the same place
and needs equal frame counts; ``align=proportional`` assumes both traversals moved at
constant speed, so query frame ``i`` of ``M`` is at reference frame ``i (N - 1) / (M - 1)``.
Or the user's own, as for ``folder:``: positions files with a tolerance in metres, or
hard and soft matrices (:mod:`ppaloc.datasets.loaders.owntruth`).

A container that records no frame count (Matroska, WebM, MPEG-TS) has its frames counted
by decoding them. FFmpeg ends such a video without an error where the file is cut short,
or where damaged data made its reader skip ahead, so the count is compared with what the
container declares (a ``NUMBER_OF_FRAMES`` tag, else its duration times its frame rate);
clearly fewer frames is a :class:`ShortVideoWarning`, and an error under
``align=proportional``, whose ground truth follows the two lengths.
"""

from __future__ import annotations

import contextlib
import itertools
import re
import warnings
from collections.abc import Iterator
from pathlib import Path
from typing import Any, NamedTuple

import numpy as np

from ppaloc.datasets.frames import FrameSequence
from ppaloc.datasets.images import MAX_IMAGE_PIXELS, missing
from ppaloc.datasets.loaders import owntruth
from ppaloc.datasets.route import RawRoute
from ppaloc.datasets.spec import DatasetSpec, Key, KindSchema
from ppaloc.errors import DataError
from ppaloc.frontend import to_grey

__all__ = [
    "SCHEMA",
    "ShortVideoWarning",
    "VideoFrames",
    "load",
    "open_video",
    "read_stream",
    "stream_frames",
]

SCHEMA = KindSchema(
    n_paths=(2,),
    keys={
        "align": Key(
            "choice",
            "index",
            "ground truth: same index, or constant-speed proportional",
            choices=("index", "proportional"),
        ),
        **owntruth.KEYS,
    },
    example="video:ref.mp4,query.mp4?step=2&align=proportional",
)


class ShortVideoWarning(UserWarning):
    """A video decoded to clearly fewer frames than its container declares: it is cut short
    or damaged (FFmpeg ends such a video without an error)."""


SHORT_FRAMES = 2
"""Frames a video may fall short of what its container declares without a word: container
durations and frame rates are estimates (rounding, a variable frame rate)."""

SHORT_FRACTION = 0.03
"""Fraction of the declared frames a video may fall short by without a word (a shortfall
must exceed both this and :data:`SHORT_FRAMES`)."""


_GRAPH_SIZE = re.compile(r"(?<![0-9])([0-9]+)x([0-9]+)(?![0-9])")
"""A frame size written ``WxH`` in a filter graph (a source's ``size=``/``s=``)."""


def _lavfi_options(target: str, what: str, options: dict[str, str] | None) -> dict[str, str]:
    """The options of a ``lavfi`` input, with the frames it makes bounded before FFmpeg
    makes one.

    FFmpeg's probe of the input (``av.open``) ran the filter graph for a frame before the
    size of its frames could be read, and a graph of 20000 x 20000 frames took gigabytes
    and was killed before the size was refused; ``max_ts_probe=0`` lets the probe end on the
    sizes the graph declares, read before any frame is made. A size written ``WxH`` in
    the graph larger than :data:`~ppaloc.datasets.images.MAX_IMAGE_PIXELS` is refused
    before the graph runs, as a source of that size scaled down after it would make its
    frames all the same.
    """
    for m in _GRAPH_SIZE.finditer(target):
        w, h = int(m.group(1)), int(m.group(2))
        if w * h > MAX_IMAGE_PIXELS:
            raise DataError(
                f"{what} makes frames of {w} x {h} pixels, more than {MAX_IMAGE_PIXELS}; give "
                "a smaller size"
            )
    return {**(options or {}), "max_ts_probe": "0"}


def open_video(
    target: str, what: str, format: str | None = None, options: dict[str, str] | None = None
) -> tuple[Any, Iterator[Any]]:
    """Open a video file, device or stream with PyAV: its container and decoded frames.

    ``target`` and ``format`` are what FFmpeg's ``-i`` and ``-f`` take (a file; a device
    such as ``/dev/video0`` with ``format="v4l2"``; a filter graph such as
    ``testsrc=size=320x240`` with ``format="lavfi"``; a URL); ``what`` names it in
    messages.

    ``options`` are FFmpeg's input options (``-NAME VALUE`` before ``-i``): the input's,
    and its decoder's, which go to the decoder the frames come from; one neither takes is
    refused (:func:`~ppaloc.datasets.loaders.ffoptions.check_input_options`: FFmpeg would
    ignore it without a word), before the input is opened where ``format`` is given (but
    for a decoder's own, which waits for the decoder), else once it is open.

    A ``lavfi`` graph's frame size is checked before the graph makes a frame
    (:func:`_lavfi_options`).

    Raises
    ------
    DataError
        If it cannot be opened, holds no video stream, claims frames of more than
        :data:`~ppaloc.datasets.images.MAX_IMAGE_PIXELS` pixels, or is given an option
        it does not take.
    """
    import av

    from ppaloc.datasets.loaders.ffoptions import check_input_options, input_options

    check_input_options(options, format, what)
    given = _lavfi_options(target, what, options) if format == "lavfi" else options or {}
    container = None
    try:
        container = av.open(target, format=format, options=given)
        if not container.streams.video:
            raise DataError(
                f"{what} holds no video stream (not a video, or cut short); give a complete video"
            )
        context = container.streams.video[0].codec_context
        if context is None:  # a stream FFmpeg cannot set a decoder up for (a file cut short)
            raise DataError(
                f"{what} holds no decodable video stream (cut short, or in a codec this "
                "FFmpeg lacks); give a complete video"
            )
        if options:  # the input is known now, and its decoder
            check_input_options(options, container.format.name, what, context.codec.name)
            known = input_options(container.format.name)
            context.options = {} if known is None else known.for_decoder(options)
        w, h = int(context.width or 0), int(context.height or 0)
        if w * h > MAX_IMAGE_PIXELS:
            raise DataError(
                f"{what} claims {w} x {h} pixels a frame, more than {MAX_IMAGE_PIXELS}; give "
                "a smaller video"
            )
        return container, container.decode(video=0)
    except DataError:
        if container is not None:
            container.close()
        raise
    except Exception as exc:  # PyAV raises many types on a bad file
        if container is not None:
            container.close()
        if isinstance(exc, EOFError):  # FFmpeg found no packet at all: a video of 0 frames
            raise DataError(
                f"{what} holds no frames (an empty video, or one cut short); give a video "
                "with frames"
            ) from None
        raise DataError(f"cannot read {what}: {_reason(exc)}") from None


def _reason(exc: BaseException) -> str:
    """An error of PyAV in words: FFmpeg's own cause without its error number and the
    file or FFmpeg function it met it in (``[Errno 1094995529] Invalid data found when
    processing input: 'avcodec_send_packet()'`` is ``Invalid data found when processing
    input``); any other error as it reads."""
    import av

    if isinstance(exc, av.FFmpegError) and exc.strerror:
        return str(exc.strerror)
    return str(exc)


def _grey(frame: Any) -> np.ndarray:
    """A decoded frame as grey ``uint8`` (ITU-R 601, as images)."""
    return to_grey(frame.to_ndarray(format="rgb24"))


def stream_frames(
    target: str, format: str | None = None, options: dict[str, str] | None = None
) -> Iterator[np.ndarray]:
    """A live stream's or camera's frames, grey, each decoded when it is asked for.

    The input is opened now (so a bad one is refused at once, in one line); each frame is
    then decoded only when the iterator is advanced, so a consumer gets the first frame
    before the second is decoded. The iterator ends with the stream (never, for a camera)
    and closes the input when it ends, fails or is closed. See :func:`open_video` for
    ``target``, ``format`` and ``options``.

    Raises
    ------
    DataError
        If it cannot be opened (now); while iterating, if frame ``k`` cannot be decoded
        (``cannot decode frame k of stream ...``) or no frame comes (``... gave no frames``).
    """
    what = f"stream {target}" + (f" (format {format})" if format else "")
    return _StreamFrames(*open_video(target, what, format, options), what)


class _StreamFrames:
    """An open input's grey frames, decoded one per ``next``; closes it at the end."""

    def __init__(self, container: Any, frames: Iterator[Any], what: str) -> None:
        self._container, self._frames, self.what = container, frames, what
        self.decoded = 0

    def __iter__(self) -> _StreamFrames:
        return self

    def __next__(self) -> np.ndarray:
        if self._container is None:
            raise StopIteration
        try:
            frame = next(self._frames, None)
            grey = None if frame is None else _grey(frame)
        except Exception as exc:  # PyAV raises many types on a broken stream
            self.close()
            raise DataError(
                f"cannot decode frame {self.decoded} of {self.what}: {_reason(exc)}"
            ) from None
        if grey is None:
            self.close()
            if not self.decoded:
                raise DataError(f"{self.what} gave no frames")
            raise StopIteration
        self.decoded += 1
        return grey

    def close(self) -> None:
        """Close the input (idempotent); the iterator then ends."""
        if self._container is not None:
            self._container.close()
        self._container = None

    def __del__(self) -> None:
        with contextlib.suppress(Exception):  # at interpreter exit av may be gone already
            self.close()


def read_stream(
    target: str, n: int, format: str | None = None, options: dict[str, str] | None = None
) -> list[np.ndarray]:
    """The first ``n`` frames, grey, of a live stream or camera (or any input PyAV opens).

    A stream has no end to count to, so ``n`` bounds it; one that ends sooner gives the
    frames it had. :func:`stream_frames` gives them one at a time instead. See
    :func:`open_video` for ``target``, ``format`` and ``options``.

    Raises
    ------
    DataError
        If it cannot be opened or decoded, or gives no frame.
    """
    frames = stream_frames(target, format, options)
    try:
        return list(itertools.islice(frames, n))
    finally:
        frames.close()


def _tag(stream: Any, name: str) -> str | None:
    """A stream tag's value (Matroska tags may carry a language: ``NUMBER_OF_FRAMES-eng``)."""
    for key, value in (getattr(stream, "metadata", None) or {}).items():
        if key.upper() == name or key.upper().startswith(f"{name}-"):
            return str(value)
    return None


class _Declared(NamedTuple):
    """The frames a container declares for a stream that records no frame count."""

    frames: int
    how: str
    """How it was read: ``4.0 s at 10 fps``, ``its NUMBER_OF_FRAMES tag``."""
    seconds: float | None
    """The stream's duration (None for a ``NUMBER_OF_FRAMES`` tag, an exact count)."""
    rate: float


def _declared(container: Any, stream: Any) -> _Declared | None:
    """The frames a container declares for a stream that records no frame count, or None
    where it declares too little to tell.

    A ``NUMBER_OF_FRAMES`` tag (mkvmerge writes one) is taken as it is; else the stream's
    duration (its own, or its ``DURATION`` tag, or the container's where the video is its
    only stream: an audio track may outlast the video) times its average frame rate.
    """
    with contextlib.suppress(ValueError, TypeError):
        tagged = int(_tag(stream, "NUMBER_OF_FRAMES") or "")
        if tagged > 0:
            return _Declared(tagged, "its NUMBER_OF_FRAMES tag", None, 0.0)
    seconds = None
    if stream.duration and stream.time_base:
        seconds = float(stream.duration * stream.time_base)
    elif (text := _tag(stream, "DURATION")) is not None:
        with contextlib.suppress(ValueError):
            h, m, sec = text.strip().split(":")
            seconds = int(h) * 3600 + int(m) * 60 + float(sec)
    elif container.duration and len(container.streams) == 1:
        seconds = container.duration / 1_000_000
    rate = float(stream.average_rate or stream.guessed_rate or 0)
    if not seconds or seconds <= 0 or rate <= 0 or round(seconds * rate) <= 0:
        return None
    return _Declared(round(seconds * rate), f"{seconds:.1f} s at {rate:.4g} fps", seconds, rate)


def _clearly_short(n: int, declared: int) -> bool:
    """Whether ``n`` decoded frames fall clearly short of ``declared`` (see
    :data:`SHORT_FRAMES`, :data:`SHORT_FRACTION`)."""
    missing = declared - n
    return missing > SHORT_FRAMES and missing > SHORT_FRACTION * declared


def _shortfall(
    path: Path, n: int, last: float | None, declared: _Declared
) -> tuple[str, bool] | None:
    """Why ``n`` decoded frames, the last ``last`` seconds after the first, fall clearly
    short of what the container declares, and whether frames are surely missing; None if
    they do not.

    Frames are surely missing where the container gives an exact count, or where they stop
    clearly before its duration (cut short, or damaged there). Frames that reach its end
    but are too few may be missing inside it (damaged data FFmpeg skipped) or the stream's
    frame rate may vary, which a duration times a frame rate does not see.
    """
    if not _clearly_short(n, declared.frames):
        return None
    head = f"video {path} decoded to {n} frames, but its container declares {declared.frames} "
    head += f"({declared.how})"
    if declared.seconds is None:
        return f"{head}: it is cut short or damaged", True
    if last is None:  # frames without times: where they went is unknown
        return f"{head}: it is cut short or damaged, or its frame rate varies", False
    after = round((declared.seconds - last) * declared.rate) - 1  # frames past the last one
    if _clearly_short(declared.frames - after, declared.frames):
        return f"{head}, and they stop at {last:.1f} s: it is cut short or damaged", True
    return (
        f"{head}, and they reach {last:.1f} s: frames are missing inside it (damaged data "
        "skipped), or its frame rate varies"
    ), False


class _Decoder:
    """A sequential decoder over one file that can restart; shared by all slices."""

    def __init__(self, path: Path) -> None:
        self.path = path
        self.container = None
        self.frames = None
        self.next_index = 0
        self.declared = 0  # the frames its container records (0: counted by decoding)
        self.short: tuple[str, bool] | None = None  # see _shortfall

    def __del__(self) -> None:
        with contextlib.suppress(Exception):  # at interpreter exit av may be gone already
            self.close()

    def open(self) -> None:
        self.close()
        self.container, self.frames = open_video(str(self.path), f"video {self.path}")
        self.next_index = 0

    def count(self) -> int:
        """The video's frames: as its container records them, else counted by decoding
        them, and then :attr:`short` says why where that is clearly fewer than its
        container declares (:func:`_shortfall`)."""
        self.open()
        stream = self.container.streams.video[0]
        n = self.declared = int(stream.frames or 0)
        self.short = None
        if n <= 0:  # the container does not say (Matroska, WebM, MPEG-TS): count by decoding
            declared = _declared(self.container, stream)
            n, last = self._decode_all()
            self.open()
            if declared is not None and n:
                self.short = _shortfall(self.path, n, last, declared)
        return n

    def _decode_all(self) -> tuple[int, float | None]:
        """How many frames decoding the whole file gives, and the time of the last from
        the first (None where the frames carry no time); a frame that fails is named."""
        n, first, last = 0, None, None
        try:
            for frame in self.frames:
                n += 1
                t = frame.time
                if t is not None:
                    first = t if first is None else first
                    last = t - first
        except Exception as exc:  # a damaged frame, met while counting (PyAV raises many types)
            self.close()
            raise DataError(
                f"cannot decode frame {n} of video {self.path} (decoded to count its frames, "
                f"which its container does not record): {_reason(exc)}; the video is damaged "
                "or cut short: give a complete video"
            ) from None
        return n, last

    def get(self, i: int) -> np.ndarray:
        if self.frames is None or i < self.next_index:
            self.open()
        try:
            while True:
                frame = next(self.frames)
                self.next_index += 1
                if self.next_index - 1 == i:
                    return _grey(frame)
        except StopIteration:
            if self.declared:  # the container's own count promised it
                raise DataError(
                    f"video {self.path} ends before frame {i} of the {self.declared} its "
                    "container declares: it is cut short or damaged; give a complete video"
                ) from None
            raise DataError(f"video {self.path} ends before frame {i}") from None
        except Exception as exc:
            raise DataError(
                f"cannot decode frame {i} of video {self.path}: {_reason(exc)}"
            ) from None

    def close(self) -> None:
        if self.container is not None:
            self.container.close()
        self.container, self.frames = None, None

    def __getstate__(self) -> dict:
        # An open file does not travel: a copy reopens the video on its first access.
        return {
            "path": self.path,
            "container": None,
            "frames": None,
            "next_index": 0,
            "declared": self.declared,
            "short": self.short,
        }


class VideoFrames(FrameSequence):
    """Grey frames of a video file, decoded on access.

    Parameters
    ----------
    path : Path
        Any container and codec FFmpeg reads.
    cache : int
        Frames kept in the LRU cache.
    proportional : bool
        The ground truth follows the video's length (``align=proportional``): a video
        that surely lacks frames its container declares (:func:`_shortfall`) is refused,
        where it is otherwise a :class:`ShortVideoWarning`, and one that may lack frames
        inside it is a warning that says what it does to the ground truth.

    Raises
    ------
    DataError
        If the file is missing, not a video, damaged where a frame is decoded to count
        them, has no frames, or (``proportional``) surely lacks frames.

    Warns
    -----
    ShortVideoWarning
        If it decodes to clearly fewer frames than its container declares.
    """

    def __init__(self, path: Path, cache: int = 16, *, proportional: bool = False) -> None:
        self.path = Path(path)
        if self.path.is_dir():
            raise DataError(f"video {self.path} is a folder; give a video file")
        if not self.path.is_file():
            raise DataError(f"video {self.path} {missing(self.path)}: check the path in the spec")
        if self.path.stat().st_size == 0:
            raise DataError(f"video {self.path} is empty (0 bytes); give a complete video")
        self._decoder = _Decoder(self.path)
        n = self._decoder.count()
        if n == 0:
            self._decoder.close()
            raise DataError(f"video {self.path} has no frames")
        if self._decoder.short is not None:
            why, surely = self._decoder.short
            if surely and proportional:
                self._decoder.close()
                raise DataError(
                    f"{why}; align=proportional places query frames by the two videos' "
                    "lengths, so every query frame's ground truth would be wrong: give a "
                    "complete video, or your own ground truth"
                )
            why += f"; its {n} frames are used"
            if proportional:
                why += (
                    ", but align=proportional places query frames by the two videos' "
                    "lengths, so their ground truth may be off"
                )
            # stacklevel 1: one warning per file and process (a map reads its video twice)
            warnings.warn(why, ShortVideoWarning, stacklevel=1)
        super().__init__(self._decoder.get, range(n), cache)

    def close(self) -> None:
        """Release the decoder (it reopens on the next access)."""
        self._decoder.close()

    def names(self) -> list[str]:
        """``VIDEO#INDEX`` per frame: the video's file name and the frame's 0-based index in
        the video (before any ``step`` selection), in this sequence's order."""
        return [f"{self.path.name}#{int(i)}" for i in self._indices]


def load(spec: DatasetSpec) -> RawRoute:
    """Open both videos; the ground truth follows ``align`` (or the spec's own)."""
    owntruth.check(spec)
    ref_path, query_path = spec.paths
    own = owntruth.given(spec)
    # proportional truth follows both lengths, unless both are the one video (a map's)
    by_length = not own and spec.options["align"] == "proportional" and ref_path != query_path
    ref = VideoFrames(ref_path, proportional=by_length)
    try:
        query = VideoFrames(query_path, proportional=by_length)
    except BaseException:
        ref.close()
        raise
    n, m = len(ref), len(query)
    if own:
        place = np.arange(m, dtype=np.float64)  # replaced by owntruth.apply
    elif spec.options["align"] == "index":
        if n != m:
            ref.close()
            query.close()
            raise DataError(
                f"reference video {ref_path} has {n} frames but query video {query_path} has "
                f"{m}; align=index needs equal counts: add align=proportional (constant speed)"
            )
        place = np.arange(m, dtype=np.float64)
    else:
        place = np.arange(m, dtype=np.float64) * ((n - 1) / max(m - 1, 1))
    raw = RawRoute(
        name=f"video {ref_path.name}->{query_path.name}",
        reference=ref,
        query=query,
        default_tolerance=0,
        query_place=place,
        meta={
            "kind": "video",
            "reference": str(ref_path),
            "query": str(query_path),
            "roles": {"database": f"frames of {ref_path}", "query": f"frames of {query_path}"},
        },
        truth={"source": f"{spec.options['align']} (frame-synchronised)"
               if spec.options["align"] == "index" else "proportional (constant speed)"},
    )  # fmt: skip
    if own:
        try:
            owntruth.apply(raw, spec)
        except BaseException:
            ref.close()
            query.close()
            raise
    return raw
