"""Save and load a TopoMap as one versioned, checksummed ``.npz`` file.

Format ``ppaloc.topomap``, version 1: an uncompressed ``.npz`` (zip of ``.npy``) holding

- ``header``: a uint8 array, the UTF-8 bytes of a JSON object (see :func:`save_map`);
- ``descriptors``, ``frame_index`` and, if the map has them, ``positions``.

Nothing is pickled, and loading never unpickles (``allow_pickle=False``). A file that is
missing, not a zip, not ours, from a newer format version, truncated or altered raises
:class:`ppaloc.errors.MapFormatError` naming the file and the cause.
"""

from __future__ import annotations

import contextlib
import datetime as dt
import hashlib
import json
import zipfile
import zlib
from pathlib import Path
from typing import Any

import numpy as np

import ppaloc
from ppaloc.errors import DataError, MapFormatError
from ppaloc.fileio import atomic_write
from ppaloc.topomap.map import TopoMap

__all__ = ["FORMAT_NAME", "FORMAT_VERSION", "load_map", "read_header", "save_map"]

FORMAT_NAME = "ppaloc.topomap"
FORMAT_VERSION = 1
_ARRAYS = ("descriptors", "frame_index", "positions")
_READ_ERRORS = (OSError, ValueError, EOFError, KeyError, zipfile.BadZipFile, zlib.error)


def _jsonable(value: Any) -> Any:
    if isinstance(value, np.generic):
        return value.item()
    if isinstance(value, np.ndarray):
        return value.tolist()
    if isinstance(value, Path):
        return str(value)
    raise TypeError(f"{type(value).__name__} is not JSON-serialisable")


def _canonical(header: dict[str, Any]) -> bytes:
    body = {k: v for k, v in header.items() if k != "sha256"}
    return json.dumps(body, sort_keys=True, separators=(",", ":"), default=_jsonable).encode()


def _checksum(header: dict[str, Any], arrays: dict[str, np.ndarray]) -> str:
    """SHA-256 of the canonical header (without ``sha256``) then each array's C-order bytes."""
    h = hashlib.sha256(_canonical(header))
    for name in sorted(arrays):
        h.update(np.ascontiguousarray(arrays[name]).tobytes())
    return h.hexdigest()


def _describe(a: np.ndarray) -> dict[str, Any]:
    return {"dtype": a.dtype.str, "shape": list(a.shape)}


def save_map(topomap: TopoMap, path: str | Path, *, dataset: str | None = None) -> Path:
    """Write ``topomap`` to ``path`` atomically (a temporary file, then ``os.replace``).

    The JSON header holds ``format`` (``"ppaloc.topomap"``), ``format_version`` (1),
    ``kind``, ``n_nodes``, ``arrays`` (dtype and shape of each array), ``layout`` (the
    snake layout: ``block_shape``, ``array_shape``, ``capacity``, ``n_tiles``; null for
    kinds without one), ``params``, ``provenance`` (the map's own provenance plus
    ``ppaloc_version``, ``created`` as ISO 8601 UTC and ``dataset`` if given) and
    ``sha256``: the SHA-256 of the header serialised canonically without ``sha256`` (JSON,
    sorted keys, no spaces) followed by the C-order bytes of the arrays in name order.

    Parameters
    ----------
    topomap : TopoMap
    path : str or Path
        Output file, written exactly as named (``.npz`` is the customary suffix).
    dataset : str, optional
        Name of the source dataset, recorded in the provenance.

    Returns
    -------
    Path
        ``path``.
    """
    path = Path(path)
    if not path.parent.is_dir():
        raise DataError(
            f"cannot write the map to {path}: folder {path.parent} does not exist; create it first"
        )
    arrays = {"descriptors": topomap.descriptors, "frame_index": topomap.frame_index}
    if topomap.positions is not None:
        arrays["positions"] = topomap.positions
    if any(a.dtype.hasobject for a in arrays.values()):
        raise ValueError("map arrays must be numeric, not object arrays")
    layout = topomap.layout
    provenance = dict(topomap.provenance)
    provenance["ppaloc_version"] = ppaloc.__version__
    provenance["created"] = dt.datetime.now(dt.UTC).isoformat(timespec="seconds")
    if dataset is not None:
        provenance["dataset"] = dataset
    header: dict[str, Any] = {
        "format": FORMAT_NAME,
        "format_version": FORMAT_VERSION,
        "kind": topomap.kind,
        "n_nodes": len(topomap),
        "arrays": {name: _describe(a) for name, a in arrays.items()},
        "layout": None
        if layout is None
        else {
            "order": "snake from the top-right block, west first",
            "block_shape": list(layout.block_shape),
            "array_shape": list(layout.array_shape),
            "capacity": layout.capacity,
            "n_tiles": layout.n_tiles(len(topomap)),
        },
        "params": topomap.params,
        "provenance": provenance,
    }
    try:
        header = json.loads(_canonical(header))  # normalise (tuples -> lists, numpy -> Python)
    except TypeError as exc:
        raise ValueError(f"map params and provenance must be JSON-serialisable: {exc}") from None
    header["sha256"] = _checksum(header, arrays)
    blob = np.frombuffer(json.dumps(header, indent=1).encode(), dtype=np.uint8)
    with atomic_write(path) as f:
        np.savez(f, header=blob, **arrays)
    return path


def _fail(path: Path, cause: str) -> MapFormatError:
    return MapFormatError(f"cannot load map {path}: {cause}")


def read_header(path: str | Path) -> dict[str, Any]:
    """Return the JSON header of a map file, checked for format and version (not checksum)."""
    path = Path(path)
    with _open(path) as npz:
        return _header(path, npz)


@contextlib.contextmanager
def _open(path: Path):
    if not path.exists():
        raise _fail(path, "no such file")
    if not path.is_file():
        raise _fail(path, "not a file")
    # Open the file ourselves so that it is closed whatever np.load makes of it.
    with open(path, "rb") as f:
        try:
            npz = np.load(f, allow_pickle=False)
        except _READ_ERRORS as exc:
            f.seek(0)
            if f.read(4) == b"PK\x03\x04":
                raise _fail(path, f"corrupt or truncated .npz archive ({exc})") from None
            raise _fail(path, "not a ppaloc map (not an .npz archive)") from None
        if not isinstance(npz, np.lib.npyio.NpzFile):
            raise _fail(path, "not a ppaloc map (a single .npy array, not an .npz archive)")
        with npz:
            yield npz


def _header(path: Path, npz: np.lib.npyio.NpzFile) -> dict[str, Any]:
    if "header" not in npz.files:
        raise _fail(path, f"not a ppaloc map (no 'header' entry; it holds {sorted(npz.files)})")
    try:
        raw = npz["header"]
        if raw.dtype != np.uint8 or raw.ndim != 1:
            raise ValueError("the header is not a byte string")
        header = json.loads(raw.tobytes().decode())
    except (*_READ_ERRORS, UnicodeDecodeError) as exc:
        raise _fail(path, f"corrupt or truncated header ({exc})") from None
    if not isinstance(header, dict) or header.get("format") != FORMAT_NAME:
        found = header.get("format") if isinstance(header, dict) else None
        raise _fail(path, f"not a ppaloc map (format {found!r}, expected {FORMAT_NAME!r})")
    version = header.get("format_version")
    if not isinstance(version, int) or isinstance(version, bool) or version < 1:
        raise _fail(path, f"corrupt header (format_version {version!r})")
    if version > FORMAT_VERSION:
        raise _fail(
            path,
            f"format version {version} is newer than this ppaloc {ppaloc.__version__} reads "
            f"(up to {FORMAT_VERSION}); upgrade ppaloc",
        )
    return header


def load_map(path: str | Path) -> TopoMap:
    """Read a map written by :func:`save_map`, verifying format, version and checksum.

    Raises
    ------
    MapFormatError
        The file is missing, not an ``.npz``, not a ppaloc map, from a newer format
        version, truncated, or its contents do not match the checksum.
    """
    path = Path(path)
    with _open(path) as npz:
        header = _header(path, npz)
        try:
            specs = header["arrays"]
            names = sorted(specs)
            if not {"descriptors", "frame_index"} <= set(names) or not set(names) <= set(_ARRAYS):
                raise ValueError(f"unexpected arrays {names}")
            arrays = {name: npz[name] for name in names}
            for name, a in arrays.items():
                if _describe(a) != specs[name]:
                    raise ValueError(f"array {name!r} is {_describe(a)}, header says {specs[name]}")
            expected = header["sha256"]
        except (*_READ_ERRORS, TypeError) as exc:
            raise _fail(path, f"corrupt or truncated file ({exc})") from None
    if _checksum(header, arrays) != expected:
        raise _fail(path, "checksum mismatch: the file was altered or damaged")
    try:
        return TopoMap(
            kind=header["kind"],
            descriptors=arrays["descriptors"],
            frame_index=arrays["frame_index"],
            positions=arrays.get("positions"),
            params=header.get("params", {}),
            provenance=header.get("provenance", {}),
        )
    except (KeyError, ValueError) as exc:
        raise _fail(path, f"inconsistent contents ({exc})") from None
