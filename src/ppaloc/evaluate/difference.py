"""The difference matrix: how unlike each query frame is to each reference frame, whatever
the method.

The place-recognition field's standard figure (SeqSLAM's "difference matrix") draws, for
every query frame (x) and reference frame (y), how different the two images are; the
route shows as a valley of low difference, and each method's predicted path can be drawn
over it to see where the images were ambiguous and where a method followed or left the
valley. The report draws it from ``arrays/_difference.npz``
(:func:`ppaloc.evaluate.figures.difference_matrix`).

Measure
    The single-frame baseline's image difference (:class:`~ppaloc.baselines.single.SingleFrame`
    with its defaults, SeqSLAM's reduction): each sensor frame reduced to 64x32 block means,
    every 8x8 patch normalised to zero mean and unit deviation, and the mean absolute
    difference per pixel of two such images (:data:`MEASURE`; units: z, the patch's
    standard deviations). It depends on no evaluated method's map, state or parameters, so
    it shows what the images themselves say, and the single-frame method's estimate is the
    smallest entry of its row.

Sampling
    A traversal of ``n`` frames is sampled every ``s = ceil(n / limit)`` frames (frames
    ``0, s, 2s, ...``; :func:`sample_indices`), each traversal on its own, with ``limit`` =
    :data:`DIFFERENCE_SAMPLES` (512, about the pixels a panel of the figure has). An entry
    is the exact difference of two real frames (nothing is averaged); a route longer than
    512 frames shows every ``s``-th row and column. The matrix takes at most 512 x 512
    float32 values (1 MiB), and while the run lasts the sampled reference images take
    512 x 2,048 float32 values (4 MiB), whatever the route's length: every pair of a
    30,000-frame route would take 3.4 GiB.

Recording
    The run fills the matrix from the frames it streams anyway (:class:`DifferenceRecorder`):
    no frame is read twice, none is kept.
"""

from __future__ import annotations

import time
from collections.abc import Iterator, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from ppaloc.baselines.single import SingleFrame
from ppaloc.topomap import TopoMap

__all__ = [
    "DIFFERENCE_SAMPLES",
    "MEASURE",
    "DifferenceMatrix",
    "DifferenceRecorder",
    "difference_matrix",
    "sample_indices",
]

DIFFERENCE_SAMPLES = 512
"""Most frames of each traversal the difference matrix samples (rows and columns)."""

MEASURE = (
    "mean absolute difference per pixel of 64x32 images with 8x8 patches normalised "
    "(the single-frame baseline's image difference)"
)
"""What one entry of the difference matrix is (written into results.json)."""


def sample_indices(n: int, limit: int = DIFFERENCE_SAMPLES) -> np.ndarray:
    """The frames of an ``n``-frame traversal the difference matrix samples.

    Every frame when ``n <= limit``, else every ``ceil(n / limit)``-th frame from frame 0,
    so at most ``limit`` frames, evenly spaced.

    Parameters
    ----------
    n : int
        Frames in the traversal.
    limit : int
        Most frames sampled (at least 1).

    Returns
    -------
    ndarray of int64, shape (min(n, limit) or fewer,)

    Examples
    --------
    >>> sample_indices(5).tolist(), sample_indices(10, limit=4).tolist()
    ([0, 1, 2, 3, 4], [0, 3, 6, 9])
    """
    if limit < 1:
        raise ValueError(f"limit must be at least 1, got {limit}")
    stride = max(1, -(-int(n) // int(limit)))
    return np.arange(0, max(int(n), 0), stride, dtype=np.int64)


@dataclass(frozen=True, eq=False)
class DifferenceMatrix:
    """The frame difference of sampled (query, reference) pairs.

    Attributes
    ----------
    values : ndarray of float32, shape (Q, R)
        ``values[i, j]`` is the difference between query frame ``query_index[i]`` and
        reference frame ``reference_index[j]`` (:data:`MEASURE`, z units; lower = more alike).
    query_index : ndarray of int64, shape (Q,)
        The sampled query frames, increasing (:func:`sample_indices`).
    reference_index : ndarray of int64, shape (R,)
        The sampled reference frames, increasing.
    measure : str
        What an entry is.
    """

    values: np.ndarray
    query_index: np.ndarray
    reference_index: np.ndarray
    measure: str = MEASURE

    @property
    def strides(self) -> tuple[int, int]:
        """Spacing of the sampled query and reference frames (1: every frame)."""

        return _stride(self.query_index), _stride(self.reference_index)

    def sampling(self) -> str:
        """The sampling in words, e.g. ``"every frame"``.

        Examples
        --------
        >>> d = DifferenceMatrix(np.zeros((2, 3)), np.array([0, 4]), np.array([0, 1, 2]))
        >>> d.sampling()
        'one query frame in 4, every reference frame'
        """
        sq, sr = self.strides
        if sq == sr == 1:
            return "every frame"

        def words(what: str, s: int) -> str:
            return f"every {what} frame" if s == 1 else f"one {what} frame in {s}"

        return f"{words('query', sq)}, {words('reference', sr)}"

    @property
    def memory_bytes(self) -> int:
        """Bytes of the three arrays."""
        return int(self.values.nbytes + self.query_index.nbytes + self.reference_index.nbytes)


class _Watched(Sequence[np.ndarray]):
    """A traversal that hands every frame read from it, by index or in order, to
    ``observe(i, frame)``; slices pass through unobserved."""

    def __init__(self, frames: Sequence[np.ndarray], observe: Any) -> None:
        self._frames, self._observe = frames, observe

    def __len__(self) -> int:
        return len(self._frames)

    def __getitem__(self, item: Any) -> Any:
        frame = self._frames[item]
        if not isinstance(item, slice):
            self._observe(int(item) % max(len(self._frames), 1), frame)
        return frame

    def __iter__(self) -> Iterator[np.ndarray]:
        for i in range(len(self)):
            yield self[i]


class DifferenceRecorder:
    """Builds the difference matrix from the frames a run streams, without reading any
    frame a second time.

    While the first method builds its map, each sampled reference frame read through
    :meth:`watch_reference` is reduced to the single-frame image (about 1 ms a frame; the
    time is counted in :attr:`reference_seconds`, which the run takes off that method's map
    build time). When the first sampled query frame arrives through :meth:`watch_query`
    the reduced images become a single-frame map, and each sampled query frame then fills
    its row (a few ms for 512 columns), between two steps and outside their timing.
    :meth:`result` reads any sampled frame that did not pass (a method that skipped it).

    Parameters
    ----------
    n_reference, n_query : int
        Frames in each traversal.
    limit : int
        Most frames sampled from each traversal (:func:`sample_indices`).

    Examples
    --------
    >>> rng = np.random.default_rng(0)
    >>> frames = [rng.integers(0, 256, (256, 256), dtype=np.uint8) for _ in range(3)]
    >>> rec = DifferenceRecorder(3, 3)
    >>> reference, query = rec.watch_reference(frames), rec.watch_query(frames)
    >>> _ = [f for f in reference], [query[i] for i in range(3)]
    >>> d = rec.result(frames, frames)
    >>> d.values.shape, np.diag(d.values).tolist(), bool(np.all(d.values + np.eye(3) > 0))
    ((3, 3), [0.0, 0.0, 0.0], True)
    """

    def __init__(self, n_reference: int, n_query: int, *, limit: int = DIFFERENCE_SAMPLES) -> None:
        self.reference_index = sample_indices(n_reference, limit)
        self.query_index = sample_indices(n_query, limit)
        self._strides = (_stride(self.reference_index), _stride(self.query_index))
        self._matcher = SingleFrame()
        shape = (len(self.reference_index), *self._matcher.descriptor_shape)
        self._images: np.ndarray | None = np.zeros(shape, dtype=np.float32)
        self._have = np.zeros(len(self.reference_index), dtype=bool)
        self._values = np.zeros((len(self.query_index), len(self.reference_index)), np.float32)
        self._done = np.zeros(len(self.query_index), dtype=bool)
        self._reference: Sequence[np.ndarray] | None = None
        self.reference_seconds = 0.0
        """Host time spent reducing reference frames as they passed through
        :meth:`watch_reference` (inside a map build)."""

    def watch_reference(self, reference: Sequence[np.ndarray]) -> Sequence[np.ndarray]:
        """``reference`` as a sequence that reduces every sampled frame read from it."""
        self._reference = reference
        return _Watched(reference, self._timed_reference)

    def watch_query(self, query: Sequence[np.ndarray]) -> Sequence[np.ndarray]:
        """``query`` as a sequence that fills the row of every sampled frame read from it."""
        return _Watched(query, self.observe_query)

    def _timed_reference(self, i: int, frame: np.ndarray) -> None:
        t = time.perf_counter()
        self.observe_reference(i, frame)
        self.reference_seconds += time.perf_counter() - t

    def observe_reference(self, i: int, frame: np.ndarray) -> None:
        """Reduce reference frame ``i`` if it is sampled and not reduced yet."""
        col, rest = divmod(i, self._strides[0])
        if rest or col >= len(self._have) or self._have[col] or self._images is None:
            return
        self._images[col] = self._matcher.describe(frame)
        self._have[col] = True

    def observe_query(self, i: int, frame: np.ndarray) -> None:
        """Fill the row of query frame ``i`` if it is sampled and not done yet."""
        row, rest = divmod(i, self._strides[1])
        if rest or row >= len(self._done) or self._done[row]:
            return
        if self._images is not None:  # the first row: the reduced images become a map
            self._adopt_map(self._reference)
        self._values[row] = self._matcher.difference_column(frame)
        self._done[row] = True

    def _adopt_map(self, reference: Sequence[np.ndarray] | None) -> None:
        assert self._images is not None
        missing = np.flatnonzero(~self._have)
        if missing.size and reference is None:
            raise ValueError("the difference matrix needs the reference frames it sampled")
        for col in missing:  # frames the watched map build did not read
            self.observe_reference(
                int(self.reference_index[col]), reference[int(self.reference_index[col])]
            )
        m = self._matcher
        m.use_map(TopoMap(m.kind, self._images, params=m.params()))
        self._images = None

    def result(
        self, reference: Sequence[np.ndarray], query: Sequence[np.ndarray]
    ) -> DifferenceMatrix | None:
        """The matrix, reading the sampled frames that did not pass; ``None`` when either
        traversal is empty."""
        if not len(self.query_index) or not len(self.reference_index):
            return None
        if self._images is not None:
            self._adopt_map(reference)
        for row in np.flatnonzero(~self._done):
            i = int(self.query_index[row])
            self.observe_query(i, query[i])
        self._matcher = SingleFrame()  # the sampled reference images are no longer needed
        return DifferenceMatrix(self._values, self.query_index, self.reference_index)


def _stride(index: np.ndarray) -> int:
    return int(index[1] - index[0]) if len(index) > 1 else 1


def difference_matrix(
    reference: Sequence[np.ndarray],
    query: Sequence[np.ndarray],
    *,
    limit: int = DIFFERENCE_SAMPLES,
) -> DifferenceMatrix | None:
    """The difference matrix of two traversals of sensor frames, reading only the sampled
    frames (for results made without a run, e.g. from a predictions file).

    Parameters
    ----------
    reference, query : sequence of ndarray, shape (256, 256), uint8
        Sensor frames (lazy streams are read one sampled frame at a time).
    limit : int
        Most frames sampled from each traversal.

    Returns
    -------
    DifferenceMatrix or None
        ``None`` when either traversal is empty.
    """
    recorder = DifferenceRecorder(len(reference), len(query), limit=limit)
    return recorder.result(reference, query)
