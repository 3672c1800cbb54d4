"""The shared core of the on-sensor pipeline: one simulated sensor and its common stages.

:class:`SensorPipeline` owns one simulated SCAMP-5 whose registers hold the map (one tile
per database register), the weights and the working planes. Every stage is a recorded
kernel (replayed on every frame) or a ``scamp5_*`` call, charged to the simulator's timing
model under a stage name; the Python code on top only does what the controller does
(integers, comparisons, loops over readouts). The stages that depend on the place
representation (the live frame's comparison with the map, the node description of the
mapping run) and the register roles are given by the subclasses
:class:`ppaloc.onsensor.lowres.LowresPipeline` and :class:`ppaloc.onsensor.lbp.LbpPipeline`;
the register table is in :mod:`ppaloc.onsensor.pipeline` and docs/onsensor.md.

The pipeline reads the filter's one parameters object,
:class:`ppaloc.localise.params.FilterParams`, and calls the host's decision functions
(:func:`~ppaloc.localise.params.transition_costs`,
:func:`~ppaloc.localise.params.likelihood_shift`,
:func:`~ppaloc.localise.params.frame_statistics`,
:func:`~ppaloc.localise.motion.forward_decision`,
:func:`~ppaloc.localise.weighted.choose_candidate`), so both presets of docs/ppa8.md run
on the sensor with the host's contract: ``"paper"`` (Algorithm 1: motion, shift,
likelihood, detection, adjustment) and ``"robust"`` (motion, transition, likelihood with a
per-frame scale on forward frames, detection, normalisation).
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from collections.abc import Callable
from dataclasses import dataclass, fields
from typing import Any, ClassVar

import numpy as np

from ppaloc.errors import PpalocError
from ppaloc.localise.motion import forward_decision
from ppaloc.localise.params import (
    FilterParams,
    frame_statistics,
    likelihood_shift,
    transition_costs,
)
from ppaloc.localise.weighted import choose_candidate
from ppaloc.onsensor import gain
from ppaloc.onsensor.program import (
    KernelCache,
    add_level,
    halve_level,
    pull,
    pull_shift,
    scale_negated,
)
from ppaloc.sim import (
    FLAG,
    IN,
    NEWS,
    R5,
    R6,
    R7,
    R8,
    XE,
    C,
    D,
    E,
    F,
    NoiseParams,
    Register,
    Scamp5,
    TimingModel,
    east,
    north,
    south,
    west,
)
from ppaloc.topomap import SnakeLayout, TopoMap, layout_for

__all__ = [
    "EVENT_SLOTS",
    "GRID",
    "SHIFTED",
    "WEIGHTS",
    "DRegs",
    "SensorPipeline",
    "class_rows",
    "mask_bits",
]

#: Grid cells per side of the live frame's reduction (docs/ppa8.md: 8x8 block means).
GRID = 8
#: Event slots of the first candidate readout; more candidates fall back to a window search.
EVENT_SLOTS = 32
#: The weight register (both representations; tile t at block PE (0, t)).
WEIGHTS = C
_W = WEIGHTS
#: Robust transition: minus the weights, shifted (``S = -w_{i-d}``, moved one node along
#: the snake per step; its row 1 of the top block row parks the edge and tile-carry values).
SHIFTED = E
#: Robust transition: the scratch copy of the snake shift (and the candidate of a cost
#: beyond the DAC); also the floor constant of the normalisation.
_X = D


@dataclass(frozen=True)
class DRegs:
    """Digital register roles of one representation (see the module table).

    Two roles may name the same register (e.g. ``pattern`` and ``root32``); every stage
    reloads such a register before it reads it, so the roles never overlap in time.
    """

    valid: Register
    cand: Register
    tmp_a: Register
    tmp_b: Register
    pattern: Register
    root32: Register
    u: Register = R5
    d: Register = R6
    u_prev: Register = R7
    d_prev: Register = R8

    def aliases(self) -> dict[str, tuple[str, ...]]:
        """Registers held by more than one role: ``{name: roles}``, roles in field order."""
        roles: dict[str, list[str]] = {}
        for f in fields(self):
            roles.setdefault(getattr(self, f.name).name, []).append(f.name)
        return {reg: tuple(r) for reg, r in roles.items() if len(r) > 1}


def class_rows(n: int, block: int) -> np.ndarray:
    """Indices ``r < n`` with ``r % 8 == r // block``: where class ``r % 8`` starts its copy."""
    r = np.arange(n)
    return r[(r % GRID) == (r // block)]


def mask_bits(n: int) -> int:
    """``rx``/``cx`` of ``load_pattern`` that matches addresses modulo ``n`` (a power of 2)."""
    return 0xFF & ~(n - 1)


def _join_digit(k) -> None:
    """Kernel body: ``D := -(D / 128 + IN)`` given ``D = -P`` (seven halvings, ``E`` scratch)."""
    cur, other = D, E
    for _ in range(7):
        k.bus2(other, NEWS, cur)  # other = -cur / 2
        cur, other = other, cur
    k.bus(D, cur, IN)


def _next_digit(k, src: Register) -> None:
    """Kernel body: ``D := 128 (src - IN)`` (one ``sub``, seven doublings; ``E`` scratch)."""
    k.sub(D, src, IN)
    for _ in range(7):
        k.mov(E, D)
        k.bus(NEWS, D, E)  # -2D
        k.bus(D, NEWS)


class SensorPipeline(ABC):
    """One simulated sensor holding a map, and the per-frame pipeline on it.

    The representation-independent core; build one with
    :func:`ppaloc.onsensor.pipeline.make_pipeline` (or a subclass directly).

    Parameters
    ----------
    n_nodes : int
        Nodes of the map (tiles follow from the layout's capacity).
    params : FilterParams
        The filter's parameters (``preset``, motion test, costs, ...), the host's object.
    alpha : int, optional
        Paper preset: the likelihood offset, a DAC constant (the localiser sets the map's
        :func:`~ppaloc.localise.weighted.suggest_alpha` when ``params.alpha`` is None).
        Default ``params.alpha``. Unused by the robust preset (``alpha_t`` per frame).
    noise : str or NoiseParams
        Noise preset (or parameters) of the simulator.
    seed : int
        Seed of the simulator's noise.
    size : int
        Array side (256 on SCAMP-5; smaller arrays, multiples of 64, for tests).
    store : str, optional
        How the map is held (a key of :attr:`stores`; default :meth:`default_store`).

    Attributes
    ----------
    representation : str
        Place representation (``"lowres"`` or ``"lbp"``): picks the snake layout.
    dr : DRegs
        Digital register roles.
    db : tuple of Register
        Database register of tile 0 and tile 1.
    static_masks : tuple of Register
        Digital registers refreshed (``REFRESH``) at every capture.
    root_means : Register or None
        Where the reduction also leaves ``+m`` at the block roots (None: nowhere).
    spread_means : bool
        Whether the block means are always spread over their blocks (``F = -m``);
        otherwise only for the image motion model.
    last_shift, last_alpha : int or None
        Robust preset: the likelihood shift ``s`` and offset ``alpha_t`` of the last frame
        that added a likelihood (None before one).
    """

    representation: ClassVar[str]
    dr: ClassVar[DRegs]
    db: ClassVar[tuple[Register, Register]]
    static_masks: ClassVar[tuple[Register, ...]]
    root_means: ClassVar[Register | None] = None
    spread_means: ClassVar[bool] = True
    #: Robust: a free analogue register the weight update writes ``-w`` into (one write
    #: instead of ``w := -(-(...))``); the next transition writes ``w`` back with its
    #: normalisation. None: the update writes the weights in place (two writes).
    NEGATED: ClassVar[Register | None] = None
    #: Map stores of the representation and the tiles one sensor holds with each
    #: (docs/onsensor.md, "Map store").
    stores: ClassVar[dict[str, int]]

    def __init__(
        self,
        n_nodes: int,
        params: FilterParams,
        *,
        alpha: int | None = None,
        noise: str | NoiseParams = "ideal",
        seed: int = 0,
        size: int = 256,
        store: str | None = None,
    ) -> None:
        if size % 64 or size < 64:
            raise PpalocError(f"array size {size} must be a multiple of 64 (8x8 grid of blocks)")
        if not isinstance(params, FilterParams):
            raise PpalocError(
                f"params must be a ppaloc.localise.params.FilterParams, got {type(params).__name__}"
            )
        representation = self.representation
        self.params = params
        self.robust = params.preset == "robust"
        self.store = self.default_store(params) if store is None else store
        if self.store not in self.stores:
            raise PpalocError(
                f"store={store!r} is not a {representation} map store; use one of "
                f"{', '.join(self.stores)}"
            )
        #: Tiles this sensor can hold with its store.
        self.max_tiles = self.stores[self.store]
        if alpha is None:
            alpha = params.alpha
        self.alpha: int | None = None if alpha is None else int(alpha)
        self.size = size
        self.block = size // GRID  # pixels per grid block side (32 on a 256 array)
        self.layout: SnakeLayout = layout_for(representation, (size, size))
        self.bh, self.bw = self.layout.block_shape
        self._block_nodes = self._block_node_table()
        self.n_nodes = int(n_nodes)
        self.tiles = self._tiles_for(self.n_nodes)
        self.sim = Scamp5(size, size, noise=noise, seed=seed)
        self.kc = KernelCache(self.sim)
        self._setup_static_masks()
        self._node_grid()
        #: Robust: the weights' scale under the array's transfer gain, calibrated on the
        #: array once (:mod:`ppaloc.onsensor.gain`); the paper preset runs as it did.
        self.scale = gain.WeightScale(gain.calibrate(self) if self.robust else 0.0)
        self.reset()

    @classmethod
    def default_store(cls, params: FilterParams) -> str:
        """The map store used when none is given (the first of :attr:`stores`)."""
        return next(iter(cls.stores))

    @property
    def capacity(self) -> int:
        """Nodes one sensor holds with this store (its tiles times a tile's nodes)."""
        return self.max_tiles * self.layout.capacity

    def _tiles_for(self, n_nodes: int) -> int:
        tiles = self.layout.n_tiles(n_nodes)
        if tiles > self.max_tiles:
            raise PpalocError(
                f"a {self.representation} map of {n_nodes} nodes needs {tiles} tiles; one "
                f"simulated sensor holds at most {self.max_tiles} with store={self.store!r} "
                f"({self.capacity} nodes): run it on a bank (ppaloc.onsensor.bank.SensorBank)"
            )
        return tiles

    def set_nodes(self, n_nodes: int) -> None:
        """Hold a map of ``n_nodes`` nodes from now on (after a keyframe mapping run).

        Recomputes the tiles and the valid roots (stage ``"setup"``) on the same sensor.
        """
        self.tiles = self._tiles_for(int(n_nodes))
        self.n_nodes = int(n_nodes)
        with self.sim.stage("setup"):
            self._valid_roots()
        self._node_grid()

    def _node_grid(self) -> None:
        """Per tile: the nodes it holds and their block (row, col) in a root readout."""
        nodes = np.arange(self.n_nodes)
        tile, br, bc = self.layout.node_to_block(nodes)
        self._tile_nodes = [
            (nodes[tile == t], br[tile == t], bc[tile == t]) for t in range(self.tiles)
        ]

    # ------------------------------------------------------------------ helpers
    @property
    def timing(self) -> TimingModel:
        """The simulator's timing model: modelled time and energy, by stage."""
        return self.sim.timing

    def _run(self, name: str, build: Callable[[Any], Any]) -> None:
        self.kc.run(name, build)

    def _root_pattern(self, dreg: Register, tile: int | None = None, row_mod: int = 0) -> None:
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

    def _setup_static_masks(self) -> None:
        with self.sim.stage("setup"):
            self._setup_masks()
            self._valid_roots()

    def _setup_masks(self) -> None:  # noqa: B027 - an optional hook, empty by default
        """Representation-specific static masks, written before the valid roots."""

    def _valid_roots(self) -> None:
        """``valid`` := the roots of blocks that hold a node (tile offsets included)."""
        sim, dr = self.sim, self.dr
        self._run("clr_valid", lambda k: k.CLR(dr.valid))
        cap = self.layout.capacity
        cols = self.layout.grid_shape[1]
        for t in range(self.tiles):
            local = min(self.n_nodes - t * cap, cap)
            full, rem = divmod(local, cols)
            self._run("clr_tmp_b", lambda k: k.CLR(dr.tmp_b))
            if full:
                sim.load_rect(dr.tmp_a, 0, 0, full * self.bh - 1, self.size - 1)
                self._run("or_tmp_b", lambda k: k.OR(dr.tmp_b, dr.tmp_a))
            if rem:
                if full % 2 == 0:
                    c0, c1 = (cols - rem) * self.bw, self.size - 1
                else:
                    c0, c1 = 0, rem * self.bw - 1
                r0 = full * self.bh
                sim.load_rect(dr.tmp_a, r0, c0, r0 + self.bh - 1, c1)
                self._run("or_tmp_b", lambda k: k.OR(dr.tmp_b, dr.tmp_a))
            self._root_pattern(dr.tmp_a, t)
            self._run("and_valid_t", lambda k: (k.AND(dr.tmp_a, dr.tmp_a, dr.tmp_b),))
            self._run("or_valid", lambda k: k.OR(dr.valid, dr.tmp_a))

    # ------------------------------------------------------------------ state
    def reset(self) -> None:
        """Zero the weights, forget the previous frame and estimate."""
        with self.sim.stage("reset"):
            self._run("reset_w", lambda k: k.res(_W))
        self.scale.reset()
        self.frames = 0
        self.prev: int | None = None
        self.have_prev_planes = False
        self.last_counts: tuple[int, int] | None = None
        self.last_shift: int | None = None
        self.last_alpha: int | None = None
        #: Robust: the threshold ``T`` whose normalisation the next transition applies
        #: (None: none pending; the transition then normalises with ``T = 0``).
        self.pending_top: int | None = None
        #: Robust, with :attr:`NEGATED`: the weights are ``-NEGATED`` (the last update's
        #: one write) instead of ``WEIGHTS``; and the stay cost ``c_0`` the next update
        #: still subtracts (:meth:`transition`).
        self.negated = False
        self.pending_offset = 0

    # ------------------------------------------------------------------ stages
    def capture(self, frame: np.ndarray) -> None:
        """Capture into ``E`` (``v = p/2 - 64``), refresh static masks, reload block roots."""
        sim, dr = self.sim, self.dr
        sim.set_image(frame)
        with sim.stage("capture"):
            static = self.static_masks

            def build(k):
                k.get_image(E)
                for reg in static:
                    k.REFRESH(reg)

            self._run("capture", build)
            bits = mask_bits(self.block)
            sim.load_pattern(dr.root32, 0, 0, bits, bits)

    def block_means(self, spread: bool | None = None) -> None:
        """``F := -m``: every PE holds minus the exact mean of its grid block of ``v``.

        A halving tree leaves each block's mean at its top-left PE (``D``). The paper
        preset spreads it back over the block by a doubling tree over a zero background;
        the robust preset by masked copies (:meth:`_spread_copies`), which write every
        PE a few times instead of summing the write noise of the background. ``spread``:
        whether to spread (default: when the representation or the image motion model
        needs it).
        """
        dr, root_means = self.dr, self.root_means
        levels = []
        d = 1
        while d < self.block:
            levels.append(d)
            d *= 2

        def reduce(k):
            k.bus(D, E)  # D = -v
            for direction in (east, south):
                for step in levels:
                    halve_level(k, D, F, direction, step)
            if root_means is not None:
                k.bus(root_means, D)  # +m at the block roots (e.g. for the descriptor)

        def spread_kernel(k):
            k.res(F)
            k.WHERE(dr.root32)
            k.mov(F, D)
            k.all()
            for direction in (west, north):
                for step in levels:
                    add_level(k, F, D, direction, step)

        with self.sim.stage("reduce"):
            self._run("reduce", reduce)
            if spread is None:
                spread = self.spread_means or self.params.motion == "image"
            if spread and self.robust:
                self._spread_copies()
            elif spread:
                self._run("spread", spread_kernel)

    def _spread_copies(self) -> None:
        """Robust: ``F := -m`` over every block by FLAG-masked copies from the block roots.

        ``F := D`` (``-m`` at the roots; a ``mov``), then per axis and ``s = 1, 2, ...,
        block / 2`` one ``scamp5_shift`` of ``F`` by ``s`` PEs written only where the
        in-block offset lies in ``[s, 2s)`` (a periodic ``load_pattern``), which copies
        the filled offsets ``[0, s)`` onward. A PE's value goes through the ``mov`` and
        one write per set bit of its in-block offsets (at most ``2 log2(block)``): the
        doubling tree of the paper preset instead adds every background PE's write noise
        into the sums (about 38 units per PE under the typical preset, against about 1).
        Exact in ideal mode. ``2 (block - 1)`` PE steps (62 on a 256 array).
        """
        sim, temp = self.sim, self.dr.tmp_a
        self._run("spread_seed", lambda k: k.mov(F, D))
        for axis, pull_from in ((1, west), (0, north)):
            step = 1
            while step < self.block:
                care = (step - 1) | (0xFF & ~(self.block - 1))  # don't care: below step, block
                if axis:
                    sim.load_pattern(temp, 0, step, 0xFF, care)
                else:
                    sim.load_pattern(temp, step, 0, care, 0xFF)
                self._run(f"where_{temp.name}", lambda k: k.WHERE(temp))
                pull_shift(sim, F, pull_from, step)
                step *= 2
        self._run("all", lambda k: k.all())

    def motion(self) -> bool:
        """Forward or stay (docs/ppa8.md item 1); updates the previous planes."""
        p = self.params
        first = self.frames == 1
        if p.motion == "always_forward":
            return not first
        if p.motion != "image":
            raise AssertionError(f"motion={p.motion!r}: the controller decides (step(moved=...))")
        return self.image_motion()

    def image_motion(self) -> bool:
        """The image motion test on the captured frame (after the spread block means).

        The first call after :meth:`reset` only keeps the planes (stay). Used per query
        frame by the image model and per reference frame by the keyframe mapping run.
        """
        p, sim, dr = self.params, self.sim, self.dr
        with sim.stage("motion"):
            self._run("motion_diff", lambda k: k.add(D, E, F))  # D = v - m
            sim.scamp5_in(E, -p.motion_margin)

            def planes(k):
                k.where(D, E)
                k.MOV(dr.u, FLAG)
                k.all()
                k.bus(NEWS, D)
                k.where(NEWS, E)
                k.MOV(dr.d, FLAG)
                k.all()

            self._run("motion_planes", planes)
            if not self.have_prev_planes:
                self._run("motion_keep", self._keep_planes)
                self.have_prev_planes = True
                self.last_counts = None
                return False

            def logic(k):
                k.AND(dr.cand, dr.u_prev, dr.d)
                k.AND(dr.tmp_a, dr.d_prev, dr.u)
                k.OR(dr.tmp_b, dr.cand, dr.tmp_a)  # changed
                k.OR(dr.tmp_a, dr.u, dr.d)  # support
                self._keep_planes(k)

            self._run("motion_logic", logic)
            changed = self._count(dr.tmp_b, "changed")
            support = self._count(dr.tmp_a, "support")
        self.last_counts = (changed, support)
        return forward_decision(
            changed, support, shift=p.motion_shift, min_support=p.motion_min_support
        )

    def _keep_planes(self, k) -> None:
        dr = self.dr
        k.MOV(dr.u_prev, dr.u)
        k.MOV(dr.d_prev, dr.d)

    def _count(self, dreg: Register, name: str) -> int:
        """Exact number of 1s of ``dreg``: 8x16 in-array sums read by the ADC, added up.

        ``global_count`` is an estimate on SCAMP-5; the motion decision needs exact
        counts, so each 8x8 block is summed by an adding tree (values 0/1, sums <= 64),
        pairs of blocks are added into ``NEWS`` as ``-(sum) >= -128`` and the controller
        adds the 512 ADC codes.
        """
        sim = self.sim
        sim.scamp5_in(E, 1)

        def build(k):
            k.res(D)
            k.WHERE(dreg)
            k.mov(D, E)
            k.all()
            for direction in (east, south):
                for step in (1, 2, 4):
                    add_level(k, D, E, direction, step)
            pull(k, E, D, east, 8)
            k.bus(NEWS, D, E)

        self._run(f"count_{name}", build)
        codes = sim.scan_areg(NEWS, 0, 0, self.size - 1, self.size - 1, 8, 16)
        return int((128 - codes.astype(np.int64)).sum())

    def shift_weights(self) -> None:
        """Forward: ``w_i := w_{i-1}`` along the snake, ``w_0 := 0`` (tiles continue).

        Inside a block row the weights move in place by a FLAG-masked ``scamp5_shift``
        (even rows west, odd rows east, the row starts excluded), so most weights take one
        analogue write per move. The row starts take the row end above from a copy made
        before (``D``), and with two tiles node 0 of tile 1 takes the last node of tile 0
        from a second copy (``E``).
        """
        sim, dr = self.sim, self.dr
        bh, bw, n = self.bh, self.bw, self.size
        tcx = 1 if self.tiles > 1 else 0
        rx = mask_bits(2 * bh)
        with sim.stage("shift"):
            copies = (D, E) if self.tiles > 1 else (D,)
            self._run(f"w_copy_{len(copies)}", lambda k: [k.bus(c, _W) for c in copies])
            sim.load_pattern(dr.tmp_a, 0, n - bw, rx, tcx)  # even row starts (east end)
            sim.load_pattern(dr.cand, bh, 0, rx, tcx)  # odd row starts (west end)
            self._run("w_starts", lambda k: k.OR(dr.tmp_b, dr.cand, dr.tmp_a))
            for row_mod, pull_from in ((1, east), (2, west)):
                self._root_pattern(dr.cand, None, row_mod=row_mod)

                def inner(k):
                    k.CLR_IF(dr.cand, dr.tmp_b)
                    k.WHERE(dr.cand)

                self._run("w_inner", inner)
                pull_shift(sim, _W, pull_from, bw)
                self._run("all", lambda k: k.all())
            pull_shift(sim, D, north, bh)  # D[r, c] = -w[r - bh, c]
            self._run("w_starts_write", lambda k: (k.WHERE(dr.tmp_b), k.bus(_W, D), k.all()))
            if self.tiles > 1:
                # the last node of tile 0 (bottom right) feeds node 0 of tile 1 (top right)
                sim.shift(E, 1, n - bh)
                sim.load_point(dr.cand, 0, n - bw + 1)
                self._run("w_carry", lambda k: (k.WHERE(dr.cand), k.bus(_W, E), k.all()))

    # --------------------------------------------------------------- robust transition
    def _snake_masks(self) -> None:
        """``tmp_b`` := the row starts, ``cand`` / ``tmp_a`` := the other roots of the even /
        odd block rows (both tiles): the FLAG masks of a snake shift."""
        sim, dr = self.sim, self.dr
        bh, bw, n = self.bh, self.bw, self.size
        tcx = 1 if self.tiles > 1 else 0
        rx = mask_bits(2 * bh)
        sim.load_pattern(dr.tmp_a, 0, n - bw, rx, tcx)  # even row starts (east end)
        sim.load_pattern(dr.cand, bh, 0, rx, tcx)  # odd row starts (west end)
        self._run("w_starts", lambda k: k.OR(dr.tmp_b, dr.cand, dr.tmp_a))
        self._root_pattern(dr.cand, None, row_mod=1)
        self._root_pattern(dr.tmp_a, None, row_mod=2)
        self._run("sn_inner", lambda k: (k.CLR_IF(dr.cand, dr.tmp_b), k.CLR_IF(dr.tmp_a, dr.tmp_b)))

    def _park(
        self,
        reg: Register,
        scratch: Register,
        edge: int,
        steps: int,
        carried: bool = False,
    ) -> None:
        """Park what enters the snake's starts during ``steps`` shifts of ``reg``.

        Row 1 of the top block row holds no root, so it is storage: at the tile-0 column
        of the first ``steps`` blocks it gets the edge value (``edge``, the DAC; on a
        bank's later sensor, ``carried``, the previous sensor's weights are there
        already, :meth:`carry_in`), and with
        two tiles, at the tile-1 column of block ``k - 1`` (counting from the top-right),
        ``reg`` of tile 0's ``k``-th last node (one ``scamp5_shift`` of a copy: 1 + 247
        steps on a 256 array). :meth:`_snake_step` then moves the right one into the two
        node-0 roots.
        """
        sim, dr = self.sim, self.dr
        n, bh = self.size, self.bh
        assert (n // bh) % 2 == 0  # the last block row runs east: tile 0 ends bottom right
        if self.tiles > 1:
            self._run(f"park_copy_{reg.name}", lambda k: k.bus(scratch, reg))
            # scratch[1, c] = -reg[n - bh, c - 1]: tile 0's last block row, one column east
            sim.shift(scratch, 1, n - bh - 1)
            if carried:  # row 1, tile-1 columns (tile 0's hold the carry)
                sim.load_pattern(dr.pattern, 1, 1, 0, mask_bits(self.bw))
            else:
                sim.load_pattern(dr.pattern, 1, 0, 0, 0xFF)  # row 1
            self._run(
                f"park_carry_{reg.name}",
                lambda k: (k.WHERE(dr.pattern), k.bus(reg, scratch), k.all()),
            )
        if not carried:
            sim.load_pattern(dr.pattern, 1, 0, 0, mask_bits(self.bw))  # row 1, tile-0 columns
            self._run("where_pattern", lambda k: k.WHERE(dr.pattern))
            sim.scamp5_in(reg, edge)
            self._run("all", lambda k: k.all())
        # the node-0 roots of the tiles, which every step writes from the parked row
        if self.tiles > 1:
            sim.load_pattern(dr.pattern, 0, n - self.bw, 0, 1)
        else:
            sim.load_point(dr.pattern, 0, n - self.bw)

    def _snake_step(self, reg: Register, scratch: Register, step: int) -> None:
        """``reg_i := reg_{i-1}`` at every node root along the snake (tiles continue).

        After :meth:`_snake_masks` and :meth:`_park`; ``step`` counts the shifts from 1.
        As :meth:`shift_weights` (FLAG-masked ``scamp5_shift`` inside the block rows, the
        row starts from a copy shifted one block row south), but with one scratch
        register: node 0 of each tile takes the value parked for this step in row 1.
        """
        sim, dr = self.sim, self.dr
        bh, bw = self.bh, self.bw
        self._run(f"sn_copy_{reg.name}", lambda k: k.bus(scratch, reg))
        for mask, pull_from in ((dr.cand, east), (dr.tmp_a, west)):
            self._run(f"where_{mask.name}", lambda k, mask=mask: k.WHERE(mask))
            pull_shift(sim, reg, pull_from, bw)
        self._run("all", lambda k: k.all())
        pull_shift(sim, scratch, north, bh)  # scratch[r, c] = -reg[r - bh, c]

        def starts(k):
            k.WHERE(dr.tmp_b)
            k.bus(reg, scratch)
            k.all()
            pull(k, scratch, reg, south, 1)  # the parked row, one row up
            if step > 1:
                pull(k, scratch, scratch, west, (step - 1) * bw)  # from block step - 1
            k.WHERE(dr.pattern)
            k.mov(reg, scratch)
            k.all()

        self._run(f"sn_starts_{reg.name}_{step}", starts)

    def _take_candidate(self, neg: Register, scratch: Register, cost: int) -> int:
        """``w := max(w, clip(x - cost))`` in place, from ``neg = -x``, ``cost >= 0``.

        One kernel with ``cost`` in ``IN`` (the DAC, up to 127): ``NEWS = -(neg + w +
        cost)`` and ``where(NEWS)`` flag the nodes where ``x - cost > w``, and
        ``bus(w, neg, IN)`` writes ``x - cost`` there: one write per taken candidate
        (``w >= -127``, so a taken one is never clipped, and the others are not
        written). Beyond the DAC (``cost > 127``) ``scratch := clip(x - 127)`` first (a
        value clipped at -128 is below every weight, so it never wins). Returns the ``bus``
        writes a taken candidate's value went through from ``neg`` (1, or 3 beyond the DAC).
        """
        sim = self.sim
        if cost > 127:
            sim.load_in(127)
            self._run(f"tr_far_{scratch.name}", lambda k: k.bus(scratch, neg, IN))
            sim.load_in(cost - 127)

            def far(k):
                k.bus(NEWS, _W, IN)
                k.where(scratch, NEWS)  # FLAG = x - cost > w
                k.sub(_W, scratch, IN)
                k.all()

            self._run(f"tr_max_far_{scratch.name}", far)
            return 3  # scratch, then the sub's two
        if cost:
            sim.load_in(cost)
        sources = (neg, IN) if cost else (neg,)

        def take(k):
            k.bus(NEWS, _W, *sources)
            k.where(NEWS)  # FLAG = x - cost > w
            k.bus(_W, *sources)
            k.all()

        self._run(f"tr_max_{neg.name}_{int(bool(cost))}", take)
        return 1

    def _subtract(self, reg: Register, value: int, name: str) -> int:
        """``reg := clip(reg - value)`` by ``add`` with ``-value`` in ``IN`` (the DAC takes
        [-128, 127], so a larger ``value`` goes in steps of 127); nothing for 0. Returns
        the ``bus`` writes ``reg`` went through (two per ``add``)."""
        writes = 0
        while value:
            part = max(min(value, 127), -128)
            self.sim.load_in(-part)
            self._run(name, lambda k: k.add(reg, reg, IN))
            writes += 2
            value -= part
        return writes

    def transition(self, costs: tuple[int, ...], carried: bool = False) -> None:
        """Robust: the last frame's normalisation, then ``w_i := clip(max_d (w_{i-d} - c_d))``.

        docs/ppa8.md (robust preset, items 5 and 2). The normalisation of the last frame
        (``n := max(clip(w - T), -memory)``, :meth:`normalise` keeps ``T``) writes no
        weight of its own: ``S`` (:data:`SHIFTED`) starts as ``-(w - T)`` (one ``bus``
        with ``-T`` in ``IN``) and moves one node along the snake per ``d``
        (:meth:`_snake_step`, with ``+memory`` and the tile carry parked first,
        :meth:`_park`); the stay candidate is ``w := clip(w - (T + c_0))`` in place (one
        ``add``; nothing when ``T + c_0 = 0``); every other candidate is taken in place by
        :meth:`_take_candidate`, which writes a weight only where its candidate wins (a
        hypothesis moving one node takes three analogue writes: copy, shift, take).
        Stage ``"normalise"``: the floor last, ``w := max(w, max(-memory - min c, -127))``
        (:meth:`_floor`). Exact: a candidate from a node below the floor, the array edge
        (``-memory - c_d``, for every ``d``, also ``d >= N``) and any clip at -127 are at
        most the floor, and no candidate reaches the top clip (``w - T < 1``). On a
        bank's later sensor (``carried``) the previous sensor's last weights, written by
        :meth:`carry_in`, enter node 0 instead of the edge.
        """
        sim, s, x = self.sim, SHIFTED, _X
        top = self.pending_top or 0
        steps = len(costs) - 1 if carried else min(len(costs) - 1, self.n_nodes - 1)
        floor = max(-int(self.params.memory) - min(costs), -127)
        negated, neg = self.negated, self.NEGATED
        # from -w (NEGATED): the stay cost waits for the update's write (w + c_0 units)
        offset = int(costs[0]) if negated and 0 < costs[0] <= min(126, 127 - floor) else 0
        with sim.stage("transition"):
            if negated:  # w := -(NEGATED + T), the normalisation in the one write back
                sim.load_in(int(top))
                self._run("tr_back", lambda k: k.bus(_W, neg, IN))
                self.negated = False
            if steps:
                self._snake_masks()
                if top and not negated:
                    sim.load_in(-int(top))
                    self._run("tr_copy_t", lambda k: k.bus(s, _W, IN))  # S := -(W - T)
                else:
                    self._run("tr_copy", lambda k: k.bus(s, _W))  # S := -W
                self._park(s, x, int(self.params.memory), steps, carried)
            stay = int(costs[0]) - offset + (0 if negated else int(top))
            # the bus writes on each candidate's weight: the stay's adds; a move's copy
            # into S and its take (the snake's shifts are controller shifts, no bus)
            writes = [self._subtract(_W, stay, "tr_stay")]
            for d in range(1, steps + 1):
                self._snake_step(s, x, d)
                writes.append(1 + self._take_candidate(s, x, int(costs[d]) - offset))
        # the weights' scale follows the cheapest candidate's path (the others of a frame
        # take as many, but a free stay; a move into a snake's row start, the first node
        # of each block row, takes a few more copies)
        cheapest = min(range(steps + 1), key=lambda d: costs[d])
        self.scale.charge(int(negated) + writes[cheapest])
        self._restore_scale()
        self.pending_top = None
        with sim.stage("normalise"):
            self._floor(floor + offset)
        self.pending_offset = offset

    def _restore_scale(self) -> None:
        """Robust: scale the weights back when the transfer gain has drifted them a step.

        At the end of the transition (``D``, ``E`` and ``NEWS`` are free, the weights in
        ``WEIGHTS``), at the valid node roots only (stage ``"restore"``;
        :mod:`ppaloc.onsensor.gain`).
        """
        sign = self.scale.due()
        if sign:
            with self.sim.stage("restore"):
                gain.restore(self, _W, self.dr.valid, sign, self.scale.step)
            self.scale.restored(sign, gain.RESTORE_WRITES)

    def _settle(self) -> None:
        """Write a stay cost the transition left to an update that does not come."""
        if self.pending_offset:
            with self.sim.stage("transition"):
                self.scale.charge(self._subtract(_W, self.pending_offset, "tr_stay"))
            self.pending_offset = 0

    # --------------------------------------------------------------- bank carry
    #: Base-128 digits of a carried value: the integer part and four of seven bits, 28
    #: fractional bits (a weight's own resolution is at most 2**-23, docs/ppa8.md).
    CARRY_DIGITS = 5

    def carry_out(self, steps: int) -> list[float]:
        """This sensor's last ``steps`` weights for the next sensor of a bank, read exactly.

        Stage ``"carry"``, before this sensor's own transition. Each weight is read in
        :attr:`CARRY_DIGITS` ADC passes: the code gives the nearest integer ``x``, then
        ``D := 128 (D - x)`` (one ``sub`` with ``x`` in ``IN``, seven doublings) brings
        the next digit into range (``D``, ``E`` are free between the motion stage and the
        transition). Item ``j`` is node ``n - 1 - j``, raised to ``T - memory`` (the
        pending normalisation's floor: a value below it loses anyway) and kept in the
        weights' range [-127, 127].
        """
        sim = self.sim
        floor = (self.pending_top or 0) - int(self.params.memory)
        scale = 128 ** (self.CARRY_DIGITS - 1)
        out = []
        with sim.stage("carry"):
            for j in range(steps):
                tile, br, bc = self.layout.node_to_block(np.array([self.n_nodes - 1 - j]))
                r, c = int(br[0]) * self.bh, int(bc[0]) * self.bw + int(tile[0])
                total, src = 0, (self.NEGATED if self.negated else _W)
                for i in range(self.CARRY_DIGITS):
                    x = int(sim.read_areg(src, r, c)) - 128
                    total = total * 128 + x
                    if i == self.CARRY_DIGITS - 1:
                        break
                    sim.load_in(x)
                    self._run(f"carry_digit_{src.name}", lambda k, src=src: _next_digit(k, src))
                    src = D
                total = -total if self.negated else total
                # with noise a read can leave the register's range: clip to it
                out.append(min(max(total / scale, floor, -127.0), 127.0))
        return out

    def carry_in(self, values: list[float]) -> None:
        """Write the previous sensor's last weights where this snake's start reads them.

        Stage ``"carry"``, before :meth:`transition` (``carried=True``): value ``j`` goes
        into the weight register at row 1 of block ``j`` (tile 0's column, a PE that
        holds no weight), so the transition's copy ``S := -(w - T)`` turns it into the
        parked ``S`` of node ``-1 - j``. Each value is built exactly in ``D``
        (:meth:`_write_value`) and copied by one ``bus`` at that PE.
        """
        sim, dr = self.sim, self.dr
        with sim.stage("carry"):
            reg, sign = (self.NEGATED, -1) if self.negated else (_W, 1)
            for j, value in enumerate(values):
                self._write_value(sign * value)
                sim.load_point(dr.pattern, 1, self.size - self.bw * (j + 1))
                self._run(
                    f"carry_put{'_n' if self.negated else ''}",
                    lambda k, reg=reg: (k.WHERE(dr.pattern), k.bus(reg, D), k.all()),
                )

    def _write_value(self, value: float) -> None:
        """``D := -value`` in every PE, exactly: DAC digits joined by halvings (``E`` scratch).

        ``value`` (a multiple of ``2**-28`` in [-127, 127]) in balanced base-128 digits
        ``y_0 + y_1/128 + ...``: ``D := -y_last``, then per digit seven halvings (each
        negates; ``D``, ``E`` in turn) and ``D := -(E + y)`` with the digit in ``IN``;
        trailing zero digits cost nothing (an integer is one DAC load).
        """
        sim = self.sim
        scale = 128 ** (self.CARRY_DIGITS - 1)
        v = round(value * scale)
        digits = []
        for _ in range(self.CARRY_DIGITS - 1):
            d = (v + 64) % 128 - 64
            digits.append(d)
            v = (v - d) // 128
        digits.append(v)  # the integer part, first
        digits.reverse()
        while len(digits) > 1 and digits[-1] == 0:
            digits.pop()
        sim.scamp5_in(D, -digits[-1])
        for d in reversed(digits[:-1]):
            sim.load_in(d)
            self._run("carry_join", _join_digit)

    def _floor(self, floor: int) -> None:
        """``w := max(w, floor)``: one kernel with ``-floor`` in ``IN``,
        ``NEWS = -(w - floor)`` flags ``w < floor`` and ``bus(W, IN)`` writes the floor
        there (one write of a DAC constant)."""
        self.sim.load_in(-floor)

        def build(k):
            k.bus(NEWS, _W, IN)
            k.where(NEWS)  # FLAG = w < floor
            k.bus(_W, IN)
            k.all()

        self._run("floor", build)

    # --------------------------------------------------------------- robust likelihood
    def compare_robust(self) -> None:
        """Robust: read every node's distance, scale it for this frame, add it.

        docs/ppa8.md (robust preset, item 3). Stage ``"scale"``: the distance trees
        leave each node's value at its block's top-left PE, per tile (:meth:`_tree`) or
        for both tiles in one kernel where the representation has the registers for it
        (:meth:`_tree_tiles`), and ``scan_areg`` reads them (the ADC codes give the
        integers ``r_i`` exactly, :meth:`_values`); the controller computes ``(b, m) =
        frame_statistics(r)``, ``s = likelihood_shift(m - b, gain)`` and ``alpha_t = b
        >> s``. Stage ``"compare"``: ``w += alpha_t - mu 2**-s`` per tile
        (:meth:`_update_robust`, kernels per shift value, recorded once) from the values
        the readout read; without :meth:`_tree_tiles` the last tile's are still in
        ``D`` and an earlier tile's tree is recomputed.
        """
        values = self.robust_values()
        best, mean = frame_statistics(values)
        s = likelihood_shift(mean - best, int(self.params.gain))
        self.robust_update(s, best >> s)

    def robust_values(self) -> np.ndarray:
        """Robust, stage ``"scale"``: every node's integer ``r_i`` (the trees, read out).

        The first half of :meth:`compare_robust` (after :meth:`prepare_live`); the trees'
        values stay in their registers for :meth:`robust_update`. A bank combines the
        values of all its sensors before the update (:mod:`ppaloc.onsensor.bank`).
        """
        sim = self.sim
        values = np.empty(self.n_nodes, np.int64)
        both = self.tiles > 1 and self._tree_tiles(None) is not None
        regs = self._tree_tiles(None) if both else None
        with sim.stage("scale"):
            if both:
                self._run("tree_tiles", self._tree_tiles)
            for t in range(self.tiles):
                if not both:
                    self._tree_calls(t)
                    self._run(f"tree_{t}", lambda k, t=t: self._tree(k, t))
                reg = regs[t] if regs else D
                nodes, br, bc = self._tile_nodes[t]
                last_row = int(br.max()) * self.bh
                codes = sim.scan_areg(reg, 0, 0, last_row, self.size - 1, self.bh, self.bw)
                values[nodes] = self._values(codes[br, bc].astype(np.int64))
        return values

    def robust_update(self, s: int, alpha: int) -> None:
        """Robust, stage ``"compare"``: ``w += alpha_t - mu 2**-s`` at every node.

        After :meth:`robust_values`, with this frame's shift ``s`` and ``alpha_t`` (the
        controller's, from every node of the map).
        """
        sim = self.sim
        self.last_shift, self.last_alpha = s, alpha
        if self.negated:  # no transition since the last update: the weights back first
            self._run("w_back", lambda k: k.bus(_W, self.NEGATED))
            self.negated = False
        if not -128 <= alpha - self.pending_offset <= 127:
            self._settle()
        offset, self.pending_offset = self.pending_offset, 0
        both = self.tiles > 1 and self._tree_tiles(None) is not None
        regs = self._tree_tiles(None) if both else None
        with sim.stage("compare"):
            for t in reversed(range(self.tiles)):
                recompute = not both and t != self.tiles - 1
                if recompute:
                    self._tree_calls(t)
                self._root_pattern(self.dr.pattern, t)
                sim.load_in(alpha - offset)  # with the stay cost the transition left
                # the pair's value and scratch registers: tile 1 (E) keeps tile 0's D
                value, scratch = (regs[t], F if t else E) if regs else (D, E)

                def build(k, t=t, recompute=recompute, value=value, scratch=scratch):
                    if recompute:
                        self._tree(k, t)
                    self._update_robust(k, s, t, value, scratch)

                name = "update" if not recompute else "tree_update"
                neg = "_n" if self.NEGATED is not None else ""
                self._run(f"{name}_{t}_s{s}{'_both' if both else ''}{neg}", build)
            self.negated = self.NEGATED is not None
        self.scale.charge(1 if self.negated else 2)  # -(w + ...) into NEGATED, or twice

    def _tree_tiles(self, k) -> tuple[Register, ...] | None:
        """Robust, two tiles: both tiles' distance trees in one kernel (``k``), or None.

        Returns the registers holding each tile's values (also for ``k=None``, without
        issuing anything); None where the representation recomputes a tile's tree
        instead (the default).
        """
        return None

    def _scaled_sources(
        self, k, s: int, need: int, value: Register = D, scratch: Register = E
    ) -> tuple[Register, ...]:
        """Registers whose sum is ``need * mu * 2**-s``, from the tree's value in ``value``.

        Halvings (``bus2``, one write each) alternate between ``value`` and ``scratch``
        and flip the sign; when the last one has the wrong sign, the pair of the last two
        (``H + (-H / 2) = H / 2``) has the right one, so no negation is written. Only
        ``s`` below the tree's scale costs extra writes (one doubling by a copy, one more
        negation when the sign is wrong).
        """
        sign, exponent = self.value_scale  # value = sign * mu * 2**-exponent
        halvings = s - exponent
        if halvings < 0:  # s = 0 at low-res (-mu/2): two copies of +-mu/2
            if sign != need:
                k.bus(scratch, value)
            else:
                k.mov(scratch, value)
            k.mov(value, scratch)  # value = scratch
            return (value, scratch)
        cur, other = value, scratch
        for _ in range(halvings):
            k.bus2(other, NEWS, cur)  # other = -cur / 2
            cur, other = other, cur
            sign = -sign
        if sign == need:
            return (cur,)
        if halvings:
            return (other, cur)  # the last two halvings: -cur / 2 ... + cur = need |mu_s|
        k.bus(other, cur)
        return (other,)

    def _update_robust(
        self, k, s: int, tile: int, value: Register = D, scratch: Register = E
    ) -> None:
        """Robust: ``w += alpha_t - mu 2**-s`` at tile ``tile``'s roots, ``alpha_t`` in ``IN``.

        The paper preset's :meth:`_update` negates the scaled term when the halvings'
        parity is wrong (one write) and moves it for tile 1 by a ``movx`` (two), then
        ``add`` (two): up to five writes on a weight's term. Here the term is a sum of
        sources with the right sign (:meth:`_scaled_sources`); tile 0 takes ``NEWS :=
        -(w + alpha - mu_s)``, ``w := -NEWS`` (the ``add``, clip [-127, 127]); tile 1
        pushes ``+mu_s`` into the east neighbour's ``NEWS`` (one write, which negates and
        moves it to the weight's PE), then ``X := -(w + alpha - mu_s)`` and ``w := -X``:
        the same two writes and clip on the weight, three fewer in all. ``value`` holds
        the tree's values, ``scratch`` is free (and ``X``).
        """
        neg = self.NEGATED
        if tile == 0:
            sources = self._scaled_sources(k, s, -1, value, scratch)
            k.WHERE(self.dr.pattern)
            if neg is not None:  # the one write: NEGATED := -(w + alpha - mu_s)
                k.bus(neg, *sources, _W, IN)
            else:
                k.bus(NEWS, *sources, _W, IN)  # -(w + alpha - mu_s), clipped; pair first
                k.bus(_W, NEWS)
            k.all()
            return
        if tile > 1:
            raise AssertionError("a sensor holds at most two tiles")
        sources = self._scaled_sources(k, s, 1, value, scratch)
        k.bus(XE, *sources)  # NEWS = -mu_s of the west neighbour: at tile 1's root
        k.WHERE(self.dr.pattern)
        if neg is not None:
            k.bus(neg, _W, NEWS, IN)
        else:
            k.bus(scratch, _W, NEWS, IN)  # -(w + alpha - mu_s), clipped
            k.bus(_W, scratch)
        k.all()

    # --------------------------------------------------------------- robust normalisation
    def normalise(self, top: int) -> None:
        """Robust: ``w := max(clip(w - T, -127, 127), -memory)`` (docs/ppa8.md item 5).

        Only remembered here (``pending_top``): the next frame's :meth:`transition`
        subtracts ``T`` with the copy and the stay candidate it writes anyway, and
        applies the floor after its candidates, so the normalisation costs no weight
        write of its own (the old kernel wrote every weight twice when ``T != 0``).
        :meth:`weights` applies a pending normalisation to what it reads.
        """
        self.pending_top = int(top)

    def _update(self, k, x: Register, y: Register, sign: int, exponent: int, tile: int) -> None:
        """``w += alpha - base 2**exponent`` at tile ``tile``'s roots (``x = sign base``).

        ``alpha`` is in ``IN`` (``load_in``: the paper's ``alpha`` or the robust
        ``alpha_t``); the roots are in ``pattern``. One ``add`` of
        three sources: ``NEWS = -(w + alpha - mu_s)`` saturates, then ``w = -NEWS``, so
        ``w`` is clipped to [-127, 127] (docs/ppa8.md).
        """
        neg = scale_negated(k, x, sign, exponent, y)
        if tile:
            spare = y if neg is x else x
            pull(k, spare, neg, west, tile)
            neg = spare
        k.WHERE(self.dr.pattern)
        k.add(_W, _W, neg, IN)
        k.all()

    # --------------------------------------------------------------- detection
    def _at_least(self, threshold: int, name: str = "det") -> bool:
        """``cand := (W >= threshold) AND valid``; True if any PE is set (``global_or``)."""
        sim, dr = self.sim, self.dr
        sim.load_in(int(threshold))
        neg = self.NEGATED if self.negated else None

        def build(k):
            if neg is not None:
                k.where(IN, neg)  # FLAG = w < threshold, from -w: no write
            else:
                k.bus(NEWS, _W)
                k.where(IN, NEWS)  # FLAG = W < threshold
            k.NOR(dr.cand, FLAG, dr.tmp_a)  # tmp_a = NOT allowed
            k.all()

        self._run(f"{name}_n" if neg is not None else name, build)
        return bool(sim.global_or(dr.cand))

    def _max_threshold(self, lo: int, hi: int) -> int | None:
        """Largest integer ``T`` in [lo, hi] with a set PE of ``cand``; None if none."""
        if not self._at_least(lo):
            return None
        while lo < hi:
            mid = (lo + hi + 1) // 2
            if self._at_least(mid):
                lo = mid
            else:
                hi = mid - 1
        return lo

    def _nodes_of(self, events: np.ndarray) -> np.ndarray:
        """The nodes of event PEs (node roots: tile ``t`` at block column offset ``t``),
        sorted, looked up in :attr:`_block_nodes`."""
        return np.sort(self._block_nodes[events[:, 0] // self.bh, events[:, 1]])

    def _block_node_table(self) -> np.ndarray:
        """``[block row, PE column]`` -> the node whose root that PE is in that block row
        (tile ``col % bw``; the layout's ``block_to_node``): made once per layout, as the
        detection and confidence stages map their events every frame."""
        rows, cols = np.indices((self.size // self.bh, self.size))
        return self.layout.block_to_node(cols % self.bw, rows, cols // self.bw)

    def _window(self, a: int, b: int) -> None:
        """``tmp_b`` := the roots of nodes ``a..b`` (clipped to the map), via rectangles."""
        sim, dr = self.sim, self.dr
        a, b = max(a, 0), min(b, self.n_nodes - 1)
        self._run("clr_tmp_b", lambda k: k.CLR(dr.tmp_b))
        cap = self.layout.capacity
        cols = self.layout.grid_shape[1]
        for t in range(self.tiles):
            la, lb = max(a - t * cap, 0), min(b - t * cap, cap - 1)
            if la > lb:
                continue
            self._run("clr_pattern", lambda k: k.CLR(dr.pattern))
            ra, rb = la // cols, lb // cols
            spans = []
            for r in sorted({ra, rb}):
                p0 = la - r * cols if r == ra else 0
                p1 = lb - r * cols if r == rb else cols - 1
                spans.append((r, r, p0, p1))
            if rb - ra > 1:
                spans.append((ra + 1, rb - 1, 0, cols - 1))
            for r0, r1, p0, p1 in spans:
                if r0 == r1 and r0 % 2 == 0:
                    c0, c1 = cols - 1 - p1, cols - 1 - p0
                else:
                    c0, c1 = p0, p1
                sim.load_rect(
                    dr.tmp_a,
                    r0 * self.bh,
                    c0 * self.bw,
                    r1 * self.bh + self.bh - 1,
                    c1 * self.bw + self.bw - 1,
                )
                self._run("or_pattern_tmp_a", lambda k: k.OR(dr.pattern, dr.tmp_a))
            self._root_pattern(dr.tmp_a, t)
            self._run("win_and", lambda k: k.AND(dr.tmp_a, dr.tmp_a, dr.pattern))
            self._run("or_tmp_b", lambda k: k.OR(dr.tmp_b, dr.tmp_a))

    def _allow(self, outside_window: bool) -> None:
        """``tmp_a`` := NOT allowed, allowed = valid (AND NOT window in ``tmp_b``)."""
        dr = self.dr
        if outside_window:
            self._run("allow_out", lambda k: (k.NOT(dr.tmp_a, dr.valid), k.OR(dr.tmp_a, dr.tmp_b)))
        else:
            self._run("allow_all", lambda k: k.NOT(dr.tmp_a, dr.valid))

    def detect(self) -> tuple[int, int]:
        """Return ``(node, T)``: the candidate ``w >= T = floor(max W)`` nearest the previous."""
        with self.sim.stage("detect"):
            top = self.local_top()
            found = self.candidates(top, self.prev)
            while found is None and top > -127:
                # only with noise: the comparator's noise hid every candidate this time
                top -= 1
                found = self.candidates(top, self.prev)
        if not found:
            return (0 if self.prev is None else self.prev), top
        return choose_candidate(np.asarray(found), self.prev), top

    def local_top(self) -> int:
        """``floor(max W)`` over this sensor's nodes (a ``global_or`` threshold search)."""
        self._settle()
        self._allow(False)
        top = self._max_threshold(-127, 127)
        assert top is not None
        return top

    def candidates(self, top: int, prev: int | None) -> list[int] | None:
        """Nodes with ``w >= top``: all of them (fewer than :data:`EVENT_SLOTS`), or the one
        nearest ``prev`` (a window search, :meth:`_nearest`); None if none is found.

        ``prev`` may lie outside this sensor's nodes (a bank gives it in local numbers).
        After :meth:`local_top`, whose ``tmp_a`` (NOT valid) it reuses.
        """
        sim, dr = self.sim, self.dr
        self._at_least(top)
        events = sim.scan_events(dr.cand, EVENT_SLOTS)
        if not len(events):
            return None
        if len(events) < EVENT_SLOTS:
            return [int(i) for i in self._nodes_of(events)]
        return [self._nearest(top, prev)]

    def _nearest(self, top: int, prev: int | None) -> int:
        """Window search: the candidate nearest ``prev`` (smaller index first)."""
        prev = 0 if prev is None else prev
        lo, hi = 0, self.n_nodes + abs(prev)
        while lo < hi:
            mid = (lo + hi) // 2
            if self._candidate_in(prev - mid, prev + mid, top):
                hi = mid
            else:
                lo = mid + 1
        for node in (prev - lo, prev + lo):
            if 0 <= node < self.n_nodes and self._candidate_in(node, node, top):
                return node
        return min(max(prev, 0), self.n_nodes - 1)  # only with noise: the candidate hid

    def _candidate_in(self, a: int, b: int, top: int) -> bool:
        """Whether a node in ``a..b`` has ``w >= top`` (``cand`` keeps those nodes)."""
        dr = self.dr
        self._allow(False)
        self._at_least(top)
        self._window(a, b)
        self._run("cand_and", lambda k: k.AND(dr.cand, dr.cand, dr.tmp_b))
        return bool(self.sim.global_or(dr.cand))

    def confidence(self, node: int, top: int) -> float:
        """``T`` minus the integer maximum outside nodes ``node - R .. node + R``."""
        r = self.params.confidence_radius
        if node - r <= 0 and node + r >= self.n_nodes - 1:
            return 0.0
        with self.sim.stage("confidence"):
            out = self.outside_max(node - r, node + r, top)
        return 0.0 if out is None else float(top - out)

    def outside_max(self, a: int, b: int, top: int) -> int | None:
        """Largest integer threshold in [-127, ``top``] met by a node outside ``a..b``."""
        self._window(a, b)
        self._allow(True)
        return self._max_threshold(-127, top)

    def adjust(self, top: int) -> None:
        """``w := clip(w - floor(gamma T))`` (an integer through the DAC)."""
        g = int(np.floor(self.params.gamma * top))
        if not g:
            return  # nothing to take off (the host skips it too)
        with self.sim.stage("adjust"):
            self.sim.scamp5_in(D, -g)
            self._run("adjust", lambda k: k.add(_W, _W, D))

    # --------------------------------------------------------------- mapping
    def sense_node(self, frame: np.ndarray) -> np.ndarray | int:
        """Describe one reference frame on the sensor, as the mapping run does.

        Capture, block means, then the representation's description
        (:meth:`_describe`); all charged to the stage ``"mapping"``.
        """
        with self.sim.stage("mapping"):
            self.capture(frame)
            self.block_means()
            return self._describe()

    def map_keyframes(self, frames: list[np.ndarray]) -> tuple[list[np.ndarray | int], list[int]]:
        """The keyframe mapping run: ``(nodes, kept)`` over a reference traversal.

        Every frame is captured, reduced and put through the sensor's own image motion
        stage (:meth:`image_motion`, between consecutive reference frames); a frame
        becomes a node when it says forward, the first frame always (docs/ppa8.md, "The
        map"; the host's :func:`ppaloc.localise.weighted.keyframe_test`). Only kept
        frames are described. All charged to the stage ``"mapping"``; the motion planes
        are forgotten at the end.
        """
        nodes: list[np.ndarray | int] = []
        kept: list[int] = []
        self.have_prev_planes = False
        for i, frame in enumerate(frames):
            with self.sim.stage("mapping"):
                self.capture(frame)
                self.block_means(spread=True)
                moved = self.image_motion()
                if moved or not kept:
                    nodes.append(self._describe())
                    kept.append(i)
        self.have_prev_planes = False
        self.last_counts = None
        return nodes, kept

    def node_blocks(self, topomap: TopoMap) -> np.ndarray:
        """Each node's values on the PEs of its block, as the comparison reads them."""
        return topomap.node_blocks()

    @abstractmethod
    def _describe(self) -> np.ndarray | int:
        """The node description of the captured frame (after :meth:`block_means`)."""

    @abstractmethod
    def prepare_live(self) -> None:
        """Put the captured frame where the comparison reads it (after the motion stage)."""

    @abstractmethod
    def compare_paper(self) -> None:
        """Paper: ``w += alpha - mu * 2**-shift`` at every node (one kernel per tile)."""

    @abstractmethod
    def _tree(self, k, tile: int) -> None:
        """Kernel body: every node's distance of tile ``tile`` at its block's top-left PE
        of ``D``, as ``value_scale[0] * mu * 2**-value_scale[1]``."""

    def _tree_calls(self, tile: int) -> None:  # noqa: B027 - an optional hook
        """Controller calls the tree kernel of ``tile`` needs first (e.g. a DAC constant)."""

    @abstractmethod
    def _values(self, codes: np.ndarray) -> np.ndarray:
        """The integers ``r_i`` of docs/ppa8.md from the ADC codes of the tree's roots."""

    #: ``(sign, exponent)``: the tree leaves ``sign * mu * 2**-exponent`` in ``D``.
    value_scale: ClassVar[tuple[int, int]]

    def compare(self) -> None:
        """Add every node's likelihood term for the captured frame to the weights."""
        self.prepare_live()
        if self.robust:
            self.compare_robust()
        else:
            self.compare_paper()

    def _live_planes(self) -> dict[str, np.ndarray]:
        """Representation-specific planes of :meth:`register_planes` (after the weights)."""
        return {}

    # --------------------------------------------------------------- frame
    def step(self, frame: np.ndarray, moved: bool | None = None) -> tuple[int, float, bool, int]:
        """Run one frame; return ``(node, score, moved, T)``.

        ``moved`` forces the motion decision (the oracle model); otherwise the configured
        model decides. Paper: motion, shift on forward, likelihood, detection,
        confidence, adjustment every k-th frame. Robust: motion, transition (frames
        >= 2), likelihood on the first and forward frames, detection, confidence,
        normalisation (docs/ppa8.md).
        """
        self.frames += 1
        self.refresh()
        self.capture(frame)
        self.block_means()
        if moved is None:
            moved = self.motion()
        if self.robust:
            first = self.frames == 1
            if not first:
                self.transition(transition_costs(bool(moved), self.params))
            if first or moved:  # a still frame repeats the last one: no new evidence
                self.compare()
        else:
            if moved:
                self.shift_weights()
            self.compare()
        node, top = self.detect()
        score = self.confidence(node, top)
        if self.robust:
            self.normalise(top)
        elif self.frames % self.params.k == 0 and self.params.gamma:
            self.adjust(top)
        self.prev = node
        return node, score, bool(moved), top

    # --------------------------------------------------------------- inspection
    def register_planes(self) -> dict[str, np.ndarray]:
        """The registers worth a picture, labelled ``"NAME: role"`` (untimed reads).

        The map tiles, the weights, the representation's live planes, the motion
        bit-planes of the last frame and the last detection's candidates; the working
        planes are left out, since after a frame they hold whatever the last stage left.
        """
        sim, dr = self.sim, self.dr
        planes = self._map_planes()
        if self.negated:
            planes[f"{self.NEGATED.name}: minus the weights"] = sim.read(self.NEGATED)
        planes[f"{_W.name}: weights"] = sim.read(_W)  # robust: before the pending normalisation
        planes.update(self._live_planes())
        planes[f"{dr.u.name}: motion, above block mean"] = sim.read(dr.u)
        planes[f"{dr.d.name}: motion, below block mean"] = sim.read(dr.d)
        planes[f"{dr.cand.name}: detection candidates"] = sim.read(dr.cand)
        return planes

    def _map_planes(self) -> dict[str, np.ndarray]:
        """The map's registers for :meth:`register_planes`, labelled."""
        return {
            f"{reg.name}: map tile {t}": self.sim.read(reg)
            for t, reg in enumerate(self.db[: self.tiles])
        }

    def refresh(self) -> None:  # noqa: B027 - an optional hook, empty by default
        """Restore a map store that needs it (the low-res levels); run before each frame."""

    def weights(self) -> np.ndarray:
        """The weights in map order, read from the register (inspection, untimed).

        Robust: with the last frame's normalisation applied (the register holds them
        before it, :meth:`normalise`), as the host reports them.
        """
        plane = -self.sim.read(self.NEGATED) if self.negated else self.sim.read(_W)
        nodes = np.arange(self.n_nodes)
        tile, br, bc = self.layout.node_to_block(nodes)
        w = plane[br * self.bh, bc * self.bw + tile].astype(np.float64)
        if self.pending_offset:
            w = np.clip(w - self.pending_offset, -127, 127)
        if self.robust and self.pending_top is not None:
            w = np.maximum(np.clip(w - self.pending_top, -127, 127), -self.params.memory)
        return w
