"""Results files: the same run gives the same bytes, and a folder whose files were altered,
mixed or pushed out of range is refused in one line naming the file and the field."""

from __future__ import annotations

import json
import os
from pathlib import Path

import numpy as np
import pytest

from ppaloc.errors import DataError
from ppaloc.evaluate.config import EvaluateConfig
from ppaloc.evaluate.results import load_results, save_results
from ppaloc.evaluate.run import run_evaluation
from ppaloc.npzfile import npz_bytes


@pytest.fixture
def result(mean_match, tiny):
    return run_evaluation(EvaluateConfig(methods=(mean_match,)), dataset=tiny, progress=False)


@pytest.fixture
def saved(result, tmp_path) -> Path:
    save_results(result, tmp_path / "out")
    return tmp_path / "out"


def _files(folder: Path) -> dict[str, bytes]:
    return {
        p.relative_to(folder).as_posix(): p.read_bytes() for p in folder.rglob("*") if p.is_file()
    }


def test_the_same_result_gives_the_same_bytes(result, tmp_path, monkeypatch):
    monkeypatch.delenv("SOURCE_DATE_EPOCH", raising=False)
    save_results(result, tmp_path / "a")
    result.created = "another time"  # the clock at run time is not written
    save_results(result, tmp_path / "b")
    assert _files(tmp_path / "a") == _files(tmp_path / "b")
    assert "created" not in json.loads((tmp_path / "a" / "results.json").read_text())


def test_source_date_epoch_is_the_created_time(result, tmp_path, monkeypatch):
    monkeypatch.setenv("SOURCE_DATE_EPOCH", "1700000000")
    save_results(result, tmp_path / "a")
    summary = json.loads((tmp_path / "a" / "results.json").read_text())
    assert summary["created"] == "2023-11-14T22:13:20+00:00"
    assert load_results(tmp_path / "a")[0].created == summary["created"]


def _rewrite(saved: Path, rel: str, **changes: np.ndarray) -> None:
    """Change arrays of one file and re-record its checksum (only range checks can tell)."""
    import hashlib

    path = saved / rel
    with np.load(path) as z:
        arrays = {k: z[k] for k in z.files}
    arrays.update(changes)
    path.write_bytes(npz_bytes(arrays))
    summary = json.loads((saved / "results.json").read_text())
    summary["files"][rel] = hashlib.sha256(path.read_bytes()).hexdigest()
    (saved / "results.json").write_text(json.dumps(summary))


@pytest.mark.parametrize(
    ("change", "message"),
    [
        (lambda n: {"node": np.full(n, 10**9)}, r"node\[0\] is 1000000000, outside 0\.\.9"),
        (lambda n: {"ref_index": np.full(n, -3)}, r"ref_index\[0\] is -3, outside 0\.\.9"),
        (lambda n: {"ranking": np.full((n, 2), 99)}, r"ranking\[0, 0\] is 99, outside -1\.\.9"),
        (lambda n: {"score": np.zeros(n + 1)}, r"score has shape \(11,\), expected 10 rows"),
        (lambda n: {"node": np.zeros(n, np.float64)}, r"node holds float64, expected integers"),
    ],
)
def test_out_of_range_arrays_are_named(saved, mean_match, change, message):
    rel = f"arrays/{mean_match}.npz"
    _rewrite(saved, rel, **change(10))
    with pytest.raises(DataError, match=rf"^{saved / rel}: {message}"):
        load_results(saved)


def test_out_of_range_ground_truth_is_named(saved):
    with np.load(saved / "arrays" / "_dataset.npz") as z:
        n = len(z["gt_indices"])
    _rewrite(saved, "arrays/_dataset.npz", gt_indices=np.full(n, 50))
    with pytest.raises(DataError, match=r"_dataset.npz: gt_indices\[0\] is 50, outside 0\.\.9"):
        load_results(saved)


def test_a_folder_that_is_not_whole(saved, mean_match, result, tmp_path):
    other = tmp_path / "other"
    result.runs[mean_match].node = result.runs[mean_match].node[::-1].copy()
    save_results(result, other)
    rel = f"arrays/{mean_match}.npz"
    (saved / rel).write_bytes((other / rel).read_bytes())  # a file of another run
    with pytest.raises(DataError, match=rf"^{saved} is not whole: {rel} does not match the"):
        load_results(saved)
    (saved / rel).unlink()
    with pytest.raises(DataError, match=rf"^{saved} is not whole: {rel} is missing; run"):
        load_results(saved)


def test_stored_paths_stay_inside_the_folder(saved, mean_match):
    summary = json.loads((saved / "results.json").read_text())
    del summary["files"]
    summary["methods"][mean_match]["arrays"] = "../../etc/passwd"
    (saved / "results.json").write_text(json.dumps(summary))
    with pytest.raises(DataError, match=r"arrays '../../etc/passwd' points outside the folder"):
        load_results(saved)


def test_a_folder_of_another_tool_is_not_replaced(result, tmp_path):
    (tmp_path / "mine").mkdir()
    (tmp_path / "mine" / "thesis.tex").write_text("keep")
    with pytest.raises(DataError, match=r"holds 'thesis.tex', which ppaloc did not write"):
        save_results(result, tmp_path / "mine")
    assert (tmp_path / "mine" / "thesis.tex").read_text() == "keep"


def test_show_refuses_out_of_range_results_in_one_line(saved, mean_match, capsys):
    from ppaloc.cli import main

    _rewrite(saved, f"arrays/{mean_match}.npz", node=np.full(10, -1))
    assert main(["show", str(saved), "-q"]) == 1
    err = capsys.readouterr().err
    assert len(err.strip().splitlines()) == 1 and "node[0] is -1, outside 0..9" in err
    assert f"{saved}/arrays/" in err and ".ppaloc-new-" not in err  # the user's folder named


def test_the_current_folder_is_not_replaced(result, tmp_path, monkeypatch):
    (tmp_path / "results.json").write_text("{}")
    monkeypatch.chdir(tmp_path)
    with pytest.raises(DataError, match=r"--out \. is the current folder or holds it"):
        save_results(result, ".")
    with pytest.raises(DataError, match=r"is the current folder or holds it"):
        save_results(result, "..")


def test_show_from_inside_the_folder_keeps_the_folder_in_place(saved, monkeypatch):
    from ppaloc.cli import main

    monkeypatch.chdir(saved)
    assert main(["show", ".", "-q"]) == 0
    assert os.path.samefile(".", saved), "the folder the shell stands in was swapped away"
    assert (saved / "report.html").is_file()


@pytest.mark.parametrize(
    ("edit", "message"),
    [
        (lambda m: m.__setitem__("f1_max", "high"), r"f1_max is 'high', expected a number"),
        # a field left out read as if it held the text 'missing'
        (lambda m: m.pop("f1_max"), r"f1_max is missing, expected a number"),
        (lambda m: m.__setitem__("f1_max", "missing"), r"f1_max is 'missing', expected a number"),
        (lambda m: m.__setitem__("auc", True), r"auc is True, expected a number"),
        (lambda m: m.__setitem__("latency_ms_median", "x"), r"latency_ms_median is 'x'"),
        (lambda m: m.__setitem__("recall_at_k", [1, 2]), r"recall_at_k is \[1, 2\]"),
        # a number no float holds: an internal error (OverflowError) of the table or report
        (lambda m: m.__setitem__("build_s", 10**400), r"build_s is 10000000000"),
        (lambda m: m.__setitem__("latency_ms_median", 10**400), r"latency_ms_median is 1000"),
        (lambda m: m.__setitem__("map_kind", 3), r"map_kind is 3, expected a string"),
        # the report reads params' descriptor: an internal error (AttributeError)
        (lambda m: m.__setitem__("params", 5), r"params is 5, expected a table of the method's"),
        (
            lambda m: m.__setitem__("modelled_time_ms", {"chip": 5}),
            r"modelled_time_ms is \{'chip': 5\}, expected a table of \{low, mid, high\}",
        ),
    ],
)
def test_a_hand_edited_summary_is_named(saved, mean_match, edit, message):
    # results.json is the one file its checksums do not cover; what a table reads is checked
    summary = json.loads((saved / "results.json").read_text())
    edit(summary["methods"][mean_match])
    (saved / "results.json").write_text(json.dumps(summary))
    with pytest.raises(DataError, match=rf"methods\.{mean_match}\.{message}"):
        load_results(saved)


@pytest.mark.parametrize("constant", ["NaN", "Infinity", "-Infinity"])
def test_a_hand_edited_nan_or_infinity_is_named(saved, mean_match, constant):
    # ppaloc writes strict JSON (null for no value): NaN or Infinity is an edit
    summary = json.loads((saved / "results.json").read_text())
    summary["methods"][mean_match]["latency_ms_median"] = "@"
    text = json.dumps(summary).replace('"@"', constant)
    (saved / "results.json").write_text(text)
    with pytest.raises(DataError, match=rf"results.json holds {constant}, which is not JSON"):
        load_results(saved)


def test_a_number_beyond_a_float_is_named(saved, mean_match):
    # 1e400 reads as inf, which ppaloc never writes (strict JSON)
    summary = json.loads((saved / "results.json").read_text())
    summary["methods"][mean_match]["f1_max"] = "@"
    (saved / "results.json").write_text(json.dumps(summary).replace('"@"', "1e400"))
    with pytest.raises(DataError, match=rf"methods\.{mean_match}\.f1_max is inf, expected"):
        load_results(saved)


def test_a_summary_without_methods_is_named(saved):
    summary = json.loads((saved / "results.json").read_text())
    summary["methods"] = {}
    (saved / "results.json").write_text(json.dumps(summary))
    with pytest.raises(DataError, match="'methods' is empty"):
        load_results(saved)


def test_a_file_where_the_figures_go_is_replaced_by_them(saved):
    from ppaloc.evaluate.report import write_report

    (saved / "figures").mkdir(exist_ok=True)
    for p in (saved / "figures").iterdir():
        p.unlink()
    (saved / "figures").rmdir()
    (saved / "figures").write_text("not a folder")
    write_report(saved)
    assert (saved / "figures").is_dir()


@pytest.mark.parametrize(
    ("text", "message"),
    [
        # read unguarded to find the report's own figures: an internal error (RecursionError)
        ("[" * 100_000 + "]" * 100_000, "results.json is nested too deep"),
        # blamed on a figure ppaloc had written: 'holds figures/x.png, which ppaloc did not write'
        ("[1, 2]", "results.json is not a results table"),
    ],
)
def test_show_names_a_results_json_it_cannot_read_beside_its_figures(saved, capsys, text, message):
    from ppaloc.cli import main
    from ppaloc.evaluate.report import write_report

    write_report(saved)
    (saved / "results.json").write_text(text)
    assert main(["show", str(saved)]) == 1
    err = capsys.readouterr().err.strip()
    assert err.startswith("ppaloc: error: ") and "\n" not in err and message in err


def test_evaluate_over_a_results_json_nested_too_deep_is_one_line(saved, capsys):
    from ppaloc.cli import main

    (saved / "results.json").write_text("[" * 100_000 + "]" * 100_000)
    spec = "synthetic:?places=12&size=32&sync=1&seed=2"
    assert main(["evaluate", "-d", spec, "-m", "single-frame", "-q", "--out", str(saved)]) == 1
    err = capsys.readouterr().err.strip()
    assert err.startswith(f"ppaloc: error: cannot read {(saved / 'results.json').resolve()} ")
    assert "(nested too deep)" in err and "\n" not in err


@pytest.mark.parametrize("field", ["latency_ms_median", "latency_ms_p95", "energy_mj"])
def test_show_reports_a_method_without_an_optional_figure(saved, mean_match, capsys, field):
    # optional fields (a number or null): the report's tables read them as absent ("-"),
    # where an entry without one was an internal error (KeyError)
    from ppaloc.cli import main

    summary = json.loads((saved / "results.json").read_text())
    del summary["methods"][mean_match][field]
    (saved / "results.json").write_text(json.dumps(summary))
    assert main(["show", str(saved)]) == 0, capsys.readouterr().err
    assert "| - |" in (saved / "report.md").read_text()


@pytest.mark.parametrize("value", ["x", -1, 0.5, True, [1]])
def test_a_protocol_ground_truth_that_is_not_a_table_is_named(saved, capsys, value):
    # the report reads its tolerance from it: an internal error (AttributeError) before
    from ppaloc.cli import main

    summary = json.loads((saved / "results.json").read_text())
    summary.setdefault("protocol", {})["ground_truth"] = value
    (saved / "results.json").write_text(json.dumps(summary))
    assert main(["show", str(saved)]) == 1
    err = capsys.readouterr().err.strip()
    assert "protocol.ground_truth is" in err and "expected a table" in err and "\n" not in err
