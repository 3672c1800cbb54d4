"""How fast the query moves through the map, and whether a method searches that speed.

A sequence method assumes a range of query speeds, in reference frames (map nodes) per
query frame: SeqSLAM searches straight lines of ``vmin .. vmax``, ABLE-M compares one
reference frame per query frame, a particle filter's motion prior moves its particles at
about one node per frame, the weighted-node filter's transition costs assume one place a
frame where it does not know the speed. A query driven at twice the mapping speed is
outside all of them, and such a method then fails for a reason that has nothing to do
with recognising places. This module measures the query's speed from the dataset's
ground truth and says so, one line for the methods that search the same speeds:

- :func:`match_centres`: the reference frame each query sits at (the median of its accepted
  reference frames; NaN for a query without a true match, which is skipped);
- :func:`window_speeds`: the speed over each window of ``window`` query frames, robustly
  (the median of the slopes between frames at least half a window apart, so a jump of the
  ground truth or a missing match moves it little);
- :func:`check_speed`: the share of windows far outside a method's range, and a warning
  when that share is large;
- :func:`speed_checks`: the check of every method that declares a range (its localiser's
  ``speed_range``), logged as a warning, one line for the methods that search the same
  speeds; each method's entry of ``results.json`` carries its own as ``speed_check``.
  A method whose motion model tells a standing query from a moving one (its localiser's
  ``follows_stops``: the weighted-node filter's image test) is checked on the frames the
  dataset says moved (``query_moved``), where it has them: a stop is not a speed it
  has to search.
"""

from __future__ import annotations

import logging
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np

__all__ = [
    "DEFAULT_REMEDY",
    "FAR",
    "SHARE",
    "WINDOW",
    "check_speed",
    "match_centres",
    "speed_checks",
    "window_speeds",
]

log = logging.getLogger(__name__)

WINDOW = 10
"""Query frames per window (SeqSLAM's ``ds``, ABLE-M's default length)."""

FAR = 0.25
"""A window is far outside a range ``lo .. hi`` below ``lo / (1 + FAR)`` or above
``hi x (1 + FAR)``: at 25% beyond SeqSLAM's 1.2, a line drifts 3 nodes from the route in
its 11 frames, more than the usual tolerance."""

SHARE = 0.25
"""A method is warned when more than this share of the route's windows is far outside."""


def match_centres(ground_truth: Sequence[np.ndarray]) -> np.ndarray:
    """The reference frame each query frame sits at, from the ground truth.

    Parameters
    ----------
    ground_truth : sequence of ndarray of int
        Accepted reference frames per query.

    Returns
    -------
    ndarray of float64, shape (M,)
        The median of each query's accepted frames; NaN where a query has none.

    Examples
    --------
    >>> match_centres([np.array([3, 4, 5]), np.array([], int), np.array([7, 8])]).tolist()
    [4.0, nan, 7.5]
    """
    return np.array([float(np.median(g)) if len(g) else np.nan for g in ground_truth])


def window_speeds(centres: np.ndarray, window: int = WINDOW) -> np.ndarray:
    """The query's speed over each window of ``window + 1`` consecutive query frames.

    The speed of the window starting at frame ``i`` is the median of the slopes
    ``(c[k] - c[j]) / (k - j)`` over every pair ``i <= j < k <= i + window`` with
    ``k - j >= window / 2`` and both centres known (a Theil-Sen slope over the long pairs
    only: centres are whole frames, so a pair ``L`` frames apart is off by up to ``1 / L``).
    One wrong frame in a window of 10 (a ground-truth jump, a stray match) enters at most 6
    of its 21 pairs, so it does not move the median far. NaN where the window holds no
    such pair.

    Parameters
    ----------
    centres : ndarray of float, shape (M,)
        From :func:`match_centres`.
    window : int
        Query frames a window spans (at least 2).

    Returns
    -------
    ndarray of float64, shape (max(M - window, 0),)
        Reference frames per query frame.

    Examples
    --------
    >>> c = 2.0 * np.arange(14)  # 2 reference frames a query frame, and one glitch
    >>> c[7] = 99.0
    >>> window_speeds(c, 10).tolist()
    [2.0, 2.0, 2.0, 2.0]
    """
    c = np.asarray(centres, dtype=np.float64)
    window = int(window)
    if window < 2:
        raise ValueError(f"window={window} must be at least 2 query frames")
    n = len(c) - window
    if n <= 0:
        return np.empty(0)
    slopes = []
    for lag in range((window + 1) // 2, window + 1):
        pair = (c[lag:] - c[:-lag]) / lag  # pair (j, j + lag)
        for start in range(window - lag + 1):  # j = i + start
            slopes.append(pair[start : start + n])
    table = np.stack(slopes, axis=1)
    out = np.full(n, np.nan)
    known = ~np.all(np.isnan(table), axis=1)
    out[known] = np.nanmedian(table[known], axis=1)
    return out


#: What the warning asks for when a method names no remedy of its own.
DEFAULT_REMEDY = "widen its speed range or subsample the query"


def check_speed(
    speeds: np.ndarray,
    speed_range: tuple[float, float],
    *,
    method: str = "this method",
    far: float = FAR,
    share: float = SHARE,
    remedy: str | None = None,
) -> dict[str, Any]:
    """Whether a large share of the route is far outside a method's range of speeds.

    Parameters
    ----------
    speeds : ndarray of float
        Window speeds (:func:`window_speeds`); NaN windows are skipped.
    speed_range : (float, float)
        The speeds the method searches, reference frames per query frame.
    method : str
        Its name, for the warning.
    far, share : float
        See :data:`FAR` and :data:`SHARE`.
    remedy : str, optional
        What widens this method's range (its localiser's ``speed_remedy``), named in the
        warning; by default "widen its speed range or subsample the query".

    Returns
    -------
    dict
        ``range`` ([lo, hi]), ``query_speed_median`` and ``share_outside`` (None without a
        known window), and ``warning``: one line, or None when the share is not large.

    Examples
    --------
    >>> check_speed(np.full(50, 2.0), (0.8, 1.2), method="seqslam")["share_outside"]
    1.0
    >>> check_speed(np.full(50, 1.0), (0.8, 1.2))["warning"] is None
    True
    """
    lo, hi = float(speed_range[0]), float(speed_range[1])
    known = np.asarray(speeds, dtype=np.float64)
    known = known[np.isfinite(known)]
    out: dict[str, Any] = {
        "range": [lo, hi],
        "query_speed_median": None,
        "share_outside": None,
        "warning": None,
    }
    if not known.size:
        return out
    outside = float(np.mean((known < lo / (1 + far)) | (known > hi * (1 + far))))
    median = float(np.median(known))
    out.update(query_speed_median=median, share_outside=outside)
    if outside > share:
        out["warning"] = _warning(method, (lo, hi), outside, median, remedy, far=far)
    return out


def _warning(
    subject: str,
    speed_range: tuple[float, float],
    outside: float,
    median: float,
    remedy: str | None,
    *,
    several: bool = False,
    far: float = FAR,
) -> str:
    """The one-line warning of :func:`check_speed`, for one method or several alike
    (``several``: the subject names them, each searching the same speeds)."""
    lo, hi = speed_range
    verb, their = ("", "their") if several else ("s", "its")
    searches = (
        f"assume{verb} a query speed of {lo:.3g}"
        if lo == hi
        else f"search{'es' if verb else ''} query speeds of {lo:.3g} to {hi:.3g}"
    )
    return (
        f"{subject} {searches} reference frames per query frame, but on {outside:.0%} of "
        f"this route the query moves at under {lo / (1 + far):.2g} or over "
        f"{hi * (1 + far):.2g} (median {median:.2f}): {their} figures here measure {their} "
        f"speed assumption, not {their} place recognition; {remedy or DEFAULT_REMEDY} "
        "(docs/baselines.md, 'Query speed')"
    )


def _follows_stops(localiser: Any, moved: np.ndarray | None) -> bool:
    """Whether ``localiser``'s check leaves the query's stops out: it follows them and the
    dataset says where they are."""
    return moved is not None and bool(getattr(localiser, "follows_stops", False))


def _names(names: Sequence[str]) -> str:
    """``a``, ``a and b each``, ``a, b and c each``: the subject of a warning shared by
    methods."""
    if len(names) == 1:
        return names[0]
    return f"{', '.join(names[:-1])} and {names[-1]} each"


def speed_checks(
    localisers: Mapping[str, Any],
    ground_truth: Sequence[np.ndarray],
    *,
    window: int = WINDOW,
    moved: np.ndarray | None = None,
) -> dict[str, dict[str, Any]]:
    """The speed check of every localiser that declares ``speed_range``, the warnings logged
    once (``logging.WARNING``, on stderr under ``ppaloc``'s command line): one line for the
    methods that search the same speeds with the same remedy, which an evaluation of every
    method would otherwise print a dozen times.

    Parameters
    ----------
    localisers : mapping of str to Localiser
        By method name; one without a ``speed_range`` attribute (single-frame matching) is
        left out.
    ground_truth : sequence of ndarray of int
        Accepted reference frames per query.
    window : int
        Query frames per window.
    moved : ndarray of bool, shape (M,), optional
        The dataset's ``query_moved`` (True where the query advanced since the frame
        before; the first frame counts as moved). A localiser whose ``follows_stops`` is
        true is checked on the other frames left out: the speeds of the query in motion.

    Returns
    -------
    dict of str to dict
        :func:`check_speed`'s result per method that declares a range, with
        ``stops_left_out``: the standing frames its check left out (0 where none were).
    """
    declared = {
        name: (tuple(rng), getattr(loc, "speed_remedy", None), _follows_stops(loc, moved))
        for name, loc in localisers.items()
        if (rng := getattr(loc, "speed_range", None)) is not None
    }
    if not declared:
        return {}
    centres = match_centres(ground_truth)
    speeds = {False: window_speeds(centres, window)}
    left_out = 0
    if moved is not None and any(stops for _, _, stops in declared.values()):
        keep = np.asarray(moved, dtype=bool).copy()
        keep[:1] = True  # the first frame has no frame before it
        left_out = int(np.count_nonzero(~keep))
        speeds[True] = window_speeds(centres[keep], window)
    out = {}
    warned: dict[tuple[tuple[float, float], str | None, bool], list[str]] = {}
    for name, (rng, remedy, stops) in declared.items():
        out[name] = check_speed(speeds[stops], (rng[0], rng[1]), method=name, remedy=remedy)
        out[name]["stops_left_out"] = left_out if stops else 0
        if out[name]["warning"]:
            key = ((float(rng[0]), float(rng[1])), remedy, stops)
            warned.setdefault(key, []).append(name)
    for (rng, remedy, _), names in warned.items():  # one line for the methods alike
        first = out[names[0]]
        line = _warning(
            _names(names),
            rng,
            first["share_outside"],
            first["query_speed_median"],
            remedy,
            several=len(names) > 1,
        )
        log.warning("%s", line)
    return out
