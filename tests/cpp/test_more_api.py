"""Device API names beyond the tutorials' (programs/more_api.cpp, one case per ``mode``):
the GUI connect callbacks under their device names, callbacks the host never triggers, a
slider's range, a line plot, a printed kernel and the host-only rests and waits."""

from __future__ import annotations

import numpy as np
import pytest

from ppaloc.cpp import compile_program, run_program
from ppaloc.errors import PpalocError

from .conftest import PROGRAMS

SOURCE = PROGRAMS / "more_api.cpp"
N = 16


@pytest.fixture(scope="module")
def frames(cxx) -> list[np.ndarray]:
    compile_program(SOURCE)  # once for the module
    rng = np.random.default_rng(5)
    return [rng.integers(0, 256, (N, N), dtype=np.uint8) for _ in range(2)]


def run(frames, mode: int, **kwargs):
    return run_program(SOURCE, frames, settings={"mode": str(mode)}, timeout=60, **kwargs)


def test_device_names_run_and_are_recorded(frames, tmp_path):
    result = run(frames, 0, out=tmp_path / "run")
    # vs_on_gui_connect/_disconnect are vs_on_host_connect/_disconnect; the recording and
    # user-value callbacks never run; the slider keeps its value in its new range
    assert result.texts == ["gui connected", "level 5", "level 5", "gui disconnected"]
    for frame, out in zip(frames, result.session.outputs, strict=True):
        # mov(C, A) goes through the bus twice (C = -(-A)): -128 saturates to 127 on the
        # way, so comes back as -127
        expected = np.maximum(frame.astype(np.float32) - 128, -127)
        np.testing.assert_array_equal(out[1], expected)
    host = (tmp_path / "run" / "host.txt").read_text()
    for line in (
        "frame 0: vs_on_gui_start_recording()",
        "frame 0: vs_on_gui_stop_recording()",
        "frame 0: vs_on_user_value()",
        "frame 0: vs_gui_set_slider_range(4, -5, 20)",  # displays 1, 2, sliders 3, 4
        "frame 0: vs_gui_set_lineplot: 'plot' shows posted values in [0, 100], as row series",
        "frame 0: vs_wait_io_agent('vs_usb')",
        "frame 0: vs_vision_chip_rest()",
        "frame 1: vs_gui_save_snapshots()",
        "frame 1: vs_scamp5_rest()",
    ):
        assert line in host.splitlines()
    # the printed kernel is recorded once, when it is built, and runs every frame
    assert host.count("scamp5_kernel_begin_print(") == 1


@pytest.mark.parametrize(
    ("mode", "message"),
    [
        (1, r"more_api.cpp:\d+: vs_gui_set_slider_range\(\d+, 20, -5\): the minimum is above"),
        (2, r"vs_gui_set_slider_range\(\d+, \.\.\.\): no slider, switch or button has this"),
        (3, r"vs_gui_set_lineplot\('plot', 0, 100, 3\): format is 0 \(auto\), 1 \(row series\)"),
        (4, r"more_api.cpp:\d+: vs_wait_io_agent\(NULL\): give an io agent: vs_usb, vs_spi"),
    ],
)  # fmt: skip
def test_misuse_is_one_line_with_its_line(frames, tmp_path, mode, message):
    with pytest.raises(PpalocError, match=message) as err:
        run(frames, mode, out=tmp_path / "run")
    assert "\n" not in str(err.value)


CALLBACK_FIRST = r"""
#include <scamp5.hpp>
using namespace SCAMP5_PE;
vs_handle shown;  // added after the callback is set, as the public VO program does
int main() {
    vs_init();
    int calls = 0;
    vs_handle level = vs_gui_add_slider("level", 0, 10, 5);
    vs_on_gui_update(level, [&](int32_t v) {
        ++calls;
        scamp5_get_image(A, B);
        scamp5_output_image(A, shown);
        vs_post_text("callback %d", v);
    });
    vs_post_text("set, %d calls", calls);
    shown = vs_gui_add_display("shown", 0, 0);
    while (1) {
        vs_frame_loop_control();
        vs_post_text("frame, %d calls", calls);
    }
}
"""


def test_gui_update_callback_runs_at_the_next_message_processing(cxx, tmp_path):
    # the device calls it when the host's value arrives, in the message processing of the
    # frame loop, never inside vs_on_gui_update: a callback that outputs to a display the
    # program adds after setting it ran at once here and stopped the run ("display handle 0
    # was not created by vs_gui_add_display")
    source = tmp_path / "callback.cpp"
    source.write_text(CALLBACK_FIRST)
    frames = [np.full((N, N), 200, np.uint8)] * 2
    result = run_program(source, frames, settings={"level": "7"}, timeout=60)
    assert result.texts == ["set, 0 calls", "callback 7", "frame, 1 calls", "frame, 1 calls"]
    # the display (handle 2, after the slider) got frame 0 in the callback
    np.testing.assert_array_equal(result.session.outputs[0][2], np.full((N, N), 72.0))


MOVED_ON_CONNECT = r"""
#include <scamp5.hpp>
using namespace SCAMP5_PE;
int main() {
    vs_init();
    vs_on_gui_update(VS_GUI_FRAME_RATE, [&](int32_t v) { vs_post_text("rate %d", v); });
    vs_on_host_connect([&] { vs_gui_move_slider(VS_GUI_FRAME_RATE, 200); });
    while (1) {
        vs_frame_loop_control();
    }
}
"""


def test_a_callback_the_program_ran_is_not_run_again_with_the_hosts_value(cxx, tmp_path):
    # the public mobile-robot tracker moves the frame rate in its connect callback, which
    # runs the rate's callback; the host's value, due at the same message processing, is
    # then the one delivered (it ran the callback a second time)
    source = tmp_path / "moved.cpp"
    source.write_text(MOVED_ON_CONNECT)
    result = run_program(source, [np.zeros((N, N), np.uint8)] * 2, timeout=60)
    assert result.texts == ["rate 200"]


BUTTON = PROGRAMS / "button.cpp"


def test_a_button_callback_runs_only_when_it_is_pressed(cxx):
    # the host sends a button's message when it is pressed, never at the start as it
    # sends a slider's value; nothing presses it here (it ran once with 0, a press)
    result = run_program(BUTTON, [np.zeros((N, N), np.uint8)] * 2, timeout=60)
    assert result.texts == ["frame 0", "frame 0"]


def test_a_button_set_to_1_is_pressed_once_at_the_start(cxx):
    frames = [np.zeros((N, N), np.uint8)] * 2
    result = run_program(BUTTON, frames, settings={"store": 1}, timeout=60)
    assert result.texts == ["pressed 1", "frame 1", "frame 1"]
    with pytest.raises(PpalocError, match=r"--set store=2 is outside the button's range \[0, 1\]"):
        run_program(BUTTON, frames, settings={"store": 2}, timeout=60)


INIT_OUTSIDE = r"""
#include <scamp5.hpp>
using namespace SCAMP5_PE;
int main() {
    vs_init();
    int level = 0;
    vs_handle h = vs_gui_add_slider("level", 0, 10, 50, &level);
    vs_gui_add_slider("low", -5, 5, -9);
    while (1) {
        vs_frame_loop_control();
        vs_post_text("%d %d", level, vs_gui_read_slider(h));
    }
}
"""


def test_a_sliders_initial_value_outside_its_range_starts_at_the_nearest_end(cxx, tmp_path):
    # min and max are the values the slider allows (the headers): the host's slider holds
    # only those, so the program gets the nearest end; it got 50 from a [0, 10] slider,
    # which no --set or live view could give back
    source = tmp_path / "init.cpp"
    source.write_text(INIT_OUTSIDE)
    result = run_program(source, [np.zeros((N, N), np.uint8)], timeout=60)
    assert result.texts == ["10 10"]
    assert result.session.gui_values == {"level": 10, "low": -5}
    assert result.session.warnings == [
        "init.cpp:7: vs_gui_add_slider('level', 0, 10, 50): the initial value is outside the "
        "range the slider allows; it starts at 10, as the host's slider holds",
        "init.cpp:8: vs_gui_add_slider('low', -5, 5, -9): the initial value is outside the "
        "range the slider allows; it starts at -5, as the host's slider holds",
    ]
