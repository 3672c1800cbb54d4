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


def test_header_names_of_digital_registers() -> None:
    # scamp5_icw.hpp: RS R1, RW R2, RN R3, RE R4, S0-S6 R5-R11, RP R12, RF R0
    pairs = {"RS": "R1", "RW": "R2", "RN": "R3", "RE": "R4", "RP": "R12", "RF": "R0"}
    pairs |= {f"S{i}": f"R{i + 5}" for i in range(7)}
    for alias, name in pairs.items():
        assert getattr(sim_pkg, alias) is register_by_name(name), alias
        assert alias in sim_pkg.__all__


def test_tutorial_style_port_with_header_names() -> None:
    # DNEWS0 with RN set reads the north neighbour: a row of ones moves one row south
    sim = sim_pkg.Scamp5(rows=4, cols=2)
    sim.write(sim_pkg.S0, [[0, 0], [1, 1], [0, 0], [0, 0]])
    with sim.kernel() as k:
        k.CLR(sim_pkg.RS, sim_pkg.RW, sim_pkg.RE)
        k.SET(sim_pkg.RN)
        k.DNEWS0(sim_pkg.S5, sim_pkg.S0)
    assert sim.read(sim_pkg.S5).astype(int).tolist() == [[0, 0], [0, 0], [1, 1], [0, 0]]


def test_alldir_reads_all_four_neighbours() -> None:
    assert int(sim_pkg.alldir) == 15  # news_t alldir in scamp5_icw.hpp
    sim = sim_pkg.Scamp5(rows=3, cols=3)
    sim.load_point(sim_pkg.R5, 1, 1)
    sim.DNEWS(sim_pkg.R6, sim_pkg.R5, sim_pkg.alldir)
    assert sim.read(sim_pkg.R6).astype(int).tolist() == [[0, 1, 0], [1, 0, 1], [0, 1, 0]]
