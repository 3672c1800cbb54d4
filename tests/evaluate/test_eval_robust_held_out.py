"""``benchmarks/eval_robust.py``: the routes no default was chosen on (``--held-out``) and the
summary lines."""

from __future__ import annotations

import json
from urllib.parse import parse_qsl

import pytest

from ppaloc.datasets.registry import load_dataset


def test_the_held_out_routes_are_new_and_load(bench_script):
    eval_robust = bench_script("eval_robust")
    held = eval_robust.held_out_routes(None, places=40)
    labels = [label for label, _ in held]
    assert len(held) == 36 and len(set(labels)) == 36
    chosen_on = {spec for _, spec in eval_robust.routes(None, places=40)}
    assert not chosen_on & {spec for _, spec in held}  # none of the 65's specs
    groups = {eval_robust.route_group(label) for label in labels}
    assert len(groups) == 10  # 4 road conditions, 4 lab ones, night at two speed spreads
    assert "generated, turns=8, night" in groups and "generated, lab, dim" in groups
    for _, spec in held[::9]:  # a road, a road at night, a lab and a straight night route
        ds = load_dataset(spec)
        assert len(ds.reference) > 0 and len(ds.query) == len(ds.ground_truth)


def _pair(spec: str) -> tuple[str, str, str]:
    """``(dataset, ref, query)`` of a real route's spec."""
    where, _, query = spec.partition("?")
    options = dict(parse_qsl(query))
    return where, options["ref"], options["query"]


def test_the_real_pairs_are_held_out_the_other_way_round(
    bench_script, shared_data, nordland_dir, gardens_point_dir
):
    eval_robust = bench_script("eval_robust")  # the fixtures skip without either dataset
    held = dict(eval_robust.held_out_routes(shared_data, places=40))
    real = {label: spec for label, spec in held.items() if not label.startswith("synthetic")}
    assert len(real) == 4 and len(held) == 40
    chosen_on = [spec for _, spec in eval_robust.routes(shared_data, places=40)]
    chosen_pairs = {_pair(spec) for spec in chosen_on if not spec.startswith("synthetic")}
    for label, spec in real.items():
        assert spec not in chosen_on
        where, ref, query = _pair(spec)
        assert (where, query, ref) in chosen_pairs, label  # a pair of the 65, reversed
        assert eval_robust.route_group(label) == label  # a real route is its own group
        ds = load_dataset(spec)
        assert len(ds.reference) > 0 and len(ds.query) == len(ds.ground_truth)


def test_the_summary_counts_the_places_a_sensor_holds_on_their_own_line(bench_script):
    eval_robust = bench_script("eval_robust")

    def record(label: str, **f1: float) -> dict:
        return {
            "label": label,
            "results": {k.replace("_", "-"): {"f1_max": v} for k, v in f1.items()},
        }

    methods = ["weighted-node-lowres16", "weighted-node-patch", "particle-filter"]
    records = [  # the host's place wins the first route, the sensor's place the second
        record("a", weighted_node_lowres16=0.5, weighted_node_patch=0.9, particle_filter=0.8),
        record("b", weighted_node_lowres16=0.9, weighted_node_patch=0.7, particle_filter=0.8),
    ]
    text, summary = eval_robust.comparison_table(records, methods)
    every, on_sensor = summary.values()
    assert (every["wins"], on_sensor["wins"]) == (2, 1)
    assert on_sensor["min_route"] == "a" and "places a sensor holds" in text


def test_the_same_place_line_counts_routes_by_their_better_place(bench_script):
    eval_robust = bench_script("eval_robust")

    def record(label: str, **f1: float) -> dict:
        columns = {k.replace("_", "-").replace("-slash-", "/"): v for k, v in f1.items()}
        return {"label": label, "results": {k: {"f1_max": v} for k, v in columns.items()}}

    records = [
        # held: the better place (16x16, by the filter's own F1) is above the particle filter
        record(
            "held",
            weighted_node_lowres16=0.90,
            particle_filter_slash_lowres16=0.85,
            weighted_node_haar=0.70,
            particle_filter_slash_haar=0.75,
        ),
        # short: the Haar signs hold, but the better place is the 16x16 one, which trails
        # (this route counted as held while any place did: five places, five chances)
        record(
            "some",
            weighted_node_lowres16=0.80,
            particle_filter_slash_lowres16=0.85,
            weighted_node_haar=0.70,
            particle_filter_slash_haar=0.70,
        ),
        # short on both places: the better one, the patch place, is the one reported
        record(
            "short",
            weighted_node_lowres16=0.60,
            particle_filter_slash_lowres16=0.50,
            weighted_node_patch=0.90,
            particle_filter_slash_patch=0.92,
        ),
        # no place ran beside the particle filter on it: not counted
        record("alone", weighted_node_lbp=0.5, particle_filter_slash_haar=0.4),
    ]
    text, stats = eval_robust.same_place_summary(records)
    assert (stats["held"], stats["held_some"], stats["routes"]) == (1, 3, 3)
    assert stats["places"] == {"lowres16": [2, 3], "haar": [1, 2], "patch": [0, 1]}
    some, short = stats["short"]
    assert (some["label"], some["place"]) == ("some", "lowres16")
    assert short["label"] == "short" and short["place"] == "patch"
    assert abs(short["gap"] + 0.02) < 1e-12
    assert text == (
        "The better weighted-node place (by its own max F1) scores at least particle-filter "
        "on that place on 1 of 3 routes (some place on 3: lowres16 2 of 3, haar 1 of 2, "
        "patch 0 of 1); below it: some (lowres16 0.800 against 0.850, short by 0.050); "
        "short (patch 0.900 against 0.920, short by 0.020)"
    )


def test_the_same_place_figure_draws_each_place_of_each_run(bench_script, tmp_path):
    figure = bench_script("figure_same_place")

    def record(label: str, wn: float, pf: float) -> dict:
        return {
            "label": label,
            "results": {
                "weighted-node-haar": {"f1_max": wn},
                "particle-filter/haar": {"f1_max": pf},
            },
        }

    run = tmp_path / "run.json"
    run.write_text(json.dumps({"routes": [record("a", 0.7, 0.6), record("b", 0.5, 0.52)]}))
    assert figure.pairs(json.loads(run.read_text())["routes"]) == {
        "haar": ([0.6, 0.52], [0.7, 0.5])
    }
    out = tmp_path / "fig" / "same-place.png"
    figure.main([str(run), str(run), "--titles", "one,two", "--out", str(out)])
    assert out.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    with pytest.raises(SystemExit, match="1 titles for 2 files"):
        figure.main([str(run), str(run), "--titles", "one", "--out", str(out)])


def test_the_seed_spread_puts_each_short_route_beside_the_particle_filter_over_seeds(
    bench_script,
):
    eval_robust = bench_script("eval_robust")
    jobs = eval_robust.seed_spread_jobs("patch", 4)
    assert [c for c, _, _ in jobs] == [f"particle-filter/patch@seed={s}" for s in (1, 2, 3)]
    assert all(name == "particle-filter" for _, name, _ in jobs)
    assert [u for _, _, u in jobs] == [{"descriptor": "patch", "seed": s} for s in (1, 2, 3)]
    # the table's other parameters run at every seed, and its own seed starts the count
    (job,) = eval_robust.seed_spread_jobs("lbp", 2, {"seed": 7, "n_particles": 200})
    assert job == ("particle-filter/lbp@seed=8", "particle-filter",
                   {"seed": 8, "n_particles": 200, "descriptor": "lbp"})  # fmt: skip
    short = [
        {"label": "a", "place": "patch", "weighted_node": 0.80, "baseline": 0.84, "gap": -0.04},
        {"label": "b", "place": "haar", "weighted_node": 0.50, "baseline": 0.52, "gap": -0.02},
        {"label": "c", "place": "lbp", "weighted_node": 0.30, "baseline": 0.31, "gap": -0.01},
    ]
    extra = {"particle-filter/patch@seed=1": 0.78, "particle-filter/patch@seed=3": 0.82}
    records = [  # seed 2 of route a failed: it is left out, not counted as 0
        {"label": "a", "results": {k: {"f1_max": v} for k, v in extra.items()}},
        {"label": "b", "results": {"particle-filter/haar@seed=1": {"f1_max": 0.50}}},
    ]
    text, rows = eval_robust.seed_spread_summary(short, records, 4)
    a, b, c = rows
    assert (a["seeds"], a["f1_max"]) == ([0, 1, 3], [0.84, 0.78, 0.82])
    assert (a["min"], a["max"], a["at_or_below"]) == (0.78, 0.84, 1)
    assert abs(a["mean"] - 0.81333) < 1e-4 and abs(a["sd"] - 0.030551) < 1e-5
    assert (b["seeds"], b["at_or_below"]) == ([0, 1], 1)  # a tie counts for the filter
    assert (c["seeds"], c["sd"]) == ([0], None)  # every extra run failed: no spread
    assert text.startswith(
        "The particle filter's max F1 over its seeds on the routes below it: a, "
        "particle-filter/patch over seeds [0, 1, 3]: mean 0.813, sd 0.031, range 0.780-0.840; "
        "the weighted-node filter's 0.800 at or above it on 1 of 3 seeds; b, "
        "particle-filter/haar over seeds 0-1: mean 0.510, sd 0.014"
    )
    assert "c, particle-filter/lbp over seed 0: mean 0.310, no sd from one run" in text


def test_the_seed_spread_needs_the_same_place_line(bench_script):
    eval_robust = bench_script("eval_robust")
    with pytest.raises(SystemExit, match="--seed-spread reads --representations"):
        eval_robust.main(["--seed-spread", "5"])
    for k in ("1", "101"):
        with pytest.raises(SystemExit, match=rf"--seed-spread {k} must be in \[2, 100\]"):
            eval_robust.main(["--representations", "--seed-spread", k])


def test_the_baselines_cache_follows_the_constants_they_read(bench_script, monkeypatch):
    # the baselines' low-res places read the filter's normalisation constants from
    # localise/params.py, which the hash left out: a changed constant served stale figures
    from ppaloc.localise import params

    eval_robust = bench_script("eval_robust")
    before = eval_robust.source_hash()
    assert eval_robust.source_hash() == before
    monkeypatch.setattr(params, "DEFAULT_CONTRAST", params.DEFAULT_CONTRAST + 1)
    assert eval_robust.source_hash() != before
    assert {"src/ppaloc/evaluate/run.py", "src/ppaloc/methods.py"} <= set(eval_robust.SOURCES)
