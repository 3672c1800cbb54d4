"""``ppaloc cpp run``: frames from an image or a dataset, ``--set`` values, the printed summary.

The click parser (``ppaloc.cli.main``) only parses flags; this module turns them into a
:func:`ppaloc.cpp.run.run_program` call.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

import numpy as np

from ppaloc.cpp.live import LiveView
from ppaloc.cpp.run import RunResult, run_program
from ppaloc.errors import PpalocError

__all__ = ["load_frames", "parse_settings", "run_cpp"]

#: Frames taken from a dataset when --frames is not given.
DATASET_FRAMES = 10


def parse_settings(items: Sequence[str]) -> dict[str, str]:
    """``["threshold=30", "edges=on"]`` -> ``{"threshold": "30", "edges": "on"}``."""
    out: dict[str, str] = {}
    for item in items:
        name, sep, value = item.partition("=")
        if not sep or not name.strip():
            raise PpalocError(f"--set {item!r} must be NAME=VALUE, e.g. --set threshold=30")
        out[name.strip()] = value.strip()
    return out


MAX_FRAMES = 2000
"""Most frames one run takes: every exposure is held in memory (64 KB each at 256 x 256)."""


def load_frames(
    image: Path | None, dataset: str | None, frames: int | None
) -> list[np.ndarray] | None:
    """The run's sensor frames: ``image`` repeated, or a dataset's query traversal."""
    from ppaloc.frontend import to_sensor

    if frames is not None and not 1 <= frames <= MAX_FRAMES:
        raise PpalocError(
            f"--frames {frames} must be in [1, {MAX_FRAMES}] (the frames are held in memory)"
        )
    if image is not None and dataset is not None:
        raise PpalocError("give --image or --dataset, not both")
    if image is not None:
        from ppaloc.datasets.images import read_grey

        frame = to_sensor(read_grey(Path(image)))
        return [frame] * (frames or 1)
    if dataset is not None:
        from ppaloc.datasets.registry import load_dataset

        query = load_dataset(dataset).query
        n = min(len(query), frames or DATASET_FRAMES)
        return [to_sensor(query[i]) for i in range(n)]
    if frames is not None:
        from ppaloc.sim.demo import synthetic_scene

        return [synthetic_scene(seed=i) for i in range(frames)]
    return None


def run_cpp(
    program: Path | Sequence[Path],
    out: Path,
    *,
    include_dirs: Sequence[Path] = (),
    defines: Sequence[str] = (),
    image: Path | None = None,
    dataset: str | None = None,
    frames: int | None = None,
    settings: Sequence[str] = (),
    timeout: float = 60.0,
    noise: str = "ideal",
    seed: int = 0,
    quiet: bool = False,
    live: LiveView | None = None,
) -> RunResult:
    """Run ``program`` on the simulator and write ``out``; print one summary line.

    ``live`` (``--live``) shows the run in a browser as it goes (:mod:`ppaloc.cpp.live`).
    """
    if seed < 0:
        raise PpalocError(f"--seed {seed} must be 0 or more")
    result = run_program(
        program,
        load_frames(image, dataset, frames),
        include_dirs=include_dirs,
        defines=defines,
        settings=parse_settings(settings),
        timeout=timeout,
        out=out,
        noise=noise,
        seed=seed,
        live=live,
    )
    if not quiet:
        s = result.summary()
        print(
            f"{s['program']}: {s['frames']} frame(s), {s['kernels']} kernel(s), "
            f"{s['icws_run']} ICWs run, modelled {s['modelled_us']:.1f} us, "
            f"wall {s['wall_s']:.2f} s -> {out}"
        )
        for warning in result.session.warnings:
            print(f"  warning: {warning}")
        for text in result.texts[:20]:
            print(f"  {text}")
    return result
