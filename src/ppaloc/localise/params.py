"""The weighted-node filter's contract: one parameters object and its decision functions.

:class:`FilterParams` holds every setting of the filter, checked once, with the defaults
of its two presets:

- ``"robust"`` (the default): a max-product Bayes filter over the nodes in the log domain
  (docs/localise.md, "The robust filter"). Each node's weight comes from the best of its
  plausible predecessors (stay, +1, +2 nodes), each charged a transition cost that the
  image motion test sets (evidence, not a switch); the likelihood is scaled per frame
  from the frame's own distances to all nodes; the weights are normalised by their
  maximum every frame and floored ``memory`` units below it, and the array edge brings
  in "no hypothesis" (the floor) instead of 0. The map gets one node per distinct place
  (keyframes chosen by the same motion test).
- ``"paper"``: Algorithm 1 of Castillo-Elizalde et al. (ICRA 2021) exactly: forward or
  stay by the motion test, ``w_i += alpha - mu_i``, the adjustment ``w -= gamma max(W)``
  every ``k`` frames, one node per reference frame.

The host filter (float and ppa8 arithmetic) and the on-sensor pipeline read the same
object and call the same decision functions (:func:`transition_costs`,
:func:`likelihood_shift`, :func:`frame_statistics`, and
:func:`ppaloc.localise.motion.forward_decision`), so the contract of docs/ppa8.md lives
in one place. Every value is a small integer a PPA controller loads through its DAC or
compares in its integer unit.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from ppaloc.errors import PpalocError
from ppaloc.localise.motion import MARGIN, PAPER_MARGIN
from ppaloc.place.normalise import MAX_CONTRAST

__all__ = [
    "DEFAULT_CONTRAST",
    "DEFAULT_SHIFT",
    "FILTER_KEYS",
    "GAMMAS",
    "MAX_ALPHA",
    "MAX_PERIOD",
    "MAX_SHIFT",
    "MAX_WINDOW",
    "PRESETS",
    "FilterParams",
    "check_int",
    "frame_statistics",
    "likelihood_shift",
    "transition_costs",
]

GAMMAS = (0.0, 0.125, 0.25, 0.5, 1.0)
"""Adjustment factors a PPA applies by halving (docs/ppa8.md)."""

PRESETS = ("robust", "paper")
"""Named presets: the robust filter (default) and the paper's Algorithm 1."""

MAX_SHIFT = 6
"""Largest per-frame likelihood shift of the robust filter (``mu * 2**-6``)."""

_MOTIONS = ("image", "always_forward", "oracle")

# Parameters that only one preset uses; giving one to the other preset is an error.
_PAPER_ONLY = ("alpha", "gamma", "k", "shift", "advance")
_ROBUST_ONLY = (
    "gain", "memory", "stay_cost", "move_cost", "skip_cost", "max_advance", "contrast"
)  # fmt: skip


MAX_ALPHA = 1e6
"""Paper preset (float arithmetic): the largest magnitude of ``alpha`` (a frame's term is
at most 255 units, so larger offsets only overflow the weights)."""

MAX_PERIOD = 1_000_000
"""Paper preset: the longest adjustment period ``k`` (frames)."""

MAX_WINDOW = 1_000_000
"""Largest ``advance`` bound and ``confidence_radius`` (nodes)."""

DEFAULT_CONTRAST = 48
"""Robust preset: the mean absolute deviation (grey levels) low-res images are normalised
to (the middle of the plateau of docs/localise.md's sensitivity table, 32-96)."""

DEFAULT_SHIFT = {"lowres": 2, "lbp": 1}
"""Paper preset: the default likelihood shift per representation. One frame's term spans
0-32 units in both (low-res ``mu`` is in [0, 127], LBP ``mu`` in [0, 64])."""


def check_int(name: str, value: Any, low: int, high: int | None = None) -> int:
    """``value`` as an int, or a one-line error naming ``name`` and the range."""
    if not isinstance(value, int | np.integer) or isinstance(value, bool):
        raise PpalocError(f"{name}={value!r} must be an integer")
    if value < low or (high is not None and value > high):
        hint = f">= {low}" if high is None else f"in [{low}, {high}]"
        raise PpalocError(f"{name}={value!r} must be {hint}")
    return int(value)


@dataclass(frozen=True)
class FilterParams:
    """Every setting of the weighted-node filter (host and sensor), validated.

    Build it with :meth:`create` (preset defaults, then the given values); the dataclass
    fields are the resolved values. ``None`` in a paper-only or robust-only field means
    "not used by this preset".

    Attributes
    ----------
    preset : {"robust", "paper"}
    motion : {"image", "always_forward", "oracle"}
        The motion model. Robust: its decision sets the transition costs. Paper: it
        decides the shift.
    motion_margin, motion_shift, motion_min_support : int
        The image motion test (:func:`ppaloc.localise.motion.forward_decision`); the
        dead zone ``motion_margin`` is 4 with the robust preset, 3 with the paper's.
    confidence_radius : int
        ``R`` of the confidence: best weight minus the best outside ``node +- R``.
    keyframes : bool
        Map one node per distinct place: a reference frame starts a new node only when
        the motion test says forward from the previous reference frame (robust default
        with the image model); False maps one node per frame (the paper).
    gain : int
        Robust: the likelihood span of one frame between its best node and the mean
        node, in register units (the per-frame shift brings the spread to within a
        factor 1.5 of it). Range [1, 32]; default 4.
    memory : int
        Robust: the floor below the best weight, in register units; with ``gain`` it
        sets how many frames of evidence a hypothesis keeps (about ``memory / gain``).
        Range [8, 127]; default 127.
    stay_cost : int
        Robust: the cost of staying on a node when the motion test says forward.
        Range [0, 64]; default 4.
    move_cost : int
        Robust: the cost of advancing when the motion test says stay. Range [0, 64];
        default 4.
    skip_cost : int
        Robust: the extra cost of each node advanced beyond one. Range [0, 64];
        default 4.
    max_advance : int
        Robust: the most nodes one frame may advance. Range [1, 3]; default 2.
    contrast : int
        Robust, low-res images: the mean absolute deviation (grey levels) every image,
        live or node, is brought near by :func:`ppaloc.place.normalise_contrast` (offset
        removed, gain from x1/2 to x4) before the comparison, so that light and contrast
        changes (dusk, night, snow) do not decide the match; 0 compares the images as
        they are. Range [0, 127]; default 48. LBP codes need none (they are invariant
        to any increasing change of intensity).
    alpha, gamma, k, shift, advance
        Paper: Algorithm 1's likelihood offset (None: from the map), adjustment factor,
        adjustment period, likelihood shift and forward window (docs/localise.md).
    """

    preset: str = "robust"
    motion: str = "image"
    motion_margin: int = MARGIN
    motion_shift: int = 6
    motion_min_support: int = 1024
    confidence_radius: int = 10
    keyframes: bool = True
    gain: int | None = 4
    memory: int | None = 127
    stay_cost: int | None = 4
    move_cost: int | None = 4
    skip_cost: int | None = 4
    max_advance: int | None = 2
    contrast: int | None = DEFAULT_CONTRAST
    alpha: float | None = None
    gamma: float | None = None
    k: int | None = None
    shift: int | None = None
    advance: tuple[int, int] | None = None
    extra: Mapping[str, Any] = field(default_factory=dict, compare=False, repr=False)

    @classmethod
    def create(
        cls,
        representation: str,
        *,
        preset: str = "robust",
        arithmetic: str = "float",
        **values: Any,
    ) -> FilterParams:
        """Resolve a preset's defaults with ``values`` and check every one.

        Parameters
        ----------
        representation : {"lowres", "lbp"}
            Sets the paper preset's default likelihood shift.
        preset : {"robust", "paper"}
        arithmetic : {"float", "ppa8"}
            ``"ppa8"`` requires an integer ``alpha`` (a DAC constant).
        **values
            Any field; a field of the other preset is an error naming the preset it
            belongs to.

        Examples
        --------
        >>> FilterParams.create("lbp").transition_defaults()
        (4, 4, 4, 2)
        >>> FilterParams.create("lbp", preset="paper").shift
        1
        """
        if preset not in PRESETS:
            raise PpalocError(f"preset={preset!r} is not one of {', '.join(PRESETS)}")
        known = {f.name for f in dataclasses.fields(cls)} - {"preset", "extra"}
        unknown = sorted(set(values) - known)
        if unknown:
            raise PpalocError(
                f"unknown filter parameter {unknown[0]!r}; parameters: {', '.join(sorted(known))}"
            )
        foreign = _ROBUST_ONLY if preset == "paper" else _PAPER_ONLY
        other = "robust" if preset == "paper" else "paper"
        for key in foreign:
            if values.get(key) is not None:
                methods = "weighted-node-paper-*" if other == "paper" else "weighted-node-*"
                raise PpalocError(
                    f"{key}={values[key]!r} is a parameter of preset {other!r}, not of "
                    f"preset {preset!r}; pass preset={other!r} (the methods {methods}) to use it"
                )
        motion = values.get("motion", "image")
        if motion not in _MOTIONS:
            raise PpalocError(f"motion={motion!r} is not one of {', '.join(_MOTIONS)}")
        out: dict[str, Any] = {"preset": preset, "motion": motion}
        margin = values.get("motion_margin")
        if margin is None:
            margin = MARGIN if preset == "robust" else PAPER_MARGIN
        out["motion_margin"] = check_int("motion_margin", margin, 0, 127)
        out["motion_shift"] = check_int("motion_shift", values.get("motion_shift", 6), 0, 16)
        out["motion_min_support"] = check_int(
            "motion_min_support", values.get("motion_min_support", 1024), 0, 256 * 256
        )
        out["confidence_radius"] = check_int(
            "confidence_radius", values.get("confidence_radius", 10), 0, MAX_WINDOW
        )
        keyframes = values.get("keyframes")
        if keyframes is None:
            keyframes = preset == "robust" and motion == "image"
        if not isinstance(keyframes, bool | np.bool_):
            raise PpalocError(f"keyframes={keyframes!r} must be True or False")
        out["keyframes"] = bool(keyframes)
        if preset == "robust":
            out["gain"] = check_int("gain", values.get("gain", 4), 1, 32)
            out["memory"] = check_int("memory", values.get("memory", 127), 8, 127)
            for key in ("stay_cost", "move_cost", "skip_cost"):
                out[key] = check_int(key, values.get(key, 4), 0, 64)
            out["max_advance"] = check_int("max_advance", values.get("max_advance", 2), 1, 3)
            out["contrast"] = check_int(
                "contrast", values.get("contrast", DEFAULT_CONTRAST), 0, MAX_CONTRAST
            )
        else:
            out.update(dict.fromkeys(_ROBUST_ONLY))
            out.update(_paper_values(representation, arithmetic, values))
        return cls(**out)

    def transition_defaults(self) -> tuple[int, int, int, int]:
        """``(stay_cost, move_cost, skip_cost, max_advance)`` (robust preset)."""
        assert self.preset == "robust"
        return (self.stay_cost, self.move_cost, self.skip_cost, self.max_advance)  # type: ignore[return-value]

    def as_dict(self) -> dict[str, Any]:
        """The resolved parameters as plain values (for reports and results files)."""
        out = {f.name: getattr(self, f.name) for f in dataclasses.fields(self) if f.name != "extra"}
        if out["advance"] is not None:
            out["advance"] = list(out["advance"])
        return out


def _paper_values(representation: str, arithmetic: str, values: Mapping[str, Any]) -> dict:
    out: dict[str, Any] = {}
    gamma = values.get("gamma", 0.5)
    if gamma is None:
        gamma = 0.5
    if gamma not in GAMMAS:
        raise PpalocError(f"gamma={gamma!r} must be one of {GAMMAS} (a PPA scales only by halving)")
    out["gamma"] = float(gamma)
    out["k"] = check_int("k", 1 if values.get("k") is None else values["k"], 1, MAX_PERIOD)
    shift = values.get("shift")
    if shift is None:
        shift = DEFAULT_SHIFT.get(representation, 2)
    out["shift"] = check_int("shift", shift, 0, 16)
    advance = values.get("advance") or (1, 1)
    try:
        lo, hi = advance
    except (TypeError, ValueError):
        raise PpalocError(f"advance={advance!r} must be a pair (lo, hi)") from None
    lo_ok = check_int("advance[0]", lo, 0, MAX_WINDOW)
    if not lo_ok <= check_int("advance[1]", hi, 1, MAX_WINDOW):
        raise PpalocError(f"advance={advance!r} must be (lo, hi) with 0 <= lo <= hi, hi >= 1")
    out["advance"] = (int(lo), int(hi))
    alpha = values.get("alpha")
    if alpha is not None:
        if arithmetic == "ppa8":
            alpha = check_int("alpha", alpha, -128, 127)  # a DAC constant
        elif isinstance(alpha, bool) or not isinstance(alpha, int | float | np.number):
            raise PpalocError(f"alpha={alpha!r} must be a number")
        elif not (math.isfinite(float(alpha)) and abs(float(alpha)) <= MAX_ALPHA):
            raise PpalocError(
                f"alpha={alpha!r} must be a number in [-{MAX_ALPHA:g}, {MAX_ALPHA:g}]"
            )
    out["alpha"] = alpha
    return out


FILTER_KEYS = tuple(f.name for f in dataclasses.fields(FilterParams) if f.name != "extra")
"""Every parameter name of the filter contract."""


def transition_costs(moved: bool, params: FilterParams) -> tuple[int, ...]:
    """Cost of advancing ``d = 0 .. max_advance`` nodes, given the motion test's decision.

    The motion test is evidence: on *forward* staying costs ``stay_cost`` and one node is
    free; on *stay* staying is free and one node costs ``move_cost``. Each node beyond
    the first adds ``skip_cost``.

    Examples
    --------
    >>> p = FilterParams.create("lbp", stay_cost=5, move_cost=3, skip_cost=2, max_advance=3)
    >>> transition_costs(True, p), transition_costs(False, p)
    ((5, 0, 2, 4), (0, 3, 5, 7))
    """
    stay, move, skip, most = params.transition_defaults()
    one = 0 if moved else move
    return (stay if moved else 0, *(one + skip * (d - 1) for d in range(1, most + 1)))


def likelihood_shift(spread: int, gain: int) -> int:
    """The per-frame likelihood shift ``s``: ``spread * 2**-s`` lands near ``gain``.

    ``s`` is the smallest in ``[0, MAX_SHIFT]`` with ``2 spread <= 3 gain 2**s`` (so the
    scaled spread lies in ``(gain * 3/4, gain * 3/2]`` unless ``s`` is at a bound). Only
    integers and shifts: the controller's arithmetic.

    Examples
    --------
    >>> [likelihood_shift(x, 4) for x in (0, 6, 7, 12, 13, 40, 10**6)]
    [0, 0, 1, 1, 2, 3, 6]
    """
    s = 0
    while s < MAX_SHIFT and 2 * spread > (3 * gain) << s:
        s += 1
    return s


def frame_statistics(values: np.ndarray) -> tuple[int, int]:
    """``(best, mean)`` of a frame's integer distances to all nodes: the min and the floor
    of the mean, which the controller computes from the readout of every node.

    Examples
    --------
    >>> frame_statistics(np.array([6, 20, 30, 11]))
    (6, 16)
    """
    v = np.asarray(values, dtype=np.int64)
    return int(v.min()), int(v.sum() // len(v))
