"""Low-res place images on the sensor: map tiles in analogue registers, SAD comparison.

Every node is a ``grid`` x ``grid`` image in a block of as many PEs (``grid`` from
:data:`ppaloc.place.LOWRES_GRIDS`): ``"lowres"``, 8x8 images, 1024 nodes per tile on a
256 array (:class:`LowresPlaces`); ``"lowres16"``, 16x16 images, 256 nodes per tile
(:class:`Lowres16Places`, contrast-normalised images only). A tile is held in one of two
map stores (docs/onsensor.md, "Map store"):

- ``"analogue"`` (the paper preset's default): ``n = q/2 - 64`` in one analogue database
  register per tile (``A``, ``B``: two tiles per sensor); it droops over a long query.
- ``"levels"`` (the robust preset's default): each pixel's two 4-bit halves ``q = 16 h +
  l`` as levels 16 apart in ``A`` (``16 h - 120``) and ``B`` (``16 l - 128``), one tile
  per sensor. Levels 16 apart survive droop and write noise: every few frames a ladder of
  15 comparisons rewrites each register with exact DAC levels (:meth:`LowresPlaces.refresh`),
  and the comparison rebuilds ``n = H/2 + L/32`` exactly (ideal mode) before its tree.

Each frame the live grid of block means is put over every node block and compared by
the clipped absolute difference, summed by a halving tree per block. Where the filter
compares contrast-normalised images (``FilterParams.contrast``, the robust preset) the
controller reads the grid's codes (64 or 256), normalises them
(:func:`ppaloc.place.normalise_contrast`, as its map's nodes were before upload) and
loads them through the DAC (:meth:`LowresPlaces.load_live`); otherwise the exact 8x8
means are replicated by shifts (:meth:`LowresPlaces.replicate`, the paper preset's).
The 16x16 grid's codes are read by the reduce stage
(:func:`ppaloc.onsensor.capture.block_means`), before the image motion test takes the
captured frame's register.
"""

from __future__ import annotations

from typing import ClassVar

import numpy as np

from ppaloc.localise.schedule import SensorPlan
from ppaloc.onsensor.minimum import refine_minimum
from ppaloc.onsensor.places import Places, Tree
from ppaloc.onsensor.program import halve_level, pull_shift, tree_levels
from ppaloc.onsensor.roles import DRegs, Roles
from ppaloc.onsensor.sensor import GRID, mask_bits
from ppaloc.place import LOWRES_GRIDS, normalise_contrast, tile_cells
from ppaloc.sim import (
    IN,
    NEWS,
    R1,
    R2,
    R3,
    R4,
    R9,
    R10,
    R11,
    A,
    B,
    D,
    Direction,
    E,
    F,
    Kernel,
    Register,
    east,
    north,
    south,
    west,
)
from ppaloc.topomap import TopoMap

__all__ = [
    "LOWRES16_ROLES",
    "LOWRES_DREGS",
    "LOWRES_ROLES",
    "ROOTS",
    "Lowres16Places",
    "LowresPlaces",
]

#: R3 holds two roles in turn: ``root32`` (the 32x32 block roots, loaded at every capture
#: and read by the spread of the block means) and ``pattern`` (node roots of one tile in
#: the comparison, the window of the detection), which each stage reloads before use. So
#: the spread must run before the comparison has overwritten R3 with node roots.
ROOTS = R3
#: Digital register roles of the low-res pipeline (``pattern`` and ``root32`` are both
#: :data:`ROOTS`).
LOWRES_DREGS = DRegs(valid=R4, cand=R9, tmp_a=R10, tmp_b=R11, pattern=ROOTS, root32=ROOTS)
#: Every register role of the low-res pipeline: the map in ``A``, ``B``; the replication
#: class masks (rows, columns) in ``R1``, ``R2`` and the valid node roots in ``R4``,
#: refreshed at every capture.
LOWRES_ROLES = Roles(
    db=(A, B),
    d=LOWRES_DREGS,
    static=(R1, R2, R4),
    in_turn=(("d.pattern", "d.root32"),),
)
#: The 16x16 low-res pipeline's roles: those of :data:`LOWRES_ROLES` without the
#: replication's class masks (its images are always normalised and loaded through the
#: DAC), so ``R1`` and ``R2`` are free.
LOWRES16_ROLES = Roles(
    db=(A, B),
    d=LOWRES_DREGS,
    static=(R4,),
    in_turn=(("d.pattern", "d.root32"),),
)


class LowresPlaces(Places):
    """Low-res 8x8 place images on the sensor (see the module docstring)."""

    representation = "lowres"
    roles = LOWRES_ROLES
    grid = LOWRES_GRIDS["lowres"]
    stores: ClassVar[dict[str, int]] = {"levels": 1, "analogue": 2}
    spread_means = True
    #: Levels store: the level of 0 in ``A`` (high halves) and ``B`` (low halves); levels
    #: are ``LEVEL_STEP`` apart, so a value is restored while its error stays below 8.
    LEVEL_BASES = (-120, -128)
    LEVEL_STEP = 16
    #: Levels store: frames between refreshes (droop <= 0.05 units/ms x 4 frames x ~1.2 ms
    #: = 0.25 of the margin of 8; an error of at most 0.12 in ``n``).
    REFRESH_EVERY = 4
    #: Replication class masks: rows, columns whose residue mod 8 is their block's index
    #: (none where the live grid is always loaded through the DAC).
    class_masks: tuple[Register, ...] = (R1, R2)
    #: The tree leaves ``-mu / 2`` at each node root.
    value_scale = (-1, 1)
    #: Address-pattern "don't care" bits of :meth:`load_live`'s classes: every PE whose
    #: row and column residues mod 8 are the grid cell's (``load_in_cells``'s
    #: ``period_mask(grid)``).
    CLASS_DONT_CARE = mask_bits(grid)

    def reset(self) -> None:
        #: The live grid as :meth:`load_live` last loaded it (normalised; inspection).
        self.live_image: np.ndarray | None = None
        #: Whether ``F`` still holds the live frame :meth:`prepare_live` put there (the
        #: refinement of the frame's best distance uses it as a working plane).
        self.live_kept = False
        #: A grid finer than 8x8: its codes as the reduce stage last read them
        #: (:meth:`describe` gives them).
        self.grid_codes: np.ndarray | None = None

    @classmethod
    def max_tiles(cls, plan: SensorPlan, store: str) -> int:
        """One tile where the schedule asks for the frame's best distance: its refinement
        (:mod:`ppaloc.onsensor.minimum`) works in the two planes beside the tree's value,
        which a second tile's value would take."""
        return 1 if plan.minimum else cls.stores[store]

    @property
    def normalised(self) -> bool:
        """Whether the filter compares contrast-normalised images (``contrast`` set)."""
        return self.params.contrast is not None

    @property
    def levels(self) -> bool:
        """Whether the map is held in the levels store."""
        return self.sensor.store == "levels"

    @classmethod
    def level_planes(cls, plane: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The ``A`` and ``B`` levels (integers) of a plane of uint8 pixels ``q``."""
        q = plane.astype(np.int64)
        step = cls.LEVEL_STEP
        return step * (q >> 4) + cls.LEVEL_BASES[0], step * (q & 15) + cls.LEVEL_BASES[1]

    def map_plane(self, tile: int = 0) -> np.ndarray:
        """The map values ``n`` of tile ``tile`` as the comparison sees them (untimed read)."""
        sim = self.sensor.sim
        if self.levels:
            return sim.read(A) / 2 + sim.read(B) / 32
        return sim.read(self.roles.db[tile])

    def refresh(self, frame: int) -> None:
        """Levels store: rewrite ``A`` and ``B`` with exact levels (stage ``"refresh"``).

        Every :attr:`REFRESH_EVERY` frames (from the first after ``reset``). Per
        register: ``D := -R`` (one ``bus``), ``R :=`` the top level (``scamp5_in``), then
        from the top down, per level ``m``: ``FLAG := R_old < m``'s lower midpoint
        (``where(D, IN)``, the midpoint through ``IN``) and ``R :=`` level ``m - 1``
        where flagged (``scamp5_in``, the DAC with offset correction: no write offsets).
        Exact in ideal mode; with noise a value is restored while droop and noise stay
        below half the step (8 units).
        """
        if not self.levels or (frame - 1) % self.REFRESH_EVERY:
            return
        sensor, step = self.sensor, self.LEVEL_STEP
        sim = sensor.sim
        with sim.stage("refresh"):
            for reg, base in zip((A, B), self.LEVEL_BASES, strict=True):
                sensor.run(_level_copy, reg)
                sim.scamp5_in(reg, base + 15 * step)
                for m in range(15, 0, -1):
                    sim.load_in(base + m * step - step // 2)
                    sensor.run(_below)  # R_old < midpoint
                    sim.scamp5_in(reg, base + (m - 1) * step)
                sensor.run(_all)

    def map_planes(self) -> dict[str, np.ndarray]:
        if not self.levels:
            return super().map_planes()
        sim = self.sensor.sim
        return {
            "A: map tile 0, high 4 bits (levels 16 h - 120)": sim.read(A),
            "B: map tile 0, low 4 bits (levels 16 l - 128)": sim.read(B),
        }

    def setup_masks(self) -> None:
        """Class masks ``R1`` (rows), ``R2`` (columns): the residue mod 8 of the row
        (column) is its grid block's index (for :meth:`replicate`; none without
        :attr:`class_masks`)."""
        if not self.class_masks:
            return
        sensor = self.sensor
        sim, dr = sensor.sim, self.roles.d
        free = (sensor.block - 1) & ~(GRID - 1) & 0xFF
        for reg, axis in zip(self.class_masks, (0, 1), strict=True):
            sensor.run(_clr, reg)
            for i in range(GRID):
                base = i * sensor.block + i
                if axis == 0:
                    sim.load_pattern(dr.tmp_a, base, 0, free, 0xFF)
                else:
                    sim.load_pattern(dr.tmp_a, 0, base, 0xFF, free)
                sensor.run(_or, reg, dr.tmp_a)

    def describe(self) -> np.ndarray:
        """The node's uint8 image from the exact block means ``m`` (stage ``reduce``).

        ``2m - 0.5`` in one bus (the only saturation, at -128, maps to the right code 0),
        and ``scan_areg_mean_8x8`` reads ``floor(2m + 128) = floor(S / 1024) = q`` per
        block: exact in ideal mode.
        """
        sim = self.sensor.sim
        sim.scamp5_in(E, -1)
        self.sensor.run(_sense)
        return sim.scan_areg_mean_8x8(NEWS)

    def prepare_live(self) -> None:
        """The live grid over every node block: normalised (:meth:`load_live`, the grid
        read out, contrast-normalised and loaded back) or exact (:meth:`replicate`)."""
        if self.normalised:
            self.load_live()
        else:
            self.replicate()
        self.live_kept = True

    def node_blocks(self, topomap: TopoMap) -> np.ndarray:
        """The nodes' images, contrast-normalised where the live one will be."""
        blocks = super().node_blocks(topomap)
        if not self.normalised:
            return blocks
        return normalise_contrast(blocks, self.params.contrast, self.patch)

    @property
    def patch(self) -> int | None:
        """The side, in cells, of the tiles ``contrast`` normalises each on its own: the
        same pixels on every grid (``contrast_patch`` counts 32x32-pixel blocks; None
        without it)."""
        return tile_cells(self.grid, self.params.contrast_patch)

    def load_live(self) -> None:
        """``F := -f'``, PE (r, c) holding the normalised live cell (r % g, c % g) of the
        place's ``g x g`` grid (:attr:`grid`: 8, or 16 for ``lowres16``).

        The controller reads the live grid as the mapping run reads a node
        (:meth:`describe`: ``q = floor(S / P)`` per block of ``P`` pixels, exact in ideal
        mode),
        normalises it (:func:`ppaloc.place.normalise_contrast`, ``params.contrast`` per
        ``params.contrast_patch`` tile) and
        writes each of the 64 cells (256 on the 16x16 grid) into every node block, as the
        public precursor loads an image (``load_analog_image``), through the simulator's
        routine for it (:meth:`ppaloc.sim.Scamp5.load_in_cells`): per cell one periodic
        ``load_pattern`` into ``tmp_a`` (row and column residues mod the grid), one
        ``load_in(q' - 128)`` and one kernel ``WHERE; bus(F, IN); all`` (``F = 128 - q' =
        -2 f'``, one write; ``q' >= 1``, so it never negates -128), then one halving over
        the plane, ``D = -F/2 = f'``, ``F := -D``. The cells partition the array, so every
        PE of ``F`` is written once before the halving. The normalised image is kept in
        :attr:`live_image` (inspection).
        """
        sensor = self.sensor
        sim, dr = sensor.sim, self.roles.d
        with sim.stage("replicate"):
            live = normalise_contrast(self.describe(), self.params.contrast, self.patch)
            self.live_image = live
            sim.load_in_cells(F, live.astype(np.int64) - 128, dr.tmp_a)
            sensor.run(_halve_live)

    def replicate(self) -> None:
        """``F := -f`` replicated, PE (r, c) holding minus the exact mean of grid block
        (r%8, c%8), by shift-and-add doubling over a zero background.

        Per axis: copy the block means at the PEs whose residue mod 8 is their block's
        index (zero elsewhere), then double that pattern over the zero background by
        controller shifts of 4, 8, 16 blocks of 8 PEs towards the far edge, and the same
        towards the near edge from a copy moved one step; the two halves are disjoint.
        """
        sensor = self.sensor
        sim = sensor.sim
        k0 = sensor.block // GRID  # copies per class inside its block, in steps of 8 PEs
        steps = []
        d = k0
        while d < sensor.size // GRID:
            steps.append(d * GRID)
            d *= 2
        with sim.stage("replicate"):
            masks = self.class_masks
            for mask, far, near in ((masks[0], north, south), (masks[1], west, east)):
                # pulling from `far` (north/west) moves the pattern towards south/east
                sensor.run(_rep_init, mask)
                self._double(E, far, steps)
                pull_shift(sim, D, near, k0 * GRID)
                sensor.run(_mov, F, D)
                self._double(D, near, steps)
                sensor.run(_join, F, D, E)

    def _double(self, acc: Register, direction: Direction, steps: list[int]) -> None:
        """``acc += F`` shifted from ``direction`` by each step in turn (``F`` = ``acc``).

        ``F`` starts as a copy of ``acc``; after each shift-and-add it takes the sum, so
        every step doubles the pattern (the last step leaves ``F`` as it is).
        """
        for i, step in enumerate(steps):
            pull_shift(self.sensor.sim, F, direction, step)
            self.sensor.run(_acc_step, acc, i == len(steps) - 1)

    def tree(self, tile: int, halving: bool) -> Tree:
        """``D = -(mu / 2)`` at each node root, ``mu`` the mean of ``min(|f - n|, 127)``
        (a halving tree over ``D`` and ``E``; the same for both presets)."""
        return (_tree, (self.levels, self.roles.db[tile], tree_steps(self.grid)))

    def values(self, codes: np.ndarray) -> np.ndarray:
        """``r = 2 (128 - code)``: the ADC code of ``-mu/2`` read back (docs/ppa8.md)."""
        return 2 * (128 - codes)

    def minimum(self, values: np.ndarray) -> float:
        """The frame's best distance refined on the array from the least readout
        (:func:`ppaloc.onsensor.minimum.refine_minimum`; ``F`` is one of its planes)."""
        if self.sensor.tiles > 1:
            raise AssertionError("the refinement reads one tile's values: plan.minimum")
        self.live_kept = False
        return refine_minimum(self.sensor, int(values.min()))

    def live_planes(self) -> dict[str, np.ndarray]:
        if not self.live_kept:
            return {}
        label = f"F: live {self.grid}x{self.grid} grid, replicated (negated)"
        return {label: self.sensor.sim.read(F)}


class Lowres16Places(LowresPlaces):
    """Low-res 16x16 place images on the sensor: 16x16 PEs a node, 256 nodes a tile.

    As :class:`LowresPlaces` with the grid of ``"lowres16"``: the reduce stage reads the
    live frame's 16x16 block means (:func:`ppaloc.onsensor.capture.block_means`, exact
    codes ``floor(S / 256)``), the controller normalises them tile by tile (the same
    64x64 pixels as the 8x8 grid's tiles) and :meth:`load_live` writes the 256 cells into
    every node block; the tree halves over 16x16 PEs (steps 1, 2, 4, 8 east, then south),
    leaving ``-mu/2`` at each root as for 8x8. Contrast-normalised images only (the robust
    preset), so there is no replication by shifts and no class masks.
    """

    representation = "lowres16"
    roles = LOWRES16_ROLES
    grid = LOWRES_GRIDS["lowres16"]
    spread_means = False  # only the image motion test reads the 8x8 means spread
    class_masks = ()
    CLASS_DONT_CARE = mask_bits(grid)

    def describe(self) -> np.ndarray:
        """The node's uint8 16x16 image: the codes the reduce stage read (exact in ideal
        mode, :func:`ppaloc.onsensor.capture.read_grid`)."""
        if self.grid_codes is None:
            raise AssertionError("describe before the reduce stage read the 16x16 grid")
        return self.grid_codes.copy()

    def replicate(self) -> None:
        raise AssertionError("lowres16 compares contrast-normalised images only (load_live)")


# Kernel builders (pure functions of their arguments, cached by what they are).
def _level_copy(k: Kernel, reg: Register) -> None:
    k.all()
    k.bus(D, reg)


def _below(k: Kernel) -> None:
    k.where(D, IN)


def _all(k: Kernel) -> None:
    k.all()


def _clr(k: Kernel, reg: Register) -> None:
    k.CLR(reg)


def _or(k: Kernel, reg: Register, x: Register) -> None:
    k.OR(reg, x)


def _sense(k: Kernel) -> None:
    k.bus2(D, NEWS, E)  # D = 0.5
    k.mov(E, F)  # E = -m
    k.bus(NEWS, F, E, D)  # NEWS = 2m - 0.5


def _halve_live(k: Kernel) -> None:
    k.bus2(D, NEWS, F)
    k.bus(F, D)


def _rep_init(k: Kernel, mask: Register) -> None:
    k.res(D)
    k.WHERE(mask)
    k.mov(D, F)
    k.all()
    k.mov(E, D)
    k.mov(F, E)


def _mov(k: Kernel, y: Register, x: Register) -> None:
    k.mov(y, x)


def _join(k: Kernel, y: Register, a: Register, b: Register) -> None:
    k.add(y, a, b)


def _acc_step(k: Kernel, acc: Register, last: bool) -> None:
    k.add(acc, acc, F)
    if not last:
        k.mov(F, acc)


def levels_difference(k: Kernel) -> None:
    """Levels store: ``D := f - n`` with ``n = H/2 + L/32`` rebuilt from ``A``, ``B``.

    Five halvings of ``L`` (``D = -L/32``), one of ``H`` (``E = -H/2``), ``NEWS := n``,
    ``D := -(n - f)`` (``F = -f``): exact in ideal mode, and the sign is irrelevant to the
    ``abs`` after it.
    """
    k.bus2(D, NEWS, B)  # -L/2
    for _ in range(2):
        k.bus2(E, NEWS, D)
        k.bus2(D, NEWS, E)  # L/4, -L/8; L/16, -L/32
    k.bus2(E, NEWS, A)  # -H/2
    k.bus(NEWS, D, E)  # n
    k.bus(D, NEWS, F)  # -(n - f)


def tree_steps(grid: int) -> tuple[int, ...]:
    """The halving tree's steps over a ``grid`` x ``grid`` node block: 1, 2, 4, ... grid/2.

    Examples
    --------
    >>> tree_steps(8), tree_steps(16)
    ((1, 2, 4), (1, 2, 4, 8))
    """
    return tuple(1 << i for i in range(grid.bit_length() - 1))


def _tree(k: Kernel, levels: bool, db: Register, steps: tuple[int, ...]) -> None:
    if levels:
        levels_difference(k)
    else:
        k.add(D, F, db)  # n - f
    k.abs(E, D)  # min(|f - n|, 127)
    k.bus2(D, NEWS, E)  # D = -|f - n| / 2
    tree_levels(k, halve_level, D, E, steps, steps)
