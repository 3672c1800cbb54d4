"""The offline method ``seqslam-centred`` through everything that steps a localiser (an
evaluation, ``map`` + ``localise``, ``bench``): each hands it the whole query first, and
the tables and the report label it offline."""

from __future__ import annotations

import json

import numpy as np
from PIL import Image

from ppaloc.cli.main import main
from ppaloc.datasets import load_dataset
from ppaloc.evaluate import EvaluateConfig, load_results, run_evaluation, save_results
from ppaloc.evaluate.report import write_report


def run(capsys, *args) -> tuple[int, str, str]:
    code = main([str(a) for a in args])
    out, err = capsys.readouterr()
    return code, out, err


def test_map_then_localise_reads_the_frames_ahead(tmp_path, capsys) -> None:
    spec = "synthetic:?places=16&size=32&sync=1&stops=0"
    code, _, err = run(capsys, "map", spec, "-m", "seqslam-centred", "--out", tmp_path / "m.npz")
    assert code == 0, err
    rng = np.random.default_rng(0)
    (tmp_path / "q").mkdir()
    frames = []
    for i in range(8):
        frames.append(tmp_path / "q" / f"q{i}.png")
        Image.fromarray(rng.integers(0, 256, (32, 32), dtype=np.uint8)).save(frames[-1])
    code, out, err = run(capsys, "localise", tmp_path / "m.npz", "-m", "seqslam-centred", *frames)
    assert code == 0, err
    assert len(out.splitlines()) == 9  # the header and one line per frame


def test_bench_times_the_offline_method(tmp_path, capsys) -> None:
    code, _, err = run(
        capsys, "bench", "-m", "seqslam-centred", "--sizes", "8", "--queries", "3",
        "--out", tmp_path, "-q",
    )  # fmt: skip
    assert code == 0, err
    (row,) = json.loads((tmp_path / "bench.json").read_text())["rows"]
    assert row["method"] == "seqslam-centred" and row["latency_ms_median"] > 0


def test_the_centred_method_is_run_offline_and_labelled(tmp_path) -> None:
    route = load_dataset("synthetic:?places=40&query=winter&seed=1&stops=0&size=64")
    cfg = EvaluateConfig(methods=("seqslam-centred",), record_weights=False)
    result = run_evaluation(cfg, dataset=route, progress=False)
    run = result.runs["seqslam-centred"]
    assert run.reads_future and run.params["mode"] == "centred"
    save_results(result, tmp_path / "out")
    write_report(tmp_path / "out")
    md = (tmp_path / "out" / "report.md").read_text()
    assert "seqslam-centred (offline: reads future frames)" in md
    assert "seqslam-centred is offline: its estimate for a frame reads frames after it" in md
    assert load_results(tmp_path / "out")[0].runs["seqslam-centred"].reads_future
