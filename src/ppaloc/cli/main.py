"""Entry point of the ``ppaloc`` command (placeholder until the CLI lands)."""

from __future__ import annotations

import sys

__all__ = ["main"]


def main(argv: list[str] | None = None) -> int:
    """Run the ``ppaloc`` command."""
    print("ppaloc: no commands yet", file=sys.stderr)
    return 1
