"""A ppaloc method of one's own: the nearest 16x16 thumbnail, its margin as confidence."""

import numpy as np

from ppaloc.localise.base import Estimate
from ppaloc.topomap import TopoMap


class Thumbnail:
    """Nearest 16x16 thumbnail by mean absolute difference (a plugin example)."""

    name = "thumbnail"

    def __init__(self, *, side: int = 16) -> None:
        self.side, self.nodes = side, None

    def describe(self, frame: np.ndarray) -> np.ndarray:
        s = frame.shape[0] // self.side  # sensor frames are 256 x 256
        return frame.reshape(self.side, s, self.side, s).mean(axis=(1, 3)).ravel()

    def build_map(self, frames) -> TopoMap:
        nodes = np.stack([self.describe(f) for f in frames])
        return self.use_map(TopoMap("thumbnail", nodes, params={"side": self.side}))

    def use_map(self, topomap: TopoMap) -> TopoMap:
        self.nodes = topomap.descriptors
        return topomap

    def reset(self) -> None:
        pass

    def step(self, frame: np.ndarray) -> Estimate:
        d = np.abs(self.nodes - self.describe(frame)).mean(axis=1)
        best, second = np.partition(d, 1)[:2] if len(d) > 1 else (d[0], d[0])
        return Estimate(node=int(np.argmin(d)), score=float(second - best))
