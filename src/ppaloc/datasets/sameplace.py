"""Same-place groups of frames, and the closure of accepted sets over them.

A traversal often shows one place in several consecutive frames: a train standing at a
station, a car at a traffic light. Which frames those are is the dataset's to say, the
same for every method, so the ground truth is *closed* over them. Over a reference group:
when a query's accepted set holds any frame of the group, it holds the whole group
(:func:`close_over_groups`). Over a query group, where the ground truth is by frame index
and the query stood longer than the reference did: every frame of the group accepts what
any frame of it accepts (:func:`close_over_query_groups`), since one image cannot be at
two places. Two rules find the groups (docs/datasets.md, "Same-place
groups", has the measurements behind the figures):

- ``still-frames`` (:data:`STILL_FRAMES`), from the frames themselves (of the
  reference, and of the query where the truth is by index), for frame-synchronised sets
  without positions: each frame is reduced to a 16x16 thumbnail
  (Pillow's anti-aliased bilinear filter, aspect not kept, so the rule reads the same on a
  64x32 or a 960x540 frame), normalised to zero mean and unit deviation. A frame is *seen*
  when its thumbnail's mean grey is at least 40 and its deviation at least 8 grey levels
  (blank, near-black and flat frames show no place, and dark frames of a moving tunnel
  look alike); consecutive seen frames are one place when the mean absolute difference of
  their normalised thumbnails is at most 0.05 and every frame of the group stays within
  0.15 of the group's first frame (so a slow creep cannot chain frames into one "place").
- ``positions`` (:func:`position_groups`), where the dataset has reference positions in
  metres: consecutive frames within ``radius_m`` of the group's first frame. The query's
  own positions then say where it stood, so its groups are not needed.

Both read each frame once, keep two thumbnails (or positions) at a time and
return the groups as an ``(G, 2)`` array of ``[first, end)`` frame ranges.
"""

from __future__ import annotations

from collections.abc import Iterable, Iterator, Sequence
from dataclasses import asdict, dataclass
from typing import Any

import numpy as np
from PIL import Image

from ppaloc.datasets.groundtruth import MAX_GROUND_TRUTH_ITEMS, PackedSets
from ppaloc.errors import DataError

__all__ = [
    "STILL_FRAMES",
    "SamePlaceRule",
    "close_over_groups",
    "close_over_query_groups",
    "group_labels",
    "position_groups",
    "still_groups",
    "thumbnail",
    "thumbnails",
]


@dataclass(frozen=True)
class SamePlaceRule:
    """The ``still-frames`` rule's parameters (see the module docstring).

    Attributes
    ----------
    thumbnail : int
        Side of the square thumbnail each frame is reduced to, in pixels.
    min_mean : float
        A frame is seen only when its thumbnail's mean grey (0-255) is at least this.
    min_std : float
        ... and its thumbnail's standard deviation is at least this (grey levels).
    max_step : float
        Largest mean absolute difference between the normalised thumbnails of two
        consecutive frames of one group (in units of each thumbnail's deviation).
    max_span : float
        Largest such difference between any frame of a group and the group's first.
    """

    thumbnail: int = 16
    min_mean: float = 40.0
    min_std: float = 8.0
    max_step: float = 0.05
    max_span: float = 0.15
    name: str = "still-frames"

    def to_dict(self) -> dict[str, Any]:
        """The rule as a JSON-able dict (its name and every parameter)."""
        out = asdict(self)
        name = out.pop("name")
        return {"rule": name, "params": out}


STILL_FRAMES = SamePlaceRule()
"""The documented rule every frame-synchronised dataset without positions uses."""


def thumbnail(
    frame: np.ndarray,
    side: int = STILL_FRAMES.thumbnail,
    extent: tuple[float, float] | None = None,
) -> np.ndarray:
    """A grey frame reduced to a ``(side, side)`` ``float32`` thumbnail.

    Pillow's bilinear filter in floating point (mode ``F``, no rounding), which widens its
    support when shrinking, so every output pixel averages its whole share of the frame;
    the aspect ratio is not kept. ``extent=(w, h)`` resamples only the frame's top-left
    ``w x h`` pixels (fractional: a reduced JPEG's partial last block,
    :func:`~ppaloc.datasets.images.read_grey_reduced`).

    Examples
    --------
    >>> t = thumbnail(np.tile(np.arange(64, dtype=np.uint8), (32, 1)), 4)
    >>> t.shape, t.dtype, [round(float(v), 1) for v in t[0]]
    ((4, 4), dtype('float32'), [9.0, 23.5, 39.5, 54.0])
    """
    a = np.asarray(frame)
    if a.ndim != 2 or a.size == 0:
        raise ValueError(f"a thumbnail needs a non-empty 2-D grey frame, got shape {a.shape}")
    image = Image.fromarray(a.astype(np.float32), mode="F")
    box = None if extent is None else (0.0, 0.0, float(extent[0]), float(extent[1]))
    out = image.resize((side, side), Image.Resampling.BILINEAR, box=box)
    return np.asarray(out, dtype=np.float32)


def thumbnails(
    frames: Sequence[np.ndarray], side: int = STILL_FRAMES.thumbnail
) -> Iterator[np.ndarray]:
    """Yield the thumbnail of every frame of a traversal, in order, one frame read at a time.

    Frames read from JPEG files are decoded at a reduced scale (at least ``4 * side``
    pixels a side, :func:`~ppaloc.datasets.images.read_grey_reduced`), several times
    faster than a full decode; on Gardens Point's 960x540 frames the thumbnails differ
    from a full decode's by 0.12 grey levels on average (3.6 at most).
    """
    from ppaloc.datasets.frames import ImageFrames
    from ppaloc.datasets.images import read_grey_reduced

    if isinstance(frames, ImageFrames):
        for i in range(len(frames)):
            grey, extent = read_grey_reduced(frames.path(i), 4 * side)
            yield thumbnail(grey, side, extent)
        return
    for frame in frames:
        yield thumbnail(frame, side)


def still_groups(thumbs: Iterable[np.ndarray], rule: SamePlaceRule = STILL_FRAMES) -> np.ndarray:
    """The ``still-frames`` groups of a traversal, from its frames' thumbnails.

    Parameters
    ----------
    thumbs : iterable of ndarray
        One thumbnail per frame, in order (:func:`thumbnails`); consumed once, two kept.
    rule : SamePlaceRule

    Returns
    -------
    ndarray of int64, shape (G, 2)
        ``[first, end)`` of each group of at least two consecutive frames.

    Examples
    --------
    >>> rng = np.random.default_rng(0)
    >>> a, b = rng.uniform(0, 255, (2, 16, 16))
    >>> dark = np.full((16, 16), 5.0)
    >>> still_groups([a, a + 1, a, b, dark, dark, b, b]).tolist()
    [[0, 3], [6, 8]]
    """
    groups: list[tuple[int, int]] = []
    start = -1  # first frame of the current candidate group; -1: none
    anchor = previous = None
    n = 0
    for i, t in enumerate(thumbs):
        n = i + 1
        z = _normalised(np.asarray(t, dtype=np.float64), rule)
        if (
            start >= 0
            and z is not None
            and float(np.abs(z - previous).mean()) <= rule.max_step
            and float(np.abs(z - anchor).mean()) <= rule.max_span
        ):
            previous = z
            continue
        if start >= 0 and i - start >= 2:
            groups.append((start, i))
        start, anchor, previous = (i, z, z) if z is not None else (-1, None, None)
    if start >= 0 and n - start >= 2:
        groups.append((start, n))
    return np.asarray(groups, dtype=np.int64).reshape(-1, 2)


def _normalised(t: np.ndarray, rule: SamePlaceRule) -> np.ndarray | None:
    """The thumbnail at zero mean and unit deviation, or None when it shows no place."""
    mean, std = float(t.mean()), float(t.std())
    if mean < rule.min_mean or std < rule.min_std:
        return None
    return (t - mean) / std


def position_groups(positions: np.ndarray, radius_m: float) -> np.ndarray:
    """Groups of consecutive reference frames within ``radius_m`` of the group's first.

    Parameters
    ----------
    positions : ndarray of float, shape (N, D)
        Reference positions in metres.
    radius_m : float
        Largest distance of a group's frame from the group's first frame, in metres.

    Returns
    -------
    ndarray of int64, shape (G, 2)
        ``[first, end)`` of each group of at least two frames.

    Examples
    --------
    >>> p = np.array([[0, 0], [0.3, 0], [0.2, 0.1], [5, 0], [9, 0], [9, 0.5]], float)
    >>> position_groups(p, 1.0).tolist()
    [[0, 3], [4, 6]]
    """
    p = np.asarray(positions, dtype=np.float64)
    p = p[:, None] if p.ndim == 1 else p
    groups: list[tuple[int, int]] = []
    start = 0
    for i in range(1, len(p) + 1):
        if i < len(p) and float(np.linalg.norm(p[i] - p[start])) <= radius_m:
            continue
        if i - start >= 2:
            groups.append((start, i))
        start = i
    return np.asarray(groups, dtype=np.int64).reshape(-1, 2)


def group_labels(groups: np.ndarray, n: int) -> np.ndarray:
    """Group number of each of ``n`` frames (-1: in no group).

    Examples
    --------
    >>> group_labels(np.array([[1, 3], [4, 6]]), 7).tolist()
    [-1, 0, 0, -1, 1, 1, -1]
    """
    groups = np.asarray(groups, dtype=np.int64).reshape(-1, 2)
    labels = np.full(n, -1, dtype=np.int64)
    lengths = groups[:, 1] - groups[:, 0]
    if lengths.size:
        frames = np.repeat(groups[:, 0], lengths) + _ramp(lengths)
        labels[frames] = np.repeat(np.arange(len(groups)), lengths)
    return labels


def _ramp(lengths: np.ndarray) -> np.ndarray:
    """``0 .. L-1`` for every length ``L``, concatenated."""
    starts = np.cumsum(lengths) - lengths
    return np.arange(int(lengths.sum()), dtype=np.int64) - np.repeat(starts, lengths)


def close_over_groups(sets: Sequence[np.ndarray], groups: np.ndarray, n_ref: int) -> PackedSets:
    """Each accepted set widened to the whole of every group it touches.

    A soft set carried by ``sets`` (:attr:`PackedSets.soft`) is closed the same way.

    Parameters
    ----------
    sets : sequence of array_like of int
        Accepted reference indices per query.
    groups : ndarray of int, shape (G, 2)
        ``[first, end)`` of each same-place group of reference frames.
    n_ref : int
        Number of reference frames.

    Returns
    -------
    PackedSets

    Raises
    ------
    DataError
        When the closed sets would hold more than
        :data:`~ppaloc.datasets.groundtruth.MAX_GROUND_TRUTH_ITEMS` (query, reference)
        pairs in all (a camera standing still for most of a long route).

    Examples
    --------
    >>> g = close_over_groups([[0], [3], [], [5, 6]], np.array([[2, 5]]), 7)
    >>> [r.tolist() for r in g]
    [[0], [2, 3, 4], [], [5, 6]]
    """
    packed = PackedSets.from_sets(sets)
    groups = np.asarray(groups, dtype=np.int64).reshape(-1, 2)
    soft = None if packed.soft is None else close_over_groups(packed.soft, groups, n_ref)
    if not len(groups) or not packed.indices.size:
        return packed.with_soft(soft) if soft is not None else packed
    labels = group_labels(groups, n_ref)
    rows = np.repeat(np.arange(len(packed), dtype=np.int64), packed.lengths)
    touched = labels[packed.indices]
    hit = touched >= 0
    pairs = np.unique(rows[hit] * len(groups) + touched[hit])  # (query, group), once each
    q, g = pairs // len(groups), pairs % len(groups)
    lengths = groups[g, 1] - groups[g, 0]
    total = int(lengths.sum()) + packed.indices.size
    if total > MAX_GROUND_TRUTH_ITEMS:
        longest = int((groups[:, 1] - groups[:, 0]).max())
        raise DataError(
            f"closing the accepted sets over the reference's same-place groups (the longest "
            f"{longest} frames) would accept up to {total} (query, reference) pairs, more than "
            f"{MAX_GROUND_TRUTH_ITEMS}; a reference that stands still this long is better cut "
            "(start=, stop=) or left unclosed (same_place=off)"
        )
    add_rows = np.repeat(q, lengths)
    add_refs = np.repeat(groups[g, 0], lengths) + _ramp(lengths)
    keys = np.unique(np.concatenate([rows * n_ref + packed.indices, add_rows * n_ref + add_refs]))
    out_rows, out_refs = keys // n_ref, keys % n_ref
    indptr = np.zeros(len(packed) + 1, dtype=np.int64)
    np.cumsum(np.bincount(out_rows, minlength=len(packed)), out=indptr[1:])
    closed = PackedSets(out_refs, indptr)
    return closed.with_soft(soft) if soft is not None else closed


def close_over_query_groups(sets: PackedSets, groups: np.ndarray) -> PackedSets:
    """Every query frame of a group accepting the union of the group's accepted sets.

    A soft set carried by ``sets`` is closed the same way. Run after
    :func:`close_over_groups`, the result stays closed over the reference's groups (a union
    of closed sets is closed).

    Parameters
    ----------
    sets : PackedSets
        Accepted reference indices per query.
    groups : ndarray of int, shape (G, 2)
        ``[first, end)`` of each same-place group of query frames, sorted and disjoint
        (as :func:`still_groups` returns them).

    Returns
    -------
    PackedSets

    Raises
    ------
    DataError
        When the closed sets would hold more than
        :data:`~ppaloc.datasets.groundtruth.MAX_GROUND_TRUTH_ITEMS` pairs in all.

    Examples
    --------
    >>> g = close_over_query_groups(PackedSets.from_sets([[0], [3], [4], [], [6]]),
    ...                             np.array([[1, 4]]))
    >>> [r.tolist() for r in g]
    [[0], [3, 4], [3, 4], [3, 4], [6]]
    """
    groups = np.asarray(groups, dtype=np.int64).reshape(-1, 2)
    soft = None if sets.soft is None else close_over_query_groups(sets.soft, groups)
    if not len(groups):
        return sets
    indices, indptr = sets.indices, sets.indptr
    lengths = sets.lengths.copy()
    unions = [np.unique(indices[indptr[first] : indptr[end]]) for first, end in groups]
    for (first, end), union in zip(groups, unions, strict=True):
        lengths[first:end] = union.size
    total = int(lengths.sum())
    if total > MAX_GROUND_TRUTH_ITEMS:  # checked before anything that large is built
        raise DataError(
            f"closing the accepted sets over the query's same-place groups would accept "
            f"{total} (query, reference) pairs, more than {MAX_GROUND_TRUTH_ITEMS}; a query "
            "that stands still this long is better cut (start=, stop=) or left unclosed "
            "(same_place=off)"
        )
    pieces, done = [], 0
    for (first, end), union in zip(groups, unions, strict=True):
        pieces += [indices[indptr[done] : indptr[first]], np.tile(union, end - first)]
        done = end
    pieces.append(indices[indptr[done] :])
    out_ptr = np.zeros(len(sets) + 1, dtype=np.int64)
    np.cumsum(lengths, out=out_ptr[1:])
    closed = PackedSets(np.concatenate(pieces), out_ptr)
    return closed.with_soft(soft) if soft is not None else closed
