"""How much a node descriptor can tell, with and without knowing the query's speed.

Not collected by pytest. For each route and each weighted-node representation (8x8 low-res
images by SAD, 32-bit LBP by Hamming distance) it prints the share of query frames whose
best match lies within the tolerance:

- ``single``: the best single-frame match;
- ``true-speed L``: the best match of the last ``L`` frames summed along the query's *true*
  trajectory (the generator's ``query_place``), i.e. a sequence matcher that knows the
  speed exactly: an upper bound for any filter over these descriptors that must infer it.

Generated routes only (they record the true positions)::

    .venv/bin/python benchmarks/sequence_bound.py
    .venv/bin/python benchmarks/sequence_bound.py --spec 'synthetic:?places=200&query=dusk&seed=2'
"""

from __future__ import annotations

import argparse

import numpy as np

from ppaloc.datasets import load_dataset, to_sensor
from ppaloc.place import lbp_descriptor, lowres_image

SPECS = tuple(
    f"synthetic:?places=200&query={q}&seed={s}&speed_var={v}"
    for s, v, q in [
        (1, 0.2, "winter"),
        (3, 0.2, "winter"),
        (1, 0.65, "autumn"),
        (2, 0.65, "winter"),
        (2, 0.65, "dusk"),
        (4, 0.65, "winter"),
    ]
)
WINDOWS = (1, 10, 20, 40)


def distances(kind: str, ref: list[np.ndarray], query: list[np.ndarray]) -> np.ndarray:
    """(M, N) distances in register units: LBP ``2 h``, low-res mean |difference| / 2."""
    if kind == "lbp":
        r = np.array([int(lbp_descriptor(f)) for f in ref], np.uint32)
        q = np.array([int(lbp_descriptor(f)) for f in query], np.uint32)
        return 2.0 * np.bitwise_count(q[:, None] ^ r[None, :])
    r = np.stack([lowres_image(f) for f in ref]).reshape(len(ref), -1).astype(np.int32)
    q = np.stack([lowres_image(f) for f in query]).reshape(len(query), -1).astype(np.int32)
    return np.abs(q[:, None, :] - r[None, :, :]).sum(-1) / 128.0


def bound(mu: np.ndarray, place: np.ndarray, tolerance: float, window: int) -> float:
    """Share of queries whose true-speed sequence of ``window`` frames matches in tolerance."""
    m, n = mu.shape
    big = float(mu.max()) + 1
    hits = []
    for t in range(m):
        total = np.zeros(n)
        for k in range(min(window, t + 1)):
            lag = round(place[t] - place[t - k])
            shifted = np.full(n, big)
            if 0 <= lag < n:
                shifted[lag:] = mu[t - k, : n - lag]
            total += shifted
        hits.append(abs(int(total.argmin()) - place[t]) <= tolerance + 0.5)
    return float(np.mean(hits))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--spec", action="append", default=None, help="a generated route")
    args = parser.parse_args()
    print("| route | descriptor | single | " + " | ".join(f"true-speed {w}" for w in WINDOWS[1:]))
    print("|---|---|" + "---|" * len(WINDOWS))
    for spec in args.spec or SPECS:
        ds = load_dataset(spec)
        ref = [to_sensor(f) for f in ds.reference]
        query = [to_sensor(f) for f in ds.query]
        place = np.asarray(ds.meta["query_place"], dtype=np.float64)
        for kind in ("lowres", "lbp"):
            mu = distances(kind, ref, query)
            cells = [f"{bound(mu, place, ds.tolerance, w):.2f}" for w in WINDOWS]
            print(f"| {spec[11:]} | {kind} | " + " | ".join(cells) + " |", flush=True)


if __name__ == "__main__":
    main()
