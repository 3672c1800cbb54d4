"""Fixtures of the evaluate tests: a stand-in method and a tiny dataset (see _standin.py), and
the scripts of benchmarks/ as modules."""

from __future__ import annotations

import importlib
import importlib.util
import sys
from pathlib import Path

import pytest


def load_standin():
    """The ``_standin`` helper module, loaded by path (tests are not a package)."""
    path = Path(__file__).with_name("_standin.py")
    spec = importlib.util.spec_from_file_location("ppaloc_tests_standin_helpers", path)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


BENCHMARKS = Path(__file__).resolve().parents[2] / "benchmarks"


def benchmark_module(name: str):
    """A script of ``benchmarks/`` imported as a module (it imports its siblings)."""
    sys.path.insert(0, str(BENCHMARKS))
    try:
        return importlib.import_module(name)
    finally:
        sys.path.remove(str(BENCHMARKS))


@pytest.fixture(scope="session")
def bench_script():
    """:func:`benchmark_module`: ``bench_script("eval_offmap")`` is that script's module."""
    return benchmark_module


@pytest.fixture(scope="session")
def standin():
    return load_standin()


@pytest.fixture
def tiny(standin):
    return standin.tiny_dataset()


@pytest.fixture
def mean_match(standin, monkeypatch):
    """Register the stand-in as method ``mean-match``; return its name."""
    return standin.register(monkeypatch)
