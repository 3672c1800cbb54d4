"""How the camera moves along the route: one frame per place, or variable speed with stops."""

from __future__ import annotations

import numpy as np

__all__ = [
    "SPEED_VAR",
    "WIDE_SPEED_VAR",
    "lateral_weave",
    "place_positions_with_stops",
    "variable_speed_positions",
]

SPEED_VAR = 0.2
"""Default peak relative deviation of the cruising speed from its mean (+-20%)."""

WIDE_SPEED_VAR = 0.65
"""The wide profile (about 0.35x to 1.65x): a hard test for one-node-per-frame filters."""

_AMPS = np.array([0.35, 0.2, 0.1]) / 0.65  # three slow sinusoids, peak sum 1


def _speed_factor(frames: int, speed_var: float, rng: np.random.Generator) -> np.ndarray:
    """``1 + speed_var * u(t)`` for t = 1..frames, ``u`` a zero-mean sum of slow sinusoids.

    The sum is centred over the frames so that the mean factor is exactly 1 there: the
    query's cruising speed averages the requested ``speed`` however short the route.
    """
    periods = rng.uniform(25.0, 160.0, 3)
    phases = rng.uniform(0.0, 2 * np.pi, 3)
    t = np.arange(1, frames + 1, dtype=np.float64)[:, None]
    u = np.sum(_AMPS * np.sin(2 * np.pi * t / periods + phases), axis=1)
    u -= u.mean()
    peak = float(np.abs(u).max()) or 1.0
    return 1.0 + speed_var * u / max(peak, 1.0)


def variable_speed_positions(
    end: float,
    spacing: float,
    speed: float,
    stops: int,
    seed: int,
    speed_var: float = SPEED_VAR,
) -> np.ndarray:
    """Route positions (m) of successive frames of a vehicle that speeds up, slows and stops.

    The cruising speed is ``speed`` places per frame times a slow random factor
    ``1 + speed_var * u(t)`` (``u`` a sum of three sinusoids with periods of 25-160 frames,
    centred to mean 0 and within [-1, 1]), so it stays within ``+-speed_var`` of ``speed``
    and averages ``speed``. The first frame is taken at cruising speed (the recording
    starts as the vehicle passes place 0). Before each of ``stops`` stops the vehicle
    brakes (the speed falls in proportion to the remaining distance), waits 6-24 frames,
    then accelerates again (at most 12% of the cruising speed per frame). Positions start
    at 0 and end exactly at ``end``.

    Parameters
    ----------
    end : float
        Last position (m).
    spacing : float
        Metres between places.
    speed : float
        Mean cruising speed in places per frame (> 0).
    stops : int
        Number of stops, at random positions in the middle 80% of the route.
    seed : int
    speed_var : float
        Peak relative speed deviation, in [0, 0.9] (default :data:`SPEED_VAR`, +-20%;
        :data:`WIDE_SPEED_VAR` gives about 0.35x-1.65x).

    Returns
    -------
    ndarray of float64, shape (F,)
        Non-decreasing positions; consecutive equal values are frames taken while stopped.
    """
    rng = np.random.default_rng([seed, 0x3071])
    cruise = speed * spacing
    factor = _speed_factor(max(int(np.ceil(end / cruise)), 1), speed_var, rng)
    stop_at = np.sort(rng.uniform(0.1, 0.9, stops)) * end
    dwell = rng.integers(6, 25, stops)
    accel = 0.12 * cruise
    # the recording starts as the vehicle passes place 0 at cruising speed, as the mapping
    # run did; only the stops start from standstill
    s, v_prev, t, k, wait = 0.0, cruise * float(factor[0]), 0, 0, 0
    out = [0.0]
    while s < end:
        if wait > 0:
            wait -= 1
            v_prev = 0.0
            out.append(s)
            continue
        v = cruise * float(factor[min(t, len(factor) - 1)])
        t += 1  # the speed profile runs on while driving, not while waiting
        v = min(v, v_prev + accel)
        if k < stops:
            v = min(v, 0.3 * (stop_at[k] - s) + 0.08 * cruise)
            if s + v >= stop_at[k]:
                s, v_prev, wait, k = float(stop_at[k]), 0.0, int(dwell[k]), k + 1
                out.append(s)
                continue
        v = max(v, 0.02 * cruise)
        s = min(s + v, end)
        v_prev = v
        out.append(s)
    return np.asarray(out, np.float64)


def place_positions_with_stops(places: int, spacing: float, stops: int, seed: int) -> np.ndarray:
    """Positions (m) of a vehicle that advances exactly one place per frame but stops.

    The paper's setting: the route is re-driven at the mapping speed, so every moving frame
    is one place on, and the vehicle halts ``stops`` times (at random places in the middle
    80% of the route, 6-24 frames each, like :func:`variable_speed_positions`). Only the
    motion model's forward-or-stay decision matters here, not the speed.

    Returns
    -------
    ndarray of float64, shape (places + total dwell,)
        Non-decreasing positions ``k * spacing``; repeated values are frames while stopped.
    """
    rng = np.random.default_rng([seed, 0x5709])
    place = np.arange(places, dtype=np.float64)
    repeats = np.ones(places, np.int64)
    if stops > 0 and places > 2:
        lo, hi = max(1, int(0.1 * places)), max(2, int(0.9 * places))
        at = rng.choice(np.arange(lo, hi), size=min(stops, hi - lo), replace=False)
        repeats[at] += rng.integers(6, 25, at.size)
    return np.repeat(place, repeats) * spacing


def lateral_weave(s: np.ndarray, seed: int, amplitude: float = 0.12) -> np.ndarray:
    """Small lateral wander of a driver around the lane position (m) at positions ``s``."""
    rng = np.random.default_rng([seed, 0x3EA7])
    p1, p2 = rng.uniform(0, 2 * np.pi, 2)
    s = np.asarray(s, np.float64)
    return amplitude * (0.7 * np.sin(s / 41.0 + p1) + 0.3 * np.sin(s / 13.0 + p2))
