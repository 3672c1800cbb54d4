"""Ground truth: which reference frames each query frame may match.

Two forms reach :class:`~ppaloc.datasets.base.RouteDataset`, both ending as one sorted
``int64`` array of accepted reference indices per query (empty: no true match), held
packed in a :class:`PackedSets` (one flat index array and one offsets array, CSR-style):
a route of M queries costs two arrays, not M array objects, and the metrics read the
packed arrays directly.

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

import hashlib
import io
import itertools
import math
import pickle
from collections.abc import Iterable, Iterator, Sequence
from pathlib import Path
from typing import overload

import numpy as np

from ppaloc.errors import DataError

__all__ = [
    "MAX_GROUND_TRUTH_BYTES",
    "MAX_GROUND_TRUTH_ITEMS",
    "MAX_TRUTH_SIDE",
    "PackedSets",
    "dilate",
    "file_digest",
    "from_positions",
    "read_truth_mat",
    "read_vprbench",
    "validate_sets",
]


class PackedSets(Sequence[np.ndarray]):
    """Accepted reference indices per query, packed: query ``i`` accepts
    ``indices[indptr[i]:indptr[i + 1]]``.

    Behaves as a read-only sequence of ``int64`` arrays (indexing, iteration, ``len``;
    a slice gives a ``PackedSets``); each row is a read-only view made on demand, so M
    queries hold two arrays instead of M array objects.

    The rows are the *hard* ground truth: what a method must find. ``soft``, where a
    dataset has one, is a second ``PackedSets`` of the same length whose rows hold each
    hard row and more: the reference frames a prediction may fall on without being wrong
    (VPR_Tutorial's ``GTsoft``; how the metrics count them is in
    :mod:`ppaloc.evaluate.metrics`). It travels with the rows through slicing and
    :meth:`from_sets`.

    Examples
    --------
    >>> g = PackedSets.from_sets([[0, 1], [], [4]])
    >>> len(g), g[0].tolist(), [r.tolist() for r in g[1:]], g.indptr.tolist()
    (3, [0, 1], [[], [4]], [0, 2, 2, 3])
    >>> s = g.with_soft([[2], [5], [3, 4, 5]])
    >>> [r.tolist() for r in s.soft], s.soft.soft is None
    ([[0, 1, 2], [5], [3, 4, 5]], True)
    """

    __slots__ = ("indices", "indptr", "soft")

    def __init__(
        self, indices: np.ndarray, indptr: np.ndarray, soft: PackedSets | None = None
    ) -> None:
        # Views (no copy) made read-only, so a row handed out cannot change the truth.
        indices = np.asarray(indices, dtype=np.int64).ravel().view()
        indptr = np.asarray(indptr, dtype=np.int64).ravel().view()
        if indptr.size == 0 or indptr[0] != 0 or indptr[-1] != indices.size:
            raise ValueError(
                f"indptr must run from 0 to {indices.size} (the number of indices), "
                f"got {indptr[:1].tolist()} .. {indptr[-1:].tolist()}"
            )
        if np.any(indptr[1:] < indptr[:-1]):
            raise ValueError("indptr must not decrease")
        indices.flags.writeable = False
        indptr.flags.writeable = False
        self.indices, self.indptr = indices, indptr
        if soft is not None and (not isinstance(soft, PackedSets) or len(soft) != len(self)):
            raise ValueError(f"soft sets must be a PackedSets of {len(self)} rows, got {soft!r}")
        self.soft = soft

    def with_soft(self, soft: Iterable[object] | None) -> PackedSets:
        """These rows with ``soft`` as their soft sets, each made to hold its hard row.

        ``soft`` is packed (:meth:`from_sets`) and every row is united with this one's, so
        a hard match is never outside its soft set; ``None`` removes the soft sets.
        """
        if soft is None:
            return PackedSets(self.indices, self.indptr)
        loose = PackedSets.from_sets(soft)
        if len(loose) != len(self):
            raise ValueError(f"{len(loose)} soft rows for {len(self)} queries")
        n = int(max(self.indices.max(initial=-1), loose.indices.max(initial=-1))) + 1
        rows = np.repeat(np.arange(len(self), dtype=np.int64), self.lengths)
        loose_rows = np.repeat(np.arange(len(self), dtype=np.int64), loose.lengths)
        keys = np.unique(np.concatenate([rows * n + self.indices, loose_rows * n + loose.indices]))
        indptr = np.zeros(len(self) + 1, dtype=np.int64)
        np.cumsum(np.bincount(keys // max(n, 1), minlength=len(self)), out=indptr[1:])
        return PackedSets(self.indices, self.indptr, PackedSets(keys % max(n, 1), indptr))

    @classmethod
    def from_sets(cls, sets: Iterable[object]) -> PackedSets:
        """Pack a sequence of per-query index arrays (a ``PackedSets`` is returned as is)."""
        if isinstance(sets, PackedSets):
            return sets
        rows = [np.asarray(s, dtype=np.int64).ravel() for s in sets]
        lengths = np.fromiter((r.size for r in rows), dtype=np.int64, count=len(rows))
        indptr = np.zeros(len(rows) + 1, dtype=np.int64)
        np.cumsum(lengths, out=indptr[1:])
        indices = np.concatenate(rows) if rows else np.zeros(0, np.int64)
        return cls(indices, indptr)

    @property
    def lengths(self) -> np.ndarray:
        """How many references each query accepts, shape (M,)."""
        return np.diff(self.indptr)

    def __len__(self) -> int:
        return self.indptr.size - 1

    @overload
    def __getitem__(self, i: int) -> np.ndarray: ...
    @overload
    def __getitem__(self, i: slice) -> PackedSets: ...
    def __getitem__(self, i: int | slice) -> np.ndarray | PackedSets:
        if isinstance(i, slice):
            start, stop, step = i.indices(len(self))
            soft = None if self.soft is None else self.soft[i]
            if step == 1:
                stop = max(stop, start)
                lo, hi = self.indptr[start], self.indptr[stop]
                return PackedSets(self.indices[lo:hi], self.indptr[start : stop + 1] - lo, soft)
            rows = PackedSets.from_sets([self[k] for k in range(start, stop, step)])
            return PackedSets(rows.indices, rows.indptr, soft)
        n = len(self)
        k = int(i)
        if not -n <= k < n:
            raise IndexError(f"query {k} is outside the {n} queries")
        k %= n
        return self.indices[self.indptr[k] : self.indptr[k + 1]]

    def __iter__(self) -> Iterator[np.ndarray]:
        indices, bounds = self.indices, self.indptr.tolist()
        for a, b in itertools.pairwise(bounds):
            yield indices[a:b]

    def __repr__(self) -> str:
        soft = "" if self.soft is None else f", soft {self.soft.indices.size}"
        return f"PackedSets({len(self)} queries, {self.indices.size} indices{soft})"


def file_digest(path: Path) -> dict[str, str]:
    """``{"name": <file name>, "sha256": <digest of its bytes>}``: a ground-truth file as
    ``meta["ground_truth_rule"]`` records it (the same file, the same entry)."""
    h = hashlib.sha256()
    with open(path, "rb") as f:
        while chunk := f.read(1 << 20):
            h.update(chunk)
    return {"name": Path(path).name, "sha256": h.hexdigest()}


def from_positions(positions: np.ndarray, n_ref: int, tolerance: int) -> PackedSets:
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
    PackedSets
        One sorted run of indices per query.

    Examples
    --------
    >>> [a.tolist() for a in from_positions(np.array([0.0, 2.5, 9.0, np.nan]), 4, 1)]
    [[0, 1], [1, 2, 3], [], []]
    """
    p = np.asarray(positions, dtype=np.float64).ravel()
    reach = tolerance + 0.5
    finite = np.isfinite(p)
    q = np.where(finite, p, 0.0)
    # Clipped in floating point first, so a huge position cannot overflow the cast.
    lo = np.maximum(np.ceil(q - reach - 1e-9), 0.0)
    hi = np.minimum(np.floor(q + reach + 1e-9), float(n_ref - 1))
    count = np.where(finite & (hi >= lo), hi - lo + 1, 0).astype(np.int64)
    first = np.where(count > 0, lo, 0).astype(np.int64)
    indptr = np.zeros(p.size + 1, dtype=np.int64)
    np.cumsum(count, out=indptr[1:])
    offset = np.arange(indptr[-1], dtype=np.int64) - np.repeat(indptr[:-1], count)
    return PackedSets(np.repeat(first, count) + offset, indptr)


def dilate(sets: Iterable[np.ndarray], n_ref: int, tolerance: int) -> PackedSets:
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
    return PackedSets.from_sets(out)


def validate_sets(
    sets: Sequence[np.ndarray], n_ref: int, source: str, overhang: int = 0
) -> PackedSets:
    """Return ``sets`` as sorted ``int64`` runs; raise if any index is outside the map.

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
    return PackedSets.from_sets(out)


# --- VPR-Bench ------------------------------------------------------------------------------

_SAFE_GLOBALS = {
    ("numpy", "ndarray"),
    ("numpy", "dtype"),
    ("numpy.core.multiarray", "_reconstruct"),
    ("numpy._core.multiarray", "_reconstruct"),
    ("numpy.core.multiarray", "scalar"),
    ("numpy._core.multiarray", "scalar"),
}


MAX_GROUND_TRUTH_BYTES = 256 << 20
"""Largest ground-truth file read (256 MiB; VPR-Bench's are a few MB)."""

MAX_GROUND_TRUTH_ITEMS = 50_000_000
"""Most elements a ground-truth array may claim in its header."""


class _NeedsTrust(Exception):
    """A well-formed pickle that asks for a global the array-only unpickler refuses."""


class _ArrayOnlyUnpickler(pickle.Unpickler):
    """Unpickler that can only rebuild numpy arrays, numpy scalars, lists and numbers.

    ``find_class`` is the only way a pickle reaches code; it refuses every global except
    the numpy array constructors above, so a crafted file cannot run anything else (the
    "restricting globals" pattern of the :mod:`pickle` documentation).
    """

    def find_class(self, module: str, name: str):
        if (module, name) in _SAFE_GLOBALS:
            return super().find_class(module, name)
        raise _NeedsTrust()


def _corrupt(path: Path, what: str) -> DataError:
    return DataError(
        f"cannot read VPR-Bench ground truth {path}: {what}; give the ground_truth_new.npy "
        "that came with the dataset"
    )


def _read_header(path: Path, raw: bytes) -> tuple[tuple[int, ...], np.dtype, io.BytesIO]:
    """The ``.npy`` header (shape, dtype) and a stream at the data; contents never quoted."""
    f = io.BytesIO(raw)
    if not raw.startswith(b"\x93NUMPY"):
        raise _corrupt(path, "it is not a .npy file (it does not start with numpy's magic bytes)")
    try:
        version = np.lib.format.read_magic(f)
        if version == (1, 0):
            shape, _fortran, dtype = np.lib.format.read_array_header_1_0(f)
        else:
            shape, _fortran, dtype = np.lib.format.read_array_header_2_0(f)
    except Exception:  # numpy's messages quote the header bytes: keep them out of ours
        raise _corrupt(path, "its .npy header is corrupt or truncated") from None
    count = math.prod(shape)
    if count > MAX_GROUND_TRUTH_ITEMS:
        raise _corrupt(
            path, f"its header claims {count} elements, more than {MAX_GROUND_TRUTH_ITEMS}"
        )
    return tuple(shape), dtype, f


def _load_npy_safely(path: Path, trust: bool = False) -> np.ndarray:
    """Read a ``.npy`` without running code: plain arrays without pickle, object arrays by
    the array-only unpickler (by full unpickling with ``trust``). Raises ``_NeedsTrust``
    for a pickle that needs more than the array-only unpickler rebuilds."""
    raw = _read_bounded(path)
    shape, dtype, f = _read_header(path, raw)
    if not dtype.hasobject:
        need = f.tell() + math.prod(shape) * dtype.itemsize
        if len(raw) < need:
            raise _corrupt(path, f"it is truncated ({len(raw)} of {need} bytes)")
        f.seek(0)
        try:
            return np.load(f, allow_pickle=False)
        except Exception:
            raise _corrupt(path, "its array data cannot be read") from None
    try:
        if trust:
            f.seek(0)
            arr = np.load(f, allow_pickle=True)
        else:
            arr = _ArrayOnlyUnpickler(f).load()
    except _NeedsTrust:
        raise
    except Exception:  # a cut or damaged pickle: not a question of trust
        raise _corrupt(path, "its pickled rows are corrupt or truncated") from None
    try:
        arr = np.asarray(arr, dtype=object)
    except Exception:
        raise _corrupt(path, "its pickled rows do not form an array") from None
    if arr.shape != shape:
        raise _corrupt(path, f"the rows form shape {arr.shape}, not the header's {shape}")
    return arr


def _read_bounded(path: Path) -> bytes:
    try:
        size = path.stat().st_size
        if size > MAX_GROUND_TRUTH_BYTES:
            raise _corrupt(path, f"it is {size} bytes, more than {MAX_GROUND_TRUTH_BYTES}")
        return path.read_bytes()
    except OSError as exc:
        raise DataError(
            f"cannot read VPR-Bench ground truth {path}: {exc.strerror or type(exc).__name__}"
        ) from None


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


def read_vprbench(path: Path, n_query: int, n_ref: int, trust: bool = False) -> PackedSets:
    """Read a VPR-Bench ``ground_truth_new.npy``: rows ``[query_index, [reference indices]]``.

    The file is a pickled object array. By default it is decoded by an unpickler that can
    rebuild only numpy arrays, lists and numbers; anything else (which a tampered file
    would need in order to run code) is refused. ``trust=True`` uses ``numpy.load(...,
    allow_pickle=True)`` instead, which runs whatever the file says: only for files you
    made or trust. A plain integer array of shape (M, 2) (one reference per query) is
    read without pickle at all. A file that is not a ``.npy``, is truncated or corrupt, or
    claims more than :data:`MAX_GROUND_TRUTH_ITEMS` elements is refused as such (``trust``
    cannot help it); messages never quote the file's bytes.

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
    PackedSets
        Accepted reference indices for each query ``0 .. n_query-1``.

    Raises
    ------
    DataError
        Naming the file and the fix.
    """
    path = Path(path)
    if path.is_dir():
        raise DataError(f"ground-truth file {path} is a folder; give the .npy file")
    if not path.is_file():
        raise DataError(f"ground-truth file {path} does not exist")
    try:
        arr = _load_npy_safely(path, trust)
    except _NeedsTrust:
        raise DataError(
            f"VPR-Bench ground truth {path} is a pickle that holds more than numbers and "
            "lists, so it was not unpickled; if you made or trust the file, add trust=1 to "
            "the spec (this runs code stored in the file)"
        ) from None
    return _vprbench_rows(arr, path, n_query, n_ref)


def _vprbench_rows(arr: object, path: Path, n_query: int, n_ref: int) -> PackedSets:
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
        except (ValueError, TypeError, IndexError, OverflowError):
            raise DataError(
                f"VPR-Bench ground truth {path}, row {r}: the query index and the reference "
                "indices must be integers"
            ) from None
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


MAX_TRUTH_SIDE = 20_000
"""Largest side of a FAB-MAP truth matrix (3.2 GB as MATLAB doubles; City Centre's is
2474)."""


def read_truth_mat(path: Path, variable: str = "truth") -> np.ndarray:
    """Read the square boolean ``truth`` matrix of a FAB-MAP ground-truth ``.mat`` file.

    Entry ``(i, j)`` is true where images (or image pairs) ``i`` and ``j`` show the same
    place. MATLAB v4-v7.2 files are read with :func:`scipy.io.loadmat` (no code runs); the
    variable's shape is read from the file's directory first (:func:`scipy.io.whosmat`),
    so a matrix over :data:`MAX_TRUTH_SIDE` is refused before it is loaded. A sparse matrix
    is read (and made dense); a struct, cell or text variable is refused.

    Raises
    ------
    DataError
        If the file is missing, unreadable, lacks the variable, is too large, not numeric
        or not square.
    """
    from scipy.io import loadmat, whosmat

    path = Path(path)
    if not path.is_file():
        raise DataError(f"ground-truth file {path} does not exist")
    try:
        listing = whosmat(str(path))
    except NotImplementedError:
        raise DataError(
            f"cannot read {path}: MATLAB v7.3 (HDF5) files are not supported; re-save it "
            "in MATLAB with save(..., '-v7')"
        ) from None
    except Exception:  # scipy raises many types on a corrupt file; never quote its bytes
        raise DataError(
            f"cannot read ground-truth matrix {path}: not a MATLAB .mat file, or corrupt"
        ) from None
    found = {name: (tuple(shape), cls) for name, shape, cls in listing}
    if variable not in found:
        names = ", ".join(list(found)[:10]) or "none"
        raise DataError(
            f"{path} has no variable {variable!r} (it has: {names}); give the FAB-MAP "
            "ground-truth file"
        )
    shape, cls = found[variable]
    if cls in ("struct", "cell", "char", "object", "function_handle", "opaque"):
        raise DataError(
            f"{path}: {variable!r} is a MATLAB {cls}, not a matrix; save the truth matrix "
            f"itself, e.g. in MATLAB truth = s.truth; save(..., 'truth', '-v7')"
        )
    if len(shape) != 2 or shape[0] != shape[1]:
        raise DataError(f"{path}: {variable!r} has shape {shape}; expected a square matrix")
    if shape[0] > MAX_TRUTH_SIDE:
        raise DataError(
            f"{path}: {variable!r} is {shape[0]}x{shape[1]}, larger than "
            f"{MAX_TRUTH_SIDE}x{MAX_TRUTH_SIDE}"
        )
    try:
        content = loadmat(str(path), variable_names=[variable])
    except Exception:
        raise DataError(f"cannot read ground-truth matrix {path}: corrupt or truncated") from None
    m = content.get(variable)
    if hasattr(m, "toarray"):  # a MATLAB sparse matrix: made dense as booleans only
        m = (m != 0).toarray()
    m = np.asarray(m)
    if m.dtype.kind not in "biuf" or m.ndim != 2 or m.shape[0] != m.shape[1]:
        raise DataError(
            f"{path}: {variable!r} is not a square numeric matrix (dtype {m.dtype}, shape "
            f"{m.shape}); save the truth matrix of 0s and 1s"
        )
    if m.dtype.kind == "f" and not np.isfinite(m).all():
        raise DataError(f"{path}: {variable!r} holds NaN or infinite entries; use 0s and 1s")
    return m != 0
