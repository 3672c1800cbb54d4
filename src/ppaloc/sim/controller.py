"""Host-side (controller) API of the simulated SCAMP-5: the ``scamp5_*`` functions."""

from __future__ import annotations

import contextlib
from collections.abc import Iterator

__all__ = ["ControllerMixin"]


class ControllerMixin:
    """Controller calls mixed into :class:`ppaloc.sim.engine.Scamp5`."""

    @contextlib.contextmanager
    def stage(self, name: str) -> Iterator[None]:
        """Group modelled costs charged inside the block under ``name``."""
        with self.timing.stage(name):  # type: ignore[attr-defined]
            yield
