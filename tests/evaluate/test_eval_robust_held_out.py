"""``benchmarks/eval_robust.py --held-out``: the routes no default was chosen on."""

from __future__ import annotations

from ppaloc.datasets.registry import load_dataset


def test_the_held_out_routes_are_new_and_load(bench_script):
    eval_robust = bench_script("eval_robust")
    held = eval_robust.held_out_routes(places=40)
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
