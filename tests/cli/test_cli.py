"""Smoke tests of every ``ppaloc`` command on tiny inputs, and of its error handling."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner
from PIL import Image

from ppaloc.cli import cli, main
from ppaloc.localise.base import Estimate

RESULT_KEYS = {
    "f1_max",
    "precision_at_f1",
    "recall_at_f1",
    "auc",
    "recall_at_100p",
    "precision_at_100r",
    "latency_ms_median",
    "latency_ms_p95",
    "modelled_latency_ms",
    "energy_mj",
    "recall_definition",
}


def run(capsys, *args: str) -> tuple[int, str, str]:
    """Run the command through the launch wrapper; return (exit code, stdout, stderr)."""
    code = main([str(a) for a in args])
    out, err = capsys.readouterr()
    return code, out, err


# -- help ------------------------------------------------------------------------------------


def test_help_shows_examples_and_commands():
    result = CliRunner().invoke(cli, ["--help"])
    assert result.exit_code == 0
    for word in ("demo", "evaluate", "map", "localise", "bench", "show", "Examples:"):
        assert word in result.output


def test_bare_command_prints_the_help_not_a_one_line_error(capsys):
    code, _, err = run(capsys)
    assert code == 2
    assert err.startswith("Usage: ppaloc [OPTIONS] COMMAND")
    assert "\nCommands:\n" in err and "error" not in err


def test_evaluate_help_lists_available_methods(mean_match):
    result = CliRunner().invoke(cli, ["evaluate", "--help"])
    assert result.exit_code == 0
    assert "Available methods" in result.output
    assert "mean-match" in result.output and "stand-in" in result.output
    assert "--tolerance" in result.output and "Examples:" in result.output


# -- evaluate ----------------------------------------------------------------------------------


def test_evaluate_writes_results_and_report(mean_match, tiny_spec, tmp_path, capsys):
    out = tmp_path / "run"
    code, stdout, err = run(
        capsys, "evaluate", "--dataset", tiny_spec, "--method", mean_match, "--out", out
    )
    assert code == 0, err
    summary = json.loads((out / "results.json").read_text())
    assert summary["dataset"] == tiny_spec and summary["tolerance"] == 1
    assert list(summary["methods"]) == [mean_match]
    assert RESULT_KEYS <= set(summary["methods"][mean_match])
    assert summary["methods"][mean_match]["recall_definition"] == "A"
    for name in ("results.csv", "report.html", "report.md"):
        assert (out / name).is_file()
    assert "R@100P" in stdout and "report:" in stdout


def test_config_file_with_flags_overriding(mean_match, tiny_spec, tmp_path, capsys):
    toml = tmp_path / "run.toml"
    toml.write_text(
        f'dataset = "{tiny_spec}"\n'
        f'methods = ["{mean_match}"]\n'
        "tolerance = 3\n"
        'recall = "B"\n'
        f'out = "{(tmp_path / "from-file").as_posix()}"\n'
        f"[params.{mean_match}]\n"
        "offset = 1\n"
        "[bench]\n"
        "sizes = [4]\n"  # another command's section is ignored
    )
    out = tmp_path / "from-flag"
    code, _, err = run(
        capsys, "evaluate", "--config", toml, "--tolerance", "0", "--out", out, "--no-report", "-q"
    )
    assert code == 0, err
    summary = json.loads((out / "results.json").read_text())
    assert summary["tolerance"] == 0  # the flag wins
    assert summary["methods"][mean_match]["recall_definition"] == "B"  # from the file
    assert summary["methods"][mean_match]["params"]["offset"] == 1
    assert summary["config"]["dataset"].endswith("tolerance=0")
    assert not (tmp_path / "from-file").exists() and not (out / "report.html").exists()


def test_param_flags_reach_the_method(mean_match, tiny_spec, tmp_path, capsys):
    out = tmp_path / "run"
    code, _, err = run(
        capsys,
        *("evaluate", "-d", tiny_spec, "-m", mean_match, "--out", out, "-q", "--no-report"),
        *("--param", f"{mean_match}.offset=2"),
    )
    assert code == 0, err
    z = np.load(out / "arrays" / f"{mean_match}.npz")
    assert z["node"][0] != 0 or z["node"][1] != 1  # shifted by 2 from the exact match


def test_a_param_flag_given_twice_with_two_values_is_refused(
    mean_match, tiny_spec, tmp_path, capsys
):
    # the later value was taken without a word
    out = tmp_path / "run"
    args = ("evaluate", "-d", tiny_spec, "-m", mean_match, "--out", out, "-q", "--no-report")
    code, _, err = run(
        capsys, *args, "--param", f"{mean_match}.offset=2", "--param", f"{mean_match}.offset=1"
    )
    assert (code, err) == (
        1,
        f"ppaloc: error: --param {mean_match}.offset is given twice (2, then 1): give it once\n",
    )
    assert not out.exists()
    code, _, err = run(capsys, "map", tiny_spec, "-m", mean_match, "--out", tmp_path / "m.npz",
                       "--param", "offset=2", "--param", "offset=3")  # fmt: skip
    assert (code, err) == (
        1,
        "ppaloc: error: --param offset is given twice (2, then 3): give it once\n",
    )
    code, _, err = run(capsys, "map", tiny_spec, "-m", mean_match, "--out", tmp_path / "m.npz",
                       "--param", "offset=2", "--param", "offset=2.0")  # fmt: skip
    assert (code, err) == (  # an integer and a float are two values
        1,
        "ppaloc: error: --param offset is given twice (2, then 2.0): give it once\n",
    )
    code, _, err = run(capsys, *args, "--param", f"{mean_match}.offset=2",
                       "--param", f" {mean_match}.offset = 2")  # fmt: skip
    assert code == 0, err  # the same value twice says one thing


def test_several_datasets_make_a_matrix(mean_match, tmp_path, capsys):
    a, b = "synthetic:?places=8&size=32&sync=1", "synthetic:?places=6&size=32&sync=1&seed=1"
    out = tmp_path / "m"
    code, _, err = run(
        capsys, "evaluate", "-d", a, "-d", b, "-m", mean_match, "--out", out, "-q", "--no-report"
    )
    assert code == 0, err
    rows = (out / "matrix.csv").read_text().splitlines()
    assert rows[0].startswith("dataset,folder,method,f1_max")
    assert [r.split(",")[0] for r in rows[1:]] == [a, b]
    assert (out / "01-synthetic-places-8-size-32-sync-1-365c8a84" / "results.json").is_file()
    assert len(list(out.glob("02-*/results.json"))) == 1
    code, stdout, err = run(capsys, "show", out)
    assert code == 0, err
    assert len(list(out.glob("*/report.html"))) == 2 and "matrix:" in stdout


# -- errors: one line, non-zero, no traceback ---------------------------------------------------


@pytest.mark.parametrize(
    ("args", "code", "message"),
    [
        (
            ["evaluate", "--dataset", "synthetic", "--method", "nope"],
            1,
            "ppaloc: error: method 'nope' is unknown; choose from: ",
        ),
        (
            ["evaluate", "--dataset", "nosuchkind:x"],
            1,
            "ppaloc: error: ",
        ),
        (["evaluate", "--method", "mean-match"], 1, "ppaloc: error: no dataset: give --dataset"),
        (["evaluate", "--frobnicate"], 1, "ppaloc evaluate: error: No such option"),
        (["nosuch"], 1, "ppaloc: error: No such command 'nosuch'"),
        (["bench", "--sizes", "4,x"], 1, "ppaloc: error: sizes '4,x' must be comma-separated"),
        (
            ["evaluate", "-d", "synthetic", "--param", "alpha=8"],
            1,
            "ppaloc: error: --param 'alpha=8' must look like METHOD.KEY=VALUE",
        ),
        (["show", "/nonexistent/run"], 1, "ppaloc: error: /nonexistent/run does not exist"),
        (
            ["evaluate", "-d", "synthetic", "-m", "mean-match", "--param", "mean-match.nope=1"],
            1,
            "ppaloc: error: method 'mean-match': unknown parameter 'nope'; its parameters: ",
        ),
        (
            ["evaluate", "-d", "synthetic", "--param", "no-such.alpha=1"],
            1,
            "ppaloc: error: params given for unknown method 'no-such'",
        ),
        (
            ["evaluate", "-d", "synthetic", "-m", "mean-match", "--recall", "D"],
            1,
            "ppaloc evaluate: error: Invalid value for '--recall'",
        ),
    ],
)
def test_user_errors_are_one_line(mean_match, capsys, args, code, message):
    got, _, err = run(capsys, *args)
    assert got == code
    assert err.startswith(message), err
    assert err.count("\n") == 1 and "Traceback" not in err


def test_unknown_config_key_is_named_before_a_missing_dataset(tmp_path, capsys):
    toml = tmp_path / "typo.toml"
    toml.write_text('datset = "synthetic"\n')
    code, _, err = run(capsys, "evaluate", "--config", toml)
    assert code == 1
    assert err.startswith(f"ppaloc: error: unknown configuration key 'datset' in {toml}; ")
    assert err.rstrip().endswith("params, out, no_report, quiet")  # every key the file may set


def test_method_params_in_a_config_file_must_be_a_table(tmp_path, capsys):
    toml = tmp_path / "loc.toml"
    toml.write_text("[localise]\nparams = [1]\n")
    code, _, err = run(capsys, "localise", tmp_path / "m.npz", tmp_path, "--config", toml)
    assert code == 1
    assert err == (
        f"ppaloc: error: params in {toml} must be a table of the method's keys, e.g. "
        "[localise.params] followed by gain = 8\n"
    )


def test_show_refuses_a_damaged_file_in_one_line(mean_match, tmp_path, capsys):
    spec = "synthetic:?places=12&size=32&sync=1"
    assert run(capsys, "map", spec, "-m", mean_match, "--out", tmp_path / "m.npz", "-q")[0] == 0
    data = (tmp_path / "m.npz").read_bytes()
    (tmp_path / "cut.npz").write_bytes(data[: len(data) // 2])
    (tmp_path / "text.npz").write_text("not an archive")
    for name in ("cut.npz", "text.npz"):
        code, _, err = run(capsys, "show", tmp_path / name)
        assert code == 1
        assert err == (
            f"ppaloc: error: {tmp_path / name} is not a readable .npz archive (not a zip file, "
            "or truncated); give a results folder, a map (.npz) or register planes (.npz)\n"
        )


def test_unknown_config_key_is_named(mean_match, tmp_path, capsys):
    toml = tmp_path / "bad.toml"
    toml.write_text('dataset = "synthetic"\ntolerence = 2\n')
    code, _, err = run(capsys, "evaluate", "--config", toml)
    assert code == 1
    assert err.startswith(f"ppaloc: error: unknown configuration key 'tolerence' in {toml}")


def test_a_bug_is_one_line_with_a_traceback_log(standin, monkeypatch, tiny_spec, tmp_path, capsys):
    class Broken(standin.MeanMatch):
        def step(self, frame: np.ndarray) -> Estimate:
            raise ZeroDivisionError("boom")

    monkeypatch.setattr(standin, "MeanMatch", Broken)
    name = standin.register(monkeypatch, "broken")
    monkeypatch.setenv("TMPDIR", str(tmp_path))
    import tempfile

    monkeypatch.setattr(tempfile, "tempdir", None)
    code, _, err = run(capsys, "evaluate", "-d", tiny_spec, "-m", name, "--out", tmp_path / "r")
    assert code == 3
    assert err.startswith("ppaloc: internal error (ZeroDivisionError: boom); this is a bug")
    assert err.count("\n") == 1
    log = Path(err.strip().rsplit(" ", 1)[-1])
    assert log.parent == tmp_path and "Traceback" in log.read_text()
    # an argument that is not UTF-8 (a file name of Latin-1 bytes) is in the log as an
    # escape: writing it failed, and the bug came out as a traceback after all
    monkeypatch.setattr(sys, "argv", ["ppaloc", "localise", "m.npz", "\udce9t\udce9.png"])
    code, _, err = run(capsys, "evaluate", "-d", tiny_spec, "-m", name, "--out", tmp_path / "r")
    assert code == 3 and err.count("\n") == 1
    log = Path(err.strip().rsplit(" ", 1)[-1])
    assert log.read_text(encoding="utf-8").startswith("ppaloc localise m.npz \\udce9t\\udce9.png\n")


# -- map, localise, bench, show, demo -------------------------------------------------------------


def _frames(folder: Path, n: int) -> list[Path]:
    folder.mkdir()
    paths = []
    for i in range(n):
        p = folder / f"q{i:02d}.png"
        Image.fromarray(np.full((24, 32), 20 * i + 10, np.uint8)).save(p)
        paths.append(p)
    return paths


def test_map_then_localise_streams_csv(mean_match, tmp_path, capsys):
    frames = _frames(tmp_path / "ref", 6)
    spec = f"folder:{tmp_path / 'ref'},{tmp_path / 'ref'}"
    code, out, err = run(capsys, "map", spec, "--method", mean_match, "--out", tmp_path / "m.npz")
    assert code == 0, err
    assert "6 mean nodes" in out
    csv_path = tmp_path / "est.csv"
    code, _, err = run(
        capsys, "localise", tmp_path / "m.npz", *frames[::-1], "--out", csv_path, "--keep-order"
    )
    assert code == 0, err
    lines = csv_path.read_text().splitlines()
    assert lines[0] == "frame,path,node,reference_frame,score,moved,latency_ms,reference_name"
    assert [int(line.split(",")[2]) for line in lines[1:]] == [5, 4, 3, 2, 1, 0]
    assert [line.split(",")[-1] for line in lines[1:]] == [f"q{i:02d}.png" for i in range(6)][::-1]
    # the folder form and stdout
    code, out, err = run(capsys, "localise", tmp_path / "m.npz", tmp_path / "ref")
    assert code == 0, err
    assert len(out.splitlines()) == 7


@pytest.mark.parametrize("method", ["weighted-node-lbp", "weighted-node-haar"])
def test_map_and_localise_with_a_real_method(method, tiny_spec, tmp_path, capsys):
    from ppaloc.methods import available_methods

    if method not in available_methods():
        pytest.skip(f"{method} is not available")
    code, _, err = run(capsys, "map", tiny_spec, "-m", method, "--out", tmp_path / "m.npz", "-q")
    assert code == 0, err
    frames = _frames(tmp_path / "q", 3)
    code, out, err = run(capsys, "localise", tmp_path / "m.npz", *frames)
    assert code == 0, err
    assert len(out.splitlines()) == 4
    code, _, err = run(capsys, "show", tmp_path / "m.npz", "--out", tmp_path / "m.png")
    assert code == 0, err
    with Image.open(tmp_path / "m.png") as im:
        assert im.size[0] >= 256
        grey = np.asarray(im.convert("L"))
    assert {0, 255} <= set(np.unique(grey).tolist())  # descriptor bits drawn black and white


def test_localise_keeps_the_maps_own_parameters_when_its_method_is_named(tmp_path, capsys):
    # `-m` naming the map's own method dropped the parameters the map was built with
    spec = "synthetic:?places=20&seed=1"
    m = tmp_path / "m.npz"
    method = "weighted-node-lowres"
    assert run(capsys, "map", spec, "-m", method, "--param", "contrast=0", "--out", m, "-q")[0] == 0
    frames = _frames(tmp_path / "q", 8)

    def rows(*extra: object) -> list[list[str]]:
        code, out, err = run(capsys, "localise", m, *frames, *extra)
        assert code == 0, err
        return [line.split(",")[2:5] for line in out.splitlines()[1:]]  # node, frame, score

    kept = rows()
    assert rows("-m", method) == kept
    assert rows("-m", method, "--param", "contrast=0") == kept
    assert rows("-m", method, "--param", "contrast=48") != kept  # the user's value wins


def test_map_localise_and_show_on_the_patch_place(tiny_spec, tmp_path, capsys):
    method = "weighted-node-patch"
    code, _, err = run(capsys, "map", tiny_spec, "-m", method, "--out", tmp_path / "m.npz", "-q")
    assert code == 0, err
    code, out, err = run(capsys, "localise", tmp_path / "m.npz", *_frames(tmp_path / "q", 3))
    assert code == 0, err
    assert len(out.splitlines()) == 4
    code, out, err = run(capsys, "show", tmp_path / "m.npz", "--out", tmp_path / "m.png")
    assert code == 0, err
    assert "patch nodes" in out and (tmp_path / "m.png").stat().st_size > 0


def test_map_builds_the_most_accurate_host_filters_map_by_default(tiny_spec, tmp_path, capsys):
    from ppaloc.topomap import load_map

    code, _, err = run(capsys, "map", tiny_spec, "--out", tmp_path / "m.npz", "-q")
    assert code == 0, err
    assert load_map(tmp_path / "m.npz").kind == "patch"


def test_a_map_of_one_node_is_named_in_the_singular(tmp_path, capsys):
    _frames(tmp_path / "ref", 1)
    code, out, err = run(capsys, "map", f"folder:{tmp_path / 'ref'}", "--out", tmp_path / "m.npz")
    assert code == 0, err
    assert "(1 patch node from" in out
    code, out, err = run(capsys, "show", tmp_path / "m.npz", "--out", tmp_path / "m.png")
    assert code == 0, err
    assert ": 1 patch node ->" in out


@pytest.mark.parametrize("kind", ["patch", "haar"])
def test_a_map_saved_from_python_is_localised_by_its_places_method(kind, tmp_path, capsys):
    from ppaloc.localise import WeightedNodeLocaliser

    rng = np.random.default_rng(3)
    ref = rng.integers(0, 256, (4, 256, 256), dtype=np.uint8)
    topomap = WeightedNodeLocaliser(kind, motion="always_forward").build_map(ref)
    assert "method" not in topomap.provenance  # built in Python: it names no method
    topomap.save(tmp_path / "m.npz")
    code, out, err = run(capsys, "localise", tmp_path / "m.npz", *_frames(tmp_path / "q", 2))
    assert code == 0, err
    assert len(out.splitlines()) == 3


def test_onsensor_auto_localises_a_map_of_any_place_it_chooses_among(tiny_spec, tmp_path, capsys):
    lbp = tmp_path / "lbp.npz"
    code, _, err = run(capsys, "map", tiny_spec, "-m", "weighted-node-lbp", "--out", lbp, "-q")
    assert code == 0, err
    frames = _frames(tmp_path / "q", 2)
    code, out, err = run(capsys, "localise", lbp, *frames, "-m", "onsensor-auto")
    assert code == 0, err  # it runs the map's own place (it asked for 16x16 nodes)
    assert len(out.splitlines()) == 3
    patch = tmp_path / "patch.npz"
    code, _, err = run(capsys, "map", tiny_spec, "-m", "weighted-node-patch", "--out", patch, "-q")
    assert code == 0, err
    code, _, err = run(capsys, "localise", patch, *frames, "-m", "onsensor-auto")
    assert code == 1 and "holds 'patch' nodes" in err and "weighted-node-patch" in err


def test_bench_writes_json(mean_match, tmp_path, capsys):
    code, out, err = run(
        capsys, "bench", "-m", mean_match, "--sizes", "4,8", "--queries", "2", "--out", tmp_path
    )
    assert code == 0, err
    rows = json.loads((tmp_path / "bench.json").read_text())["rows"]
    assert [r["n_nodes"] for r in rows] == [4, 8]
    assert "8 nodes" in out


def test_show_results_map_and_planes(mean_match, tiny_spec, tmp_path, capsys):
    run_dir = tmp_path / "run"
    assert (
        run(capsys, "evaluate", "-d", tiny_spec, "-m", mean_match, "--out", run_dir, "-q")[0] == 0
    )
    (run_dir / "report.html").unlink()
    code, out, err = run(capsys, "show", run_dir)
    assert code == 0, err
    assert (run_dir / "report.html").is_file() and "R@100P" in out
    # a map of a kind without a PE layout: drawn as a descriptor matrix
    spec = "synthetic:?places=6&size=32&sync=1"
    assert run(capsys, "map", spec, "-m", mean_match, "--out", tmp_path / "m.npz", "-q")[0] == 0
    code, _, err = run(capsys, "show", tmp_path / "m.npz")
    assert code == 0, err
    assert (tmp_path / "m.png").is_file()
    # register planes
    planes = tmp_path / "planes.npz"
    np.savez(planes, A=np.zeros((256, 256)), FLAG=np.ones((256, 256), bool))
    code, _, err = run(capsys, "show", planes, "--out", tmp_path / "p.png", "-q")
    assert code == 0, err
    with Image.open(tmp_path / "p.png") as im:
        assert im.size[0] > 512


def test_show_replaces_only_its_own_png_beside_the_input(mean_match, tmp_path, capsys):
    # `show m.npz` draws m.png beside it: it replaced a photo of the user's of that name
    spec = "synthetic:?places=6&size=32&sync=1"
    m = tmp_path / "m.npz"
    assert run(capsys, "map", spec, "-m", mean_match, "--out", m, "-q")[0] == 0
    photo = tmp_path / "m.png"
    Image.fromarray(np.full((4, 4), 7, np.uint8)).save(photo)
    kept = photo.read_bytes()
    code, _, err = run(capsys, "show", m, "-q")
    assert code == 1 and photo.read_bytes() == kept
    assert err.strip() == (
        f"ppaloc: error: {photo} exists and carries no mark of a plot ppaloc drew (PNG text "
        "'Software: ppaloc', which ppaloc's images carry since 2026-12-07): show would "
        f"replace it; give --out {photo} to replace it, or another name"
    )
    assert run(capsys, "show", m, "--out", photo, "-q")[0] == 0  # named: replaced
    code, _, err = run(capsys, "show", m, "-q")  # its own plot, drawn again in place
    assert code == 0, err
    planes = tmp_path / "planes.npz"  # a montage of planes is marked too
    np.savez(planes, A=np.zeros((8, 8)))
    assert run(capsys, "show", planes, "-q")[0] == 0
    assert run(capsys, "show", planes, "-q")[0] == 0


def test_show_and_localise_never_write_over_their_inputs(mean_match, tmp_path, capsys):
    spec = "synthetic:?places=6&size=32&sync=1"
    m = tmp_path / "m.npz"
    assert run(capsys, "map", spec, "-m", mean_match, "--out", m, "-q")[0] == 0
    saved = m.read_bytes()
    frames = tmp_path / "frames"
    frames.mkdir()
    for i in range(2):
        Image.fromarray(np.full((32, 32), 40 * i, np.uint8)).save(frames / f"f{i}.png")
    for argv in (
        ("show", m, "--out", m),
        ("localise", m, frames, "--out", m),
        ("localise", m, frames, "--out", frames / "f1.png"),
    ):
        code, _, err = run(capsys, *argv)
        assert code == 1 and "would overwrite the input" in err and err.count("\n") == 1
    assert m.read_bytes() == saved
    assert (frames / "f1.png").read_bytes()[:4] == b"\x89PNG"


def test_show_refuses_a_map_of_no_nodes(tmp_path, capsys):
    from ppaloc.topomap import TopoMap

    empty = TopoMap("lbp", np.zeros(0, np.uint32)).save(tmp_path / "z.npz")
    code, _, err = run(capsys, "show", empty)
    assert code == 1 and "is a map of 0 nodes: there is nothing to draw" in err


def test_show_refuses_planes_that_are_not_numbers(tmp_path, capsys):
    bad = tmp_path / "p.npz"
    np.savez(bad, A=np.zeros((4, 4)), T=np.array([["a", "b"]]))
    code, _, err = run(capsys, "show", bad)
    assert code == 1 and "array 'T' holds <U1 values, not numbers or bits" in err
    assert not (tmp_path / "p.png").exists()


def test_an_oracle_motion_run_takes_the_datasets_moves(mean_match, tiny_spec, tmp_path, capsys):
    argv = ["evaluate", "-d", "synthetic:?places=8&size=32", "-m", "weighted-node-lbp"]
    param = ["--param", 'weighted-node-lbp.motion="oracle"', "--no-report", "-q"]
    code, _, err = run(capsys, *argv, *param, "--out", tmp_path / "r")
    assert code == 0, err


def test_demo_end_to_end(mean_match, monkeypatch, tmp_path, capsys):
    import ppaloc.evaluate.run as run_module

    monkeypatch.setattr(run_module, "available_methods", lambda: [mean_match])
    out = tmp_path / "demo"
    code, stdout, err = run(capsys, "demo", "--out", out, "--places", "12", "--bench-sizes", "4,8")
    assert code == 0, err
    summary = json.loads((out / "results.json").read_text())
    assert summary["dataset"].startswith("synthetic:?places=12&query=winter")
    assert (out / "bench.json").is_file() and (out / "report.html").is_file()
    assert "demo done" in stdout


# -- the installed console script -----------------------------------------------------------------


def _script() -> str:
    exe = Path(sys.executable).with_name("ppaloc")
    if not exe.is_file():
        pytest.skip("the ppaloc console script is not installed next to this python")
    return str(exe)


def test_console_script_errors_without_traceback(tmp_path):
    env = {**os.environ, "COLUMNS": "100"}
    done = subprocess.run(
        [_script(), "evaluate", "--dataset", "synthetic", "--method", "no-such-method"],
        capture_output=True,
        text=True,
        cwd=tmp_path,
        env=env,
        timeout=60,
        check=False,
    )
    assert done.returncode == 1
    assert done.stderr.startswith("ppaloc: error: method 'no-such-method' is unknown")
    assert done.stderr.count("\n") == 1 and "Traceback" not in done.stderr
    assert not list(tmp_path.iterdir())  # nothing written into the working directory
    ok = subprocess.run(
        [_script(), "--version"], capture_output=True, text=True, timeout=60, check=False
    )
    assert ok.returncode == 0 and "ppaloc" in ok.stdout


@pytest.mark.slow
def test_demo_runs_every_available_method(tmp_path, capsys):
    from ppaloc.methods import available_methods

    out = tmp_path / "demo"
    code, _, err = run(capsys, "demo", "--out", out, "--places", "12", "--bench-sizes", "8", "-q")
    assert code == 0, err
    summary = json.loads((out / "results.json").read_text())
    assert list(summary["methods"]) == available_methods()
    for name, m in summary["methods"].items():
        assert 0.0 <= m["f1_max"] <= 1.0 and m["latency_ms_median"] > 0, name
        assert (m["modelled_latency_ms"] is not None) == name.startswith("onsensor"), name
    assert (out / "report.html").is_file() and (out / "report.md").is_file()


@pytest.mark.data
def test_evaluate_on_a_nordland_slice(nordland_dir, tmp_path, capsys):
    from ppaloc.methods import available_methods

    method = "single-frame" if "single-frame" in available_methods() else None
    if method is None:
        pytest.skip("single-frame is not available")
    spec = f"nordland:{nordland_dir}?ref=summer&query=winter&stop=40"
    out = tmp_path / "n"
    code, _, err = run(capsys, "evaluate", "-d", spec, "-m", method, "--out", out, "-q")
    assert code == 0, err
    summary = json.loads((out / "results.json").read_text())
    assert summary["n_queries"] == 40 and summary["n_reference"] == 40
    assert 0.0 <= summary["methods"][method]["f1_max"] <= 1.0


def test_warm_up_without_numba_is_one_line(monkeypatch, capsys):
    import ppaloc.sim.engines as engines

    monkeypatch.setattr(engines, "available_engines", lambda: ["reference", "numpy"])
    assert main(["warm-up"]) == 1
    err = capsys.readouterr().err
    assert err.startswith("ppaloc: error: ppaloc warm-up compiles the simulator's numba code")
    assert len(err.splitlines()) == 1 and "ppaloc[fast]" in err


def test_warm_up_runs_the_pipelines_then_waits_for_their_compiles(monkeypatch, capsys):
    """`ppaloc warm-up` runs every on-sensor pipeline, then compiles in the foreground
    (here the runs and the compiles are counted, not made)."""
    import ppaloc.onsensor.warm as warm

    calls = []

    class Counted:
        def __init__(self, rep, **kw):
            calls.append((rep, kw["preset"], kw["noise"]))

        def build_map(self, frames):
            assert len(frames) == 24

        def step(self, frame):
            pass

    monkeypatch.setattr(warm, "OnSensorLocaliser", Counted)
    monkeypatch.setattr(warm, "finish_compiles", lambda progress: 2)
    assert main(["warm-up"]) == 0
    assert sorted(calls) == sorted(warm.CONFIGS)
    assert ("lowres16", "robust", "typical") in calls and (
        "lowres16",
        "paper",
        "ideal",
    ) not in calls
    assert f"compiled {2 * len(warm.CONFIGS)} fused stretches" in capsys.readouterr().out
