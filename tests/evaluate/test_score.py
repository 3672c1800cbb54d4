"""ppaloc.evaluate.score: predictions read from a file are measured exactly as a run is."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from PIL import Image

from ppaloc.datasets import RouteDataset, load_dataset
from ppaloc.datasets.frames import ImageFrames, RenderedFrames
from ppaloc.errors import DataError
from ppaloc.evaluate import evaluate_estimates
from ppaloc.evaluate.results import load_results, save_results
from ppaloc.evaluate.score import (
    PREDICTION_FROM_FILE,
    ScoreConfig,
    read_predictions,
    score_predictions,
)

from ..datasets.test_loaders import _write_video


def _dataset(n: int = 4, tolerance: int = 0, m: int | None = None) -> RouteDataset:
    """``n`` rendered reference frames and ``m`` (default ``n``) query frames; query ``i``
    matches reference ``i`` (within ``tolerance``)."""
    frame = np.zeros((8, 8), np.uint8)
    m = n if m is None else m
    truth = [np.arange(max(0, i - tolerance), min(n, i + tolerance + 1)) for i in range(m)]
    return RouteDataset(
        "tiny",
        RenderedFrames(lambda i: frame, n),
        RenderedFrames(lambda i: frame, m),
        truth,
        tolerance=tolerance,
        meta={"spec": "tiny"},
    )


def _write(path: Path, text: str) -> Path:
    path.write_text(text)
    return path


def test_a_hand_computed_golden(tmp_path):
    # q0 -> 0 (right, 0.9), q1 -> 1 (right, 0.8), q2 -> 0 (wrong, 0.7), q3 -> 3 (right, 0.1):
    # thresholds 0.9, 0.8, 0.7, 0.1 give (P, R) = (1, 1/4), (1, 2/4), (2/3, 2/4), (3/4, 3/4)
    f = _write(tmp_path / "mine.csv", "query,reference,score\n2,0,0.7\n0,0,0.9\n3,3,0.1\n1,1,0.8\n")
    result = score_predictions(ScoreConfig("tiny", (str(f),)), dataset=_dataset())
    run = result.runs["mine"]
    assert run.ref_index.tolist() == [0, 1, 0, 3]  # ordered by query, not by row
    assert run.score.tolist() == [0.9, 0.8, 0.7, 0.1]
    m = run.metrics
    assert m.f1_max == pytest.approx(0.75)
    assert m.recall_at_100p == pytest.approx(0.5)
    assert m.precision_at_100r == pytest.approx(0.75)
    assert m.curve.precision.tolist() == pytest.approx([1, 1, 2 / 3, 3 / 4])
    assert run.ranking.shape == (4, 0) and np.isnan(run.latency_ms).all()
    assert (run.moved == -1).all() and run.build_s is None
    assert result.protocol["prediction"] == PREDICTION_FROM_FILE
    assert result.config["command"] == "score" and result.config["methods"] == ["mine"]


def test_a_result_of_predictions_round_trips_through_the_results_files(tmp_path):
    f = _write(
        tmp_path / "p.csv",
        "method,query,reference,reference_2,score,latency_ms,moved\n"
        "a,0,0,1,0.9,1.5,0\na,1,2,1,0.5,2.5,1\nb,1,1,,0.2,,\nb,0,3,,0.4,,\n",
    )
    result = score_predictions(ScoreConfig("tiny", (str(f),)), dataset=_dataset(m=2))
    assert list(result.runs) == ["a", "b"]
    a, b = result.runs["a"], result.runs["b"]
    assert a.ranking.tolist() == [[0, 1], [2, 1]] and a.metrics.recall_at_k.tolist() == [0.5, 1.0]
    assert a.latency_ms.tolist() == [1.5, 2.5] and a.moved.tolist() == [0, 1]
    assert b.ref_index.tolist() == [3, 1] and b.ranking.tolist() == [[3, -1], [1, -1]]
    save_results(result, tmp_path / "out")
    summary = json.loads((tmp_path / "out" / "results.json").read_text())
    assert summary["methods"]["b"]["latency_ms_median"] is None
    assert summary["methods"]["a"]["latency_ms_median"] == 2.0
    assert summary["methods"]["a"]["build_s"] is None
    back, _ = load_results(tmp_path / "out")
    assert back.runs["a"].metrics.f1_max == a.metrics.f1_max
    assert back.runs["b"].build_s is None


def test_a_localise_csv_is_read_as_it_is(tmp_path):
    f = _write(
        tmp_path / "est.csv",
        "frame,path,node,reference_frame,score,moved,latency_ms,reference_name\n"
        "0,q/a.png,3,3,1.5,0,0.5,\n1,q/b.png,0,0,2,1,0.25,\n2,q/c.png,2,2,3,,1,\n"
        "3,q/d.png,3,3,4,1,1,\n",
    )
    (p,) = read_predictions(f)
    assert p.label == "est"
    assert p.queries["query"] == ["0", "1", "2", "3"]
    assert p.queries["query_name"][:2] == ["q/a.png", "q/b.png"]
    assert p.references[0] == {"reference": ["3", "0", "2", "3"], "reference_name": [""] * 4}
    assert p.moved.tolist() == [0, 1, -1, 1] and p.latency_ms.tolist() == [0.5, 0.25, 1, 1]
    # a dataset without frame names: the indices are used (the empty names ignored)
    run = score_predictions(ScoreConfig("t", (str(f),)), dataset=_dataset(n=4)).runs["est"]
    assert run.ref_index.tolist() == [3, 0, 2, 3] and run.metrics.precision_at_100r == 0.5
    assert run.motion_accuracy is None  # the dataset does not know the true motion


def _folders(tmp_path: Path, n: int = 5) -> tuple[Path, Path]:
    ref, query = tmp_path / "ref", tmp_path / "query"
    for folder in (ref, query):
        folder.mkdir()
        for i in range(n):
            Image.fromarray(np.full((4, 4), i, np.uint8)).save(folder / f"img{i}.png")
    return ref, query


def test_names_are_matched_where_the_dataset_has_files(tmp_path):
    ref, query = _folders(tmp_path, 5)
    spec = f"folder:{ref},{query}?start=1"  # the selection shifts every index by one
    ds = load_dataset(spec)
    assert isinstance(ds.query, ImageFrames) and ds.query.names()[0] == "img1.png"
    f = _write(
        tmp_path / "p.csv",
        "frame,path,reference_frame,reference_name,score\n"
        # localise's frame and reference_frame count from its own first frame: wrong here;
        # the names are right, and are what is used
        + "".join(f"{i},{query}/img{i + 1}.png,{i},img{i + 1}.png,1\n" for i in range(4)),
    )
    run = score_predictions(ScoreConfig(spec, (str(f),))).runs["p"]
    assert run.ref_index.tolist() == [0, 1, 2, 3] and run.metrics.precision_at_100r == 1.0


def test_a_video_frame_is_named_by_its_file_and_index(tmp_path):
    path = tmp_path / "v.mp4"
    _write_video(path, [np.full((32, 32), 50 * i, np.uint8) for i in range(4)], fps=5)
    ds = load_dataset(f"video:{path},{path}?step=2")
    assert ds.reference.names() == ["v.mp4#0", "v.mp4#2"]


def test_a_dataset_without_names_refuses_a_name_column(tmp_path):
    f = _write(tmp_path / "p.csv", "query_name,reference,score\na.png,0,1\n")
    with pytest.raises(DataError) as info:
        score_predictions(ScoreConfig("t", (str(f),)), dataset=_dataset())
    assert str(info.value) == (
        f"{f}: query_name needs frame names, and the query frames of 'tiny' have none "
        "(rendered frames); give query indices (query column)"
    )


rows = st.lists(
    st.tuples(st.integers(0, 5), st.floats(-100, 100, allow_nan=False, width=32)),
    min_size=6,
    max_size=6,
)


@settings(max_examples=40, deadline=None)
@given(rows=rows, order=st.permutations(range(6)), tolerance=st.integers(0, 2))
def test_any_row_order_scores_as_the_arrays_do(tmp_path_factory, rows, order, tolerance):
    """The file's row order never matters: the metrics are those of the arrays by query."""
    ds = _dataset(n=6, tolerance=tolerance)
    folder = tmp_path_factory.mktemp("p")
    lines = [f"{q},{rows[q][0]},{rows[q][1]!r}" for q in order]
    f = _write(folder / "m.csv", "query,reference,score\n" + "\n".join(lines) + "\n")
    run = score_predictions(ScoreConfig("t", (str(f),)), dataset=ds).runs["m"]
    ref = np.array([r for r, _ in rows])
    score = np.array([s for _, s in rows], dtype=np.float64)
    want = evaluate_estimates(ref, score, ds.ground_truth)
    assert run.metrics.f1_max == want.f1_max and run.metrics.auc == want.auc
    assert run.metrics.curve.recall.tolist() == want.curve.recall.tolist()


def test_a_file_of_many_methods_draws_the_best_in_each_figure(tmp_path, monkeypatch):
    # a panel, curve or box per label: a file of hundreds of labels took minutes to lay
    # out (the position figure alone, 150 rows of panels)
    from ppaloc.evaluate import figures
    from ppaloc.evaluate.report import _figures

    monkeypatch.setattr(figures, "MAX_DRAWN", 3, raising=False)  # 12: a smaller test
    n, labels = 16, 5
    rows = ["method,query,reference,score,latency_ms"]
    for k in range(labels):  # method mK predicts the first K queries right
        rows += [f"m{k},{q},{q if q < k else (q + 8) % n},{q / n},1.5" for q in range(n)]
    f = _write(tmp_path / "many.csv", "\n".join(rows) + "\n")
    result = score_predictions(ScoreConfig("tiny", (str(f),)), dataset=_dataset(n))
    best = ["m2", "m3", "m4"]
    pr = figures.pr_curves(result)
    assert [t.get_text().split(" ")[0] for t in pr.axes[0].get_legend().get_texts()] == best
    position = figures.position_along_route(result)
    assert [a.get_title().split(":")[0] for a in position.axes if a.get_visible()] == best
    latency = figures.latency_per_frame(result)
    assert [t.get_text() for t in latency.axes[0].get_yticklabels()] == best
    captions = {fig.key: fig.caption for fig in _figures(result, None)}
    note = f"Drawn: the 3 methods of highest max F1 of the {labels}"
    assert all(note in captions[k] for k in ("pr-curves", "position", "latency"))
