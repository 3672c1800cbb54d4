"""The ``ppaloc`` command."""

from ppaloc.cli.main import main

__all__ = ["main"]
