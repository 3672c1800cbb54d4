"""Chains of neighbour moves, composed into one pass (the compiled engine's first tier).

A shift by several elements is spelt on SCAMP-5 as a chain of one-element moves, each an
ICW: ``mov2x(F, F, east, east)`` is ``bus(XW, F); bus(F, XE)``, and the on-sensor
programs' in-block sums move a plane by up to 16 elements that way. Each move reads what
the one before wrote: a push (``bus(XW, F)``: NEWS gets its neighbour's ``-F``) feeds a
read (``bus(F, XE)``: F gets ``-`` its neighbour's NEWS), which feeds the next push. Run
ICW by ICW that is one pass over the plane per element moved.

In ideal mode with FLAG set everywhere every step is a fixed function of one value (the
push ``clip(-x)``, the read ``clip(-(0 + x))``) at a fixed offset, so the chain's result at
element ``p`` is the composed function of the source at ``p`` plus the chain's offset,
unless the path from ``p`` back to the source leaves the array: then the value is fixed by
the last step whose neighbour lies beyond the edge (a push there delivers 0, a read of
nothing gives ``clip(-0) = -0.0``) and the steps after it, a constant per column (or per
row) computed here once. So the engine writes each plane the chain leaves (its last
write, unless a later ICW overwrites it unread) in one pass, bit for bit what the ICWs
one by one leave; under a partial FLAG it runs them one by one.

With noise each step adds its own gain, cell offsets and noise window at the position it
writes, so nothing composes: the engine still runs every step's arithmetic, but band by
band of rows, the planes between the steps in buffers that stay in the first-level
cache, and only the planes the chain leaves are stored (``compiled._noisy_chain``).

Chains run along one axis (a move of the other axis ends one), so a row of the result
reads one row of the source.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from ppaloc.sim.isa import Instruction

__all__ = ["Chain", "compose", "find", "tables"]

_F32 = np.float32
#: Longest chain composed as one (a longer run of moves is composed in pieces; this
#: bounds the work of the edge tables, made when a kernel is encoded).
MAX_STEPS = 64


@dataclass(frozen=True)
class Chain:
    """ICWs ``[start, start + len(steps))`` of a kernel, composed.

    ``steps``: per step (read?, offset along the axis); ``axis`` 1 for a row chain (east
    or west moves), 0 for a column chain; ``source`` the plane step 1 reads; ``outputs``
    (plane, steps applied) of every plane the chain leaves written (by :func:`compose`:
    of those a later ICW may read).
    """

    start: int
    steps: tuple[tuple[bool, int], ...]
    axis: int
    source: int
    outputs: tuple[tuple[int, int], ...]


def _move(ins: Instruction) -> tuple[bool, tuple[int, int], int, int] | None:
    """(read?, offset of the element read, source plane, destination plane) of a one-step
    neighbour move, else None. A read ``bus(y, XE)`` reads the east neighbour's NEWS; a
    push ``bus(XW, x)`` gives every NEWS the ``-x`` of its east neighbour."""
    if ins.op != "bus" or len(ins.dsts) != 1 or len(ins.srcs) != 1:
        return None
    (dst,), (src,) = ins.dsts, ins.srcs
    if src.role == "neighbour" and dst.role != "neighbour" and dst.kind == "analog":
        return True, src.direction.offset, src.index, dst.index
    if dst.role == "neighbour" and src.role != "neighbour" and src.kind == "analog":
        dr, dc = dst.direction.offset
        return False, (-dr, -dc), src.index, dst.index
    return None


def find(instructions: list[Instruction], skipped: set[int]) -> list[Chain]:
    """The kernel's chains of two or more linked moves along one axis (``skipped``: ICWs
    the engine does not run, which end a chain)."""
    moves = [None if n in skipped else _move(ins) for n, ins in enumerate(instructions)]
    chains = []
    n = 0
    while n < len(moves):
        first = moves[n]
        if first is None:
            n += 1
            continue
        axis = 1 if first[1][0] == 0 else 0
        end = n + 1
        while end < len(moves) and end - n < MAX_STEPS:
            m, prev = moves[end], moves[end - 1]
            # linked: reads what the step before wrote, and moves along the same axis
            if m is None or m[2] != prev[3] or m[0] == prev[0] or m[1][1 - axis] != 0:
                break
            end += 1
        if end - n >= 2:
            run = moves[n:end]
            last = {m[3]: k + 1 for k, m in enumerate(run)}  # plane -> steps applied
            chains.append(
                Chain(
                    start=n,
                    steps=tuple((m[0], m[1][axis]) for m in run),
                    axis=axis,
                    source=run[0][2],
                    outputs=tuple(last.items()),
                )
            )
        n = end
    return chains


def compose(
    instructions: list[Instruction],
    skipped: set[int],
    unread: list[set[int]],
    noisy: bool = False,
) -> list[Chain]:
    """The chains worth composing, each with the outputs a later ICW may read (not in
    ``unread`` at its last step: the planes whose value there no later ICW reads).

    In ideal mode a two-step chain whose result is its own source is left to run ICW by
    ICW: the row buffer that result needs makes it cost what its two moves do. Under
    noise (``noisy``) every step still costs its arithmetic, cell offsets and noise
    window, and the chain saves the passes over the planes between the steps: a row
    chain takes each row through its steps once for all its outputs, a column chain
    would walk each output's steps on its own (two live outputs: nearly twice its
    steps), so one with more than one output is left to run ICW by ICW.
    """
    kept = []
    for ch in find(instructions, skipped):
        gone = unread[ch.start + len(ch.steps) - 1]
        outputs = tuple((p, n) for p, n in ch.outputs if p not in gone)
        if noisy:
            if ch.axis == 1 or len(outputs) <= 1:
                kept.append(replace(ch, outputs=outputs))
        elif len(ch.steps) > 2 or ch.source not in {p for p, _ in outputs}:
            kept.append(replace(ch, outputs=outputs))
    return kept


def _step(read: bool, x: np.float32) -> np.float32:
    """One move's value, as the engine computes it (float32; saturation at every step)."""
    v = -(_F32(0.0) + x) if read else -x
    return _F32(min(max(v, _F32(-128.0)), _F32(127.0)))


def _interior(steps: tuple[tuple[bool, int], ...], n: int, size: int) -> tuple[int, int, int]:
    """(lo, hi, offset): the elements along the axis whose path back through the first
    ``n`` steps stays inside ``[0, size)``, and where their source lies (``p + offset``)."""
    suffix = np.cumsum([off for _, off in steps[:n]][::-1])  # offsets of steps n, n-1, ...
    lo = min(size, max(0, -int(suffix.min())))
    hi = min(size, size - int(suffix.max()))
    return lo, max(lo, hi), int(suffix[-1])


def _edges(steps: tuple[tuple[bool, int], ...], n: int, size: int) -> np.ndarray:
    """Per element along the axis, the value of output ``n`` where its path leaves the
    array (inside elements keep 0: the engine computes them)."""
    out = np.zeros(size, dtype=_F32)
    for p in range(size):
        q, v = p, None
        for s in range(n - 1, -1, -1):  # back from step n, to the first one outside
            read, off = steps[s]
            q += off
            if not 0 <= q < size:
                v = _F32(-0.0) if read else _F32(0.0)  # no sender: 0; a read of none: -0
                for later in steps[s + 1 : n]:
                    v = _step(later[0], v)
                break
        if v is not None:
            out[p] = v
    return out


def _form(steps: tuple[tuple[bool, int], ...], n: int) -> tuple[int, int, int]:
    """The first ``n`` steps' function of a value as (read 1?, read 2?, negate?).

    After two steps a value lies in [-127, 127] (the first saturates into [-128, 127],
    the second's negation into [-127, 127]), where each later step negates it exactly:
    steps 3..n are one negation or none. Zeros too, since reads and pushes alternate: a
    read makes a zero -0.0 (``-(0 + 0)``), which the push after it makes 0.0, which the
    next read makes -0.0 again, as a negation does.
    """
    second = steps[1][0] if n > 1 else False
    return int(steps[0][0]), int(second), max(0, n - 2) % 2


def tables(
    chains: list[Chain], rows: int, cols: int, edge_values: bool = True
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The chains as the engine's arrays: ``(heads, outputs, edges)``.

    - heads (chain, 5): source plane, axis, first output, outputs, row order (1
      upwards, -1 downwards, 0: the source is copied first);
    - outputs (output, 8): plane, steps applied, source offset, interior lo and hi,
      then :func:`_form`;
    - edges (output, max(rows, cols)): the values beyond the interior (:func:`_edges`;
      zeros unless ``edge_values``: under noise an element beyond the interior gets its
      own offsets and draws, computed as the chain runs).
    """
    heads, outs, edges = [], [], []
    width = max(rows, cols)
    for ch in chains:
        size = cols if ch.axis == 1 else rows
        offsets = []
        for plane, n in ch.outputs:
            lo, hi, off = _interior(ch.steps, n, size)
            outs.append((plane, n, off, lo, hi, *_form(ch.steps, n)))
            e = np.zeros(width, dtype=_F32)
            if edge_values:
                e[:size] = _edges(ch.steps, n, size)
            edges.append(e)
            offsets.append(off)
        order = 1
        if ch.axis == 0 and ch.source in {p for p, _ in ch.outputs}:  # rows read first
            order = 1 if min(offsets) >= 0 else -1 if max(offsets) <= 0 else 0
        heads.append((ch.source, ch.axis, len(outs) - len(offsets), len(offsets), order))
    return (
        np.array(heads, dtype=np.int64).reshape(-1, 5),
        np.array(outs, dtype=np.int64).reshape(-1, 8),
        np.array(edges, dtype=_F32).reshape(-1, width),
    )
