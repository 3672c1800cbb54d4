"""What the baselines share: map building and checks, rankings and uniqueness confidences.

:class:`MapLocaliser` holds the map handling every baseline repeats (``build_map``,
``use_map``); :class:`ImageLocaliser` adds the node descriptor of SeqSLAM, the particle
filter and single-frame matching (SeqSLAM's patch-normalised image by default, or the
weighted-node filter's low-res image or LBP code: :mod:`ppaloc.baselines._descriptors`)
and the difference column.
"""

from __future__ import annotations

from collections.abc import Callable, Iterable, Sequence
from typing import ClassVar

import numpy as np

from ppaloc.baselines._descriptors import (
    LOWRES_CONTRAST,
    LOWRES_PATCH,
    haar_distances,
    haar_place,
    lbp_distances,
    lbp_place,
    lowres_distances,
    lowres_place,
)
from ppaloc.errors import PpalocError
from ppaloc.localise.base import MethodParam, signature_parameters
from ppaloc.place import HAAR_WORDS, LOWRES_GRIDS
from ppaloc.place.patch import mean_abs_diff, preprocess
from ppaloc.topomap import TopoMap

__all__ = [
    "ImageLocaliser",
    "MapLocaliser",
    "check_map",
    "require_map",
    "stack_descriptors",
    "top_k",
    "uniqueness_ratio",
]


def stack_descriptors(
    frames: Iterable[np.ndarray], describe: Callable[[np.ndarray], np.ndarray], what: str
) -> np.ndarray:
    """``describe(frame)`` of every frame, stacked, reading the frames once in order (a lazy
    traversal is never held whole: only the descriptors are); an empty one is refused."""
    out = [describe(f) for f in frames]
    if not out:
        raise PpalocError(f"{what}: the reference traversal is empty; give at least one frame")
    return np.stack(out)


def check_map(topomap: TopoMap, kind: str, shape: tuple[int, ...], method: str) -> TopoMap:
    """Check that ``topomap`` was built by ``method`` with the same parameters.

    Parameters
    ----------
    topomap : TopoMap
    kind : str
        The map kind the method writes (``TopoMap.kind``).
    shape : tuple of int
        The per-node descriptor shape the method's parameters give.
    method : str
        The method's name, for the message.

    Raises
    ------
    PpalocError
        If the kind or the descriptor shape differ, or the map is empty.
    """
    if topomap.kind != kind:
        raise PpalocError(
            f"{method} cannot use a map of kind {topomap.kind!r}; it needs kind {kind!r} "
            f"(build one with `ppaloc map SPEC --method {method}` or the localiser's build_map)"
        )
    if len(topomap) == 0:
        raise PpalocError(f"{method}: the map has no nodes; build it from at least one frame")
    got = tuple(topomap.descriptors.shape[1:])
    if got != tuple(shape):
        raise PpalocError(
            f"{method}: the map's node descriptors have shape {got} but these parameters "
            f"give {tuple(shape)}; use the parameters the map was built with ({topomap.params})"
        )
    return topomap


def require_map(topomap: TopoMap | None, method: str) -> TopoMap:
    """Return the map, or raise if none was built or given yet."""
    if topomap is None:
        raise PpalocError(f"{method}: no map yet; call build_map(frames) or use_map(map) first")
    return topomap


def top_k(evidence: np.ndarray, k: int) -> np.ndarray:
    """Indices of the ``k`` largest entries of ``evidence``, largest first (ties: lower index).

    Returns
    -------
    ndarray of int64, shape (min(k, N),)
    """
    n = len(evidence)
    k = min(int(k), n)
    if k <= 0:
        return np.empty(0, dtype=np.int64)
    if k < n:
        part = np.argpartition(-evidence, k - 1)[:k]
    else:
        part = np.arange(n)
    order = np.lexsort((part, -evidence[part]))
    return part[order].astype(np.int64)


def uniqueness_ratio(costs: np.ndarray, best: int, radius: int) -> float:
    """Return ``1 - costs[best] / min(costs outside best +- radius)`` in [0, 1].

    This is OpenSeqSLAM's match quality (the ratio of the best cost to the best cost outside
    a window around it; lower is a more unique match), turned into a confidence that grows
    with uniqueness. With no finite competitor the match is as unique as it gets (1.0); with
    a best cost that is not finite, or a competitor at zero cost, it is 0.0.
    """
    best_cost = float(costs[best])
    lo, hi = max(0, best - radius), min(len(costs), best + radius + 1)
    outside = np.concatenate((costs[:lo], costs[hi:]))
    second = float(outside.min()) if outside.size else np.inf
    if not np.isfinite(best_cost):
        return 0.0
    if not np.isfinite(second):
        return 1.0
    if second <= 0.0:
        return 0.0
    return float(np.clip(1.0 - best_cost / second, 0.0, 1.0))


class MapLocaliser:
    """Map handling shared by the baselines: one descriptor per reference frame.

    A subclass sets ``name`` and ``kind`` (the ``TopoMap.kind`` it writes) and provides
    ``describe(frame)``, ``descriptor_shape`` (the per-node shape its parameters give),
    ``params()`` (stored with the map) and ``reset()``. A subclass that takes several node
    descriptors lists them in ``DESCRIPTORS`` (its own first), sets ``descriptor`` and
    stores it in ``params()["descriptor"]``; :meth:`use_map` refuses a map of another.
    """

    name: str
    kind: str
    map: TopoMap | None
    #: The node descriptors the class can compare, its own (the default) first.
    DESCRIPTORS: ClassVar[tuple[str, ...]] = ()
    #: The node descriptor of this instance (one of :attr:`DESCRIPTORS`).
    descriptor: str = ""
    #: Accepted range of each numeric keyword parameter (a subclass's table).
    RANGES: ClassVar[dict[str, tuple[float, float]]] = {}

    @classmethod
    def parameters(cls) -> tuple[MethodParam, ...]:
        """Every keyword the class takes (:class:`~ppaloc.localise.base.MethodParam`): the
        signature's types and defaults, the ranges of :attr:`RANGES`."""
        return signature_parameters(cls, cls.RANGES)

    @property
    def descriptor_shape(self) -> tuple[int, ...]:
        """Shape of one node descriptor under the current parameters."""
        raise NotImplementedError

    def params(self) -> dict:
        """The parameters that shape the map (JSON-serialisable)."""
        raise NotImplementedError

    def descriptor_params(self) -> dict:
        """What the node descriptor is (JSON-serialisable), part of :meth:`params`:
        ``{"descriptor": ...}`` for a class with :attr:`DESCRIPTORS`, else nothing."""
        return {"descriptor": self.descriptor} if self.DESCRIPTORS else {}

    def describe(self, frame: np.ndarray) -> np.ndarray:
        """The node descriptor of one sensor frame, shape ``descriptor_shape``."""
        raise NotImplementedError

    def reset(self) -> None:
        """Forget the query history; keep the map."""
        raise NotImplementedError

    def build_map(self, frames: Sequence[np.ndarray]) -> TopoMap:
        """Build and keep a map with one descriptor (:meth:`describe`) per reference frame.

        Raises
        ------
        PpalocError
            If ``frames`` is empty or a frame is not a (256, 256) ``uint8`` sensor frame.
        """
        desc = stack_descriptors(frames, self.describe, self.name)
        return self.use_map(TopoMap(self.kind, desc, params=self.params()))

    def use_map(self, topomap: TopoMap) -> TopoMap:
        """Adopt an existing map (built by :meth:`build_map` with the same parameters).

        Raises
        ------
        PpalocError
            If the map is of another kind, holds another node descriptor (a map without
            ``params["descriptor"]`` holds the class's own), is empty, or its descriptors
            have another shape.
        """
        if self.DESCRIPTORS and topomap.kind == self.kind:
            params = topomap.params if isinstance(topomap.params, dict) else {}
            got = params.get("descriptor", self.DESCRIPTORS[0])
            if got != self.descriptor:
                raise PpalocError(
                    f"{self.name}: the map's nodes are descriptor={got!r} but this localiser "
                    f"compares descriptor={self.descriptor!r}; give descriptor={got!r} or "
                    "build the map again"
                )
            for key in ("contrast", "contrast_patch"):
                want = self.descriptor_params().get(key)
                if want is not None and params.get(key) != want:
                    had = f"{key}={params[key]!r}" if key in params else f"no {key}"
                    raise PpalocError(
                        f"{self.name}: the map's {got} nodes were normalised with {had}, "
                        f"this version normalises them with {key}={want!r}; build the map "
                        "again"
                    )
        self.map = check_map(topomap, self.kind, self.descriptor_shape, self.name)
        self.reset()
        return self.map


class ImageLocaliser(MapLocaliser):
    """A :class:`MapLocaliser` whose node descriptor is SeqSLAM's patch-normalised image
    (``descriptor="patch"``), or the weighted-node filter's place: its contrast-normalised
    8x8 or 16x16 image (``"lowres"``, ``"lowres16"``), its 32-bit LBP code (``"lbp"``) or its
    192 Haar signs (``"haar"``;
    :mod:`ppaloc.baselines._descriptors`).

    A subclass sets ``descriptor``, ``size`` (rows, cols), ``patch`` and, if it stores
    OpenSeqSLAM's quantised form, ``quantise`` (the last three shape ``"patch"`` only).
    """

    DESCRIPTORS: ClassVar[tuple[str, ...]] = ("patch", "lowres", "lowres16", "lbp", "haar")
    descriptor: str = "patch"
    size: tuple[int, int]
    patch: int
    quantise: bool = False

    @property
    def descriptor_shape(self) -> tuple[int, ...]:
        """``size`` (one downsampled image per node), ``(8, 8)`` for ``"lowres"``,
        ``(16, 16)`` for ``"lowres16"``, ``()`` (one uint32 code) for ``"lbp"``, ``(8,)``
        (8 uint32 words) for ``"haar"``."""
        if self.descriptor in LOWRES_GRIDS:
            grid = LOWRES_GRIDS[self.descriptor]
            return (grid, grid)
        if self.descriptor == "lbp":
            return ()
        if self.descriptor == "haar":
            return (HAAR_WORDS,)
        return self.size

    def descriptor_params(self) -> dict:
        """What the node descriptor is: ``"descriptor"``, with ``size`` and ``patch`` for
        ``"patch"`` and ``contrast`` and ``contrast_patch`` (the target and the tile of
        the normalisation, checked by :meth:`use_map`) for ``"lowres"``."""
        if self.descriptor in LOWRES_GRIDS:
            return {
                "descriptor": self.descriptor,
                "contrast": LOWRES_CONTRAST,
                "contrast_patch": LOWRES_PATCH,
            }
        if self.descriptor in ("lbp", "haar"):
            return {"descriptor": self.descriptor}
        return {"descriptor": "patch", "size": list(self.size), "patch": self.patch}

    def describe(self, frame: np.ndarray) -> np.ndarray:
        """The node descriptor of one sensor frame: the patch-normalised downsampled image
        (float32, shape ``size``), the low-res place (uint8, (8, 8) or (16, 16)) or the
        LBP code (uint32, ())."""
        if self.descriptor in LOWRES_GRIDS:
            return lowres_place(frame, self.descriptor)
        if self.descriptor == "lbp":
            return lbp_place(frame)
        if self.descriptor == "haar":
            return haar_place(frame)
        return preprocess(frame, self.size, self.patch, quantise=self.quantise)

    def distances(self, described: np.ndarray, nodes: np.ndarray) -> np.ndarray:
        """Distance from one described frame (:meth:`describe`) to every node.

        Returns
        -------
        ndarray of float64, shape (N,)
            The mean absolute difference per pixel (``"patch"``) or per cell
            (``"lowres"``, ``"lowres16"``), or the Hamming distance in bits (``"lbp"``,
            ``"haar"``).
        """
        if self.descriptor in LOWRES_GRIDS:
            return lowres_distances(described, nodes)
        if self.descriptor == "lbp":
            return lbp_distances(described, nodes)
        if self.descriptor == "haar":
            return haar_distances(described, nodes)
        return mean_abs_diff(described, nodes)

    def difference_column(self, frame: np.ndarray) -> np.ndarray:
        """Distance between one query frame and every node (:meth:`distances`).

        Returns
        -------
        ndarray of float64, shape (N,)

        Raises
        ------
        PpalocError
            Before a map exists.
        """
        topomap = require_map(self.map, self.name)
        return self.distances(self.describe(frame), topomap.descriptors)
