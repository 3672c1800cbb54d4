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
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from ppaloc.errors import DatasetSpecError

__all__ = [
    "COMMON_KEYS",
    "DatasetSpec",
    "Key",
    "parse_bool",
    "parse_spec",
]


def _parse_int(text: str, minimum: int | None) -> int:
    try:
        value = int(text.strip(), 10)
    except ValueError:
        raise ValueError("an integer") from None
    if minimum is not None and value < minimum:
        raise ValueError(f"an integer >= {minimum}")
    return value


def _parse_float(text: str, minimum: float | None) -> float:
    try:
        value = float(text.strip())
    except ValueError:
        raise ValueError("a number") from None
    if not math.isfinite(value):
        raise ValueError("a finite number")
    if minimum is not None and value < minimum:
        raise ValueError(f"a number >= {minimum:g}")
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
    choices : tuple of str
        The accepted values of a ``choice`` key (compared lower-case).
    """

    kind: str
    default: Any
    help: str
    minimum: float | None = None
    choices: tuple[str, ...] = ()

    def parse(self, text: str) -> Any:
        """Return the typed value of ``text``; raise ``ValueError`` naming what is expected."""
        if self.kind == "int":
            return _parse_int(text, None if self.minimum is None else int(self.minimum))
        if self.kind == "float":
            return _parse_float(text, self.minimum)
        if self.kind == "bool":
            return parse_bool(text)
        if self.kind == "choice":
            low = text.strip().lower()
            if low not in self.choices:
                raise ValueError("one of " + ", ".join(self.choices))
            return low
        if not text:
            raise ValueError("a non-empty value")
        return text


COMMON_KEYS: dict[str, Key] = {
    "tolerance": Key("int", None, "accepted distance to the true reference, in frames", 0),
    "start": Key("int", None, "first frame (or place) kept", 0),
    "stop": Key("int", None, "frame (or place) where the selection stops (exclusive)", 1),
    "step": Key("int", 1, "keep every step-th frame", 1),
    "patch_norm": Key(
        "int", None, "patch-normalise every frame in PxP tiles at native resolution", 2
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
    if not isinstance(text, str) or not text.strip():
        raise DatasetSpecError(
            "empty dataset spec: write KIND:PATH[?key=value&...], e.g. "
            "synthetic:?places=500&query=winter"
        )
    kinds = ", ".join(sorted(schemas))
    kind_text, sep, rest = text.strip().partition(":")
    kind = kind_text.strip().lower()
    if kind not in schemas:
        if not sep:
            raise DatasetSpecError(
                f"dataset spec {text!r} has no kind: write KIND:PATH[?key=value&...] "
                f"with KIND one of {kinds}"
            )
        raise DatasetSpecError(
            f"unknown dataset kind {kind_text!r} in {text!r}: use one of {kinds}"
        )
    schema = schemas[kind]
    path_text, _, query = rest.partition("?")
    path_text = path_text.strip()
    parts = [p.strip() for p in path_text.split(",")] if path_text else []
    if len(parts) not in schema.n_paths:
        want = " or ".join(str(n) for n in schema.n_paths)
        raise DatasetSpecError(
            f"dataset spec {text!r}: kind {kind!r} takes {want} path(s), got {len(parts)}; "
            f"e.g. {schema.example}"
        )
    if any(not p for p in parts):
        raise DatasetSpecError(f"dataset spec {text!r} has an empty path; e.g. {schema.example}")
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
                f"dataset spec {text!r}: {item!r} is not key=value; separate pairs with '&'"
            )
        if name not in keys:
            raise DatasetSpecError(
                f"dataset spec {text!r}: unknown key {name!r} for kind {kind!r}; "
                f"valid keys: {', '.join(sorted(keys))}"
            )
        if name in given:
            raise DatasetSpecError(f"dataset spec {text!r}: key {name!r} is given twice")
        try:
            options[name] = keys[name].parse(value)
        except ValueError as exc:
            raise DatasetSpecError(
                f"dataset spec {text!r}: key {name!r} must be {exc}, got {value!r}"
            ) from None
        given.add(name)
    start, stop = options.get("start"), options.get("stop")
    if start is not None and stop is not None and stop <= start:
        raise DatasetSpecError(
            f"dataset spec {text!r}: stop={stop} must be greater than start={start}"
        )
    paths = tuple(Path(p).expanduser() for p in parts)
    return DatasetSpec(kind, paths, options, frozenset(given), text)
