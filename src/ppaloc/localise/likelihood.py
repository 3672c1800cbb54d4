"""Per-frame distances from the live frame to every map node, and their register scale.

Every place a register holds gives an integer distance per node (the host's float place a
float), which the filter turns into the scaled likelihood ``mu_s`` in register units with
one power-of-two factor (docs/ppa8.md, "Likelihood"):

- ``"lowres"``, ``arithmetic="ppa8"``: ``T_i = sum over the 64 cells of
  min(|S_c - 1024 q_ic|, 254 * 1024)`` with ``S_c`` the live frame's exact block sum and
  ``q_ic`` the node's uint8 image (:meth:`ppaloc.place.LowresIndex.sad_to_sums`). In
  register units ``mu_i = T_i / 2**17``, the mean over the cells of ``min(|f - n_i|, 127)``,
  because ``|f - n| = |S/1024 - q| / 2``.
- ``"lowres"``, ``arithmetic="float"``: the live frame quantised like a node
  (``floor(S/1024)``, :func:`ppaloc.place.lowres_image`) and the uint8 SAD
  (:meth:`ppaloc.place.LowresIndex.sad`), ``mu_i = SAD_i / 128``: the fast path, within
  half a register unit of the exact value.
- ``"lowres"`` with ``contrast`` (the robust preset): the live image quantised like a
  node, then both it and every node normalised by
  :func:`ppaloc.place.normalise_contrast` (each 2x2 tile of blocks on its own by
  default, ``patch``), and the uint8 SAD; ``arithmetic="ppa8"`` gives
  it in the units above, ``T_i = 1024 * SAD_i`` (the register's cap of 254 grey levels
  per cell never binds: the normalised levels run 1..255). On the sensor the controller
  reads the live image's 64 codes, normalises them and loads them through the DAC
  (docs/ppa8.md).
- ``"lowres16"`` (contrast only): as ``"lowres"`` with contrast on the 16x16 grid, each
  tile of ``2 patch`` x ``2 patch`` blocks normalised on its own (the same pixels as the
  8x8 grid's tile of ``patch`` x ``patch``). ``mu_i`` is again the mean over the cells of
  ``|f - n_i|``: ``SAD_i / 512`` in float; in ppa8 ``T_i = 256 * SAD_i`` (the pixels per
  block times the SAD, as for 8x8), so ``mu_i = T_i / 2**17`` in both (cells x pixels per
  block = 65,536 either way).
- ``"lbp"``: ``h_i = popcount(x XOR d_i)`` in [0, 32]. On the PPA each differing bit of a
  node's 4x8-PE block loads the DAC constant 2 and an adding tree over the 32 PEs leaves
  their sum, so ``mu_i = 2 * h_i`` in [0, 64] register units.
- ``"haar"``: ``h_i`` = the differing bits of the 192-bit Haar-sign places
  (:func:`ppaloc.place.hamming_words`). On the PPA each differing bit of a node's 16x16-PE
  block loads 64 and a halving tree averages the 256 PEs, so ``mu_i = h_i / 4`` in
  [0, 48] register units, exactly in the update; the controller reads it rounded,
  ``floor(h_i / 4 + 1/2)`` (the ADC code of the root, :data:`HAAR_EXPONENT`).
- ``"patch"`` (host, float only): SeqSLAM's patch-normalised 64x32 image, the baselines'
  own place (:func:`ppaloc.place.patch_image`). ``mu_i = PATCH_UNITS * m_i`` with ``m_i``
  the mean absolute difference per pixel in deviations (:func:`ppaloc.place.mean_abs_diff`),
  a float: no register holds the place's 2048 floats (:data:`FLOAT_PLACES`).

Every case then scales by ``2**-shift``.
"""

from __future__ import annotations

import copy

import numpy as np

from ppaloc.errors import PpalocError
from ppaloc.place import (
    SENSOR_SIZE,
    LowresIndex,
    block_sums,
    haar_descriptor,
    hamming,
    hamming_words,
    lbp_descriptor,
    lowres_grid,
    lowres_image,
    mean_abs_diff,
    normalise_contrast,
    patch_image,
    tile_cells,
)

__all__ = [
    "BINARY_PLACES",
    "FLOAT_PLACES",
    "HAAR_EXPONENT",
    "LOWRES_CAP",
    "PATCH_UNITS",
    "NodeDistances",
    "distance_scale",
    "float_divisor",
]

LOWRES_CAP = 254
"""Per-cell cap of ``|m - q|`` in grey levels: a register difference of 127."""

BINARY_PLACES = ("lbp", "haar")
"""The places compared by Hamming distance: exact integer distances, no contrast."""

FLOAT_PLACES = ("patch",)
"""The places no register holds (the host's alone): float distances, float arithmetic."""

PATCH_UNITS = 64.0
"""``"patch"``: register units per deviation of mean absolute difference. Two unrelated
patch-normalised pixels differ by about ``2 / sqrt(pi)`` (1.13) deviations, so an unrelated
node reads some 70 units, in the range of the low-res places' ``mu`` (0-127); the robust
filter scales each frame from its own spread, so the factor only keeps the spread well above
``gain``."""

HAAR_EXPONENT = 2
"""Haar signs: ``mu = h * 2**-HAAR_EXPONENT`` register units (64 per differing bit averaged
over a 256-PE block)."""


def float_divisor(representation: str) -> int:
    """Low-res in float: ``mu = SAD / divisor``, twice the cells (``|f - n|`` is half a
    grey-level difference, and ``mu`` its mean over the cells): 128 for 8x8, 512 for 16x16."""
    grid = lowres_grid(representation)
    if grid is None:
        raise ValueError(f"{representation!r} is not a low-res representation")
    return 2 * grid * grid


def distance_scale(representation: str, shift: int, exact: bool) -> float:
    """Factor from a raw integer distance to ``mu_s`` in register units (module doc).

    Examples
    --------
    >>> distance_scale("lbp", 2, True), distance_scale("lowres", 0, False)
    (0.5, 0.0078125)
    >>> distance_scale("haar", 1, True), distance_scale("haar", 1, False)
    (0.125, 0.125)
    >>> distance_scale("lowres16", 0, False), distance_scale("lowres16", 0, True) * 2**17
    (0.001953125, 1.0)
    >>> distance_scale("patch", 2, False)
    0.25
    """
    if representation == "lbp":
        return 2.0 ** (1 - shift)
    if representation == "haar":
        return 2.0 ** -(HAAR_EXPONENT + shift)
    if representation in FLOAT_PLACES:
        return 2.0**-shift
    if exact:
        return 2.0 ** -(17 + shift)
    return 2.0**-shift / float_divisor(representation)


class NodeDistances:
    """Raw distances from a live sensor frame to all N nodes of one map.

    Parameters
    ----------
    kind : {"lowres", "lowres16", "lbp", "haar", "patch"}
    descriptors : ndarray
        The map's nodes: uint8 (N, 8, 8) or (N, 16, 16), uint32 (N,) (LBP) or (N, 8)
        (Haar signs), float32 (N, 32, 64) (the patch-normalised image).
    exact : bool
        Low-res only: the register's distance (ppa8): to the unquantised live frame, or
        with ``contrast`` capped per cell; else the uint8 SAD to the quantised frame.
    contrast : int, optional
        Low-res only: compare contrast-normalised images
        (:func:`ppaloc.place.normalise_contrast` with this target; 0 compares the
        quantised images as they are). None (the paper preset): no normalisation, and
        ``exact`` compares the unquantised live frame.
    patch : int, optional
        Low-res with ``contrast``: normalise each ``patch`` x ``patch`` tile of 32x32-pixel
        blocks on its own (on the 16x16 grid the same pixels, ``2 patch`` cells a side;
        None: the whole image).
    """

    def __init__(
        self,
        kind: str,
        descriptors: np.ndarray,
        *,
        exact: bool,
        contrast: int | None = None,
        patch: int | None = None,
    ) -> None:
        self.kind = kind
        self.exact = exact
        self.contrast = contrast
        self.grid = lowres_grid(kind) or 8
        self.patch = tile_cells(self.grid, patch)
        # pixels per block: T = P * SAD is the register's sum (module doc)
        self._pixels_bits = ((SENSOR_SIZE // self.grid) ** 2).bit_length() - 1
        if self.grid != 8 and contrast is None:  # the paper preset's path is the 8x8 one
            raise PpalocError(
                f"the {kind} place compares contrast-normalised images only: give contrast="
            )
        if kind in FLOAT_PLACES:
            if exact:
                raise PpalocError(
                    f"the {kind} place has no register arithmetic (no register holds it): "
                    "use arithmetic='float'"
                )
            self._nodes = np.ascontiguousarray(descriptors, dtype=np.float32)
            self.out = np.empty(len(self._nodes), np.float64)
        elif kind in BINARY_PLACES:
            self._nodes = np.ascontiguousarray(descriptors, dtype=np.uint32)
            self.out = np.empty(len(self._nodes), np.uint8 if kind == "lbp" else np.uint16)
        else:
            nodes = np.asarray(descriptors, np.uint8)
            if contrast is not None:
                nodes = normalise_contrast(nodes, contrast, self.patch)
            self._index = LowresIndex(nodes)
            self.out = np.empty(len(self._index), np.uint16)

    def sharing(self) -> NodeDistances:
        """The same distances on the same map, its nodes (read only) shared and its output
        buffer its own: a second weight set of one map without a second copy of it."""
        other = copy.copy(self)
        other.out = np.empty_like(self.out)
        return other

    def live(self, frame: np.ndarray) -> np.ndarray:
        """Low-res: the live image as the comparison sees it, (grid, grid) uint8 (normalised
        with ``contrast``; without it the quantised image, which ``exact`` does not use)."""
        image = lowres_image(frame, self.grid)
        if self.contrast is None:
            return image
        return normalise_contrast(image, self.contrast, self.patch)

    def __call__(self, frame: np.ndarray) -> np.ndarray:
        """Return the raw distances (shape (N,); reused buffer except for exact low-res)."""
        if self.kind == "lbp":
            return hamming(lbp_descriptor(frame), self._nodes, out=self.out)
        if self.kind == "haar":
            return hamming_words(haar_descriptor(frame), self._nodes, out=self.out)
        if self.kind in FLOAT_PLACES:
            np.multiply(mean_abs_diff(patch_image(frame), self._nodes), PATCH_UNITS, out=self.out)
            return self.out
        if self.exact:
            if self.contrast is None:
                return self._index.sad_to_sums(block_sums(frame, 8), cap=LOWRES_CAP)
            # levels 1..255: no cell reaches the cap, so T = P SAD exactly
            sad = self._index.sad(self.live(frame), out=self.out).astype(np.int64)
            return sad << self._pixels_bits
        return self._index.sad(self.live(frame), out=self.out)

    def registers(self, raw: np.ndarray) -> np.ndarray:
        """``raw`` (from :meth:`__call__`) as the register holds it: low-res with
        ``contrast`` (the robust preset) the integer ``T = P SAD`` (``P`` pixels a block;
        what ``exact`` returns already), the binary places their Hamming distance as it
        is. The robust preset's readout reads these in either arithmetic
        (:func:`ppaloc.localise.host.read_values`). Without ``contrast`` a float map
        compares the quantised frame, not the register's unquantised sums."""
        if self.kind in BINARY_PLACES or self.kind in FLOAT_PLACES or self.exact:
            return raw
        return raw.astype(np.int64) << self._pixels_bits
