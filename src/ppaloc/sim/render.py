"""Register planes as images: one register to PNG, or a labelled montage of several.

Analogue registers are drawn in grey on a *fixed* scale, -128 -> black, 127 -> white
(``v + 128``, clipped), so images of different registers and frames compare directly;
digital registers are black (0) and white (1). PNGs are written atomically (a temporary
file in the target folder, then ``os.replace``), so a reader never sees half a file.

Examples
--------
>>> import numpy as np
>>> plane_to_image(np.array([[-128.0, 0.0, 127.0]])).tolist()
[[0, 128, 255]]
>>> plane_to_image(np.array([[False, True]])).tolist()
[[0, 255]]
"""

from __future__ import annotations

import os
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np
from PIL import Image, ImageDraw, ImageFont

from ppaloc.errors import SimulatorError
from ppaloc.fileio import write_png
from ppaloc.sim.registers import Register

if TYPE_CHECKING:
    from ppaloc.sim.engine import Scamp5

__all__ = ["plane_to_image", "render_montage", "render_register", "save_png"]

_LABEL_H = 14  # pixels of the label strip above each montage tile
_GAP = 4  # pixels between tiles
_BACKGROUND = 64  # grey of the montage background (distinct from black and white)


def plane_to_image(plane: np.ndarray) -> np.ndarray:
    """A register plane as an 8-bit grey image.

    Parameters
    ----------
    plane : numpy.ndarray, shape (rows, cols)
        Bool (digital register) or float (analogue register, register units).

    Returns
    -------
    numpy.ndarray of uint8, shape (rows, cols)
        Digital: 0 / 255. Analogue: ``v + 128`` rounded half up and clipped to [0, 255],
        so -128 is black and 127 white whatever the plane's own range.
    """
    arr = np.asarray(plane)
    if arr.ndim != 2:
        raise SimulatorError(f"a register plane is 2-D (rows, cols); got shape {arr.shape}")
    if arr.dtype == bool:
        return np.where(arr, 255, 0).astype(np.uint8)
    return np.clip(np.floor(arr.astype(np.float64) + 128.5), 0, 255).astype(np.uint8)


def _write_atomically(image: Image.Image, path: Path) -> Path:
    path = Path(path)
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        write_png(path, image)
    except OSError as e:
        raise SimulatorError(
            f"cannot write {str(path)!r}: {e.strerror or e}; choose a writable folder"
        ) from e
    return path


def _scaled(image: np.ndarray, scale: int) -> Image.Image:
    if not isinstance(scale, int) or isinstance(scale, bool) or scale < 1:
        raise SimulatorError(f"scale={scale!r} is invalid: use a positive integer")
    img = Image.fromarray(image)
    if scale > 1:
        img = img.resize((img.width * scale, img.height * scale), Image.Resampling.NEAREST)
    return img


def save_png(image: np.ndarray, path: str | os.PathLike[str], *, scale: int = 1) -> Path:
    """Write a uint8 grey image as PNG, enlarged ``scale`` times (nearest neighbour).

    Returns
    -------
    pathlib.Path
        The path written.
    """
    arr = np.asarray(image)
    if arr.dtype != np.uint8 or arr.ndim != 2:
        raise SimulatorError(f"save_png needs a 2-D uint8 image, got {arr.dtype} {arr.shape}")
    return _write_atomically(_scaled(arr, scale), Path(path))


def render_register(
    sim: Scamp5, reg: Register, path: str | os.PathLike[str], *, scale: int = 1
) -> Path:
    """Write one register of ``sim`` as a PNG of ``rows * scale`` x ``cols * scale`` pixels.

    Untimed: this inspects the simulator (``sim.read``), it is not a hardware readout.

    Returns
    -------
    pathlib.Path
        The path written.
    """
    return save_png(plane_to_image(sim.read(reg)), path, scale=scale)


def render_montage(
    planes: Scamp5 | Mapping[str, np.ndarray],
    path: str | os.PathLike[str],
    registers: Sequence[Register] = (),
    *,
    columns: int | None = None,
    scale: int = 1,
) -> Path:
    """Write several register planes side by side, each labelled with its name.

    Parameters
    ----------
    planes : Scamp5 or Mapping[str, numpy.ndarray]
        A simulator (then ``registers`` names the registers to draw) or labelled planes
        (label -> bool or float array; all of one shape).
    path : path-like
        PNG to write.
    registers : sequence of Register
        With a simulator: the registers to draw, in order.
    columns : int, optional
        Tiles per row (default: up to 4).
    scale : int
        Enlargement of every tile (nearest neighbour).

    Returns
    -------
    pathlib.Path
        The path written. Tiles are ``rows * scale`` x ``cols * scale`` pixels under a
        14-pixel label strip, 4 pixels apart.
    """
    if isinstance(planes, Mapping):
        items = [(str(k), np.asarray(v)) for k, v in planes.items()]
    else:
        if not registers:
            raise SimulatorError("render_montage: name the registers to draw, e.g. [PIX, A, R5]")
        for reg in registers:
            if not isinstance(reg, Register):
                raise SimulatorError(
                    f"render_montage: {reg!r} is not a register handle; pass handles from "
                    "ppaloc.sim, e.g. [PIX, A, R5]"
                )
        items = [(reg.name, planes.read(reg)) for reg in registers]
    if not items:
        raise SimulatorError("render_montage: nothing to draw; give at least one plane")
    shapes = {p.shape for _, p in items}
    if len(shapes) != 1:
        raise SimulatorError(f"render_montage: planes differ in shape {sorted(shapes)}")
    tiles = [(label, _scaled(plane_to_image(p), scale)) for label, p in items]
    n = len(tiles)
    ncol = min(n, 4) if columns is None else columns
    if not isinstance(ncol, int) or ncol < 1:
        raise SimulatorError(f"columns={columns!r} is invalid: use a positive integer")
    nrow = -(-n // ncol)
    tw, th = tiles[0][1].size
    cell_w, cell_h = tw + _GAP, th + _LABEL_H + _GAP
    canvas = Image.new("L", (ncol * cell_w + _GAP, nrow * cell_h + _GAP), _BACKGROUND)
    draw = ImageDraw.Draw(canvas)
    font = ImageFont.load_default()
    for i, (label, tile) in enumerate(tiles):
        x = _GAP + (i % ncol) * cell_w
        y = _GAP + (i // ncol) * cell_h
        draw.text((x, y), label, fill=255, font=font)
        canvas.paste(tile, (x, y + _LABEL_H))
    return _write_atomically(canvas, Path(path))
