"""The robust preset: its ppa8 contract written out literally, and what it is for."""

import math
from fractions import Fraction

import numpy as np
import pytest
from hypothesis import example, given, settings
from hypothesis import strategies as st

from ppaloc.evaluate.run import predicted_frames
from ppaloc.localise.params import (
    VARY_AGE,
    FilterParams,
    PathSpeed,
    frame_scale,
    likelihood_shift,
    refined_minimum,
    transition_costs,
)
from ppaloc.localise.schedule import make_schedule
from ppaloc.localise.weighted import WeightedNodeLocaliser
from ppaloc.place import block_sums, lowres_image, normalise_contrast
from ppaloc.topomap import TopoMap

from .conftest import blocky, stepped


def _gate(path, p: FilterParams, least: int | None = None) -> Fraction | None:
    """The speed of a path of ``(node, confidence)`` forward estimates over its last
    ``speed_window`` frames, 1/2 to 2 nodes a frame, where its estimates were sure (by
    ``least``, default ``speed_confidence``) and only advanced, at most ``max_advance``
    a frame; else None."""
    least = p.speed_confidence if least is None else least
    recent = path[-1 - p.speed_window :]
    steps = np.diff([node for node, _ in recent])
    if (
        p.speed_window
        and len(recent) == p.speed_window + 1
        and all(0 <= d <= p.max_advance for d in steps)
        and all(score >= least for _, score in recent)
    ):
        return min(max(Fraction(int(steps.sum()), p.speed_window), Fraction(1, 2)), Fraction(2))
    return None


def naive_robust(nodes, frames, moves, p: FilterParams, frame_index=None, centre=None):
    """docs/ppa8.md, "Robust preset", written out literally for low-res maps (8x8 or
    16x16 nodes; a tile of ``contrast_patch`` 32-pixel blocks is twice as many 16-pixel
    ones), the map's nodes made from reference frames ``frame_index`` (default one each).
    The speed lanes first, at ``1 + k (lane_speed - 1) / lanes`` for ``k = lanes .. 1``
    (with ``lane_speed``), then at 1/2 (with ``slow_lane``): the same filter with every
    forward frame's costs centred on ``centre`` (the lane's speed); after each frame
    the first lane's path speed (its gate at ``lane_confidence``) that is at least ``1 +
    gain / (2 skip_cost)`` (or ``max_advance``) or at most ``1 - gain / (2 stay_cost)``,
    from a path that did not stall, is taken where the filter's own path shows none;
    where none is, that of the surest lane above one node a frame (the first of equals)
    where its confidence reaches ``lane_confidence`` and leads the filter's last forward
    frame's by ``lane_speed_lead``, its node at most ``confidence_radius`` ahead of the
    filter's last: its path's speed with no confidence asked, in the same range, from a
    path that did not stall; a frame reports the surest lane's estimate
    and confidence where they lead its own by ``lane_lead``. The estimate reported is
    the rounded centroid of the nodes within ``centroid_radius`` of the one detected,
    each weighed by ``exp((x - max x) / centroid_temperature)``, ``x`` its weight
    rounded half up to an integer; the filter goes on from the detected node. The
    confidence reported is the frame's (or the lane's) times the share of ``exp((x - max
    x) / concentration_temperature)`` held within one node of the detected one among
    the nodes within ``concentration_radius`` of it (at least 2; else 1), the lanes'
    own leads and gates reading the confidence before it; the filter's own estimate
    reports 0 where its path held the map's last node over its last ``min(2,
    lost_window)`` forward frames."""
    lane = [None] * (len(frames) + 1)
    lane_outs = []  # each lane's (reported, weights, confidence, node) per frame, fastest first
    lane_any = []  # each lane's path speed after each frame, no confidence asked
    lane_v = []  # each lane's speed
    fast, slow = Fraction(0), Fraction(-1)
    if centre is None:
        fast = Fraction(p.max_advance)  # above the filter's own speeds
        if p.skip_cost:
            fast = min(fast, 1 + Fraction(p.gain, 2 * p.skip_cost))
        slow = 1 - Fraction(p.gain, 2 * p.stay_cost) if p.stay_cost else Fraction(-1)
        speeds = [1 + Fraction(k * (p.lane_speed - 1), p.lanes) for k in range(p.lanes, 0, -1)]
        for v in (speeds if p.lane_speed else []) + ([Fraction(1, 2)] if p.slow_lane else []):
            lane_out, seen, anyway = naive_robust(nodes, frames, moves, p, frame_index, v)
            lane_outs.append(lane_out)
            lane_any.append(anyway)
            lane_v.append(v)
            lane = [
                a if a is not None else b if b is not None and (b >= fast or b <= slow) else None
                for a, b in zip(lane, seen, strict=True)
            ]
    n, grid = len(nodes), nodes.shape[-1]
    first = np.arange(n) if frame_index is None else np.asarray(frame_index)
    stood = np.append(np.diff(first), 1) > 1  # the map stood still there: several frames
    stood[:-1] |= stood[1:].copy()  # ... or at the next node (a query stops a place short)
    cells, patch = grid * grid, p.contrast_patch * grid // 8
    # every image, live or node, contrast-normalised (docs/ppa8.md, "Robust preset")
    q = normalise_contrast(nodes, p.contrast, patch).astype(float).reshape(n, cells)
    w = np.zeros(n)
    out, prev, path = [], None, []  # path: (node, confidence) of each forward frame
    lost_at = []  # whether the filter's own path had stalled, per frame
    end_at = []  # ... or held the map's last node over END_WINDOW (2) forward frames
    still = 0  # frames since the last forward decision
    offs = []  # each speed the gate passed: off one node a frame by 3/8 or more
    speeds = [None]  # the path's speed after each frame (its gate's)
    anyway = [None]  # ... and with no confidence asked
    for t, (frame, moved) in enumerate(zip(frames, moves, strict=True), start=1):
        if t > 1:
            c = transition_costs(moved, p)
            v = _gate(path, p)
            if moved and centre is not None:  # a lane: centred on its own speed
                v = centre
            elif v is None:  # the lane's speed where the path shows none
                v = lane[t]
            faster = [k for k, u in enumerate(lane_v) if u > 1]  # the lanes above 1
            if v is None and faster and path and p.lane_speed_lead:  # the surest's
                k = max(faster, key=lambda k: (lane_outs[k][t - 1][2], -k))  # first of equals
                node, score = lane_outs[k][t - 1][3], lane_outs[k][t - 1][2]
                if (
                    score >= p.lane_confidence
                    and score >= path[-1][1] + p.lane_speed_lead
                    and 0 <= node - path[-1][0] <= p.confidence_radius  # where its speed took it
                ):
                    b = lane_any[k][t]
                    v = b if b is not None and (b >= fast or b <= slow) else None
            if moved and v is not None:
                # the transition centred on the speed v, 1/2 to 2 nodes a frame
                slope = [p.stay_cost if d < v else p.skip_cost for d in range(len(c))]
                c = [math.floor(slope[d] * abs(d - v) + 0.5) for d in range(len(c))]
                c = [x - min(c) for x in c]
                offs.append((len(path) + 1, abs(v - 1) >= 3 / 8))
            elif (  # of the last 16 such speeds, those of the last 64 forward frames
                moved
                and p.speed_vary
                and sum(off for f, off in offs[-16:] if len(path) + 1 - f < 64) >= p.speed_vary
            ):
                # no speed, but the speed varies: one node a frame at half the costs
                stay, skip = p.stay_cost // 2, p.skip_cost // 2
                c = [stay if d == 0 else skip * (d - 1) for d in range(len(c))]
            cand = []
            for d, cost in enumerate(c):
                src = np.concatenate((np.full(d, -p.memory), w))[:n] if d else w
                cand.append(src - cost)
            w = np.clip(np.max(cand, axis=0), -127, 127)
        if t == 1 or moved:
            f = normalise_contrast(lowres_image(frame, grid), p.contrast, patch)
            f = f.reshape(cells) / 2 - 64
            mu = np.minimum(np.abs(f - (q / 2 - 64)), 127).mean(axis=1)
            code = np.floor(128.5 - mu / 2)
            r = 2 * (128 - code)
            b = math.ceil(16 * mu.min()) / 16 - 1 / 32  # mu_min to 1/16
            s = 0
            while s < 6 and 2 * (r.mean() - b) > 3 * p.gain * 2**s:
                s += 1
            term = np.clip(math.floor(b * 2.0**-s) - mu * 2.0**-s, -128, 127)
            w = np.clip(w + term, -127, 127)
            if p.local_gain:  # item 3's local term: q units a strictly closer neighbour
                step, window = p.local_gain // (2 * p.local_window), p.local_window
                closer = [
                    sum(mu[j] < mu[i] for j in range(max(0, i - window), min(n, i + window + 1)))
                    for i in range(n)
                ]
                w = np.clip(w - step * np.array(closer), -127, 127)
        top = math.floor(w.max())
        cands = np.flatnonzero(w >= math.floor(16 * w.max()) / 16)
        node = cands[0] if prev is None else cands[np.argmin(np.abs(cands - prev))]
        prev = node
        r = p.confidence_radius
        outside = np.concatenate((w[: max(node - r, 0)], w[node + r + 1 :]))
        score = 0.0  # the refined threshold minus the outside maximum, each to 1/16
        if len(outside):
            score = math.floor(16 * w.max()) / 16 - math.floor(16 * outside.max()) / 16
        still = 0 if moved else still + 1  # frames since the last forward decision
        if still and not stood[node]:  # a still frame where the map kept moving
            score = min(score, max(0.0, score - p.still_decay * still))
        if moved and t > 1:
            path.append((int(node), score))
        lost = p.lost_window  # the record of forward frames held one place: on any frame
        if lost and len(path) > lost and len({n for n, _ in path[-1 - lost :]}) == 1:
            score = min(score, 0.0)  # the path stood still while the query moved
        rad = p.centroid_radius  # the reported node: the centroid of the reads about it
        a, b = max(node - rad, 0), min(node + rad, n - 1)
        x = [math.floor(v + 0.5) for v in w[a : b + 1]]
        e = [math.exp((v - max(x)) / p.centroid_temperature) for v in x]
        shown = a + math.floor(sum(i * v for i, v in enumerate(e)) / sum(e) + 0.5)
        share, rad = 1.0, p.concentration_radius  # the weights' share about the node
        if rad >= 2:
            a = max(node - rad, 0)
            x = [math.floor(v + 0.5) for v in w[a : min(node + rad, n - 1) + 1]]
            e = [math.exp((v - max(x)) / p.concentration_temperature) for v in x]
            share = sum(v for i, v in enumerate(e, start=a) if abs(i - node) <= 1) / sum(e)
        w = np.maximum(np.clip(w - top, -127, 127), -p.memory)
        out.append((int(shown), w.copy(), score, int(node), share))
        stalled = lost and len(path) > lost and len({n for n, _ in path[-1 - lost :]}) == 1
        gate = None if centre is None else p.lane_confidence  # a lane's path: its own gate
        speeds.append(None if stalled else _gate(path, p, gate))  # a stalled lane: none
        anyway.append(None if stalled else _gate(path, p, 0))
        lost_at.append(stalled)
        e = min(2, lost)
        end_at.append(bool(e) and len(path) > e and all(m == n - 1 for m, _ in path[-1 - e :]))
    for t, (shown, w, score, node, share) in enumerate(out):  # a lane that leads: its own
        lanes = [o[t] for o in lane_outs]
        best = max(lanes, key=lambda o: o[2], default=None)  # the first of equals
        own = True
        if p.lane_lead and best is not None and best[2] >= score + p.lane_lead and not lost_at[t]:
            shown, score, share, own = best[0], best[2], best[4], False
        if centre is None:  # the confidence reported; a lane's keeps its own for the above
            score *= share
            if own and end_at[t]:  # the filter's own path ran past the map's last node
                score = min(score, 0.0)
        out[t] = (shown, w, score, node, share)
    return out, speeds, anyway


#: The contract's explicit cases below differ from this one only where they say.
_CASE = dict(
    seed=0,
    n=4,
    gain=4,
    memory=127,
    costs=(4, 4, 4),
    max_advance=3,
    contrast=48,
    patch=2,
    kind="lowres",
    local=(2, 1),
    speed=(0, 0),
    lost=0,
    vary=0,
    decay=0,
    lanes=1,
    slow=False,
    lead=32,
    lane_gate=0,
    speed_lead=0,
    centroid=(2, 2),
    spread=(4, 4),
)


@settings(max_examples=25, deadline=None)
@given(
    seed=st.integers(0, 2**31),
    n=st.integers(2, 12),
    gain=st.integers(1, 32),
    memory=st.integers(8, 127),
    costs=st.tuples(st.integers(0, 64), st.integers(0, 64), st.integers(0, 64)),
    max_advance=st.integers(1, 3),
    contrast=st.sampled_from([0, 1, 16, 48, 127]),
    patch=st.sampled_from([2, 4, 8]),
    kind=st.sampled_from(["lowres", "lowres16"]),
    local=st.sampled_from([(0, 1), (2, 1), (8, 2), (6, 3)]),
    speed=st.sampled_from([(0, 0), (2, 0), (2, 4), (3, 1)]),
    lost=st.sampled_from([0, 2, 4]),
    vary=st.sampled_from([0, 1, 2]),
    decay=st.sampled_from([0, 4, 16]),
    lanes=st.integers(1, 3),
    slow=st.booleans(),
    lead=st.sampled_from([0, 8, 32]),
    lane_gate=st.sampled_from([0, 4, 24]),
    speed_lead=st.sampled_from([0, 4, 8, 24]),
    centroid=st.sampled_from([(0, 2), (2, 2), (4, 1), (3, 8), (2, 64)]),
    spread=st.sampled_from([(0, 4), (4, 4), (1, 4), (2, 1), (8, 16), (3, 64)]),
)
@example(  # a still frame after a stalled path: its score is 0, its margin positive
    **{**_CASE, "seed": 1, "max_advance": 1, "lost": 2}
)
@example(  # speeds off one node a frame, then a forward frame the gate fails: half costs
    **{**_CASE, "costs": (6, 4, 6), "local": (0, 1), "speed": (2, 0), "vary": 1}
)
@example(  # still frames on a map that stood still at some nodes and not at others
    **{**_CASE, "seed": 3, "n": 6, "decay": 4}
)
@example(  # the speed lane's path sets the costs where the filter's own shows no speed
    **{**_CASE, "seed": 2, "n": 8, "gain": 1, "memory": 8, "costs": (2, 0, 0)}
    | {"max_advance": 2, "contrast": 0, "local": (0, 1), "speed": (2, 0)}
)
@example(  # a lane's path passes its own gate (0 units), below the filter's own (4)
    **{**_CASE, "n": 8, "gain": 1, "memory": 8, "costs": (2, 0, 0), "max_advance": 2}
    | {"contrast": 0, "local": (0, 1), "speed": (2, 4), "lead": 0, "lane_gate": 0}
)
@example(  # no path passes a gate; the surest lane leads on the frame: its path's speed
    **{**_CASE, "n": 8, "max_advance": 2, "contrast": 0, "local": (0, 1), "speed": (2, 4)}
    | {"lead": 0, "lane_gate": 4, "speed_lead": 4}
)
@example(  # ... but not where its confidence is below the lanes' gate (16), lead or not
    **{**_CASE, "n": 8, "max_advance": 2, "contrast": 0, "local": (0, 1), "speed": (2, 4)}
    | {"lead": 0, "lane_gate": 16, "speed_lead": 4}
)
@example(  # ... nor where the surest lane is beyond confidence_radius of the filter
    **{**_CASE, "seed": 1, "n": 8, "max_advance": 2, "contrast": 0, "local": (0, 1)}
    | {"speed": (2, 4), "lead": 0, "lane_gate": 4, "speed_lead": 4}
)
@example(  # the slow lane leads: it hands over no speed on its lead
    **{**_CASE, "seed": 12, "n": 8, "max_advance": 2, "contrast": 0, "local": (0, 1)}
    | {"speed": (2, 4), "lead": 0, "lane_gate": 4, "speed_lead": 4, "slow": True}
)
@example(  # the slower lane's path sets the costs where the faster lane's shows none
    **{**_CASE, "seed": 132, "n": 8, "memory": 8, "costs": (2, 0, 4), "max_advance": 2}
    | {"contrast": 0, "local": (0, 1), "speed": (2, 0), "lanes": 2}
)
@example(  # the slow lane's path sets the costs: at or below the filter's own range
    **{**_CASE, "seed": 1, "n": 8, "memory": 8, "costs": (4, 0, 4), "max_advance": 2}
    | {"contrast": 0, "local": (0, 1), "speed": (2, 0), "slow": True}
)
@example(  # ... and a lane whose path stalled gives no speed
    **{**_CASE, "seed": 96, "n": 8, "memory": 8, "costs": (4, 0, 4), "max_advance": 2}
    | {"contrast": 0, "local": (0, 1), "speed": (2, 0), "slow": True, "lost": 2}
)
@example(  # a speed lane's confidence leads the filter's: its estimate is reported
    **{**_CASE, "seed": 54, "n": 8, "gain": 16, "memory": 64, "costs": (4, 0, 4)}
    | {"max_advance": 2, "contrast": 0, "local": (0, 1), "speed": (2, 0), "lead": 8}
)
@example(  # ... but not where the filter's own path stalled: it stays lost
    **{**_CASE, "seed": 16, "n": 8, "gain": 16, "memory": 64, "costs": (4, 0, 4)}
    | {"max_advance": 2, "contrast": 0, "local": (0, 1), "speed": (2, 0), "lead": 8, "lost": 2}
)
def test_ppa8_equals_the_robust_contract_written_out(
    seed,
    n,
    gain,
    memory,
    costs,
    max_advance,
    contrast,
    patch,
    kind,
    local,
    speed,
    lost,
    vary,
    decay,
    lanes,
    slow,
    lead,
    lane_gate,
    speed_lead,
    centroid,
    spread,
):
    rng = np.random.default_rng(seed)
    grid = 16 if kind == "lowres16" else 8
    nodes = rng.integers(0, 256, (n, grid, grid), dtype=np.uint8)
    frames = rng.integers(0, 256, (9, 256, 256), dtype=np.uint8)
    moves = rng.random(9) < 0.7
    frame_index = np.cumsum(rng.integers(1, 3, n)) - 1  # some nodes stand for two frames
    kw = dict(
        gain=gain,
        memory=memory,
        stay_cost=costs[0],
        move_cost=costs[1],
        skip_cost=costs[2],
        max_advance=max_advance,
        contrast=contrast,
        contrast_patch=patch,
        local_gain=local[0],
        local_window=local[1],
        speed_window=speed[0],
        speed_confidence=speed[1],
        lost_window=lost,
        speed_vary=vary,
        still_decay=decay,
        lanes=lanes,
        slow_lane=slow,
        lane_lead=lead,
        lane_confidence=lane_gate,
        lane_speed_lead=speed_lead,
        centroid_radius=centroid[0],
        centroid_temperature=centroid[1],
        concentration_radius=spread[0],
        concentration_temperature=spread[1],
        confidence_radius=1,
    )
    loc = WeightedNodeLocaliser(
        kind,
        arithmetic="ppa8",
        motion="oracle",
        oracle_moves=moves,
        record_weights=True,
        **kw,
    )
    loc.use_map(TopoMap(kind, nodes, frame_index=frame_index))
    want, _, _ = naive_robust(nodes, frames, moves, loc.params, frame_index)
    for est, (node, w, score, _, _) in zip(loc.localise(frames), want, strict=True):
        assert est.node == node and est.score == score
        np.testing.assert_array_equal(est.weights, w)
        assert est.weights.max() < 1 and est.weights.min() >= -memory


def test_transition_golden():
    # one node per frame, weights [0, -10, -20, -127]; forward: stay costs 4, +2 costs 4
    p = FilterParams.create("lbp", memory=100, max_advance=2)
    loc = WeightedNodeLocaliser("lbp", memory=100, max_advance=2, arithmetic="ppa8")
    loc.use_map(TopoMap("lbp", np.zeros(4, np.uint32)))
    ex = loc.executor
    ex.set_weights([0, -10, -20, -127])
    ex.transition(transition_costs(True, p))
    # node 0: max(0 - 4, edge -100 - 0, edge - 4); node 1: max(-14, 0, -104);
    # node 2: max(-24, -10, 0 - 4); node 3: max(-131 -> clip, -20, -14)
    np.testing.assert_array_equal(ex.weights(), [-4, 0, -4, -14])
    ex.transition(transition_costs(False, p))  # stay: free; +1 costs 4, +2 costs 8
    np.testing.assert_array_equal(ex.weights(), [-4, 0, -4, -8])


@pytest.mark.parametrize("pattern", [(1,), (2,), (1, 2), (0, 1, 1)])
def test_follows_a_query_at_another_speed(route, pattern):
    """A query at 0.67-2 places per frame: the robust filter follows it; the paper's
    one-node shift cannot (it falls behind at speed 2).

    At speed 2 the true path pays ``skip_cost`` every frame and a path at speed 1 loses
    about ``gain`` units of evidence (3/4 to 3/2 of it, by the power-of-two scale), so
    the margin is thin by design: the images stay as they are (``contrast=0``), whose
    scale lands the evidence above the cost; normalised, this toy route's lands below.
    The confidence's window is two nodes (``confidence_radius``): the default ten would
    leave no node of this 20-node map outside a middle estimate's window, its confidence
    0 there, and a speed lane's estimate would be reported (``lane_lead``)."""
    frames, truth = stepped(route, pattern)
    loc = WeightedNodeLocaliser("lowres", motion="always_forward", contrast=0, confidence_radius=2)
    loc.build_map(route)
    got = np.array([e.node for e in loc.localise(frames)])
    assert np.abs(got - truth)[3:].max() <= 1
    if pattern == (2,):
        paper = WeightedNodeLocaliser("lowres", preset="paper", motion="always_forward")
        paper.build_map(route)
        lag = np.array([e.node for e in paper.localise(frames)]) - truth
        assert np.abs(lag).max() > 2


@pytest.mark.parametrize("arithmetic", ["float", "ppa8"])
def test_a_query_that_leaves_the_map_is_reported_lost(route, arithmetic):
    """The query drives on past the map's last node: the estimate stays on it while the
    motion test sees the frames move, so once it has held that place over its last two
    forward frames (``END_WINDOW``; frames 11-19) the confidence is 0, and over
    ``lost_window`` (8) anywhere on the map (frames 17-19); before, it is positive, and
    the estimates are the same with the rules off."""
    kw = dict(arithmetic=arithmetic, motion="always_forward", confidence_radius=1)
    loc = WeightedNodeLocaliser("lowres", **kw)
    off = WeightedNodeLocaliser("lowres", lost_window=0, **kw)
    for each in (loc, off):
        each.build_map(route[:10])
    got, plain = loc.localise(route), off.localise(route)
    nodes, scores = [e.node for e in got], [e.score for e in got]
    assert nodes == [e.node for e in plain]
    assert nodes[3:] == [*range(3, 10), *[9] * 10]  # held on the last node
    # every frame after the first is a forward one: frame i's window reaches frame i - 8
    stalled = [i for i in range(9, 20) if len(set(nodes[i - 8 : i + 1])) == 1]
    assert stalled == [17, 18, 19]
    past_end = [i for i in range(9, 20) if nodes[i - 2 : i + 1] == [9, 9, 9]]
    assert past_end == list(range(11, 20))
    assert all(scores[i] == 0 for i in past_end)
    assert all(scores[i] > 0 for i in range(3, 11))
    assert all(plain[i].score > 0 for i in range(3, 20))


@pytest.mark.parametrize("arithmetic", ["float", "ppa8"])
def test_a_query_that_stops_after_leaving_the_map_stays_lost(route, arithmetic):
    """A still frame keeps the last forward frame's record: the query drives past the
    map's last node (reported lost from frame 11, two forward frames on it) and then
    stands (frames 20-24, called still by the controller's decision, the oracle's
    here), so those frames are lost
    too, though their weights' margin is as high as before; a query that stops on the
    map keeps its confidence (``still_decay`` off: its own test is below)."""
    moves = [True] * 20 + [False] * 5
    frames = np.concatenate((route, np.repeat(route[-1:], 5, axis=0)))
    kw = dict(
        arithmetic=arithmetic,
        motion="oracle",
        oracle_moves=moves,
        confidence_radius=1,
        still_decay=0,
    )
    loc, off = (WeightedNodeLocaliser("lowres", lost_window=w, **kw) for w in (8, 0))
    for each in (loc, off):
        each.build_map(route[:10])
    got, plain = loc.localise(frames), off.localise(frames)
    assert [e.node for e in got] == [e.node for e in plain]
    assert [e.score == 0 for e in got[3:]] == [False] * 8 + [True] * 14
    assert all(e.score > 0 for e in plain[17:])
    on = WeightedNodeLocaliser("lowres", **kw)  # the same query stops on a longer map
    on.build_map(route)
    assert all(e.score > 0 for e in on.localise(frames)[3:])


@pytest.mark.parametrize("arithmetic", ["float", "ppa8"])
@pytest.mark.parametrize("runs", [False, True])
def test_the_confidence_falls_on_still_frames_where_the_map_kept_moving(route, arithmetic, runs):
    """A query stands 4 frames at place 5, 4 at place 12 and 4 at place 15; the map
    stood still at places 12 and 16 (keyframe nodes of 6 and 2 reference frames, or runs
    of nodes of one place on a map of every frame) and not at 5 or 15. On the still
    frames at place 5 the confidence falls by ``still_decay`` (4 here) units a frame to
    0 at the least; at place 12, and at place 15 a place short of the map's stop at 16,
    it is the weights' margin, as on every frame with the rule off. The estimates are
    the same either way."""
    order = [*range(6), *[5] * 4, *range(6, 13), *[12] * 4, *range(13, 16), *[15] * 4, 16]
    moves = [True] * 6 + [False] * 4 + [True] * 7 + [False] * 4 + [True] * 3 + [False] * 4
    moves.append(True)
    if runs:  # place 12 is nodes 12-17 of one place, place 16 nodes 21-22
        ref = np.concatenate(
            (route[:13], np.repeat(route[12:13], 5, axis=0), route[13:17], route[16:])
        )
        places = np.array([*range(13), *[12] * 5, *range(13, 17), *range(16, 20)])
        m = TopoMap("lowres", lowres_image(ref, 8), np.arange(26), places=places)
    else:  # node 12 stands for reference frames 12-17, node 16 for 21-22
        m = TopoMap("lowres", lowres_image(route, 8), [*range(13), *range(18, 22), *range(23, 26)])
    kw = dict(arithmetic=arithmetic, motion="oracle", oracle_moves=moves, confidence_radius=1)
    kw |= dict(concentration_radius=0)  # the still frames' rule alone: the margin reported
    got, plain = [], []
    for decay, out in ((4, got), (0, plain)):
        loc = WeightedNodeLocaliser("lowres", still_decay=decay, **kw)
        loc.use_map(m)
        out += loc.localise(route[order])
    assert [e.node for e in got] == [e.node for e in plain]
    at5, at12 = slice(6, 10), slice(17, 21)
    fell = [e.score for e in got[at5]]
    assert fell == [max(e.score - 4 * k, 0.0) for k, e in enumerate(plain[at5], start=1)]
    assert fell[0] > 0 and fell[-1] == 0  # a fall, down to the floor
    at15 = slice(24, 28)
    assert all(e.score > 0 for e in plain[at12]) and all(e.score > 0 for e in plain[at15])
    assert [e.score for e in got[at12]] == [e.score for e in plain[at12]]
    assert [e.score for e in got[21:]] == [e.score for e in plain[21:]]


def test_a_path_held_in_a_run_of_one_place_is_a_path_held(route):
    """On a map with runs the stall is counted in places: past a map whose last place is
    a run of 5 nodes, the estimate flows along the run (nodes 9-13) and holds its last
    node, and the score falls to 0 once place 9, the map's last, has held over two
    forward frames (frames 11-19; ``past_map_end``), where counting nodes would see no
    stall before frame 15. (The detected nodes: the centroid of the run's equal weights
    would report a node inside it.)"""
    ref = np.concatenate((route[:10], np.repeat(route[9:10], 4, axis=0)))
    places = np.array([*range(10), 9, 9, 9, 9])
    m = TopoMap("lowres", lowres_image(ref, 8), np.arange(14), places=places)
    kw = dict(motion="always_forward", confidence_radius=1, centroid_radius=0)
    loc = WeightedNodeLocaliser("lowres", **kw)
    loc.use_map(m)
    est = loc.localise(route)
    assert [e.node for e in est][9:] == [9, 10, 11, 12, *[13] * 7]
    assert [e.score == 0 for e in est[9:]] == [False] * 2 + [True] * 9


def test_keyframes_merge_a_stop_into_one_node_that_predicts_its_own_frame():
    """A reference that stands still for 4 frames maps to one node; that node predicts its
    own frame, whatever the ground truth (which frames show one place is the dataset's)."""
    rng = np.random.default_rng(2)
    route = rng.integers(0, 256, (12, 256, 256), dtype=np.uint8)  # textured: the test sees
    ref = np.concatenate((route[:5], np.repeat(route[5:6], 4, axis=0), route[6:]))
    loc = WeightedNodeLocaliser("lowres", arithmetic="ppa8")
    m = loc.build_map(ref)
    assert len(m) == len(route)
    first, end = m.frame_spans()
    assert (first[5], end[5]) == (5, 9)
    assert predicted_frames(np.array([5, 6]), m.frame_index).tolist() == [5, 9]
    off = WeightedNodeLocaliser("lowres", keyframes=False)
    assert len(off.build_map(ref)) == len(ref)


def test_still_frames_add_no_evidence(route):
    """A frame the motion test calls still changes the weights by the transition alone."""
    loc = WeightedNodeLocaliser(
        "lowres", motion="oracle", oracle_moves=[False, True, False], record_weights=True
    )
    loc.use_map(TopoMap("lowres", np.stack([block_sums(f) >> 10 for f in route]).astype(np.uint8)))
    loc.step(route[3])
    before = loc.step(route[4]).weights.astype(np.float64)
    after = loc.step(blocky(np.zeros((8, 8)))).weights  # an unrelated frame, called still
    c = transition_costs(False, loc.params)
    padded = np.concatenate((np.full(2, -127.0), before))
    pred = np.max([padded[2 - d : 2 - d + len(before)] - c[d] for d in range(3)], axis=0)
    want = np.maximum(pred - pred.max(), -127)
    np.testing.assert_allclose(after, want, atol=1e-5)


def test_scale_follows_the_frame_not_the_map():
    """Distances four times larger (a darker, other-season query) get a shift two larger."""
    assert likelihood_shift(64, 4) == likelihood_shift(16, 4) + 2


@given(st.integers(0, 128 * 128))
def test_the_refined_minimum_is_the_middle_of_the_sixteenth_mu_lies_in(sad):
    """On the distances' 1/128 grid: within 1/32 of ``mu``, and ``b + 1/32`` the first
    sixteenth at or above it (what five threshold tests on the array give)."""
    mu = sad / 128
    b = refined_minimum(mu)
    assert abs(b - mu) <= 1 / 32
    assert (b + 1 / 32) * 16 == math.ceil(16 * mu)


@given(
    values=st.lists(st.integers(0, 256), min_size=1, max_size=40),
    best32=st.integers(-1, 32 * 256),
    gain=st.integers(1, 32),
)
def test_the_scale_in_integers_is_the_scale_of_the_exact_mean(values, best32, gain):
    """Register arithmetic compares ``2 (mean - b)`` on the sum, without rounding the
    mean: the same shift as in float, and ``alpha_t = floor(b 2**-s)``."""
    v = np.array(values)
    best = best32 / 32
    s, alpha = frame_scale(v, best, gain, exact=True)
    assert s == frame_scale(v.astype(float), best, gain, exact=False)[0]
    assert alpha == math.floor(best * 2.0**-s)


@settings(max_examples=30, deadline=None)
@given(
    seed=st.integers(0, 2**31),
    n=st.integers(1, 40),
    kind=st.sampled_from(["lowres", "lowres16", "lbp", "haar"]),
    gain=st.integers(1, 32),
)
def test_float_and_ppa8_decide_the_scale_on_the_same_readout(seed, n, kind, gain):
    """The frame's scale depends on the frame and the map only, and both arithmetics
    take it from the controller's readout: the same values and best distance, and the
    schedule adds the likelihood at the same shift and ``alpha_t`` (docs/ppa8.md,
    "Register arithmetic against float")."""
    rng = np.random.default_rng(seed)
    cells = rng.integers(0, 248, (n + 1, 16, 16))  # 16-pixel cells: every place differs
    frames = np.kron(cells, np.ones((16, 16))).astype(np.uint8)
    frames += rng.integers(0, 8, frames.shape, dtype=np.uint8)  # texture within a cell
    seen = []
    for arithmetic in ("float", "ppa8"):
        loc = WeightedNodeLocaliser(kind, arithmetic=arithmetic, keyframes=False, gain=gain)
        loc.build_map(frames[:n])
        ex, added = loc.executor, []
        add = ex.add_scaled
        ex.add_scaled = lambda shift, alpha, add=add, added=added: (
            added.append((shift, alpha)) or add(shift, alpha)
        )
        loc.step(frames[n])
        values = ex.node_values()
        seen.append((values.tolist(), ex.minimum(values), added))
    assert seen[0] == seen[1]


@settings(max_examples=40, deadline=None)
@given(
    seed=st.integers(0, 2**31),
    n=st.integers(1, 30),
    costs=st.tuples(st.integers(0, 64), st.integers(0, 64), st.integers(0, 64)),
    arithmetic=st.sampled_from(["float", "ppa8"]),
)
def test_a_weight_flows_along_its_run_for_free(seed, n, costs, arithmetic):
    """On a map with runs, the transition's result is the running maximum within each
    run of nodes of one place, written out literally."""
    from ppaloc.localise.host import HostExecutor

    rng = np.random.default_rng(seed)
    places = np.concatenate(([0], np.cumsum(rng.random(n - 1) < 0.5))).astype(np.int64)
    topomap = TopoMap("lbp", np.zeros(n, np.uint32), places=places)
    p = FilterParams.create("lbp", memory=127)
    ex = HostExecutor("lbp", p, arithmetic=arithmetic)
    ex.use_map(topomap)
    w = np.round(rng.uniform(-127, 1, n) * 64) / 64
    ex.set_weights(w)
    ex.transition(costs)
    want = np.empty(n)
    for i in range(n):
        cand = [w[i] - costs[0]]
        cand += [(w[i - d] if i - d >= 0 else -127) - costs[d] for d in (1, 2)]
        want[i] = np.clip(max(cand), -127, 127)
    for i in range(1, n):
        if places[i] == places[i - 1]:
            want[i] = max(want[i], want[i - 1])
    np.testing.assert_array_equal(ex.weights(), want.astype(ex.weights().dtype))


def test_a_map_of_every_frame_follows_the_stops_of_the_reference():
    """Frames repeated in the reference (stops) are runs of one place: the filter on a
    map of every frame then estimates the places the keyframe map's filter does; without
    the runs it lags behind after each stop."""
    from ppaloc.datasets import to_sensor
    from ppaloc.datasets.registry import load_dataset

    ds = load_dataset("synthetic:?places=80&query=autumn&seed=3")
    ref = [to_sensor(f) for f in ds.reference]
    query = [to_sensor(f) for f in ds.query]
    stops = {15: 12, 40: 20}
    frames, place = [], []
    for i, f in enumerate(ref):
        frames += [f] * stops.get(i, 1)
        place += [i] * stops.get(i, 1)
    place = np.array(place)
    for rep in ("lowres", "lbp"):
        keyframes = WeightedNodeLocaliser(rep)
        keyframes.build_map(ref)
        want = keyframes.topomap.frame_index[[keyframes.step(f).node for f in query]]
        every = WeightedNodeLocaliser(rep, keyframes=False)
        m = every.build_map(frames)
        assert np.array_equal(m.places, place)
        got = place[[every.step(f).node for f in query]]
        bare = WeightedNodeLocaliser(rep, keyframes=False)
        bare.use_map(TopoMap(m.kind, m.descriptors, m.frame_index, params=m.params))
        without = place[[bare.step(f).node for f in query]]
        assert np.mean(got == want) >= 0.9 > 0.8 >= np.mean(without == want)


def test_the_confidence_leaves_out_places_not_nodes():
    places = np.array([0, 1, 1, 1, 1, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13])
    topomap = TopoMap("lbp", np.zeros(len(places), np.uint32), places=places)
    schedule = make_schedule(FilterParams.create("lbp", confidence_radius=2))
    schedule.use_map(topomap)
    assert schedule.window(5) == (0, 7)  # places 0..3 around place 1
    assert schedule.window(12) == (10, 14)
    schedule.use_map(TopoMap("lbp", np.zeros(len(places), np.uint32)))
    assert schedule.window(5) == (3, 7)


def test_the_record_of_speeds_that_varied_ages_out():
    """Four gated speeds off one place a frame make the speed vary; a forward frame 63
    forward frames later still reads them, the 64th no longer (``VARY_AGE``), and
    still frames do not age them."""
    s = make_schedule(FilterParams.create("lbp"))
    s.reset()
    assert [s.note_speed(True, PathSpeed(1, 2)) for _ in range(4)] == [False] * 3 + [True]
    assert s.note_speed(False, None)  # a still frame: no forward frame counted
    assert all(s.note_speed(True, None) for _ in range(VARY_AGE - 4))
    assert s.note_speed(False, None)
    assert not s.note_speed(True, None)  # the first of the four is 64 forward frames old
    off = make_schedule(FilterParams.create("lbp", speed_vary=0))
    off.reset()
    assert not any(off.note_speed(True, PathSpeed(1, 2)) for _ in range(8))
