"""Finding and reading image files: natural sort, folder listing, grey decoding."""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
from PIL import Image, UnidentifiedImageError

from ppaloc.errors import DataError

__all__ = ["IMAGE_SUFFIXES", "list_images", "natural_key", "read_grey", "require_dir"]

IMAGE_SUFFIXES = frozenset({".png", ".jpg", ".jpeg", ".bmp", ".tif", ".tiff", ".pgm", ".ppm"})
"""File suffixes taken as images (compared lower-case)."""

_DIGITS = re.compile(r"(\d+)")


def natural_key(name: str) -> tuple:
    """Sort key that orders embedded numbers by value: ``Image2`` before ``Image10``.

    Examples
    --------
    >>> sorted(["Image10.jpg", "Image2.jpg", "image1.jpg"], key=natural_key)
    ['image1.jpg', 'Image2.jpg', 'Image10.jpg']
    """
    parts = _DIGITS.split(name)
    key = tuple((0, int(p), "") if p.isdigit() else (1, 0, p.lower()) for p in parts)
    return (key, name)  # the exact name breaks ties (e.g. "a01" and "a1")


def require_dir(path: Path, what: str = "folder") -> Path:
    """Return ``path`` if it is a directory, else raise a ``DataError`` naming it."""
    path = Path(path)
    if not path.exists():
        raise DataError(f"{what} {path} does not exist: check the path in the dataset spec")
    if not path.is_dir():
        raise DataError(f"{what} {path} is not a folder: give the folder that holds the images")
    return path


def list_images(folder: Path, what: str = "image folder") -> list[Path]:
    """Return the image files in ``folder``, naturally sorted.

    Raises
    ------
    DataError
        If the folder is missing or holds no image (suffixes in :data:`IMAGE_SUFFIXES`).
    """
    folder = require_dir(folder, what)
    files = [p for p in folder.iterdir() if p.is_file() and p.suffix.lower() in IMAGE_SUFFIXES]
    if not files:
        raise DataError(
            f"{what} {folder} holds no images ({', '.join(sorted(IMAGE_SUFFIXES))}): "
            "give the folder that holds the frames"
        )
    return sorted(files, key=lambda p: natural_key(p.name))


def read_grey(path: Path) -> np.ndarray:
    """Read an image file as a 2-D ``uint8`` grey array.

    Colour is converted with the ITU-R 601 luma weights (Pillow ``convert("L")``), 16-bit
    grey is scaled to 8 bits.

    Raises
    ------
    DataError
        If the file is missing, not an image, or corrupt (e.g. truncated).
    """
    path = Path(path)
    try:
        with Image.open(path) as im:
            im.load()
            if im.mode in ("I;16", "I;16B", "I;16L", "I"):
                a = np.asarray(im, dtype=np.float64)
                top = 65535.0 if im.mode.startswith("I;16") or a.max() > 255 else 255.0
                return np.clip(np.rint(a * (255.0 / top)), 0, 255).astype(np.uint8)
            if im.mode == "F":
                a = np.asarray(im, dtype=np.float64)
                scale = 255.0 if a.size and a.max() <= 1.0 else 1.0
                return np.clip(np.rint(a * scale), 0, 255).astype(np.uint8)
            return np.asarray(im.convert("L"), dtype=np.uint8)
    except FileNotFoundError:
        raise DataError(f"image {path} does not exist (was it moved after listing?)") from None
    except (UnidentifiedImageError, OSError, ValueError, SyntaxError) as exc:
        raise DataError(
            f"cannot read image {path}: {exc}; replace the file or remove it from the folder"
        ) from None
