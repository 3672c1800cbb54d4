"""Analogue and digital non-idealities of the simulated SCAMP-5 array.

The model (see docs/sim.md for each parameter's source) perturbs every analogue register
write of a bus instruction::

    value = (1 + g) * ideal + offset[register, element] + n

- ``g``: transfer error proportional to the signal, one draw per ICW from
  N(transfer_gain, transfer_gain_sd) (a bus copies a current; the copy has a gain error);
- ``offset``: fixed-pattern offset of the element's register cell, drawn once per seed
  from N(0, fixed_offset_sd);
- ``n``: temporal noise, N(0, temporal_sd) per element and write; bus2/bus3 add
  N(0, division_sd) on top (the current split between two or three cells is uneven).

and, with elapsed modelled time (``sim.timing.now_us``), analogue values droop towards 0 by
``decay_per_ms`` (absolute, in register units per millisecond) and, if enabled, digital
registers not written or refreshed for ``digital_retention_ms`` lose their ones at
``digital_flip_per_ms``.

Speed: drawing a fresh Gaussian plane per write costs far more than the write itself. The
model keeps a seeded *bank* of Gaussian samples four times larger than the array (and at
least 65,536 samples longer, for small arrays) and takes, per write, the contiguous window
that starts at a random offset (a view, no copy). Every window is a plane of i.i.d.
N(0, sd) samples; two writes share samples only at a shifted position (element i of one
write meets element i + k of another), so one element's noise across writes is
independent unless two offsets coincide (probability 1/max(3N, 65536) per pair, N =
rows * cols). The test suite checks mean, variance and lag-1 correlation per element.

Every random value is drawn by index (:mod:`ppaloc.sim.draws`): the bank, the offsets and
draw ``j``'s window start and gain are functions of the seed and their index alone
(:meth:`NoiseModel.draw`); only digital decay draws from a sequential generator.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass, fields

import numpy as np

from ppaloc.errors import SimulatorError
from ppaloc.sim import draws, hostloops

try:  # the ufunc behind np.clip, without the wrapper's per-call overhead
    from numpy._core.umath import clip as fast_clip
except ImportError:  # numpy < 2
    from numpy.core.umath import clip as fast_clip

__all__ = ["PRESETS", "NoiseModel", "NoiseParams", "fast_clip", "resolve_noise"]


@dataclass(frozen=True)
class NoiseParams:
    """Magnitudes of every non-ideality, in register units (the range is [-128, 127]).

    Parameters
    ----------
    transfer_gain : float
        Mean relative error of one bus transfer (dimensionless, e.g. -0.001 = 0.1 % loss).
    transfer_gain_sd : float
        Standard deviation of the per-ICW relative transfer error.
    temporal_sd : float
        Standard deviation of the temporal noise added to every analogue write.
    fixed_offset_sd : float
        Standard deviation of the per-element, per-register fixed-pattern offset.
    division_sd : float
        Extra temporal standard deviation on writes of ``bus2``/``bus3``.
    decay_per_ms : float
        Droop of stored analogue values towards 0, in units per millisecond of modelled
        time.
    pixel_offset_sd : float
        Fixed-pattern offset of the photodiode reading ``PIX`` (before reset cancellation).
    digital_retention_ms : float or None
        Time a 1 in a digital register survives without a write or ``REFRESH``; None
        disables digital decay.
    digital_flip_per_ms : float
        After the retention time, the probability per millisecond that a 1 decays to 0
        (in [0, 1]).
    """

    transfer_gain: float = 0.0
    transfer_gain_sd: float = 0.0
    temporal_sd: float = 0.0
    fixed_offset_sd: float = 0.0
    division_sd: float = 0.0
    decay_per_ms: float = 0.0
    pixel_offset_sd: float = 0.0
    digital_retention_ms: float | None = None
    digital_flip_per_ms: float = 0.0

    def __post_init__(self) -> None:
        for f in fields(self):
            v = getattr(self, f.name)
            if v is None:
                continue
            if isinstance(v, bool) or not isinstance(v, int | float | np.integer | np.floating):
                raise SimulatorError(
                    f"NoiseParams.{f.name}={v!r} is invalid: use a number (register units, "
                    "ms or probabilities as documented)"
                )
            if not math.isfinite(v) or (f.name != "transfer_gain" and v < 0):
                raise SimulatorError(
                    f"NoiseParams.{f.name}={v!r} is invalid: use a finite value "
                    "(non-negative except transfer_gain)"
                )
        if self.digital_flip_per_ms > 1:
            raise SimulatorError(
                f"NoiseParams.digital_flip_per_ms={self.digital_flip_per_ms!r} is invalid: it "
                "is a probability per millisecond, in [0, 1]"
            )


#: Named presets. "typical" takes the retention time from the SCAMP-5 headers and
#: estimates the other magnitudes (docs/sim.md says which is which); "low" and "high"
#: scale every magnitude by 1/4 and 2.5.
PRESETS: dict[str, NoiseParams] = {
    "typical": NoiseParams(
        transfer_gain=-0.002,
        transfer_gain_sd=0.002,
        temporal_sd=0.25,
        fixed_offset_sd=0.25,
        division_sd=0.25,
        decay_per_ms=0.05,
        pixel_offset_sd=1.0,
        digital_retention_ms=1500.0,
        digital_flip_per_ms=0.001,
    ),
}
PRESETS["low"] = NoiseParams(
    **{
        k: (v / 4 if isinstance(v, float) and k != "digital_retention_ms" else v)
        for k, v in asdict(PRESETS["typical"]).items()
    }
)
PRESETS["high"] = NoiseParams(
    **{
        k: (v * 2.5 if isinstance(v, float) and k != "digital_retention_ms" else v)
        for k, v in asdict(PRESETS["typical"]).items()
    }
)


def resolve_noise(noise: str | NoiseParams) -> NoiseParams | None:
    """The parameters named by ``noise`` (None for ``"ideal"``).

    Raises
    ------
    SimulatorError
        If ``noise`` is neither ``"ideal"``, a preset name nor a :class:`NoiseParams`.
    """
    if isinstance(noise, NoiseParams):
        return noise
    if noise == "ideal":
        return None
    if isinstance(noise, str) and noise in PRESETS:
        return PRESETS[noise]
    raise SimulatorError(
        f"noise={noise!r} is unknown: use 'ideal', one of {sorted(PRESETS)} "
        "or a ppaloc.sim.NoiseParams"
    )


_BANK_FACTOR = 4  # bank length / plane size ...
_MIN_STARTS = 1 << 16  # ... but at least this many window starts, for small arrays
_DRAWS = 4096  # per-ICW draws (window starts, gains) made at once
# the streams of ppaloc.sim.draws the model draws from (keys of (seed, stream))
_OFFSETS, _PIXEL, _BANK, _STARTS, _GAINS = 1, 2, 3, 4, 5


class NoiseModel:
    """Seeded noise source of one simulator.

    Parameters
    ----------
    noise : str or NoiseParams
        ``"ideal"``, a key of :data:`PRESETS`, or custom parameters.
    shape : tuple of int
        (rows, cols) of the array.
    n_analog : int
        Number of analogue register planes (fixed-pattern offsets are per plane).
    seed : int
        Seed; the same seed gives the same noise, bit for bit.

    Attributes
    ----------
    ideal : bool
        True when no noise is modelled (saturation only).
    params : NoiseParams or None
        The parameters (None when ideal).
    """

    def __init__(
        self, noise: str | NoiseParams, shape: tuple[int, int], n_analog: int, seed: int = 0
    ) -> None:
        self.params = resolve_noise(noise)
        self.ideal = self.params is None
        self.shape = shape
        self.rng = np.random.default_rng([seed, 0x5CA45])  # digital decay's draws
        size = shape[0] * shape[1]
        self._size = size
        p = self.params or NoiseParams()
        if self.ideal:  # zeros whose signs PIX takes from rpix: as drawn since the start
            self.offsets = (self.rng.standard_normal((n_analog, *shape)) * 0.0).astype(np.float32)
            self.pixel_offset = (self.rng.standard_normal(shape) * 0.0).astype(np.float32)
            self._bank = self._bank_div = np.zeros(0, np.float32)
        else:  # every sample a pure function of (seed, stream, index): ppaloc.sim.draws
            n_off = n_analog * size
            self.offsets = draws.normal(
                draws.key(seed, _OFFSETS), 0, n_off, p.fixed_offset_sd
            ).reshape(n_analog, *shape)
            self.pixel_offset = draws.normal(
                draws.key(seed, _PIXEL), 0, size, p.pixel_offset_sd
            ).reshape(shape)
            bank_len = max(size * _BANK_FACTOR, size + _MIN_STARTS)
            z = draws.normal(draws.key(seed, _BANK), 0, bank_len)
            self._bank = z * np.float32(p.temporal_sd)
            self._bank_div = z * np.float32(math.hypot(p.temporal_sd, p.division_sd))
        self._key_starts = draws.key(seed, _STARTS)
        self._key_gains = draws.key(seed, _GAINS)
        self._batch = -1  # the batch of _DRAWS draws in _starts and _gains
        self._k = _DRAWS
        self._starts: list[int] = []  # the batch as lists (window: one element, fast)
        self._gains: list[float] = []
        self._starts_a = np.zeros(0, dtype=np.int64)  # and as arrays (take: views)
        self._gains_a = np.zeros(0, dtype=np.float64)

    @property
    def draws_taken(self) -> int:
        """How many draws (window starts, with their gains) were taken so far."""
        return self._batch * _DRAWS + self._k

    def draw(self, first: int, m: int) -> tuple[np.ndarray, np.ndarray]:
        """Draws ``first .. first + m - 1`` by index: (window starts (m,) int64, negated
        gains ``-(1 + g)`` (m,) float64); the same whichever draws were taken before.

        Raises
        ------
        SimulatorError
            If the model is ideal (it draws nothing).
        """
        if self.ideal:
            raise SimulatorError(
                "NoiseModel.draw: an ideal model draws no noise; use a noise preset or NoiseParams"
            )
        idx = np.arange(first, first + m, dtype=np.uint64)
        span = len(self._bank) - self._size
        starts = draws.index_below(self._key_starts, idx, span + 1)
        p = self.params or NoiseParams()
        z = draws.normal_of_bits(draws.bits(self._key_gains, idx)).astype(np.float64)
        return starts, -(1.0 + p.transfer_gain + p.transfer_gain_sd * z)

    def _refill(self) -> None:
        self._batch += 1
        self._starts_a, self._gains_a = self.draw(self._batch * _DRAWS, _DRAWS)
        self._starts, self._gains = self._starts_a.tolist(), self._gains_a.tolist()
        self._k = 0

    def window(self, divided: bool = False) -> np.ndarray:
        """A (rows, cols) view of fresh temporal noise (with division noise if ``divided``)."""
        if self._k >= _DRAWS:
            self._refill()
        s = self._starts[self._k]
        self._k += 1
        bank = self._bank_div if divided else self._bank
        return bank[s : s + self._size].reshape(self.shape)

    def negated_gain(self) -> float:
        """``-(1 + g)`` for one transfer (the bus negates; g is the transfer error)."""
        if self._k >= _DRAWS:
            self._refill()
        return self._gains[self._k]

    def take(self, m: int) -> tuple[np.ndarray, np.ndarray]:
        """The next ``m`` draw indices at once: (window starts, negated gains), both (m,).

        Draw ``j`` is the same whether taken here or by ``m`` calls of :meth:`window`
        (whose ICW reads :meth:`negated_gain` at its first index), so an engine that
        takes a whole kernel's draws up front leaves the same bytes as one that draws
        ICW by ICW.
        """
        if self._k >= _DRAWS:
            self._refill()
        k = self._k
        if k + m <= _DRAWS:  # inside the batch (nearly always): views, no copy
            self._k = k + m
            return self._starts_a[k : k + m], self._gains_a[k : k + m]
        starts = np.empty(m, dtype=np.int64)
        gains = np.empty(m, dtype=np.float64)
        done = 0
        while done < m:
            if self._k >= _DRAWS:
                self._refill()
            n = min(m - done, _DRAWS - self._k)
            starts[done : done + n] = self._starts_a[self._k : self._k + n]
            gains[done : done + n] = self._gains_a[self._k : self._k + n]
            self._k += n
            done += n
        return starts, gains

    def terms(self, plane: int, divided: bool) -> tuple[np.ndarray, np.ndarray]:
        """The terms one noisy write of ``plane`` adds, in this order: the plane's
        fixed-pattern offset and a fresh temporal-noise window (one draw)."""
        return self.offsets[plane], self.window(divided)

    def perturb(self, values: np.ndarray, plane: int, divided: bool) -> None:
        """Add the fixed-pattern offset of ``plane`` and temporal noise to ``values`` in place."""
        offset, window = self.terms(plane, divided)
        np.add(values, offset, out=values)
        np.add(values, window, out=values)

    def droop(self, planes: np.ndarray, elapsed_us: float) -> None:
        """Let analogue ``planes`` (one plane or (n, rows, cols)) droop towards 0 for
        ``elapsed_us``."""
        step = self.droop_step(elapsed_us)
        if step is not None:  # v -> v - clip(v, -step, step): towards 0, never past it
            hostloops.droop(planes, step)

    def droop_step(self, elapsed_us: float) -> np.float32 | None:
        """How far a value droops towards 0 in ``elapsed_us`` (None: not at all)."""
        if self.ideal or elapsed_us <= 0 or self.params.decay_per_ms == 0:
            return None
        return np.float32(self.params.decay_per_ms * elapsed_us / 1000.0)

    def digital_decay(self, plane: np.ndarray, age_us: float, elapsed_us: float) -> None:
        """Let ones in a digital ``plane`` decay after its retention time has passed.

        ``age_us`` is the time since the register was last written or refreshed, of
        which ``elapsed_us`` passed since the previous check.
        """
        p = self.params
        if self.ideal or p.digital_retention_ms is None or p.digital_flip_per_ms == 0:
            return
        over_ms = min(age_us, elapsed_us) / 1000.0 if age_us > p.digital_retention_ms * 1e3 else 0
        over_ms = min(over_ms, age_us / 1000.0 - p.digital_retention_ms)
        if over_ms <= 0:
            return
        prob = 1.0 - (1.0 - p.digital_flip_per_ms) ** over_ms
        if prob > 0.01:
            plane &= self.rng.random(plane.shape) >= prob
        else:  # few flips (the usual case, one kernel's worth of time): draw only those
            flat = plane.reshape(-1)
            hits = self.rng.binomial(flat.size, prob)
            if hits:
                flat[self.rng.integers(0, flat.size, hits)] = False
