"""A SCAMP-5d program as a C++ programmer gives it: source files, include folders, defines.

:func:`make_project` checks every input before anything is compiled (a missing file, a
folder given as a source, a source given twice, an include folder that is not one, a bad
``-D``), each refused in one line naming it; :func:`project_headers` finds the project's
own headers that the sources include (``#include "x.hpp"`` or ``<x.hpp>``, followed
through the headers), so the source scan covers them and the build cache keys on them.
"""

from __future__ import annotations

import os
import re
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

from ppaloc.errors import PpalocError

__all__ = ["HEADER_SUFFIXES", "Project", "make_project", "parse_define", "project_headers"]

#: What counts as a header beside a source (keyed in the build cache even when the
#: include scan cannot see its ``#include``, e.g. one behind a macro).
HEADER_SUFFIXES = frozenset({".h", ".hh", ".hpp", ".hxx", ".inc"})

#: The most headers the include scan follows (a guard against an include folder such as
#: /usr/include given by mistake).
MAX_HEADERS = 2000

_DEFINE = re.compile(r"[A-Za-z_]\w*")
_INCLUDE = re.compile(r'^[ \t]*#[ \t]*include[ \t]*(?:"([^"\n]+)"|<([^>\n]+)>)', re.M)


@dataclass(frozen=True)
class Project:
    """A checked program: ``sources`` (the first names the program), ``include_dirs``
    (``-I``, searched in order after the shim's own headers) and ``defines`` (``-D``, as
    ``NAME`` or ``NAME=VALUE``)."""

    sources: tuple[Path, ...]
    include_dirs: tuple[Path, ...] = ()
    defines: tuple[str, ...] = ()

    @property
    def name(self) -> str:
        """The program's name in messages: its first source file's."""
        return self.sources[0].name


def parse_define(text: str) -> str:
    """A ``-D`` value checked: ``NAME``, ``NAME=VALUE`` (``NAME=`` defines it empty).

    >>> parse_define("THRESHOLD=30"), parse_define("DEBUG")
    ('THRESHOLD=30', 'DEBUG')
    """
    name, _, value = str(text).partition("=")
    if not _DEFINE.fullmatch(name) or any(c in value for c in "\n\r\0"):
        raise PpalocError(
            f"-D {text!r} must be NAME or NAME=VALUE with NAME a C++ identifier and VALUE "
            "on one line, e.g. -D THRESHOLD=30 or -DDEBUG"
        )
    return str(text)


def make_project(
    sources: str | os.PathLike[str] | Sequence[str | os.PathLike[str]],
    include_dirs: Sequence[str | os.PathLike[str]] = (),
    defines: Sequence[str] = (),
) -> Project:
    """Check a program's inputs and gather them; one line naming the first bad one.

    Raises
    ------
    PpalocError
        A source that is missing, a folder or given twice; an include folder that is
        missing or a file; a ``-D`` that is not ``NAME[=VALUE]``.
    """
    if isinstance(sources, str | os.PathLike):
        sources = [sources]
    paths = [Path(s) for s in sources]
    if not paths:
        raise PpalocError("no program given: name its .cpp file(s), e.g. ppaloc cpp run main.cpp")
    seen: dict[Path, Path] = {}
    for path in paths:
        if path.is_dir():
            raise PpalocError(
                f"{path} is a folder, not a C++ source: give its .cpp files, and its header "
                f"folders with -I {path}"
            )
        if path.exists() and not path.is_file():  # read by the compiler, a pipe would block
            raise PpalocError(
                f"the program source {path} is not a regular file (a pipe, device or socket); "
                "give a C++ source file"
            )
        if not path.is_file():
            raise PpalocError(f"the program source {path} does not exist")
        key = path.resolve()
        if key in seen:
            raise PpalocError(f"{path} is given twice (as {seen[key]}): give each source once")
        seen[key] = path
    folders = [Path(d) for d in include_dirs]
    for folder in folders:
        if not folder.is_dir():
            what = "is a file" if folder.exists() else "does not exist"
            raise PpalocError(f"-I {folder}: the include folder {what}; give a folder of headers")
    return Project(tuple(paths), tuple(folders), tuple(parse_define(d) for d in defines))


def _resolve(name: str, quoted: bool, here: Path, folders: Sequence[Path]) -> Path | None:
    """The project file ``#include`` of ``name`` reads, or None (a system or shim header)."""
    for folder in ([here] if quoted else []) + list(folders):
        candidate = folder / name
        if candidate.is_file():
            return candidate
        if candidate.exists() and not candidate.is_dir():  # the compiler would wait on a pipe
            shown = f'"{name}"' if quoted else f"<{name}>"
            raise PpalocError(
                f"#include {shown} names {candidate}, which is not a regular file (a pipe, "
                "device or socket): the compiler would wait on it; replace it with the header "
                "file"
            )
    return None


def _refuse_backslash(name: str, quoted: bool, path: Path, line: int, project: Project) -> None:
    """Refuse ``#include "..\\inc\\x.hpp"`` where ``../inc/x.hpp`` is a project file: the
    device's Windows toolchain takes ``\\`` as a folder separator, g++ here as part of the
    name (it would say only that no such file exists)."""
    fixed = name.replace("\\", "/")
    if _resolve(fixed, quoted, path.parent, project.include_dirs) is None:
        return
    shown, fixed = (f'"{name}"', f'"{fixed}"') if quoted else (f"<{name}>", f"<{fixed}>")
    raise PpalocError(
        f"{path}:{line}: #include {shown} separates folders with \\, which only a Windows "
        f"compiler reads as a folder separator (g++ here takes it as part of the file "
        f"name): write #include {fixed}"
    )


def project_headers(project: Project, shadowed: frozenset[str] = frozenset()) -> list[Path]:
    """The project's own headers, in the order first included: what the sources include
    from their own folders or the ``-I`` folders, followed through those headers.

    ``<name>`` of a name in ``shadowed`` (the shim's headers, searched before the ``-I``
    folders) is the shim's, even where a project folder holds a file of that name (the
    vendor's ``scamp5.hpp`` in a copied SDK folder); ``"name"`` still finds a copy beside
    the including file first, as the compiler does.

    A header the compiler reaches only through a macro (``#include HEADER``) is not seen:
    the build cache also keys on every header beside a source (:data:`HEADER_SUFFIXES`).
    """
    found: list[Path] = []
    seen = {p.resolve() for p in project.sources}
    todo = list(project.sources)
    while todo:
        path = todo.pop(0)
        try:
            text = path.read_text(encoding="utf-8", errors="replace")
        except OSError:
            continue
        for m in _INCLUDE.finditer(text):
            name, quoted = (m.group(1), True) if m.group(1) else (m.group(2), False)
            if not quoted and name in shadowed:
                continue
            header = _resolve(name, quoted, path.parent, project.include_dirs)
            if header is None and "\\" in name:
                _refuse_backslash(name, quoted, path, text[: m.start()].count("\n") + 1, project)
            if header is None and name.replace("\\", "/").rsplit("/", 1)[-1] == "scamp7.hpp":
                line = text[: m.start()].count("\n") + 1
                shown = f'"{name}"' if quoted else f"<{name}>"
                raise PpalocError(
                    f"{path}:{line}: #include {shown} is the SCAMP-7 device header: ppaloc "
                    "simulates the SCAMP-5d and runs its "
                    "programs (#include <scamp5.hpp>); a SCAMP-7 program is not supported"
                )
            if header is None or header.resolve() in seen:
                continue
            seen.add(header.resolve())
            found.append(header)
            todo.append(header)
            if len(found) >= MAX_HEADERS:
                return found
    return found
