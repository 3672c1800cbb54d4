"""Haar-sign places on the sensor: 16x16-PE blocks of bits in digital registers, Hamming.

Every node is the 16x16 plane of its 192 Haar signs (:func:`ppaloc.place.haar_plane`), one
bit per PE of a 16x16 block of a digital database register (``R10``, ``R11``: 256 nodes
per tile, two tiles a sensor, longer maps on a bank). The registers are those of the LBP
pipeline (:data:`ppaloc.onsensor.lbp.LBP_ROLES`): both are bit planes compared by XOR.

Each frame the reduce stage reads the live frame's 16x16 block codes
(:func:`ppaloc.onsensor.capture.block_means`, as for ``lowres16``), the controller computes
the signs from them (the host's function on the same integers, exact in ideal mode) and
ORs one periodic ``load_pattern`` per set bit into the descriptor plane; the comparison
XORs it with each tile, loads 64 into every differing PE and halves over the 16x16 block
(steps 1, 2, 4, 8 east, then south), leaving ``+h/4`` at the node's root
(docs/onsensor.md, "Haar signs").
"""

from __future__ import annotations

from typing import ClassVar

import numpy as np

from ppaloc.localise.likelihood import HAAR_EXPONENT
from ppaloc.onsensor.lbp import DESCRIPTOR, DESCRIPTOR_TMP, LbpPlaces, _clr, _or
from ppaloc.onsensor.lowres import tree_steps
from ppaloc.onsensor.places import Tree
from ppaloc.onsensor.program import halve_level
from ppaloc.onsensor.sensor import mask_bits
from ppaloc.place import HAAR_GRID, haar_plane, pack_plane, unpack_plane
from ppaloc.sim import D, E, Kernel, Register, east, south

__all__ = ["HAAR_BIT_VALUE", "HaarPlaces"]

HAAR_BIT_VALUE = 64
"""The DAC constant loaded per differing bit: averaged over the 256 PEs of a block it
leaves ``64 h / 256 = h * 2**-HAAR_EXPONENT`` at the root."""
assert HAAR_BIT_VALUE * 2**HAAR_EXPONENT == HAAR_GRID * HAAR_GRID


class HaarPlaces(LbpPlaces):
    """192 Haar signs a node on the sensor (see the module docstring)."""

    representation = "haar"
    grid = HAAR_GRID
    BIT_VALUE: ClassVar[dict[bool, int]] = {True: HAAR_BIT_VALUE}

    def reset(self) -> None:
        """Forget the live descriptor and the grid read."""
        self.last_code = np.zeros(HAAR_GRID * HAAR_GRID // 32, np.uint32)
        self.grid_codes: np.ndarray | None = None

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
        """OR one periodic pattern per set sign into the cleared :data:`DESCRIPTOR`: PE
        ``(r, c)`` of every 16x16 block for cell ``(r, c)`` of the plane."""
        sensor = self.sensor
        sim = sensor.sim
        bits = mask_bits(HAAR_GRID)
        with sim.stage("haar"):
            sensor.run(_clr, DESCRIPTOR)
            for r, c in zip(*np.nonzero(unpack_plane(code)), strict=True):
                sim.load_pattern(DESCRIPTOR_TMP, int(r), int(c), bits, bits)
                sensor.run(_or, DESCRIPTOR, DESCRIPTOR_TMP)

    def tree(self, tile: int, halving: bool) -> Tree:
        """``D = h/4`` at each node root, ``h`` the differing signs (``E`` = 64 loaded first
        by :meth:`tree_calls`): a halving tree over the 16x16 block (the robust preset's
        scaled readout; the paper preset does not run this place)."""
        if not halving:
            raise AssertionError("the Haar-sign place has the robust preset's halving tree only")
        return (_tree, (self.roles.d.cand, self.roles.db[tile], tree_steps(HAAR_GRID)))


def _tree(k: Kernel, cand: Register, db: Register, steps: tuple[int, ...]) -> None:
    k.XOR(cand, DESCRIPTOR, db)
    k.res(D)
    k.WHERE(cand)
    k.mov(D, E)
    k.all()
    for direction in (east, south):
        for step in steps:
            halve_level(k, D, E, direction, step)
