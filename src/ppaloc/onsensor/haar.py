"""Haar-sign places on the sensor: 16x16-PE blocks of bits in digital registers, Hamming.

Every node is the 16x16 plane of its 192 Haar signs (:func:`ppaloc.place.haar_plane`), one
bit per PE of a 16x16 block of a digital database register (``R10``, ``R11``: 256 nodes
per tile, two tiles a sensor, longer maps on a bank). The registers are those of the LBP
pipeline (:data:`ppaloc.onsensor.lbp.LBP_ROLES`): both are bit planes compared by XOR.

Each frame the reduce stage reads the live frame's 16x16 block codes
(:func:`ppaloc.onsensor.capture.block_means`, as for ``lowres16``), the controller computes
the signs from them (the host's function on the same integers, exact in ideal mode) and
writes them into the descriptor plane with one periodic ``load_pattern`` per set sign, or,
where more than half are set (a dark or flat frame ties them to 1), per cleared sign after
two patterns of every sign's cell, so at most 98 a frame; the comparison
XORs it with each tile, loads 64 into every differing PE and halves over the 16x16 block
(steps 1, 2, 4, 8 east, then south), leaving ``+h/4`` at the node's root
(docs/onsensor.md, "Haar signs").
"""

from __future__ import annotations

from typing import ClassVar

import numpy as np

from ppaloc.onsensor.lbp import DESCRIPTOR, DESCRIPTOR_TMP, LbpPlaces, hamming_tree
from ppaloc.onsensor.lowres import tree_steps
from ppaloc.onsensor.places import Tree
from ppaloc.place import HAAR_GRID, HAAR_WORDS, haar_plane, pack_plane, unpack_plane
from ppaloc.sim import Kernel, Register

__all__ = ["HAAR_BIT_VALUE", "HaarPlaces"]

HAAR_BIT_VALUE = 64
"""The DAC constant loaded per differing bit: averaged over the 256 PEs of a block it
leaves ``64 h / 256 = h * 2**-HAAR_EXPONENT`` at the root (``HAAR_EXPONENT`` = 2)."""

#: The cells that hold a sign, as two periodic patterns ``(r, c, rx, cx)``: the even rows,
#: and the even columns of the odd rows (cell (odd, odd) of every 2x2 is always 0).
_SIGN_CELLS = ((0, 0, 0xFE, 0xFF), (1, 0, 0xFE, 0xFE))
_SIGNED = np.ones((HAAR_GRID, HAAR_GRID), bool)
_SIGNED[1::2, 1::2] = False


class HaarPlaces(LbpPlaces):
    """192 Haar signs a node on the sensor (see the module docstring).

    The LBP pipeline's registers and stages with the descriptor computed by the controller
    from the 16x16 codes (:meth:`describe`); :meth:`LbpPlaces.descriptor`, the LBP code
    compared on the array, is not used.
    """

    representation = "haar"
    grid = HAAR_GRID
    BIT_VALUE: ClassVar[dict[bool, int]] = {True: HAAR_BIT_VALUE}

    def reset(self) -> None:
        """Forget the live descriptor and the grid read."""
        self.last_code = np.zeros(HAAR_WORDS, np.uint32)
        self.grid_codes = None

    def describe(self) -> np.ndarray:
        """The node's packed signs (8 uint32 words) from the 16x16 codes the reduce stage
        read (exact in ideal mode, :func:`ppaloc.onsensor.capture.read_grid`)."""
        if self.grid_codes is None:
            raise AssertionError("describe before the reduce stage read the 16x16 grid")
        return pack_plane(haar_plane(self.grid_codes))

    def prepare_live(self) -> None:
        """The live signs in every node block of :data:`DESCRIPTOR` (R3)."""
        code = self.last_code = self.describe()
        self.load_descriptor(code)

    def load_descriptor(self, code: np.ndarray) -> None:  # type: ignore[override]
        """The signs into :data:`DESCRIPTOR`, PE ``(r, c)`` of every 16x16 block for cell
        ``(r, c)`` of the plane: from a cleared plane one periodic pattern ORed per set
        sign, or, where more signs are set than cleared, every sign's cell set by two
        patterns and one pattern cleared (``NOT tmp AND``) per cleared sign."""
        sensor = self.sensor
        sim = sensor.sim
        plane = unpack_plane(code)
        ones = plane == 1
        zeros = _SIGNED & (plane == 0)
        with sim.stage("haar"):
            if ones.sum() <= zeros.sum() + len(_SIGN_CELLS):
                sensor.run(_clr, DESCRIPTOR)
                sim.pattern_cells(DESCRIPTOR, ones, DESCRIPTOR_TMP)
                return
            (r0, c0, rx0, cx0), (r1, c1, rx1, cx1) = _SIGN_CELLS
            sim.load_pattern(DESCRIPTOR, r0, c0, rx0, cx0)
            sim.load_pattern(DESCRIPTOR_TMP, r1, c1, rx1, cx1)
            sensor.run(_or, DESCRIPTOR, DESCRIPTOR_TMP)
            sim.pattern_cells(DESCRIPTOR, zeros, DESCRIPTOR_TMP, clear=True)

    def tree_calls(self, tile: int, halving: bool) -> None:
        """``E :=`` :data:`HAAR_BIT_VALUE` through the DAC (the halving tree only)."""
        if not halving:
            raise AssertionError("the Haar-sign place has the robust preset's halving tree only")
        super().tree_calls(tile, halving)

    def values(self, codes: np.ndarray) -> np.ndarray:
        """``r = code - 128 = floor(h/4 + 1/2)``: the ADC code of the root's ``h/4`` read
        back, rounded (the update adds the root itself)."""
        return codes - 128

    def tree(self, tile: int, halving: bool) -> Tree:
        """``D = h/4`` at each node root, ``h`` the differing signs (``E`` = 64 loaded first
        by :meth:`tree_calls`): a halving tree over the 16x16 block (the robust preset's
        scaled readout; the paper preset does not run this place)."""
        if not halving:
            raise AssertionError("the Haar-sign place has the robust preset's halving tree only")
        steps = tree_steps(HAAR_GRID)
        return (hamming_tree, (self.roles.d.cand, self.roles.db[tile], True, (steps, steps)))


def _clr(k: Kernel, reg: Register) -> None:
    k.CLR(reg)


def _or(k: Kernel, reg: Register, x: Register) -> None:
    k.OR(reg, x)
