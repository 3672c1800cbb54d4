"""ppaloc.onsensor: the paper's mapping and localisation as PPA programs on ``ppaloc.sim``.

See docs/onsensor.md for the register allocation, the kernels and calls of every stage
and the modelled time budget.
"""

from ppaloc.onsensor.localiser import OnSensorLocaliser

__all__ = ["OnSensorLocaliser"]
