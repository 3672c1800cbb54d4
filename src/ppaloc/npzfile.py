"""``.npz`` archives written reproducibly and read within stated bounds.

:func:`npz_bytes` writes the arrays as numpy's ``savez`` does, but every zip entry carries
the same timestamp (``SOURCE_DATE_EPOCH`` if set, else 1980-01-01, the zip epoch), so equal
arrays give equal bytes. :func:`read_npz` checks every member before allocating anything:
it must be a plain ``.npy`` whose header's shape and dtype account exactly for the bytes the
member holds, the member must fit in the archive (stored) or within deflate's largest ratio
(compressed), and the total must stay under ``max_bytes``. Nothing is unpickled.
"""

from __future__ import annotations

import io
import math
import zipfile
import zlib
from collections.abc import Collection, Mapping
from pathlib import Path
from typing import IO

import numpy as np

from ppaloc.fileio import source_date

__all__ = ["NpzError", "npz_bytes", "read_npz", "write_npz"]

_DEFLATE_MAX_RATIO = 1032  # deflate cannot expand one byte into more than this
_READ_ERRORS = (
    OSError,
    ValueError,
    EOFError,
    KeyError,
    SyntaxError,
    TypeError,
    RecursionError,
    MemoryError,
    OverflowError,
    # zipfile on a member whose altered fields ask for what it does not do: a zip version
    # or compression method it lacks (NotImplementedError), an encrypted member
    # (RuntimeError: "password required")
    NotImplementedError,
    RuntimeError,
    zipfile.BadZipFile,
    zlib.error,
)


class NpzError(ValueError):
    """An archive that is not a well-formed, bounded ``.npz``; the message is the cause."""


def _zip_time() -> tuple[int, int, int, int, int, int]:
    when = source_date()
    if when is None or when.year < 1980:
        return (1980, 1, 1, 0, 0, 0)
    return (when.year, when.month, when.day, when.hour, when.minute, when.second)


def write_npz(f: IO[bytes], arrays: Mapping[str, np.ndarray], *, compress: bool) -> None:
    """Write ``arrays`` to the binary file ``f`` as an ``.npz`` (``name.npy`` per array, in
    the given order), with fixed entry timestamps; object arrays are refused."""
    method = zipfile.ZIP_DEFLATED if compress else zipfile.ZIP_STORED
    stamp = _zip_time()
    with zipfile.ZipFile(f, mode="w", compression=method, allowZip64=True) as zf:
        for name, value in arrays.items():
            info = zipfile.ZipInfo(f"{name}.npy", date_time=stamp)
            info.compress_type = method
            info.external_attr = 0o644 << 16
            with zf.open(info, "w", force_zip64=True) as out:
                np.lib.format.write_array(out, np.asanyarray(value), allow_pickle=False)


def npz_bytes(arrays: Mapping[str, np.ndarray], *, compress: bool = True) -> bytes:
    """The bytes of :func:`write_npz`.

    Examples
    --------
    >>> import numpy as np
    >>> a = npz_bytes({"x": np.arange(3)})
    >>> a == npz_bytes({"x": np.arange(3)}), read_npz(io.BytesIO(a), max_bytes=1024)["x"].tolist()
    (True, [0, 1, 2])
    """
    buf = io.BytesIO()
    write_npz(buf, arrays, compress=compress)
    return buf.getvalue()


def _member_header(
    zf: zipfile.ZipFile, info: zipfile.ZipInfo
) -> tuple[tuple[int, ...], np.dtype, int]:
    """Shape, dtype and header length of one ``.npy`` member, read without its data."""
    with zf.open(info) as g:
        version = np.lib.format.read_magic(g)
        if version == (1, 0):
            shape, _, dtype = np.lib.format.read_array_header_1_0(g)
        elif version == (2, 0):
            shape, _, dtype = np.lib.format.read_array_header_2_0(g)
        else:
            raise NpzError(f"member {info.filename!r} is .npy version {version}; not supported")
        return tuple(int(d) for d in shape), dtype, g.tell()


def _check_member(
    zf: zipfile.ZipFile, info: zipfile.ZipInfo, archive_size: int | None, limit: int
) -> int:
    """The data bytes of a member, after checking that its claims are possible."""
    name = info.filename
    if not name.endswith(".npy") or "/" in name:
        raise NpzError(f"member {name!r} is not an .npy array")
    if info.compress_type == zipfile.ZIP_STORED:
        if archive_size is not None and info.file_size > archive_size:
            raise NpzError(
                f"member {name!r} claims {info.file_size} bytes, more than the archive holds "
                "(truncated or altered)"
            )
    elif info.file_size > _DEFLATE_MAX_RATIO * info.compress_size + 1024:
        raise NpzError(
            f"member {name!r} claims {info.file_size} bytes from {info.compress_size} "
            "compressed bytes, more than deflate can produce (altered)"
        )
    if info.file_size > limit:
        raise NpzError(f"member {name!r} holds {info.file_size} bytes, over the {limit}-byte limit")
    try:
        shape, dtype, offset = _member_header(zf, info)
    except NpzError:
        raise
    except (zipfile.BadZipFile, zlib.error, EOFError) as exc:  # e.g. a bad CRC at the end
        raise NpzError(f"corrupt or truncated archive (member {name!r}: {exc})") from None
    except _READ_ERRORS:
        raise NpzError(
            f"member {name!r} has no readable .npy header (corrupt or altered)"
        ) from None
    if dtype.hasobject:
        raise NpzError(f"member {name!r} holds Python objects (pickled data); refused")
    if any(d < 0 for d in shape):
        raise NpzError(f"member {name!r} claims a negative shape {shape}")
    claimed = math.prod(shape) * dtype.itemsize
    if offset + claimed != info.file_size:
        raise NpzError(
            f"member {name!r} claims shape {shape} of {dtype} ({claimed} bytes) but holds "
            f"{max(info.file_size - offset, 0)} bytes of data (truncated or altered)"
        )
    return claimed


def read_npz(
    source: str | Path | IO[bytes],
    *,
    max_bytes: int,
    member_limits: Mapping[str, int] | None = None,
    only: Collection[str] | None = None,
) -> dict[str, np.ndarray]:
    """Every array of an ``.npz``, keyed by name, after bounding what each member claims.

    Parameters
    ----------
    source : path or binary file
    max_bytes : int
        Most data bytes accepted in all, and in any one member.
    member_limits : mapping, optional
        A smaller limit for some members, by array name.
    only : collection of str, optional
        Read only these arrays (every member is still checked).

    Raises
    ------
    NpzError
        The file is not a zip archive, a member is not a plain ``.npy``, claims more than it
        holds or than the limits, or cannot be read; the message says which and why.
    """
    limits = dict(member_limits or {})
    own = isinstance(source, str | Path)
    f = open(source, "rb") if own else source  # closed in the finally below
    try:
        try:
            zf = zipfile.ZipFile(f)
        except (zipfile.BadZipFile, OSError, ValueError, EOFError, NotImplementedError) as exc:
            raise NpzError(f"corrupt or truncated .npz archive ({exc})") from None
        with zf:
            size = None
            try:
                size = f.seek(0, io.SEEK_END)
            except (OSError, AttributeError):
                pass
            total = 0
            infos = zf.infolist()
            names = [i.filename for i in infos]
            if len(set(names)) != len(names):
                raise NpzError("the archive names one member twice (altered)")
            try:
                for info in infos:
                    limit = min(limits.get(info.filename[:-4], max_bytes), max_bytes)
                    total += _check_member(zf, info, size, limit)
                    if total > max_bytes:
                        raise NpzError(f"the arrays hold more than the {max_bytes}-byte limit")
                arrays = {}
                for info in infos:
                    if only is not None and info.filename[:-4] not in only:
                        continue
                    with zf.open(info) as g:
                        arrays[info.filename[:-4]] = np.lib.format.read_array(g, allow_pickle=False)
            except NpzError:
                raise
            except _READ_ERRORS as exc:
                cause = " ".join(str(exc).split())[:160]
                raise NpzError(
                    f"corrupt or truncated archive ({type(exc).__name__}: {cause})"
                ) from None
            return arrays
    finally:
        if own:
            f.close()
