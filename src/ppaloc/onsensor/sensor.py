"""One simulated sensor holding a map: the narrow facade every stage of the pipeline uses.

:class:`Sensor` owns a simulated SCAMP-5 (:class:`ppaloc.sim.Scamp5`), its kernel cache,
the snake layout of the map and the register roles (:mod:`ppaloc.onsensor.roles`), and
offers what every stage needs: :meth:`Sensor.run` (a kernel, recorded once by what it
is), the node-root patterns and the node windows. The stages themselves
(:mod:`~ppaloc.onsensor.capture`, :mod:`~ppaloc.onsensor.motion`,
:mod:`~ppaloc.onsensor.snake`, :mod:`~ppaloc.onsensor.transition`,
:mod:`~ppaloc.onsensor.likelihood`, :mod:`~ppaloc.onsensor.detect`,
:mod:`~ppaloc.onsensor.carry`) are functions of a sensor, and the representation's
(:mod:`~ppaloc.onsensor.lowres`, :mod:`~ppaloc.onsensor.lbp`) are methods of its places
object; :class:`ppaloc.onsensor.executor.SensorExecutor` runs them in a schedule's order.
"""

from __future__ import annotations

from collections.abc import Callable, Iterable, Sequence
from contextlib import AbstractContextManager
from typing import Any

import numpy as np

from ppaloc.errors import PpalocError
from ppaloc.onsensor.program import KernelCache, and_planes
from ppaloc.onsensor.roles import Roles
from ppaloc.place import LOWRES_GRIDS
from ppaloc.sim import Kernel, NoiseParams, Register, Scamp5, TimingModel
from ppaloc.sim.observe import SimObserver
from ppaloc.topomap import SnakeLayout, layout_for

__all__ = ["GRID", "Sensor", "mask_bits"]

#: Grid cells per side of the live frame's reduction (docs/ppa8.md: 8x8 block means), the
#: blocks of the image motion test and of the ``"lowres"`` place; finer places
#: (:data:`ppaloc.place.LOWRES_GRIDS`) refine these blocks.
GRID = LOWRES_GRIDS["lowres"]


def mask_bits(n: int) -> int:
    """``rx``/``cx`` of ``load_pattern`` that matches addresses modulo ``n`` (a power of 2)."""
    return 0xFF & ~(n - 1)


class Sensor:
    """A simulated sensor, its map's geometry and its register roles.

    Parameters
    ----------
    representation : {"lowres", "lowres16", "lbp", "haar"}
        Picks the snake layout (8x8 PEs per node, 16x16, or 4x8).
    roles : Roles
        The register roles (checked).
    n_nodes : int
        Nodes of the map on this sensor.
    store : str
        How the map is held (docs/onsensor.md, "Map store").
    max_tiles : int
        Tiles the sensor holds with that store.
    noise : str or NoiseParams
        Noise preset (or parameters) of the simulator.
    seed : int
        Seed of the simulator's noise.
    size : int
        Array side (256 on SCAMP-5; smaller arrays, multiples of 64, for tests).
    observers : sequence of SimObserver
        Observers of the simulator (``Scamp5(observers=...)``, :mod:`ppaloc.sim.observe`).

    Attributes
    ----------
    sim : Scamp5
    kernels : KernelCache
    layout : SnakeLayout
    bh, bw : int
        A node block's height and width in PEs.
    block : int
        Pixels per side of a grid block (32 on a 256 array).
    tiles : int
        Tiles the map takes.
    run_steps, run_rects, run_places, run_chains
        The controller's table of the map's runs of one place (:mod:`ppaloc.onsensor.runs`):
        the longest run less one (0: no runs), per tile the rectangles that hold the
        roots of the nodes continuing their predecessor's place, each node's place
        (None: no runs), and the local term's chains along the runs
        (:func:`~ppaloc.onsensor.runs.plan_runs`).
    """

    def __init__(
        self,
        representation: str,
        roles: Roles,
        n_nodes: int,
        *,
        store: str,
        max_tiles: int,
        noise: str | NoiseParams = "ideal",
        seed: int = 0,
        size: int = 256,
        observers: Sequence[SimObserver] = (),
    ) -> None:
        if size % 64 or size < 64:
            raise PpalocError(f"array size {size} must be a multiple of 64 (8x8 grid of blocks)")
        self.representation = representation
        self.roles = roles.check()
        self.store = store
        self.max_tiles = int(max_tiles)
        self.size = size
        self.block = size // GRID
        self.layout: SnakeLayout = layout_for(representation, (size, size))
        self.bh, self.bw = self.layout.block_shape
        self.block_nodes = self._block_node_table()
        self._roots: dict[int, tuple[int, int]] = {}  # node -> its root PE (root_of)
        self.n_nodes = int(n_nodes)
        self.tiles = self.tiles_for(self.n_nodes)
        self.run_steps = 0
        self.run_rects: dict[int, list[tuple[int, int, int, int]]] = {}
        self.run_places: np.ndarray | None = None
        self.run_chains: dict[tuple[int, bool], tuple[list[tuple[int, int, int, int]], int]] = {}
        #: The local term's neighbours and pairs across tiles, per window (onsensor.local).
        self.local_plans: dict[int, tuple[np.ndarray, list[tuple[int, int]]]] = {}
        self.sim = Scamp5(size, size, noise=noise, seed=seed, observers=observers)
        self.kernels = KernelCache(self.sim)
        # the cache's own call, without this method's frame on every kernel run
        self.run = self.kernels.run  # type: ignore[method-assign]
        self.node_grid()

    # ------------------------------------------------------------------ geometry
    @property
    def capacity(self) -> int:
        """Nodes this sensor holds (its tiles times a tile's nodes)."""
        return self.max_tiles * self.layout.capacity

    @property
    def timing(self) -> TimingModel:
        """The simulator's timing model: modelled time and energy, by stage."""
        return self.sim.timing

    def stage(self, name: str) -> AbstractContextManager[Any]:
        """Charge what runs inside to the timing model's stage ``name``."""
        return self.sim.stage(name)

    def tiles_for(self, n_nodes: int) -> int:
        """Tiles a map of ``n_nodes`` takes, or a one-line error when it does not fit."""
        tiles = self.layout.n_tiles(n_nodes)
        if tiles > self.max_tiles:
            raise PpalocError(
                f"a {self.representation} map of {n_nodes} nodes needs {tiles} tiles; one "
                f"simulated sensor holds at most {self.max_tiles} with store={self.store!r} "
                f"({self.capacity} nodes): run it on a bank (ppaloc.onsensor.bank.SensorBank)"
            )
        return tiles

    def node_grid(self) -> None:
        """Per tile: the nodes it holds and their block (row, col) in a root readout."""
        nodes = np.arange(self.n_nodes)
        tile, br, bc = self.layout.node_to_block(nodes)
        self.tile_nodes = [
            (nodes[tile == t], br[tile == t], bc[tile == t]) for t in range(self.tiles)
        ]

    def _block_node_table(self) -> np.ndarray:
        """``[block row, PE column]`` -> the node whose root that PE is in that block row
        (tile ``col % bw``; the layout's ``block_to_node``): made once per layout, as the
        detection and confidence stages map their events every frame."""
        rows, cols = np.indices((self.size // self.bh, self.size))
        return self.layout.block_to_node(cols % self.bw, rows, cols // self.bw)

    def nodes_of(self, events: np.ndarray) -> np.ndarray:
        """The nodes of event PEs (node roots: tile ``t`` at block column offset ``t``),
        sorted, looked up in :attr:`block_nodes`."""
        return np.sort(self.block_nodes[events[:, 0] // self.bh, events[:, 1]])

    def root_of(self, node: int) -> tuple[int, int]:
        """The PE ``(row, col)`` of ``node``'s root (tile offset included; worked out once
        per node, as the local term and the carry ask for a few every frame)."""
        root = self._roots.get(node)
        if root is None:
            tile, br, bc = self.layout.node_to_block(np.array([node]))
            root = int(br[0]) * self.bh, int(bc[0]) * self.bw + int(tile[0])
            self._roots[int(node)] = root
        return root

    # ------------------------------------------------------------------ kernels and masks
    def run(self, build: Callable[..., Any], *args: Any) -> Kernel:
        """Run the kernel ``build(k, *args)`` records (recorded once; :class:`KernelCache`)."""
        return self.kernels.run(build, *args)

    def root_pattern(self, dreg: Register, tile: int | None = None, row_mod: int = 0) -> None:
        """Load node-root PEs into ``dreg``: block top-left + tile column offset.

        ``tile=None``: the roots of every tile; ``row_mod``: 0 (all block rows), or
        1/2 for even/odd block rows only.
        """
        bh, bw = self.bh, self.bw
        if row_mod:
            r, rx = (0 if row_mod == 1 else bh), mask_bits(2 * bh)
        else:
            r, rx = 0, mask_bits(bh)
        if tile is None:
            c, cx = 0, mask_bits(bw) | (1 if self.tiles > 1 else 0)
        else:
            c, cx = tile, mask_bits(bw)
        self.sim.load_pattern(dreg, r, c, rx, cx)

    def valid_roots(self) -> None:
        """``valid`` := the roots of blocks that hold a node (tile offsets included)."""
        sim, dr = self.sim, self.roles.d
        self.run(_clr, dr.valid)
        cap = self.layout.capacity
        cols = self.layout.grid_shape[1]
        for t in range(self.tiles):
            local = min(self.n_nodes - t * cap, cap)
            full, rem = divmod(local, cols)
            self.run(_clr, dr.tmp_b)
            if full:
                sim.load_rect(dr.tmp_a, 0, 0, full * self.bh - 1, self.size - 1)
                self.run(_or, dr.tmp_b, dr.tmp_a)
            if rem:
                if full % 2 == 0:
                    c0, c1 = (cols - rem) * self.bw, self.size - 1
                else:
                    c0, c1 = 0, rem * self.bw - 1
                r0 = full * self.bh
                sim.load_rect(dr.tmp_a, r0, c0, r0 + self.bh - 1, c1)
                self.run(_or, dr.tmp_b, dr.tmp_a)
            self.root_pattern(dr.tmp_a, t)
            self.run(and_planes, dr.tmp_a, dr.tmp_a, dr.tmp_b)
            self.run(_or, dr.valid, dr.tmp_a)

    def rect_mask(self, target: Register, rects: Iterable[tuple[int, int, int, int]]) -> None:
        """``target`` := the OR of the rectangles ``(r0, c0, r1, c1)`` (one ``load_rect``
        into ``tmp_a`` and one OR each)."""
        self.run(_clr, target)
        for rect in rects:
            self.sim.load_rect(self.roles.d.tmp_a, *rect)
            self.run(_or, target, self.roles.d.tmp_a)

    def roots_in(
        self,
        target: Register,
        scratch: Register,
        rects: Iterable[tuple[int, Sequence[tuple[int, int, int, int]]]],
    ) -> None:
        """``target`` := for each ``(tile, rectangles)``, the node roots of that tile inside
        the rectangles (built in ``scratch``, then ANDed with the tile's root pattern)."""
        dr = self.roles.d
        self.run(_clr, target)
        for t, tile_rects in rects:
            self.rect_mask(scratch, tile_rects)
            self.root_pattern(dr.tmp_a, t)
            self.run(and_planes, dr.tmp_a, dr.tmp_a, scratch)
            self.run(_or, target, dr.tmp_a)

    def window(self, a: int, b: int) -> None:
        """``tmp_b`` := the roots of nodes ``a..b`` (clipped to the map), via rectangles."""
        dr = self.roles.d
        a, b = max(a, 0), min(b, self.n_nodes - 1)
        cap = self.layout.capacity
        cols = self.layout.grid_shape[1]
        per_tile = []
        for t in range(self.tiles):
            la, lb = max(a - t * cap, 0), min(b - t * cap, cap - 1)
            if la > lb:
                continue
            ra, rb = la // cols, lb // cols
            spans = []
            for r in sorted({ra, rb}):
                p0 = la - r * cols if r == ra else 0
                p1 = lb - r * cols if r == rb else cols - 1
                spans.append((r, r, p0, p1))
            if rb - ra > 1:
                spans.append((ra + 1, rb - 1, 0, cols - 1))
            rects = []
            for r0, r1, p0, p1 in spans:
                if r0 == r1 and r0 % 2 == 0:
                    c0, c1 = cols - 1 - p1, cols - 1 - p0
                else:
                    c0, c1 = p0, p1
                rects.append(
                    (
                        r0 * self.bh,
                        c0 * self.bw,
                        r1 * self.bh + self.bh - 1,
                        c1 * self.bw + self.bw - 1,
                    )
                )
            per_tile.append((t, rects))
        self.roots_in(dr.tmp_b, dr.pattern, per_tile)

    def allow(self, outside_window: bool) -> None:
        """``tmp_a`` := NOT allowed; allowed = valid (AND NOT the window in ``tmp_b``)."""
        dr = self.roles.d
        if outside_window:
            self.run(_allow_out, dr.tmp_a, dr.valid, dr.tmp_b)
        else:
            self.run(_not, dr.tmp_a, dr.valid)


# Kernel builders of one or two digital ICWs, shared by every stage.
def _clr(k: Kernel, r: Register) -> None:
    k.CLR(r)


def _or(k: Kernel, r: Register, x: Register) -> None:
    k.OR(r, x)


def _not(k: Kernel, r: Register, x: Register) -> None:
    k.NOT(r, x)


def _allow_out(k: Kernel, r: Register, valid: Register, window: Register) -> None:
    k.NOT(r, valid)
    k.OR(r, window)
