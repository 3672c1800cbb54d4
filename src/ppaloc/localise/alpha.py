"""The paper preset's likelihood offset ``alpha``, chosen from the map alone.

docs/localise.md, "Choosing alpha".
"""

from __future__ import annotations

import math

import numpy as np

from ppaloc.errors import PpalocError
from ppaloc.localise.likelihood import distance_scale
from ppaloc.localise.params import DEFAULT_SHIFT
from ppaloc.topomap import TopoMap

__all__ = ["ALPHA_CAP", "ALPHA_FACTOR", "suggest_alpha"]

_REPRESENTATIONS = tuple(DEFAULT_SHIFT)
"""The places the paper preset runs on (not ``"lowres16"``, which it does not compare)."""


def _far_mu(topomap: TopoMap, shift: int) -> np.ndarray:
    """``mu_s`` between each node and the node half the map away (unrelated places)."""
    d = topomap.descriptors
    n = len(d)
    far = (np.arange(n) + n // 2) % n
    if topomap.kind == "lbp":
        x = np.asarray(d, np.uint32)
        raw = np.bitwise_count(x ^ x[far]).astype(np.float64)
    else:
        x = np.asarray(d, np.int64).reshape(n, -1)
        raw = np.abs(x - x[far]).sum(axis=1).astype(np.float64) * 1024
    return raw * distance_scale(topomap.kind, shift, exact=True)


ALPHA_FACTOR = 3.0
"""How far above the map's unrelated-place likelihoods :func:`suggest_alpha` puts alpha."""

ALPHA_CAP = 63
"""The largest suggested alpha: with ``gamma = 1/2`` every frame the best weight settles
near ``2 * (alpha - mu_true)``, which must stay below the 127 bound (no ties there)."""


def suggest_alpha(
    topomap: TopoMap,
    shift: int = 2,
    quantile: float = 0.99,
    factor: float = ALPHA_FACTOR,
) -> int:
    """Choose ``alpha`` from the map alone: a multiple of the unrelated-place likelihoods.

    ``alpha`` is the scaled likelihood at which a node neither gains nor loses weight.
    Only *differences* between nodes decide the estimate, so ``alpha`` matters in two
    places: a true match seen under new conditions (season, light) scores worse than
    anything in the map itself, and if ``alpha`` sits below it the true node's weight
    sinks below the 0 that enters node 0 on every forward move (the estimate then sticks
    to node 0); too high and every weight climbs to the register bound (ppa8) faster than
    the adjustment takes it off. The map gives an upper reference without any query:
    nodes half the map apart are unrelated places. A true match under other conditions
    can be worse than any of them (snow or dusk against a summer map shifts every block
    mean: on the synthetic route the winter query's true match scores about twice the
    map's 0.99 quantile), so alpha is ``factor`` (3) times the ``quantile`` of their
    ``mu_s``, rounded up to an integer (the PPA loads it through the DAC) and capped at
    :data:`ALPHA_CAP`. A generous alpha costs little: with the adjustment every frame
    (``k = 1``, ``gamma = 1/2``) only differences between weights matter until the best
    weight would reach the 127 bound, which the cap prevents.

    Parameters
    ----------
    topomap : TopoMap
        A map of kind ``"lowres"`` or ``"lbp"`` with at least 3 nodes.
    shift : int
        The filter's likelihood shift ``s`` (``mu_s = mu * 2**-s``).
    quantile : float
        Which quantile of the unrelated-pair likelihoods (default 0.99).
    factor : float
        Multiple of that quantile (default :data:`ALPHA_FACTOR`).

    Returns
    -------
    int
        ``alpha`` in [0, :data:`ALPHA_CAP`].

    Examples
    --------
    >>> from ppaloc.topomap import TopoMap
    >>> m = TopoMap("lbp", np.array([0, 0xF, 0xFF, 0xFFF], np.uint32))
    >>> suggest_alpha(m, shift=0, factor=1)  # far pairs differ in 8 bits: mu = 16
    16
    >>> suggest_alpha(m, shift=0)  # 3 * 16, capped
    48
    """
    if topomap.kind not in _REPRESENTATIONS:
        raise PpalocError(f"cannot suggest alpha for a map of kind {topomap.kind!r}")
    if len(topomap) < 3:
        raise PpalocError(
            f"a map of {len(topomap)} nodes is too small to choose alpha from; pass alpha= "
            "explicitly"
        )
    if not 0.0 <= quantile <= 1.0:
        raise PpalocError(f"quantile={quantile!r} must be in [0, 1]")
    if not (math.isfinite(factor) and factor > 0):
        raise PpalocError(f"factor={factor!r} must be a positive number")
    away = _far_mu(topomap, shift)
    value = factor * float(np.quantile(away, quantile))
    return int(min(max(math.ceil(value), 0), ALPHA_CAP))
