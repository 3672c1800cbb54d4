"""The shape of a route: turns (yaw), hills (pitch) and a driver's lateral drift.

The world stays in *route coordinates* (``s`` along the route, ``x`` across it); a
:class:`RoutePath` says how the route bends. The renderer of a bent route
(:class:`~ppaloc.datasets.synthetic.curved.CurvedRenderer`) projects a point ``u`` metres
ahead and ``x`` across as if the route were unrolled at the depth ``u`` but moved sideways by
the bend of the route between the camera and that depth, ``lateral(u) = integral of
sin(heading(s+v) - heading(s) - yaw) dv`` (the classic "pseudo-3D" road), so a corner sweeps
the whole view sideways while the camera rotates and reveals what lies beyond it.

A turn changes the heading by 25-90 degrees along an arc whose curvature rises and falls as
a raised cosine (no jumps in the heading rate): half of them are *corners* (radius 12-25 m
on a road, 0.8-2 m indoors), half *curves* (radius 50-150 m, 3-8 m indoors). The turns are
spread over the route, one per equal slot, at random places inside the middle of their slot.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

__all__ = ["DS", "RoutePath", "drift", "make_path"]

DS = 0.25
"""Sampling step of the path profiles (m)."""


@dataclass(frozen=True)
class RoutePath:
    """Heading, height and turn flags of a route, sampled every :data:`DS` metres.

    Attributes
    ----------
    s0 : float
        Route position of the first sample (m).
    heading : ndarray of float64
        Heading (rad) relative to the start; it grows in right turns.
    pitch : ndarray of float64
        Camera pitch (rad, positive looking up) from the route's hills.
    turning : ndarray of bool
        The sample lies on a turn's arc (its curvature is above a tenth of the turn's peak).
    turns : ndarray of float64, shape (T, 3)
        ``(start, end, angle)`` of every turn (m, m, rad).
    """

    s0: float
    heading: np.ndarray
    pitch: np.ndarray
    turning: np.ndarray
    turns: np.ndarray

    def _index(self, s: np.ndarray) -> np.ndarray:
        return (np.asarray(s, np.float64) - self.s0) / DS

    def heading_at(self, s: np.ndarray) -> np.ndarray:
        """Heading (rad) at route positions ``s`` (m), linearly interpolated."""
        i = self._index(s)
        return np.interp(i, np.arange(self.heading.size), self.heading)

    def pitch_at(self, s: float) -> float:
        i = float(self._index(s))
        return float(np.interp(i, np.arange(self.pitch.size), self.pitch))

    def turning_at(self, s: np.ndarray) -> np.ndarray:
        """Whether each route position ``s`` (m) lies on a turn's arc."""
        i = np.clip(np.rint(self._index(s)).astype(np.int64), 0, self.turning.size - 1)
        return self.turning[i]


def make_path(
    begin: float,
    end: float,
    drive_end: float,
    turns: int,
    seed: int,
    *,
    indoor: bool = False,
    hills: bool = True,
) -> RoutePath:
    """A route with ``turns`` turns between ``0.05`` and ``0.95`` of ``[0, drive_end]``.

    Parameters
    ----------
    begin, end : float
        Extent of the profiles (m); they cover the world, beyond the driven part.
    drive_end : float
        Last position a traversal drives to (m); the turns lie inside.
    turns : int
        Number of turns (0: straight).
    seed : int
        Same seed, same route.
    indoor : bool
        Tight corners and curves of a building (radii in metres, not tens of metres), and
        no hills.
    hills : bool
        Gentle hills: the camera pitches by up to about 2 degrees over 150-400 m.
    """
    rng = np.random.default_rng([seed, 0x7E2A])
    n = int(np.ceil((end - begin) / DS)) + 1
    s = begin + np.arange(n) * DS
    kappa = np.zeros(n)
    turning = np.zeros(n, bool)
    rows = []
    lo, hi = 0.05 * drive_end, 0.95 * drive_end
    slot = (hi - lo) / max(turns, 1)
    for k in range(turns):
        angle = float(rng.uniform(np.radians(25), np.radians(90))) * float(rng.choice([-1, 1]))
        corner = rng.random() < 0.5
        if indoor:
            radius = rng.uniform(0.8, 2.0) if corner else rng.uniform(3.0, 8.0)
        else:
            radius = rng.uniform(12.0, 25.0) if corner else rng.uniform(50.0, 150.0)
        length = min(float(radius) * abs(angle), 0.6 * slot)
        length = max(length, 2 * DS * 4)
        a = lo + k * slot + float(rng.uniform(0.2, 0.8)) * (slot - length)
        t = (s - a) / length
        on = (t >= 0) & (t <= 1)
        window = np.where(on, 1 - np.cos(2 * np.pi * np.clip(t, 0, 1)), 0.0)
        kappa += window * angle / length
        turning |= window > 0.2  # a tenth of the peak (the window peaks at 2)
        rows.append((a, a + length, angle))
    heading = np.concatenate([[0.0], np.cumsum(0.5 * (kappa[1:] + kappa[:-1]) * DS)])
    heading -= np.interp(0.0, s, heading)
    pitch = np.zeros(n)
    if hills and not indoor:
        for _ in range(2):
            wave = rng.uniform(150.0, 400.0)
            amp = rng.uniform(0.012, 0.02)
            pitch += amp * np.sin(2 * np.pi * s / wave + rng.uniform(0, 2 * np.pi))
    return RoutePath(
        s0=float(begin),
        heading=heading,
        pitch=pitch,
        turning=turning,
        turns=np.array(rows, np.float64).reshape(-1, 3),
    )


def drift(
    s: np.ndarray, path: RoutePath, seed: int, amplitude: float, cut: float, period: float = 120.0
) -> np.ndarray:
    """Lateral drift (m): a slow wander of ``amplitude`` plus cutting into each turn by ``cut``.

    The wander has periods of ``period`` and ``0.37 * period`` metres; cutting moves toward
    the inside of a turn in proportion to the heading rate (``cut`` at the sharpest point).
    """
    rng = np.random.default_rng([seed, 0xD21F])
    p1, p2 = rng.uniform(0, 2 * np.pi, 2)
    s = np.asarray(s, np.float64)
    w = 2 * np.pi / period
    out = amplitude * (0.7 * np.sin(s * w + p1) + 0.3 * np.sin(s * w / 0.37 + p2))
    rate = np.gradient(path.heading) / DS
    peak = float(np.abs(rate).max()) or 1.0
    inside = np.interp((s - path.s0) / DS, np.arange(rate.size), rate) / peak
    return out - cut * inside
