"""The compiled engine's second tier: a kernel run often becomes generated, fused loops.

The first tier (:mod:`ppaloc.sim.engines.compiled`) runs one ICW at a time, one pass over
the plane each: on this kind of machine a pass costs about as much in loads, stores and
saturation as the ICW's arithmetic, so a 6-ICW macro sequence costs six passes. Here a
run of ICWs is cut into *passes* (:func:`plan`) and each pass becomes one loop over the
elements in generated Python source (:func:`source`), compiled by numba: every ICW of
the pass works on values held in machine registers, a plane is loaded once and stored
once, intermediate values of a scratch plane never reach memory.

An ICW with a neighbour term joins a pass through a *pre-step* that materialises the term
before the loop, from the planes as they are when the pass starts: a read of the
neighbours' NEWS (0 from an unflagged neighbour; beyond the edge -0.0, which adds
nothing, as "no term" does) or a push (the sender's value, 0 from an unflagged or
missing sender). So such an ICW starts a new pass when the pass has already written what
its term reads (NEWS, a pushed source, or FLAG). Everything else in a pass is element-wise
and exact: the same float32 operations in the same order as the reference engine, noise
draws at the same indices, so results are the same bytes.

Generated modules are kept in a cache folder (:func:`cache_folder`) with numba's own
cache beside them, so a stretch is compiled once per machine; each is named by the hash
of its source (which holds the hash of the helpers it calls). Compiling takes seconds per
stretch, so the engine has it done by another process (:class:`Background`, this
module run as ``python -m``) while its first tier goes on.
"""

from __future__ import annotations

import hashlib
import importlib.util
import json
import math
import os
import re
import subprocess
import sys
from dataclasses import dataclass, field
from pathlib import Path

import numba
import numpy as np

from ppaloc.fileio import user_cache, write_bytes
from ppaloc.sim.engines.compiled import _NO_RUNTIME, _all_set, _clip, _inline
from ppaloc.sim.isa import Instruction
from ppaloc.sim.registers import FLAG, NEWS, PIX, R0, R12

__all__ = [
    "FUSABLE", "Background", "Pass", "background", "cache_folder", "cached", "draws",
    "failed", "fusable", "load", "mark_cached", "plan", "source",
]  # fmt: skip

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


def plan(instructions: list[Instruction]) -> list[Pass]:
    """Cut a run of fusable ICWs into passes (see the module's docstring)."""
    passes = [Pass()]
    for n, ins in enumerate(instructions):
        if not fusable(ins):
            raise ValueError(f"{ins} cannot be fused")
        if not passes[-1].admits(ins):
            passes.append(Pass())
        passes[-1].add(n, ins)
    return passes


# ---------------------------------------------------------------------------- codegen
_HEADER = '''"""Generated by ppaloc.sim.engines.fused: {what}."""
# runtime {runtime}
import numpy as np
from ppaloc.sim.engines.fused import {jit} as JIT
from ppaloc.sim.engines.fused import all_ones, clip, clip_hi, clip_lo, pre_push, pre_read

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
          everywhere: bool, v: _Names) -> None:  # fmt: skip
    """The loop body of one pass: every ICW on register-held values, in order.

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
                (f"T[{pre_of[('read', i, id(s))] * n} + p]", _INSIDE)
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
                    val, dr = f"T[{pre_of[('push', i, id(dst))] * n} + p]", _INSIDE
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
          everywhere: bool, tag: str) -> None:  # fmt: skip
    """One pass's loop: load what it touches, run the body, store what it wrote. Its
    loop counter and flag test are named by ``tag``, so that no name is assigned twice."""
    inner = _Writer()
    _loop_lines(inner, depth, ps, draw_of, noisy, n, everywhere)
    for line in inner.lines:
        w.lines.append(re.sub(r"\b(p|acc)\b", rf"\g<1>{tag}", line))


def _loop_lines(w: _Writer, depth: int, ps: Pass, draw_of: dict[int, int], noisy: bool,
                n: int, everywhere: bool) -> None:  # fmt: skip
    a_set, d_set, lread, lwrite = _touched(ps)
    flag_written = _F in ps.written_d
    v = _Names()
    if flag_written:
        w(depth, "acc = True")
    w(depth, f"for p in range({n}):")
    for x in sorted(a_set):
        w(depth + 1, f"{v.new(f'a{x}')} = A[{x * n} + p]")
    for x in sorted(d_set):
        value = "np.uint8(1)" if x == _F and everywhere else f"D[{x * n} + p]"
        w(depth + 1, f"{v.new(f'd{x}')} = {value}")
    if lread:
        w(depth + 1, f"{v.new('lt')} = L[p]")
    _body(w, depth + 1, ps, draw_of, noisy, n, everywhere, v)
    for x in sorted(ps.written_a):
        w(depth + 1, f"A[{x * n} + p] = {v[f'a{x}']}")
    for x in sorted(ps.written_d):
        w(depth + 1, f"D[{x * n} + p] = {v[f'd{x}']}")
    if lwrite:
        w(depth + 1, f"L[p] = {v['lt']}")
    if flag_written:
        w(depth + 1, f"acc = acc & ({v[f'd{_F}']} != 0)")
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


@JIT
def pre_read(T, k, A, D, rows, cols, dr, dc):
    """T[k] := each element's neighbour (r + dr, c + dc) NEWS where that neighbour is
    flagged, 0 where it is not, -0.0 beyond the edge (adding it leaves a sum as it is)."""
    n = rows * cols
    nz = np.float32(-0.0)
    zero = np.float32(0.0)
    c_lo, c_hi = max(0, -dc), min(cols, cols - dc)
    news, flag = A[_NEWS * n : (_NEWS + 1) * n], D[_F * n : (_F + 1) * n]
    for r in range(rows):
        o = T[k * n + r * cols : k * n + (r + 1) * cols]
        q = r + dr
        if q < 0 or q >= rows:
            for c in range(cols):
                o[c] = nz
            continue
        for c in range(0, c_lo):
            o[c] = nz
        for c in range(c_hi, cols):
            o[c] = nz
        s = q * cols + c_lo + dc
        oi, x, f = o[c_lo:c_hi], news[s : s + c_hi - c_lo], flag[s : s + c_hi - c_lo]
        for c in range(c_hi - c_lo):
            oi[c] = x[c] if f[c] else zero


@JIT
def pre_push(T, k, A, D, rows, cols, dr, dc, srcs, ns, parts, noisy, scale):
    """T[k] := the value pushed into each element by its sender (r - dr, c - dc): the
    sum of the ``ns`` planes ``srcs`` (four entries) there, as the bus makes it (saturated
    when ideal, times the ICW's gain when noisy), 0 where the sender is unflagged or
    beyond the edge."""
    n = rows * cols
    zero = np.float32(0.0)
    m_half = np.float32(-0.5)
    m_parts = np.float32(-parts)
    c_lo, c_hi = max(0, dc), min(cols, cols + dc)
    flag = D[_F * n : (_F + 1) * n]
    for r in range(rows):
        o = T[k * n + r * cols : k * n + (r + 1) * cols]
        q = r - dr
        if q < 0 or q >= rows:
            for c in range(cols):
                o[c] = zero
            continue
        for c in range(0, c_lo):
            o[c] = zero
        for c in range(c_hi, cols):
            o[c] = zero
        s = q * cols + c_lo - dc
        w = c_hi - c_lo
        oi, f = o[c_lo:c_hi], flag[s : s + w]
        for c in range(w):  # the sum of the sources, left to right (0 with none)
            oi[c] = zero
        for j in range(ns):
            x = A[srcs[j] * n + s : srcs[j] * n + s + w]
            if j == 0:
                for c in range(w):
                    oi[c] = x[c]
            else:
                for c in range(w):
                    oi[c] = oi[c] + x[c]
        if noisy:  # the bus's value, then 0 from an unflagged sender: loops without branches
            for c in range(w):
                v = oi[c] * scale
                oi[c] = v if f[c] else zero
        elif parts == 1:
            for c in range(w):
                v = clip(-oi[c])
                oi[c] = v if f[c] else zero
        elif parts == 2:
            for c in range(w):
                v = clip(oi[c] * m_half)
                oi[c] = v if f[c] else zero
        else:
            for c in range(w):
                v = clip(oi[c] / m_parts)
                oi[c] = v if f[c] else zero


def _pre_step(w: _Writer, depth: int, k: int, kind: str, ins: Instruction, reg, rows: int,
              cols: int, noisy: bool, sc: str) -> None:  # fmt: skip
    """T[k] := the neighbour term, from the planes at the pass's start."""
    dr, dc = reg.direction.offset
    if kind == "read":
        w(depth, f"pre_read(T, {k}, A, D, {rows}, {cols}, {dr}, {dc})")
        return
    srcs = "S_" + "_".join(str(s.index) for s in ins.srcs)  # a module constant
    scale = sc if noisy else "F0"
    w(depth, f"pre_push(T, {k}, A, D, {rows}, {cols}, {dr}, {dc}, {srcs}, {len(ins.srcs)}, "
             f"{_parts(ins)}, {noisy}, {scale})")  # fmt: skip


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
    for srcs in sorted(
        {
            tuple(s.index for s in ins.srcs)
            for ps in passes
            for kind, i, _ in ps.pre
            if kind == "push"
            for ins in [instructions[i]]
        }
    ):
        padded = [*srcs, 0, 0, 0, 0][:4]  # unused entries name plane 0
        w(0, f"S_{'_'.join(map(str, srcs))} = np.array({padded}, dtype=np.int64)")
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
    for number, ps in enumerate(passes):
        if not any(_touched(ps)):  # only nops: no loop (its body would be empty)
            continue
        for i, ins in ps.icws:
            if noisy:
                bank = "BK" if _parts(ins) == 1 or ins.op == "where" else "BD"
                for k in range(draws(ins, noisy)):
                    j = draw_of[i] + k
                    w(1, f"bk{j} = {bank}[starts[{j}] : starts[{j}] + {n}]")
                if ins.op in _TRANSFERS:
                    w(1, f"sc{i} = np.float32(gains[{draw_of[i]}] / {_parts(ins)})")
        for k, (kind, i, reg) in enumerate(ps.pre):
            _pre_step(w, 1, k, kind, dict(ps.icws)[i], reg, rows, cols, noisy, f"sc{i}")
        if ps.flag_read_first():  # a variant for FLAG set everywhere: no masks, no loads
            w(1, "if fa:")
            _loop(w, 2, ps, draw_of, noisy, n, True, f"_{number}a")
            w(1, "else:")
            _loop(w, 2, ps, draw_of, noisy, n, False, f"_{number}b")
        else:
            _loop(w, 1, ps, draw_of, noisy, n, False, f"_{number}")
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
        if not path.exists() or path.read_text() != text:
            write_bytes(path, text)
    except OSError:
        return None
    return path


class Background:
    """Compiles generated modules in a separate process, one at a time, so that a
    simulator keeps running its first tier meanwhile (compiling takes seconds per
    stretch; the second core of a machine does it). A finished module is marked as
    :func:`cached`; a process that fails marks it ``.failed`` and it is not tried again."""

    def __init__(self) -> None:
        self._queue: list[tuple[str, list[str]]] = []
        self._running: subprocess.Popen | None = None

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
                self._running = subprocess.Popen(
                    argv, stdin=subprocess.DEVNULL, stdout=subprocess.DEVNULL,
                    stderr=subprocess.DEVNULL,
                )  # fmt: skip
                return


#: The one background compiler of this process.
background = Background()


def failed(text: str) -> bool:
    """Whether a background compile of ``text`` failed on this machine."""
    return (cache_folder() / f"{_name(text)}.failed").exists()


def _warm(path: str, shapes: dict[str, list[int]]) -> None:
    """Compile the module at ``path`` by one run on zero arrays of ``shapes`` (those of
    the simulator's arguments, so numba caches the same signature), then mark it."""
    os.nice(10)
    name = Path(path).stem
    spec = importlib.util.spec_from_file_location(name, path)
    module = sys.modules[name] = importlib.util.module_from_spec(spec)  # numba's cache
    text = Path(path).read_text()
    try:
        spec.loader.exec_module(module)  # records the module by name, as the simulator's
        dtypes = {
            "a": np.float32, "d": np.bool_, "latch": np.bool_, "scratch": np.float32,
            "offsets": np.float32, "pixel": np.float32, "bank": np.float32,
            "bank_div": np.float32, "starts": np.int64, "gains": np.float64,
        }  # fmt: skip
        args = [np.zeros(shapes[key], dtype) for key, dtype in dtypes.items()]
        module.run(*args, False)
    except Exception:
        (Path(path).with_suffix(".failed")).touch()
        raise
    mark_cached(text)


def _in_memory(name: str, text: str):
    import types

    module = types.ModuleType(name)
    text = text.replace("import JIT as JIT", "import JIT_IN_MEMORY as JIT")
    exec(compile(text, f"<{name}>", "exec"), module.__dict__)
    return module


if __name__ == "__main__":  # the background compiler's process: module path, shapes
    _warm(sys.argv[1], json.loads(sys.argv[2]))
