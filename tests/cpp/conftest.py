"""Fixtures of the C++ tests: a compiler or a clear skip, and the test programs."""

from __future__ import annotations

from pathlib import Path

import pytest

from ppaloc.cpp.build import compiler

PROGRAMS = Path(__file__).resolve().parent / "programs"


@pytest.fixture(scope="session")
def cxx() -> str:
    """The C++ compiler; skips where the machine has none."""
    found = compiler()
    if found is None:
        pytest.skip("no C++ compiler (g++) here: install Debian's g++ package (make test does)")
    return found
