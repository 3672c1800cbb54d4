"""Compile the simulator's fused code for the on-sensor pipelines ahead, in the foreground.

The compiled engine moves a stretch of ICWs run often to generated, fused loops, compiled
once per machine (about 0.1 s an ICW) by a background process while its first tier runs,
and stopped with the command that asked for it (:mod:`ppaloc.sim.engines.fused`). So a
short command may end before the fast code is there. :func:`warm_up` runs every on-sensor
pipeline (every representation in each preset it runs, ideal and ``typical`` noise) long enough
for each hot stretch to ask for its compile, then compiles them all and waits: later runs
find them in the cache folder (``ppaloc warm-up``).
"""

from __future__ import annotations

from collections.abc import Callable

from ppaloc.localise.params import runs_on
from ppaloc.onsensor.localiser import SENSOR_REPRESENTATIONS, OnSensorLocaliser
from ppaloc.sim.demo import synthetic_scene
from ppaloc.sim.engines import finish_compiles
from ppaloc.sim.engines.compiled import FUSE_AFTER

__all__ = ["CONFIGS", "warm_up"]

#: ``(representation, preset, noise)`` of every pipeline :func:`warm_up` runs (the 16x16
#: images and the Haar signs in the robust preset only, the one that runs on them).
CONFIGS = tuple(
    (rep, preset, noise)
    for rep in SENSOR_REPRESENTATIONS
    for preset in ("robust", "paper")
    if runs_on(rep, preset)
    for noise in ("ideal", "typical")
)

Progress = Callable[[str, int, int], None]
"""``progress(task, done, total)``."""


def warm_up(progress: Progress | None = None, *, nodes: int = 24) -> int:
    """Run each pipeline of :data:`CONFIGS` for ``FUSE_AFTER + 8`` frames on a map of
    ``nodes`` scenes (every stage, the image motion test, frames that move), then
    compile every fused stretch they asked for. Returns how many were compiled.

    ``progress("run", i, n)`` after each pipeline, ``progress("compile", done, total)``
    after each compile.
    """
    scenes = [synthetic_scene(seed=s) for s in range(nodes + FUSE_AFTER + 8)]
    compiled = 0
    for i, (rep, preset, noise) in enumerate(CONFIGS, 1):
        extra = {"alpha": 8} if preset == "paper" else {}
        loc = OnSensorLocaliser(
            rep, noise=noise, preset=preset, motion="image", keyframes=False, **extra
        )
        loc.build_map(scenes[:nodes])
        for frame in scenes[nodes:]:
            loc.step(frame)
        if progress:
            progress("run", i, len(CONFIGS))
        compiled += finish_compiles(
            None if progress is None else (lambda d, t: progress("compile", d, t))
        )
    return compiled
