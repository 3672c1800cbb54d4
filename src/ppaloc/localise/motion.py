"""Motion models: did the camera move forward by one place since the previous frame?

The weighted-node filter shifts every weight one node along the map when the motion model
says *forward*, and leaves them where they are on *stay*. Three models:

- :class:`ImageMotion` (``motion="image"``): decided from the current and previous sensor
  frames by one-bit operations a pixel processor array computes in place (docs/ppa8.md,
  "Per frame", item 1). Each pixel is compared with the mean of its 32x32 block (the same
  block means the place representations are made of) with a dead zone of ``margin``:
  ``U`` = clearly above, ``D`` = clearly below. A pixel that was clearly above and is now
  clearly below (or the reverse) saw an edge cross it: the image content moved. The
  decision compares the number of such crossings with the number of clearly-textured
  pixels, so it does not depend on how much texture a scene has; the dead zone makes
  still frames under sensor noise count (almost) no crossings, and a second count, of
  the crossings one of whose four neighbours crossed too, must pass a lower bar: noise
  crosses pixels one by one, a moving edge crosses a run of them.
- :class:`AlwaysForward` (``motion="always_forward"``): for frame-synchronised datasets
  (one query frame per reference frame, e.g. Nordland).
- :class:`OracleMotion` (``motion="oracle"``): the ground-truth decisions, for experiments
  that separate motion-model errors from place-matching errors.

Why this test and not a direction test (edges moving outward from the image centre): a
forward-facing camera that stops sees the same image, and one that moves sees changed
content; reversing is outside the paper's model, so *changed vs. unchanged* is the whole
decision. A radial-flow test needs sub-block edge localisation in two frames and is
fragile where the scene is dominated by lateral motion (curves, camera shake); the
crossing count is one XOR-like expression, two pixel counts and one integer comparison
on the controller.

The first frame after ``reset`` has no predecessor: every model but the oracle says stay
(all weights are zero then, so the decision changes nothing but the report).
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING, NamedTuple

import numpy as np

from ppaloc.errors import PpalocError
from ppaloc.place import SENSOR_SIZE, block_sums

if TYPE_CHECKING:  # params imports this module's margins
    from ppaloc.localise.params import FilterParams

__all__ = [
    "COHERENT_SHIFT",
    "MARGIN",
    "PAPER_MARGIN",
    "AlwaysForward",
    "ImageMotion",
    "MotionCounts",
    "MotionModel",
    "OracleMotion",
    "check_moves",
    "coherent_crossings",
    "counted_decision",
    "crossed_pixels",
    "crossing_counts",
    "forward_decision",
    "motion_planes",
]

_BLOCK = 32  # pixels per block side: the 8x8 grid of docs/ppa8.md

MARGIN = 4
"""Default dead zone of the test, register units (8 grey levels), the robust filter's
(docs/localise.md, "The motion model": 2-8 measured on every route of
``benchmarks/eval_robust.py``)."""

PAPER_MARGIN = 3
"""The paper preset's dead zone (6 grey levels), as it was measured with Algorithm 1."""

COHERENT_SHIFT = 8
"""Default second bar of the test, the robust filter's: forward also needs ``2**-8`` of
the textured pixels crossed beside another crossing (docs/localise.md, "The motion
model": 7-9 measured on every route of ``benchmarks/eval_robust.py``, and its held-out
ones)."""


def motion_planes(frame: np.ndarray, margin: int = MARGIN) -> tuple[np.ndarray, np.ndarray]:
    """Return the two one-bit planes ``(U, D)`` of a sensor frame.

    In register units (``v = p/2 - 64``, docs/ppa8.md) with ``m`` the exact mean of ``v``
    over the pixel's 32x32 block: ``U = [v - m - margin > 0]``, ``D = [m - v - margin > 0]``.
    Computed here in integers: with ``x = 1024*p - (block sum of p)``,
    ``U = [x > 2048*margin]`` and ``D = [-x > 2048*margin]``.

    Parameters
    ----------
    frame : ndarray of uint8, shape (256, 256)
        A sensor frame.
    margin : int
        Dead zone in register units (one unit = two grey levels); a non-negative integer
        because the PPA loads it through the DAC.

    Returns
    -------
    U, D : ndarray of bool, shape (256, 256)
        Pixels clearly above (``U``) and clearly below (``D``) their block mean.

    Examples
    --------
    >>> f = np.zeros((256, 256), np.uint8)
    >>> f[:16] = 200  # top half of the first block row bright, bottom half dark
    >>> U, D = motion_planes(f)
    >>> int(U.sum()), int(D.sum())
    (4096, 4096)
    """
    # |x| <= 255 * 1024 fits int32, which is several times faster here than int64
    sums = block_sums(frame, SENSOR_SIZE // _BLOCK).astype(np.int32)
    x = np.asarray(frame, dtype=np.int32).reshape(8, _BLOCK, 8, _BLOCK) << 10
    x -= sums[:, None, :, None]
    x = x.reshape(SENSOR_SIZE, SENSOR_SIZE)
    limit = 2048 * int(margin)
    return x > limit, x < -limit


def coherent_crossings(crossed: np.ndarray) -> np.ndarray:
    """Return the crossings of ``crossed`` that have a crossing among their 4 neighbours.

    Sensor and rendering noise cross pixels one by one, independently, so a noisy still
    frame's crossings are mostly alone; an edge that moves crosses every pixel along it,
    so a moving frame's come in runs. Keeping only the crossings with a crossing
    neighbour (north, east, south or west; nothing beyond the array's edge) drops the
    first and keeps most of the second. On the PPA it is one ``DNEWS`` (the OR of the
    four neighbours) and one ``AND``.

    Examples
    --------
    >>> c = np.zeros((4, 5), bool)
    >>> c[0, 0] = c[2, 2] = c[2, 3] = True  # one alone, one pair
    >>> coherent_crossings(c).astype(int)
    array([[0, 0, 0, 0, 0],
           [0, 0, 0, 0, 0],
           [0, 0, 1, 1, 0],
           [0, 0, 0, 0, 0]])
    """
    c = np.asarray(crossed, dtype=bool)
    near = np.zeros_like(c)
    near[1:] |= c[:-1]
    near[:-1] |= c[1:]
    near[:, 1:] |= c[:, :-1]
    near[:, :-1] |= c[:, 1:]
    return c & near


def crossed_pixels(
    previous: tuple[np.ndarray, np.ndarray], current: tuple[np.ndarray, np.ndarray]
) -> np.ndarray:
    """``(U_prev & D) | (D_prev & U)``: the pixels that crossed their block mean by more
    than the margin between two frames' planes."""
    (u0, d0), (u1, d1) = previous, current
    return (u0 & d1) | (d0 & u1)


def crossing_counts(
    previous: tuple[np.ndarray, np.ndarray],
    current: tuple[np.ndarray, np.ndarray],
    coherent: bool = False,
) -> tuple[int, ...]:
    """Return ``(changed, support)``, or with ``coherent`` ``(changed, support,
    coherent)``, for two frames' planes.

    ``changed = count((U_prev & D) | (D_prev & U))``: pixels that crossed their block mean
    by more than the margin; ``support = count(U | D)``: clearly-textured pixels now;
    ``coherent``: the crossings with a crossing neighbour (:func:`coherent_crossings`).
    On the PPA each is an exact count: block sums on the array read through the ADC
    (``global_count`` is only an estimate; docs/ppa8.md).
    """
    crossed = crossed_pixels(previous, current)
    changed = int(np.count_nonzero(crossed))
    support = int(np.count_nonzero(current[0] | current[1]))
    if not coherent:
        return changed, support
    return changed, support, int(np.count_nonzero(coherent_crossings(crossed)))


def forward_decision(
    changed: int,
    support: int,
    coherent: int | None = None,
    *,
    shift: int = 6,
    min_support: int = 1024,
    coherent_shift: int = 0,
) -> bool:
    """Decide forward (True) or stay from the counts, in controller integers.

    Forward iff ``support < min_support`` (too little texture to tell: assume the
    vehicle keeps moving) or ``changed * 2**shift >= support`` (at least ``2**-shift`` of
    the textured pixels saw an edge cross them) and, where ``coherent_shift`` is not 0,
    ``coherent * 2**coherent_shift >= support`` (at least ``2**-coherent_shift`` of them
    crossed beside another crossing: noise alone crosses pixels one by one).

    Examples
    --------
    >>> forward_decision(0, 50000), forward_decision(800, 50000), forward_decision(0, 10)
    (False, True, True)
    >>> forward_decision(800, 50000, 100, coherent_shift=7)  # 800 alone, noise
    False
    """
    if support < min_support:
        return True
    if changed << shift < support:
        return False
    if not coherent_shift:
        return True
    if coherent is None:
        raise ValueError("coherent_shift needs the coherent count")
    return coherent << coherent_shift >= support


class MotionCounts(NamedTuple):
    """The counts one decision of the image test read (None: not read)."""

    changed: int | None
    support: int
    coherent: int | None = None


def counted_decision(
    count_changed: Callable[[], int],
    count_support: Callable[[], int],
    count_coherent: Callable[[], int],
    *,
    shift: int = 6,
    min_support: int = 1024,
    coherent_shift: int = 0,
) -> tuple[bool, MotionCounts]:
    """:func:`forward_decision`, reading each count only where the decision needs it.

    Each count is a pass over the array and 512 ADC reads on the sensor (about 65 us), so
    the controller reads them in this order, host and sensor alike. Without the coherent
    count: ``changed``, then ``support``. With it: ``support``; ``coherent``, which says
    still where it fails its bar and forward where it passes the first one too (every
    coherent crossing is a crossing); ``changed`` only in between.

    Examples
    --------
    >>> counts = {"changed": lambda: 900, "support": lambda: 50000, "coherent": lambda: 800}
    >>> counted_decision(*counts.values(), coherent_shift=8)
    (True, MotionCounts(changed=None, support=50000, coherent=800))
    """
    if not coherent_shift:
        changed = count_changed()
        support = count_support()
        moved = forward_decision(changed, support, shift=shift, min_support=min_support)
        return moved, MotionCounts(changed, support)
    support = count_support()
    if support < min_support:
        return True, MotionCounts(None, support)
    coherent = count_coherent()
    if coherent << coherent_shift < support:
        return False, MotionCounts(None, support, coherent)
    if coherent << shift >= support:
        return True, MotionCounts(None, support, coherent)
    changed = count_changed()
    return changed << shift >= support, MotionCounts(changed, support, coherent)


class MotionModel:
    """Interface of a motion model: ``reset()``, then ``step(frame) -> bool`` per frame."""

    name = "motion"

    def reset(self) -> None:
        """Forget the previous frame."""

    def step(self, frame: np.ndarray) -> bool:  # pragma: no cover - interface
        """Return True when the camera moved forward since the previous frame."""
        raise NotImplementedError


@dataclass
class ImageMotion(MotionModel):
    """Forward/stay from block-mean crossings between consecutive frames (see module doc).

    Parameters
    ----------
    margin : int
        Dead zone in register units (default :data:`MARGIN`, 4 = 8 grey levels): still
        Nordland frames with added Gaussian noise of 2 grey levels count no crossings at
        all, while real motion crosses thousands of pixels. On Nordland the winter frames
        where the map holds one node for a summer stop are called moving less often with 8
        grey levels than with 6 (the paper preset keeps :data:`PAPER_MARGIN`).
    shift : int
        Forward when at least ``2**-shift`` of the textured pixels crossed (default 6:
        1/64). On the synthetic route with stops (seed 1), still frames cross 0.56-0.85%
        of their textured pixels (rendering noise) and the slowest moving frame 5.5%;
        1/64 sits between the two, about a factor 2-3 from each.
    min_support : int
        Below this many textured pixels (of 65536) the frame is featureless (tunnels,
        blank frames) and the model says forward.
    coherent_shift : int
        Forward also needs ``2**-coherent_shift`` of the textured pixels crossed beside
        another crossing (:func:`coherent_crossings`); 0 turns the second test off. At
        night a still generated frame sees up to 2.3% of its textured pixels cross, one
        by one, from rendering noise, above the 1/64 of ``shift``; at most 0.2% of them
        have a crossing neighbour, against 0.9% and more in a moving frame (default
        :data:`COHERENT_SHIFT`, 8: 1/256, the two's geometric middle).
    """

    margin: int = MARGIN
    shift: int = 6
    min_support: int = 1024
    coherent_shift: int = COHERENT_SHIFT
    name = "image"

    @classmethod
    def of(cls, params: FilterParams) -> ImageMotion:
        """The test a :class:`ppaloc.localise.params.FilterParams` sets (its ``motion_*``)."""
        return cls(
            params.motion_margin,
            params.motion_shift,
            params.motion_min_support,
            params.motion_coherent_shift,
        )

    def __post_init__(self) -> None:
        for key in ("margin", "shift", "min_support", "coherent_shift"):
            value = getattr(self, key)
            if not isinstance(value, int | np.integer) or value < 0:
                raise PpalocError(
                    f"motion {key}={value!r} must be a non-negative integer (the PPA "
                    "loads it through the DAC or compares it on the controller)"
                )
        self._previous: tuple[np.ndarray, np.ndarray] | None = None
        self.last_counts: MotionCounts | None = None

    def reset(self) -> None:
        self._previous = None
        self.last_counts = None

    def step(self, frame: np.ndarray) -> bool:
        planes = motion_planes(frame, self.margin)
        previous, self._previous = self._previous, planes
        if previous is None:
            self.last_counts = None
            return False
        crossed = crossed_pixels(previous, planes)
        moved, self.last_counts = counted_decision(
            lambda: int(np.count_nonzero(crossed)),
            lambda: int(np.count_nonzero(planes[0] | planes[1])),
            lambda: int(np.count_nonzero(coherent_crossings(crossed))),
            shift=self.shift,
            min_support=self.min_support,
            coherent_shift=self.coherent_shift,
        )
        return moved


class AlwaysForward(MotionModel):
    """Forward on every frame but the first after ``reset`` (frame-synchronised data)."""

    name = "always_forward"

    def __init__(self) -> None:
        self._started = False

    def reset(self) -> None:
        self._started = False

    def step(self, frame: np.ndarray) -> bool:
        started, self._started = self._started, True
        return started


def check_moves(moves: object) -> np.ndarray:
    """``moves`` as a 1-D bool array, or a one-line error: ground-truth moves are a list
    of booleans (True/False or 1/0), one per query frame, nothing else."""
    try:
        a = np.asarray(moves)
    except (TypeError, ValueError):
        a = np.asarray([object()])  # ragged or nested beyond an array: refused below
    ok = a.ndim == 1 and (
        a.dtype == np.bool_ or (a.dtype.kind in "iu" and bool(np.isin(a, (0, 1)).all()))
    )
    if not ok:
        shown = repr(moves)
        raise PpalocError(
            f"oracle_moves={shown[:60]}{'...' if len(shown) > 60 else ''} must be a list of "
            "booleans (true/false or 1/0), one per query frame"
        )
    return a.astype(bool)


class OracleMotion(MotionModel):
    """The ground-truth decisions: frame ``n`` after ``reset`` gets ``moves[n]``.

    Parameters
    ----------
    moves : sequence of bool
        ``moves[n]`` is True when the camera moved forward between query frames ``n-1``
        and ``n`` (a dataset's ``query_moved``).
    """

    name = "oracle"

    def __init__(self, moves: Sequence[bool] | np.ndarray) -> None:
        self.moves = check_moves(moves)
        self._n = 0

    def reset(self) -> None:
        self._n = 0

    def step(self, frame: np.ndarray) -> bool:
        if self._n >= len(self.moves):
            raise PpalocError(
                f"the oracle motion model has {len(self.moves)} ground-truth moves but was "
                f"asked for frame {self._n}; pass oracle_moves covering every query frame"
            )
        moved = bool(self.moves[self._n])
        self._n += 1
        return moved
