"""The ``scamp5_draw_*`` controller calls and their pixel geometry.

The geometry is pure functions of integer coordinates, so the drawing calls stay thin and
the shapes can be tested on their own. Lines are Bresenham's (every step moves one element
along the major axis, both end points included); circles the midpoint circle (the eight
symmetric octants of the outline, radius 0 the centre alone). Both return ``(rows, cols)``
integer arrays, possibly outside the array: the caller wraps or clips them.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import numpy as np

from ppaloc.errors import SimulatorError
from ppaloc.sim.observe import controller_call

if TYPE_CHECKING:
    from ppaloc.sim.registers import Register

__all__ = ["DrawMixin", "circle_points", "line_points"]


def line_points(r0: int, c0: int, r1: int, c1: int) -> tuple[np.ndarray, np.ndarray]:
    """Elements of the line from (r0, c0) to (r1, c1), both included, in drawing order."""
    dr, dc = abs(r1 - r0), abs(c1 - c0)
    sr, sc = (1 if r1 >= r0 else -1), (1 if c1 >= c0 else -1)
    rows, cols = [], []
    r, c = r0, c0
    err = dc - dr
    while True:
        rows.append(r)
        cols.append(c)
        if r == r1 and c == c1:
            break
        e2 = 2 * err
        if e2 > -dr:
            err -= dr
            c += sc
        if e2 < dc:
            err += dc
            r += sr
    return np.asarray(rows, dtype=np.int64), np.asarray(cols, dtype=np.int64)


def circle_points(r: int, c: int, radius: int) -> tuple[np.ndarray, np.ndarray]:
    """Elements of the outline of the circle of ``radius`` around (r, c) (midpoint rule)."""
    pts: set[tuple[int, int]] = set()
    x, y = radius, 0
    err = 1 - radius
    while x >= y:
        for dr, dc in ((y, x), (x, y), (x, -y), (y, -x), (-y, -x), (-x, -y), (-x, y), (-y, x)):
            pts.add((r + dr, c + dc))
        y += 1
        if err < 0:
            err += 2 * y + 1
        else:
            x -= 1
            err += 2 * (y - x) + 1
    ordered = sorted(pts)
    return (
        np.asarray([p[0] for p in ordered], dtype=np.int64),
        np.asarray([p[1] for p in ordered], dtype=np.int64),
    )


class DrawMixin:
    """The ``scamp5_draw_*`` calls: draw 1s into the DREG chosen by ``draw_begin``.

    Coordinates are array coordinates (``scamp_addr=True``: hardware addresses, column 0
    at the east edge, as for every controller call). Each call charges the timing model:
    ``scamp5_draw_pixel`` once per element drawn, ``scamp5_draw_rect`` once per rectangle;
    ``draw_negate`` runs the 2-ICW ``NOT`` macro as a kernel.
    """

    rows: int
    cols: int
    timing: Any

    if TYPE_CHECKING:

        def _dreg(self, call: str, reg: Any, *, source: bool = False) -> Register: ...
        def _dplane(self, reg: Register) -> np.ndarray: ...
        def _write_digital(self, reg: Register, values: np.ndarray) -> None: ...
        def _rect(self, call: str, r0: int, c0: int, r1: int, c1: int, sa: bool) -> np.ndarray: ...

    @controller_call
    def draw_begin(self, dreg: Register) -> None:
        """``scamp5_draw_begin``: the later ``draw_*`` calls draw into ``dreg`` (R0-R12)."""
        self.__dict__["_draw_target"] = self._dreg("draw_begin", dreg)

    @controller_call
    def draw_end(self) -> None:
        """``scamp5_draw_end``: end the drawing operations."""
        self.__dict__["_draw_target"] = None

    def _target(self, call: str) -> Register:
        target = self.__dict__.get("_draw_target")
        if target is None:
            raise SimulatorError(f"{call}: no drawing target; call draw_begin(dreg) first")
        return target

    def _draw(self, call: str, rows: np.ndarray, cols: np.ndarray, wrap: bool, sa: bool) -> int:
        """OR 1s at (rows, cols) into the target: wrapped round the array or clipped to it."""
        target = self._target(call)
        if sa:
            cols = self.cols - 1 - cols
        if wrap:
            rows, cols = rows % self.rows, cols % self.cols
        else:
            inside = (rows >= 0) & (rows < self.rows) & (cols >= 0) & (cols < self.cols)
            rows, cols = rows[inside], cols[inside]
        plane = self._dplane(target).copy()
        plane[rows, cols] = True
        self._write_digital(target, plane)
        for _ in range(len(rows)):
            self.timing.charge_call("scamp5_draw_pixel")
        return len(rows)

    @controller_call
    def draw_pixel(self, r: int, c: int, *, scamp_addr: bool = False) -> None:
        """``scamp5_draw_pixel``: a 1 at (r, c), wrapped round the array if outside."""
        self._draw("draw_pixel", np.array([_int("draw_pixel", "r", r)]),
                   np.array([_int("draw_pixel", "c", c)]), True, scamp_addr)  # fmt: skip

    @controller_call
    def draw_point(self, r: int, c: int, *, scamp_addr: bool = False) -> bool:
        """``scamp5_draw_point``: a 1 at (r, c) if inside the array; returns whether drawn."""
        rows = np.array([_int("draw_point", "r", r)])
        cols = np.array([_int("draw_point", "c", c)])
        return bool(self._draw("draw_point", rows, cols, False, scamp_addr))

    @controller_call
    def draw_rect(self, r0: int, c0: int, r1: int, c1: int, *, scamp_addr: bool = False) -> None:
        """``scamp5_draw_rect``: 1s over the rectangle with corners (r0, c0), (r1, c1)
        (inclusive, any order; filled, as ``scamp5_load_rect`` fills it, but ORed into
        the target instead of replacing it)."""
        target = self._target("draw_rect")
        rect = self._rect("draw_rect", r0, c0, r1, c1, scamp_addr)
        self.timing.charge_call("scamp5_draw_rect")
        self._write_digital(target, self._dplane(target) | rect)

    @controller_call
    def draw_line(
        self, r0: int, c0: int, r1: int, c1: int, repeat: bool = False, *, scamp_addr: bool = False
    ) -> None:
        """``scamp5_draw_line``: the line (Bresenham) from (r0, c0) to (r1, c1); with
        ``repeat`` the points beyond the edge wrap round, else they are not drawn."""
        call = "draw_line"
        args = [_int(call, n, v) for n, v in (("r0", r0), ("c0", c0), ("r1", r1), ("c1", c1))]
        rows, cols = line_points(*args)
        self._draw(call, rows, cols, bool(repeat), scamp_addr)

    @controller_call
    def draw_circle(
        self, r: int, c: int, radius: int, repeat: bool = False, *, scamp_addr: bool = False
    ) -> None:
        """``scamp5_draw_circle``: the outline (midpoint circle) of ``radius`` around
        (r, c); ``repeat`` wraps the points beyond the edge, else they are not drawn."""
        call = "draw_circle"
        rad = _int(call, "radius", radius)
        if rad < 0:
            raise SimulatorError(f"{call}: radius={radius!r} is negative; use 0 or more")
        rows, cols = circle_points(_int(call, "r", r), _int(call, "c", c), rad)
        self._draw(call, rows, cols, bool(repeat), scamp_addr)

    @controller_call
    def draw_negate(self) -> None:
        """``scamp5_draw_negate``: invert the target DREG (the 2-ICW ``NOT`` macro)."""
        self.NOT(self._target("draw_negate"))  # type: ignore[attr-defined]


#: The largest magnitude of a drawing coordinate or radius (as of a shift): a line or circle
#: is enumerated point by point, so a coordinate of 2**31 would take hours and gigabytes.
DRAW_LIMIT = 1 << 16


def _int(call: str, name: str, value: Any) -> int:
    if isinstance(value, bool | np.bool_) or not isinstance(value, int | np.integer):
        raise SimulatorError(f"{call}: {name}={value!r} must be an integer")
    if not -DRAW_LIMIT <= value <= DRAW_LIMIT:
        raise SimulatorError(
            f"{call}: {name}={value!r} is out of range; use [{-DRAW_LIMIT}, {DRAW_LIMIT}]"
        )
    return int(value)


# SCAMP-5 spellings, so published host code ports line by line.
for _name in ("begin", "end", "pixel", "point", "rect", "line", "circle", "negate"):
    setattr(DrawMixin, f"scamp5_draw_{_name}", getattr(DrawMixin, f"draw_{_name}"))
del _name
