"""The weighted-node filter's per-frame pipeline as PPA programs: how the modules fit.

:func:`make_pipeline` builds the sensor executor of a place representation by name: a
:class:`~ppaloc.onsensor.executor.SensorExecutor` on which a schedule
(:mod:`ppaloc.localise.schedule`) runs its frame. Modules:

=====================================  ==================================================
:mod:`ppaloc.onsensor.sensor`          :class:`Sensor`: the simulator, its kernel cache,
                                       the snake layout, node-root patterns and windows
:mod:`ppaloc.onsensor.roles`           register roles, declared once and checked
:mod:`ppaloc.onsensor.capture`         capture, block means (stages capture, reduce)
:mod:`ppaloc.onsensor.motion`          the image motion test (stage motion)
:mod:`ppaloc.onsensor.snake`           moves along the snake (paper shift; robust copies)
:mod:`ppaloc.onsensor.transition`      robust transition, scale restore, floor
:mod:`ppaloc.onsensor.likelihood`      robust scaled readout and update; paper update
:mod:`ppaloc.onsensor.minimum`         the frame's best distance, refined on the array
:mod:`ppaloc.onsensor.detect`          detection and confidence
:mod:`ppaloc.onsensor.carry`           a bank's exact carry between sensors
:mod:`ppaloc.onsensor.weights`         what the controller still owes the weights
:mod:`ppaloc.onsensor.lowres`          :class:`LowresPlaces`: 8x8 images, map stores,
                                       replication, SAD trees; :class:`Lowres16Places`:
                                       16x16 images (the grid read by the reduce stage)
:mod:`ppaloc.onsensor.lbp`             :class:`LbpPlaces`: descriptor on the array,
                                       descriptor load, Hamming trees
:mod:`ppaloc.onsensor.haar`            :class:`HaarPlaces`: the 192 Haar signs from the
                                       16x16 codes, their load, Hamming trees
:mod:`ppaloc.onsensor.executor`        :class:`SensorExecutor`: the schedule's steps
:mod:`ppaloc.onsensor.bank`            :class:`SensorBank`: the same steps on a bank
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

The roles are :data:`ppaloc.onsensor.lowres.LOWRES_ROLES` and
:data:`ppaloc.onsensor.lbp.LBP_ROLES` (:class:`ppaloc.onsensor.roles.Roles`, checked
when a sensor is built).
"""

from __future__ import annotations

from collections.abc import Sequence

from ppaloc.localise.params import FilterParams
from ppaloc.localise.schedule import SCHEDULES, SensorPlan
from ppaloc.onsensor.executor import PLACES, SensorExecutor
from ppaloc.onsensor.lbp import LbpPlaces
from ppaloc.onsensor.lowres import Lowres16Places, LowresPlaces
from ppaloc.onsensor.roles import DRegs, Roles
from ppaloc.sim import NoiseParams
from ppaloc.sim.observe import SimObserver

__all__ = [
    "PLACES",
    "DRegs",
    "LbpPlaces",
    "Lowres16Places",
    "LowresPlaces",
    "Roles",
    "SensorExecutor",
    "make_pipeline",
]


def make_pipeline(
    representation: str,
    n_nodes: int,
    params: FilterParams,
    *,
    plan: SensorPlan | None = None,
    noise: str | NoiseParams = "ideal",
    seed: int = 0,
    size: int = 256,
    store: str | None = None,
    observers: Sequence[SimObserver] = (),
) -> SensorExecutor:
    """Build the sensor executor of ``representation`` (a key of :data:`PLACES`).

    Parameters
    ----------
    representation : {"lowres", "lowres16", "lbp", "haar"}
    n_nodes : int
        Nodes of the map.
    params : FilterParams
        The filter's parameters.
    plan : SensorPlan, optional
        What the schedule asks of the sensor (default: the plan of ``params.preset``'s
        schedule).
    noise : str or NoiseParams
        Noise preset (or parameters) of the simulator.
    seed : int
        Seed of the simulator's noise.
    size : int
        Array side (256 on SCAMP-5; multiples of 64).
    store : str, optional
        Map store (default: the first of the plan's the representation has).
    observers : sequence of SimObserver
        Observers of the sensor's simulator (:mod:`ppaloc.sim.observe`).

    Examples
    --------
    >>> p = FilterParams.create("lbp", motion="always_forward")
    >>> type(make_pipeline("lbp", 4, p, size=64).places).__name__
    'LbpPlaces'
    """
    if plan is None:
        plan = SCHEDULES[params.preset].sensor
    return SensorExecutor(
        representation,
        n_nodes,
        params,
        plan,
        noise=noise,
        seed=seed,
        size=size,
        store=store,
        observers=observers,
    )
