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
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from collections.abc import Callable
from dataclasses import dataclass, fields
from typing import Any, ClassVar

import numpy as np

from ppaloc.errors import PpalocError
from ppaloc.localise.motion import forward_decision
from ppaloc.localise.weighted import choose_candidate
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
from ppaloc.topomap import SnakeLayout, layout_for

__all__ = [
    "EVENT_SLOTS",
    "GRID",
    "WEIGHTS",
    "DRegs",
    "PipelineParams",
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


@dataclass(frozen=True)
class PipelineParams:
    """The filter parameters the pipeline needs (the host's, docs/ppa8.md)."""

    alpha: int
    gamma: float
    k: int
    shift: int
    motion: str
    margin: int = 3
    motion_shift: int = 6
    min_support: int = 1024
    confidence_radius: int = 10


def class_rows(n: int, block: int) -> np.ndarray:
    """Indices ``r < n`` with ``r % 8 == r // block``: where class ``r % 8`` starts its copy."""
    r = np.arange(n)
    return r[(r % GRID) == (r // block)]


def mask_bits(n: int) -> int:
    """``rx``/``cx`` of ``load_pattern`` that matches addresses modulo ``n`` (a power of 2)."""
    return 0xFF & ~(n - 1)


class SensorPipeline(ABC):
    """One simulated sensor holding a map, and the per-frame pipeline on it.

    The representation-independent core; build one with
    :func:`ppaloc.onsensor.pipeline.make_pipeline` (or a subclass directly).

    Parameters
    ----------
    n_nodes : int
        Nodes of the map (tiles follow from the layout's capacity).
    params : PipelineParams
    noise : str or NoiseParams
        Noise preset (or parameters) of the simulator.
    seed : int
        Seed of the simulator's noise.
    size : int
        Array side (256 on SCAMP-5; smaller arrays, multiples of 64, for tests).

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
    """

    representation: ClassVar[str]
    dr: ClassVar[DRegs]
    db: ClassVar[tuple[Register, Register]]
    static_masks: ClassVar[tuple[Register, ...]]
    root_means: ClassVar[Register | None] = None
    spread_means: ClassVar[bool] = True

    def __init__(
        self,
        n_nodes: int,
        params: PipelineParams,
        *,
        noise: str | NoiseParams = "ideal",
        seed: int = 0,
        size: int = 256,
    ) -> None:
        if size % 64 or size < 64:
            raise PpalocError(f"array size {size} must be a multiple of 64 (8x8 grid of blocks)")
        representation = self.representation
        self.params = params
        self.size = size
        self.block = size // GRID  # pixels per grid block side (32 on a 256 array)
        self.layout: SnakeLayout = layout_for(representation, (size, size))
        self.bh, self.bw = self.layout.block_shape
        self.n_nodes = int(n_nodes)
        self.tiles = self.layout.n_tiles(self.n_nodes)
        if self.tiles > 2:
            raise PpalocError(
                f"a {representation} map of {n_nodes} nodes needs {self.tiles} tiles; one "
                f"simulated sensor holds at most 2 ({2 * self.layout.capacity} nodes): "
                "split the route"
            )
        self.sim = Scamp5(size, size, noise=noise, seed=seed)
        self.kc = KernelCache(self.sim)
        self._setup_static_masks()
        self.reset()

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
        self.frames = 0
        self.prev: int | None = None
        self.have_prev_planes = False
        self.last_counts: tuple[int, int] | None = None

    # ------------------------------------------------------------------ stages
    def capture(self, frame: np.ndarray) -> None:
        """Capture into ``E`` (``v = p/2 - 64``), refresh static masks, reload block roots."""
        sim, dr = self.sim, self.dr
        sim.set_image(frame)
        with sim.stage("capture"):
            static = self.static_masks

            def build(k):
                k.get_image(E, F)
                for reg in static:
                    k.REFRESH(reg)

            self._run("capture", build)
            bits = mask_bits(self.block)
            sim.load_pattern(dr.root32, 0, 0, bits, bits)

    def block_means(self) -> None:
        """``F := -m``: every PE holds minus the exact mean of its grid block of ``v``.

        A halving tree leaves each block's mean at its top-left PE (``D``); a doubling
        tree over a zero background spreads it back over the block.
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

        def spread(k):
            k.res(F)
            k.WHERE(dr.root32)
            k.mov(F, D)
            k.all()
            for direction in (west, north):
                for step in levels:
                    add_level(k, F, D, direction, step)

        with self.sim.stage("reduce"):
            self._run("reduce", reduce)
            if self.spread_means or self.params.motion == "image":
                self._run("spread", spread)

    def motion(self) -> bool:
        """Forward or stay (docs/ppa8.md item 1); updates the previous planes."""
        p, sim, dr = self.params, self.sim, self.dr
        first = self.frames == 1
        if p.motion == "always_forward":
            return not first
        if p.motion != "image":
            raise AssertionError(p.motion)
        with sim.stage("motion"):
            self._run("motion_diff", lambda k: k.add(D, E, F))  # D = v - m
            sim.scamp5_in(E, -p.margin)

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
        return forward_decision(changed, support, shift=p.motion_shift, min_support=p.min_support)

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

    def _update(self, k, x: Register, y: Register, sign: int, exponent: int, tile: int) -> None:
        """``w += alpha - base 2**exponent`` at tile ``tile``'s roots (``x = sign base``).

        ``alpha`` is in ``IN`` (``load_in``); the roots are in ``pattern``. One ``add`` of
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

        def build(k):
            k.bus(NEWS, _W)
            k.where(IN, NEWS)  # FLAG = W < threshold
            k.NOR(dr.cand, FLAG, dr.tmp_a)  # tmp_a = NOT allowed
            k.all()

        self._run(name, build)
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
        rows, cols = events[:, 0], events[:, 1]
        tile = cols % self.bw
        return np.sort(self.layout.block_to_node(tile, rows // self.bh, cols // self.bw))

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
        sim, dr = self.sim, self.dr
        with sim.stage("detect"):
            self._allow(False)
            top = self._max_threshold(-127, 127)
            assert top is not None
            self._at_least(top)
            events = sim.scan_events(dr.cand, EVENT_SLOTS)
            while not len(events) and top > -127:
                # only with noise: the comparator's noise hid every candidate this time
                top -= 1
                self._at_least(top)
                events = sim.scan_events(dr.cand, EVENT_SLOTS)
            if not len(events):
                node = 0 if self.prev is None else self.prev
            elif len(events) < EVENT_SLOTS:
                node = choose_candidate(self._nodes_of(events), self.prev)
            else:
                node = self._nearest(top)
        return node, top

    def _nearest(self, top: int) -> int:
        """Window search: the candidate nearest the previous estimate (smaller index first)."""
        prev = 0 if self.prev is None else self.prev
        lo, hi = 0, self.n_nodes
        while lo < hi:
            mid = (lo + hi) // 2
            if self._candidate_in(prev - mid, prev + mid, top):
                hi = mid
            else:
                lo = mid + 1
        for node in (prev - lo, prev + lo):
            if 0 <= node < self.n_nodes and self._candidate_in(node, node, top):
                return node
        return prev  # only with noise: the comparator's noise hid the candidate

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
            self._window(node - r, node + r)
            self._allow(True)
            out = self._max_threshold(-127, top)
        return 0.0 if out is None else float(top - out)

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

    @abstractmethod
    def _describe(self) -> np.ndarray | int:
        """The node description of the captured frame (after :meth:`block_means`)."""

    @abstractmethod
    def compare(self) -> None:
        """Add every node's likelihood term for the captured frame to the weights."""

    def _live_planes(self) -> dict[str, np.ndarray]:
        """Representation-specific planes of :meth:`register_planes` (after the weights)."""
        return {}

    # --------------------------------------------------------------- frame
    def step(self, frame: np.ndarray, moved: bool | None = None) -> tuple[int, float, bool, int]:
        """Run one frame; return ``(node, score, moved, T)``.

        ``moved`` forces the motion decision (the oracle model); otherwise the configured
        model decides.
        """
        self.frames += 1
        self.capture(frame)
        self.block_means()
        if moved is None:
            moved = self.motion()
        if moved:
            self.shift_weights()
        self.compare()
        node, top = self.detect()
        score = self.confidence(node, top)
        if self.frames % self.params.k == 0 and self.params.gamma:
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
        planes = {
            f"{reg.name}: map tile {t}": sim.read(reg)
            for t, reg in enumerate(self.db[: self.tiles])
        }
        planes[f"{_W.name}: weights"] = sim.read(_W)
        planes.update(self._live_planes())
        planes[f"{dr.u.name}: motion, above block mean"] = sim.read(dr.u)
        planes[f"{dr.d.name}: motion, below block mean"] = sim.read(dr.d)
        planes[f"{dr.cand.name}: detection candidates"] = sim.read(dr.cand)
        return planes

    def weights(self) -> np.ndarray:
        """The weights in map order, read from the register (inspection, untimed)."""
        plane = self.sim.read(_W)
        nodes = np.arange(self.n_nodes)
        tile, br, bc = self.layout.node_to_block(nodes)
        return plane[br * self.bh, bc * self.bw + tile].astype(np.float64)
