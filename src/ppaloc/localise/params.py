"""The weighted-node filter's contract: one parameters object and its decision functions.

:class:`FilterParams` holds every setting of the filter, checked once, with the defaults
of its two presets:

- ``"robust"`` (the default): a max-product Bayes filter over the nodes in the log domain
  (docs/localise.md, "The robust filter"). Each node's weight comes from the best of its
  plausible predecessors (stay, +1, +2, +3 nodes), each charged a transition cost that the
  image motion test sets (evidence, not a switch), centred on the speed the estimate's
  own path shows where the filter was sure of it; the likelihood is scaled per frame
  from the frame's own distances to all nodes; the weights are normalised by their
  maximum every frame and floored ``memory`` units below it, and the array edge brings
  in "no hypothesis" (the floor) instead of 0. The map gets one node per distinct place
  (keyframes chosen by the same motion test).
- ``"paper"``: Algorithm 1 of Castillo-Elizalde et al. (ICRA 2021) exactly: forward or
  stay by the motion test, ``w_i += alpha - mu_i``, the adjustment ``w -= gamma max(W)``
  every ``k`` frames, one node per reference frame.

Each preset's per-frame steps are a schedule (:mod:`ppaloc.localise.schedule`), which
every executor (the host in float or ppa8 arithmetic, the simulated sensor, a bank of
sensors) runs; the schedules call the decision functions here
(:func:`transition_costs` with :func:`path_speed`, :func:`frame_scale` with
:func:`likelihood_shift` and :func:`refined_minimum`, :func:`adjustment`) and
:func:`ppaloc.localise.motion.forward_decision`, so the contract of docs/ppa8.md lives
in one place. Every value is a small integer a PPA controller loads through its DAC or
compares in its integer unit.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any, Literal, NamedTuple

import numpy as np

from ppaloc.errors import PpalocError
from ppaloc.localise.base import MethodParam
from ppaloc.localise.likelihood import FLOAT_PLACES
from ppaloc.localise.motion import COHERENT_SHIFT, MARGIN, PAPER_MARGIN
from ppaloc.place.normalise import MAX_CONTRAST

__all__ = [
    "CONTRAST_PATCHES",
    "DEFAULT_CONTRAST",
    "DEFAULT_CONTRAST_PATCH",
    "DEFAULT_SHIFT",
    "DETECT_BITS",
    "END_WINDOW",
    "FILTER_KEYS",
    "GAMMAS",
    "MAX_ALPHA",
    "MAX_PERIOD",
    "MAX_SHIFT",
    "MAX_WINDOW",
    "MINIMUM_BITS",
    "MOTIONS",
    "NO_LANES",
    "PARAM_LINES",
    "VARY_AGE",
    "VARY_BAND",
    "VARY_RECORD",
    "DeclaredSpeeds",
    "FilterParams",
    "Param",
    "PathSpeed",
    "adjustment",
    "assumed_speeds",
    "centroid_window",
    "check_int",
    "choose_candidate",
    "concentration",
    "filter_method_params",
    "frame_scale",
    "lane_reported",
    "lane_speed_led",
    "lane_speed_taken",
    "lane_speeds",
    "likelihood_shift",
    "local_centroid",
    "local_step",
    "past_map_end",
    "path_speed",
    "path_stalled",
    "preset_group",
    "refined_minimum",
    "runs_on",
    "speed_off",
    "speed_remedy",
    "speed_varies",
    "still_score",
    "stood_at_or_next",
    "transition_costs",
    "weight_read",
]

GAMMAS = (0.0, 0.125, 0.25, 0.5, 1.0)
"""Adjustment factors a PPA applies by halving (docs/ppa8.md)."""

MAX_SHIFT = 6
"""Largest per-frame likelihood shift of the robust filter (``mu * 2**-6``)."""

MOTIONS = ("image", "always_forward", "oracle")
"""The motion models (:mod:`ppaloc.localise.motion`)."""

NO_LANES = {"lane_speed": 0, "slow_lane": False}
"""Robust parameters that turn every speed lane off (:func:`lane_speeds`): one weight set,
on the sensor one sensor (or bank)."""


MAX_ALPHA = 1e6
"""Paper preset (float arithmetic): the largest magnitude of ``alpha`` (a frame's term is
at most 255 units, so larger offsets only overflow the weights)."""

MAX_PERIOD = 1_000_000
"""Paper preset: the longest adjustment period ``k`` (frames)."""

MAX_WINDOW = 1_000_000
"""Largest ``advance`` bound and ``confidence_radius`` (nodes)."""

VARY_RECORD = 16
"""Robust preset: how many of the last speeds the path's gate passed (:func:`path_speed`)
:func:`speed_varies` reads."""

VARY_AGE = 64
"""Robust preset: a speed the gate passed counts in :func:`speed_varies` for this many
forward frames (from the one it was passed on): a record the gate has not renewed
lately says nothing of the speed now."""

VARY_BAND = 3
"""Robust preset: a speed the gate passed is *off* one place a frame when it differs from
it by at least ``VARY_BAND / 8`` place a frame (:func:`speed_off`)."""

DEFAULT_CONTRAST = 48
"""Robust preset: the mean absolute deviation (grey levels) low-res images are normalised
to (the middle of the plateau of docs/localise.md's sensitivity table, 32-127)."""

DEFAULT_CONTRAST_PATCH = 2
"""Robust preset: the side (blocks) of the tiles of a low-res image normalised each on its
own: 2, sixteen 2x2 tiles of 64x64 pixels (docs/localise.md, "Local contrast")."""

CONTRAST_PATCHES = (2, 4, 8)
"""The tile sides that divide the 8x8 image; 8 normalises the whole image at once."""

DEFAULT_SHIFT = {"lowres": 2, "lbp": 1}
"""Paper preset: the default likelihood shift per representation. One frame's term spans
0-32 units in both (low-res ``mu`` is in [0, 127], LBP ``mu`` in [0, 64]). Its keys are
the representations the paper preset runs on (:func:`runs_on`)."""


def runs_on(representation: str, preset: str) -> bool:
    """Whether ``preset`` runs on ``representation``: a robust preset on every one, the
    paper's on those of :data:`DEFAULT_SHIFT` (not ``"lowres16"``, whose images it would
    compare unnormalised, nor the Haar signs or the patch-normalised image, which it does
    not describe).

    Examples
    --------
    >>> runs_on("lowres16", "robust"), runs_on("lowres16", "paper"), runs_on("lbp", "paper")
    (True, False, True)
    """
    return preset_group(preset) == "robust" or representation in DEFAULT_SHIFT


def check_int(name: str, value: Any, low: int, high: int | None = None) -> int:
    """``value`` as an int, or a one-line error naming ``name`` and the range."""
    if not isinstance(value, int | np.integer) or isinstance(value, bool):
        raise PpalocError(f"{name}={value!r} must be an integer")
    if value < low or (high is not None and value > high):
        hint = f">= {low}" if high is None else f"in [{low}, {high}]"
        raise PpalocError(f"{name}={value!r} must be {hint}")
    return int(value)


@dataclass(frozen=True)
class Param:
    """One filter parameter's contract: which presets read it, its default and its range.

    Attributes
    ----------
    group : {"robust", "paper"} or None
        The parameter group of the presets that read it (None: every preset); giving it
        to a preset of the other group is an error.
    kind : {"int", "window", "bool", "motion", "gamma", "alpha", "advance", "patch"}
        How a value is checked.
    default : Any
        The value when none (or None) is given; a callable ``default(representation,
        group, values)`` where it depends on them (documented with the field).
    low, high : int, optional
        The accepted range of an ``int``.
    """

    group: str | None
    kind: str
    default: Any
    low: int | None = None
    high: int | None = None


def _param(group: str | None, kind: str, default: Any, low=None, high=None) -> dict:
    return {"param": Param(group, kind, default, low, high)}


FLOAT_ONLY = {
    "enhance": "the sensor cannot divide a node's distance by its neighbours' deviation",
}
"""Options the host's float filter runs and ``ppa8`` and the sensor refuse, with why."""


def local_step(gain: int, window: int) -> int | None:
    """Register units a node loses per strictly closer neighbour (``local_gain``):
    ``gain / (2 window)`` when it is an integer (a DAC constant, what ``ppa8`` and the
    sensor subtract per comparison), else None (float arithmetic only)."""
    step, rest = divmod(int(gain), 2 * int(window))
    return None if rest else step


def _margin_default(representation: str, group: str, values: Mapping[str, Any]) -> int:
    return MARGIN if group == "robust" else PAPER_MARGIN


def _coherent_default(representation: str, group: str, values: Mapping[str, Any]) -> int:
    return COHERENT_SHIFT if group == "robust" else 0


def _keyframes_default(representation: str, group: str, values: Mapping[str, Any]) -> bool:
    return group == "robust" and values.get("motion", "image") == "image"


def _shift_default(representation: str, group: str, values: Mapping[str, Any]) -> int:
    return DEFAULT_SHIFT.get(representation, 2)


@dataclass(frozen=True)
class FilterParams:
    """Every setting of the weighted-node filter (host and sensor), validated.

    Build it with :meth:`create` (the preset's defaults, then the given values); the
    dataclass fields are the resolved values. Each field's one default and one range are
    in its :class:`Param` (``dataclasses.fields(FilterParams)[i].metadata["param"]``), read
    by :meth:`create`, the documentation and the command's checks alike. ``None`` in a
    field of the other preset's group means "not used by this preset".

    Attributes
    ----------
    preset : str
        A registered schedule (:mod:`ppaloc.localise.schedule`): ``"robust"`` (the
        default) or ``"paper"``, or one registered since.
    motion : {"image", "always_forward", "oracle"}
        The motion model. Robust: its decision sets the transition costs. Paper: it
        decides the shift.
    motion_margin, motion_shift, motion_min_support : int
        The image motion test (:func:`ppaloc.localise.motion.forward_decision`); the
        dead zone ``motion_margin`` is 4 with the robust group, 3 with the paper's.
    motion_coherent_shift : int
        Forward also needs ``2**-motion_coherent_shift`` of the textured pixels crossed
        beside another crossing (:func:`ppaloc.localise.motion.coherent_crossings`:
        noise crosses pixels one by one); 0 turns it off. Default 8 (1/256) with the
        robust group, 0 with the paper's (Algorithm 1 as the paper ran it).
    confidence_radius : int
        ``R`` of the confidence: best weight minus the best outside ``node +- R``.
    keyframes : bool
        Map one node per distinct place: a reference frame starts a new node only when
        the motion test says forward from the previous reference frame (default: on for
        the robust group with the image model); False maps one node per frame (the paper).
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
        Robust: the most nodes one frame may advance. Range [1, 3]; default 3 (a query
        up to three places a frame ahead of the map; each node beyond one still costs
        ``skip_cost``).
    contrast : int
        Robust, low-res images: the mean absolute deviation (grey levels) every image,
        live or node, is brought near by :func:`ppaloc.place.normalise_contrast` (offset
        removed, gain from x1/2 to x4) before the comparison, so that light and contrast
        changes (dusk, night, snow) do not decide the match; 0 compares the images as
        they are. Range [0, 127]; default 48. LBP codes need none (they are invariant
        to any increasing change of intensity).
    contrast_patch : int
        Robust, low-res images: the side, in 32x32-pixel blocks, of the square tiles
        that ``contrast`` normalises each on its own (one of :data:`CONTRAST_PATCHES`;
        default 2, sixteen tiles of 2x2 blocks, 64x64 pixels; 8 is the whole image). On
        the 16x16 grid of ``lowres16`` a tile covers the same pixels, 4x4 cells. Local
        normalisation takes out light that varies across the image (a bright sky over a
        dark road, street lights at night), which one offset and gain per image leave
        in. The controller applies it to the 64 codes it reads, so the sensor's
        time does not change.
    enhance : int
        Robust, host in float arithmetic only: SeqSLAM's local contrast enhancement of
        each frame's distances along the map (:func:`ppaloc.localise.enhance.
        contrast_enhance`, window ``enhance`` nodes, SeqSLAM's and the particle filter's
        ``R`` = 10), the likelihood then read from the z-scores; 0 (the default) reads
        the distances as they are. Not part of the ppa8 contract: the sensor cannot
        divide each node's distance by its neighbours' deviation, so ``ppa8`` and the
        sensor refuse it (docs/localise.md, "Local contrast of the distances").
    local_gain, local_window : int
        Robust: on each frame that adds evidence, every node also loses ``local_gain``
        units times the share of the ``2 local_window`` nodes around it that are closer
        to the frame (:func:`ppaloc.localise.enhance.closer_share`; on a map with runs
        the nodes next to its run, :func:`~ppaloc.localise.enhance.place_neighbours`):
        contrast between neighbouring places, which the transition needs to follow a
        varying speed, beside the raw likelihood's evidence. Ranges [0, 32] (default 2,
        half the raw term's span ``gain``; 0 is off) and [1, 16] (default 1: the two
        neighbours, one unit each). In ``ppa8`` and on the sensor a closer neighbour costs
        ``local_gain / (2 local_window)`` units, which must be an integer (a DAC
        constant, :func:`local_step`; ``onsensor.local``).
    speed_window, speed_confidence : int
        Robust: the speed of the estimate's own path over its last ``speed_window``
        forward frames (:func:`path_speed`) centres a forward frame's transition costs
        (:func:`transition_costs`), where the estimates at both ends and between them
        (``speed_window + 1``) had a confidence of at least ``speed_confidence`` units
        and the path only advanced, at most ``max_advance`` places a frame. Ranges
        [0, 64] (default 8; 0 is off: the costs of one node a frame) and [0, 127]
        (default 32). Controller integers only: the sensor runs it unchanged.
    lost_window : int
        Robust: the reported confidence is 0 while the estimate has held one place
        over its last ``lost_window`` forward frames, and on the still frames after
        them (:func:`path_stalled`): a path that stands still while the motion test
        sees the query move does not explain the frames (the query left the map, or a
        node that matches everything holds the estimate). Range [0, 64] (default 8; 0 is off).
        The estimates and the speed's gate are unchanged; controller integers only.
    speed_vary : int
        Robust: where at least ``speed_vary`` of the last :data:`VARY_RECORD` speeds the
        path's gate passed, within the last :data:`VARY_AGE` forward frames, were off one
        place a frame (:func:`speed_varies`), the query's
        speed is known to vary, and a forward frame whose path shows no speed gets the
        transition costs at half scale (:func:`transition_costs`): the speed is unknown
        there, so staying and skipping cost less. Range [0, 16] (default 4; 0 is off).
        Controller integers only.
    still_decay : int
        Robust: on a still frame the reported confidence falls by ``still_decay`` units
        for each frame since the last forward decision, to 0 at the least, unless the
        estimate's place or the next stands for several reference frames (the map stood
        still there too, :meth:`~ppaloc.topomap.TopoMap.place_frames`;
        :func:`stood_at_or_next`, :func:`still_score`): a
        still frame adds no evidence, so the estimate is the one the query stopped
        with, and a query that stops where the map kept moving may have stopped a
        place or two from it. Range [0, 127] (default 16; 0 is off). The estimates and
        the speed's gate are unchanged; controller integers only.
    lane_speed, lanes : int
        Robust: further sets of weights, the *speed lanes*, run the same frame, each with
        a forward frame's costs centred on its own speed: ``lanes`` speeds evenly spaced
        above one place a frame up to ``lane_speed`` (:func:`lane_speeds`; 3/2 and 2 at
        the defaults). Where the filter's own path shows no speed and a lane's path
        shows one (its gate, :func:`path_speed`) outside the speeds the filter follows
        on its own costs, the filter's costs centre on that lane's speed, the first such
        lane's, fastest first (:func:`lane_speed_taken`): a query faster than the map
        is followed without a setting for it. Ranges [0, 3] (default 2; 0 is off, 1 is the filter's
        own speed and refused; at most ``max_advance``) and [1, 4] (default 2). On the
        sensor each lane is a further sensor that takes the same frames
        (docs/onsensor.md, "The speed lanes"). Controller integers only.
    slow_lane : bool
        Robust: one more speed lane, at half a place a frame (the slowest speed
        :func:`path_speed` shows), whose path's speed the filter takes where it is at or
        below the bottom of the filter's own range (:func:`lane_speed_taken`): a query
        slower than the map is followed as a faster one is. A lane whose path stalled
        (:func:`path_stalled`) hands over no speed. Default True.
    lane_lead : int
        Robust: the filter reports a speed lane's estimate and confidence instead of its
        own where the lane's confidence leads its own by at least ``lane_lead`` units,
        the surest such lane's, unless its own path stalled (:func:`lane_reported`):
        where the filter has lost a query faster or slower than its costs follow and a
        lane holds it. Range [0, 127] (default 32; 0 is off). Controller integers only:
        the sensor reads every lane's confidence already.
    lane_confidence : int
        Robust: the confidence a speed lane's path must hold at each of its
        ``speed_window + 1`` estimates for the filter to take its speed
        (:func:`path_speed`'s gate with this in place of ``speed_confidence``;
        :func:`lane_speed_taken`). Lower than the filter's own gate: a lane's speed is
        taken only where the filter's own path shows none and only outside the speeds its
        own costs follow, and a lane that holds a query faster or slower than the map is
        sure of it less often than a filter that follows one at its pace. Range [0, 127]
        (default 24). Controller integers only.
    lane_speed_lead : int
        Robust: where neither the filter's own path nor any lane's passes its gate, the
        surest of the lanes faster than the map hands its path's speed over on the
        frame's evidence alone, where its confidence is at least ``lane_confidence``,
        leads the filter's own last one by at least ``lane_speed_lead`` units and its
        place is at most ``confidence_radius`` places ahead of the filter's
        (:func:`lane_speed_led`): its path's speed with no confidence asked of it, taken
        as :func:`lane_speed_taken` takes a lane's. A lane that holds a query faster
        than the map while the filter falls behind it is seldom sure of it nine frames
        in a row, and is then the surest of the weight sets by a wide margin. Range [0,
        127] (default 8; 0 is off). Controller integers only.
    centroid_radius, centroid_temperature : int
        Robust: the frame reports the rounded centroid of the nodes within
        ``centroid_radius`` of the detected one, each weighed by ``exp((w - w_max) /
        centroid_temperature)`` over those nodes, their weights as the controller reads
        them (one ADC read each on the sensor and in ``ppa8``; :func:`local_centroid`):
        where a neighbour's weight is nearly the best, the query often stands between
        them or on it. The detection, the confidence and everything the filter goes on
        from keep the detected node (so on the host and the ideal sensor nothing else
        changes; a noisy sensor's reads draw readout noise like any other). Ranges [0, 8]
        (default 2; 0 reports the detected node, and 1 nearly always does: a neighbour
        pulls the centroid at most half a node) and [1, 64] units (default 2, half a
        frame's likelihood span ``gain``).
    concentration_radius, concentration_temperature : int
        Robust: the reported confidence is the margin (``confidence_radius``) times the
        weights' concentration about the detected node: the share of ``exp((w - w_max)
        / concentration_temperature)`` that the detected node and its two neighbours
        hold among the nodes within ``concentration_radius`` of it, their weights as the
        controller reads them (:func:`concentration`). The margin sees competitors
        beyond ``confidence_radius`` places; a hill of the weights that is broad, or a
        second one close by, says the filter is unsure where along the route it is,
        which the margin does not see. Only the reported confidence takes it: the path's
        gate, the lanes' leads and everything the filter goes on from keep the margin.
        Ranges [0, 8] (default 4; 0 and 1 are off: the share is then 1) and [1, 64]
        units (default 4, a frame's likelihood span ``gain``).
    alpha, gamma, k, shift, advance
        Paper: Algorithm 1's likelihood offset (None: from the map), adjustment factor
        (one of :data:`GAMMAS`, default 1/2), adjustment period (default 1), likelihood
        shift (default :data:`DEFAULT_SHIFT` of the representation) and forward window
        (default ``(1, 1)``) (docs/localise.md).
    """

    preset: str = "robust"
    motion: str = field(default="image", metadata=_param(None, "motion", "image"))
    motion_margin: int = field(
        default=MARGIN, metadata=_param(None, "int", _margin_default, 0, 127)
    )
    motion_shift: int = field(default=6, metadata=_param(None, "int", 6, 0, 16))
    motion_min_support: int = field(default=1024, metadata=_param(None, "int", 1024, 0, 256 * 256))
    motion_coherent_shift: int = field(
        default=COHERENT_SHIFT, metadata=_param(None, "int", _coherent_default, 0, 16)
    )
    confidence_radius: int = field(default=10, metadata=_param(None, "int", 10, 0, MAX_WINDOW))
    keyframes: bool = field(default=True, metadata=_param(None, "bool", _keyframes_default))
    gain: int | None = field(default=4, metadata=_param("robust", "int", 4, 1, 32))
    memory: int | None = field(default=127, metadata=_param("robust", "int", 127, 8, 127))
    stay_cost: int | None = field(default=4, metadata=_param("robust", "int", 4, 0, 64))
    move_cost: int | None = field(default=4, metadata=_param("robust", "int", 4, 0, 64))
    skip_cost: int | None = field(default=4, metadata=_param("robust", "int", 4, 0, 64))
    max_advance: int | None = field(default=3, metadata=_param("robust", "int", 3, 1, 3))
    contrast: int | None = field(
        default=DEFAULT_CONTRAST,
        metadata=_param("robust", "int", DEFAULT_CONTRAST, 0, MAX_CONTRAST),
    )
    contrast_patch: int | None = field(
        default=DEFAULT_CONTRAST_PATCH,
        metadata=_param("robust", "patch", DEFAULT_CONTRAST_PATCH),
    )
    enhance: int | None = field(default=0, metadata=_param("robust", "window", 0, 0, MAX_WINDOW))
    local_gain: int | None = field(default=2, metadata=_param("robust", "int", 2, 0, 32))
    local_window: int | None = field(default=1, metadata=_param("robust", "int", 1, 1, 16))
    speed_window: int | None = field(default=8, metadata=_param("robust", "int", 8, 0, 64))
    speed_confidence: int | None = field(default=32, metadata=_param("robust", "int", 32, 0, 127))
    lost_window: int | None = field(default=8, metadata=_param("robust", "int", 8, 0, 64))
    speed_vary: int | None = field(default=4, metadata=_param("robust", "int", 4, 0, VARY_RECORD))
    still_decay: int | None = field(default=16, metadata=_param("robust", "int", 16, 0, 127))
    lane_speed: int | None = field(default=2, metadata=_param("robust", "int", 2, 0, 3))
    lanes: int | None = field(default=2, metadata=_param("robust", "int", 2, 1, 4))
    slow_lane: bool | None = field(default=True, metadata=_param("robust", "bool", True))
    lane_lead: int | None = field(default=32, metadata=_param("robust", "int", 32, 0, 127))
    lane_confidence: int | None = field(default=24, metadata=_param("robust", "int", 24, 0, 127))
    lane_speed_lead: int | None = field(default=8, metadata=_param("robust", "int", 8, 0, 127))
    centroid_radius: int | None = field(default=2, metadata=_param("robust", "int", 2, 0, 8))
    centroid_temperature: int | None = field(default=2, metadata=_param("robust", "int", 2, 1, 64))
    concentration_radius: int | None = field(default=4, metadata=_param("robust", "int", 4, 0, 8))
    concentration_temperature: int | None = field(
        default=4, metadata=_param("robust", "int", 4, 1, 64)
    )
    alpha: float | None = field(default=None, metadata=_param("paper", "alpha", None))
    gamma: float | None = field(default=None, metadata=_param("paper", "gamma", 0.5))
    k: int | None = field(default=None, metadata=_param("paper", "int", 1, 1, MAX_PERIOD))
    shift: int | None = field(default=None, metadata=_param("paper", "int", _shift_default, 0, 16))
    advance: tuple[int, int] | None = field(
        default=None, metadata=_param("paper", "advance", (1, 1))
    )

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
        representation : {"lowres", "lowres16", "lbp", "haar", "patch"}
            Sets the paper preset's default likelihood shift (lowres16, haar and patch run
            the robust group only; patch in float only).
        preset : str
            A registered schedule's name (:data:`PRESETS`: ``"robust"``, ``"paper"``).
        arithmetic : {"float", "ppa8"}
            ``"ppa8"`` requires an integer ``alpha`` (a DAC constant).
        **values
            Any field; None takes the default; a field of the other preset's group is
            an error naming the preset it belongs to.

        Examples
        --------
        >>> FilterParams.create("lbp").transition_defaults()
        (4, 4, 4, 3)
        >>> FilterParams.create("lbp", preset="paper").shift
        1
        """
        group = preset_group(preset)
        if not runs_on(representation, preset):
            why = {
                "lowres16": ", which compares contrast-normalised images only",
                "haar": ", which the paper does not describe",
                "patch": ", which the paper does not describe",
            }.get(representation, "")
            raise PpalocError(
                f"preset={preset!r} does not run on the {representation} place{why}; use a "
                f"robust preset, or {' or '.join(DEFAULT_SHIFT)}"
            )
        if arithmetic == "ppa8" and representation in FLOAT_PLACES:
            raise PpalocError(
                f"arithmetic='ppa8' does not run on the {representation} place, which no "
                "register holds (a host place of floats); use arithmetic='float'"
            )
        params = {f.name: f.metadata["param"] for f in dataclasses.fields(cls) if f.metadata}
        unknown = sorted(set(values) - set(params))
        if unknown:
            raise PpalocError(
                f"unknown filter parameter {unknown[0]!r}; parameters: {', '.join(sorted(params))}"
            )
        for key, spec in params.items():
            if spec.group not in (None, group) and values.get(key) is not None:
                other = spec.group
                methods = (
                    "weighted-node-paper-*, onsensor-paper-*"
                    if other == "paper"
                    else "weighted-node-*, onsensor-*"
                )
                raise PpalocError(
                    f"{key}={values[key]!r} is a parameter of preset {other!r}, not of "
                    f"preset {preset!r}; pass preset={other!r} (the methods {methods}) to use it"
                )
        out: dict[str, Any] = {"preset": preset}
        for key, spec in params.items():
            if spec.group not in (None, group):
                out[key] = None
                continue
            value = values.get(key)
            if value is None or (spec.kind == "advance" and not value):
                value = spec.default
                if callable(value):
                    value = value(representation, group, values)
                if spec.kind in ("alpha",):
                    out[key] = value
                    continue
            out[key] = _check(key, value, spec, arithmetic)
        for key, why in FLOAT_ONLY.items():
            if out.get(key) and arithmetic != "float":
                raise PpalocError(
                    f"{key}={out[key]} runs on the host in float arithmetic only ({why}); "
                    f"use a weighted-node-* method with arithmetic='float', or {key}=0"
                )
        lane, most = out.get("lane_speed"), out.get("max_advance")
        if lane == 1:
            raise PpalocError(
                "lane_speed=1 is the filter's own speed: use 0 (no lane) or 2 .. max_advance"
            )
        if lane and lane > most:
            if values.get("lane_speed") is not None:
                raise PpalocError(
                    f"lane_speed={lane} is above max_advance={most}: the lane advances at "
                    f"most max_advance places a frame; use 0 (no lane) or 2 .. {most}"
                )
            out["lane_speed"] = 0  # the default lane needs room the given max_advance leaves out
        gain, window = out.get("local_gain"), out.get("local_window")
        if gain and arithmetic != "float" and local_step(gain, window) is None:
            raise PpalocError(
                f"local_gain={gain} with local_window={window}: in {arithmetic} arithmetic "
                f"and on the sensor a closer neighbour costs local_gain / (2 local_window) "
                f"units, a DAC integer; use a multiple of {2 * window}, or arithmetic='float'"
            )
        return cls(**out)

    @property
    def group(self) -> str:
        """The parameter group of this preset (``"robust"`` or ``"paper"``)."""
        return preset_group(self.preset)

    def transition_defaults(self) -> tuple[int, int, int, int]:
        """``(stay_cost, move_cost, skip_cost, max_advance)`` (robust group)."""
        assert self.group == "robust"
        return (self.stay_cost, self.move_cost, self.skip_cost, self.max_advance)  # type: ignore[return-value]

    def as_dict(self) -> dict[str, Any]:
        """The resolved parameters as plain values (for reports and results files)."""
        out = {f.name: getattr(self, f.name) for f in dataclasses.fields(self)}
        if out["advance"] is not None:
            out["advance"] = list(out["advance"])
        return out


def preset_group(preset: str) -> str:
    """The parameter group (``"robust"`` or ``"paper"``) of a registered preset, or a
    one-line error listing the presets."""
    from ppaloc.localise.schedule import SCHEDULES  # the registry imports this module

    schedule = SCHEDULES.get(preset) if isinstance(preset, str) else None
    if schedule is None:
        raise PpalocError(f"preset={preset!r} is not one of {', '.join(SCHEDULES)}")
    return schedule.uses


def _check(key: str, value: Any, spec: Param, arithmetic: str) -> Any:
    """``value`` checked against ``spec`` (a one-line error naming ``key`` otherwise)."""
    if spec.kind == "int":
        return check_int(key, value, spec.low, spec.high)  # type: ignore[arg-type]
    if spec.kind == "window":
        window = check_int(key, value, spec.low, spec.high)  # type: ignore[arg-type]
        if window == 1:
            raise PpalocError(f"{key}=1 must be 0 (off) or at least 2 nodes")
        return window
    if spec.kind == "bool":
        if not isinstance(value, bool | np.bool_):
            raise PpalocError(f"{key}={value!r} must be True or False")
        return bool(value)
    if spec.kind == "motion":
        if value not in MOTIONS:
            raise PpalocError(f"{key}={value!r} is not one of {', '.join(MOTIONS)}")
        return value
    if spec.kind == "patch":
        if isinstance(value, bool) or value not in CONTRAST_PATCHES:
            sides = ", ".join(map(str, CONTRAST_PATCHES))
            raise PpalocError(f"{key}={value!r} must be one of {sides} (blocks of the 8x8 image)")
        return int(value)
    if spec.kind == "gamma":
        if value not in GAMMAS:
            raise PpalocError(
                f"gamma={value!r} must be one of {GAMMAS} (a PPA scales only by halving)"
            )
        return float(value)
    if spec.kind == "advance":
        try:
            lo, hi = value
        except (TypeError, ValueError):
            raise PpalocError(f"advance={value!r} must be a pair (lo, hi)") from None
        lo_ok = check_int("advance[0]", lo, 0, MAX_WINDOW)
        if not lo_ok <= check_int("advance[1]", hi, 1, MAX_WINDOW):
            raise PpalocError(f"advance={value!r} must be (lo, hi) with 0 <= lo <= hi, hi >= 1")
        return (int(lo), int(hi))
    if spec.kind == "alpha":
        if arithmetic == "ppa8":
            return check_int("alpha", value, -128, 127)  # a DAC constant
        if isinstance(value, bool) or not isinstance(value, int | float | np.number):
            raise PpalocError(f"alpha={value!r} must be a number")
        if not (math.isfinite(float(value)) and abs(float(value)) <= MAX_ALPHA):
            bounds = f"[-{MAX_ALPHA:g}, {MAX_ALPHA:g}]"
            raise PpalocError(f"alpha={value!r} must be a number in {bounds}")
        return value
    raise AssertionError(f"unknown parameter kind {spec.kind!r}")


FILTER_KEYS = tuple(f.name for f in dataclasses.fields(FilterParams))
"""Every parameter name of the filter contract."""


class PathSpeed(NamedTuple):
    """A speed as the controller holds it: ``places`` advanced over ``frames`` forward
    frames (two integers, so ``v = places / frames`` needs no division)."""

    places: int
    frames: int


def transition_costs(
    moved: bool, params: FilterParams, speed: PathSpeed | None = None, varies: bool = False
) -> tuple[int, ...]:
    """Cost of advancing ``d = 0 .. max_advance`` nodes, given the motion test's decision.

    The motion test is evidence: on *forward* staying costs ``stay_cost`` and one node is
    free; on *stay* staying is free and one node costs ``move_cost``. Each node beyond
    the first adds ``skip_cost``.

    ``speed`` (:func:`path_speed`) centres a forward frame's costs on ``v = places /
    frames`` instead of one node: ``d`` costs ``stay_cost (v - d)`` below ``v`` and
    ``skip_cost (d - v)`` above it, rounded half up (``floor(x + 1/2)``, in integers:
    ``(2 k |d frames - places| + frames) // (2 frames)``), less the least of them. No
    speed, or ``v = 1``, gives the costs above. With no speed where the query's speed
    ``varies`` (:func:`speed_varies`), a forward frame's costs are those of one node a
    frame at half scale: ``stay_cost // 2`` and ``skip_cost // 2`` (the speed is unknown
    and known to change, so a pause or a skip is no longer unlikely).

    Examples
    --------
    >>> p = FilterParams.create("lbp", stay_cost=5, move_cost=3, skip_cost=2, max_advance=3)
    >>> transition_costs(True, p), transition_costs(False, p)
    ((5, 0, 2, 4), (0, 3, 5, 7))
    >>> q = FilterParams.create("lbp")
    >>> transition_costs(True, q, PathSpeed(3, 2)), transition_costs(True, q, PathSpeed(2, 3))
    ((4, 0, 0, 4), (2, 0, 4, 8))
    >>> transition_costs(True, q, varies=True), transition_costs(False, q, varies=True)
    ((2, 0, 2, 4), (0, 4, 8, 12))
    """
    stay, move, skip, most = params.transition_defaults()
    if not moved:
        return (0, *(move + skip * (d - 1) for d in range(1, most + 1)))
    if speed is None and varies:
        stay, skip = stay // 2, skip // 2
    a, f = speed or (1, 1)
    costs = [
        ((stay if d * f < a else skip) * abs(d * f - a) * 2 + f) // (2 * f) for d in range(most + 1)
    ]
    least = min(costs)
    return tuple(c - least for c in costs)


def assumed_speeds(params: FilterParams) -> tuple[float, float]:
    """The query speeds, in places a query frame, the filter follows without knowing the
    speed: its ``speed_range``, checked against the query by ``ppaloc evaluate`` as every
    sequence method's is (:mod:`ppaloc.evaluate.speed`).

    Robust preset: a forward frame's costs assume one place a frame (item 1), so a path
    at a steady ``v`` pays ``stay_cost (1 - v)`` units a frame below it and ``skip_cost
    (v - 1)`` above it, against a frame's evidence of about ``gain`` units between the
    best and the mean node. The filter's own range is where that is at most half the
    evidence, ``1 - gain / (2 stay_cost)`` to ``1 + gain / (2 skip_cost)``, within ``0 ..
    max_advance``: 0.5 to 1.5 at the defaults. Above it the speed lanes
    (:func:`lane_speeds`, :func:`lane_speed_taken`) follow the query up to the fastest
    lane's speed, ``lane_speed``, 2 at the defaults, and below it down to the slow
    lane's, 1/2 (``slow_lane``): on a generated route the filter keeps its
    one-place-a-frame figure from half a place a frame to 1.5, loses part of it at 2
    and keeps most of it at 0.35 (docs/localise.md, "A query faster or slower than the
    map"). Paper preset: the nodes one forward frame shifts the
    weights, ``advance`` (one). The check reads the query's speed in reference frames,
    which are places wherever the reference moves.

    Examples
    --------
    >>> assumed_speeds(FilterParams.create("lbp"))
    (0.5, 2.0)
    >>> assumed_speeds(FilterParams.create("lbp", lane_speed=0))
    (0.5, 1.5)
    >>> assumed_speeds(FilterParams.create("lbp", stay_cost=8, skip_cost=2))
    (0.5, 2.0)
    >>> assumed_speeds(FilterParams.create("lbp", stay_cost=8, slow_lane=False))
    (0.75, 2.0)
    >>> assumed_speeds(FilterParams.create("lbp", skip_cost=0))
    (0.5, 3.0)
    >>> assumed_speeds(FilterParams.create("lbp", preset="paper"))
    (1.0, 1.0)
    """
    if params.preset == "paper":
        lo, hi = params.advance or (1, 1)
        return (float(lo), float(hi))
    gain, stay, skip = int(params.gain), int(params.stay_cost), int(params.skip_cost)  # type: ignore[arg-type]
    most = float(params.max_advance)  # type: ignore[arg-type]
    lo = 0.0 if stay == 0 else max(0.0, 1.0 - gain / (2 * stay))
    hi = most if skip == 0 else min(most, 1.0 + gain / (2 * skip))
    if params.slow_lane:
        lo = min(lo, 0.5)
    return (lo, max(hi, float(params.lane_speed or 0)))


def lane_speeds(params: FilterParams) -> tuple[PathSpeed, ...]:
    """The speeds of the filter's speed lanes, fastest first: ``lanes`` speeds evenly
    spaced above one place a frame up to ``lane_speed``, ``1 + k (lane_speed - 1) /
    lanes`` for ``k = lanes .. 1``, as reduced fractions (none where ``lane_speed`` is
    0), then with ``slow_lane`` half a place a frame.

    The filter's own costs follow a query from ``1 - gain / (2 stay_cost)`` to ``1 +
    gain / (2 skip_cost)`` places a frame (1/2 to 3/2 at the defaults,
    :func:`assumed_speeds`), and a lane's costs follow it about as far either side of
    the lane's speed: lanes at 3/2 and 2 cover the speeds between the filter's own and
    twice the map's pace with room to spare, and a lane at 1/2 those below the filter's.

    Examples
    --------
    >>> lane_speeds(FilterParams.create("lbp"))
    (PathSpeed(places=2, frames=1), PathSpeed(places=3, frames=2), PathSpeed(places=1, frames=2))
    >>> lane_speeds(FilterParams.create("lbp", lanes=1, slow_lane=False))
    (PathSpeed(places=2, frames=1),)
    >>> lane_speeds(FilterParams.create("lbp", lane_speed=0, slow_lane=False))
    ()
    >>> [a / f for a, f in lane_speeds(FilterParams.create("lbp", lane_speed=3, lanes=4))]
    [3.0, 2.5, 2.0, 1.5, 0.5]
    """
    top, n = int(params.lane_speed or 0), int(params.lanes or 0)
    out = []
    for k in range(n, 0, -1) if top else ():
        a, f = n + k * (top - 1), n
        g = math.gcd(a, f)
        out.append(PathSpeed(a // g, f // g))
    if params.slow_lane:
        out.append(PathSpeed(1, 2))
    return tuple(out)


def lane_speed_taken(lane_path: PathSpeed | None, params: FilterParams) -> PathSpeed | None:
    """The speed of a speed lane's path (:func:`lane_speeds`) where the filter takes it,
    or None.

    ``lane_path`` is :func:`path_speed` of the lane's own estimates (the same gate: a
    path the lane was sure of over ``speed_window`` forward frames). The filter takes it
    where it is outside what the filter's own costs follow (:func:`assumed_speeds`
    without the lanes: ``1 - gain / (2 stay_cost)`` to ``1 + gain / (2 skip_cost)``,
    within ``0 .. max_advance``), the speeds at which a path pays more than half a
    frame's evidence a frame; the speeds between are the filter's own. In integers:
    ``2 skip places >= (2 skip + gain) frames`` or ``places >= max_advance frames``
    above, ``2 stay places <= (2 stay - gain) frames`` below.

    Examples
    --------
    >>> p = FilterParams.create("lbp")
    >>> lane_speed_taken(PathSpeed(14, 8), p), lane_speed_taken(PathSpeed(11, 8), p)
    (PathSpeed(places=14, frames=8), None)
    >>> lane_speed_taken(PathSpeed(12, 8), p)  # 3/2: the top of the filter's own
    PathSpeed(places=12, frames=8)
    >>> lane_speed_taken(PathSpeed(4, 8), p), lane_speed_taken(PathSpeed(5, 8), p)
    (PathSpeed(places=4, frames=8), None)
    """
    if lane_path is None:
        return None
    gain, stay, skip = int(params.gain), int(params.stay_cost), int(params.skip_cost)  # type: ignore[arg-type]
    most = int(params.max_advance)  # type: ignore[arg-type]
    a, f = lane_path
    above = (skip > 0 and 2 * skip * a >= (2 * skip + gain) * f) or a >= most * f
    below = stay > 0 and 2 * stay * a <= (2 * stay - gain) * f
    return lane_path if above or below else None


def lane_speed_led(
    own: tuple[int, float] | None, lanes: Sequence[tuple[int, float]], params: FilterParams
) -> int | None:
    """The speed lane whose path's speed the filter takes on this frame's lead alone, or
    None.

    ``own`` is the filter's ``(place, confidence)`` on its last forward frame (None
    before the first) and ``lanes`` the lanes' on this one, fastest first
    (:func:`lane_speeds`; each confidence after the lane's own still-frame and
    stalled-path rules). Of the lanes faster than one place a frame, the surest (the
    first of equals), where its confidence is at least ``lane_confidence``, leads the
    filter's by at least ``lane_speed_lead`` units, and its place is where a query at
    its speed leaves the filter's: at most ``confidence_radius`` places ahead of it.
    None where ``lane_speed_lead`` is 0.

    Asked only where neither the filter's own path nor a lane's passed its gate
    (:func:`path_speed`): a lane that holds a query faster than the filter's costs
    follow is the surest weight set by a wide margin on most frames as the filter falls
    behind, seldom on nine in a row. A surest lane elsewhere on the map holds a place
    that looks like the query's, which says nothing of its speed. The slow lane hands
    over nothing here (its path's gate only): at the map's pace on Gardens Point it
    leads an unsure filter close to the filter's own place. Comparisons only: the
    controller's arithmetic.

    Examples
    --------
    >>> p = FilterParams.create("lbp")  # lanes at 2, 3/2 and 1/2; lane_speed_lead 8
    >>> lane_speed_led((40, 6.0), [(44, 20.0), (43, 31.0), (40, 2.0)], p)
    1
    >>> lane_speed_led((40, 24.0), [(44, 20.0), (43, 31.0)], p) is None  # a lead of 7
    True
    >>> lane_speed_led((40, 0.0), [(44, 23.5), (43, 12.0)], p) is None  # below 24
    True
    >>> lane_speed_led((40, 6.0), [(90, 31.0), (43, 20.0)], p) is None  # 50 places on
    True
    >>> lane_speed_led((40, 6.0), [(44, 28.0), (43, 5.0), (37, 31.0)], p)  # not the slow
    0
    >>> lane_speed_led((40, 0.0), [(44, 90.0)], FilterParams.create("lbp", lane_speed_lead=0))
    """
    lead = int(params.lane_speed_lead or 0)
    if not lead or own is None:
        return None
    faster = [k for k, (a, f) in enumerate(lane_speeds(params)) if a > f and k < len(lanes)]
    if not faster:
        return None
    best = max(faster, key=lambda k: (lanes[k][1], -k))
    place, score = lanes[best]
    if score < int(params.lane_confidence or 0) or score < own[1] + lead:
        return None
    return best if 0 <= place - own[0] <= int(params.confidence_radius) else None


def lane_reported(
    score: float, lane_scores: Sequence[float], params: FilterParams, stalled: bool = False
) -> int | None:
    """The speed lane whose estimate the filter reports instead of its own, or None.

    ``score`` is the filter's confidence of the frame and ``lane_scores`` the lanes',
    fastest first (:func:`lane_speeds`; each after its own still-frame and stalled-path
    rules). A lane's estimate is reported where its confidence leads the filter's by at
    least ``lane_lead`` units: the surest such lane's, the first of equals. All weight
    sets take the same likelihood, so their confidences are margins in the same units;
    a lane that leads by as much as a path must hold to set a speed
    (``speed_confidence``) explains the recent frames where the filter's own costs lost
    them (a query at a speed the filter's costs do not follow). None where
    ``lane_lead`` is 0, and where the filter's own path ``stalled``
    (:func:`path_stalled`): a filter that reports itself lost (the query left the map)
    stays lost. Comparisons only: the controller's arithmetic.

    Examples
    --------
    >>> p = FilterParams.create("lbp")
    >>> lane_reported(4.0, [40.0, 36.0, 0.0], p), lane_reported(10.0, [40.0, 41.5], p)
    (0, None)
    >>> lane_reported(0.0, [33.0, 40.0], p)  # the surest of those that lead
    1
    >>> lane_reported(0.0, [33.0, 40.0], p, stalled=True) is None
    True
    >>> lane_reported(0.0, [90.0], FilterParams.create("lbp", lane_lead=0)) is None
    True
    """
    lead = int(params.lane_lead or 0)
    if not lead or not lane_scores or stalled:
        return None
    best = max(range(len(lane_scores)), key=lambda k: (lane_scores[k], -k))
    return best if lane_scores[best] >= score + lead else None


def speed_remedy(params: FilterParams) -> str:
    """What widens the speeds the filter follows (:func:`assumed_speeds`), for the speed
    check's warning: the robust preset's costs; for the paper preset, the robust one.

    Examples
    --------
    >>> speed_remedy(FilterParams.create("lbp"))[:44]
    'lower skip_cost for a faster query (1: up to'
    """
    if params.preset == "paper":
        return "use the robust preset (0.5 to 2 places a frame, wider with lower costs)"
    hi = assumed_speeds(dataclasses.replace(params, skip_cost=1))[1]
    return (
        f"lower skip_cost for a faster query (1: up to {hi:g} places a frame) or stay_cost for "
        "a slower one, or subsample the query"
    )


class DeclaredSpeeds:
    """The speeds a weighted-node localiser declares, from its ``params`` (one contract for
    the host filter and the sensor): what ``ppaloc evaluate`` checks the query against, as
    for every sequence method (:mod:`ppaloc.evaluate.speed`)."""

    params: FilterParams

    @property
    def speed_range(self) -> tuple[float, float]:
        """The query speeds, in places a query frame, the filter follows without knowing
        the speed (:func:`assumed_speeds`; 0.5 to 2 at the robust defaults)."""
        return assumed_speeds(self.params)

    @property
    def speed_remedy(self) -> str:
        """What widens :attr:`speed_range`, named by the speed check's warning
        (:func:`speed_remedy`)."""
        return speed_remedy(self.params)

    @property
    def follows_stops(self) -> bool:
        """Whether the filter's motion model tells a standing query from a moving one (the
        image test and the oracle do; ``always_forward`` does not): its speed check leaves
        the query's stops out, which it follows whatever its range."""
        return self.params.motion != "always_forward"


def path_speed(
    places: Sequence[int],
    scores: Sequence[float],
    params: FilterParams,
    confidence: int | None = None,
) -> PathSpeed | None:
    """The speed the estimate's own path shows, or None where it shows none.

    ``places`` and ``scores`` are the estimate's place and confidence on the forward
    frames so far (oldest first). Over the last ``speed_window`` of them (``W``), the
    path advanced ``a = places[-1] - places[-1-W]`` places: the speed is ``(a, W)``,
    clipped to 1/2 .. 2 places a frame. None (the costs of one node a frame) while fewer
    than ``W + 1`` estimates are known, where ``speed_window`` is 0, and where the path
    is not one the transition could have taken with confidence: a step back or beyond
    ``max_advance`` (a re-localisation), or a confidence below ``speed_confidence`` at
    any of the ``W + 1`` estimates (a path locked on wrong places would set a wrong
    speed; ``confidence`` in its place where given: a speed lane's gate,
    ``lane_confidence``). Integers and comparisons only: the controller's arithmetic.

    Examples
    --------
    >>> p = FilterParams.create("lbp", speed_window=4, speed_confidence=16)
    >>> path_speed([3, 5, 6, 8, 9, 11], [40] * 6, p)  # 6 places in 4 frames
    PathSpeed(places=6, frames=4)
    >>> path_speed([3, 5, 6, 8, 9, 11], [40, 40, 40, 8, 40, 40], p) is None
    True
    >>> path_speed([0, 0, 0, 0, 1], [40] * 5, p)  # 1/4 a frame: clipped
    PathSpeed(places=1, frames=2)
    >>> path_speed([3, 5, 6, 8, 9, 11], [40, 40, 40, 8, 40, 40], p, confidence=8)
    PathSpeed(places=6, frames=4)
    """
    w = int(params.speed_window or 0)
    if w == 0 or len(places) <= w:
        return None
    path = np.asarray(places[-1 - w :], dtype=np.int64)
    steps = np.diff(path)
    if steps.min() < 0 or steps.max() > int(params.max_advance):  # type: ignore[arg-type]
        return None
    least = params.speed_confidence if confidence is None else confidence
    if min(scores[-1 - w :]) < least:  # type: ignore[operator]
        return None
    a = int(path[-1] - path[0])
    if 2 * a < w:
        return PathSpeed(1, 2)
    if a > 2 * w:
        return PathSpeed(2, 1)
    return PathSpeed(a, w)


def speed_off(speed: PathSpeed) -> bool:
    """Whether a speed the path's gate passed is off one place a frame by at least
    :data:`VARY_BAND` / 8 place a frame: ``8 |places - frames| >= VARY_BAND frames``
    (integers: the controller's arithmetic).

    Examples
    --------
    >>> [speed_off(PathSpeed(a, 8)) for a in (5, 6, 8, 10, 11)]
    [True, False, False, False, True]
    >>> speed_off(PathSpeed(1, 2)), speed_off(PathSpeed(2, 1))  # the clip's ends
    (True, True)
    """
    return 8 * abs(speed.places - speed.frames) >= VARY_BAND * speed.frames


def speed_varies(offs: Sequence[bool], params: FilterParams) -> bool:
    """Whether the query's speed is known to vary: at least ``speed_vary`` of the last
    :data:`VARY_RECORD` speeds the path's gate passed (``offs``, oldest first, each
    :func:`speed_off`; the schedule passes those of the last :data:`VARY_AGE` forward
    frames) were off one place a frame. False where ``speed_vary`` is 0.

    A route driven at the map's pace shows speeds near one place a frame wherever the
    filter is sure of its path, so it keeps item 1's costs where the filter is unsure; a
    query whose speed swings shows it on the frames the filter was sure of, and the
    frames it is unsure of are those whose speed it does not know.

    Examples
    --------
    >>> p = FilterParams.create("lbp", speed_vary=2)
    >>> speed_varies([True, False, False], p), speed_varies([True, False, True], p)
    (False, True)
    >>> speed_varies([True] * 2 + [False] * 16, p)  # older than the record
    False
    """
    k = int(params.speed_vary or 0)
    return k > 0 and sum(map(bool, offs[-VARY_RECORD:])) >= k


def path_stalled(places: Sequence[int], params: FilterParams) -> bool:
    """Whether the estimate's own path stood still while the query moved: it held one
    place on each of its last ``lost_window`` forward frames and the one before them
    (``places`` oldest first, as :func:`path_speed` reads them). A query at the
    slowest speed the transition follows (1/2 a frame) moves on within two frames, so
    a path held for ``lost_window`` of them does not explain the frames the motion test
    saw move: the query left the map, or a node that matches everything holds the
    estimate. False while fewer than ``lost_window + 1`` estimates are known and where
    ``lost_window`` is 0. A still frame reads the record its last forward frame left
    (the query stopped where the path had stalled). Comparisons of integers only: the
    controller's arithmetic.

    Examples
    --------
    >>> p = FilterParams.create("lbp", lost_window=4)
    >>> path_stalled([39, 40, 40, 40, 40, 40], p), path_stalled([40, 40, 40, 40, 41], p)
    (True, False)
    >>> path_stalled([40, 40, 40, 40], p)  # the window is not full yet
    False
    """
    w = int(params.lost_window or 0)
    if w == 0 or len(places) <= w:
        return False
    tail = places[-1 - w :]
    return min(tail) == max(tail)


END_WINDOW = 2
"""Forward frames over which a path that holds the map's last place has run past it
(:func:`past_map_end`): a query at the slowest speed the transition follows (1/2 a
frame) leaves a place within two."""


def past_map_end(places: Sequence[int], last_place: int, params: FilterParams) -> bool:
    """Whether the estimate's path held the map's last place on each of its last
    ``min(END_WINDOW, lost_window)`` forward frames and the one before them
    (``places`` oldest first, as :func:`path_stalled` reads them).

    Where the path stalls in the middle of the map a node that matches everything may
    hold it, so :func:`path_stalled` waits ``lost_window`` forward frames; at the last
    place the weights cannot go on, so a query still moving after :data:`END_WINDOW`
    frames there has left the map (the route goes on past where it was mapped), and
    the confidence says so from then on. Off with ``lost_window`` 0.

    Examples
    --------
    >>> p = FilterParams.create("lbp")
    >>> past_map_end([97, 98, 99, 99, 99], 99, p), past_map_end([97, 98, 99, 99], 99, p)
    (True, False)
    >>> past_map_end([50, 50, 50], 99, p)  # held, but not the last place
    False
    """
    w = min(END_WINDOW, int(params.lost_window or 0))
    if w == 0 or len(places) <= w:
        return False
    return all(place == last_place for place in places[-1 - w :])


def stood_at_or_next(place_frames: np.ndarray) -> np.ndarray:
    """Per node: whether the map stood still at its place or at the next node's (each
    standing for several reference frames), the ``stood`` of :func:`still_score`.

    The motion test calls a query slowing into a stop still a frame or two before it
    halts, so the filter stops a place short of the map's stop: that estimate is where a
    vehicle stops too.

    Examples
    --------
    >>> stood_at_or_next(np.array([1, 1, 4, 1, 2])).tolist()
    [False, True, True, True, True]
    """
    stood = np.asarray(place_frames) > 1
    return stood | np.append(stood[1:], False)


def still_score(score: float, still: int, stood: bool, params: FilterParams) -> float:
    """The reported confidence of a frame ``still`` frames after the last forward
    decision (0 on a forward frame): ``score`` less ``still_decay`` units a frame, to 0
    at the least, unless the estimate's place or the next stands for several reference
    frames (``stood``: the map stood still there too, :func:`stood_at_or_next`).

    A still frame adds no evidence (derivation item 5), so the estimate is the one the
    query stopped with. The motion test calls a slowing query still a frame or two
    before it halts, and a starting one forward a frame or two after it leaves, so the
    filter stops a place short of where the query stands, or stays behind when it
    leaves. Where the map stood still too (a run of reference frames at the estimate's
    place, or at the next one, where a query stopping a place short stands), that place
    is where a vehicle stops, and the estimate is as sure as when it stopped. The
    controller's arithmetic on the score it reports: no array time.

    Examples
    --------
    >>> p = FilterParams.create("lbp", still_decay=16)
    >>> still_score(40.0, 0, False, p), still_score(40.0, 2, False, p)
    (40.0, 8.0)
    >>> still_score(40.0, 3, False, p), still_score(40.0, 3, True, p)
    (0.0, 40.0)
    >>> still_score(40.0, 3, False, FilterParams.create("lbp", still_decay=0))
    40.0
    """
    c = int(params.still_decay or 0)
    if not c or not still or stood:
        return score
    return min(score, max(0.0, score - c * still))


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


MINIMUM_BITS = 4
"""Robust, register arithmetic: the fraction bits of a frame's best distance ``b`` (the
sensor refines the low-res readout's least value, good to 2 units, on the array:
:func:`refined_minimum`)."""

DETECT_BITS = 4
"""Robust, register arithmetic: the fraction bits of the detection threshold (the
candidates are the nodes with ``w >= floor(2**4 max W) / 2**4``; docs/ppa8.md)."""


def refined_minimum(mu_min: float) -> float:
    """Register arithmetic: the frame's best distance as the sensor refines it, ``b =
    ceil(2**k mu_min) / 2**k - 2**-(k+1)`` with ``k =`` :data:`MINIMUM_BITS` (the middle of
    the last step of a threshold search at ``2**-k``; exact for a dyadic ``mu_min``).

    Examples
    --------
    >>> refined_minimum(3.0), refined_minimum(3.01), refined_minimum(0.0)
    (2.96875, 3.03125, -0.03125)
    """
    step = 2**MINIMUM_BITS
    return math.ceil(mu_min * step) / step - 0.5 / step


def frame_scale(values: np.ndarray, best: float, gain: int, *, exact: bool) -> tuple[int, float]:
    """Robust: this frame's likelihood shift ``s`` and offset ``alpha_t`` from the values
    read from every node and the frame's best distance ``best`` (docs/ppa8.md, robust
    preset, item 3).

    ``s`` is the smallest in ``[0, MAX_SHIFT]`` with ``2 (mean - best) <= 3 gain 2**s``
    (:func:`likelihood_shift`). ``exact`` (the readout's integers, which the sensor,
    ppa8 and float all read): ``best`` is a multiple of ``2**-5``; the comparison is
    made in integers on the sum, ``2 (32 sum - 32 N best) <= 96 gain 2**s N`` (no
    rounding of the mean), and ``alpha_t = floor(best 2**-s)``, a DAC integer.
    Otherwise (float distances ``enhance`` made) the mean as a float and ``alpha_t =
    best 2**-s``.

    Examples
    --------
    >>> frame_scale(np.array([6, 20, 30, 11]), 6, 4, exact=True)
    (1, 3)
    >>> frame_scale(np.array([6.0, 20.0, 30.0, 11.0]), 6.0, 4, exact=False)
    (1, 3.0)
    >>> frame_scale(np.array([0, 13, 13, 13]), 0, 1, exact=True)  # mean 9.75, not 9
    (3, 0)
    """
    if exact:
        n = len(values)
        b32 = round(best * 32)
        excess = 2 * (32 * int(np.sum(values, dtype=np.int64)) - n * b32)  # 64 N (mean - b)
        s = 0
        while s < MAX_SHIFT and excess > (96 * gain * n) << s:
            s += 1
        return s, b32 >> (5 + s)
    fmean = float(values.mean())
    s = likelihood_shift(fmean - best, gain)
    return s, best * 2.0**-s


def adjustment(gamma: float, top: float, *, exact: bool) -> float:
    """Paper: what the adjustment takes off every weight, ``gamma T`` (floored to an
    integer in register arithmetic, which loads it through the DAC).

    Examples
    --------
    >>> adjustment(0.5, 7, exact=True), adjustment(0.5, 7.0, exact=False)
    (3, 3.5)
    """
    return math.floor(gamma * top) if exact else gamma * top


def choose_candidate(candidates: np.ndarray, previous: int | None) -> int:
    """The detection tie-break: the candidate nearest ``previous``, then the smaller index.

    Parameters
    ----------
    candidates : ndarray of int, shape (C,)
        Sorted node indices whose weight reached the detection threshold (C >= 1).
    previous : int or None
        The previous estimate; None on the first frame (the smallest candidate wins).

    Examples
    --------
    >>> choose_candidate(np.array([2, 7, 12]), 10), choose_candidate(np.array([4, 8]), 6)
    (12, 4)
    """
    if previous is None:
        return int(candidates[0])
    # argmin returns the first minimum, i.e. the smaller index on equal distance
    return int(candidates[np.argmin(np.abs(candidates - previous))])


def centroid_window(node: int, radius: int, n_nodes: int) -> tuple[int, int]:
    """The nodes ``(a, b)`` (inclusive) whose weights the reported estimate reads:
    ``node +- radius`` within the map."""
    return max(0, node - radius), min(n_nodes - 1, node + radius)


def weight_read(value: float) -> int:
    """A weight as one ADC read gives it to the controller: the nearest integer, halves
    up (the simulator's ``read_areg``, docs/sim.md)."""
    return math.floor(value + 0.5)


def _relative_mass(weights: Sequence[float], temperature: int) -> list[float]:
    """``exp((w - w_max) / temperature)`` of each weight: the posterior's mass relative to
    the best node's, at the temperature of the reported estimate or confidence."""
    top = max(weights)
    return [math.exp((w - top) / temperature) for w in weights]


def local_centroid(weights: Sequence[float], first: int, temperature: int) -> int:
    """The reported estimate: the rounded centroid (halves up) of nodes ``first,
    first + 1, ...``, each weighed by ``exp((w - w_max) / temperature)`` over ``weights``,
    the weights of the :func:`centroid_window` as read.

    The max-product weights peak at one node, but on a map of one node per distinct
    place the query stands between two nodes as often as on one, and then both hold
    nearly the best weight; a weight ``temperature`` units below the best counts ``1/e``
    as much. Flat weights give the window's middle; one weight far above the rest gives
    its node. Controller arithmetic on a few values read: no array time beyond the reads.

    Examples
    --------
    >>> local_centroid([0, 10, 30, 29, 29], 0, 2)
    3
    >>> local_centroid([0, 10, 30, 20, 5], 0, 2), local_centroid([4, 4, 4], 7, 2)
    (2, 8)
    """
    p = _relative_mass(weights, temperature)
    centre = sum(i * q for i, q in enumerate(p)) / sum(p)
    return first + math.floor(centre + 0.5)


def concentration(weights: Sequence[float], first: int, node: int, temperature: int) -> float:
    """The weights' concentration about ``node``: the share of ``exp((w - w_max) /
    temperature)`` that ``node - 1 .. node + 1`` hold among nodes ``first, first + 1,
    ...`` (``weights``, as read; the window about ``node`` that
    :func:`centroid_window` gives for ``concentration_radius``). In (0, 1]: near 1 where
    every weight two or more nodes from ``node`` is far below the best, 1/3 where the
    nine weights of a window of +-4 are equal, 1/2 where a second hill as high lies two
    or more nodes away. The reported confidence is the margin times it. Controller
    arithmetic on the values read.

    Examples
    --------
    >>> round(concentration([0, 0, 40, 0, 0], 0, 2, 4), 3)
    1.0
    >>> round(concentration([30, 36, 40, 36, 30], 0, 2, 4), 3)
    0.914
    >>> round(concentration([40, 0, 40, 0, 0], 0, 2, 4), 3)
    0.5
    """
    p = _relative_mass(weights, temperature)
    near = sum(q for i, q in enumerate(p, start=first) if abs(i - node) <= 1)
    return near / sum(p)


PARAM_LINES = {
    "motion": "the forward/still decision: the image test, always forward, or the true moves",
    "motion_margin": "the motion test's dead zone, register units (two grey levels each)",
    "motion_shift": "forward where at least 2**-shift of the textured pixels saw an edge cross",
    "motion_min_support": "below this many textured pixels a frame counts as forward",
    "motion_coherent_shift": "forward also needs 2**-shift crossed beside a crossing; 0 off",
    "confidence_radius": "confidence: the best weight minus the best outside +-R places",
    "keyframes": "one node per distinct place (a stop of the reference is one node)",
    "gain": "a frame's likelihood span between its best and its mean node, units",
    "memory": "the floor below the best weight, units (memory / gain frames of evidence)",
    "stay_cost": "cost of staying when the motion test says forward",
    "move_cost": "cost of advancing when the motion test says still",
    "skip_cost": "cost of each node advanced beyond one in a frame",
    "max_advance": "the most nodes one frame may advance",
    "contrast": "low-res: grey-level deviation each image tile is normalised to; 0 off",
    "contrast_patch": "low-res: side of the normalised tiles, in 32-pixel blocks (8: whole)",
    "enhance": "host float only: SeqSLAM's contrast enhancement window, nodes, at least 2; 0 off",
    "local_gain": "units a node loses when all 2 local_window neighbours are closer",
    "local_window": "neighbours each side the local term compares a node with",
    "speed_window": "forward frames over which the detected path gives its speed; 0 off",
    "speed_confidence": "confidence the path needs on every frame of the window to give it",
    "lost_window": "confidence 0 while the detected node held one place this many frames",
    "speed_vary": "forward costs halved where no speed shows and this many lately varied; 0 off",
    "still_decay": "confidence lost a still frame where the map kept moving; 0 off",
    "lane_speed": "the fastest speed lane, places a frame: 2 .. max_advance, or 0 (none "
    "faster; see slow_lane)",
    "lanes": "speed lanes above one place a frame, evenly spaced up to lane_speed",
    "slow_lane": "one more lane at half a place a frame",
    "lane_lead": "report a lane's estimate where its confidence leads by this; 0 off",
    "lane_confidence": "confidence a lane's path needs for the filter to take its speed",
    "lane_speed_lead": "a sure faster lane's lead that hands its speed over; 0 off",
    "centroid_radius": "report the weights' centroid over +-this many nodes; 0 off",
    "centroid_temperature": "the centroid weighs each node by exp((w - best) / this), units",
    "concentration_radius": "confidence times the weights' share at +-1 of those at +-this; 0 off",
    "concentration_temperature": "the share weighs each node by exp((w - best) / this), units",
    "alpha": "paper: the likelihood offset (none: chosen from the map)",
    "gamma": "paper: the adjustment factor: 0, 1/8, 1/4, 1/2 or 1",
    "k": "paper: the adjustment's period, frames",
    "shift": "paper: the likelihood's right shift",
    "advance": "paper: the forward window [lo, hi], nodes",
}
"""One line per filter parameter on what it sets, for ``ppaloc methods NAME``
(:func:`filter_method_params`; the :class:`FilterParams` docstring and docs/localise.md
say more)."""


def filter_method_params() -> tuple[MethodParam, ...]:
    """Every filter parameter as a method parameter (type, default, range), from the one
    declaration of each in :class:`FilterParams` (a default that depends on the preset or
    the representation is given as None)."""
    import typing

    hints = typing.get_type_hints(FilterParams)
    out = [MethodParam("preset", str, "robust", doc="a registered schedule: robust, paper")]
    choices = {"motion": MOTIONS, "patch": CONTRAST_PATCHES}  # the values a kind accepts
    for f in dataclasses.fields(FilterParams):
        spec: Param | None = f.metadata.get("param")
        if spec is None:
            continue
        default = None if callable(spec.default) else spec.default
        hint = hints[f.name]
        if spec.kind in choices:  # the values themselves, not any text or integer
            hint = Literal[choices[spec.kind]]  # type: ignore[valid-type]
            if type(None) in typing.get_args(hints[f.name]):
                hint = hint | None
        doc = PARAM_LINES.get(f.name, "")
        out.append(MethodParam(f.name, hint, default, spec.low, spec.high, doc))
    return tuple(out)
