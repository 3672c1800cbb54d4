"""Place representations on the host: low-resolution images and binary descriptors.

Every place starts from the exact block means of a (256, 256) uint8 sensor frame
(docs/ppa8.md): 8x8 or 16x16 low-res images, compared by the sum of absolute differences
(:func:`sad`; the robust filter normalises the contrast of each tile of blocks first,
:func:`normalise_contrast`), the 32-bit LBP code of the 8x8 grid (:func:`hamming`) and the
192-bit Haar signs of its blocks (:func:`haar_descriptor`, :func:`hamming_words`), both
compared by Hamming distance. Everything is vectorised over leading axes (frames) or N
nodes and exact. Beside them, SeqSLAM's patch-normalised 64x32 image (:func:`patch_image`,
:func:`mean_abs_diff`), the baselines' own place, which the weighted-node filter also
takes on the host (no register holds its 2048 floats).
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
from ppaloc.place.haar import (
    HAAR_BITS,
    HAAR_GRID,
    HAAR_WORDS,
    haar_descriptor,
    haar_plane,
    hamming_words,
    pack_plane,
    unpack_plane,
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
from ppaloc.place.patch import PATCH_SHAPE, mean_abs_diff, patch_image
from ppaloc.place.sad import sad

__all__ = [
    "CONTRAST_SCALES",
    "HAAR_BITS",
    "HAAR_GRID",
    "HAAR_WORDS",
    "LBP_BITS",
    "LOWRES_GRIDS",
    "PATCH_SHAPE",
    "SENSOR_SIZE",
    "LowresIndex",
    "block_means",
    "block_sums",
    "contrast_scale",
    "haar_descriptor",
    "haar_plane",
    "hamming",
    "hamming_words",
    "lbp_descriptor",
    "lbp_from_grid",
    "lbp_grid",
    "lowres_grid",
    "lowres_image",
    "mean_abs_diff",
    "normalise_contrast",
    "pack_bits",
    "pack_plane",
    "patch_image",
    "sad",
    "tile_cells",
    "unpack_bits",
    "unpack_plane",
]
