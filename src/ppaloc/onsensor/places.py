"""What a place representation gives the on-sensor pipeline: its registers and stages.

A representation (:class:`ppaloc.onsensor.lowres.LowresPlaces`,
:class:`ppaloc.onsensor.lbp.LbpPlaces`, :class:`ppaloc.onsensor.haar.HaarPlaces`)
declares its register roles and map stores, and does the stages that depend on what a
node is: the static masks, the description of a reference frame, the live frame put where
the comparison reads it, each tile's distance tree, and the readout of its values.
Everything else (capture, motion, transition, detection) is the same for all and lives in
the stage modules.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any, ClassVar

import numpy as np

from ppaloc.errors import PpalocError
from ppaloc.localise.params import FilterParams
from ppaloc.localise.schedule import SensorPlan
from ppaloc.onsensor.roles import Roles
from ppaloc.onsensor.sensor import GRID, Sensor
from ppaloc.topomap import TopoMap

__all__ = ["Places", "Tree"]

Tree = tuple[Callable[..., Any], tuple]
"""A kernel body as ``(builder, args)``: ``builder(k, *args)`` records it."""


class Places:
    """A place representation on the sensor (see the module docstring).

    Parameters
    ----------
    sensor : Sensor
        The sensor holding the map (built with :attr:`roles`).
    params : FilterParams
        The filter's parameters (the low-res ``contrast``).

    Attributes
    ----------
    representation : str
    roles : Roles
        The register roles (checked by the sensor).
    stores : dict of str to int
        Map stores and the tiles one sensor holds with each (docs/onsensor.md, "Map
        store").
    spread_means : bool
        Whether the comparison needs the block means spread over the blocks (otherwise
        only the image motion test does).
    value_scale : (int, int)
        ``(sign, e)``: a tile's tree leaves ``sign * mu * 2**-e`` at every node root.
    grid : int
        Cells per side of the live grid the reduce stage reads out where it is finer than
        the 8x8 block means (:func:`ppaloc.onsensor.capture.block_means`); 8: none read
        there.
    grid_codes : ndarray of uint8 or None
        The finer grid's codes as the reduce stage last read them.
    """

    representation: ClassVar[str]
    roles: ClassVar[Roles]
    stores: ClassVar[dict[str, int]]
    spread_means: ClassVar[bool] = True
    value_scale: ClassVar[tuple[int, int]]
    grid: ClassVar[int] = GRID
    grid_codes: np.ndarray | None = None

    def __init__(self, sensor: Sensor, params: FilterParams) -> None:
        self.sensor = sensor
        self.params = params
        self.reset()

    @classmethod
    def choose_store(cls, plan: SensorPlan, store: str | None) -> str:
        """``store`` if it is one of :attr:`stores`, else the first the schedule's plan
        prefers that this representation has; a one-line error for an unknown store."""
        if store is None:
            return next((s for s in plan.stores if s in cls.stores), next(iter(cls.stores)))
        if store not in cls.stores:
            raise PpalocError(
                f"store={store!r} is not a {cls.representation} map store; use one of "
                f"{', '.join(cls.stores)}"
            )
        return store

    @classmethod
    def max_tiles(cls, plan: SensorPlan, store: str) -> int:
        """Tiles one sensor holds with ``store`` under ``plan`` (:attr:`stores`)."""
        return cls.stores[store]

    def reset(self) -> None:
        """Forget the query (a representation's own per-frame memory)."""

    def setup_masks(self) -> None:
        """Representation-specific static masks, written before the valid roots."""

    def refresh(self, frame: int) -> None:
        """Restore a map store that needs it, before frame ``frame`` (from 1)."""

    def describe(self) -> Any:  # pragma: no cover - interface
        """The node description of the captured frame (after the block means)."""
        raise NotImplementedError

    def prepare_live(self) -> None:  # pragma: no cover - interface
        """Put the captured frame where the comparison reads it (after the motion stage)."""
        raise NotImplementedError

    def tree(self, tile: int, halving: bool) -> Tree:  # pragma: no cover - interface
        """Tile ``tile``'s distance tree: :attr:`value_scale` at each root of ``spare``
        (``halving``: the scaled readout's tree, else the paper's adding tree)."""
        raise NotImplementedError

    def tree_calls(self, tile: int, halving: bool) -> None:
        """Controller calls the tree of ``tile`` needs first (e.g. a DAC constant)."""

    def values(self, codes: np.ndarray) -> np.ndarray:  # pragma: no cover - interface
        """The integers ``r_i`` of docs/ppa8.md from the ADC codes of the trees' roots."""
        raise NotImplementedError

    def minimum(self, values: np.ndarray) -> float:
        """Robust: the frame's best distance from the readout ``values`` (the least of
        them where the readout is exact, as the descriptors' Hamming distances are)."""
        return int(values.min())

    def node_blocks(self, topomap: TopoMap) -> np.ndarray:
        """Each node's values on the PEs of its block, as the comparison reads them."""
        return topomap.node_blocks()

    def map_planes(self) -> dict[str, np.ndarray]:
        """The map's registers for a picture, labelled (untimed reads)."""
        sim = self.sensor.sim
        return {
            f"{reg.name}: map tile {t}": sim.read(reg)
            for t, reg in enumerate(self.roles.db[: self.sensor.tiles])
        }

    def live_planes(self) -> dict[str, np.ndarray]:
        """The live frame's registers for a picture, labelled (after the weights)."""
        return {}
