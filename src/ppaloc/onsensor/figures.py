"""Pictures of the sensor's registers, like the paper's figures.

- :func:`database_figure`: the database register(s), the snake of 8x8 thumbnails (or of
  4x8 descriptor bit blocks), as the sensor holds them.
- :func:`weights_figure`: the weight register after several frames of a query, each node's
  weight drawn over its whole block (the register holds it at the block's root PE).
- :func:`difference_figure`: one frame's live image, its replicated 8x8 grid (or
  descriptor), the database and the difference register (``|f - n|`` per PE, or the
  XOR of the descriptors).
- :func:`weights_history_image`: weights over time, one row per frame (from
  ``Estimate.weights``).

All of them read registers with ``sim.read`` (untimed inspection; the difference register
is recomputed by a kernel charged to the stage ``"inspection"``) and write PNGs
atomically through :mod:`ppaloc.sim.render`.
"""

from __future__ import annotations

import os
from collections.abc import Sequence
from pathlib import Path

import numpy as np

from ppaloc.errors import PpalocError
from ppaloc.localise.base import Estimate
from ppaloc.onsensor.executor import SensorExecutor
from ppaloc.onsensor.lbp import DESCRIPTOR
from ppaloc.onsensor.localiser import OnSensorLocaliser
from ppaloc.onsensor.lowres import LowresPlaces, levels_difference
from ppaloc.sim import R9, D, E, F, Kernel, Register
from ppaloc.sim.render import render_montage, save_png

__all__ = ["database_figure", "difference_figure", "weights_figure", "weights_history_image"]


def _pipeline(localiser: OnSensorLocaliser) -> SensorExecutor:
    pipe = localiser.pipeline
    if pipe is None:
        raise PpalocError("the localiser has no map yet: call build_map(frames) first")
    if not isinstance(pipe, SensorExecutor):  # a bank: its first sensor
        pipe = pipe.sensors[0]
    return pipe


def database_figure(
    localiser: OnSensorLocaliser, path: str | os.PathLike[str], *, scale: int = 2
) -> Path:
    """Write the database of every tile (``A``/``B`` images, ``R10``/``R11`` bits).

    The low-res levels store is drawn as the values ``n`` its two registers give.
    """
    pipe = _pipeline(localiser)
    db = pipe.sensor.roles.db
    if pipe.store == "levels":
        planes = {"database tile 0 (n = A/2 + B/32)": pipe.places.map_plane(0)}  # type: ignore[attr-defined]
    else:
        planes = {
            f"database tile {t} ({db[t].name})": pipe.sim.read(db[t]) for t in range(pipe.tiles)
        }
    return render_montage(planes, path, scale=scale)


def _weight_blocks(pipe: SensorExecutor) -> np.ndarray:
    """The weight register with each node's root value drawn over its block (tile 0)."""
    w = pipe.weights()
    n = min(len(w), pipe.layout.capacity)
    grid = np.full(pipe.layout.grid_shape, -128.0)
    _, br, bc = pipe.layout.node_to_block(np.arange(n))
    grid[br, bc] = w[:n]
    return pipe.layout.expand(grid)


def weights_figure(
    localiser: OnSensorLocaliser,
    frames: Sequence[np.ndarray],
    path: str | os.PathLike[str],
    *,
    snapshots: int = 4,
    scale: int = 2,
) -> Path:
    """Run ``frames`` from a reset and draw the weight register after ``snapshots`` of them.

    Unoccupied blocks are black; weights use the register scale (-128 black, 127 white).
    """
    pipe = _pipeline(localiser)
    if not frames:
        raise PpalocError("weights_figure needs at least one query frame")
    when = set(np.linspace(0, len(frames) - 1, max(1, snapshots)).round().astype(int).tolist())
    localiser.reset()
    planes = {}
    for i, frame in enumerate(frames):
        est = localiser.step(frame)
        if i in when:
            planes[f"W after frame {i} (node {est.node})"] = _weight_blocks(pipe)
    return render_montage(planes, path, scale=scale)


def difference_figure(
    localiser: OnSensorLocaliser,
    frame: np.ndarray,
    path: str | os.PathLike[str],
    *,
    scale: int = 2,
) -> Path:
    """Localise ``frame`` and draw the live image, replicated frame, database, difference.

    The difference register is tile 0's: ``|f - n|`` (clipped at 127) for images, the XOR
    of the replicated descriptor and the database for descriptors.
    """
    pipe = _pipeline(localiser)
    sim = pipe.sim
    localiser.step(frame)
    db = pipe.sensor.roles.db[0]
    planes = {"live frame (PIX as captured)": frame.astype(np.float32) / 2 - 64}
    places = pipe.places
    with sim.stage("inspection"):
        if isinstance(places, LowresPlaces):
            if not places.live_kept:  # F served a later stage: load the frame again
                pipe.capture(frame)
                places.prepare_live()
            pipe.sensor.run(_difference, places.levels, db)
            planes[f"replicated {places.grid}x{places.grid} grid (-F)"] = -sim.read(F)
            name = "n = A/2 + B/32" if places.levels else db.name
            planes[f"database ({name})"] = places.map_plane(0)
            planes["difference |f - n| (E)"] = sim.read(E)
        else:
            places.load_descriptor(places.last_code)  # type: ignore[attr-defined]
            pipe.sensor.run(_xor, db)
            planes[f"replicated descriptor ({DESCRIPTOR.name})"] = sim.read(DESCRIPTOR)
            planes[f"database ({db.name})"] = sim.read(db)
            planes["difference XOR (R9)"] = sim.read(R9)
    return render_montage(planes, path, scale=scale)


def _difference(k: Kernel, levels: bool, db: Register) -> None:
    if levels:
        levels_difference(k)  # f - n
    else:
        k.add(D, F, db)
    k.abs(E, D)


def _xor(k: Kernel, db: Register) -> None:
    k.XOR(R9, DESCRIPTOR, db)


def weights_history_image(
    estimates: Sequence[Estimate], path: str | os.PathLike[str], *, scale: int = 1
) -> Path:
    """Weights over time: row ``t`` is frame ``t``'s weights in map order (register scale)."""
    rows = [e.weights for e in estimates if e.weights is not None]
    if not rows:
        raise PpalocError("no weights recorded: build the localiser with record_weights=True")
    w = np.stack(rows)
    image = np.clip(np.floor(w + 128.5), 0, 255).astype(np.uint8)
    return save_png(image, path, scale=scale)
