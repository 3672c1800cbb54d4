"""Bad input refused in one line before anything is written: each case here once printed
part of its output, a wrong cause or a traceback, and each test fails on the code before
its fix."""

from __future__ import annotations

from pathlib import Path

import numpy as np
from PIL import Image

from ppaloc.cli import main


def run(capsys, *args: object) -> tuple[int, str, str]:
    code = main([str(a) for a in args])
    out, err = capsys.readouterr()
    return code, out, err


def _images(folder: Path, n: int) -> Path:
    folder.mkdir(parents=True, exist_ok=True)
    rng = np.random.default_rng(n)
    for i in range(n):
        Image.fromarray(rng.integers(0, 256, (16, 24), np.uint8)).save(folder / f"q{i}.png")
    return folder


def test_localise_refuses_oracle_moves_short_of_the_frames_before_any_line(
    tiny_spec, tmp_path, capsys
):
    # a CSV header and a row were printed before the oracle ran out of moves
    m = tmp_path / "m.npz"
    code, _, err = run(capsys, "map", tiny_spec, "-m", "weighted-node-lbp", "--out", m, "-q")
    assert code == 0, err
    frames = _images(tmp_path / "q", 3)
    code, out, err = run(
        capsys, "localise", m, frames, "--param", "motion=oracle", "--param", "oracle_moves=[true]"
    )
    assert (code, out) == (1, "")
    assert err == (
        "ppaloc: error: method 'weighted-node-lbp': oracle_moves holds 1 moves for the 3 "
        "frames given; give one a query frame, or another --param motion\n"
    )
    csv = tmp_path / "est.csv"
    args = ("--param", "motion=oracle", "--param", "oracle_moves=[true, false, true]")
    code, _, err = run(capsys, "localise", m, frames, *args, "--out", csv)
    assert code == 0, err
    assert len(csv.read_text().splitlines()) == 4
