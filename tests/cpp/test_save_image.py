"""vs_sim::save_image (programs/save_image.cpp, one case per ``mode``): a register as the
8-bit BMP a readout gives, under the run's saved/ folder, at no modelled time; paths that
would leave the run's folder, and a run without one, refused in one line."""

from __future__ import annotations

import numpy as np
import pytest
from PIL import Image

from ppaloc.cli import main
from ppaloc.cpp import compile_program, run_program
from ppaloc.errors import PpalocError

from .conftest import PROGRAMS

SOURCE = PROGRAMS / "save_image.cpp"
N = 16


@pytest.fixture(scope="module")
def frames(cxx) -> list[np.ndarray]:
    compile_program(SOURCE)  # once for the module
    rng = np.random.default_rng(7)
    return [rng.integers(0, 256, (N, N), dtype=np.uint8) for _ in range(2)]


def run(frames, mode: int, **kwargs):
    return run_program(SOURCE, frames, settings={"mode": str(mode)}, timeout=60, **kwargs)


def test_registers_are_saved_as_8_bit_bmps_in_the_runs_folder(frames, tmp_path):
    out = tmp_path / "run"
    result = run(frames, 0, out=out)
    saved = out / "saved"
    names = sorted(p.relative_to(saved).as_posix() for p in saved.rglob("*") if p.is_file())
    assert names == ["grey.bmp", "points/r5_1.bmp", "points/r5_2.bmp"]  # "\\" a separator
    with Image.open(saved / "grey.bmp") as grey:
        assert grey.format == "BMP" and grey.mode in ("L", "P")
        # A holds the frame as v - 128: its ADC codes are the frame's grey levels (the
        # last frame's: each save of a path replaces the one before)
        np.testing.assert_array_equal(np.asarray(grey.convert("L")), frames[-1])
    with Image.open(saved / "points" / "r5_1.bmp") as point:
        expected = np.zeros((N, N), np.uint8)
        expected[3, N - 1 - 4] = 255  # hardware column 4, counted from the east edge
        np.testing.assert_array_equal(np.asarray(point.convert("L")), expected)
    # a simulator-only call: the same modelled time as the program without the saves
    assert result.session.sim.timing.now_us == run(frames, 1).session.sim.timing.now_us
    run(frames, 0, out=out)  # an earlier run's folder, saved/ and all, is replaced


@pytest.mark.parametrize(
    ("mode", "message"),
    [
        (2, r"save_image.cpp:23: vs_sim::save_image\(A, '/tmp/grey.bmp'\): an absolute path"),
        (3, r"save_image.cpp:24: vs_sim::save_image\(A, '../grey.bmp'\): '..' would leave"),
        (4, r"save_image.cpp:25: .*: an absolute path: give one relative to the run's folder"),
        (5, r"save_image.cpp:28: .*'grey/a.bmp'\): 'grey' is a file this run saved, not a"),
    ],
)
def test_paths_outside_the_runs_folder_are_refused(frames, tmp_path, mode, message):
    with pytest.raises(PpalocError, match=message) as err:
        run(frames, mode, out=tmp_path / "run")
    assert "\n" not in str(err.value)
    assert not (tmp_path / "run").exists()


def test_a_run_without_an_output_folder_refuses_to_save(frames):
    with pytest.raises(PpalocError) as err:
        run(frames, 0)
    assert str(err.value) == (
        "save_image.cpp:18: vs_sim::save_image(A, 'grey.bmp'): this run has no output folder "
        "to save into: give one (ppaloc cpp run --out DIR, run_program(..., out=DIR))"
    )


@pytest.mark.parametrize(
    "mine",
    [
        ("saved/notes.txt", "saved/notes.txt"),
        ("saved/points/mine.bmp", "saved/points/mine.bmp"),
        ("saved/mine/a.bmp", "saved/mine"),  # the first entry the run did not write
    ],
)
def test_a_users_file_inside_saved_is_refused(frames, tmp_path, capsys, mine):
    mine, named = mine
    out = tmp_path / "run"
    args = ["cpp", "run", str(SOURCE), "--out", str(out), "-q", "--frames", "2"]
    assert main(args) == 0
    assert main(args) == 0  # an earlier run's saved/: every file in it the run's own
    (out / mine).parent.mkdir(parents=True, exist_ok=True)
    (out / mine).write_text("keep me")
    assert main(args) == 1
    err = capsys.readouterr().err
    assert f"holds {named!r}, which ppaloc cpp run did not write" in err
    assert len(err.splitlines()) == 1 and (out / mine).read_text() == "keep me"
