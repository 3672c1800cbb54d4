"""Tutorial-style SCAMP-5d programs run on the simulator, each checked against numpy.

One program (programs/tutorial.cpp) holds every case behind a ``mode`` slider, so the
module compiles once (the build cache keys on the source's hash).
"""

from __future__ import annotations

import numpy as np
import pytest

from ppaloc.cpp import compile_program, run_program
from ppaloc.sim import A, C, D, E, Scamp5, east
from ppaloc.sim.controller import to_scamp_buffer

from .conftest import PROGRAMS

SOURCE = PROGRAMS / "tutorial.cpp"
N = 64
ANALOG, DIGITAL, BITS = 1, 2, 3  # display handles, in the order the program adds them


@pytest.fixture(scope="module")
def frames(cxx) -> list[np.ndarray]:
    compile_program(SOURCE)  # once for the module
    rng = np.random.default_rng(5)
    return [rng.integers(0, 256, (N, N), dtype=np.uint8) for _ in range(2)]


def run(frames, mode: int, **settings):
    values = {"mode": str(mode), **{k: str(v) for k, v in settings.items()}}
    return run_program(SOURCE, frames, settings=values, timeout=60)


def full_range(frame: np.ndarray) -> np.ndarray:
    return frame.astype(np.float32) / 2 - 64  # get_image(A): the half range, p/2 - 64


def codes(values: np.ndarray) -> np.ndarray:
    return np.clip(np.floor(values + 128.5), 0, 255).astype(np.int64)


def block_codes(plane: np.ndarray, n: int) -> np.ndarray:
    b = plane.shape[0] // n
    return codes(plane.reshape(n, b, n, b).mean(axis=(1, 3), dtype=np.float64))


@pytest.mark.parametrize("threshold", [20, -30])
def test_capture_and_slider_threshold(frames, threshold):
    result = run(frames, 0, threshold=threshold)
    outputs = result.session.outputs
    assert len(outputs) == 2  # one per frame of the loop
    for frame, out in zip(frames, outputs, strict=True):
        np.testing.assert_array_equal(out[DIGITAL], full_range(frame) - threshold > 0)
    assert result.session.gui_values["threshold"] == threshold
    assert result.texts[-1] == "frame 2 done"


def test_edges_with_neighbour_moves(frames):
    out = run(frames, 1).session.outputs
    for frame, got in zip(frames, out, strict=True):
        a = full_range(frame)
        east = np.zeros_like(a)
        east[:, :-1] = a[:, 1:]  # movx(C, A, east): beyond the edge reads 0
        np.testing.assert_array_equal(got[ANALOG], np.abs(a - east))


def test_dnews_dilation(frames):
    out = run(frames, 2, threshold=60).session.outputs
    for frame, got in zip(frames, out, strict=True):
        r5 = full_range(frame) - 60 > 0
        grown = r5.copy()
        grown[1:] |= r5[:-1]
        grown[:-1] |= r5[1:]
        grown[:, 1:] |= r5[:, :-1]
        grown[:, :-1] |= r5[:, 1:]
        np.testing.assert_array_equal(got[DIGITAL], grown)
    # the switch turns the dilation off
    out = run(frames, 2, threshold=60, dilate="off").session.outputs
    np.testing.assert_array_equal(out[0][DIGITAL], full_range(frames[0]) - 60 > 0)


def test_load_pattern_grid(frames):
    got = run(frames, 3).session.outputs[0][DIGITAL]
    rows, cols = np.indices((N, N))
    hardware_col = N - 1 - cols  # hardware column 0 is the east edge
    np.testing.assert_array_equal(got, (rows % 8 == 0) | (hardware_col % 8 == 0))


def test_event_readout(frames):
    result = run(frames, 4, threshold=62)
    first = [t for t in result.texts if t.startswith("event")]
    session = result.session
    per_frame = [[t for f, t in session.texts if f == k and t.startswith("event")] for k in (0, 1)]
    assert per_frame[0] and first[: len(per_frame[0])] == per_frame[0]
    for frame, texts in zip(frames, per_frame, strict=True):
        r, c = np.nonzero(full_range(frame) - 62 > 0)
        hw = N - 1 - c
        order = np.lexsort((r, hw))  # hardware columns first, rows within
        want = [f"event {hw[i]} {r[i]}" for i in order[:16]]
        assert texts == want


def test_global_sums_and_readouts(frames):
    result = run(frames, 5, threshold=0)
    sums = [t for t in result.texts if t.startswith("sums")]
    for frame, text in zip(frames, sums, strict=True):
        a = full_range(frame)
        c16, c64 = block_codes(a, 4), block_codes(a, 8)
        r5 = a > 0
        temp = np.where(r5, 127.0, -128.0)
        count = int(np.floor(4095 * block_codes(temp, 4).sum() / (255 * 16) + 0.5))
        px = codes(np.array(a[3, N - 1 - 5]))
        first = to_scamp_buffer(c16)[0]  # buffer order: column-major from the top right
        assert text == f"sums {c16.sum()} {c64.sum()} {count} {int(r5.any())} {px} {first}"


def test_control_flow_on_readouts(frames):
    result = run(frames, 6)
    got = [int(t.split()[1]) for t in result.texts if t.startswith("max")]
    want = []
    for frame in frames:
        a = full_range(frame)
        want.append(max(t for t in range(-128, 128) if (a > t).any()))
    assert got == want
    kernels = result.session.kernels
    # the loop body's kernel is recorded once and replayed on every step of the search
    assert max(k.runs for k in kernels.values()) >= 2 * 7


def test_bitstack_and_dreg_scan(frames):
    result = run(frames, 7)
    got = result.session.outputs[0][BITS]
    rows, cols = np.indices((N, N))
    value = (rows % 2 == 0) * 2 + ((N - 1 - cols) % 2 == 0)
    np.testing.assert_array_equal(got, np.floor(value * 85.0 + 0.5) - 128)
    assert "dreg 85 85" in result.texts  # bit k of byte j: hardware column 8j + k


def test_drawing_flood_and_box(frames):
    result = run(frames, 8)
    out = result.session.outputs[0]
    rows, cols = np.indices((N, N))
    hw = N - 1 - cols
    drawn = ((rows >= 2) & (rows <= 10) & (hw >= 3) & (hw <= 20)) | ((rows <= 5) & (rows == hw))
    np.testing.assert_array_equal(out[DIGITAL], drawn)
    # top-right then bottom-left corner, hardware columns: the east edge is column 0
    assert "box 0 0 10 20" in result.texts
    rect = (rows >= 30) & (rows <= 50) & (hw >= 30) & (hw <= 50)
    np.testing.assert_array_equal(out[BITS], rect)  # the flood stays in its island
    sim = Scamp5(N, N)
    sim.set_image(frames[0])
    with sim.kernel() as k:
        k.get_image(A)
    assert f"fast {sim.global_sum_fast(A)}" in result.texts


def test_several_destination_bus(frames):
    result = run(frames, 9)
    out = result.session.outputs[0]
    a = full_range(frames[0])
    np.testing.assert_array_equal(out[ANALOG], -a / 2)
    np.testing.assert_array_equal(out[BITS], -a)
    (kernel,) = [k for k in result.session.kernels.values() if k.calls[0].startswith("bus")]
    assert kernel.calls[0] == "bus({C, D}, {A})" and len(kernel.kernel) == 3


def test_raw_icw_word(frames):
    result = run(frames, 10)
    np.testing.assert_array_equal(result.session.outputs[0][ANALOG], -full_range(frames[0]))
    (kernel,) = [k for k in result.session.kernels.values() if "icw" in " ".join(k.calls)]
    assert kernel.calls[1] == "icw(0, {13, 21, 22})"


def test_dynamic_kernels_leave_the_icw_stack(frames):
    result = run(frames, 11)
    assert result.session.warnings == []
    sim = Scamp5(N, N)
    sim.set_image(frames[-1])
    with sim.kernel() as k:
        k.get_image(A)
        k.newsblur(C, A, 61)
    np.testing.assert_array_equal(result.session.outputs[-1][ANALOG], sim.read(C))
    overflow = run(frames, 12)
    assert overflow.session.warnings and "ICW stack" in overflow.session.warnings[0]


def test_outputs_folder(frames, tmp_path):
    out = tmp_path / "run"
    result = run_program(SOURCE, frames, settings={"mode": "1"}, out=out)
    names = sorted(p.name for p in out.iterdir())
    assert names == ["displays", "montage.png", "stdout.txt", "summary.json", "text.txt",
                     "timing.json"]  # fmt: skip
    assert sorted(p.name for p in (out / "displays" / "analog").iterdir()) == [
        "frame_0000.png",
        "frame_0001.png",
    ]
    timing = result.timing()
    assert len(timing["frames"]) == 2
    assert all(k["runs"] == 2 for k in timing["kernels"])
    frames_us = sum(f["modelled_us"] for f in timing["frames"])
    ending = result.session.sim.timing.call_us("vs_frame_loop_control")  # after the last
    assert frames_us + ending == pytest.approx(timing["total_us"])
    # the chip's part equals the same kernels run from Python; the loop adds the
    # loop control and the output of one 64 x 64 image per frame
    sim = Scamp5(N, N)
    chip = 0.0
    for frame in frames:
        sim.set_image(frame)
        t0 = sim.timing.now_us
        with sim.kernel() as k:
            k.get_image(A)
        with sim.kernel() as k:
            k.movx(C, A, east)
            k.sub(E, A, C)
            k.abs(D, E)
        chip += sim.timing.now_us - t0
    assert sum(f["chip_us"] for f in timing["frames"]) == pytest.approx(chip)
    assert timing["frames"][1]["loop_us"] > 0
