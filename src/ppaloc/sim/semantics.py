"""Pure numpy definitions of the primitives whose effect is more than a bus sum or a logic op.

Each function takes and returns whole planes (no FLAG, no R0 rule, no noise, no clip): the
one definition every engine calls, so the reference, numpy and compiled engines cannot
disagree on what ``blur`` or ``PROP0`` does. The engines add the rules common to every
ICW (FLAG masks analogue writes, R12 is written only where R0 = 1, saturation).

What is modelled and what is an approximation is stated per function and in docs/sim.md:
the headers give these ICWs' bits and a one-line meaning, not their analogue transfer.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import numpy as np

from ppaloc.sim.registers import DNEWS_SELECTORS, R0, R1, R2, R12, Direction

__all__ = [
    "BLUR_LINK",
    "blur_value",
    "build_blur",
    "build_prop",
    "diffuse",
    "neighbour",
    "propagate",
]

#: Share of the difference to a linked neighbour that one blur ICW moves (per link).
#: An estimate: the headers call blur an "analog asynchronized blur" without a figure.
BLUR_LINK = np.float32(0.125)


def neighbour(plane: np.ndarray, direction: Direction, fill: float | bool = 0) -> np.ndarray:
    """``plane`` of the neighbour in ``direction`` (``fill`` beyond the array edge)."""
    dr, dc = direction.offset
    rows, cols = plane.shape
    out = np.full_like(plane, fill)
    out[max(0, -dr) : rows - max(0, dr), max(0, -dc) : cols - max(0, dc)] = plane[
        max(0, dr) : rows - max(0, -dr), max(0, dc) : cols - max(0, -dc)
    ]
    return out


def _links(shape: tuple[int, int], r1: np.ndarray | None, r2: np.ndarray | None):
    """Conducting links: ``south[r, c]`` joins (r, c) and (r+1, c); ``west[r, c]`` joins
    (r, c) and (r, c-1). A link conducts where its element's R1 (south) / R2 (west) is 1."""
    rows = shape[0]
    south = np.ones(shape, dtype=bool) if r1 is None else r1.astype(bool, copy=True)
    west = np.ones(shape, dtype=bool) if r2 is None else r2.astype(bool, copy=True)
    south[rows - 1, :] = False  # no element beyond the edge
    west[:, 0] = False
    return south, west


def diffuse(
    x: np.ndarray,
    *,
    horizontal: bool = True,
    vertical: bool = True,
    r1: np.ndarray | None = None,
    r2: np.ndarray | None = None,
    steps: int = 1,
) -> np.ndarray:
    """``steps`` rounds of resistive diffusion of ``x`` over the conducting links.

    Each round moves :data:`BLUR_LINK` of the difference across every conducting link
    (east-west links with ``horizontal``, north-south ones with ``vertical``), so the sum
    is kept and a constant plane is unchanged; nothing flows beyond the array edge.
    ``r1``/``r2`` enable the links as :func:`_links` says (None: every link conducts).
    """
    v = np.asarray(x, dtype=np.float32).copy()
    south, west = _links(v.shape, r1, r2)
    k = BLUR_LINK
    for _ in range(steps):
        flow = np.zeros_like(v)
        if vertical:
            d = np.zeros_like(v)
            d[:-1] = (v[1:] - v[:-1]) * south[:-1]  # from the south neighbour into (r, c)
            flow += d
            flow[1:] -= d[:-1]
        if horizontal:
            d = np.zeros_like(v)
            d[:, 1:] = (v[:, :-1] - v[:, 1:]) * west[:, 1:]  # from the west neighbour
            flow += d
            flow[:, :-1] -= d[:, 1:]
        v = v + k * flow
    return v


def blur_value(
    x: np.ndarray, r1: np.ndarray, r2: np.ndarray, *, horizontal: bool, vertical: bool
) -> np.ndarray:
    """What ``blur``/``blurh``/``blurv(a, x)`` write into ``a``: ``-diffuse(x)``.

    A blur ICW is a bus transfer (the destination gets the negated source, as ``bus``)
    with the diffusion network switched in; R1 and R2, read by ``blurset``, enable the
    links (R1: to the south neighbour, R2: to the west neighbour, per element).
    """
    return -diffuse(x, horizontal=horizontal, vertical=vertical, r1=r1, r2=r2)


def propagate(
    seed: np.ndarray, mask: np.ndarray, selectors: dict[Direction, np.ndarray], boundary: bool
) -> np.ndarray:
    """Asynchronous propagation (``PROP0``/``PROP1``): ``seed`` flooded through ``mask``.

    An element becomes 1 where ``mask`` is 1 and a neighbour its own selectors name (R1
    south, R2 west, R3 north, R4 east, as for DNEWS) is 1, repeated until nothing changes
    (``boundary``: the value beyond the array edge). Elements already 1 stay 1. The chip's
    propagation reaches a finite distance per ICW that the headers do not state; here one
    ICW reaches the fixed point.
    """
    out = np.asarray(seed, dtype=bool).copy()
    mask = np.asarray(mask, dtype=bool)
    if len(selectors) == 4 and all(s.all() for s in selectors.values()):
        return _flood_all_directions(out, mask, boundary)
    active = [(d, s.astype(bool)) for d, s in selectors.items() if s.any()]
    while True:
        reach = np.zeros_like(out)
        for d, sel in active:
            reach |= sel & neighbour(out, d, fill=boundary)
        new = out | (reach & mask)
        if np.array_equal(new, out):
            return out
        out = new


_CROSS = np.array([[0, 1, 0], [1, 1, 1], [0, 1, 0]], dtype=bool)


def _flood_all_directions(seed: np.ndarray, mask: np.ndarray, boundary: bool) -> np.ndarray:
    """:func:`propagate` when every element selects all four neighbours (connected fill)."""
    from scipy import ndimage

    start = ndimage.binary_dilation(seed, _CROSS) & mask
    if boundary:
        edge = np.zeros_like(mask)
        edge[0, :] = edge[-1, :] = edge[:, 0] = edge[:, -1] = True
        start |= edge & mask
    return ndimage.binary_propagation(start, _CROSS, mask=mask) | seed


# ----------------------------------------------------------------------------------------
# Building blocks of the numpy engine for the rows of isa.OPS defined here. They call the
# pure functions above and apply the rules every ICW shares through the simulator's own
# planes and helpers (``_a``, ``_d``, ``_flag_mask``, ``_blend``, ``noise``).


def build_blur(sim: Any, ins: Any, horizontal: bool, vertical: bool) -> Callable[[], None]:
    """``blur``/``blurh``/``blurv(a, x)``: ``a := -diffuse(x)`` where FLAG, clipped; noisy
    like one bus transfer (gain, the written cell's offset, temporal noise)."""
    (dst,), (src,) = ins.dsts, ins.srcs
    plane, x = sim._analog_planes[dst.index], sim._analog_planes[src.index]
    r1, r2 = sim._d[R1.index], sim._d[R2.index]
    noise = sim.noise

    def run() -> None:
        v = diffuse(x, horizontal=horizontal, vertical=vertical, r1=r1, r2=r2)
        if noise.ideal:
            np.negative(v, out=v)
        else:
            np.multiply(v, np.float32(noise.negated_gain()), out=v)
            noise.perturb(v, dst.index, False)
        np.clip(v, -128, 127, out=v)
        mask = sim._flag_mask()
        if mask is None:
            np.copyto(plane, v)
        else:
            sim._blend(plane, v, mask)

    return run


def build_prop(sim: Any, ins: Any, boundary: bool) -> Callable[[], None]:
    """``PROP0``/``PROP1``: ``R12 := propagate(R12, R0, selectors R1-R4, boundary)``."""
    r12, r0 = sim._d[R12.index], sim._d[R0.index]
    selectors = {d: sim._d[r.index] for d, r in DNEWS_SELECTORS.items()}

    def run() -> None:
        np.copyto(r12, propagate(r12, r0, selectors, boundary))

    return run
