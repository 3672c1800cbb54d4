"""Save and load a TopoMap as one versioned, checksummed ``.npz`` file.

Format ``ppaloc.topomap``, version 2: an uncompressed ``.npz`` (zip of ``.npy``) holding

- ``header``: a uint8 array, the UTF-8 bytes of a JSON object (see :func:`save_map`);
- ``descriptors``, ``frame_index`` and, if the map has them, ``positions`` and
  ``places`` (version 2; a map without places is written as version 1, which every
  reader takes).

Nothing is pickled, and loading never unpickles. The same map gives the same bytes (no
clock time is written unless ``SOURCE_DATE_EPOCH`` is set). Loading bounds every size
before allocating (:data:`MAX_MAP_BYTES`, :data:`MAX_HEADER_BYTES`,
:data:`MAX_HEADER_DEPTH`) and checks every field; a file that is missing, not a zip, not
ours, from a newer format version, truncated, altered or out of range raises
:class:`ppaloc.errors.MapFormatError` naming the file, the field and the cause.
"""

from __future__ import annotations

import hashlib
import json
import math
from pathlib import Path
from typing import Any

import numpy as np

import ppaloc
from ppaloc.errors import DataError, MapFormatError
from ppaloc.fileio import atomic_write, source_date
from ppaloc.npzfile import NpzError, read_npz, write_npz
from ppaloc.topomap.map import TopoMap, value_problem

__all__ = [
    "FORMAT_NAME",
    "FORMAT_VERSION",
    "MAX_HEADER_BYTES",
    "MAX_HEADER_DEPTH",
    "MAX_HEADER_NUMBER",
    "MAX_MAP_BYTES",
    "load_map",
    "read_header",
    "save_map",
]

FORMAT_NAME = "ppaloc.topomap"
FORMAT_VERSION = 2
MAX_MAP_BYTES = 4 << 30
"""Most array bytes a map file may hold (4 GiB: about 60 million 8x8 nodes)."""
MAX_HEADER_BYTES = 1 << 20
"""Most bytes of a map's JSON header (1 MiB)."""
MAX_HEADER_DEPTH = 32
"""Deepest nesting of lists and objects accepted in a map's header."""
MAX_HEADER_NUMBER = 2**53
"""Largest magnitude of a number in a map's header (counts and parameters; the largest
float64 that still holds every integer exactly)."""
_ARRAYS = ("descriptors", "frame_index", "positions", "places")


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


def refuse_missing_folder(path: str | Path) -> None:
    """Refuse, in one line, a map file whose folder does not exist (a mistyped folder is
    not created): :func:`save_map` asks it, and ``ppaloc map`` before it builds the map."""
    path = Path(path)
    if not path.parent.is_dir():
        raise DataError(
            f"cannot write the map to {path}: folder {path.parent} does not exist; create it first"
        )


def save_map(topomap: TopoMap, path: str | Path, *, dataset: str | None = None) -> Path:
    """Write ``topomap`` to ``path`` atomically (a temporary file, then ``os.replace``).

    The JSON header holds ``format`` (``"ppaloc.topomap"``), ``format_version`` (2 for a
    map with places, else 1), ``kind``, ``n_nodes``, ``arrays`` (dtype and shape of each
    array), ``layout`` (the snake layout: ``block_shape``, ``array_shape``, ``capacity``,
    ``n_tiles``; null for kinds without one), ``params``, ``provenance`` (the map's own
    provenance plus ``ppaloc_version``, ``dataset`` if given and, only when
    ``SOURCE_DATE_EPOCH`` is set, ``created`` as ISO 8601 UTC: the same map gives the same
    bytes) and ``sha256``: the SHA-256 of the header serialised canonically without
    ``sha256`` (JSON, sorted keys, no spaces) followed by the C-order bytes of the arrays
    in name order.

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
    refuse_missing_folder(path)
    arrays = {"descriptors": topomap.descriptors, "frame_index": topomap.frame_index}
    if topomap.positions is not None:
        arrays["positions"] = topomap.positions
    if topomap.places is not None:
        arrays["places"] = topomap.places
    if any(a.dtype.hasobject for a in arrays.values()):
        raise ValueError("map arrays must be numeric, not object arrays")
    layout = topomap.layout
    provenance = dict(topomap.provenance)
    provenance["ppaloc_version"] = ppaloc.__version__
    provenance.pop("created", None)
    when = source_date()
    if when is not None:
        provenance["created"] = when.isoformat(timespec="seconds")
    if dataset is not None:
        provenance["dataset"] = dataset
    header: dict[str, Any] = {
        "format": FORMAT_NAME,
        "format_version": FORMAT_VERSION if topomap.places is not None else 1,
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
        write_npz(f, {"header": blob, **arrays}, compress=False)
    return path


def _fail(path: Path, cause: str) -> MapFormatError:
    return MapFormatError(f"cannot load map {path}: {cause}")


def read_header(path: str | Path) -> dict[str, Any]:
    """Return the JSON header of a map file, checked for format and version (not checksum)."""
    path = Path(path)
    return _header(path, _read(path, only=("header",)))


def _read(path: Path, only: tuple[str, ...] | None = None) -> dict[str, np.ndarray]:
    """The arrays of a map file, every member bounded before it is read."""
    if not path.exists():
        raise _fail(path, "no such file")
    if not path.is_file():
        raise _fail(path, "not a file")
    try:
        with open(path, "rb") as f:
            magic = f.read(6)
            if magic == b"\x93NUMPY":
                raise _fail(path, "not a ppaloc map (a single .npy array, not an .npz archive)")
            if magic[:4] != b"PK\x03\x04":
                raise _fail(path, "not a ppaloc map (not an .npz archive)")
            f.seek(0)
            return read_npz(
                f, max_bytes=MAX_MAP_BYTES, member_limits={"header": MAX_HEADER_BYTES}, only=only
            )
    except NpzError as exc:
        raise _fail(path, str(exc)) from None
    except OSError as exc:
        raise _fail(path, f"cannot read it ({exc.strerror or exc})") from None


def _walk(value: Any, path: str = "header") -> str | None:
    """The first place in a parsed header nested too deep or holding a non-finite number."""
    stack = [(value, path, 1)]
    while stack:
        v, where, depth = stack.pop()
        if isinstance(v, dict | list):
            if depth > MAX_HEADER_DEPTH:
                return f"{where} is nested deeper than {MAX_HEADER_DEPTH} levels"
            items = v.items() if isinstance(v, dict) else enumerate(v)
            for k, item in items:
                key = f"{where}.{k}" if isinstance(v, dict) else f"{where}[{k}]"
                stack.append((item, key, depth + 1))
        elif isinstance(v, float) and not math.isfinite(v):
            return f"{where} is {v}, not a finite number"
        elif isinstance(v, int | float) and not isinstance(v, bool) and abs(v) > MAX_HEADER_NUMBER:
            return f"{where} is {v:.3g}, outside +-2^53, the range of a map header's numbers"
    return None


def _header(path: Path, arrays: dict[str, np.ndarray]) -> dict[str, Any]:
    if "header" not in arrays:
        raise _fail(path, f"not a ppaloc map (no 'header' entry; it holds {sorted(arrays)})")
    raw = arrays["header"]
    if raw.dtype != np.uint8 or raw.ndim != 1:
        raise _fail(path, "corrupt header (not a byte string)")
    try:
        header = json.loads(raw.tobytes().decode())
    except RecursionError:
        raise _fail(path, f"header is nested deeper than {MAX_HEADER_DEPTH} levels") from None
    except (ValueError, UnicodeDecodeError) as exc:
        raise _fail(path, f"corrupt or truncated header ({type(exc).__name__})") from None
    if not isinstance(header, dict) or header.get("format") != FORMAT_NAME:
        found = header.get("format") if isinstance(header, dict) else None
        shown = found if isinstance(found, str | None) else type(found).__name__
        raise _fail(path, f"not a ppaloc map (format {shown!r:.60}, expected {FORMAT_NAME!r})")
    problem = _walk(header)
    if problem:
        raise _fail(path, problem)
    version = header.get("format_version")
    if not isinstance(version, int) or isinstance(version, bool) or version < 1:
        raise _fail(path, f"header.format_version is {version!r:.40}, not a version number")
    if version > FORMAT_VERSION:
        raise _fail(
            path,
            f"format version {version} is newer than this ppaloc {ppaloc.__version__} reads "
            f"(up to {FORMAT_VERSION}); upgrade ppaloc",
        )
    return header


def _field_error(header: dict[str, Any]) -> str | None:
    """The first header field of the wrong type, as a message, or None."""
    kinds = {
        "kind": str,
        "n_nodes": int,
        "arrays": dict,
        "sha256": str,
        "params": dict,
        "provenance": dict,
    }
    for key, kind in kinds.items():
        if key in ("params", "provenance") and key not in header:
            continue
        value = header.get(key)
        if not isinstance(value, kind) or isinstance(value, bool):
            return f"header.{key} is {value!r:.40}, expected a {kind.__name__}"
    if header["n_nodes"] < 0:
        return f"header.n_nodes is {header['n_nodes']}, expected a count >= 0"
    return None


def _array_error(header: dict[str, Any], arrays: dict[str, np.ndarray]) -> str | None:
    """The first array that contradicts the header or is out of range, or None."""
    n = header["n_nodes"]
    for name, a in arrays.items():
        if len(a) != n if a.ndim else True:
            return f"{name} has {len(a) if a.ndim else 0} entries, header.n_nodes is {n}"
        if a.dtype.kind not in "biuf":
            return f"{name} holds {a.dtype}, not numbers"
    fi = arrays["frame_index"]
    if fi.dtype.kind not in "iu":
        return f"frame_index holds {fi.dtype}, expected integers"
    problem = value_problem(header["kind"], arrays["descriptors"], fi, arrays.get("positions"))
    if problem:
        return problem
    n_frames = header.get("params", {}).get("n_frames")
    if isinstance(n_frames, int) and not isinstance(n_frames, bool) and len(fi):
        if int(fi.max()) >= n_frames:
            i = int(np.argmax(fi))
            return (
                f"frame_index[{i}] is {int(fi[i])}, beyond params.n_frames = {n_frames} "
                "reference frames"
            )
    return None


def load_map(path: str | Path) -> TopoMap:
    """Read a map written by :func:`save_map`, verifying format, version, fields and checksum.

    Raises
    ------
    MapFormatError
        The file is missing, not an ``.npz``, not a ppaloc map, from a newer format
        version, truncated, larger than the limits, out of range in a field, or its
        contents do not match the checksum; the message names the file and the field.
    """
    path = Path(path)
    found = _read(path)
    header = _header(path, found)
    problem = _field_error(header)
    if problem:
        raise _fail(path, problem)
    specs = header["arrays"]
    names = sorted(specs)
    if not {"descriptors", "frame_index"} <= set(names) or not set(names) <= set(_ARRAYS):
        raise _fail(path, f"header.arrays names {names!r:.80}, expected descriptors, frame_index")
    missing = [n for n in names if n not in found]
    if missing:
        raise _fail(path, f"no {missing[0]!r} array, which header.arrays lists (truncated)")
    arrays = {name: found[name] for name in names}
    for name, a in arrays.items():
        if _describe(a) != specs[name]:
            raise _fail(path, f"array {name!r} is {_describe(a)}, header says {specs[name]!r:.80}")
    problem = _array_error(header, arrays)
    if problem:
        raise _fail(path, problem)
    if _checksum(header, arrays) != header["sha256"]:
        raise _fail(path, "checksum mismatch: the file was altered or damaged")
    try:
        return TopoMap(
            kind=header["kind"],
            descriptors=arrays["descriptors"],
            frame_index=arrays["frame_index"],
            positions=arrays.get("positions"),
            places=arrays.get("places"),
            params=header.get("params", {}),
            provenance=header.get("provenance", {}),
        )
    except (KeyError, ValueError) as exc:
        raise _fail(path, f"inconsistent contents ({exc})") from None
