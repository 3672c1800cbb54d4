"""Fixtures shared by the whole suite."""

from __future__ import annotations

from pathlib import Path

import pytest

PROJECT_ROOT = Path(__file__).resolve().parents[1]
SHARED_DATA = PROJECT_ROOT.parent / "shared" / "data"


@pytest.fixture(scope="session")
def shared_data() -> Path:
    """``../shared/data`` (real dataset copies); skips the test where it is absent."""
    if not SHARED_DATA.is_dir():
        pytest.skip("../shared/data is not present")
    return SHARED_DATA


@pytest.fixture(scope="session")
def nordland_dir(shared_data: Path) -> Path:
    path = shared_data / "nordland-64x32"
    if not path.is_dir():
        pytest.skip("../shared/data/nordland-64x32 is not present")
    return path


@pytest.fixture(scope="session")
def gardens_point_dir(shared_data: Path) -> Path:
    path = shared_data / "gardens-point"
    if not path.is_dir():
        pytest.skip("../shared/data/gardens-point is not present")
    return path
