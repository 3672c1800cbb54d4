"""Engines that run recorded ICWs on a simulator's planes, selectable by name.

All engines share one interface (:class:`Engine`): ``compile(instructions)`` returns a
runner that performs the ICWs on the simulator's register planes, in order, with the
noise model's draws taken in the same order, so every engine gives the same bytes.

- ``"reference"``: one ICW at a time on fresh arrays, written to be obviously correct;
- ``"numpy"``: each ICW compiled once into bound, in-place numpy operations;
- ``"compiled"``: a kernel encoded once and run by a numba-compiled loop (needs numba).

``Scamp5(engine=None)`` takes :func:`default_engine`: the ``PPALOC_ENGINE`` environment
variable if set, else the fastest engine installed.
"""

from __future__ import annotations

import importlib
import importlib.util
import os
from collections.abc import Callable
from typing import TYPE_CHECKING, Protocol

from ppaloc.errors import SimulatorError
from ppaloc.sim.isa import Instruction

if TYPE_CHECKING:
    from ppaloc.sim.engine import Scamp5

__all__ = [
    "ENGINES",
    "Engine",
    "available_engines",
    "check_environment",
    "default_engine",
    "finish_compiles",
    "in_order",
    "make_engine",
]

#: Engine name -> "module:Class", slowest first.
ENGINES: dict[str, str] = {
    "reference": "ppaloc.sim.engines.reference:ReferenceEngine",
    "numpy": "ppaloc.sim.engines.numpy_engine:NumpyEngine",
    "compiled": "ppaloc.sim.engines.compiled:CompiledEngine",
}

#: The environment variable that names the default engine (e.g. for running the suite).
ENV_VAR = "PPALOC_ENGINE"


class Engine(Protocol):
    """What a simulator needs from an engine."""

    name: str

    def supports(self, op: str) -> bool:
        """Whether the engine models the primitive ``op`` (a key of ``isa.OPS``)."""

    def compile(self, instructions: tuple[Instruction, ...]) -> Callable[[], None]:
        """A runner performing ``instructions`` on the simulator's planes."""


def in_order(ops: list[Callable[[], None]]) -> Callable[[], None]:
    """One runner calling ``ops`` in order (the op itself when there is one)."""
    if len(ops) == 1:
        return ops[0]

    def run() -> None:
        for op in ops:
            op()

    return run


def _installed(name: str) -> bool:
    return name != "compiled" or importlib.util.find_spec("numba") is not None


def available_engines() -> list[str]:
    """Names of the engines that can run here (the compiled one needs numba)."""
    return [n for n in ENGINES if _installed(n)]


def default_engine() -> str:
    """``$PPALOC_ENGINE`` if set, else the fastest installed engine."""
    name = os.environ.get(ENV_VAR)
    if name:
        _check(name, f"{ENV_VAR}={name!r}")
        return name
    return available_engines()[-1]


def check_environment() -> None:
    """Refuse, in one line and before any work, an environment setting the default engine
    would refuse at its first simulator: ``$PPALOC_ENGINE``, and for the compiled engine
    ``$PPALOC_FUSE_AFTER`` and ``$PPALOC_THREADS`` (a command that runs host methods
    first would otherwise run them before it fails)."""
    if default_engine() == "compiled":
        from ppaloc.sim.engines.compiled import fuse_after_from_env, threads_from_env

        fuse_after_from_env()
        threads_from_env()


def _check(name: object, shown: str) -> None:
    if name not in ENGINES:
        raise SimulatorError(f"{shown} is not an engine: use one of {', '.join(ENGINES)}")
    if not _installed(str(name)):
        raise SimulatorError(
            f"{shown} needs numba, which is not installed: pip install numba, or use engine='numpy'"
        )


def make_engine(name: str | None, sim: Scamp5) -> Engine:
    """The engine called ``name`` (None: :func:`default_engine`) bound to ``sim``."""
    if name is None:
        name = default_engine()
    _check(name, f"engine={name!r}")
    module, cls = ENGINES[name].split(":")
    return getattr(importlib.import_module(module), cls)(sim)


def finish_compiles(progress: Callable[[int, int], None] | None = None) -> int:
    """Compile, in the foreground, every fused stretch this process has asked for (the
    compiled engine's second tier compiles them in a background process otherwise, and
    stops at exit whatever is unfinished); ``progress(done, total)`` after each. Returns
    how many were compiled (0 without numba)."""
    if importlib.util.find_spec("numba") is None:
        return 0
    from ppaloc.sim.engines import fused

    return fused.background.drain(progress)
