"""``ppaloc score``: an outside method's predictions scored as ``evaluate`` scores a run, and
every problem of a predictions file refused in one line before any work."""

from __future__ import annotations

import json
import os
from pathlib import Path

import numpy as np
import pytest
from PIL import Image

from ppaloc.cli import main


def run(capsys, *args: object) -> tuple[int, str, str]:
    code = main([str(a) for a in args])
    out, err = capsys.readouterr()
    return code, out, err


@pytest.fixture
def spec(tmp_path) -> str:
    """A folder dataset of 4 reference and 4 query images (img0.png .. img3.png), frame
    ``i`` of one the same place as frame ``i`` of the other (tolerance 0)."""
    rng = np.random.default_rng(0)
    frames = [rng.integers(0, 256, (16, 16), np.uint8) for _ in range(4)]
    for side in ("ref", "query"):
        (tmp_path / side).mkdir()
        for i, grey in enumerate(frames):
            Image.fromarray(grey).save(tmp_path / side / f"img{i}.png")
    return f"folder:{tmp_path / 'ref'},{tmp_path / 'query'}"


def _csv(tmp_path: Path, text: str, name: str = "mine.csv") -> Path:
    path = tmp_path / name
    path.write_text(text)
    return path


GOLDEN = "query,reference,score\n0,0,0.9\n1,1,0.8\n2,0,0.7\n3,3,0.1\n"
"""q2 wrong: max F1 0.75 (hand-computed in tests/evaluate/test_score.py)."""


def test_score_writes_the_results_and_report_of_evaluate(spec, tmp_path, capsys):
    f = _csv(tmp_path, GOLDEN)
    out = tmp_path / "scored"
    code, stdout, err = run(capsys, "score", f, "--dataset", spec, "--out", out)
    assert code == 0, err
    summary = json.loads((out / "results.json").read_text())
    assert list(summary["methods"]) == ["mine"]
    m = summary["methods"]["mine"]
    assert m["f1_max"] == 0.75 and m["precision_at_100r"] == 0.75 and m["recall_at_100p"] == 0.5
    assert m["params"] == {"predictions": str(f)} and m["latency_ms_median"] is None
    assert summary["protocol"]["prediction"].startswith("one reference frame per query, as ")
    assert summary["config"]["command"] == "score"
    for name in ("results.csv", "report.html", "report.md", "arrays/mine.npz"):
        assert (out / name).is_file(), name
    assert "R@100P" in stdout and "report:" in stdout
    # the folder is an ordinary results folder: show rebuilds its report from the files
    (out / "report.html").unlink()
    assert run(capsys, "show", out)[0] == 0 and (out / "report.html").is_file()


def test_several_files_and_a_method_column_make_several_methods(spec, tmp_path, capsys):
    a = _csv(tmp_path, GOLDEN, "netvlad.csv")
    b = _csv(
        tmp_path,
        "method,query_name,reference_name,score\n"
        + "".join(f"x,img{i}.png,img{i}.png,1\n" for i in range(4))
        + "".join(f"y,query/img{i}.png,img{3 - i}.png,{i}\n" for i in range(4)),
        "two.csv",
    )
    out = tmp_path / "scored"
    code, _, err = run(capsys, "score", a, b, "-d", spec, "--out", out, "-q", "--no-report")
    assert code == 0, err
    methods = json.loads((out / "results.json").read_text())["methods"]
    assert list(methods) == ["netvlad", "x", "y"]
    assert methods["x"]["f1_max"] == 1.0 and methods["y"]["precision_at_100r"] == 0.0


def test_a_localise_csv_is_scored_as_it_is(tmp_path, capsys, spec):
    from ppaloc.methods import available_methods

    if "single-frame" not in available_methods():
        pytest.skip("single-frame is not available")
    m = tmp_path / "m.npz"
    assert (
        run(capsys, "map", f"folder:{tmp_path / 'ref'}", "-m", "single-frame", "--out", m)[0] == 0
    )
    est = tmp_path / "est.csv"
    code, _, err = run(capsys, "localise", m, tmp_path / "query", "--out", est)
    assert code == 0, err
    assert est.read_text().splitlines()[1].endswith(",img0.png")  # the reference frame's name
    code, _, err = run(capsys, "score", est, "-d", spec, "--out", tmp_path / "s", "-q")
    assert code == 0, err
    methods = json.loads((tmp_path / "s" / "results.json").read_text())["methods"]
    assert methods["est"]["precision_at_100r"] == 1.0 and methods["est"]["latency_ms_median"] > 0


# -- every problem: one line naming the row and the fix, before any work -----------------------


def _refused(capsys, tmp_path, spec, text: str, *extra: object, name: str = "mine.csv") -> str:
    f = _csv(tmp_path, text, name)
    out = tmp_path / "never"
    code, stdout, err = run(capsys, "score", f, "-d", spec, "--out", out, *extra)
    assert code == 1 and err.count("\n") == 1 and "Traceback" not in err, err
    assert not out.exists() and not stdout  # nothing was done
    return err.removeprefix("ppaloc: error: ").rstrip("\n").replace(str(f), "F")


ERRORS = {
    "missing score column": (
        "query,reference\n0,0\n",
        "F has no score column (its columns: query, reference); add score, the confidence "
        "of each prediction, higher = surer",
    ),
    "missing query column": (
        "reference,score\n0,1\n",
        "F names no query: add a query column (the 0-based query index) or query_name (the "
        "query frame's file name)",
    ),
    "missing reference column": (
        "query,score\n0,1\n",
        "F names no predicted reference: add a reference column (the 0-based reference "
        "index) or reference_name (the reference frame's file name)",
    ),
    "unknown column": (
        "query,reference,scroe\n0,0,1\n",
        "F line 1: unknown column 'scroe'; the columns are query, query_name, reference, "
        "reference_name, score, method, reference_2.., reference_name_2.., latency_ms, moved "
        "(and localise's frame, path, node, reference_frame; see docs/evaluate-cli.md, "
        "Predictions files)",
    ),
    "one column twice": (
        "frame,query,reference,score\n0,0,0,1\n",
        "F line 1: columns 'frame' and 'query' both give the query; keep one of them",
    ),
    "a gap in the ranks": (
        "query,reference,reference_3,score\n0,0,1,1\n",
        "F line 1: reference ranks jump from 1 to 3; give reference_2 (every rank from 2 up "
        "to the deepest)",
    ),
    "query index out of range": (
        GOLDEN + "4,0,0.5\n",
        "F line 6: query 4 is outside the 4 query frames of 'SPEC' (0..3); indices are "
        "0-based over the query traversal after its start/stop/step",
    ),
    "reference index out of range": (
        "query,reference,score\n0,0,1\n1,9,1\n2,2,1\n3,3,1\n",
        "F line 3: reference 9 is outside the 4 reference frames of 'SPEC' (0..3); indices "
        "are 0-based over the reference traversal after its start/stop/step",
    ),
    "reference name not in the dataset": (
        "query,reference_name,score\n0,img0.png,1\n1,img9.png,1\n2,img2.png,1\n3,img3.png,1\n",
        "F line 3: reference_name 'img9.png' is not a reference frame of 'SPEC' (its 4 "
        "frames are named 'img0.png' .. 'img3.png'); give a name from the reference "
        "traversal, or reference indices",
    ),
    "a query twice": (
        "query,reference,score\n0,0,1\n1,1,1\n0,2,1\n",
        "F line 4: query 0 of method 'mine' is already predicted on line 2; give one row "
        "per query and method",
    ),
    "missing queries": (
        "query,reference,score\n0,0,1\n1,1,1\n3,3,1\n",
        "F: method 'mine' predicts 3 of the 4 queries of 'SPEC'; the first missing is query "
        "2 (img2.png): give one row for every query (a query the method could not place: "
        "its lowest score), or select the queries predicted with the spec's start=/stop=",
    ),
    "a NaN score": (
        "query,reference,score\n0,0,1\n1,1,nan\n",
        "F line 3: score is nan; give every query a finite confidence, higher = surer (a "
        "query the method could not place: its lowest score)",
    ),
    "a score that is not a number": (
        "query,reference,score\n0,0,high\n",
        "F line 2: score 'high' is not a number; give every query a finite confidence, "
        "higher = surer (a query the method could not place: its lowest score)",
    ),
    "a query index that is not a whole number": (
        "query,reference,score\n0.5,0,1\n",
        "F line 2: query '0.5' is not a query index; give the 0-based index of the query "
        "frame (a whole number >= 0)",
    ),
    "an empty prediction": (
        "query,reference,score\n0,,1\n",
        "F line 2: no predicted reference; give the reference frame this query is matched "
        "to (every query needs one)",
    ),
    "a row of the wrong width": (
        "query,reference,score\n0,0\n",
        "F line 2 has 2 fields for the header's 3 columns; give every row one field per "
        "column (an empty field where there is no value)",
    ),
    "an empty file": (
        "",
        "F is empty; give a CSV whose first line names its columns, e.g. query,reference,score",
    ),
    "a header without rows": (
        "query,reference,score\n",
        "F has a header but no rows; give one row per query",
    ),
    "a bad moved value": (
        "query,reference,score,moved\n0,0,1,yes\n",
        "F line 2: moved 'yes' is not 1, 0 or empty; give the method's motion decision (1 "
        "forward, 0 stay) or leave it empty",
    ),
    "a negative latency": (
        "query,reference,score,latency_ms\n0,0,1,-2\n",
        "F line 2: latency_ms is -2; a time is >= 0 (or leave it empty)",
    ),
    "a latency over a day": (
        "query,reference,score,latency_ms\n0,0,1,1e308\n",
        "F line 2: latency_ms is 1e+308, more than a day per query (at most 86400000); give "
        "the time in milliseconds",
    ),
    "a rank with a leading zero": (
        "query,reference,reference_02,score\n0,0,1,1\n",
        "F line 1: unknown column 'reference_02'; the columns are query, query_name, "
        "reference, reference_name, score, method, reference_2.., reference_name_2.., "
        "latency_ms, moved (and localise's frame, path, node, reference_frame; see "
        "docs/evaluate-cli.md, Predictions files)",
    ),
    "a name column left empty": (
        "query_name,reference,score\n,0,1\n,1,1\n",
        "F: query_name is empty on every row; give each row its query frame's name, or "
        "query indices (query column)",
    ),
    "a bad method label": (
        "method,query,reference,score\n_x,0,0,1\n",
        "F line 2: method '_x', which is not a label of 1 to 64 printable characters not "
        "starting with _ or .; give a label such as netvlad",
    ),
}


@pytest.mark.parametrize("case", list(ERRORS))
def test_each_problem_is_one_line_naming_the_row_and_the_fix(spec, tmp_path, capsys, case):
    text, message = ERRORS[case]
    shown = repr(spec) if len(repr(spec)) <= 80 else repr(spec)[:76] + "...'"
    assert _refused(capsys, tmp_path, spec, text) == message.replace("'SPEC'", shown)


def test_a_file_that_is_not_utf8_names_its_line(spec, tmp_path, capsys):
    f = tmp_path / "mine.csv"
    f.write_bytes(b"query,reference,score\n0,0,1\n1,\xff,1\n")
    code, _, err = run(capsys, "score", f, "-d", spec, "--out", tmp_path / "o")
    assert code == 1
    assert err == (
        f"ppaloc: error: {f} line 3: the reference field is not UTF-8 text; save the file as "
        "UTF-8 text (only the frames' file names, query_name and reference_name, may hold "
        "other bytes)\n"
    )


def test_a_header_that_is_not_utf8_is_refused(spec, tmp_path, capsys):
    f = tmp_path / "mine.csv"
    f.write_bytes(b"query,reference,sc\xe9re\n0,0,1\n")
    code, _, err = run(capsys, "score", f, "-d", spec, "--out", tmp_path / "o")
    assert code == 1
    assert err.startswith(f"ppaloc: error: {f} line 1: the header is not UTF-8 text;")


def test_file_names_that_are_not_utf8_are_read_as_their_own_bytes(tmp_path):
    """ppaloc localise writes a frame's file name that is not UTF-8 back as its bytes; the
    file's names read as the folder listing reads them (os.fsdecode)."""
    from ppaloc.evaluate.score import read_predictions

    f = tmp_path / "mine.csv"
    f.write_bytes(b"query_name,reference_name,score\ncaf\xe9-1.png,caf\xe9-0.png,0.5\n")
    (p,) = read_predictions(f)
    assert p.queries["query_name"] == [os.fsdecode(b"caf\xe9-1.png")]
    assert p.references[0]["reference_name"] == [os.fsdecode(b"caf\xe9-0.png")]


def test_a_file_too_large_is_refused_before_it_is_read(spec, tmp_path, capsys, monkeypatch):
    import ppaloc.evaluate.score as score

    monkeypatch.setattr(score, "MAX_PREDICTIONS_BYTES", 40)
    f = _csv(tmp_path, GOLDEN)
    code, _, err = run(capsys, "score", f, "-d", spec, "--out", tmp_path / "o")
    assert code == 1
    assert err == (
        f"ppaloc: error: predictions file {f} is {len(GOLDEN)} bytes, more than 40 (0 MiB); "
        "split it by method into several files\n"
    )


def test_a_pipe_is_refused_without_blocking(spec, tmp_path, capsys):
    fifo = tmp_path / "pipe.csv"
    os.mkfifo(fifo)
    code, _, err = run(capsys, "score", fifo, "-d", spec, "--out", tmp_path / "o")
    assert code == 1
    assert err == (
        f"ppaloc: error: predictions file {fifo} is not a regular file (a pipe, device or "
        "socket); save the predictions to a file and give that\n"
    )


def test_two_files_of_one_label_are_refused(spec, tmp_path, capsys):
    (tmp_path / "a").mkdir()
    (tmp_path / "b").mkdir()
    a, b = _csv(tmp_path / "a", GOLDEN), _csv(tmp_path / "b", GOLDEN)
    code, _, err = run(capsys, "score", a, b, "-d", spec, "--out", tmp_path / "o")
    assert code == 1
    assert err == (
        f"ppaloc: error: method 'mine' is given by {a} and {b}; give each method one label "
        "(a method column, or rename a file)\n"
    )


def test_no_dataset_and_a_contradicting_tolerance_are_refused(spec, tmp_path, capsys):
    f = _csv(tmp_path, GOLDEN)
    code, _, err = run(capsys, "score", f)
    assert code == 1 and err.startswith("ppaloc: error: no dataset: give --dataset SPEC")
    code, _, err = run(capsys, "score", f, "-d", spec + "?tolerance=1", "--tolerance", "2")
    assert code == 1 and "contradicts tolerance=1 in the dataset spec" in err


def test_the_output_may_not_lie_in_the_datasets_folders(spec, tmp_path, capsys):
    f = _csv(tmp_path, GOLDEN)
    code, _, err = run(capsys, "score", f, "-d", spec, "--out", tmp_path / "ref" / "scored")
    assert code == 1
    assert "lies inside the dataset's input folder" in err and err.count("\n") == 1


@pytest.mark.parametrize("column", ["query", "reference"])
def test_show_refuses_an_index_no_64_bit_integer_holds(tmp_path, capsys, column):
    # 19 digits matched the index pattern and overflowed in show (an internal error)
    rows = {"query": "9999999999999999999,0,1", "reference": "0,9999999999999999999,1"}
    f = tmp_path / "p.csv"
    f.write_text(f"query,reference,score\n{rows[column]}\n")
    assert main(["show", str(f)]) == 1
    err = capsys.readouterr().err
    assert err.startswith(f"ppaloc: error: {f} line 2: {column} '9999999999999999999' is not a")
    assert err.count("\n") == 1 and not (tmp_path / "p.png").exists()


def test_show_draws_the_first_methods_of_a_file_of_many(tmp_path, monkeypatch):
    # a panel a label: a file of 300 labels took minutes to lay out and drew a PNG of
    # 100,000 rows of pixels
    from ppaloc.cli.showcsv import predictions_figure
    from ppaloc.evaluate import figures
    from ppaloc.evaluate.score import read_predictions

    monkeypatch.setattr(figures, "MAX_DRAWN", 2)
    f = tmp_path / "p.csv"
    f.write_text("method,query,reference,score\n" + "".join(f"m{k},0,0,1\n" for k in range(5)))
    fig = predictions_figure(read_predictions(f), "p.csv")
    assert [a.get_title() for a in fig.axes if a.get_title()] == [
        "m0: 1 predictions",
        "m1: 1 predictions",
    ]
    assert fig.get_suptitle() == "p.csv (the first 2 of 5 methods)"
