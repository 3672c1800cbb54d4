"""Finding and reading image files: natural sort, folder listing, grey decoding."""

from __future__ import annotations

import errno
import os
import re
import warnings
from pathlib import Path

import numpy as np
from PIL import Image, UnidentifiedImageError

from ppaloc.errors import DataError

__all__ = [
    "FOLDER_FIX",
    "IMAGE_SUFFIXES",
    "MAX_IMAGES",
    "MAX_IMAGE_PIXELS",
    "dataset_file",
    "list_images",
    "natural_key",
    "read_grey",
    "read_grey_reduced",
    "require_dir",
]

MAX_IMAGE_PIXELS = 50_000_000
"""Largest image accepted, width x height (a 10,000 x 5,000 panorama; a frame is smaller by
far), checked from the header before any pixel is decoded."""

MAX_IMAGES = 5_000_000
"""Most images one folder may hold."""

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


def missing(path: Path) -> str:
    """Why a file a spec names cannot be read as one: ``"does not exist"``, or, for a pipe,
    device or socket (which ppaloc never opens: a pipe would block), ``"is not a regular
    file (a pipe, device or socket)"``."""
    if Path(path).exists():
        return "is not a regular file (a pipe, device or socket)"
    return "does not exist"


def require_dir(path: Path, what: str = "folder") -> Path:
    """Return ``path`` if it is a directory, else raise a ``DataError`` naming it."""
    path = Path(path)
    if not path.exists():
        where = ""
        if not path.is_absolute():  # a spec from a --config file elsewhere reads from here too
            where = f" (a relative path is read from the current folder, {Path.cwd()})"
        raise DataError(f"{what} {path} does not exist: check the path in the dataset spec{where}")
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
    files = []
    try:
        entries = folder.iterdir()
        for p in entries:
            if p.suffix.lower() not in IMAGE_SUFFIXES:
                continue
            if p.is_symlink() and not p.exists():
                if _leads_into_loop(p):
                    raise DataError(
                        f"{what} {folder}: {p.name} is a symbolic link that leads into a loop "
                        "(links that lead back to themselves); fix the link or remove it"
                    )
                raise DataError(
                    f"{what} {folder}: {p.name} is a symbolic link to {_link_target(p)}, which "
                    "does not exist; restore the target or remove the link"
                )
            if not p.is_file():
                # skipped, it dropped a frame without a word (and moved every later frame's
                # index against the other traversal's)
                kind = "a folder" if p.is_dir() else "a pipe, device or socket"
                raise DataError(
                    f"{what} {folder}: {p.name} is named like an image but is {kind}; move it "
                    "out of the folder or rename it"
                )
            files.append(p)
            if len(files) > MAX_IMAGES:
                raise DataError(f"{what} {folder} holds more than {MAX_IMAGES} images")
    except PermissionError:
        raise DataError(f"{what} {folder} cannot be listed (permission denied)") from None
    if not files:
        raise DataError(
            f"{what} {folder} holds no images ({', '.join(sorted(IMAGE_SUFFIXES))}): "
            "give the folder that holds the frames"
        )
    return sorted(files, key=lambda p: natural_key(p.name))


def dataset_file(root: Path, name: str, key: str, suffix: str) -> Path:
    """The file a spec key names: ``name`` relative to the dataset folder ``root`` must stay
    inside it (after following links); an absolute path is the user's explicit choice of a
    file elsewhere. Either way it must end in ``suffix`` and be a regular file.

    Raises
    ------
    DataError
        Naming the key, the path and the rule.
    """
    given = Path(name).expanduser()
    if given.suffix.lower() != suffix:
        raise DataError(f"{key}={name!r} must name a {suffix} file")
    path = given if given.is_absolute() else root / given
    if not given.is_absolute():
        try:
            inside = path.resolve().is_relative_to(root.resolve())
        except (OSError, RuntimeError):
            inside = False
        if not inside:
            raise DataError(
                f"{key}={name!r} points outside the dataset folder {root}; a relative {key} "
                f"stays inside it: give a file elsewhere by its absolute path ({key}=/full/"
                f"path/file{suffix})"
            )
    if path.is_dir():
        raise DataError(f"{key}={name!r}: {path} is a folder; give the {suffix} file")
    if not path.is_file():
        raise DataError(f"{key}={name!r}: ground-truth file {path} does not exist")
    return path


def _leads_into_loop(p: Path) -> bool:
    """Whether following the link ``p`` meets a loop of links."""
    try:
        os.stat(p)
    except OSError as exc:
        return exc.errno == errno.ELOOP
    return False


def _link_target(p: Path) -> str:
    try:
        return str(p.readlink())
    except OSError:
        return "a missing file"


FOLDER_FIX = "replace the file or remove it from the folder"
"""The advice of a :func:`read_grey` error about an image found in a folder."""


def read_grey(path: Path, *, fix: str = FOLDER_FIX) -> np.ndarray:
    """Read an image file as a 2-D ``uint8`` grey array.

    Colour is converted with the ITU-R 601 luma weights (Pillow ``convert("L")``), 16-bit
    grey is scaled to 8 bits. An image over :data:`MAX_IMAGE_PIXELS` is refused from its
    header, before any pixel is decoded (Pillow's own decompression-bomb warning, for
    sizes between its warning and error limits, is not shown: the refusal says it).

    Parameters
    ----------
    path : Path
    fix : str
        What the user should do about a bad file, ending each error (default: the
        advice for an image listed from a folder; a command given the file itself says
        otherwise).

    Raises
    ------
    DataError
        If the file is missing, not an image, or corrupt (e.g. truncated).
    """
    return _read(Path(path), None, fix)[0]


def read_grey_reduced(path: Path, at_least: int) -> tuple[np.ndarray, tuple[float, float]]:
    """Read an image as grey, a JPEG decoded at a reduced scale, for thumbnails.

    A JPEG is decoded by Pillow's ``draft`` at the largest power-of-two reduction (up to
    1/8) that keeps both sides at least ``at_least`` pixels, luma only, several times
    faster than a full decode; any other format is read whole (:func:`read_grey`).

    Returns
    -------
    ndarray of uint8, shape (h, w)
        The (possibly reduced) grey image.
    (float, float)
        The width and height of the whole image in the returned image's pixels (a reduced
        JPEG's last row and column may hold a partial block, so they can be less than
        ``w`` and ``h``): the box to resample from.

    Raises
    ------
    DataError
        As :func:`read_grey`.
    """
    return _read(Path(path), int(at_least), FOLDER_FIX)


def _read(path: Path, draft: int | None, fix: str) -> tuple[np.ndarray, tuple[float, float]]:
    if path.exists() and not path.is_file() and not path.is_dir():  # opening a pipe blocks
        raise DataError(f"image {path} is not a regular file (a pipe, device or socket); {fix}")
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", Image.DecompressionBombWarning)
            im = Image.open(path)
        with im:
            w, h = im.size
            if w < 1 or h < 1 or w * h > MAX_IMAGE_PIXELS:
                raise DataError(
                    f"image {path} claims {w} x {h} pixels, outside 1 to {MAX_IMAGE_PIXELS} "
                    f"pixels; {fix}"
                )
            if draft is not None and im.format == "JPEG":
                im.draft("L", (draft, draft))
            im.load()
            # A draft decodes at 1/s (s = 1, 2, 4 or 8) to ceil(w / s) x ceil(h / s) pixels.
            rw, rh = im.size
            scale = next((k for k in (1, 2, 4, 8) if -(-w // k) == rw and -(-h // k) == rh), 1)
            extent = (w / scale, h / scale)
            if im.mode in ("I;16", "I;16B", "I;16L", "I"):
                a = np.asarray(im, dtype=np.float64)
                top = 65535.0 if im.mode.startswith("I;16") or a.max() > 255 else 255.0
                return np.clip(np.rint(a * (255.0 / top)), 0, 255).astype(np.uint8), extent
            if im.mode == "F":
                a = np.asarray(im, dtype=np.float64)
                if not np.isfinite(a).all():
                    raise DataError(
                        f"image {path} holds {int((~np.isfinite(a)).sum())} NaN or infinite "
                        f"pixels; fill them (e.g. with 0), or {fix}"
                    )
                top = 255.0 if a.size and a.max() <= 1.0 else 1.0
                return np.clip(np.rint(a * top), 0, 255).astype(np.uint8), extent
            return np.asarray(im.convert("L"), dtype=np.uint8), extent
    except FileNotFoundError:
        raise DataError(f"image {path} does not exist (was it moved after listing?)") from None
    except IsADirectoryError:
        raise DataError(f"image {path} is a folder, not an image file") from None
    except Image.DecompressionBombError as exc:  # Pillow refuses it in open()
        claimed = re.search(r"\((\d+) pixels\)", str(exc))
        count = f"{claimed.group(1)}; " if claimed else ""
        raise DataError(
            f"image {path} claims too many pixels ({count}at most {MAX_IMAGE_PIXELS}); {fix}"
        ) from None
    except (UnidentifiedImageError, OSError, ValueError, SyntaxError, EOFError) as exc:
        raise DataError(f"cannot read image {path}: {_reason(exc)}; {fix}") from None
    except MemoryError:
        raise DataError(f"image {path} is too large to decode") from None


def _reason(exc: BaseException) -> str:
    """A one-line cause that never quotes file contents (Pillow quotes none; cut long ones)."""
    text = " ".join(str(exc).split()) or type(exc).__name__
    return text if len(text) <= 160 else text[:157] + "..."
