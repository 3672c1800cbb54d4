"""SeqSLAM (Milford & Wyeth, ICRA 2012) as an online, incremental ``Localiser``.

The pipeline and its defaults follow OpenSeqSLAM (Sünderhauf et al., 2013):

1. each frame is reduced to a 64x32 grey image and patch normalised (8x8 tiles);
2. a *difference column*: the mean absolute difference per pixel between the query image
   and every map node (one column of OpenSeqSLAM's difference matrix D, map along rows);
   ``descriptor="lowres"`` (or another of the filter's places) replaces steps 1 and 2 by
   the weighted-node filter's place and its distance
   (:mod:`ppaloc.baselines._descriptors`);
3. *local contrast enhancement* of that column along the map axis: each entry minus the
   mean, over the standard deviation, of the entries within +-Rwindow/2 nodes;
4. a search over straight-line trajectories through the last ``ds + 1`` enhanced columns,
   one per velocity in ``[vmin, vmax]`` (step ``vstep``); the cost of a node is the
   smallest trajectory sum ending (past-only) or centred (offline) on it;
5. the estimate is the cheapest node; the confidence compares its cost with the cheapest
   cost outside +-Rwindow/2 nodes around it (OpenSeqSLAM's uniqueness ratio).

Two modes:

``mode="past"`` (default)
    The trajectory *ends* at the current frame: columns ``t - ds .. t``. This is the fair
    comparison for an online localiser: nothing of the future is read.
    :meth:`SeqSLAM.step` keeps a ring buffer of the last ``ds + 1`` enhanced columns, so a
    step costs O(N x (pixels + ds x velocities)).
``mode="centred"`` (method ``seqslam-centred``)
    OpenSeqSLAM's original window, columns ``t - ds/2 .. t + ds/2``: it reads ``ds/2``
    future frames, so it is offline: over a whole query with
    :meth:`SeqSLAM.localise_sequence`, or frame by frame after :meth:`SeqSLAM.read_ahead`
    has been handed the query (``reads_future`` is true: the evaluation does so).

A trajectory that lacks frames (before the start or past the end of the query, or off the
map) pays the expected cost of an unrelated pair for each (``edges="expected"``), so a
short sequence is never cheaper, or surer, than a full one and every node can be reached;
``edges="cut"`` keeps OpenSeqSLAM's ``inf`` off the map and cut windows.

References
----------
M. Milford and G. Wyeth, "SeqSLAM: Visual route-based navigation for sunny summer days and
stormy winter nights", ICRA 2012. N. Sünderhauf, P. Neubert, P. Protzel, "Are we there yet?
Challenging SeqSLAM on a 3000 km journey across all four seasons", ICRA 2013 workshop
(OpenSeqSLAM).
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import ClassVar, Literal

import numpy as np

from ppaloc.baselines._common import ImageLocaliser, require_map, top_k, uniqueness_ratio
from ppaloc.baselines._descriptors import check_descriptor
from ppaloc.errors import PpalocError
from ppaloc.localise.base import Estimate
from ppaloc.localise.enhance import contrast_enhance
from ppaloc.place.patch import check_patch_image
from ppaloc.topomap import TopoMap

__all__ = ["SeqSLAM", "contrast_enhance", "trajectory_costs", "trajectory_offsets"]

KIND = "seqslam"


def trajectory_offsets(rel: np.ndarray, velocities: np.ndarray) -> np.ndarray:
    """Map-node offsets of every straight-line trajectory.

    Parameters
    ----------
    rel : ndarray of int, shape (K,)
        Query-frame offsets of the trajectory's columns relative to the anchor frame
        (``-ds .. 0`` past-only, ``-ds/2 .. ds/2`` centred).
    velocities : ndarray of float, shape (V,)
        Map nodes advanced per query frame.

    Returns
    -------
    ndarray of int64, shape (V', K)
        ``floor(rel * v)`` per velocity (computed on values rounded to 1e-9, so that e.g.
        ``-10 * 0.7`` is exactly -7), duplicate trajectories removed (OpenSeqSLAM likewise
        keeps only velocities that give distinct trajectories).
    """
    prod = np.round(np.outer(np.asarray(velocities, float), np.asarray(rel, float)), 9)
    offsets = np.floor(prod).astype(np.int64)
    return np.unique(offsets, axis=0)


def trajectory_costs(
    columns: np.ndarray, offsets: np.ndarray, fill: np.ndarray | None = None
) -> np.ndarray:
    """Cheapest straight-line trajectory cost anchored at every map node.

    Parameters
    ----------
    columns : ndarray, shape (K, N)
        Contrast-enhanced difference columns, one per query frame of the trajectory, in the
        order of ``offsets``' columns.
    offsets : ndarray of int, shape (V, K)
        From :func:`trajectory_offsets`.
    fill : ndarray, shape (K,), optional
        What a trajectory pays in column ``k`` where it lies outside the map (node index
        outside ``0 .. N-1``). None: ``inf``, OpenSeqSLAM's row of infinite cost, so such a
        trajectory never wins.

    Returns
    -------
    ndarray of float64, shape (N,)
        ``cost[e] = min_v sum_k columns[k, e + offsets[v, k]]``, each term outside the map
        replaced by ``fill[k]``.

    Examples
    --------
    >>> cols = np.array([[5.0, 1.0, 4.0], [2.0, 3.0, 0.0]])
    >>> trajectory_costs(cols, np.array([[-1, 0]])).tolist()
    [inf, 8.0, 1.0]
    >>> trajectory_costs(cols, np.array([[-1, 0]]), fill=np.array([9.0, 9.0])).tolist()
    [11.0, 8.0, 1.0]
    """
    k_cols, n = columns.shape
    pad = int(np.abs(offsets).max()) if offsets.size else 0
    outside = np.full(k_cols, np.inf) if fill is None else np.asarray(fill, dtype=np.float64)
    padded = np.repeat(outside[:, None], n + 2 * pad, axis=1)
    padded[:, pad : pad + n] = columns
    best = np.full(n, np.inf)
    acc = np.empty(n)
    for row in offsets:
        acc[:] = 0.0
        for k, o in enumerate(row):
            start = pad + int(o)
            acc += padded[k, start : start + n]
        np.minimum(best, acc, out=best)
    return best


class SeqSLAM(ImageLocaliser):
    """SeqSLAM over a 1-D map, past-only and incremental by default.

    Parameters
    ----------
    mode : {"past", "centred"}
        ``"past"``: online, the trajectory ends at the current frame (default).
        ``"centred"``: OpenSeqSLAM's window centred on the frame; it reads ``ds/2`` future
        frames, so it runs offline: over a whole query with :meth:`localise_sequence`, or
        frame by frame after :meth:`read_ahead` has been handed the query.
    size : (rows, cols)
        Downsampled image size (OpenSeqSLAM: 32 rows x 64 columns), each side a divisor of
        256 and a multiple of ``patch``; ``descriptor="patch"`` only.
    patch : int
        Patch normalisation tile side (OpenSeqSLAM: 8), at least 2; ``descriptor="patch"``
        only.
    quantise : bool
        Store patch-normalised images as OpenSeqSLAM does (``127 + round(z)``); default
        False keeps the float z-scores (see docs/baselines.md); ``descriptor="patch"``
        only.
    descriptor : {"patch", "lowres", "lowres16", "lbp", "haar"}
        What a node holds and how the difference column compares it: OpenSeqSLAM's
        patch-normalised image by the mean absolute difference per pixel (default), the
        weighted-node filter's contrast-normalised 8x8 or 16x16 image by the mean absolute
        difference per cell, or its 32-bit LBP code by the Hamming distance
        (:mod:`ppaloc.baselines._descriptors`). Enhancement and line search are the same.
    ds : int
        Trajectory length in frames; the trajectory spans ``ds + 1`` frames (OpenSeqSLAM:
        10, rounded up to even for the centred mode).
    vmin, vmax, vstep : float
        Velocities searched, in map nodes per query frame (OpenSeqSLAM: 0.8, 1.2, 0.1).
    rwindow : int
        Window of the uniqueness confidence: the competitor is the cheapest node outside
        ``best +- rwindow // 2`` (OpenSeqSLAM: 10).
    enhance_window : int
        Contrast enhancement window ``R`` (OpenSeqSLAM: 10); 0 switches it off.
    edges : {"expected", "cut"}
        What a trajectory pays for the frames it lacks: ``"expected"`` (default) counts
        each missing term at the median of its query's enhanced column (the cost of an
        unrelated pair), both where the line leaves the map and for frames before the start
        (or past the end) of the query, so every node can be reached and a short sequence
        is never cheaper, or surer, than a full one; ``"cut"`` is OpenSeqSLAM's ``inf``
        outside the map with windows cut to the frames that exist (OpenSeqSLAM itself gives
        the first and last ``ds/2`` queries no match at all).
    top_k : int
        Length of ``Estimate.ranking``.
    record_weights : bool
        Put per-node evidence (minus the trajectory cost, higher = better) in
        ``Estimate.weights``.

    Examples
    --------
    >>> rng = np.random.default_rng(0)
    >>> frames = [rng.integers(0, 256, (256, 256), dtype=np.uint8) for _ in range(30)]
    >>> s = SeqSLAM()
    >>> _ = s.build_map(frames)
    >>> [s.step(f).node for f in frames[5:12]]
    [5, 6, 7, 8, 9, 10, 11]
    >>> s.speed_range
    (0.8, 1.2)
    """

    name = "seqslam"
    kind = KIND

    #: Accepted range of each numeric parameter (of each item of a pair), where a value
    #: drives memory or time or leaves the method's meaning; the published defaults lie
    #: inside. ``ds``: the trajectory set-up grows as ds^2, about 1 s at 500.
    RANGES: ClassVar[dict[str, tuple[float, float]]] = {
        "size": (1, 256),
        "patch": (2, 256),
        "ds": (0, 500),
        "vmin": (0.001, 100.0),
        "vmax": (0.001, 100.0),
        "vstep": (0.001, 100.0),
        "rwindow": (0, 1_000_000),
        "enhance_window": (0, 10_000),
        "top_k": (1, 10_000),
    }

    def __init__(
        self,
        *,
        mode: Literal["past", "centred"] = "past",
        size: tuple[int, int] = (32, 64),
        patch: int = 8,
        quantise: bool = False,
        descriptor: Literal["patch", "lowres", "lowres16", "lbp", "haar"] = "patch",
        ds: int = 10,
        vmin: float = 0.8,
        vmax: float = 1.2,
        vstep: float = 0.1,
        rwindow: int = 10,
        enhance_window: int = 10,
        edges: Literal["expected", "cut"] = "expected",
        top_k: int = 10,
        record_weights: bool = False,
    ) -> None:
        if mode not in ("past", "centred"):
            raise PpalocError(f"SeqSLAM mode={mode!r} is unknown; choose 'past' or 'centred'")
        if edges not in ("expected", "cut"):
            raise PpalocError(f"SeqSLAM edges={edges!r} is unknown; choose 'expected' or 'cut'")
        if int(ds) < 0:
            raise PpalocError(f"SeqSLAM ds={ds!r} must be a non-negative number of frames")
        if not (0 < vmin <= vmax) or vstep <= 0:
            raise PpalocError(
                f"SeqSLAM velocities need 0 < vmin <= vmax and vstep > 0, got vmin={vmin}, "
                f"vmax={vmax}, vstep={vstep}"
            )
        if rwindow < 0 or enhance_window < 0 or top_k < 1:
            raise PpalocError(
                f"SeqSLAM rwindow={rwindow} and enhance_window={enhance_window} must be >= 0 "
                f"and top_k={top_k} >= 1"
            )
        self.mode = mode
        self.size = (int(size[0]), int(size[1]))
        self.patch = int(patch)
        self.quantise = bool(quantise)
        own = {
            "size": (self.size, (32, 64)),
            "patch": (self.patch, 8),
            "quantise": (self.quantise, False),
        }
        self.descriptor = check_descriptor("SeqSLAM", descriptor, own)
        if self.descriptor == "patch":  # at build, not at the first frame
            check_patch_image("SeqSLAM", self.size, self.patch)
        self.ds = int(ds) + (int(ds) % 2 if mode == "centred" else 0)
        n_v = round((vmax - vmin) / vstep) + 1
        self.velocities = vmin + vstep * np.arange(n_v)
        self.velocities = self.velocities[self.velocities <= vmax + 1e-9]
        self.rwindow = int(rwindow)
        self.enhance_window = int(enhance_window)
        self.edges = edges
        self.top_k = int(top_k)
        self.record_weights = bool(record_weights)
        self.map: TopoMap | None = None
        self._offsets: dict[tuple[int, int], np.ndarray] = {}
        self._ahead: Sequence[np.ndarray] | None = None
        self.reset()

    @property
    def reads_future(self) -> bool:
        """Whether an estimate reads frames after its own (the centred mode): such a method
        is offline and is handed the whole query first (:meth:`read_ahead`)."""
        return self.mode == "centred"

    @property
    def speed_range(self) -> tuple[float, float]:
        """The query speeds the trajectory search covers, in map nodes (reference frames)
        per query frame: the slowest and fastest velocity searched."""
        return (round(float(self.velocities[0]), 9), round(float(self.velocities[-1]), 9))

    # ------------------------------------------------------------------ map
    def params(self) -> dict:
        """The parameters that shape the map and the matching (JSON-serialisable)."""
        return {
            **self.descriptor_params(),
            **({"quantise": self.quantise} if self.descriptor == "patch" else {}),
            "ds": self.ds,
            "velocities": [round(float(v), 9) for v in self.velocities],
            "rwindow": self.rwindow,
            "enhance_window": self.enhance_window,
        }

    def reset(self) -> None:
        """Forget the query history (and a query handed to :meth:`read_ahead`); keep the map."""
        n = 0 if self.map is None else len(self.map)
        self._columns = np.zeros((self.ds + 1, n))  # ring of enhanced columns
        self._fills = np.zeros(self.ds + 1)  # the median of each
        self._frames: list[np.ndarray | None] = [None] * (self.ds + 1)  # centred: step's check
        self._count = 0  # columns computed so far
        self._t = 0  # the next query frame (centred mode)
        self._ahead = None

    # ------------------------------------------------------------- matching
    def enhanced_column(self, frame: np.ndarray) -> np.ndarray:
        """The contrast-enhanced difference column of one query frame, shape (N,)."""
        return contrast_enhance(self.difference_column(frame), self.enhance_window)

    def window_costs(self, columns: np.ndarray, fills: np.ndarray, first: int) -> np.ndarray:
        """Trajectory cost of every node from the enhanced columns of one query window.

        Parameters
        ----------
        columns : ndarray, shape (K, N)
            Enhanced columns of the query frames ``t + first .. t + first + K - 1`` that
            exist, oldest first (``t``: the frame being localised).
        fills : ndarray, shape (K,)
            The median of each column: the expected cost of an unrelated pair.
        first : int
            Offset of the first column from ``t`` (``-(K - 1)`` past-only).

        Returns
        -------
        ndarray of float64, shape (N,)
            With ``edges="expected"`` a term off the map costs its column's median and
            each of the ``ds + 1 - K`` frames the window lacks costs the mean of ``fills``;
            with ``edges="cut"`` off the map is ``inf`` and the lacking frames cost nothing.
        """
        k = len(columns)
        key = (first, k)
        if key not in self._offsets:
            self._offsets[key] = trajectory_offsets(np.arange(first, first + k), self.velocities)
        if self.edges == "cut":
            return trajectory_costs(columns, self._offsets[key])
        costs = trajectory_costs(columns, self._offsets[key], fill=fills)
        missing = self.ds + 1 - k
        return costs + missing * float(np.mean(fills)) if missing else costs

    def _estimate(self, costs: np.ndarray) -> Estimate:
        best = int(np.argmin(costs))
        score = uniqueness_ratio(costs, best, self.rwindow // 2)
        evidence = -costs
        return Estimate(
            node=best,
            score=score,
            ranking=top_k(evidence, self.top_k),
            weights=evidence.copy() if self.record_weights else None,
        )

    def _push(self, frame: np.ndarray) -> None:
        """Compute the enhanced column of the next frame into the ring buffer."""
        column = contrast_enhance(self.difference_column(frame), self.enhance_window)
        slot = self._count % (self.ds + 1)
        self._columns[slot] = column
        self._fills[slot] = float(np.median(column))
        if self.mode == "centred":
            self._frames[slot] = np.asarray(frame)
        self._count += 1

    def read_ahead(self, frames: Sequence[np.ndarray]) -> None:
        """Hand the centred mode the whole query (sensor frames), so that :meth:`step` can
        read ``ds/2`` frames ahead of the frame it localises; forgets the query history.

        Frames are read once each, ``ds/2`` frames before their own step; ``step`` must then
        be called with the frames of this traversal, in order.

        Raises
        ------
        PpalocError
            In the past-only mode, which reads no future frame, or before a map exists.
        """
        if self.mode != "centred":
            raise PpalocError(
                "SeqSLAM mode='past' reads no future frame; read_ahead is for mode='centred'"
            )
        require_map(self.map, self.name)
        self.reset()
        self._ahead = frames

    def step(self, frame: np.ndarray) -> Estimate:
        """Localise one new query frame.

        Past-only mode: from this frame and the ``ds`` before it. Centred mode: from the
        ``ds/2`` frames on either side, read from the traversal given to :meth:`read_ahead`.

        Raises
        ------
        PpalocError
            Before a map exists; in the centred mode without :meth:`read_ahead`, past the
            end of its traversal, or with a frame other than the next one of it.
        """
        require_map(self.map, self.name)
        if self.mode == "past":
            self._push(frame)
            k = min(self._count, self.ds + 1)
            order = np.arange(self._count - k, self._count) % (self.ds + 1)  # oldest first
            columns, fills = self._columns[order], self._fills[order]
            return self._estimate(self.window_costs(columns, fills, -(k - 1)))
        if self._ahead is None:
            raise PpalocError(
                "SeqSLAM mode='centred' needs ds/2 future frames and cannot run online; "
                "call read_ahead(query) first (ppaloc evaluate does, for seqslam-centred), "
                "or localise_sequence(frames), or use mode='past'"
            )
        t, q, half = self._t, len(self._ahead), self.ds // 2
        if t >= q:
            raise PpalocError(
                f"SeqSLAM centred: step called {t + 1} times, but read_ahead was given {q} "
                "frames; call read_ahead again for a new query"
            )
        lo, hi = max(0, t - half), min(q - 1, t + half)
        while self._count <= hi:
            self._push(self._ahead[self._count])
        order = np.arange(lo, hi + 1) % (self.ds + 1)
        if not np.array_equal(frame, self._frames[t % (self.ds + 1)]):
            raise PpalocError(
                f"SeqSLAM centred: step got a frame other than frame {t} of the query given "
                "to read_ahead; step through that query in order (or call read_ahead again)"
            )
        self._t += 1
        return self._estimate(self.window_costs(self._columns[order], self._fills[order], lo - t))

    def localise_sequence(self, frames: Sequence[np.ndarray]) -> list[Estimate]:
        """Localise a whole query traversal at once (batch), in either mode.

        The difference matrix is computed for all frames, enhanced column by column, then
        each frame's trajectory window is searched: frames ``t - ds .. t`` in the past-only
        mode (the same estimates as :meth:`step` frame by frame), ``t - ds/2 .. t + ds/2``
        in the centred mode (the same as :meth:`step` after :meth:`read_ahead`). The map and
        the online state are left untouched.
        """
        require_map(self.map, self.name)
        columns = [self.difference_column(f) for f in frames]  # one pass, no frame kept
        if not columns:
            return []
        diff = np.stack(columns, axis=1)
        del columns
        enhanced = contrast_enhance(diff, self.enhance_window).T  # (Q, N)
        fills = np.median(enhanced, axis=1)
        q = len(enhanced)
        if self.mode == "past":
            before, after = self.ds, 0
        else:
            before = after = self.ds // 2
        out = []
        for t in range(q):
            lo, hi = max(0, t - before), min(q - 1, t + after)
            costs = self.window_costs(enhanced[lo : hi + 1], fills[lo : hi + 1], lo - t)
            out.append(self._estimate(costs))
        return out
