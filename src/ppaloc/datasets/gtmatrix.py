"""Ground-truth matrices: ``M x N`` tables of 0/1 saying which reference frames each query
may match, hard (what must be found) and soft (also not wrong), as VPR_Tutorial (Schubert
et al.) uses ``GThard`` and ``GTsoft``.

Row ``j`` is query frame ``j``, column ``i`` reference frame ``i`` (``transpose=True``
reads a references x queries file, VPR_Tutorial's own layout). Three file formats, none
of which can run code:

- ``.npy``: a 2-D array of ``bool``, integers or floats holding only 0 and 1, read without
  unpickling (an object array is refused) and by blocks of rows from a memory map;
- ``.npz``: the arrays ``GThard`` and, where present, ``GTsoft`` (VPR_Tutorial's
  ``GT.npz``), or its only array;
- ``.csv``: one line per row, values separated by commas, each 0 or 1 (``1``, ``1.0``
  and numpy's ``1.000000000000000000e+00`` alike), no header.

Every value and the shape are checked before the sets are built; a matrix may have at
most :data:`MAX_MATRIX_CELLS` cells and :data:`MAX_GROUND_TRUTH_ITEMS` ones.
"""

from __future__ import annotations

import hashlib
import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ppaloc.datasets.groundtruth import MAX_GROUND_TRUTH_BYTES, MAX_GROUND_TRUTH_ITEMS, PackedSets
from ppaloc.datasets.images import missing
from ppaloc.errors import DataError

__all__ = ["MAX_MATRIX_CELLS", "MatrixFile", "read_matrix"]

MAX_MATRIX_CELLS = 1 << 28
"""Most cells a ground-truth matrix may have (268 million: 16,384 x 16,384; a larger
route gives its ground truth as positions)."""

_SUFFIXES = (".npy", ".npz", ".csv")
_ROWS_PER_BLOCK = 1 << 12


@dataclass(frozen=True)
class MatrixFile:
    """A ground-truth matrix as read.

    Attributes
    ----------
    path : Path
    sets : PackedSets
        The accepted reference indices of each query (rows of ones).
    soft : PackedSets or None
        From an ``.npz``'s ``GTsoft``, where it has one.
    shape : (int, int)
        As stored in the file.
    sha256 : str
        Of the file's bytes.
    """

    path: Path
    sets: PackedSets = field(repr=False)
    soft: PackedSets | None = field(repr=False)
    shape: tuple[int, int]
    sha256: str


def read_matrix(
    path: str | Path, n_query: int, n_ref: int, what: str, *, transpose: bool = False
) -> MatrixFile:
    """Read a ground-truth matrix of ``n_query x n_ref`` 0/1 values.

    Parameters
    ----------
    path : str or Path
        A ``.npy``, ``.npz`` or ``.csv`` file.
    n_query, n_ref : int
        Traversal lengths: the expected shape (``(n_ref, n_query)`` with ``transpose``).
    what : str
        The spec key that named it (``gt``, ``gt_soft``), for messages.
    transpose : bool
        The file is references x queries.

    Returns
    -------
    MatrixFile

    Raises
    ------
    DataError
        Naming the file, the bad value's place and the fix.

    Examples
    --------
    >>> import tempfile
    >>> path = Path(tempfile.mkdtemp()) / "gt.csv"
    >>> _ = path.write_text("1,1,0\\n0,0,0\\n")
    >>> [r.tolist() for r in read_matrix(path, 2, 3, "gt").sets]
    [[0, 1], []]
    """
    path = Path(path).expanduser()
    where = f"{what}={path}"
    if path.is_dir():
        raise DataError(f"{where} is a folder; give the ground-truth matrix file")
    if not path.is_file():
        raise DataError(f"{where} {missing(path)}: check the path in the dataset spec")
    suffix = path.suffix.lower()
    if suffix not in _SUFFIXES:
        raise DataError(f"{where} must be a .npy, .npz or .csv file of 0s and 1s")
    try:
        size = path.stat().st_size
    except OSError as exc:
        raise DataError(f"cannot read {where}: {exc.strerror or exc}") from None
    if size > MAX_GROUND_TRUTH_BYTES:
        raise DataError(
            f"{where} is {size} bytes, more than {MAX_GROUND_TRUTH_BYTES}; save it as a "
            "bool .npy, or give the ground truth as positions"
        )
    want = (n_ref, n_query) if transpose else (n_query, n_ref)
    soft = None
    if suffix == ".npy":
        array = _open_npy(path, where)
        sets = _from_array(array, want, where, transpose)
        shape = array.shape
    elif suffix == ".npz":
        arrays = _read_npz(path, where)
        hard = arrays.get("GThard", arrays.get(next(iter(arrays))) if len(arrays) == 1 else None)
        if hard is None:
            names = ", ".join(sorted(arrays)[:6])
            raise DataError(
                f"{where} holds {names}, not GThard; save the hard matrix as GThard (and the "
                "soft one as GTsoft)"
            )
        sets = _from_array(hard, want, f"{where} (GThard)", transpose)
        if "GTsoft" in arrays:
            soft = _from_array(arrays["GTsoft"], want, f"{where} (GTsoft)", transpose)
        shape = hard.shape
    else:
        sets, shape = _read_csv(path, want, where, transpose)
    digest = hashlib.sha256()
    with open(path, "rb") as f:
        while chunk := f.read(1 << 20):
            digest.update(chunk)
    return MatrixFile(path, sets, soft, (int(shape[0]), int(shape[1])), digest.hexdigest())


def _shape_error(
    where: str,
    shape: tuple[int, ...],
    want: tuple[int, int],
    transpose: bool,
    found: str | None = None,
) -> DataError:
    rows, cols = ("references", "queries") if transpose else ("queries", "references")
    row = "reference" if transpose else "query"
    hint = ""
    if len(shape) == 2 and tuple(shape) == want[::-1] and want[0] != want[1]:
        hint = (
            "; it looks transposed: add gt_transpose=1 for a references x queries file "
            "(VPR_Tutorial's layout)"
            if not transpose
            else "; it looks transposed: drop gt_transpose"
        )
    found = found or f"shape {tuple(shape)}"
    return DataError(
        f"{where} has {found}; expected {want[0]} x {want[1]} ({rows} x {cols}, "
        f"one row per {row}){hint}"
    )


def _open_npy(path: Path, where: str) -> np.ndarray:
    """A memory map of a plain ``.npy`` whose header was checked first (no unpickling)."""
    try:
        with open(path, "rb") as f:
            version = np.lib.format.read_magic(f)
            if version == (1, 0):
                shape, fortran, dtype = np.lib.format.read_array_header_1_0(f)
            else:
                shape, fortran, dtype = np.lib.format.read_array_header_2_0(f)
            offset = f.tell()
    except Exception:  # numpy quotes the header bytes: keep them out of the message
        raise DataError(
            f"{where} is not a .npy file (or its header is corrupt); save the matrix with "
            "numpy.save"
        ) from None
    if dtype.hasobject:
        raise DataError(
            f"{where} holds Python objects (a pickle), which are never loaded; save a bool "
            "or 0/1 numeric array"
        )
    _check_dtype(dtype, where)
    count = math.prod(shape)
    if count > MAX_MATRIX_CELLS:
        raise DataError(f"{where} claims {count} cells, more than {MAX_MATRIX_CELLS}")
    need = offset + count * dtype.itemsize
    if path.stat().st_size < need:
        raise DataError(f"{where} is truncated ({path.stat().st_size} of {need} bytes)")
    if count == 0:
        return np.zeros(shape, dtype=dtype)
    return np.memmap(
        path, dtype=dtype, mode="r", offset=offset, shape=tuple(shape),
        order="F" if fortran else "C",
    )  # fmt: skip


def _read_npz(path: Path, where: str) -> dict[str, np.ndarray]:
    from ppaloc.npzfile import NpzError, read_npz

    try:
        arrays = read_npz(path, max_bytes=MAX_GROUND_TRUTH_BYTES)
    except NpzError as exc:
        raise DataError(f"cannot read {where}: {exc}") from None
    except OSError as exc:
        raise DataError(f"cannot read {where}: {exc.strerror or exc}") from None
    if not arrays:
        raise DataError(f"{where} holds no arrays; save GThard (and GTsoft) in it")
    for name, a in arrays.items():
        _check_dtype(a.dtype, f"{where} ({name})")
        if a.size > MAX_MATRIX_CELLS:
            raise DataError(f"{where} ({name}) has {a.size} cells, more than {MAX_MATRIX_CELLS}")
    return arrays


def _check_dtype(dtype: np.dtype, where: str) -> None:
    if dtype.kind not in "biuf":
        raise DataError(
            f"{where} holds {dtype} values; a ground-truth matrix is bool or numbers 0 and 1"
        )


def _from_array(
    array: np.ndarray, want: tuple[int, int], where: str, transpose: bool
) -> PackedSets:
    """The accepted sets of a checked 0/1 array, read a block of rows at a time."""
    if array.ndim != 2 or tuple(array.shape) != want:
        raise _shape_error(where, array.shape, want, transpose)
    rows: list[np.ndarray] = []
    cols: list[np.ndarray] = []
    total = 0
    for a in range(0, array.shape[0], _ROWS_PER_BLOCK):
        block = np.asarray(array[a : a + _ROWS_PER_BLOCK])
        if block.dtype.kind != "b":
            bad = ~((block == 0) | (block == 1))
            if bad.any():
                r, c = (int(v) for v in np.argwhere(bad)[0])
                raise DataError(
                    f"{where}: row {a + r}, column {c} is {block[r, c].item()!r}; a ground-truth "
                    "matrix holds only 0 and 1"
                )
        r, c = np.nonzero(block)
        total += r.size
        if total > MAX_GROUND_TRUTH_ITEMS:
            raise DataError(
                f"{where} holds more than {MAX_GROUND_TRUTH_ITEMS} ones; the accepted sets "
                "would not fit in memory"
            )
        rows.append(r.astype(np.int64) + a)
        cols.append(c.astype(np.int64))
    return _pack(rows, cols, want, transpose)


def _pack(
    rows: list[np.ndarray], cols: list[np.ndarray], want: tuple[int, int], transpose: bool
) -> PackedSets:
    r = np.concatenate(rows) if rows else np.zeros(0, np.int64)
    c = np.concatenate(cols) if cols else np.zeros(0, np.int64)
    n_query = want[1] if transpose else want[0]
    query, ref = (c, r) if transpose else (r, c)
    order = np.lexsort((ref, query))
    indptr = np.zeros(n_query + 1, dtype=np.int64)
    np.cumsum(np.bincount(query, minlength=n_query), out=indptr[1:])
    return PackedSets(ref[order], indptr)


def _read_csv(
    path: Path, want: tuple[int, int], where: str, transpose: bool
) -> tuple[PackedSets, tuple[int, int]]:
    rows: list[np.ndarray] = []
    cols: list[np.ndarray] = []
    total = 0
    n_rows = 0
    try:
        with open(path, encoding="utf-8-sig", newline="") as f:
            for line_no, line in enumerate(f, 1):
                text = line.strip()
                if not text:
                    continue
                fields = text.split(",")
                if n_rows >= want[0] or len(fields) != want[1]:
                    raise _csv_shape_error(path, where, want, transpose)
                ones = _csv_row(fields, where, line_no)
                total += ones.size
                if total > MAX_GROUND_TRUTH_ITEMS:
                    raise DataError(
                        f"{where} holds more than {MAX_GROUND_TRUTH_ITEMS} ones; the accepted "
                        "sets would not fit in memory"
                    )
                rows.append(np.full(ones.size, n_rows, np.int64))
                cols.append(ones)
                n_rows += 1
    except UnicodeDecodeError:
        raise DataError(f"{where} is not a UTF-8 text CSV; save the matrix as text") from None
    except OSError as exc:
        raise DataError(f"cannot read {where}: {exc.strerror or exc}") from None
    if n_rows == 0 < want[0]:  # no line held a value: no shape to report
        raise _shape_error(where, (), want, transpose, found="no values (an empty file)")
    if n_rows != want[0]:
        raise _shape_error(where, (n_rows, want[1]), want, transpose)
    return _pack(rows, cols, want, transpose), want


def _csv_shape_error(path: Path, where: str, want: tuple[int, int], transpose: bool) -> DataError:
    """The error for a CSV that is not ``want``: its whole shape (so that a transposed file
    is named as one), or the first line whose number of values differs from the first's."""
    n_rows, n_cols, first = 0, 0, 0
    with open(path, encoding="utf-8-sig", newline="") as f:
        for line_no, line in enumerate(f, 1):
            text = line.strip()
            if not text:
                continue
            count = len(text.split(","))
            if n_rows == 0:
                n_cols, first = count, line_no
            elif count != n_cols:
                return DataError(
                    f"{where}, line {line_no} has {count} values where line {first} has "
                    f"{n_cols}; every line is one row of the matrix, {want[1]} values "
                    "separated by commas"
                )
            n_rows += 1
    return _shape_error(where, (n_rows, n_cols), want, transpose)


def _csv_row(fields: list[str], where: str, line_no: int) -> np.ndarray:
    """Column numbers of the ones of one CSV line; every field must be 0 or 1."""
    try:
        values = np.array([float(v) if v.strip() else np.nan for v in fields])
    except ValueError:
        values = None
    if values is None or not np.all((values == 0) | (values == 1)):
        for c, v in enumerate(fields):
            try:
                ok = float(v) in (0.0, 1.0) if v.strip() else False
            except ValueError:
                ok = False
            if not ok:
                shown = v.strip()[:20]
                raise DataError(
                    f"{where}, line {line_no}, column {c}: {shown!r} is not 0 or 1; a "
                    "ground-truth matrix holds only 0 and 1, separated by commas (no header)"
                )
    return np.flatnonzero(values == 1).astype(np.int64)
