"""Localisation on the host: the ``Localiser`` interface and the weighted-node filter."""

from ppaloc.localise.base import Estimate, Localiser

__all__ = ["Estimate", "Localiser"]
