"""Random valid ICWs drawn from the op table itself, for the engines' property tests.

Loaded by tests/sim/conftest.py as ``ppaloc_tests_sim_icws`` (the suite imports tests in
importlib mode: they are not a package, so a helper beside them is not importable as is).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence

from hypothesis import reject
from hypothesis import strategies as st

import ppaloc.sim as s
from ppaloc.errors import RegisterMisuseError
from ppaloc.sim import OPS
from ppaloc.sim.isa import make

Pools = Mapping[str, tuple[Sequence, Sequence]]
"""Per register kind (``"analog"``, ``"digital"``): the destinations and the sources."""

LOCAL = [s.A, s.B, s.C, s.D, s.E, s.F]
"""The analogue registers of an element's own."""
AXES = {1: [(s.XE, s.XW), (s.XW, s.XE)], 0: [(s.XN, s.XS), (s.XS, s.XN)]}
"""Per axis: the read of each direction's neighbour, and the push that reads the same one."""


@st.composite
def icws(draw: st.DrawFn, pools: Pools) -> tuple[str, tuple, tuple]:
    """One valid instruction of any row of the op table, its registers from ``pools``."""
    op = draw(st.sampled_from(sorted(OPS)))
    spec = OPS[op]
    regs = []
    for kind, (lo, hi), role in ((spec.dst_kind, spec.n_dst, 0), (spec.src_kind, spec.n_src, 1)):
        if kind not in pools:
            regs.append(())
            continue
        pool = pools[kind][role]
        regs.append(tuple(draw(st.lists(st.sampled_from(pool), min_size=lo, max_size=hi))))
    try:
        make(op, regs[0], regs[1])
    except RegisterMisuseError:
        reject()
    return op, regs[0], regs[1]


@st.composite
def chain(draw: st.DrawFn, most: int = 6) -> list[tuple]:
    """Linked neighbour moves along one axis (2 to ``most`` steps), each reading what the
    one before wrote, from NEWS or a local plane."""
    axis = draw(st.sampled_from([0, 1]))
    read = draw(st.booleans())
    plane = s.NEWS if read else draw(st.sampled_from(LOCAL))
    out = []
    for _ in range(draw(st.integers(2, most))):
        read_reg, push_reg = draw(st.sampled_from(AXES[axis]))
        if read:
            plane = draw(st.sampled_from(LOCAL))
            out.append(("bus", (plane,), (read_reg,)))
        else:
            out.append(("bus", (push_reg,), (plane,)))
            plane = s.NEWS
        read = not read
    return out
