"""The range of every seed ppaloc takes.

One bound for the commands, the configuration files, the methods' parameters, the
simulator's noise and the route generator: a seed is a signed 64-bit integer, so it
keeps its value through JSON, TOML, ``.npz`` files and numpy's ``int64`` alike.
"""

from __future__ import annotations

__all__ = ["SEED_MAX"]

SEED_MAX = 2**63 - 1
"""The largest seed; the smallest is 0."""
