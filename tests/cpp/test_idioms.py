"""Usages found in public device programs beyond the tutorials (``programs/idioms.cpp``)."""

from __future__ import annotations

import numpy as np
import pytest

from ppaloc.cpp import compile_program, run_program
from ppaloc.errors import PpalocError

from .conftest import PROGRAMS

IDIOMS = PROGRAMS / "idioms.cpp"


@pytest.fixture(scope="module")
def idioms(cxx):
    return compile_program(IDIOMS)


def run(mode: int, frames, tmp_path=None):
    out = None if tmp_path is None else tmp_path / "out"
    return run_program(IDIOMS, frames, settings={"mode": mode}, timeout=60, out=out)


def test_a_free_running_loop_counts_its_frames_with_the_loop_counter(cxx, tmp_path):
    # while (1) { vs_process_message(); ...; vs_loop_counter_inc(); } with no frame trigger
    # (the public AnalogNet demos): each increment ends a frame; it ran until the timeout
    frames = [np.full((64, 64), 40 * (k + 1), np.uint8) for k in range(3)]
    source = PROGRAMS / "free_running.cpp"
    result = run_program(source, frames, timeout=60, out=tmp_path / "out")
    session = result.session
    assert [t for _, t in session.texts] == ["pass 0", "pass 1", "pass 2"]
    assert [f for f, _ in session.texts] == [0, 1, 2]
    (handle,) = session.displays
    shown = [session.outputs[k][handle] for k in range(3)]
    for k, plane in enumerate(shown):  # get_image's full range: p - 128
        assert np.all(plane == 40 * (k + 1) - 128)
    assert len(session.frame_us) == 3


def test_an_event_scan_beyond_4000_slots_scans_4000(idioms):
    # scamp5_scan_events takes a uint16_t max_num and "up to 4000 events" are scanned
    # (scamp5_output.hpp): 5000 slots give the first 4000 events, then end markers;
    # it was refused (max_num=5000 is out of range)
    result = run(1, [np.zeros((64, 64), np.uint8)])
    # all 4096 elements set; hardware column first: slot k is column k // 64, row k % 64
    assert result.session.texts[0][1] == "last 3999: 62 31; then 0 0"


def test_gpio_pins_read_their_pull_or_their_output(idioms, tmp_path):
    # vs_gpio.h (the public SCAMP-Image-Acquisition program drives lights through it)
    result = run(2, [np.zeros((64, 64), np.uint8)], tmp_path)
    assert result.session.texts[0][1] == "gpio 1 0 1 1"
    host = (tmp_path / "out" / "host.txt").read_text().splitlines()
    assert host[:4] == [
        "frame 0: vs_gpio_as_input(23, 1)",
        "frame 0: vs_gpio_as_input(27, 0)",
        "frame 0: vs_gpio_as_output(28)",
        "frame 0: vs_gpio_output(28, 1)",
    ]


def test_a_gpio_pin_beyond_the_port_is_named(idioms):
    with pytest.raises(PpalocError) as err:
        run(3, [np.zeros((64, 64), np.uint8)])
    assert str(err.value) == (
        "idioms.cpp:33: vs_gpio_output(40, 1): GPIO port 6 has pins 0 to 31 "
        "(VS_GPIO_X0 ... VS_GPIO_X4 are the board's)"
    )


COUNTED_BEFORE_THE_WAIT = r"""
#include <scamp5.hpp>
using namespace SCAMP5_PE;
int main() {
    vs_init();
    for (int k = 0; k < MODE; k++) {  // a warm-up counted on the loop counter
        vs_process_message();
        vs_loop_counter_inc();
    }
    while (1) {
        vs_loop_counter_inc();  // the three calls of vs_frame_loop_control, written out
        vs_wait_frame_trigger();
        vs_process_message();
        vs_post_text("body");
    }
}
"""


@pytest.mark.parametrize("warm_up", [0, 10])
def test_a_program_that_waits_for_the_trigger_anywhere_counts_loops_without_ending_frames(
    cxx, tmp_path, warm_up
):
    # the loop counter counted before the first wait (the documented order of
    # vs_frame_loop_control's three calls, or a warm-up loop): its frames are the waits
    source = tmp_path / "counted.cpp"
    source.write_text(COUNTED_BEFORE_THE_WAIT.replace("MODE", str(warm_up)))
    frames = [np.zeros((64, 64), np.uint8)] * 4
    result = run_program(source, frames, timeout=60)
    assert [(f, t) for f, t in result.session.texts] == [(k, "body") for k in range(4)]
