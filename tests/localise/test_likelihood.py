import numpy as np
import pytest

from ppaloc.errors import PpalocError
from ppaloc.localise.likelihood import NodeDistances, distance_scale
from ppaloc.place import lowres_image, normalise_contrast

from .conftest import blocky


def test_scales_put_mu_in_register_units():
    # low-res: a node 20 grey levels from the live frame in every cell is 10 units away
    node = np.full((1, 8, 8), 100, np.uint8)
    frame = blocky(np.full((8, 8), 120))
    exact = NodeDistances("lowres", node, exact=True)(frame)
    quant = NodeDistances("lowres", node, exact=False)(frame)
    assert exact[0] * distance_scale("lowres", 0, True) == 10.0
    assert quant[0] * distance_scale("lowres", 0, False) == 10.0
    assert distance_scale("lowres", 2, True) == 2.0**-19
    # lbp: 3 differing bits are 6 register units
    assert distance_scale("lbp", 0, True) * 3 == 6.0


def test_exact_lowres_sees_the_unquantised_frame_and_the_clip():
    frame = np.zeros((256, 256), np.uint8)
    frame[0, 0] = 255  # block (0, 0) sums to 255: mean 0.249..., lowres_image 0
    nodes = np.stack([lowres_image(frame), np.full((8, 8), 255, np.uint8)])
    got = NodeDistances("lowres", nodes, exact=True)(frame)
    # node 0: only cell (0, 0) differs, by 255/1024 grey levels; node 1: 63 cells at
    # |0 - 255*1024| clipped to 254*1024, plus |255 - 261120| = 260865, also clipped
    assert got.tolist() == [255, 64 * 254 * 1024]


def test_lbp_distances():
    d = NodeDistances("lbp", np.array([0, 0xFFFFFFFF], np.uint32), exact=True)
    frame = np.zeros((256, 256), np.uint8)  # flat: every neighbour >= centre, all ones
    assert d(frame).tolist() == [32, 0]


def test_contrast_normalised_lowres_compares_the_normalised_images():
    """With ``contrast`` both the live image and the nodes are normalised first: a darker,
    flatter copy of a node's scene is near distance 0; ``exact`` gives the same integers
    in the units of the unquantised path (1024 per grey level)."""
    rng = np.random.default_rng(3)
    scene = rng.integers(40, 216, (8, 8))
    dim = (scene - 40) // 2 + 10  # the same place at dusk: darker, half the contrast
    nodes = np.stack([scene, np.full((8, 8), 255), np.full((8, 8), 1)]).astype(np.uint8)
    frame = blocky(dim)
    exact = NodeDistances("lowres", nodes, exact=True, contrast=48)
    quant = NodeDistances("lowres", nodes, exact=False, contrast=48)
    live = normalise_contrast(dim, 48).astype(np.int64)
    want = np.abs(live[None] - normalise_contrast(nodes, 48).astype(np.int64)).sum(axis=(1, 2))
    np.testing.assert_array_equal(quant(frame), want)
    assert exact(frame).tolist() == [1024 * int(w) for w in want]
    assert want[0] < 64 * 2  # within a grey level or two per cell (rounding, the gain step)
    np.testing.assert_array_equal(exact.live(frame), live)
    # each 2x2 tile of blocks on its own (the robust preset's default tile)
    tiles = NodeDistances("lowres", nodes, exact=True, contrast=48, patch=2)
    live2 = normalise_contrast(dim, 48, 2).astype(np.int64)
    want2 = np.abs(live2[None] - normalise_contrast(nodes, 48, 2).astype(np.int64)).sum(axis=(1, 2))
    assert exact(frame).tolist() != tiles(frame).tolist() == [1024 * int(w) for w in want2]
    np.testing.assert_array_equal(tiles.live(frame), live2)
    # the paper preset's path (contrast None) sees the raw images: far apart
    assert NodeDistances("lowres", nodes, exact=False)(frame)[0] > 64 * 40


def test_lowres16_compares_16x16_images_normalised_in_tiles_of_the_same_pixels():
    """``lowres16``: the live frame's 16x16 image and the nodes, each 4x4 tile of cells
    (64x64 pixels, as a 2x2 tile of the 8x8 grid) normalised on its own; mu is the mean
    per cell in both arithmetics, and ppa8's T is 256 (pixels a block) times the SAD."""
    rng = np.random.default_rng(5)
    scene = rng.integers(40, 216, (16, 16))
    dim = (scene - 40) // 2 + 10
    nodes = np.stack([scene, np.full((16, 16), 200), rng.integers(0, 256, (16, 16))])
    nodes = nodes.astype(np.uint8)
    frame = np.kron(dim.astype(np.uint8), np.ones((16, 16), np.uint8))
    quant = NodeDistances("lowres16", nodes, exact=False, contrast=48, patch=2)
    exact = NodeDistances("lowres16", nodes, exact=True, contrast=48, patch=2)
    live = normalise_contrast(dim, 48, 4).astype(np.int64)
    want = np.abs(live[None] - normalise_contrast(nodes, 48, 4).astype(np.int64)).sum(axis=(1, 2))
    np.testing.assert_array_equal(quant.live(frame), live)
    np.testing.assert_array_equal(quant(frame), want)
    assert exact(frame).tolist() == [256 * int(w) for w in want]
    for d, is_exact in ((quant, False), (exact, True)):
        mu = d(frame).astype(np.float64) * distance_scale("lowres16", 0, is_exact)
        np.testing.assert_allclose(mu, want / 512)  # mean over 256 cells of |f - n| = d / 2
    assert want[0] < 256 * 2  # the dim copy of node 0's scene is within rounding


def test_lowres16_needs_the_contrast_normalisation():
    nodes = np.zeros((2, 16, 16), np.uint8)
    with pytest.raises(PpalocError, match="contrast-normalised"):
        NodeDistances("lowres16", nodes, exact=True)


def test_float_values_are_mu_and_the_ppa8_readout_is_within_its_step():
    """The controller's values: float ``mu`` itself (SAD / 512 for 16x16, / 128 for 8x8);
    ppa8 the ADC code of ``-mu/2`` read back, within 2 units (one code) of ``mu``."""
    from ppaloc.localise.host import read_values

    rng = np.random.default_rng(8)
    for kind, grid in (("lowres", 8), ("lowres16", 16)):
        nodes = rng.integers(0, 256, (40, grid, grid), dtype=np.uint8)
        frame = rng.integers(0, 256, (256, 256), dtype=np.uint8)
        quant = NodeDistances(kind, nodes, exact=False, contrast=48, patch=2)
        exact = NodeDistances(kind, nodes, exact=True, contrast=48, patch=2)
        sad = quant(frame).astype(np.float64)
        mu = read_values(kind, quant(frame), False)
        np.testing.assert_array_equal(mu, sad / (2 * grid * grid))
        r = read_values(kind, exact(frame), True)
        assert np.all(np.abs(r - mu) <= 2) and np.all(r % 2 == 0)


def test_alpha_is_not_suggested_for_the_16x16_place():
    from ppaloc.localise.alpha import suggest_alpha
    from ppaloc.topomap import TopoMap

    m = TopoMap("lowres16", np.zeros((4, 16, 16), np.uint8))
    with pytest.raises(PpalocError, match="cannot suggest alpha for a map of kind 'lowres16'"):
        suggest_alpha(m, shift=0)


def test_haar_distances_count_differing_signs_and_read_as_quarters():
    """Haar signs: ``mu = h / 4`` register units in the update (both arithmetics) and the
    ppa8 readout of the root's ADC code ``floor(h / 4 + 1/2)`` (round half up)."""
    from ppaloc.localise.host import read_values
    from ppaloc.place import haar_descriptor, hamming_words, pack_plane

    rng = np.random.default_rng(11)
    planes = rng.integers(0, 2, (30, 16, 16), dtype=np.uint8)
    planes[:, 1::2, 1::2] = 0
    nodes = pack_plane(planes)
    frame = rng.integers(0, 256, (256, 256), dtype=np.uint8)
    h = NodeDistances("haar", nodes, exact=True)(frame)
    assert h.dtype == np.uint16
    np.testing.assert_array_equal(h, hamming_words(haar_descriptor(frame), nodes))
    # float compares the same integers; a second frame reuses the buffer from zero
    fl = NodeDistances("haar", nodes, exact=False)
    other = rng.integers(0, 256, (256, 256), dtype=np.uint8)
    np.testing.assert_array_equal(fl(frame).copy(), h)
    np.testing.assert_array_equal(fl(other), hamming_words(haar_descriptor(other), nodes))
    assert distance_scale("haar", 0, True) == distance_scale("haar", 0, False) == 0.25
    np.testing.assert_array_equal(read_values("haar", h, False), h / 4.0)
    raw = np.arange(0, 193, dtype=np.uint16)
    read = read_values("haar", raw, True)
    np.testing.assert_array_equal(read, np.floor(raw / 4.0 + 0.5).astype(np.int64))
    assert read[[1, 2, 5, 6]].tolist() == [0, 1, 1, 2]  # 1/4 -> 0, 1/2 -> 1 (half up)


def test_haar_is_refused_by_the_paper_preset():
    from ppaloc.localise.params import FilterParams

    with pytest.raises(
        PpalocError,
        match=r"^preset='paper' does not run on the haar place, which the paper does not "
        r"describe; use a robust preset, or lowres or lbp$",
    ):
        FilterParams.create("haar", preset="paper")
