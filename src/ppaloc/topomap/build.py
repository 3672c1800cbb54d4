"""Mapping: turn a reference traversal into a TopoMap."""

from __future__ import annotations

from collections.abc import Callable, Iterable
from functools import partial
from typing import Any

import numpy as np

from ppaloc.frontend import to_sensor
from ppaloc.place import (
    LOWRES_GRIDS,
    haar_descriptor,
    hamming,
    hamming_words,
    lbp_descriptor,
    lowres_image,
    mean_abs_diff,
    patch_image,
    sad,
)
from ppaloc.topomap.map import KIND_SPECS, TopoMap

__all__ = ["KEYFRAME_UNITS", "build_topomap", "describe"]

KEYFRAME_UNITS = {
    "lowres": "mean absolute difference per 8x8 cell, grey levels (SAD / 64)",
    "lowres16": "mean absolute difference per 16x16 cell, grey levels (SAD / 256)",
    "lbp": "Hamming distance, bits",
    "haar": "Hamming distance, bits",
    "patch": "mean absolute difference per pixel of the patch-normalised image, deviations",
}
"""What ``keyframe_threshold`` measures for each kind."""

_DESCRIBE: dict[str, Callable[[np.ndarray], np.ndarray]] = {
    **{kind: partial(lowres_image, grid=g) for kind, g in LOWRES_GRIDS.items()},
    "lbp": lbp_descriptor,
    "haar": haar_descriptor,
    "patch": patch_image,
}


def describe(frame: np.ndarray, kind: str) -> np.ndarray:
    """Return the node descriptor of one frame: uint8 (8, 8) or (16, 16), a uint32
    scalar array (LBP), 8 uint32 words (Haar signs) or the float32 (32, 64)
    patch-normalised image.

    Any frame is first shown to the sensor (:func:`ppaloc.frontend.to_sensor`,
    the identity for a (256, 256) uint8 frame).
    """
    return _describer(kind)(to_sensor(frame))


def _describer(kind: str) -> Callable[[np.ndarray], np.ndarray]:
    if kind not in _DESCRIBE:
        raise ValueError(f"kind={kind!r} has no place representation; use {', '.join(_DESCRIBE)}")
    return _DESCRIBE[kind]


def _change(kind: str, descriptor: np.ndarray, last: np.ndarray) -> float:
    if kind in LOWRES_GRIDS:
        return float(sad(descriptor, last[None])[0]) / descriptor.size
    if kind == "haar":
        return float(hamming_words(descriptor, last[None])[0])
    if kind == "patch":
        return float(mean_abs_diff(descriptor, last[None])[0])
    return float(hamming(descriptor, last.reshape(1))[0])


class _Rows:
    """Rows appended one at a time into one preallocated array (``capacity`` rows, doubled
    when full): a long traversal leaves no per-frame object behind, only the array."""

    def __init__(self, dtype: np.dtype, shape: tuple[int, ...], capacity: int | None) -> None:
        self._a = np.empty((max(int(capacity or 0), 1), *shape), dtype)
        self._n = 0

    def __len__(self) -> int:
        return self._n

    def append(self, row: Any) -> None:
        if self._n == len(self._a):
            self._a = np.concatenate((self._a, np.empty_like(self._a)))
        self._a[self._n] = row
        self._n += 1

    def last(self) -> np.ndarray:
        return self._a[self._n - 1]

    def array(self) -> np.ndarray:
        """The rows so far (a trimmed copy when fewer than the capacity)."""
        return self._a if self._n == len(self._a) else self._a[: self._n].copy()


def build_topomap(
    frames: Iterable[np.ndarray],
    kind: str,
    *,
    keyframe_threshold: float | None = None,
    keep: Callable[[np.ndarray], bool] | None = None,
    new_place: Callable[[np.ndarray], bool] | None = None,
    positions: np.ndarray | None = None,
    dataset: str | None = None,
    progress: Callable[[int, int | None], None] | None = None,
) -> TopoMap:
    """Build a map from a reference traversal, one node per frame or per keyframe.

    Parameters
    ----------
    frames : iterable of ndarray
        The reference traversal in route order; (256, 256) uint8 sensor frames, or any
        frame :func:`~ppaloc.frontend.to_sensor` accepts. Read once, in order,
        so a lazy sequence is never held in memory whole.
    kind : {"lowres", "lowres16", "lbp", "haar", "patch"}
        The place representation (:mod:`ppaloc.place`).
    keyframe_threshold : float, optional
        None (default, the paper): every frame becomes a node. Otherwise the first frame
        becomes a node, and each later frame becomes a node only when its change from the
        *last node* (not the last frame, so slow drift accumulates) is strictly above the
        threshold: for ``"lowres"`` the mean absolute difference per cell in grey levels
        (SAD / 64; ``"lowres16"`` SAD / 256), for ``"lbp"`` and ``"haar"`` the Hamming
        distance in bits, for ``"patch"`` the mean absolute difference per pixel in
        deviations.
        0 drops only exact repeats (e.g. a vehicle standing still in a static scene).
    keep : callable, optional
        Another keyframe rule: ``keep(sensor_frame)`` is called on every frame in order
        and a frame after the first becomes a node only when it returns True (the
        weighted-node filter passes its motion test: a new node when the camera moved
        on). Cannot be combined with ``keyframe_threshold``.
    new_place : callable, optional
        With one node per frame: ``new_place(sensor_frame)`` is called on every frame in
        order, and a frame after the first shows the previous frame's place when it
        returns False; the map records the places (``TopoMap.places``: a stop of the
        reference is a run of nodes of one place). Cannot be combined with a keyframe
        rule.
    positions : ndarray, shape (n_frames, D) or (n_frames,), optional
        Per-frame route positions; the nodes keep those of their frames.
    dataset : str, optional
        Name of the source traversal, kept in ``provenance["dataset"]``.
    progress : callable, optional
        Called after each frame as ``progress(frames_done, total)``; ``total`` is
        ``len(frames)`` where it exists, else None.

    Returns
    -------
    TopoMap
        ``frame_index`` holds each node's source frame; ``params`` holds ``kind``,
        ``keyframe_threshold``, ``keyframe_units``, ``keyframes`` and ``n_frames``.

    Examples
    --------
    >>> import numpy as np
    >>> frames = [np.full((256, 256), v, np.uint8) for v in (10, 10, 12, 40)]
    >>> build_topomap(frames, "lowres").frame_index.tolist()
    [0, 1, 2, 3]
    >>> build_topomap(frames, "lowres", keyframe_threshold=5).frame_index.tolist()
    [0, 3]
    """
    describe_sensor = _describer(kind)
    if keyframe_threshold is not None and not keyframe_threshold >= 0:
        raise ValueError(f"keyframe_threshold={keyframe_threshold!r} must be >= 0 or None")
    if keyframe_threshold is not None and keep is not None:
        raise ValueError("give keyframe_threshold or keep, not both")
    if new_place is not None and (keep is not None or keyframe_threshold is not None):
        raise ValueError("new_place records the places of a map of every frame: no keyframe rule")
    total = len(frames) if hasattr(frames, "__len__") else None  # type: ignore[arg-type]
    dtype, shape = KIND_SPECS[kind]
    descriptors = _Rows(dtype, shape, total)
    kept = _Rows(np.dtype(np.int64), (), total)
    places = None if new_place is None else _Rows(np.dtype(np.int64), (), total)
    n_frames = 0
    for i, frame in enumerate(frames):
        sensor = to_sensor(frame)
        d = describe_sensor(sensor)
        moved_on = True if keep is None else bool(keep(sensor))
        if places is not None:
            new = bool(new_place(sensor))  # type: ignore[misc]
            places.append(0 if not len(places) else places.last() + int(new))
        if not len(descriptors) or (
            moved_on
            if keyframe_threshold is None
            else _change(kind, d, descriptors.last()) > keyframe_threshold
        ):
            descriptors.append(d)
            kept.append(i)
        n_frames = i + 1
        if progress is not None:
            progress(n_frames, total)
    stacked, kept_index = descriptors.array(), kept.array()
    node_positions = None
    if positions is not None:
        pos = np.asarray(positions, dtype=np.float64)
        if len(pos) != n_frames:
            raise ValueError(f"positions has {len(pos)} rows for {n_frames} frames")
        node_positions = pos[kept_index]
    params: dict[str, Any] = {
        "kind": kind,
        "keyframe_threshold": keyframe_threshold,
        "keyframes": "motion test" if keep is not None else None,
        "keyframe_units": None if keyframe_threshold is None else KEYFRAME_UNITS[kind],
        "n_frames": n_frames,
    }
    if new_place is not None:
        params["places"] = "motion test"
    provenance = {} if dataset is None else {"dataset": dataset}
    return TopoMap(
        kind,
        stacked,
        frame_index=kept_index,
        positions=node_positions,
        places=None if places is None else places.array(),
        params=params,
        provenance=provenance,
    )
