import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays
from scipy import ndimage

from ppaloc.errors import PpalocError
from ppaloc.localise.motion import (
    MARGIN,
    PAPER_MARGIN,
    AlwaysForward,
    ImageMotion,
    OracleMotion,
    check_moves,
    coherent_crossings,
    counted_decision,
    crossing_counts,
    forward_decision,
    motion_planes,
)


def square(half: int) -> np.ndarray:
    """A dark frame with a bright centred square and a ring of texture in every block."""
    f = np.full((256, 256), 40, np.uint8)
    f[128 - half : 128 + half, 128 - half : 128 + half] = 220
    return f


def test_planes_golden_margin():
    f = np.zeros((256, 256), np.uint8)
    f[0, 0] = 10  # block mean 10/1024: x = 10240 - 10 at (0,0), -10 elsewhere in block
    u, d = motion_planes(f, margin=2)  # limit 4096
    assert u[0, 0] and u.sum() == 1 and d.sum() == 0
    u, d = motion_planes(f, margin=3)  # limit 6144: 10230 still above
    assert u.sum() == 1
    f[0, 0] = 5  # x = 5115 < 6144
    assert motion_planes(f, margin=3)[0].sum() == 0


@pytest.mark.parametrize("seed", range(3))
def test_planes_match_the_register_definition(seed):
    # docs/ppa8.md in register units, exact in float64: U = [v - m - margin > 0], D = [m - v
    # - margin > 0], v = p/2 - 64, m = the 32x32 block mean of v
    rng = np.random.default_rng(seed)
    f = rng.integers(0, 256, (256, 256), dtype=np.uint8)
    f[:64] //= 16  # low-contrast blocks: offsets near the margin
    margin = int(rng.integers(0, 40))
    v = f / 2 - 64
    m = v.reshape(8, 32, 8, 32).mean(axis=(1, 3)).repeat(32, 0).repeat(32, 1)
    u, d = motion_planes(f, margin)
    np.testing.assert_array_equal(u, v - m - margin > 0)
    np.testing.assert_array_equal(d, m - v - margin > 0)


def test_expanding_pattern_is_forward_still_is_stay():
    m = ImageMotion()
    assert m.step(square(40)) is False  # first frame: no predecessor
    assert m.step(square(56)) is True  # edges moved outwards
    assert m.step(square(56)) is False  # nothing moved
    changed, support, coherent = m.last_counts  # the coherent count says still
    assert changed is None and coherent == 0 and support > 0


def test_noise_is_stay():
    rng = np.random.default_rng(0)
    base = square(50).astype(int)
    m = ImageMotion()
    decisions = []
    for _ in range(5):
        noisy = np.clip(base + rng.normal(0, 2, base.shape).round(), 0, 255).astype(np.uint8)
        decisions.append(m.step(noisy))
    assert decisions == [False] * 5


def test_featureless_is_forward():
    m = ImageMotion()
    m.step(np.zeros((256, 256), np.uint8))
    assert m.step(np.zeros((256, 256), np.uint8)) is True
    assert m.last_counts == (None, 0, None)  # featureless: forward on support alone


def test_decision_golden():
    assert forward_decision(0, 50000) is False
    assert forward_decision(782, 50000) is True  # 782 * 64 = 50048
    assert forward_decision(781, 50000) is False
    assert forward_decision(391, 50000, shift=7) is True
    assert forward_decision(0, 1023) is True
    assert forward_decision(0, 1024) is False
    assert forward_decision(782, 50000, 391, coherent_shift=7) is True  # 391 * 128 = 50048
    assert forward_decision(782, 50000, 390, coherent_shift=7) is False
    assert forward_decision(781, 50000, 50000, coherent_shift=7) is False  # both must pass
    assert forward_decision(0, 1023, 0, coherent_shift=7) is True


def test_crossing_counts():
    u0 = np.array([1, 0, 1, 0], bool)
    d0 = np.array([0, 1, 0, 0], bool)
    u1 = np.array([0, 1, 1, 0], bool)
    d1 = np.array([1, 0, 0, 0], bool)
    assert crossing_counts((u0, d0), (u1, d1)) == (2, 3)


def test_coherent_counts_keep_only_crossings_with_a_crossing_neighbour():
    u0 = np.zeros((4, 4), bool)
    d0 = np.zeros((4, 4), bool)
    d0[0, 0] = d0[2, 1] = d0[2, 2] = d0[3, 3] = True  # crossed: one alone, a pair, a corner
    u1 = d0.copy()
    d1 = np.zeros((4, 4), bool)
    d1[3, 2] = True  # one more textured pixel, crossed by nothing
    assert crossing_counts((u0, d0), (u1, d1)) == (4, 5)
    assert crossing_counts((u0, d0), (u1, d1), coherent=True) == (4, 5, 2)


@settings(max_examples=60, deadline=None)
@given(arrays(bool, st.tuples(st.integers(1, 9), st.integers(1, 9))))
def test_coherent_crossings_are_those_with_a_crossing_4_neighbour(crossed):
    cross = np.array([[0, 1, 0], [1, 0, 1], [0, 1, 0]])
    near = ndimage.convolve(crossed.astype(int), cross, mode="constant", cval=0)
    np.testing.assert_array_equal(coherent_crossings(crossed), crossed & (near > 0))


def test_still_noise_is_dropped_and_a_moved_edge_kept():
    """Pixel noise alone crosses single pixels (forward without the coherent count); a
    square that grows crosses rings of them (forward either way)."""
    rng = np.random.default_rng(3)
    f = square(40).astype(int)
    a, b = (np.clip(f + rng.normal(0, 6, f.shape), 0, 255).astype(np.uint8) for _ in range(2))
    changed, support, coherent = crossing_counts(motion_planes(a), motion_planes(b), coherent=True)
    assert changed << 6 >= support > coherent << 8  # the first bar passes, the second not
    for coherent_shift, want in ((0, True), (8, False)):
        m = ImageMotion(coherent_shift=coherent_shift)
        m.step(a)
        assert m.step(b) is want
        assert m.last_counts == ((changed, support, None) if want else (None, support, coherent))
        assert m.step(np.clip(square(48) + (b - square(40)), 0, 255)) is True
    with pytest.raises(PpalocError, match="motion coherent_shift=-1 must be a non-negative"):
        ImageMotion(coherent_shift=-1)


@settings(max_examples=200, deadline=None)
@given(
    st.integers(0, 70000),
    st.integers(0, 70000),
    st.integers(0, 70000),
    st.integers(0, 16),
    st.integers(0, 16),
    st.integers(0, 3000),
)
def test_counted_decision_is_the_rule_and_reads_support_and_coherent_first(
    a, b, c, shift, coherent_shift, min_support
):
    """Whatever it leaves unread, the decision is :func:`forward_decision`'s on every count;
    the first count read is ``changed`` without the coherent count, ``support`` with it."""
    coherent, changed, support = sorted((a, b, c))  # coherent <= changed <= support
    bars = {"shift": shift, "min_support": min_support, "coherent_shift": coherent_shift}
    read: list[str] = []

    def counter(name: str, value: int):
        return lambda: read.append(name) or value

    moved, counts = counted_decision(
        counter("changed", changed), counter("support", support),
        counter("coherent", coherent), **bars,
    )  # fmt: skip
    assert moved == forward_decision(changed, support, coherent, **bars)
    assert read[0] == ("support" if coherent_shift else "changed")
    assert [f for f in counts._fields if getattr(counts, f) is not None] == sorted(
        read, key=counts._fields.index
    )
    assert len(read) == len(set(read))


def test_reset_forgets_previous_frame():
    m = ImageMotion()
    m.step(square(40))
    m.reset()
    assert m.step(square(60)) is False


def test_always_forward_and_oracle():
    a = AlwaysForward()
    f = square(10)
    assert [a.step(f), a.step(f), a.step(f)] == [False, True, True]
    o = OracleMotion([True, False])
    assert [o.step(f), o.step(f)] == [True, False]
    with pytest.raises(PpalocError, match="has 2 ground-truth moves but was asked for frame 2"):
        o.step(f)


def test_bad_parameter_message():
    with pytest.raises(PpalocError, match=r"motion margin=-1 must be a non-negative integer"):
        ImageMotion(margin=-1)


def test_the_dead_zone_is_the_presets():
    from ppaloc.localise import WeightedNodeLocaliser
    from ppaloc.localise.params import FilterParams

    assert FilterParams.create("lbp").motion_margin == MARGIN == 4
    assert FilterParams.create("lbp", preset="paper").motion_margin == PAPER_MARGIN == 3
    assert FilterParams.create("lowres", preset="paper", motion_margin=5).motion_margin == 5
    assert WeightedNodeLocaliser("lbp").motion_model.margin == 4
    assert WeightedNodeLocaliser("lbp", preset="paper").motion_model.margin == 3
    assert ImageMotion().margin == MARGIN
    assert FilterParams.create("lbp").motion_coherent_shift == 8
    assert FilterParams.create("lbp", preset="paper").motion_coherent_shift == 0
    assert WeightedNodeLocaliser("lbp").motion_model.coherent_shift == 8
    assert WeightedNodeLocaliser("lbp", preset="paper").motion_model.coherent_shift == 0


@pytest.mark.parametrize("moves", [float("nan"), [0, 2], [[True]], ["yes"], [0.5], "10"])
def test_oracle_moves_are_booleans_only(moves):
    with pytest.raises(PpalocError, match="must be a list of booleans"):
        check_moves(moves)
    assert check_moves([1, 0, True]).tolist() == [True, False, True]
