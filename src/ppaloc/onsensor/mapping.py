"""Writing a map into the sensor's registers, as the controller would on SCAMP-5.

The controller can reach individual PEs only through address patterns (``load_rect``,
``load_point``, ``load_pattern``) and the DAC (``scamp5_in``). A map is written plane by
plane in the snake layout of :mod:`ppaloc.topomap.layout`:

- low-res nodes (``n = q/2 - 64``; the robust preset's ``q`` contrast-normalised by the
  controller first, :func:`ppaloc.place.normalise_contrast`) into an analogue register:
  for every distinct value ``2n = q - 128`` the controller ORs one ``load_rect`` per
  horizontal run of PEs holding it into a digital mask, loads the value through the DAC
  where the mask is set, and at the end one halving turns ``2n`` into ``n`` exactly;
  with the levels store the two 4-bit halves' levels go into ``A`` and ``B`` the same
  way (16 values each, no halving);
- LBP descriptors into a digital register: one ``load_rect`` per run of set bits, ORed.

Everything is charged to the stage ``"mapping"``.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from ppaloc.onsensor.lowres import LowresPlaces
from ppaloc.onsensor.runs import plan_runs
from ppaloc.onsensor.sensor import Sensor
from ppaloc.sim import NEWS, D, Kernel, Register
from ppaloc.topomap import TopoMap

if TYPE_CHECKING:
    from ppaloc.onsensor.executor import SensorExecutor

__all__ = ["row_runs", "upload_map"]


def row_runs(plane: np.ndarray) -> list[tuple[int, int, int, int]]:
    """Maximal horizontal runs of equal values: ``(value, row, col0, col1)`` (inclusive)."""
    runs = []
    rows, cols = plane.shape
    for r in range(rows):
        row = plane[r]
        starts = np.flatnonzero(np.r_[True, row[1:] != row[:-1]])
        ends = np.r_[starts[1:], cols] - 1
        for c0, c1 in zip(starts, ends, strict=True):
            runs.append((int(row[c0]), r, int(c0), int(c1)))
    return runs


def _mask_from_runs(sensor: Sensor, target: Register, runs) -> None:
    sensor.rect_mask(target, [(r, c0, r, c1) for _, r, c0, c1 in runs])


def _write_values(sensor: Sensor, db: Register, values: np.ndarray, skip: int | None) -> None:
    """``db := values`` (integers): ``res``, then per distinct value (but ``skip``, which
    ``res`` leaves as 0) a mask of its runs and one DAC load where it is set."""
    sensor.run(_res, db)
    runs = [run for run in row_runs(values) if skip is None or run[0] != skip]
    runs.sort(key=lambda run: run[0])
    by_value: dict[int, list] = {}
    for run in runs:
        by_value.setdefault(run[0], []).append(run)
    mask = sensor.roles.d.tmp_b
    for value, group in by_value.items():
        _mask_from_runs(sensor, mask, group)
        sensor.run(_where, mask)
        sensor.sim.scamp5_in(db, value)
        sensor.run(_all)


def upload_map(pipe: SensorExecutor, topomap: TopoMap, runs: bool = True) -> None:
    """Write ``topomap``'s nodes into ``pipe``'s database registers (timed, stage "mapping").

    With ``runs``, the controller also keeps the table of a map's runs of one place
    (``TopoMap.places``; :func:`ppaloc.onsensor.runs.plan_runs`).
    """
    # the map's own PE blocks (uint8 images, or 4x8 bits) as the comparison reads them
    # (low-res images contrast-normalised where the filter compares them so), laid out
    # for this array
    blocks = pipe.node_blocks(topomap)
    sensor = pipe.sensor
    db = sensor.roles.db
    with sensor.stage("mapping"):
        lowres = isinstance(pipe.places, LowresPlaces)
        if lowres and pipe.store == "levels":
            (plane,) = sensor.layout.to_planes(blocks, fill=0)
            for reg, values in zip(db, LowresPlaces.level_planes(plane), strict=True):
                _write_values(sensor, reg, values, skip=None)
        elif lowres:
            planes = sensor.layout.to_planes(blocks, fill=128)
            for t, plane in enumerate(planes):
                _write_values(sensor, db[t], plane.astype(np.int64) - 128, skip=0)
                sensor.run(_halve, db[t])
        else:
            planes = sensor.layout.to_planes(blocks, fill=0)
            for t, plane in enumerate(planes):
                found = [run for run in row_runs(plane.astype(np.int64)) if run[0]]
                _mask_from_runs(sensor, db[t], found)
    plan_runs(sensor, topomap.places if runs else None)


def _res(k: Kernel, r: Register) -> None:
    k.res(r)


def _where(k: Kernel, mask: Register) -> None:
    k.WHERE(mask)


def _all(k: Kernel) -> None:
    k.all()


def _halve(k: Kernel, db: Register) -> None:
    k.bus2(D, NEWS, db)  # D = -(2n)/2
    k.bus(db, D)
