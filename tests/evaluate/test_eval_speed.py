"""``benchmarks/eval_speed.py``: one route per constant speed, every method's figure and
its declared speeds."""

from __future__ import annotations

import pytest

from ppaloc.errors import PpalocError


def test_the_route_and_the_table(bench_script):
    eval_speed = bench_script("eval_speed")
    assert eval_speed.route("winter", 3, 0.5) == (
        "synthetic:?places=200&query=winter&seed=3&speed=0.5"
    )
    methods = ("weighted-node-lowres", "particle-filter", "single-frame")
    figures = {
        0.5: dict(zip(methods, (0.9, 0.8, 0.1), strict=True)),
        2.0: dict(zip(methods, (0.2, 0.7, 0.1), strict=True)),
    }
    lines = eval_speed.table(figures, methods).splitlines()
    assert lines[0] == "| speed | weighted-node-lowres | particle-filter | single-frame |"
    assert lines[2:4] == ["| 0.5 | 0.900 | 0.800 | 0.100 |", "| 2 | 0.200 | 0.700 | 0.100 |"]
    assert lines[4] == "| declared | 0.5-2 | 0.64-1.67 | - |"


def test_a_sweep_runs_every_method_at_every_speed(bench_script, capsys):
    eval_speed = bench_script("eval_speed")
    got = eval_speed.sweep("autumn", 1, (1.0, 2.0), ("single-frame", "able-m"), places=24)
    assert list(got) == [1.0, 2.0] and all(
        set(row) == {"single-frame", "able-m"} for row in got.values()
    )
    assert all(0.0 <= f <= 1.0 for row in got.values() for f in row.values())
    assert "autumn seed 1 speed 2" in capsys.readouterr().out


def test_a_method_s_parameters_reach_its_runs_and_its_range(bench_script):
    """``--param`` sets a method's parameters in the runs and in its declared range."""
    eval_speed = bench_script("eval_speed")
    params = {"weighted-node-lowres": {"lane_speed": 0}}
    figures = {1.0: {"weighted-node-lowres": 0.5}}
    assert eval_speed.table(figures, ("weighted-node-lowres",), params).endswith(
        "| declared | 0.5-1.5 |"
    )
    with pytest.raises(PpalocError, match="unknown parameter 'window'"):
        eval_speed.sweep("autumn", 1, (2.0,), ("able-m",), 24, {"able-m": {"window": 3}})


def test_a_faster_query_keeps_every_v_th_frame(bench_script):
    """Nordland's query driven faster: frame ``round(i v)``, half up, below ``n``; never
    slower than the traversal."""
    eval_speed = bench_script("eval_speed")
    assert eval_speed.faster(9, 2).tolist() == [0, 2, 4, 6, 8]
    assert eval_speed.faster(7, 1.5).tolist() == [0, 2, 3, 5, 6]
    assert eval_speed.faster(4, 1).tolist() == [0, 1, 2, 3]
    with pytest.raises(SystemExit, match="1 or faster"):
        eval_speed.faster(4, 0.5)


def test_the_same_information_runs_each_baseline_on_every_place(bench_script, capsys):
    """``--representations``: the particle filter once per descriptor, beside the
    weighted-node place, and a line saying whether a place holds against it."""
    eval_speed = bench_script("eval_speed")
    methods = ("weighted-node-lbp", "particle-filter")
    got = eval_speed.sweep("autumn", 1, (1.0,), methods, 24, None, True)
    assert list(got[1.0]) == [
        "weighted-node-lbp",
        *(f"particle-filter/{d}" for d in ("lowres", "lowres16", "lbp", "haar", "patch")),
    ]
    line = eval_speed.same_place(got[1.0])
    wn, pf = got[1.0]["weighted-node-lbp"], got[1.0]["particle-filter/lbp"]
    assert line.startswith("at least" if wn >= pf else "below") and "lbp" in line
    table = eval_speed.table(got, tuple(got[1.0]))
    assert table.splitlines()[-1].startswith("| declared | 0.5-2 | 0.64-1.67 |")
