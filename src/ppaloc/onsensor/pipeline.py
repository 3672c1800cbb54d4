"""The weighted-node filter's per-frame pipeline as PPA programs: kernels plus controller calls.

A pipeline owns one simulated SCAMP-5 holding a map and runs either preset of the filter
(``FilterParams.preset``: ``"robust"`` or ``"paper"``, docs/ppa8.md).
:func:`make_pipeline` builds the one of a place representation by name. Modules:

=====================================  ==================================================
:mod:`ppaloc.onsensor.core`            :class:`SensorPipeline`: capture, block means,
                                       motion, weight shift (paper), transition, scale
                                       readout and normalisation (robust), detection,
                                       confidence, adjustment (paper), keyframe
                                       mapping, reset, inspection
:mod:`ppaloc.onsensor.lowres`          :class:`LowresPipeline`: replication, SAD
                                       comparison, ``sense_node`` of 8x8 images
:mod:`ppaloc.onsensor.lbp`             :class:`LbpPipeline`: descriptor on the array,
                                       descriptor load, Hamming comparison
=====================================  ==================================================

docs/onsensor.md gives the register allocation, every stage's kernels and calls, and the
modelled budget. Register roles (``A``-``F`` analogue, ``R1``-``R11`` digital; ``R0``/``R12``
are the scratch of the logic macros, ``NEWS`` the scratch of the analogue ones):

===========  =========================================  ==================================
register     lowres                                     lbp
===========  =========================================  ==================================
A, B         database tile 0, tile 1 (``n = q/2 - 64``)  -w (robust, A), block means (B)
C            weights (tile t at block PE (0, t))        weights
D, E, F      working planes (robust transition: E the   same (F free after the motion
             shifted weights, D scratch; F keeps the    stage)
             block means for the replication)
R1, R2       replication class masks (rows, cols)       32x32 block roots, valid node roots
R3, R4       32x32 block roots, valid node roots        frame descriptor, pattern temp
R5-R8        motion planes U, D, previous U, D          same
R9-R11       candidates and temps                       candidates, database tiles 0, 1
===========  =========================================  ==================================

Shared registers: lowres R3 is both ``root32`` and ``pattern``
(:data:`ppaloc.onsensor.lowres.ROOTS`); lbp R1 is both (:data:`ppaloc.onsensor.lbp.ROOTS`),
and lbp R3/R4 are the descriptor and its temp as well as ``tmp_b``/``tmp_a``.
"""

from __future__ import annotations

from ppaloc.errors import PpalocError
from ppaloc.localise.params import FilterParams
from ppaloc.onsensor.core import DRegs, SensorPipeline, class_rows
from ppaloc.onsensor.lbp import LbpPipeline
from ppaloc.onsensor.lowres import LowresPipeline
from ppaloc.sim import NoiseParams

__all__ = [
    "PIPELINES",
    "DRegs",
    "LbpPipeline",
    "LowresPipeline",
    "SensorPipeline",
    "class_rows",
    "make_pipeline",
]

#: Pipeline class of each place representation.
PIPELINES: dict[str, type[SensorPipeline]] = {
    "lowres": LowresPipeline,
    "lbp": LbpPipeline,
}


def make_pipeline(
    representation: str,
    n_nodes: int,
    params: FilterParams,
    *,
    alpha: int | None = None,
    noise: str | NoiseParams = "ideal",
    seed: int = 0,
    size: int = 256,
    store: str | None = None,
) -> SensorPipeline:
    """Build the pipeline of ``representation`` (``"lowres"`` or ``"lbp"``).

    Parameters
    ----------
    representation : {"lowres", "lbp"}
    n_nodes : int
        Nodes of the map.
    params : FilterParams
        The filter's parameters (the host's object, :class:`FilterParams`).
    alpha : int, optional
        Paper preset: the likelihood offset (default ``params.alpha``).
    noise : str or NoiseParams
        Noise preset (or parameters) of the simulator.
    seed : int
        Seed of the simulator's noise.
    size : int
        Array side (256 on SCAMP-5; multiples of 64).
    store : str, optional
        Map store (``SensorPipeline.stores``; default the representation's for the preset).

    Returns
    -------
    SensorPipeline
        A :class:`LowresPipeline` or :class:`LbpPipeline`.

    Examples
    --------
    >>> p = FilterParams.create("lbp", motion="always_forward")
    >>> type(make_pipeline("lbp", 4, p, size=64)).__name__
    'LbpPipeline'
    """
    try:
        cls = PIPELINES[representation]
    except KeyError:
        raise PpalocError(
            f"no on-sensor pipeline for representation {representation!r}; known: "
            f"{', '.join(PIPELINES)}"
        ) from None
    return cls(n_nodes, params, alpha=alpha, noise=noise, seed=seed, size=size, store=store)
