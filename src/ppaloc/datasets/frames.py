"""Lazy frame sequences: a traversal that loads (or renders) each frame on access.

A 30,000-frame traversal must not sit in memory, so a traversal is a ``Sequence`` whose
``__getitem__`` reads one frame. Slicing returns another lazy sequence (no frame is read);
a small per-sequence LRU cache keeps the last few frames, because localisers often look at
frame ``i`` and ``i-1`` together.
"""

from __future__ import annotations

from collections import OrderedDict
from collections.abc import Callable, Iterator, Sequence
from pathlib import Path
from typing import overload

import numpy as np

__all__ = ["FrameSequence", "ImageFrames", "RenderedFrames", "as_frames"]

DEFAULT_CACHE = 16
"""Frames each sequence keeps (least recently used dropped first)."""


class FrameSequence(Sequence[np.ndarray]):
    """A lazy, sliceable sequence of 2-D ``uint8`` frames.

    Parameters
    ----------
    load : callable
        ``load(i) -> ndarray`` for a source index ``i`` (the index before any slicing).
    indices : sequence of int
        Source indices in this sequence's order.
    cache : int
        How many frames to keep (0 disables the cache).

    Examples
    --------
    >>> seq = FrameSequence(lambda i: np.full((2, 2), i, np.uint8), range(10))
    >>> len(seq[2:8:2]), int(seq[2:8:2][1][0, 0]), [int(f[0, 0]) for f in seq[[9, 0]]]
    (3, 4, [9, 0])

    Notes
    -----
    Returned frames are read-only views of the cached array, so a caller cannot alter what
    the next caller sees; copy before writing.
    """

    def __init__(
        self,
        load: Callable[[int], np.ndarray],
        indices: Sequence[int],
        cache: int = DEFAULT_CACHE,
    ) -> None:
        self._load = load
        self._indices = np.asarray(indices, dtype=np.int64)
        self._cache_size = int(cache)
        self._cache: OrderedDict[int, np.ndarray] = OrderedDict()

    def __len__(self) -> int:
        return int(self._indices.size)

    @property
    def source_indices(self) -> np.ndarray:
        """Index of each frame in the unsliced source, shape (len(self),)."""
        return self._indices.copy()

    @overload
    def __getitem__(self, item: int) -> np.ndarray: ...

    @overload
    def __getitem__(self, item: slice | Sequence[int]) -> FrameSequence: ...

    def __getitem__(self, item: int | slice | Sequence[int]) -> np.ndarray | FrameSequence:
        if isinstance(item, slice):
            return self.select(self._indices[item], positional=False)
        if isinstance(item, (list, tuple, np.ndarray)):
            idx = np.asarray(item, dtype=np.int64).ravel()
            n = len(self)
            if idx.size and (idx.min() < -n or idx.max() >= n):
                raise IndexError(f"frame indices out of range for {n} frames")
            return self.select(idx % n if n else idx)
        i = int(item)
        n = len(self)
        if i < 0:
            i += n
        if not 0 <= i < n:
            raise IndexError(f"frame index {item} out of range for {n} frames")
        return self._get(int(self._indices[i]))

    def select(self, idx: Sequence[int], positional: bool = True) -> FrameSequence:
        """Return a lazy sub-sequence.

        Parameters
        ----------
        idx : sequence of int
            Positions in this sequence (``positional=True``) or source indices.
        """
        chosen = self._indices[np.asarray(idx, dtype=np.int64)] if positional else idx
        return type(self)._from(self, chosen)

    @classmethod
    def _from(cls, other: FrameSequence, indices: Sequence[int]) -> FrameSequence:
        new = cls.__new__(cls)
        new.__dict__.update(other.__dict__)
        new._indices = np.asarray(indices, dtype=np.int64)
        new._cache = OrderedDict()
        return new

    def transformed(
        self, fn: Callable[[np.ndarray], np.ndarray], cache: int | None = None
    ) -> FrameSequence:
        """Return a lazy sequence of ``fn(frame)`` for every frame (applied when read).

        The result is sliceable like this one and has its own cache of ``cache`` frames
        (default: this one's size); ``fn`` should be a picklable callable (not a lambda)
        if the sequence is to be pickled.

        Examples
        --------
        >>> seq = FrameSequence(lambda i: np.full((1, 1), i, np.uint8), range(5))
        >>> [int(f[0, 0]) for f in seq.transformed(np.negative)[1:3]]
        [255, 254]
        """
        new = type(self)._from(self, self._indices)
        new._load = _Transformed(self._load, fn)
        if cache is not None:
            new._cache_size = int(cache)
        return new

    def names(self) -> list[str] | None:
        """The name of each frame's source, in this sequence's order, or None where frames
        have no file (rendered frames, arrays in memory).

        Image files are named by their file name (``images-00010.png``), video frames by
        the video's file name and the frame's 0-based index in it (``query.mp4#12``): the
        names ``ppaloc localise`` writes and ``ppaloc score`` matches.
        """
        return None

    def __iter__(self) -> Iterator[np.ndarray]:
        for src in self._indices:
            yield self._get(int(src))

    def _get(self, src: int) -> np.ndarray:
        hit = self._cache.get(src)
        if hit is not None:
            self._cache.move_to_end(src)
            return hit
        # a read-only view: the loader's own array (e.g. one a caller handed in) stays writable
        frame = np.asarray(self._load(src)).view()
        frame.setflags(write=False)
        if self._cache_size > 0:
            self._cache[src] = frame
            while len(self._cache) > self._cache_size:
                self._cache.popitem(last=False)
        return frame

    def __repr__(self) -> str:
        return f"{type(self).__name__}({len(self)} frames)"


def as_frames(frames: Sequence[np.ndarray], cache: int = DEFAULT_CACHE) -> FrameSequence:
    """``frames`` as a :class:`FrameSequence`: itself if it is one, else a lazy wrapper
    that reads ``frames[i]`` on access (a plain list of arrays, a caller's own sequence).

    Examples
    --------
    >>> seq = as_frames([np.zeros((1, 1), np.uint8), np.ones((1, 1), np.uint8)])
    >>> [int(f[0, 0]) for f in seq.transformed(np.negative)]
    [0, 255]
    """
    if isinstance(frames, FrameSequence):
        return frames
    return FrameSequence(frames.__getitem__, range(len(frames)), cache)


class _Transformed:
    """``fn(load(i))`` (picklable when ``load`` and ``fn`` are)."""

    def __init__(
        self, load: Callable[[int], np.ndarray], fn: Callable[[np.ndarray], np.ndarray]
    ) -> None:
        self.load, self.fn = load, fn

    def __call__(self, i: int) -> np.ndarray:
        return self.fn(self.load(i))


class ImageFrames(FrameSequence):
    """Frames read from image files (grey ``uint8``), one file per frame.

    Parameters
    ----------
    paths : sequence of Path
        One image per frame, in traversal order.
    cache : int
        Frames kept in the LRU cache.
    """

    def __init__(self, paths: Sequence[Path], cache: int = DEFAULT_CACHE) -> None:
        self.paths = tuple(Path(p) for p in paths)
        super().__init__(self._read, range(len(self.paths)), cache)

    def _read(self, i: int) -> np.ndarray:
        from ppaloc.datasets.images import read_grey

        return read_grey(self.paths[i])

    def path(self, i: int) -> Path:
        """The file behind frame ``i`` of this (possibly sliced) sequence."""
        return self.paths[int(self._indices[i])]

    def names(self) -> list[str]:
        """Each frame's file name (without its folder), in this sequence's order.

        Examples
        --------
        >>> ImageFrames([Path("a/f1.png"), Path("a/f2.png")])[::-1].names()
        ['f2.png', 'f1.png']
        """
        return [self.paths[int(i)].name for i in self._indices]


class RenderedFrames(FrameSequence):
    """Frames computed on access by ``render(i)`` (e.g. the procedural generator)."""

    def __init__(
        self, render: Callable[[int], np.ndarray], n: int, cache: int = DEFAULT_CACHE
    ) -> None:
        super().__init__(render, range(int(n)), cache)
