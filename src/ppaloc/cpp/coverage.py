"""How much of a SCAMP-5d header set the shim covers: the declared ``scamp5_*``/``vs_*``
names (functions, constants, types, namespaces; any case) the shim lacks.

The headers are the user's own copy, read at run time (``benchmarks/cpp_coverage.py``);
nothing of them is kept here. Declarations are found by pattern, not by a C++ parser: a
``#define`` (not an include guard), a ``namespace``, ``struct``/``class``/``enum``/
``union``, ``typedef`` or ``using`` name, an enumerator, and a name written after a type
(``T name``, ``T *name``, ``T*name``) and followed by ``(``, ``=``, ``;`` or ``[`` (a
function or a variable); a block under
``#ifdef ..._PRIVATE`` is the library's own and left out.
"""

from __future__ import annotations

import re
from dataclasses import dataclass
from importlib import resources
from pathlib import Path

from ppaloc.cpp.build import strip_code
from ppaloc.cpp.project import HEADER_SUFFIXES
from ppaloc.cpp.shimgen import constants_header, kernel_macros, macros_header
from ppaloc.errors import PpalocError

__all__ = ["Coverage", "HeaderFolderError", "coverage", "declared_names", "shim_names"]

_PREFIX = r"(?:[Ss][Cc][Aa][Mm][Pp]5|[Vv][Ss])_\w+"
_NAME = re.compile(rf"\b({_PREFIX})")
# Words that precede a call, not a declaration.
_NOT_TYPES = frozenset(
    "return else case new delete throw sizeof if while for switch do goto typedef".split()
)


class HeaderFolderError(PpalocError):
    """A header folder that does not exist or holds no C/C++ header."""


def _headers(folders: list[Path]) -> dict[str, Path]:
    """Header file name -> file, the first folder's winning as on a compiler's ``-I`` path."""
    found: dict[str, Path] = {}
    for folder in folders:
        if not folder.is_dir():
            raise HeaderFolderError(f"{folder}: no such folder; give the device's include folder")
        for f in sorted(folder.iterdir()):
            if f.suffix in HEADER_SUFFIXES and f.is_file():
                found.setdefault(f.name, f)
    return found


def _reached(folders: list[Path]) -> list[Path]:
    """Every header of the first folder and those its ``#include`` lines reach through
    the folders (searched in order, by file name)."""
    by_name = _headers(folders)
    first = [f for f in by_name.values() if f.parent == folders[0]]
    if not first:
        raise HeaderFolderError(f"{folders[0]}: holds no C or C++ header (.h, .hpp, ...)")
    seen: dict[Path, None] = {}
    todo = list(first)
    while todo:
        f = todo.pop(0)
        if f in seen:
            continue
        seen[f] = None
        text = f.read_text(encoding="utf-8", errors="replace")
        for inc in re.findall(r'^\s*#\s*include\s*[<"]([^>"]+)[>"]', text, flags=re.M):
            hit = by_name.get(Path(inc).name)
            if hit is not None and hit not in seen:
                todo.append(hit)
    return sorted(seen)


def _public(code: str) -> str:
    """``code`` without its ``#ifdef ..._PRIVATE`` blocks (the device library's own)."""
    out: list[str] = []
    depth = 0  # nesting inside a private block; 0 outside
    for line in code.splitlines():
        directive = re.match(r"\s*#\s*(\w+)\s*(\w*)", line)
        word = directive.group(1) if directive else ""
        if depth:
            depth += word in ("if", "ifdef", "ifndef")
            depth -= word == "endif"
        elif word == "ifdef" and directive and "PRIVATE" in directive.group(2):
            depth = 1
        else:
            out.append(line)
    return "\n".join(out)


def _declared(code: str) -> set[str]:
    """The prefixed names one header's code (comments and strings blanked) declares,
    outside its private blocks."""
    code = _public(code)
    guards = set(re.findall(r"#\s*ifndef\s+(\w+)", code))
    names: set[str] = set()
    for name, value in re.findall(r"^[ \t]*#[ \t]*define[ \t]+(\w+)([^\n]*)", code, re.M):
        if not (name in guards and not value.strip()):
            names.add(name)
    names.update(re.findall(r"\b(?:namespace|struct|class|union|enum)\s+(\w+)", code))
    names.update(re.findall(r"\busing\s+(\w+)\s*=", code))
    names.update(re.findall(r"\b(\w+)\s*;", "\n".join(re.findall(r"\btypedef\b[^;]*;", code))))
    names.update(re.findall(r"\(\s*\*\s*(\w+)\s*\)\s*\(", code))
    for body in re.findall(r"\benum\b[^{;]*\{([^}]*)\}", code):
        names.update(re.findall(r"(?:^|,)\s*(\w+)", body))
    # a type, then the name: after a space, or after a * or & with none (``T*name(``)
    for m in re.finditer(rf"([\w*&>]+?)(?:\s+[*&]*|[*&]+)\s*({_PREFIX})\s*[(=;\[]", code):
        if m.group(1) not in _NOT_TYPES:
            names.add(m.group(2))
    return {n for n in names if re.fullmatch(_PREFIX, n)}


def declared_names(folders: list[Path]) -> dict[str, str]:
    """Each declared ``scamp5_*``/``vs_*`` name (any case) -> the header that declares it.

    Parameters
    ----------
    folders
        The device's include folders, searched in order: the headers of the first and
        those they include (``include/s5d_m0`` then ``include`` for the device library).

    Raises
    ------
    HeaderFolderError
        A folder that does not exist, or a first folder with no header.
    """
    out: dict[str, str] = {}
    for f in _reached(folders):
        for name in sorted(_declared(strip_code(f.read_text(encoding="utf-8", errors="replace")))):
            out.setdefault(name, f.name)
    return out


def shim_names() -> frozenset[str]:
    """Every prefixed name the shim's code defines or uses (its headers, comments left
    out, and the generated ones) and every kernel function."""
    include = resources.files("ppaloc.cpp").joinpath("include")
    texts = [h.read_text(encoding="utf-8") for h in include.iterdir() if h.name.endswith(".hpp")]
    texts += [constants_header(), macros_header()]
    code = "\n".join(strip_code(t) for t in texts)
    return frozenset(set(_NAME.findall(code)) | set(kernel_macros()))


@dataclass(frozen=True)
class Coverage:
    """The declared names of a header set, split by whether the shim has them."""

    #: Declared name -> its header.
    declared: dict[str, str]
    #: Declared names the shim has, sorted.
    covered: list[str]
    #: Declared names the shim lacks, sorted.
    missing: list[str]

    def summary(self) -> str:
        """``covered / total`` with the share, one line."""
        n, total = len(self.covered), len(self.declared)
        return f"{n} / {total} declared scamp5_*/vs_* names covered ({100 * n / total:.0f}%)"


def coverage(folders: list[Path]) -> Coverage:
    """Compare the names the headers in ``folders`` declare (:func:`declared_names`) with
    the shim's (:func:`shim_names`)."""
    declared = declared_names(folders)
    if not declared:
        raise HeaderFolderError(
            f"{folders[0]}: its headers declare no scamp5_*/vs_* name; give the SCAMP-5d "
            "include folder"
        )
    have = shim_names()
    covered = sorted(n for n in declared if n in have)
    missing = sorted(n for n in declared if n not in have)
    return Coverage(declared, covered, missing)
