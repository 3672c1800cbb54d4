"""``RouteDataset``: a reference traversal, a query traversal and the ground truth."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np

__all__ = ["RouteDataset"]


@dataclass(eq=False)
class RouteDataset:
    """Two traversals of one route and which reference frames each query frame may match.

    Parameters
    ----------
    name : str
        Human-readable name, e.g. ``"nordland summer->winter"``.
    reference, query : Sequence of ndarray
        Lazy sequences of frames (2-D ``uint8``, any size; loaded on access). The reference
        becomes the map; the query is localised against it, in order.
    ground_truth : Sequence of ndarray of int
        For each query index, the sorted reference indices accepted as correct (tolerance
        already applied). An empty array means the query has no true match.
    tolerance : int
        The tolerance (in reference frames) that ``ground_truth`` was built with.
    reference_positions, query_positions : ndarray of float, shape (N, D), optional
        Route positions in metres, where the dataset has them.
    query_moved : ndarray of bool, shape (M,), optional
        Whether the camera moved forward (by at least one place) between query frames
        ``i-1`` and ``i``, where known; feeds the ``oracle`` motion model and its accuracy.
    """

    name: str
    reference: Sequence[np.ndarray]
    query: Sequence[np.ndarray]
    ground_truth: Sequence[np.ndarray]
    tolerance: int = 0
    reference_positions: np.ndarray | None = None
    query_positions: np.ndarray | None = None
    query_moved: np.ndarray | None = None
    meta: dict = field(default_factory=dict)

    def __post_init__(self) -> None:
        if len(self.ground_truth) != len(self.query):
            raise ValueError(
                f"ground truth has {len(self.ground_truth)} rows for {len(self.query)} queries"
            )
