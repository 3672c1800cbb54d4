"""The last names of the device folder's own headers (programs/device_names.cpp, one case
per ``mode``): the registers' ICW fields with the device's values, raw ICWs built from them
and run with ``vs_scamp5_execute_icw``, the DAC, the vector types, the error flags, and the
host graphics, requests and calibrations the host records."""

from __future__ import annotations

import numpy as np
import pytest

from ppaloc.cpp import compile_program, run_program
from ppaloc.errors import PpalocError

from .conftest import PROGRAMS

SOURCE = PROGRAMS / "device_names.cpp"
N = 16


@pytest.fixture(scope="module")
def frames(cxx) -> list[np.ndarray]:
    compile_program(SOURCE)  # once for the module
    rng = np.random.default_rng(7)
    return [rng.integers(0, 256, (N, N), dtype=np.uint8)]


def run(frames, mode: int, **kwargs):
    return run_program(SOURCE, frames, settings={"mode": str(mode)}, timeout=60, **kwargs)


def test_device_names_work_as_on_the_device(frames, tmp_path):
    result = run(frames, 0, out=tmp_path / "run")
    # the values of the device's register constants (scamp5_icw.hpp)
    assert result.texts[:4] == [
        "R5 2 16 3 1",
        "A 8192 2097152 NEWS 65536 16778240",
        "FLAG 0 64",
        "temporaries 1 1",
    ]
    # roi(100, 50, 10, 6): x 95-104, y 47-52; moved 160 right and bound: x 246-255
    assert result.texts[4:8] == [
        "roi 95 47 104 52",
        "bound 246 47 255 52 w 10 h 6 c 251 50",
        "box 1 2 3 4 rc 7 9",
        "errors 0",
    ]
    # a second request while one is under way is refused; the image request times out
    assert result.texts[8:] == ["requests 0 1 done 0", "image status -1 size 0 x 0"]
    a = frames[0].astype(np.float32) - 128
    out = result.session.outputs[0]  # by display handle: 1, 2, 3
    moved, negated, dac = out[1], out[2], out[3]
    np.testing.assert_array_equal(moved, a <= 0)  # MOV(R6, R5), then NOT(R7, R6): raw words
    np.testing.assert_array_equal(negated, np.minimum(-a, 127))  # bus(B, A) as a raw word
    np.testing.assert_array_equal(dac, np.full((N, N), 127.0))  # DAC code 4095: the top
    host = (tmp_path / "run" / "host.txt").read_text().splitlines()
    for line in (
        "frame 0: vs_scamp5_calibrate_dac(0)",
        "frame 0: vs_scamp5_calibrate_mid(1)",
        "frame 0: vs_scamp5_calibrate_global_sum()",
        "frame 0: vs_scamp5_configure_clock('NULL: the default clocks')",
        "frame 0: vs_gui_graphics_api::set_color(255, 0, 0, 255)",
        "frame 0: vs_gui_graphics_api::draw_line(0, 0, 10, 10)",
        "frame 0: vs_gui_graphics_api::m_scale('1.5, 2')",
        "frame 0: vs_gui_request_image('image.bmp', 1, 1000)",
    ):
        assert line in host
    assert not any("request_file" in line for line in host)  # refused: one at a time


@pytest.mark.parametrize(
    ("mode", "message"),
    [
        (1, r"device_names.cpp:\d+: .*the AER, DOUT and FAST clocks are not modelled"),
        (2, r"device_names.cpp:\d+: vs_gui_graphics_api::draw_point draws over a display: "
            r"call it inside the callback of vs_gui_display_graphics"),
    ],
)  # fmt: skip
def test_misuse_is_one_line_with_its_line(frames, tmp_path, mode, message):
    with pytest.raises(PpalocError, match=message) as err:
        run(frames, mode, out=tmp_path / "run")
    assert "\n" not in str(err.value)


def test_the_frame_trigger_starts_each_frame(frames):
    three = [np.full((N, N), v, np.uint8) for v in (10, 100, 250)]
    result = run_program(SOURCE, three, settings={"mode": "3"}, timeout=20)
    # frame 0 from vs_frame_loop_control, frames 1 and 2 from the program's own loop
    assert [t.split(":")[0] for t in result.texts] == ["frame 2", "frame 3"]
    low, high = (int(t.split(": ")[1]) for t in result.texts)
    assert low < high  # each trigger brought the next frame's image
    assert result.session.loops == 4


def test_an_overflow_of_the_icw_stack_sets_the_devices_flag(frames):
    result = run_program(SOURCE, frames * 3, settings={"mode": "4"}, timeout=60)
    # set from the frame loop's answer after the overflowing kernel first ran
    assert result.texts == ["overflow 0", "overflow 1", "overflow 1"]
    assert any("lost" in w for w in result.session.warnings)
