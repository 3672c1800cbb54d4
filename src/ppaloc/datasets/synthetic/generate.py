"""``make_synthetic``: two traversals of one generated route and their ground truth."""

from __future__ import annotations

from typing import Any

import numpy as np

from ppaloc.datasets.base import RouteDataset
from ppaloc.datasets.frames import RenderedFrames
from ppaloc.datasets.route import RawRoute, assemble
from ppaloc.datasets.synthetic.conditions import CONDITIONS, condition
from ppaloc.datasets.synthetic.motion import (
    SPEED_VAR,
    lateral_weave,
    place_positions_with_stops,
    variable_speed_positions,
)
from ppaloc.datasets.synthetic.render import LANE_CENTRE, Renderer
from ppaloc.datasets.synthetic.world import make_world
from ppaloc.errors import DataError

__all__ = ["make_synthetic", "synthetic_route"]


class _Drive:
    """Renders frame ``i`` of one traversal: camera at ``(s[i], x[i])`` (picklable)."""

    def __init__(self, renderer: Renderer, s: np.ndarray, x: np.ndarray, traversal: int) -> None:
        self.renderer, self.s, self.x, self.traversal = renderer, s, x, traversal

    def __call__(self, i: int) -> np.ndarray:
        return self.renderer.render(float(self.s[i]), float(self.x[i]), (self.traversal, i))


def synthetic_route(
    places: int = 500,
    ref: str = "summer",
    query: str = "winter",
    seed: int = 0,
    *,
    sync: bool = False,
    spacing: float = 4.0,
    speed: float = 1.0,
    stops: int | None = None,
    extra: int = 0,
    offset: float | None = None,
    size: int = 256,
    speed_var: float = SPEED_VAR,
) -> RawRoute:
    """The two traversals of a generated route and their true positions, before selection.

    Parameters
    ----------
    places : int
        Reference frames: one per place, ``spacing`` metres apart.
    ref, query : str
        Conditions of the two traversals (``summer``, ``autumn``, ``winter``, ``night``,
        ``dusk``).
    seed : int
        Seeds the world, the query's motion, clouds and noise: same seed, same bytes.
    sync : bool
        One query frame per place while moving (the paper's setting: the route re-driven
        at the mapping speed) instead of variable speed; ``stops`` still adds halts.
    spacing : float
        Metres between places.
    speed : float
        Mean query speed in places per frame (variable-speed mode).
    speed_var : float
        Peak relative deviation of the query's cruising speed from ``speed`` (default 0.2:
        within +-20%, as a driver re-driving a route; 0.65 gives the wide 0.35x-1.65x
        profile).
    stops : int, optional
        Query stops (default: one per 150 places, at least one, at variable speed; none
        with ``sync``).
    extra : int
        Places the query drives past the end of the map (no true match there).
    offset : float, optional
        Query lateral offset (m) instead of the condition's.
    size : int
        Frame side (pixels).

    Returns
    -------
    RawRoute
        Grey ``uint8`` frames rendered on access; positions in metres ``(s, x)``; the
        query's true place in reference-frame units.
    """
    for name in (ref, query):
        if name not in CONDITIONS:
            raise DataError(f"unknown condition {name!r}: choose from {', '.join(CONDITIONS)}")
    if places < 2:
        raise DataError(f"places={places}: a route needs at least 2 places")
    if not 0.0 <= speed_var <= 0.9:
        raise DataError(
            f"speed_var={speed_var}: the relative speed variation must be in [0, 0.9] "
            "(0.2 is the default, 0.65 the wide profile)"
        )
    ref_c, query_c = condition(ref), condition(query)
    world = make_world(places * spacing + extra * spacing, seed)
    end = (places - 1 + extra) * spacing
    ref_s = np.arange(places, dtype=np.float64) * spacing
    if sync:
        q_s = place_positions_with_stops(places + extra, spacing, stops or 0, seed)
    else:
        n_stops = max(1, places // 150) if stops is None else stops
        q_s = variable_speed_positions(end, spacing, speed, n_stops, seed, speed_var)
    q_off = query_c.offset if offset is None else offset
    ref_x = LANE_CENTRE + ref_c.offset + lateral_weave(ref_s, seed * 2 + 0)
    q_x = LANE_CENTRE + q_off + lateral_weave(q_s, seed * 2 + 1)
    ref_r = Renderer(world, ref_c, size, seed=0)
    q_r = Renderer(world, query_c, size, seed=1)
    reference = RenderedFrames(_Drive(ref_r, ref_s, ref_x, 0), places)
    queries = RenderedFrames(_Drive(q_r, q_s, q_x, 1), q_s.size)
    return RawRoute(
        name=f"synthetic {ref}->{query}",
        reference=reference,
        query=queries,
        default_tolerance=1,
        query_place=q_s / spacing,
        reference_positions=np.stack([ref_s, ref_x], 1),
        query_positions=np.stack([q_s, q_x], 1),
        motion_known=True,
        meta={
            "kind": "synthetic",
            "seed": seed,
            "spacing_m": spacing,
            "conditions": (ref, query),
            "sync": sync,
        },
    )


def make_synthetic(
    places: int = 500,
    ref: str = "summer",
    query: str = "winter",
    seed: int = 0,
    *,
    tolerance: int = 1,
    start: int | None = None,
    stop: int | None = None,
    step: int = 1,
    patch_norm: int | None = None,
    **route: Any,
) -> RouteDataset:
    """Two traversals of a procedurally generated route, with exact ground truth.

    Parameters
    ----------
    places, ref, query, seed
        As in :func:`synthetic_route`.
    tolerance : int
        Accepted distance in places.
    start, stop, step : int, optional
        Select places ``start:stop:step`` (and the query frames nearest to them).
    patch_norm : int, optional
        Patch-normalise every frame in tiles of this side (the ``patch_norm`` spec key).
    **route
        The other keywords of :func:`synthetic_route` (``sync``, ``spacing``, ``speed``,
        ``speed_var``, ``stops``, ``extra``, ``offset``, ``size``).

    Returns
    -------
    RouteDataset
        Grey ``uint8`` frames rendered on access; positions in metres ``(s, x)``;
        ``query_moved[i]``: frame ``i``'s nearest place is ahead of frame ``i-1``'s.

    Examples
    --------
    >>> ds = make_synthetic(places=30, sync=True, seed=2, size=64)
    >>> ds.reference[0].shape, ds.ground_truth[0].tolist()
    ((64, 64), [0, 1])
    """
    raw = synthetic_route(places, ref, query, seed, **route)
    options = {
        "tolerance": tolerance,
        "start": start,
        "stop": stop,
        "step": step,
        "patch_norm": patch_norm,
    }
    return assemble(raw, options)
