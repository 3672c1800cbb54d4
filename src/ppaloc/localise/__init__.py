"""Localisation on the host: the ``Localiser`` interface and the weighted-node filter."""

from ppaloc.localise.base import Estimate, Localiser
from ppaloc.localise.motion import AlwaysForward, ImageMotion, OracleMotion
from ppaloc.localise.weighted import WeightedNodeLocaliser, suggest_alpha

__all__ = [
    "AlwaysForward",
    "Estimate",
    "ImageMotion",
    "Localiser",
    "OracleMotion",
    "WeightedNodeLocaliser",
    "suggest_alpha",
]
