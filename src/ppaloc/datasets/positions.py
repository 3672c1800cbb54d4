"""Positions files: where each frame was taken, and the ground truth in metres they give.

A positions file is a CSV with a header and one row per frame, in frame order. Its
coordinates are one recognised pair of columns (names compared case-insensitively, spaces
trimmed; other columns are ignored):

- ``x``, ``y``: metres in any local Cartesian frame;
- ``easting``, ``northing``: UTM metres, all rows in one zone (a ``zone`` or ``utm_zone``
  column, where present, must hold one value in both files);
- ``lat`` or ``latitude``, ``lon``, ``lng``, ``long`` or ``longitude``: WGS84 degrees.

A ``file``, ``filename``, ``image`` or ``name`` column, where present, must name each
frame's image file (so a file written for another folder, or sorted differently, is
caught). The reference's and the query's files must use the same pair. Latitude and
longitude become metres on the WGS84 ellipsoid: earth-centred coordinates rotated to
east, north, up at the reference's first frame, so every distance is the straight-line
distance between the two points (within a millimetre of the distance along the ground up
to a few kilometres).

With ``tolerance_m=T``, query ``j`` accepts every reference frame within ``T`` metres of
its position (:func:`from_metres`); a query with none has no true match.
"""

from __future__ import annotations

import csv
import hashlib
import io
import math
import re
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ppaloc.datasets.groundtruth import MAX_GROUND_TRUTH_BYTES, MAX_GROUND_TRUTH_ITEMS, PackedSets
from ppaloc.datasets.images import missing
from ppaloc.errors import DataError

__all__ = [
    "COORDINATES",
    "MAX_POSITIONS_BYTES",
    "MAX_POSITION_M",
    "PositionsFile",
    "from_metres",
    "read_positions",
    "to_metres",
]

MAX_POSITIONS_BYTES = MAX_GROUND_TRUTH_BYTES
"""Largest positions file read (256 MiB: about 8 million rows of ``x,y``)."""

MAX_POSITION_M = 1e9
"""Largest magnitude of an ``x``, ``y``, easting or northing, in metres (a million
kilometres, beyond any route on the ground): the distances between positions are then
exact to a micrometre, where coordinates near 1e154 overflowed the squared distances."""

COORDINATES: dict[str, tuple[tuple[str, ...], tuple[str, ...]]] = {
    "xy": (("x",), ("y",)),
    "utm": (("easting",), ("northing",)),
    "latlon": (("lat", "latitude"), ("lon", "lng", "long", "longitude")),
}
"""Coordinate kind -> (names of its first column, names of its second)."""

_NAME_COLUMNS = ("file", "filename", "image", "name")
_ZONE_COLUMNS = ("zone", "utm_zone")
_NUMBER = re.compile(r"[+-]?([0-9]+\.?[0-9]*|\.[0-9]+)([eE][+-]?[0-9]+)?")
_UNITS = {"xy": "x/y metres", "utm": "UTM easting/northing", "latlon": "lat/lon degrees"}

# WGS84
_A = 6378137.0
_F = 1 / 298.257223563
_E2 = _F * (2 - _F)


@dataclass(frozen=True)
class PositionsFile:
    """One positions file as read.

    Attributes
    ----------
    path : Path
    kind : {"xy", "utm", "latlon"}
        Which pair of columns it holds.
    values : ndarray of float, shape (N, 2)
        The pair as written (x, y; easting, northing; or lat, lon in degrees).
    columns : (str, str)
        The two column names as written in the header.
    zone : str or None
        The UTM zone column's one value, where there is one.
    sha256 : str
        Of the file's bytes.
    """

    path: Path
    kind: str
    values: np.ndarray = field(repr=False)
    columns: tuple[str, str]
    zone: str | None
    sha256: str

    @property
    def units(self) -> str:
        """The coordinates in words, e.g. ``"lat/lon degrees"``."""
        return _UNITS[self.kind]


def read_positions(
    path: str | Path, n_frames: int, what: str, names: Sequence[str] | None = None
) -> PositionsFile:
    """Read and check a positions CSV of ``n_frames`` rows.

    Parameters
    ----------
    path : str or Path
        The CSV file.
    n_frames : int
        Frames of the traversal it belongs to: one row each.
    what : str
        The spec key that named it (``ref_positions``, ``query_positions``), for messages.
    names : sequence of str, optional
        The frames' file names, checked against a file-name column where there is one.

    Returns
    -------
    PositionsFile

    Raises
    ------
    DataError
        Naming the file, the row or column and the fix: missing or unreadable file, no
        header, no recognised pair or two of them, a row of the wrong length, a value that
        is not a finite number, a latitude or longitude out of range, several UTM zones,
        a file name that is not the frame's, a row count other than ``n_frames``.
    """
    path = Path(path).expanduser()
    raw = _read_bytes(path, what)
    where = f"{what}={path}"
    try:
        text = raw.decode("utf-8-sig")
    except UnicodeDecodeError as exc:
        raise DataError(
            f"{where} is not UTF-8 text (byte {exc.start}); save it as a UTF-8 CSV"
        ) from None
    if "\0" in text:
        raise DataError(f"{where} holds NUL bytes: it is not a CSV text file")
    reader = csv.reader(io.StringIO(text, newline=""))
    try:
        header = next(reader, None)
        if header is None or not any(h.strip() for h in header):
            raise DataError(
                f"{where} is empty or has no header; its first line names the columns, "
                "e.g. x,y or lat,lon"
            )
        keys = [h.strip().lower() for h in header]
        kind, cols = _pair(keys, header, where)
        name_col = next((k for k, h in enumerate(keys) if h in _NAME_COLUMNS), None)
        zone_col = next((k for k, h in enumerate(keys) if h in _ZONE_COLUMNS), None)
        values = np.empty((min(n_frames, 1 << 20), 2), dtype=np.float64)
        zones: set[str] = set()
        n = 0
        for row in reader:
            if not row or (len(row) == 1 and not row[0].strip()):
                continue  # a blank line
            line = reader.line_num
            if len(row) != len(header):
                raise DataError(
                    f"{where}, line {line}: {len(row)} fields where the header has "
                    f"{len(header)}; every row needs one value per column"
                )
            if n >= n_frames:
                raise DataError(
                    f"{where} has more than {n_frames} rows for the {n_frames} frames of its "
                    "traversal; give one row per frame, in frame order"
                )
            if n == len(values):
                values = np.resize(values, (min(2 * n, n_frames), 2))
            for k, c in enumerate(cols):
                values[n, k] = _number(row[c], where, line, header[c])
            if kind == "latlon":
                _check_degrees(values[n], where, line, (header[cols[0]], header[cols[1]]))
            else:
                _check_metres(values[n], where, line, (header[cols[0]], header[cols[1]]))
            if names is not None and name_col is not None:
                given = row[name_col].strip()
                if Path(given).name != names[n]:
                    raise DataError(
                        f"{where}, line {line}: {header[name_col].strip()} is {given!r:.60} "
                        f"but frame {n} is {names[n]!r}; sort the rows in frame order (or "
                        "give the file written for this folder)"
                    )
            if zone_col is not None:
                zones.add(row[zone_col].strip().upper())
            n += 1
    except csv.Error as exc:
        raise DataError(f"{where} is not a readable CSV ({exc}); save it as plain CSV") from None
    if n != n_frames:
        raise DataError(
            f"{where} has {n} rows for the {n_frames} frames of its traversal; give one row "
            "per frame, in frame order"
        )
    values = values[:n]
    zone = None
    if zones:
        if len(zones) > 1:
            shown = ", ".join(sorted(zones)[:4])
            raise DataError(
                f"{where} spans UTM zones {shown}; UTM metres of two zones do not mix: "
                "give lat/lon instead"
            )
        zone = zones.pop()
    return PositionsFile(
        path=path,
        kind=kind,
        values=values,
        columns=(header[cols[0]].strip(), header[cols[1]].strip()),
        zone=zone,
        sha256=hashlib.sha256(raw).hexdigest(),
    )


def _read_bytes(path: Path, what: str) -> bytes:
    if path.is_dir():
        raise DataError(f"{what}={path} is a folder; give the positions .csv file")
    if not path.is_file():
        raise DataError(f"{what}={path} {missing(path)}: check the path in the dataset spec")
    if path.suffix.lower() != ".csv":
        raise DataError(f"{what}={path} must be a .csv file (x,y / easting,northing / lat,lon)")
    try:
        size = path.stat().st_size
        if size > MAX_POSITIONS_BYTES:
            raise DataError(
                f"{what}={path} is {size} bytes, more than {MAX_POSITIONS_BYTES}; one row per "
                "frame with two coordinates fits far below that"
            )
        return path.read_bytes()
    except OSError as exc:
        raise DataError(f"cannot read {what}={path}: {exc.strerror or exc}") from None


def _pair(keys: list[str], header: list[str], where: str) -> tuple[str, tuple[int, int]]:
    """The one recognised coordinate pair of a header: its kind and column numbers."""
    found: dict[str, tuple[int, int]] = {}
    for kind, (first, second) in COORDINATES.items():
        a = [k for k, h in enumerate(keys) if h in first]
        b = [k for k, h in enumerate(keys) if h in second]
        if len(a) > 1 or len(b) > 1:
            twice = [header[k].strip() for k in (a if len(a) > 1 else b)]
            raise DataError(f"{where}: columns {', '.join(twice)} name one coordinate twice")
        if a and b:
            found[kind] = (a[0], b[0])
        elif a or b:
            one = header[(a or b)[0]].strip()
            other = "/".join(second if a else first)
            raise DataError(
                f"{where} has a {one!r} column but no {other} column to pair it with; give "
                "both columns of one pair (x,y / easting,northing / lat,lon)"
            )
    if not found:
        shown = ", ".join(repr(h.strip()) for h in header[:8])
        raise DataError(
            f"{where} has no coordinate columns (header: {shown}); name them x,y (metres), "
            "easting,northing (UTM) or lat,lon (degrees)"
        )
    if len(found) > 1:
        both = " and ".join(_UNITS[k] for k in found)
        raise DataError(f"{where} holds both {both}: mixed units; keep the columns of one pair")
    kind = next(iter(found))
    return kind, found[kind]


def _number(text: str, where: str, line: int, column: str) -> float:
    t = text.strip()
    if not t:
        raise DataError(
            f"{where}, line {line}, column {column.strip()!r} is empty; every frame needs a "
            "position (remove the frame, or fill the value)"
        )
    if len(t) > 40 or not _NUMBER.fullmatch(t):
        shown = t if len(t) <= 40 else t[:37] + "..."
        if t.lower().lstrip("+-") in ("nan", "inf", "infinity"):
            raise DataError(
                f"{where}, line {line}, column {column.strip()!r} is {shown}; every frame needs "
                "a finite position (remove the frame, or fill the value)"
            )
        raise DataError(
            f"{where}, line {line}, column {column.strip()!r}: {shown!r} is not a number; "
            "write plain decimals (e.g. 12.5)"
        )
    value = float(t)
    if not math.isfinite(value):
        raise DataError(
            f"{where}, line {line}, column {column.strip()!r} is {t}: too large to be a position"
        )
    return value


def _check_degrees(pair: np.ndarray, where: str, line: int, columns: tuple[str, str]) -> None:
    for k, (limit, name) in enumerate(((90.0, "latitude"), (180.0, "longitude"))):
        if abs(pair[k]) > limit:
            swapped = " (are latitude and longitude swapped?)" if k == 0 else ""
            raise DataError(
                f"{where}, line {line}: {columns[k].strip()} {pair[k]:g} is not a "
                f"{name} in -{limit:g}..{limit:g} degrees{swapped}"
            )


def _check_metres(pair: np.ndarray, where: str, line: int, columns: tuple[str, str]) -> None:
    for k in range(2):
        if abs(pair[k]) > MAX_POSITION_M:
            raise DataError(
                f"{where}, line {line}: {columns[k].strip()} {pair[k]:g} is not a position in "
                f"-{MAX_POSITION_M:g}..{MAX_POSITION_M:g} metres (a million kilometres); "
                "give positions in metres"
            )


def to_metres(reference: PositionsFile, query: PositionsFile) -> tuple[np.ndarray, np.ndarray]:
    """Both traversals' positions in one frame of metres.

    ``x,y`` and UTM are metres already (shape (N, 2)); lat/lon become east, north and up
    on the WGS84 ellipsoid at the reference's first frame (shape (N, 3)), so Euclidean
    distances are straight-line distances in metres.

    Raises
    ------
    DataError
        If the two files use different coordinates (mixed units) or UTM zones.

    Examples
    --------
    >>> from pathlib import Path
    >>> def at(lat, lon):
    ...     where = np.array([[lat, lon]])
    ...     return PositionsFile(Path("p.csv"), "latlon", where, ("lat", "lon"), None, "")
    >>> ref, qry = to_metres(at(0.0, 0.0), at(0.0, 0.001))
    >>> round(float(np.linalg.norm(qry[0] - ref[0])), 2)
    111.32
    """
    if reference.kind != query.kind:
        raise DataError(
            f"mixed units: {reference.path} holds {reference.units} but {query.path} holds "
            f"{query.units}; give both traversals' positions in the same coordinates"
        )
    if reference.zone is not None and query.zone is not None and reference.zone != query.zone:
        raise DataError(
            f"{reference.path} is in UTM zone {reference.zone} but {query.path} in zone "
            f"{query.zone}; UTM metres of two zones do not mix: give lat/lon instead"
        )
    if reference.kind != "latlon":
        return reference.values.copy(), query.values.copy()
    origin = _ecef(reference.values[:1])[0]
    lat0, lon0 = np.radians(reference.values[0])
    rotation = np.array(
        [
            [-math.sin(lon0), math.cos(lon0), 0.0],
            [-math.sin(lat0) * math.cos(lon0), -math.sin(lat0) * math.sin(lon0), math.cos(lat0)],
            [math.cos(lat0) * math.cos(lon0), math.cos(lat0) * math.sin(lon0), math.sin(lat0)],
        ]
    )
    return (
        (_ecef(reference.values) - origin) @ rotation.T,
        (_ecef(query.values) - origin) @ rotation.T,
    )


def _ecef(latlon: np.ndarray) -> np.ndarray:
    """Earth-centred, earth-fixed metres of WGS84 (lat, lon) degrees at height 0."""
    lat, lon = np.radians(latlon[:, 0]), np.radians(latlon[:, 1])
    n = _A / np.sqrt(1 - _E2 * np.sin(lat) ** 2)
    return np.stack(
        [n * np.cos(lat) * np.cos(lon), n * np.cos(lat) * np.sin(lon), n * (1 - _E2) * np.sin(lat)],
        axis=1,
    )


_BLOCK_PAIRS = 1 << 20
"""Accepted pairs built per block in :func:`from_metres` (a few MB of working lists)."""


def from_metres(
    reference: np.ndarray, query: np.ndarray, tolerance_m: float, key: str = "tolerance_m"
) -> PackedSets:
    """For each query, the reference frames within ``tolerance_m`` metres (inclusive).

    Parameters
    ----------
    reference, query : ndarray of float, shape (N, D) and (M, D)
        Positions in metres (:func:`to_metres`).
    tolerance_m : float
        Largest accepted distance in metres.
    key : str
        The spec key the tolerance came from, for the message.

    Returns
    -------
    PackedSets
        Sorted reference indices per query; empty where no reference is that close.

    Raises
    ------
    DataError
        When the tolerance accepts more than :data:`MAX_GROUND_TRUTH_ITEMS`
        (query, reference) pairs in all: the accepted sets would not fit in memory.

    Examples
    --------
    >>> ref = np.array([[0.0, 0.0], [10.0, 0.0], [20.0, 0.0]])
    >>> qry = np.array([[1.0, 0.0], [15.0, 0.0], [100.0, 0.0]])
    >>> [r.tolist() for r in from_metres(ref, qry, 5.0)]
    [[0], [1, 2], []]
    """
    from scipy.spatial import cKDTree

    ref = np.asarray(reference, dtype=np.float64)
    qry = np.asarray(query, dtype=np.float64)
    tree = cKDTree(ref)
    counts = np.asarray(
        tree.query_ball_point(qry, r=float(tolerance_m), return_length=True), dtype=np.int64
    ).reshape(len(qry))
    total = int(counts.sum())
    if total > MAX_GROUND_TRUTH_ITEMS:
        raise DataError(
            f"{key}={tolerance_m:g} accepts {total} (query, reference) pairs, more than "
            f"{MAX_GROUND_TRUTH_ITEMS}; lower the tolerance"
        )
    indptr = np.zeros(len(qry) + 1, dtype=np.int64)
    np.cumsum(counts, out=indptr[1:])
    indices = np.empty(total, dtype=np.int64)
    a = 0
    while a < len(qry):
        # as many queries as keep the block's Python lists near _BLOCK_PAIRS entries
        b = int(np.searchsorted(indptr, indptr[a] + _BLOCK_PAIRS, side="right")) - 1
        b = min(max(b, a + 1), len(qry))
        for k, found in enumerate(tree.query_ball_point(qry[a:b], r=float(tolerance_m))):
            row = np.sort(np.asarray(found, dtype=np.int64))
            indices[indptr[a + k] : indptr[a + k] + row.size] = row
        a = b
    return PackedSets(indices, indptr)
