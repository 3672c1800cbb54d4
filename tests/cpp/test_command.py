"""``ppaloc cpp run``'s inputs: --set values and the frames of an image or a dataset."""

from __future__ import annotations

import numpy as np
import pytest
from PIL import Image

from ppaloc.cpp.command import load_frames, parse_settings
from ppaloc.errors import PpalocError


def test_parse_settings():
    assert parse_settings(["threshold=30", " dilate = off"]) == {"threshold": "30", "dilate": "off"}
    with pytest.raises(PpalocError, match="must be NAME=VALUE"):
        parse_settings(["threshold"])


def test_a_setting_given_twice_with_two_values_is_refused():
    # the later value was taken without a word
    from ppaloc.cpp.command import parse_stream_options

    assert parse_settings(["threshold=30", "threshold = 30"]) == {"threshold": "30"}
    with pytest.raises(PpalocError) as err:
        parse_settings(["threshold=30", "dilate=on", "threshold=40"])
    assert str(err.value) == "--set threshold is given twice ('30', then '40'): give it once"
    with pytest.raises(PpalocError) as err:
        parse_stream_options(["framerate=30", "framerate=25"])
    assert str(err.value) == (
        "--stream-option framerate is given twice ('30', then '25'): give it once"
    )
    # a long value is cut as the --param of every other command cuts it, marked as cut (it
    # lost its closing quote and showed no sign of the cut)
    with pytest.raises(PpalocError) as err:
        parse_settings(["name=" + "a" * 100, "name=b"])
    assert str(err.value) == f"--set name is given twice ('{'a' * 56}..., then 'b'): give it once"


def _session(**settings: str):
    from ppaloc.cpp.server import Session
    from ppaloc.sim import Scamp5

    return Session(Scamp5(4, 4), [], settings, program="p.cpp")


def test_a_gui_name_matches_as_declared_or_without_its_colon():
    s = _session(**{"edge mode": "1", "gain": "2", "a": "on"})
    assert s.gui_value("slider", "edge mode: ", 0, 9, 0, 1) == 1
    assert s.gui_value("slider", "gain", 0, 9, 0, 2) == 2
    assert s.gui_value("slider", "other", 0, 9, 7, 3) == 7
    s.gui_value("switch", "a:", 0, 1, 0, 4)
    s.check_settings()  # "a" fits one item so far
    s.gui_value("switch", "a", 0, 1, 0, 5)
    with pytest.raises(PpalocError, match=r"^--set a=\.\.\. names 2 items of p\.cpp \(a:, a\): "):
        s.check_settings()


def test_an_unknown_gui_name_lists_the_names_as_typed():
    s = _session(nope="1")
    s.gui_value("slider", "edge mode: ", 0, 9, 0, 1)
    s.gui_value("slider", "threshold:", 0, 9, 0, 2)
    with pytest.raises(PpalocError) as err:
        s.check_settings()
    assert str(err.value) == (
        "--set nope=...: p.cpp has no slider, switch or button of that name "
        "(it has: 'edge mode', threshold)"
    )


def test_a_setting_is_a_plain_integer_as_the_hosts_slider_gives_one():
    # Python's int() took 1_0 as 10 and the Arabic-Indic digit three as 3, without a word
    s = _session(a="+7", b=" -3 ", c="1_0", d="\u0663", e="0x10")
    assert s.gui_value("slider", "a", -9, 9, 0, 1) == 7
    assert s.gui_value("slider", "b", -9, 9, 0, 2) == -3
    for name in "cde":
        with pytest.raises(PpalocError, match=rf"^--set {name}=.*: the slider takes an integer"):
            s.gui_value("slider", name, 0, 99, 0, 3)


def test_two_names_of_one_gui_item_are_refused():
    s = _session(gain="1", **{"gain:": "2"})
    with pytest.raises(PpalocError, match=r"--set gain=\.\.\. and --set gain:=\.\.\. both name"):
        s.gui_value("slider", "gain: ", 0, 9, 0, 1)


def test_frames_from_an_image(tmp_path):
    path = tmp_path / "scene.png"
    Image.fromarray(np.full((40, 60), 200, np.uint8)).save(path)
    frames = list(load_frames(path, None, 3))
    assert len(frames) == 3 and frames[0].shape == (256, 256) and frames[0].dtype == np.uint8
    assert int(frames[0][100, 100]) == 200


def test_an_image_that_is_a_pipe_is_refused_not_waited_on(tmp_path):
    import os

    os.mkfifo(tmp_path / "scene.png")  # opening it would wait for a writer for ever
    with pytest.raises(PpalocError) as err:
        load_frames(tmp_path / "scene.png", None, 1)
    assert str(err.value) == (
        f"image {tmp_path / 'scene.png'} is not a regular file (a pipe, device or socket); "
        "give --image an image file"
    )


def test_frames_from_a_dataset_and_defaults():
    frames = list(load_frames(None, "synthetic:?places=12&seed=2", 2))
    assert len(frames) == 2 and frames[1].shape == (256, 256)
    assert load_frames(None, None, None) is None  # run_program's default scene
    assert len(list(load_frames(None, None, 2))) == 2
    with pytest.raises(PpalocError, match=r"^give one of --image, --dataset and --stream, not "):
        load_frames("a.png", "synthetic:", None)
    with pytest.raises(PpalocError, match=r"--frames 0 must be in \[1, 2000\]"):
        load_frames(None, None, 0)
    with pytest.raises(PpalocError, match="held in memory"):  # refused before any is made
        load_frames(None, None, 10**8)


def test_more_frames_than_a_dataset_holds_are_refused_not_cut(tmp_path):
    for i in range(3):
        Image.fromarray(np.full((40, 60), 50 * i, np.uint8)).save(tmp_path / f"f{i}.png")
    assert len(list(load_frames(None, f"folder:{tmp_path}", 3))) == 3
    assert len(list(load_frames(None, f"folder:{tmp_path}", None))) == 3  # all, unasked
    with pytest.raises(PpalocError) as err:
        load_frames(None, f"folder:{tmp_path}", 5)
    assert str(err.value) == (
        f"--frames 5: --dataset folder:{tmp_path} has 3 frame(s); give --frames 3 or fewer, "
        "or leave it out"
    )


@pytest.mark.parametrize("timeout", [float("inf"), float("nan"), 1e300, 0, -1])
def test_a_timeout_out_of_range_is_refused_before_the_build(tmp_path, timeout):
    from ppaloc.cpp.run import run_program

    with pytest.raises(PpalocError, match=r"timeout=.* must be a number of seconds in"):
        run_program(tmp_path / "none.cpp", timeout=timeout)


def test_settings_take_numbers_and_bools():
    from ppaloc.cpp.run import check_settings

    got = check_settings({"threshold": 30, "dilate": True, "off": False, "gain": 2.0, "m": "on"})
    assert got == {"threshold": "30", "dilate": "1", "off": "0", "gain": "2", "m": "on"}
    assert check_settings({"n": np.int64(-3)}) == {"n": "-3"}
    assert check_settings(None) == {}


@pytest.mark.parametrize(
    ("settings", "message"),
    [
        (
            {"threshold": None},
            r"^settings\['threshold'\]=None: a slider, switch or button takes a number, ",
        ),
        ({"threshold": [1]}, r"^settings\['threshold'\]=\[1\]: "),
        (
            {"threshold": 2.5},
            r"^settings\['threshold'\]=2.5: a slider, switch or button takes an integer",
        ),
        ({"threshold": float("nan")}, r"^settings\['threshold'\]=nan: .* takes an integer"),
        ({3: 1}, r"^settings key 3 must be a slider's, switch's or button's name"),
        ([("threshold", 1)], r"^settings=\[\('threshold', 1\)\] must be a mapping"),
    ],
)
def test_other_settings_are_refused_before_the_build(tmp_path, settings, message):
    from ppaloc.cpp.run import run_program

    with pytest.raises(PpalocError, match=message):
        run_program(tmp_path / "none.cpp", settings=settings)
    assert list(tmp_path.iterdir()) == []
