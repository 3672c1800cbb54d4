"""A 1-D particle filter over map nodes, in the manner of Liu & Zhang's visual paths.

Particles live on map nodes. Per query frame:

1. *motion*: each particle independently stays (``p_stay``), moves one node forward
   (``p_forward``), jumps 2 .. ``max_jump`` nodes forward (``p_jump``, uniform over the
   jump) or is re-drawn uniformly over the map (the rest, ``1 - p_stay - p_forward -
   p_jump``: recovery from kidnapping and from a wrong lock). A particle that runs past
   the last node is re-drawn uniformly too (clamping it there would pile particles up at
   the end of the map). The first frame of a query has no motion step (particles start uniform).
2. *weighting*: the query is compared with every node on SeqSLAM's patch-normalised 64x32
   image (mean absolute difference per pixel; ``descriptor="lowres"``, ``"lbp"`` and the
   others: the weighted-node filter's place, :mod:`ppaloc.baselines._descriptors`), and by
   default the column of distances is contrast-enhanced as in SeqSLAM (the filter
   replaces SeqSLAM's exhaustive trajectory search, not its difference matrix), giving
   ``d``; a particle on node ``i`` gets weight
   ``exp(-(d_i - d_min) / sigma)`` with ``sigma = sigma_rel x (median(d) - d_min)``, so
   the likelihood does not depend on the overall scale of ``d``.
3. *estimate*: the weighted particle histogram over nodes, smoothed over +-1 node; the
   estimate is its densest node and the confidence the fraction of the weight within +-1
   node of it.
4. *systematic resampling* (one uniform draw, ``n_particles`` evenly spaced pointers).

Every random draw comes from ``numpy.random.default_rng(seed)``, re-created by
:meth:`ParticleFilter.reset`, so a run is identical under the same seed.

References
----------
Y. Liu and H. Zhang, "Visual loop closure detection with a compact image descriptor",
IROS 2012, and "Towards improving the efficiency of sequence-based SLAM", ICMA 2013
(1-D particle filter over the path of reference images).
"""

from __future__ import annotations

from typing import ClassVar, Literal

import numpy as np

from ppaloc.baselines._common import ImageLocaliser, top_k
from ppaloc.baselines._descriptors import check_descriptor
from ppaloc.errors import PpalocError
from ppaloc.localise.base import Estimate
from ppaloc.localise.enhance import contrast_enhance
from ppaloc.place.patch import check_patch_image
from ppaloc.seeds import SEED_MAX
from ppaloc.topomap import TopoMap

__all__ = ["ParticleFilter", "systematic_resample"]

KIND = "particle-filter"

SPEED_WINDOW = 10
"""Frames over which :attr:`ParticleFilter.speed_range` averages a particle's moves."""


def systematic_resample(weights: np.ndarray, u: float) -> np.ndarray:
    """Indices drawn by systematic resampling.

    Parameters
    ----------
    weights : ndarray, shape (P,)
        Non-negative weights with a positive sum.
    u : float
        The one uniform draw in [0, 1).

    Returns
    -------
    ndarray of int64, shape (P,)
        Index ``j`` appears about ``P x weights[j] / sum(weights)`` times (floor or ceil).

    Examples
    --------
    >>> systematic_resample(np.array([0.5, 0.25, 0.25, 0.0]), 0.5).tolist()
    [0, 0, 1, 2]
    """
    p = len(weights)
    cum = np.cumsum(weights, dtype=np.float64)
    cum /= cum[-1]
    pointers = (u + np.arange(p)) / p
    return np.minimum(np.searchsorted(cum, pointers, side="right"), p - 1).astype(np.int64)


class ParticleFilter(ImageLocaliser):
    """1-D particle filter over map nodes (after Liu & Zhang), seeded.

    Parameters
    ----------
    n_particles : int
        Number of particles.
    p_stay, p_forward, p_jump : float
        Motion model probabilities; the remainder (5% by default) is uniform
        re-initialisation.
    max_jump : int
        Largest forward jump in nodes (jumps are uniform over 2 .. max_jump).
    sigma_rel : float
        Likelihood temperature as a fraction of the median distance above the minimum.
        The default and the 5% re-initialisation were chosen on synthetic routes that no
        evaluation uses (``benchmarks/eval_baselines.py --tune-particle``).
    observation : {"enhanced", "raw"}
        What the likelihood is computed from: the difference column after SeqSLAM's local
        contrast enhancement (default; Liu & Zhang's filter replaces SeqSLAM's exhaustive
        trajectory search and keeps its difference matrix) or the raw distances.
    enhance_window : int
        Contrast enhancement window (as SeqSLAM: 10).
    size : (rows, cols)
        Downsampled image size (as SeqSLAM: 32 x 64), each side a divisor of 256 and a
        multiple of ``patch``; ``descriptor="patch"`` only.
    patch : int
        Patch normalisation tile side (as SeqSLAM: 8), at least 2; ``descriptor="patch"``
        only.
    descriptor : {"patch", "lowres", "lowres16", "lbp", "haar"}
        What a node holds and how it is compared: SeqSLAM's patch-normalised image by the
        mean absolute difference per pixel (default), the weighted-node filter's
        contrast-normalised 8x8 or 16x16 image by the mean absolute difference per cell, or its
        32-bit LBP code or 192 Haar signs by the Hamming distance
        (:mod:`ppaloc.baselines._descriptors`).
        The filter is the same on each.
    seed : int
        Seed of every random draw.
    top_k : int
        Length of ``Estimate.ranking``.
    record_weights : bool
        Put the smoothed particle histogram (fractions summing to about 3) in
        ``Estimate.weights``.
    """

    name = "particle-filter"
    kind = KIND

    #: Accepted range of each numeric parameter (of each item of a pair), where a value
    #: drives memory or time or leaves the method's meaning; the published defaults lie
    #: inside.
    RANGES: ClassVar[dict[str, tuple[float, float]]] = {
        "n_particles": (1, 10_000_000),
        "p_stay": (0.0, 1.0),
        "p_forward": (0.0, 1.0),
        "p_jump": (0.0, 1.0),
        "max_jump": (2, 1_000_000),
        "sigma_rel": (1e-9, 1e6),
        "enhance_window": (0, 10_000),
        "size": (1, 256),
        "patch": (2, 256),
        "seed": (0, SEED_MAX),
        "top_k": (1, 10_000),
    }

    def __init__(
        self,
        *,
        n_particles: int = 1000,
        p_stay: float = 0.15,
        p_forward: float = 0.6,
        p_jump: float = 0.2,
        max_jump: int = 3,
        sigma_rel: float = 0.5,
        observation: Literal["enhanced", "raw"] = "enhanced",
        enhance_window: int = 10,
        size: tuple[int, int] = (32, 64),
        patch: int = 8,
        descriptor: Literal["patch", "lowres", "lowres16", "lbp", "haar"] = "patch",
        seed: int = 0,
        top_k: int = 10,
        record_weights: bool = False,
    ) -> None:
        probs = (p_stay, p_forward, p_jump)
        if min(probs) < 0 or sum(probs) > 1 + 1e-12:
            raise PpalocError(
                f"ParticleFilter motion probabilities p_stay={p_stay}, p_forward={p_forward}, "
                f"p_jump={p_jump} must be >= 0 and sum to at most 1 (the rest re-initialises)"
            )
        if observation not in ("enhanced", "raw"):
            raise PpalocError(
                f"ParticleFilter observation={observation!r} is unknown; choose 'enhanced' or 'raw'"
            )
        if int(n_particles) < 1 or int(max_jump) < 2 or sigma_rel <= 0 or top_k < 1:
            raise PpalocError(
                f"ParticleFilter needs n_particles >= 1, max_jump >= 2, sigma_rel > 0 and "
                f"top_k >= 1, got {n_particles}, {max_jump}, {sigma_rel}, {top_k}"
            )
        self.n_particles = int(n_particles)
        self.p_stay, self.p_forward, self.p_jump = (float(p) for p in probs)
        self.max_jump = int(max_jump)
        self.sigma_rel = float(sigma_rel)
        self.observation = observation
        self.enhance_window = int(enhance_window)
        self.size = (int(size[0]), int(size[1]))
        self.patch = int(patch)
        own = {"size": (self.size, (32, 64)), "patch": (self.patch, 8)}
        self.descriptor = check_descriptor("ParticleFilter", descriptor, own)
        if self.descriptor == "patch":  # at build, not at the first frame
            check_patch_image("ParticleFilter", self.size, self.patch)
        self.seed = int(seed)
        self.top_k = int(top_k)
        self.record_weights = bool(record_weights)
        self.map: TopoMap | None = None
        self.reset()

    @property
    def speed_range(self) -> tuple[float, float]:
        """The query speeds the motion prior follows, in map nodes per query frame: the mean
        move of a particle that is not re-drawn, +- two standard deviations of its average
        over ``WINDOW`` = 10 frames (the window :mod:`ppaloc.evaluate.speed` measures the
        query over); 0.64 to 1.67 at the defaults.

        Examples
        --------
        >>> [round(v, 2) for v in ParticleFilter().speed_range]
        [0.64, 1.67]
        """
        moving = self.p_stay + self.p_forward + self.p_jump
        if moving <= 0:
            return (0.0, 0.0)
        jumps = np.arange(2, self.max_jump + 1, dtype=np.float64)
        mean = (self.p_forward + self.p_jump * jumps.mean()) / moving
        square = (self.p_forward + self.p_jump * (jumps**2).mean()) / moving
        spread = 2.0 * np.sqrt(max(square - mean**2, 0.0) / SPEED_WINDOW)
        return (float(max(mean - spread, 0.0)), float(mean + spread))

    def params(self) -> dict:
        """The parameters that shape the map (JSON-serialisable)."""
        return self.descriptor_params()

    def reset(self) -> None:
        """Re-seed the generator and spread the particles uniformly; keep the map."""
        self._rng = np.random.default_rng(self.seed)
        n = 0 if self.map is None else len(self.map)
        self.particles = self._rng.integers(0, n, self.n_particles) if n else np.zeros(0, np.int64)
        self._started = False

    def _move(self, n: int) -> None:
        rng = self._rng
        u = rng.random(self.n_particles)
        jumps = rng.integers(2, self.max_jump + 1, self.n_particles)
        fresh = rng.integers(0, n, self.n_particles)
        a = self.p_stay
        b = a + self.p_forward
        c = b + self.p_jump
        step = np.where(u < a, 0, np.where(u < b, 1, jumps))
        moved = self.particles + step
        # Re-initialised particles, and those that ran past the last node, are re-drawn.
        self.particles = np.where((u < c) & (moved < n), moved, fresh)

    def step(self, frame: np.ndarray) -> Estimate:
        """Move, weight, estimate and resample for one new query frame."""
        d = self.difference_column(frame)
        n = len(d)
        if self._started:
            self._move(n)
        self._started = True
        if self.observation == "enhanced":
            d = contrast_enhance(d, self.enhance_window)
        d_min = float(d.min())
        spread = float(np.median(d)) - d_min
        sigma = self.sigma_rel * spread if spread > 0 else 1.0
        w = np.exp(-(d[self.particles] - d_min) / sigma)
        total = float(w.sum())
        if not np.isfinite(total) or total <= 0.0:
            w = np.full(self.n_particles, 1.0)
            total = float(self.n_particles)
        w /= total
        hist = np.bincount(self.particles, weights=w, minlength=n)
        smooth = hist.copy()
        smooth[1:] += hist[:-1]
        smooth[:-1] += hist[1:]
        best = int(np.argmax(smooth))
        estimate = Estimate(
            node=best,
            score=float(min(smooth[best], 1.0)),
            ranking=top_k(smooth, self.top_k),
            weights=smooth if self.record_weights else None,
        )
        self.particles = self.particles[systematic_resample(w, float(self._rng.random()))]
        return estimate
