"""The baselines on the weighted-node filter's place: descriptor="lowres" and "lbp".

Tiny hand-made frames whose 8x8 block means are known: their low-res places and LBP codes,
and every method's distances to them, are worked out by hand.
"""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays

from ppaloc.baselines import ABLEM, ParticleFilter, SeqSLAM, SingleFrame
from ppaloc.baselines._descriptors import (
    LOWRES_CONTRAST,
    LOWRES_PATCH,
    lbp_distances,
    lbp_place,
    lowres_distances,
    lowres_place,
)
from ppaloc.baselines.seqslam import contrast_enhance
from ppaloc.errors import PpalocError
from ppaloc.methods import make_localiser
from ppaloc.place import (
    haar_descriptor,
    lbp_descriptor,
    lowres_image,
    normalise_contrast,
    unpack_plane,
)
from ppaloc.topomap import TopoMap

IMAGE = [SeqSLAM, ParticleFilter, SingleFrame]


def blocks(means: np.ndarray) -> np.ndarray:
    """A sensor frame whose 8x8 block means are ``means`` (each block 32x32 pixels)."""
    return np.kron(np.asarray(means, np.uint8), np.ones((32, 32), np.uint8))


def column(col: int, value: int) -> np.ndarray:
    """Block means ``value`` in block column ``col``, 0 elsewhere."""
    m = np.zeros((8, 8))
    m[:, col] = value
    return blocks(m)


def bright_centres(*cells: tuple[int, int]) -> np.ndarray:
    """A dark frame with one bright block at the given blocks of the 8x8 grid."""
    m = np.zeros((8, 8))
    for r, c in cells:
        m[r, c] = 200
    return blocks(m)


# The centres of the LBP's four 3x3 cells are blocks (2, 2), (2, 5), (5, 2), (5, 5) of the
# 8x8 grid (its central 6x6, cut in four). A flat frame sets every bit (neighbours >= the
# centre); a bright centre clears its cell's 8 bits.
FLAT = blocks(np.zeros((8, 8)))  # 0xFFFFFFFF
TOP_LEFT = bright_centres((2, 2))  # 0x00FFFFFF
ALL_FOUR = bright_centres((2, 2), (2, 5), (5, 2), (5, 5))  # 0x00000000
TOP_RIGHT = bright_centres((2, 5))  # 0xFF00FFFF


def test_lowres_place_golden_and_contrast_invariance() -> None:
    # Block column 1 at 100, the rest 0: the 2x2 tiles over columns 0-1 have mean 50 ->
    # 128 and mad 50 -> gain x1 (nearest 48/50): 78 | 178; every other tile is flat: 128.
    a = lowres_place(column(1, 100))
    assert a.dtype == np.uint8 and a.shape == (8, 8)
    assert a[0].tolist() == [78, 178] + [128] * 6 and (a == a[0]).all()
    # Column 1 at 200 and column 6 at 50 (mean 100, mad 100 -> gain x1/2; a tile of its
    # own: mean 25, mad 25 -> gain x2): each tile on its own gives the same place.
    m = np.zeros((8, 8))
    m[:, 1], m[:, 6] = 200, 50
    b = lowres_place(blocks(m))
    np.testing.assert_array_equal(b[:, :2], a[:, :2])
    assert b[0, 6:].tolist() == [178, 78]
    assert (LOWRES_CONTRAST, LOWRES_PATCH) == (48, 2)


def test_lbp_place_golden() -> None:
    assert [int(lbp_place(f)) for f in (FLAT, TOP_LEFT, ALL_FOUR, TOP_RIGHT)] == [
        0xFFFFFFFF,
        0x00FFFFFF,
        0x00000000,
        0xFF00FFFF,
    ]


def test_distances_golden() -> None:
    q = np.full((8, 8), 128, np.uint8)
    nodes = np.stack([q, q + 3, q - 64])
    assert lowres_distances(q, nodes).tolist() == [0.0, 3.0, 64.0]
    codes = np.array([0xFFFFFFFF, 0x00FFFFFF, 0], np.uint32)
    assert lbp_distances(np.uint32(0xFF00FFFF), codes).tolist() == [8.0, 16.0, 24.0]


@pytest.mark.parametrize("cls", IMAGE)
def test_nodes_are_exactly_the_weighted_node_filters_places(cls) -> None:
    rng = np.random.default_rng(3)
    frames = rng.integers(0, 256, (5, 256, 256), dtype=np.uint8)
    low = cls(descriptor="lowres").build_map(frames)
    expected = normalise_contrast(lowres_image(frames), 48, 2)
    assert low.descriptors.dtype == np.uint8
    np.testing.assert_array_equal(low.descriptors, expected)
    assert low.params["descriptor"] == "lowres" and low.params["contrast"] == 48
    assert low.params["contrast_patch"] == 2
    lbp = cls(descriptor="lbp").build_map(frames)
    assert lbp.descriptors.dtype == np.uint32 and lbp.descriptors.shape == (5,)
    np.testing.assert_array_equal(lbp.descriptors, lbp_descriptor(frames))
    assert lbp.params["descriptor"] == "lbp" and "size" not in lbp.params
    assert cls().build_map(frames[:1]).params["descriptor"] == "patch"


@pytest.mark.parametrize("cls", IMAGE)
def test_lowres16_nodes_are_the_filters_16x16_places(cls) -> None:
    rng = np.random.default_rng(4)
    frames = rng.integers(0, 256, (4, 256, 256), dtype=np.uint8)
    loc = cls(descriptor="lowres16")
    m = loc.build_map(frames)
    # the 16x16 image's 4x4 tiles are the 8x8 image's 2x2 ones: the same 64x64 pixels
    np.testing.assert_array_equal(
        m.descriptors, normalise_contrast(lowres_image(frames, 16), 48, 4)
    )
    assert m.descriptors.shape == (4, 16, 16) and m.params["descriptor"] == "lowres16"
    assert m.params["contrast_patch"] == 2
    np.testing.assert_array_equal(lowres_place(frames[1], "lowres16"), m.descriptors[1])
    column = loc.difference_column(frames[2])
    assert column[2] == 0 and (column[[0, 1, 3]] > 10).all()
    want = np.abs(m.descriptors[0].astype(int) - m.descriptors[2]).sum() / 256
    assert column[0] == want
    with pytest.raises(PpalocError, match="descriptor='lowres16' but this localiser compares"):
        cls(descriptor="lowres").use_map(m)


@pytest.mark.parametrize("cls", IMAGE)
def test_haar_nodes_are_the_filters_signs_and_compared_in_bits(cls) -> None:
    rng = np.random.default_rng(5)
    frames = rng.integers(0, 256, (4, 256, 256), dtype=np.uint8)
    loc = cls(descriptor="haar")
    m = loc.build_map(frames)
    assert m.descriptors.dtype == np.uint32 and m.descriptors.shape == (4, 8)
    np.testing.assert_array_equal(m.descriptors, haar_descriptor(frames))
    assert m.params["descriptor"] == "haar" and "contrast" not in m.params
    column = loc.difference_column(frames[2])
    want = [
        np.count_nonzero(unpack_plane(m.descriptors[i]) != unpack_plane(m.descriptors[2]))
        for i in range(4)
    ]
    assert column.tolist() == want and column[2] == 0
    with pytest.raises(PpalocError, match="descriptor='haar' but this localiser compares"):
        cls(descriptor="lbp").use_map(m)


@pytest.mark.parametrize("cls", IMAGE)
def test_difference_columns_golden(cls) -> None:
    low = cls(descriptor="lowres")
    low.build_map([column(1, 100), column(1, 200), column(0, 100)])
    # The first two are one place under another contrast; the third differs by 100 on
    # the 16 cells of block columns 0 and 1 (78 <-> 178), a mean of 25 per cell.
    assert low.difference_column(column(1, 100)).tolist() == [0.0, 0.0, 25.0]
    lbp = cls(descriptor="lbp")
    lbp.build_map([FLAT, TOP_LEFT, ALL_FOUR])
    assert lbp.difference_column(TOP_RIGHT).tolist() == [8.0, 16.0, 24.0]
    assert lbp.difference_column(TOP_LEFT).tolist() == [8.0, 0.0, 24.0]


def test_single_frame_on_lbp_golden() -> None:
    s = SingleFrame(descriptor="lbp", radius=0, record_weights=True)
    s.build_map([FLAT, TOP_LEFT, ALL_FOUR])
    e = s.step(TOP_RIGHT)  # distances 8, 16, 24: node 0; 1 - 8 / 16
    assert e.node == 0 and e.score == 0.5 and e.weights.tolist() == [-8.0, -16.0, -24.0]


def test_seqslam_enhances_the_hamming_column() -> None:
    s = SeqSLAM(descriptor="lbp", ds=0, enhance_window=2, record_weights=True)
    s.build_map([FLAT, TOP_LEFT, ALL_FOUR])
    e = s.step(TOP_RIGHT)
    expected = contrast_enhance(np.array([8.0, 16.0, 24.0]), 2)
    np.testing.assert_allclose(-e.weights, expected)
    assert e.node == 0


@pytest.mark.parametrize("descriptor", ["lowres", "lbp"])
@pytest.mark.parametrize("mode", ["past", "centred"])
def test_seqslam_step_equals_batch_on_each_descriptor(toy_route, descriptor, mode) -> None:
    ref, query = toy_route
    s = SeqSLAM(descriptor=descriptor, mode=mode, record_weights=True)
    s.build_map(ref)
    batch = s.localise_sequence(query[:14])
    if mode == "centred":
        s.read_ahead(query[:14])
    online = [s.step(f) for f in query[:14]]
    for a, b in zip(batch, online, strict=True):
        assert a.node == b.node and a.score == b.score
        np.testing.assert_array_equal(a.weights, b.weights)


@pytest.mark.parametrize(
    ("cls", "descriptor"),
    [(c, d) for c in IMAGE for d in ("lowres", "lowres16", "lbp", "haar")]
    + [(ABLEM, "lbp"), (ABLEM, "haar")],
)
def test_each_method_locks_on_with_the_filters_place(toy_route, cls, descriptor) -> None:
    ref, query = toy_route
    loc = cls(descriptor=descriptor)
    loc.build_map(ref)
    nodes = np.array([loc.step(f).node for f in query])
    assert np.mean(np.abs(nodes[10:] - np.arange(20, 50)) <= 1) >= 0.9


def test_ablem_on_lbp_codes_golden() -> None:
    a = ABLEM(descriptor="lbp", length=1, record_weights=True)
    assert a.n_bits == 32 and a.n_bytes == 4 and a.fill == 16.0
    m = a.build_map([FLAT, TOP_LEFT, ALL_FOUR])
    assert m.descriptors.tolist() == [[255] * 4, [0, 255, 255, 255], [0] * 4]
    assert m.params == {"descriptor": "lbp", "n_bits": 32, "length": 1}
    e = a.step(TOP_RIGHT)
    assert e.node == 0 and e.weights.tolist() == [-8.0, -16.0, -24.0]
    assert e.score == 1.0 - 8.0 / 32.0  # the similarity of the best sequence
    two = ABLEM(descriptor="lbp", length=2, record_weights=True)
    two.use_map(m)
    two.step(TOP_LEFT)  # h = 8, 0, 24
    # Then h = 32, 24, 0 and S[e] = h_t[e] + h_{t-1}[e-1] (16 bits before node 0).
    assert two.step(ALL_FOUR).weights.tolist() == [-(32 + 16), -(24 + 8), -(0 + 0)]


@given(arrays(np.uint8, (3, 8, 8), elements=st.integers(0, 255)))
@settings(max_examples=25, deadline=None)
def test_a_frame_of_the_map_is_at_distance_zero_from_its_node(means) -> None:
    frames = [blocks(m) for m in means]
    for descriptor in ("lowres", "lbp"):
        s = SingleFrame(descriptor=descriptor)
        s.build_map(frames)
        for i, f in enumerate(frames):
            d = s.difference_column(f)
            assert d[i] == 0.0 and d.min() == 0.0


# -- errors ---------------------------------------------------------------------------------


@pytest.mark.parametrize(("cls", "what"), [(SeqSLAM, "SeqSLAM"), (SingleFrame, "SingleFrame")])
def test_unknown_descriptor_names_the_choices(cls, what) -> None:
    with pytest.raises(PpalocError, match=f"^{what} descriptor='sift' is unknown; choose 'patch'"):
        cls(descriptor="sift")


def test_image_parameters_with_another_descriptor_are_refused() -> None:
    with pytest.raises(
        PpalocError,
        match=r"^ParticleFilter size=\(8, 8\) shapes descriptor='patch' only; with "
        r"descriptor='lowres' leave it at its default \(32, 64\), or use descriptor='patch'$",
    ):
        ParticleFilter(descriptor="lowres", size=(8, 8))
    with pytest.raises(PpalocError, match=r"^SeqSLAM quantise=True shapes descriptor='patch'"):
        SeqSLAM(descriptor="lbp", quantise=True)
    with pytest.raises(PpalocError, match=r"^ABLE-M n_bits=256 shapes descriptor='ldb' only"):
        ABLEM(descriptor="lbp", n_bits=256)
    SeqSLAM(descriptor="lbp", size=[32, 64], patch=8)  # the defaults, spelt out, are fine


def test_ablem_on_haar_signs_counts_the_differing_signs() -> None:
    rng = np.random.default_rng(7)
    frames = rng.integers(0, 256, (4, 256, 256), dtype=np.uint8)
    a = ABLEM(descriptor="haar", length=1, record_weights=True)
    m = a.build_map(frames)
    assert m.descriptors.shape == (4, 32) and m.params["n_bits"] == 192
    words = haar_descriptor(frames)
    np.testing.assert_array_equal(m.descriptors, words.astype(">u4").view(np.uint8))
    est = a.step(frames[1])
    want = [np.count_nonzero(unpack_plane(words[i]) != unpack_plane(words[1])) for i in range(4)]
    assert est.node == 1 and (-est.weights).tolist() == want


def test_ablem_refuses_images() -> None:
    for image in ("lowres", "lowres16", "patch"):
        with pytest.raises(
            PpalocError,
            match=f"^ABLE-M descriptor='{image}' is an image, and ABLE-M matches binary codes "
            "by Hamming distance; choose 'ldb'",
        ):
            ABLEM(descriptor=image)
    with pytest.raises(PpalocError, match=r"^ABLE-M descriptor='orb' is unknown; choose 'ldb'"):
        ABLEM(descriptor="orb")


def test_registry_checks_the_descriptor() -> None:
    with pytest.raises(
        PpalocError,
        match=r"^method 'particle-filter': descriptor='sift' must be one of 'patch', 'lowres', "
        r"'lowres16', 'lbp', 'haar'$",
    ):
        make_localiser("particle-filter", descriptor="sift")
    assert make_localiser("seqslam-centred", descriptor="lbp").descriptor == "lbp"


@pytest.mark.parametrize("cls", IMAGE)
def test_maps_of_another_descriptor_are_refused(cls, toy_route) -> None:
    ref, _ = toy_route
    low = cls(descriptor="lowres").build_map(ref[:3])
    with pytest.raises(
        PpalocError,
        match=f"^{cls.name}: the map's nodes are descriptor='lowres' but this localiser "
        "compares descriptor='patch'; give descriptor='lowres' or build the map again$",
    ):
        cls().use_map(low)
    with pytest.raises(PpalocError, match=r"nodes are descriptor='lowres' but .* descriptor='lbp'"):
        cls(descriptor="lbp").use_map(low)
    other = TopoMap(cls.kind, low.descriptors, params={**low.params, "contrast": 32})
    with pytest.raises(
        PpalocError,
        match=f"^{cls.name}: the map's lowres nodes were normalised with contrast=32, this "
        "version normalises them with contrast=48; build the map again$",
    ):
        cls(descriptor="lowres").use_map(other)
    # a map saved before tiles were normalised on their own
    before = {k: v for k, v in low.params.items() if k != "contrast_patch"}
    other = TopoMap(cls.kind, low.descriptors, params=before)
    with pytest.raises(PpalocError, match=r"with no contrast_patch, .* contrast_patch=2; build"):
        cls(descriptor="lowres").use_map(other)
    # A map saved before descriptors existed holds the method's own image.
    old = cls().build_map(ref[:3])
    old = TopoMap(cls.kind, old.descriptors, params={"size": [32, 64], "patch": 8})
    cls().use_map(old)
    with pytest.raises(PpalocError, match=r"nodes are descriptor='patch' but .* descriptor='lbp'"):
        cls(descriptor="lbp").use_map(old)


def test_a_saved_map_keeps_its_descriptor(tmp_path, toy_route) -> None:
    ref, query = toy_route
    pf = ParticleFilter(descriptor="lbp")
    m = pf.build_map(ref[:10])
    loaded = TopoMap.load(m.save(tmp_path / "pf.npz"))
    again = ParticleFilter(descriptor="lbp")
    again.use_map(loaded)
    assert [again.step(f).node for f in query[:5]] == [pf.step(f).node for f in query[:5]]
    with pytest.raises(PpalocError, match="descriptor='lbp' but"):
        ParticleFilter().use_map(loaded)
