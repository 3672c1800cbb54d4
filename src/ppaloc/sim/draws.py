"""Counter-based random draws: a value is a pure function of (key, index).

The noise model (:mod:`ppaloc.sim.noise`) needs, per seed, planes of Gaussian samples and,
per analogue write, a window start and a transfer gain. Drawing them from a sequential
generator ties each value to the order of the draws before it; here draw ``c`` of a
stream is computed from the stream's 64-bit key and ``c`` alone, so any engine, in any
order, in chunks or one by one, gets the same bytes by construction.

- **Bits.** ``mix64(key + c * 0x9E3779B97F4A7C15)``: SplitMix64 (Steele, Lea & Flood,
  OOPSLA 2014; the generator that seeds ``xoshiro``) evaluated at position ``c`` of the
  stream that starts at ``key``. Two 64-bit multiplies per value, vectorised.
- **Normal.** The top 32 bits: one for the sign, 31 for the two-sided tail probability
  ``v = (k + 1/2) / 2**31``, and ``|z| = sqrt(2) * erfinv(1 - v)`` by Giles' single-precision
  approximation ("Approximating the erfinv function", GPU Computing Gems, 2011; absolute
  error at most about 1.1e-6 for ``|z| < 5.04``, that is all but 5e-7 of the draws, which
  is a relative error below 2e-6 for ``|z| > 0.1``, and below 4e-4 beyond 5.04) with
  ``log`` computed from the float's exponent and an atanh series (no library call, so the
  loop vectorises and numpy gives the same bytes).
  The smallest ``v`` is 2**-32: the largest ``|z|`` is 6.336 (a true normal exceeds it
  with probability 2.3e-10 per draw). Every operation is float32 in a fixed order;
  :func:`normal_numpy` is the same arithmetic on numpy arrays, used without numba and
  checked against the compiled loop by ``tests/sim/test_draws.py``.

Keys come from :class:`numpy.random.SeedSequence` of ``(seed, stream)``, so streams of
one seed, and the same stream of two seeds, start at unrelated positions.
"""

from __future__ import annotations

import importlib.util
from types import SimpleNamespace

import numpy as np

from ppaloc.errors import SimulatorError

__all__ = ["bits", "index_below", "key", "normal", "normal_numpy", "normal_of_bits"]

GOLDEN = np.uint64(0x9E3779B97F4A7C15)
_M1 = np.uint64(0xBF58476D1CE4E5B9)
_M2 = np.uint64(0x94D049BB133111EB)

_F = np.float32
# Giles' single-precision erfinv: w < 5 (central) and w >= 5 (tails), Horner order
_CENTRAL = tuple(
    _F(c)
    for c in (
        2.81022636e-08, 3.43273939e-07, -3.5233877e-06, -4.39150654e-06, 0.00021858087,
        -0.00125372503, -0.00417768164, 0.246640727, 1.50140941,
    )
)  # fmt: skip
_TAIL = tuple(
    _F(c)
    for c in (
        -0.000200214257, 0.000100950558, 0.00134934322, -0.00367342844, 0.00573950773,
        -0.0076224613, 0.00943887047, 1.00167406, 2.83297682,
    )
)  # fmt: skip
_SQRT2 = _F(1.4142135623730951)
_LN2_HI = _F(0.693145751953125)  # ln 2 split so that e * hi is exact
_LN2_LO = _F(1.428606765330187e-06)
_HALF, _ONE, _TWO, _THREE, _FIVE, _W0 = _F(0.5), _F(1.0), _F(2.0), _F(3.0), _F(5.0), _F(2.5)
_SQRT_HALF2 = _F(1.4142135)  # mantissas above this are halved: |log m| series stays short
_INV = (_F(1 / 3), _F(1 / 5), _F(1 / 7), _F(1 / 9))
_TO_UNIT = _F(2.0**-31)


def key(seed: int, stream: int) -> np.uint64:
    """The 64-bit key of ``stream`` (a small integer naming what is drawn) under ``seed``.

    Examples
    --------
    >>> bool(key(0, 1) == key(0, 1)), bool(key(0, 1) == key(0, 2))
    (True, False)
    """
    return np.random.SeedSequence([int(seed), int(stream), 0xD4A3]).generate_state(1, np.uint64)[0]


def bits(k: np.uint64, counters: np.ndarray) -> np.ndarray:
    """64 random bits per counter (uint64 array of ``counters``' shape): SplitMix64 at each
    position of the stream ``k``."""
    c = np.asarray(counters, dtype=np.uint64)
    z = c.reshape(-1) * GOLDEN + np.uint64(k)  # arrays wrap silently (scalars would warn)
    z = (z ^ (z >> np.uint64(30))) * _M1
    z = (z ^ (z >> np.uint64(27))) * _M2
    return (z ^ (z >> np.uint64(31))).reshape(c.shape)


def index_below(k: np.uint64, counters: np.ndarray, n: int) -> np.ndarray:
    """A uniform integer in ``[0, n)`` per counter (int64), ``n <= 2**32``: the top 32
    bits times ``n``, shifted down (bias below ``n / 2**32``)."""
    if not 1 <= n <= 1 << 32:
        raise SimulatorError(f"index_below: n={n} is out of range; use 1 <= n <= 2**32")
    top = bits(k, counters) >> np.uint64(32)
    return ((top * np.uint64(n)) >> np.uint64(32)).astype(np.int64)


def normal_of_bits(h: np.ndarray) -> np.ndarray:
    """Standard normal float32 values of 64-bit words ``h`` (their top 32 bits), numpy."""
    top = np.asarray(h, dtype=np.uint64) >> np.uint64(32)
    k = (top & np.uint64(0x7FFFFFFF)).astype(np.int32)
    v = (k.astype(np.float32) + _HALF) * _TO_UNIT  # two-sided tail probability, (0, 1]
    y = v * (_TWO - v)  # (1 - t)(1 + t) for t = 1 - v
    b = y.view(np.int32)
    e = (b >> np.int32(23)) - np.int32(127)
    m = ((b & np.int32(0x7FFFFF)) | np.int32(0x3F800000)).view(np.float32)
    big = m > _SQRT_HALF2
    m = np.where(big, m * _HALF, m)
    e = np.where(big, e + np.int32(1), e)
    f = m - _ONE
    s = f / (_TWO + f)
    s2 = s * s
    t3, t5, t7, t9 = _INV
    log_m = _TWO * s * (_ONE + s2 * (t3 + s2 * (t5 + s2 * (t7 + s2 * t9))))
    ef = e.astype(np.float32)
    w = -((ef * _LN2_HI) + (log_m + ef * _LN2_LO))
    wa = w - _W0
    pa = np.full_like(w, _CENTRAL[0])
    for c in _CENTRAL[1:]:
        pa = c + pa * wa
    wb = np.sqrt(w) - _THREE
    pb = np.full_like(w, _TAIL[0])
    for c in _TAIL[1:]:
        pb = c + pb * wb
    p = np.where(w < _FIVE, pa, pb)
    r = _SQRT2 * (p * (_ONE - v))
    return np.where((top & np.uint64(0x80000000)) != 0, -r, r)


def normal_numpy(k: np.uint64, start: int, n: int, scale: float = 1.0) -> np.ndarray:
    """``scale`` times standard normal draws ``start .. start + n - 1`` of stream ``k``
    (float32, (n,)), in numpy: the bytes :func:`normal` gives."""
    z = normal_of_bits(bits(k, np.arange(start, start + n, dtype=np.uint64)))
    return z * np.float32(scale)


def normal(k: np.uint64, start: int, n: int, scale: float = 1.0) -> np.ndarray:
    """``scale`` times standard normal draws ``start .. start + n - 1`` of stream ``k``
    (float32, (n,)): one vectorised loop when numba is installed, else
    :func:`normal_numpy` (the same bytes).

    Examples
    --------
    >>> a = normal(key(7, 0), 0, 1000)
    >>> bool(np.array_equal(a[10:20], normal(key(7, 0), 10, 10)))
    True
    >>> round(float(a.std()), 1)
    1.0
    """
    loops = _loops()
    if loops is None:
        return normal_numpy(k, start, n, scale)
    out = np.empty(n, np.float32)
    loops.fill_normal(out, np.uint64(k), np.uint64(start), np.float32(scale))
    return out


_LOOPS: SimpleNamespace | None = None
_CHECKED = False


def _loops() -> SimpleNamespace | None:
    global _LOOPS, _CHECKED
    if not _CHECKED:
        _CHECKED = True
        if importlib.util.find_spec("numba") is not None:
            _LOOPS = _numba_loops()
    return _LOOPS


def _numba_loops() -> SimpleNamespace:
    """The compiled loop of :func:`normal` (bit casts and sqrt as LLVM instructions, no
    library call, numpy's error model: the loop vectorises)."""
    import numba
    from llvmlite import ir
    from numba.core import types
    from numba.extending import intrinsic

    @intrinsic
    def f32_bits(typingctx, x):  # pragma: no cover - compiled
        def codegen(context, builder, signature, args):
            return builder.bitcast(args[0], ir.IntType(32))

        return types.int32(types.float32), codegen

    @intrinsic
    def bits_f32(typingctx, x):  # pragma: no cover - compiled
        def codegen(context, builder, signature, args):
            return builder.bitcast(args[0], ir.FloatType())

        return types.float32(types.int32), codegen

    @intrinsic
    def sqrt32(typingctx, x):  # pragma: no cover - compiled
        def codegen(context, builder, signature, args):
            fn = builder.module.declare_intrinsic("llvm.sqrt", [ir.FloatType()])
            return builder.call(fn, [args[0]])

        return types.float32(types.float32), codegen

    a0, a1, a2, a3, a4, a5, a6, a7, a8 = _CENTRAL
    b0, b1, b2, b3, b4, b5, b6, b7, b8 = _TAIL
    t3, t5, t7, t9 = _INV
    sqrt2, ln2_hi, ln2_lo, to_unit = _SQRT2, _LN2_HI, _LN2_LO, _TO_UNIT
    half, one, two, three, five, w0, big_m = _HALF, _ONE, _TWO, _THREE, _FIVE, _W0, _SQRT_HALF2
    golden, m1, m2 = GOLDEN, _M1, _M2
    opts = {"cache": True, "nogil": True, "boundscheck": False, "error_model": "numpy"}

    @numba.njit(inline="always", **opts)
    def draw(k, c):  # pragma: no cover - compiled
        z = c * golden + k
        z = (z ^ (z >> np.uint64(30))) * m1
        z = (z ^ (z >> np.uint64(27))) * m2
        return z ^ (z >> np.uint64(31))

    @numba.njit(inline="always", **opts)
    def horner9(x, c0, c1, c2, c3, c4, c5, c6, c7, c8):  # pragma: no cover - compiled
        """``c0 x**8 + ... + c8`` in Horner's order, as :func:`normal_of_bits` sums it."""
        p = c1 + c0 * x
        for c in (c2, c3, c4, c5, c6, c7, c8):
            p = c + p * x
        return p

    @numba.njit(inline="always", **opts)
    def normal32(h):  # pragma: no cover - compiled
        top = h >> np.uint64(32)
        k = np.int32(top & np.uint64(0x7FFFFFFF))
        v = (np.float32(k) + half) * to_unit
        y = v * (two - v)
        b = f32_bits(y)
        e = np.int32((b >> np.int32(23)) - np.int32(127))
        m = bits_f32(np.int32((b & np.int32(0x7FFFFF)) | np.int32(0x3F800000)))
        big = m > big_m
        m = m * half if big else m
        e = e + np.int32(1) if big else e
        f = m - one
        s = f / (two + f)
        s2 = s * s
        log_m = two * s * (one + s2 * (t3 + s2 * (t5 + s2 * (t7 + s2 * t9))))
        ef = np.float32(e)
        w = -((ef * ln2_hi) + (log_m + ef * ln2_lo))
        pa = horner9(w - w0, a0, a1, a2, a3, a4, a5, a6, a7, a8)
        pb = horner9(sqrt32(w) - three, b0, b1, b2, b3, b4, b5, b6, b7, b8)
        p = pa if w < five else pb
        r = sqrt2 * (p * (one - v))
        return -r if (top & np.uint64(0x80000000)) != np.uint64(0) else r

    @numba.njit(**opts)
    def fill_normal(out, k, start, scale):  # pragma: no cover - compiled
        for i in range(out.size):
            out[i] = normal32(draw(k, start + np.uint64(i))) * scale

    return SimpleNamespace(fill_normal=fill_normal, draw=draw, normal32=normal32)
