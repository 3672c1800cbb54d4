"""Ground truth: which reference frames each query frame may match.

Two forms reach :class:`~ppaloc.datasets.base.RouteDataset`, both ending as one sorted
``int64`` array of accepted reference indices per query (empty: no true match):

- *positions*: each query has a true position ``p`` on the reference, in reference-frame
  units (``p = i`` for frame-synchronised traversals, fractional for the generator's
  variable-speed query, non-finite for "nowhere on the map"). With tolerance ``t`` the
  accepted frames are ``k`` with ``|k - p| <= t + 0.5``: for an integer ``p`` that is
  ``p-t .. p+t``.
- *sets*: explicit accepted indices from a file (VPR-Bench rows, a FAB-MAP ``truth``
  matrix), dilated by ``t`` frames on either side.

This module also reads the two ground-truth file formats, never running untrusted code.
"""

from __future__ import annotations

import io
import pickle
from collections.abc import Iterable, Sequence
from pathlib import Path

import numpy as np

from ppaloc.errors import DataError

__all__ = [
    "dilate",
    "from_positions",
    "read_truth_mat",
    "read_vprbench",
    "validate_sets",
]


def from_positions(positions: np.ndarray, n_ref: int, tolerance: int) -> list[np.ndarray]:
    """Accepted reference indices for queries at fractional reference positions.

    Parameters
    ----------
    positions : ndarray of float, shape (M,)
        True position of each query in reference-frame units; non-finite = no match.
    n_ref : int
        Number of reference frames (indices outside ``[0, n_ref)`` are never accepted).
    tolerance : int
        Accepted distance in frames.

    Returns
    -------
    list of ndarray of int64
        One sorted array per query.

    Examples
    --------
    >>> [a.tolist() for a in from_positions(np.array([0.0, 2.5, 9.0, np.nan]), 4, 1)]
    [[0, 1], [1, 2, 3], [], []]
    """
    p = np.asarray(positions, dtype=np.float64)
    reach = tolerance + 0.5
    out = []
    for q in p:
        if not np.isfinite(q):
            out.append(np.empty(0, np.int64))
            continue
        lo = max(int(np.ceil(q - reach - 1e-9)), 0)
        hi = min(int(np.floor(q + reach + 1e-9)), n_ref - 1)
        out.append(np.arange(lo, hi + 1, dtype=np.int64) if hi >= lo else np.empty(0, np.int64))
    return out


def dilate(sets: Iterable[np.ndarray], n_ref: int, tolerance: int) -> list[np.ndarray]:
    """Widen each accepted set by ``tolerance`` frames on both sides (clipped to the map).

    Examples
    --------
    >>> [a.tolist() for a in dilate([np.array([0, 5]), np.array([], int)], 7, 1)]
    [[0, 1, 4, 5, 6], []]
    """
    out = []
    for s in sets:
        s = np.asarray(s, dtype=np.int64)
        if tolerance and s.size:
            s = (s[:, None] + np.arange(-tolerance, tolerance + 1)[None, :]).ravel()
            s = s[(s >= 0) & (s < n_ref)]
        out.append(np.unique(s))
    return out


def validate_sets(
    sets: Sequence[np.ndarray], n_ref: int, source: str, overhang: int = 0
) -> list[np.ndarray]:
    """Return ``sets`` as sorted ``int64`` arrays; raise if any index is outside the map.

    Parameters
    ----------
    sets : sequence of array_like of int
        Accepted reference indices per query.
    n_ref : int
        Number of reference frames.
    source : str
        Where the sets came from (for the message).
    overhang : int
        Indices up to this far outside ``[0, n_ref)`` are dropped instead of refused: a
        +-k window written without clipping at the ends of the route (VPR-Bench's Gardens
        Point file accepts references 200 and 201 of 0..199).

    Raises
    ------
    DataError
        Naming ``source``, the query and the bad index.
    """
    out = []
    for q, s in enumerate(sets):
        a = np.unique(np.asarray(s, dtype=np.int64).ravel())
        bad = a[(a < -overhang) | (a >= n_ref + overhang)]
        if bad.size:
            raise DataError(
                f"{source}: query {q} accepts reference index {int(bad[0])}, outside the "
                f"{n_ref} reference frames; the ground truth does not belong to these folders"
            )
        out.append(a[(a >= 0) & (a < n_ref)])
    return out


# --- VPR-Bench ------------------------------------------------------------------------------

_SAFE_GLOBALS = {
    ("numpy", "ndarray"),
    ("numpy", "dtype"),
    ("numpy.core.multiarray", "_reconstruct"),
    ("numpy._core.multiarray", "_reconstruct"),
    ("numpy.core.multiarray", "scalar"),
    ("numpy._core.multiarray", "scalar"),
}


class _ArrayOnlyUnpickler(pickle.Unpickler):
    """Unpickler that can only rebuild numpy arrays, numpy scalars, lists and numbers.

    ``find_class`` is the only way a pickle reaches code; it refuses every global except
    the numpy array constructors above, so a crafted file cannot run anything else (the
    "restricting globals" pattern of the :mod:`pickle` documentation).
    """

    def find_class(self, module: str, name: str):
        if (module, name) in _SAFE_GLOBALS:
            return super().find_class(module, name)
        raise pickle.UnpicklingError(f"global {module}.{name} is not allowed")


def _load_npy_safely(path: Path) -> np.ndarray:
    raw = path.read_bytes()
    with io.BytesIO(raw) as f:
        version = np.lib.format.read_magic(f)
        if version == (1, 0):
            shape, _fortran, dtype = np.lib.format.read_array_header_1_0(f)
        else:
            shape, _fortran, dtype = np.lib.format.read_array_header_2_0(f)
        if not dtype.hasobject:
            f.seek(0)
            return np.load(f, allow_pickle=False)
        arr = _ArrayOnlyUnpickler(f).load()
    arr = np.asarray(arr, dtype=object)
    if arr.shape != tuple(shape):
        raise ValueError(f"array shape {arr.shape} differs from the header's {shape}")
    return arr


def _row_to_ints(value: object) -> np.ndarray:
    a = np.asarray(value if not isinstance(value, np.ndarray) else value.tolist())
    if a.dtype == object:
        a = np.asarray([int(x) for x in np.ravel(a)])
    a = np.atleast_1d(a)
    if a.size and not np.issubdtype(a.dtype, np.integer):
        if np.issubdtype(a.dtype, np.floating) and np.all(np.isfinite(a)) and np.all(a == a // 1):
            a = a.astype(np.int64)
        else:
            raise ValueError(f"indices must be integers, got {a.dtype}")
    return a.astype(np.int64).ravel()


def read_vprbench(path: Path, n_query: int, n_ref: int, trust: bool = False) -> list[np.ndarray]:
    """Read a VPR-Bench ``ground_truth_new.npy``: rows ``[query_index, [reference indices]]``.

    The file is a pickled object array. By default it is decoded by an unpickler that can
    rebuild only numpy arrays, lists and numbers; anything else (which a tampered file
    would need in order to run code) is refused. ``trust=True`` uses ``numpy.load(...,
    allow_pickle=True)`` instead, which runs whatever the file says: only for files you
    made or trust. A plain integer array of shape (M, 2) (one reference per query) is
    read without pickle at all.

    Parameters
    ----------
    path : Path
        The ``.npy`` file.
    n_query, n_ref : int
        Traversal lengths; every query must appear once, every index must be in range.
    trust : bool
        Allow full unpickling.

    Returns
    -------
    list of ndarray of int64
        Accepted reference indices for each query ``0 .. n_query-1``.

    Raises
    ------
    DataError
        Naming the file and the fix.
    """
    path = Path(path)
    if not path.is_file():
        raise DataError(f"ground-truth file {path} does not exist")
    try:
        if trust:
            arr = np.load(path, allow_pickle=True)
        else:
            arr = _load_npy_safely(path)
    except (pickle.UnpicklingError, ValueError, EOFError, OSError, TypeError, KeyError) as exc:
        hint = (
            ""
            if trust
            else "; it holds more than numbers and lists, so it was not unpickled. If you "
            "trust the file, add trust=1 to the spec (this runs code stored in the file)"
        )
        raise DataError(f"cannot read VPR-Bench ground truth {path}: {exc}{hint}") from None
    except Exception as exc:  # a malformed pickle can raise almost anything
        raise DataError(f"cannot read VPR-Bench ground truth {path}: {exc!r}") from None
    return _vprbench_rows(arr, path, n_query, n_ref)


def _vprbench_rows(arr: object, path: Path, n_query: int, n_ref: int) -> list[np.ndarray]:
    rows = np.asarray(arr, dtype=object)
    if rows.ndim != 2 or rows.shape[1] != 2:
        raise DataError(
            f"VPR-Bench ground truth {path} has shape {rows.shape}; expected (queries, 2) rows "
            "of [query_index, [reference indices]]"
        )
    sets: list[np.ndarray | None] = [None] * n_query
    for r, (qi, refs) in enumerate(rows):
        try:
            q = int(_row_to_ints(qi)[0])
            accepted = _row_to_ints(refs)
        except (ValueError, TypeError, IndexError) as exc:
            raise DataError(f"VPR-Bench ground truth {path}, row {r}: {exc}") from None
        if not 0 <= q < n_query:
            raise DataError(
                f"VPR-Bench ground truth {path}, row {r}: query index {q} is outside the "
                f"{n_query} query images"
            )
        if sets[q] is not None:
            raise DataError(f"VPR-Bench ground truth {path}: query {q} appears twice")
        sets[q] = accepted
    missing = [q for q, s in enumerate(sets) if s is None]
    if missing:
        raise DataError(
            f"VPR-Bench ground truth {path} has no row for {len(missing)} of {n_query} query "
            f"images (first: {missing[0]}); it does not match the query folder"
        )
    rows = [s for s in sets if s is not None]
    overhang = max((np.unique(s).size - 1) // 2 for s in rows) if rows else 0
    return validate_sets(rows, n_ref, f"ground truth {path}", overhang)


# --- FAB-MAP truth matrix -------------------------------------------------------------------


def read_truth_mat(path: Path, variable: str = "truth") -> np.ndarray:
    """Read the square boolean ``truth`` matrix of a FAB-MAP ground-truth ``.mat`` file.

    Entry ``(i, j)`` is true where images (or image pairs) ``i`` and ``j`` show the same
    place. MATLAB v4-v7.2 files are read with :func:`scipy.io.loadmat` (no code runs).

    Raises
    ------
    DataError
        If the file is missing, unreadable, lacks the variable or is not square.
    """
    from scipy.io import loadmat

    path = Path(path)
    if not path.is_file():
        raise DataError(f"ground-truth file {path} does not exist")
    try:
        content = loadmat(str(path))
    except NotImplementedError:
        raise DataError(
            f"cannot read {path}: MATLAB v7.3 (HDF5) files are not supported; re-save it "
            "in MATLAB with save(..., '-v7')"
        ) from None
    except Exception as exc:  # scipy raises many types on a corrupt file
        raise DataError(f"cannot read ground-truth matrix {path}: {exc}") from None
    if variable not in content:
        names = [k for k in content if not k.startswith("__")]
        raise DataError(
            f"{path} has no variable {variable!r} (it has: {', '.join(names) or 'none'}); "
            "give the FAB-MAP ground-truth file"
        )
    m = np.asarray(content[variable])
    if m.ndim != 2 or m.shape[0] != m.shape[1]:
        raise DataError(f"{path}: {variable!r} has shape {m.shape}; expected a square matrix")
    return m != 0
