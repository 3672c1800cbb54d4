"""Fixtures of the CLI tests: the evaluate tests' stand-in method, and a tiny route spec."""

from __future__ import annotations

import importlib.util
from pathlib import Path

import pytest

TINY = "synthetic:?places=12&size=32&sync=1&seed=2"
"""A 12-place procedural route (one query frame per place), fast to render."""


@pytest.fixture(scope="session")
def standin():
    path = Path(__file__).parents[1] / "evaluate" / "_standin.py"
    spec = importlib.util.spec_from_file_location("ppaloc_tests_standin_helpers_cli", path)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


@pytest.fixture
def mean_match(standin, monkeypatch):
    """Register the stand-in as method ``mean-match``; return its name."""
    return standin.register(monkeypatch)


@pytest.fixture
def tiny_spec() -> str:
    return TINY
