"""TopoMap validation and mapping from a traversal."""

from __future__ import annotations

import numpy as np
import pytest

from ppaloc.place import lbp_descriptor, lowres_image
from ppaloc.topomap import TopoMap, build_topomap


def test_constructor_stays_compatible_and_validates() -> None:
    m = TopoMap("lowres", np.zeros((3, 8, 8), np.uint8), None, None, {})
    assert len(m) == 3 and m.frame_index.tolist() == [0, 1, 2] and m.n_tiles == 1
    assert TopoMap("seqslam", np.zeros((4, 64), np.float32)).layout is None
    with pytest.raises(ValueError, match=r"a 'lbp' map holds uint32 descriptors of shape \(N, \)"):
        TopoMap("lbp", np.zeros(3, np.int64))
    with pytest.raises(ValueError, match=r"one reference frame per node, shape \(3,\), got \(2,\)"):
        TopoMap("lbp", np.zeros(3, np.uint32), frame_index=[0, 1])
    # a frame_index of one row per node but two columns read "has 3 entries for 3 nodes"
    with pytest.raises(ValueError) as err:
        TopoMap("lbp", np.zeros(3, np.uint32), frame_index=np.zeros((3, 2), np.int64))
    assert str(err.value) == (
        "frame_index must hold one reference frame per node, shape (3,), got (3, 2)"
    )
    with pytest.raises(ValueError, match=r"positions must have shape \(N, D\) with N = 3"):
        TopoMap("lbp", np.zeros(3, np.uint32), positions=np.zeros((2, 2)))
    assert TopoMap("lbp", np.zeros(3, np.uint32), positions=np.arange(3)).positions.shape == (3, 1)


@pytest.fixture(scope="module")
def traversal() -> list[np.ndarray]:
    rng = np.random.default_rng(31)
    base = rng.integers(0, 200, (256, 256), dtype=np.uint8)
    frames = [base, base.copy(), base + 1, base + 2, base + 40, base + 40]
    return frames


@pytest.mark.parametrize("kind", ["lowres", "lbp"])
def test_a_node_per_frame(traversal: list[np.ndarray], kind: str) -> None:
    calls: list[tuple[int, int | None]] = []
    m = build_topomap(traversal, kind, dataset="toy", progress=lambda i, n: calls.append((i, n)))
    assert m.kind == kind and len(m) == len(traversal)
    expected = np.stack(traversal)
    expected = lowres_image(expected) if kind == "lowres" else lbp_descriptor(expected)
    np.testing.assert_array_equal(m.descriptors, expected)
    assert m.frame_index.tolist() == list(range(6))
    assert m.provenance == {"dataset": "toy"}
    assert m.params["keyframe_threshold"] is None and m.params["n_frames"] == 6
    assert calls == [(i, 6) for i in range(1, 7)]


def test_lowres_keyframes_compare_with_the_last_node(traversal: list[np.ndarray]) -> None:
    # mean change per cell vs the last node: 0, 1, 2 (> 1.5: node), 40 (node), 0
    m = build_topomap(iter(traversal), "lowres", keyframe_threshold=1.5, positions=np.arange(6.0))
    assert m.frame_index.tolist() == [0, 3, 4]
    assert m.positions[:, 0].tolist() == [0.0, 3.0, 4.0]
    assert m.params["keyframe_units"].startswith("mean absolute difference per 8x8 cell")
    assert build_topomap(traversal, "lowres", keyframe_threshold=0).frame_index.tolist() == [
        0,
        2,
        3,
        4,
    ]


def test_lbp_keyframes_use_hamming_bits() -> None:
    rng = np.random.default_rng(32)
    frames = [rng.integers(0, 256, (256, 256), dtype=np.uint8) for _ in range(5)]
    frames.insert(1, frames[0])
    d = lbp_descriptor(np.stack(frames))
    m = build_topomap(frames, "lbp", keyframe_threshold=0)
    assert m.frame_index.tolist() == [0, 2, 3, 4, 5]
    m = build_topomap(frames, "lbp", keyframe_threshold=32)
    assert m.frame_index.tolist() == [0]
    np.testing.assert_array_equal(m.descriptors, d[:1])


def test_frames_of_any_size_are_shown_to_the_sensor_first() -> None:
    small = np.full((32, 64), 77, np.uint8)
    m = build_topomap([small], "lowres")
    np.testing.assert_array_equal(m.descriptors[0], np.full((8, 8), 77))


def test_build_rejects_bad_arguments() -> None:
    frame = np.zeros((256, 256), np.uint8)
    with pytest.raises(ValueError, match="kind='hog' has no place representation"):
        build_topomap([frame], "hog")
    with pytest.raises(ValueError, match="keyframe_threshold=-1 must be >= 0 or None"):
        build_topomap([frame], "lbp", keyframe_threshold=-1)
    with pytest.raises(ValueError, match="positions has 2 rows for 1 frames"):
        build_topomap([frame], "lbp", positions=np.zeros(2))
    assert len(build_topomap([], "lbp")) == 0


def test_planes_put_each_node_in_its_snake_block() -> None:
    lowres = np.arange(1025 * 64, dtype=np.int64).reshape(1025, 8, 8) % 251
    m = TopoMap("lowres", lowres.astype(np.uint8))
    planes = m.planes()
    assert planes.shape == (2, 256, 256) and planes.dtype == np.uint8
    np.testing.assert_array_equal(planes[0, 0:8, 248:256], lowres[0])
    np.testing.assert_array_equal(planes[0, 0:8, 240:248], lowres[1])
    np.testing.assert_array_equal(planes[0, 8:16, 0:8], lowres[32])
    np.testing.assert_array_equal(planes[1, 0:8, 248:256], lowres[1024])
    # LBP: row k of the 4x8 block is cell k's code, MSB in column 0
    lbp = TopoMap("lbp", np.array([0xBA00FFF7, 1], np.uint32)).planes()
    np.testing.assert_array_equal(lbp[0, 0, 248:256], [1, 0, 1, 1, 1, 0, 1, 0])
    np.testing.assert_array_equal(lbp[0, 1, 248:256], 0)
    np.testing.assert_array_equal(lbp[0, 3, 248:256], [1, 1, 1, 1, 0, 1, 1, 1])
    np.testing.assert_array_equal(lbp[0, 0:4, 240:248].ravel(), np.eye(32, dtype=np.uint8)[31])
    with pytest.raises(ValueError, match="a 'seqslam' map has no PE layout"):
        TopoMap("seqslam", np.zeros((2, 4))).planes()


def test_places_are_runs_from_zero_and_windows_count_places() -> None:
    nodes = np.zeros(6, np.uint32)
    m = TopoMap("lbp", nodes, places=[0, 1, 1, 1, 2, 3])
    assert m.has_runs and not TopoMap("lbp", nodes, places=np.arange(6)).has_runs
    assert [m.place_window(i, 1) for i in (0, 2, 4, 5)] == [(0, 3), (0, 4), (1, 5), (4, 5)]
    assert TopoMap("lbp", nodes).place_window(2, 1) == (1, 3)
    for bad in ([1, 1, 2, 3, 4, 5], [0, 2, 3, 4, 5, 6], [0, 1, 0, 1, 2, 3], [0, 1, 2]):
        with pytest.raises(ValueError, match="places"):
            TopoMap("lbp", nodes, places=bad)


def test_a_map_of_every_frame_records_the_places_new_place_gives() -> None:
    frames = [np.full((256, 256), v, np.uint8) for v in (10, 10, 10, 40, 40, 90)]
    seen: list[int] = []

    def new_place(frame: np.ndarray) -> bool:
        new = not seen or int(frame[0, 0]) != seen[-1]
        seen.append(int(frame[0, 0]))
        return new

    m = build_topomap(frames, "lowres", new_place=new_place)
    assert m.places.tolist() == [0, 0, 0, 1, 1, 2] and len(m) == 6
    assert m.params["places"] == "motion test"
    with pytest.raises(ValueError, match="no keyframe rule"):
        build_topomap(frames, "lowres", new_place=new_place, keyframe_threshold=1)


def test_a_16x16_map_its_keyframes_and_its_planes(traversal: list[np.ndarray]) -> None:
    m = build_topomap(traversal, "lowres16")
    np.testing.assert_array_equal(m.descriptors, lowres_image(np.stack(traversal), 16))
    # the same mean change per cell as on 8x8 (every pixel moves alike): 0, 1, 2, 40, 0
    keyed = build_topomap(traversal, "lowres16", keyframe_threshold=1.5)
    assert keyed.frame_index.tolist() == [0, 3, 4]
    assert keyed.params["keyframe_units"].startswith("mean absolute difference per 16x16")
    assert m.layout.capacity == 256 and m.node_blocks().shape == (6, 16, 16)
    planes = m.planes()
    assert planes.shape == (1, 256, 256)
    # node 0 is the top-right 16x16 block, node 1 the block west of it
    np.testing.assert_array_equal(planes[0, :16, 240:], m.descriptors[0])
    np.testing.assert_array_equal(planes[0, :16, 224:240], m.descriptors[1])
