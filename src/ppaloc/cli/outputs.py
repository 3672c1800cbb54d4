"""Where a command may write: every output location is checked before the run starts.

A run that fails only after minutes of work because ``--out`` cannot be written wastes the
work; so each command checks its output first: the text is not empty and holds no NUL,
no part of the way to it is a regular file, a folder target is not a file and a file
target is not a folder, an existing device, pipe or socket (``/dev/null``) is never
replaced, and the nearest existing folder of where the output lands (a link's target's
folder, since the file a link names is replaced beside it; a folder's own parent, where
it is staged) accepts a new file (tried for real, so it holds for root and read-only
mounts alike).
"""

from __future__ import annotations

import os
import tempfile
from collections.abc import Sequence
from pathlib import Path

from ppaloc.errors import DataError, PpalocError
from ppaloc.fileio import leads_into_loop

__all__ = [
    "MAX_NAME",
    "MAX_PATH",
    "STDOUT",
    "check_output",
    "check_path_text",
    "check_png",
    "check_suffix",
    "check_text_output",
    "refuse_input_as_out",
    "refuse_link_loop",
    "refuse_stdout",
    "resolve",
]

MAX_PATH = 4096
"""Longest path accepted (Linux's PATH_MAX)."""

MAX_NAME = 255
"""Longest name between two slashes, in bytes (NAME_MAX)."""


STDOUT = "-"
"""An output given as ``-`` (the text as typed): standard output where the command writes
one text file (:func:`check_text_output`: ``ppaloc localise``'s CSV), refused where it
writes a folder of several files or a binary file (:func:`check_output`). ``./-`` names a
file or folder called ``-``."""


def refuse_stdout(text: object, flag: str, *, folder: bool) -> None:
    """Refuse ``-`` (:data:`STDOUT`) as an output that cannot go to standard output: a
    folder of several files, or a binary file.

    Raises
    ------
    PpalocError
        Naming the flag, what the command writes and the fix.

    Examples
    --------
    >>> try:
    ...     refuse_stdout("-", "--out", folder=True)
    ... except PpalocError as exc:
    ...     print(str(exc)[:71])
    --out - is standard output, but this command writes a folder of several
    >>> refuse_stdout("./-", "--out", folder=True)  # a folder named '-'
    """
    if not (isinstance(text, str) and text == STDOUT):
        return
    what = "a folder of several files" if folder else "a binary file, not text"
    name = "folder" if folder else "file"
    raise PpalocError(
        f"{flag} - is standard output, but this command writes {what}; give a {name} name "
        "(./- for one named '-')"
    )


def refuse_folder_text(text: str | os.PathLike[str], flag: str) -> None:
    """Refuse a file's path written as a folder's, ending in ``/``: ``--out maps/`` would
    otherwise become a file named ``maps`` (a path drops its trailing slash).

    Raises
    ------
    PpalocError
        Naming the flag and the fix.
    """
    raw = os.fspath(text)
    if isinstance(raw, str) and raw.rstrip("/" + os.sep) and raw.endswith(("/", os.sep)):
        raise PpalocError(f"{flag} {raw} ends in '/', which names a folder; give a file name")


def check_path_text(text: str | os.PathLike[str], flag: str) -> Path:
    """``text`` as a :class:`Path`, refusing an empty path, a NUL or an over-long one.

    Raises
    ------
    PpalocError
        Naming the flag and the fix.

    Examples
    --------
    >>> check_path_text("", "--out")
    Traceback (most recent call last):
    ppaloc.errors.PpalocError: --out '' is empty: give a file or folder name
    """
    if not isinstance(text, str | os.PathLike):
        raise PpalocError(f"{flag}={text!r} must be a path (a string), e.g. {flag} results")
    raw = os.fspath(text)
    if not isinstance(raw, str) or not raw.strip():
        raise PpalocError(f"{flag} {raw!r} is empty: give a file or folder name")
    if "\0" in raw:
        raise PpalocError(f"{flag} {raw!r} holds a NUL character, which no path can hold")
    if len(raw) > MAX_PATH:
        raise PpalocError(f"{flag} is a path of {len(raw)} characters: at most {MAX_PATH}")
    longest = max((len(os.fsencode(part)) for part in Path(raw).parts), default=0)
    if longest > MAX_NAME:
        raise PpalocError(
            f"{flag} has a name of {longest} bytes between slashes: at most {MAX_NAME}"
        )
    return Path(raw).expanduser()


def refuse_link_loop(path: str | os.PathLike[str], what: str) -> None:
    """Refuse a path that is (or lies under) a loop of symbolic links, which no command can
    read or write, naming it: the system's own "not found" or "is a file" would mislead.

    Raises
    ------
    DataError
        Naming ``what`` (``--out``, ``the dataset's input``), the path and the fix.
    """
    if leads_into_loop(path):
        raise DataError(
            f"{what} {os.fspath(path)} leads into a symlink loop (links that lead back "
            "to themselves); give a real file or folder, or fix the links"
        )


def resolve(path: str | os.PathLike[str], what: str) -> Path:
    """``path`` made absolute with its links followed (:meth:`Path.resolve`), a loop of
    symbolic links refused in one line (:func:`refuse_link_loop`) instead of the
    ``RuntimeError`` (or, from Python 3.13, the unresolved path) that ``resolve`` gives."""
    refuse_link_loop(path, what)
    try:
        return Path(path).resolve()
    except RuntimeError:  # a loop made between the check and here
        refuse_link_loop(path, what)
        raise


def check_output(
    text: str | os.PathLike[str], flag: str = "--out", *, folder: bool, in_place: bool = False
) -> Path:
    """Check that ``text`` can become the output folder (``folder=True``) or file.

    ``in_place``: the command writes into an existing folder rather than replacing it
    through a staging folder beside it (``ppaloc sweep``), so that folder, not its parent,
    must accept a new file.

    Returns
    -------
    Path
        The checked path.

    Raises
    ------
    PpalocError
        Before any work: the path is empty, is ``-`` (:func:`refuse_stdout`), is the wrong
        kind of entry, lies under a regular file, or its nearest existing folder cannot be
        written.
    """
    refuse_stdout(text, flag, folder=folder)
    path = check_path_text(text, flag)
    if not folder:
        refuse_folder_text(text, flag)
    refuse_link_loop(path, flag)
    what = "folder" if folder else "file"
    if path.exists() or path.is_symlink():
        if path.exists() and not (path.is_dir() or path.is_file()):
            raise PpalocError(
                f"{flag} {path} is a device, pipe or socket, not a {what}; writing would "
                f"replace it: give a {what} name"
            )
        if folder and not path.is_dir():
            raise PpalocError(f"{flag} {path} is a file; give a folder for the results")
        if not folder and path.is_dir():
            raise PpalocError(f"{flag} {path} is a folder; give a file name")
        if path.exists() and not os.access(path, os.W_OK):  # a dangling link: its folder
            raise PpalocError(f"{flag} {path} is not writable; give a {what} you can write")
    # where the write lands: the file a link names is replaced beside it, and a folder is
    # replaced through a staging folder beside it, with links followed (fileio); a folder
    # written in place (a sweep's) takes its files itself
    real = Path(os.path.realpath(path))
    if path.is_symlink() and not folder and not real.parent.is_dir():
        raise PpalocError(
            f"{flag} {path} is a symbolic link to {real}, whose folder {real.parent} is not "
            f"a folder that exists; create it, or give another {what}"
        )
    probe = real if folder and in_place and real.is_dir() else real.parent
    while not probe.exists():
        if probe.is_symlink():
            raise PpalocError(f"{flag} {path}: {probe} is a dangling symbolic link")
        probe = probe.parent
    if not probe.is_dir():
        raise PpalocError(
            f"{flag} {path} lies under {probe}, which is a file, not a folder; give another {what}"
        )
    try:
        fd, name = tempfile.mkstemp(prefix=".ppaloc-probe-", dir=probe)
    except OSError as exc:
        reason = exc.strerror or type(exc).__name__
        raise PpalocError(
            f"{flag} {path}: cannot write in {probe} ({reason}); give a {what} you can write"
        ) from None
    os.close(fd)
    os.unlink(name)
    return path


def check_text_output(text: str | os.PathLike[str], flag: str = "--out") -> Path | None:
    """Check an output file whose text may go to standard output: None for ``-``
    (:data:`STDOUT`), else the checked file (:func:`check_output`).

    Examples
    --------
    >>> check_text_output("-") is None
    True
    """
    if isinstance(text, str) and text == STDOUT:
        return None
    return check_output(text, flag, folder=False)


def default_png(path: Path) -> Path:
    """Where ``ppaloc show`` draws ``path`` without ``--out``: beside it, as ``.png``.

    A PNG already there is replaced only where it carries ppaloc's mark (an earlier
    ``show``; :func:`ppaloc.fileio.drawn_by_ppaloc`); one of the user's (a frame, a photo)
    would be lost, so without the mark ``--out`` must name it.

    Raises
    ------
    PpalocError
        Naming the file and the fix.
    """
    from ppaloc.fileio import drawn_by_ppaloc

    out = path.with_suffix(".png")
    if out.exists() and not drawn_by_ppaloc(out):
        raise PpalocError(
            f"{out} exists and carries no mark of a plot ppaloc drew (PNG text 'Software: "
            f"ppaloc', which ppaloc's images carry since 2026-12-07): show would replace it; "
            f"give --out {out} to replace it, or another name"
        )
    return out


def check_png(out: Path) -> None:
    """Refuse an ``--out`` of ``ppaloc show`` whose suffix names another format than the
    PNG it writes (``x.pdf`` would hold PNG bytes).

    Raises
    ------
    PpalocError
        Naming the file and the fix.
    """
    if out.suffix.lower() != ".png":
        raise PpalocError(f"--out {out}: show draws PNG images; give a file name ending in .png")


def check_suffix(out: Path, writes: str, fix: str) -> None:
    """Refuse an ``--out`` whose suffix names an image, a video or a map (``.npz``) where
    the command writes something else (``ppaloc map --out x.png`` wrote a map named as an
    image, which a folder of frames then held as an unreadable image).

    Parameters
    ----------
    out : Path
        The output file.
    writes : str
        What the command writes there (``"a map (.npz)"``).
    fix : str
        The name to give (``"a name ending in .npz"``).

    Raises
    ------
    PpalocError
        Naming the file, what it would hold and the fix.
    """
    from ppaloc.cli.localise import VIDEO_SUFFIXES
    from ppaloc.datasets.images import IMAGE_SUFFIXES

    suffix = out.suffix.lower()
    named = (
        "an image"
        if suffix in IMAGE_SUFFIXES
        else "a video"
        if suffix in VIDEO_SUFFIXES
        else "a map"
        if suffix == ".npz"
        else None
    )
    if named is not None and not writes.startswith(named):
        raise PpalocError(f"--out {out} names {named}, but it would hold {writes}; give {fix}")


def refuse_input_as_out(
    out: Path | None, inputs: Sequence[str | os.PathLike[str]], what: str = "the"
) -> None:
    """Refuse an ``--out`` that is one of the command's inputs or lies in an input folder:
    writing it would replace what the user saved, or add a file to a folder the command
    (or its next run) reads as input (a map named ``x.png`` among a folder's frames).

    Parameters
    ----------
    out : Path, optional
        The output (None: nothing is written).
    inputs : sequence of path
        The files and folders the command reads.
    what : str
        Whose inputs, for the message (``"the dataset's"``).

    Raises
    ------
    DataError
        Naming the output, the input and the fix.
    """
    if out is None:
        return
    target = resolve(out, "--out")
    sources = [resolve(given, f"{what} input") for given in inputs]
    for given, source in zip(inputs, sources, strict=True):
        if target == source:
            raise DataError(
                f"--out {out} would overwrite {what} input {given}; give another file name"
            )
    for given, source in zip(inputs, sources, strict=True):
        if source.is_dir() and source in target.parents:
            raise DataError(
                f"--out {out} lies inside {what} input folder {given}, which would then hold "
                "it among its inputs; write it outside that folder"
            )
