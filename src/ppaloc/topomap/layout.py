"""The snake layout: where each map node lives on the PE array, and how tiles continue.

A map is a 1-D chain of nodes. On the pixel processor array each node occupies one block
of PEs; blocks are visited in a *snake*: start at the top-right block, run west along the
block row, step down one block row and run back east, and so on. Consecutive nodes are
always in edge-adjacent blocks, so "every weight moves to the next node" is a shift by
one block: west on even block rows, east on odd ones, south at a row end. A map larger
than one plane continues on further tiles (further registers or sensors): node
``capacity`` is the top-right block of tile 1, and so on.
"""

from __future__ import annotations

from dataclasses import dataclass
from enum import IntEnum

import numpy as np

from ppaloc.place import LOWRES_GRIDS

__all__ = ["KIND_BLOCK_SHAPES", "Direction", "SnakeLayout", "layout_for"]

KIND_BLOCK_SHAPES: dict[str, tuple[int, int]] = {
    **{kind: (g, g) for kind, g in LOWRES_GRIDS.items()},
    "lbp": (4, 8),
    "haar": (16, 16),
}
"""PE block (rows, cols) per node for each place representation.

``"lowres"``: 8x8 PEs, one per grid cell (cell (r, c) at block PE (r, c)); ``"lowres16"``
likewise with 16x16 PEs (256 nodes per tile).
``"lbp"``: 4 rows x 8 columns = 32 PEs, one per descriptor bit; row k holds the 8-bit
code of cell k (top-left, top-right, bottom-left, bottom-right), MSB in column 0, so bit
``31 - b`` of the uint32 is at block PE ``(b // 8, b % 8)``.
``"haar"``: 16x16 PEs, one per cell of the Haar-sign plane (:func:`ppaloc.place.haar_plane`;
256 nodes per tile).
"""


class Direction(IntEnum):
    """Where the next node along the snake lies, seen from a block."""

    WEST = 0
    EAST = 1
    SOUTH = 2
    NEXT_TILE = 3
    """The last block of a tile: the next node is the top-right block of the next tile."""


@dataclass(frozen=True)
class SnakeLayout:
    """Node index <-> (tile, block row, block column) <-> PE rectangle.

    Parameters
    ----------
    block_shape : (int, int)
        PEs per node block, (rows, cols); must divide ``array_shape``.
    array_shape : (int, int)
        PEs per tile (the SCAMP-5 array is 256x256).

    Notes
    -----
    Index conversions are vectorised: they take and return integer arrays of any shape.
    PE rectangles are half-open, like numpy slices: a node covers rows ``row0 <= r < row1``
    and columns ``col0 <= c < col1`` of its tile. Row 0 is the top of the array, column 0
    its left (west) edge.

    Examples
    --------
    >>> layout = SnakeLayout((8, 8))
    >>> layout.capacity, layout.grid_shape
    (1024, (32, 32))
    >>> layout.node_to_block([0, 1, 31, 32, 1024])
    (array([0, 0, 0, 0, 1]), array([0, 0, 0, 1, 0]), array([31, 30,  0,  0, 31]))
    """

    block_shape: tuple[int, int]
    array_shape: tuple[int, int] = (256, 256)

    def __post_init__(self) -> None:
        bs = tuple(int(v) for v in self.block_shape)
        shape = tuple(int(v) for v in self.array_shape)
        if len(bs) != 2 or len(shape) != 2 or min(bs) < 1 or min(shape) < 1:
            raise ValueError(
                f"block_shape={self.block_shape} and array_shape={self.array_shape} must be "
                "pairs of positive integers"
            )
        if shape[0] % bs[0] or shape[1] % bs[1]:
            raise ValueError(
                f"block_shape={bs} does not tile array_shape={shape}; pick a block whose "
                "sides divide the array's"
            )
        object.__setattr__(self, "block_shape", bs)
        object.__setattr__(self, "array_shape", shape)

    # -- sizes ---------------------------------------------------------------------------

    @property
    def grid_shape(self) -> tuple[int, int]:
        """Blocks per tile, (block rows, block columns)."""
        return (
            self.array_shape[0] // self.block_shape[0],
            self.array_shape[1] // self.block_shape[1],
        )

    @property
    def capacity(self) -> int:
        """Nodes per tile."""
        rows, cols = self.grid_shape
        return rows * cols

    def n_tiles(self, n_nodes: int) -> int:
        """Tiles needed for ``n_nodes`` nodes (0 for an empty map)."""
        if n_nodes < 0:
            raise ValueError(f"n_nodes={n_nodes} must be >= 0")
        return -(-int(n_nodes) // self.capacity)

    # -- index conversions ---------------------------------------------------------------

    def node_to_block(self, node: np.ndarray | int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Return ``(tile, block_row, block_col)`` of node indices (any shape, >= 0)."""
        i = np.asarray(node, dtype=np.int64)
        if i.size and i.min() < 0:
            raise ValueError(f"node indices must be >= 0, got {int(i.min())}")
        cols = self.grid_shape[1]
        tile, j = np.divmod(i, self.capacity)
        brow, pos = np.divmod(j, cols)
        bcol = np.where(brow % 2 == 0, cols - 1 - pos, pos)
        return tile, brow, bcol

    def block_to_node(
        self, tile: np.ndarray | int, block_row: np.ndarray | int, block_col: np.ndarray | int
    ) -> np.ndarray:
        """Return the node index of blocks (inverse of :meth:`node_to_block`)."""
        t = np.asarray(tile, dtype=np.int64)
        r = np.asarray(block_row, dtype=np.int64)
        c = np.asarray(block_col, dtype=np.int64)
        rows, cols = self.grid_shape
        bad = (t < 0) | (r < 0) | (r >= rows) | (c < 0) | (c >= cols)
        if np.any(bad):
            raise ValueError(
                f"blocks must lie in tiles >= 0, rows 0..{rows - 1}, columns 0..{cols - 1}"
            )
        pos = np.where(r % 2 == 0, cols - 1 - c, c)
        return t * self.capacity + r * cols + pos

    def pe_rect(self, node: np.ndarray | int) -> np.ndarray:
        """Return the PE rectangle of nodes.

        Returns
        -------
        ndarray of int64, shape (..., 5)
            ``(tile, row0, col0, row1, col1)``, half-open.
        """
        tile, brow, bcol = self.node_to_block(node)
        bh, bw = self.block_shape
        return np.stack([tile, brow * bh, bcol * bw, (brow + 1) * bh, (bcol + 1) * bw], axis=-1)

    def pe_rects(self, n_nodes: int) -> np.ndarray:
        """Return the PE rectangles of nodes ``0 .. n_nodes - 1``, shape (n_nodes, 5)."""
        return self.pe_rect(np.arange(n_nodes))

    def pe_to_node(
        self, tile: np.ndarray | int, row: np.ndarray | int, col: np.ndarray | int
    ) -> np.ndarray:
        """Return the node whose block holds PE ``(row, col)`` of ``tile``."""
        bh, bw = self.block_shape
        return self.block_to_node(tile, np.asarray(row) // bh, np.asarray(col) // bw)

    # -- per-tile maps for PE programs ---------------------------------------------------

    def block_index_grid(self) -> np.ndarray:
        """Node index within a tile of every block, shape ``grid_shape`` (int64)."""
        rows, cols = self.grid_shape
        r, c = np.indices((rows, cols))
        return self.block_to_node(0, r, c)

    def next_direction(self) -> np.ndarray:
        """Direction of the next node from every block of a tile, shape ``grid_shape``.

        Values are :class:`Direction` codes (int8): WEST along even block rows, EAST along
        odd ones, SOUTH at the row end, NEXT_TILE at the tile's last block.
        """
        rows, cols = self.grid_shape
        r, c = np.indices((rows, cols))
        even = r % 2 == 0
        d = np.where(even, Direction.WEST, Direction.EAST).astype(np.int8)
        row_end = np.where(even, c == 0, c == cols - 1)
        d[row_end] = Direction.SOUTH
        _, last_r, last_c = self.node_to_block(self.capacity - 1)
        d[last_r, last_c] = Direction.NEXT_TILE
        return d

    def expand(self, block_values: np.ndarray) -> np.ndarray:
        """Broadcast per-block values of shape ``grid_shape`` to PEs, shape ``array_shape``."""
        v = np.asarray(block_values)
        if v.shape[-2:] != self.grid_shape:
            raise ValueError(
                f"block values must have shape (..., {self.grid_shape}), got {v.shape}"
            )
        bh, bw = self.block_shape
        return np.repeat(np.repeat(v, bh, axis=-2), bw, axis=-1)

    def direction_mask(self, direction: Direction | int, *, pe: bool = True) -> np.ndarray:
        """Boolean mask of the blocks whose next node lies in ``direction``.

        Parameters
        ----------
        direction : Direction
        pe : bool
            True (default): one entry per PE, shape ``array_shape``; False: per block.
        """
        m = self.next_direction() == int(Direction(direction))
        return self.expand(m) if pe else m

    def row_parity_mask(self, parity: int, *, pe: bool = True) -> np.ndarray:
        """Boolean mask of the blocks on even (``parity=0``) or odd (1) block rows.

        Even rows run west, odd rows east; a PE program shifts the two halves separately.
        """
        if parity not in (0, 1):
            raise ValueError(f"parity={parity!r} must be 0 (even block rows) or 1 (odd)")
        rows, cols = self.grid_shape
        m = np.zeros((rows, cols), bool)
        m[parity::2] = True
        return self.expand(m) if pe else m

    def occupied_mask(self, n_nodes: int, tile: int, *, pe: bool = True) -> np.ndarray:
        """Boolean mask of the blocks of ``tile`` that hold one of ``n_nodes`` nodes."""
        local = np.clip(n_nodes - tile * self.capacity, 0, self.capacity)
        m = self.block_index_grid() < local
        return self.expand(m) if pe else m

    # -- node values <-> planes ----------------------------------------------------------

    def to_planes(self, values: np.ndarray, *, fill: int | float = 0) -> np.ndarray:
        """Place per-node blocks of values on tiles.

        Parameters
        ----------
        values : ndarray, shape (N, block_rows, block_cols)
            One block of PE values per node, in map order.
        fill : scalar
            Value of PEs that hold no node.

        Returns
        -------
        ndarray, shape (n_tiles, array_rows, array_cols)
            Same dtype as ``values``.
        """
        v = np.asarray(values)
        if v.ndim != 3 or v.shape[1:] != self.block_shape:
            raise ValueError(f"values must have shape (N, {self.block_shape}), got {v.shape}")
        n = len(v)
        rows, cols = self.grid_shape
        bh, bw = self.block_shape
        padded = np.full((self.n_tiles(n) * self.capacity, bh, bw), fill, dtype=v.dtype)
        padded[:n] = v
        order = self.block_index_grid().reshape(-1)  # tile-local node of each block, row-major
        tiles = padded.reshape(-1, self.capacity, bh, bw)[:, order]
        tiles = tiles.reshape(-1, rows, cols, bh, bw).transpose(0, 1, 3, 2, 4)
        return np.ascontiguousarray(tiles.reshape(-1, *self.array_shape))

    def from_planes(self, planes: np.ndarray, n_nodes: int) -> np.ndarray:
        """Inverse of :meth:`to_planes`: the first ``n_nodes`` node blocks, (N, bh, bw)."""
        p = np.asarray(planes)
        if p.ndim != 3 or p.shape[1:] != self.array_shape or len(p) < self.n_tiles(n_nodes):
            raise ValueError(
                f"planes must have shape ({self.n_tiles(n_nodes)}, {self.array_shape}) "
                f"for {n_nodes} nodes, got {p.shape}"
            )
        rows, cols = self.grid_shape
        bh, bw = self.block_shape
        blocks = p.reshape(-1, rows, bh, cols, bw).transpose(0, 1, 3, 2, 4)
        blocks = blocks.reshape(len(p), self.capacity, bh, bw)
        inverse = np.argsort(self.block_index_grid().reshape(-1))
        return blocks[:, inverse].reshape(-1, bh, bw)[:n_nodes].copy()


def layout_for(kind: str, array_shape: tuple[int, int] = (256, 256)) -> SnakeLayout:
    """Return the snake layout of a place representation (:data:`KIND_BLOCK_SHAPES`).

    Examples
    --------
    >>> [layout_for(kind).capacity for kind in ("lbp", "lowres", "lowres16", "haar")]
    [2048, 1024, 256, 256]
    """
    try:
        block = KIND_BLOCK_SHAPES[kind]
    except KeyError:
        raise ValueError(
            f"no PE layout for kind {kind!r}; known kinds: {', '.join(KIND_BLOCK_SHAPES)}"
        ) from None
    return SnakeLayout(block, array_shape)
