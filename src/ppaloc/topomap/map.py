"""The topological map: an ordered list of nodes along a route."""

from __future__ import annotations

import json
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from ppaloc.place import HAAR_WORDS, LOWRES_GRIDS, PATCH_SHAPE, unpack_bits, unpack_plane
from ppaloc.topomap.layout import KIND_BLOCK_SHAPES, SnakeLayout, layout_for

__all__ = ["KIND_SPECS", "PATCH_LIMIT", "TopoMap", "value_problem"]

KIND_SPECS: dict[str, tuple[np.dtype, tuple[int, ...]]] = {
    **{kind: (np.dtype(np.uint8), (g, g)) for kind, g in LOWRES_GRIDS.items()},
    "lbp": (np.dtype(np.uint32), ()),
    "haar": (np.dtype(np.uint32), (HAAR_WORDS,)),
    "patch": (np.dtype(np.float32), PATCH_SHAPE),
}
"""Descriptor dtype and per-node shape of the place representations of ``ppaloc.place``.

Other kinds (a baseline's own descriptors) are accepted with any numeric dtype.
"""


#: The largest value a ``"patch"`` map's descriptors may hold: each is a z-score within
#: its tile, at most ``(n - 1) / sqrt(n)`` for a tile of ``n`` pixels (7.875 for the 8x8
#: tiles of :func:`ppaloc.place.patch_image`), below ``sqrt(2048)`` for any tile of the
#: 64x32 image. A larger value is an altered map, and near float32's limit its distances
#: overflow to infinity.
PATCH_LIMIT = 46.0


def value_problem(
    kind: str,
    descriptors: np.ndarray,
    frame_index: np.ndarray,
    positions: np.ndarray | None,
) -> str | None:
    """The first value no map can hold, in words, or None: a reference frame number below
    0, a NaN or infinity in float descriptors or in the positions (the filters' distances
    and the evaluation's errors would be NaN), a ``"patch"`` value beyond
    :data:`PATCH_LIMIT`. One check for the constructor and for :func:`~ppaloc.topomap.
    load_map` alike, so a map that can be made can be saved and loaded again."""
    fi = np.asarray(frame_index)
    if len(fi) and int(fi.min()) < 0:
        i = int(np.argmin(fi))
        return f"frame_index[{i}] is {int(fi[i])}; reference frame numbers are >= 0"
    for name, a in (("descriptors", descriptors), ("positions", positions)):
        if a is not None and a.dtype.kind == "f" and a.size and not np.isfinite(a).all():
            i = int(np.flatnonzero(~np.isfinite(a.reshape(len(a), -1)).all(axis=1))[0])
            return f"{name}[{i}] holds a NaN or infinite value"
    d = descriptors
    if kind == "patch" and d.size and float(np.abs(d).max()) > PATCH_LIMIT:
        i = int(np.flatnonzero((np.abs(d.reshape(len(d), -1)) > PATCH_LIMIT).any(axis=1))[0])
        value = float(np.abs(d[i]).max())
        return (
            f"descriptors[{i}] holds {value:.3g}, outside +-{PATCH_LIMIT:g}, the range of a "
            "patch-normalised image"
        )
    return None


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
        Index of the reference frame each node was made from (default ``0 .. N-1``).
    positions : ndarray of float, shape (N, D), optional
        Route position of each node in metres, where the dataset has one.
    params : dict
        Parameters used to build the map (JSON-serialisable), kept for provenance.
    provenance : dict
        Where the map came from (JSON-serialisable): filled by :func:`build_topomap`
        (``dataset``) and by :meth:`save` (``ppaloc_version``, ``created``).
    places : ndarray of int, shape (N,), optional
        The place each node shows, from 0 and rising by 0 or 1 from node to node: the
        nodes of one place are a run (a stop of the reference kept frame by frame, as a
        map of one node per frame keeps it). None: every node is a place of its own.

    Examples
    --------
    >>> import numpy as np
    >>> m = TopoMap("lbp", np.array([1, 2, 3], np.uint32))
    >>> len(m), m.frame_index.tolist(), m.layout.capacity, m.n_tiles
    (3, [0, 1, 2], 2048, 1)
    """

    kind: str
    descriptors: np.ndarray
    frame_index: np.ndarray | None = None
    positions: np.ndarray | None = None
    params: dict[str, Any] = field(default_factory=dict)
    provenance: dict[str, Any] = field(default_factory=dict)
    places: np.ndarray | None = None

    def __post_init__(self) -> None:
        if not isinstance(self.kind, str) or not self.kind:
            raise ValueError(
                f"kind must name what a node holds (a str such as 'lbp'), got {self.kind!r:.40}"
            )
        self.descriptors = np.asarray(self.descriptors)
        if self.descriptors.ndim == 0:
            raise ValueError("descriptors must have one entry per node, shape (N, ...)")
        spec = KIND_SPECS.get(self.kind)
        if spec is not None:
            dtype, shape = spec
            if self.descriptors.dtype != dtype or self.descriptors.shape[1:] != shape:
                raise ValueError(
                    f"a {self.kind!r} map holds {dtype} descriptors of shape (N, "
                    f"{', '.join(map(str, shape))}), got {self.descriptors.dtype} "
                    f"{self.descriptors.shape}; build them with ppaloc.place"
                )
        if self.frame_index is None:
            self.frame_index = np.arange(len(self.descriptors))
        try:
            self.frame_index = np.asarray(self.frame_index, dtype=np.int64)
        except (OverflowError, TypeError, ValueError):
            raise ValueError(
                f"frame_index must hold one reference frame number per node (integers), got "
                f"{self.frame_index!r:.60}"
            ) from None
        if self.frame_index.shape != (len(self.descriptors),):
            raise ValueError(
                f"frame_index must hold one reference frame per node, shape "
                f"({len(self.descriptors)},), got {self.frame_index.shape}"
            )
        if self.positions is not None:
            self.positions = np.asarray(self.positions, dtype=np.float64)
            if self.positions.ndim == 1:
                self.positions = self.positions[:, None]
            if self.positions.ndim != 2 or len(self.positions) != len(self.descriptors):
                raise ValueError(
                    f"positions must have shape (N, D) with N = {len(self.descriptors)} nodes, "
                    f"got {self.positions.shape}"
                )

        problem = value_problem(self.kind, self.descriptors, self.frame_index, self.positions)
        if problem:
            raise ValueError(problem)
        if self.places is not None:
            self.places = np.asarray(self.places)
            if self.places.shape != (len(self.descriptors),) or not np.issubdtype(
                self.places.dtype, np.integer
            ):
                raise ValueError(
                    f"places must hold one integer per node ({len(self.descriptors)}), got "
                    f"{self.places.dtype} {self.places.shape}"
                )
            self.places = self.places.astype(np.int64)
            steps = np.diff(self.places)
            if len(self.places) and (self.places[0] != 0 or ((steps != 0) & (steps != 1)).any()):
                raise ValueError(
                    "places must start at 0 and rise by 0 or 1 from node to node (a run of "
                    "equal places is one place)"
                )

    def __len__(self) -> int:
        return len(self.descriptors)

    @property
    def has_runs(self) -> bool:
        """Whether some consecutive nodes show one place (:attr:`places`)."""
        return (
            self.places is not None
            and bool(len(self.places))
            and (int(self.places[-1]) + 1 < len(self.places))
        )

    def place_window(self, node: int, radius: int) -> tuple[int, int]:
        """The nodes ``a .. b`` (inclusive) whose place is within ``radius`` places of
        ``node``'s: ``node +- radius`` where every node is a place of its own.

        Examples
        --------
        >>> import numpy as np
        >>> m = TopoMap("lbp", np.zeros(6, np.uint32), places=[0, 1, 1, 1, 2, 3])
        >>> m.place_window(2, 1), m.place_window(5, 1)
        ((0, 4), (4, 5))
        >>> TopoMap("lbp", np.zeros(6, np.uint32)).place_window(2, 1)
        (1, 3)
        """
        if self.places is None:
            return node - radius, node + radius
        p = int(self.places[node])
        a = int(np.searchsorted(self.places, p - radius, side="left"))
        b = int(np.searchsorted(self.places, p + radius, side="right")) - 1
        return a, b

    def frame_spans(self) -> tuple[np.ndarray, np.ndarray]:
        """``(first, end)``: node ``j`` stands for reference frames ``first[j] <= f < end[j]``.

        A keyframe map's node covers the frames up to the next node's frame (a stop in
        the reference is one node); the last node runs to ``params["n_frames"]`` where
        the map records it, else to its own frame + 1. Evaluation does not use them: an
        estimate is scored by its node's own frame (``frame_index``), as every method's.

        Examples
        --------
        >>> import numpy as np
        >>> nodes = np.zeros(3, np.uint32)
        >>> m = TopoMap("lbp", nodes, frame_index=[0, 1, 5], params={"n_frames": 8})
        >>> [a.tolist() for a in m.frame_spans()]
        [[0, 1, 5], [1, 5, 8]]
        """
        first = self.frame_index
        if len(first) == 0:
            return first.copy(), first.copy()
        n_frames = self.params.get("n_frames") if isinstance(self.params, dict) else None
        last_end = first[-1] + 1
        if isinstance(n_frames, int) and not isinstance(n_frames, bool) and n_frames > first[-1]:
            last_end = n_frames
        end = np.empty_like(first)
        end[:-1] = first[1:]
        end[-1] = last_end
        np.maximum(end, first + 1, out=end)  # a map whose frames are not increasing
        return first.copy(), end

    def place_frames(self) -> np.ndarray:
        """How many reference frames each node's place stands for: its frame span
        (:meth:`frame_spans`) summed over the nodes of its place (:attr:`places`). More
        than one where the reference stood still (or hardly moved): a stop kept as one
        node of a keyframe map, or as a run of nodes of a map of every frame.

        Examples
        --------
        >>> import numpy as np
        >>> nodes = np.zeros(4, np.uint32)
        >>> TopoMap("lbp", nodes, frame_index=[0, 1, 5, 6], params={"n_frames": 7}).place_frames()
        array([1, 4, 1, 1])
        >>> TopoMap("lbp", nodes, places=[0, 1, 1, 2]).place_frames()
        array([1, 2, 2, 1])
        """
        first, end = self.frame_spans()
        spans = end - first
        if self.places is None or not len(spans):
            return spans
        per_place = np.bincount(self.places, weights=spans).astype(np.int64)
        return per_place[self.places]

    @property
    def layout(self) -> SnakeLayout | None:
        """The snake layout of this kind on a 256x256 array (None for kinds without one)."""
        return layout_for(self.kind) if self.kind in KIND_BLOCK_SHAPES else None

    @property
    def n_tiles(self) -> int | None:
        """Planes (registers or sensors) the map needs on the PE array, where it has a layout."""
        layout = self.layout
        return None if layout is None else layout.n_tiles(len(self))

    def node_blocks(self) -> np.ndarray:
        """Return each node's values on the PEs of its block, shape (N, block_rows, block_cols).

        ``"lowres"``, ``"lowres16"``: the uint8 (8, 8) or (16, 16) image itself. ``"lbp"``:
        the 32 bits as uint8 0/1 in a 4x8 block, row k = cell k's code, MSB in column 0
        (see ``KIND_BLOCK_SHAPES``). ``"haar"``: the 16x16 plane of 0/1 Haar signs.
        """
        if self.kind in LOWRES_GRIDS:
            return self.descriptors
        if self.kind == "lbp":
            return unpack_bits(self.descriptors).reshape(len(self), *KIND_BLOCK_SHAPES["lbp"])
        if self.kind == "haar":
            return unpack_plane(self.descriptors)
        raise ValueError(
            f"a {self.kind!r} map has no PE layout; only {', '.join(KIND_BLOCK_SHAPES)} do"
        )

    def planes(self, *, fill: int = 0) -> np.ndarray:
        """Return the map as PE planes, shape (n_tiles, 256, 256), in the snake layout.

        Examples
        --------
        >>> import numpy as np
        >>> p = TopoMap("lbp", np.array([0x80000001], np.uint32)).planes()
        >>> p.shape, int(p[0, 0, 248]), int(p[0, 3, 255]), int(p.sum())
        ((1, 256, 256), 1, 1, 2)
        """
        blocks = self.node_blocks()  # raises for a kind without a PE layout
        return layout_for(self.kind).to_planes(blocks, fill=fill)

    def save(self, path: str | Path, *, dataset: str | None = None) -> Path:
        """Write the map to one versioned ``.npz`` file, atomically (see :func:`save_map`)."""
        from ppaloc.topomap.io import save_map

        return save_map(self, path, dataset=dataset)

    @classmethod
    def load(cls, path: str | Path) -> TopoMap:
        """Read a map written by :meth:`save` (see :func:`load_map`)."""
        from ppaloc.topomap.io import load_map

        return load_map(path)

    def equals(self, other: TopoMap) -> bool:
        """True when both maps hold the same kind, arrays and parameters (as saved)."""

        def same(a: np.ndarray | None, b: np.ndarray | None) -> bool:
            if a is None or b is None:
                return a is b
            return a.dtype == b.dtype and a.shape == b.shape and bool(np.array_equal(a, b))

        return (
            self.kind == other.kind
            and same(self.descriptors, other.descriptors)
            and same(self.frame_index, other.frame_index)
            and same(self.positions, other.positions)
            and same(self.places, other.places)
            and _normalised(self.params) == _normalised(other.params)
        )


def _normalised(params: dict[str, Any]) -> str:
    """Parameters as saved (JSON: tuples become lists), for comparison."""
    return json.dumps(params, sort_keys=True, default=str)
