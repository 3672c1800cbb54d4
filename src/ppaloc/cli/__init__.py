"""The ``ppaloc`` command."""

from ppaloc.cli.main import cli, main

__all__ = ["cli", "main"]
