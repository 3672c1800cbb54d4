"""`ppaloc evaluate --out DIR` over an earlier run, killed (SIGKILL) at several moments:
DIR is always the whole earlier run or the whole new one, `ppaloc show DIR` works, and
nothing is left behind (no `.tmp` file, no staging folder once the next command ran)."""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
import time
from pathlib import Path

import pytest

from ppaloc.cli import main

TINY = "synthetic:?places=12&size=32&sync=1&seed=2"
OLD = {"weighted-node-lbp", "single-frame"}
NEW = {"single-frame"}

# The child runs the CLI with one step of the write made fatal: it SIGKILLs itself there.
CHILD = r"""
import os, signal, sys
import ppaloc.fileio as fio

mode, n = sys.argv[1], int(sys.argv[2])


def die():
    os.kill(os.getpid(), signal.SIGKILL)


if mode == "replace":  # the n-th file moved into place (inside the staging folder)
    real_replace, count = os.replace, [0]

    def replace(a, b, **kw):
        count[0] += 1
        if count[0] == n:
            die()
        return real_replace(a, b, **kw)

    os.replace = replace
elif mode == "before-exchange":
    fio._exchange = lambda a, b: die()
elif mode == "after-exchange":  # the new folder is in, the old one not yet deleted
    real_exchange = fio._exchange

    def exchange(a, b):
        real_exchange(a, b)
        die()

    fio._exchange = exchange
elif mode == "aside":  # no exchange: killed between renaming the old folder aside and the new in
    fio._exchange = lambda a, b: False
    real_rename = os.rename

    def rename(a, b):
        real_rename(a, b)
        if ".ppaloc-old-" in str(b):
            die()

    os.rename = rename
from ppaloc.cli import main

sys.exit(main(sys.argv[3:]))
"""


def _evaluate(out: Path, methods: set[str], *extra: str) -> list[str]:
    args = ["evaluate", "-d", TINY, "--out", str(out), "-q", *extra]
    for m in sorted(methods):
        args += ["-m", m]
    return args


@pytest.fixture(scope="module")
def _old_template(tmp_path_factory) -> Path:
    out = tmp_path_factory.mktemp("template") / "run"
    assert main(_evaluate(out, OLD, "--no-report")) == 0
    return out


@pytest.fixture
def old_run(_old_template, tmp_path) -> Path:
    """A copy of an earlier run of two methods (the new runs have one)."""
    out = tmp_path / "run"
    shutil.copytree(_old_template, out)
    return out


def _methods(out: Path) -> set[str]:
    return set(json.loads((out / "results.json").read_text())["methods"])


def _check_whole(out: Path, expected: tuple[set[str], ...], capsys) -> None:
    # Right after the kill, a temporary can only be inside the hidden staging folder,
    # which the next command on the folder removes.
    left = [p for p in out.parent.rglob("*.tmp") if ".ppaloc-new-" not in str(p)]
    assert not left, "a killed write left a temporary file"
    assert main(["show", str(out), "-q"]) == 0, capsys.readouterr().err
    assert not list(out.parent.rglob("*.tmp"))
    methods = _methods(out)
    assert methods in expected
    arrays = {p.stem for p in (out / "arrays").glob("*.npz")} - {"_dataset", "_difference"}
    assert arrays == methods, "arrays of another run's methods were left in the folder"
    assert sorted(os.listdir(out.parent)) == ["run"], "a staging folder was left behind"


@pytest.mark.slow
@pytest.mark.parametrize(
    ("mode", "n", "report", "expected"),
    [
        ("replace", 2, False, (OLD,)),
        ("replace", 7, True, (OLD,)),  # while the report's figures are written
        ("before-exchange", 0, False, (OLD,)),
        ("after-exchange", 0, False, (NEW,)),
        ("aside", 0, False, (OLD,)),
    ],
)
def test_evaluate_killed_over_an_earlier_run(old_run, mode, n, report, expected, capsys):
    extra = () if report else ("--no-report",)
    args = [sys.executable, "-c", CHILD, mode, str(n), *_evaluate(old_run, NEW, *extra)]
    done = subprocess.run(args, capture_output=True, text=True, check=False, timeout=120)
    assert done.returncode == -9, done.stderr[-2000:]
    _check_whole(old_run, expected, capsys)


@pytest.mark.slow
def test_evaluate_killed_from_outside(old_run, capsys):
    args = [sys.executable, "-m", "ppaloc", *_evaluate(old_run, NEW)]
    for delay in (0.5, 1.5):
        proc = subprocess.Popen(args, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        time.sleep(delay)
        proc.kill()  # SIGKILL
        proc.wait(timeout=60)
        _check_whole(old_run, (OLD, NEW), capsys)


def test_a_rerun_leaves_nothing_of_the_earlier_run(old_run, capsys):
    (old_run / "bench.json").write_text("{}")  # `ppaloc bench --out` into the folder: kept
    assert main(_evaluate(old_run, NEW, "--no-report")) == 0
    assert _methods(old_run) == NEW
    assert sorted(p.name for p in old_run.rglob("*")) == sorted(
        [
            "arrays",
            "_dataset.npz",
            "_difference.npz",
            "single-frame.npz",
            "bench.json",
            "results.csv",
            "results.json",
        ]
    )


def test_a_folder_of_other_files_is_refused_before_the_run(tmp_path, capsys):
    mine = tmp_path / "mine"
    mine.mkdir()
    (mine / "notes.txt").write_text("keep me")
    assert main(_evaluate(mine, NEW)) == 1
    err = capsys.readouterr().err
    assert "holds 'notes.txt', which ppaloc did not write" in err and len(err.splitlines()) == 1
    assert os.listdir(mine) == ["notes.txt"]


@pytest.mark.parametrize(
    "names",
    [
        ["2024-01-01.jpg", "2024-01-02.jpg"],  # look like a matrix run's NN-<spec>, are files
        ["10-holiday"],  # a folder of that form without a results.json
        [".results.json.mybackup.tmp"],  # a hidden file of a results name, not ppaloc's form
        ["figures"],  # only names ppaloc writes, but no results file marks it as a run's
    ],
)
def test_a_folder_that_is_no_results_folder_is_refused(tmp_path, capsys, names):
    mine = tmp_path / "mine"
    mine.mkdir()
    for n in names:
        if "." in n:
            (mine / n).write_text("keep me")
        else:
            (mine / n).mkdir()
    assert main(_evaluate(mine, NEW)) == 1
    assert len(capsys.readouterr().err.splitlines()) == 1
    assert sorted(os.listdir(mine)) == sorted(names)


def test_out_through_a_link_and_dotdot_is_the_folder_the_system_means(
    tmp_path, capsys, monkeypatch
):
    """``lnk/..`` is the link target's parent, not the current folder."""
    work = tmp_path / "work"
    (tmp_path / "deep" / "01-x").mkdir(parents=True)
    work.mkdir()
    (work / "my-thesis.txt").write_text("keep me")
    (work / "lnk").symlink_to(tmp_path / "deep" / "01-x")
    monkeypatch.chdir(work)
    assert main(_evaluate(Path("lnk/.."), NEW)) == 1  # deep/ holds 01-x, no results
    capsys.readouterr()
    assert (work / "my-thesis.txt").read_text() == "keep me"
    assert (tmp_path / "deep" / "01-x").is_dir()


def test_sweep_refuses_a_folder_of_other_files(tmp_path):
    from ppaloc.errors import PpalocError
    from ppaloc.evaluate.sweep import check_sweep_folder

    mine = tmp_path / "proj"
    (mine / "figures").mkdir(parents=True)
    (mine / "figures" / "heatmap-1.png").write_bytes(b"png")  # a name a sweep writes
    with pytest.raises(PpalocError, match="not an earlier sweep folder"):
        check_sweep_folder(mine)
    (mine / "notes.txt").write_text("keep me")
    with pytest.raises(PpalocError, match=r"holds 'notes\.txt', which a sweep did not write"):
        check_sweep_folder(mine)
    check_sweep_folder(tmp_path / "new")  # absent: fine
    (tmp_path / "old" / "cells").mkdir(parents=True)
    check_sweep_folder(tmp_path / "old")  # an earlier sweep's: fine


def test_stale_temporaries_of_other_forms_are_never_removed(tmp_path):
    from ppaloc import fileio

    target = tmp_path / "m.npz"
    others = [".m.npz.mybackup.tmp", ".m.npz.123.tmp", ".m.npz.99999999-zzzzzzzz.tmp"]
    for n in others:
        (tmp_path / n).write_text("keep me")
    dead = tmp_path / ".m.npz.999999999-0123abcd.tmp"  # ppaloc's form, no such process
    dead.write_text("stale")
    fileio.write_bytes(target, b"data")
    assert all((tmp_path / n).exists() for n in others)
    assert not dead.exists()


@pytest.fixture(scope="module")
def _reported_template(tmp_path_factory) -> Path:
    out = tmp_path_factory.mktemp("reported") / "run"
    assert main(_evaluate(out, {"onsensor-lbp", "single-frame"})) == 0
    return out


@pytest.mark.parametrize(
    "mine",
    [
        ("arrays/mine.npz", "arrays/mine.npz"),
        ("figures/notes.txt", "figures/notes.txt"),
        ("figures/.pr-curves.png.mybackup.tmp", "figures/.pr-curves.png.mybackup.tmp"),
        ("arrays/sub/notes.txt", "arrays/sub"),  # the first entry ppaloc did not write
    ],
)
def test_a_users_file_inside_a_results_subfolder_is_refused(
    _reported_template, tmp_path, capsys, mine
):
    mine, named = mine
    run = tmp_path / "run"
    shutil.copytree(_reported_template, run)
    assert main(_evaluate(run, NEW)) == 0  # every file ppaloc wrote, figures included, is its own
    (run / mine).parent.mkdir(parents=True, exist_ok=True)
    (run / mine).write_text("keep me")
    assert main(_evaluate(run, NEW)) == 1
    err = capsys.readouterr().err
    assert f"holds {named!r}, which ppaloc did not write" in err and len(err.splitlines()) == 1
    assert (run / mine).read_text() == "keep me"


def test_a_users_file_inside_a_matrix_runs_folder_is_refused(tmp_path, capsys):
    out = tmp_path / "matrix"
    args = ["evaluate", "-d", TINY, "-d", TINY + "&query=night", "-m", "single-frame"]
    assert main([*args, "--out", str(out), "-q", "--no-report"]) == 0
    (sub,) = [p for p in out.iterdir() if p.name.startswith("02-")]
    (sub / "arrays" / "mine.npz").write_bytes(b"keep me")
    assert main([*args, "--out", str(out), "-q", "--no-report"]) == 1
    err = capsys.readouterr().err
    assert f"holds '{sub.name}/arrays/mine.npz', which ppaloc did not write" in err
    assert (sub / "arrays" / "mine.npz").read_bytes() == b"keep me"


def test_show_keeps_a_users_file_in_figures(_reported_template, tmp_path, capsys):
    run = tmp_path / "run"
    shutil.copytree(_reported_template, run)
    assert main(["show", str(run), "-q"]) == 0  # the report's own figures are replaced
    (run / "figures" / "notes.txt").write_text("keep me")
    assert main(["show", str(run), "-q"]) == 1
    err = capsys.readouterr().err
    assert "holds 'figures/notes.txt', which ppaloc did not write" in err
    assert len(err.splitlines()) == 1 and (run / "figures" / "notes.txt").read_text() == "keep me"


@pytest.mark.parametrize("damage", ["corrupt", "unreadable", "not a table"])
def test_an_unreadable_results_json_is_named_as_the_cause(tmp_path, capsys, monkeypatch, damage):
    # the folder was refused as holding 'arrays/_dataset.npz', which ppaloc did not write
    run = tmp_path / "run"
    assert main(_evaluate(run, NEW)) == 0
    summary = run / "results.json"
    why = {"corrupt": "not JSON: Expecting property name", "not a table": "not a results table"}
    summary.write_text({"corrupt": "{bad", "not a table": "[1]"}.get(damage, "{}"))
    kept = {p: p.read_bytes() for p in run.rglob("*") if p.is_file()}
    with monkeypatch.context() as patch:
        if damage == "unreadable":  # a chmod is no obstacle to root: the read is refused here
            real = Path.read_bytes

            def read_bytes(self: Path) -> bytes:
                if self.name == "results.json":
                    raise PermissionError(13, "Permission denied", str(self))
                return real(self)

            patch.setattr(Path, "read_bytes", read_bytes)
        assert main(_evaluate(run, NEW)) == 1
    err = capsys.readouterr().err
    reason = why.get(damage, "Permission denied")
    assert err.startswith(f"ppaloc: error: cannot read {summary.resolve()} ({reason}")
    assert err.endswith(
        "which names the files ppaloc wrote in its arrays/ and figures/, so the folder cannot "
        "be replaced without losing a file of yours; restore results.json (read permission, or "
        "a copy) or give a new folder\n"
    )
    assert {p: p.read_bytes() for p in run.rglob("*") if p.is_file()} == kept
