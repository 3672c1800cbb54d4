"""The command never surprises: each case here once did (a wrong hint, a silent choice, a
block, a leak), and each test fails on the code before its fix."""

from __future__ import annotations

import io
import json
import os
import sys
import threading
import warnings
from pathlib import Path

import numpy as np
import pytest
from PIL import Image

from ppaloc.cli import main


def run(capsys, *args: object) -> tuple[int, str, str]:
    code = main([str(a) for a in args])
    out, err = capsys.readouterr()
    return code, out, err


def _images(folder: Path, names: list[str]) -> list[Path]:
    folder.mkdir(parents=True, exist_ok=True)
    rng = np.random.default_rng(len(names))
    paths = []
    for name in names:
        Image.fromarray(rng.integers(0, 256, (16, 24), np.uint8)).save(folder / name)
        paths.append(folder / name)
    return paths


def _video(path: Path, n: int) -> Path:
    av = pytest.importorskip("av")
    rng = np.random.default_rng(n)
    with av.open(str(path), "w") as container:
        stream = container.add_stream("mpeg4", rate=5)
        stream.width, stream.height, stream.pix_fmt = 32, 32, "yuv420p"
        for _ in range(n):
            rgb = rng.integers(0, 256, (32, 32, 3), np.uint8)
            for packet in stream.encode(av.VideoFrame.from_ndarray(rgb, format="rgb24")):
                container.mux(packet)
        for packet in stream.encode():
            container.mux(packet)
    return path


@pytest.fixture
def folder_map(tmp_path, capsys, mean_match) -> Path:
    """A map of the stand-in method over five reference images, built from the folder
    alone (``folder:REF``: no query folder needed)."""
    _images(tmp_path / "ref", [f"r{i}.png" for i in range(5)])
    out = tmp_path / "m.npz"
    code, _, err = run(capsys, "map", f"folder:{tmp_path / 'ref'}", "-m", mean_match, "--out", out)
    assert code == 0, err
    return out


# -- localise: videos, names, order, advice --------------------------------------------------


def test_localise_takes_a_video_and_names_the_reference_frames(tmp_path, capsys, mean_match):
    ref = _video(tmp_path / "ref.mp4", 4)
    m = tmp_path / "m.npz"
    code, _, err = run(capsys, "map", f"video:{ref}", "-m", mean_match, "--out", m, "-q")
    assert code == 0, err
    code, out, err = run(capsys, "localise", m, ref)
    assert code == 0, err
    lines = out.splitlines()
    assert lines[0] == "frame,path,node,reference_frame,score,moved,latency_ms,reference_name"
    rows = [line.split(",") for line in lines[1:]]
    assert [r[1] for r in rows] == [f"{ref}#{i}" for i in range(4)]
    assert [r[-1] for r in rows] == [f"ref.mp4#{r[3]}" for r in rows]


def test_a_file_that_is_no_image_nor_video_gets_the_right_advice(tmp_path, capsys, folder_map):
    notes = tmp_path / "notes.mp4"
    notes.write_text("not a video")
    bad = tmp_path / "frame.png"
    bad.write_bytes(b"\x89PNG\r\n\x1a\n cut short")
    code, _, err = run(capsys, "localise", folder_map, notes)
    assert code == 1 and "remove it from the folder" not in err
    assert err.startswith(f"ppaloc: error: cannot read video {notes}: ")
    code, _, err = run(capsys, "localise", folder_map, bad)
    assert code == 1 and err.count("\n") == 1
    assert "remove it from the folder" not in err
    assert err.rstrip().endswith(
        "give image files, videos or folders of images (leave this file out)"
    )


def test_files_of_one_folder_out_of_natural_order_are_refused(tmp_path, capsys, folder_map):
    frames = _images(tmp_path / "q", ["frame1.png", "frame2.png", "frame10.png"])
    shell_order = sorted(frames, key=str)  # what `q/*.png` expands to: frame1, frame10, frame2
    code, _, err = run(capsys, "localise", folder_map, *shell_order)
    assert code == 1
    assert err == (
        f"ppaloc: error: frames are localised in the order given, and {frames[2]} comes before "
        f"{frames[1]}, which natural order of file names puts first (a shell sorts frame10 "
        "before frame2); give the folder (its images are taken in natural order), the files in "
        "natural order (ls -v), or --keep-order to localise them as given\n"
    )
    code, out, err = run(capsys, "localise", folder_map, tmp_path / "q")  # the folder: natural
    assert code == 0, err
    assert [line.split(",")[1] for line in out.splitlines()[1:]] == [str(p) for p in frames]
    code, out, err = run(capsys, "localise", folder_map, *shell_order, "--keep-order")
    assert code == 0, err
    assert [line.split(",")[1] for line in out.splitlines()[1:]] == [str(p) for p in shell_order]


# -- map: the reference alone, never into its own dataset folder ---------------------------------


def test_map_takes_the_reference_folder_alone(tmp_path, capsys, folder_map):
    from ppaloc.topomap import load_map

    topomap = load_map(folder_map)
    assert len(topomap) == 5
    assert topomap.provenance["reference_names"] == [f"r{i}.png" for i in range(5)]


@pytest.mark.parametrize("spec", ["folder:{a},{a}", "folder:{a}"])
def test_map_never_writes_into_its_own_dataset_folder(tmp_path, capsys, mean_match, spec):
    a = tmp_path / "a"
    _images(a, ["f0.png", "f1.png"])
    out = a / "x.png"
    code, _, err = run(capsys, "map", spec.format(a=a), "-m", mean_match, "--out", out)
    assert code == 1
    assert err == (
        f"ppaloc: error: --out {out} lies inside the dataset's input folder {a}, which would "
        "then hold it among its inputs; write it outside that folder\n"
    )
    assert sorted(p.name for p in a.iterdir()) == ["f0.png", "f1.png"]


# -- evaluate: matrix folders, tolerance --------------------------------------------------------


def test_matrix_folders_of_long_specs_differ_beyond_their_number():
    from ppaloc.cli.commands import matrix_folder

    a = "synthetic:?places=300&query=winter&seed=1&speed_var=0.65&stops=2&start=10&stop=300"
    b = a.replace("stop=300", "stop=400")
    name_a, name_b = matrix_folder(0, a), matrix_folder(0, b)
    assert name_a != name_b  # both cut to the same 64 characters, told apart by the hash
    assert name_a[:-8] == name_b[:-8]
    assert matrix_folder(0, a) == name_a  # the same spec, the same name, every run


@pytest.mark.parametrize(("flag", "ok"), [("2", True), ("3", False)])
def test_tolerance_beside_a_specs_own_is_refused_unless_equal(
    tmp_path, capsys, mean_match, flag, ok
):
    spec = "synthetic:?places=6&size=32&sync=1&tolerance=2"
    out = tmp_path / "r"
    code, _, err = run(
        capsys, "evaluate", "-d", spec, "-m", mean_match, "--tolerance", flag, "--out", out, "-q"
    )
    if ok:
        assert code == 0, err
        assert json.loads((out / "results.json").read_text())["tolerance"] == 2
    else:
        assert code == 1 and not out.exists()
        assert err == (
            "ppaloc: error: tolerance 3 (--tolerance, or tolerance = in a configuration file) "
            f"contradicts tolerance=2 in the dataset spec '{spec}': give the tolerance in one "
            "place only\n"
        )


def test_a_sweep_refuses_a_tolerance_axis_beside_a_specs_own(tmp_path, capsys):
    toml = tmp_path / "s.toml"
    toml.write_text(
        '[sweep]\nmethods = ["single-frame"]\ndatasets = ["synthetic:?places=6&tolerance=1"]\n'
        "tolerance = [1, 2]\n"
    )
    code, _, err = run(capsys, "sweep", "--config", toml, "--out", tmp_path / "sw")
    assert code == 1 and "contradicts tolerance=1 in the dataset spec" in err
    assert not (tmp_path / "sw").exists()


# -- messages: long values cut, warnings as one line ----------------------------------------------


def test_a_huge_value_is_cut_in_a_usage_error(capsys):
    spec = "synthetic:?places=" + "1" * 40_000
    code, _, err = run(capsys, "evaluate", spec)  # forgot -d: an extra argument
    assert code == 1 and err.count("\n") == 1
    assert len(err) < 500 and "... (40020 characters)" in err


def test_pillows_decompression_bomb_warning_does_not_leak(
    tmp_path, capsys, folder_map, monkeypatch
):
    from PIL import Image as PILImage

    monkeypatch.setattr(PILImage, "MAX_IMAGE_PIXELS", 200)  # warns above 200, errors above 400
    frame = _images(tmp_path / "q", ["big.png"])[0]  # 16 x 24 = 384 pixels
    code, out, err = run(capsys, "localise", folder_map, frame)
    assert code == 0 and err == "", err  # ppaloc's own limit decides; Pillow's warning is not shown
    assert len(out.splitlines()) == 2


def test_planes_holding_nan_are_one_line_not_a_cast_warning(tmp_path, capsys):
    planes = tmp_path / "planes.npz"
    np.savez(planes, A=np.array([[np.nan, 1.0], [np.inf, 0.0]]))
    code, _, err = run(capsys, "show", planes)
    assert code == 1
    assert err == (
        f"ppaloc: error: {planes}: array 'A' holds 2 NaN or infinite values, which no register "
        "holds; replace them (e.g. np.nan_to_num) before drawing\n"
    )


def test_planes_of_two_shapes_are_named_with_the_file(tmp_path, capsys):
    # the montage's own message: 'render_montage: planes differ in shape [(4, 4), (5, 5)]'
    planes = tmp_path / "planes.npz"
    np.savez(planes, A=np.zeros((4, 4)), B=np.ones((5, 5)))
    code, _, err = run(capsys, "show", planes)
    assert code == 1 and not planes.with_suffix(".png").exists()
    assert err == (
        f"ppaloc: error: {planes}: arrays 'A' (4 x 4) and 'B' (5 x 5) differ in shape; "
        "register planes are drawn side by side at one size: save the planes of each size in "
        "a file of their own\n"
    )


def test_planes_of_more_cells_than_show_draws_are_refused(tmp_path, capsys):
    # a few kB compressed: a 40,000 x 40,000 plane of the same kind took 15 GB and a minute
    planes = tmp_path / "planes.npz"
    np.savez_compressed(planes, A=np.zeros((8000, 8000), bool))
    code, _, err = run(capsys, "show", planes)
    assert code == 1 and not planes.with_suffix(".png").exists()
    assert err == (
        f"ppaloc: error: {planes}: its 2-D arrays hold 64000000 cells, more than the 50000000 "
        "ppaloc show draws (a sensor's plane is 256 x 256); save fewer or smaller planes\n"
    )


def test_an_empty_plane_is_refused_not_drawn_as_nothing(tmp_path, capsys):
    # a (0, 5) array was "drawn": a PNG of its label alone, "1 planes -> ..."
    planes = tmp_path / "planes.npz"
    np.savez(planes, A=np.zeros((0, 5)), B=np.ones((4, 4)))
    code, _, err = run(capsys, "show", planes)
    assert code == 1 and not planes.with_suffix(".png").exists()
    assert err == (
        f"ppaloc: error: {planes}: array 'A' has shape (0, 5), no cells to draw; give planes "
        "of at least one row and one column\n"
    )
    # alone, it was drawn (a PNG of its label) and reported as one plane, exit 0
    np.savez(planes, A=np.zeros((5, 0), bool))
    code, out, err = run(capsys, "show", planes)
    assert code == 1 and out == "" and not planes.with_suffix(".png").exists()
    assert "array 'A' has shape (5, 0), no cells to draw" in err


def test_a_warning_that_reaches_the_user_is_one_line(tmp_path, capsys, monkeypatch):
    import ppaloc.cli.commands as commands
    from ppaloc.errors import PpalocError

    def warn_then_fail(*args, **kwargs):
        warnings.warn("something odd\nover two lines", UserWarning, stacklevel=1)
        raise PpalocError("the real problem")

    monkeypatch.setattr(commands, "run_show", warn_then_fail)
    with warnings.catch_warnings():
        warnings.simplefilter("default")
        code, _, err = run(capsys, "show", tmp_path)
    assert code == 1
    assert err == (
        "ppaloc: warning: UserWarning: something odd over two lines\n"
        "ppaloc: error: the real problem\n"
    )


# -- --config: only a regular file is opened -----------------------------------------------


def test_config_given_a_fifo_is_refused_without_blocking(tmp_path, capsys):
    fifo = tmp_path / "run.toml"
    os.mkfifo(fifo)
    result: dict[str, int] = {}
    worker = threading.Thread(
        target=lambda: result.setdefault("code", main(["evaluate", "--config", str(fifo)]))
    )
    worker.start()
    worker.join(timeout=20)
    if worker.is_alive():  # blocked in open(): release it, then fail
        with open(fifo, "w"):
            pass
        worker.join()
        pytest.fail("--config blocked on a FIFO")
    assert result["code"] == 1
    assert capsys.readouterr().err == (
        f"ppaloc: error: config file {fifo} is not a regular file (a pipe, device or socket); "
        "give a TOML file\n"
    )


# -- show: a localise CSV -------------------------------------------------------------------


def test_show_draws_a_localise_csv(tmp_path, capsys, folder_map):
    frames = _images(tmp_path / "q", [f"q{i}.png" for i in range(20)])
    est = tmp_path / "est.csv"
    assert run(capsys, "localise", folder_map, tmp_path / "q", "--out", est)[0] == 0
    code, out, err = run(capsys, "show", est)
    assert code == 0, err
    assert out.splitlines()[-1] == f"{est}: 20 predictions -> {est.with_suffix('.png')}"
    assert "q0.png" in out and "q19.png" in out and "..." in out  # first and last rows
    with Image.open(est.with_suffix(".png")) as im:
        assert im.size[0] > 500
    assert len(frames) == 20
    code, _, err = run(capsys, "show", est, "--out", est)
    assert code == 1 and "would overwrite the input" in err


@pytest.mark.parametrize(
    "scores",
    [
        # their span is inf, which the colour bar could not draw (an internal error, "Axis
        # limits cannot be NaN or Inf")
        ("-1e308", "1e308", "0"),
        # equal and near a float64's limit: the colour bar's ticks overflowed (an internal
        # error, "arange: cannot compute length")
        ("1e308", "1e308", "1e308"),
        ("-1.7e308", "-1.7e308", "-1.7e308"),
    ],
)
def test_show_draws_scores_whose_span_overflows(tmp_path, capsys, scores):
    # finite scores that score accepts
    est = tmp_path / "est.csv"
    rows = "".join(f"{i},{i + 1},{v}\n" for i, v in enumerate(scores))
    est.write_text("query,reference,score\n" + rows)
    code, _, err = run(capsys, "show", est, "-q")
    assert code == 0, err
    with Image.open(est.with_suffix(".png")) as im:
        assert im.size[0] > 500


def test_an_out_that_is_a_link_writes_the_file_it_names(tmp_path, capsys, folder_map):
    # the link was replaced by a file and the file it named kept its old rows
    q = _images(tmp_path / "q", ["a.png"])[0]
    (tmp_path / "runs").mkdir()
    (tmp_path / "runs" / "est.csv").write_text("old\n")
    link = tmp_path / "est.csv"
    link.symlink_to("runs/est.csv")
    code, _, err = run(capsys, "localise", folder_map, q, "--out", link)
    assert code == 0, err
    assert link.is_symlink()
    assert (tmp_path / "runs" / "est.csv").read_text().startswith("frame,path,node,")


def test_localise_writes_a_file_name_that_is_not_utf8_to_its_csv(tmp_path, capsys, folder_map):
    q = tmp_path / "q"
    (raw,) = _images(q, ["e.png"])
    os.rename(raw, os.path.join(os.fsencode(q), b"e\xff.png"))  # a name of Latin-1 bytes
    est = tmp_path / "est.csv"
    code, _, err = run(capsys, "localise", folder_map, q, "--out", est)
    assert code == 0, err
    row = est.read_bytes().splitlines()[1]
    assert row.split(b",")[:2] == [b"0", os.fsencode(q) + b"/e\xff.png"]  # its own bytes


def test_localise_does_not_create_the_folder_of_its_csv(tmp_path, capsys, folder_map):
    _images(tmp_path / "q", ["q0.png"])
    out = tmp_path / "missing" / "dir" / "est.csv"
    code, _, err = run(capsys, "localise", folder_map, tmp_path / "q", "--out", out)
    assert code == 1
    assert err == (
        f"ppaloc: error: cannot write the CSV to {out}: folder {out.parent} does not exist; "
        "create it first\n"
    )
    assert not (tmp_path / "missing").exists()
    code, _, err = run(capsys, "map", "synthetic:?places=4&size=32", "--out", out.parent / "m.npz")
    assert code == 1 and "does not exist; create it first" in err  # as map says


def test_localise_says_an_unknown_method_name_came_from_the_map(tmp_path, capsys, folder_map):
    from ppaloc.topomap import load_map

    topomap = load_map(folder_map)
    topomap.provenance["method"] = "netvlad-of-mine"
    topomap.save(folder_map)
    code, _, err = run(capsys, "localise", folder_map, tmp_path / "ref")
    assert code == 1 and err.count("\n") == 1
    assert err.startswith(
        f"ppaloc: error: map {folder_map} names method 'netvlad-of-mine' (its "
        "provenance.method), which is unknown here; give --method, one of: "
    )


def test_show_out_is_a_png_and_not_for_a_results_folder(tmp_path, capsys, folder_map):
    for name in ("m.pdf", "m.svg", "m"):
        code, _, err = run(capsys, "show", folder_map, "--out", tmp_path / name)
        assert code == 1 and err == (
            f"ppaloc: error: --out {tmp_path / name}: show draws PNG images; give a file name "
            "ending in .png\n"
        )
        assert not (tmp_path / name).exists()
    assert run(capsys, "show", folder_map, "--out", tmp_path / "m.PNG", "-q")[0] == 0
    results = tmp_path / "run"
    spec = "synthetic:?places=6&size=32&sync=1"
    evaluate = ["evaluate", "-d", spec, "-m", "single-frame", "--no-report", "-q"]
    code, _, err = run(capsys, *evaluate, "--out", results)
    assert code == 0, err
    code, _, err = run(capsys, "show", results, "--out", tmp_path / "r.png")
    assert code == 1 and err.count("\n") == 1
    assert "a results folder's report is rebuilt inside it" in err and "leave it out" in err
    assert not (tmp_path / "r.png").exists() and not (results / "report.html").exists()


def test_show_of_a_folder_that_is_no_results_folder_names_the_folder_not_out(tmp_path, capsys):
    # --out was blamed ("a results folder's report is rebuilt inside it (frames/report.html)")
    # for a folder of images, which show does not draw with or without it
    frames = tmp_path / "frames"
    _images(frames, ["f0.png"])
    code, _, err = run(capsys, "show", frames, "--out", tmp_path / "f.png")
    assert code == 1
    assert err == (
        f"ppaloc: error: {frames} holds no results.json; give a folder written by "
        "`ppaloc evaluate --out`\n"
    )
    assert not (tmp_path / "f.png").exists()


def test_show_of_a_cpp_runs_folder_names_its_summary_not_out(tmp_path, capsys):
    # --out was blamed for a folder whose summary.json is a cpp run's, not a sweep's: only
    # without --out was the summary named as the cause
    run_folder = tmp_path / "run"
    run_folder.mkdir()
    (run_folder / "summary.json").write_text('{"program": "p.cpp", "frames": 0}\n')
    for extra in ([], ["--out", tmp_path / "f.png"]):
        code, _, err = run(capsys, "show", run_folder, *extra)
        assert code == 1
        assert (
            err == f"ppaloc: error: {run_folder / 'summary.json'} is not a ppaloc sweep summary\n"
        )
    assert not (tmp_path / "f.png").exists()


def test_map_refuses_a_missing_folder_before_it_reads_the_dataset(tmp_path, capsys):
    out = tmp_path / "missing" / "m.npz"
    missing = tmp_path / "no-such-route"  # the folder is refused first: nothing is read
    code, _, err = run(capsys, "map", f"folder:{missing}", "--out", out)
    assert code == 1
    assert err == (
        f"ppaloc: error: cannot write the map to {out}: folder {out.parent} does not exist; "
        "create it first\n"
    )


# -- a full disk ------------------------------------------------------------------------------


def test_a_full_disk_is_one_line_naming_the_file(tmp_path, capsys, monkeypatch):
    # it was an internal error (exit 3, "this is a bug"): the system's error named no file
    from ppaloc import fileio

    def disk_full(*_args):
        raise OSError(28, "No space left on device")

    monkeypatch.setattr(fileio.os, "fsync", disk_full)
    out = tmp_path / "m.npz"
    code, _, err = run(capsys, "map", "synthetic:?places=4&size=32", "--out", out, "-q")
    assert (code, err) == (
        1,
        f"ppaloc: error: No space left on device: '{out}'; free some space there or give "
        "another location\n",
    )
    assert os.listdir(tmp_path) == []
    ev = tmp_path / "ev"
    code, _, err = run(capsys, "evaluate", "-d", "synthetic:?places=4&size=32", "-m",
                       "single-frame", "--no-report", "-q", "--out", ev)  # fmt: skip
    assert code == 1 and err.startswith(f"ppaloc: error: No space left on device: '{ev}/")
    assert os.listdir(tmp_path) == []  # no staging folder left either


class _FullStdout(io.StringIO):
    """Standard output on a full disk: the system's error names no file."""

    def __init__(self, fail_on: str) -> None:
        super().__init__()
        self.fail_on = fail_on

    def write(self, text: str) -> int:
        if self.fail_on == "write":
            raise OSError(28, "No space left on device")
        return super().write(text)

    def flush(self) -> None:
        if self.fail_on == "flush":
            raise OSError(28, "No space left on device")


@pytest.mark.parametrize("fail_on", ["write", "flush"])
def test_a_full_disk_under_standard_output_is_one_line(
    fail_on, folder_map, tmp_path, capsys, monkeypatch
):
    # `ppaloc localise MAP FRAMES > est.csv` on a full disk, or `ppaloc --help > file`, was
    # an internal error (exit 3, "this is a bug"): the error of a write to stdout names no
    # file
    frames = _images(tmp_path / "q", ["q0.png", "q1.png"])[0].parent
    expected = (
        "ppaloc: error: No space left on device: 'standard output'; free some space there or "
        "give another location\n"
    )
    for args in (["localise", folder_map, frames], ["--help"], ["map", "--help"]):
        monkeypatch.setattr(sys, "stdout", _FullStdout(fail_on))
        code, _, err = run(capsys, *args)
        assert (code, err) == (1, expected), args


class _FullBytes(io.BytesIO):
    """A full disk under a binary stream: the system's error names no file."""

    def write(self, data: bytes) -> int:
        raise OSError(28, "No space left on device")


class _AsciiStdout(io.StringIO):
    """Standard output whose encoding cannot hold every character (PYTHONIOENCODING=ascii):
    click writes to its binary buffer instead."""

    encoding = "ascii"

    def __init__(self) -> None:
        super().__init__()
        self.buffer = _FullBytes()


def test_a_full_disk_under_standard_outputs_buffer_is_one_line(capsys, monkeypatch):
    # click writes to sys.stdout.buffer where the text stream's encoding is ascii: that
    # stream's error was unnamed (exit 3, "this is a bug")
    monkeypatch.setattr(sys, "stdout", _AsciiStdout())
    code, _, err = run(capsys, "--help")
    assert code == 1
    assert err == (
        "ppaloc: error: No space left on device: 'standard output'; free some space there or "
        "give another location\n"
    )


def test_oracle_moves_short_of_the_query_are_refused_before_the_run(tmp_path, capsys):
    # refused at the first frame beyond them, after the map was built and the frames run
    spec = "synthetic:?places=12&size=32&sync=1&seed=2"
    code, _, err = run(
        capsys, "evaluate", "-d", spec, "-m", "weighted-node-lbp", "--no-report", "-q",
        "--param", "weighted-node-lbp.motion=oracle",
        "--param", "weighted-node-lbp.oracle_moves=[true, false]",
        "--out", tmp_path / "r",
    )  # fmt: skip
    assert code == 1 and not (tmp_path / "r").exists()
    assert err.startswith(
        "ppaloc: error: method 'weighted-node-lbp': oracle_moves holds 2 moves for the "
    ) and err.endswith(
        f"query frames of '{spec}'; give one a query frame, or leave "
        "oracle_moves out to read the dataset's true motion\n"
    )


@pytest.mark.parametrize(
    ("name", "value", "says"),
    [
        ("PPALOC_ENGINE", "xx", "PPALOC_ENGINE='xx' is not an engine"),
        ("PPALOC_THREADS", "abc", "PPALOC_THREADS='abc' is invalid"),
        ("PPALOC_FUSE_AFTER", "soon", "PPALOC_FUSE_AFTER='soon' is invalid"),
    ],
)
def test_a_bad_engine_setting_is_refused_before_any_method_runs(
    tmp_path, capsys, monkeypatch, name, value, says
):
    # refused when the simulator started, after the host methods listed before it had run
    pytest.importorskip("numba")
    import ppaloc.evaluate.run as evaluate_run

    ran: list[str] = []
    real = evaluate_run.run_method
    monkeypatch.setattr(
        evaluate_run, "run_method", lambda name, *a, **k: ran.append(name) or real(name, *a, **k)
    )
    # PPALOC_THREADS and PPALOC_FUSE_AFTER are the compiled engine's settings, checked when
    # it is the default engine (another engine never reads them): so the default is named
    # here, whatever engine the suite runs with (--engine)
    monkeypatch.setenv("PPALOC_ENGINE", "compiled")
    monkeypatch.setenv(name, value)
    spec = "synthetic:?places=12&size=32&sync=1&seed=2"
    code, _, err = run(
        capsys, "evaluate", "-d", spec, "-m", "weighted-node-lbp", "-m", "onsensor-lbp",
        "--no-report", "-q", "--out", tmp_path / "r",
    )  # fmt: skip
    assert code == 1 and not (tmp_path / "r").exists() and ran == []
    assert says in err and err.count("\n") == 1


def test_a_bad_thread_count_is_refused_on_a_small_array_too(monkeypatch):
    # read only for arrays of SPLIT_MIN elements or more, so a small one took any value
    pytest.importorskip("numba")
    from ppaloc.errors import SimulatorError
    from ppaloc.sim import Scamp5

    monkeypatch.setenv("PPALOC_THREADS", "many")
    with pytest.raises(SimulatorError, match="PPALOC_THREADS='many' is invalid"):
        Scamp5(8, 8, engine="compiled")


@pytest.mark.parametrize("command", ["evaluate", "bench"])
def test_a_param_flag_for_a_method_left_out_of_the_run_is_refused(
    tmp_path, capsys, mean_match, tiny_spec, command
):
    # it changed nothing and said nothing: a typo of the method's name went unseen
    where = ["-d", tiny_spec] if command == "evaluate" else ["--sizes", "8"]
    code, _, err = run(
        capsys, command, *where, "-m", mean_match, "--param", "seqslam.ds=10",
        "--out", tmp_path / "r",
    )  # fmt: skip
    assert code == 1 and not (tmp_path / "r").exists()
    assert err == (
        f"ppaloc: error: --param seqslam.ds is for a method this run leaves out (methods: "
        f"{mean_match}); add --method seqslam or correct the method's name\n"
    )


def test_a_config_files_params_for_a_method_left_out_still_run(
    tmp_path, capsys, mean_match, tiny_spec
):
    # a shared file's tables for other methods are not the flag's mistake
    config = tmp_path / "run.toml"
    config.write_text(f'methods = ["{mean_match}"]\n[params.seqslam]\nds = 10\n')
    code, _, err = run(
        capsys, "evaluate", "-d", tiny_spec, "--config", config, "--no-report", "-q",
        "--out", tmp_path / "r",
    )  # fmt: skip
    assert code == 0, err
    assert (tmp_path / "r" / "results.json").exists()


@pytest.mark.parametrize("command", ["evaluate", "bench"])
def test_a_param_flag_for_a_method_the_files_list_leaves_out_names_the_file(
    tmp_path, capsys, mean_match, tiny_spec, command
):
    # "add --method seqslam" would replace the file's methods with seqslam alone
    config = tmp_path / "run.toml"
    config.write_text(f'[{command}]\nmethods = ["{mean_match}"]\n')
    where = ["-d", tiny_spec] if command == "evaluate" else ["--sizes", "8"]
    code, _, err = run(
        capsys, command, *where, "--config", config, "--param", "seqslam.ds=10",
        "--out", tmp_path / "r",
    )  # fmt: skip
    assert code == 1 and not (tmp_path / "r").exists()
    assert err == (
        f"ppaloc: error: --param seqslam.ds is for a method this run leaves out (methods: "
        f"{mean_match}); add 'seqslam' to methods in {config} (a --method flag would "
        "replace that list) or correct the method's name\n"
    )


@pytest.mark.parametrize("command", ["show", "score"])
def test_a_table_of_results_given_as_predictions_names_its_folder(
    tmp_path, capsys, tiny_spec, command
):
    # it was "unknown column 'f1_max'; the columns are query, ...": true, but no help
    table = tmp_path / "run" / "results.csv"
    table.parent.mkdir()
    table.write_text("method,f1_max,auc\nweighted-node-lbp,0.9,0.8\n")
    extra = ["-d", tiny_spec, "--out", tmp_path / "scored"] if command == "score" else []
    code, _, err = run(capsys, command, table, *extra)
    assert code == 1
    assert err == (
        f"ppaloc: error: {table} is a table of results (f1_max per method: results.csv or "
        "matrix.csv of ppaloc evaluate, summary.csv of ppaloc sweep), not predictions (one "
        "row per query: query, reference, score); ppaloc show shows the folder the run "
        "wrote it in\n"
    )  # a copy: its folder holds no results.json, ppaloc show would refuse it
    if command == "score":  # in the run's folder, which ppaloc show reads, it is named
        (table.parent / "results.json").write_text("{}")
        code, _, err = run(capsys, command, table, *extra)
        assert code == 1 and err.endswith(f"; ppaloc show {table.parent} shows its folder\n")


def test_predictions_with_an_extra_f1_max_column_are_not_called_a_table_of_results(
    tmp_path, capsys, tiny_spec
):
    # query, reference and score are predictions: the unknown column is the one to name
    path = tmp_path / "pred.csv"
    path.write_text("query,reference,score,f1_max\n0,0,0.5,1\n")
    code, _, err = run(capsys, "score", path, "-d", tiny_spec, "--out", tmp_path / "s")
    assert code == 1 and err.count("\n") == 1
    assert err.startswith(f"ppaloc: error: {path} line 1: unknown column 'f1_max'; ")


@pytest.mark.parametrize("command", ["evaluate", "bench"])
def test_methods_joined_by_a_comma_are_named_as_several(
    tmp_path, capsys, mean_match, tiny_spec, command
):
    # "-m a,b" was "method 'a,b' is unknown; choose from: ..." with both names in the list
    where = ["-d", tiny_spec] if command == "evaluate" else ["--sizes", "8"]
    code, _, err = run(
        capsys, command, *where, "-m", f"{mean_match},seqslam", "--out", tmp_path / "r"
    )
    assert code == 1 and not (tmp_path / "r").exists()
    assert err == (
        f"ppaloc: error: method '{mean_match},seqslam' names 2 methods in one: give each its "
        f"own --method (-m {mean_match} -m seqslam), or list them in a configuration file "
        "(methods = [...])\n"
    )


def test_a_value_the_filter_refuses_names_the_method(tmp_path, capsys, tiny_spec):
    # of two methods run, the message said neither: "motion='forwards' is not one of ..."
    code, _, err = run(
        capsys, "evaluate", "-d", tiny_spec, "-m", "weighted-node-lbp", "-m", "onsensor-lbp",
        "--param", "onsensor-lbp.alpha=3", "--out", tmp_path / "r",
    )  # fmt: skip
    assert code == 1 and err == (
        "ppaloc: error: method 'onsensor-lbp': alpha=3 is a parameter of preset 'paper', not "
        "of preset 'robust'; pass preset='paper' (the methods weighted-node-paper-*, "
        "onsensor-paper-*) to use it\n"
    )
    code, _, err = run(
        capsys, "evaluate", "-d", tiny_spec, "-m", "weighted-node-lbp",
        "--param", "weighted-node-lbp.motion=forwards", "--out", tmp_path / "r",
    )  # fmt: skip
    assert code == 1 and err == (
        "ppaloc: error: method 'weighted-node-lbp': motion='forwards' must be one of 'image', "
        "'always_forward', 'oracle'\n"
    )


def test_show_of_a_file_of_a_results_folder_names_the_folder(
    tmp_path, capsys, mean_match, tiny_spec
):
    # results.json was "not a readable .npz archive", a method's arrays "differ in shape"
    folder = tmp_path / "run"
    code, _, err = run(capsys, "evaluate", "-d", tiny_spec, "-m", mean_match, "-q", "--out", folder)
    assert code == 0, err
    for name in ("results.json", "results.csv", "report.html", f"arrays/{mean_match}.npz"):
        code, out, err = run(capsys, "show", folder / name)
        assert code == 1 and not out, name
        assert err == (
            f"ppaloc: error: {folder / name} is a file of the results folder {folder}: "
            f"ppaloc show {folder} shows it (the table, and the report rebuilt from its files)\n"
        )
    code, _, err = run(capsys, "show", folder)
    assert code == 0, err
    # the difference matrix, one 2-D array, is drawn as it was, not refused with the rest
    difference = folder / "arrays" / "_difference.npz"
    assert difference.is_file()
    code, out, err = run(capsys, "show", difference, "--out", tmp_path / "d.png")
    assert code == 0, err
    assert out.startswith(f"{difference}: 1 planes -> ") and (tmp_path / "d.png").is_file()


def test_show_titles_the_table_as_the_run_did(tmp_path, capsys, mean_match, tiny_spec):
    # the run printed "NAME (SPEC)", show the spec alone
    folder = tmp_path / "run"
    code, out, err = run(capsys, "evaluate", "-d", tiny_spec, "-m", mean_match, "--out", folder)
    assert code == 0, err
    title = out.splitlines()[0].strip()
    assert title.endswith(f"({tiny_spec})") and not title.startswith("(")
    code, shown, err = run(capsys, "show", folder)
    assert code == 0, err
    assert shown.splitlines()[0].strip() == title


def test_the_table_keeps_method_names_whole_on_an_80_column_terminal(
    tmp_path, capsys, monkeypatch, tiny_spec
):
    # the name column had folded to five letters a line ("weigh", "ted-n", "ode-p", ...)
    from rich.console import Console

    import ppaloc.cli.commands as commands

    folder = tmp_path / "run"
    names = ["weighted-node-paper-lowres", "onsensor-paper-lbp", "seqslam-centred"]
    argv = ["evaluate", "-d", tiny_spec, "--out", folder, "-q", "--no-report"]
    code, _, err = run(capsys, *argv, *(a for n in names for a in ("-m", n)))
    assert code == 0, err
    summary = json.loads((folder / "results.json").read_text())
    for width, left_out in ((80, "P@F1, R@F1, loop ms"), (200, None)):
        monkeypatch.setattr(commands, "_console", lambda w=width: Console(width=w))
        commands.print_results_table(summary, title="t")
        out = capsys.readouterr().out
        table = out.split("F1 = max F1", 1)[0]
        assert max(len(line) for line in table.splitlines()) <= width
        assert all(f" {n}" in table for n in ["weighted-node-paper-lowres", *names[1:]])
        assert "F1" in table and "R@100P" in table and "mJ" in table
        if left_out:
            assert f"left out to fit this terminal's {width} columns: {left_out}" in out
        else:
            assert "left out" not in out and " P@F1 " in table


def test_the_narrow_table_leaves_out_the_columns_without_a_figure_first(
    tmp_path, capsys, monkeypatch, tiny_spec
):
    # host methods only: chip ms, loop ms and mJ are all "-", and go before any figure
    from rich.console import Console

    import ppaloc.cli.commands as commands

    folder = tmp_path / "run"
    argv = ["evaluate", "-d", tiny_spec, "--out", folder, "-q", "--no-report"]
    code, _, err = run(capsys, *argv, "-m", "weighted-node-paper-lowres", "-m", "seqslam")
    assert code == 0, err
    summary = json.loads((folder / "results.json").read_text())
    monkeypatch.setattr(commands, "_console", lambda: Console(width=200))
    commands.print_results_table(summary)
    line = next(x for x in capsys.readouterr().out.splitlines() if " Method " in x)
    width = len(line) - 1  # one column short of the whole table
    monkeypatch.setattr(commands, "_console", lambda: Console(width=width))
    commands.print_results_table(summary)
    out = capsys.readouterr().out
    assert f"left out to fit this terminal's {width} columns: loop ms (a wider" in out
    assert " P@F1 " in out and " R@F1 " in out and " chip ms " in out


def test_show_draws_a_methods_register_planes_under_their_labels(tmp_path, capsys, monkeypatch):
    # arrays/METHOD.registers.npz was drawn as "plane0", "plane1", its labels unread
    import ppaloc.sim.render as render

    drawn = {}
    monkeypatch.setattr(render, "render_montage", lambda planes, out, **k: drawn.update(planes))
    path = tmp_path / "run" / "arrays" / "onsensor-lbp.registers.npz"
    path.parent.mkdir(parents=True)
    planes = {f"plane{i}": np.full((4, 4), i, np.int16) for i in range(2)}
    np.savez(path, **planes, labels=np.array(["C: weights", "R9: detection candidates"]))
    code, _, err = run(capsys, "show", path, "--out", tmp_path / "r.png")
    assert code == 0, err
    assert list(drawn) == ["C: weights", "R9: detection candidates"]
    assert drawn["R9: detection candidates"][0, 0] == 1


def test_an_out_the_user_cannot_read_is_still_written(
    tmp_path, capsys, folder_map, mean_match, monkeypatch
):
    # an output is written, never read: a write-only file given to --out was refused as
    # "not readable" (os.access is faked, since this suite may run as root)
    import os

    q = _images(tmp_path / "q", ["a.png"])[0]
    outs = {"map": tmp_path / "m2.npz", "localise": tmp_path / "est.csv"}
    for path in outs.values():
        path.write_text("old\n")
    access = os.access
    monkeypatch.setattr(
        os,
        "access",
        lambda p, mode, **kw: (
            False if mode == os.R_OK and Path(p) in outs.values() else access(p, mode, **kw)
        ),
    )
    ref = f"folder:{tmp_path / 'ref'}"
    code, _, err = run(capsys, "map", ref, "-m", mean_match, "--out", outs["map"], "-q")
    assert code == 0, err
    code, _, err = run(capsys, "localise", folder_map, q, "--out", outs["localise"])
    assert code == 0, err
    assert outs["localise"].read_text().startswith("frame,")
