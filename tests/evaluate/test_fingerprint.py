"""``benchmarks/fingerprint.py``: equal estimates hash equal, whichever executor made them."""

from __future__ import annotations


def test_the_sensor_and_the_host_register_arithmetic_hash_alike(bench_script):
    """LBP's sensor keeps minus the weights, so a zero weight reads -0.0 there; the
    fingerprint hashes the values, not the sign of a zero."""
    from ppaloc.datasets import load_dataset
    from ppaloc.evaluate.run import sensor_frames

    fingerprint = bench_script("fingerprint")
    ds = load_dataset("synthetic:?places=12&query=winter&seed=0&sync=1")
    frames = {"r": (sensor_frames(ds.reference), sensor_frames(ds.query))}
    host = fingerprint.run_case("r", "weighted-node-lbp", {"arithmetic": "ppa8"}, frames, False)
    sensor = fingerprint.run_case("r", "onsensor-lbp", {"noise": "ideal"}, frames, False)
    assert host == sensor
    assert host != fingerprint.run_case(
        "r", "weighted-node-lowres", {"arithmetic": "ppa8"}, frames, False
    )
