"""Register roles of the on-sensor pipeline, declared once per representation and checked.

Every stage names registers by role (``roles.weights``, ``roles.d.cand``, ...), never by a
bare register, so the allocation of docs/onsensor.md is written in one place. A role is

- *kept* when its value lives from one frame to the next (the map, the weights, the
  valid node roots, the static masks, the previous frame's motion planes), or
- *working* when a stage loads it before it reads it (block means, the replicated live
  frame, candidates, temporaries, patterns).

:meth:`Roles.check` refuses an allocation where two kept roles share a register, a
working role sits on a kept one's register, or two working roles share one without being
declared to take it in turn (:attr:`Roles.in_turn`): two live values can never share a
register by accident.
"""

from __future__ import annotations

from dataclasses import dataclass, fields

from ppaloc.errors import PpalocError
from ppaloc.sim import R5, R6, R7, R8, C, D, E, F, Register

__all__ = ["DRegs", "Roles"]


@dataclass(frozen=True)
class DRegs:
    """Digital register roles of one representation.

    ``valid``, ``u_prev`` and ``d_prev`` are kept (the valid node roots; the previous
    frame's motion planes); the others are working registers.
    """

    valid: Register
    cand: Register
    tmp_a: Register
    tmp_b: Register
    pattern: Register
    root32: Register
    u: Register = R5
    d: Register = R6
    u_prev: Register = R7
    d_prev: Register = R8

    def __post_init__(self) -> None:
        # the roles key the kernel cache on every kernel run: hash them once
        object.__setattr__(self, "_hash", hash(tuple(getattr(self, f.name) for f in fields(self))))

    def __hash__(self) -> int:
        return self.__dict__["_hash"]

    def __reduce__(self) -> tuple:
        return (DRegs, tuple(getattr(self, f.name) for f in fields(self)))

    #: The kept digital roles (live from one frame to the next).
    KEPT = ("valid", "u_prev", "d_prev")

    def aliases(self) -> dict[str, tuple[str, ...]]:
        """Registers held by more than one role: ``{name: roles}``, roles in field order."""
        roles: dict[str, list[str]] = {}
        for f in fields(self):
            roles.setdefault(getattr(self, f.name).name, []).append(f.name)
        return {reg: tuple(r) for reg, r in roles.items() if len(r) > 1}


@dataclass(frozen=True)
class Roles:
    """Every register role of one representation's pipeline.

    Attributes
    ----------
    db : tuple of Register
        The map's database registers (kept): one per tile, or the two halves of the
        low-res levels store.
    d : DRegs
        The digital roles.
    static : tuple of Register
        Digital masks written at set-up and refreshed at every capture (kept).
    weights : Register
        The weights (kept): tile ``t`` at block PE ``(0, t)``.
    negated : Register or None
        Robust, where there is a free analogue register: minus the weights from the
        update to the next transition (kept across that frame boundary).
    means : Register
        Working: ``-m`` spread over the blocks, then the live frame as the comparison
        reads it (replicated low-res grid).
    frame : Register
        Working: the captured image ``v`` (until the motion stage), then the second
        scratch plane of the trees and halvings.
    shifted : Register
        Working: the robust transition's ``-w`` moved along the snake (on ``frame``'s
        register, in turn).
    spare : Register
        Working: the first scratch plane (trees, the transition's copy, DAC constants).
    root_means : Register or None
        Working: where the block means are also left at the block roots (LBP: the
        descriptor compares them there).
    in_turn : tuple of tuple of str
        Pairs of working roles (``"d.pattern"``, ``"d.root32"``, ...) that share a
        register in turn: every stage reloads it before it reads it. ``frame`` and
        ``shifted`` always do (the transition runs after the motion stage has read the
        captured frame).
    """

    db: tuple[Register, ...]
    d: DRegs
    static: tuple[Register, ...]
    weights: Register = C
    negated: Register | None = None
    means: Register = F
    frame: Register = E
    shifted: Register = E
    spare: Register = D
    root_means: Register | None = None
    in_turn: tuple[tuple[str, str], ...] = ()

    def kept(self) -> list[tuple[str, Register]]:
        """The kept roles, ``(role, register)``; a static mask that is also the map or
        the valid roots (refreshed with them) is listed once, under its role."""
        out = [(f"db[{i}]", r) for i, r in enumerate(self.db)]
        out.append(("weights", self.weights))
        if self.negated is not None:
            out.append(("negated", self.negated))
        out += [(f"d.{name}", getattr(self.d, name)) for name in DRegs.KEPT]
        named = {r for _, r in out}
        out += [(f"static[{i}]", r) for i, r in enumerate(self.static) if r not in named]
        return out

    def working(self) -> dict[str, Register]:
        """The working roles: ``{role: register}``."""
        out = {
            "means": self.means,
            "frame": self.frame,
            "shifted": self.shifted,
            "spare": self.spare,
        }
        if self.root_means is not None:
            out["root_means"] = self.root_means
        out.update(
            {f"d.{f.name}": getattr(self.d, f.name) for f in fields(self.d)
             if f.name not in DRegs.KEPT}
        )  # fmt: skip
        return out

    def check(self) -> Roles:
        """Refuse two live values on one register (see the module docstring); return self.

        Examples
        --------
        >>> from ppaloc.sim import R1, R2, R3, R4, R9, A, B
        >>> d = DRegs(valid=R4, cand=R9, tmp_a=R1, tmp_b=R2, pattern=R3, root32=R3)
        >>> _ = Roles((A, B), d, (R4,), in_turn=(("d.pattern", "d.root32"),)).check()
        >>> Roles((A, C), d, (R4,), in_turn=(("d.pattern", "d.root32"),)).check()
        Traceback (most recent call last):
        ppaloc.errors.PpalocError: register roles: db[1] and weights both hold C
        """
        owner: dict[Register, str] = {}
        for role, reg in self.kept():
            if reg in owner:
                raise PpalocError(f"register roles: {owner[reg]} and {role} both hold {reg}")
            owner[reg] = role
        allowed = {frozenset(pair) for pair in (("frame", "shifted"), *self.in_turn)}
        seen: dict[Register, str] = {}
        for role, reg in self.working().items():
            if reg in owner:
                raise PpalocError(
                    f"register roles: working {role} is on {reg}, which {owner[reg]} keeps"
                )
            other = seen.setdefault(reg, role)
            if other != role and frozenset((other, role)) not in allowed:
                raise PpalocError(
                    f"register roles: {other} and {role} both use {reg}; declare them in "
                    "in_turn if every stage reloads it before reading it"
                )
        return self
