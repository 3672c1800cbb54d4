"""``representation="auto"``: the richest place a map's length leaves room for."""

from __future__ import annotations

import pytest

from ppaloc.errors import PpalocError
from ppaloc.localise.schedule import PaperSchedule, RobustSchedule
from ppaloc.localise.weighted import WeightedNodeLocaliser
from ppaloc.methods import make_localiser
from ppaloc.onsensor import OnSensorLocaliser, choose
from ppaloc.onsensor.choose import choose_place, place_table, sensor_capacity

ROBUST, PAPER = RobustSchedule.sensor, PaperSchedule.sensor


def test_capacities_come_from_the_layouts_and_the_stores():
    """A tile's nodes (the PE block of each place) times the tiles one sensor holds."""
    assert [sensor_capacity(r, ROBUST) for r in ("lowres16", "haar", "lowres", "lbp")] == [
        256,
        512,
        1024,
        4096,
    ]
    # the paper's preset keeps two analogue tiles of 8x8 images (no best-distance planes)
    assert sensor_capacity("lowres", PAPER) == 2048
    # a test's 64x64 array: 4x4 blocks of 16x16 PEs
    assert sensor_capacity("lowres16", ROBUST, size=64) == 16


@pytest.mark.parametrize(
    ("n_nodes", "sensors", "want"),
    [
        (1, 1, "lowres16"),
        (256, 1, "lowres16"),
        (257, 1, "haar"),
        (512, 1, "haar"),
        (513, 1, "lowres"),
        (1024, 1, "lowres"),
        (1025, 1, "lbp"),
        (4096, 1, "lbp"),
        (1788, 7, "lowres16"),  # Nordland's frames on seven sensors
        (1788, 2, "lowres"),
        (1788, 4, "haar"),
        (9000, 2, "lbp"),  # fits nowhere: the place needing the fewest sensors
        (300, 2, "lowres16"),
    ],
)
def test_the_richest_place_that_fits(n_nodes, sensors, want):
    assert choose_place(n_nodes, sensors, ROBUST) == want


def test_the_paper_preset_chooses_among_its_places_on_one_sensor():
    assert choose_place(100, 1, PAPER, runs_on=("lowres", "lbp")) == "lowres"
    assert choose_place(3000, 4, PAPER, runs_on=("lowres", "lbp")) == "lbp"  # no bank
    assert place_table(PAPER, 4, runs_on=("lowres", "lbp")) == [(2048, "lowres"), (4096, "lbp")]


def test_the_table_lists_each_place_up_to_its_longest_map():
    assert place_table(ROBUST, 2) == [
        (512, "lowres16"),
        (1024, "haar"),
        (2048, "lowres"),
        (8192, "lbp"),
    ]


@pytest.mark.parametrize(
    ("args", "message"),
    [
        ((0, 1), "a map of 0 nodes"),
        ((10, 0), r"sensors=0 must be in \[1, 65536\]"),
        ((10, True), "sensors=True must be an integer"),
    ],
)
def test_bad_choices_are_refused_in_one_line(args, message):
    with pytest.raises(PpalocError, match=message):
        choose_place(*args, ROBUST)


def test_auto_maps_the_richest_place_and_runs_it_as_the_fixed_localiser(blocky_route):
    ref, query = blocky_route(8, 3, [0, 1, 2, 2, 3, 5, 6, 7])
    auto = make_localiser("onsensor-auto", motion="always_forward")
    assert auto.name == "onsensor-auto"
    topomap = auto.build_map(ref)
    assert auto.representation == topomap.kind == "lowres16"
    fixed = OnSensorLocaliser("lowres16", motion="always_forward")
    fixed.build_map(ref)
    got, want = auto.localise(query), fixed.localise(query)
    assert [(e.node, e.score) for e in got] == [(e.node, e.score) for e in want]


def test_auto_follows_the_arrays_capacity(blocky_route):
    """On a 64x64 test array a tile holds 16 nodes of 16x16 PEs (two digital tiles of Haar
    signs a sensor) and 64 of 8x8: a map of 40 frames gets 8x8 images, unless two
    sensors may hold its Haar signs."""
    ref, _ = blocky_route(40, 4)
    small = [f[::4, ::4] for f in ref]
    one = OnSensorLocaliser("auto", size=64, motion="always_forward")
    one.build_map(small)
    two = OnSensorLocaliser("auto", size=64, sensors=2, motion="always_forward")
    two.build_map(small)
    assert (one.representation, two.representation) == ("lowres", "haar")
    assert one.store == "levels" and two.store == "digital"
    assert choose_place(40, 3, ROBUST, size=64) == "lowres16"  # 3 x 16 16x16 images


def test_auto_counts_places_not_frames(blocky_route, monkeypatch):
    """With keyframes a stop of the reference is one node: the choice counts the places
    the map will have (those of the host's keyframe map); without, every frame."""
    places, _ = blocky_route(6, 5)
    ref = [places[i] for i in (0, 1, 2, 2, 2, 2, 3, 4, 5)]  # a stop at place 2
    counted = []
    real = choose.choose_place
    monkeypatch.setattr(
        choose, "choose_place", lambda n, *a, **k: counted.append(n) or real(n, *a, **k)
    )
    host = WeightedNodeLocaliser("lowres16").build_map(ref)
    assert len(OnSensorLocaliser("auto").build_map(ref)) == len(host) == 6
    OnSensorLocaliser("auto", keyframes=False, motion="always_forward").build_map(ref)
    assert counted == [6, 9]


def test_auto_with_the_paper_preset_and_a_loaded_map(blocky_route):
    ref, _ = blocky_route(5, 6)
    paper = OnSensorLocaliser("auto", preset="paper", alpha=8, motion="always_forward")
    assert paper.build_map(ref).kind == "lowres"  # the paper's preset compares 8x8 at most
    assert paper.params.shift == 2  # the paper's default shift of the chosen place
    lbp_map = WeightedNodeLocaliser("lbp", motion="always_forward").build_map(ref)
    loaded = OnSensorLocaliser("auto", motion="always_forward")
    loaded.use_map(lbp_map)
    assert (loaded.representation, loaded.store) == ("lbp", "digital")
    l16 = WeightedNodeLocaliser("lowres16", motion="always_forward").build_map(ref)
    with pytest.raises(PpalocError, match="holds 'lowres16' nodes, which representation='auto'"):
        paper.use_map(l16)


@pytest.mark.parametrize(
    ("kw", "message"),
    [
        ({"representation": "lowres", "sensors": 2}, "sensors=2 is for representation='auto'"),
        ({"representation": "auto", "store": "levels"}, "store='levels': representation='auto'"),
        ({"representation": "auto", "sensors": 0}, "sensors=0 must be"),
        ({"representation": "auto", "gain": 0}, "gain=0 must be"),
        ({"representation": "auto", "preset": "nope"}, "preset='nope' is not one of"),
    ],
)
def test_auto_refuses_bad_arguments_before_any_work(kw, message):
    with pytest.raises(PpalocError, match=message):
        OnSensorLocaliser(**kw)
