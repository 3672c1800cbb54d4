"""The on-sensor system's figures: agreement, modelled frame time, noise, figures.

Run from the project root: ``python benchmarks/eval_onsensor.py [--part NAME ...]
[--preset robust paper] [--figures DIR]``. Not collected by pytest. Parts (each for the
presets given, default both):

- ``agreement``: in ideal mode, ``OnSensorLocaliser`` against
  ``WeightedNodeLocaliser(arithmetic="ppa8")`` with the same parameters, each mapping the
  reference itself (robust with image motion: keyframes, so the kept frames are compared
  too): the fraction of frames with the same node, the same motion decision and the
  same score (robust: equal, both the refined threshold minus the outside maximum, each
  to 1/16; paper: the two scores within 1), and the largest weight
  difference, on the synthetic route (image motion) and on Nordland summer -> winter
  (image motion with a keyframe map and with a map of every frame, whose stops the robust
  preset keeps as runs; always forward), for both representations, with the median
  frame's modelled ``chip`` time.
- ``timing``: modelled latency and energy per frame at the paper's map sizes (1024 low-res
  images, 2048 descriptors) and at Nordland's (1788 nodes: two low-res tiles), with the
  per-stage breakdown (mean over frames) and the ratio to the paper's 2.59 ms / 3.17 ms
  on SCAMP-5.
- ``noise``: max F1 (recall definition A, tolerance of the dataset) in ideal mode, under
  the ``"typical"`` noise preset and under that preset without analogue droop, on
  Nordland summer -> winter, Gardens Point day_left -> day_right and day_right ->
  night_right, both representations, always-forward motion (all are frame-synchronised);
  the noisy figures are means over ``--seeds`` noise seeds (default 4), with the fraction
  of the ideal max F1 each preset keeps; ``--store levels analogue`` runs both low-res map
  stores (default: each preset's own), ``--noise-levels`` picks the noisy settings.
- ``stages``: where the noise enters: the robust preset under the typical preset without
  droop with single stages made exact (``--exact``), each as a simulation experiment that
  lets the stage run and then puts the exact result of its noisy inputs in its output
  registers (:func:`exact_stages`), mean max F1 over ``--seeds``; routes as ``noise``.
- ``terms``: what each physical term of the ``"typical"`` preset costs: the robust
  preset's max F1 with each term switched off in turn (:data:`TERMS`), both
  representations at their default map stores, mean over ``--seeds``.
- ``forgetting``: the host's robust filter with its weights scaled by a factor every
  frame, the forgetting a signal-proportional transfer gain on the weights' analogue
  writes amounts to (no other noise).
- ``figures``: the database, weights and difference registers (PNG) into ``--figures``
  (the paper preset's files as before, the robust preset's with ``_robust``).

``--rep`` picks the representations of ``agreement``, ``timing`` and ``noise`` (default
``lowres lbp``; ``lowres16`` and ``haar`` run the robust preset only, and their timing is
set beside the paper's 8x8 figure at 1024 nodes); ``--motion`` the Nordland agreement's
motion models and maps. A map on a bank is timed as the bank counts it: per phase its slowest sensor
plus one exchange per synchronisation point (docs/onsensor.md, "Sensor banks").
"""

from __future__ import annotations

import argparse
import ast
import dataclasses
import statistics
import time
import warnings
from collections import defaultdict
from pathlib import Path

import numpy as np

from ppaloc.datasets import to_sensor
from ppaloc.datasets.registry import load_dataset
from ppaloc.evaluate.metrics import is_correct, max_f1, pr_curve
from ppaloc.evaluate.run import predicted_frames
from ppaloc.localise.params import runs_on
from ppaloc.localise.schedule import SCHEDULES
from ppaloc.localise.weighted import WeightedNodeLocaliser
from ppaloc.onsensor import OnSensorLocaliser
from ppaloc.onsensor.executor import PLACES
from ppaloc.place import haar_plane, pack_plane
from ppaloc.sim import PRESETS
from ppaloc.sim.kernel import IcwStackWarning
from ppaloc.topomap import TopoMap

DATA = "../shared/data"
NORDLAND = f"nordland:{DATA}/nordland-64x32?ref=summer&query=winter"
GARDENS = f"gardens-point:{DATA}/gardens-point?ref=day_left&query=day_right"
GARDENS_NIGHT = f"gardens-point:{DATA}/gardens-point?ref=day_right&query=night_right"
NOISE_ROUTES = {
    "nordland": ("nordland summer->winter", NORDLAND),
    "gardens": ("gardens day_l->day_r", GARDENS),
    "gardens-night": ("gardens day_r->night_r", GARDENS_NIGHT),
}
SYNTHETIC = "synthetic:?places=300&query=winter&seed=1"
#: The paper's SCAMP-5d frame times and map sizes; lowres16 and haar are compared with the
#: paper's 8x8 images on a map of as many nodes.
PAPER_MS = {"lowres": 2.59, "lowres16": 2.59, "haar": 2.59, "lbp": 3.17}
PAPER_NODES = {"lowres": 1024, "lowres16": 1024, "haar": 1024, "lbp": 2048}
#: The representations each part runs by default (``--rep`` picks others).
REPRESENTATIONS = ("lowres", "lbp")
NORDLAND_NODES = 1788
FILTER_PRESETS = ("robust", "paper")
#: The "typical" preset without analogue droop: separates the droop of the stored database
#: (the map sits in registers for the whole query) from the per-operation noise.
NO_DROOP = dataclasses.replace(PRESETS["typical"], decay_per_ms=0.0)


def load(spec: str):
    ds = load_dataset(spec)
    return [to_sensor(f) for f in ds.reference], [to_sensor(f) for f in ds.query], ds


def _runs(rep: str, presets: tuple[str, ...]) -> list[str]:
    """The presets ``rep`` runs in (lowres16, haar: the robust presets only)."""
    return [p for p in presets if runs_on(rep, p)]


def agreement(
    name: str,
    spec: str,
    motions: tuple[str, ...],
    presets: tuple[str, ...] = FILTER_PRESETS,
    reps: tuple[str, ...] = REPRESENTATIONS,
    params: dict | None = None,
) -> None:
    """Host ppa8 against the sensor, each mapping the reference itself (``params``: the
    robust preset's filter parameters for both). A motion
    ``"image, every frame"`` maps every frame (``keyframes=false``): the robust preset
    keeps the reference's stops as runs of one place (docs/onsensor.md, "Runs of one
    place")."""
    ref, query, _ = load(spec)
    for rep in reps:
        for preset in _runs(rep, presets):
            for variant in motions:
                motion, _, every = variant.partition(", ")
                kw = {"preset": preset, "motion": motion, "record_weights": True}
                if preset == "robust":
                    kw |= params or {}
                if every:
                    kw["keyframes"] = False
                host = WeightedNodeLocaliser(rep, arithmetic="ppa8", **kw)
                sensor = OnSensorLocaliser(rep, **kw)
                t = time.perf_counter()
                with warnings.catch_warnings(record=True) as caught:
                    warnings.simplefilter("always", IcwStackWarning)
                    want, got = host.build_map(ref), sensor.build_map(ref)
                    a, b = host.localise(query), sensor.localise(query)
                same_map = (
                    np.array_equal(want.frame_index, got.frame_index)
                    and np.array_equal(want.descriptors, got.descriptors)
                    and (want.places is None) == (got.places is None)
                    and (want.places is None or np.array_equal(want.places, got.places))
                )
                # a kernel cut short by a full ICW stack is a wrong program: name it
                lost = sum(issubclass(w.category, IcwStackWarning) for w in caught)
                pairs = list(zip(a, b, strict=True))
                node = np.mean([x.node == y.node for x, y in pairs])
                moved = np.mean([x.moved == y.moved for x, y in pairs])
                if preset == "robust":  # both refined to 2**-DETECT_BITS: equal
                    score = [y.score == x.score for x, y in pairs]
                else:
                    score = [abs(y.score - x.score) < 1 for x, y in pairs]
                werr = max(float(np.abs(x.weights - y.weights).max()) for x, y in pairs)
                chip = np.median([y.modelled_latency_ms for y in b])
                print(
                    f"agreement {name:24s} {rep:6s} {preset:6s} {variant:19s} "
                    f"nodes={len(got)} same map={same_map} node {node * 100:7.2f}% "
                    f"moved {moved * 100:7.2f}% score {np.mean(score) * 100:7.2f}% "
                    f"max |dw|={werr:.1e} of {len(query)} frames, chip {chip:.2f} ms "
                    f"({len(query) / (time.perf_counter() - t):.1f} frames/s host+sensor)"
                    + (f"; ICW STACK FULL: {lost} kernel(s) lost ICWs" if lost else ""),
                    flush=True,
                )


def _frames(n: int) -> list[np.ndarray]:
    rng = np.random.default_rng(0)
    out = []
    cells = rng.integers(0, 256, (n, 17, 17)).astype(np.uint8)
    for i in range(n):
        big = np.kron(cells[i], np.ones((16, 16), np.uint8))
        out.append(big[i % 16 : i % 16 + 256, :256])
    return out


def _random_map(rep: str, n: int) -> TopoMap:
    rng = np.random.default_rng(1)
    if rep == "lbp":
        return TopoMap("lbp", rng.integers(0, 2**32, n, dtype=np.uint32))
    if rep == "haar":  # the signs of random 16x16 images (the unused cells 0)
        return TopoMap(rep, pack_plane(haar_plane(rng.integers(0, 256, (n, 16, 16)))))
    side = 16 if rep == "lowres16" else 8
    return TopoMap(rep, rng.integers(0, 256, (n, side, side), dtype=np.uint8))


def timing(
    n_frames: int = 24,
    presets: tuple[str, ...] = FILTER_PRESETS,
    reps: tuple[str, ...] = REPRESENTATIONS,
    params: dict | None = None,
) -> None:
    """Per-stage modelled time per frame at the paper's and Nordland's map sizes.

    The frames are blocky random images moving by one pixel per frame, so the image
    motion test says forward on every frame (every stage of either preset runs); a
    robust *stay* frame skips the scale readout, the replication/descriptor, the best
    distance's refinement, the update and the local term (the "stay frame" line).
    """
    for rep in reps:
        for n in (PAPER_NODES[rep], NORDLAND_NODES):
            topomap = _random_map(rep, n)
            for preset in _runs(rep, presets):
                for motion in ("image", "always_forward"):
                    kw = {"alpha": 8} if preset == "paper" else dict(params or {})
                    loc = OnSensorLocaliser(rep, preset=preset, motion=motion, **kw)
                    loc.use_map(topomap)
                    _time_frames(loc, rep, n, preset, motion, n_frames)


def _time_frames(loc, rep: str, n: int, preset: str, motion: str, n_frames: int) -> None:
    sim = loc.pipeline.sim
    per_stage: dict[str, list[float]] = defaultdict(list)
    totals, energy = [], []
    for i, frame in enumerate(_frames(n_frames)):
        sim.timing.reset()
        est = loc.step(frame)
        if i < 2:  # the first frame records the kernels and has no motion decision
            continue
        report = sim.timing.report()
        for s in report.stages:
            per_stage[s.name].append(s.us)
        totals.append(est.modelled_latency_ms)
        energy.append(est.energy_mj)
    ms = statistics.median(totals)
    print(
        f"\ntiming {rep} ({n} nodes, {loc.pipeline.tiles} tile(s)"
        f"{_sensors(loc)}), preset={preset}, "
        f"motion={motion}: {ms:.3f} ms per frame (median), {ms / PAPER_MS[rep]:.2f} x the "
        f"paper's {PAPER_MS[rep]} ms; energy {statistics.median(energy):.3f} mJ per frame"
    )
    means = {}
    for name, values in per_stage.items():
        full = values + [0.0] * (len(totals) - len(values))
        means[name] = statistics.mean(full)
        print(f"  {name:12s} {means[name]:8.1f} us (mean over frames)")
    if preset == "robust":
        live = ("scale", "replicate", "lbp", "haar", "minimum", "compare", "local")
        stay = sum(v for k, v in means.items() if k not in live) / 1000.0
        print(f"  {'stay frame':12s} {stay * 1000:8.1f} us (robust: no likelihood on stay)")


def _sensors(loc: OnSensorLocaliser) -> str:
    """``", a bank of k sensors"`` where the map is on a bank (its time: the slowest
    sensor of each phase plus one exchange per synchronisation point)."""
    sensors = getattr(loc.pipeline, "sensors", None)
    return "" if sensors is None else f" on a bank of {len(sensors)} sensors"


def _max_f1(loc: OnSensorLocaliser, query, truth) -> float:
    """Max F1 of the localiser over ``query``, each node read as the reference frame it
    predicts (its own frame on a keyframe map), as the evaluation's runner reads it."""
    has_match = np.array([len(t) > 0 for t in truth])
    est = loc.localise(query)
    frames = predicted_frames(np.array([e.node for e in est]), loc.topomap.frame_index)
    correct = is_correct(frames, truth)
    return max_f1(pr_curve([e.score for e in est], correct, has_match, recall="A"))[0]


#: Robust filter parameters the noise part's sensors take (``--filter``; inherited by the
#: worker processes).
FILTER: dict = {}


def _noisy_f1(args) -> float:
    spec, rep, preset, level, seed, n_query, exact, store = (*args, None)[:8]
    ref, query, ds = load(spec)
    query = query[:n_query]
    truth = list(ds.ground_truth)[: len(query)]
    setting = NO_DROOP if level == "typical-no-droop" else level
    kw = FILTER if preset == "robust" else {}
    loc = OnSensorLocaliser(
        rep, noise=setting, seed=seed, preset=preset, motion="always_forward", store=store, **kw
    )
    loc.build_map(ref)  # mapped by the same (noisy) sensor
    if exact:
        exact_stages(loc, set(exact))
    return _max_f1(loc, query, truth)


def _map(jobs: list, processes: int) -> list:
    if processes <= 1:
        return [_noisy_f1(j) for j in jobs]
    from multiprocessing import get_context

    with get_context("fork").Pool(processes) as pool:
        return pool.map(_noisy_f1, jobs, chunksize=1)


def _stores(rep: str, preset: str, stores: tuple[str, ...]) -> list[str | None]:
    """The map stores to run: ``"default"`` is the preset's own; others where they exist."""
    own = PLACES[rep].stores
    out = [None if s == "default" else s for s in stores if s == "default" or s in own]
    default = PLACES[rep].choose_store(SCHEDULES[preset].sensor, None)
    return list(dict.fromkeys(default if s is None else s for s in out))


def noise(
    n_query: int | None = None,
    presets: tuple[str, ...] = FILTER_PRESETS,
    seeds: int = 4,
    processes: int = 2,
    routes: tuple[str, ...] = tuple(NOISE_ROUTES),
    stores: tuple[str, ...] = ("default",),
    levels: tuple[str, ...] = ("typical", "typical-no-droop"),
    reps: tuple[str, ...] = REPRESENTATIONS,
) -> None:
    """Max F1 ideal and under each noisy ``levels`` (over ``seeds``), per map store."""
    rows = []
    for name, spec in (NOISE_ROUTES[r] for r in routes):
        for rep in reps:
            for preset in _runs(rep, presets):
                for store in _stores(rep, preset, stores):
                    t = time.perf_counter()
                    jobs = [(spec, rep, preset, "ideal", 0, n_query, (), store)]
                    for level in levels:
                        jobs += [
                            (spec, rep, preset, level, seed, n_query, (), store)
                            for seed in range(seeds)
                        ]
                    f1 = _map(jobs, processes)
                    ideal = f1[0]
                    per = [f1[1 + i * seeds : 1 + (i + 1) * seeds] for i in range(len(levels))]
                    means = [float(np.mean(v)) for v in per]
                    rows.append((name, rep, preset, store, ideal, means))
                    text = " ".join(
                        f"{lv}={m:.3f} [{' '.join(f'{v:.2f}' for v in vals)}] kept {m / ideal:.2f}"
                        for lv, m, vals in zip(levels, means, per, strict=True)
                    )
                    print(
                        f"noise {name:24s} {rep:6s} {preset:6s} {store:8s} ideal={ideal:.3f} "
                        f"{text} ({time.perf_counter() - t:.0f} s)",
                        flush=True,
                    )
    head = " | ".join(f"{lv} (kept)" for lv in levels)
    print(f"\n| route | rep | preset | map store | ideal | {head} |")
    print("|---|---|---|---|---:|" + "---:|" * len(levels))
    for name, rep, preset, store, ideal, means in rows:
        cells = " | ".join(f"{m:.3f} ({m / ideal:.2f})" for m in means)
        print(f"| {name} | {rep} | {preset} | {store} | {ideal:.3f} | {cells} |")


# ------------------------------------------------------------------ noise terms
#: The terms of a noise preset the ``terms`` part switches off, one at a time: each
#: label's fields are set to 0 (the transfer gain's mean and spread together, and its
#: mean alone).
TERMS = {
    "transfer gain": ("transfer_gain", "transfer_gain_sd"),
    "transfer gain mean": ("transfer_gain",),
    "fixed-pattern offset": ("fixed_offset_sd",),
    "temporal": ("temporal_sd",),
    "division": ("division_sd",),
    "droop": ("decay_per_ms",),
    "pixel offset": ("pixel_offset_sd",),
    "digital flips": ("digital_flip_per_ms",),
}


def terms(
    n_query: int | None = None,
    seeds: int = 3,
    processes: int = 2,
    routes: tuple[str, ...] = ("nordland",),
    level: str = "typical",
) -> None:
    """Max F1 of the robust preset under ``level`` with each of its terms switched off.

    What each physical term of the preset costs (the gain of switching it off, mean over
    ``seeds``), each map store and representation at its default; complements
    ``stages``, which says where in the program the noise enters.
    """
    base = PRESETS[level]
    configs = [("none", base)]
    for label, names in TERMS.items():
        if any(getattr(base, n) for n in names):
            configs.append((label, dataclasses.replace(base, **dict.fromkeys(names, 0.0))))
    print(f"\n| route | rep | {level} with this term off | max F1 (mean over seeds) | seeds |")
    print("|---|---|---|---:|---|")
    for name, spec in (NOISE_ROUTES[r] for r in routes):
        for rep in ("lowres", "lbp"):
            jobs = [(spec, rep, "robust", "ideal", 0, n_query, ())]
            jobs += [
                (spec, rep, "robust", params, seed, n_query, ())
                for _, params in configs
                for seed in range(seeds)
            ]
            f1 = _map(jobs, processes)
            print(f"| {name} | {rep} | ideal | {f1[0]:.3f} | |", flush=True)
            for i, (label, _) in enumerate(configs):
                vals = f1[1 + i * seeds : 1 + (i + 1) * seeds]
                print(
                    f"| {name} | {rep} | {label} | {np.mean(vals):.3f} | "
                    f"{' '.join(f'{v:.2f}' for v in vals)} |",
                    flush=True,
                )


def forgetting(
    factors: tuple[float, ...] = (1.0, 0.998, 0.996, 0.992, 0.985),
    routes: tuple[str, ...] = ("nordland",),
) -> None:
    """The host's robust filter with its weights scaled by ``factor`` every frame.

    A signal-proportional transfer gain ``g`` on each of the ``k`` analogue writes a
    weight takes per frame scales the weights (and so every difference between two
    hypotheses) by about ``(1 + g) ** k``: exponential forgetting. This runs the host
    filter (float arithmetic, the robust preset's defaults, always-forward motion) with
    that forgetting alone, to show what it costs without any other noise.
    """
    print("\n| route | rep | weights x factor per frame | max F1 |")
    print("|---|---|---|---:|")
    for name, spec in (NOISE_ROUTES[r] for r in routes):
        ref, query, ds = load(spec)
        truth = list(ds.ground_truth)[: len(query)]
        has_match = np.array([len(t) > 0 for t in truth])
        for rep in ("lowres", "lbp"):
            for factor in factors:
                host = WeightedNodeLocaliser(
                    rep, arithmetic="float", preset="robust", motion="always_forward"
                )
                host.build_map(ref)
                ex = host.executor
                transition = ex.transition

                def forget(costs, ex=ex, transition=transition, factor=factor):
                    ex._w *= factor  # a simulation experiment: the weights before it
                    transition(costs)

                ex.transition = forget  # the schedule calls its executor's transition
                est = host.localise(query)
                nodes = np.array([e.node for e in est])
                # a node's own frame, as ppaloc evaluate scores every method
                correct = is_correct(predicted_frames(nodes, host.topomap.frame_index), truth)
                curve = pr_curve([e.score for e in est], correct, has_match, recall="A")
                print(f"| {name} | {rep} | {factor} | {max_f1(curve)[0]:.3f} |", flush=True)


# ------------------------------------------------------------------ stages made exact
#: The stages :func:`exact_stages` can make exact, per representation.
STAGES = {
    "lowres": ("replicate", "tree", "scale", "update", "transition", "detect"),
    "lbp": ("descriptor", "tree", "scale", "update", "transition", "detect"),
}


def _roots(pipe) -> tuple[np.ndarray, np.ndarray]:
    sensor = pipe.sensor
    t, br, bc = sensor.layout.node_to_block(np.arange(sensor.n_nodes))
    return br * sensor.bh, bc * sensor.bw + t


def exact_stages(loc: OnSensorLocaliser, stages: set[str]) -> None:
    """Make ``stages`` of the robust pipeline exact (a simulation experiment, untimed).

    Each stage still runs (timing, noise draws), then its output registers get the exact
    result of the inputs it had (read untimed): ``replicate`` (low-res: spread and
    replication, or the live image's readout, normalisation and load) ``F`` := the block
    means the halving tree left at the roots (contrast-normalised), tiled;
    ``descriptor`` (LBP) the live code := the LBP code of those root means (``B``);
    ``tree`` the readout trees' values := ``mu`` of the replicated frame or descriptor
    and the database as they are (a tree recomputed inside an update kernel stays as it
    is); ``scale`` the readout := the integers ``r_i`` of exact values; ``update`` the
    weights := ``clip(w + clip(alpha_t - mu 2**-s))`` with the values the readout read;
    ``transition`` (with the normalisation it applies) the weights := the host's two
    steps; ``detect`` the node and ``T`` from the weights.

    The hooks wrap the executor's steps and its sensor's ``run`` on this one localiser
    (an experiment on a copy of the pipeline, never a mode of the library).
    """
    from ppaloc.localise.params import choose_candidate
    from ppaloc.onsensor import capture, lbp, lowres
    from ppaloc.place import lbp_from_grid, normalise_contrast
    from ppaloc.sim import C, D, F

    pipe = loc.pipeline
    sensor, places, weights = pipe.sensor, pipe.places, pipe.state
    p, rep, sim = pipe.params, pipe.representation, pipe.sim
    neg_reg = sensor.roles.negated
    rows, cols = _roots(pipe)
    state: dict = {}

    def get_w() -> np.ndarray:
        """The weights' register values (minus ``negated`` after a one-write update)."""
        if weights.negated:
            return -sim.read(neg_reg)[rows, cols].astype(np.float64)
        return sim.read(C)[rows, cols].astype(np.float64)

    def set_w(w: np.ndarray) -> None:
        reg = neg_reg if weights.negated else C
        plane = sim.read(reg).copy()
        plane[rows, cols] = -w if weights.negated else w
        sim.write(reg, plane)

    def keep_scale(before: float) -> None:
        """An exact stage leaves the weights' scale as it found it (no drift, no step)."""
        weights.scale.log_scale = before

    def exact_mu() -> np.ndarray:
        """``mu`` per node from the registers' operands, exactly."""
        if rep == "lowres":  # F as the trees found it (two tiles use it as a scratch)
            frame = state.get("frame", sim.read(F)).astype(np.float64)
            out = np.empty(sensor.n_nodes)
            for t in range(sensor.tiles):
                nodes, br, bc = sensor.tile_nodes[t]
                db = places.map_plane(t).astype(np.float64)
                a = np.minimum(np.abs(np.clip(frame + db, -128, 127)), 127)
                m = a.reshape(sensor.size // 8, 8, sensor.size // 8, 8).mean(axis=(1, 3))
                out[nodes] = m[br, bc]
            return out
        db = np.asarray(loc.topomap.descriptors, np.uint32)
        return 2.0 * np.bitwise_count(db ^ np.uint32(places.last_code))

    def pair_registers():
        pair = places.tree_tiles() if sensor.tiles > 1 else None
        return None if pair is None else pair[2]

    trees = {lowres._tree, lowres._tree_pair, lbp._tree}
    run_kernel = sensor.run

    def run(build, *args):
        if build in (capture._spread_tree, capture._mov):  # the halving tree's root means
            state["roots"] = sim.read(D)[:: sensor.block, :: sensor.block].astype(np.float64)
        if build in trees:
            state["frame"] = sim.read(F).copy()
        kernel = run_kernel(build, *args)
        if "tree" in stages and build in trees:
            state["mu"] = exact_mu()
            sign, exponent = places.value_scale
            regs = pair_registers() if build is lowres._tree_pair else None
            db = args[0] if build is lowres._tree_pair else args[1]
            for t in range(sensor.tiles):
                if regs is None and db != sensor.roles.db[t]:
                    continue
                reg = regs[t] if regs else D
                nodes, br, bc = sensor.tile_nodes[t]
                plane = sim.read(reg).copy()
                plane[br * sensor.bh, bc * sensor.bw] = sign * state["mu"][nodes] * 2.0**-exponent
                sim.write(reg, plane)
        return kernel

    sensor.run = run

    if rep == "lowres":
        live = places.load_live if places.normalised else places.replicate

        def exact_replicate() -> None:
            live()
            if "replicate" not in stages:
                return
            if places.normalised:  # F = -f' of the exact grid, contrast-normalised
                m = -state["roots"]  # the exact block means (state: the reduce's roots)
                q = normalise_contrast(np.floor(2 * m + 128).astype(np.int64), p.contrast)
                grid = -(q.astype(np.float64) / 2 - 64)
            else:  # F = -m of grid block (r % 8, c % 8)
                grid = state["roots"]
            sim.write(F, np.tile(grid, (sensor.size // 8, sensor.size // 8)))

        if places.normalised:
            places.load_live = exact_replicate
        else:
            places.replicate = exact_replicate
    else:
        descriptor = places.descriptor

        def exact_descriptor() -> int:
            code = descriptor()
            if "descriptor" in stages:
                means = sim.read(sensor.roles.root_means)
                m = means[:: sensor.block, :: sensor.block].astype(np.float64)
                code = int(lbp_from_grid(m[1:7, 1:7]))
            return code

        places.descriptor = exact_descriptor

    values = places.values

    def exact_values(codes: np.ndarray) -> np.ndarray:
        t = state["tile"]
        state["tile"] = t + 1
        nodes, br, bc = sensor.tile_nodes[t]
        regs = pair_registers()
        reg = regs[t] if regs else D
        sign, exponent = places.value_scale
        tree = sim.read(reg)[br * sensor.bh, bc * sensor.bw].astype(np.float64)
        state["tree_mu"][nodes] = sign * tree * 2.0**exponent
        if "scale" not in stages:
            return values(codes)
        mu = exact_mu()[nodes]
        if rep == "lowres":
            return 2 * (128 - np.floor(128.5 - mu / 2)).astype(np.int64)
        return mu.astype(np.int64)

    places.values = exact_values
    node_values, add_scaled = pipe.node_values, pipe.add_scaled

    def exact_node_values() -> np.ndarray:
        state["tile"], state["tree_mu"] = 0, np.empty(sensor.n_nodes)
        return node_values()

    def exact_add_scaled(shift: int, alpha: float) -> None:
        w, offset, before = get_w(), weights.pending_offset, weights.scale.log_scale
        add_scaled(shift, alpha)
        if "update" in stages:  # the register holds w + offset: the update subtracts it
            s, alpha_t = weights.last_shift, weights.last_alpha
            t = np.clip(alpha_t - offset - state["tree_mu"] * 2.0**-s, -128, 127)
            set_w(np.clip(w + t, -127, 127))
            keep_scale(before)

    pipe.node_values, pipe.add_scaled = exact_node_values, exact_add_scaled
    transition = pipe.transition

    def exact_transition(costs, carried: bool = False) -> None:
        w, top, before = get_w(), weights.pending_top, weights.scale.log_scale
        transition(costs, carried)
        if "transition" in stages:
            keep_scale(before)
            offset = weights.pending_offset  # the stay cost left to the update
            if top is not None:
                w = np.maximum(np.clip(w - top, -127, 127), -p.memory)
            n = len(w)
            best = w - costs[0]
            for d in range(1, len(costs)):
                moved = np.r_[np.full(min(d, n), -float(p.memory)), w[: max(n - d, 0)]]
                best = np.maximum(best, np.clip(moved - costs[d], -127, 127))
            set_w(np.clip(np.clip(best, -127, 127) + offset, -127, 127))

    pipe.transition = exact_transition
    detect = pipe.detect

    def exact_detect(prev: int | None) -> tuple[int, int]:
        node, top = detect(prev)
        if "detect" in stages:
            w = get_w()
            top = int(np.floor(w.max()))
            node = choose_candidate(np.flatnonzero(w >= top), prev)
        return node, top

    pipe.detect = exact_detect


def stages_table(
    n_query: int | None = None,
    seeds: int = 4,
    processes: int = 2,
    exact: list[str] | None = None,
    routes: tuple[str, ...] = tuple(NOISE_ROUTES),
    store: str | None = None,
) -> None:
    """Max F1 of the robust preset (typical, no droop) with single stages made exact.

    ``store`` picks the low-res map store (``"analogue"`` keeps a two-tile map on one
    sensor, which the experiment needs; the default ``levels`` store runs Nordland on a
    bank).
    """
    print("\n| route | rep | stage made exact | max F1 (mean over seeds) | seeds |")
    print("|---|---|---|---:|---|")
    for name, spec in (NOISE_ROUTES[r] for r in routes):
        for rep in ("lowres", "lbp"):
            stages = [s for s in STAGES[rep] if exact is None or s in exact]
            own = store if store in PLACES[rep].stores else None
            configs = [(), *((s,) for s in stages), tuple(stages)]
            jobs = [
                (spec, rep, "robust", "typical-no-droop", seed, n_query, c, own)
                for c in configs
                for seed in range(seeds)
            ]
            f1 = _map(jobs, processes)
            for i, c in enumerate(configs):
                vals = f1[i * seeds : (i + 1) * seeds]
                label = "none" if not c else ("all of them" if len(c) > 1 else c[0])
                print(
                    f"| {name} | {rep} | {label} | {np.mean(vals):.3f} | "
                    f"{' '.join(f'{v:.2f}' for v in vals)} |",
                    flush=True,
                )


def figures(out: Path, presets: tuple[str, ...] = FILTER_PRESETS) -> None:
    from ppaloc.onsensor.figures import (
        database_figure,
        difference_figure,
        weights_figure,
        weights_history_image,
    )

    out.mkdir(parents=True, exist_ok=True)
    ref, query, _ = load(GARDENS)
    for preset in presets:
        tag = "" if preset == "paper" else f"_{preset}"
        for rep in ("lowres", "lbp"):
            loc = OnSensorLocaliser(
                rep, preset=preset, motion="always_forward", record_weights=True
            )
            loc.build_map(ref)
            print(database_figure(loc, out / f"{rep}{tag}_database.png"))
            print(weights_figure(loc, query[:60], out / f"{rep}{tag}_weights.png", snapshots=4))
            print(difference_figure(loc, query[60], out / f"{rep}{tag}_difference.png"))
            history = out / f"{rep}{tag}_weights_history.png"
            print(weights_history_image(loc.localise(query), history))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument(
        "--part",
        nargs="*",
        default=["agreement", "timing", "noise", "figures"],
        choices=["agreement", "timing", "noise", "stages", "terms", "forgetting", "figures"],
    )
    parser.add_argument("--seeds", type=int, default=4, help="noise seeds (noise, stages)")
    parser.add_argument("--processes", type=int, default=2, help="worker processes")
    parser.add_argument(
        "--exact", nargs="*", default=None, help="stages part: only these stages (default all)"
    )
    parser.add_argument(
        "--noise-route",
        nargs="*",
        default=list(NOISE_ROUTES),
        choices=list(NOISE_ROUTES),
        help="routes of the noise and stages parts (default all)",
    )
    parser.add_argument(
        "--store",
        nargs="*",
        default=["default"],
        help="noise part: map stores (default: each preset's; e.g. levels analogue); stages "
        "part: the first one given",
    )
    parser.add_argument(
        "--noise-levels",
        nargs="*",
        default=["typical", "typical-no-droop"],
        choices=["low", "typical", "high", "typical-no-droop"],
        help="noise part: the noisy settings (default typical, typical without droop)",
    )
    parser.add_argument("--figures", type=Path, default=Path("onsensor-figures"))
    parser.add_argument("--max-query", type=int, default=None, help="first N queries only")
    parser.add_argument(
        "--preset",
        nargs="*",
        default=list(FILTER_PRESETS),
        choices=list(FILTER_PRESETS),
        help="filter presets to run (default both)",
    )
    parser.add_argument(
        "--rep",
        nargs="*",
        default=list(REPRESENTATIONS),
        choices=list(PLACES),
        help="representations of the agreement, timing and noise parts (default lowres "
        "lbp; lowres16 and haar run the robust preset only)",
    )
    parser.add_argument(
        "--motion",
        nargs="*",
        default=["image", "image, every frame", "always_forward"],
        choices=["image", "image, every frame", "always_forward"],
        help="agreement part: the Nordland route's motion models and maps (default all)",
    )
    parser.add_argument(
        "--route",
        nargs="*",
        default=["synthetic", "nordland"],
        choices=["synthetic", "nordland"],
        help="routes of the agreement part (default both)",
    )
    parser.add_argument(
        "--filter",
        action="append",
        default=[],
        metavar="KEY=VALUE",
        help="agreement, timing and noise parts: a robust filter parameter (for host and "
        "sensor alike; e.g. local_gain=2), repeatable",
    )
    args = parser.parse_args()
    presets, reps = tuple(args.preset), tuple(args.rep)
    params = {}
    for item in args.filter:
        key, _, value = item.partition("=")
        try:
            params[key] = ast.literal_eval(value)
        except (ValueError, SyntaxError):  # a bare word: the string itself
            params[key] = value
    FILTER.update(params)
    if "timing" in args.part:
        timing(presets=presets, reps=reps, params=params)
    if "agreement" in args.part:
        if "synthetic" in args.route:
            agreement("synthetic (300 places)", SYNTHETIC, ("image",), presets, reps, params)
        if "nordland" in args.route:
            motions = tuple(args.motion)
            agreement("nordland summer->winter", NORDLAND, motions, presets, reps, params)
    if "noise" in args.part:
        noise(
            args.max_query,
            presets,
            args.seeds,
            args.processes,
            tuple(args.noise_route),
            tuple(args.store),
            tuple(args.noise_levels),
            reps,
        )
    if "stages" in args.part:
        stages_table(
            args.max_query,
            args.seeds,
            args.processes,
            args.exact,
            tuple(args.noise_route),
            next((s for s in args.store if s != "default"), None),
        )
    if "terms" in args.part:
        terms(args.max_query, args.seeds, args.processes, tuple(args.noise_route))
    if "forgetting" in args.part:
        forgetting(routes=tuple(args.noise_route))
    if "figures" in args.part:
        figures(args.figures, presets)


if __name__ == "__main__":
    main()
