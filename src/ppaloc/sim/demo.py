"""The simulator demo: capture a synthetic scene, find its edges on the array, draw the planes.

``run_demo(out_dir)`` builds a 256 x 256 :class:`~ppaloc.sim.engine.Scamp5`, shows it a
seeded synthetic scene (gradients, a disc, a bar grating, a dark block), then runs, each
as a timed stage:

1. *capture*: one kernel, ``get_image(A)`` (A := the half-range image, ``p/2 - 64``);
2. *edges*: one kernel of neighbour differences, ``C := A_east - A``,
   ``B := A_south - A``, ``D := |C| + |B|``;
3. *threshold*: ``scamp5_in(F, 16)``, ``load_rect`` of the interior into R6 (the last
   row and column compare with the 0 beyond the edge) and a kernel
   ``R5 := (D - F > 0) AND R6``;
4. *readout*: ``global_count(R5)`` and ``scan_events(R5, 16)``.

It writes a labelled montage of the register planes (PNG), prints the modelled timing
table and returns the PNG's path.
"""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np

from ppaloc.sim.engine import Scamp5
from ppaloc.sim.registers import FLAG, R5, R6, R7, A, B, C, D, E, F, east, south
from ppaloc.sim.render import render_montage

__all__ = ["DEMO_PNG", "run_demo", "synthetic_scene"]

#: File name of the montage ``run_demo`` writes into ``out_dir``.
DEMO_PNG = "sim_demo.png"

_EDGE_THRESHOLD = 16  # register units; a step of 32 grey levels in the 8-bit image


def synthetic_scene(rows: int = 256, cols: int = 256, seed: int = 0) -> np.ndarray:
    """A seeded grey test scene with smooth gradients and sharp-edged shapes.

    Parameters
    ----------
    rows, cols : int
        Image size.
    seed : int
        Seed of the shapes' jitter and of the sensor noise; same seed, same bytes.

    Returns
    -------
    numpy.ndarray of uint8, shape (rows, cols)
    """
    rng = np.random.default_rng(seed)
    y, x = np.mgrid[0:rows, 0:cols].astype(np.float64)
    v, u = y / max(rows - 1, 1), x / max(cols - 1, 1)
    img = 40.0 + 110.0 * u + 30.0 * v  # smooth gradients: no edges
    cy, cx = np.array([0.32, 0.28]) + rng.uniform(-0.04, 0.04, 2)
    disc = (v - cy) ** 2 + (u - cx) ** 2 < 0.16**2
    img[disc] = 235.0
    grating = (v > 0.1) & (v < 0.35) & (u > 0.58) & (u < 0.92)
    img[grating] = np.where((x[grating] // 8) % 2 == 0, 210.0, 50.0)
    top = 0.58 + rng.uniform(-0.03, 0.03)
    block = (v > top) & (v < top + 0.27) & (u > 0.55) & (u < 0.9)
    img[block] = 15.0
    tri = (v > 0.6) & (v < 0.92) & (u > 0.08) & (u - 0.08 < (v - 0.6) * 1.2)
    img[tri] = 190.0
    img += rng.normal(0.0, 2.0, img.shape)
    return np.clip(np.rint(img), 0, 255).astype(np.uint8)


def run_demo(
    out_dir: str | os.PathLike[str], *, noise: str = "ideal", seed: int = 0, echo: bool = True
) -> Path:
    """Run the simulator demo and write its register montage into ``out_dir``.

    Parameters
    ----------
    out_dir : path-like
        Folder for the PNG (created if needed).
    noise : str
        Noise preset of the simulator (``"ideal"``, ``"low"``, ``"typical"``, ``"high"``).
    seed : int
        Seed of the scene and the simulator.
    echo : bool
        Print the timing table and a summary to the terminal.

    Returns
    -------
    pathlib.Path
        The montage PNG (``out_dir / "sim_demo.png"``).
    """
    sim = Scamp5(256, 256, noise=noise, seed=seed)
    sim.set_image(synthetic_scene(sim.rows, sim.cols, seed))

    with sim.stage("capture"), sim.kernel() as k:
        k.get_image(A)

    with sim.stage("edges"), sim.kernel() as k:
        k.movx(C, A, east)  # C := A of the east neighbour
        k.sub(C, C, A)  # C := A_east - A
        k.abs(D, C)  # D := |A_east - A|
        k.movx(B, A, south)
        k.sub(B, B, A)  # B := A_south - A
        k.abs(E, B)
        k.add(D, D, E)  # D := |A_east - A| + |A_south - A|

    with sim.stage("threshold"):
        sim.scamp5_in(F, _EDGE_THRESHOLD)
        # the last row and column compare with the 0 beyond the edge: leave them out
        sim.load_rect(R6, 0, 0, sim.rows - 2, sim.cols - 2)
        with sim.kernel() as k:
            k.sub(E, D, F)
            k.where(E)
            k.MOV(R7, FLAG)
            k.all()
            k.AND(R5, R7, R6)

    with sim.stage("readout"):
        count = sim.global_count(R5, E)
        events = sim.scan_events(R5, 16)

    path = render_montage(
        {
            "image A": sim.read(A),
            "A_east - A": sim.read(C),
            "A_south - A": sim.read(B),
            "edges D": sim.read(D),
            "R5 = D > 16": sim.read(R5),
        },
        Path(out_dir) / DEMO_PNG,
        columns=5,
    )
    if echo:
        from rich.console import Console

        console = Console()
        console.print(sim.timing.report())
        console.print(
            f"edge elements: global_count = {count}/4095 "
            f"(exact {int(sim.read(R5).sum())} of {sim.rows * sim.cols}); "
            f"first events (row, col): {events[:4].tolist()}"
        )
        console.print(f"register montage: {path}")
    return path
