import numpy as np
import pytest

from ppaloc.errors import PpalocError
from ppaloc.localise.motion import (
    MARGIN,
    PAPER_MARGIN,
    AlwaysForward,
    ImageMotion,
    OracleMotion,
    check_moves,
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
    changed, support = m.last_counts
    assert changed == 0 and support > 0


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
    assert m.last_counts == (0, 0)


def test_decision_golden():
    assert forward_decision(0, 50000) is False
    assert forward_decision(782, 50000) is True  # 782 * 64 = 50048
    assert forward_decision(781, 50000) is False
    assert forward_decision(391, 50000, shift=7) is True
    assert forward_decision(0, 1023) is True
    assert forward_decision(0, 1024) is False


def test_crossing_counts():
    u0 = np.array([1, 0, 1, 0], bool)
    d0 = np.array([0, 1, 0, 0], bool)
    u1 = np.array([0, 1, 1, 0], bool)
    d1 = np.array([1, 0, 0, 0], bool)
    assert crossing_counts((u0, d0), (u1, d1)) == (2, 3)


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


@pytest.mark.parametrize("moves", [float("nan"), [0, 2], [[True]], ["yes"], [0.5], "10"])
def test_oracle_moves_are_booleans_only(moves):
    with pytest.raises(PpalocError, match="must be a list of booleans"):
        check_moves(moves)
    assert check_moves([1, 0, True]).tolist() == [True, False, True]
