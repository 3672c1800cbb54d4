"""The device API around the chip (programs/device_api.cpp, one case per ``mode``): the
host's GUI items, vs_random, outputs other than whole images, host graphics, data posts
and the host-only calls, each checked against numpy or a hand-computed value."""

from __future__ import annotations

import json

import numpy as np
import pytest

from ppaloc.cpp import compile_program, run_program
from ppaloc.errors import PpalocError

from .conftest import PROGRAMS

SOURCE = PROGRAMS / "device_api.cpp"
N = 64
FIRST, SECOND, THIRD = 1, 2, 3  # display handles, in the order the program adds them


@pytest.fixture(scope="module")
def frames(cxx) -> list[np.ndarray]:
    compile_program(SOURCE)  # once for the module
    rng = np.random.default_rng(11)
    return [rng.integers(0, 256, (N, N), dtype=np.uint8) for _ in range(2)]


def run(frames, mode: int, **kwargs):
    return run_program(SOURCE, frames, settings={"mode": str(mode)}, timeout=60, **kwargs)


def test_host_gui_items_read_their_defaults(frames):
    result = run(frames, 0)
    # the frame gain reads 1, so scamp5_get_image(A, B, gain) runs; the rate callback
    # got the frame rate at once
    assert result.texts[:2] == ["gain 1 rate 30 callback 30 simulation 1"] * 2
    for frame, out in zip(frames, result.session.outputs, strict=True):
        np.testing.assert_array_equal(out[FIRST], frame.astype(np.float32) - 128)  # yf


def test_host_connects_then_disconnects_and_shuts_down(frames, tmp_path):
    result = run(frames, 0, out=tmp_path / "run")
    log = result.session.host_log
    assert log[:3] == [(0, "vs_sim::reset_model(0)"), (0, "host: connected (vs_on_host_connect)"),
                       (0, "vs_led_on(2)")]  # fmt: skip
    assert [t for _, t in log[3:]] == [
        "host: disconnected (vs_on_host_disconnect)",
        "vs_led_off(2)",
        "host: shutting down (vs_on_shutdown)",
    ]
    assert result.texts[-1] == "shutdown"
    host = (tmp_path / "run" / "host.txt").read_text().splitlines()
    assert host[1] == "frame 0: host: connected (vs_on_host_connect)"
    assert host[-1] == "after the run: host: shutting down (vs_on_shutdown)"
    assert json.loads((tmp_path / "run" / "summary.json").read_text())["host_calls"] == 6


def mwc(seed: int):
    """The device generator: multiply-with-carry on two 16-bit lags."""
    w, z = (521288629 + seed) % 2**32, (362436069 - seed) % 2**32
    while True:
        z = 36969 * (z & 0xFFFF) + (z >> 16)
        w = 18000 * (w & 0xFFFF) + (w >> 16)
        yield z, w


def test_vs_random_is_seeded_and_reproducible(frames):
    texts = run(frames, 1).texts
    assert texts[0] == texts[1]  # a seed gives the same numbers every time
    first, a, b, again, seed, plain16, chance = map(int, texts[0].split())
    gen = mwc(7)
    z, w = next(gen)
    # by hand: z0 = 362436069 - 7 = 362436062 = 5530 * 65536 + 21982, so
    # z = 36969 * 21982 + 5530 = 812658088; w0 = 521288636 = 7954 * 65536 + 15292, so
    # w = 18000 * 15292 + 7954 = 275263954; first = (z << 16) + (w & 0xFFFF) mod 2^32
    assert (z, w) == (812_658_088, 275_263_954)
    assert first == 765_997_522 == ((z << 16) + (w & 0xFFFF)) % 2**32
    z, w = next(gen)
    assert a == (((z << 8) + (w & 0xFF)) & 0xFFFF) * 100 // 65536
    z, w = next(gen)
    assert b == (((z << 8) + (w & 0xFF)) & 0xFFFF) * 11 // 65536 - 5
    assert again == first  # reset() starts the sequence again
    z, w = next(mwc(0))
    assert seed == 0 and plain16 == ((z << 8) + (w & 0xFF)) & 0xFFFF
    assert chance == 1  # a chance of 1/1


def test_outputs_of_areg_events_and_bounding_box(frames, tmp_path):
    result = run(frames, 2, out=tmp_path / "run")
    for frame, out in zip(frames, result.session.outputs, strict=True):
        a = frame.astype(np.float32) - 128  # scamp5_get_image's yf
        hw = a[:, ::-1]  # hardware column order
        np.testing.assert_array_equal(out[FIRST], hw[1::2, 0::2][:, ::-1])  # s=2, r0=1, c0=0
        assert out[FIRST].shape == (32, 32)
        events = np.zeros((N, N), bool)
        events[3, N - 1 - 2] = events[10, N - 1 - 20] = True
        np.testing.assert_array_equal(out[SECOND], events)
        box = np.zeros((N, N), bool)  # outline from (3, hw 2) to (10, hw 20)
        box[3, N - 21 : N - 2] = box[10, N - 21 : N - 2] = True
        box[3:11, N - 21] = box[3:11, N - 3] = True
        np.testing.assert_array_equal(out[THIRD], box)
    assert result.texts[0] == "box 3 2 10 20"  # the result buffer, as scan_boundingbox gives
    # the sub-sampled display keeps its size; the montage shows it at the array's size
    from PIL import Image

    with Image.open(tmp_path / "run" / "displays" / "first" / "frame_0000.png") as png:
        assert png.size == (32, 32)
    assert (tmp_path / "run" / "montage.png").exists()


def test_bounding_box_of_the_top_right_element_is_drawn(frames):
    """scamp5_output_boundingbox outputs "the bounding box coordinates of the '1's": a 1
    at hardware address (0, 0) alone has the box (0, 0, 0, 0), the bytes an empty
    register gives too, and is drawn; an empty register draws nothing."""
    result = run(frames, 8)
    corner = np.zeros((N, N), bool)
    corner[0, N - 1] = True  # hardware column 0 is the east edge
    for out in result.session.outputs:
        np.testing.assert_array_equal(out[FIRST], corner)
        assert not out[SECOND].any()
    assert result.texts[0] == "box 0 0 0 0 none 0 0 0 0"


def test_vs_wait_passes_modelled_time(frames):
    """vs_wait(usec) is a "polled time delay" (vs_m0.hpp) on the controller: the modelled
    clock the stopwatch reads advances by usec (and the call's overhead), on the chip's
    side of the frame (the public programs wait out exposures with it), not the loop's."""
    result = run(frames, 9)
    timing = result.session.sim.timing
    waited = timing.call_us("vs_wait", 2500)
    assert 2500 <= waited < 2501
    assert result.texts[:2] == [f"waited {int(waited + 0.5)}"] * 2
    calls = {st.name: st.calls.get("vs_wait", 0) for st in timing.report().stages}
    assert calls.pop("loop") == 0 and sum(calls.values()) == 2  # vs_wait(0) is free
    s = result.session
    assert len(s.frame_us) == 2
    for us, loop in zip(s.frame_us, s.frame_loop_us, strict=True):
        assert loop < 2500 <= us - loop  # the wait is in chip_us, not loop_us


def test_bound_io_agents_read_back(frames):
    """scamp5_get_io_agent (scamp5_output.hpp) and vs_post_get_io_agent (vs_post.hpp)
    return the agent bound last: vs_usb before any binding, as assumed here."""
    assert run(frames, 22).texts[0] == "agents 1 1 1 1"


def test_host_sliders_of_the_update_table_are_named(frames):
    """vs_on_gui_update's table (vs_interaction.hpp) names VS_GUI_VECTOR_LENGTH,
    _IMAGE_LENGTH and _IMAGE_BLEND: they compile, with the device's handles
    (vs_protocol_gui.hpp); their callbacks are never called, the host here holding no
    value for them."""
    assert run(frames, 23).texts[0] == "blend -1 handles 132 133 134"


def test_display_of_byte_images_and_events(frames):
    out = run(frames, 3).session.outputs[0]
    # 4 x 2, column-major from the top-right element (scamp5_output.hpp): buffer[1] is the
    # right column's second row, buffer[2] the next column's first
    np.testing.assert_array_equal(out[FIRST] + 128, [[255, 200, 100, 0], [5, 250, 150, 50]])
    patched = frames[0].astype(np.float32) - 128
    # rows 5-6, hardware columns 6-7 (array columns N - 8 and N - 7), first byte top-right
    patched[5:7, N - 8 : N - 6] = np.array([[100, 0], [150, 50]]) - 128.0
    np.testing.assert_array_equal(out[SECOND], patched)  # pasted over the image
    marks = np.zeros((N, N), bool)
    marks[2, N - 1 - 1] = marks[0, 0] = True  # (column 1, row 2), (column 63, row 0); (0,0) ends
    np.testing.assert_array_equal(out[THIRD], marks)


def test_scanned_regions_display_as_they_were_scanned(frames):
    """scamp5_display_image takes scamp5_scan_areg's buffer ("useful when used in
    combination with scanning functions such as scamp5_scan_areg", the same layout), and a
    patch at the region's own address lands where it was scanned."""
    for frame, out in zip(frames, run(frames, 7).session.outputs, strict=True):
        a = frame.astype(np.float32) - 128  # scamp5_get_image's yf; its ADC codes are frame
        np.testing.assert_array_equal(out[FIRST], a)
        black = np.full((N, N), -128.0, np.float32)
        black[10:13, N - 25 : N - 20] = a[10:13, N - 25 : N - 20]  # hardware columns 20-24
        np.testing.assert_array_equal(out[SECOND], black)
        np.testing.assert_array_equal(out[THIRD], a)


def test_a_patch_goes_over_the_display_previous_image(frames):
    """scamp5_display_image_patch "will apply the image over the previous image in the
    display" (scamp5_output.hpp): a digital register's image (drawn as 0 and 255) and the
    image an earlier frame left stay around it."""
    first, second = run(frames, 26).session.outputs
    patch = np.array([[30, 10], [40, 20]], np.float32) - 128  # column-major, top-right first
    digital = np.full((N, N), -128.0, np.float32)
    digital[3, N - 1 - 2] = 127.0  # the point at row 3, hardware column 2
    digital[10:12, N - 12 : N - 10] = patch
    np.testing.assert_array_equal(first[FIRST], digital)
    earlier = frames[0].astype(np.float32) - 128  # frame 0's image of A on the second display
    earlier[20:22, N - 22 : N - 20] = patch
    np.testing.assert_array_equal(second[SECOND], earlier)


def test_display_of_boxes_rgb_image_and_text(frames):
    result = run(frames, 4)
    out = result.session.outputs[0]
    boxes = np.zeros((N, N), bool)
    boxes[1, 1:4] = boxes[3, 1:4] = boxes[1:4, 1] = boxes[1:4, 3] = True  # hw cols 60-62
    boxes[10, N - 11] = True  # a one-pixel box
    np.testing.assert_array_equal(out[FIRST], boxes)
    # RGB drawn as its grey level, bottom row first
    np.testing.assert_array_equal(out[SECOND] + 128, [[255], [60]])
    assert (0, "vs_gui_display_text: 'third' at row 5, column 4, RGBA (255, 255, 255, 255): "
            "'hello'") in result.session.host_log  # fmt: skip


def test_host_only_calls_are_accepted_and_recorded(frames, tmp_path):
    result = run(frames, 5, out=tmp_path / "run")
    frame0 = [t for f, t in result.session.host_log if f == 0][3:]
    assert frame0 == [
        "vs_configure_frame_trigger(1, 60)",
        "vs_frame_trigger_set(1, 30)",
        "vs_disable_frame_trigger()",
        "vs_enable_frame_trigger()",
        "vs_led_toggle(1)",
        "vs_scamp5_configure_voltage(3, 1200)",
        "vs_post_bind_io_agent('vs_usb')",
        "scamp5_bind_io_agent('vs_spi')",
        "vs_gui_set_scope: 'first' shows posted values in [0, 100], 64 wide",
        "vs_gui_set_barplot: 'second' shows posted values in [-10, 10], 4 wide",
        "vs_gui_save_image(1, 'saved/first.bmp')",
        "vs_sim::config('server_port', '27715')",  # vs_sim::save_image is served, not here
        "scamp5_kernel::print_debug_info()",
        "allow_highspeed(1)",  # recorded once: the static kernel is recorded once
    ]
    (kernel,) = [k for k in result.session.kernels.values() if k.calls == ["mov(C, A)"]]
    assert kernel.runs == 2  # allow_highspeed leaves the kernel's ICWs as they are
    assert (tmp_path / "run" / "saved" / "a.bmp").is_file()


def test_posted_data_keeps_frame_channel_and_type(frames, tmp_path):
    result = run(frames, 6, out=tmp_path / "run")
    posts = result.session.posts
    assert posts[:4] == [
        {"frame": 0, "channel": SECOND, "type": "int16", "data": [[-1, 2, 300]]},
        {"frame": 0, "channel": SECOND, "type": "int32", "data": [[1, -2], [3, 70000]]},
        {"frame": 0, "channel": 9, "type": "int8", "data": [[-128], [127]]},
        {"frame": 0, "channel": 9, "type": "float", "data": [[0.5]]},
    ]
    assert [p["frame"] for p in posts[4:]] == [1] * 4
    assert json.loads((tmp_path / "run" / "posts.json").read_text()) == posts
    run(frames, 6, out=tmp_path / "run")  # an earlier run's folder, host.txt and all, is replaced


@pytest.mark.parametrize(
    ("mode", "message"),
    [
        (10, r"device_api.cpp:\d+: vs_gui_read_slider\(77, \.\.\.\): no slider, switch or "
             r"button has this handle; give one that vs_gui_add_slider"),
        (11, r"device_api.cpp:\d+: vs_led_on\(7\): the board has LEDs 0 to 2"),
        (12, r"vs_configure_frame_trigger\(9, 60\): mode 9 is not a frame trigger mode"),
        (14, r"scamp5_output_areg\(A, 1, 2, 3, 0\): r0=3 is not a phase of s=2; use 0 to 1"),
        (15, r"device_api.cpp:\d+: display handle 55 was not created by vs_gui_add_display"),
        (16, r"device_api.cpp:\d+: scamp5_display_image_patch: a 2 x 2 patch at row 63, "
             r"hardware column 0 runs off the 64 x 64 display"),
        (25, r"device_api.cpp:\d+: scamp5_display_image_patch: a 2 x 2 patch at row 0, "
             r"hardware column 63 runs off the 64 x 64 display"),
        (17, r"vs_post_bind_io_agent\(NULL\): give an io agent: vs_usb, vs_spi or vs_uart"),
        (18, r"allow_highspeed\(\) is a kernel function: call it inside a kernel"),
        (19, r"vs_frame_trigger_set\(1, 0\): the interval num/den s needs num and den above 0"),
        # it stopped in the shim: "an uncaught exception std::length_error", no line
        (20, r"device_api.cpp:\d+: vs_post_int16\(18446744073709551615 rows, 4 cols\): more "
             r"than a post carries \(16777216 bytes\); give the array's rows and columns"),
        (21, r"device_api.cpp:\d+: scamp5_display_events\(18446744073709551615 events\): more "
             r"than a post carries \(16777216 bytes\); give the number of events in the buffer"),
        (24, r"device_api.cpp:\d+: vs_gui_read_slider\(VS_GUI_IMAGE_LENGTH, \.\.\.\): the "
             r"host's own slider, whose value the headers do not give and this run does not hold"),
    ],
)  # fmt: skip
def test_misuse_is_one_line_with_its_line(frames, tmp_path, mode, message):
    with pytest.raises(PpalocError, match=message) as err:
        run(frames, mode, out=tmp_path / "run")
    assert "\n" not in str(err.value)
    assert not (tmp_path / "run").exists()
