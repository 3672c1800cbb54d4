"""Random valid ICWs drawn from the op table itself, for the engines' property tests.

Loaded by tests/sim/conftest.py as ``ppaloc_tests_sim_icws`` (the suite imports tests in
importlib mode: they are not a package, so a helper beside them is not importable as is).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence

from hypothesis import reject
from hypothesis import strategies as st

from ppaloc.errors import RegisterMisuseError
from ppaloc.sim import OPS
from ppaloc.sim.isa import make

Pools = Mapping[str, tuple[Sequence, Sequence]]
"""Per register kind (``"analog"``, ``"digital"``): the destinations and the sources."""


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
