"""Register handles and neighbour directions of the simulated SCAMP-5 processing element.

Every processing element (PE) of a SCAMP-5 array holds seven analogue registers
(``A``-``F`` and ``NEWS``), the photodiode ``PIX``, the DAC input ``IN``, thirteen 1-bit
registers (``R0``-``R12``), the activity flag ``FLAG``, the controller's ``SELECT`` pattern
and its ``RECT`` rectangle. A program names registers through the handles defined here; the
simulator keeps one plane (an array of shape ``(rows, cols)``) per register.

``XN``, ``XE``, ``XS`` and ``XW`` are not registers of their own: they name the ``NEWS``
register of the north, east, south or west neighbour. As a source, ``XE`` reads the east
neighbour's ``NEWS``; as a destination, ``XW`` writes the west neighbour's ``NEWS`` (so
``bus(XW, x)`` leaves in every ``NEWS`` the negated ``x`` of the element to its east).

Directions are flags (east=1, west=2, north=4, south=8 as in the SCAMP-5 headers), so
``DNEWS`` can take several at once (``north | east``).
"""

from __future__ import annotations

import enum
from dataclasses import dataclass, field

from ppaloc.errors import RegisterMisuseError

__all__ = [
    "ANALOG_PLANES",
    "DIGITAL_PLANES",
    "FLAG",
    "IN",
    "NEWS",
    "PIX",
    "R0",
    "R1",
    "R2",
    "R3",
    "R4",
    "R5",
    "R6",
    "R7",
    "R8",
    "R9",
    "R10",
    "R11",
    "R12",
    "RE",
    "RECT",
    "RF",
    "RN",
    "RP",
    "RS",
    "RW",
    "S0",
    "S1",
    "S2",
    "S3",
    "S4",
    "S5",
    "S6",
    "SELECT",
    "XE",
    "XN",
    "XS",
    "XW",
    "A",
    "B",
    "C",
    "D",
    "Direction",
    "E",
    "F",
    "Register",
    "UnknownRegisterError",
    "alldir",
    "east",
    "north",
    "register_by_name",
    "south",
    "west",
]


class Direction(enum.IntFlag):
    """A neighbour direction; combine with ``|`` where an instruction accepts several.

    ``offset`` is the (row, col) step to the neighbour: row 0 is north, col grows east.
    """

    east = 1
    west = 2
    north = 4
    south = 8

    @property
    def offset(self) -> tuple[int, int]:
        """(d_row, d_col) from an element to its neighbour in this (single) direction."""
        return _OFFSETS[self]


_OFFSETS = {
    Direction.east: (0, 1),
    Direction.west: (0, -1),
    Direction.north: (-1, 0),
    Direction.south: (1, 0),
}

north = Direction.north
east = Direction.east
south = Direction.south
west = Direction.west
#: All four directions (``alldir`` of the SCAMP-5 headers), e.g. ``DNEWS(R5, R6, alldir)``.
alldir = north | east | south | west


@dataclass(frozen=True, slots=True)
class Register:
    """A handle naming one register of every processing element.

    Attributes
    ----------
    name : str
        The SCAMP-5 name (``"A"``, ``"NEWS"``, ``"XE"``, ``"R12"``, ...).
    kind : str
        ``"analog"`` or ``"digital"``.
    index : int
        Plane index in the simulator's analogue or digital register file. Neighbour
        aliases carry the index of ``NEWS``.
    role : str
        ``"general"`` (A-F, R0-R12), ``"news"``, ``"neighbour"`` (XN/XE/XS/XW),
        ``"pixel"`` (PIX), ``"input"`` (IN), ``"flag"`` (FLAG) or ``"select"`` (SELECT).
    direction : Direction or None
        For neighbour aliases, the direction of the neighbour whose ``NEWS`` is named.
    """

    name: str
    kind: str
    index: int
    role: str = "general"
    direction: Direction | None = None
    _hash: int = field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        # a handle keys caches on every kernel run: hash its fields once
        object.__setattr__(self, "_hash", hash((self.name, self.kind, self.index, self.role)))

    def __hash__(self) -> int:
        return self._hash

    def __reduce__(self) -> tuple:
        # rebuilt by the constructor: a string's hash differs from process to process
        return (Register, (self.name, self.kind, self.index, self.role, self.direction))

    @property
    def writable(self) -> bool:
        """Whether an instruction may name this register as its destination."""
        return self.role in ("general", "news", "neighbour")

    def __repr__(self) -> str:
        return self.name


# Analogue register file: plane indices.
A = Register("A", "analog", 0)
B = Register("B", "analog", 1)
C = Register("C", "analog", 2)
D = Register("D", "analog", 3)
E = Register("E", "analog", 4)
F = Register("F", "analog", 5)
NEWS = Register("NEWS", "analog", 6, "news")
PIX = Register("PIX", "analog", 7, "pixel")
IN = Register("IN", "analog", 8, "input")
XN = Register("XN", "analog", 6, "neighbour", Direction.north)
XE = Register("XE", "analog", 6, "neighbour", Direction.east)
XS = Register("XS", "analog", 6, "neighbour", Direction.south)
XW = Register("XW", "analog", 6, "neighbour", Direction.west)

ANALOG_PLANES: tuple[Register, ...] = (A, B, C, D, E, F, NEWS, PIX, IN)

# Digital register file: plane indices.
R0 = Register("R0", "digital", 0)
R1 = Register("R1", "digital", 1)
R2 = Register("R2", "digital", 2)
R3 = Register("R3", "digital", 3)
R4 = Register("R4", "digital", 4)
R5 = Register("R5", "digital", 5)
R6 = Register("R6", "digital", 6)
R7 = Register("R7", "digital", 7)
R8 = Register("R8", "digital", 8)
R9 = Register("R9", "digital", 9)
R10 = Register("R10", "digital", 10)
R11 = Register("R11", "digital", 11)
R12 = Register("R12", "digital", 12)
FLAG = Register("FLAG", "digital", 13, "flag")
SELECT = Register("SELECT", "digital", 14, "select")
#: The rectangle ``scamp5_select_rect`` loads (read-only, like SELECT).
RECT = Register("RECT", "digital", 15, "select")

DIGITAL_PLANES: tuple[Register, ...] = (
    R0,
    R1,
    R2,
    R3,
    R4,
    R5,
    R6,
    R7,
    R8,
    R9,
    R10,
    R11,
    R12,
    FLAG,
    SELECT,
    RECT,
)

# The SCAMP-5 headers' other names for the digital registers (``scamp5_icw.hpp``,
# namespace SCAMP5_PE), used throughout published code: the DNEWS selectors by the
# direction they read from, S0-S6 for the general registers, RF and RP for the scratch pair.
RS, RW, RN, RE = R1, R2, R3, R4
S0, S1, S2, S3, S4, S5, S6 = R5, R6, R7, R8, R9, R10, R11
RF, RP = R0, R12

#: Selector registers of DNEWS, by direction (R1 south, R2 west, R3 north, R4 east).
DNEWS_SELECTORS: dict[Direction, Register] = {
    Direction.south: R1,
    Direction.west: R2,
    Direction.north: R3,
    Direction.east: R4,
}

_BY_NAME = {r.name: r for r in (*ANALOG_PLANES, XN, XE, XS, XW, *DIGITAL_PLANES)}


class UnknownRegisterError(RegisterMisuseError, KeyError):
    """No register has the name asked for (also a ``KeyError``, as a failed lookup)."""

    __str__ = Exception.__str__  # the message, not KeyError's quoted repr


def register_by_name(name: str) -> Register:
    """The handle called ``name`` (e.g. ``"A"``, ``"R5"``, ``"XE"``).

    Raises
    ------
    UnknownRegisterError
        If no register has that name (a ``RegisterMisuseError`` and a ``KeyError``).
    """
    try:
        return _BY_NAME[name]
    except (KeyError, TypeError):
        raise UnknownRegisterError(
            f"no register is called {name!r}; use one of {', '.join(_BY_NAME)}"
        ) from None
