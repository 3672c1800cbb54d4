"""The range of every seed ppaloc takes.

One bound for the commands, the configuration files, the methods' parameters (the
on-sensor methods' noise seed among them), the route generator and ``ppaloc cpp run``: a
seed is a signed 64-bit integer, so it keeps its value through JSON, TOML, ``.npz`` files
and numpy's ``int64`` alike. (``Scamp5`` itself, the simulator's Python API, takes any
seed of 0 or more, as numpy's generators do.)
"""

from __future__ import annotations

__all__ = ["SEED_MAX"]

SEED_MAX = 2**63 - 1
"""The largest seed; the smallest is 0."""
