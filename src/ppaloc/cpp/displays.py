"""What the host would show: device outputs other than whole register images, as planes.

A device program sends the host GUI more than register images: a sub-sampled analogue
register (``scamp5_output_areg``), the events or the bounding box of a digital register
(``scamp5_output_events``, ``scamp5_output_boundingbox``) and byte images, point lists
and boxes it computed itself (``scamp5_display_*``, ``vs_gui_display_image``). The
functions here turn each into the plane a display keeps for the frame, in the array's
orientation (column 0 at the west edge) as :func:`ppaloc.sim.render.plane_to_image`
draws it: bool for marks (events, box outlines), float ``value - 128`` for byte images,
so a byte ``b`` is drawn as grey level ``b``.

Positions arrive as the device writes them: events and boxes in hardware addresses
(column 0 at the east edge, docs/sim-controller.md); byte images of ``scamp5_display_image``
column-major from the top-right element, as ``scamp5_scan_areg`` fills them
(``scamp5_output.hpp``), those of ``vs_gui_display_image`` in the layout its format gives
(top-down, left to right by default).
"""

from __future__ import annotations

import numpy as np

from ppaloc.errors import PpalocError

__all__ = [
    "BYTES_PER_PIXEL",
    "DisplayError",
    "box_outlines",
    "byte_image",
    "event_marks",
    "fit_plane",
    "subsample",
]

#: The pixel sizes ``vs_gui_display_image`` takes: grey and RGB.
BYTES_PER_PIXEL = (1, 3)


class DisplayError(PpalocError):
    """A display call's data does not describe an image, events or boxes."""


def subsample(plane: np.ndarray, s: int, r0: int, c0: int) -> np.ndarray:
    """``scamp5_output_areg``: every ``s``-th element from hardware row ``r0``, column ``c0``.

    Parameters
    ----------
    plane : ndarray, shape (rows, cols)
        The register, array orientation.
    s : int
        The sub-sampling divisor (1: the whole plane).
    r0, c0 : int
        The phase, in ``[0, s)``: hardware row and column of the first element taken.

    Returns
    -------
    ndarray, shape (ceil((rows - r0) / s), ceil((cols - c0) / s))
        Array orientation (hardware column ``c0`` is the last column).

    Examples
    --------
    >>> p = np.arange(16.0).reshape(4, 4)
    >>> subsample(p, 2, 0, 0)  # hardware columns 0 and 2 are array columns 3 and 1
    array([[ 1.,  3.],
           [ 9., 11.]])
    """
    rows, cols = plane.shape
    if not 1 <= s <= min(rows, cols):
        raise DisplayError(f"s={s} is not a sub-sampling divisor here; use 1 to {min(rows, cols)}")
    for name, v in (("r0", r0), ("c0", c0)):
        if not 0 <= v < s:
            raise DisplayError(f"{name}={v} is not a phase of s={s}; use 0 to {s - 1}")
    return np.ascontiguousarray(plane[:, ::-1][r0::s, c0::s][:, ::-1])


def _positions(data: bytes, width: int, count: int, what: str) -> np.ndarray:
    need = width * count
    if count < 0 or len(data) < need:
        raise DisplayError(f"{count} {what} need {need} bytes, the buffer holds {len(data)}")
    return np.frombuffer(data[:need], np.uint8).reshape(count, width).astype(np.int64)


def event_marks(shape: tuple[int, int], cr: bytes, count: int) -> np.ndarray:
    """The events of a ``(column, row)`` byte-pair buffer, marked on a bool plane.

    Pairs past the end of the array are left out; ``(0, 0)`` ends the list, as the
    device's scan buffers mark their end (docs/cpp.md "Readout layouts").

    Examples
    --------
    >>> event_marks((2, 3), bytes([0, 1, 2, 0, 0, 0, 1, 1]), 4).astype(int)
    array([[1, 0, 0],
           [0, 0, 1]])
    """
    rows, cols = shape
    pairs = _positions(cr, 2, count, "events")
    plane = np.zeros(shape, bool)
    for c, r in pairs:
        if c == 0 and r == 0:
            break
        if r < rows and c < cols:
            plane[r, cols - 1 - c] = True
    return plane


def box_outlines(
    shape: tuple[int, int], boxes: bytes, count: int, *, empty_zeros: bool = True
) -> np.ndarray:
    """Boxes of 4 bytes each (``r, c`` of the top-right corner, then of the bottom-left
    one, hardware columns: the layout of ``scamp5_scan_boundingbox``) drawn as outlines
    on a bool plane, clipped to the array; an all-zero box (an empty register) draws
    nothing, unless ``empty_zeros`` is False (the caller knows it is the box of a 1 at
    hardware address (0, 0) alone).

    Examples
    --------
    >>> box_outlines((4, 4), bytes([1, 1, 2, 2]), 1).astype(int)
    array([[0, 0, 0, 0],
           [0, 1, 1, 0],
           [0, 1, 1, 0],
           [0, 0, 0, 0]])
    """
    rows, cols = shape
    plane = np.zeros(shape, bool)
    for r_a, c_a, r_b, c_b in _positions(boxes, 4, count, "boxes"):
        if empty_zeros and not (r_a or c_a or r_b or c_b):
            continue
        top, bottom = sorted((r_a, r_b))
        # hardware column c is array column cols - 1 - c
        left, right = sorted((cols - 1 - c_a, cols - 1 - c_b))
        bottom, right = min(bottom, rows - 1), min(right, cols - 1)
        left = max(left, 0)
        if top > bottom or left > right:
            continue
        plane[top, left : right + 1] = plane[bottom, left : right + 1] = True
        plane[top : bottom + 1, left] = plane[top : bottom + 1, right] = True
    return plane


def byte_image(
    data: bytes,
    w: int,
    h: int,
    pixel_bytes: int = 1,
    *,
    bottom_to_top: bool = False,
    right_to_left: bool = False,
    column_major: bool = False,
    channel_array: bool = False,
) -> np.ndarray:
    """A ``w`` x ``h`` byte image as a display plane (``value - 128``, float32, top-down).

    ``pixel_bytes`` 3 is RGB, drawn as its grey level (the mean of the channels; displays
    here are grey); ``channel_array`` stores the channels as three planes, not interleaved.
    The flags are those of the device's image format (``vs_gui_imageformat_t``).

    Examples
    --------
    >>> byte_image(bytes([0, 128, 255, 10]), 2, 2) + 128
    array([[  0., 128.],
           [255.,  10.]], dtype=float32)
    >>> byte_image(bytes([0, 128, 255, 10]), 2, 2, column_major=True) + 128
    array([[  0., 255.],
           [128.,  10.]], dtype=float32)
    """
    if w < 1 or h < 1:
        raise DisplayError(f"an image of {w} x {h} pixels: give a width and height of 1 or more")
    if pixel_bytes not in BYTES_PER_PIXEL:
        raise DisplayError(f"pixel_bytes={pixel_bytes}: use 1 (grey) or 3 (RGB)")
    need = w * h * pixel_bytes
    if len(data) < need:
        raise DisplayError(f"a {w} x {h} image needs {need} bytes, the buffer holds {len(data)}")
    raw = np.frombuffer(data[:need], np.uint8).astype(np.float32)
    if pixel_bytes == 3:
        raw = raw.reshape(3, -1).mean(axis=0) if channel_array else raw.reshape(-1, 3).mean(axis=1)
        raw = np.floor(raw + 0.5)
    img = raw.reshape(w, h).T if column_major else raw.reshape(h, w)
    if bottom_to_top:
        img = img[::-1]
    if right_to_left:
        img = img[:, ::-1]
    return np.ascontiguousarray(img - 128.0, dtype=np.float32)


def fit_plane(plane: np.ndarray, rows: int, cols: int) -> np.ndarray:
    """``plane`` resized to ``rows`` x ``cols`` by nearest neighbour (a montage's tiles
    share one shape; a display's own PNGs keep the size sent).

    Examples
    --------
    >>> fit_plane(np.array([[1, 2]]), 2, 4)
    array([[1, 1, 2, 2],
           [1, 1, 2, 2]])
    """
    h, w = plane.shape
    if (h, w) == (rows, cols):
        return plane
    return plane[(np.arange(rows) * h) // rows][:, (np.arange(cols) * w) // cols]
