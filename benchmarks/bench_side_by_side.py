"""The on-sensor pipelines of an earlier commit and of the working tree, side by side.

``python benchmarks/bench_side_by_side.py BASE [--reps lowres,lbp] [--noise ideal,typical]
[--rounds 16]`` copies ``src/ppaloc`` of commit ``BASE`` (``git archive``) into a
temporary folder as the package ``ppaloc_base`` (every ``ppaloc.`` import renamed), builds
the benchmark's localiser (``bench_onsensor.localiser``: robust preset, speed lanes off,
first tier) from each tree, and steps both through the same frames in one process, frame
by frame, the one that goes first alternating: on a shared machine the two trees see the
same load. Prints per pipeline the median frame (ms and simulated frames/s) of each tree,
their ratio and the median of the frames' paired ratios, and whether both trees gave the
same estimates (node, score, modelled latency and energy) on a last pass.
"""

from __future__ import annotations

import argparse
import importlib
import io
import os
import re
import statistics
import subprocess
import sys
import tarfile
import tempfile
import time
from pathlib import Path
from types import ModuleType
from typing import Any

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(Path(__file__).resolve().parent))


def base_package(commit: str, folder: Path) -> ModuleType:
    """``src/ppaloc`` of ``commit`` imported as ``ppaloc_base`` from ``folder``."""
    tar = subprocess.run(
        ["git", "-C", str(ROOT), "archive", commit, "src/ppaloc"],
        check=True,
        capture_output=True,
    ).stdout
    with tarfile.open(fileobj=io.BytesIO(tar)) as archive:
        archive.extractall(folder, filter="data")
    package = folder / "ppaloc_base"
    (folder / "src" / "ppaloc").rename(package)
    for path in package.rglob("*.py"):
        text = path.read_text()
        text = re.sub(r"\bppaloc\.", "ppaloc_base.", text)
        text = re.sub(r"\bfrom ppaloc import\b", "from ppaloc_base import", text)
        path.write_text(text)
    sys.path.insert(0, str(folder))
    return importlib.import_module("ppaloc_base")


def localiser(package: ModuleType, representation: str, noise: str):
    """The benchmark's localiser built from ``package``, run once through its frames."""
    import bench_onsensor as bench

    params = importlib.import_module(f"{package.__name__}.localise.params")
    onsensor = importlib.import_module(f"{package.__name__}.onsensor")
    topomap = importlib.import_module(f"{package.__name__}.topomap")
    built = bench.topomap(representation)
    loc = onsensor.OnSensorLocaliser(
        representation, noise=noise, preset="robust", motion="image", **dict(params.NO_LANES)
    )
    loc.use_map(topomap.TopoMap(built.kind, built.descriptors))
    for frame in bench.frames():
        loc.step(frame)
    return loc


def alternate(locs: dict[Any, Any], rounds: int) -> dict[Any, list[float]]:
    """Each localiser of ``locs`` stepped through the benchmark's frames ``rounds`` times,
    frame by frame, the one that goes first alternating (both see the same load): the
    seconds of every step, per key."""
    import bench_onsensor as bench

    times: dict[Any, list[float]] = {k: [] for k in locs}
    order = list(locs)
    for _ in range(rounds):
        for frame in bench.frames():
            order.reverse()
            for k in order:
                t = time.perf_counter()
                locs[k].step(frame)
                times[k].append(time.perf_counter() - t)
    return times


def same_estimates(a: Any, b: Any) -> bool:
    """Whether two localisers give the same node, score, modelled latency and energy on
    one more pass over the benchmark's frames."""
    import bench_onsensor as bench

    return all(
        (x.node, x.score, x.modelled_latency_ms, x.energy_mj)
        == (y.node, y.score, y.modelled_latency_ms, y.energy_mj)
        for x, y in zip(
            [a.step(f) for f in bench.frames()], [b.step(f) for f in bench.frames()], strict=True
        )
    )


def medians(a: list[float], b: list[float]) -> tuple[float, float, float]:
    """(median of ``a``, median of ``b``, median of the paired ratios ``a / b``)."""
    paired = statistics.median(x / y for x, y in zip(a, b, strict=True))
    return statistics.median(a), statistics.median(b), paired


def side_by_side(base: ModuleType, representation: str, noise: str, rounds: int) -> str:
    """One line of figures: both trees' localisers, frames alternating."""
    import ppaloc

    locs = {
        "base": localiser(base, representation, noise),
        "tree": localiser(ppaloc, representation, noise),
    }
    times = alternate(locs, rounds)
    return compared(representation, noise, locs, times, "base", "tree")


def compared(
    representation: str,
    noise: str,
    locs: dict[Any, Any],
    times: dict[Any, list[float]],
    first: Any,
    second: Any,
    labels: tuple[str, str] | None = None,
) -> str:
    """The printed line of two localisers stepped by :func:`alternate`: each one's median
    frame (ms and frames/s), their ratio, the paired ratio and whether their estimates
    agree (``labels`` name them, else their keys in ``locs``)."""
    m0, m1, paired = medians(times[first], times[second])
    same = same_estimates(locs[first], locs[second])
    a, b = labels or (str(first), str(second))
    return (
        f"{representation:8s} {noise:8s} {a} {m0 * 1e3:6.2f} ms ({1 / m0:6.1f} frames/s)  "
        f"{b} {m1 * 1e3:6.2f} ms ({1 / m1:6.1f} frames/s)  ratio {m0 / m1:.3f}  "
        f"paired {paired:.3f}  same estimates {same}"
    )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("base", help="the commit to compare the working tree with")
    parser.add_argument("--reps", default="lowres,lbp")
    parser.add_argument("--noise", default="ideal,typical")
    parser.add_argument("--rounds", type=int, default=16, help="passes over the 12 frames")
    args = parser.parse_args()
    os.environ["PPALOC_FUSE_AFTER"] = "never"
    with tempfile.TemporaryDirectory() as folder:
        base = base_package(args.base, Path(folder))
        for rep in args.reps.split(","):
            for noise in args.noise.split(","):
                print(side_by_side(base, rep, noise, args.rounds), flush=True)


if __name__ == "__main__":
    main()
