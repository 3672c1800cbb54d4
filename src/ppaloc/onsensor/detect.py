"""Detection and confidence on the sensor (docs/ppa8.md, items 4).

Stages ``"detect"`` and ``"confidence"``. The controller finds ``T = floor(max W)`` by a
search of ``global_or`` over thresholds loaded through the DAC (:func:`max_threshold`),
started from the last frame's ``T`` (:func:`largest_met`); with ``bits`` fraction bits
(the robust preset, :data:`~ppaloc.localise.params.DETECT_BITS`) it refines the
candidates' threshold to ``floor(2**bits max W) / 2**bits`` by a search of as many steps
over ``T + j 2**-bits``, the fraction a plane built by halvings of a DAC integer
(:func:`max_fraction`). The candidates are then all of them from one event readout, or
the one nearest the previous estimate by a window search (:func:`nearest`); the host's
:func:`~ppaloc.localise.params.choose_candidate` breaks the tie. The confidence is that
threshold minus the largest threshold met outside ``node +- R``, found the same way (an
integer search started from ``T`` less the last frame's gap, then with ``bits`` the
fraction's steps).
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from ppaloc.localise.params import choose_candidate
from ppaloc.onsensor.program import and_planes
from ppaloc.onsensor.roles import DRegs
from ppaloc.onsensor.sensor import Sensor
from ppaloc.onsensor.transition import settle
from ppaloc.onsensor.weights import WeightState
from ppaloc.sim import FLAG, IN, NEWS, Kernel, Register

__all__ = [
    "EVENT_SLOTS",
    "at_least",
    "candidates",
    "confidence",
    "detect",
    "largest_met",
    "local_top",
    "max_fraction",
    "max_threshold",
    "nearest",
    "outside_fraction",
    "outside_max",
]

#: Event slots of the first candidate readout; more candidates fall back to a window search.
EVENT_SLOTS = 32


def at_least(
    sensor: Sensor, state: WeightState, threshold: int, frac: int = 0, bits: int = 0
) -> bool:
    """``cand := (W >= threshold + frac 2**-bits) AND valid``; True if any PE is set
    (``global_or``).

    ``tmp_a`` must hold NOT allowed (:meth:`Sensor.allow`). A fraction is a plane of
    ``spare`` and ``frame`` (free at detection): the DAC integer ``+-frac``, then ``bits``
    halvings (``bus2``, each flips the sign), a third source of the comparison.
    """
    sim, r = sensor.sim, sensor.roles
    if frac:
        sim.scamp5_in(r.spare, frac if bits % 2 == 0 else -frac)
    sim.load_in(int(threshold))
    src = r.negated if state.negated else r.weights
    if frac:
        sensor.run(_at_least_fraction, r.d, src, state.negated, r.spare, r.frame, bits)
    elif state.negated:
        sensor.run(_at_least_negated, r.d, src)
    else:
        sensor.run(_at_least, r.d, src)
    return bool(sim.global_or(r.d.cand))


def _at_least(k: Kernel, dr: DRegs, w: Register) -> None:
    k.bus(NEWS, w)
    k.where(IN, NEWS)  # FLAG = W < threshold
    k.NOR(dr.cand, FLAG, dr.tmp_a)  # tmp_a = NOT allowed
    k.all()


def _at_least_negated(k: Kernel, dr: DRegs, neg: Register) -> None:
    k.where(IN, neg)  # FLAG = w < threshold, from -w: no write
    k.NOR(dr.cand, FLAG, dr.tmp_a)
    k.all()


def _at_least_fraction(
    k: Kernel, dr: DRegs, src: Register, negated: bool, a: Register, b: Register, bits: int
) -> None:
    """``a`` holds ``(-1)**bits frac``: ``bits`` halvings leave ``+frac 2**-bits`` in
    ``a`` or ``b``, then ``FLAG = W < threshold + frac 2**-bits`` as :func:`_at_least`."""
    cur, other = a, b
    for _ in range(bits):
        k.bus2(other, NEWS, cur)
        cur, other = other, cur
    if negated:
        k.where(IN, cur, src)
    else:
        k.bus(NEWS, src)
        k.where(IN, cur, NEWS)
    k.NOR(dr.cand, FLAG, dr.tmp_a)
    k.all()


def largest_met(
    test: Callable[[int], bool], lo: int, hi: int, guess: int | None = None
) -> int | None:
    """The largest ``t`` in ``[lo, hi]`` with ``test(t)``, for a test that holds up to a
    value and fails above it; None when ``test(lo)`` fails.

    Without ``guess``: ``test(lo)``, then bisection (``1 + ceil(log2(hi - lo + 1))``
    tests). With one (the controller's expectation, e.g. last frame's answer), the search
    gallops from it, steps of 1, 2, 4, ... up while the test holds or down while it
    fails, then bisects the bracket: 2 tests when the answer is the guess or one below,
    about ``2 log2(|answer - guess|)`` otherwise. For such a test both find the same
    value.

    Examples
    --------
    >>> calls = []
    >>> def test(t):
    ...     calls.append(t)
    ...     return t <= 5
    >>> largest_met(test, -127, 127), len(calls)
    (5, 9)
    >>> calls.clear(); largest_met(test, -127, 127, guess=5), calls
    (5, [5, 6])
    >>> largest_met(lambda t: False, -127, 127, guess=0), largest_met(test, 6, 9, guess=7)
    (None, None)
    """
    if guess is None:
        if not test(lo):
            return None
    else:
        guess = min(max(int(guess), lo), hi)
        step = 1
        if test(guess):
            lo = guess
            while lo < hi:
                probe = min(guess + step, hi)
                if not test(probe):
                    hi = probe - 1
                    break
                lo, step = probe, 2 * step
        else:
            hi = guess - 1
            while True:
                if hi < lo:
                    return None
                probe = max(guess - step, lo)
                if test(probe):
                    lo = probe
                    break
                hi, step = probe - 1, 2 * step
    return _bisect(test, lo, hi)


def _bisect(test: Callable[[int], bool], lo: int, hi: int) -> int:
    """The largest ``t`` in ``[lo, hi]`` with ``test(t)``, ``test(lo)`` known to hold
    (``ceil(log2(hi - lo + 1))`` tests)."""
    while lo < hi:
        mid = (lo + hi + 1) // 2
        if test(mid):
            lo = mid
        else:
            hi = mid - 1
    return lo


def max_threshold(
    sensor: Sensor, state: WeightState, lo: int, hi: int, guess: int | None = None
) -> int | None:
    """Largest integer ``T`` in [lo, hi] with a set PE of ``cand``; None if none. The
    search starts from ``guess`` where the controller has one (:func:`largest_met`)."""
    return largest_met(lambda t: at_least(sensor, state, t), lo, hi, guess)


def max_fraction(sensor: Sensor, state: WeightState, top: int, bits: int) -> int:
    """Largest ``j`` in ``[0, 2**bits)`` with a node at ``w >= top + j 2**-bits``, after
    :func:`local_top` found ``top`` (``bits`` steps; ``j = 0`` is known to hold)."""
    return _bisect(lambda j: at_least(sensor, state, top, j, bits), 0, 2**bits - 1)


def detect(sensor: Sensor, state: WeightState, prev: int | None, bits: int = 0) -> tuple[int, int]:
    """``(node, T)``: the candidate nearest ``prev`` among ``w >= floor(2**bits max W) /
    2**bits``, and ``T = floor(max W)``; the fraction found is left in
    ``state.top_fraction`` (the confidence's)."""
    state.top_fraction = 0
    with sensor.stage("detect"):
        top = local_top(sensor, state)
        frac = max_fraction(sensor, state, top, bits) if bits else 0
        state.top_fraction = frac
        found = candidates(sensor, state, top, prev, frac, bits)
        if found is None and frac:
            state.top_fraction = 0  # only with noise, as below: the threshold falls to T
            found = candidates(sensor, state, top, prev)
        while found is None and top > -127:
            # only with noise: the comparator's noise hid every candidate this time
            top -= 1
            found = candidates(sensor, state, top, prev)
    if not found:
        return (0 if prev is None else prev), top
    return choose_candidate(np.asarray(found), prev), top


def local_top(sensor: Sensor, state: WeightState) -> int:
    """``floor(max W)`` over this sensor's nodes (a ``global_or`` threshold search)."""
    settle(sensor, state)
    sensor.allow(False)
    top = max_threshold(sensor, state, -127, 127, state.last_top)
    assert top is not None
    state.last_top = top
    return top


def candidates(
    sensor: Sensor,
    state: WeightState,
    top: int,
    prev: int | None,
    frac: int = 0,
    bits: int = 0,
) -> list[int] | None:
    """Nodes with ``w >= top + frac 2**-bits``: all of them (fewer than
    :data:`EVENT_SLOTS`), or the one nearest ``prev`` (a window search, :func:`nearest`);
    None if none is found.

    ``prev`` may lie outside this sensor's nodes (a bank gives it in local numbers).
    After :func:`local_top`, whose ``tmp_a`` (NOT valid) it reuses.
    """
    at_least(sensor, state, top, frac, bits)
    events = sensor.sim.scan_events(sensor.roles.d.cand, EVENT_SLOTS)
    if not len(events):
        return None
    if len(events) < EVENT_SLOTS:
        return [int(i) for i in sensor.nodes_of(events)]
    return [nearest(sensor, state, top, prev, frac, bits)]


def nearest(
    sensor: Sensor, state: WeightState, top: int, prev: int | None, frac: int = 0, bits: int = 0
) -> int:
    """Window search: the candidate (``w >= top + frac 2**-bits``) nearest ``prev``
    (smaller index first)."""
    prev = 0 if prev is None else prev
    level = (top, frac, bits)
    lo, hi = 0, sensor.n_nodes + abs(prev)
    while lo < hi:
        mid = (lo + hi) // 2
        if _candidate_in(sensor, state, prev - mid, prev + mid, level):
            hi = mid
        else:
            lo = mid + 1
    for node in (prev - lo, prev + lo):
        if 0 <= node < sensor.n_nodes and _candidate_in(sensor, state, node, node, level):
            return node
    return min(max(prev, 0), sensor.n_nodes - 1)  # only with noise: the candidate hid


def _candidate_in(
    sensor: Sensor, state: WeightState, a: int, b: int, level: tuple[int, int, int]
) -> bool:
    """Whether a node in ``a..b`` has ``w >= top + frac 2**-bits`` (``level``; ``cand``
    keeps those nodes)."""
    dr = sensor.roles.d
    sensor.allow(False)
    at_least(sensor, state, *level)
    sensor.window(a, b)
    sensor.run(and_planes, dr.cand, dr.cand, dr.tmp_b)  # cand := cand AND window
    return bool(sensor.sim.global_or(dr.cand))


def confidence(
    sensor: Sensor, state: WeightState, top: int, a: int, b: int, bits: int = 0
) -> float:
    """``T`` minus the integer maximum outside nodes ``a .. b`` (0 when none is outside);
    with ``bits``, each refined to ``2**-bits``: ``T`` by the detection's fraction
    (``state.top_fraction``), the outside maximum by as many steps of a fraction search
    over the same nodes (:func:`outside_fraction`)."""
    if a <= 0 and b >= sensor.n_nodes - 1:
        return 0.0
    with sensor.stage("confidence"):
        out = outside_max(sensor, state, a, b, top)
        if out is None:
            return 0.0
        frac = outside_fraction(sensor, state, out, bits)
    return float(top - out) + (state.top_fraction - frac) / 2**bits


def outside_max(sensor: Sensor, state: WeightState, a: int, b: int, top: int) -> int | None:
    """Largest integer threshold in [-127, ``top``] met by a node outside ``a..b``."""
    sensor.window(a, b)
    sensor.allow(True)
    gap = state.last_gap
    out = max_threshold(sensor, state, -127, top, None if gap is None else top - gap)
    state.last_gap = None if out is None else top - out
    return out


def outside_fraction(sensor: Sensor, state: WeightState, out: int, bits: int) -> int:
    """After :func:`outside_max` found ``out`` (its mask of the outside nodes still in
    ``tmp_a``): the largest ``j < 2**bits`` with an outside node at ``w >= out + j
    2**-bits`` (0 without ``bits``)."""
    return max_fraction(sensor, state, out, bits) if bits else 0
