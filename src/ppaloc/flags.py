"""Keys a command line gives with a flag, repeatable: one key given twice.

At the bottom of the layers, so that the command (``cli``: ``--param``) and the C++ run's
command (``cpp.command``: ``--set``, ``--stream-option``) refuse a contradiction alike,
in one wording.
"""

from __future__ import annotations

from typing import Any

from ppaloc.errors import PpalocError

__all__ = ["set_once", "short"]


def short(value: Any, limit: int = 60) -> str:
    """``repr(value)`` cut to ``limit`` characters, for messages.

    >>> short("x" * 100, 12)
    "'xxxxxxxx..."
    """
    text = repr(value)
    return text if len(text) <= limit else text[: limit - 3] + "..."


def set_once(table: dict[str, Any], key: str, value: Any, what: str) -> None:
    """``table[key] = value`` for a repeatable flag, refusing a key given before with
    another value: two values are a contradiction for the user to settle (the same one
    again is fine; ``10`` and ``10.0``, or ``1`` and ``true``, are two). ``what`` names
    the key as given, for the message (``--param seqslam.ds``, ``--set threshold``).

    Raises
    ------
    PpalocError
        ``--set threshold is given twice ('30', then '40'): give it once``.

    >>> table = {}
    >>> set_once(table, "ds", 10, "--param seqslam.ds")
    >>> set_once(table, "ds", 10, "--param seqslam.ds")
    >>> set_once(table, "ds", 10.0, "--param seqslam.ds")
    Traceback (most recent call last):
    ppaloc.errors.PpalocError: --param seqslam.ds is given twice (10, then 10.0): give it once
    """
    if key in table and (type(table[key]) is not type(value) or table[key] != value):
        raise PpalocError(
            f"{what} is given twice ({short(table[key])}, then {short(value)}): give it once"
        )
    table[key] = value
