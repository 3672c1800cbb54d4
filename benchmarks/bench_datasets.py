"""Datasets: the procedural generator's frame rate, frame loading and the sensor front-end.

``make bench`` runs these with pytest-benchmark; ``python benchmarks/bench_datasets.py``
prints medians (milliseconds per frame, one core) and the generator's frames per second;
``python benchmarks/bench_datasets.py --difficulty`` prints how far each condition moves
single-frame matching from the summer reference (straight and with turns) and from the
unchanged lab.

Target: the generator renders at least 200 grey 256x256 frames per second per condition
(median), so a 500-place route with its query is ready in a few seconds and tests can use
it freely.
"""

from __future__ import annotations

import itertools
import statistics
import time
from collections.abc import Callable
from functools import cache
from pathlib import Path

import numpy as np
import pytest

from ppaloc.datasets import load_dataset, to_sensor
from ppaloc.datasets.synthetic.conditions import CONDITIONS
from ppaloc.datasets.synthetic.render import LANE_CENTRE, Renderer
from ppaloc.datasets.synthetic.world import make_world

SHARED = Path(__file__).resolve().parents[1].parent / "shared" / "data"
TARGET_FPS = 200.0


@cache
def world():
    return make_world(40_000.0, seed=1)


def render_case(name: str) -> Callable[[], np.ndarray]:
    """One call renders the next frame (4 m further) of a drive under condition ``name``."""
    renderer = Renderer(world(), CONDITIONS[name], 256, seed=1)
    counter = itertools.count()

    def step() -> np.ndarray:
        i = next(counter) % 9000
        return renderer.render(4.0 * i, LANE_CENTRE, (1, i))

    return step


WORLD_SPECS = {
    "road with turns (winter query)": "synthetic:?places=2000&turns=60&query=winter&seed=1",
    "lab map (lab)": "synthetic:?world=lab&places=2000&query=lab&seed=1",
    "lab query=changed": "synthetic:?world=lab&places=2000&query=changed&seed=1",
    "lab query=dim": "synthetic:?world=lab&places=2000&query=dim&seed=1",
}
"""The bent road and the lab worlds, timed through ``load_dataset`` (fresh frames each call)."""


def dataset_case(
    spec: str = "synthetic:?places=2000&query=winter&seed=1",
) -> Callable[[], np.ndarray]:
    """One call reads the next query frame of a spec-loaded synthetic route (lazy path)."""
    ds = load_dataset(spec)
    counter = itertools.count()
    return lambda: ds.query[next(counter) % len(ds.query)]


def cases() -> dict[str, Callable[[], object]]:
    """Every timed operation, by name; each call is one frame."""
    out: dict[str, Callable[[], object]] = {
        f"synthetic render {name}": render_case(name) for name in CONDITIONS
    }
    out["synthetic via load_dataset (winter query)"] = dataset_case()
    for label, spec in WORLD_SPECS.items():
        out[f"synthetic {label}"] = dataset_case(spec)
    colour = np.random.default_rng(0).integers(0, 256, (540, 960, 3), dtype=np.uint8)
    out["to_sensor 960x540 colour"] = lambda: to_sensor(colour)
    small = np.random.default_rng(1).integers(0, 256, (32, 64), dtype=np.uint8)
    out["to_sensor 64x32 grey"] = lambda: to_sensor(small)
    if (SHARED / "nordland-64x32").is_dir():
        ds = load_dataset(f"nordland:{SHARED / 'nordland-64x32'}")
        counter = itertools.count()
        out["nordland read + to_sensor"] = lambda: to_sensor(
            ds.query[next(counter) % len(ds.query)]
        )
    return out


CASES = cases()


@pytest.mark.parametrize("name", list(CASES))
def test_datasets(benchmark, name: str) -> None:
    benchmark.group = "datasets"
    benchmark(CASES[name])


def median_ms(fn: Callable[[], object], repeats: int = 300) -> tuple[float, float]:
    """Median wall time per call and mean process CPU time per call (ms).

    On a shared machine the wall time includes waiting for a core; the CPU time does not.
    """
    for _ in range(20):
        fn()  # warm up
    times = []
    cpu0 = time.process_time()
    for _ in range(repeats):
        t0 = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t0)
    cpu = (time.process_time() - cpu0) / repeats
    return 1e3 * statistics.median(times), 1e3 * cpu


DIFFICULTY_WORLDS = {
    "summer": "",
    "summer, road with 8 turns": "&turns=8",
    "lab": "&world=lab",
}
"""Map traversal label -> the world's spec keys, for :func:`difficulty`."""


def difficulty(places: int = 300, seed: int = 1) -> dict[str, float]:
    """Share of queries whose best single-frame match is within +-1 place, per condition.

    Frame-synchronised reference (summer on the straight road and the road with 8 turns,
    ``lab`` in the lab); 16x16 box thumbnails, each normalised to zero mean and unit
    deviation, compared by mean absolute difference. A rough gauge of how much each
    condition changes appearance, not a method under test. Keys ``"ref -> query"``.
    """
    from PIL import Image

    from ppaloc.datasets.synthetic.lab import LAB_CONDITIONS

    def thumbs(frames) -> np.ndarray:
        t = np.stack(
            [np.asarray(Image.fromarray(f).resize((16, 16), Image.Resampling.BOX)) for f in frames]
        ).astype(np.float32)
        t -= t.mean(axis=(1, 2), keepdims=True)
        t /= t.std(axis=(1, 2), keepdims=True) + 1e-6
        return t.reshape(len(t), -1)

    out = {}
    for label, keys in DIFFICULTY_WORLDS.items():
        for name in LAB_CONDITIONS if "world=lab" in keys else CONDITIONS:
            spec = f"synthetic:?places={places}&sync=1&seed={seed}&query={name}{keys}"
            ds = load_dataset(spec)
            ref, qry = thumbs(ds.reference), thumbs(ds.query)
            best = np.abs(qry[:, None, :] - ref[None, :, :]).mean(-1).argmin(1)
            out[f"{label} -> {name}"] = float(np.mean(np.abs(best - np.arange(len(qry))) <= 1))
    return out


if __name__ == "__main__":
    import sys

    if "--difficulty" in sys.argv:
        for name, share in difficulty().items():
            print(f"{name:<38} single-frame top-1 within +-1 place: {share:6.1%}")
        raise SystemExit(0)
    print(f"{'case':<44} {'median':>9} {'cpu':>9}")
    for name, fn in CASES.items():
        ms, cpu_ms = median_ms(fn)
        note = ""
        if name.startswith("synthetic"):
            fps = 1e3 / ms
            verdict = "meets" if fps >= TARGET_FPS else "BELOW"
            note = (
                f"{fps:6.0f} frames/s ({verdict} {TARGET_FPS:.0f}; {1e3 / cpu_ms:.0f} by CPU time)"
            )
        print(f"{name:<44} {ms:6.3f} ms {cpu_ms:6.3f} ms  {note}")
