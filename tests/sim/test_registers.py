"""Register handles, neighbour aliases and directions."""

from __future__ import annotations

import pytest

import ppaloc.sim as sim_pkg
from ppaloc.sim import (
    FLAG,
    IN,
    NEWS,
    PIX,
    R0,
    R12,
    SELECT,
    XE,
    XN,
    XS,
    XW,
    A,
    Direction,
    F,
    east,
    north,
    south,
    west,
)
from ppaloc.sim.registers import DNEWS_SELECTORS, register_by_name


def test_public_names_exist() -> None:
    names = ["Scamp5", "NEWS", "PIX", "IN", "FLAG", "SELECT", "XN", "XE", "XS", "XW"]
    names += list("ABCDEF") + [f"R{i}" for i in range(13)]
    names += ["north", "east", "south", "west", "NoiseParams", "PRESETS", "TimingModel"]
    for name in names:
        assert hasattr(sim_pkg, name), name
        assert name in sim_pkg.__all__


def test_kinds_and_roles() -> None:
    assert (A.kind, A.role, A.writable) == ("analog", "general", True)
    assert (F.index, NEWS.index) == (5, 6)
    assert not PIX.writable and not IN.writable
    assert (R0.kind, R12.index) == ("digital", 12)
    assert not FLAG.writable and not SELECT.writable
    for alias, d in ((XN, north), (XE, east), (XS, south), (XW, west)):
        assert alias.index == NEWS.index and alias.direction is d and alias.writable
    assert repr(XE) == "XE"


def test_directions_are_flags_with_row_col_offsets() -> None:
    assert (int(east), int(west), int(north), int(south)) == (1, 2, 4, 8)
    assert north.offset == (-1, 0) and south.offset == (1, 0)
    assert east.offset == (0, 1) and west.offset == (0, -1)
    both = north | east
    assert isinstance(both, Direction) and north in both and south not in both


def test_dnews_selectors_follow_scamp5() -> None:
    assert [DNEWS_SELECTORS[d].name for d in (south, west, north, east)] == [
        "R1",
        "R2",
        "R3",
        "R4",
    ]


def test_register_by_name() -> None:
    assert register_by_name("XE") is XE
    with pytest.raises(KeyError):
        register_by_name("G")
