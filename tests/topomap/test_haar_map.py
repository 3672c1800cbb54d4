"""A map of Haar-sign places: packed words on the host, 16x16-PE blocks on the array."""

from __future__ import annotations

import numpy as np

from ppaloc.topomap import TopoMap, build_topomap


def test_haar_map_holds_packed_signs_and_lays_them_out_on_16x16_blocks():
    from ppaloc.place import haar_descriptor, unpack_plane

    rng = np.random.default_rng(5)
    frames = rng.integers(0, 256, (3, 256, 256), dtype=np.uint8)
    m = build_topomap(list(frames), "haar")
    assert m.descriptors.shape == (3, 8) and m.descriptors.dtype == np.uint32
    np.testing.assert_array_equal(m.descriptors, haar_descriptor(frames))
    blocks = m.node_blocks()
    np.testing.assert_array_equal(blocks, unpack_plane(m.descriptors))
    assert m.layout.capacity == 256
    planes = m.planes()
    np.testing.assert_array_equal(planes[0, :16, 240:], blocks[0])  # node 0: top-right
    # a keyframe threshold counts differing signs, strictly above it
    h = int(np.count_nonzero(blocks[0] != blocks[1]))
    assert 0 < h <= 192
    three = [frames[0], frames[0], frames[1]]
    assert build_topomap(three, "haar", keyframe_threshold=0).frame_index.tolist() == [0, 2]
    assert build_topomap(three, "haar", keyframe_threshold=h - 1).frame_index.tolist() == [0, 2]
    assert build_topomap(three, "haar", keyframe_threshold=h).frame_index.tolist() == [0]


def test_a_haar_map_survives_a_save_and_a_load(tmp_path):
    rng = np.random.default_rng(6)
    m = build_topomap(list(rng.integers(0, 256, (4, 256, 256), dtype=np.uint8)), "haar")
    back = TopoMap.load(m.save(tmp_path / "haar.npz"))
    assert back.kind == "haar" and back.equals(m)
