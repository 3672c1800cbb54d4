"""The ``patch_norm=P`` spec key: per-tile normalisation of every frame, lazily."""

from __future__ import annotations

import pickle

import numpy as np
import pytest
from PIL import Image

from ppaloc.datasets import load_dataset, make_synthetic, parse_dataset_spec
from ppaloc.datasets.frames import FrameSequence
from ppaloc.datasets.normalise import patch_normalise_frame
from ppaloc.errors import DatasetSpecError


def test_golden_tiny_array_with_partial_edge_tiles():
    # 3x5 in 2x2 tiles: tiles of 2x2, 2x2, 2x1 on top, 1x2, 1x2, 1x1 at the bottom.
    a = np.array(
        [
            [0, 2, 10, 10, 7],
            [4, 6, 10, 30, 9],
            [1, 3, 50, 50, 200],
        ],
        np.uint8,
    )
    expected = [
        # [[0,2],[4,6]]: mean 3, std sqrt(5); [[10,10],[10,30]]: mean 15, std sqrt(75);
        # [7,9]: z = -1, +1
        [85, 114, 110, 110, 96],
        [142, 171, 110, 183, 160],
        # [1,3]: z = -1, +1; [50,50] and the single pixel 200 are flat
        [96, 160, 128, 128, 128],
    ]
    assert patch_normalise_frame(a, 2).tolist() == expected


def test_tiles_have_zero_mean_unit_deviation_before_quantisation():
    rng = np.random.default_rng(0)
    a = rng.integers(0, 256, (24, 40), dtype=np.uint8)
    out = patch_normalise_frame(a, 8).astype(np.float64)
    z = (out - 128.0) / 32.0
    tiles = z.reshape(3, 8, 5, 8).transpose(0, 2, 1, 3).reshape(15, 64)
    assert np.abs(tiles.mean(axis=1)).max() < 0.02
    assert np.abs(tiles.std(axis=1) - 1.0).max() < 0.05


def test_flat_frame_becomes_128():
    for value in (0, 77, 255):
        out = patch_normalise_frame(np.full((7, 9), value, np.uint8), 4)
        assert out.dtype == np.uint8 and out.shape == (7, 9)
        assert (out == 128).all()


def test_extremes_clip_to_uint8():
    a = np.zeros((1, 64), np.uint8)
    a[0, 0] = 255  # one bright pixel among 63 dark ones: z = sqrt(63), about 7.9
    out = patch_normalise_frame(a, 64)
    assert out[0, 0] == 255 and out[0, 1] == 124


@pytest.mark.parametrize("value", ["1", "0", "-3", "eight", "2.5", ""])
def test_bad_value_is_one_line_spec_error(value):
    with pytest.raises(DatasetSpecError) as info:
        parse_dataset_spec(f"synthetic:?places=20&patch_norm={value}")
    message = str(info.value)
    assert "key 'patch_norm' must be an integer" in message
    assert "\n" not in message


def test_every_kind_accepts_the_key_default_unset():
    spec = parse_dataset_spec("nordland:d?patch_norm=8")
    assert spec.options["patch_norm"] == 8
    assert parse_dataset_spec("folder:a,b").options["patch_norm"] is None
    for text in ("gardens-point:d", "vprbench:d", "citycentre:d", "video:a,b", "synthetic:"):
        assert parse_dataset_spec(f"{text}?patch_norm=3").options["patch_norm"] == 3


def test_spec_key_normalises_both_traversals_lazily(tmp_path):
    rng = np.random.default_rng(1)
    frames = [rng.integers(0, 256, (12, 16), dtype=np.uint8) for _ in range(4)]
    for side in ("ref", "qry"):
        (tmp_path / side).mkdir()
        for k, f in enumerate(frames):
            Image.fromarray(f).save(tmp_path / side / f"Image{k:03d}.png")
    spec = f"folder:{tmp_path / 'ref'},{tmp_path / 'qry'}"
    plain = load_dataset(spec)
    normed = load_dataset(spec + "?patch_norm=5&start=1")
    assert isinstance(normed.reference, FrameSequence)
    assert len(normed.reference) == len(normed.query) == 3
    assert normed.meta["patch_norm"] == 5
    for traversal in (normed.reference, normed.query):
        for j in range(3):
            got = traversal[j]
            assert got.dtype == np.uint8 and got.shape == (12, 16)
            assert np.array_equal(got, patch_normalise_frame(plain.reference[j + 1], 5))
    assert not np.array_equal(normed.query[0], plain.query[1])
    # slicing stays lazy and keeps the transform; the sequence still pickles
    sliced = pickle.loads(pickle.dumps(normed.query[1:]))
    assert np.array_equal(sliced[0], normed.query[1])


def test_make_synthetic_keyword_matches_the_spec():
    a = make_synthetic(places=8, sync=True, seed=2, size=32, patch_norm=4)
    b = load_dataset("synthetic:?places=8&sync=1&seed=2&size=32&patch_norm=4")
    assert np.array_equal(a.query[3], b.query[3])
    assert abs(float(a.query[3].mean()) - 128.0) < 2.0
