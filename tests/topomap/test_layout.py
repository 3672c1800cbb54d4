"""The snake layout: a bijection, adjacency, tiles continuing, masks and planes."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from ppaloc.topomap import Direction, SnakeLayout, layout_for

NORDLAND_NODES = 1788  # the half route used as the map


def small_layouts() -> st.SearchStrategy[SnakeLayout]:
    def make(bh: int, bw: int, rows: int, cols: int) -> SnakeLayout:
        return SnakeLayout((bh, bw), (bh * rows, bw * cols))

    return st.builds(
        make, st.integers(1, 4), st.integers(1, 4), st.integers(1, 6), st.integers(1, 6)
    )


def test_golden_snake_on_a_small_array() -> None:
    layout = SnakeLayout((2, 2), (6, 8))  # 3 block rows x 4 block columns
    np.testing.assert_array_equal(
        layout.block_index_grid(), [[3, 2, 1, 0], [4, 5, 6, 7], [11, 10, 9, 8]]
    )
    w, e, s, t = Direction.WEST, Direction.EAST, Direction.SOUTH, Direction.NEXT_TILE
    np.testing.assert_array_equal(
        layout.next_direction(), [[s, w, w, w], [e, e, e, s], [t, w, w, w]]
    )
    np.testing.assert_array_equal(layout.pe_rect(0), [0, 0, 6, 2, 8])
    np.testing.assert_array_equal(layout.pe_rect([4, 12]), [[0, 2, 0, 4, 2], [1, 0, 6, 2, 8]])


def test_paper_layouts_and_nordland_fit() -> None:
    lowres, lbp = layout_for("lowres"), layout_for("lbp")
    assert (lowres.block_shape, lowres.grid_shape, lowres.capacity) == ((8, 8), (32, 32), 1024)
    assert (lbp.block_shape, lbp.grid_shape, lbp.capacity) == ((4, 8), (64, 32), 2048)
    assert lowres.n_tiles(NORDLAND_NODES) == 2
    assert lbp.n_tiles(NORDLAND_NODES) == 1
    assert lowres.n_tiles(0) == 0 and lowres.n_tiles(1024) == 1 and lowres.n_tiles(1025) == 2
    rects = lowres.pe_rects(NORDLAND_NODES)
    assert rects.shape == (NORDLAND_NODES, 5)
    np.testing.assert_array_equal(rects[0], [0, 0, 248, 8, 256])  # top-right block
    np.testing.assert_array_equal(rects[1023], [0, 248, 248, 256, 256])  # ends bottom-right
    np.testing.assert_array_equal(rects[1024], [1, 0, 248, 8, 256])  # tile 1 starts again
    with pytest.raises(
        ValueError, match="no PE layout for kind 'hog'; known kinds: lowres, lowres16, lbp"
    ):
        layout_for("hog")


@given(small_layouts(), st.integers(0, 3))
def test_snake_is_a_bijection_with_adjacent_consecutive_blocks(
    layout: SnakeLayout, extra: int
) -> None:
    n = layout.capacity * 2 + extra
    tile, r, c = layout.node_to_block(np.arange(n))
    np.testing.assert_array_equal(layout.block_to_node(tile, r, c), np.arange(n))
    for t in range(2):  # every block of a full tile is used exactly once
        sel = tile == t
        cells = set(zip(r[sel].tolist(), c[sel].tolist(), strict=True))
        assert len(cells) == layout.capacity
    same_tile = tile[1:] == tile[:-1]
    steps = np.abs(np.diff(r)) + np.abs(np.diff(c))
    assert np.all(steps[same_tile] == 1)
    # tiles continue: the first node of a tile follows the last node of the previous one
    starts = np.flatnonzero(~same_tile) + 1
    np.testing.assert_array_equal(tile[starts], tile[starts - 1] + 1)
    np.testing.assert_array_equal(r[starts], 0)
    np.testing.assert_array_equal(c[starts], layout.grid_shape[1] - 1)


@given(small_layouts())
def test_next_direction_points_at_the_next_node(layout: SnakeLayout) -> None:
    d = layout.next_direction()
    grid = layout.block_index_grid()
    step = {Direction.WEST: (0, -1), Direction.EAST: (0, 1), Direction.SOUTH: (1, 0)}
    for (br, bc), code in np.ndenumerate(d):
        if code == Direction.NEXT_TILE:
            assert grid[br, bc] == layout.capacity - 1
            continue
        dr, dc = step[Direction(int(code))]
        assert grid[br + dr, bc + dc] == grid[br, bc] + 1


@given(small_layouts(), st.data())
def test_pe_rect_and_pe_to_node_agree(layout: SnakeLayout, data: st.DataObject) -> None:
    node = data.draw(st.integers(0, 3 * layout.capacity))
    t, r0, c0, r1, c1 = layout.pe_rect(node).tolist()
    assert (r1 - r0, c1 - c0) == layout.block_shape
    assert layout.pe_to_node(t, r0, c0) == node
    assert layout.pe_to_node(t, r1 - 1, c1 - 1) == node


def test_masks() -> None:
    layout = SnakeLayout((2, 2), (6, 8))
    odd = layout.row_parity_mask(1)
    assert odd.shape == (6, 8)
    np.testing.assert_array_equal(odd[:, 0], [0, 0, 1, 1, 0, 0])
    np.testing.assert_array_equal(layout.row_parity_mask(0, pe=False)[:, 0], [1, 0, 1])
    np.testing.assert_array_equal(
        layout.direction_mask(Direction.SOUTH, pe=False),
        [[1, 0, 0, 0], [0, 0, 0, 1], [0, 0, 0, 0]],
    )
    assert layout.direction_mask(Direction.WEST).sum() == 6 * 4
    # 14 nodes: tile 0 is full, tile 1 holds nodes 12 and 13 (its two right-most blocks)
    np.testing.assert_array_equal(layout.occupied_mask(14, 0, pe=False), np.ones((3, 4)))
    np.testing.assert_array_equal(
        layout.occupied_mask(14, 1, pe=False), [[0, 0, 1, 1], [0, 0, 0, 0], [0, 0, 0, 0]]
    )
    with pytest.raises(ValueError, match="parity=2 must be 0"):
        layout.row_parity_mask(2)


def test_to_planes_places_each_node_block_and_round_trips() -> None:
    layout = SnakeLayout((2, 2), (6, 8))
    values = np.arange(14 * 4, dtype=np.int16).reshape(14, 2, 2)
    planes = layout.to_planes(values, fill=-1)
    assert planes.shape == (2, 6, 8) and planes.dtype == np.int16
    np.testing.assert_array_equal(planes[0, 0:2, 6:8], values[0])
    np.testing.assert_array_equal(planes[0, 2:4, 0:2], values[4])
    np.testing.assert_array_equal(planes[1, 0:2, 4:6], values[13])
    assert (planes[1, 2:] == -1).all()
    np.testing.assert_array_equal(layout.from_planes(planes, 14), values)


def test_layout_rejects_blocks_that_do_not_tile() -> None:
    with pytest.raises(ValueError, match=r"block_shape=\(3, 8\) does not tile array_shape"):
        SnakeLayout((3, 8))
    with pytest.raises(ValueError, match="node indices must be >= 0, got -1"):
        layout_for("lbp").node_to_block(-1)
    with pytest.raises(ValueError, match=r"blocks must lie in tiles >= 0, rows 0\.\.63"):
        layout_for("lbp").block_to_node(0, 64, 0)
