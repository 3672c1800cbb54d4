"""Runs, result files and bench on the stand-in method and the tiny dataset."""

from __future__ import annotations

import csv
import json

import numpy as np
import pytest

from ppaloc.errors import DataError, PpalocError
from ppaloc.evaluate.bench import load_bench, run_bench, save_bench
from ppaloc.evaluate.config import (
    BenchConfig,
    EvaluateConfig,
    config_from_mapping,
    read_toml,
    with_tolerance,
)
from ppaloc.evaluate.results import CSV_COLUMNS, load_results, save_results
from ppaloc.evaluate.run import resolve_methods, run_evaluation, run_method, sensor_frames

REQUIRED = {
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


def test_sensor_frames_reports_progress_per_frame():
    frames = [np.full((4, 6), v, dtype=np.uint8) for v in (0, 7, 255)]
    calls = []
    out = sensor_frames(frames, lambda task, done: calls.append((task, done)), task="ref")
    assert calls == [("ref", 1), ("ref", 2), ("ref", 3)]
    assert [f.shape for f in out] == [(256, 256)] * 3
    assert [int(f[0, 0]) for f in out] == [0, 7, 255]


def test_run_method_arrays_and_metrics(standin, tiny):
    loc = standin.MeanMatch(record_weights=True)
    ref, qry = sensor_frames(tiny.reference), sensor_frames(tiny.query)
    run = run_method(
        "mean-match",
        ref,
        qry,
        tiny.ground_truth,
        localiser=loc,
        reference_positions=tiny.reference_positions,
        query_positions=tiny.query_positions,
    )
    assert loc.steps == len(qry)  # every query frame stepped exactly once
    np.testing.assert_array_equal(run.node, np.arange(10))
    np.testing.assert_array_equal(run.ref_index, np.arange(10))
    assert run.moved.tolist() == [-1] * 10
    assert run.ranking.shape == (10, 3) and run.ranking[:, 0].tolist() == list(range(10))
    assert run.weights.shape == (10, 10) and run.weights.dtype == np.float32
    assert run.latency_ms.shape == (10,) and (run.latency_ms > 0).all()
    assert run.modelled_latency_ms is None and run.energy_mj is None
    m = run.metrics
    # nine queries with a true match, all correct; the last has none (wrong by definition)
    assert (m.n_with_match, m.n_correct, m.precision_at_100r) == (9, 9, 0.9)
    assert m.recall_at_100p == 1.0 and m.f1_max == 1.0
    assert m.error_m_median == pytest.approx(1.0)  # query positions are 1 m off
    assert m.recall_at_k.tolist() == [1.0, 1.0, 1.0]


def test_run_method_maps_nodes_through_frame_index(standin, tiny):
    class Keyframed(standin.MeanMatch):
        def build_map(self, frames):
            topomap = super().build_map(frames[::2])
            topomap.frame_index = np.arange(0, len(frames), 2)
            return topomap

    ref, qry = sensor_frames(tiny.reference), sensor_frames(tiny.query)
    run = run_method("k", ref, qry, tiny.ground_truth, localiser=Keyframed())
    assert run.n_nodes == 5
    # node j stands for frames 2j and 2j + 1, and predicts its own frame, 2j, whatever
    # the ground truth says
    assert run.ref_index.tolist() == (2 * run.node).tolist()
    assert run.ranking.max() <= 8
    strict = [np.array([2 * int(n) + 1]) for n in run.node]  # the other frame of each span
    again = run_method("k", ref, qry, strict, localiser=Keyframed())
    assert again.ref_index.tolist() == run.ref_index.tolist()
    assert again.metrics.precision_at_100r == 0.0


def test_predictions_do_not_depend_on_the_tolerance():
    """Every method predicts the same reference frames at tolerance 1 and 3 (a reference
    stop merged into one node by the keyframe maps included)."""
    from ppaloc.datasets import load_dataset

    spec = "synthetic:?places=24&query=winter&seed=3&sync=1&stops=1"
    methods = ["weighted-node-lowres", "weighted-node-lbp", "seqslam", "single-frame"]
    predicted = []
    for tol in (1, 3):
        ds = load_dataset(f"{spec}&tolerance={tol}")
        stop = [*ds.reference[:8], *[ds.reference[8]] * 4, *ds.reference[9:]]
        ds.reference = stop  # a reference that stands still for 4 frames
        ds.reference_positions = ds.query_positions = None
        ds.ground_truth = [np.where(g > 8, g + 3, g) for g in ds.ground_truth]
        config = EvaluateConfig(dataset=spec, methods=methods)
        result = run_evaluation(config, dataset=ds, progress=False)
        predicted.append({m: r.ref_index.tolist() for m, r in result.runs.items()})
        assert result.runs["weighted-node-lowres"].n_nodes < len(stop)
        assert result.protocol["prediction"].startswith("one reference frame per query")
    assert predicted[0] == predicted[1]


def test_weights_dropped_above_the_limit(standin, tiny):
    ref, qry = sensor_frames(tiny.reference), sensor_frames(tiny.query)
    loc = standin.MeanMatch(record_weights=True)
    run = run_method("m", ref, qry, tiny.ground_truth, localiser=loc, max_weight_values=99)
    assert run.weights is None


def test_modelled_latency_and_energy_summarised(standin, tiny):
    ref, qry = sensor_frames(tiny.reference), sensor_frames(tiny.query)
    loc = standin.MeanMatch(modelled=True)
    run = run_method("m", ref, qry, tiny.ground_truth, localiser=loc)
    s = run.summary()
    assert s["modelled_latency_ms"] == 0.25 and s["energy_mj"] == pytest.approx(0.002)
    assert list(run.registers) == ["A: ramp", "R5: bits"]
    assert run.registers["R5: bits"].dtype == bool


def test_evaluation_through_the_registry_passes_seed_and_weights(mean_match, tiny):
    cfg = EvaluateConfig(methods=(mean_match,), seed=7, params={mean_match: {"offset": 1}})
    result = run_evaluation(cfg, dataset=tiny, progress=False)
    run = result.runs[mean_match]
    assert run.params == {"offset": 1, "seed": 7, "record_weights": True}
    np.testing.assert_array_equal(run.node, (np.arange(10) + 1) % 10)
    assert run.weights is not None
    assert result.dataset == "tiny" and result.tolerance == 1


def test_results_files_round_trip(mean_match, tiny, tmp_path):
    result = run_evaluation(EvaluateConfig(methods=(mean_match,)), dataset=tiny, progress=False)
    path = save_results(result, tmp_path / "out")
    summary = json.loads(path.read_text())
    assert {"dataset", "tolerance", "methods"} <= set(summary)
    assert REQUIRED <= set(summary["methods"][mean_match])
    assert summary["methods"][mean_match]["modelled_latency_ms"] is None
    assert summary["ppaloc_version"] and summary["config"]["methods"] == [mean_match]
    with open(tmp_path / "out" / "results.csv") as f:
        rows = list(csv.reader(f))
    assert rows[0] == CSV_COLUMNS and rows[1][0] == mean_match
    assert float(rows[1][1]) == pytest.approx(1.0)
    assert "registers" not in summary["methods"][mean_match]  # a host method has none
    back, _ = load_results(tmp_path / "out")
    a, b = result.runs[mean_match], back.runs[mean_match]
    for key in ("node", "ref_index", "score", "moved", "ranking", "latency_ms", "weights"):
        np.testing.assert_array_equal(getattr(a, key), getattr(b, key))
    assert b.metrics.f1_max == a.metrics.f1_max and b.metrics.auc == a.metrics.auc
    assert [g.tolist() for g in back.ground_truth] == [g.tolist() for g in result.ground_truth]
    assert not list((tmp_path / "out").rglob("*.tmp"))  # atomic writes leave nothing behind
    from ppaloc.fileio import default_file_mode

    assert (tmp_path / "out" / "results.json").stat().st_mode & 0o777 == default_file_mode()


def test_damaged_results_are_named_not_crashed_on(mean_match, tiny, tmp_path):
    result = run_evaluation(EvaluateConfig(methods=(mean_match,)), dataset=tiny, progress=False)
    out = tmp_path / "out"
    path = save_results(result, out)
    arrays = out / "arrays" / f"{mean_match}.npz"
    arrays.write_bytes(arrays.read_bytes()[:300])
    with pytest.raises(DataError, match=rf"{out} is not whole: arrays/{mean_match}.npz does not"):
        load_results(out)
    summary = json.loads(path.read_text())
    del summary["files"]  # a folder of an older ppaloc, without checksums
    path.write_text(json.dumps(summary))
    with pytest.raises(DataError, match=rf"cannot read {arrays} \(.*\); run `ppaloc evaluate"):
        load_results(out)
    path.write_text('{"methods": {}}')
    with pytest.raises(DataError, match=r"results.json has no 'dataset' entry; give a folder"):
        load_results(out)


def test_same_seed_same_result_bytes(mean_match, tiny, tmp_path):
    for name in ("a", "b"):
        r = run_evaluation(EvaluateConfig(methods=(mean_match,)), dataset=tiny, progress=False)
        save_results(r, tmp_path / name)
    for name in ("a", "b"):
        z = np.load(tmp_path / name / "arrays" / f"{mean_match}.npz")
        assert z["node"].tolist() == list(range(10))


def test_resolve_methods_messages(mean_match):
    assert mean_match in resolve_methods([])
    assert resolve_methods([mean_match, mean_match]) == [mean_match]
    with pytest.raises(PpalocError, match=r"method 'nope' is unknown; choose from: .*mean-match"):
        resolve_methods(["nope"])


def test_config_rejects_unknown_keys_and_bad_values(tmp_path):
    with pytest.raises(PpalocError, match=r"unknown configuration key 'tolerence' in x.toml"):
        config_from_mapping(EvaluateConfig, {"tolerence": 2}, source="x.toml")
    with pytest.raises(PpalocError, match=r"recall='D' must be one of A, B, C"):
        EvaluateConfig(recall="D")
    with pytest.raises(PpalocError, match=r"tolerance=-1 must be an integer in \[0, 1000\]"):
        EvaluateConfig(tolerance=-1)
    with pytest.raises(PpalocError, match=r"sizes=1 must be an integer in \[2, 262144\]"):
        BenchConfig(sizes=(1,))
    for cls, key, value, words in [
        (EvaluateConfig, "methods", 3, "a list of strings"),
        (EvaluateConfig, "tolerance", "x", "an integer"),
        (EvaluateConfig, "seed", True, "an integer"),
        (EvaluateConfig, "dataset", 5, "a string"),
        (BenchConfig, "sizes", "a", "a list of integers"),
        (BenchConfig, "max_build_s", "1", "a number"),
    ]:
        with pytest.raises(PpalocError, match=rf"^{key}={value!r} in x.toml must be {words}$"):
            config_from_mapping(cls, {key: value}, source="x.toml")
    assert config_from_mapping(BenchConfig, {"max_build_s": 2, "sizes": [4]}).max_build_s == 2
    bad = tmp_path / "bad.toml"
    bad.write_text("dataset = \n")
    with pytest.raises(PpalocError, match=r"bad.toml is not valid TOML"):
        read_toml(bad)
    with pytest.raises(PpalocError, match=r"config file .*missing.toml does not exist"):
        read_toml(tmp_path / "missing.toml")
    # a file an editor saved as UTF-8 with a byte-order mark (Windows Notepad) is UTF-8 too
    bom = tmp_path / "bom.toml"
    bom.write_bytes(b"\xef\xbb\xbfseed = 3\n")
    assert read_toml(bom) == {"seed": 3}


def test_with_tolerance():
    assert with_tolerance("synthetic", 2) == "synthetic:?tolerance=2"
    assert with_tolerance("a:b?x=1&tolerance=0&y=2", 3) == "a:b?x=1&y=2&tolerance=3"
    assert EvaluateConfig(dataset="a:b", tolerance=2).resolved_dataset() == "a:b?tolerance=2"


def test_bench_rows_and_files(mean_match, tmp_path):
    cfg = BenchConfig(methods=(mean_match,), sizes=(4, 8), queries=3, warmup=1)
    calls = []
    bench = run_bench(cfg, progress=lambda name, done: calls.append((name, done)))
    assert calls == [(mean_match, 1), (mean_match, 2)]
    assert [(r["method"], r["n_nodes"], r["queries"]) for r in bench["rows"]] == [
        (mean_match, 4, 3),
        (mean_match, 8, 3),
    ]
    assert all(r["latency_ms_p95"] >= r["latency_ms_median"] > 0 for r in bench["rows"])
    save_bench(bench, tmp_path / "bench.json")
    assert load_bench(tmp_path / "bench.json")["rows"] == bench["rows"]
    assert (tmp_path / "bench.csv").read_text().startswith("method,n_nodes,")
    assert load_bench(tmp_path / "none.json") is None
    (tmp_path / "cut.json").write_text('{"rows": [')
    with pytest.raises(DataError, match=r"cut.json \(.*\); delete it or run `ppaloc bench` again"):
        load_bench(tmp_path / "cut.json")
    (tmp_path / "other.json").write_text("[1, 2]")
    with pytest.raises(DataError, match=r"other.json has no 'rows' list; it was not written by"):
        load_bench(tmp_path / "other.json")


def test_bench_records_sizes_a_method_refuses(standin, monkeypatch):
    class Small(standin.MeanMatch):
        def build_map(self, frames):
            if len(frames) > 4:
                raise PpalocError(f"{len(frames)} nodes do not fit; split the route")
            return super().build_map(frames)

    monkeypatch.setattr(standin, "MeanMatch", Small)
    name = standin.register(monkeypatch, "small")
    rows = run_bench(BenchConfig(methods=(name,), sizes=(4, 8), queries=2))["rows"]
    assert "latency_ms_median" in rows[0]
    assert rows[1] == {
        "method": name,
        "n_nodes": 8,
        "skipped": "8 nodes do not fit; split the route",
    }


def test_progress_bar_is_silent_off_a_terminal(mean_match, tiny, capfd):
    run_evaluation(EvaluateConfig(methods=(mean_match,)), dataset=tiny, progress=True)
    out, err = capfd.readouterr()
    assert out == "" and err == ""


def test_register_planes_round_trip(standin, monkeypatch, tiny, tmp_path):
    name = standin.register(monkeypatch, "sensor", modelled=True)
    result = run_evaluation(EvaluateConfig(methods=(name,)), dataset=tiny, progress=False)
    summary = json.loads(save_results(result, tmp_path).read_text())
    assert summary["methods"][name]["registers"] == f"arrays/{name}.registers.npz"
    back, _ = load_results(tmp_path)
    planes = back.runs[name].registers
    assert list(planes) == ["A: ramp", "R5: bits"]
    np.testing.assert_array_equal(planes["A: ramp"], result.runs[name].registers["A: ramp"])
    assert planes["R5: bits"].dtype == bool


def test_register_planes_of_a_real_onsensor_localiser():
    from ppaloc.evaluate.run import register_planes
    from ppaloc.methods import available_methods, make_localiser

    if "onsensor-lbp" not in available_methods():
        pytest.skip("onsensor-lbp is not available")
    loc = make_localiser("onsensor-lbp")
    frames = [np.full((256, 256), 16 * i, np.uint8) for i in range(4)]
    loc.build_map(frames)
    loc.reset()
    loc.step(frames[1])
    planes = register_planes(loc)
    assert "C: weights" in planes and "R10: map tile 0" in planes
    assert all(p.shape == (256, 256) for p in planes.values())


def test_oracle_motion_reads_the_dataset(tiny):
    from ppaloc.methods import available_methods

    if "weighted-node-lbp" not in available_methods():
        pytest.skip("weighted-node-lbp is not available")
    params = {"weighted-node-lbp": {"motion": "oracle"}}
    cfg = EvaluateConfig(
        dataset="synthetic:?places=12&size=32&seed=2", methods=("weighted-node-lbp",), params=params
    )
    run = run_evaluation(cfg, progress=False).runs["weighted-node-lbp"]
    assert run.motion_accuracy == 1.0
    assert run.params["oracle_moves"] == "dataset query_moved"
    with pytest.raises(PpalocError, match=r"motion='oracle' needs the true query motion"):
        run_evaluation(EvaluateConfig(methods=("weighted-node-lbp",), params=params), dataset=tiny)


def test_bad_parameters_fail_before_any_data_is_loaded(mean_match):
    cfg = EvaluateConfig(
        dataset="nosuchkind:x", methods=(mean_match,), params={mean_match: {"x": 1}}
    )
    with pytest.raises(PpalocError, match=r"method 'mean-match': .*'x'"):
        run_evaluation(cfg, progress=False)


def test_bench_skips_sizes_over_the_build_budget(standin, monkeypatch):
    import time

    class Slow(standin.MeanMatch):
        def build_map(self, frames):
            time.sleep(0.01 * len(frames))  # 10 ms per node
            return super().build_map(frames)

    monkeypatch.setattr(standin, "MeanMatch", Slow)
    name = standin.register(monkeypatch, "slow")
    cfg = BenchConfig(methods=(name,), sizes=(2, 4, 64), queries=1, warmup=0, max_build_s=0.3)
    rows = run_bench(cfg)["rows"]
    assert [("skipped" in r) for r in rows] == [False, False, True]
    assert rows[2]["skipped"].startswith("building 64 nodes would take about")


def test_infinite_scores_and_partly_modelled_frames_stay_strict_json(standin, tiny, tmp_path):
    class Odd(standin.MeanMatch):
        def step(self, frame):
            est = super().step(frame)
            lat = 0.5 if self.steps % 2 else None  # only every other frame modelled
            score = float("inf") if self.steps == 1 else est.score
            return type(est)(node=est.node, score=score, modelled_latency_ms=lat)

    result = run_evaluation(
        EvaluateConfig(), dataset=tiny, localisers={"odd": Odd()}, progress=False
    )
    summary = json.loads(save_results(result, tmp_path).read_text())  # strict parse
    assert summary["methods"]["odd"]["modelled_latency_ms"] == 0.5
