"""Local contrast enhancement of a column of distances along the map (SeqSLAM's step 3).

Each entry becomes a z-score among its neighbours along the map: a place that is a little
closer to the live frame than the places around it stands out, whatever the level of the
whole column. SeqSLAM and the particle filter enhance their difference columns so
(:mod:`ppaloc.baselines.seqslam`); the host's weighted-node filter may too (``enhance``,
docs/localise.md, "Local contrast of the distances"). One function serves all three.
:func:`closer_share` is the local contrast a PPA could compute, by comparisons alone (the
filter's ``local_gain``).
"""

from __future__ import annotations

import numpy as np

__all__ = [
    "ENHANCE_UNITS",
    "closer_count",
    "closer_share",
    "contrast_enhance",
    "count_closer",
    "place_neighbours",
]

ENHANCE_UNITS = 16
"""Register units per standard deviation of an enhanced distance (the weighted-node filter's
``enhance``): the per-frame scale then brings the column's spread to ``gain``, so this
fixes only where the power-of-two shift lands, as the grey levels of a raw distance do."""


def contrast_enhance(column: np.ndarray, window: int = 10) -> np.ndarray:
    """Local contrast enhancement of difference values along the map axis.

    Parameters
    ----------
    column : ndarray, shape (N,) or (N, Q)
        Difference values, map nodes along axis 0 (one column per query frame).
    window : int
        OpenSeqSLAM's ``contrastEnhancement.R``: entry ``i`` is normalised by the mean and
        standard deviation (Bessel-corrected) of entries ``i - window//2 .. i + window//2``
        (cut at the ends of the map). ``window=0`` switches the enhancement off.

    Returns
    -------
    ndarray of float64, same shape
        ``(d_i - mean) / std + (m - 1) / sqrt(m)`` with ``m = 2 * (window // 2) + 1`` the
        full window length. A z-score within a window of ``m`` values is never below
        ``-(m - 1) / sqrt(m)``, so the shift makes every value non-negative with a constant
        that is known before any frame arrives. Where the local deviation is 0 (or the
        window holds one entry) the z-score is 0. ``window=0`` returns ``d`` unchanged.

    Notes
    -----
    OpenSeqSLAM subtracts the minimum of the *whole* enhanced matrix, which needs every
    query frame. A constant shift leaves the ranking of trajectories of equal length
    unchanged, keeps the uniqueness ratio comparable from frame to frame, and (unlike a
    per-column minimum) does not give a one-frame trajectory a cost of exactly 0.
    """
    d = np.asarray(column, dtype=np.float64)
    squeeze = d.ndim == 1
    if squeeze:
        d = d[:, None]
    n = d.shape[0]
    if int(window) == 0:
        return d[:, 0].copy() if squeeze else d.copy()
    half = int(window) // 2
    zero = np.zeros((1, d.shape[1]))
    c1 = np.concatenate((zero, np.cumsum(d, axis=0)))
    c2 = np.concatenate((zero, np.cumsum(d * d, axis=0)))
    idx = np.arange(n)
    lo = np.maximum(idx - half, 0)
    hi = np.minimum(idx + half + 1, n)
    count = (hi - lo)[:, None].astype(np.float64)
    s1 = c1[hi] - c1[lo]
    s2 = c2[hi] - c2[lo]
    mean = s1 / count
    var = np.maximum(s2 - s1 * mean, 0.0) / np.maximum(count - 1.0, 1.0)
    std = np.sqrt(var)
    ok = (std > 1e-12 * np.maximum(np.abs(mean), 1.0)) & (count > 1)
    out = np.where(ok, (d - mean) / np.where(ok, std, 1.0), 0.0)
    m = 2 * half + 1
    out += (m - 1) / np.sqrt(m)
    return out[:, 0] if squeeze else out


def place_neighbours(places: np.ndarray, window: int) -> np.ndarray:
    """The nodes a node's distance is compared with: ``out[0, k - 1, i]`` is the last
    node of the place ``k`` before node ``i``'s, ``out[1, k - 1, i]`` the first node of
    the place ``k`` after it (-1 past either end of the map), for ``k`` = 1 ..
    ``window``.

    ``places`` is each node's place (non-decreasing, one step at a time:
    ``TopoMap.places``). On a map of one node per place these are the nodes ``i -+ k``.
    On a map with runs (a stop of the reference as a run of nodes of one place) a run's
    nodes are one place: none is compared with another of its run, and each is compared
    with the nodes next to its run, which on the keyframe map would be its node's
    neighbours.

    Examples
    --------
    >>> place_neighbours(np.array([0, 1, 1, 2]), 1).tolist()
    [[[-1, 0, 0, 2]], [[1, 3, 3, -1]]]
    """
    places = np.asarray(places, dtype=np.int64)
    w = int(window)
    if w < 1:
        raise ValueError(f"window={window} must be at least 1")
    n = len(places)
    if n == 0:
        return np.zeros((2, w, 0), np.int64)
    steps = np.diff(places)
    if len(steps) and (steps.min() < 0 or steps.max() > 1):
        raise ValueError("places must rise by 0 or 1 from one node to the next")
    first_place = int(places[0])
    count = int(places[-1]) - first_place + 1
    index = places - first_place
    starts = np.searchsorted(index, np.arange(count), side="left")
    ends = np.searchsorted(index, np.arange(count), side="right") - 1
    out = np.full((2, w, n), -1, np.int64)
    for k in range(1, w + 1):
        before, after = index - k, index + k
        out[0, k - 1] = np.where(before >= 0, ends[np.clip(before, 0, count - 1)], -1)
        out[1, k - 1] = np.where(after < count, starts[np.clip(after, 0, count - 1)], -1)
    return out


def closer_count(column: np.ndarray, window: int, places: np.ndarray | None = None) -> np.ndarray:
    """For each node, how many of its ``2 window`` neighbours along the map have a
    strictly smaller distance (int64): the nodes within ``+-window``, or on a map with
    runs (``places``, :func:`place_neighbours`) the nodes next to its run's ``window``
    places each way. Nodes past either end of the map count as not smaller.

    It needs only comparisons of a distance with its neighbours' (on a PPA, shifted
    copies along the snake and a comparison each), where :func:`contrast_enhance` divides.

    Examples
    --------
    >>> closer_count(np.array([3.0, 1.0, 2.0, 5.0]), 1).tolist()
    [1, 0, 1, 1]
    >>> closer_count(np.array([3.0, 1.0, 2.0, 5.0]), 1, np.array([0, 1, 1, 2])).tolist()
    [1, 0, 0, 1]
    """
    d = np.asarray(column, dtype=np.float64)
    n, w = len(d), int(window)
    if w < 1:
        raise ValueError(f"window={window} must be at least 1")
    if places is not None:
        return count_closer(d, place_neighbours(places, w))
    count = np.zeros(n, np.int64)
    padded = np.concatenate((np.full(w, np.inf), d, np.full(w, np.inf)))
    for k in range(-w, w + 1):
        if k:
            count += padded[w + k : w + k + n] < d
    return count


def count_closer(column: np.ndarray, neighbours: np.ndarray) -> np.ndarray:
    """:func:`closer_count` from a table of :func:`place_neighbours` (-1 past an end of
    the map, never smaller), which a filter works out once per map and window.

    Examples
    --------
    >>> count_closer(np.array([3.0, 1.0, 2.0, 5.0]), place_neighbours(np.array([0, 1, 1, 2]), 1))
    array([1, 0, 0, 1])
    """
    d = np.asarray(column, dtype=np.float64)
    padded = np.append(d, np.inf)  # index -1: past an end of the map
    count = np.zeros(len(d), np.int64)
    for side in neighbours:
        for nodes in side:
            count += padded[nodes] < d
    return count


def closer_share(column: np.ndarray, window: int, places: np.ndarray | None = None) -> np.ndarray:
    """:func:`closer_count` as a share of the ``2 window`` neighbours (on a map with runs,
    ``places``, the nodes next to a node's run): 0 for a node no neighbour beats (the
    local best), 1 for the local worst.

    Examples
    --------
    >>> closer_share(np.array([3.0, 1.0, 2.0, 5.0]), 1).tolist()
    [0.5, 0.0, 0.5, 0.5]
    """
    return closer_count(column, window, places) / (2 * int(window))
