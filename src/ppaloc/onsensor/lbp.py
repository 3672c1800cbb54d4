"""LBP descriptors on the sensor: map tiles in digital registers, Hamming comparison.

Every node is a 32-bit LBP code in a 4x8 PE block of a digital database register
(``R10``, ``R11``: 2048 nodes per tile on a 256 array). Each frame the live code is
computed on the array from the block means, read by the controller, replicated into
every 4x8 block and compared by XOR, its bits counted per block by a tree
(docs/onsensor.md).
"""

from __future__ import annotations

from typing import ClassVar

import numpy as np

from ppaloc.onsensor.places import Places, Tree
from ppaloc.onsensor.program import add_level, halve_level, neg_copy, tree_levels
from ppaloc.onsensor.roles import DRegs, Roles
from ppaloc.sim import FLAG, R1, R2, R3, R4, R9, R10, R11, A, B, D, E, Kernel, Register

__all__ = [
    "DESCRIPTOR",
    "DESCRIPTOR_TMP",
    "LBP_CENTRES",
    "LBP_DREGS",
    "LBP_NEIGHBOURS",
    "LBP_ROLES",
    "LBP_TREE",
    "ROOTS",
    "LbpPlaces",
    "hamming_tree",
]

#: Neighbour offsets of an LBP code, MSB first: clockwise from the top-left (docs/ppa8.md).
LBP_NEIGHBOURS = ((-1, -1), (-1, 0), (-1, 1), (0, 1), (1, 1), (1, 0), (1, -1), (0, -1))
#: Grid block of each LBP cell's centre, in concatenation order (MSB first).
LBP_CENTRES = ((2, 2), (2, 5), (5, 2), (5, 5))

#: R1 holds two roles in turn: ``root32`` (the 32x32 block roots, loaded at every capture
#: and read by the spread of the block means) and ``pattern`` (node roots of one tile in
#: the comparison, the window of the detection), which each stage reloads before use.
ROOTS = R1
#: The replicated frame descriptor: the same register as ``tmp_b`` (R3), so it lives from
#: :meth:`LbpPlaces.load_descriptor` to the comparison only (detection reuses R3).
DESCRIPTOR = R3
#: The descriptor's pattern temp: the same register as ``tmp_a`` (R4).
DESCRIPTOR_TMP = R4
#: Digital register roles of the LBP pipeline (``pattern`` and ``root32`` are both
#: :data:`ROOTS`; ``tmp_b`` is :data:`DESCRIPTOR`, ``tmp_a`` :data:`DESCRIPTOR_TMP`).
LBP_DREGS = DRegs(
    valid=R2, cand=R9, tmp_a=DESCRIPTOR_TMP, tmp_b=DESCRIPTOR, pattern=ROOTS, root32=ROOTS
)
#: Every register role of the LBP pipeline: the map in ``R10``, ``R11`` (refreshed with
#: the valid node roots ``R2`` at every capture); ``+m`` at the block roots in ``B``;
#: robust: minus the weights in ``A`` from the update to the next transition.
LBP_ROLES = Roles(
    db=(R10, R11),
    d=LBP_DREGS,
    static=(R2, R10, R11),
    negated=A,
    root_means=B,
    in_turn=(("d.pattern", "d.root32"),),
)


#: The tree's steps over a 4x8-PE node block: east 1, 2, 4, then south 1, 2.
LBP_TREE = ((1, 2, 4), (1, 2))


class LbpPlaces(Places):
    """32-bit LBP descriptors on the sensor (see the module docstring)."""

    representation = "lbp"
    roles = LBP_ROLES
    stores: ClassVar[dict[str, int]] = {"digital": 2}
    spread_means = False  # only the image motion model needs F = -m over the blocks
    #: The tree leaves ``mu = 2h`` at each node root.
    value_scale = (1, 0)
    #: The DAC constant loaded per differing bit: the adding tree (paper) sums ``2`` per
    #: bit (``mu = 2h``), the halving tree (the scaled readout) averages ``64``.
    BIT_VALUE: ClassVar[dict[bool, int]] = {False: 2, True: 2 * 32}

    def reset(self) -> None:
        """Forget the live descriptor."""
        self.last_code = 0  # the controller's copy of the last live descriptor

    def describe(self) -> int:
        """The live descriptor of :meth:`descriptor`."""
        return self.descriptor()

    def prepare_live(self) -> None:
        """Compute and read the live descriptor and replicate it (:data:`DESCRIPTOR`)."""
        code = self.last_code = self.descriptor()
        self.load_descriptor(code)

    def tree_calls(self, tile: int, halving: bool) -> None:
        """``E :=`` the value of one differing bit (:attr:`BIT_VALUE`), through the DAC."""
        self.sensor.sim.scamp5_in(E, self.BIT_VALUE[halving])

    def tree(self, tile: int, halving: bool) -> Tree:
        """``D = 2h = mu`` at each node root, ``h`` the differing bits (``E`` loaded first).

        Adding tree (the paper's): 2 per differing bit (``mu`` itself, <= 64, cannot
        saturate). Halving tree (the scaled readout): 64 per differing bit averaged over
        the 32 PEs (the positive sums ``-(q + q')`` lie in [-128, 0], and every halving is
        exact), which halves the write noise of the levels below at every level where the
        adding tree sums it: under the typical preset about 1 unit of ``mu`` instead of 6.6.
        """
        return (hamming_tree, (self.roles.d.cand, self.roles.db[tile], halving, LBP_TREE))

    def values(self, codes: np.ndarray) -> np.ndarray:
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
        sensor = self.sensor
        sim, dr, means = sensor.sim, self.roles.d, self.roles.root_means
        code = 0
        with sim.stage("lbp"):
            for j, (drow, dcol) in enumerate(LBP_NEIGHBOURS):
                sensor.run(neg_copy, E, means)  # E = -m
                # E[x] := -m of the neighbour block: the picture moves by minus the offset
                sim.shift(E, -dcol * sensor.block, drow * sensor.block)
                sensor.run(_compare, means, dr.cand)
                for cell, (gi, gj) in enumerate(LBP_CENTRES):
                    if sim.global_or(dr.cand, gi * sensor.block, gj * sensor.block, 0, 0):
                        code |= 1 << (31 - (cell * 8 + j))
        return code

    def load_descriptor(self, code: int) -> None:
        """Replicate a 32-bit code into every 4x8 block of :data:`DESCRIPTOR` (R3)."""
        sensor = self.sensor
        sim = sensor.sim
        bits = np.array([code >> (31 - b) & 1 for b in range(32)], bool)
        with sim.stage("lbp"):
            sensor.run(_clr, DESCRIPTOR)
            # bit b is cell (b // 8, b % 8) of the 4x8 block: one pattern and OR a set bit
            sim.pattern_cells(DESCRIPTOR, bits.reshape(sensor.bh, sensor.bw), DESCRIPTOR_TMP)


def _compare(k: Kernel, means: Register, cand: Register) -> None:
    k.where(means, E)  # centre > neighbour
    k.NOT(cand, FLAG)  # neighbour >= centre
    k.all()


def _clr(k: Kernel, reg: Register) -> None:
    k.CLR(reg)


def hamming_tree(
    k: Kernel,
    cand: Register,
    db: Register,
    halving: bool,
    steps: tuple[tuple[int, ...], tuple[int, ...]],
) -> None:
    """A binary place's distance tree: ``cand := DESCRIPTOR XOR db``, ``D := E`` (the
    DAC's value of one differing bit) where they differ, then a halving or adding tree
    over the node block, ``steps`` east and south (:func:`ppaloc.onsensor.program.tree_levels`)."""
    k.XOR(cand, DESCRIPTOR, db)
    k.res(D)
    k.WHERE(cand)
    k.mov(D, E)
    k.all()
    tree_levels(k, halve_level if halving else add_level, D, E, *steps)
