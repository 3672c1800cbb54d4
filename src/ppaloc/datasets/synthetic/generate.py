"""``make_synthetic``: two traversals of one generated route and their ground truth."""

from __future__ import annotations

from typing import Any

import numpy as np

from ppaloc.datasets.base import RouteDataset
from ppaloc.datasets.frames import RenderedFrames
from ppaloc.datasets.route import RawRoute, assemble
from ppaloc.datasets.synthetic.conditions import CONDITIONS, condition
from ppaloc.datasets.synthetic.curved import CurvedRenderer
from ppaloc.datasets.synthetic.lab import (
    LAB_CONDITIONS,
    LAB_SPACING,
    LabRenderer,
    change_world,
    make_lab,
)
from ppaloc.datasets.synthetic.motion import (
    SPEED_VAR,
    lateral_weave,
    place_positions_with_stops,
    variable_speed_positions,
)
from ppaloc.datasets.synthetic.path import drift, make_path
from ppaloc.datasets.synthetic.render import LANE_CENTRE, Renderer
from ppaloc.datasets.synthetic.world import make_world
from ppaloc.errors import DataError
from ppaloc.seeds import SEED_MAX

__all__ = [
    "MAX_OFFSET",
    "MAX_PLACES",
    "MAX_QUERY_FRAMES",
    "MAX_ROUTE_M",
    "MAX_SEED",
    "MAX_SIZE",
    "MAX_SPACING",
    "MAX_SPEED",
    "MAX_TURN_PLACES",
    "WORLDS",
    "make_synthetic",
    "synthetic_route",
]

WORLDS = ("road", "lab")
"""The generated worlds: the road (default) and the indoor laboratory."""

# Bounds of the generator's inputs: each one drives memory or time (docs/datasets.md).
MAX_PLACES = 1_000_000
"""Most places of one route (the positions and ground truth grow with it)."""
MAX_ROUTE_M = 4_000_000.0
"""Longest route, ``(places + extra) * spacing`` metres (the world is built per metre:
about 30 s for the longest)."""
MAX_QUERY_FRAMES = 2_000_000
"""Most query frames a route may need (``(places + extra) / speed`` plus the stops)."""
MAX_TURN_PLACES = 30_000_000
"""Most ``turns x (places + extra)`` of a route with turns (the lab always has some): the
bent route's geometry grows with both)."""
MAX_SPACING = 100.0
"""Widest spacing between places, metres."""
MAX_SPEED = 10.0
"""Fastest mean query speed, places per frame."""
MAX_OFFSET = 20.0
"""Largest lateral offset of the query, metres either side."""
MAX_SIZE = 1024
"""Largest frame side, pixels (a frame renders in time and memory of its area)."""
MAX_SEED = SEED_MAX
"""Largest seed (:data:`ppaloc.seeds.SEED_MAX`, as every seed)."""

_MAX_DWELL = 24  # frames of one stop (motion.py draws 6-24)

_ONE_PER_PLACE = "generated reference: one frame per place, never standing still"


def _roles(world: str, ref: str, query: str, sync: bool, spacing: float) -> dict[str, str]:
    """``meta["roles"]``: what the generated reference and query traversals are."""
    drive = "one frame per place (stops included)" if sync else "variable speed with stops"
    return {
        "database": f"synthetic {world}, {ref}, one frame per place ({spacing:g} m apart)",
        "query": f"synthetic {world}, {query}, {drive}",
    }


def _check_bounds(
    places: int, spacing: float, speed: float, stops: int | None, extra: int, sync: bool,
    size: int, offset: float | None, seed: int,
) -> None:  # fmt: skip
    """Refuse inputs whose route would be too long, too slow to make, or not drivable."""
    for name, value, low, high in (
        ("places", places, 2, MAX_PLACES),
        ("extra", extra, 0, places),
        ("stops", 0 if stops is None else stops, 0, places),
        ("size", size, 16, MAX_SIZE),
        ("seed", seed, 0, MAX_SEED),
    ):
        if isinstance(value, bool) or not isinstance(value, int | np.integer):
            raise DataError(f"{name}={value!r} must be an integer in [{low}, {high}]")
        if not low <= value <= high:
            bound = f"{high} = places" if name in ("extra", "stops") else f"{high}"
            raise DataError(f"{name}={value!r} must be an integer in [{low}, {bound}]")
    for name, value, low, high in (
        ("spacing", spacing, 0.05, MAX_SPACING),
        ("speed", speed, 0.05, MAX_SPEED),
        ("offset", 0.0 if offset is None else offset, -MAX_OFFSET, MAX_OFFSET),
    ):
        if isinstance(value, bool) or not isinstance(value, int | float | np.floating):
            raise DataError(f"{name}={value!r} must be a number in [{low:g}, {high:g}]")
        if not (np.isfinite(value) and low <= value <= high):
            raise DataError(f"{name}={value!r} must be a number in [{low:g}, {high:g}]")
    length = (places + extra) * spacing
    if length > MAX_ROUTE_M:
        raise DataError(
            f"(places + extra) x spacing = {length:.3g} m is longer than the generator's "
            f"{MAX_ROUTE_M:.0f} m: fewer places or a smaller spacing"
        )
    n_stops = stops if stops is not None else (0 if sync else max(1, places // 150))
    frames = (places + extra) / (1.0 if sync else speed) + n_stops * _MAX_DWELL
    if frames > MAX_QUERY_FRAMES:
        raise DataError(
            f"the query would need about {frames:.3g} frames, more than the generator's "
            f"{MAX_QUERY_FRAMES}: fewer places or stops, or a higher speed"
        )


class _Drive:
    """Renders frame ``i`` of one traversal: camera at ``(s[i], x[i])`` (picklable)."""

    def __init__(self, renderer: Renderer, s: np.ndarray, x: np.ndarray, traversal: int) -> None:
        self.renderer, self.s, self.x, self.traversal = renderer, s, x, traversal

    def __call__(self, i: int) -> np.ndarray:
        return self.renderer.render(float(self.s[i]), float(self.x[i]), (self.traversal, i))


class _TurningDrive(_Drive):
    """A :class:`_Drive` on a bent route: the camera also turns by ``yaw[i]`` (rad)."""

    def __init__(self, renderer, s: np.ndarray, x: np.ndarray, yaw: np.ndarray, traversal: int):
        super().__init__(renderer, s, x, traversal)
        self.yaw = yaw

    def __call__(self, i: int) -> np.ndarray:
        key = (self.traversal, i)
        return self.renderer.render(float(self.s[i]), float(self.x[i]), key, float(self.yaw[i]))


def _yaw(s: np.ndarray, x: np.ndarray, path, look: float) -> np.ndarray:
    """Camera heading relative to the route: along the drift, and a little into each turn."""
    if s.size < 2:
        return np.zeros_like(s)
    ds = np.gradient(s)
    slope = np.divide(np.gradient(x), ds, out=np.zeros_like(s), where=ds > 1e-9)
    # while stopped the heading stays as it was
    for i in np.flatnonzero(ds <= 1e-9):
        slope[i] = slope[i - 1] if i else 0.0
    lead = 0.3 * (path.heading_at(s + look) - path.heading_at(s))
    return np.arctan(slope) + lead


def synthetic_route(
    places: int = 500,
    ref: str | None = None,
    query: str | None = None,
    seed: int = 0,
    *,
    world: str = "road",
    turns: int | None = None,
    sync: bool = False,
    spacing: float | None = None,
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
    ref, query : str, optional
        Conditions of the two traversals: on the road ``summer`` (default reference),
        ``autumn``, ``winter`` (default query), ``night``, ``dusk``; in the lab ``lab``
        (default reference), ``changed`` (default query), ``moved``, ``people``, ``dim``.
    seed : int
        Seeds the world, the query's motion, clouds and noise: same seed, same bytes.
    world : {"road", "lab"}
        The procedural road (default) or the indoor laboratory.
    turns : int, optional
        How many turns the route makes, in ``[0, places // 4]``; default 0 on the road (the
        straight route) and ``max(1, places // 25)`` in the lab.
    sync : bool
        One query frame per place while moving (the paper's setting: the route re-driven
        at the mapping speed) instead of variable speed; ``stops`` still adds halts.
    spacing : float, optional
        Metres between places (default 4.0 on the road, 0.5 in the lab).
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
    if world not in WORLDS:
        raise DataError(f"unknown world {world!r}: choose from {', '.join(WORLDS)}")
    names = CONDITIONS if world == "road" else LAB_CONDITIONS
    ref = ref or ("summer" if world == "road" else "lab")
    query = query or ("winter" if world == "road" else "changed")
    for name in (ref, query):
        if name not in names:
            where = "" if world == "road" else " in the lab"
            raise DataError(f"unknown condition {name!r}{where}: choose from {', '.join(names)}")
    if spacing is None:
        spacing = 4.0 if world == "road" else LAB_SPACING
    _check_bounds(places, spacing, speed, stops, extra, sync, size, offset, seed)
    if turns is None:
        turns = 0 if world == "road" else max(1, places // 25)
        if turns > places // 4:  # the lab's one turn needs four places
            raise DataError(
                f"a lab route of {places} places is too short for the lab's default of "
                "max(1, places // 25) turns (one turn takes 4 places): give places=4 or "
                "more, or turns=0"
            )
    if not 0 <= turns <= places // 4:
        raise DataError(
            f"turns={turns}: a route of {places} places takes 0 to places//4 = {places // 4} turns"
        )
    if turns * (places + extra) > MAX_TURN_PLACES:
        most = MAX_TURN_PLACES // (places + extra)
        raise DataError(
            f"turns={turns} on {places + extra} places (places + extra) is more than the "
            f"generator's {MAX_TURN_PLACES} turn-places (turns x places): at most {most} "
            "turns on this route, or fewer places"
            + (" (the lab's default is places // 25)" if world == "lab" else "")
        )
    if not 0.0 <= speed_var <= 0.9:
        raise DataError(
            f"speed_var={speed_var}: the relative speed variation must be in [0, 0.9] "
            "(0.2 is the default, 0.65 the wide profile)"
        )
    if world == "lab" or turns > 0:
        return _bent_route(
            world, places, ref, query, seed, turns, sync, spacing, speed, stops, extra, offset,
            size, speed_var,
        )  # fmt: skip
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
        same_place="none",
        truth={"source": "route position", "same_place_reason": _ONE_PER_PLACE},
        meta={
            "kind": "synthetic",
            "roles": _roles("road", ref, query, sync, spacing),
            "seed": seed,
            "spacing_m": spacing,
            "conditions": (ref, query),
            "sync": sync,
            "world": "road",
            "turns": 0,
            "query_turning": np.zeros(q_s.size, bool),
            "reference_turning": np.zeros(places, bool),
        },
    )


def _query_positions(places, spacing, sync, stops, extra, speed, seed, speed_var):
    end = (places - 1 + extra) * spacing
    if sync:
        return place_positions_with_stops(places + extra, spacing, stops or 0, seed)
    n_stops = max(1, places // 150) if stops is None else stops
    return variable_speed_positions(end, spacing, speed, n_stops, seed, speed_var)


def _bent_route(
    world, places, ref, query, seed, turns, sync, spacing, speed, stops, extra, offset, size,
    speed_var,
) -> RawRoute:  # fmt: skip
    """A road route with turns and hills, or the lab: rendered by a :class:`CurvedRenderer`."""
    length = (places + extra) * spacing
    ref_s = np.arange(places, dtype=np.float64) * spacing
    q_s = _query_positions(places, spacing, sync, stops, extra, speed, seed, speed_var)
    end = (places - 1 + extra) * spacing
    if world == "road":
        ref_c, query_c = condition(ref), condition(query)
        w = make_world(length, seed)
        path = make_path(-60.0, length + 220.0, end, turns, seed)
        q_off = query_c.offset if offset is None else offset
        ref_x = LANE_CENTRE + ref_c.offset + drift(ref_s, path, seed * 2, 0.25, 0.5)
        q_x = LANE_CENTRE + q_off + drift(q_s, path, seed * 2 + 1, 0.25, 0.5)
        look, ref_w, q_w = 6.0, w, w
        kw = {"path": path}
        ref_r = CurvedRenderer(ref_w, ref_c, size, seed=0, **kw)
        q_r = CurvedRenderer(q_w, query_c, size, seed=1, **kw)
    else:
        ref_lc, q_lc = LAB_CONDITIONS[ref], LAB_CONDITIONS[query]
        w, path = make_lab(length, end, turns, seed)
        q_off = q_lc.condition.offset if offset is None else offset
        ref_x = ref_lc.condition.offset + drift(ref_s, path, seed * 2, 0.05, 0.15, 12.0)
        q_x = q_off + drift(q_s, path, seed * 2 + 1, 0.05, 0.15, 12.0)
        look = 0.8
        ref_r = LabRenderer(change_world(w, ref_lc, seed * 2), ref_lc, size, seed=0, path=path)
        q_r = LabRenderer(change_world(w, q_lc, seed * 2 + 1), q_lc, size, seed=1, path=path)
    ref_yaw, q_yaw = _yaw(ref_s, ref_x, path, look), _yaw(q_s, q_x, path, look)
    return RawRoute(
        name=f"synthetic {world} {ref}->{query}" if world == "lab" else f"synthetic {ref}->{query}",
        reference=RenderedFrames(_TurningDrive(ref_r, ref_s, ref_x, ref_yaw, 0), places),
        query=RenderedFrames(_TurningDrive(q_r, q_s, q_x, q_yaw, 1), q_s.size),
        default_tolerance=1,
        query_place=q_s / spacing,
        reference_positions=np.stack([ref_s, ref_x], 1),
        query_positions=np.stack([q_s, q_x], 1),
        motion_known=True,
        same_place="none",
        truth={"source": "route position", "same_place_reason": _ONE_PER_PLACE},
        meta={
            "kind": "synthetic",
            "roles": _roles(world, ref, query, sync, spacing),
            "seed": seed,
            "spacing_m": spacing,
            "conditions": (ref, query),
            "sync": sync,
            "world": world,
            "turns": int(turns),
            "query_turning": path.turning_at(q_s),
            "reference_turning": path.turning_at(ref_s),
        },
    )


def make_synthetic(
    places: int = 500,
    ref: str | None = None,
    query: str | None = None,
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
