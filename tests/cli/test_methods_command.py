"""``ppaloc methods``: the methods and each one's parameters from the command line, with
the default each runs with and what it accepts (only the docs and the source said so)."""

from __future__ import annotations

import pytest

from ppaloc.cli import main
from ppaloc.cli.main import _parse_value
from ppaloc.methods import (
    available_methods,
    check_method,
    make_localiser,
    method_parameters,
    parameter_table,
    registry,
)


def run(capsys, *args: str) -> tuple[int, str, str]:
    code = main(list(args))
    out, err = capsys.readouterr()
    return code, out, err


def test_methods_lists_every_available_method_with_its_summary(capsys):
    code, out, err = run(capsys, "methods")
    assert code == 0 and not err
    listed = [line.split()[0] for line in out.splitlines()[: len(available_methods())]]
    assert listed == available_methods()
    assert registry()["seqslam"].summary in out


def test_a_methods_parameters_show_their_defaults_and_ranges(capsys):
    code, out, err = run(capsys, "methods", "weighted-node-lbp", "seqslam")
    assert code == 0 and not err
    lines = {line.split()[0]: line.split() for line in out.splitlines() if line.strip()}
    assert lines["gain"][1:7] == ["4", "an", "integer", "in", "[1,", "32]"]
    assert lines["ds"][1:3] == ["10", "an"]
    assert "--param METHOD.KEY=VALUE" in out


def test_the_paper_preset_shows_its_own_defaults_and_names_the_others(capsys):
    code, out, _ = run(capsys, "methods", "onsensor-paper-lowres")
    assert code == 0
    shift = [line.split() for line in out.splitlines() if line.split()[:1] == ["shift"]]
    assert shift[0][1] == "2"  # the paper preset's shift for 8x8 images, not the class's None
    assert "not read by its preset (other methods' parameters): gain, memory," in out


@pytest.mark.parametrize("name", available_methods())
def test_every_default_shown_is_a_value_the_method_takes(name):
    rows, left_out = parameter_table(name)
    declared = method_parameters(name) or {}
    assert {r[0] for r in rows} | set(left_out) | set(registry()[name].defaults) == set(declared)
    built = make_localiser(name)
    given = {}
    for key, default, _, _ in rows:
        if default == "-":
            continue
        value = _parse_value(default)
        given[key] = value
        resolved = getattr(getattr(built, "params", None), key, declared[key].default)
        assert value == (list(resolved) if isinstance(resolved, tuple) else resolved), key
    check_method(name, given)  # every default, given back with --param, is accepted


def test_an_unknown_method_is_one_line(capsys):
    code, out, err = run(capsys, "methods", "seqslm")
    assert code == 1 and not out
    assert err.startswith("ppaloc: error: method 'seqslm' is unknown; choose from: ")
    assert err.count("\n") == 1


def test_every_filter_parameter_says_what_it_sets_and_its_choices(capsys):
    from ppaloc.localise.params import PARAM_LINES, filter_method_params

    for param in filter_method_params():
        assert param.doc, f"{param.name} has no line for ppaloc methods"
    assert set(PARAM_LINES) == {p.name for p in filter_method_params()} - {"preset"}
    code, out, _ = run(capsys, "methods", "weighted-node-lowres", "weighted-node-paper-lbp")
    assert code == 0
    lines = {line.split()[0]: line for line in out.splitlines() if line.strip()}
    assert "one of 2, 4, 8" in lines["contrast_patch"]
    assert "one of 'image', 'always_forward', 'oracle'" in lines["motion"]
    assert "the most nodes one frame may advance" in lines["max_advance"]
    # a line is printed as written: square brackets are not taken for rich's markup
    assert "paper: the forward window [lo, hi], nodes" in lines["advance"]


def test_a_choice_given_out_of_its_values_is_refused_with_them(capsys):
    code, _, err = run(
        capsys, "evaluate", "-d", "synthetic:?places=20&seed=1", "-m", "weighted-node-lowres",
        "--param", "weighted-node-lowres.contrast_patch=3", "--out", "unused",
    )  # fmt: skip
    assert code == 1
    assert "contrast_patch=3 must be one of 2, 4, 8" in err


@pytest.mark.parametrize("name", available_methods())
def test_every_parameter_of_a_built_in_method_says_what_it_sets(name):
    # the baselines' lines come from their class docstrings' Parameters sections
    rows, _ = parameter_table(name)
    assert rows and all(what for _, _, _, what in rows), [r[0] for r in rows if not r[3]]
    if name == "particle-filter":
        lines = {key: what for key, _, _, what in rows}
        assert lines["n_particles"] == "Number of particles."
        assert (
            lines["max_jump"]
            == "Largest forward jump in nodes (jumps are uniform over 2 .. max_jump)."
        )
        assert lines["p_jump"] == lines["p_stay"]  # "p_stay, p_forward, p_jump : float"


def test_a_choice_is_checked_by_value_not_by_its_exact_type():
    from typing import Literal

    import numpy as np

    from ppaloc.errors import PpalocError
    from ppaloc.methods import _fits, check_parameters

    check_parameters("weighted-node-lowres", {"motion": np.str_("image"), "contrast_patch": 4})
    with pytest.raises(PpalocError, match="contrast_patch=3 must be one of 2, 4, 8"):
        check_parameters("weighted-node-lowres", {"contrast_patch": 3})

    class Count(int):  # an int by subclass, as numpy's str_ is a str
        pass

    assert _fits(Count(2), Literal[1, 2]) and not _fits(True, Literal[1, 2])  # True == 1
    assert _fits(True, Literal[True, "auto"]) and not _fits(1, Literal[True])


def test_the_enhance_row_says_a_window_of_one_is_refused():
    # the row read "an integer in [0, 1000000]" and "0 off", and enhance=1 was refused
    (row,) = [r for r in parameter_table("weighted-node-lbp")[0] if r[0] == "enhance"]
    assert "at least 2" in row[3] and "0 off" in row[3]
    make_localiser("weighted-node-lbp", enhance=2)
    with pytest.raises(Exception, match="at least 2"):
        make_localiser("weighted-node-lbp", enhance=1)


def test_the_lane_speed_row_says_one_is_refused():
    # the row read "an integer in [0, 3]", and lane_speed=1 was refused
    (row,) = [r for r in parameter_table("weighted-node-lbp")[0] if r[0] == "lane_speed"]
    assert "2 .. max_advance, or 0" in row[3]
    make_localiser("weighted-node-lbp", lane_speed=2)
    with pytest.raises(Exception, match=r"2 \.\. max_advance"):
        make_localiser("weighted-node-lbp", lane_speed=1)
