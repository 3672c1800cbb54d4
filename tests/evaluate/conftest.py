"""Fixtures of the evaluate tests: a stand-in method and a tiny dataset (see _standin.py)."""

from __future__ import annotations

import importlib.util
from pathlib import Path

import pytest


def load_standin():
    """The ``_standin`` helper module, loaded by path (tests are not a package)."""
    path = Path(__file__).with_name("_standin.py")
    spec = importlib.util.spec_from_file_location("ppaloc_tests_standin_helpers", path)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


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
