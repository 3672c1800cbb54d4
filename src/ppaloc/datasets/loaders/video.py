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
"""

from __future__ import annotations

import contextlib
import itertools
import re
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import numpy as np

from ppaloc.datasets.frames import FrameSequence
from ppaloc.datasets.images import MAX_IMAGE_PIXELS, missing
from ppaloc.datasets.loaders import owntruth
from ppaloc.datasets.route import RawRoute
from ppaloc.datasets.spec import DatasetSpec, Key, KindSchema
from ppaloc.errors import DataError
from ppaloc.frontend import to_grey

__all__ = ["SCHEMA", "VideoFrames", "load", "open_video", "read_stream", "stream_frames"]

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


class _Decoder:
    """A sequential decoder over one file that can restart; shared by all slices."""

    def __init__(self, path: Path) -> None:
        self.path = path
        self.container = None
        self.frames = None
        self.next_index = 0

    def __del__(self) -> None:
        with contextlib.suppress(Exception):  # at interpreter exit av may be gone already
            self.close()

    def open(self) -> None:
        self.close()
        self.container, self.frames = open_video(str(self.path), f"video {self.path}")
        self.next_index = 0

    def count(self) -> int:
        self.open()
        n = int(self.container.streams.video[0].frames or 0)
        if n <= 0:  # the container does not say (Matroska, WebM, MPEG-TS): count by decoding
            n = self._decode_all()
            self.open()
        return n

    def _decode_all(self) -> int:
        """How many frames decoding the whole file gives; a frame that fails is named."""
        n = 0
        try:
            for _ in self.frames:
                n += 1
        except Exception as exc:  # a damaged frame, met while counting (PyAV raises many types)
            self.close()
            raise DataError(
                f"cannot decode frame {n} of video {self.path} (decoded to count its frames, "
                f"which its container does not record): {_reason(exc)}; the video is damaged "
                "or cut short: give a complete video"
            ) from None
        return n

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
        return {"path": self.path, "container": None, "frames": None, "next_index": 0}


class VideoFrames(FrameSequence):
    """Grey frames of a video file, decoded on access.

    Parameters
    ----------
    path : Path
        Any container and codec FFmpeg reads.
    cache : int
        Frames kept in the LRU cache.
    """

    def __init__(self, path: Path, cache: int = 16) -> None:
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
    ref, query = VideoFrames(ref_path), VideoFrames(query_path)
    n, m = len(ref), len(query)
    own = owntruth.given(spec)
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
