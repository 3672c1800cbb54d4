"""LBP descriptors on the sensor: map tiles in digital registers, Hamming comparison.

Every node is a 32-bit LBP code in a 4x8 PE block of a digital database register
(``R10``, ``R11``: 2048 nodes per tile on a 256 array). Each frame the live code is
computed on the array from the block means, read by the controller, replicated into
every 4x8 block and compared by XOR, its bits counted per block by an adding tree
(docs/onsensor.md).
"""

from __future__ import annotations

from typing import ClassVar

import numpy as np

from ppaloc.onsensor.core import DRegs, SensorPipeline, mask_bits
from ppaloc.onsensor.program import add_level, halve_level
from ppaloc.sim import FLAG, R1, R2, R3, R4, R9, R10, R11, A, B, D, E, east, south

__all__ = [
    "DESCRIPTOR",
    "DESCRIPTOR_TMP",
    "LBP_CENTRES",
    "LBP_DREGS",
    "LBP_NEIGHBOURS",
    "ROOTS",
    "LbpPipeline",
]

#: Neighbour offsets of an LBP code, MSB first: clockwise from the top-left (docs/ppa8.md).
LBP_NEIGHBOURS = ((-1, -1), (-1, 0), (-1, 1), (0, 1), (1, 1), (1, 0), (1, -1), (0, -1))
#: Grid block of each LBP cell's centre, in concatenation order (MSB first).
LBP_CENTRES = ((2, 2), (2, 5), (5, 2), (5, 5))

#: R1 holds two roles in turn: ``root32`` (the 32x32 block roots, loaded at every capture
#: and read by the spread of the block means) and ``pattern`` (node roots of one tile in
#: the comparison, the window of the detection), which each stage reloads before use.
ROOTS = R1
#: The replicated frame descriptor: the same register as ``tmp_b`` (R3), so it lives
#: from :meth:`LbpPipeline.load_descriptor` to the comparison only (detection reuses R3).
DESCRIPTOR = R3
#: The descriptor's pattern temp: the same register as ``tmp_a`` (R4).
DESCRIPTOR_TMP = R4
#: Digital register roles of the LBP pipeline (``pattern`` and ``root32`` are both
#: :data:`ROOTS`; ``tmp_b`` is :data:`DESCRIPTOR`, ``tmp_a`` :data:`DESCRIPTOR_TMP`).
LBP_DREGS = DRegs(
    valid=R2, cand=R9, tmp_a=DESCRIPTOR_TMP, tmp_b=DESCRIPTOR, pattern=ROOTS, root32=ROOTS
)


class LbpPipeline(SensorPipeline):
    """The pipeline for 32-bit LBP descriptors (see :class:`SensorPipeline`).

    Registers: database tiles in ``R10``, ``R11``; block roots and node-root patterns
    share ``R1`` (:data:`ROOTS`); valid node roots in ``R2``; the replicated descriptor in
    ``R3`` (also ``tmp_b``) with its temp ``R4`` (also ``tmp_a``); candidates in ``R9``;
    ``+m`` at the block roots in ``B``; robust: minus the weights in ``A`` from the
    update to the next transition (:attr:`SensorPipeline.NEGATED`).
    """

    representation = "lbp"
    dr = LBP_DREGS
    db = (R10, R11)
    static_masks = (R2, R10, R11)  # valid roots, database tiles
    stores: ClassVar[dict[str, int]] = {"digital": 2}
    root_means = B
    NEGATED = A  # minus the weights after the update (A is otherwise free)
    spread_means = False  # only the image motion model needs F = -m over the blocks

    def reset(self) -> None:
        """Zero the weights, forget the previous frame, estimate and live descriptor."""
        super().reset()
        self.last_code = 0  # the controller's copy of the last live descriptor

    def _describe(self) -> int:
        """The live descriptor of :meth:`descriptor`."""
        return self.descriptor()

    #: The tree leaves ``mu = 2h`` at each node root.
    value_scale = (1, 0)

    def prepare_live(self) -> None:
        """Compute and read the live descriptor and replicate it (:data:`DESCRIPTOR`)."""
        code = self.last_code = self.descriptor()
        self.load_descriptor(code)

    def compare_paper(self) -> None:
        """Paper: :meth:`compare_lbp`."""
        self.compare_lbp()

    #: The DAC constant loaded per differing bit: the paper preset's adding tree sums
    #: ``2`` per bit (``mu = 2h``), the robust preset's halving tree averages ``64``.
    BIT_VALUE: ClassVar[dict[bool, int]] = {False: 2, True: 2 * 32}

    def _tree_calls(self, tile: int) -> None:
        """``E :=`` the value of one differing bit (:attr:`BIT_VALUE`), through the DAC."""
        self.sim.scamp5_in(E, self.BIT_VALUE[self.robust])

    def _tree(self, k, tile: int) -> None:
        """``D = 2h = mu`` at each node root, ``h`` the differing bits (``E`` loaded first).

        Paper: an adding tree of 2 per differing bit (``mu`` itself, <= 64, cannot
        saturate). Robust: a halving tree of 64 per differing bit over the 32 PEs (the
        positive sums ``-(q + q')`` lie in [-128, 0], and every halving is exact), which
        halves the write noise of the levels below at every level where the adding tree
        sums it: under the typical preset about 1 unit of ``mu`` instead of 6.6.
        """
        k.XOR(self.dr.cand, DESCRIPTOR, self.db[tile])
        k.res(D)
        k.WHERE(self.dr.cand)
        k.mov(D, E)
        k.all()
        level = halve_level if self.robust else add_level
        for step in (1, 2, 4):
            level(k, D, E, east, step)
        for step in (1, 2):
            level(k, D, E, south, step)

    def _values(self, codes: np.ndarray) -> np.ndarray:
        """``r = code - 128 = mu = 2h`` (exact: ``mu`` is an integer)."""
        return codes - 128

    def descriptor(self) -> int:
        """The live frame's 32-bit LBP code: compared on the array, read bit by bit.

        The block means are compared where the halving tree left them (``B = +m`` at each
        32x32 block's top-left PE), the most accurate place on a noisy array: for each of
        the 8 neighbour directions a copy is shifted by one block (two for diagonals) and
        ``where(m_centre - m_neighbour)`` decides the bit (neighbour >= centre) at the four
        cell-centre roots, read by point ``global_or``s.
        """
        sim, dr, means = self.sim, self.dr, self.root_means
        code = 0
        with sim.stage("lbp"):
            for j, (drow, dcol) in enumerate(LBP_NEIGHBOURS):
                self._run("lbp_copy", lambda k: k.bus(E, means))  # E = -m
                # E[x] := -m of the neighbour block: the picture moves by minus the offset
                sim.shift(E, -dcol * self.block, drow * self.block)

                def build(k):
                    k.where(means, E)  # centre > neighbour
                    k.NOT(dr.cand, FLAG)  # neighbour >= centre
                    k.all()

                self._run("lbp_compare", build)
                for cell, (gi, gj) in enumerate(LBP_CENTRES):
                    if sim.global_or(dr.cand, gi * self.block, gj * self.block, 0, 0):
                        code |= 1 << (31 - (cell * 8 + j))
        return code

    def load_descriptor(self, code: int) -> None:
        """Replicate a 32-bit code into every 4x8 block of :data:`DESCRIPTOR` (R3)."""
        sim = self.sim
        with sim.stage("lbp"):
            self._run("desc_clr", lambda k: k.CLR(DESCRIPTOR))
            for b in range(32):
                if code >> (31 - b) & 1:
                    bits_r, bits_c = mask_bits(self.bh), mask_bits(self.bw)
                    sim.load_pattern(DESCRIPTOR_TMP, b // 8, b % 8, bits_r, bits_c)
                    self._run("desc_or", lambda k: k.OR(DESCRIPTOR, DESCRIPTOR_TMP))

    def compare_lbp(self) -> None:
        """Per tile: ``w += alpha - 2 h 2**-s``, ``h`` the count of XOR bits in the block.

        Each differing bit loads 2 (the DAC constant), so the adding tree leaves
        ``mu = 2h`` itself (<= 64): the largest signal that cannot saturate, which keeps
        the write offsets of the tree small beside it.
        """
        sim, dr, p = self.sim, self.dr, self.params
        with sim.stage("compare"):
            for t in range(self.tiles):
                self._tree_calls(t)
                self._root_pattern(dr.pattern, t)
                sim.load_in(self.alpha)

                def build(k, t=t):
                    self._tree(k, t)
                    # D = 2h = mu; mu_s = mu 2**-s
                    self._update(k, D, E, 1, -p.shift, t)

                self._run(f"hamming_{t}", build)
