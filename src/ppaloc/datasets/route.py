"""From what a loader found to a :class:`RouteDataset`: selection, tolerance, same place.

Every loader returns a :class:`RawRoute` (full traversals and the ground truth *before*
tolerance); :func:`assemble` then applies the common spec keys ``start``, ``stop``,
``step``, ``tolerance``, ``soft_tolerance`` and ``same_place`` in one place, so they mean
the same for every kind:

- Positional ground truth (frame-synchronised layouts, the generator): ``start``/``stop``
  select reference frames (places) ``start <= i < stop`` and the query frames whose true
  position is nearest to one of them; ``step`` then keeps every step-th of each. Tolerance
  counts kept reference frames.
- Explicit ground truth (VPR-Bench, City Centre, a matrix): the same slice is applied to
  each traversal by index; accepted references are remapped to the kept ones, then
  dilated by the tolerance.
- Ground truth in metres (positions files): the same slice by index; each kept query
  accepts the kept references within ``tolerance_m`` metres.
- ``soft_tolerance`` (``soft_tolerance_m``, a soft matrix): the soft sets, built the same
  way, each holding its hard set.
- ``same_place``: the accepted sets (hard and soft) are closed over the reference's
  same-place groups (:mod:`ppaloc.datasets.sameplace`), found on the kept reference frames
  as read from the files (before ``patch_norm``).
- ``patch_norm=P``: every frame of both traversals is patch-normalised in PxP tiles when
  it is read (:func:`ppaloc.datasets.normalise.patch_normalise_frame`).

``meta["ground_truth_rule"]`` records all of it (:func:`assemble`).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from ppaloc.datasets.base import RouteDataset
from ppaloc.datasets.frames import FrameSequence
from ppaloc.datasets.groundtruth import PackedSets, dilate, from_positions
from ppaloc.datasets.normalise import PatchNormalise
from ppaloc.datasets.positions import from_metres
from ppaloc.datasets.sameplace import (
    STILL_FRAMES,
    close_over_groups,
    close_over_query_groups,
    position_groups,
    still_groups,
    thumbnails,
)
from ppaloc.errors import DataError

__all__ = ["SAME_PLACE_M", "RawRoute", "assemble"]

SAME_PLACE_M = 1.0
"""Default radius of a same-place group found from positions, in metres."""


@dataclass
class RawRoute:
    """A loader's result before the common keys are applied.

    Exactly one of ``query_place``, ``accepted`` and ``metres`` gives the ground truth.

    Attributes
    ----------
    query_place : ndarray of float, shape (M,), optional
        True position of each query in reference-frame units (non-finite: off the map).
    accepted : list of ndarray, optional
        Explicit accepted reference indices per query (before tolerance).
    accepted_soft : list of ndarray, optional
        Explicit soft sets per query (a soft matrix), with ``accepted``.
    metres : bool
        The ground truth is every reference within ``tolerance_m`` metres of each query,
        from ``reference_positions`` and ``query_positions`` (metres).
    reference_positions, query_positions : ndarray of float, shape (N, D), (M, D), optional
        Positions in metres, where known.
    motion_known : bool
        Whether ``query_place`` is exact enough to derive ``query_moved``.
    truth : dict
        What the loader says of its ground truth for ``meta["ground_truth_rule"]``: at
        least ``source`` (e.g. ``"index"``, ``"file name"``), and ``files`` it read.
    same_place : str, optional
        What ``same_place=auto`` means here: ``"images"``, ``"positions"``, ``"none"``
        (the loader knows the reference never stands; ``truth["same_place_reason"]``
        says why) or ``"off"``. Default: ``"images"`` for positional ground truth,
        ``"positions"`` for metres, ``"off"`` for explicit sets (a file's word).
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
    accepted_soft: Sequence[np.ndarray] | None = None
    metres: bool = False
    truth: dict = field(default_factory=dict)
    same_place: str | None = None

    @property
    def kind(self) -> str:
        """``"frames"``, ``"metres"``, ``"matrix"`` or ``"sets"``: what the truth is."""
        if self.metres:
            return "metres"
        if self.query_place is not None:
            return "frames"
        return "matrix" if self.truth.get("matrix") else "sets"


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
    """Apply ``start``/``stop``/``step``, the tolerances, ``same_place`` and
    ``patch_norm``, and build the :class:`RouteDataset`.

    ``meta["ground_truth_rule"]`` (JSON-able, the same for the same dataset) records:
    ``kind`` (``frames``, ``metres``, ``matrix`` or ``sets``), ``source`` and the files read
    (name and SHA-256), ``tolerance`` and ``tolerance_unit``, the soft tolerance or file
    where there is one, and ``same_place``: the rule's name and parameters, how many groups
    and grouped reference frames it found, and how many queries' accepted sets the closure
    changed.
    """
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
    soft_tol = options.get("soft_tolerance")
    if soft_tol is not None and soft_tol < tol:
        raise DataError(
            f"soft_tolerance={soft_tol} is below tolerance={tol}; a soft set holds its hard "
            "set and more: give soft_tolerance >= tolerance"
        )
    rule: dict[str, Any] = {"kind": raw.kind, **_without(raw.truth, "matrix")}
    sel = (start, stop, step)
    if raw.metres:
        built = _metres_truth(raw, options, ref_idx, sel)
        tol = 0
    elif raw.query_place is not None:
        built = _positional_truth(raw, ref_idx, sel, tol, soft_tol)
    else:
        built = _explicit_truth(raw, ref_idx, sel, tol, soft_tol)
    truth, soft, q_idx, new_place, units = built
    rule.update(units)
    moved = moved_from_places(new_place) if new_place is not None and raw.motion_known else None
    if q_idx.size == 0:
        raise DataError(
            f"start={start} stop={stop} keeps none of the {len(raw.query)} query frames; "
            "widen the selection"
        )
    if soft is not None:
        truth = truth.with_soft(soft)
    truth, groups, query_groups, rule["same_place"] = _same_place(
        raw, options, truth, ref_idx, q_idx
    )
    meta["ground_truth_rule"] = rule
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
        reference_groups=groups,
        query_groups=query_groups,
        tolerance_m=rule["tolerance"] if raw.metres else None,
    )


_Built = tuple[PackedSets, PackedSets | None, np.ndarray, np.ndarray | None, dict[str, Any]]
"""(hard sets, soft sets, kept queries, their places in kept-reference units where the
truth is positional, the tolerance entries of ``ground_truth_rule``)."""


def _metres_truth(
    raw: RawRoute, options: Mapping[str, Any], ref_idx: np.ndarray, sel: tuple
) -> _Built:
    """Every kept reference within ``tolerance_m`` of each kept query (the same slice of
    both traversals by index)."""
    tol_m = float(options["tolerance_m"])
    soft_m = options.get("soft_tolerance_m")
    q_idx = np.arange(len(raw.query))[slice(*sel)]
    ref_m = np.asarray(raw.reference_positions)[ref_idx]
    qry_m = np.asarray(raw.query_positions)[q_idx]
    truth = from_metres(ref_m, qry_m, tol_m)
    units: dict[str, Any] = {"tolerance": tol_m, "tolerance_unit": "metres"}
    soft = None
    if soft_m is not None:
        soft = from_metres(ref_m, qry_m, float(soft_m), "soft_tolerance_m")
        units["soft_tolerance"] = float(soft_m)
    return truth, soft, q_idx, None, units


def _positional_truth(
    raw: RawRoute, ref_idx: np.ndarray, sel: tuple, tol: int, soft_tol: int | None
) -> _Built:
    """The kept places and the queries nearest to one of them, ``tol`` frames either side."""
    start, stop, step = sel
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
    units: dict[str, Any] = {"tolerance": tol, "tolerance_unit": "frames"}
    soft = None
    if soft_tol is not None:
        soft = from_positions(new_place, ref_idx.size, int(soft_tol))
        units["soft_tolerance"] = int(soft_tol)
    return truth, soft, q_idx, new_place, units


def _explicit_truth(
    raw: RawRoute, ref_idx: np.ndarray, sel: tuple, tol: int, soft_tol: int | None
) -> _Built:
    """The loader's sets, sliced by index, remapped to the kept references and dilated."""
    assert raw.accepted is not None, "a RawRoute needs query_place, accepted or metres"
    q_idx = np.arange(len(raw.query))[slice(*sel)]
    new_of_old = np.full(len(raw.reference), -1, np.int64)
    new_of_old[ref_idx] = np.arange(ref_idx.size)
    truth = dilate(_remap(raw.accepted, q_idx, new_of_old), ref_idx.size, tol)
    units: dict[str, Any] = {"tolerance": tol, "tolerance_unit": "frames"}
    soft = None
    if raw.accepted_soft is not None:
        soft = dilate(_remap(raw.accepted_soft, q_idx, new_of_old), ref_idx.size, tol)
    elif soft_tol is not None:
        soft = dilate(_remap(raw.accepted, q_idx, new_of_old), ref_idx.size, int(soft_tol))
        units["soft_tolerance"] = int(soft_tol)
    return truth, soft, q_idx, None, units


def _without(d: Mapping[str, Any], *keys: str) -> dict[str, Any]:
    return {k: v for k, v in d.items() if k not in keys}


def _remap(
    sets: Sequence[np.ndarray], q_idx: np.ndarray, new_of_old: np.ndarray
) -> list[np.ndarray]:
    """The kept queries' sets in kept-reference numbering (dropped references removed)."""
    out = []
    for q in q_idx:
        a = new_of_old[np.asarray(sets[q], np.int64)]
        out.append(a[a >= 0])
    return out


def _same_place(
    raw: RawRoute,
    options: Mapping[str, Any],
    truth: PackedSets,
    ref_idx: np.ndarray,
    q_idx: np.ndarray,
) -> tuple[PackedSets, np.ndarray | None, np.ndarray | None, dict[str, Any]]:
    """The truth closed over the kept frames' same-place groups, the reference's and the
    query's groups, and the rule's entry of ``ground_truth_rule``.

    The ``still-frames`` rule reads both traversals: the reference's groups widen every
    set that touches them, and the query's make each frame of a group accept what any
    frame of it accepts (``same_place=reference-images`` reads the reference only, the
    rule before the query's stops were read). The ``positions`` rule groups the
    reference only: the query's positions already say where it stood.
    """
    asked = options.get("same_place") or "auto"
    default = raw.same_place or {"frames": "images", "metres": "positions"}.get(raw.kind, "off")
    mode = default if asked == "auto" else asked
    if mode == "off":
        why = "same_place=off" if asked == "off" else "explicit ground truth: the file's word"
        return truth, None, None, {"rule": "off", "reason": why}
    if mode == "none":
        reason = raw.truth.get("same_place_reason", "")
        return truth, None, None, {"rule": "none", "reason": reason}
    query_groups = None
    if mode == "positions":
        if raw.reference_positions is None:
            raise DataError(
                "same_place=positions needs reference positions, which this dataset does not "
                "have: use same_place=images (or give ref_positions= and query_positions=)"
            )
        radius = options.get("same_place_m")
        radius = SAME_PLACE_M if radius is None else float(radius)
        groups = position_groups(np.asarray(raw.reference_positions)[ref_idx], radius)
        entry: dict[str, Any] = {"rule": "positions", "params": {"radius_m": radius}}
    else:
        groups = still_groups(thumbnails(raw.reference.select(ref_idx)), STILL_FRAMES)
        entry = STILL_FRAMES.to_dict()
        if mode == "reference-images":  # the rule before the query's stops were read
            entry["traversals"] = "reference"
        else:
            query_groups = still_groups(thumbnails(raw.query.select(q_idx)), STILL_FRAMES)
    closed = close_over_groups(truth, groups, ref_idx.size)
    entry.update(groups=len(groups), grouped_frames=_frames_in(groups))
    if query_groups is not None:
        closed = close_over_query_groups(closed, query_groups)
        entry.update(query_groups=len(query_groups), query_grouped_frames=_frames_in(query_groups))
    entry["queries_changed"] = int(np.count_nonzero(closed.lengths != truth.lengths))
    return closed, groups, query_groups, entry


def _frames_in(groups: np.ndarray) -> int:
    return int((groups[:, 1] - groups[:, 0]).sum())


def _take(a: np.ndarray | None, idx: np.ndarray) -> np.ndarray | None:
    return None if a is None else np.asarray(a)[idx]
