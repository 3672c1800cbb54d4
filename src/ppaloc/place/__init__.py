"""Place representations on the host: 8x8 low-resolution images and 32-bit LBP descriptors.

Both start from the exact 8x8 block means of a (256, 256) uint8 sensor frame
(docs/ppa8.md). Low-res nodes are compared by the sum of absolute differences (:func:`sad`),
LBP descriptors by Hamming distance (:func:`hamming`); the robust filter compares low-res
images after a contrast normalisation of each tile of blocks (:func:`normalise_contrast`).
Everything is vectorised over leading axes (frames) or N nodes and exact.
"""

from ppaloc.place.grid import (
    LOWRES_GRIDS,
    SENSOR_SIZE,
    block_means,
    block_sums,
    lowres_grid,
    lowres_image,
    tile_cells,
)
from ppaloc.place.index import LowresIndex
from ppaloc.place.lbp import (
    LBP_BITS,
    hamming,
    lbp_descriptor,
    lbp_from_grid,
    lbp_grid,
    pack_bits,
    unpack_bits,
)
from ppaloc.place.normalise import CONTRAST_SCALES, contrast_scale, normalise_contrast
from ppaloc.place.sad import sad

__all__ = [
    "CONTRAST_SCALES",
    "LBP_BITS",
    "LOWRES_GRIDS",
    "SENSOR_SIZE",
    "LowresIndex",
    "block_means",
    "block_sums",
    "contrast_scale",
    "hamming",
    "lbp_descriptor",
    "lbp_from_grid",
    "lbp_grid",
    "lowres_grid",
    "lowres_image",
    "normalise_contrast",
    "pack_bits",
    "sad",
    "tile_cells",
    "unpack_bits",
]
