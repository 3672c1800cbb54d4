"""The compiled engine's second tier: a kernel run often becomes generated, fused loops.

The first tier (:mod:`ppaloc.sim.engines.compiled`) runs one ICW at a time, one pass over
the plane each: on this kind of machine a pass costs about as much in loads, stores and
saturation as the ICW's arithmetic, so a 6-ICW macro sequence costs six passes. Here a
run of ICWs is cut into *passes* (:func:`plan`) and each pass becomes one loop over the
elements in generated Python source (:func:`source`), compiled by numba: every ICW of
the pass works on values held in machine registers, a plane is loaded once and stored
once, intermediate values of a scratch plane never reach memory.

An ICW with a neighbour term takes it from the planes as they are when its pass starts:
a read of the neighbours' NEWS (0 from an unflagged neighbour; beyond the edge -0.0,
which adds nothing, as "no term" does) or a push (the sender's value, 0 from an
unflagged or missing sender). So such an ICW starts a new pass when the pass has already
written what its term reads (NEWS, a pushed source, or FLAG). Everything else in a pass
is element-wise and exact: the same float32 operations in the same order as the
reference engine, noise draws at the same indices, so results are the same bytes.

Consecutive passes run together as a *group* (:func:`groups`), row by row in one loop,
each pass a row behind the one before (:func:`_group`): a term's row is made as soon as
the rows it comes from are as its pass starts them, and kept in one of three slots, so
the rows a group works on stay in the first-level cache from its first pass to its last,
and a plane that a later pass of the group overwrites unread is not stored at all.
Generated modules are kept in a cache folder (:func:`cache_folder`) with numba's own
cache beside them, so a stretch is compiled once per machine; each is named by the hash
of its source (which holds the hash of the helpers it calls). Compiling takes seconds per
stretch, so the engine has it done by another process (:class:`Background`, this
module run as ``python -m``) while its first tier goes on.
"""

from __future__ import annotations

import atexit
import hashlib
import importlib.util
import json
import logging
import math
import os
import re
import subprocess
import sys
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numba
import numpy as np

from ppaloc.fileio import user_cache, write_bytes
from ppaloc.sim.engines.compiled import _NO_RUNTIME, _all_set, _clip, _inline
from ppaloc.sim.isa import Instruction
from ppaloc.sim.registers import FLAG, NEWS, PIX, R0, R12

__all__ = [
    "FUSABLE", "Background", "Pass", "background", "cache_folder", "cached", "compile_here",
    "draws", "failed", "fusable", "groups", "load", "mark_cached", "plan", "scratch_planes",
    "source",
]  # fmt: skip

log = logging.getLogger(__name__)

_TRANSFERS = ("bus", "bus2", "bus3", "busn", "sq")
#: ICWs a pass can hold (the others end it and run on the first tier).
FUSABLE = frozenset(
    (*_TRANSFERS, "nop", "blurset", "rpix", "where", "all", "SET", "CLR", "MOV", "NOT",
     "OR", "NOR", "WHERE", "LATCH", "LATCHN", "UNLATCH", "PROP_R")
)  # fmt: skip
_F, _NEWS, _PIX, _R0, _R12 = FLAG.index, NEWS.index, PIX.index, R0.index, R12.index

#: What generated modules use: their decorator (cached on disk; in memory without a cache
#: folder), the saturation and the FLAG test of the first tier.
JIT = numba.njit(cache=True, nogil=True, boundscheck=False, **_NO_RUNTIME)
JIT_IN_MEMORY = numba.njit(nogil=True, boundscheck=False, **_NO_RUNTIME)
clip = _clip
all_ones = _all_set
# the helpers' version, in every generated module: numba's cache of a module does not see
# a change in the functions it calls, so a new version of them must give new modules
_RUNTIME = hashlib.sha256(
    Path(__file__).read_bytes() + Path(_clip.py_func.__code__.co_filename).read_bytes()
).hexdigest()[:16]


@_inline
def clip_hi(v):
    """The upper half of the saturation (a value that cannot fall below -128)."""
    hi = np.float32(127.0)
    return hi if v > hi else v


@_inline
def clip_lo(v):
    """The lower half of the saturation (a value that cannot rise above 127)."""
    lo = np.float32(-128.0)
    return lo if v < lo else v


def draws(ins: Instruction, noisy: bool) -> int:
    """Noise draws of one ICW: one per analogue destination of a transfer, one per where."""
    if not noisy:
        return 0
    if ins.op in _TRANSFERS:
        return len(ins.dsts)
    return 1 if ins.op == "where" else 0


def _parts(ins: Instruction) -> int:
    if ins.op in ("bus2", "bus3", "busn"):
        return len(ins.dsts)
    return 1


@dataclass
class Pass:
    """ICWs run as one loop: ``icws`` as (index in the run, ICW), pre-steps as
    (kind, ICW index, register) with kind "read" (a neighbour source) or "push"."""

    icws: list[tuple[int, Instruction]] = field(default_factory=list)
    pre: list[tuple[str, int, object]] = field(default_factory=list)
    written_a: set[int] = field(default_factory=set)
    written_d: set[int] = field(default_factory=set)

    def admits(self, ins: Instruction) -> bool:
        """Whether ``ins``'s neighbour terms can be taken from the state at the pass's start."""
        nbr_src = any(s.role == "neighbour" for s in ins.srcs)
        pushed = any(d.role == "neighbour" for d in ins.dsts)
        if not (nbr_src or pushed):
            return True
        if _F in self.written_d:
            return False
        if nbr_src and _NEWS in self.written_a:
            return False
        return not (pushed and any(s.index in self.written_a for s in ins.srcs))

    def add(self, n: int, ins: Instruction) -> None:
        for s in ins.srcs:
            if s.role == "neighbour":
                self.pre.append(("read", n, s))
        for d in ins.dsts:
            if d.role == "neighbour":
                self.pre.append(("push", n, d))
        self.icws.append((n, ins))
        for d in ins.dsts:
            (self.written_a if d.kind == "analog" else self.written_d).add(d.index)
        if ins.op in ("where", "all", "WHERE"):
            self.written_d.add(_F)
        if ins.op == "rpix":
            self.written_a.add(_PIX)

    def flag_read_first(self) -> bool:
        """Whether the loop reads FLAG before any ICW of the pass writes it."""
        for _, ins in self.icws:
            if ins.op in _TRANSFERS or any(s.index == _F and s.kind == "digital" for s in ins.srcs):
                return True
            if ins.op in ("where", "all", "WHERE"):
                return False
        return False


def fusable(ins: Instruction) -> bool:
    """Whether ``ins`` can be part of a pass."""
    if ins.op not in FUSABLE:
        return False
    if any(d.role == "neighbour" for d in ins.dsts):  # a push: of up to 4 local sources
        return len(ins.srcs) <= 4 and all(s.role != "neighbour" for s in ins.srcs)
    return True


_ANALOGUE = frozenset((*_TRANSFERS, "where", "rpix"))
_NEUTRAL = frozenset(("nop", "blurset", "all"))


def _side(ins: Instruction) -> str | None:
    """Which side an ICW works on: "a" analogue, "d" digital, None neither."""
    if ins.op in _NEUTRAL:
        return None
    return "a" if ins.op in _ANALOGUE else "d"


def plan(instructions: list[Instruction]) -> list[Pass]:
    """Cut a run of fusable ICWs into passes (see the module's docstring); a pass also
    ends where the ICWs turn from analogue to digital or back: a loop of float32 and one
    of byte planes each vectorise, a loop of both much less well."""
    passes = [Pass()]
    side = None
    for n, ins in enumerate(instructions):
        if not fusable(ins):
            raise ValueError(f"{ins} cannot be fused")
        now = _side(ins)
        turn = now is not None and side is not None and now != side
        if turn or not passes[-1].admits(ins):
            passes.append(Pass())
        side = now or side
        passes[-1].add(n, ins)
    return passes


# ---------------------------------------------------------------------------- codegen
_HEADER = '''"""Generated by ppaloc.sim.engines.fused: {what}."""
# runtime {runtime}
import numpy as np
from ppaloc.sim.engines.fused import {jit} as JIT
from ppaloc.sim.engines.fused import all_ones, clip, clip_hi, clip_lo

F0 = np.float32(0.0)
NZ = np.float32(-0.0)
MH = np.float32(-0.5)
'''


class _Writer:
    def __init__(self) -> None:
        self.lines: list[str] = []

    def __call__(self, depth: int, text: str) -> None:
        self.lines.append("    " * depth + text)


Range = tuple[float, float]
_INSIDE: Range = (-128.0, 127.0)
_ANY: Range = (-math.inf, math.inf)


def _plane_range(x: int) -> Range:
    """What a plane holds: A-F and NEWS only ever hold saturated values (every write to
    them saturates, droop moves towards 0); PIX and IN are not assumed."""
    return _INSIDE if x <= _NEWS else _ANY


def _saturate(expr: str, r: Range) -> tuple[str, Range]:
    """``expr`` saturated to [-128, 127], with only the bounds its range can cross."""
    lo_ok, hi_ok = r[0] >= -128.0, r[1] <= 127.0
    out = (min(max(r[0], -128.0), 127.0), max(min(r[1], 127.0), -128.0))
    if lo_ok and hi_ok:
        return expr, r
    if lo_ok:
        return f"clip_hi({expr})", out
    if hi_ok:
        return f"clip_lo({expr})", out
    return f"clip({expr})", out


def _bus(expr: str, r: Range, parts: int) -> tuple[str, Range]:
    """The ideal bus value of a sum ``expr`` with range ``r``: -(sum) / parts, saturated."""
    if parts == 1:
        return _saturate(f"-{expr}", (-r[1], -r[0]))
    if parts == 2:
        return _saturate(f"{expr} * MH", (r[1] * -0.5, r[0] * -0.5))
    return _saturate(f"{expr} / M{parts}", (r[1] / -parts, r[0] / -parts))


def _sum(local: list[tuple[str, Range]], far: list[tuple[str, Range]]) -> tuple[str, Range]:
    """Local terms left to right, then neighbour terms, as the reference adds them: from
    the first local term, or from 0 when there is none (0 + -0.0 is 0)."""
    terms = [*local[1:], *far]
    expr, r = local[0] if local else ("F0", (0.0, 0.0))
    for t, tr in terms:
        expr, r = f"({expr} + {t})", (r[0] + tr[0], r[1] + tr[1])
    return expr, r


class _Names:
    """Single-assignment names of the values in one loop body (numba types and lowers a
    long body of fresh names much faster than one of reassigned ones)."""

    def __init__(self) -> None:
        self.now: dict[str, str] = {}
        self.count = 0

    def new(self, key: str) -> str:
        self.count += 1
        self.now[key] = name = f"{key}_{self.count}"
        return name

    def __getitem__(self, key: str) -> str:
        return self.now[key]


def _body(w: _Writer, depth: int, ps: Pass, draw_of: dict[int, int], noisy: bool, n: int,
          everywhere: bool, v: _Names, term: Callable[[int], str]) -> None:  # fmt: skip
    """The loop body of one pass: every ICW on register-held values, in order.
    ``term(k)`` is the element's value of the pass's ``k``-th neighbour term.

    ``everywhere``: FLAG is set everywhere at the start (until an ICW of the pass writes
    it), so writes need no mask. Each analogue value's range is followed through the
    pass, so a saturation is written only where the value can leave [-128, 127].
    """
    pre_of = {(kind, i, id(r)): k for k, (kind, i, r) in enumerate(ps.pre)}
    ranges: dict[int, Range] = {x: _plane_range(x) for x in range(_NEWS + 3)}
    masked = not everywhere
    flag = f"d{_F}"

    def assign(x: int, val: str, r: Range) -> None:
        key = f"a{x}"
        if masked:  # the value first (loads outside the select, so that it vectorises)
            old_name, old = v[key], ranges[x]
            new = v.new("w")
            w(depth, f"{new} = {val}")
            w(depth, f"{v.new(key)} = {new} if {v[flag]} else {old_name}")
            ranges[x] = (min(old[0], r[0]), max(old[1], r[1]))
        else:
            w(depth, f"{v.new(key)} = {val}")
            ranges[x] = r

    def store_d(x: int, value: str) -> None:
        """A digital write (R12 keeps its value where R0 is 0)."""
        key = f"d{x}"
        if x == _R12:
            old = v[key]
            w(depth, f"{v.new(key)} = np.uint8({value}) if {v[f'd{_R0}']} else {old}")
        else:
            w(depth, f"{v.new(key)} = np.uint8({value})")

    def ors(srcs: tuple) -> str:
        return " | ".join(v[f"d{s.index}"] for s in srcs)

    for i, ins in ps.icws:
        op, b = ins.op, draw_of[i]
        if op in ("nop", "blurset"):
            continue
        if op == "rpix":
            w(depth, f"{v.new(f'a{_PIX}')} = PX[p]")
            ranges[_PIX] = _ANY
        elif op in _TRANSFERS or op == "where":
            local = [(v[f"a{s.index}"], ranges[s.index]) for s in ins.srcs
                     if s.role != "neighbour"]  # fmt: skip
            far = [
                (term(pre_of[("read", i, id(s))]), _INSIDE)
                for s in ins.srcs
                if s.role == "neighbour"
            ]  # fmt: skip  (a neighbour's NEWS, 0 or -0.0)
            expr, r = _sum(local, far)
            total = v.new("t")
            w(depth, f"{total} = {expr}")
            if op == "where":
                cond = f"({total} + bk{b}[p]) > F0" if noisy else f"{total} > F0"
                w(depth, f"{v.new(flag)} = np.uint8({cond})")
                masked = True
                continue
            value = v.new("v")
            if noisy:
                w(depth, f"{value} = {total} * sc{i}")
                vr = _ANY
            else:
                expr, vr = _bus(total, r, _parts(ins))
                w(depth, f"{value} = {expr}")
            for k, dst in enumerate(ins.dsts):
                if dst.role == "neighbour":  # the sender's value, from the pre-step
                    val, dr = term(pre_of[("push", i, id(dst))]), _INSIDE
                else:
                    val, dr = value, vr
                if noisy:
                    val = f"clip(({val} + OFF[{dst.index * n} + p]) + bk{b + k}[p])"
                    dr = _INSIDE
                assign(dst.index, val, dr)
        elif op == "all":
            w(depth, f"{v.new(flag)} = np.uint8(1)")
            masked = False
        elif op in ("SET", "CLR"):
            value = "1" if op == "SET" else "0"
            for x in sorted((d.index for d in ins.dsts), key=lambda x: x != _R12):  # R12 first
                store_d(x, value)
        elif op == "MOV":
            store_d(ins.dsts[0].index, v[f"d{ins.srcs[0].index}"])
        elif op in ("NOT", "NOR", "OR"):
            u = v.new("u")
            w(depth, f"{u} = ({ors(ins.srcs)})" + ("" if op == "OR" else " ^ 1"))
            store_d(ins.dsts[0].index, u)
        elif op == "WHERE":
            value = ors(ins.srcs)  # before FLAG's new name: FLAG may be a source
            w(depth, f"{v.new(flag)} = np.uint8({value})")
            masked = True
        elif op in ("LATCH", "PROP_R", "LATCHN"):
            flip = " ^ 1" if op == "LATCHN" else ""
            w(depth, f"{v.new('lt')} = np.uint8(({ors(ins.srcs)}){flip})")
        elif op == "UNLATCH":
            store_d(ins.dsts[0].index, v["lt"])
        else:  # pragma: no cover - FUSABLE and this list agree
            raise AssertionError(op)


def _loop(w: _Writer, depth: int, ps: Pass, draw_of: dict[int, int], noisy: bool, n: int,
          everywhere: bool, tag: str, row: tuple[str, str, int] | None = None,
          term: Callable[[int], str] | None = None,
          unstored: frozenset[int] = frozenset()) -> None:  # fmt: skip
    """One pass's loop: load what it touches, run the body, store what it wrote. Its loop
    counter and flag test are named by ``tag``, so that no name is assigned twice.

    Over all elements by default; over one row when ``row`` is (the row's first element,
    its first in T, its length), through views that start there (an index that cannot be
    negative needs no wraparound test, so the loop vectorises); the flag test is then the
    caller's. Analogue planes in ``unstored`` are not stored (a later pass overwrites
    them before anything reads them)."""
    inner = _Writer()
    term = term or (lambda k: f"T[{k * n} + p]")
    count = n if row is None else row[2]
    _loop_lines(inner, depth, ps, draw_of, noisy, n, count, everywhere, row is not None, term,
                unstored)  # fmt: skip
    lines = [re.sub(r"\b(p|acc)\b", rf"\g<1>{tag}", line) for line in inner.lines]
    if row is not None:
        names: dict[str, None] = {}
        view = re.compile(r"\b(A|D|L|PX|OFF|T|bk\d+)\[")
        lines = [view.sub(lambda m: names.setdefault(m[1]) or f"{m[1]}{tag}[", x) for x in lines]
        for x in names:
            w(depth, f"{x}{tag} = {x}[{row[1] if x == 'T' else row[0]}:]")
    w.lines.extend(lines)


def _loop_lines(w: _Writer, depth: int, ps: Pass, draw_of: dict[int, int], noisy: bool,
                n: int, count: int, everywhere: bool, by_row: bool,
                term: Callable[[int], str], unstored: frozenset[int]) -> None:  # fmt: skip
    a_set, d_set, lread, lwrite = _touched(ps)
    flag_written = _F in ps.written_d
    v = _Names()
    if flag_written and not by_row:
        w(depth, "acc = True")
    w(depth, f"for p in range({count}):")
    for x in sorted(a_set):
        w(depth + 1, f"{v.new(f'a{x}')} = A[{x * n} + p]")
    for x in sorted(d_set):
        value = "np.uint8(1)" if x == _F and everywhere else f"D[{x * n} + p]"
        w(depth + 1, f"{v.new(f'd{x}')} = {value}")
    if lread:
        w(depth + 1, f"{v.new('lt')} = L[p]")
    _body(w, depth + 1, ps, draw_of, noisy, n, everywhere, v, term)
    for x in sorted(ps.written_a - unstored):
        w(depth + 1, f"A[{x * n} + p] = {v[f'a{x}']}")
    for x in sorted(ps.written_d):
        w(depth + 1, f"D[{x * n} + p] = {v[f'd{x}']}")
    if lwrite:
        w(depth + 1, f"L[p] = {v['lt']}")
    if flag_written:
        w(depth + 1, f"acc = acc & ({v[f'd{_F}']} != 0)")
        if not by_row:
            w(depth, "fa = acc")


def _touched(ps: Pass) -> tuple[set[int], set[int], bool, bool]:
    """(analogue planes, digital planes, latch read, latch written) of a pass."""
    a, d = set(), set()
    lread = lwrite = False
    for _, ins in ps.icws:
        for r in (*ins.srcs, *ins.dsts):
            if r.role == "neighbour":
                continue
            (a if r.kind == "analog" else d).add(r.index)
        if ins.op in _TRANSFERS or ins.op == "where":
            d.add(_F)
            a.update(x.index for x in ins.dsts if x.role == "neighbour")
        if ins.op in ("all", "WHERE"):
            d.add(_F)
        if ins.op == "UNLATCH":
            lread = True
        if ins.op in ("LATCH", "LATCHN", "PROP_R"):
            lwrite = True
        if any(x.index == _R12 for x in ins.dsts):
            d.add(_R0)
    return a | ps.written_a, d | ps.written_d, lread, lwrite


#: Rows of each neighbour term a group keeps (its rows r - 1, r, r + 1 around the row r
#: that a pass works on; see :func:`_group`).
SLOTS = 3
#: Passes at most in one group (bounds the generated function's length, so its compile time).
GROUP_PASSES = 8


def groups(passes: list[Pass]) -> list[list[Pass]]:
    """Consecutive passes run row by row in one loop (:func:`_group`): a group ends after a
    pass that writes FLAG, since whether FLAG is set everywhere, known at a group's start,
    chooses the code of the passes after it; and after :data:`GROUP_PASSES` passes."""
    out: list[list[Pass]] = [[]]
    for ps in passes:
        if len(out[-1]) == GROUP_PASSES:
            out.append([])
        out[-1].append(ps)
        if _F in ps.written_d:
            out.append([])
    return [g for g in out if g]


def scratch_planes(instructions: list[Instruction], rows: int) -> int:
    """Scratch planes (of ``rows`` rows) the fused code of ``instructions`` needs, at
    least 1: :data:`SLOTS` rows for each neighbour term of a group."""
    terms = max(sum(len(ps.pre) for ps in g) for g in groups(plan(instructions)))
    return max(1, -(-terms * SLOTS // rows))


def _by_rows(group: list[Pass]) -> bool:
    return len(group) > 1 or bool(group[0].pre)


def _capture(w: _Writer, depth: int, k: int, kind: str, ins: Instruction, reg, rows: int,
             cols: int, noisy: bool, sc: str, q: str, flagged: bool, tag: str) -> None:  # fmt: skip
    """Term ``k``'s row fed by row ``q`` of the planes as they are now (``flagged``: FLAG
    is set everywhere), in T's slot of that row.

    A read: row ``q - dr`` takes each element's neighbour (r + dr, c + dc) NEWS where that
    neighbour is flagged, 0 where it is not, -0.0 beyond the edge (adding it leaves a sum
    as it is). A push: row ``q + dr`` takes the value pushed by each element's sender
    (r - dr, c - dc), the sum of the ICW's sources there as the bus makes it (saturated
    when ideal, times the ICW's gain when noisy), 0 where the sender is unflagged or beyond
    the edge. The row no row feeds (at the edge) is filled when ``q`` is that edge row.
    Every index is a loop counter from 0 on a view, so the loops vectorise.
    """
    n = rows * cols
    dr, dc = reg.direction.offset
    read = kind == "read"
    step = -dr if read else dr  # the row fed is q + step
    col = -dc if read else dc  # ... at column c + col, from column c
    lo, hi = max(0, col), min(cols, cols + col)  # the columns fed
    none = "NZ" if read else "F0"
    c = f"c{k}{tag}"
    base = k * SLOTS * cols
    if dr != 0:  # the edge row: nothing feeds it
        edge = rows - 1 if step < 0 else 0
        w(depth, f"if {q} == {edge}:")
        w(depth + 1, f"for {c} in range({cols}):")
        w(depth + 2, f"T[{base + edge % SLOTS * cols} + {c}] = {none}")
    fed = f"{q} + {step}" if step else q
    if step:
        w(depth, f"if {fed} >= 0 and {fed} < {rows}:")
        depth += 1
    out = f"t{k}{tag}"
    w(depth, f"{out} = T[{base} + ({fed}) % {SLOTS} * {cols} :]")
    for x in [*range(0, lo), *range(hi, cols)]:
        w(depth, f"{out}[{x}] = {none}")
    src = f"{q} * {cols} + {lo - col}"  # the first column that feeds
    names = [f"f{k}{tag}"]
    if not flagged:
        w(depth, f"{names[0]} = D[{_F * n} + {src} :]")
    if read:
        w(depth, f"x{k}{tag} = A[{_NEWS * n} + {src} :]")
        value = f"x{k}{tag}[{c}]"
    else:
        terms = []
        for j, s in enumerate(ins.srcs):
            w(depth, f"x{k}_{j}{tag} = A[{s.index * n} + {src} :]")
            terms.append(f"x{k}_{j}{tag}[{c}]")
        total = terms[0] if terms else "F0"
        for term in terms[1:]:
            total = f"({total} + {term})"
        parts = _parts(ins)
        if noisy:
            value = f"{total} * {sc}"
        elif parts == 1:
            value = f"clip(-{total})"
        elif parts == 2:
            value = f"clip({total} * MH)"
        else:
            value = f"clip({total} / M{parts})"
    if not flagged:
        value = f"{value} if {names[0]}[{c}] else F0"
    w(depth, f"for {c} in range({hi - lo}):")
    w(depth + 1, f"{out}[{lo} + {c}] = {value}")


def _first_access(ps: Pass, x: int, everywhere: bool) -> str | None:
    """How a pass's body first meets analogue plane ``x``: "read" (a masked write keeps
    the old value, so it reads it too), "write" (the whole plane overwritten), or None."""
    masked = not everywhere
    for _, ins in ps.icws:
        local = {s.index for s in ins.srcs if s.kind == "analog" and s.role != "neighbour"}
        if x in local:
            return "read"
        if ins.op in ("where", "WHERE"):
            masked = True
            continue
        if ins.op == "all":
            masked = False
        written = {d.index for d in ins.dsts if d.kind == "analog"}
        if ins.op == "rpix":
            written.add(_PIX)
        if x in written:
            return "read" if masked else "write"
    return None


def _captured(ps: Pass) -> set[int]:
    """The analogue planes the rows of a pass's neighbour terms are made from."""
    out: set[int] = set()
    for kind, i, _ in ps.pre:
        ins = dict(ps.icws)[i]
        if kind == "read":
            out.add(_NEWS)
        else:
            out.update(s.index for s in ins.srcs if s.role != "neighbour")
    return out


def _unstored(group: list[Pass], flagged: list[bool]) -> list[frozenset[int]]:
    """Per pass of a group, the analogue planes it writes that a later pass of the group
    overwrites before anything reads them (``flagged``: whether each pass runs with FLAG
    set everywhere, so that its writes are whole): those need not be stored."""
    out = []
    for s, ps in enumerate(group):
        dead = set()
        for x in ps.written_a:
            for u in range(s + 1, len(group)):
                if x in _captured(group[u]):
                    break
                access = _first_access(group[u], x, flagged[u])
                if access == "read":
                    break
                if access == "write":
                    dead.add(x)
                    break
        out.append(frozenset(dead))
    return out


def _group(w: _Writer, depth: int, group: list[Pass], first: int, draw_of: dict[int, int],
           noisy: bool, rows: int, cols: int, everywhere: bool, tag: str) -> None:  # fmt: skip
    """Passes ``first``, ``first + 1``, ... as one loop over rows, a wavefront: in step
    ``i`` pass ``s`` works on row ``i - 1 - s``. When a pass has done row ``q``, the rows
    of the next pass's neighbour terms that row ``q`` feeds are made from it (the planes'
    row ``q`` is then as the next pass starts it; rows below are not yet). A term's row
    ``r`` needs rows ``r - 1`` to ``r + 1``, done by the step in which the next pass
    reaches ``r``; so each term keeps :data:`SLOTS` rows, and the rows a group works on
    stay in the caches from the first pass to the last."""
    n = rows * cols
    starts = [sum(len(ps.pre) for ps in group[:s]) for s in range(len(group))]
    flag_last = _F in group[-1].written_d
    if flag_last:
        w(depth, f"acc{tag} = True")

    def captures(s: int, q: str, d: int) -> None:
        ps = group[s]
        for j, (kind, i, reg) in enumerate(ps.pre):
            _capture(w, d, starts[s] + j, kind, dict(ps.icws)[i], reg, rows, cols, noisy,
                     f"sc{i}", q, everywhere, tag)  # fmt: skip

    flagged = [everywhere and ps.flag_read_first() for ps in group]
    unstored = _unstored(group, flagged)
    w(depth, f"for i{tag} in range({rows + len(group)}):")
    if group[0].pre:
        w(depth + 1, f"if i{tag} < {rows}:")
        captures(0, f"i{tag}", depth + 2)
    for s, ps in enumerate(group):
        number = f"{first + s}{tag}"
        r = f"r{number}"
        w(depth + 1, f"{r} = i{tag} - {s + 1}")
        w(depth + 1, f"if {r} >= 0 and {r} < {rows}:")

        def term(k: int, s: int = s) -> str:
            return f"T[{(starts[s] + k) * SLOTS * cols} + p]"

        sub = _Writer()
        _loop(sub, depth + 2, ps, draw_of, noisy, n, flagged[s], f"_{number}",
              (f"{r} * {cols}", f"{r} % {SLOTS} * {cols}", cols), term, unstored[s])  # fmt: skip
        w.lines.extend(line.replace(f"acc_{number}", f"acc{tag}") for line in sub.lines)
        if s + 1 < len(group):
            captures(s + 1, r, depth + 2)
    if flag_last:
        w(depth, f"fa = acc{tag}")


_ARGS = "A, D, L, T, OFF, PX, BK, BD, starts, gains, fa"


def source(instructions: list[Instruction], rows: int, cols: int, noisy: bool) -> str:
    """The generated module of one run of fusable ICWs: ``run(...)`` performs them and
    returns whether FLAG is set everywhere at its end. Each pass is a function of its own
    (numba compiles several small functions much faster than one long one)."""
    n = rows * cols
    passes = plan(instructions)
    draw_of, m = {}, 0
    for i, ins in enumerate(instructions):
        draw_of[i] = m
        m += draws(ins, noisy)
    w = _Writer()
    what = f"{len(instructions)} ICWs, {len(passes)} passes, {rows}x{cols}"
    w(0, _HEADER.format(what=what, jit="JIT", runtime=_RUNTIME))
    for parts in sorted({_parts(ins) for ins in instructions if _parts(ins) > 2}):
        w(0, f"M{parts} = np.float32({-parts})")
    w(0, "")
    w(0, "")
    w(0, "@JIT")
    w(0, "def run(a, d, latch, scratch, offsets, pixel, bank, bank_div, starts, gains, known):")
    w(1, "A = a.reshape(a.size)")
    w(1, "D = d.view(np.uint8).reshape(d.size)")
    w(1, "L = latch.view(np.uint8).reshape(latch.size)")
    w(1, "T = scratch.reshape(scratch.size)")
    w(1, "OFF = offsets.reshape(offsets.size)")
    w(1, "PX = pixel.reshape(pixel.size)")
    w(1, "BK, BD = bank, bank_div")
    w(1, f"fa = known or all_ones(D[{_F * n}:{(_F + 1) * n}])")
    number = 0
    for g, group in enumerate(groups(passes)):
        first, number = number, number + len(group)
        if not any(any(_touched(ps)) for ps in group):  # only nops: no loop (its body
            continue  # would be empty)
        for ps in group:
            for i, ins in ps.icws:
                if noisy:
                    bank = "BK" if _parts(ins) == 1 or ins.op == "where" else "BD"
                    for k in range(draws(ins, noisy)):
                        j = draw_of[i] + k
                        w(1, f"bk{j} = {bank}[starts[{j}] : starts[{j}] + {n}]")
                    if ins.op in _TRANSFERS:
                        w(1, f"sc{i} = np.float32(gains[{draw_of[i]}] / {_parts(ins)})")
        ps = group[0]
        if not _by_rows(group):  # one pass, no neighbour terms: one loop
            if ps.flag_read_first():  # a variant for FLAG set everywhere: no masks, no loads
                w(1, "if fa:")
                _loop(w, 2, ps, draw_of, noisy, n, True, f"_{first}a")
                w(1, "else:")
                _loop(w, 2, ps, draw_of, noisy, n, False, f"_{first}b")
            else:
                _loop(w, 1, ps, draw_of, noisy, n, False, f"_{first}")
        elif any(ps.flag_read_first() for ps in group):
            w(1, "if fa:")
            _group(w, 2, group, first, draw_of, noisy, rows, cols, True, f"g{g}a")
            w(1, "else:")
            _group(w, 2, group, first, draw_of, noisy, rows, cols, False, f"g{g}b")
        else:
            _group(w, 1, group, first, draw_of, noisy, rows, cols, False, f"g{g}")
    w(1, "return fa")
    return "\n".join(w.lines) + "\n"


# ------------------------------------------------------------------------------ loading
def cache_folder() -> Path:
    """Where generated modules and their numba cache live: ``$PPALOC_KERNEL_CACHE``, else
    ``~/.cache/ppaloc/kernels`` (under ``$XDG_CACHE_HOME`` when set)."""
    return user_cache("kernels", "PPALOC_KERNEL_CACHE")


def _name(text: str) -> str:
    return f"ppaloc_fused_{hashlib.sha256(text.encode()).hexdigest()[:24]}"


def cached(text: str) -> bool:
    """Whether the module ``text`` has been compiled and run on this machine before (its
    machine code is then in numba's cache beside it)."""
    return (cache_folder() / f"{_name(text)}.ok").exists()


def marks(text: str) -> tuple[str, str]:
    """The files :func:`cached` and :func:`failed` look for, as text: a stretch waiting
    for its code looks every 16 runs with one ``os.path.exists`` each, not a hash of its
    text and a path built each time."""
    base = cache_folder() / _name(text)
    return f"{base}.ok", f"{base}.failed"


def mark_cached(text: str) -> None:
    """Record that the module ``text`` has been compiled (see :func:`cached`)."""
    try:
        (cache_folder() / f"{_name(text)}.ok").touch()
    except OSError:  # a folder that cannot be written: nothing is kept
        pass


def load(text: str):
    """The ``run`` function of a generated module (compiled by numba on its first call).

    The module is written (atomically) to the cache folder under the hash of its text and
    imported from there, so numba's on-disk cache keeps its machine code; where the folder
    cannot be written it is compiled in memory for this process only.
    """
    name = _name(text)
    if name in sys.modules:
        return sys.modules[name].run
    path = _module_path(text)
    if path is None:
        module = _in_memory(name, text)
    else:
        spec = importlib.util.spec_from_file_location(name, path)
        module = sys.modules[name] = importlib.util.module_from_spec(spec)
        try:
            spec.loader.exec_module(module)
        except BaseException:  # no half-made module left behind to hide the error
            del sys.modules[name]
            raise
    sys.modules[name] = module
    return module.run


def _module_path(text: str) -> Path | None:
    """The module ``text`` written to the cache folder (None where it cannot be)."""
    path = cache_folder() / f"{_name(text)}.py"
    try:
        if not path.exists() or path.read_text(encoding="utf-8") != text:
            write_bytes(path, text)
    except OSError:
        return None
    return path


class Background:
    """Compiles generated modules in a separate process, one at a time, so that a
    simulator keeps running its first tier meanwhile (compiling takes seconds per
    stretch; the second core of a machine does it). A finished module is marked as
    :func:`cached`; a process that fails marks it ``.failed`` and it is not tried again.

    No compile outlives the process that asked for it: when that process exits (or is
    killed) the running compile is stopped and the queue dropped (a stopped compile marks
    nothing, so it is asked for again the next time). The first compile of a process is
    announced (logged at INFO, ``ppaloc -v`` shows it); ``PPALOC_FUSE_AFTER=never``
    switches the tier off, and ``ppaloc warm-up`` compiles ahead, in the foreground.
    """

    def __init__(self) -> None:
        self._queue: list[tuple[str, list[str]]] = []
        self._running: subprocess.Popen | None = None
        self.started = 0
        self.stopped = 0
        self._hooked = False

    def request(self, text: str, shapes: dict[str, list[int]]) -> None:
        """Queue ``text`` for compiling with arguments of ``shapes`` (see :func:`_warm`)."""
        path = _module_path(text)
        if path is None or cached(text) or failed(text):
            return
        argv = [sys.executable, "-m", __name__, str(path), json.dumps(shapes)]
        self._queue.append((text, argv))
        self.poll()

    def poll(self) -> None:
        """Start the next queued compile when none is running."""
        if self._running is not None and self._running.poll() is None:
            return
        self._running = None
        while self._queue:
            text, argv = self._queue.pop(0)
            if not (cached(text) or failed(text)):
                if not self._hooked:
                    atexit.register(self.stop)
                    self._hooked = True
                if not self.started:
                    log.info(
                        "compiling fused kernels in a background process while the first "
                        "tier runs (PPALOC_FUSE_AFTER=never: off; `ppaloc warm-up` compiles "
                        "them ahead)"
                    )
                self._running = subprocess.Popen(
                    argv, stdin=subprocess.DEVNULL, stdout=subprocess.DEVNULL,
                    stderr=subprocess.DEVNULL, env={**os.environ, PARENT_ENV: str(os.getpid())},
                )  # fmt: skip
                self.started += 1
                return

    def drain(self, progress: Callable[[int, int], None] | None = None) -> int:
        """Compile everything queued, waiting for each process in turn (the foreground
        compile of ``ppaloc warm-up``); ``progress(done, total)`` after each. Returns how
        many compiles ran."""
        done = 0
        while True:
            if self._running is not None:
                self._running.wait()
                self._running = None
                done += 1
                if progress:
                    progress(done, done + len(self._queue))
            if not self._queue:
                return done
            self.poll()
            if self._running is None:  # the rest were cached or failed meanwhile
                self._queue.clear()
                return done

    def stop(self) -> int:
        """Stop the running compile and drop the queue; returns how many were left
        unfinished (the running one and the queued ones)."""
        left = len(self._queue)
        self._queue.clear()
        proc, self._running = self._running, None
        if proc is not None and proc.poll() is None:
            left += 1
            proc.terminate()
            try:
                proc.wait(timeout=5)
            except subprocess.TimeoutExpired:
                proc.kill()
                proc.wait()
        if left:
            self.stopped += left
            log.info("stopped %d unfinished fused-kernel compile(s) at exit", left)
        return left


#: The one background compiler of this process.
background = Background()


#: The environment variable through which a background compile learns which process
#: asked for it (it ends at once if that one has died already).
PARENT_ENV = "PPALOC_COMPILE_PARENT"


def _die_with_parent() -> None:
    """Linux: be sent SIGTERM when the process that started this one dies (even by
    SIGKILL), so no compile outlives the command that asked for it; elsewhere nothing.
    A process started by another than :data:`PARENT_ENV` names ends at once (its parent
    died before this one could ask to follow it)."""
    given = os.environ.get(PARENT_ENV, "")
    parent = int(given) if given.isdigit() else os.getppid()
    try:
        import ctypes
        import signal

        libc = ctypes.CDLL(None, use_errno=True)
        libc.prctl(1, int(signal.SIGTERM), 0, 0, 0)  # PR_SET_PDEATHSIG
    except (OSError, AttributeError):
        return
    if os.getppid() != parent:  # the parent died before the request took effect
        sys.exit(0)


def failed(text: str) -> bool:
    """Whether a background compile of ``text`` failed on this machine."""
    return (cache_folder() / f"{_name(text)}.failed").exists()


def _warm(path: str, shapes: dict[str, list[int]]) -> None:
    """Compile the module at ``path`` by one run on zero arrays of ``shapes`` (those of
    the simulator's arguments, so numba caches the same signature), then mark it."""
    _die_with_parent()
    os.nice(10)
    name = Path(path).stem
    spec = importlib.util.spec_from_file_location(name, path)
    module = sys.modules[name] = importlib.util.module_from_spec(spec)  # numba's cache
    text = Path(path).read_text(encoding="utf-8")
    try:
        spec.loader.exec_module(module)  # records the module by name, as the simulator's
        _run_on_zeros(module.run, shapes)
    except Exception:
        (Path(path).with_suffix(".failed")).touch()
        raise
    mark_cached(text)


def _run_on_zeros(run: Any, shapes: dict[str, list[int]]) -> None:
    """One run of a generated module's ``run`` on zero arrays of ``shapes``: numba compiles
    it for the simulator's argument types, and no plane of a simulator is touched."""
    dtypes = {
        "a": np.float32, "d": np.bool_, "latch": np.bool_, "scratch": np.float32,
        "offsets": np.float32, "pixel": np.float32, "bank": np.float32,
        "bank_div": np.float32, "starts": np.int64, "gains": np.float64,
    }  # fmt: skip
    run(*[np.zeros(shapes[key], dtype) for key, dtype in dtypes.items()], False)


def compile_here(text: str, shapes: dict[str, list[int]]) -> bool:
    """Compile the module ``text`` in this process (``fuse_after`` 1), as the background
    compiler would: True when it is ready; False, the stretch marked as failed (so no
    process tries it again) and a warning logged, where numba cannot compile it (a
    stretch of about a thousand ICWs exceeds the recursion numba's analysis of one
    function takes). The simulator then runs the stretch on the first tier, as it does
    after a failed background compile; nothing of the simulator is touched either way."""
    try:
        _run_on_zeros(load(text), shapes)
    except Exception as e:  # numba's errors, RecursionError among them
        try:
            folder = cache_folder()
            folder.mkdir(parents=True, exist_ok=True)
            (folder / f"{_name(text)}.failed").touch()
        except OSError:  # a folder that cannot be written: nothing is kept
            pass
        log.warning(
            "a stretch of fused code could not be compiled (%s); the engine's first tier runs it",
            type(e).__name__,
        )
        return False
    mark_cached(text)
    return True


def _in_memory(name: str, text: str):
    import types

    module = types.ModuleType(name)
    text = text.replace("import JIT as JIT", "import JIT_IN_MEMORY as JIT")
    exec(compile(text, f"<{name}>", "exec"), module.__dict__)
    return module


if __name__ == "__main__":  # the background compiler's process: module path, shapes
    _warm(sys.argv[1], json.loads(sys.argv[2]))
