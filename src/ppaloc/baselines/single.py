"""Single-frame best match: no sequence, no motion, the floor every sequence method must clear.

Each query frame is reduced exactly as SeqSLAM reduces it (64x32, 8x8 patch normalisation)
and compared with every node by the mean absolute difference per pixel; the estimate is the
closest node. The confidence is the uniqueness of the best distance against the best
distance outside ``+- radius`` nodes: ``1 - d_best / d_second``. ``descriptor="lowres"``,
``"lowres16"``, ``"lbp"`` or ``"haar"`` matches the weighted-node filter's place instead
(:mod:`ppaloc.baselines._descriptors`).
"""

from __future__ import annotations

from typing import ClassVar, Literal

import numpy as np

from ppaloc.baselines._common import ImageLocaliser, top_k, uniqueness_ratio
from ppaloc.baselines._descriptors import check_descriptor
from ppaloc.errors import PpalocError
from ppaloc.localise.base import Estimate
from ppaloc.place.patch import check_patch_image
from ppaloc.topomap import TopoMap

__all__ = ["SingleFrame"]

KIND = "single-frame"


class SingleFrame(ImageLocaliser):
    """Best single-frame match on SeqSLAM's patch-normalised images.

    Parameters
    ----------
    size : (rows, cols)
        Downsampled image size (as SeqSLAM: 32 x 64), each side a divisor of 256 and a
        multiple of ``patch``; ``descriptor="patch"`` only.
    patch : int
        Patch normalisation tile side (as SeqSLAM: 8), at least 2; ``descriptor="patch"``
        only.
    descriptor : {"patch", "lowres", "lowres16", "lbp", "haar"}
        What a node holds and how it is compared: SeqSLAM's patch-normalised image by the
        mean absolute difference per pixel (default), the weighted-node filter's
        contrast-normalised 8x8 or 16x16 image by the mean absolute difference per cell, or its
        32-bit LBP code by the Hamming distance (:mod:`ppaloc.baselines._descriptors`).
    radius : int
        The competitor of the confidence is the closest node outside ``best +- radius``
        (5, SeqSLAM's ``Rwindow / 2``).
    top_k : int
        Length of ``Estimate.ranking``.
    record_weights : bool
        Put minus the distance of every node in ``Estimate.weights``.
    """

    name = "single-frame"
    kind = KIND

    #: Accepted range of each numeric parameter (of each item of a pair), where a value
    #: drives memory or time or leaves the method's meaning; the defaults lie inside.
    RANGES: ClassVar[dict[str, tuple[float, float]]] = {
        "size": (1, 256),
        "patch": (2, 256),
        "radius": (0, 1_000_000),
        "top_k": (1, 10_000),
    }

    def __init__(
        self,
        *,
        size: tuple[int, int] = (32, 64),
        patch: int = 8,
        descriptor: Literal["patch", "lowres", "lowres16", "lbp", "haar"] = "patch",
        radius: int = 5,
        top_k: int = 10,
        record_weights: bool = False,
    ) -> None:
        if radius < 0 or top_k < 1:
            raise PpalocError(
                f"SingleFrame needs radius >= 0 and top_k >= 1, got radius={radius}, top_k={top_k}"
            )
        self.size = (int(size[0]), int(size[1]))
        self.patch = int(patch)
        own = {"size": (self.size, (32, 64)), "patch": (self.patch, 8)}
        self.descriptor = check_descriptor("SingleFrame", descriptor, own)
        if self.descriptor == "patch":  # at build, not at the first frame
            check_patch_image("SingleFrame", self.size, self.patch)
        self.radius = int(radius)
        self.top_k = int(top_k)
        self.record_weights = bool(record_weights)
        self.map: TopoMap | None = None

    def params(self) -> dict:
        """The parameters that shape the map (JSON-serialisable)."""
        return {**self.descriptor_params(), "radius": self.radius}

    def reset(self) -> None:
        """Nothing to forget: every frame is matched on its own."""

    def step(self, frame: np.ndarray) -> Estimate:
        """Match one query frame against every node."""
        d = self.difference_column(frame)
        best = int(np.argmin(d))
        return Estimate(
            node=best,
            score=uniqueness_ratio(d, best, self.radius),
            ranking=top_k(-d, self.top_k),
            weights=-d if self.record_weights else None,
        )
