"""The procedural route generator: a drive through a generated world under named conditions.

``make_synthetic(...)`` (or the spec ``synthetic:?places=500&query=winter&seed=1``) gives a
:class:`~ppaloc.datasets.base.RouteDataset`; :func:`conditions_montage` draws the conditions.
"""

from ppaloc.datasets.synthetic.conditions import CONDITIONS, Condition
from ppaloc.datasets.synthetic.generate import make_synthetic
from ppaloc.datasets.synthetic.montage import conditions_montage, sequence_strip

__all__ = ["CONDITIONS", "Condition", "conditions_montage", "make_synthetic", "sequence_strip"]
