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
        and same-place closure already applied): the *hard* ground truth, what a method
        must find. An empty array means the query has no true match. A
        :class:`~ppaloc.datasets.groundtruth.PackedSets` may carry soft sets
        (:attr:`soft_ground_truth`).
    tolerance : int
        The tolerance (in reference frames) that ``ground_truth`` was built with (0 when
        it was built in metres: ``tolerance_m``).
    reference_positions, query_positions : ndarray of float, shape (N, D), optional
        Route positions in metres, where the dataset has them.
    query_moved : ndarray of bool, shape (M,), optional
        Whether the camera moved forward (by at least one place) between query frames
        ``i-1`` and ``i``, where known; feeds the ``oracle`` motion model and its accuracy.
    meta : dict
        Loader details; every loader sets ``meta["roles"]`` (``{"database": ...,
        "query": ...}``, what each traversal is) and :func:`~ppaloc.datasets.route.
        assemble` sets ``meta["ground_truth_rule"]`` (how the ground truth was made).
    reference_groups : ndarray of int, shape (G, 2), optional
        ``[first, end)`` of each same-place group of reference frames the ground truth was
        closed over (:mod:`ppaloc.datasets.sameplace`); None when no rule ran.
    query_groups : ndarray of int, shape (G, 2), optional
        ``[first, end)`` of each same-place group of query frames the ground truth was
        closed over (the ``still-frames`` rule reads both traversals); None when no rule
        read the query.
    tolerance_m : float, optional
        The tolerance in metres, where the ground truth comes from positions.
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
    reference_groups: np.ndarray | None = None
    query_groups: np.ndarray | None = None
    tolerance_m: float | None = None

    def __post_init__(self) -> None:
        if len(self.ground_truth) != len(self.query):
            raise ValueError(
                f"ground truth has {len(self.ground_truth)} rows for {len(self.query)} queries"
            )
        if self.query_moved is not None and len(self.query_moved) != len(self.query):
            raise ValueError(
                f"query_moved has {len(self.query_moved)} entries for {len(self.query)} "
                "queries: one per query frame"
            )

    @property
    def soft_ground_truth(self) -> Sequence[np.ndarray] | None:
        """Per query, the reference indices a prediction may fall on without being wrong
        (each holding its hard set); None when the dataset has no soft ground truth."""
        return getattr(self.ground_truth, "soft", None)
