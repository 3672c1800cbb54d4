"""Writing files and folders so that a reader never sees half of one.

Files: every file ppaloc writes for a user (maps, results, reports, figures) goes through
:func:`atomic_write`. The bytes go to an anonymous file in the target folder (Linux
``O_TMPFILE``: it has no name, so a killed process leaves nothing behind), which is given a
temporary name and moved over the target in one ``os.replace``. Where anonymous files are
not available, a named ``.NAME.PID-XXXX.tmp`` is used instead; a later write of the same
target removes those whose process is gone. Only names of exactly that form (a process
id and hex digits) are ever removed, and only when that process is gone from this
machine: one machine is assumed to write a folder (on a volume that several hosts write at
once, a live writer elsewhere would look gone).

Folders: a results folder is written by :func:`new_folder` (or changed by
:func:`update_folder`) into a hidden staging folder beside it, ``.NAME.ppaloc-new-PID-XXXX``,
which then takes the target's place in one step: an atomic exchange of the two names
(Linux ``renameat2(RENAME_EXCHANGE)``), after which the old contents, now under the staging
name, are deleted. A reader sees the whole old folder or the whole new one, never a mix.
Where the exchange is not available the old folder is renamed aside
(``.NAME.ppaloc-old-PID-XXXX``) and the new one renamed in; if a process dies between the
two renames, the next transaction on the folder (and :func:`recover_folder`) moves the old
one back. Staging folders of dead processes are removed by the next transaction.

Reproducible bytes: files hold no clock time unless ``SOURCE_DATE_EPOCH`` is set
(:func:`source_date`), so the same inputs give the same bytes.
"""

from __future__ import annotations

import contextlib
import ctypes
import datetime as dt
import errno
import os
import re
import secrets
import shutil
import signal
import threading
from collections.abc import Callable, Iterable, Iterator
from contextlib import AbstractContextManager, contextmanager
from pathlib import Path
from typing import IO, Any

from ppaloc.errors import PpalocError

__all__ = [
    "PNG_SOFTWARE",
    "atomic_write",
    "check_replaceable_folder",
    "default_file_mode",
    "drawn_by_ppaloc",
    "held_interrupt",
    "leads_into_loop",
    "new_folder",
    "recover_folder",
    "source_date",
    "update_folder",
    "user_cache",
    "write_bytes",
    "write_png",
]


#: The PNG ``Software`` text of every image ppaloc draws: ``ppaloc show`` replaces a PNG
#: beside its input only where it carries this (:func:`drawn_by_ppaloc`).
PNG_SOFTWARE = "ppaloc"


def write_png(path: str | os.PathLike[str], image: Any, **options: Any) -> None:
    """Write a Pillow ``image`` to ``path`` as PNG through :func:`atomic_write`, with the
    ``Software`` text :data:`PNG_SOFTWARE` that :func:`drawn_by_ppaloc` reads (``options``
    go to ``Image.save``, e.g. ``optimize=True``)."""
    from PIL import PngImagePlugin

    info = PngImagePlugin.PngInfo()
    info.add_text("Software", PNG_SOFTWARE)
    with atomic_write(path) as f:
        image.save(f, format="PNG", pnginfo=info, **options)


def drawn_by_ppaloc(path: str | os.PathLike[str]) -> bool:
    """Whether ``path`` is a PNG ppaloc drew (its ``Software`` text is :data:`PNG_SOFTWARE`);
    False for any other file, or none."""
    from PIL import Image, UnidentifiedImageError

    try:
        with Image.open(path) as img:
            return img.format == "PNG" and img.info.get("Software") == PNG_SOFTWARE
    except (OSError, UnidentifiedImageError, ValueError):
        return False


def default_file_mode() -> int:
    """The mode ``open()`` gives a new file under the current umask (0644 under 022).

    ``tempfile.mkstemp`` creates files readable by their owner only; outputs are ordinary
    files, so they get the ordinary mode.
    """
    mask = os.umask(0)
    os.umask(mask)
    return 0o666 & ~mask


def source_date() -> dt.datetime | None:
    """The time to record in a file: ``SOURCE_DATE_EPOCH`` (UTC) if set, else None.

    ppaloc writes no clock time into its files by default, so that the same inputs give
    byte-identical outputs; a build that wants a date in them sets ``SOURCE_DATE_EPOCH``
    (seconds since 1970, the reproducible-builds convention).

    Raises
    ------
    PpalocError
        If ``SOURCE_DATE_EPOCH`` is set but is not a non-negative integer.
    """
    raw = os.environ.get("SOURCE_DATE_EPOCH")
    if raw is None or raw.strip() == "":
        return None
    try:
        seconds = int(raw)
        if seconds < 0:
            raise ValueError
        return dt.datetime.fromtimestamp(seconds, dt.UTC)
    except (ValueError, OverflowError, OSError):
        raise PpalocError(
            f"SOURCE_DATE_EPOCH={raw!r} is not a time; give whole seconds since 1970, e.g. "
            "SOURCE_DATE_EPOCH=1700000000, or unset it"
        ) from None


# -- files -----------------------------------------------------------------------------------


def _alive(pid: int) -> bool:
    if pid == os.getpid():
        return True
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except (PermissionError, OverflowError, ValueError):
        return pid > 0
    return True


def _owner_pid(token: str) -> int | None:
    """The process id of a token ppaloc wrote (``PID-xxxxxxxx``: hex digits after the
    process id), or None for any other name, which is never ppaloc's and so never removed."""
    match = re.fullmatch(r"(\d{1,10})-[0-9a-f]{4,16}", token)
    return int(match.group(1)) if match else None


def _sweep_stale_files(folder: Path, name: str) -> None:
    """Remove the temporaries of ``folder/name`` that a dead process left behind."""
    prefix, suffix = f".{name}.", ".tmp"
    with contextlib.suppress(OSError), os.scandir(folder) as entries:
        for entry in entries:
            if not (entry.name.startswith(prefix) and entry.name.endswith(suffix)):
                continue
            token = entry.name[len(prefix) : -len(suffix)]
            pid = _owner_pid(token)
            with contextlib.suppress(OSError):
                if not entry.is_file(follow_symlinks=False):
                    continue
                if pid is None or _alive(pid):  # not ppaloc's name, or its writer lives
                    continue
                os.unlink(entry.path)


def _temp_name(path: Path) -> Path:
    return path.parent / f".{path.name}.{os.getpid()}-{secrets.token_hex(4)}.tmp"


def _open_anonymous(folder: Path) -> int | None:
    """An unnamed file in ``folder`` (``O_TMPFILE``), or None where the system has none."""
    flag = getattr(os, "O_TMPFILE", None)
    if flag is None or not os.path.isdir("/proc/self/fd"):
        return None
    try:
        return os.open(folder, flag | os.O_RDWR, default_file_mode())
    except OSError:
        return None


def _name_anonymous(fd: int, path: Path) -> Path:
    """Give the unnamed file ``fd`` a temporary name beside ``path``; return that name."""
    tmp = _temp_name(path)
    try:
        os.link(f"/proc/self/fd/{fd}", tmp)
    except OSError:  # e.g. /proc hidden: copy the bytes into a named temporary
        try:
            with open(tmp, "xb") as out:
                os.lseek(fd, 0, os.SEEK_SET)
                while chunk := os.read(fd, 1 << 20):
                    out.write(chunk)
                out.flush()
                os.fsync(out.fileno())
        except BaseException:  # a full disk, an interrupt: no half copy is left
            tmp.unlink(missing_ok=True)
            raise
    return tmp


@contextmanager
def atomic_write(path: str | os.PathLike, mode: str = "wb", **open_kwargs: Any) -> Iterator[IO]:
    """Open a temporary file beside ``path``; when the block ends cleanly it becomes ``path``.

    The folder must exist. On an exception the temporary file is removed and ``path`` is
    left as it was; if the process is killed, an anonymous temporary disappears with it
    (a named one is removed by the next write of ``path``). A symbolic link is followed,
    as the shell's ``>`` follows it (except inside a staging folder of
    :func:`update_folder` or :func:`new_folder`, whose entries are replaced with the
    folder): the file it names is replaced and the link kept
    (replacing the link itself lost it, and ``--out /dev/stdout`` made ``/dev/stdout`` a
    file). A file that is replaced keeps its permissions, as with ``>``; a new one gets
    :func:`default_file_mode`. A target that is a device, pipe or socket is refused (a
    ``PpalocError``).

    Examples
    --------
    >>> import pathlib, tempfile
    >>> target = pathlib.Path(tempfile.mkdtemp()) / "note.txt"
    >>> with atomic_write(target, "w") as f:
    ...     _ = f.write("hello")
    >>> target.read_text()
    'hello'
    """
    path = Path(path)
    if path.is_symlink() and not _in_stage(path):
        # a link inside a staging folder is a copy of the folder's entry, replaced with the
        # folder whole: written through, it changed the file it names before the folder
        # was in, or if the command then failed
        _refuse_link_loop(path)
        path = Path(os.path.realpath(path))
    if not path.is_symlink() and path.exists() and not path.is_file() and not path.is_dir():
        # a write replaces its target whole: it never takes the place of a device (a
        # /dev/null), pipe or socket, however the name was reached (--out, a default name)
        raise PpalocError(
            f"{path} is a device, pipe or socket, not a file; writing would replace it: give "
            "a file name (or move it aside)"
        )
    try:  # the permissions of the file replaced: a private (0600) file stays private
        kept = os.stat(path).st_mode & 0o777 if path.is_file() and not path.is_symlink() else None
    except OSError:
        kept = None
    _sweep_stale_files(path.parent, path.name)
    fd = _open_anonymous(path.parent)
    tmp: Path | None = None
    if fd is None:
        tmp = _temp_name(path)
        try:
            fd = os.open(tmp, os.O_RDWR | os.O_CREAT | os.O_EXCL, default_file_mode())
        except OSError as exc:
            raise _naming(exc, path) from None
    try:
        with os.fdopen(fd, mode, closefd=False, **open_kwargs) as f:
            yield f
            f.flush()
        os.fsync(fd)
        if tmp is None:
            tmp = _name_anonymous(fd, path)
        if kept is not None:
            os.chmod(tmp, kept)
        os.replace(tmp, path)
        tmp = None
    except OSError as exc:
        named = _naming(exc, path)
        if named is exc:
            raise
        raise named from exc
    finally:
        os.close(fd)
        if tmp is not None:
            tmp.unlink(missing_ok=True)


def _refuse_link_loop(path: Path) -> None:
    """Refuse to write through ``path``, a symbolic link, where it leads into a loop of
    links: there is no file to replace, and the write replaced the link itself with a file
    (a ``report.html`` linked to itself, a name ppaloc picks for its output).

    Raises
    ------
    PpalocError
        Naming the link and the fix.
    """
    if leads_into_loop(path):
        raise PpalocError(
            f"cannot write {path}: it is a symbolic link that leads into a loop (links "
            "that lead back to themselves), which writing would replace with a file; "
            "remove the link or point it at a file"
        )


def leads_into_loop(path: str | os.PathLike[str]) -> bool:
    """Whether ``path`` is, or lies under, a loop of symbolic links (the system's ELOOP):
    no file is there to read or write. A path with a NUL is not one (it is refused with
    its own message where it is checked).

    Examples
    --------
    >>> import tempfile
    >>> folder = Path(tempfile.mkdtemp())
    >>> (folder / "a").symlink_to(folder / "a")
    >>> leads_into_loop(folder / "a"), leads_into_loop(folder)
    (True, False)
    """
    try:
        os.stat(path)
    except OSError as exc:
        return exc.errno == errno.ELOOP
    except ValueError:
        return False
    return False


_WRITE_ERRNOS = frozenset({errno.ENOSPC, errno.EDQUOT, errno.EFBIG, errno.EIO})
"""The errors of a write or a flush that name no file: the file being written is meant."""


def _naming(exc: OSError, path: Path) -> OSError:
    """``exc`` naming ``path``, the file being written, where it is a write's error that
    names no file (a full disk) or it names a temporary of ``path``: what the user asked
    for, not ours. Any other error (of the caller's own work in the block) is left as it
    is."""
    name = exc.filename
    if name is None and exc.errno not in _WRITE_ERRNOS:
        return exc
    if name is not None:
        name = Path(os.fsdecode(name))
        ours = name.parent == path.parent and name.name.startswith(f".{path.name}.")
        if not (ours and name.name.endswith(".tmp")):
            return exc
    return OSError(exc.errno, exc.strerror, str(path))


def write_bytes(path: str | os.PathLike, data: bytes | str) -> Path:
    """Write ``data`` (text as UTF-8) to ``path`` atomically, creating its folder."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    with atomic_write(path) as f:
        f.write(data.encode("utf-8") if isinstance(data, str) else data)
    return path


def user_cache(name: str, env: str) -> Path:
    """The cache folder ``name`` of ppaloc: ``$env`` if set, else
    ``$XDG_CACHE_HOME/ppaloc/name`` (``~/.cache/ppaloc/name``). Not created here."""
    explicit = os.environ.get(env)
    if explicit:
        return Path(explicit)
    base = os.environ.get("XDG_CACHE_HOME") or str(Path.home() / ".cache")
    return Path(base) / "ppaloc" / name


# -- folders ---------------------------------------------------------------------------------

_RENAME_EXCHANGE = 2
_AT_FDCWD = -100


def _renameat2() -> Any:
    try:
        fn = ctypes.CDLL(None, use_errno=True).renameat2
    except (OSError, AttributeError):
        return None
    fn.argtypes = [ctypes.c_int, ctypes.c_char_p, ctypes.c_int, ctypes.c_char_p, ctypes.c_uint]
    fn.restype = ctypes.c_int
    return fn


_RENAMEAT2 = _renameat2()


def _exchange(a: Path, b: Path) -> bool:
    """Swap the names ``a`` and ``b`` in one step; False where the system cannot."""
    if _RENAMEAT2 is None:
        return False
    rc = _RENAMEAT2(_AT_FDCWD, os.fsencode(a), _AT_FDCWD, os.fsencode(b), _RENAME_EXCHANGE)
    if rc == 0:
        return True
    err = ctypes.get_errno()
    if err in (errno.EINVAL, errno.ENOSYS, errno.ENOTSUP, errno.EOPNOTSUPP, errno.EXDEV):
        return False  # this file system (or kernel) has no exchange: rename aside instead
    raise OSError(err, f"cannot swap {b} into place: {os.strerror(err)}", str(b))


def _stages(target: Path, role: str) -> list[tuple[Path, int | None]]:
    prefix = f".{target.name}.ppaloc-{role}-"
    found = []
    with contextlib.suppress(OSError), os.scandir(target.parent) as entries:
        for entry in entries:
            if entry.name.startswith(prefix):
                found.append((Path(entry.path), _owner_pid(entry.name[len(prefix) :])))
    return found


def _fsync_dir(folder: Path) -> None:
    with contextlib.suppress(OSError):
        fd = os.open(folder, os.O_RDONLY)
        try:
            os.fsync(fd)
        finally:
            os.close(fd)


def recover_folder(target: str | os.PathLike) -> None:
    """Finish what a killed transaction on ``target`` left: restore the old folder if the
    new one never arrived, and delete the staging folders of dead processes."""
    target = Path(target)
    if not target.parent.is_dir():
        return
    for old, pid in _stages(target, "old"):
        if pid is None or _alive(pid):
            continue
        if not os.path.lexists(target):
            os.rename(old, target)
        else:
            shutil.rmtree(old, ignore_errors=True)
    for stage, pid in _stages(target, "new"):
        if pid is not None and not _alive(pid):
            shutil.rmtree(stage, ignore_errors=True)


def check_replaceable_folder(
    out: str | os.PathLike,
    *,
    owned: Callable[[Path, str], bool],
    marked: Callable[[Path], bool],
    markers: str,
    writer: str,
    kind: str,
    error: type[PpalocError] = PpalocError,
    nested: bool = False,
) -> None:
    """Refuse an ``--out`` that a command replaces whole when a user's files may be in it.

    The one check of every command that writes a folder whole (results, sweeps, C++ runs),
    before any work: first what a killed transaction on the folder left is finished
    (:func:`recover_folder`); then an absent folder is fine; the current folder (or one
    holding it), a file, a folder holding a name ``owned(folder, name)`` rejects, or a
    non-empty folder without ``marked(folder)`` (not an earlier one) raise ``error``.
    With ``nested``, every entry below an owned subfolder is asked too, as its path
    relative to the folder (``owned(folder, "arrays/x.npz")``): a user's file inside
    ``arrays/`` would go with the folder as surely as one at the top.
    ``markers`` names what marks an earlier folder, ``writer`` who writes these folders
    ("ppaloc", "a sweep") and ``kind`` what the folder is ("results folder"), for the
    one-line messages. Links are resolved before ``..`` (the folder the path names).
    """
    given, real = out, Path(os.path.realpath(out))
    recover_folder(real)
    if not real.exists():
        return
    here = Path.cwd().resolve()
    if real.resolve() == here or real.resolve() in here.parents:
        raise error(
            f"--out {given} is the current folder or holds it, and a {kind} is replaced "
            "whole; give a new folder name"
        )
    if not real.is_dir():
        raise error(f"--out {given} is a file; give a folder for the {kind}")
    names = os.listdir(real)
    foreign = sorted(n for n in names if not owned(real, n))
    if nested and not foreign:
        foreign = [rel for rel in _entries_below(real, sorted(names)) if not owned(real, rel)][:1]
    if foreign:
        raise error(
            f"--out {given} holds {foreign[0]!r}, which {writer} did not write, and a "
            f"{kind} is replaced whole; give a new folder or an earlier {kind}"
        )
    if names and not marked(real):
        raise error(
            f"--out {given} is not empty and holds no {markers}, so it is not an earlier "
            f"{kind}, and a {kind} is replaced whole; give a new folder"
        )


def _entries_below(folder: Path, names: Iterable[str]) -> Iterator[str]:
    """Every entry below the subfolders ``names`` of ``folder`` (links not followed), as a
    path relative to ``folder`` with ``/``, parents before their contents, names sorted."""
    for name in names:
        sub = folder / name
        if sub.is_symlink() or not sub.is_dir():
            continue
        try:
            inside = sorted(os.listdir(sub))
        except OSError:
            continue
        for entry in inside:
            yield f"{name}/{entry}"
        yield from _entries_below(folder, (f"{name}/{entry}" for entry in inside))


def _link_tree(source: Path, dest: Path, keep: Callable[[str], bool]) -> None:
    """Recreate the top-level entries of ``source`` that ``keep`` accepts in ``dest``, files
    as hard links (cheap, and safe: ppaloc replaces files, never rewrites them in place)."""
    for entry in sorted(os.scandir(source), key=lambda e: e.name):
        if not keep(entry.name):
            continue
        if entry.is_dir(follow_symlinks=False):
            shutil.copytree(entry.path, dest / entry.name, symlinks=True, copy_function=_link)
        else:
            _link(entry.path, dest / entry.name)


def _link(src: str, dst: str | Path) -> None:
    if os.path.islink(src):
        os.symlink(os.readlink(src), dst)
        return
    try:
        os.link(src, dst)
    except OSError:
        shutil.copy2(src, dst)


@contextmanager
def _transaction(target: Path, keep: Callable[[str], bool] | None) -> Iterator[Path]:
    # the folder meant, links followed before "..", as the system resolves the path (a
    # textual "lnk/.." would be the current folder); a link itself is kept, its folder replaced
    target = Path(os.path.realpath(target))
    if os.path.lexists(target) and not target.is_dir():
        raise NotADirectoryError(errno.ENOTDIR, "not a folder", str(target))
    recover_folder(target)
    token = f"{os.getpid()}-{secrets.token_hex(4)}"
    stage = target.parent / f".{target.name}.ppaloc-new-{token}"
    try:
        stage.mkdir()
    except OSError as exc:
        if exc.errno not in (errno.EACCES, errno.EPERM, errno.EROFS, errno.ENOENT, errno.ENOTDIR):
            raise
        raise PpalocError(
            f"cannot write {target}: its folder {target.parent} is not a writable folder "
            f"({exc.strerror}); give a location you can write to"
        ) from None
    try:
        if keep is not None and target.is_dir():
            _link_tree(target, stage, keep)
        try:
            yield stage
        except OSError as exc:  # a full disk names the file in target, not in our stage
            named = _in_target(exc, stage, target)
            if named is exc:
                raise
            raise named from exc
        _fsync_dir(stage)
        # Ctrl-C is held from here: once the new folder is in, it is the command's result,
        # and the old contents must not be left under a hidden name
        with _sigint_held() as interrupted:
            try:
                if not target.exists():
                    os.rename(stage, target)
                elif _exchange(stage, target):
                    pass  # the stage name now holds the old contents, deleted below
                else:
                    aside = target.parent / f".{target.name}.ppaloc-old-{token}"
                    os.rename(target, aside)
                    os.rename(stage, target)
                    stage = aside
                _fsync_dir(target.parent)
            finally:
                shutil.rmtree(stage, ignore_errors=True)
        if interrupted and _in_stage(target):
            raise KeyboardInterrupt  # a folder inside another's stage: that one is not done
        if interrupted:  # this folder is done; a command writing more asks held_interrupt()
            _HELD.append(True)
    finally:
        shutil.rmtree(stage, ignore_errors=True)


def _in_target(exc: OSError, stage: Path, target: Path) -> OSError:
    """``exc`` naming the file of ``target`` that its path in ``stage`` becomes."""
    if exc.filename is None:
        return exc
    name = Path(os.fsdecode(exc.filename))
    if not name.is_relative_to(stage):
        return exc
    return OSError(exc.errno, exc.strerror, str(target / name.relative_to(stage)))


def _in_stage(path: Path) -> bool:
    """Whether ``path`` lies inside the staging folder of another transaction (a matrix
    run's dataset folders inside the matrix's stage)."""
    return any(".ppaloc-new-" in parent.name for parent in path.parents)


_HELD: list[bool] = []
"""Ctrl-C held by a finished transaction (:func:`held_interrupt`)."""


def held_interrupt() -> bool:
    """Whether a Ctrl-C came while a finished folder transaction held it, since the last
    call (which clears it). The folder is the command's result and stays; a command that
    writes one folder after another (a sweep's cells) stops after the one it wrote, which
    otherwise lost the Ctrl-C and ran on to its end."""
    came = bool(_HELD)
    _HELD.clear()
    return came


@contextmanager
def _sigint_held() -> Iterator[list[bool]]:
    """Hold Ctrl-C (SIGINT) back during the block; the list yielded is non-empty once one
    came. Only the main thread can set a handler; elsewhere the block runs as it is."""
    came: list[bool] = []
    if threading.current_thread() is not threading.main_thread():
        yield came
        return
    previous = signal.signal(signal.SIGINT, lambda *_: came.append(True))
    try:
        yield came
    finally:
        signal.signal(signal.SIGINT, signal.default_int_handler if previous is None else previous)


def new_folder(
    target: str | os.PathLike, *, carry: Iterable[str] = ()
) -> AbstractContextManager[Path]:
    """A context manager: an empty staging folder that replaces ``target`` whole when the
    block ends cleanly (``target`` is created if absent; its parent must exist).

    ``carry`` names top-level entries of the current ``target`` to keep (linked into the
    stage before the block). On an exception the stage is deleted and ``target`` stays as
    it was.

    Examples
    --------
    >>> import pathlib, tempfile
    >>> out = pathlib.Path(tempfile.mkdtemp()) / "run"
    >>> with new_folder(out) as stage:
    ...     _ = (stage / "a.txt").write_text("new")
    >>> sorted(p.name for p in out.parent.iterdir()), (out / "a.txt").read_text()
    (['run'], 'new')
    """
    names = set(carry)
    return _transaction(Path(target), (lambda n: n in names) if names else None)


def update_folder(target: str | os.PathLike) -> AbstractContextManager[Path]:
    """A context manager: a staging copy of ``target`` (its files hard-linked) to change,
    which replaces ``target`` whole when the block ends cleanly."""
    return _transaction(Path(target), lambda name: True)
