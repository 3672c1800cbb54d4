"""Compiling a SCAMP-5d program against the shim, once per content (a cache by hash).

:func:`check_project` names every API call the simulator does not model, with its file and
line, in every source and included project header, before anything is compiled;
:func:`compile_program` runs the system C++ compiler (``g++``, or ``$CXX``) with
AddressSanitizer, so an out-of-bounds write stops the program at once, and keeps the
executable under a hash of everything that went into it (sources, headers, defines; files
by name, not folder: the same program compiled from a temporary copy hits the cache).
"""

from __future__ import annotations

import hashlib
import os
import re
import shutil
import subprocess
import tempfile
from collections.abc import Sequence
from functools import cache
from importlib import resources
from pathlib import Path

from ppaloc.cpp.project import HEADER_SUFFIXES, Project, make_project, project_headers
from ppaloc.cpp.shimgen import constants_header, kernel_macros, macros_header
from ppaloc.errors import PpalocError
from ppaloc.fileio import user_cache

__all__ = [
    "SHIM_HEADERS",
    "CompileError",
    "UnmodelledCallError",
    "cache_dir",
    "check_project",
    "check_source",
    "compile_program",
    "compiler",
    "known_names",
    "strip_code",
]

#: Compiler flags: C++17, debug lines for messages, AddressSanitizer for bad memory access.
FLAGS = ("-std=c++17", "-O0", "-g", "-fsanitize=address", "-fno-omit-frame-pointer")

# Kernel functions of the SCAMP-5d library, refused unless the simulator has them (a name
# the simulator has, e.g. blur since it models diffusion, is in its kernel functions).
_VENDOR_KERNEL_ONLY = (
    "blur", "blurh", "blurv", "blurset", "gauss", "gaussh", "gaussv", "sq", "aout",
    "PROP0", "PROP1", "PROP_R1", "PROP_R2",
)  # fmt: skip


#: The longest message that lists several unmodelled functions on one line.
ONE_LINE = 160


class CompileError(PpalocError):
    """The C++ compiler rejected the program (the message is the compiler's own)."""


class UnmodelledCallError(PpalocError):
    """The program calls a SCAMP-5d function the simulator does not model."""


def compiler() -> str | None:
    """The C++ compiler to use (``$CXX``, else ``g++``; an empty ``$CXX`` is unset, as
    make takes it), or None when there is none."""
    return shutil.which(os.environ.get("CXX") or "g++")


def _no_compiler() -> str:
    """Why there is no compiler, naming what was looked for: ``$CXX`` where it is set."""
    given = os.environ.get("CXX")
    if given:
        return (
            f"$CXX={given!r:.200} is not a program found on PATH; set CXX to a C++ compiler "
            "(g++, clang++, or its full path) or unset it to use g++"
        )
    return "no C++ compiler found (g++); install Debian's g++ package or set $CXX"


def cache_dir() -> Path:
    """Where compiled programs are kept (``$PPALOC_CPP_CACHE``, else the user cache; a
    private folder under the system's temp where that cannot be written)."""
    return user_cache("cpp", "PPALOC_CPP_CACHE")


#: The headers the shim provides (its own and the generated ones): ``<scamp5.hpp>`` is
#: the shim's, whatever a ``-I`` folder holds.
SHIM_HEADERS = frozenset(
    {h.name for h in resources.files("ppaloc.cpp").joinpath("include").iterdir()}
    | {"ppaloc_gen_consts.hpp", "ppaloc_gen_macros.hpp"}
)


def _shim_text() -> str:
    """Every header of the shim (``scamp5.hpp``, ``vs_random.hpp``, ...), in name order."""
    include = resources.files("ppaloc.cpp").joinpath("include")
    headers = sorted(
        (h for h in include.iterdir() if h.name.endswith(".hpp")), key=lambda h: h.name
    )
    return "\n".join(h.read_text(encoding="utf-8") for h in headers)


@cache
def known_names() -> frozenset[str]:
    """Every ``scamp5_*``/``vs_*`` name the shim defines and every kernel function."""
    names = set(re.findall(r"\b((?:scamp5|vs)_\w+)", _shim_text()))
    return frozenset(names | set(kernel_macros()))


def strip_code(text: str) -> str:
    """Comments and string literals blanked out, newlines kept (so lines still count)."""

    def blank(m: re.Match) -> str:
        s = m.group(0)
        if s.startswith(("/", "'")) or s.startswith('"'):
            return re.sub(r"[^\n]", " ", s)
        return s

    pattern = r'//[^\n]*|/\*.*?\*/|"(?:\\.|[^"\\\n])*"|\'(?:\\.|[^\'\\\n])*\''
    return re.sub(pattern, blank, text, flags=re.S)


def _defined_here(code: str) -> set[str]:
    """Names the program defines itself (a function or variable written after a type)."""
    pattern = r"\b[A-Za-z_][\w:<>]*[\s*&]+((?:scamp5|vs)_\w+)\s*(?:\([^;{}]*\)\s*\{|[=;\[])"
    return set(re.findall(pattern, code))


def check_source(text: str, name: str, defined: frozenset[str] = frozenset()) -> None:
    """Refuse a program that calls SCAMP-5d functions the simulator does not model.

    Raises
    ------
    UnmodelledCallError
        Naming every such function at once, sorted by name, each with its lines: one
        function as ``prog.cpp:12: scamp5_foo is a SCAMP-5d function the simulator does not
        model; ...``, several on one line while they fit in :data:`ONE_LINE` characters
        (``prog.cpp: 2 SCAMP-5d functions the simulator does not model: aout (line 9),
        vs_foo (lines 3, 7); ...``), else one a line, separated by commas.

    ``defined`` adds names the program's other files define (:func:`check_project`).
    """
    code = strip_code(text)
    known = known_names() | _defined_here(code) | defined
    found: list[tuple[int, str]] = []
    for m in re.finditer(r"\b((?:scamp5|vs)_\w+)\b(?=\s*\()", code):
        if m.group(1) not in known:
            found.append((m.start(), m.group(1)))
    unmodelled = [n for n in _VENDOR_KERNEL_ONLY if n not in known]
    if unmodelled:
        calls = r"\b(" + "|".join(map(re.escape, unmodelled)) + r")\s*\("
        found += [(m.start(), m.group(1)) for m in re.finditer(calls, code)]
    if not found:
        return
    lines: dict[str, list[int]] = {}
    for at, fn in sorted(found):
        line = code.count("\n", 0, at) + 1
        if line not in lines.setdefault(fn, []):
            lines[fn].append(line)
    see = "docs/cpp.md lists what is modelled"
    if len(lines) == 1:
        ((fn, where),) = lines.items()
        also = "" if len(where) == 1 else f" (also lines {', '.join(map(str, where[1:]))})"
        raise UnmodelledCallError(
            f"{name}:{where[0]}: {fn} is a SCAMP-5d function the simulator does not model"
            f"{also}; {see}"
        )
    items = [
        f"{fn} (line{'s' if len(w) > 1 else ''} {', '.join(map(str, w))})"
        for fn, w in sorted(lines.items())
    ]
    head = f"{name}: {len(items)} SCAMP-5d functions the simulator does not model"
    one = f"{head}: {', '.join(items)}; {see}"
    if len(one) <= ONE_LINE:
        raise UnmodelledCallError(one)
    # one a line, each but the last ending in a comma, so that the CLI's one line (the
    # lines joined by spaces) still separates them
    raise UnmodelledCallError(f"{head} ({see}):\n" + ",\n".join(f"  {i}" for i in items))


def _generated(root: Path) -> Path:
    """The generated headers, written once per content under ``root/gen-HASH``."""
    consts, macros = constants_header(), macros_header()
    digest = hashlib.sha256((consts + macros).encode()).hexdigest()[:16]
    folder = root / f"gen-{digest}"
    if not (folder / "ppaloc_gen_macros.hpp").exists():
        tmp = root / f".gen-{digest}-{os.getpid()}"
        tmp.mkdir(parents=True, exist_ok=True)
        (tmp / "ppaloc_gen_consts.hpp").write_text(consts, encoding="utf-8")
        (tmp / "ppaloc_gen_macros.hpp").write_text(macros, encoding="utf-8")
        try:
            os.rename(tmp, folder)
        except OSError:  # another process got there first
            shutil.rmtree(tmp, ignore_errors=True)
    return folder


# The linker's lines that name a cause ("collect2: error: ld returned 1 exit status" alone
# does not): a symbol missing (main, a function declared and never defined) or defined
# twice, a file it cannot read (a non-source file given as a program).
_LINKER_CAUSES = re.compile(
    r"undefined reference|multiple definition|first defined here|undefined symbol|"
    r"duplicate symbol|file format not recognized|file not recognized|cannot find|"
    r"error adding symbols"
)


def _compiler_message(output: str, limit: int = 12) -> str:
    lines = [ln for ln in output.splitlines() if ln.strip()]
    errors = [ln for ln in lines if "error" in ln or _LINKER_CAUSES.search(ln)]
    shown = (errors or lines)[:limit]
    return "\n".join(shown)


def check_project(project: Project) -> list[Path]:
    """Scan every source and every project header it includes (:func:`check_source`);
    the headers, for the cache key.

    A name one file defines (a helper ``vs_blend`` in ``extra.cpp``) is known in all.
    """
    headers, texts = _read_project(project)
    _check_texts(texts)
    return headers


def _read_project(project: Project) -> tuple[list[Path], list[tuple[Path, str]]]:
    """The project's headers, and the text of every source and header, read once for every
    scan of the build (the unmodelled calls, the frame triggers)."""
    headers = project_headers(project, SHIM_HEADERS)
    texts: list[tuple[Path, str]] = []
    for path in [*project.sources, *headers]:
        try:
            texts.append((path, path.read_text(encoding="utf-8", errors="replace")))
        except OSError as exc:
            raise PpalocError(f"cannot read {path}: {exc.strerror}") from None
    return headers, texts


def _check_texts(texts: Sequence[tuple[Path, str]]) -> None:
    """:func:`check_project`'s scan of texts already read."""
    defined = frozenset().union(*(_defined_here(strip_code(t)) for _, t in texts))
    for path, text in texts:
        check_source(text, str(path), defined)


_TRIGGERS = re.compile(r"\b(?:vs_frame_loop_control|vs_wait_frame_trigger)\s*\(")


def _paced(texts: Sequence[tuple[Path, str]]) -> bool:
    """Whether the program waits for the frame trigger anywhere (``vs_frame_loop_control``
    or ``vs_wait_frame_trigger`` called in a source or a project header): its frames are
    those waits, and ``vs_loop_counter_inc`` only counts. A program that names neither runs
    free, and each ``vs_loop_counter_inc`` ends one of its frames (docs/cpp.md)."""
    return any(_TRIGGERS.search(strip_code(text)) for _, text in texts)


def compile_program(
    source: str | os.PathLike[str] | Sequence[str | os.PathLike[str]] | Project,
    include_dirs: Sequence[str | os.PathLike[str]] = (),
    defines: Sequence[str] = (),
) -> Path:
    """Compile a program against the shim; the executable's path (cached by content).

    Parameters
    ----------
    source : path, sequence of paths or Project
        The program's C++ source file(s), compiled and linked together.
    include_dirs : sequence of paths
        Header folders (``-I``), searched after the shim's own.
    defines : sequence of str
        Macros (``-D``): ``NAME`` or ``NAME=VALUE``.

    Raises
    ------
    PpalocError
        If a file is missing, a source is a folder, an include folder is not one, a define
        is malformed, or there is no C++ compiler.
    UnmodelledCallError
        If a source or an included project header calls SCAMP-5d functions the simulator
        does not model (all named, with that file's name and lines, before compiling).
    CompileError
        With the compiler's own messages (file, line, column) when it does not compile.
    """
    project = source if isinstance(source, Project) else make_project(source, include_dirs, defines)
    headers, texts = _read_project(project)
    _check_texts(texts)
    cxx = compiler()
    if cxx is None:
        raise PpalocError(_no_compiler())
    root = cache_dir()
    try:
        root.mkdir(parents=True, exist_ok=True)
        probe = root / f".probe-{os.getpid()}"
        probe.touch()
        probe.unlink()
    except OSError:  # a read-only home: a private folder under the system's temp
        root = Path(tempfile.gettempdir()) / f"ppaloc-cpp-{os.getuid()}"
        root.mkdir(mode=0o700, exist_ok=True)
    include = resources.files("ppaloc.cpp").joinpath("include")
    gen = _generated(root)
    version = subprocess.run(
        [cxx, "--version"], capture_output=True, text=True, errors="replace"
    ).stdout
    key = hashlib.sha256(
        "\0".join(
            [_shim_text(), (gen / "ppaloc_gen_macros.hpp").read_text(encoding="utf-8"),
             (gen / "ppaloc_gen_consts.hpp").read_text(encoding="utf-8"), " ".join(FLAGS), version,
             _inputs(project, headers)]
        ).encode("utf-8", "surrogateescape")  # a name or -D value of other bytes: its bytes
    ).hexdigest()[:24]  # fmt: skip
    exe = root / f"prog-{key}"
    if exe.exists():
        return exe
    tmp = root / f".prog-{key}-{os.getpid()}"
    cmd = [cxx, *FLAGS, f"-I{include}", f"-I{gen}"]
    cmd += [f"-I{d}" for d in project.include_dirs]
    cmd += [f"-D{d}" for d in project.defines]
    cmd += [f"-DPPA_PACED={int(_paced(texts))}"]  # a function of the sources
    cmd += [*map(str, project.sources), "-o", str(tmp)]
    try:
        done = subprocess.run(cmd, capture_output=True, text=True, errors="replace")
        if done.returncode != 0:
            names = ", ".join(map(str, project.sources))
            raise CompileError(
                f"{names} {'does' if len(project.sources) == 1 else 'do'} not compile:\n"
                f"{_compiler_message(done.stderr + done.stdout)}"
            )
        os.replace(tmp, exe)
    finally:
        tmp.unlink(missing_ok=True)  # a failed or interrupted build leaves nothing
    _prune(root)
    return exe


def _inputs(project: Project, headers: Sequence[Path]) -> str:
    """Everything of the program that goes into its build, for the cache key: each source
    in order, the defines, the headers the sources include and every header beside a
    source (so a changed header builds the program again); files by name and text, not
    folder (the same program compiled from a temporary copy hits the cache). Bytes that are
    not UTF-8 are kept as themselves (``surrogateescape``): two sources that differ in them
    only are two programs."""
    parts = ["sources"]
    for path in project.sources:
        parts += [path.name, path.read_text(encoding="utf-8", errors="surrogateescape")]
    parts += ["defines", *project.defines, "headers"]
    beside = {
        h
        for folder in {p.parent for p in project.sources}
        for h in folder.glob("*")
        if h.suffix in HEADER_SUFFIXES and h.is_file()
    }
    for header in [*headers, *sorted(beside - set(headers))]:
        try:
            parts += [header.name, header.read_text(encoding="utf-8", errors="surrogateescape")]
        except OSError:
            continue
    return "\0".join(parts)


#: Compiled programs kept in the cache (the least recently built beyond this are removed).
KEEP = 64


def _prune(root: Path) -> None:
    def built(p: Path) -> float:
        try:
            return p.stat().st_mtime
        except FileNotFoundError:  # another process pruned it meanwhile
            return 0.0

    progs = sorted(root.glob("prog-*"), key=built, reverse=True)
    for old in progs[KEEP:]:
        old.unlink(missing_ok=True)
