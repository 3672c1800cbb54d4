"""The dataset spec string: ``KIND:PATH[?key=value&...]``.

One string names a dataset on the command line, e.g.
``nordland:DATA/nordland-64x32?ref=summer&query=winter&tolerance=2``. This module only parses
and type-checks it against the keys each kind declares; the loaders live elsewhere.

Grammar
-------
- ``KIND`` is the text before the first ``:`` (case-insensitive). A kind that needs no path
  may be written alone (``synthetic``) or with an empty path (``synthetic:?places=100``).
- ``PATH`` is everything up to the first ``?``; kinds with two traversals take two paths
  separated by a comma (``folder:REF_DIR,QUERY_DIR``), so a path cannot contain ``,`` or ``?``.
- The query is ``&``-separated ``key=value`` pairs; each key at most once; unknown keys are
  an error that lists the valid ones.
"""

from __future__ import annotations

import math
import os
import re
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from ppaloc.errors import DatasetSpecError

__all__ = [
    "COMMON_KEYS",
    "INT_LIMIT",
    "MAX_TEXT",
    "MAX_TOLERANCE",
    "DatasetSpec",
    "Key",
    "parse_bool",
    "parse_spec",
]


INT_LIMIT = 2**63 - 1
"""Largest magnitude of any integer key (one a 64-bit array index can hold)."""


_INT = re.compile(r"[+-]?[0-9]+")
_FLOAT = re.compile(r"[+-]?([0-9]+\.?[0-9]*|\.[0-9]+)([eE][+-]?[0-9]+)?|[+-]?(inf|nan)", re.I)
"""Plain decimal numbers only (Python's int/float also take ``2_0``, ``０`` and hex floats)."""


def _show(text: str, limit: int = 80) -> str:
    """``repr(text)``, cut to about ``limit`` characters (a message never echoes a huge value)."""
    shown = repr(text)
    return shown if len(shown) <= limit else f"{shown[: limit - 20]}...' ({len(text)} chars)"


def _range_words(noun: str, minimum: float | None, maximum: float | None) -> str:
    fmt = (lambda v: str(int(v))) if noun == "an integer" else (lambda v: f"{v:g}")
    if minimum is not None and maximum is not None:
        return f"{noun} in [{fmt(minimum)}, {fmt(maximum)}]"
    if minimum is not None:
        return f"{noun} >= {fmt(minimum)}"
    if maximum is not None:
        return f"{noun} <= {fmt(maximum)}"
    return noun


def _parse_int(text: str, minimum: int | None, maximum: int | None) -> int:
    words = _range_words("an integer", minimum, maximum)
    text = text.strip()
    if len(text) > 40 or not _INT.fullmatch(text):  # no key takes 40 digits
        raise ValueError(words)
    try:
        value = int(text, 10)
    except ValueError:
        raise ValueError(words) from None
    if abs(value) > INT_LIMIT:
        raise ValueError(
            _range_words("an integer", minimum, INT_LIMIT if maximum is None else maximum)
        )
    if (minimum is not None and value < minimum) or (maximum is not None and value > maximum):
        raise ValueError(words)
    return value


def _parse_float(text: str, minimum: float | None, maximum: float | None) -> float:
    words = _range_words("a number", minimum, maximum)
    text = text.strip()
    if len(text) > 40 or not _FLOAT.fullmatch(text):
        raise ValueError(words)
    try:
        value = float(text)
    except ValueError:
        raise ValueError(words) from None
    if not math.isfinite(value):
        raise ValueError("a finite " + words.removeprefix("a "))
    if (minimum is not None and value < minimum) or (maximum is not None and value > maximum):
        raise ValueError(words)
    return value


_TRUE = {"1", "true", "yes", "on"}
_FALSE = {"0", "false", "no", "off"}


def parse_bool(text: str) -> bool:
    """Return the truth value of ``1/0``, ``true/false``, ``yes/no`` or ``on/off``."""
    low = text.strip().lower()
    if low in _TRUE:
        return True
    if low in _FALSE:
        return False
    raise ValueError("1 or 0 (or true/false)")


@dataclass(frozen=True)
class Key:
    """One ``key=value`` a dataset kind accepts.

    Parameters
    ----------
    kind : {"int", "float", "bool", "str", "choice"}
        How the value text is parsed.
    default : Any
        The value when the key is absent (``None``: not set).
    help : str
        One line for the documentation and error messages.
    minimum : int or float, optional
        Smallest accepted value for ``int`` and ``float`` keys.
    maximum : int or float, optional
        Largest accepted value (a documented bound where the value drives memory or
        time; integers are always bounded by :data:`INT_LIMIT`).
    choices : tuple of str
        The accepted values of a ``choice`` key (compared lower-case).
    """

    kind: str
    default: Any
    help: str
    minimum: float | None = None
    choices: tuple[str, ...] = ()
    maximum: float | None = None

    def parse(self, text: str) -> Any:
        """Return the typed value of ``text``; raise ``ValueError`` naming what is expected."""
        if self.kind == "int":
            low = None if self.minimum is None else int(self.minimum)
            return _parse_int(text, low, None if self.maximum is None else int(self.maximum))
        if self.kind == "float":
            return _parse_float(text, self.minimum, self.maximum)
        if self.kind == "bool":
            return parse_bool(text)
        if self.kind == "choice":
            low = text.strip().lower()
            if low not in self.choices:
                raise ValueError("one of " + ", ".join(self.choices))
            return low
        if not text:
            raise ValueError("a non-empty value")
        if "\0" in text or len(text) > MAX_TEXT:
            raise ValueError(f"text of at most {MAX_TEXT} characters without NUL")
        return text


MAX_TEXT = 4096
"""Longest text value (a file name) a key accepts."""

MAX_NAME = 255
"""Longest name between two slashes in a path, in bytes (the file system's NAME_MAX)."""

MAX_SPEC = 16384
"""Longest spec string accepted (paths included)."""

MAX_TOLERANCE = 1000
"""Largest ``tolerance``: each accepted set grows by 2 x tolerance frames."""

COMMON_KEYS: dict[str, Key] = {
    "tolerance": Key(
        "int",
        None,
        "accepted distance to the true reference, in frames",
        0,
        maximum=MAX_TOLERANCE,
    ),
    "soft_tolerance": Key(
        "int",
        None,
        "soft ground truth: also not wrong within this many frames (>= tolerance)",
        0,
        maximum=MAX_TOLERANCE,
    ),
    "same_place": Key(
        "choice",
        "auto",
        "close the accepted sets over the same-place groups: auto (the kind's rule), "
        "images (still frames of both traversals), reference-images (of the reference "
        "only), positions, off",
        choices=("auto", "images", "reference-images", "positions", "off"),
    ),
    "start": Key("int", None, "first frame (or place) kept", 0),
    "stop": Key("int", None, "frame (or place) where the selection stops (exclusive)", 1),
    "step": Key("int", 1, "keep every step-th frame", 1),
    "patch_norm": Key(
        "int",
        None,
        "patch-normalise every frame in PxP tiles at native resolution",
        2,
        maximum=4096,
    ),
}
"""Keys every kind accepts. ``tolerance`` has a per-kind default (see the loaders)."""


@dataclass(frozen=True)
class DatasetSpec:
    """A parsed dataset spec.

    Attributes
    ----------
    kind : str
        Lower-case kind, e.g. ``"nordland"``.
    paths : tuple of Path
        Zero, one or two paths, as the kind requires.
    options : Mapping[str, Any]
        Every key the kind accepts, typed, with defaults filled in.
    given : frozenset of str
        The keys the user wrote (to tell a default from an explicit value).
    text : str
        The original spec string, for messages.
    """

    kind: str
    paths: tuple[Path, ...]
    options: Mapping[str, Any] = field(default_factory=dict)
    given: frozenset[str] = frozenset()
    text: str = ""


@dataclass(frozen=True)
class KindSchema:
    """What a kind accepts: how many paths, which keys, an example for messages."""

    n_paths: tuple[int, ...]
    keys: Mapping[str, Key]
    example: str


def _refuse_whole_path(text: str, rest: str) -> None:
    """Refuse a spec whose path is one file or folder with ``,`` or ``?`` in its name (a
    folder ``a,b``), which the spec's syntax cuts in two: it was refused as a missing
    folder ``a``, or ``?d`` read as a key without a value, while the folder was there."""
    cuts = [i for i, c in enumerate(rest) if c == "?"]
    for whole in [rest[:i].strip() for i in cuts] + [rest.strip()]:
        # os.path.exists: a name too long for the system is no path (Path.exists raises)
        if ("," in whole or "?" in whole) and os.path.exists(os.path.expanduser(whole)):
            raise DatasetSpecError(
                f"dataset spec {_show(text)}: {_show(whole)} is one path, but a spec reads ',' "
                "as the cut between two paths and '?' as the start of its keys, so no path in "
                "a spec can hold them; give a link to it whose name has neither"
            )


def parse_spec(
    text: str,
    schemas: Mapping[str, KindSchema],
    path_check: Callable[[str], None] | None = None,
) -> DatasetSpec:
    """Parse ``text`` against the kinds in ``schemas``.

    Parameters
    ----------
    text : str
        The spec, e.g. ``"folder:ref,query?tolerance=1"``.
    schemas : Mapping[str, KindSchema]
        Kind name -> accepted path count and keys (common keys are added here).
    path_check : callable, optional
        Called with each path text; may raise ``DatasetSpecError``.

    Returns
    -------
    DatasetSpec

    Raises
    ------
    DatasetSpecError
        Naming the bad part of the spec and the fix.
    """
    if not isinstance(text, str):  # a Path, bytes or a number is not a spec, nor empty
        raise DatasetSpecError(
            f"a dataset spec is a str, got {text!r:.60}: write KIND:PATH[?key=value&...], e.g. "
            "synthetic:?places=500&query=winter or folder:PATH"
        )
    if not text.strip():
        raise DatasetSpecError(
            "empty dataset spec: write KIND:PATH[?key=value&...], e.g. "
            "synthetic:?places=500&query=winter"
        )
    if len(text) > MAX_SPEC:
        raise DatasetSpecError(
            f"dataset spec of {len(text)} characters is too long: at most {MAX_SPEC}"
        )
    if "\0" in text:
        raise DatasetSpecError(
            f"dataset spec {_show(text)} holds a NUL character: remove it (no path can hold one)"
        )
    kinds = ", ".join(sorted(schemas))
    kind_text, sep, rest = text.strip().partition(":")
    kind = kind_text.strip().lower()
    if kind not in schemas:
        if not sep:
            raise DatasetSpecError(
                f"dataset spec {_show(text)} has no kind: write KIND:PATH[?key=value&...] "
                f"with KIND one of {kinds}"
            )
        raise DatasetSpecError(
            f"unknown dataset kind {_show(kind_text)} in {_show(text)}: use one of {kinds}"
        )
    schema = schemas[kind]
    path_text, _, query = rest.partition("?")
    path_text = path_text.strip()
    parts = [p.strip() for p in path_text.split(",")] if path_text else []
    if not all(os.path.exists(os.path.expanduser(p)) for p in parts) or "?" in rest:
        _refuse_whole_path(text, rest)
    if len(parts) not in schema.n_paths:
        want = " or ".join(str(n) for n in schema.n_paths)
        raise DatasetSpecError(
            f"dataset spec {_show(text)}: kind {kind!r} takes {want} path(s), got {len(parts)}; "
            f"e.g. {schema.example}"
        )
    if any(not p for p in parts):
        raise DatasetSpecError(
            f"dataset spec {_show(text)} has an empty path; e.g. {schema.example}"
        )
    for p in parts:
        longest = max((len(part.encode("utf-8", "replace")) for part in Path(p).parts), default=0)
        if longest > MAX_NAME:
            raise DatasetSpecError(
                f"dataset spec {_show(text)}: a path has a name of {longest} bytes between "
                f"slashes; at most {MAX_NAME}"
            )
    if path_check is not None:
        for p in parts:
            path_check(p)
    keys = {**COMMON_KEYS, **schema.keys}
    options: dict[str, Any] = {name: key.default for name, key in keys.items()}
    given: set[str] = set()
    for item in query.split("&") if query.strip() else []:
        name, eq, value = item.partition("=")
        name = name.strip().lower()
        if not eq or not name:
            raise DatasetSpecError(
                f"dataset spec {_show(text)}: {_show(item)} is not key=value; "
                "separate pairs with '&'"
            )
        if name not in keys:
            raise DatasetSpecError(
                f"dataset spec {_show(text)}: unknown key {_show(name)} for kind {kind!r}; "
                f"valid keys: {', '.join(sorted(keys))}"
            )
        if name in given:
            raise DatasetSpecError(f"dataset spec {_show(text)}: key {name!r} is given twice")
        try:
            options[name] = keys[name].parse(value)
        except ValueError as exc:
            raise DatasetSpecError(
                f"dataset spec {_show(text)}: key {name!r} must be {exc}, got {_show(value)}"
            ) from None
        given.add(name)
    start, stop = options.get("start"), options.get("stop")
    if start is not None and stop is not None and stop <= start:
        raise DatasetSpecError(
            f"dataset spec {_show(text)}: stop={stop} must be greater than start={start}"
        )
    paths = tuple(Path(p).expanduser() for p in parts)
    return DatasetSpec(kind, paths, options, frozenset(given), text)
