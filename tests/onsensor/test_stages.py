"""Stages of the on-sensor pipeline on a small (64x64) array, against numpy references."""

from __future__ import annotations

import numpy as np
import pytest

from ppaloc.errors import PpalocError
from ppaloc.localise.params import FilterParams
from ppaloc.localise.schedule import make_schedule
from ppaloc.onsensor import detect
from ppaloc.onsensor.executor import SensorExecutor
from ppaloc.onsensor.lbp import LbpPlaces
from ppaloc.onsensor.lowres import LowresPlaces
from ppaloc.onsensor.mapping import row_runs, upload_map
from ppaloc.onsensor.motion import count
from ppaloc.onsensor.pipeline import make_pipeline
from ppaloc.onsensor.program import KernelCache, halve_level, pull, scale_negated
from ppaloc.place import lbp_from_grid, normalise_contrast
from ppaloc.sim import NEWS, A, B, C, D, E, F, Scamp5, east, north, south, west
from ppaloc.topomap import TopoMap

SIZE = 64
PARAMS = FilterParams.create(
    "lowres", preset="paper", arithmetic="ppa8", alpha=4, k=4, shift=2, motion="always_forward"
)


ROBUST = FilterParams.create("lowres", arithmetic="ppa8", motion="always_forward")


def _pipe(rep: str = "lowres", n: int = 40, preset: str = "paper") -> SensorExecutor:
    params = PARAMS if preset == "paper" else ROBUST
    return make_pipeline(rep, n, params, size=SIZE)


def _frame(seed: int) -> np.ndarray:
    rng = np.random.default_rng(seed)
    return rng.integers(0, 256, (SIZE, SIZE), dtype=np.uint8)


def _means(frame: np.ndarray) -> np.ndarray:
    v = frame.astype(np.float64) / 2 - 64
    b = SIZE // 8
    return v.reshape(8, b, 8, b).mean(axis=(1, 3))


@pytest.mark.parametrize(("direction", "d"), [(east, 1), (west, 2), (south, 3), (north, 5)])
def test_pull_moves_by_d_in_every_direction(direction, d):
    sim = Scamp5(8, 8)
    x = np.arange(64, dtype=np.float32).reshape(8, 8) - 32
    sim.write(A, x)
    with sim.kernel() as k:
        pull(k, B, A, direction, d)
    dr, dc = direction.offset
    want = np.zeros_like(x)
    for r in range(8):
        for c in range(8):
            rr, cc = r + d * dr, c + d * dc
            if 0 <= rr < 8 and 0 <= cc < 8:
                want[r, c] = x[rr, cc]
    np.testing.assert_array_equal(sim.read(B), want)


def test_halve_level_keeps_the_extreme_pair_unsaturated():
    sim = Scamp5(1, 4)
    sim.write(A, np.array([[64.0, 64.0, -63.5, -63.5]]))  # holds -q: q = -64 and 63.5
    with sim.kernel() as k:
        halve_level(k, A, B, east, 1)
    assert sim.read(A)[0, 0] == 64.0  # -(-64 + -64) / 2 exactly, no clip at 128
    assert sim.read(A)[0, 2] == -63.5


@pytest.mark.parametrize(("sign", "exponent"), [(1, 1), (-1, 1), (1, 0), (-1, -1), (1, -3)])
def test_scale_negated(sign, exponent):
    sim = Scamp5(1, 2)
    base = np.array([[5.25, 12.0]], np.float32)
    sim.write(A, sign * base)
    with sim.kernel() as k:
        out = scale_negated(k, A, sign, exponent, B)
    np.testing.assert_array_equal(sim.read(out), -base * 2.0**exponent)


def _acc(k, x):
    k.add(A, A, x)


BUILT: list[int] = []


def _counted(k, x):
    BUILT.append(1)
    _acc(k, x)


def test_kernel_cache_records_once_and_replays():
    sim = Scamp5(2, 2)
    cache = KernelCache(sim)
    BUILT.clear()
    sim.write(B, np.ones((2, 2)))
    for _ in range(3):
        cache.run(_counted, B)
    assert BUILT == [1] and cache.icws == 2 and cache.kernels == 1
    np.testing.assert_array_equal(sim.read(A), np.full((2, 2), 3.0))


def test_kernel_cache_keys_hold_every_value_the_body_reads():
    """A kernel is known by its builder and the values it is built from: another
    argument records another kernel, two builders of the same body share one, and a
    builder over an object (whose state may change under the same key) is refused."""
    sim = Scamp5(2, 2)
    cache = KernelCache(sim)
    cache.run(_acc, B)
    cache.run(_acc, C)  # another body under the same builder
    cache.run(lambda k: k.add(A, A, B))  # the first body again, from another builder
    assert cache.kernels == 2 and cache.icws == 4

    class Holder:
        reg = B

    holder = Holder()
    with pytest.raises(PpalocError, match="closure value 'holder' is Holder"):
        cache.run(lambda k: k.add(A, A, holder.reg))
    with pytest.raises(PpalocError, match="must be a function, not method"):
        cache.run(cache.run, B)


def _acc_on_heap(k, x):
    k.move_to_heap(True)
    _acc(k, x)


def test_kernel_cache_shares_a_body_only_where_it_is_kept():
    """The same ICWs on the stack and on the heap are two kernels: neither builder's
    kernel takes the other's place, and only the stack one holds the stack."""
    from ppaloc.sim.kernel import icw_stack

    sim = Scamp5(2, 2)
    cache = KernelCache(sim, check=True)
    on_stack, on_heap = cache.run(_acc, B), cache.run(_acc_on_heap, B)
    cache.run(_acc, B), cache.run(_acc_on_heap, B)  # replayed, each checked again
    assert not on_stack.on_heap and on_heap.on_heap and on_stack is not on_heap
    assert cache.kernels == 2 and cache.icws == 2 == icw_stack(sim).used


def test_kernel_cache_check_mode_finds_a_body_its_key_does_not_hold():
    sim = Scamp5(2, 2)
    cache = KernelCache(sim, check=True)
    source = {"reg": B}

    def sneaky(k):  # reads a dict it was not given: the key cannot see it
        k.add(A, A, source["reg"])

    with pytest.raises(PpalocError, match="closure value 'source' is dict"):
        cache.run(sneaky)
    which = [B]

    def build(k, i):
        k.add(A, A, GLOBAL_REGS[which[0] is C])

    with pytest.raises(PpalocError, match="closure value 'which' is list"):
        cache.run(build, 0)
    cache.run(_global_reader)
    GLOBAL_REGS[0] = C  # a global the builder reads changes
    try:
        with pytest.raises(AssertionError, match="records a different body under the same key"):
            cache.run(_global_reader)
    finally:
        GLOBAL_REGS[0] = B


GLOBAL_REGS = [B, C]


def _global_reader(k):
    k.add(A, A, GLOBAL_REGS[0])


@pytest.mark.parametrize("preset", ["paper", "robust"])
def test_block_means_are_exact_everywhere_in_the_block(preset):
    pipe = _pipe(preset=preset)
    frame = _frame(1)
    pipe.capture(frame)
    got = -pipe.sim.read(F).astype(np.float64)
    np.testing.assert_array_equal(got, np.kron(_means(frame), np.ones((8, 8))))


@pytest.mark.parametrize("preset", ["paper", "robust"])
def test_replicate_tiles_the_grid_into_every_node_block(preset):
    pipe = _pipe(preset=preset)
    frame = _frame(2)
    pipe.capture(frame)
    pipe.places.prepare_live()
    got = -pipe.sim.read(F).astype(np.float64)
    grid = _means(frame)  # paper: the exact block means
    if preset == "robust":  # the block means' floors, contrast-normalised (levels q'/2 - 64)
        q = np.floor(2 * (grid + 64)).astype(np.int64)
        c, tile = pipe.params.contrast, pipe.params.contrast_patch
        grid = normalise_contrast(q, c, tile).astype(np.float64) / 2 - 64
    np.testing.assert_array_equal(got, np.tile(grid, (SIZE // 8, SIZE // 8)))


def test_upload_writes_the_snake_layout_exactly():
    rng = np.random.default_rng(3)
    q = rng.integers(0, 256, (70, 8, 8), dtype=np.uint8)  # 2 tiles of 64 nodes at 64x64
    pipe = _pipe("lowres", len(q))
    upload_map(pipe, TopoMap("lowres", q))
    planes = pipe.layout.to_planes(q, fill=128).astype(np.float64) / 2 - 64
    np.testing.assert_array_equal(pipe.sim.read(A), planes[0])
    np.testing.assert_array_equal(pipe.sim.read(B), planes[1])


def test_upload_lbp_bits_and_row_runs():
    codes = np.array([0x80000001, 0xFFFFFFFF], np.uint32)
    bits = TopoMap("lbp", codes).node_blocks()
    assert bits[0, 0, 0] and bits[0, 3, 7] and bits[0].sum() == 2 and bits[1].all()
    assert row_runs(np.array([[1, 1, 0], [2, 2, 2]])) == [(1, 0, 0, 1), (0, 0, 2, 2), (2, 1, 0, 2)]
    pipe = _pipe("lbp", 2)
    upload_map(pipe, TopoMap("lbp", codes))
    plane = pipe.layout.to_planes(bits.astype(bool), fill=False)[0]
    np.testing.assert_array_equal(pipe.sim.read(pipe.sensor.roles.db[0]), plane)


@pytest.mark.parametrize("n", [40, 100])
def test_snake_shift_moves_every_weight_one_node_and_zeroes_node_0(n):
    pipe = _pipe("lowres", n)
    t, br, bc = pipe.layout.node_to_block(np.arange(n))
    w = np.zeros((SIZE, SIZE), np.float32)
    values = np.arange(n, dtype=np.float32) % 100 + 1
    w[br * 8, bc * 8 + t] = values
    pipe.sim.write(C, w)
    pipe.shift()
    np.testing.assert_array_equal(pipe.weights(), np.r_[0, values[:-1]])


def test_descriptor_equals_the_host_lbp_of_the_central_grid():
    pipe = _pipe("lbp", 4)
    for seed in range(3):
        frame = _frame(10 + seed)
        pipe.capture(frame)
        code = pipe.places.descriptor()
        assert code == int(lbp_from_grid(_means(frame)[1:7, 1:7]))


def test_motion_counts_are_exact():
    params = FilterParams.create("lowres", preset="paper", alpha=4, k=4, motion_margin=3)
    pipe = make_pipeline("lowres", 10, params, size=SIZE)
    rng = np.random.default_rng(5)
    plane = rng.random((SIZE, SIZE)) < 0.3
    tmp = pipe.sensor.roles.d.tmp_b
    pipe.sim.write(tmp, plane)
    assert count(pipe.sensor, tmp) == int(plane.sum())
    pipe.sim.write(tmp, np.ones((SIZE, SIZE), bool))
    assert count(pipe.sensor, tmp) == SIZE * SIZE  # full 8x16 blocks: -128, no clip


def _motion_counts(frames: list[np.ndarray], margin: int) -> list[tuple[int, int, int]]:
    """The image motion test's ``(changed, support, coherent)`` in numpy at any array size:
    block means of ``SIZE // 8`` pixels, the dead zone, the crossings, those of them with
    a crossing among their four neighbours."""
    from ppaloc.localise.motion import coherent_crossings

    b = frames[0].shape[0] // 8
    out, prev = [], None
    for f in frames:
        p = f.astype(np.int64)
        sums = p.reshape(8, b, 8, b).sum(axis=(1, 3))
        x = p * b * b - np.kron(sums, np.ones((b, b), np.int64))
        u, d = x > 2 * b * b * margin, x < -2 * b * b * margin
        if prev is not None:
            crossed = (prev[0] & d) | (prev[1] & u)
            coherent = int(coherent_crossings(crossed).sum())
            out.append((int(crossed.sum()), int((u | d).sum()), coherent))
        prev = (u, d)
    return out


@pytest.mark.parametrize("rep", ["lowres", "lbp", "lowres16"])
@pytest.mark.parametrize(
    ("shift", "coherent_shift", "read", "forward"),
    [
        (6, 8, "sk sk sk sk sk", "..F.F"),  # the defaults: the coherent count decides
        (1, 12, "csk sk csk sk csk", "....F"),  # coherent between the bars: changed too
        (6, 0, "cs cs cs cs cs", "..F.F"),  # the paper's test: changed, then support
    ],
)
def test_motion_stage_counts_as_numpy_and_keeps_every_kept_register(
    rep, shift, coherent_shift, read, forward
):
    """Consecutive frames with pixel noise (crossings alone) and a moved stripe (crossings
    in runs): the counts the sensor reads are numpy's, its decisions the rule's, and
    every digital register a role keeps (the valid node roots, the class masks, the
    map's bits: some in R1-R4, which ``DNEWS`` overwrites with its direction) holds
    what it held."""
    from ppaloc.localise.motion import forward_decision

    bars = {"motion_shift": shift, "motion_coherent_shift": coherent_shift}
    params = FilterParams.create(rep, arithmetic="ppa8", **bars)
    pipe = make_pipeline(rep, 4, params, size=SIZE)
    rng = np.random.default_rng(9)
    base = np.kron(rng.integers(0, 256, (16, 16)), np.ones((4, 4), np.int64))
    frames = []
    for move in (0, 0, 0, 3, 3, 9):
        noisy = np.roll(base, move, axis=1) + rng.integers(-12, 13, base.shape)
        frames.append(np.clip(noisy, 0, 255).astype(np.uint8))
    roles = pipe.sensor.roles
    kept = {
        reg
        for name, reg in roles.kept()
        if reg.kind == "digital" and name not in ("d.u_prev", "d.d_prev")
    }
    assert {"R1", "R2", "R4"} <= {r.name for r in kept} if rep == "lowres" else kept
    got, moved = [], []
    for frame in frames:
        pipe.capture(frame)
        planes = {reg: rng.random((SIZE, SIZE)) < 0.5 for reg in kept}
        for reg, plane in planes.items():
            pipe.sim.write(reg, plane)
        moved.append(pipe.motion(None))
        for reg, plane in planes.items():
            np.testing.assert_array_equal(pipe.sim.read(reg), plane, err_msg=reg.name)
        got.append(pipe.planes.last_counts)
    want = _motion_counts(frames, params.motion_margin)
    names = {"c": "changed", "s": "support", "k": "coherent"}
    for counts, full, letters in zip(got[1:], want, read.split(), strict=True):
        assert [f for f in counts._fields if getattr(counts, f) is not None] == [
            names[x] for x in "csk" if x in letters
        ]
        assert all(
            getattr(counts, f) in (None, v) for f, v in zip(counts._fields, full, strict=True)
        )
    rule = [forward_decision(*w, shift=shift, coherent_shift=coherent_shift) for w in want]
    assert moved[1:] == rule == [x == "F" for x in forward]
    # the still frames' noise crosses pixels alone, the moved stripe's crossings run
    assert want[0][0] > 4 * want[0][2] and want[2][0] < 2 * want[2][2]


def test_make_pipeline_picks_the_places_of_the_representation():
    assert type(_pipe("lowres").places) is LowresPlaces
    assert type(_pipe("lbp", 4).places) is LbpPlaces
    assert isinstance(_pipe("lbp", 4), SensorExecutor)
    with pytest.raises(PpalocError, match="no on-sensor pipeline"):
        make_pipeline("hog", 4, PARAMS, size=SIZE)


def test_shared_registers_are_named():
    from ppaloc.onsensor import lbp, lowres

    dl, db = LowresPlaces.roles.d, LbpPlaces.roles.d
    assert dl.aliases() == {"R3": ("pattern", "root32")}
    assert db.aliases() == {"R1": ("pattern", "root32")}
    assert lowres.ROOTS == dl.pattern == dl.root32
    assert lbp.DESCRIPTOR == db.tmp_b and lbp.DESCRIPTOR_TMP == db.tmp_a


@pytest.mark.parametrize("places", [LowresPlaces, LbpPlaces])
def test_register_roles_keep_live_values_apart(places):
    """Each representation's roles pass the check, and moving any working role onto a
    register a kept role holds is refused."""
    import dataclasses

    roles = places.roles.check()
    kept = dict(roles.kept())
    for role in ("means", "spare", "frame"):
        for reg in kept.values():
            if reg.kind != "analog":
                continue
            with pytest.raises(PpalocError, match=f"working {role} is on {reg.name}"):
                dataclasses.replace(roles, **{role: reg}).check()
    d = dataclasses.replace(roles.d, cand=roles.d.valid)
    with pytest.raises(PpalocError, match=r"working d\.cand is on"):
        dataclasses.replace(roles, d=d).check()


def test_too_many_tiles_is_a_clear_error():
    with pytest.raises(PpalocError, match="needs 3 tiles"):
        _pipe("lowres", 3 * 64)


def test_unused_registers_are_untouched_by_a_frame():
    pipe = _pipe("lbp", 4)
    schedule = make_schedule(pipe.params)
    schedule.use_map(TopoMap("lbp", np.zeros(4, np.uint32)))
    pipe.sim.write(A, np.full((SIZE, SIZE), 7.0))
    schedule.step(pipe, _frame(7))
    assert (pipe.sim.read(A) == 7.0).all() and NEWS.name == "NEWS" and D != E


@pytest.mark.parametrize(("prev", "want"), [(None, 10), (50, 50), (95, 90), (3, 10)])
def test_detection_tie_break_with_more_ties_than_event_slots(prev, want):
    n = 120  # lbp at 64x64: 128 nodes per tile
    pipe = _pipe("lbp", n)
    t, br, bc = pipe.layout.node_to_block(np.arange(n))
    w = np.full((SIZE, SIZE), -50.0, np.float32)
    values = np.full(n, -20.0, np.float32)
    values[10:91] = 30.5  # 81 candidates tie at floor(max) = 30
    w[br * 4, bc * 8 + t] = values
    w[4 * 15, 8 * 7] = 90.0  # an unused block (beyond node 119) never counts
    pipe.sim.write(C, w)
    assert pipe.detect(prev) == (want, 30)


@pytest.mark.parametrize("negated", [False, True])
@pytest.mark.parametrize(("bits", "want"), [(0, [3, 7, 40, 41]), (4, [7, 41]), (2, [3, 7, 41])])
def test_detection_refines_the_candidates_threshold_by_fraction_bits(negated, bits, want):
    """Candidates at ``floor(2**bits max W) / 2**bits`` (max 30.97: 30.9375 at 4 bits, 30.75
    at 2), from the weights or from minus them in the free register; T stays 30."""
    n = 60
    pipe = _pipe("lbp", n)
    t, br, bc = pipe.layout.node_to_block(np.arange(n))
    values = np.full(n, -20.0, np.float32)
    values[[3, 7, 40, 41]] = 30.8, 30.97, 30.1, 30.95
    w = np.full((SIZE, SIZE), 99.0, np.float32)  # only the node roots count
    w[br * 4, bc * 8 + t] = values
    if negated:
        pipe.sim.write(A, -w)
        pipe.state.negated = True
    else:
        pipe.sim.write(C, w)
    pipe.sensor.allow(False)
    top = detect.local_top(pipe.sensor, pipe.state)
    frac = detect.max_fraction(pipe.sensor, pipe.state, top, bits) if bits else 0
    assert (top, frac) == (30, {0: 0, 2: 3, 4: 15}[bits])
    assert detect.candidates(pipe.sensor, pipe.state, top, None, frac, bits) == want
    nearest = min(want, key=lambda node: (abs(node - 40), node))
    assert pipe.detect(40, bits) == (nearest, 30)


def test_confidence_is_the_threshold_gap_outside_the_window():
    n = 100
    pipe = _pipe("lbp", n)
    t, br, bc = pipe.layout.node_to_block(np.arange(n))
    values = np.full(n, -20.0, np.float32)
    values[60], values[65], values[90] = 40.5, 35.0, 10.2  # 65 is inside +-10 of 60
    w = np.zeros((SIZE, SIZE), np.float32)
    w[br * 4, bc * 8 + t] = values
    pipe.sim.write(C, w)
    node, top = pipe.detect(None)
    assert (node, top) == (60, 40)
    assert pipe.confidence(node, top, (node - 10, node + 10)) == 40 - 10
    # refined to 1/16: T = 40.5 (the detection's fraction), outside 10.2 -> 10.1875
    node, top = pipe.detect(None, 4)
    assert (node, top, pipe.state.top_fraction) == (60, 40, 8)
    assert pipe.confidence(node, top, (node - 10, node + 10), 4) == 40.5 - 10.1875


@pytest.mark.parametrize("rep", ["lowres", "lbp"])
def test_event_nodes_come_from_the_block_table_as_the_layout_maps_them(rep):
    """Every node root of every tile maps to its node through the table made once, as
    the layout's block_to_node maps it; events come back sorted."""
    p = FilterParams.create(rep, motion="always_forward")
    pipe = make_pipeline(rep, 4, p, size=64)
    nodes = np.arange(2 * pipe.layout.capacity)
    tile, br, bc = pipe.layout.node_to_block(nodes)
    events = np.stack([br * pipe.sensor.bh, bc * pipe.sensor.bw + tile], axis=1)
    assert np.array_equal(pipe.sensor.nodes_of(events[::-1]), nodes)
    rows, cols = events[:, 0], events[:, 1]
    want = pipe.layout.block_to_node(
        cols % pipe.sensor.bw, rows // pipe.sensor.bh, cols // pipe.sensor.bw
    )
    assert np.array_equal(pipe.sensor.nodes_of(events), np.sort(want))


def test_a_map_with_runs_keeps_its_table_on_the_controller():
    """A map of every frame with runs: the sensor takes it and keeps the runs' table
    (longest run less one; the rectangles of continuing roots), the paper preset ignores
    the runs, and a map without runs leaves nothing to do."""
    from ppaloc.onsensor import OnSensorLocaliser

    runs = TopoMap("lbp", np.zeros(12, np.uint32), places=[0, 1, 1, 1, 2, 3, 3, 4, 5, 6, 7, 7])
    loc = OnSensorLocaliser("lbp", size=64)
    loc.use_map(runs)
    sensor = loc.pipeline.sensor
    assert sensor.run_steps == 2
    # nodes 2, 3 (block row 0, columns 5 and 4), 6 (column 1), 11 (row 1, column 3)
    assert sensor.run_rects == {0: [(0, 32, 0, 47), (0, 8, 0, 15), (4, 24, 4, 31)]}
    paper = OnSensorLocaliser("lbp", size=64, preset="paper")
    paper.use_map(runs)
    assert paper.pipeline.sensor.run_steps == 0
    loc.use_map(TopoMap("lbp", np.zeros(12, np.uint32)))
    assert loc.pipeline.sensor.run_steps == 0 and loc.pipeline.sensor.run_rects == {}
