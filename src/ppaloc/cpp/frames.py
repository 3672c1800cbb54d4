"""A run's frames, taken one at a time as the program asks for them.

A :class:`FrameSource` wraps any iterable of exposures: a list, or a generator that
decodes a camera or a stream as it goes. The session takes frame ``k`` when the program
starts its ``k``-th frame-loop pass, so a live stream's first frame reaches the program
before the next one is decoded, and a long ``--frames`` count of a stream costs no wait
up front.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Iterable, Iterator, Sized

import numpy as np

from ppaloc.errors import PpalocError

__all__ = ["FrameSource"]


class FrameSource:
    """At most ``limit`` exposures of ``frames``, taken in turn; checked as they come.

    Parameters
    ----------
    frames : iterable of (H, W) uint8 arrays
        The exposures: a list, or an iterator that reads them as they are asked for (it may
        raise a :class:`~ppaloc.errors.PpalocError` naming a frame it cannot read).
    limit : int, optional
        The most frames taken (an endless stream's ``--frames``); default all of them.
    convert : callable, optional
        Applied to each frame as it is read (``ppaloc.frontend.to_sensor`` for a stream's
        grey frames of any size).

    Attributes
    ----------
    bound : int or None
        The most frames this source gives (``limit``, or the list's length, whichever is
        smaller); None for an unbounded iterator.
    taken : int
        Frames handed out so far.
    error : str or None
        Why the frames ended early: a frame that could not be read (the source's one-line
        message) or that is not like the first; None while they run or after a clean end.
    waited_s : float
        Wall time spent reading frames (not the program's: a run's timeout leaves it out).

    Examples
    --------
    >>> src = FrameSource(iter([np.zeros((2, 2), np.uint8)] * 5), limit=3)
    >>> src.bound, src.take().shape, src.take() is not None, src.take() is not None
    (3, (2, 2), True, True)
    >>> src.take() is None, src.taken, src.error
    (True, 3, None)
    """

    def __init__(
        self,
        frames: Iterable[np.ndarray],
        limit: int | None = None,
        convert: Callable[[np.ndarray], np.ndarray] | None = None,
    ) -> None:
        size = len(frames) if isinstance(frames, Sized) else None
        if limit is not None and size is not None:
            size = min(size, limit)
        self.bound: int | None = limit if size is None else size
        self.taken = 0
        self.error: str | None = None
        self.waited_s = 0.0
        self._frames: Iterator[np.ndarray] = iter(frames)
        self._input = frames  # closed with the source, if it can be
        self._convert = convert
        self._next: np.ndarray | None = None  # read by peek, not yet taken
        self._shape: tuple[int, ...] | None = None
        self._ended = False

    def peek(self) -> np.ndarray | None:
        """The frame :meth:`take` gives next, read now if it was not (None at the end)."""
        if self._next is None:
            self._next = self._read()
        return self._next

    def take(self) -> np.ndarray | None:
        """The next frame, or None when the frames ended (:attr:`error` says if early)."""
        frame = self.peek()
        self._next = None
        if frame is not None:
            self.taken += 1
            if self.bound is not None and self.taken >= self.bound:
                self.close()  # a camera stops capturing as soon as its last frame is taken
        return frame

    def __iter__(self) -> Iterator[np.ndarray]:
        """The frames left, then a :class:`~ppaloc.errors.PpalocError` if one failed."""
        while (frame := self.take()) is not None:
            yield frame
        if self.error is not None:
            raise PpalocError(self.error)

    def close(self) -> None:
        """End the frames and release their input (a stream's ``close``), if it has one."""
        self._ended = True
        close = getattr(self._input, "close", None)
        if close is not None:
            close()

    def _read(self) -> np.ndarray | None:
        if self._ended:
            return None
        if self.bound is not None and self.taken >= self.bound:
            self.close()  # a camera stops capturing as soon as its last frame is taken
            return None
        index = self.taken
        start = time.perf_counter()
        try:
            frame = next(self._frames)
            frame = np.asarray(frame if self._convert is None else self._convert(frame))
        except StopIteration:
            frame = None
        except PpalocError as exc:
            self.error = str(exc)
            frame = None
        finally:
            self.waited_s += time.perf_counter() - start
        if frame is not None and self._shape is None:
            self._shape = frame.shape
        if frame is not None and (
            frame.dtype != np.uint8 or frame.ndim != 2 or frame.shape != self._shape
        ):
            like = f"of shape {self._shape} as frame 0" if index else "of one shape"
            self.error = (
                f"frame {index} is a {frame.dtype} array of shape {frame.shape}: frames must be "
                f"uint8 images {like} (convert them with ppaloc.frontend.to_sensor)"
            )
            frame = None
        if frame is None:
            self.close()
        return frame
