"""SHA-256 fingerprints of every weighted-node executor's estimates, to show a change is
byte-for-byte neutral.

Not collected by pytest. Run from anywhere (paths resolve from this file)::

    .venv/bin/python benchmarks/fingerprint.py            # every case, one line each
    .venv/bin/python benchmarks/fingerprint.py --quick    # the generated routes only
    .venv/bin/python benchmarks/fingerprint.py --json fp.json
    .venv/bin/python benchmarks/fingerprint.py --estimates   # without latency and energy

Each case builds a method's map from a short route's reference frames and steps every
query frame once (the localiser directly, no evaluation), then hashes the map (its
descriptors and each node's frame) and, per query, the estimate's node, score, motion
decision, recorded weights, modelled latency and energy. The cases cover the host filter
(float and ppa8 register arithmetic, both presets, every representation; the 16x16
images and the Haar signs in the robust preset only, the one that runs on them), the
simulated sensor (the same presets and representations, ideal and ``typical`` noise) and a
bank of sensors (a map split over three simulated sensors). The last line hashes every case
together: equal before and after a refactoring means the same bytes everywhere.
``--estimates`` leaves the modelled latency and energy out, to show that a change of
what the sensor costs (a further sensor, a timing model) changes no estimate.
Routes from ``../shared/data`` are used when present (a note says when they are not).
"""

from __future__ import annotations

import argparse
import hashlib
import json
import sys
import time
from pathlib import Path
from typing import Any

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
DATA = ROOT.parent / "shared" / "data"

ROUTES = {
    "synthetic-sync": "synthetic:?places=48&query=winter&seed=0&sync=1&stops=2",
    "synthetic-speed": "synthetic:?places=48&query=dusk&seed=2&speed_var=0.65",
    "nordland": "nordland:{data}/nordland-64x32?ref=summer&query=winter&start=700&stop=760",
    "gardens-point": "gardens-point:{data}/gardens-point?ref=day_right&query=night_right&stop=48",
}


def cases(quick: bool) -> list[tuple[str, str, dict[str, Any]]]:
    """``(route, method, params)`` of every case."""
    from ppaloc.localise.params import runs_on

    out: list[tuple[str, str, dict[str, Any]]] = []
    routes = ["synthetic-sync", "synthetic-speed"]
    if not quick:
        routes += ["nordland", "gardens-point"]
    for route in routes:
        for rep in ("lowres", "lbp", "lowres16", "haar"):
            for preset in ("", "paper-") if runs_on(rep, "paper") else ("",):
                for arithmetic in ("float", "ppa8"):
                    out.append((route, f"weighted-node-{preset}{rep}", {"arithmetic": arithmetic}))
                for noise in ("ideal", "typical"):
                    out.append((route, f"onsensor-{preset}{rep}", {"noise": noise}))
            out.append((route, f"onsensor-{rep}", {"noise": "ideal", "sensor_nodes": 16}))
    return out


def _digest(parts: list[np.ndarray | bytes | str]) -> str:
    h = hashlib.sha256()
    for part in parts:
        if isinstance(part, str):
            part = part.encode()
        if isinstance(part, np.ndarray):
            h.update(str((part.dtype.str, part.shape)).encode())
            part = np.ascontiguousarray(part).tobytes()
        h.update(part)
    return h.hexdigest()


def run_case(
    route: str, method: str, params: dict[str, Any], frames: dict, cost: bool = True
) -> str:
    """The fingerprint of one case (``cost``: with each frame's modelled latency and
    energy)."""
    from ppaloc.methods import make_localiser

    reference, query = frames[route]
    loc = make_localiser(method, record_weights=True, **params)
    topomap = loc.build_map(reference)
    loc.reset()
    parts: list[Any] = [
        np.asarray(topomap.descriptors),
        np.asarray(topomap.frame_index, np.int64),
    ]
    for frame in query:
        est = loc.step(frame)
        parts.append(
            np.array(
                [
                    est.node,
                    est.score,
                    -1 if est.moved is None else int(est.moved),
                    np.nan
                    if not cost or est.modelled_latency_ms is None
                    else est.modelled_latency_ms,
                    np.nan if not cost or est.energy_mj is None else est.energy_mj,
                ],
                np.float64,
            )
        )
        # + 0.0: a zero read from a negated register is -0.0, a different byte pattern
        parts.append(np.asarray(est.weights, np.float64) + 0.0)
    return _digest(parts)


def load_frames(routes: set[str]) -> dict:
    from ppaloc.datasets import load_dataset
    from ppaloc.evaluate.run import sensor_frames

    out = {}
    for route in sorted(routes):
        spec = ROUTES[route].format(data=DATA)
        if "{data}" in ROUTES[route] and not DATA.is_dir():
            print(f"note: {DATA} not found: route {route} skipped", file=sys.stderr)
            continue
        ds = load_dataset(spec)
        out[route] = (sensor_frames(ds.reference), sensor_frames(ds.query))
    return out


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--quick", action="store_true", help="the generated routes only")
    parser.add_argument("--json", type=Path, help="also write every fingerprint here")
    parser.add_argument(
        "--estimates", action="store_true", help="leave the modelled latency and energy out"
    )
    args = parser.parse_args(argv)
    todo = cases(args.quick)
    frames = load_frames({route for route, _, _ in todo})
    results: dict[str, str] = {}
    t0 = time.perf_counter()
    for route, method, params in todo:
        if route not in frames:
            continue
        label = f"{route} {method} " + " ".join(f"{k}={v}" for k, v in sorted(params.items()))
        results[label] = run_case(route, method, params, frames, cost=not args.estimates)
        print(f"{results[label][:16]}  {label}", flush=True)
    total = _digest(sorted(f"{k}={v}" for k, v in results.items()))
    print(f"{total[:16]}  all {len(results)} cases ({time.perf_counter() - t0:.0f} s)")
    if args.json:
        args.json.write_text(json.dumps({"cases": results, "all": total}, indent=1) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
