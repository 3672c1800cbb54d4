"""The topological map: an ordered list of nodes along a route."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np

__all__ = ["TopoMap"]


@dataclass(eq=False)
class TopoMap:
    """A 1-D topological map of a route: node i follows node i-1 along the route.

    Parameters
    ----------
    kind : str
        What a node holds, e.g. ``"lowres"`` (8x8 block means, uint8, shape (N, 8, 8)),
        ``"lbp"`` (32-bit descriptors, uint32, shape (N,)) or a baseline's own kind.
    descriptors : ndarray, shape (N, ...)
        One descriptor per node, in map order.
    frame_index : ndarray of int, shape (N,)
        Index of the reference frame each node was made from.
    positions : ndarray of float, shape (N, D), optional
        Route position of each node in metres, where the dataset has one.
    params : dict
        Parameters used to build the map (JSON-serialisable), kept for provenance.
    """

    kind: str
    descriptors: np.ndarray
    frame_index: np.ndarray | None = None
    positions: np.ndarray | None = None
    params: dict[str, Any] = field(default_factory=dict)

    def __post_init__(self) -> None:
        self.descriptors = np.asarray(self.descriptors)
        if self.frame_index is None:
            self.frame_index = np.arange(len(self.descriptors))
        self.frame_index = np.asarray(self.frame_index, dtype=np.int64)
        if len(self.frame_index) != len(self.descriptors):
            raise ValueError(
                f"frame_index has {len(self.frame_index)} entries for {len(self.descriptors)} nodes"
            )

    def __len__(self) -> int:
        return len(self.descriptors)
