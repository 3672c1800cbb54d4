"""Bad input refused in one line before anything is written: each case here once printed
part of its output, a wrong cause or a traceback, and each test fails on the code before
its fix."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from PIL import Image

from ppaloc.cli import main
from ppaloc.errors import PpalocError


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


def test_the_out_probe_tries_the_folder_a_link_leads_to(tmp_path, capsys, monkeypatch):
    # the link's own folder was tried, so a target folder the run could not write (or one
    # missing) failed only when the result was written, after the work
    import tempfile

    from ppaloc.cli import outputs

    here, there = tmp_path / "here", tmp_path / "there"
    here.mkdir()
    there.mkdir()
    (here / "est.csv").symlink_to(there / "est.csv")
    real = tempfile.mkstemp

    def mkstemp(*args, dir=None, **kwargs):  # a folder root cannot be kept out of
        if Path(dir) == there:
            raise PermissionError(13, "Permission denied")
        return real(*args, dir=dir, **kwargs)

    monkeypatch.setattr(outputs.tempfile, "mkstemp", mkstemp)
    with pytest.raises(PpalocError, match=f"cannot write in {there} \\(Permission denied\\)"):
        outputs.check_output(here / "est.csv", folder=False)
    (here / "gone.csv").symlink_to(tmp_path / "missing" / "est.csv")
    with pytest.raises(PpalocError, match=r"whose folder .*missing is not a folder that exists"):
        outputs.check_output(here / "gone.csv", folder=False)


@pytest.mark.parametrize("command", ["sweep", "cpp run"])
def test_an_out_inside_a_dataset_folder_is_refused_as_evaluate_refuses_it(
    tmp_path, capsys, command
):
    # sweep and cpp run wrote their folder among the frames they read
    _images(tmp_path / "ref", 2)
    _images(tmp_path / "qry", 2)
    out = tmp_path / "qry" / "out"
    if command == "sweep":
        spec = f"folder:{tmp_path / 'ref'},{tmp_path / 'qry'}"
        args = ["sweep", "-m", "single-frame", "-d", spec, "-q", "--out", out]
    else:
        program = Path(__file__).parents[1] / "cpp" / "programs" / "means.cpp"
        spec = f"folder:{tmp_path / 'qry'}"
        args = ["cpp", "run", program, "--dataset", spec, "-q", "--out", out]
    code, _, err = run(capsys, *args)
    assert (code, err) == (
        1,
        f"ppaloc: error: --out {out} lies inside the dataset's input folder {tmp_path / 'qry'}, "
        "which would then hold it among its inputs; write it outside that folder\n",
    )
    assert not out.exists()


def test_sweep_out_is_probed_in_the_folder_it_writes_in(tmp_path, capsys, monkeypatch):
    # a sweep writes its cells, summary and report into its folder, not beside it: an
    # existing folder it can write, in a parent it cannot, was refused before the run
    import tempfile

    from ppaloc.cli import commands, outputs

    out = tmp_path / "sweep1"
    out.mkdir()
    real = tempfile.mkstemp

    def mkstemp(*args, dir=None, **kwargs):  # the parent, as a folder root cannot write in
        if Path(dir) == tmp_path:
            raise PermissionError(13, "Permission denied")
        return real(*args, dir=dir, **kwargs)

    ran = []
    monkeypatch.setattr(outputs.tempfile, "mkstemp", mkstemp)
    monkeypatch.setattr(commands, "run_sweep", lambda config, out, **kw: ran.append(out))
    args = ["sweep", "-m", "single-frame", "-d", "synthetic:?places=20", "-q", "--out", out]
    code, _, err = run(capsys, *args)
    assert code == 0, err
    assert ran == [out]
    # a folder still to be made is made in the parent, which must take it
    code, _, err = run(capsys, *args[:-1], tmp_path / "sweep2")
    assert code == 1
    assert f"cannot write in {tmp_path} (Permission denied)" in err
