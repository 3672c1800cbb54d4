"""How the camera moves along the route: one frame per place, or variable speed with stops."""

from __future__ import annotations

import numpy as np

__all__ = ["lateral_weave", "variable_speed_positions"]


def variable_speed_positions(
    end: float, spacing: float, speed: float, stops: int, seed: int
) -> np.ndarray:
    """Route positions (m) of successive frames of a vehicle that speeds up, slows and stops.

    The speed is ``speed`` places per frame modulated by three slow sinusoids (between
    about 0.35x and 1.65x), ramps down before each of ``stops`` stops, waits 6-24 frames,
    then ramps up again. Positions start at 0 and end exactly at ``end``.

    Parameters
    ----------
    end : float
        Last position (m).
    spacing : float
        Metres between places.
    speed : float
        Mean speed in places per frame (> 0).
    stops : int
        Number of stops, at random positions in the middle 80% of the route.
    seed : int

    Returns
    -------
    ndarray of float64, shape (F,)
        Non-decreasing positions; consecutive equal values are frames taken while stopped.
    """
    rng = np.random.default_rng([seed, 0x3071])
    periods = rng.uniform(25.0, 160.0, 3)
    phases = rng.uniform(0.0, 2 * np.pi, 3)
    amps = np.array([0.35, 0.2, 0.1])
    stop_at = np.sort(rng.uniform(0.1, 0.9, stops)) * end
    dwell = rng.integers(6, 25, stops)
    cruise = speed * spacing
    accel = 0.12 * cruise
    s, v_prev, t, k, wait = 0.0, 0.0, 0, 0, 0
    out = [0.0]
    while s < end:
        t += 1
        if wait > 0:
            wait -= 1
            v_prev = 0.0
            out.append(s)
            continue
        v = cruise * (1.0 + float(np.sum(amps * np.sin(2 * np.pi * t / periods + phases))))
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


def lateral_weave(s: np.ndarray, seed: int, amplitude: float = 0.12) -> np.ndarray:
    """Small lateral wander of a driver around the lane position (m) at positions ``s``."""
    rng = np.random.default_rng([seed, 0x3EA7])
    p1, p2 = rng.uniform(0, 2 * np.pi, 2)
    s = np.asarray(s, np.float64)
    return amplitude * (0.7 * np.sin(s / 41.0 + p1) + 0.3 * np.sin(s / 13.0 + p2))
