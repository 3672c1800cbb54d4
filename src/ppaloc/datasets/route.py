"""From what a loader found to a :class:`RouteDataset`: selection and tolerance.

Every loader returns a :class:`RawRoute` (full traversals and the ground truth *before*
tolerance); :func:`assemble` then applies the common spec keys ``start``, ``stop``,
``step`` and ``tolerance`` in one place, so they mean the same for every kind:

- Positional ground truth (frame-synchronised layouts, the generator): ``start``/``stop``
  select reference frames (places) ``start <= i < stop`` and the query frames whose true
  position is nearest to one of them; ``step`` then keeps every step-th of each. Tolerance
  counts kept reference frames.
- Explicit ground truth (VPR-Bench, City Centre): the same slice is applied to each
  traversal by index; accepted references are remapped to the kept ones, then dilated by
  the tolerance.
- ``patch_norm=P``: every frame of both traversals is patch-normalised in PxP tiles when
  it is read (:func:`ppaloc.datasets.normalise.patch_normalise_frame`).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from ppaloc.datasets.base import RouteDataset
from ppaloc.datasets.frames import FrameSequence
from ppaloc.datasets.groundtruth import dilate, from_positions
from ppaloc.datasets.normalise import PatchNormalise
from ppaloc.errors import DataError

__all__ = ["RawRoute", "assemble"]


@dataclass
class RawRoute:
    """A loader's result before the common keys are applied.

    Exactly one of ``query_place`` and ``accepted`` is set.

    Attributes
    ----------
    query_place : ndarray of float, shape (M,), optional
        True position of each query in reference-frame units (non-finite: off the map).
    accepted : list of ndarray, optional
        Explicit accepted reference indices per query (before tolerance).
    motion_known : bool
        Whether ``query_place`` is exact enough to derive ``query_moved``.
    """

    name: str
    reference: FrameSequence
    query: FrameSequence
    default_tolerance: int
    query_place: np.ndarray | None = None
    accepted: Sequence[np.ndarray] | None = None
    reference_positions: np.ndarray | None = None
    query_positions: np.ndarray | None = None
    motion_known: bool = False
    meta: dict = field(default_factory=dict)


def moved_from_places(places: np.ndarray) -> np.ndarray:
    """``moved[i]``: the nearest place of frame ``i`` is ahead of that of frame ``i-1``.

    The first frame has no predecessor and is marked ``False``.

    Examples
    --------
    >>> moved_from_places(np.array([0.0, 0.4, 0.6, 0.6, 2.0])).tolist()
    [False, False, True, False, True]
    """
    nearest = np.floor(np.asarray(places, np.float64) + 0.5)
    moved = np.zeros(nearest.shape, bool)
    moved[1:] = nearest[1:] > nearest[:-1]
    return moved


def assemble(raw: RawRoute, options: Mapping[str, Any]) -> RouteDataset:
    """Apply ``start``/``stop``/``step``/``tolerance``/``patch_norm`` and build the
    :class:`RouteDataset`."""
    tol = options.get("tolerance")
    tol = raw.default_tolerance if tol is None else int(tol)
    start, stop, step = options.get("start"), options.get("stop"), int(options.get("step") or 1)
    n_ref = len(raw.reference)
    ref_idx = np.arange(n_ref)[slice(start, stop, step)]
    if ref_idx.size == 0:
        raise DataError(
            f"start={start} stop={stop} keeps none of the {n_ref} reference frames; "
            f"choose start below {n_ref}"
        )
    meta = dict(raw.meta)
    if raw.query_place is not None:
        place = np.asarray(raw.query_place, np.float64)
        nearest = np.floor(place + 0.5)
        keep = np.ones(place.shape, bool)
        finite = np.isfinite(place)
        if start is not None:
            keep &= finite & (nearest >= start)
        if stop is not None:
            keep &= finite & (nearest < stop)
        q_idx = np.flatnonzero(keep)[::step]
        new_place = (place[q_idx] - (start or 0)) / step
        truth = from_positions(new_place, ref_idx.size, tol)
        moved = moved_from_places(new_place) if raw.motion_known else None
    else:
        assert raw.accepted is not None, "a RawRoute needs query_place or accepted"
        q_idx = np.arange(len(raw.query))[slice(start, stop, step)]
        new_of_old = np.full(n_ref, -1, np.int64)
        new_of_old[ref_idx] = np.arange(ref_idx.size)
        kept = []
        for q in q_idx:
            a = new_of_old[np.asarray(raw.accepted[q], np.int64)]
            kept.append(a[a >= 0])
        truth = dilate(kept, ref_idx.size, tol)
        moved = None
        new_place = None
    if q_idx.size == 0:
        raise DataError(
            f"start={start} stop={stop} keeps none of the {len(raw.query)} query frames; "
            "widen the selection"
        )
    if start is not None or stop is not None or step != 1:
        meta["selection"] = {"start": start, "stop": stop, "step": step}
    if new_place is not None:
        meta["query_place"] = new_place
    for key, idx in (("query_turning", q_idx), ("reference_turning", ref_idx)):
        if key in meta:  # per-frame flags follow the selection
            meta[key] = np.asarray(meta[key], bool)[idx]
    reference, query = raw.reference.select(ref_idx), raw.query.select(q_idx)
    patch = options.get("patch_norm")
    if patch is not None:
        transform = PatchNormalise(int(patch))
        reference, query = reference.transformed(transform), query.transformed(transform)
        meta["patch_norm"] = int(patch)
    return RouteDataset(
        name=raw.name,
        reference=reference,
        query=query,
        ground_truth=truth,
        tolerance=tol,
        reference_positions=_take(raw.reference_positions, ref_idx),
        query_positions=_take(raw.query_positions, q_idx),
        query_moved=moved,
        meta=meta,
    )


def _take(a: np.ndarray | None, idx: np.ndarray) -> np.ndarray | None:
    return None if a is None else np.asarray(a)[idx]
